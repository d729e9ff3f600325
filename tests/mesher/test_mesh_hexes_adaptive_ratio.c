/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_adaptive_ratio.c — what adaptive hexes (--elements hex
 * --adaptive: the coarser sampling grid of mesher/hex_base.c, then the interior coarsening
 * of mesher/dc_hex_adaptive.c) promise against uniform hexes, both after the quality pass as
 * `volmesh mesh` runs it: at least 2x fewer hexes, none inverted, min scaled Jacobian
 * (corners, centre and Gauss points) at least 0.5, a closed boundary with the uniform mesh's
 * Euler characteristic and components, the volume within 1% of the uniform mesh's and of the
 * phantom's, the boundary within half a voxel of the isosurface both ways; and where a
 * coarser grid loses the shape (the one-voxel plate) the full-resolution one. */
/* ctest parts: 2 */
#include "hex_checks.h"
#include <stdlib.h>
#include <string.h>

/* Hexes of v at iso 0 (adaptive or uniform) after the quality pass, checked: *rep. */
static vm_status pass_mesh(const vm_volume *v, int adaptive, vm_mesh *m, vm_mesh_report *rep) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = adaptive;
    o.lo = 0.0;
    vm_status s = vm_mesh_volume(v, &o, m, NULL, &err);
    CHECK_OK(s, &err);
    if (s) return s;
    vm_hex_improve_options io;
    vm_hex_improve_options_default(&io);
    io.lo = 0.0;
    vm_hex_improve_report ir;
    s = vm_mesh_improve_hexes(m, v, &io, &ir, &err);
    CHECK_OK(s, &err);
    if (!s) s = vm_mesh_check(m, rep, &err);
    CHECK_OK(s, &err);
    if (s) vm_mesh_free(m);
    return s;
}

/* The sphere and the torus at 64^3 (48^3 under the sanitizers, ratio not checked there):
 * measured 3.1x and 3.0x fewer hexes, min scaled Jacobian 0.500 both, 0.05 and 0.33 voxel. */
static void adaptiveHexesAreHalfTheUniformOnesWithTheirShape(void) {
    const char *sanitized = getenv("VM_SANITIZED");
    int small = sanitized && strcmp(sanitized, "1") == 0;
    const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS};
    for (size_t c = 0; c < sizeof kinds / sizeof kinds[0]; c++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        CHECK_OK(vm_phantom_make(kinds[c], small ? 48 : 64, 0.0, 0, &v, &info, &err), &err);
        vm_mesh uni, ada;
        vm_mesh_report ru, ra;
        if (pass_mesh(&v, 0, &uni, &ru) == VM_OK) {
            if (pass_mesh(&v, 1, &ada, &ra) == VM_OK) {
                vm_surface_distance d;
                CHECK_OK(vm_mesh_surface_distance(&ada, &v, 0.0, 1, 0.0, 0, &d, &err), &err);
                printf("  %s: %zu uniform, %zu adaptive hexes (%.2fx), min scaled Jacobian "
                       "%.4f / %.4f, volume %.1f / %.1f (%.1f), distance %.3f voxel\n",
                       info.name, uni.ncells, ada.ncells,
                       (double)uni.ncells / (double)ada.ncells, ru.min_scaled_jacobian,
                       ra.min_scaled_jacobian, ru.volume, ra.volume, info.volume,
                       d.hausdorff / d.voxel);
                if (!small)
                    CHECK_MSG(2 * ada.ncells <= uni.ncells, "%s: %zu adaptive, %zu uniform",
                              info.name, ada.ncells, uni.ncells);
                CHECK_MSG(ra.inverted == 0, "%s: %zu inverted", info.name, ra.inverted);
                CHECK_MSG(ra.min_scaled_jacobian >= 0.5, "%s: min scaled Jacobian %.4f",
                          info.name, ra.min_scaled_jacobian);
                CHECK(ra.overshared_faces == 0);
                CHECK(ra.boundary_closed == 1);
                CHECK(ra.boundary_nonmanifold_vertices == 0);
                CHECK_MSG(ra.boundary_euler == ru.boundary_euler && ra.boundary_euler == info.euler,
                          "%s: Euler %ld, uniform %ld", info.name, ra.boundary_euler,
                          ru.boundary_euler);
                CHECK_MSG(ra.components == ru.components &&
                              ra.components == (size_t)info.components,
                          "%s: %zu components", info.name, ra.components);
                CHECK_MSG(fabs(ra.volume - ru.volume) <= 0.01 * ru.volume,
                          "%s: volume %.1f, uniform %.1f", info.name, ra.volume, ru.volume);
                CHECK_MSG(fabs(ra.volume - info.volume) <= 0.01 * info.volume,
                          "%s: volume %.1f, phantom %.1f", info.name, ra.volume, info.volume);
                CHECK_MSG(d.hausdorff <= 0.5 * d.voxel, "%s: %.3f voxel off", info.name,
                          d.hausdorff / d.voxel);
                vm_mesh_free(&ada);
            }
            vm_mesh_free(&uni);
        }
        vm_volume_free(&v);
    }
}

