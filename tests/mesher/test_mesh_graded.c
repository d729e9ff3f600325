/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_graded.c — the graded mesher (isosurface stuffing over an octree sized
 * in world units): every mesh is valid and has the topology of its voxels (the cubical reading
 * dual contouring has), graded meshes are much smaller than uniform ones, and the sizes asked
 * for (--max-edge, --distance, anisotropic voxels) are met. */
#include "mesher/graded_internal.h"
#include "test.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rng_state;

static int make_volume(vm_volume *v, int64_t nx, int64_t ny, int64_t nz, float fill) {
    vm_error err;
    int64_t dims[3] = {nx, ny, nz};
    vm_status s = vm_volume_alloc(v, dims, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return 0;
    for (size_t i = 0; i < vm_volume_count(v); i++)
        v->data[i] = fill;
    return 1;
}

/* A noiseless phantom of n^3 voxels, checked. */
static vm_status phantom(vm_phantom_kind kind, int n, vm_volume *v, vm_phantom_info *info,
                         vm_error *err) {
    vm_status s = vm_phantom_make(kind, n, 0.0, 1u, v, info, err);
    CHECK_OK(s, err);
    return s;
}

static void graded_options(vm_mesh_options *o) {
    vm_mesh_options_default(o);
    o->graded = 1;
}

/* Meshes v and checks validity and, when euler/comps are given (comps > 0), the topology.
 * [out] r, and the run's counters in *st (may be NULL). Returns 0 when meshing failed. */
static int mesh_and_check_stats(const char *label, const vm_volume *v, const vm_mesh_options *o,
                                long euler, size_t comps, int quiet, vm_mesh_report *r,
                                vm_mesh_stats *st) {
    vm_mesh m;
    vm_error err;
    vm_status s = vm_mesh_volume(v, o, &m, st, &err);
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
              r->boundary_nonmanifold_edges, r->boundary_nonmanifold_vertices,
              r->boundary_euler, euler, r->components, comps);
    if (!quiet)
        printf("    %s: tets %zu euler %ld components %zu volume %.6g dihedral %.2f..%.2f\n",
               label, r->cells, r->boundary_euler, r->components, r->volume, r->min_dihedral,
               r->max_dihedral);
    return 1;
}

static int mesh_and_check(const char *label, const vm_volume *v, const vm_mesh_options *o,
                          long euler, size_t comps, int quiet, vm_mesh_report *r) {
    return mesh_and_check_stats(label, v, o, euler, comps, quiet, r, NULL);
}

