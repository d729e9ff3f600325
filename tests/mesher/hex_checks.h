/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/hex_checks.h — the checks test_mesh_hexes*.c share: a valid hex mesh with its
 * topology and volume, and what the quality pass (vm_mesh_improve_hexes) promises. */
#ifndef VM_TESTS_HEX_CHECKS_H
#define VM_TESTS_HEX_CHECKS_H
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "volmesh/improve.h"
#include "test.h"

/* Meshes v at iso lo in hexes, uniform (levels 0) or with up to `levels` coarse levels
 * (--adaptive --max-level levels); st may be NULL. */
static inline vm_status mesh_hex_levels(const vm_volume *v, double lo, int levels, vm_mesh *m,
                                        vm_mesh_stats *st) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = levels > 0;
    if (levels > 0) o.max_level = levels;
    o.lo = lo;
    vm_status s = vm_mesh_volume(v, &o, m, st, &err);
    CHECK_OK(s, &err);
    return s;
}

/* Adds a one-voxel plate (10 x 10 x 0.6 voxels round the plane z = 2, a sphere
 * topologically: one more component, boundary Euler characteristic 2 more, about 60 voxels
 * of volume) in v's low corner, away from the phantoms. No point of the coarser grids (z a
 * multiple of 1.5, 1.4 or 1.3) is inside it, so adaptive hexes keep the full-resolution grid
 * and coarsen its interior (mesher/hex_base.c, dc_hex_adaptive.c). */
static inline void add_corner_plate(vm_volume *v) {
    for (int64_t k = 0; k < v->dims[2]; k++)
        for (int64_t j = 0; j < v->dims[1]; j++)
            for (int64_t i = 0; i < v->dims[0]; i++) {
                double x = (double)i, y = (double)j, z = (double)k;
                double f = fmin(0.3 - fabs(z - 2.0),
                                fmin(fmin(x - 2.0, 12.0 - x), fmin(y - 2.0, 12.0 - y)));
                float *d = v->data + i + v->dims[0] * (j + v->dims[1] * k);
                if ((float)f > *d) *d = (float)f;
            }
}

static inline void check_hex_mesh(const char *label, const vm_mesh *m, long euler, size_t comps,
                           double volume, double tol) {
    vm_mesh_report r;
    vm_error err;
    CHECK_OK(vm_mesh_check(m, &r, &err), &err);
    printf("  %s: %zu hexes, min scaled Jacobian %.4f, volume %.2f (expected %.2f)\n", label,
           m->ncells, r.min_scaled_jacobian, r.volume, volume);
    CHECK(m->kind == VM_HEX8);
    CHECK_MSG(r.inverted == 0, "%s: %zu inverted", label, r.inverted);
    CHECK(r.overshared_faces == 0);
    CHECK(r.boundary_closed == 1);
    CHECK(r.boundary_nonmanifold_vertices == 0);
    CHECK_MSG(r.boundary_euler == euler, "%s: Euler %ld, expected %ld", label, r.boundary_euler,
              euler);
    CHECK_MSG(r.components == comps, "%s: %zu components, expected %zu", label, r.components,
              comps);
    if (volume > 0) CHECK_MSG(fabs(r.volume - volume) <= tol * volume, "%s: volume", label);
}

/* Runs the quality pass on m (meshed from v at iso lo) and checks what it promises against
 * the mesh before it: no inverted hex, the worst scaled Jacobian not lower and at least
 * floor, the same boundary topology, the volume within 2% (of expected when given, else of
 * the mesh before), the boundary points within 0.5 voxel of the isosurface. */
static inline void check_improved(const char *label, vm_mesh *m, const vm_volume *v, double lo,
                           double floor, double expected_volume) {
    vm_mesh_report before, after;
    vm_error err;
    CHECK_OK(vm_mesh_check(m, &before, &err), &err);
    vm_hex_improve_options o;
    vm_hex_improve_options_default(&o);
    o.lo = lo;
    vm_test_progress_log prog = {"hex pass", 0, 0, 0, 0, 0, 0.0, 0.0};
    o.progress = vm_test_progress;
    o.progress_user = &prog;
    vm_hex_improve_report r;
    vm_status s = vm_mesh_improve_hexes(m, v, &o, &r, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return;
    /* the bar moves forward only and ends full */
    CHECK_MSG(prog.calls >= 1 && prog.backwards == 0 && prog.ended && prog.other_stage == 0,
              "%s: progress %d calls, %d backwards, ended %d, %d of other stages", label,
              prog.calls, prog.backwards, prog.ended, prog.other_stage);
    CHECK_OK(vm_mesh_check(m, &after, &err), &err);
    printf("  %s: %zu -> %zu hexes (pillow layer %s), min scaled Jacobian %.4f -> %.4f, "
           "%zu -> %zu below 0.2, volume %.1f -> %.1f, surface distance %.3f -> %.3f, %.2f s\n",
           label, r.hexes_before, r.hexes_after,
           r.pillow_undone ? "undone" : r.pillow_hexes ? "kept" : "not needed",
           r.min_sj_before, r.min_sj_after,
           r.below_02_before, r.below_02_after, before.volume, after.volume,
           r.max_surface_distance_before, r.max_surface_distance, r.seconds);
    CHECK_MSG(after.inverted == 0, "%s: %zu inverted", label, after.inverted);
    CHECK_MSG(r.min_sj_after >= r.min_sj_before, "%s: the pass lowered the minimum", label);
    CHECK_MSG(after.min_scaled_jacobian >= floor, "%s: min scaled Jacobian %.4f < %.2f", label,
              after.min_scaled_jacobian, floor);
    CHECK(after.overshared_faces == 0);
    CHECK(after.boundary_closed == 1);
    CHECK(after.boundary_nonmanifold_vertices == 0);
    CHECK_MSG(after.boundary_euler == before.boundary_euler, "%s: Euler %ld -> %ld", label,
              before.boundary_euler, after.boundary_euler);
    CHECK(after.components == before.components);
    double ref = expected_volume > 0 ? expected_volume : before.volume;
    CHECK_MSG(fabs(after.volume - ref) <= 0.02 * ref, "%s: volume %.1f vs %.1f", label,
              after.volume, ref);
    /* The pass never takes a boundary point further off than 0.5 voxel or than the mesher
     * had it (relaxation can leave points up to ~0.87 voxel off; the pass brings them within
     * 0.45 where the hexes around allow). */
    CHECK_MSG(r.max_surface_distance <= fmax(0.5, r.max_surface_distance_before) + 1e-6,
              "%s: boundary %.3f voxel off the isosurface (%.3f before)", label,
              r.max_surface_distance, r.max_surface_distance_before);
}

/* Reads shared volume file, meshes it in hexes at iso, checks the raw mesh when euler >= 0
 * (its Euler characteristic and components), then the pass against floor. Skips (returns 0)
 * when the shared data is absent. */
static inline int check_shared_volume(const char *file, double iso, double floor, long euler,
                                      size_t comps, int run_pass) {
    const char *path = vm_test_shared(file);
    if (!path) return 0;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.lo = iso;
    vm_mesh m;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    char label[96];
    snprintf(label, sizeof label, "%s iso %g", file, iso);
    if (s == VM_OK && euler >= 0) check_hex_mesh(label, &m, euler, comps, 0, 0);
    if (s == VM_OK && run_pass) check_improved(label, &m, &v, iso, floor, 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
    return 1;
}
#endif