/* The cut sphere at 96^3, cut by the box face x = 0: on each coarser grid (steps 1.5, 1.4,
 * 1.3) the quality pass ended at 0.47-0.48 while the whole pillow layer covered the box face
 * too (a box quad whose rim point was in no other box quad kept a corner angle near 180
 * degrees), so adaptive hexes fell back to the voxel grid's interior coarsening: 1.59x fewer
 * hexes than uniform, min scaled Jacobian 0.490. The layer now ends on the box (improve/
 * hex_improve.c, pillow's open sheet): step 1.5 is kept, measured 43,848 hexes after the pass
 * against 124,860 uniform hexes before it (139,672 after), min scaled Jacobian 0.5002, 0.36
 * voxel. The uniform count before the pass is the cheaper and stricter reference here (the
 * pass adds the layer's hexes). Skipped under the sanitizers (minutes there). */
static void adaptiveHexesOfABoxCutSphereKeepTheCoarseGrid(void) {
    const char *sanitized = getenv("VM_SANITIZED");
    if (sanitized && strcmp(sanitized, "1") == 0) {
        vm_test_skip("minutes under the sanitizers: left to the Release run");
        return;
    }
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_CUT_SPHERE, 96, 0.0, 0, &v, &info, &err), &err);
    vm_mesh uni, ada;
    vm_mesh_report ra;
    if (mesh_hex_levels(&v, 0.0, 0, &uni, NULL) == VM_OK) {
        if (pass_mesh(&v, 1, &ada, &ra) == VM_OK) {
            vm_surface_distance d;
            CHECK_OK(vm_mesh_surface_distance(&ada, &v, 0.0, 1, 0.0, 0, &d, &err), &err);
            printf("  %s 96^3: %zu uniform hexes before the pass, %zu adaptive after it "
                   "(%.2fx), min scaled Jacobian %.4f, volume %.1f (%.1f), distance %.3f voxel\n",
                   info.name, uni.ncells, ada.ncells, (double)uni.ncells / (double)ada.ncells,
                   ra.min_scaled_jacobian, ra.volume, info.volume, d.hausdorff / d.voxel);
            CHECK_MSG(2 * ada.ncells <= uni.ncells, "%zu adaptive, %zu uniform", ada.ncells,
                      uni.ncells);
            CHECK_MSG(ra.inverted == 0, "%zu inverted", ra.inverted);
            CHECK_MSG(ra.min_scaled_jacobian >= 0.5, "min scaled Jacobian %.4f",
                      ra.min_scaled_jacobian);
            CHECK(ra.overshared_faces == 0);
            CHECK(ra.boundary_closed == 1);
            CHECK(ra.boundary_nonmanifold_vertices == 0);
            CHECK_MSG(ra.boundary_euler == info.euler, "Euler %ld", ra.boundary_euler);
            CHECK_MSG(ra.components == (size_t)info.components, "%zu components",
                      ra.components);
            CHECK_MSG(fabs(ra.volume - info.volume) <= 0.01 * info.volume, "volume %.1f",
                      ra.volume);
            CHECK_MSG(d.hausdorff <= 0.5 * d.voxel, "%.3f voxel off", d.hausdorff / d.voxel);
            vm_mesh_free(&ada);
        }
        vm_mesh_free(&uni);
    }
    vm_volume_free(&v);
}

/* The plate, one voxel thick, changes its shape on a coarser grid: adaptive hexes keep the
 * full-resolution grid there (as many hexes as uniform before the pass: no interior block
 * fits either), a valid mesh with the plate's topology. */
