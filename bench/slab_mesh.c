/* SPDX-License-Identifier: BSD-3-Clause */
/* bench/slab_mesh.c — the mesh stage alone, whole or by slabs: reads a volume (whole, or slab
 * after slab through a vm_volume_reader) and meshes it (vm_mesh_volume or
 * vm_mesh_volume_slabs), nothing else, in a process of its own so that the peak resident set
 * is that stage's (volmesh mesh also writes, checks and reports, whose peaks come after).
 * Build beside the library (see docs/BENCHMARKS.md, "Meshing by slabs"):
 *   cc -O2 -fopenmp -Iinclude bench/slab_mesh.c build/libvolmesh.a -lz -lm -o slab_mesh
 * Usage: slab_mesh FILE ISO [--adaptive] [--size S] [--slabs N]
 * Prints: slabs, tets, points, CPU seconds of the process, peak resident set in MB. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>
#include "volmesh/volmesh.h"

static vm_status planes(int64_t z0, int64_t z1, vm_volume *out, void *user, vm_error *err) {
    return vm_volume_reader_read(user, z0, z1, out->data, err);
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: slab_mesh FILE ISO [--adaptive] [--size S] [--slabs N]\n");
        return 2;
    }
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = atof(argv[2]);
    int slabs = 0;
    for (int i = 3; i < argc; i++) {
        if (!strcmp(argv[i], "--adaptive")) o.adaptive = 1;
        if (!strcmp(argv[i], "--size") && i + 1 < argc) o.cell_size = atoi(argv[++i]);
        if (!strcmp(argv[i], "--slabs") && i + 1 < argc) slabs = atoi(argv[++i]);
    }
    vm_volume v;
    vm_mesh m;
    vm_error err;
    vm_status s;
    if (slabs > 0) {
        vm_volume_reader *r = NULL;
        s = vm_volume_reader_open(argv[1], NULL, &v, &r, &err);
        vm_slab_options so = {slabs, 0, planes, r};
        if (!s) s = vm_mesh_volume_slabs(&v, &o, &so, &m, NULL, &err);
        vm_volume_reader_close(r);
    } else {
        s = vm_volume_read(argv[1], &v, &err);
        if (!s) s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    }
    vm_volume_free(&v);
    if (s) {
        fprintf(stderr, "slab_mesh: %s\n", err.message);
        return 2;
    }
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    printf("slabs %d: %zu tets, %zu points, %.1f CPU s, %.0f MB\n", slabs, m.ncells, m.npoints,
           (double)t.tv_sec + 1e-9 * (double)t.tv_nsec, (double)ru.ru_maxrss / 1024.0);
    vm_mesh_free(&m);
    return 0;
}
