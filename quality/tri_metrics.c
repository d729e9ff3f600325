/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/tri_metrics.c — triangle and quadrilateral metrics in 3-D: aspect ratio, corner
 * angles, scaled Jacobian, edge ratio (Verdict manual SAND2007-1751 ch. 4 and 5). */
#include "volmesh/quality.h"
#include "../core/vec3.h"

/* Edge vectors e[i] = p[i+1] - p[i] of an n-gon and their lengths; returns 0 when an edge has
 * zero length or a coordinate is not finite. */
static int polygon_edges(const double (*p)[3], int n, double e[4][3], double l[4]) {
    int ok = 1;
    for (int i = 0; i < n; i++) {
        vm__sub3(p[(i + 1) % n], p[i], e[i]);
        l[i] = vm__norm3(e[i]);
        if (!(l[i] > 0.0) || !isfinite(l[i])) ok = 0;
    }
    return ok;
}

/* Interior angles of an n-gon (degrees, 0..180 each); returns 0 when degenerate. */
static int polygon_angles(const double (*p)[3], int n, double ang[4]) {
    double e[4][3], l[4];
    if (!polygon_edges(p, n, e, l)) return 0;
    for (int i = 0; i < n; i++) {
        const double *next = e[i], *prev = e[(i + n - 1) % n];
        double back[3] = {-prev[0], -prev[1], -prev[2]};
        ang[i] = vm__angle_deg(next, back);
    }
    return 1;
}

static double edge_ratio(const double (*p)[3], int n) {
    double e[4][3], l[4];
    polygon_edges(p, n, e, l);
    double lo = l[0], hi = l[0];
    for (int i = 1; i < n; i++) {
        if (!isfinite(l[i])) return VM_QUALITY_HUGE;
        if (l[i] < lo) lo = l[i];
        if (l[i] > hi) hi = l[i];
    }
    return vm__cap_ratio(hi / lo, VM_QUALITY_HUGE);
}

static double min_of(const double *a, int n) {
    double m = a[0];
    for (int i = 1; i < n; i++)
        if (a[i] < m) m = a[i];
    return m;
}

static double max_of(const double *a, int n) {
    double m = a[0];
    for (int i = 1; i < n; i++)
        if (a[i] > m) m = a[i];
    return m;
}

/* ---- triangles -------------------------------------------------------------------------- */

double vm_tri_aspect_ratio(const double p[3][3]) {
    double e[4][3], l[4], n[3];
    polygon_edges(p, 3, e, l);
    vm__cross3(e[0], e[1], n);
    double area = 0.5 * vm__norm3(n);
    double q = max_of(l, 3) * (l[0] + l[1] + l[2]) / (4.0 * sqrt(3.0) * area);
    return vm__cap_ratio(q, VM_QUALITY_HUGE);
}

double vm_tri_min_angle(const double p[3][3]) {
    double a[4];
    return polygon_angles(p, 3, a) ? min_of(a, 3) : 0.0;
}

double vm_tri_max_angle(const double p[3][3]) {
    double a[4];
    return polygon_angles(p, 3, a) ? max_of(a, 3) : 180.0;
}

double vm_tri_scaled_jacobian(const double p[3][3]) {
    double e[4][3], l[4], n[3];
    if (!polygon_edges(p, 3, e, l)) return 0.0;
    vm__cross3(e[0], e[1], n);
    double pmax = fmax(l[0] * l[1], fmax(l[1] * l[2], l[2] * l[0]));
    double q = (2.0 / sqrt(3.0)) * vm__norm3(n) / pmax;
    if (!isfinite(q)) return 0.0;
    return q > 1.0 ? 1.0 : q;
}

double vm_tri_edge_ratio(const double p[3][3]) {
    return edge_ratio(p, 3);
}

/* ---- quadrilaterals --------------------------------------------------------------------- */

double vm_quad_aspect_ratio(const double p[4][3]) {
    double e[4][3], l[4], d1[3], d2[3], n[3];
    polygon_edges(p, 4, e, l);
    vm__sub3(p[2], p[0], d1);
    vm__sub3(p[3], p[1], d2);
    vm__cross3(d1, d2, n);
    double area = 0.5 * vm__norm3(n);
    double q = max_of(l, 4) * (l[0] + l[1] + l[2] + l[3]) / (4.0 * area);
    return vm__cap_ratio(q, VM_QUALITY_HUGE);
}

/* Unit normal of a quad from its principal axes X1 = (p1-p0)+(p2-p3), X2 = (p2-p1)+(p3-p0);
 * returns 0 when they are parallel or a coordinate is not finite. */
static int quad_normal(double e[4][3], double n[3]) {
    double x1[3], x2[3];
    for (int d = 0; d < 3; d++) {
        x1[d] = e[0][d] - e[2][d];
        x2[d] = e[1][d] - e[3][d];
    }
    vm__cross3(x1, x2, n);
    double l = vm__norm3(n);
    if (!(l > 0.0) || !isfinite(l)) return 0;
    for (int d = 0; d < 3; d++)
        n[d] /= l;
    return 1;
}

/* Interior angles of a quad, 0..360: a corner that turns against the quad's normal is
 * reflex (360 minus its angle), as Verdict counts it. Returns 0 when degenerate. */
static int quad_angles(const double p[4][3], double ang[4]) {
    double e[4][3], l[4], n[3];
    if (!polygon_angles(p, 4, ang)) return 0;
    polygon_edges(p, 4, e, l);
    if (!quad_normal(e, n)) return 1;
    for (int i = 0; i < 4; i++) {
        const double *next = e[i], *prev = e[(i + 3) % 4];
        double back[3] = {-prev[0], -prev[1], -prev[2]}, c[3];
        vm__cross3(next, back, c);
        if (vm__dot3(c, n) < 0.0) ang[i] = 360.0 - ang[i];
    }
    return 1;
}

double vm_quad_min_angle(const double p[4][3]) {
    double a[4];
    return quad_angles(p, a) ? min_of(a, 4) : 0.0;
}

double vm_quad_max_angle(const double p[4][3]) {
    double a[4];
    return quad_angles(p, a) ? max_of(a, 4) : 360.0;
}

double vm_quad_scaled_jacobian(const double p[4][3]) {
    double e[4][3], l[4];
    if (!polygon_edges(p, 4, e, l)) return 0.0;
    double nrm[3];
    if (!quad_normal(e, nrm)) return 0.0;
    double smin = 1.0;
    for (int i = 0; i < 4; i++) {
        const double *next = e[i], *prev = e[(i + 3) % 4];
        double back[3] = {-prev[0], -prev[1], -prev[2]}, c[3];
        vm__cross3(next, back, c);
        double s = vm__dot3(c, nrm) / (l[i] * l[(i + 3) % 4]);
        if (s < smin) smin = s;
    }
    if (!isfinite(smin)) return 0.0;
    return smin < -1.0 ? -1.0 : smin;
}

double vm_quad_edge_ratio(const double p[4][3]) {
    return edge_ratio(p, 4);
}
