/* SPDX-License-Identifier: BSD-3-Clause */
/* bench/mesh_mem.c — peak resident set after each stage of a `volmesh mesh` run (read, mesh,
 * quality pass, write, checks), so that the peak of the mesher stage is told from the pass's
 * and the writer's (issue #12). Build beside the library (docs/BENCHMARKS.md, "Memory of the
 * adaptive mesher"):
 *   cc -O2 -fopenmp -Iinclude bench/mesh_mem.c build/libvolmesh.a -lz -lm -o mesh_mem
 * Usage: mesh_mem FILE ISO OUT.vtu [adaptive] [size S] [hex] [improve]
 * Prints one line per stage: its name, the peak resident set so far (MB), and that peak
 * beyond the float volume per output element (bytes); then the element count. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include "volmesh/volmesh.h"

static double peak_mb(void) {
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_maxrss / 1024.0; /* kB on Linux */
}

static double vol_mb, ncells = 1;

static void stage(const char *name) {
    double p = peak_mb();
    printf("%-8s peak %8.1f MB  beyond the volume %8.1f MB  %7.1f B/element\n", name, p,
           p - vol_mb, (p - vol_mb) * 1048576.0 / ncells);
    fflush(stdout);
}

static int fail(const char *what, const vm_error *e) {
    fprintf(stderr, "mesh_mem: %s: %s\n", what, e->message);
    return 1;
}

int main(int argc, char **argv) {
    if (argc < 4) {
        fprintf(stderr, "usage: mesh_mem FILE ISO OUT.vtu [adaptive] [size S] [hex] [improve]\n");
        return 2;
    }
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = atof(argv[2]);
    int improve = 0;
    for (int i = 4; i < argc; i++) {
        if (strcmp(argv[i], "adaptive") == 0) o.adaptive = 1;
        else if (strcmp(argv[i], "hex") == 0) o.elements = VM_HEX8;
        else if (strcmp(argv[i], "improve") == 0) improve = 1;
        else if (strcmp(argv[i], "size") == 0 && i + 1 < argc) o.cell_size = atoi(argv[++i]);
        else {
            fprintf(stderr, "mesh_mem: unknown argument %s\n", argv[i]);
            return 2;
        }
    }
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    if (vm_volume_read(argv[1], &v, &err)) return fail(argv[1], &err);
    vol_mb = (double)vm_volume_count(&v) * sizeof(float) / 1048576.0;
    stage("read");
    vm_mesh m;
    vm_mesh_stats st;
    if (vm_mesh_volume(&v, &o, &m, &st, &err)) return fail("mesh", &err);
    ncells = (double)m.ncells;
    stage("mesh");
    if (improve && m.kind == VM_TET4) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        io.lo = o.lo;
        io.has_lo = 1;
        if (vm_mesh_improve(&m, &v, &io, NULL, &err)) return fail("improve", &err);
        ncells = (double)m.ncells;
        stage("improve");
    }
    vm_volume_free(&v); /* as the CLI does before writing */
    if (vm_mesh_write(argv[3], &m, &err)) return fail(argv[3], &err);
    stage("write");
    vm_mesh_report rep;
    if (vm_mesh_check_with(&m, NULL, NULL, &rep, &err)) return fail("check", &err);
    stage("check");
    printf("elements %zu points %zu\n", m.ncells, m.npoints);
    vm_mesh_free(&m);
    return 0;
}
