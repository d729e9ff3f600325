/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_graded.c — the graded mesher (isosurface stuffing over an octree sized
 * in world units): every mesh is valid and has the topology of its voxels (the cubical reading
 * dual contouring has), graded meshes are much smaller than uniform ones, and the sizes asked
 * for (--max-edge, --distance, anisotropic voxels) are met. */
#include "test.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state;
static double rng_uniform(void) { /* splitmix64, in [0, 1) */
    uint64_t z = (rng_state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) / 9007199254740992.0;
}

static int make_volume(vm_volume *v, int64_t nx, int64_t ny, int64_t nz, float fill) {
    vm_error err;
    int64_t dims[3] = {nx, ny, nz};
    vm_status s = vm_volume_alloc(v, dims, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return 0;
    for (size_t i = 0; i < vm_volume_count(v); i++) v->data[i] = fill;
    return 1;
}

static void graded_options(vm_mesh_options *o) {
    vm_mesh_options_default(o);
    o->graded = 1;
}

/* Meshes v and checks validity and, when euler/comps are given (comps > 0), the topology.
 * [out] r. Returns 0 when meshing failed. */
static int mesh_and_check(const char *label, const vm_volume *v, const vm_mesh_options *o,
                          long euler, size_t comps, int quiet, vm_mesh_report *r) {
    vm_mesh m;
    vm_error err;
    vm_status s = vm_mesh_volume(v, o, &m, NULL, &err);
    CHECK_MSG(s == VM_OK, "%s: %s", label, err.message);
    if (s != VM_OK) return 0;
    s = vm_mesh_check(&m, r, &err);
    CHECK_MSG(s == VM_OK, "%s: %s", label, err.message);
    vm_mesh_free(&m);
    if (s != VM_OK) return 0;
    int ok = r->inverted == 0 && r->degenerate == 0 && r->overshared_faces == 0 &&
             r->boundary_closed == 1 && r->boundary_nonmanifold_vertices == 0 &&
             (comps == 0 || (r->boundary_euler == euler && r->components == comps));
    CHECK_MSG(ok,
              "%s: inverted %zu degenerate %zu overshared %zu closed %d nm-edges %zu "
              "nm-vertices %zu euler %ld (expected %ld) components %zu (expected %zu)",
              label, r->inverted, r->degenerate, r->overshared_faces, r->boundary_closed,
              r->boundary_nonmanifold_edges, r->boundary_nonmanifold_vertices, r->boundary_euler,
              euler, r->components, comps);
    if (!quiet)
        printf("    %s: tets %zu euler %ld components %zu volume %.6g dihedral %.2f..%.2f\n",
               label, r->cells, r->boundary_euler, r->components, r->volume, r->min_dihedral,
               r->max_dihedral);
    return 1;
}

static void everyCubePatternKeepsTheCubicalTopology(void) {
    vm_mesh_options o;
    graded_options(&o);
    int before = vm_test_failures;
    for (int pat = 1; pat < 256; pat++) {
        vm_volume v;
        if (!make_volume(&v, 4, 4, 4, -1.0f)) return;
        for (int q = 0; q < 8; q++)
            if (pat >> q & 1) v.data[(1 + (q & 1)) + 4 * ((1 + (q >> 1 & 1)) + 4 * (1 + (q >> 2)))] = 1.0f;
        long euler;
        size_t comps;
        vm_test_digital_topology(&v, 1, 0.0, 0, 0.0, &euler, &comps);
        char label[64];
        snprintf(label, sizeof label, "cube pattern %d", pat);
        vm_mesh_report r;
        mesh_and_check(label, &v, &o, euler, comps, 1, &r);
        vm_volume_free(&v);
    }
    printf("  all 255 patterns of a 2x2x2 cube: %s\n",
           vm_test_failures == before ? "ok" : "FAILED");
}

static void randomVolumesKeepTheCubicalTopology(void) {
    static const int sizes[] = {8, 12, 12, 16, 20, 20};
    for (size_t c = 0; c < sizeof sizes / sizeof sizes[0]; c++) {
        vm_volume v;
        int n = sizes[c];
        if (!make_volume(&v, n, n, n, 0.0f)) continue;
        rng_state = 0x5eed0000ull + c;
        for (size_t i = 0; i < vm_volume_count(&v); i++)
            v.data[i] = (float)(2.0 * rng_uniform() - 1.0);
        long euler;
        size_t comps;
        vm_test_digital_topology(&v, 1, 0.0, 0, 0.0, &euler, &comps);
        vm_mesh_options o;
        graded_options(&o);
        char label[64];
        snprintf(label, sizeof label, "random %d^3 seed %zu", n, c);
        vm_mesh_report r;
        mesh_and_check(label, &v, &o, euler, comps, 0, &r);
        vm_volume_free(&v);
    }
}

static const vm_phantom_kind phantoms[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS,
                                           VM_PHANTOM_GENUS3, VM_PHANTOM_TWO_SPHERES,
                                           VM_PHANTOM_PLATE, VM_PHANTOM_CUT_SPHERE};

static void noisyPhantomsKeepTheCubicalTopology(void) {
    static const double noise[] = {0.3, 1.0};
    for (size_t t = 0; t < sizeof phantoms / sizeof phantoms[0]; t++)
        for (size_t q = 0; q < 2; q++) {
            vm_volume v;
            vm_phantom_info info;
            vm_error err;
            vm_status s = vm_phantom_make(phantoms[t], 48, noise[q], 77u + (unsigned)q, &v,
                                          &info, &err);
            CHECK_OK(s, &err);
            if (s != VM_OK) continue;
            long euler;
            size_t comps;
            vm_test_digital_topology(&v, 1, 0.0, 0, 0.0, &euler, &comps);
            vm_mesh_options o;
            graded_options(&o);
            char label[96];
            snprintf(label, sizeof label, "%s 48^3 noise %.1f", info.name, noise[q]);
            vm_mesh_report r;
            mesh_and_check(label, &v, &o, euler, comps, 0, &r);
            vm_volume_free(&v);
        }
}

/* Clean phantoms: the known topology, the volume within 2%, and at least 3x fewer tets than
 * the uniform dual-contouring mesh. */
static void gradedPhantomsAreSmallAndFaithful(void) {
    for (size_t t = 0; t < sizeof phantoms / sizeof phantoms[0]; t++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        vm_status s = vm_phantom_make(phantoms[t], 64, 0.0, 1u, &v, &info, &err);
        CHECK_OK(s, &err);
        if (s != VM_OK) continue;
        vm_mesh_options o;
        graded_options(&o);
        vm_mesh_report r, u;
        char label[96];
        snprintf(label, sizeof label, "%s 64^3 graded", info.name);
        if (mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &r)) {
            vm_mesh_options_default(&o);
            snprintf(label, sizeof label, "%s 64^3 uniform (dual contouring)", info.name);
            if (mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &u))
                CHECK_MSG(3 * r.cells <= u.cells, "%s: graded %zu tets, uniform %zu", info.name,
                          r.cells, u.cells);
            CHECK_MSG(fabs(r.volume - info.volume) <= 0.02 * info.volume,
                      "%s: volume %.6g, expected %.6g", info.name, r.volume, info.volume);
        }
        vm_volume_free(&v);
    }
}

TEST_MAIN(T(everyCubePatternKeepsTheCubicalTopology), T(randomVolumesKeepTheCubicalTopology),
          T(noisyPhantomsKeepTheCubicalTopology), T(gradedPhantomsAreSmallAndFaithful))
