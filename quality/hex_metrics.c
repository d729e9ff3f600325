/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/hex_metrics.c — hexahedron metrics: scaled Jacobian, Jacobian, skew, taper, edge
 * ratio and exact trilinear volume (Verdict manual SAND2007-1751 ch. 7). */
#include "volmesh/quality.h"
#include "../core/vec3.h"

/* For each VTK hex corner, its three neighbours in right-handed order. */
static const int hex_corner[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                     {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};
static const int hex_edge[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                    {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/* Signs of the nodes in the principal axes (xi, eta, zeta on [-1,1]^3). */
static const double sxi[8] = {-1, 1, 1, -1, -1, 1, 1, -1};
static const double seta[8] = {-1, -1, 1, 1, -1, -1, 1, 1};
static const double szeta[8] = {-1, -1, -1, -1, 1, 1, 1, 1};

/* Principal axes X1, X2, X3 (x[0..2]) and cross derivatives X12, X13, X23 (x[3..5]), each the
 * signed sum of the eight nodes (8 times the derivative of the trilinear map at the centre).
 * Node 0 is subtracted first so that large offsets do not cost precision. */
static void hex_axes(const double p[8][3], double x[6][3]) {
    for (int k = 0; k < 6; k++)
        x[k][0] = x[k][1] = x[k][2] = 0.0;
    for (int i = 0; i < 8; i++) {
        double q[3];
        vm__sub3(p[i], p[0], q);
        double s[6] = {sxi[i], seta[i], szeta[i], sxi[i] * seta[i], sxi[i] * szeta[i],
                       seta[i] * szeta[i]};
        for (int k = 0; k < 6; k++)
            for (int d = 0; d < 3; d++)
                x[k][d] += s[k] * q[d];
    }
}

/* Corner c's three edge vectors. */
static void corner_edges(const double p[8][3], int c, double e[3][3]) {
    for (int k = 0; k < 3; k++)
        vm__sub3(p[hex_corner[c][k + 1]], p[hex_corner[c][0]], e[k]);
}

/* det(a,b,c) / (|a||b||c|), 0 when a vector vanishes or the result is not finite. */
static double normalized_det(const double a[3], const double b[3], const double c[3]) {
    double denom = vm__norm3(a) * vm__norm3(b) * vm__norm3(c);
    if (!(denom > 0.0) || !isfinite(denom)) return 0.0;
    double s = vm__triple(a, b, c) / denom;
    return isfinite(s) ? s : 0.0;
}

double vm_hex_corner_scaled_jacobian(const double p[8][3], int c) {
    double e[3][3];
    corner_edges(p, c, e);
    return normalized_det(e[0], e[1], e[2]);
}

/* s clamped to the scaled Jacobian's full range, which starts at -1. */
static double clamp_scaled_jacobian(double s) { return s < -1.0 ? -1.0 : s; }

/* The smallest corner scaled Jacobian. */
double vm_hex_min_scaled_jacobian(const double p[8][3]) {
    double smin = 1.0;
    for (int c = 0; c < 8; c++) {
        double s = vm_hex_corner_scaled_jacobian(p, c);
        if (s < smin) smin = s;
    }
    return clamp_scaled_jacobian(smin);
}

/* The smallest of the corner scaled Jacobians and the centre's. */
double vm_hex_scaled_jacobian(const double p[8][3]) {
    double x[6][3];
    hex_axes(p, x);
    double s = normalized_det(x[0], x[1], x[2]);
    double smin = vm_hex_min_scaled_jacobian(p);
    return clamp_scaled_jacobian(s < smin ? s : smin);
}

double vm_hex_jacobian(const double p[8][3]) {
    double x[6][3];
    hex_axes(p, x);
    /* Each of X1..X3 is four times the mean edge vector along its direction, so the
     * centre Jacobian of the map from the unit cube is det(X1,X2,X3)/64. */
    double jmin = vm__triple(x[0], x[1], x[2]) / 64.0;
    for (int c = 0; c < 8; c++) {
        double e[3][3];
        corner_edges(p, c, e);
        double j = vm__triple(e[0], e[1], e[2]);
        if (j < jmin) jmin = j;
    }
    return isfinite(jmin) ? jmin : 0.0;
}

double vm_hex_skew(const double p[8][3]) {
    double x[6][3], u[3][3];
    hex_axes(p, x);
    for (int k = 0; k < 3; k++) {
        double l = vm__norm3(x[k]);
        if (!(l > 0.0) || !isfinite(l)) return 1.0;
        for (int d = 0; d < 3; d++)
            u[k][d] = x[k][d] / l;
    }
    double s = fabs(vm__dot3(u[0], u[1]));
    double t = fabs(vm__dot3(u[0], u[2]));
    if (t > s) s = t;
    t = fabs(vm__dot3(u[1], u[2]));
    if (t > s) s = t;
    return s > 1.0 ? 1.0 : s;
}

double vm_hex_taper(const double p[8][3]) {
    double x[6][3];
    hex_axes(p, x);
    double l[6];
    for (int k = 0; k < 6; k++)
        l[k] = vm__norm3(x[k]);
    double t12 = l[3] / fmin(l[0], l[1]);
    double t13 = l[4] / fmin(l[0], l[2]);
    double t23 = l[5] / fmin(l[1], l[2]);
    double t = fmax(t12, fmax(t13, t23));
    /* fmax drops a NaN operand, so check the axes themselves. */
    if (!(fmin(l[0], fmin(l[1], l[2])) > 0.0)) return VM_QUALITY_HUGE;
    return vm__cap_ratio(t, VM_QUALITY_HUGE);
}

double vm_hex_edge_ratio(const double p[8][3]) {
    double lmin2 = INFINITY, lmax2 = 0.0;
    for (int k = 0; k < 12; k++) {
        double e[3];
        vm__sub3(p[hex_edge[k][1]], p[hex_edge[k][0]], e);
        double l2 = vm__dot3(e, e);
        if (!isfinite(l2)) return VM_QUALITY_HUGE;
        if (l2 < lmin2) lmin2 = l2;
        if (l2 > lmax2) lmax2 = l2;
    }
    return vm__cap_ratio(sqrt(lmax2 / lmin2), VM_QUALITY_HUGE);
}

double vm_hex_volume(const double p[8][3]) {
    /* Divergence theorem over the six bilinear faces, each split into four triangles
     * around its vertex average; exact for the trilinear hexahedron. Coordinates are
     * taken relative to node 0 to limit round-off. */
    static const int face[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                   {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    double q[8][3];
    for (int i = 0; i < 8; i++)
        vm__sub3(p[i], p[0], q[i]);
    double v = 0.0;
    for (int f = 0; f < 6; f++) {
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                c[d] += 0.25 * q[face[f][k]][d];
        for (int k = 0; k < 4; k++)
            v += vm__triple(c, q[face[f][k]], q[face[f][(k + 1) % 4]]);
    }
    v /= 6.0;
    return isfinite(v) ? v : 0.0;
}