static void everyCubePatternKeepsTheCubicalTopology(void) {
    vm_mesh_options o;
    graded_options(&o);
    int before = vm_test_failures;
    for (int pat = 1; pat < 256; pat++) {
        vm_volume v;
        if (!make_volume(&v, 4, 4, 4, -1.0f)) return;
        for (int q = 0; q < 8; q++)
            if (pat >> q & 1)
                v.data[(1 + (q & 1)) + 4 * ((1 + (q >> 1 & 1)) + 4 * (1 + (q >> 2)))] = 1.0f;
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
            v.data[i] = (float)(2.0 * vm_test_uniform(&rng_state) - 1.0);
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
                                           VM_PHANTOM_PLATE,  VM_PHANTOM_CUT_SPHERE};

static void noisyPhantomsKeepTheCubicalTopology(void) {
    static const double noise[] = {0.3, 1.0};
    for (size_t t = 0; t < sizeof phantoms / sizeof phantoms[0]; t++)
        for (size_t q = 0; q < 2; q++) {
            vm_volume v;
            vm_phantom_info info;
            vm_error err;
            vm_status s =
                vm_phantom_make(phantoms[t], 48, noise[q], 77u + (unsigned)q, &v, &info, &err);
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

/* The longest edge of a tet mesh. */
static double longest_edge(const vm_mesh *m) {
    double e = 0;
    for (size_t t = 0; t < m->ncells; t++)
        for (int a = 0; a < 4; a++)
            for (int c = a + 1; c < 4; c++) {
                const double *p = m->points + 3 * (size_t)m->cells[4 * t + (size_t)a],
                             *q = m->points + 3 * (size_t)m->cells[4 * t + (size_t)c];
                double d2 = 0;
                for (int k = 0; k < 3; k++)
                    d2 += (p[k] - q[k]) * (p[k] - q[k]);
                e = fmax(e, sqrt(d2));
            }
    return e;
}

/* The mean of each tet's smallest dihedral angle over a mesh. */
static double mean_min_dihedral(const vm_mesh *m) {
    vm_quality_summary q;
    vm_error err;
    double mean = 0;
    CHECK_OK(vm_quality_report(m, &q, &err), &err);
    CHECK(vm_quality_lookup(&q, "min_dihedral.mean", &mean) == VM_OK);
    return mean;
}

static int tri_cmp(const void *x, const void *y) {
    return memcmp(x, y, 3 * sizeof(vm_index));
}

/* The boundary triangles of a tet mesh, each sorted, the list sorted (qsort: for big
 * meshes). [out] *n. Free the list. */
static vm_index (*boundary_list(const vm_mesh *m, size_t *n))[3] {
    static const int fo[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    size_t nf = 4 * m->ncells;
    vm_index(*f)[3] = malloc((nf + 1) * sizeof *f);
    *n = 0;
    if (!f) return NULL;
    for (size_t t = 0; t < m->ncells; t++)
        for (int k = 0; k < 4; k++) {
            vm_index *q = f[4 * t + (size_t)k];
            for (int j = 0; j < 3; j++)
                q[j] = m->cells[4 * t + (size_t)fo[k][j]];
            for (int a = 0; a < 3; a++)
                for (int b = a + 1; b < 3; b++)
                    if (q[b] < q[a]) {
                        vm_index x = q[a];
                        q[a] = q[b];
                        q[b] = x;
                    }
        }
    qsort(f, nf, sizeof *f, tri_cmp);
    for (size_t i = 0; i < nf;) {
        size_t j = i + 1;
        while (j < nf && !tri_cmp(f[i], f[j]))
            j++;
        if (j == i + 1) memmove(f[(*n)++], f[i], sizeof f[i]);
        i = j;
    }
    return f;
}

/* Checks tet mesh m into *r, first turning every tet over (its first two corners swapped)
 * when they all came out inverted: the tests below list corners without minding their turn. */
static void check_turned(vm_mesh *m, vm_mesh_report *r) {
    vm_error err;
    CHECK_OK(vm_mesh_check(m, r, &err), &err);
    if (!r->inverted) return;
    for (size_t t = 0; t < m->ncells; t++) {
        vm_index x = m->cells[4 * t];
        m->cells[4 * t] = m->cells[4 * t + 1];
        m->cells[4 * t + 1] = x;
    }
    CHECK_OK(vm_mesh_check(m, r, &err), &err);
}

/* Edge removal (vm__gr_flips): a tall bipyramid over a regular n-gon (n = 4..7, apexes 3
 * radii above and below) is a ring of n tets around its axis with dihedral angles up to 147
 * to 154 degrees. The flips take the axis out (no tet keeps both apexes), leave the boundary
 * and the volume as they were and better the worst angles; at n = 4 and 5 by edge removal
 * alone, into the 2n - 4 tets of a triangulated n-gon. */
static void edgeRemovalMendsTallBipyramids(void) {
    vm_volume v;
    if (!make_volume(&v, 9, 9, 9, 1.0f)) return;
    for (int n = 4; n <= 7; n++) {
        vm_mesh m;
        vm_error err;
        vm_mesh_init(&m, VM_TET4);
        const double c[3] = {4.0, 4.0, 4.0}, h = 3.0;
        for (int i = 0; i < n; i++) {
            double a = 2.0 * 3.14159265358979323846 * i / n;
            double p[3] = {c[0] + cos(a), c[1] + sin(a), c[2]};
            CHECK(vm_mesh_add_point(&m, p, &err) == i);
        }
        double pd[3] = {c[0], c[1], c[2] - h}, pe[3] = {c[0], c[1], c[2] + h};
        vm_index d = vm_mesh_add_point(&m, pd, &err), e = vm_mesh_add_point(&m, pe, &err);
        for (int i = 0; i < n; i++) {
            vm_index q[4] = {i, (i + 1) % n, d, e};
            CHECK_OK(vm_mesh_add_cell(&m, q, 0, &err), &err);
        }
        vm_mesh_report r0, r1;
        check_turned(&m, &r0);
        size_t nb0 = 0, nb1 = 0;
        vm_index(*b0)[3] = boundary_list(&m, &nb0);
        size_t flips = 0, removals = 0, bremovals = 0;
        CHECK_OK(vm__gr_flips(&m, &v, 0.0, 1, 0.0, 0, 0.0, 0.0, &flips, &removals, &bremovals,
                              &err),
                 &err);
        CHECK(bremovals == 0);
        CHECK_OK(vm_mesh_check(&m, &r1, &err), &err);
        vm_index(*b1)[3] = boundary_list(&m, &nb1);
        size_t axis = 0;
        for (size_t t = 0; t < m.ncells; t++) {
            int hd = 0, he = 0;
            for (int k = 0; k < 4; k++) {
                hd |= m.cells[4 * t + (size_t)k] == d;
                he |= m.cells[4 * t + (size_t)k] == e;
            }
            axis += hd && he;
        }
        printf("    bipyramid n = %d: %zu flips (%zu edge removals), %zu -> %zu tets, "
               "dihedral %.1f..%.1f -> %.1f..%.1f\n",
               n, flips, removals, (size_t)n, m.ncells, r0.min_dihedral, r0.max_dihedral,
               r1.min_dihedral, r1.max_dihedral);
        CHECK(flips >= 1 && removals >= 1 && axis == 0);
        if (n <= 5) CHECK(flips == removals && m.ncells == (size_t)(2 * n - 4));
        CHECK(r1.inverted == 0 && r1.degenerate == 0 && r1.overshared_faces == 0 &&
              r1.boundary_closed == 1 && r1.boundary_euler == 2 && r1.components == 1);
        CHECK(fabs(r1.volume - r0.volume) <= 1e-12 * r0.volume);
        CHECK(b0 && b1 && nb0 == 2 * (size_t)n && nb1 == nb0 &&
              !memcmp(b0, b1, nb0 * sizeof b0[0]));
        free(b0);
        free(b1);
        CHECK_MSG(r1.max_dihedral < r0.max_dihedral - 10.0, "max %.2f -> %.2f", r0.max_dihedral,
                  r1.max_dihedral);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

/* Boundary edge removal (vm__gr_flips with a distance bound, as the coarsening's flips run):
 * on a stuffed torus (48^3, no coarsening) it turns boundary edges (the boundary keeps its
 * triangle count, but not its triangles), and the mesh stays valid, closed, of the same
 * Euler characteristic and components, its volume within 1%, its boundary within the bound
 * of the isosurface both ways (half a voxel, or where the stuffed mesh was). */
static void boundaryEdgesFlipWithinTheBound(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    if (phantom(VM_PHANTOM_TORUS, 48, &v, &info, &err) != VM_OK) return;
    vm_mesh_options o;
    graded_options(&o);
    o.no_coarsen = 1;
    vm_mesh m;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    const double D = 0.5;
    vm_mesh_report r0, r1;
    vm_surface_distance d0, d1;
    CHECK_OK(vm_mesh_check(&m, &r0, &err), &err);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0.0, 1, 0.0, 0, &d0, &err), &err);
    size_t nb0 = 0, nb1 = 0;
    vm_index(*b0)[3] = boundary_list(&m, &nb0);
    size_t flips = 0, removals = 0, bremovals = 0;
    CHECK_OK(vm__gr_flips(&m, &v, 0.0, 1, 0.0, 0, 0.0, D, &flips, &removals, &bremovals, &err),
             &err);
    CHECK_OK(vm_mesh_check(&m, &r1, &err), &err);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0.0, 1, 0.0, 0, &d1, &err), &err);
    vm_index(*b1)[3] = boundary_list(&m, &nb1);
    size_t same = 0;
    for (size_t i = 0, j = 0; b0 && b1 && i < nb0 && j < nb1;) {
        int c = tri_cmp(b0[i], b1[j]);
        if (!c) same++;
        if (c <= 0) i++;
        if (c >= 0) j++;
    }
    printf("    torus 48^3 stuffed: %zu flips (%zu edge removals, %zu boundary edge removals), "
           "%zu -> "
           "%zu tets, %zu of %zu boundary triangles kept, distance %.3f / %.3f -> %.3f / "
           "%.3f\n",
           flips, removals, bremovals, r0.cells, r1.cells, same, nb0, d0.mesh_to_surface_max,
           d0.surface_to_mesh_max, d1.mesh_to_surface_max, d1.surface_to_mesh_max);
    CHECK(bremovals > 0 && nb1 == nb0 && same < nb0);
    CHECK(r1.inverted == 0 && r1.degenerate == 0 && r1.overshared_faces == 0 &&
          r1.boundary_closed == 1 && r1.boundary_nonmanifold_vertices == 0 &&
          r1.boundary_euler == r0.boundary_euler && r1.components == r0.components);
    CHECK_MSG(fabs(r1.volume - r0.volume) <= 0.01 * r0.volume, "volume %.6g -> %.6g",
              r0.volume, r1.volume);
    CHECK(d1.mesh_to_surface_max <= 1.05 * fmax(D, d0.mesh_to_surface_max) &&
          d1.surface_to_mesh_max <= 1.05 * fmax(D, d0.surface_to_mesh_max));
    free(b0);
    free(b1);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Boundary edge removal in a border plane (vm__gr_flips): a tent over a thin rhombus on
 * the volume's bottom plane, two tets round its long diagonal (dihedral angles 19.5 to 152.7
 * degrees), is flipped onto the short diagonal. Its four corners lie in the plane, so the flip
 * keeps the boundary's place though the isosurface checks cannot read it (the field is
 * constant): the coarsening's repair left such a tet at 13.05 degrees on the CT head
 * (--distance 1.45). */
static void flatBorderEdgesFlip(void) {
    vm_volume v;
    if (!make_volume(&v, 9, 9, 9, 1.0f)) return;
    vm_mesh m;
    vm_error err;
    vm_mesh_init(&m, VM_TET4);
    const double p[5][3] = {{2, 4, 0}, {6, 4, 0}, {4, 3.5, 0}, {4, 4, 2}, {4, 4.5, 0}};
    for (int i = 0; i < 5; i++)
        CHECK(vm_mesh_add_point(&m, p[i], &err) == (vm_index)i);
    const vm_index q[2][4] = {{0, 1, 2, 3}, {0, 1, 3, 4}};
    for (int t = 0; t < 2; t++)
        CHECK_OK(vm_mesh_add_cell(&m, q[t], 0, &err), &err);
    vm_mesh_report r0, r1;
    check_turned(&m, &r0);
    size_t flips = 0, removals = 0, bremovals = 0;
    CHECK_OK(
        vm__gr_flips(&m, &v, 0.0, 1, 0.0, 0, 0.0, 0.5, &flips, &removals, &bremovals, &err),
        &err);
    CHECK_OK(vm_mesh_check(&m, &r1, &err), &err);
    printf("    tent on the border plane: %zu boundary edge removals, dihedral %.1f..%.1f -> "
           "%.1f..%.1f\n",
           bremovals, r0.min_dihedral, r0.max_dihedral, r1.min_dihedral, r1.max_dihedral);
    CHECK(bremovals == 1 && m.ncells == 2 && m.npoints == 5);
    /* no tet holds the long diagonal; both hold the short one */
    for (size_t t = 0; t < m.ncells; t++) {
        int h[5] = {0};
        for (int k = 0; k < 4; k++)
            h[m.cells[4 * t + (size_t)k]] = 1;
        CHECK(!(h[0] && h[1]) && h[2] && h[4]);
    }
    CHECK(r1.inverted == 0 && r1.degenerate == 0 && r1.boundary_closed == 1 &&
          r1.boundary_euler == 2 && r1.components == 1);
    CHECK(fabs(r1.volume - r0.volume) <= 1e-12 * r0.volume);
    CHECK_MSG(r1.min_dihedral > r0.min_dihedral + 10.0, "min %.2f -> %.2f", r0.min_dihedral,
              r1.min_dihedral);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Coarsening near the volume's border (vm__gr_coarsen): the stuffing holds a cut across the
 * border a hair off the plane (GR_CUT_BORDER of its edge) where the vertex on the plane
 * cannot go on the surface; the CT head (--distance 1.15) kept such points 0.03 mm apart in a
 * 0.6 degree tet, as the checks read their triangles beyond the volume and refused every
 * collapse. Here a ball cut by the top plane is stuffed, its points on that plane lifted a
 * hundredth of a voxel beyond it, and coarsened: most of the lifted points go, the
 * boundary stays closed with the ball's topology. */
static void hairBeyondTheBorderCoarsens(void) {
    const int n = 16;
    vm_volume v;
    if (!make_volume(&v, n, n, n, 0.0f)) return;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double r = sqrt((i - 7.3) * (i - 7.3) + (j - 7.6) * (j - 7.6) +
                                (k - 17.0) * (k - 17.0));
                v.data[i + n * (j + n * k)] = (float)(9.0 - r);
            }
    vm_mesh_options o;
    graded_options(&o);
    o.no_coarsen = 1;
    vm_mesh m;
    vm_error err;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    const double top = n - 1;
    size_t lifted = 0, left = 0;
    for (size_t i = 0; i < m.npoints; i++) {
        double *p = m.points + 3 * i;
        int side = p[0] <= 0 || p[0] >= top || p[1] <= 0 || p[1] >= top;
        if (p[2] == top && !side) {
            p[2] += 0.01;
            lifted++;
        }
    }
    gr_field f;
    CHECK_OK(vm__gr_field_init(&f, &v, &o, &err), &err);
    size_t removed = 0;
    CHECK_OK(vm__gr_coarsen(&m, &f, 0.5, 0.0, 0, 1, NULL, &removed, &err), &err);
    vm__gr_field_free(&f);
    for (size_t i = 0; i < m.npoints; i++)
        left += m.points[3 * i + 2] > top;
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
    printf("    ball cut by the top plane: %zu points lifted beyond it, %zu left after "
           "coarsening (%zu vertices removed), dihedral %.1f..%.1f\n",
           lifted, left, removed, r.min_dihedral, r.max_dihedral);
    CHECK(lifted >= 20);
    CHECK_MSG(left * 4 <= lifted, "%zu of %zu lifted points left", left, lifted);
    CHECK(r.inverted == 0 && r.degenerate == 0 && r.boundary_closed == 1 &&
          r.boundary_euler == 2 && r.components == 1);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* vm__gr_mean_smooth (the graded pass's last step): on a graded genus 3 (after its quality
 * pass) whose interior vertices were pushed off their places (each 0.3 voxel along a fixed
 * pseudo-random direction, kept only where its tets stay within 15..150 degrees), the
 * sweeps win back most of the mean of the smallest dihedral angles that the pushes cost,
 * move no boundary vertex, lower no worst angle and lengthen no edge past max_edge. */
static void meanSweepsRaiseTheMeanInside(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 48, 0.0, 1u, &v, &info, &err), &err);
    vm_mesh_options o;
    graded_options(&o);
    vm_mesh m;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    /* with its quality pass: every tet within 15..150 degrees before the pushes */
    vm_improve_options io;
    vm_improve_options_default(&io);
    io.lo = 0.0;
    io.has_lo = 1;
    CHECK_OK(vm_mesh_improve_graded(&m, &v, &io, NULL, &err), &err);
    /* boundary vertices: the corners of faces of one tet */
    vm_mesh b;
    CHECK_OK(vm_mesh_boundary(&m, &b, &err), &err);
    unsigned char *bnd = calloc(m.npoints, 1);
    for (size_t i = 0; i < b.npoints; i++)
        for (size_t j = 0; j < m.npoints; j++)
            if (!memcmp(b.points + 3 * i, m.points + 3 * j, 3 * sizeof(double))) bnd[j] = 1;
    double mean_in = mean_min_dihedral(&m);
    size_t pushed = vm_test_push_interior(&m, 0.3, 12345u, 0.0);
    double edge_max = longest_edge(&m);
    vm_mesh_report r0, r1;
    CHECK_OK(vm_mesh_check(&m, &r0, &err), &err);
    double mean0 = mean_min_dihedral(&m);
    double *before = malloc(3 * m.npoints * sizeof *before);
    memcpy(before, m.points, 3 * m.npoints * sizeof *before);
    size_t moved = 0, flips[4];
    CHECK_OK(vm__gr_mean_smooth(&m, &v, 0.0, 1, 0.0, 0, edge_max, 0.0, &moved, flips, &err),
             &err);
    CHECK_OK(vm_mesh_check(&m, &r1, &err), &err);
    double mean1 = mean_min_dihedral(&m);
    printf("    genus3 48^3: mean smallest dihedral %.2f, %zu interior vertices pushed %.2f, "
           "swept %.2f; worst %.2f -> %.2f, %zu moved\n",
           mean_in, pushed, mean0, mean1, r0.min_dihedral, r1.min_dihedral, moved);
    CHECK(pushed > 10 && moved > 0);
    /* they win back at least half of what the pushes cost (85% here) */
    CHECK_MSG(mean0 < mean_in && mean1 >= mean0 + 0.5 * (mean_in - mean0),
              "mean %.3f, pushed %.3f, swept %.3f", mean_in, mean0, mean1);
    CHECK(r1.inverted == 0 && r1.min_dihedral >= r0.min_dihedral - 1e-9 &&
          r1.max_dihedral <= 150 + 1e-9 && r1.boundary_euler == r0.boundary_euler);
    size_t bmoved = 0;
    for (size_t i = 0; i < m.npoints; i++)
        if (bnd[i] && memcmp(before + 3 * i, m.points + 3 * i, 3 * sizeof(double))) bmoved++;
    CHECK(bmoved == 0);
    CHECK(longest_edge(&m) <= edge_max + 1e-9);
    free(before);
    free(bnd);
    vm_mesh_free(&b);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Clean phantoms: the known topology, the boundary within the distance bound (half a voxel)
 * of the isosurface both ways, the volume within 5% (chords cut convex parts), and fewer tets
 * than the uniform dual-contouring mesh by a floor per shape that this step reaches (the
 * sizing issue asks 4x; docs/SIZING.md says where it stands). The plate is a sheet one voxel
 * thick, all base cells in any mesh: a graded mesh must only not be much larger there. The
 * cut sphere meets the volume's border, where the mesh closes it with a flat face and keeps
 * faces a hair off the plane beside its rim: the distance measures them against the plane's
 * section of the material too (until 2026-12-06 against the isosurface alone, which read
 * 0.945 voxel and let this case go to twice the bound). The sphere's and the torus's floors
 * need the interior merges of the coarsening (182x and 65x without); the cut sphere's needs
 * collapses within the flat face on the border plane and along its rim (270x; 41x when border
 * vertices stayed). */
typedef struct graded_case {
    vm_phantom_kind kind;
    double min_ratio;       /* uniform tets / graded tets at least */
    double mesh_to_surface; /* bound on that side, in units of the distance bound */
    double min_mean;        /* mean of each tet's smallest dihedral angle at least (degrees;
                               the coarsening's mean sweeps: 38.1, 35.9 and 37.3 without;
                               genus 3 fell below the old floor, 39.3, to 38.5 with edge
                               removal: 30% fewer tets for the same shape; the torus went
                               from 38.6 to 36.2 when the move sweeps went colour by colour,
                               in 495 tets instead of 561: over the five phantoms at 48, 64
                               and 80, the mean angle moved 40.8 -> 40.5 and the tets +2.5%,
                               each shape up at one size and down at another) */
} graded_case;

static void gradedPhantomsAreSmallAndFaithful(void) {
    static const graded_case cases[] = {
        {VM_PHANTOM_SPHERE, 400, 1.05, 38.8}, {VM_PHANTOM_TORUS, 150, 1.05, 35.8},
        {VM_PHANTOM_GENUS3, 25, 1.05, 38.2},  {VM_PHANTOM_TWO_SPHERES, 120, 1.05, 0},
        {VM_PHANTOM_PLATE, 1 / 1.2, 1.05, 0}, {VM_PHANTOM_CUT_SPHERE, 150, 1.05, 0}};
    for (size_t t = 0; t < sizeof cases / sizeof cases[0]; t++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        vm_status s = vm_phantom_make(cases[t].kind, 64, 0.0, 1u, &v, &info, &err);
        CHECK_OK(s, &err);
        if (s != VM_OK) continue;
        vm_mesh_options o;
        graded_options(&o);
        vm_mesh_report r, u;
        char label[96];
        snprintf(label, sizeof label, "%s 64^3 graded", info.name);
        vm_mesh gm;
        vm_surface_distance sd;
        s = vm_mesh_volume(&v, &o, &gm, NULL, &err);
        CHECK_OK(s, &err);
        if (s == VM_OK) {
            s = vm_mesh_surface_distance(&gm, &v, 0.0, 1, 0.0, 0, &sd, &err);
            CHECK_OK(s, &err);
            /* The samples' own spacing allows a hair over the bound (docs/QUALITY.md). */
            CHECK_MSG(s != VM_OK || (sd.mesh_to_surface_max <= 0.5 * cases[t].mesh_to_surface &&
                                     sd.surface_to_mesh_max <= 0.5 * 1.05),
                      "%s: distance %.3f / %.3f", info.name, sd.mesh_to_surface_max,
                      sd.surface_to_mesh_max);
            printf("    %s: distance mesh->surface %.3f surface->mesh %.3f (bound 0.5)\n",
                   info.name, sd.mesh_to_surface_max, sd.surface_to_mesh_max);
            vm_quality_summary q;
            double mean = 0;
            CHECK_OK(vm_quality_report(&gm, &q, &err), &err);
            CHECK(vm_quality_lookup(&q, "min_dihedral.mean", &mean) == VM_OK);
            printf("    %s: mean of the smallest dihedral angles %.2f deg\n", info.name, mean);
            CHECK_MSG(mean >= cases[t].min_mean, "%s: mean smallest dihedral %.2f, floor %.1f",
                      info.name, mean, cases[t].min_mean);
            vm_mesh_free(&gm);
        }
        if (mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &r)) {
            vm_mesh_options_default(&o);
            snprintf(label, sizeof label, "%s 64^3 uniform (dual contouring)", info.name);
            if (mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &u))
                CHECK_MSG((double)u.cells >= cases[t].min_ratio * (double)r.cells,
                          "%s: graded %zu tets, uniform %zu (ratio floor %.2f)", info.name,
                          r.cells, u.cells, cases[t].min_ratio);
            CHECK_MSG(fabs(r.volume - info.volume) <= 0.05 * info.volume,
                      "%s: volume %.6g, expected %.6g", info.name, r.volume, info.volume);
        }
        vm_volume_free(&v);
    }
}

