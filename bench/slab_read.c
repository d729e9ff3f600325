/* SPDX-License-Identifier: BSD-3-Clause */
/* bench/slab_read.c — time and peak memory of reading a volume whole, its header, or one
 * slab of planes (vm_volume_read_slab), in a process of its own so that the peak is that
 * read's. Build beside the library (see docs/BENCHMARKS.md, "Reading by slabs"):
 *   cc -O2 -fopenmp -Iinclude bench/slab_read.c build/libvolmesh.a -lz -lm -o slab_read
 * Usage: slab_read FILE whole | info | slab Z0 Z1 | forward N | restart N [REPEAT]
 * forward N: the volume in N slabs read in increasing z by one vm_volume_reader into one
 * buffer (a gzip stream inflated once in all); restart N: the same slabs read by
 * vm_volume_read_slab, each from the start of the data.
 * Prints: mode, seconds (best of REPEAT), peak resident set in MB, voxels read. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include "volmesh/volmesh.h"

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: slab_read FILE whole|info|slab Z0 Z1|forward N|restart N "
                        "[REPEAT]\n");
        return 2;
    }
    const char *path = argv[1], *mode = argv[2];
    int slab = strcmp(mode, "slab") == 0;
    int slabs = strcmp(mode, "forward") == 0 || strcmp(mode, "restart") == 0;
    long z0 = slab && argc > 4 ? atol(argv[3]) : 0, z1 = slab && argc > 4 ? atol(argv[4]) : 0;
    long nslabs = slabs && argc > 3 ? atol(argv[3]) : 1;
    int args = slab ? 5 : slabs ? 4 : 3;
    int repeat = argc > args ? atoi(argv[args]) : 1;
    if (slabs) {
        vm_volume info;
        vm_error err;
        if (nslabs < 1 || vm_volume_read_info(path, &info, &err)) {
            fprintf(stderr, "slab_read: %s\n", nslabs < 1 ? "N must be >= 1" : err.message);
            return 2;
        }
        long nz = (long)info.dims[2];
        size_t plane = (size_t)info.dims[0] * (size_t)info.dims[1];
        float *buf = malloc(plane * (size_t)((nz + nslabs - 1) / nslabs) * sizeof(float));
        double best = 1e30;
        for (int r = 0; r < (repeat > 0 ? repeat : 1) && buf; r++) {
            double t0 = now();
            vm_volume_reader *rd = NULL;
            if (mode[0] == 'f' && vm_volume_reader_open(path, NULL, NULL, &rd, &err)) {
                fprintf(stderr, "slab_read: %s\n", err.message);
                return 2;
            }
            for (long k = 0; k < nslabs; k++) {
                long a = nz * k / nslabs, b = nz * (k + 1) / nslabs;
                vm_volume v;
                vm_status s = VM_OK;
                if (b <= a) continue;
                if (rd) {
                    s = vm_volume_reader_read(rd, a, b, buf, &err);
                } else {
                    s = vm_volume_read_slab(path, a, b, &v, &err);
                    if (!s) vm_volume_free(&v);
                }
                if (s) {
                    fprintf(stderr, "slab_read: %s\n", err.message);
                    return 2;
                }
            }
            vm_volume_reader_close(rd);
            double t = now() - t0;
            if (t < best) best = t;
        }
        free(buf);
        struct rusage ru;
        getrusage(RUSAGE_SELF, &ru);
        printf("%s %ld %.3f s %.1f MB %zu voxels\n", mode, nslabs, best,
               (double)ru.ru_maxrss / 1024.0, plane * (size_t)nz);
        return 0;
    }
    double best = 1e30;
    size_t voxels = 0;
    for (int r = 0; r < (repeat > 0 ? repeat : 1); r++) {
        vm_volume v;
        vm_error err;
        vm_error_clear(&err);
        double t0 = now();
        vm_status s;
#ifdef SLAB_READ_BASE
        s = strcmp(mode, "whole") == 0 ? vm_volume_read(path, &v, &err) : VM_ERR_ARG;
#else
        s = strcmp(mode, "whole") == 0  ? vm_volume_read(path, &v, &err)
            : strcmp(mode, "info") == 0 ? vm_volume_read_info(path, &v, &err)
            : slab                      ? vm_volume_read_slab(path, z0, z1, &v, &err)
                                        : VM_ERR_ARG;
#endif
        double t = now() - t0;
        if (s) {
            fprintf(stderr, "slab_read: %s\n", err.message[0] ? err.message : "bad mode");
            return 2;
        }
        voxels = v.data ? vm_volume_count(&v) : 0;
        vm_volume_free(&v);
        if (t < best) best = t;
    }
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("%s %.3f s %.1f MB %zu voxels\n", mode, best, (double)ru.ru_maxrss / 1024.0, voxels);
    return 0;
}
