/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_threads.c — the hex quality pass (vm_mesh_improve_hexes) gives
 * the same mesh, byte for byte, on any number of threads: its sweeps run level by level on
 * threads and must see the moves a sweep in point order would. */
#include <stdlib.h>
#include <string.h>
#include "hex_checks.h"

#ifndef PHANTOM
#define PHANTOM VM_PHANTOM_TORUS
#define PHANTOM_N 32
#define PHANTOM_NOISE 0.3
#endif

/* Runs the pass on a copy of raw on n threads. [out] out (free it), r. */
static void improve_on(int n, const vm_mesh *raw, const vm_volume *v, double iso, vm_mesh *out,
                       vm_hex_improve_report *r) {
    vm_error err;
    vm_set_threads(n);
    vm_mesh_init(out, VM_HEX8);
    CHECK_OK(vm_mesh_reserve(out, raw->npoints, raw->ncells, &err), &err);
    memcpy(out->points, raw->points, 3 * raw->npoints * sizeof *out->points);
    memcpy(out->cells, raw->cells, 8 * raw->ncells * sizeof *out->cells);
    memcpy(out->region, raw->region, raw->ncells * sizeof *out->region);
    out->npoints = raw->npoints;
    out->ncells = raw->ncells;
    vm_hex_improve_options o;
    vm_hex_improve_options_default(&o);
    o.lo = iso;
    CHECK_OK(vm_mesh_improve_hexes(out, v, &o, r, &err), &err);
}

/* A noisy torus comes out of the mesher with inverted hexes: the pass untangles, smooths,
 * pillows, polishes and repairs, every kind of sweep. 1, 2 and 3 threads: the same
 * points, hexes and report counts, no inverted hex. */
static void hexPassGivesTheSameBytesForOneTwoAndThreeThreads(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(PHANTOM, PHANTOM_N, PHANTOM_NOISE, 7, &v, &info, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.elements = VM_HEX8;
    mo.lo = 0;
    vm_mesh raw;
    CHECK_OK(vm_mesh_volume(&v, &mo, &raw, NULL, &err), &err);
    int before = vm_set_threads(1);
    printf("  %s %d^3 noise %.2f: %zu hexes\n", info.name, PHANTOM_N, PHANTOM_NOISE, raw.ncells);
    vm_mesh ref;
    vm_hex_improve_report r1;
    improve_on(1, &raw, &v, 0, &ref, &r1);
    CHECK_MSG(r1.inverted_before > 0 && r1.inverted_after == 0,
              "noisy phantom: %zu inverted before, %zu after", r1.inverted_before, r1.inverted_after);
    static const int counts[] = {2, 3};
    for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
        vm_mesh m;
        vm_hex_improve_report r;
        improve_on(counts[c], &raw, &v, 0, &m, &r);
        CHECK_MSG(m.npoints == ref.npoints && m.ncells == ref.ncells,
                  "%d threads: %zu points %zu hexes, 1 thread %zu %zu", counts[c], m.npoints,
                  m.ncells, ref.npoints, ref.ncells);
        if (m.npoints == ref.npoints && m.ncells == ref.ncells) {
            CHECK_MSG(memcmp(m.points, ref.points, 3 * m.npoints * sizeof *m.points) == 0,
                      "%d threads: other point positions", counts[c]);
            CHECK_MSG(memcmp(m.cells, ref.cells, 8 * m.ncells * sizeof *m.cells) == 0,
                      "%d threads: other hexes", counts[c]);
        }
        CHECK_MSG(r.moves == r1.moves && r.sweeps == r1.sweeps &&
                      r.min_sj_after == r1.min_sj_after,
                  "%d threads: %zu moves %d sweeps min %.6f; 1 thread %zu %d %.6f", counts[c],
                  r.moves, r.sweeps, r.min_sj_after, r1.moves, r1.sweeps, r1.min_sj_after);
        printf("  %d threads: %zu hexes, %zu moves, min scaled Jacobian %.4f, %.2f s (1 "
               "thread %.2f s)\n",
               counts[c], m.ncells, r.moves, r.min_sj_after, r.seconds, r1.seconds);
        vm_mesh_free(&m);
    }
    vm_set_threads(before);
    vm_mesh_free(&ref);
    vm_mesh_free(&raw);
    vm_volume_free(&v);
}

TEST_MAIN(T(hexPassGivesTheSameBytesForOneTwoAndThreeThreads))
