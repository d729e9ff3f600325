/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes.c — what the hexahedral mesher guarantees: on the phantoms and
 * the shared volumes, no inverted hex, every interior quad shared by exactly two hexes, a
 * closed manifold boundary with the known Euler characteristic, and the volume; after the
 * quality pass (vm_mesh_improve_hexes, issue #5) the same, a worst scaled Jacobian that never
 * went down and reaches 0.2, and a boundary on the isosurface. */
#include <stdlib.h>
#include <string.h>
/* ctest parts: 2 */
#include "hex_checks.h"

/* The six phantoms at 64^3, each test meshing them the same way. */
static const vm_phantom_kind phantom_kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS,
                                                VM_PHANTOM_GENUS3, VM_PHANTOM_TWO_SPHERES,
                                                VM_PHANTOM_PLATE, VM_PHANTOM_CUT_SPHERE};
#define N_PHANTOMS (sizeof phantom_kinds / sizeof phantom_kinds[0])

/* Makes phantom t and its raw hex mesh (no quality pass). [out] v, info, m, st; the mesh
 * status is returned (and checked); v is always made. */
static vm_status mesh_phantom_hexes(size_t t, vm_volume *v, vm_phantom_info *info, vm_mesh *m,
                                    vm_mesh_stats *st) {
    vm_error err;
    CHECK_OK(vm_phantom_make(phantom_kinds[t], 64, 0.0, 0, v, info, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    vm_status s = vm_mesh_volume(v, &o, m, st, &err);
    CHECK_OK(s, &err);
    return s;
}

/* Issue 34's bar for the boundary: within half a voxel of the isosurface both ways, every
 * point of the boundary faces (vm_mesh_surface_distance, what `volmesh quality --volume`
 * reports). Measured after the pass: 0.08-0.36 voxel (torus 0.36, genus-3 0.34,
 * cut-sphere 0.34; before the snap of the far points 0.66, 0.66 and 0.48). */
#define PHANTOM_BOUNDARY_MAX 0.45

static void check_boundary_distance(const char *label, const vm_mesh *m, const vm_volume *v,
                                    double lo, double bar) {
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(m, v, lo, 1, 0.0, 0, &d, &err), &err);
    double m2s = d.mesh_to_surface_max / d.voxel, s2m = d.surface_to_mesh_max / d.voxel;
    printf("  %s: boundary to isosurface %.3f voxel, isosurface to boundary %.3f\n", label,
           m2s, s2m);
    CHECK_MSG(m2s <= bar && s2m <= bar, "%s: boundary %.3f / %.3f voxel off (bar %.2f)", label,
              m2s, s2m, bar);
}

/* Each phantom meshed once: the raw mesh valid with its topology and volume, then the pass
 * reaching the bar on it, its boundary within the bar of the isosurface. */
static void hexMeshOfEachPhantomIsValidAndThePassReachesTheBar(void) {
    const char *sanitized = getenv("VM_SANITIZED");
    int small = sanitized && strcmp(sanitized, "1") == 0;
    for (size_t t = 0; t < N_PHANTOMS; t++) {
        vm_volume v;
        vm_phantom_info info;
        vm_mesh m;
        vm_mesh_stats st;
        vm_status s = mesh_phantom_hexes(t, &v, &info, &m, &st);
        if (s == VM_OK) {
            CHECK(st.repaired_points == 0);
            /* the bar: 2% at 64^3 (measured: genus-3 tubes -0.84%, plate -0.61%,
             * the others within 0.11%) */
            check_hex_mesh(info.name, &m, info.euler, (size_t)info.components, info.volume,
                           0.02);
            /* under the sanitizers the pass runs on the small ones only (a minute or more
             * each on the others: left to the Release run) */
            if (!small || m.ncells < 10000) {
                /* issue 34: 0.5 (measured 0.5000-0.501; 0.876 on the plate) */
                check_improved(info.name, &m, &v, 0.0, 0.4995, info.volume);
                check_boundary_distance(info.name, &m, &v, 0.0, PHANTOM_BOUNDARY_MAX);
            } else
                printf("  %s: the pass left to the Release run (sanitizer build)\n", info.name);
        }
        vm_mesh_free(&m);
        vm_volume_free(&v);
    }
}

/* The smaller shared volumes, meshed once: ironProt and hydrogen come out of the mesher
 * valid (checked with their Euler characteristic and components), the CT head at 1150 and the
 * MR head with 28 and 112 inverted hexes that the pass untangles; after the pass all reach
 * the bar of 0.2 (issue #5; the measured minimum beside each). On the heads the whole pillow
 * layer tangles on their folded boundaries, so the pass runs without it; the polish (boundary
 * points sliding along the isosurface) takes both over 0.2 there, so the selective layer is
 * not needed, and the repair (coupled moves on the last patches below the bar) with its bar
 * raised to 0.52 takes them to or near 0.5 (issue 34; every hex measured at its corners,
 * centre and Gauss points; docs/IMPROVE.md). The big heads are in test_mesh_hexes_heads.c.
 * Under the sanitizers the pass runs on the MR head only; the others get the raw-mesh
 * checks. */
static void hexMeshOfSharedVolumesIsValidAndThePassReachesTheBar(void) {
    static const struct {
        const char *file;
        double iso, floor;
        long euler; /* of the raw mesh; -1: not checked (the raw mesh has inverted hexes) */
        size_t comps;
        int sanitized_pass; /* the pass runs under the sanitizers too */
    } cases[] = {{"ironProt.vtk", 128, 0.4995, 50, 25, 0},       /* measured 0.501 */
                 {"hydrogen.vti", 0.1, 0.45, 4, 3, 0},           /* 0.5000 */
                 {"ct_head_quarter.nrrd", 1150, 0.42, -1, 0, 0}, /* 0.4749 */
                 {"HeadMRVolume.mhd", 50, 0.45, -1, 0, 1}};      /* 0.5000 */
    const char *sanitized = getenv("VM_SANITIZED");
    int small = sanitized && strcmp(sanitized, "1") == 0;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        int pass = !small || cases[c].sanitized_pass;
        if (!pass) printf("  %s: the pass left to the Release run (sanitizer build)\n",
                          cases[c].file);
        if (!check_shared_volume(cases[c].file, cases[c].iso, cases[c].floor, cases[c].euler,
                                 cases[c].comps, pass))
            return;
    }
}

/* --adaptive with hexes (issue #5) meshes: a valid closed mesh with fewer hexes than
 * uniform on a bulky shape (the full checks are in test_mesh_hexes_adaptive.c). */
static void hexMeshAdaptiveModeIsValidAndCoarser(void) {
    vm_volume v;
    vm_error err;
    vm_phantom_info info;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 40, 0.0, 0, &v, &info, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    vm_mesh u, m;
    CHECK_OK(vm_mesh_volume(&v, &o, &u, NULL, &err), &err);
    o.adaptive = 1;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    check_hex_mesh("sphere 40^3 adaptive", &m, info.euler, (size_t)info.components,
                   info.volume, 0.02);
    CHECK_MSG(m.ncells < u.ncells, "adaptive %zu hexes, uniform %zu", m.ncells, u.ncells);
    vm_mesh_free(&u);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(hexMeshOfEachPhantomIsValidAndThePassReachesTheBar),
          T(hexMeshOfSharedVolumesIsValidAndThePassReachesTheBar),
          T(hexMeshAdaptiveModeIsValidAndCoarser))