/* Coarsening (the default) keeps the topology and the distance both ways, and takes out at
 * least half of the stuffed mesh's tets on smooth shapes. */
static void coarseningHalvesTheStuffedMesh(void) {
    static const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS,
                                            VM_PHANTOM_GENUS3};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        if (phantom(kinds[k], 64, &v, &info, &err) != VM_OK) continue;
        vm_mesh_options o;
        graded_options(&o);
        vm_mesh_report coarse, stuffed;
        char label[96];
        snprintf(label, sizeof label, "%s 64^3 stuffed (--no-coarsen)", info.name);
        o.no_coarsen = 1;
        int ok = mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &stuffed);
        o.no_coarsen = 0;
        vm_mesh m;
        vm_mesh_stats st;
        vm_status s = vm_mesh_volume(&v, &o, &m, &st, &err);
        CHECK_OK(s, &err);
        if (s == VM_OK) {
            vm_surface_distance sd;
            s = vm_mesh_surface_distance(&m, &v, 0.0, 1, 0.0, 0, &sd, &err);
            CHECK_OK(s, &err);
            CHECK_MSG(s != VM_OK || (sd.mesh_to_surface_max <= 0.5 * 1.05 &&
                                     sd.surface_to_mesh_max <= 0.5 * 1.05),
                      "%s coarsened: distance %.3f / %.3f", info.name,
                      sd.mesh_to_surface_max, sd.surface_to_mesh_max);
            CHECK_MSG(st.coarsened > 0, "%s: nothing coarsened", info.name);
            vm_mesh_free(&m);
        }
        snprintf(label, sizeof label, "%s 64^3 coarsened", info.name);
        if (ok && mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &coarse)) {
            CHECK_MSG(2 * coarse.cells <= stuffed.cells, "%s: coarsened %zu, stuffed %zu",
                      info.name, coarse.cells, stuffed.cells);
            CHECK_MSG(fabs(coarse.volume - stuffed.volume) <= 0.015 * stuffed.volume,
                      "%s: volume %.6g, stuffed %.6g", info.name, coarse.volume,
                      stuffed.volume);
        }
        vm_volume_free(&v);
    }
}

