/* quality/tet_metrics.c — tetrahedron and hexahedron element metrics.
 * Definitions from the Verdict manual (Stimpson et al., SAND2007-1751), sections on tet
 * volume, dihedral angles and scaled Jacobian, and hex scaled Jacobian. */
#include "volmesh/quality.h"
#include <math.h>

static void sub3(const double a[3], const double b[3], double out[3]) {
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static void cross3(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot3(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double triple(const double a[3], const double b[3], const double c[3]) {
    double t[3];
    cross3(b, c, t);
    return dot3(a, t);
}

double vm_tet_signed_volume(const double p[4][3]) {
    double a[3], b[3], c[3];
    sub3(p[1], p[0], a);
    sub3(p[2], p[0], b);
    sub3(p[3], p[0], c);
    double v = triple(a, b, c) / 6.0;
    return isfinite(v) ? v : 0.0;
}

/* Faces opposite node 0..3, ordered so their normals point out of a positive tet. */
static const int tet_face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/* Fills the six dihedral angles (degrees); returns 0 when the tet is degenerate (zero
 * volume relative to its size, or non-finite coordinates). */
static int tet_dihedrals(const double p[4][3], double ang[6]) {
    double n[4][3], len[4], lmax2 = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            double e[3];
            sub3(p[j], p[i], e);
            double l2 = dot3(e, e);
            if (l2 > lmax2) lmax2 = l2;
        }
    double vol6 = 6.0 * vm_tet_signed_volume(p);
    /* Volume below round-off relative to edge length cubed means the points are coplanar. */
    if (!isfinite(lmax2) || lmax2 <= 0.0 || fabs(vol6) <= 1e-13 * lmax2 * sqrt(lmax2)) return 0;
    for (int f = 0; f < 4; f++) {
        double a[3], b[3];
        sub3(p[tet_face[f][1]], p[tet_face[f][0]], a);
        sub3(p[tet_face[f][2]], p[tet_face[f][0]], b);
        cross3(a, b, n[f]);
        len[f] = sqrt(dot3(n[f], n[f]));
        if (!(len[f] > 0.0)) return 0;
    }
    /* The dihedral angle at the edge shared by two faces is pi minus the angle between their
     * outward normals; the sign of the volume flips every normal, so it cancels. */
    int k = 0;
    for (int f = 0; f < 4; f++)
        for (int g = f + 1; g < 4; g++) {
            double c = dot3(n[f], n[g]) / (len[f] * len[g]);
            if (c > 1.0) c = 1.0;
            if (c < -1.0) c = -1.0;
            ang[k++] = 180.0 - acos(c) * (180.0 / 3.14159265358979323846);
        }
    return 1;
}

double vm_tet_min_dihedral(const double p[4][3]) {
    double a[6];
    if (!tet_dihedrals(p, a)) return 0.0;
    double m = a[0];
    for (int i = 1; i < 6; i++)
        if (a[i] < m) m = a[i];
    return m;
}

double vm_tet_max_dihedral(const double p[4][3]) {
    double a[6];
    if (!tet_dihedrals(p, a)) return 180.0;
    double m = a[0];
    for (int i = 1; i < 6; i++)
        if (a[i] > m) m = a[i];
    return m;
}

double vm_tet_scaled_jacobian(const double p[4][3]) {
    /* Verdict: 6V * sqrt(2) / max over the corners of the product of the three edge
     * lengths meeting there. */
    double e[6][3];
    sub3(p[1], p[0], e[0]);
    sub3(p[2], p[1], e[1]);
    sub3(p[0], p[2], e[2]);
    sub3(p[3], p[0], e[3]);
    sub3(p[3], p[1], e[4]);
    sub3(p[3], p[2], e[5]);
    double l[6];
    for (int i = 0; i < 6; i++)
        l[i] = sqrt(dot3(e[i], e[i]));
    double c[4] = {l[0] * l[2] * l[3], l[0] * l[1] * l[4], l[1] * l[2] * l[5],
                   l[3] * l[4] * l[5]};
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

/* For each VTK hex corner, its three neighbours in right-handed order. */
static const int hex_corner[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                     {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};

double vm_hex_min_scaled_jacobian(const double p[8][3]) {
    double smin = 1.0;
    for (int c = 0; c < 8; c++) {
        double e[3][3], l[3];
        for (int k = 0; k < 3; k++) {
            sub3(p[hex_corner[c][k + 1]], p[hex_corner[c][0]], e[k]);
            l[k] = sqrt(dot3(e[k], e[k]));
        }
        double denom = l[0] * l[1] * l[2];
        double s = (denom > 0.0 && isfinite(denom)) ? triple(e[0], e[1], e[2]) / denom : 0.0;
        if (!isfinite(s)) s = 0.0;
        if (s < smin) smin = s;
    }
    if (smin < -1.0) smin = -1.0;
    return smin;
}

double vm_hex_volume(const double p[8][3]) {
    /* Divergence theorem over the six bilinear faces, each split into four triangles
     * around its vertex average; exact for the trilinear hexahedron. Coordinates are
     * taken relative to node 0 to limit round-off. */
    static const int face[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                   {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    double q[8][3];
    for (int i = 0; i < 8; i++)
        sub3(p[i], p[0], q[i]);
    double v = 0.0;
    for (int f = 0; f < 6; f++) {
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 4; k++)
            for (int d = 0; d < 3; d++)
                c[d] += 0.25 * q[face[f][k]][d];
        for (int k = 0; k < 4; k++)
            v += triple(c, q[face[f][k]], q[face[f][(k + 1) % 4]]);
    }
    v /= 6.0;
    return isfinite(v) ? v : 0.0;
}
