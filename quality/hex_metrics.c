/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/hex_metrics.c — hexahedron metrics: scaled Jacobian, Jacobian, skew, taper, edge
 * ratio and exact trilinear volume (Verdict manual SAND2007-1751 ch. 7). The Jacobians are
 * sampled at Verdict's points (the 8 corners and the centre) and at the 2x2x2 Gauss points a
 * solver integrates C3D8 at, so that a hex valid here is valid for VTK and for CalculiX. */
#include "volmesh/quality.h"
#include <string.h>
#include "../core/vec3.h"
#include "quality_internal.h"

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

/* The 2x2x2 Gauss points of the unit cube [0,1]^3: 1/2 -+ 1/(2 sqrt 3) on each axis. */
#define GAUSS_LO 0.21132486540518711775
#define GAUSS_HI 0.78867513459481288225

/* The edges the map's derivatives blend: the four along u (0-1, 3-2, 4-5, 7-6), along v
 * (0-3, 1-2, 4-7, 5-6), along w (0-4, 1-5, 2-6, 3-7). */
static const int map_edge[12][2] = {{0, 1}, {3, 2}, {4, 5}, {7, 6}, {0, 3}, {1, 2},
                                    {4, 7}, {5, 6}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/* For corner c (VTK order), the edges its derivatives du, dv, dw are: e[iu], e[iv], e[iw]
 * in map_edge's numbering. */
static const int corner_cols[8][3] = {{0, 4, 8}, {0, 5, 9},  {1, 5, 10}, {1, 4, 11},
                                      {2, 6, 8}, {2, 7, 9}, {3, 7, 10}, {3, 6, 11}};

/* a + t (b - a) written as (1 - t) a + t b, component-wise. */
static void lerp3(const double a[3], const double b[3], double t, double out[3]) {
    for (int d = 0; d < 3; d++) out[d] = (1.0 - t) * a[d] + t * b[d];
}

/* The four bilinear blends of the edges q[0..3] (at (s,t) = (0,0), (1,0), (0,1), (1,1))
 * at the Gauss coordinates, out[sbit + 2 tbit]. */
static void gauss_blends(const double *q0, const double *q1, const double *q2, const double *q3,
                         double out[4][3]) {
    double a[2][3], b[2][3];
    lerp3(q0, q1, GAUSS_LO, a[0]);
    lerp3(q0, q1, GAUSS_HI, a[1]);
    lerp3(q2, q3, GAUSS_LO, b[0]);
    lerp3(q2, q3, GAUSS_HI, b[1]);
    for (int sb = 0; sb < 2; sb++) {
        lerp3(a[sb], b[sb], GAUSS_LO, out[sb]);
        lerp3(a[sb], b[sb], GAUSS_HI, out[sb + 2]);
    }
}

void vm__hex_jacobian_samples(const double p[8][3], double det[VM_HEX_SAMPLES],
                              double len[VM_HEX_SAMPLES]) {
    double e[12][3], el[12];
    for (int k = 0; k < 12; k++) {
        vm__sub3(p[map_edge[k][1]], p[map_edge[k][0]], e[k]);
        el[k] = vm__norm3(e[k]);
    }
    /* the corners: their own edges */
    for (int c = 0; c < 8; c++) {
        const int *k = corner_cols[c];
        det[c] = vm__triple(e[k[0]], e[k[1]], e[k[2]]);
        len[c] = el[k[0]] * el[k[1]] * el[k[2]];
    }
    /* the centre: the mean edge along each direction */
    double x[3][3];
    for (int k = 0; k < 3; k++)
        for (int d = 0; d < 3; d++)
            x[k][d] = 0.25 * (e[4 * k][d] + e[4 * k + 1][d] + e[4 * k + 2][d] + e[4 * k + 3][d]);
    det[8] = vm__triple(x[0], x[1], x[2]);
    len[8] = vm__norm3(x[0]) * vm__norm3(x[1]) * vm__norm3(x[2]);
    /* the Gauss points: du depends on (v, w) only, dv on (u, w), dw on (u, v) */
    double gu[4][3], gv[4][3], gw[4][3], lu[4], lv[4], lw[4];
    gauss_blends(e[0], e[1], e[2], e[3], gu);  /* v fastest: 01, 32 at w = 0; 45, 76 */
    gauss_blends(e[4], e[5], e[6], e[7], gv);  /* u fastest: 03, 12 at w = 0; 47, 56 */
    gauss_blends(e[8], e[9], e[11], e[10], gw); /* u fastest: 04, 15 at v = 0; 37, 26 */
    for (int k = 0; k < 4; k++) {
        lu[k] = vm__norm3(gu[k]);
        lv[k] = vm__norm3(gv[k]);
        lw[k] = vm__norm3(gw[k]);
    }
    for (int g = 0; g < 8; g++) {
        int ub = g & 1, vb = (g >> 1) & 1, wb = (g >> 2) & 1;
        int iu = vb + 2 * wb, iv = ub + 2 * wb, iw = ub + 2 * vb;
        det[9 + g] = vm__triple(gu[iu], gv[iv], gw[iw]);
        len[9 + g] = lu[iu] * lv[iv] * lw[iw];
    }
}

const unsigned char vm__hex_sample_col[VM_HEX_SAMPLES][3] = {
    {0, 4, 8},   {0, 5, 9},   {1, 5, 10},  {1, 4, 11},  {2, 6, 8},   {2, 7, 9},
    {3, 7, 10},  {3, 6, 11},  {12, 13, 14}, {15, 19, 23}, {15, 20, 24}, {16, 19, 25},
    {16, 20, 26}, {17, 21, 23}, {17, 22, 24}, {18, 21, 25}, {18, 22, 26}};

/* lerp3 and gauss_blends over 4 components. */
static void lerp4(const double a[4], const double b[4], double t, double out[4]) {
    for (int d = 0; d < 4; d++) out[d] = (1.0 - t) * a[d] + t * b[d];
}

static void gauss_blends4(const double *q0, const double *q1, const double *q2,
                          const double *q3, double out[4][4]) {
    double a[2][4], b[2][4];
    lerp4(q0, q1, GAUSS_LO, a[0]);
    lerp4(q0, q1, GAUSS_HI, a[1]);
    lerp4(q2, q3, GAUSS_LO, b[0]);
    lerp4(q2, q3, GAUSS_HI, b[1]);
    for (int sb = 0; sb < 2; sb++) {
        lerp4(a[sb], b[sb], GAUSS_LO, out[sb]);
        lerp4(a[sb], b[sb], GAUSS_HI, out[sb + 2]);
    }
}

void vm__hex_columns(const double p[8][4], double col[VM_HEX_COLUMNS][4]) {
    double(*e)[4] = col;
    for (int k = 0; k < 12; k++)
        for (int d = 0; d < 4; d++) e[k][d] = p[map_edge[k][1]][d] - p[map_edge[k][0]][d];
    for (int k = 0; k < 3; k++)
        for (int d = 0; d < 4; d++)
            col[12 + k][d] =
                0.25 * (e[4 * k][d] + e[4 * k + 1][d] + e[4 * k + 2][d] + e[4 * k + 3][d]);
    gauss_blends4(e[0], e[1], e[2], e[3], col + 15);
    gauss_blends4(e[4], e[5], e[6], e[7], col + 19);
    gauss_blends4(e[8], e[9], e[11], e[10], col + 23);
}

/* The smallest of the scaled Jacobians at the corners, the centre and the Gauss points. */
double vm_hex_scaled_jacobian(const double p[8][3]) {
    double det[VM_HEX_SAMPLES], len[VM_HEX_SAMPLES], smin = 1.0;
    vm__hex_jacobian_samples(p, det, len);
    for (int s = 0; s < VM_HEX_SAMPLES; s++) {
        double q = vm__hex_sample_sj(det[s], len[s]);
        if (q < smin) smin = q;
    }
    return clamp_scaled_jacobian(smin);
}

/* The same measure: a hex is valid when it is > 0. */
double vm_hex_min_scaled_jacobian(const double p[8][3]) { return vm_hex_scaled_jacobian(p); }

double vm_hex_jacobian(const double p[8][3]) {
    double det[VM_HEX_SAMPLES], len[VM_HEX_SAMPLES], jmin = INFINITY;
    vm__hex_jacobian_samples(p, det, len);
    for (int s = 0; s < VM_HEX_SAMPLES; s++) {
        if (!isfinite(det[s])) return 0.0;
        if (det[s] < jmin) jmin = det[s];
    }
    return jmin;
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
