/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_metrics.c — every element metric on golden elements (regular, flat,
 * inverted, degenerate and a few with hand-computed values), the never-NaN promise on
 * non-finite input, and invariance under rigid motion and scaling. */
#include "test.h"
#include <string.h>
#include "quality/quality_internal.h"

#define HUGE_Q VM_QUALITY_HUGE
#define S2 1.4142135623730951
#define S3 1.7320508075688772
#define DIH 70.52877936550931 /* acos(1/3) in degrees */

typedef struct golden {
    const char *name;
    double p[8][3];
    double want[VM_QUALITY_MAX_METRICS]; /* in vm_quality_metrics order */
} golden;

/* Checks one kind: the table lists exactly `names`, and every golden element gives its
 * values (1e-9 relative, or absolute near zero). */
static void check_kind(vm_cell_kind kind, const char *const *names, const golden *g, size_t ng) {
    const vm_metric_info *t;
    size_t nm = vm_quality_metrics(kind, &t);
    size_t nn = 0;
    while (names[nn]) nn++;
    CHECK_MSG(nm == nn, "%s: %zu metrics, expected %zu", vm_cell_kind_name(kind), nm, nn);
    for (size_t k = 0; k < nm && k < nn; k++)
        CHECK_MSG(strcmp(t[k].name, names[k]) == 0, "metric %zu is %s, expected %s", k,
                  t[k].name, names[k]);
    for (size_t i = 0; i < ng; i++)
        for (size_t k = 0; k < nm; k++) {
            double got = t[k].eval((const double(*)[3])g[i].p), want = g[i].want[k];
            double tol = 1e-9 * fmax(1.0, fabs(want));
            CHECK_MSG(fabs(got - want) <= tol, "%s %s: %s = %.15g, expected %.15g",
                      vm_cell_kind_name(kind), g[i].name, t[k].name, got, want);
        }
}

/* Unit-edge regular tet, positively oriented. */
#define REG_TET                                                                            \
    {{0, 0, 0}, {1, 0, 0}, {0.5, S3 / 2, 0}, {0.5, S3 / 6, 0.816496580927726}}
#define REG_TET_INV                                                                        \
    {{1, 0, 0}, {0, 0, 0}, {0.5, S3 / 2, 0}, {0.5, S3 / 6, 0.816496580927726}}

static void tetMetricsMatchGoldenValues(void) {
    static const char *const names[] = {"min_dihedral", "max_dihedral", "min_face_angle",
                                        "max_face_angle", "radius_ratio", "aspect_ratio",
                                        "edge_ratio", "scaled_jacobian", "volume_measure",
                                        "volume", NULL};
    /* Corner tet: faces three right isosceles triangles and one equilateral; circumradius
     * sqrt(3)/2, inradius 1/(3+sqrt(3)), so R/(3r) = (1+sqrt(3))/2 and so is the aspect
     * ratio; its volume is half that of the equilateral tet with the same circumradius. */
    const double rc = (1.0 + S3) / 2.0;
    static golden g[5];
    const golden init[5] = {
        {"regular", REG_TET, {DIH, DIH, 60, 60, 1, 1, 1, 1, 1, S2 / 12}},
        {"corner", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
         {54.735610317245346, 90, 45, 90, 0, 0, S2, S2 / 2, 0.5, 1.0 / 6}},
        {"flat", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}},
         {0, 180, 45, 90, HUGE_Q, HUGE_Q, S2, 0, 0, 0}},
        {"inverted", REG_TET_INV, {DIH, DIH, 60, 60, 1, 1, 1, -1, -1, -S2 / 12}},
        {"degenerate", {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 0, 1}},
         {0, 180, 0, 180, HUGE_Q, HUGE_Q, HUGE_Q, 0, 0, 0}},
    };
    memcpy(g, init, sizeof g);
    g[1].want[4] = rc;
    g[1].want[5] = rc;
    check_kind(VM_TET4, names, g, 5);
}