/* --max-edge bounds every edge; a coarser --distance makes fewer tets; anisotropic voxels
 * (1:1:3) keep the topology and the volume. */
static void sizesAreMet(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    vm_status s = phantom(VM_PHANTOM_TORUS, 48, &v, &info, &err);
    if (s != VM_OK) return;
    size_t counts[3];
    static const double dist[3] = {0.25, 0.5, 1.0};
    for (int k = 0; k < 3; k++) {
        vm_mesh_options o;
        graded_options(&o);
        o.distance = dist[k];
        vm_mesh_report r;
        char label[64];
        snprintf(label, sizeof label, "torus --distance %.2f", dist[k]);
        counts[k] = mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &r)
                        ? r.cells
                        : 0;
    }
    CHECK_MSG(counts[0] > counts[1] && counts[1] > counts[2], "tets %zu %zu %zu", counts[0],
              counts[1], counts[2]);
    vm_mesh_options o;
    graded_options(&o);
    o.max_edge = 3.0;
    vm_mesh m;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s == VM_OK) {
        double longest = 0;
        static const int e[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
        for (size_t c = 0; c < m.ncells; c++)
            for (int k = 0; k < 6; k++) {
                const double *a = m.points + 3 * (size_t)m.cells[4 * c + (size_t)e[k][0]];
                const double *b = m.points + 3 * (size_t)m.cells[4 * c + (size_t)e[k][1]];
                double l = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                                (a[2] - b[2]) * (a[2] - b[2]));
                if (l > longest) longest = l;
            }
        CHECK_MSG(longest <= 3.0 + 1e-9, "longest edge %.4f over --max-edge 3", longest);
        printf("    torus --max-edge 3: %zu tets, longest edge %.3f\n", m.ncells, longest);
        vm_mesh_free(&m);
    }
    v.spacing[2] = 3.0;
    long euler;
    size_t comps;
    vm_test_digital_topology(&v, 1, 0.0, 0, 0.0, &euler, &comps);
    graded_options(&o);
    vm_mesh_report r;
    mesh_and_check("torus, voxels 1:1:3", &v, &o, euler, comps, 0, &r);
    CHECK_MSG(fabs(r.volume - 3 * info.volume) <= 0.05 * 3 * info.volume,
              "anisotropic volume %.6g, expected %.6g", r.volume, 3 * info.volume);
    vm_volume_free(&v);
}

