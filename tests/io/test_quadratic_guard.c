/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_quadratic_guard.c — the curved quadratic tets of io/mid_curve.c on a sphere
 * field: surface edges' mid nodes move toward the sphere as far as the Jacobian guard allows;
 * a flat tet whose fully projected nodes would fold it is pulled back until det J > 0 on a
 * grid of points; nodes on the volume's box faces and without a volume stay straight (on a
 * whole ball, test_quadratic_curved.py finds them on the sphere). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "test.h"
#include "io/mesh_util.h"

enum { N = 32 };
static const double R = 10.0, C = 15.5; /* sphere radius and centre, in voxels */

/* f = R - |x - c| sampled on N^3 points (unit spacing, origin 0). */
static void sphere_volume(vm_volume *v) {
    int64_t dims[3] = {N, N, N};
    vm_error err;
    CHECK_OK(vm_volume_alloc(v, dims, &err), &err);
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++)
                v->data[i + N * (j + N * k)] =
                    (float)(R - sqrt((i - C) * (i - C) + (j - C) * (j - C) + (k - C) * (k - C)));
}

/* A point on the sphere at polar angle th, azimuth ph, pushed in by depth. */
static void on_sphere(double th, double ph, double depth, double p[3]) {
    p[0] = C + (R - depth) * sin(th) * cos(ph);
    p[1] = C + (R - depth) * sin(th) * sin(ph);
    p[2] = C + (R - depth) * cos(th);
}

/* One tet, p[3] under the face p[0] p[1] p[2] (positive VTK orientation either way). */
static void one_tet(vm_mesh *m, double p[4][3]) {
    vm_error err;
    vm_mesh_init(m, VM_TET4);
    for (int k = 0; k < 4; k++) CHECK(vm_mesh_add_point(m, p[k], &err) == k);
    double e[3][3];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) e[a][b] = p[b + 1][a] - p[0][a];
    double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                 e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                 e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    vm_index c[4] = {0, 1, 2, 3};
    if (det < 0) c[1] = 2, c[2] = 1;
    CHECK_OK(vm_mesh_add_cell(m, c, 0, &err), &err);
}

/* det J of the tet10 x (VTK order) at barycentric l, written from the shape functions
 * N_i = L_i (2 L_i - 1), N_ij = 4 L_i L_j. */
