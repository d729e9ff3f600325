/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/tet_metrics.c — tetrahedron metrics: volume, dihedral and face angles, scaled
 * Jacobian, radius/aspect/edge ratios (Verdict manual SAND2007-1751 ch. 6) and the ABAQUS
 * volume measure (ABAQUS/CAE "Verify Mesh" element check). */
#include "volmesh/quality.h"
#include "tet_internal.h"
#include "../core/vec3.h"

double vm_tet_signed_volume(const double p[4][3]) {
    double a[3], b[3], c[3];
    vm__sub3(p[1], p[0], a);
    vm__sub3(p[2], p[0], b);
    vm__sub3(p[3], p[0], c);
    double v = vm__triple(a, b, c) / 6.0;
    return isfinite(v) ? v : 0.0;
}

/* Faces opposite node 0..3, ordered so their normals point out of a positive tet. */
static const int tet_face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
/* The six edges (i < j). */
static const int tet_edge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

/* Squared edge lengths in tet_edge order; returns the largest. */
static double edge_lengths2(const double p[4][3], double l2[6]) {
    double lmax2 = 0.0;
    for (int k = 0; k < 6; k++) {
        double e[3];
        vm__sub3(p[tet_edge[k][1]], p[tet_edge[k][0]], e);
        l2[k] = vm__dot3(e, e);
        if (l2[k] > lmax2) lmax2 = l2[k];
    }
    return lmax2;
}

/* The smallest and largest of n angles between vector pairs (u[i], w[i]) with |u[i]| |w[i]|
 * = len[i] > 0: the pairs are ranked by their cosines and only the two extremes take an
 * atan2, unless a cosine is within 1e-6 of +-1, where cosines no longer rank slivers and
 * every angle is evaluated. The values are those of the smallest and largest vm__angle_deg
 * (up to a tie within round-off). */
static void angle_extremes(int n, const double (*u)[3], const double (*w)[3],
                           const double *len, double *lo, double *hi) {
    int imin = 0, imax = 0;
    double cmin = 2.0, cmax = -2.0;
    for (int i = 0; i < n; i++) {
        double c = vm__dot3(u[i], w[i]) / len[i];
        if (c > cmax) {
            cmax = c;
            imin = i;
        }
        if (c < cmin) {
            cmin = c;
            imax = i;
        }
    }
    if (cmax < 1.0 - 1e-6 && cmin > -1.0 + 1e-6) {
        *lo = vm__angle_deg(u[imin], w[imin]);
        *hi = vm__angle_deg(u[imax], w[imax]);
        return;
    }
    *lo = 180.0;
    *hi = 0.0;
    for (int i = 0; i < n; i++) {
        double a = vm__angle_deg(u[i], w[i]);
        if (a < *lo) *lo = a;
        if (a > *hi) *hi = a;
    }
}

void vm__tet_dihedral_range(const double p[4][3], double *min_deg, double *max_deg) {
    double n[4][3], l2[6], ln[4];
    double lmax2 = edge_lengths2(p, l2);
    double vol6 = 6.0 * vm_tet_signed_volume(p);
    *min_deg = 0.0;
    *max_deg = 180.0;
    /* Degenerate: volume below round-off relative to edge length cubed (coplanar points),
     * a zero face or a non-finite coordinate. The dihedral angle at the edge shared by two
     * faces is the angle between one outward normal and the other reversed; the sign of the
     * volume flips every normal, so it cancels. */
    if (!isfinite(lmax2) || lmax2 <= 0.0 || fabs(vol6) <= 1e-13 * lmax2 * sqrt(lmax2)) return;
    for (int f = 0; f < 4; f++) {
        double a[3], b[3];
        vm__sub3(p[tet_face[f][1]], p[tet_face[f][0]], a);
        vm__sub3(p[tet_face[f][2]], p[tet_face[f][0]], b);
        vm__cross3(a, b, n[f]);
        ln[f] = vm__norm3(n[f]);
        if (!(ln[f] > 0.0)) return;
    }
    double u[6][3], w[6][3], len[6];
    int k = 0;
    for (int f = 0; f < 4; f++)
        for (int g = f + 1; g < 4; g++) {
            for (int d = 0; d < 3; d++) {
                u[k][d] = n[f][d];
                w[k][d] = -n[g][d];
            }
            len[k++] = ln[f] * ln[g];
        }
    angle_extremes(6, (const double(*)[3])u, (const double(*)[3])w, len, min_deg, max_deg);
}

/* One end of the range a range function gives for p: the low end, or the high end (hi). */
static double range_end(void (*range)(const double p[4][3], double *lo, double *hi),
                        const double p[4][3], int hi) {
    double r[2];
    range(p, &r[0], &r[1]);
    return r[hi];
}

double vm_tet_min_dihedral(const double p[4][3]) {
    return range_end(vm__tet_dihedral_range, p, 0);
}

double vm_tet_max_dihedral(const double p[4][3]) {
    return range_end(vm__tet_dihedral_range, p, 1);
}

double vm_tet_scaled_jacobian(const double p[4][3]) {
    double l2[6], l[6];
    edge_lengths2(p, l2);
    for (int i = 0; i < 6; i++)
        l[i] = sqrt(l2[i]);
    /* Edges at each corner, in tet_edge numbering. */
    double c[4] = {l[0] * l[1] * l[2], l[0] * l[3] * l[4], l[1] * l[3] * l[5],
                   l[2] * l[4] * l[5]};
    double cmax = c[0];
    for (int i = 1; i < 4; i++)
        if (c[i] > cmax) cmax = c[i];
    if (!(cmax > 0.0) || !isfinite(cmax)) return 0.0;
    double sj = 6.0 * vm_tet_signed_volume(p) * sqrt(2.0) / cmax;
    if (!isfinite(sj)) return 0.0;
    if (sj > 1.0) sj = 1.0;
    if (sj < -1.0) sj = -1.0;
    return sj;
}

