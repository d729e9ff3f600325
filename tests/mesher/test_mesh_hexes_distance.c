/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_distance.c — issue 34's boundary bar on voxels that are not
 * cubes: after the quality pass, the two-sided distance between the hex mesh's boundary and
 * the isosurface (vm_mesh_surface_distance, the measure of --distance-check) in voxels of
 * the cube root of one voxel's volume, the unit the pass bounds its moves in (improve/
 * hex_improve.c). A torus phantom with its voxels 3.2 x 3.2 x 1.5 as the CT head's, so a
 * pass that bounded its moves in index units (0.45 of a 3.2 voxel is 0.58 of the cube-root
 * voxel across x and y) fails it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "hex_checks.h"

/* Bounds in voxels (the cube root of one voxel's volume): issue 34's bar is 0.5 both ways;
 * boundary -> isosurface also below what a pass bounding its moves in index units leaves
 * (measured 2026-12-05: uniform 0.373, adaptive 0.418; with the bound in these voxels and
 * the quads' samples bounded too: 0.307 and 0.345). */
#define BAR 0.5
#define OUT_UNIFORM 0.34
#define OUT_ADAPTIVE 0.38

/* A copy of hex mesh m. [out] out (free it). */
static void copy_mesh(const vm_mesh *m, vm_mesh *out) {
    vm_error err;
    vm_mesh_init(out, VM_HEX8);
    CHECK_OK(vm_mesh_reserve(out, m->npoints, m->ncells, &err), &err);
    memcpy(out->points, m->points, 3 * m->npoints * sizeof *out->points);
    memcpy(out->cells, m->cells, 8 * m->ncells * sizeof *out->cells);
    memcpy(out->region, m->region, m->ncells * sizeof *out->region);
    out->npoints = m->npoints;
    out->ncells = m->ncells;
}

static void measure(const char *label, int levels, double out_max) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 48, 0.0, 1, &v, NULL, &err), &err);
    v.spacing[0] = v.spacing[1] = 3.2;
    v.spacing[2] = 1.5;
    vm_mesh m;
    if (mesh_hex_levels(&v, 0.0, levels, &m, NULL) != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    /* the quads' bound reads the points round the moving one: the same bytes on 2 threads */
    vm_mesh two;
    copy_mesh(&m, &two);
    int threads = vm_set_threads(1);
    check_improved(label, &m, &v, 0.0, 0.5, 0);
    vm_set_threads(2);
    vm_hex_improve_options ho;
    vm_hex_improve_options_default(&ho);
    ho.lo = 0.0;
    vm_hex_improve_report hr;
    CHECK_OK(vm_mesh_improve_hexes(&two, &v, &ho, &hr, &err), &err);
    vm_set_threads(threads);
    CHECK_MSG(two.npoints == m.npoints && two.ncells == m.ncells &&
                  memcmp(two.points, m.points, 3 * m.npoints * sizeof *m.points) == 0 &&
                  memcmp(two.cells, m.cells, 8 * m.ncells * sizeof *m.cells) == 0,
              "%s: other bytes on 2 threads", label);
    vm_mesh_free(&two);
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
    vm_surface_distance d;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0.0, 1, 0.0, 0, &d, &err), &err);
    double out = d.mesh_to_surface_max / d.voxel, in = d.surface_to_mesh_max / d.voxel;
    printf("  %s: %zu hexes, min scaled Jacobian %.4f, boundary -> isosurface %.3f voxel, "
           "isosurface -> boundary %.3f voxel (voxel %.3f)\n",
           label, m.ncells, r.min_scaled_jacobian, out, in, d.voxel);
    CHECK_MSG(r.inverted == 0, "%s: %zu inverted", label, r.inverted);
    CHECK_MSG(r.min_scaled_jacobian >= 0.5, "%s: min scaled Jacobian %.4f", label,
              r.min_scaled_jacobian);
    CHECK(r.boundary_closed == 1);
    CHECK_MSG(r.boundary_euler == 0 && r.components == 1, "%s: Euler %ld, %zu components",
              label, r.boundary_euler, r.components);
    CHECK_MSG(out <= out_max, "%s: boundary %.3f voxel off the isosurface (at most %.2f)",
              label, out, out_max);
    CHECK_MSG(in <= BAR, "%s: isosurface %.3f voxel off the boundary", label, in);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void anisotropicTorusHexBoundaryWithinHalfAVoxel(void) {
    measure("torus 48^3, 3.2 x 3.2 x 1.5 voxels, uniform", 0, OUT_UNIFORM);
}

static void anisotropicTorusAdaptiveHexBoundaryWithinHalfAVoxel(void) {
    measure("torus 48^3, 3.2 x 3.2 x 1.5 voxels, adaptive", 4, OUT_ADAPTIVE);
}

/* ironProt at 128 (issue 34's bar on a real volume): both ways within 0.45 voxel. Before
 * the isosurface samples (and the quads' diagonal samples and the distance's compass
 * search where the gradient line finds no crossing), the isosurface was up to 0.674 voxel
 * from the boundary, where the pass chorded a small bump off, and the boundary 0.578 from
 * it (measured 2026-12-07 after: 0.398 and 0.401). */
#define IRONPROT_MAX 0.45

static void ironProtHexBoundaryWithinHalfAVoxelBothWays(void) {
    const char *path = vm_test_shared("ironProt.vtk");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    vm_mesh m;
    if (mesh_hex_levels(&v, 128.0, 0, &m, NULL) != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    check_improved("ironProt 128", &m, &v, 128.0, 0.5, 0);
    vm_surface_distance d;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 128.0, 1, 0.0, 0, &d, &err), &err);
    double out = d.mesh_to_surface_max / d.voxel, in = d.surface_to_mesh_max / d.voxel;
    printf("  ironProt 128: boundary -> isosurface %.3f voxel, isosurface -> boundary %.3f\n",
           out, in);
    CHECK_MSG(out <= IRONPROT_MAX, "boundary %.3f voxel off the isosurface", out);
    CHECK_MSG(in <= IRONPROT_MAX, "isosurface %.3f voxel off the boundary", in);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(anisotropicTorusHexBoundaryWithinHalfAVoxel),
          T(anisotropicTorusAdaptiveHexBoundaryWithinHalfAVoxel),
          T(ironProtHexBoundaryWithinHalfAVoxelBothWays))