static void hexMetricsMatchGoldenValues(void) {
    static const char *const names[] = {"scaled_jacobian", "jacobian", "skew", "taper",
                                        "edge_ratio", "volume", NULL};
    const double sh = 0.8944271909999159; /* 1/sqrt(1.25): the sheared hex */
    static const golden g[] = {
        {"cube",
         {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},
         {1, 1, 0, 0, 1, 1}},
        {"box 1x2x3",
         {{0, 0, 0}, {1, 0, 0}, {1, 2, 0}, {0, 2, 0}, {0, 0, 3}, {1, 0, 3}, {1, 2, 3}, {0, 2, 3}},
         {1, 6, 0, 0, 3, 6}},
        /* Top face shifted by half an edge along x: a parallelepiped. */
        {"sheared",
         {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {.5, 0, 1}, {1.5, 0, 1}, {1.5, 1, 1},
          {.5, 1, 1}},
         {0.8944271909999159, 1, 0.4472135954999579, 0, 1.118033988749895, 1}},
        /* Top face a 0.5-square centred over the unit bottom: a frustum (taper only). */
        {"frustum",
         {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {.25, .25, 1}, {.75, .25, 1},
          {.75, .75, 1}, {.25, .75, 1}},
         {0, 0, 0, 0, 0, 0}},
        {"flat",
         {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},
         {0, 0, 1, HUGE_Q, HUGE_Q, 0}},
        {"inverted",
         {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}, {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}},
         {-1, -1, 0, 0, 1, -1}},
        {"degenerate", {{0}}, {0, 0, 1, HUGE_Q, HUGE_Q, 0}},
    };
    (void)sh;
    golden f[7];
    memcpy(f, g, sizeof f);
    /* Frustum: bottom corners see edges 1, 1 and the slanted sqrt(1.125); top corners 0.5,
     * 0.5 and the same slant. Scaled Jacobian: corner det / lengths, minimum at the bottom:
     * det(e_x, e_y, (.25,.25,1)) = 1 over 1*1*sqrt(1.125); top corner: 0.25 over 0.25*sqrt(1.125),
     * equal; centre: X1 = (3,0,0), X2 = (0,3,0), X3 = (0,0,4) gives 1. Jacobian: min(1, 0.25,
     * 36/64) = 0.25. Taper: X12 = 0, X13 = (1,0,0)... |X13| = 1, min(|X1|,|X3|) = 3: 1/3.
     * Edge ratio: sqrt(1.125)/0.5. Volume of the frustum: (1 + 0.25 + 0.5)/3 = 7/12. */
    const double s = 1.0 / sqrt(1.125);
    const double fr[6] = {s, 0.25, 0, 1.0 / 3.0, sqrt(1.125) / 0.5, 7.0 / 12.0};
    memcpy(f[3].want, fr, sizeof fr);
    check_kind(VM_HEX8, names, f, 7);
}

static void triangleMetricsMatchGoldenValues(void) {
    static const char *const names[] = {"aspect_ratio", "min_angle", "max_angle",
                                        "scaled_jacobian", "edge_ratio", NULL};
    const double ar_right = S2 * (2 + S2) / (4 * S3 * 0.5);
    golden g[5] = {
        {"equilateral", {{0, 0, 0}, {1, 0, 0}, {0.5, S3 / 2, 0}}, {1, 60, 60, 1, 1}},
        {"right", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {0, 45, 90, 2 / S3 * S2 / 2, S2}},
        {"flat", {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {HUGE_Q, 0, 180, 0, 2}},
        {"reversed", {{0, 0, 0}, {0.5, S3 / 2, 0}, {1, 0, 0}}, {1, 60, 60, 1, 1}},
        {"degenerate", {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}}, {HUGE_Q, 0, 180, 0, HUGE_Q}},
    };
    g[1].want[0] = ar_right;
    check_kind(VM_TRI3, names, g, 5);
}