/* A size field (its own grid, coarser and shifted) asks for edges of 2 on the ball's left half
 * and 24 on its right: the left half holds at least 4 times the tets of the right, no tet
 * there has an edge over 2, and the topology holds. A size of 0 is refused. */
static void sizeFieldSetsTheDensity(void) {
    vm_volume v, sf;
    vm_phantom_info info;
    vm_error err;
    vm_status s = vm_phantom_make(VM_PHANTOM_SPHERE, 48, 0.0, 1u, &v, &info, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return;
    if (!make_volume(&sf, 13, 5, 5, 24.0f)) {
        vm_volume_free(&v);
        return;
    }
    for (int d = 0; d < 3; d++) {
        sf.spacing[d] = 4.0;
        sf.origin[d] = -1.0;
    }
    /* x = -1 + 4 i: sizes 2 up to x = 19, 24 from x = 23 (the ball's centre is at 23.5) */
    for (int64_t k = 0; k < 5; k++)
        for (int64_t j = 0; j < 5; j++)
            for (int64_t i = 0; i < 6; i++)
                sf.data[i + 13 * (j + 5 * k)] = 2.0f;
    vm_mesh_options o;
    graded_options(&o);
    o.size_field = &sf;
    vm_mesh m;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s == VM_OK) {
        size_t left = 0, right = 0;
        double longest = 0;
        for (size_t c = 0; c < m.ncells; c++) {
            double cx = 0, lo = INFINITY;
            for (int k = 0; k < 4; k++) {
                double x = m.points[3 * (size_t)m.cells[4 * c + (size_t)k]];
                cx += 0.25 * x;
                lo = fmin(lo, x);
            }
            if (cx < 23.5) left++;
            else right++;
            if (lo >= 19.0 - 1e-9) continue;
            for (int a = 0; a < 4; a++)
                for (int b = a + 1; b < 4; b++) {
                    const double *p = m.points + 3 * (size_t)m.cells[4 * c + (size_t)a];
                    const double *q = m.points + 3 * (size_t)m.cells[4 * c + (size_t)b];
                    if (fmax(p[0], q[0]) > 19.0 - 4.0) continue; /* within a cell of x=19 */
                    double l = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                                    (p[2] - q[2]) * (p[2] - q[2]));
                    longest = fmax(longest, l);
                }
        }
        CHECK_MSG(left >= 4 * right, "size field: %zu tets left, %zu right", left, right);
        CHECK_MSG(longest <= 2.0 + 1e-9, "size field: an edge of %.3f where 2 is asked",
                  longest);
        printf("    sphere, size field 2 | 24: %zu tets left, %zu right, longest left %.3f\n",
               left, right, longest);
        vm_mesh_report r;
        if (vm_mesh_check(&m, &r, &err) == VM_OK)
            CHECK(r.boundary_euler == 2 && r.components == 1 && r.inverted == 0);
        vm_mesh_free(&m);
    }
    sf.data[7] = 0.0f;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_MSG(s == VM_ERR_ARG && strstr(err.message, "--size-field"), "size 0: %d %s", (int)s,
              err.message);
    if (s == VM_OK) vm_mesh_free(&m);
    o.graded = 0;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_MSG(s == VM_ERR_ARG, "a size field without graded sizing: %d", (int)s);
    if (s == VM_OK) vm_mesh_free(&m);
    vm_volume_free(&sf);
    vm_volume_free(&v);
}