/* Sum of the four face areas. */
static double face_area_sum(const double p[4][3]) {
    double s = 0.0;
    for (int f = 0; f < 4; f++) {
        double a[3], b[3], n[3];
        vm__sub3(p[tet_face[f][1]], p[tet_face[f][0]], a);
        vm__sub3(p[tet_face[f][2]], p[tet_face[f][0]], b);
        vm__cross3(a, b, n);
        s += 0.5 * vm__norm3(n);
    }
    return s;
}

void vm__tet_circum_vector(const double p[4][3], double a[3], double bc[3], double w[3]) {
    double b[3], c[3], ca[3], ab[3];
    vm__sub3(p[1], p[0], a);
    vm__sub3(p[2], p[0], b);
    vm__sub3(p[3], p[0], c);
    vm__cross3(b, c, bc);
    vm__cross3(c, a, ca);
    vm__cross3(a, b, ab);
    double la = vm__dot3(a, a), lb = vm__dot3(b, b), lc = vm__dot3(c, c);
    for (int d = 0; d < 3; d++)
        w[d] = la * bc[d] + lb * ca[d] + lc * ab[d];
}

/* Circumradius times 12V: the length of vm__tet_circum_vector's w. */
static double circumradius_12v(const double p[4][3]) {
    double a[3], bc[3], w[3];
    vm__tet_circum_vector(p, a, bc, w);
    return vm__norm3(w);
}

double vm_tet_radius_ratio(const double p[4][3]) {
    /* R = N / (12 V) and r = 3 V / S, so R / (3 r) = N S / (108 V^2). */
    double v = fabs(vm_tet_signed_volume(p));
    double q = circumradius_12v(p) * face_area_sum(p) / (108.0 * v * v);
    return vm__cap_ratio(q, VM_QUALITY_HUGE);
}

double vm_tet_aspect_ratio(const double p[4][3]) {
    /* h_max / (2 sqrt(6) r) with r = 3 V / S. */
    double l2[6];
    double hmax = sqrt(edge_lengths2(p, l2));
    double v = fabs(vm_tet_signed_volume(p));
    double q = hmax * face_area_sum(p) / (6.0 * sqrt(6.0) * v);
    return vm__cap_ratio(q, VM_QUALITY_HUGE);
}

double vm_tet_edge_ratio(const double p[4][3]) {
    double l2[6];
    double lmax2 = edge_lengths2(p, l2), lmin2 = l2[0];
    for (int k = 1; k < 6; k++)
        if (l2[k] < lmin2) lmin2 = l2[k];
    return vm__cap_ratio(sqrt(lmax2 / lmin2), VM_QUALITY_HUGE);
}

void vm__tet_face_angle_range(const double p[4][3], double *min_deg, double *max_deg) {
    double u[12][3], w[12][3], len[12];
    *min_deg = 0.0;
    *max_deg = 180.0;
    int k = 0;
    for (int f = 0; f < 4; f++)
        for (int i = 0; i < 3; i++) {
            const double *o = p[tet_face[f][i]];
            vm__sub3(p[tet_face[f][(i + 1) % 3]], o, u[k]);
            vm__sub3(p[tet_face[f][(i + 2) % 3]], o, w[k]);
            double la = vm__dot3(u[k], u[k]), lb = vm__dot3(w[k], w[k]);
            /* An edge of zero length or a non-finite coordinate: degenerate. */
            if (!(la > 0.0) || !(lb > 0.0) || !isfinite(la) || !isfinite(lb)) return;
            len[k++] = sqrt(la * lb);
        }
    angle_extremes(12, (const double(*)[3])u, (const double(*)[3])w, len, min_deg, max_deg);
}

double vm_tet_min_face_angle(const double p[4][3]) {
    return range_end(vm__tet_face_angle_range, p, 0);
}

double vm_tet_max_face_angle(const double p[4][3]) {
    return range_end(vm__tet_face_angle_range, p, 1);
}

double vm_tet_volume_measure(const double p[4][3]) {
    /* The equilateral tet with circumradius R has edge 4R/sqrt(6) and volume
     * 8 R^3 / (9 sqrt(3)). A vanishing volume sends R to infinity and the ratio to 0. */
    double v = vm_tet_signed_volume(p);
    double n = circumradius_12v(p);
    if (v == 0.0 || !(n > 0.0) || !isfinite(n)) return 0.0;
    double r = n / (12.0 * fabs(v)); /* circumradius */
    double q = v / (8.0 * r * r * r / (9.0 * sqrt(3.0)));
    if (!isfinite(q)) return 0.0;
    if (q > 1.0) q = 1.0;
    if (q < -1.0) q = -1.0;
    return q;
}

unsigned vm__tet_abaqus_fails(double volume_measure, double min_face_angle,
                              double max_face_angle) {
    unsigned f = 0;
    if (volume_measure < VM__ABAQUS_VOLUME_MEASURE) f |= VM__ABAQUS_FAILS_VOLUME;
    if (min_face_angle < VM__ABAQUS_SMALL_FACE_ANGLE) f |= VM__ABAQUS_FAILS_SMALL;
    if (max_face_angle > VM__ABAQUS_LARGE_FACE_ANGLE) f |= VM__ABAQUS_FAILS_LARGE;
    return f;
}