static void quadMetricsMatchGoldenValues(void) {
    static const char *const names[] = {"aspect_ratio", "min_angle", "max_angle",
                                        "scaled_jacobian", "edge_ratio", NULL};
    static const golden g[] = {
        {"square", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {1, 90, 90, 1, 1}},
        {"rectangle 2x1", {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}}, {1.5, 90, 90, 1, 2}},
        /* Unit rhombus with 60 and 120 degree corners. */
        {"rhombus",
         {{0, 0, 0}, {1, 0, 0}, {1.5, S3 / 2, 0}, {0.5, S3 / 2, 0}},
         {2.0 / S3, 60, 120, S3 / 2, 1}},
        {"reversed", {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, {1, 90, 90, 1, 1}},
        /* A dart: the corner at (1.5, 0.5) is reflex, 360 - 126.87 degrees. */
        {"dart", {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {1.5, 0.5, 0}},
         {1.0 + 1.5811388300841898 + 1.0, 18.43494882292201, 233.13010235415598, -0.8,
          1.2649110640673518}},
        {"degenerate", {{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {0, 1, 0}},
         {S2 * (2 + S2) / 2, 0, 360, 0, HUGE_Q}},
    };
    check_kind(VM_QUAD4, names, g, 6);
}

/* Every metric of every kind returns a finite value inside its full range for elements with
 * NaN, infinite, huge, tiny and coincident coordinates. */
static void metricsNeverReturnNaNOrLeaveTheirRange(void) {
    static const vm_cell_kind kinds[] = {VM_TET4, VM_HEX8, VM_TRI3, VM_QUAD4};
    const double bad[] = {NAN, INFINITY, -INFINITY, 1e300, 1e-300, 0.0, -1e300};
    unsigned seed = 12345;
    for (size_t ki = 0; ki < 4; ki++) {
        const vm_metric_info *t;
        size_t nm = vm_quality_metrics(kinds[ki], &t);
        int nn = vm_cell_nodes(kinds[ki]);
        for (int trial = 0; trial < 3000; trial++) {
            double p[8][3];
            for (int i = 0; i < nn; i++)
                for (int d = 0; d < 3; d++) {
                    seed = seed * 1103515245u + 12345u;
                    p[i][d] = (double)((seed >> 8) % 2001) / 1000.0 - 1.0;
                }
            /* Some trials poison one coordinate, some collapse nodes, some keep it valid. */
            seed = seed * 1103515245u + 12345u;
            int mode = (int)((seed >> 16) % 4);
            if (mode == 1) p[(seed >> 4) % (unsigned)nn][(seed >> 9) % 3] = bad[(seed >> 20) % 7];
            if (mode == 2) memcpy(p[1], p[0], sizeof p[0]);
            if (mode == 3)
                for (int i = 0; i < nn; i++) p[i][2] = 0.0;
            for (size_t k = 0; k < nm; k++) {
                double v = t[k].eval((const double(*)[3])p);
                CHECK_MSG(isfinite(v), "%s %s gave %g (trial %d)", vm_cell_kind_name(kinds[ki]),
                          t[k].name, v, trial);
                CHECK_MSG(v >= t[k].full_lo - 1e-12 && v <= t[k].full_hi + 1e-12,
                          "%s %s = %g outside its full range (trial %d)",
                          vm_cell_kind_name(kinds[ki]), t[k].name, v, trial);
            }
        }
    }
}

/* Shape metrics do not change under translation, rotation and uniform scaling; the
 * volume scales with the cube and the hex Jacobian too. */
static void shapeMetricsIgnoreRigidMotionAndScale(void) {
    static const vm_cell_kind kinds[] = {VM_TET4, VM_HEX8, VM_TRI3, VM_QUAD4};
    static const double base[8][3] = {{0, 0, 0},      {1.1, 0.1, 0},  {1, 0.9, 0.1},
                                      {-0.1, 1, 0},   {0.1, 0, 1.2},  {1, 0.1, 0.9},
                                      {1.2, 1, 1.1},  {0, 0.9, 1}};
    const double c = cos(0.7), s = sin(0.7), scale = 37.5;
    for (size_t ki = 0; ki < 4; ki++) {
        const vm_metric_info *t;
        size_t nm = vm_quality_metrics(kinds[ki], &t);
        double p[8][3];
        for (int i = 0; i < 8; i++) {
            /* Rotate about z, then about x, scale and move far away. */
            double x = c * base[i][0] - s * base[i][1], y = s * base[i][0] + c * base[i][1];
            double z = base[i][2];
            double y2 = c * y - s * z, z2 = s * y + c * z;
            p[i][0] = scale * x + 1000.0;
            p[i][1] = scale * y2 - 2000.0;
            p[i][2] = scale * z2 + 500.0;
        }
        for (size_t k = 0; k < nm; k++) {
            double a = t[k].eval(base), b = t[k].eval((const double(*)[3])p);
            int cubic = strcmp(t[k].name, "volume") == 0 || strcmp(t[k].name, "jacobian") == 0;
            if (cubic) a *= scale * scale * scale;
            CHECK_MSG(fabs(a - b) <= 1e-9 * fmax(1.0, fabs(a)), "%s %s: %.15g moved, %.15g",
                      vm_cell_kind_name(kinds[ki]), t[k].name, b, a);
        }
    }
}

/* The tables name each metric once per kind and their ranges are consistent. */
static void metricTablesAreConsistent(void) {
    static const vm_cell_kind kinds[] = {VM_TET4, VM_HEX8, VM_TRI3, VM_QUAD4};
    for (size_t ki = 0; ki < 4; ki++) {
        const vm_metric_info *t;
        size_t nm = vm_quality_metrics(kinds[ki], &t);
        CHECK(nm > 0 && nm <= VM_QUALITY_MAX_METRICS);
        for (size_t k = 0; k < nm; k++) {
            CHECK(t[k].kind == kinds[ki]);
            CHECK(vm_quality_find_metric(kinds[ki], t[k].name) == &t[k]);
            CHECK(t[k].full_lo <= t[k].acceptable_lo && t[k].acceptable_hi <= t[k].full_hi);
            CHECK(isnan(t[k].ideal) ||
                  (t[k].ideal >= t[k].acceptable_lo && t[k].ideal <= t[k].acceptable_hi));
        }
    }
    CHECK(vm_quality_find_metric(VM_HEX8, "min_dihedral") == NULL);
    const vm_metric_info *t;
    CHECK(vm_quality_metrics((vm_cell_kind)99, &t) == 0);
}

/* Known values: the corners alone miss a hex whose corners are fine but whose centre folds;
 * the scaled Jacobian samples the centre (and the Gauss points) too. */
static void hexScaledJacobianIncludesTheCentre(void) {
    const double cube[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    CHECK_NEAR(vm_hex_scaled_jacobian(cube), 1.0, 1e-15);
    CHECK_NEAR(vm_hex_min_scaled_jacobian(cube), 1.0, 1e-15);
    /* Twist the top face by 90 degrees: corners stay right-handed-ish but the centre axis
     * X1 x X2 . X3 keeps its sign while the corners degrade; the two must differ or agree
     * exactly as the definitions say: the full measure is never above the corners' one. */
    double tw[8][3];
    memcpy(tw, cube, sizeof tw);
    for (int i = 4; i < 8; i++) {
        double x = cube[i][0] - 0.5, y = cube[i][1] - 0.5;
        tw[i][0] = 0.5 - y * 0.9;
        tw[i][1] = 0.5 + x * 0.9;
    }
    double corners = 1.0;
    for (int c = 0; c < 8; c++)
        corners = fmin(corners, vm_hex_corner_scaled_jacobian((const double(*)[3])tw, c));
    CHECK(vm_hex_scaled_jacobian((const double(*)[3])tw) <= corners);
}

/* The scaled Jacobian at (xi, eta, zeta) in [-1,1]^3, the plain way: derivatives of the
 * eight trilinear shape functions (1 + xi_i xi)(1 + eta_i eta)(1 + zeta_i zeta) / 8. */
static double sj_at(const double p[8][3], double xi, double eta, double zeta, double *det) {
    static const double s[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                   {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    double J[3][3] = {{0}};
    for (int i = 0; i < 8; i++) {
        double d[3] = {s[i][0] * (1 + s[i][1] * eta) * (1 + s[i][2] * zeta) / 8,
                       s[i][1] * (1 + s[i][0] * xi) * (1 + s[i][2] * zeta) / 8,
                       s[i][2] * (1 + s[i][0] * xi) * (1 + s[i][1] * eta) / 8};
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) J[k][a] += d[k] * p[i][a];
    }
    double dt = J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) -
                J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
                J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
    double l = 1;
    for (int k = 0; k < 3; k++)
        l *= sqrt(J[k][0] * J[k][0] + J[k][1] * J[k][1] + J[k][2] * J[k][2]);
    *det = dt;
    return dt / l;
}

/* The minimum of sj_at over the corners, the centre and the 2x2x2 Gauss points, and of the
 * determinant in unit-cube units (8 times the [-1,1]^3 one). */
static double sj_by_shape_functions(const double p[8][3], double *jmin) {
    const double g = 1.0 / S3, at[5] = {-1, -g, 0, g, 1};
    double m = INFINITY;
    *jmin = INFINITY;
    for (int i = 0; i < 5; i++)
        for (int j = 0; j < 5; j++)
            for (int k = 0; k < 5; k++) {
                int nz = (i == 2) + (j == 2) + (k == 2);
                int ends = (i % 4 == 0) + (j % 4 == 0) + (k % 4 == 0);
                int gauss = (i % 2 == 1) + (j % 2 == 1) + (k % 2 == 1);
                if (!(nz == 3 || ends == 3 || gauss == 3)) continue;
                double det, v = sj_at(p, at[i], at[j], at[k], &det);
                m = fmin(m, v);
                *jmin = fmin(*jmin, 8 * det);
            }
    return m;
}

/* vm_hex_corner_scaled_jacobian: 1 at every corner of a cube, -1 at a mirrored corner, 0 at
 * a zero-length edge; on perturbed hexes vm_hex_scaled_jacobian (and vm_hex_min_scaled_
 * jacobian, the same) is the minimum over the corners, the centre and the Gauss points by
 * the shape functions, never above the corners' minimum, and vm_hex_jacobian likewise. */
static void hexCornerScaledJacobianIsTheMinimumsTerm(void) {
    const double cube[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    for (int c = 0; c < 8; c++)
        CHECK_NEAR(vm_hex_corner_scaled_jacobian(cube, c), 1.0, 1e-15);
    double p[8][3];
    memcpy(p, cube, sizeof p);
    for (int k = 0; k < 8; k++)
        p[k][0] = -cube[k][0]; /* the mirror image: every corner left-handed */
    for (int c = 0; c < 8; c++)
        CHECK_NEAR(vm_hex_corner_scaled_jacobian((const double(*)[3])p, c), -1.0, 1e-15);
    memcpy(p, cube, sizeof p);
    memcpy(p[1], p[0], sizeof p[1]); /* edge 0-1 of length 0 */
    CHECK(vm_hex_corner_scaled_jacobian((const double(*)[3])p, 0) == 0.0);
    unsigned seed = 12345;
    for (int trial = 0; trial < 200; trial++) {
        for (int k = 0; k < 8; k++)
            for (int a = 0; a < 3; a++) {
                seed = seed * 1103515245u + 12345u;
                p[k][a] = cube[k][a] + 0.6 * ((double)(seed >> 8 & 0xffff) / 65535.0 - 0.5);
            }
        double m = 1.0;
        for (int c = 0; c < 8; c++) {
            double j = vm_hex_corner_scaled_jacobian((const double(*)[3])p, c);
            CHECK(j >= -1.0 && j <= 1.0);
            if (j < m) m = j;
        }
        double s = vm_hex_scaled_jacobian((const double(*)[3])p), jmin;
        CHECK(s <= m + 1e-15);
        CHECK(s == vm_hex_min_scaled_jacobian((const double(*)[3])p));
        double want = sj_by_shape_functions((const double(*)[3])p, &jmin);
        CHECK_NEAR(s, fmax(want, -1.0), 1e-12);
        CHECK_NEAR(vm_hex_jacobian((const double(*)[3])p), jmin, 1e-12);
    }
}

/* A hex whose eight corners are all fine (scaled Jacobian 0.89) and whose centre is fine
 * too (0.87: VTK's vtkMeshQuality, which samples only those, calls it good), but which folds
 * between them: at a Gauss point of a C3D8 the Jacobian is negative, so CalculiX
 * refuses it. Every path counts it inverted: the metric, the corner-sampling name kept for
 * old callers, the Jacobian, vm_mesh_check (the mesh summary's figures) and the quality
 * report (volmesh quality, the HTML report). */
static void hexFoldedBetweenItsCornersIsInvertedByEveryPath(void) {
    const double p[8][3] = {{-6, -14, 0}, {25, -20, -15}, {13, 31, -15}, {15, 30, -18},
                            {-1, -12, 8}, {29, -18, -7},  {8, 30, -17},  {10, 29, -21}};
    for (int c = 0; c < 8; c++) CHECK(vm_hex_corner_scaled_jacobian(p, c) > 0.85);
    double det, centre = sj_at(p, 0, 0, 0, &det);
    CHECK(centre > 0.85 && det > 0);
    const double g = 1.0 / S3;
    double gauss = INFINITY, gdet = INFINITY;
    for (int k = 0; k < 8; k++) {
        gauss = fmin(gauss, sj_at(p, k & 1 ? g : -g, k & 2 ? g : -g, k & 4 ? g : -g, &det));
        gdet = fmin(gdet, det);
    }
    CHECK(gauss < -0.3 && gdet < 0);
    double jmin, want = sj_by_shape_functions(p, &jmin);
    CHECK_NEAR(want, gauss, 1e-12);
    CHECK_NEAR(vm_hex_scaled_jacobian(p), want, 1e-12);
    CHECK(vm_hex_min_scaled_jacobian(p) == vm_hex_scaled_jacobian(p));
    CHECK(vm_hex_jacobian(p) < 0);
    CHECK_NEAR(vm_hex_jacobian(p), jmin, 1e-9);

    vm_mesh m;
    vm_mesh_init(&m, VM_HEX8);
    vm_index n[8];
    for (int i = 0; i < 8; i++) n[i] = vm_mesh_add_point(&m, p[i], NULL);
    CHECK_OK(vm_mesh_add_cell(&m, n, 1, NULL), NULL);
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&m, &r, NULL), NULL);
    CHECK(r.inverted == 1);
    CHECK(r.below_target == 1);
    CHECK_NEAR(r.min_scaled_jacobian, want, 1e-12);
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&m, &q, NULL), NULL);
    double x = 0;
    CHECK(vm_quality_lookup(&q, "inverted", &x) == VM_OK && x == 1);
    CHECK(vm_quality_lookup(&q, "scaled_jacobian.min", &x) == VM_OK);
    CHECK_NEAR(x, want, 1e-12);
    CHECK(vm_quality_lookup(&q, "jacobian.min", &x) == VM_OK && x < 0);
    vm_mesh_free(&m);
}