/* The octree's grading on a torus: with --grading R every leaf within ceil(ln 2 / ln R)
 * cells of its own size is at most one level coarser (2:1 at the default), R = 1.3 gives more
 * tets than the default, and the mesh keeps its topology. */
static void gradingSpreadsLevelChanges(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    vm_status s = phantom(VM_PHANTOM_TORUS, 48, &v, &info, &err);
    if (s != VM_OK) return;
    vm_mesh_options o;
    graded_options(&o);
    gr_field f;
    s = vm__gr_field_init(&f, &v, &o, &err);
    CHECK_OK(s, &err);
    static const int layers[2] = {1, 3};
    for (int c = 0; c < 2 && s == VM_OK; c++) {
        gr_sizing sz = {{1, 1, 1}, INFINITY, 0.5, layers[c]};
        gr_tree t;
        s = vm__gr_tree_build(&t, &f, &sz, &err);
        if (s == VM_OK) s = vm__gr_tree_balance(&t, &err);
        CHECK_OK(s, &err);
        size_t bad = 0, jumps = 0;
        int64_t root = (int64_t)2 << t.root_level;
        for (size_t i = 0; i < t.n && s == VM_OK; i++) {
            const gr_node *q = &t.node[i];
            if (q->child >= 0) continue;
            int64_t e = (int64_t)2 << q->level;
            int m = layers[c];
            for (int dz = -m; dz <= m; dz++)
                for (int dy = -m; dy <= m; dy++)
                    for (int dx = -m; dx <= m; dx++) {
                        int64_t p[3] = {q->a[0] + dx * e + e / 2, q->a[1] + dy * e + e / 2,
                                        q->a[2] + dz * e + e / 2};
                        if (p[0] < 0 || p[1] < 0 || p[2] < 0 || p[0] >= root || p[1] >= root ||
                            p[2] >= root)
                            continue;
                        int64_t nb = vm__gr_tree_find(&t, p, 0);
                        if (nb < 0) continue;
                        if (t.node[nb].level > q->level + 1) bad++;
                        if (t.node[nb].level == q->level + 1) jumps++;
                    }
        }
        CHECK_MSG(bad == 0 && jumps > 0, "layers %d: %zu leaves too coarse near a finer one",
                  layers[c], bad);
        printf("    torus, %d layer(s) per size: %zu leaves\n", layers[c], t.leaves);
        vm__gr_tree_free(&t);
    }
    vm__gr_field_free(&f);
    vm_mesh_report r0, r1;
    graded_options(&o);
    int ok0 = mesh_and_check("torus", &v, &o, info.euler, (size_t)info.components, 1, &r0);
    o.grading = 1.3;
    int ok1 =
        mesh_and_check("torus --grading 1.3", &v, &o, info.euler, (size_t)info.components, 0, &r1);
    if (ok0 && ok1) CHECK_MSG(r1.cells > r0.cells, "tets %zu vs %zu", r1.cells, r0.cells);
    o.grading = 1.05;
    vm_mesh m;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_MSG(s == VM_ERR_ARG, "--grading 1.05 accepted");
    if (s == VM_OK) vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* --tets N: the sizes are scaled until the mesh has N tets within 25%, on a torus, for a
 * target above and one below the default's count; the topology holds. */
static void tetTargetIsMet(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    vm_status s = phantom(VM_PHANTOM_TORUS, 48, &v, &info, &err);
    if (s != VM_OK) return;
    vm_mesh_options o;
    graded_options(&o);
    vm_mesh_report r;
    size_t base = mesh_and_check("torus, default", &v, &o, info.euler,
                                 (size_t)info.components, 1, &r)
                      ? r.cells
                      : 0;
    static const double factor[2] = {3.0, 0.5};
    for (int k = 0; k < 2 && base; k++) {
        graded_options(&o);
        o.tets = (size_t)(factor[k] * (double)base);
        char label[64];
        snprintf(label, sizeof label, "torus --tets %zu", o.tets);
        if (!mesh_and_check(label, &v, &o, info.euler, (size_t)info.components, 0, &r))
            continue;
        CHECK_MSG(r.cells >= 0.75 * (double)o.tets && r.cells <= 1.25 * (double)o.tets,
                  "--tets %zu gave %zu (default %zu)", o.tets, r.cells, base);
    }
    vm_volume_free(&v);
}

/* A ball of 1:1:10 voxels (clinical CT's 0.5 mm pixels and 5 mm slices): near-cubic base
 * cells, the topology kept, and the quality pass keeps the volume within 2% at 15..150 degrees
 * (the reliability issue's item 5). */
static void anisotropicVoxelsKeepVolumeThroughThePass(void) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    vm_status s = phantom(VM_PHANTOM_SPHERE, 40, &v, &info, &err);
    if (s != VM_OK) return;
    v.spacing[2] = 10.0;
    vm_mesh_options o;
    graded_options(&o);
    vm_mesh m;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s == VM_OK) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        vm_improve_report ir;
        /* the pass graded meshes get (the CLI's and Python's): it scales the pass's bounds,
         * in index voxels, to the shortest axis; the plain vm_mesh_improve would allow half
         * an index voxel, 5 units, along z here (6% of the volume lost when coarsening
         * leaves tets failing ABAQUS's check for it to contract) */
        s = vm_mesh_improve_graded(&m, &v, &io, &ir, &err);
        CHECK_OK(s, &err);
        vm_mesh_report r;
        if (s == VM_OK && vm_mesh_check(&m, &r, &err) == VM_OK) {
            CHECK(r.inverted == 0 && r.boundary_closed && r.boundary_euler == 2 &&
                  r.components == 1);
            CHECK_MSG(r.min_dihedral >= 15 - 1e-9 && r.max_dihedral <= 150 + 1e-9,
                      "dihedral %.2f..%.2f", r.min_dihedral, r.max_dihedral);
            CHECK_MSG(fabs(ir.volume_after - ir.volume_before) <= 0.02 * ir.volume_before,
                      "volume %.6g before the pass, %.6g after", ir.volume_before,
                      ir.volume_after);
            CHECK_MSG(fabs(r.volume - 10 * info.volume) <= 0.05 * 10 * info.volume,
                      "volume %.6g, the ball's %.6g", r.volume, 10 * info.volume);
            printf(
                "    ball 1:1:10: %zu tets, volume %.6g -> %.6g (ball %.6g), %.2f..%.2f deg\n",
                r.cells, ir.volume_before, ir.volume_after, 10 * info.volume, r.min_dihedral,
                r.max_dihedral);
        }
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