static void aPlateKeepsTheFullResolutionGrid(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_PLATE, 40, 0.0, 0, &v, &info, &err), &err);
    vm_mesh uni, ada;
    if (mesh_hex_levels(&v, 0.0, 0, &uni, NULL) == VM_OK) {
        if (mesh_hex_levels(&v, 0.0, 4, &ada, NULL) == VM_OK) {
            printf("  plate 40^3: %zu uniform, %zu adaptive hexes\n", uni.ncells, ada.ncells);
            CHECK(ada.ncells == uni.ncells);
            check_hex_mesh("plate", &ada, info.euler, (size_t)info.components, info.volume,
                           0.05);
            vm_mesh_free(&ada);
        }
        vm_mesh_free(&uni);
    }
    vm_volume_free(&v);
}

/* A plate 1.2 voxels thick (bench/hex_adaptive.py's) keeps its shape on the grid 1.4 voxels
 * apart, but only with the pass's pillow layer round every hex: 3 200 hexes against 1 936
 * uniform before the grid's check counted them. Adaptive hexes never end with more than
 * uniform ones. */
static void aThinPlateGetsNoMoreHexesThanUniform(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 64, 0.0, 0, &v, NULL, &err), &err);
    double c = 31.5, a = 0.35 * 63;
    for (int64_t k = 0; k < v.dims[2]; k++)
        for (int64_t j = 0; j < v.dims[1]; j++)
            for (int64_t i = 0; i < v.dims[0]; i++) {
                double f = fmin(0.6 - fabs((double)k - floor(c)),
                                fmin(a - fabs((double)i - c), a - fabs((double)j - c)));
                v.data[i + v.dims[0] * (j + v.dims[1] * k)] = (float)f;
            }
    vm_mesh uni, ada;
    vm_mesh_report ru, ra;
    if (pass_mesh(&v, 0, &uni, &ru) == VM_OK) {
        if (pass_mesh(&v, 1, &ada, &ra) == VM_OK) {
            printf("  plate 64^3, 1.2 voxels thick: %zu uniform, %zu adaptive hexes after the "
                   "pass (min scaled Jacobian %.4f, %.4f)\n",
                   uni.ncells, ada.ncells, ru.min_scaled_jacobian, ra.min_scaled_jacobian);
            CHECK_MSG(ada.ncells <= uni.ncells, "%zu adaptive hexes > %zu uniform", ada.ncells,
                      uni.ncells);
            CHECK(ra.inverted == 0 && ra.min_scaled_jacobian >= 0.5);
            CHECK(ra.boundary_euler == ru.boundary_euler && ra.components == ru.components);
            vm_mesh_free(&ada);
        }
        vm_mesh_free(&uni);
    }
    vm_volume_free(&v);
}

/* The grid's choice rests on checks that run on threads (the distance measure): the same
 * mesh at 1 and 3 threads, on the genus-3 solid at 64^3, whose coarse grid is grown by a
 * shift (the secant path), and fewer hexes than uniform. */
static void theChosenGridIsTheSameForAnyThreadCount(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 64, 0.0, 0, &v, &info, &err), &err);
    int before = vm_set_threads(1);
    vm_mesh a, b, u;
    if (mesh_hex_levels(&v, 0.0, 0, &u, NULL) == VM_OK) {
        if (mesh_hex_levels(&v, 0.0, 4, &a, NULL) == VM_OK) {
            vm_set_threads(3);
            if (mesh_hex_levels(&v, 0.0, 4, &b, NULL) == VM_OK) {
                printf("  genus3 64^3: %zu uniform, %zu adaptive hexes before the pass\n",
                       u.ncells, a.ncells);
                CHECK(3 * a.ncells < u.ncells);
                CHECK(a.ncells == b.ncells && a.npoints == b.npoints);
                if (a.ncells == b.ncells && a.npoints == b.npoints) {
                    CHECK(memcmp(a.points, b.points, 3 * a.npoints * sizeof(double)) == 0);
                    CHECK(memcmp(a.cells, b.cells, 8 * a.ncells * sizeof(vm_index)) == 0);
                }
                vm_mesh_free(&b);
            }
            vm_mesh_free(&a);
        }
        vm_mesh_free(&u);
    }
    vm_set_threads(before);
    vm_volume_free(&v);
}

TEST_MAIN(T(adaptiveHexesAreHalfTheUniformOnesWithTheirShape),
          T(adaptiveHexesOfABoxCutSphereKeepTheCoarseGrid), T(aPlateKeepsTheFullResolutionGrid),
          T(aThinPlateGetsNoMoreHexesThanUniform), T(theChosenGridIsTheSameForAnyThreadCount))