static double triple3(const double *a, const double *b, const double *c) {
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/* The hex pass's set-up (improve/hex_improve.c): vm__hex_columns gives the columns the
 * samples take their determinants of, and with a fourth component of 1 at node k each
 * column's coefficient of that node, so that every sample's determinant is affine in the
 * node: det(x0 + dx) = det(x0) + g . dx with g = b_a (r_b x r_c) + b_b (r_c x r_a) +
 * b_c (r_a x r_b). Checked against vm__hex_jacobian_samples at the moved node. */
static void hexSampleDeterminantsAreAffineInEachNode(void) {
    const double cube[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    unsigned seed = 777;
    for (int trial = 0; trial < 100; trial++) {
        double p[8][3], p4[8][4], col[VM_HEX_COLUMNS][4], dx[3];
        for (int q = 0; q < 8; q++)
            for (int a = 0; a < 3; a++) {
                seed = seed * 1103515245u + 12345u;
                p[q][a] = cube[q][a] + 0.8 * ((double)(seed >> 8 & 0xffff) / 65535.0 - 0.5);
            }
        int k = trial % 8;
        for (int a = 0; a < 3; a++) {
            seed = seed * 1103515245u + 12345u;
            dx[a] = 0.4 * ((double)(seed >> 8 & 0xffff) / 65535.0 - 0.5);
        }
        for (int q = 0; q < 8; q++) {
            memcpy(p4[q], p[q], sizeof p[q]);
            p4[q][3] = q == k;
        }
        vm__hex_columns((const double(*)[4])p4, col);
        double det[VM_HEX_SAMPLES], len[VM_HEX_SAMPLES];
        vm__hex_jacobian_samples((const double(*)[3])p, det, len);
        for (int s = 0; s < VM_HEX_SAMPLES; s++) {
            const unsigned char *c = vm__hex_sample_col[s];
            CHECK_NEAR(triple3(col[c[0]], col[c[1]], col[c[2]]), det[s], 1e-12);
            double l = 1;
            for (int j = 0; j < 3; j++)
                l *= sqrt(col[c[j]][0] * col[c[j]][0] + col[c[j]][1] * col[c[j]][1] +
                          col[c[j]][2] * col[c[j]][2]);
            CHECK_NEAR(l, len[s], 1e-12);
        }
        double moved[8][3], det1[VM_HEX_SAMPLES], len1[VM_HEX_SAMPLES];
        memcpy(moved, p, sizeof moved);
        for (int a = 0; a < 3; a++) moved[k][a] += dx[a];
        vm__hex_jacobian_samples((const double(*)[3])moved, det1, len1);
        for (int s = 0; s < VM_HEX_SAMPLES; s++) {
            const unsigned char *c = vm__hex_sample_col[s];
            const double *ra = col[c[0]], *rb = col[c[1]], *rc = col[c[2]];
            double g = 0;
            for (int a = 0; a < 3; a++) {
                int a1 = (a + 1) % 3, a2 = (a + 2) % 3;
                double bxc = rb[a1] * rc[a2] - rb[a2] * rc[a1];
                double cxa = rc[a1] * ra[a2] - rc[a2] * ra[a1];
                double axb = ra[a1] * rb[a2] - ra[a2] * rb[a1];
                g += (ra[3] * bxc + rb[3] * cxa + rc[3] * axb) * dx[a];
            }
            CHECK_NEAR(det[s] + g, det1[s], 1e-12);
        }
    }
}

/* All six dihedral and twelve face angles of a tet by atan2, the slow and plain way. */
static void all_angles(const double p[4][3], double dih[6], double face[12]) {
    static const int fc[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    double n[4][3];
    int k = 0;
    for (int f = 0; f < 4; f++) {
        double a[3], b[3];
        for (int d = 0; d < 3; d++) {
            a[d] = p[fc[f][1]][d] - p[fc[f][0]][d];
            b[d] = p[fc[f][2]][d] - p[fc[f][0]][d];
        }
        n[f][0] = a[1] * b[2] - a[2] * b[1];
        n[f][1] = a[2] * b[0] - a[0] * b[2];
        n[f][2] = a[0] * b[1] - a[1] * b[0];
        for (int i = 0; i < 3; i++) {
            const double *o = p[fc[f][i]], *q1 = p[fc[f][(i + 1) % 3]], *q2 = p[fc[f][(i + 2) % 3]];
            double u[3] = {q1[0] - o[0], q1[1] - o[1], q1[2] - o[2]};
            double w[3] = {q2[0] - o[0], q2[1] - o[1], q2[2] - o[2]};
            double c[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                           u[0] * w[1] - u[1] * w[0]};
            face[k++] = atan2(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
                              u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) * 57.29577951308232;
        }
    }
    k = 0;
    for (int f = 0; f < 4; f++)
        for (int g = f + 1; g < 4; g++) {
            const double *u = n[f];
            double w[3] = {-n[g][0], -n[g][1], -n[g][2]};
            double c[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                           u[0] * w[1] - u[1] * w[0]};
            dih[k++] = atan2(sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]),
                             u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) * 57.29577951308232;
        }
}

/* The angle metrics rank the angles by cosine and take atan2 of the extremes only; on random
 * tets, flattened slivers down to 1e-12 thick, needles and caps they must still give the
 * smallest and largest of all the angles. */
static void angleExtremesMatchEveryAngleOnRandomSliverAndNeedleTets(void) {
    unsigned r = 7u;
    int checked = 0;
    for (int it = 0; it < 20000; it++) {
        double p[4][3];
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++) {
                r = r * 1664525u + 1013904223u;
                p[i][d] = (double)(r >> 8) / 16777216.0;
            }
        int mode = it % 4;
        double flat = pow(10.0, -(double)(it % 13)); /* 1 .. 1e-12 */
        if (mode == 1)
            for (int i = 0; i < 4; i++) p[i][2] = 0.5 + flat * (p[i][2] - 0.5); /* sliver */
        if (mode == 2)
            for (int i = 0; i < 4; i++) { /* needle along x */
                p[i][1] = 0.5 + flat * (p[i][1] - 0.5);
                p[i][2] = 0.5 + flat * (p[i][2] - 0.5);
            }
        if (mode == 3) /* cap: node 3 near the opposite face's plane centre */
            for (int d = 0; d < 3; d++)
                p[3][d] = (p[0][d] + p[1][d] + p[2][d]) / 3.0 + flat * (p[3][d] - 0.5);
        double dih[6], face[12];
        all_angles((const double(*)[3])p, dih, face);
        double dlo = 180, dhi = 0, flo = 180, fhi = 0;
        for (int i = 0; i < 6; i++) dlo = fmin(dlo, dih[i]), dhi = fmax(dhi, dih[i]);
        for (int i = 0; i < 12; i++) flo = fmin(flo, face[i]), fhi = fmax(fhi, face[i]);
        double got_dlo = vm_tet_min_dihedral((const double(*)[3])p);
        double got_dhi = vm_tet_max_dihedral((const double(*)[3])p);
        double got_flo = vm_tet_min_face_angle((const double(*)[3])p);
        double got_fhi = vm_tet_max_face_angle((const double(*)[3])p);
        /* The metric calls a tet degenerate (0 / 180) below a volume threshold: skip those. */
        if (got_dlo == 0.0 && got_dhi == 180.0) continue;
        checked++;
        double tol = 1e-9 * fmax(1.0, dlo);
        CHECK_MSG(fabs(got_dlo - dlo) <= tol && fabs(got_dhi - dhi) <= 1e-9 * 180,
                  "tet %d (mode %d, flat %g): dihedral %.17g..%.17g, all angles give %.17g..%.17g",
                  it, mode, flat, got_dlo, got_dhi, dlo, dhi);
        CHECK_MSG(fabs(got_flo - flo) <= 1e-9 * fmax(1.0, flo) && fabs(got_fhi - fhi) <= 1e-9 * 180,
                  "tet %d (mode %d, flat %g): face %.17g..%.17g, all angles give %.17g..%.17g",
                  it, mode, flat, got_flo, got_fhi, flo, fhi);
        if (vm_test_failures > 5) return;
    }
    CHECK(checked > 15000);
}

TEST_MAIN(T(angleExtremesMatchEveryAngleOnRandomSliverAndNeedleTets),
         T(tetMetricsMatchGoldenValues), T(hexMetricsMatchGoldenValues),
          T(triangleMetricsMatchGoldenValues), T(quadMetricsMatchGoldenValues),
          T(metricsNeverReturnNaNOrLeaveTheirRange), T(shapeMetricsIgnoreRigidMotionAndScale),
          T(metricTablesAreConsistent), T(hexScaledJacobianIncludesTheCentre),
          T(hexCornerScaledJacobianIsTheMinimumsTerm),
          T(hexFoldedBetweenItsCornersIsInvertedByEveryPath),
          T(hexSampleDeterminantsAreAffineInEachNode))