/* The topology's safety net points at the parts that differ: checked against the voxels of
 * a ball beside a ring, a mesh of those voxels has no misfit; a mesh of the ball alone has
 * one, around the ring's voxels and away from the ball; a mesh of the ball and a filled ring
 * (Euler 2, not 0) has one around the ring. */
static void topologyMisfitsAreFound(void) {
    enum { N = 28 };
    vm_volume full, part[2];
    if (!make_volume(&full, N, N, N, -1.0f)) return;
    for (int c = 0; c < 2; c++)
        if (!make_volume(&part[c], N, N, N, -1.0f)) return;
    for (int64_t k = 0; k < N; k++)
        for (int64_t j = 0; j < N; j++)
            for (int64_t i = 0; i < N; i++) {
                size_t at = (size_t)(i + N * (j + N * k));
                double ball = 3.5 - sqrt((double)((i - 7) * (i - 7) + (j - 7) * (j - 7) +
                                                  (k - 7) * (k - 7)));
                double rr = sqrt((double)((i - 18) * (i - 18) + (j - 18) * (j - 18))) - 5.0;
                double ring = 2.2 - sqrt(rr * rr + (double)((k - 18) * (k - 18)));
                double disc = fmin(7.2 - sqrt((double)((i - 18) * (i - 18) + (j - 18) * (j - 18))),
                                   2.2 - fabs((double)(k - 18)));
                full.data[at] = (float)fmax(ball, ring);
                part[0].data[at] = (float)ball;
                part[1].data[at] = (float)fmax(ball, disc);
            }
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = 0.0;
    o.has_lo = 1;
    vm_error err;
    gr_field f;
    vm_status s = vm__gr_field_init(&f, &full, &o, &err);
    CHECK_OK(s, &err);
    for (int c = -1; c < 2 && s == VM_OK; c++) {
        vm_mesh m;
        s = vm_mesh_volume(c < 0 ? &full : &part[c], &o, &m, NULL, &err);
        CHECK_OK(s, &err);
        if (s != VM_OK) break;
        double *boxes = NULL;
        size_t nb = 0;
        s = vm__gr_topology_misfits(&f, &m, &boxes, &nb, &err);
        CHECK_OK(s, &err);
        vm_mesh_free(&m);
        if (s != VM_OK) break;
        CHECK_MSG(nb == (c < 0 ? 0u : 1u), "mesh %d: %zu misfit boxes", c, nb);
        if (nb == 1) {
            /* the ring's voxels (11..25 across, 16..20 high) inside, the ball's (3.5..10.5)
             * outside */
            int holds = 1, clear = 0;
            for (int d = 0; d < 3; d++) {
                double lo = d < 2 ? 13.0 : 16.0, hi = d < 2 ? 23.0 : 20.0;
                if (boxes[d] > lo || boxes[3 + d] < hi) holds = 0;
                if (boxes[d] > 10.5) clear = 1;
            }
            CHECK_MSG(holds && clear, "mesh %d: box %.1f %.1f %.1f .. %.1f %.1f %.1f", c,
                      boxes[0], boxes[1], boxes[2], boxes[3], boxes[4], boxes[5]);
        }
        free(boxes);
    }
    if (s == VM_OK) vm__gr_field_free(&f);
    vm_volume_free(&full);
    vm_volume_free(&part[0]);
    vm_volume_free(&part[1]);
}

/* Tets of m away from the ball (centroid over 10 voxels from the axis x = y = 20) spanning the
 * plate (z extent of 0.9 of its thickness 3 or more); *inner: tets with centroid within 5 of
 * the centre. */
static size_t plate_spans(const vm_mesh *m, size_t *inner) {
    size_t n = 0;
    *inner = 0;
    for (size_t c = 0; c < m->ncells; c++) {
        double lo = INFINITY, hi = -INFINITY, cx = 0, cy = 0, cz = 0;
        for (int k = 0; k < 4; k++) {
            const double *p = m->points + 3 * (size_t)m->cells[4 * c + (size_t)k];
            lo = fmin(lo, p[2]);
            hi = fmax(hi, p[2]);
            cx += 0.25 * p[0], cy += 0.25 * p[1], cz += 0.25 * p[2];
        }
        double r = hypot(cx - 20, cy - 20);
        if (r > 10 && hi - lo >= 0.9 * 3.0) n++;
        if (r * r + (cz - 20) * (cz - 20) < 25) ++*inner;
    }
    return n;
}

/* --min-layers: a plate 3 voxels thick round a ball of radius 8. Coarsened as usual, tets
 * span the plate; with 2 layers none does, before and after the quality pass, the topology
 * stays, and the ball's inside (16 voxels across, the cap of thickness that counts) stays
 * coarser than with the plate's bound (thickness 4 between voxel centres over 2) everywhere. */
