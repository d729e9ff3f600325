/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_adaptive.c — the adaptive hex mesher (mesher/dc_hex_adaptive.c,
 * which makes its transitions conforming by pillowing: see docs/ALGORITHMS.md, "Adaptive
 * hexahedra") on the phantoms, and its refusal of bad options. */
#include "hex_checks.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Adaptive hexes on the six phantoms at 64^3 (48^3 under the sanitizers): a valid,
 * conforming, closed mesh with the phantom's topology and volume within 2%, fewer hexes than
 * uniform (before the pass) where a coarser grid keeps the shape (mesher/hex_base.c: step 1.5
 * voxels on all but the one-voxel plate, which keeps the full-resolution grid and, too thin
 * for an interior block, the uniform mesh), and the quality pass reaching 0.2 on them. */
static void adaptiveHexMeshOfEachPhantomIsValidAndCoarser(void) {
    static const struct {
        vm_phantom_kind kind;
        double max_ratio; /* adaptive / uniform hexes at most (measured beside) */
    } cases[] = {{VM_PHANTOM_SPHERE, 0.35},      /* 0.296 */
                 {VM_PHANTOM_TORUS, 0.35},       /* 0.29 */
                 {VM_PHANTOM_GENUS3, 0.4},       /* 0.32 */
                 {VM_PHANTOM_TWO_SPHERES, 0.35}, /* 0.30 */
                 {VM_PHANTOM_PLATE, 1.0},        /* 1 */
                 {VM_PHANTOM_CUT_SPHERE, 0.35}}; /* 0.30 */
    const char *sanitized = getenv("VM_SANITIZED");
    int small = sanitized && strcmp(sanitized, "1") == 0;
    int n = small ? 48 : 64;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        CHECK_OK(vm_phantom_make(cases[c].kind, n, 0.0, 0, &v, &info, &err), &err);
        vm_mesh uni, ada;
        vm_mesh_stats su, sa;
        if (mesh_hex_levels(&v, 0.0, 0, &uni, &su) == VM_OK &&
            mesh_hex_levels(&v, 0.0, 1, &ada, &sa) == VM_OK) {
            double ratio = (double)ada.ncells / (double)uni.ncells;
            printf("  %s %d^3: %zu uniform, %zu adaptive hexes (%.3f)\n", info.name, n,
                   uni.ncells, ada.ncells, ratio);
            CHECK(ada.ncells <= uni.ncells);
            if (!small)
                CHECK_MSG(ratio <= cases[c].max_ratio, "%s: ratio %.3f", info.name, ratio);
            check_hex_mesh(info.name, &ada, info.euler, (size_t)info.components, info.volume,
                           0.02);
            /* the pass on the transitions of the interior coarsening is in
             * test_mesh_hexes_adaptive_pass.c */
            if (!small && ada.ncells < uni.ncells && cases[c].kind != VM_PHANTOM_SPHERE)
                check_improved(info.name, &ada, &v, 0.0, 0.2, info.volume);
            vm_mesh_free(&ada);
        }
        vm_mesh_free(&uni);
        vm_volume_free(&v);
    }
}

/* --error below 0 or not a number is a bad argument for adaptive hexes (which do not use it:
 * their boundary is the uniform one), named in the message, and leaves no mesh. */
static void adaptiveHexMeshRejectsABadError(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 0, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = 1;
    vm_mesh m;
    const double bad[] = {-0.5, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o.error = bad[i];
        CHECK(vm_mesh_volume(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
        CHECK_MSG(strstr(err.message, "error") != NULL, "message '%s'", err.message);
        CHECK(m.ncells == 0);
    }
    o.error = 0.0; /* 0 is allowed, and a valid mesh */
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    CHECK(m.ncells > 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* --max-level outside 1..10 is a bad argument for hexes too, named in the message, and
 * leaves no mesh. */
static void adaptiveHexMeshRejectsABadMaxLevel(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 0, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = 1;
    vm_mesh m;
    for (int level = -1; level <= 11; level += 12) {
        o.max_level = level;
        CHECK(vm_mesh_volume(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
        CHECK(strstr(err.message, "max level") != NULL);
        CHECK(m.ncells == 0);
    }
    vm_volume_free(&v);
}

TEST_MAIN(T(adaptiveHexMeshOfEachPhantomIsValidAndCoarser), T(adaptiveHexMeshRejectsABadError),
          T(adaptiveHexMeshRejectsABadMaxLevel))