static double det10(double x[10][3], const double l[4]) {
    static const int ed[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
    static const double g[4][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double j[3][3] = {{0}};
    for (int n = 0; n < 10; n++)
        for (int b = 0; b < 3; b++) {
            double d = n < 4 ? (4 * l[n] - 1) * g[n][b]
                             : 4 * (l[ed[n - 4][1]] * g[ed[n - 4][0]][b] +
                                    l[ed[n - 4][0]] * g[ed[n - 4][1]][b]);
            for (int a = 0; a < 3; a++) j[a][b] += x[n][a] * d;
        }
    return j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) -
           j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
           j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
}

/* The smallest det J over corners, edge middles, centroid and a 5x5x5 grid of inner points. */
static double min_det(const vm__quadratic *q) {
    double x[10][3], worst = INFINITY;
    for (int n = 0; n < 10; n++) memcpy(x[n], q->view.points + 3 * (size_t)q->view.cells[n],
                                        sizeof x[n]);
    for (int a = 0; a <= 6; a++)
        for (int b = 0; a + b <= 6; b++)
            for (int c = 0; a + b + c <= 6; c++) {
                double l[4] = {a / 6.0, b / 6.0, c / 6.0, (6 - a - b - c) / 6.0};
                double d = det10(x, l);
                if (d < worst) worst = d;
            }
    return worst;
}

static double radius(const double *p) {
    return sqrt((p[0] - C) * (p[0] - C) + (p[1] - C) * (p[1] - C) + (p[2] - C) * (p[2] - C));
}

static vm_mesh_write_options curve_opts(const vm_volume *v) {
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.order = 2;
    o.curve_volume = v;
    o.curve_lo = 0;
    o.curve_has_lo = 1;
    return o;
}

/* A tet of three corners on the sphere and one 4 voxels under them. In a one-tet mesh every
 * edge is a boundary edge: the edges to the inner corner, moved fully onto the sphere, fold
 * it, so the guard halves every move of the tet until it is valid (to 1/4 here). */
static void curvedSurfaceEdgesMoveTowardTheSphereAsFarAsTheGuardAllows(void) {
    vm_volume v;
    sphere_volume(&v);
    double p[4][3];
    on_sphere(0.9, 0.2, 0, p[0]);
    on_sphere(1.2, 0.3, 0, p[1]);
    on_sphere(1.0, 0.6, 0, p[2]);
    on_sphere(1.0, 0.35, 4, p[3]);
    vm_mesh m;
    one_tet(&m, p);
    vm_mesh_write_options o = curve_opts(&v);
    vm__quadratic q, flat;
    vm_error err;
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, &o, &q, &err), &err);
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, NULL, &flat, &err), &err);
    /* edges 0-1, 1-2, 2-0 join the surface corners: their mid nodes move out, not past R */
    for (int e = 0; e < 3; e++) {
        double r = radius(q.view.points + 3 * (size_t)q.view.cells[4 + e]);
        double r0 = radius(flat.view.points + 3 * (size_t)flat.view.cells[4 + e]);
        CHECK_MSG(r > r0 + 0.01 && r < R + 1e-3, "edge %d mid node at radius %.6f (straight "
                  "%.6f, sphere %g)", e, r, r0, R);
    }
    CHECK(min_det(&q) > 0);
    vm__quadratic_free(&flat);
    vm__quadratic_free(&q);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void aFlatTetIsPulledBackUntilItsJacobianIsPositive(void) {
    vm_volume v;
    sphere_volume(&v);
    double p[4][3];
    on_sphere(1.0, 0.0, 0, p[0]);
    on_sphere(1.0, 0.5, 0, p[1]);
    on_sphere(1.45, 0.25, 0, p[2]);
    on_sphere(1.15, 0.25, -0.05, p[3]); /* just outside the chord face: a flat tet */
    vm_mesh m;
    one_tet(&m, p);
    vm_mesh_write_options o = curve_opts(&v);
    vm__quadratic q;
    vm_error err;
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, &o, &q, &err), &err);
    double guarded = min_det(&q);
    /* the same tet with every boundary mid node fully on the sphere folds: the guard acted */
    vm__quadratic full;
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, NULL, &full, &err), &err);
    for (int e = 0; e < 6; e++) {
        double *x = full.view.points + 3 * (size_t)full.view.cells[4 + e];
        double r = radius(x);
        for (int a = 0; a < 3; a++) x[a] = C + (x[a] - C) * R / r;
    }
    double unguarded = min_det(&full);
    CHECK_MSG(unguarded < 0, "the fully projected flat tet has det J %g (expected to fold)",
              unguarded);
    CHECK_MSG(guarded > 0, "the curved flat tet has det J %g", guarded);
    vm__quadratic_free(&full);
    vm__quadratic_free(&q);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void boxFacesAndNoVolumeStayStraight(void) {
    vm_volume v;
    sphere_volume(&v);
    /* a tet whose face lies on the box face x = 0 (material there: f >= 0 is false, but the
     * rule is geometric) keeps that face's mid nodes at the middle */
    double p[4][3] = {{0, 10, 10}, {0, 14, 10}, {0, 10, 14}, {3, 11, 11}};
    vm_mesh m;
    one_tet(&m, p);
    vm_mesh_write_options o = curve_opts(&v);
    vm__quadratic q;
    vm_error err;
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, &o, &q, &err), &err);
    for (int e = 0; e < 3; e++)
        CHECK(q.view.points[3 * (size_t)q.view.cells[4 + e]] == 0.0);
    vm__quadratic_free(&q);
    vm_mesh_free(&m);
    /* no volume: every mid node at its edge's middle */
    double s[4][3];
    on_sphere(0.9, 0.2, 0, s[0]);
    on_sphere(1.2, 0.3, 0, s[1]);
    on_sphere(1.0, 0.6, 0, s[2]);
    on_sphere(1.0, 0.35, 4, s[3]);
    one_tet(&m, s);
    vm_mesh_write_options plain;
    vm_mesh_write_options_init(&plain);
    plain.order = 2;
    CHECK_OK(vm__quadratic_make("t.vtu", &m, NULL, &plain, &q, &err), &err);
    for (int e = 0; e < 6; e++) {
        const double *x = q.view.points + 3 * (size_t)q.view.cells[4 + e];
        const double *a = m.points + 3 * (size_t)m.cells[vm__tet_edges[e][0]];
        const double *b = m.points + 3 * (size_t)m.cells[vm__tet_edges[e][1]];
        for (int d = 0; d < 3; d++) CHECK(x[d] == 0.5 * (a[d] + b[d]));
    }
    vm__quadratic_free(&q);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"curvedSurfaceEdgesMoveTowardTheSphereAsFarAsTheGuardAllows",
         curvedSurfaceEdgesMoveTowardTheSphereAsFarAsTheGuardAllows},
        {"aFlatTetIsPulledBackUntilItsJacobianIsPositive",
         aFlatTetIsPulledBackUntilItsJacobianIsPositive},
        {"boxFacesAndNoVolumeStayStraight", boxFacesAndNoVolumeStayStraight},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