static void minLayersKeepThinPartsLayered(void) {
    vm_volume v;
    if (!make_volume(&v, 40, 40, 40, 0.0f)) return;
    for (int64_t k = 0; k < 40; k++)
        for (int64_t j = 0; j < 40; j++)
            for (int64_t i = 0; i < 40; i++) {
                double x = (double)i - 20, y = (double)j - 20, z = (double)k - 20;
                double plate = fmin(1.5 - fabs(z), 14 - hypot(x, y));
                double ball = 8 - sqrt(x * x + y * y + z * z);
                v.data[i + 40 * (j + 40 * k)] = (float)fmax(plate, ball);
            }
    vm_mesh_options o;
    graded_options(&o);
    vm_mesh m;
    vm_error err;
    size_t spans[3] = {0, 0, 0}, inner[3] = {0, 0, 0}, tets[3] = {0, 0, 0};
    for (int layered = 0; layered < 3; layered++) {
        o.min_layers = layered == 1 ? 2 : 0;
        o.max_edge = layered == 2 ? 2.0 : 0;
        vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
        CHECK_OK(s, &err);
        if (s != VM_OK) continue;
        spans[layered] = plate_spans(&m, &inner[layered]);
        tets[layered] = m.ncells;
        vm_mesh_report r;
        if (vm_mesh_check(&m, &r, &err) == VM_OK)
            CHECK_MSG(r.boundary_euler == 2 && r.components == 1 && r.inverted == 0,
                      "min layers %d: Euler %ld, %zu components, %zu inverted", o.min_layers,
                      (long)r.boundary_euler, r.components, r.inverted);
        if (layered == 1) {
            vm_improve_options io;
            vm_improve_options_default(&io);
            io.has_lo = 1;
            io.lo = 0;
            s = vm_mesh_improve_graded(&m, &v, &io, NULL, &err);
            CHECK_OK(s, &err);
            size_t in2;
            size_t after = plate_spans(&m, &in2);
            CHECK_MSG(after == 0, "min layers 2: %zu tets span the plate after the pass", after);
        }
        vm_mesh_free(&m);
    }
    printf("    plate: %zu tets, %zu spanning, %zu in the ball's core; --min-layers 2: %zu tets, "
           "%zu spanning, %zu in the core; --max-edge 2: %zu tets, %zu in the core\n",
           tets[0], spans[0], inner[0], tets[1], spans[1], inner[1], tets[2], inner[2]);
    CHECK_MSG(spans[0] > 0, "without --min-layers no tet spans the plate: the test proves nothing");
    CHECK_MSG(spans[1] == 0, "min layers 2: %zu tets span the plate", spans[1]);
    /* the bound is the plate's: the ball's core is coarser than under the same bound
     * everywhere */
    CHECK_MSG(2 * inner[1] <= inner[2], "min layers 2: %zu tets in the ball's core, %zu with "
              "--max-edge 2", inner[1], inner[2]);
    o.max_edge = 0;
    o.min_layers = 101;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_MSG(s == VM_ERR_ARG, "101 layers: %d", (int)s);
    if (s == VM_OK) vm_mesh_free(&m);
    o.min_layers = 2;
    o.graded = 0;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_MSG(s == VM_ERR_ARG, "layers without graded sizing: %d", (int)s);
    if (s == VM_OK) vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Voxels whose value is the bound itself are inside (the voxels' topology counts them so).
 * Lattice points are computed in world units, so a voxel point comes out a rounding error
 * off its voxel plane when the spacing is not a binary fraction (0.8 mm): the field must
 * read the voxel's value there exactly, not 1e-13 off it. On the organ of bench/organ.py a
 * coarse cell's centre on such a voxel read it outside, its first mesh had two handles more
 * than its voxels, and the topology round that mended it doubled the octree (89k leaves to
 * 177k). */
static void voxelsAtTheBoundReadExactly(void) {
    static const double spacings[][3] = {{0.8, 0.8, 1.5}, {0.7, 0.9, 1.1}, {0.3, 0.3, 0.3}};
    for (size_t c = 0; c < sizeof spacings / sizeof spacings[0]; c++) {
        vm_volume v;
        int n = 24;
        if (!make_volume(&v, n, n, n, 0.0f)) continue;
        for (int d = 0; d < 3; d++)
            v.spacing[d] = spacings[c][d];
        /* a blob of integer values, many of its surface voxels exactly at the bound */
        rng_state = 0xb0d0000ull + c;
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double r = sqrt((i - 11.5) * (i - 11.5) + (j - 11.5) * (j - 11.5) +
                                    (k - 11.5) * (k - 11.5) * 0.5);
                    double x =
                        floor(3 * (8 - r) + 0.5) + floor(3 * vm_test_uniform(&rng_state)) - 1;
                    v.data[i + n * (j + n * k)] = (float)(x > 20 ? 20 : x < -20 ? -20 : x);
                }
        vm_mesh_options o;
        graded_options(&o);
        char label[64];
        snprintf(label, sizeof label, "spacing %g %g %g", spacings[c][0], spacings[c][1],
                 spacings[c][2]);
        /* the field at every voxel point reached as a lattice point */
        gr_field f;
        vm_error err;
        CHECK_OK(vm__gr_field_init(&f, &v, &o, &err), &err);
        size_t off = 0;
        gr_tree t; /* base cells of a voxel, one cell of margin (as vm__gr_tree_build) */
        memset(&t, 0, sizeof t);
        for (int d = 0; d < 3; d++) {
            t.h0[d] = v.spacing[d];
            t.u0[d] = -v.spacing[d];
        }
        for (int k = 0; k < n; k++)
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    int64_t p[3] = {2 * (i + 1), 2 * (j + 1), 2 * (k + 1)};
                    double u[3];
                    vm__gr_lattice_pos(&t, p, u);
                    off += vm__gr_phi(&f, u) != vm__gr_phi_point(&f, i, j, k);
                }
        CHECK_MSG(off == 0, "%s: %zu voxel points read off their values", label, off);
        vm__gr_field_free(&f);
        /* and the first mesh has the voxels' topology, with no round to mend it */
        long euler;
        size_t comps;
        vm_test_digital_topology(&v, 1, 0.0, 0, 0.0, &euler, &comps);
        vm_mesh_report r;
        vm_mesh_stats st;
        if (mesh_and_check_stats(label, &v, &o, euler, comps, 1, &r, &st))
            CHECK_MSG(st.topology_rounds == 0, "%s: %zu topology rounds", label,
                      st.topology_rounds);
        vm_volume_free(&v);
    }
}

TEST_MAIN(T(everyCubePatternKeepsTheCubicalTopology), T(voxelsAtTheBoundReadExactly),
          T(coarseningHalvesTheStuffedMesh), T(randomVolumesKeepTheCubicalTopology),
          T(noisyPhantomsKeepTheCubicalTopology), T(gradedPhantomsAreSmallAndFaithful),
          T(meanSweepsRaiseTheMeanInside), T(edgeRemovalMendsTallBipyramids),
          T(boundaryEdgesFlipWithinTheBound), T(flatBorderEdgesFlip),
          T(hairBeyondTheBorderCoarsens), T(sizesAreMet), T(sizeFieldSetsTheDensity),
          T(tetTargetIsMet), T(gradingSpreadsLevelChanges),
          T(anisotropicVoxelsKeepVolumeThroughThePass), T(topologyMisfitsAreFound),
          T(minLayersKeepThinPartsLayered))
