/* bench/slab_read.c — time and peak memory of reading a volume whole, its header, or one
 * slab of planes (vm_volume_read_slab), in a process of its own so that the peak is that
 * read's. Build beside the library (see docs/BENCHMARKS.md, "Reading by slabs"):
 *   cc -O2 -fopenmp -Iinclude bench/slab_read.c build/libvolmesh.a -lz -lm -o slab_read
 * Usage: slab_read FILE whole | info | slab Z0 Z1 [REPEAT]
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
        fprintf(stderr, "usage: slab_read FILE whole|info|slab Z0 Z1 [REPEAT]\n");
        return 2;
    }
    const char *path = argv[1], *mode = argv[2];
    int slab = strcmp(mode, "slab") == 0;
    long z0 = slab && argc > 4 ? atol(argv[3]) : 0, z1 = slab && argc > 4 ? atol(argv[4]) : 0;
    int repeat = argc > (slab ? 5 : 3) ? atoi(argv[slab ? 5 : 3]) : 1;
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
