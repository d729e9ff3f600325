/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/tet_internal.h — tet metrics shared inside quality/ and with improve/ (private). */
#ifndef VM_TET_INTERNAL_H
#define VM_TET_INTERNAL_H

#include <math.h>
#include "../core/vec3.h"

/* Smallest and largest dihedral angle of a tet in degrees, from one evaluation of the six
 * angles: the values of vm_tet_min_dihedral and vm_tet_max_dihedral (0 and 180 for a
 * degenerate tet). */
void vm__tet_dihedral_range(const double p[4][3], double *min_deg, double *max_deg);

/* Smallest and largest face angle in degrees from one evaluation of the twelve: the values
 * of vm_tet_min_face_angle and vm_tet_max_face_angle (0 and 180 for a degenerate tet). */
void vm__tet_face_angle_range(const double p[4][3], double *min_deg, double *max_deg);

/* With a, b, c the edges from node 0: a, bc = b x c (so a . bc = 6V) and
 * w = |a|^2 (b x c) + |b|^2 (c x a) + |c|^2 (a x b), the circumcentre relative to node 0
 * times 12V (its length is the circumradius times 12V). */
void vm__tet_circum_vector(const double p[4][3], double a[3], double bc[3], double w[3]);

/* ABAQUS's element check for tetrahedra: the default failure criteria of ABAQUS/CAE's
 * "Verify Mesh" (Analysis Checks: volume measure, smallest and largest face angle). */
#define VM__ABAQUS_VOLUME_MEASURE 0.02 /* fails below: V / (regular tet of the same R) */
#define VM__ABAQUS_SMALL_FACE_ANGLE 10.0 /* fails with a face angle below (degrees) */
#define VM__ABAQUS_LARGE_FACE_ANGLE 160.0 /* fails with a face angle above (degrees) */
/* The two angle limits' cosines (cos 10 and cos 160 degrees), for tests on cosines. */
#define VM__ABAQUS_COS_SMALL_FACE_ANGLE 0.984807753012208
#define VM__ABAQUS_COS_LARGE_FACE_ANGLE (-0.9396926207859083)

/* What ABAQUS's check finds wrong with a tet: a bit set for each limit it fails. */
enum {
    VM__ABAQUS_FAILS_VOLUME = 1, /* volume measure below VM__ABAQUS_VOLUME_MEASURE */
    VM__ABAQUS_FAILS_SMALL = 2,  /* a face angle below VM__ABAQUS_SMALL_FACE_ANGLE */
    VM__ABAQUS_FAILS_LARGE = 4   /* a face angle above VM__ABAQUS_LARGE_FACE_ANGLE */
};
/* ABAQUS's element check on a tet's volume measure and smallest and largest face angles
 * (degrees): the VM__ABAQUS_FAILS_* bits of the limits it fails, 0 when it passes. */
unsigned vm__tet_abaqus_fails(double volume_measure, double min_face_angle,
                              double max_face_angle);

/* --- Cosine-level measures (no inverse trigonometry), for the hot loops of the quality pass
 * (improve/) and of whoever ranks many tets against angle limits. An angle's cosine decides
 * a comparison with a limit wherever it is clearly on one side; callers measure the angle
 * itself only within round-off of the limit. */

/* Faces opposite node 0..3 (VM__TET_FACE_NODES[f]), ordered so that their normals point out
 * of a positive tet. */
#define VM__TET_FACE_NODES {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}}

/* The cosines of the smallest and largest dihedral angles from the four faces' outward
 * normals n (any length len[f] > 0), [out] *cmax (the smallest angle's) and *cmin (the
 * largest's), clamped to [-1, 1]. */
static inline void vm__tet_normal_cosines(const double n[4][3], const double len[4],
                                          double *cmax, double *cmin) {
    double hi = -2.0, lo = 2.0;
    for (int f = 0; f < 4; f++)
        for (int g = f + 1; g < 4; g++) {
            double cs = -vm__dot3(n[f], n[g]) / (len[f] * len[g]);
            if (cs > hi) hi = cs;
            if (cs < lo) lo = cs;
        }
    *cmax = hi > 1.0 ? 1.0 : hi;
    *cmin = lo < -1.0 ? -1.0 : lo;
}

/* The cosines of a tet's smallest and largest dihedral angles, [out] *cmax (the smallest
 * angle's) and *cmin (the largest's), clamped to [-1, 1]. Returns 0, leaving them unset, when
 * the tet is not clearly positive: 6 V at most 1e-12 times its longest edge cubed, a zero
 * face, or a coordinate not finite. */
static inline int vm__tet_dihedral_cosines(const double p[4][3], double *cmax, double *cmin) {
    static const int fo[4][3] = VM__TET_FACE_NODES;
    double lmax2 = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            double e[3];
            vm__sub3(p[j], p[i], e);
            double l2 = vm__dot3(e, e);
            if (l2 > lmax2) lmax2 = l2;
        }
    double a[3], b[3], c[3], t[3];
    vm__sub3(p[1], p[0], a);
    vm__sub3(p[2], p[0], b);
    vm__sub3(p[3], p[0], c);
    vm__cross3(b, c, t);
    double vol6 = vm__dot3(a, t);
    if (!isfinite(vol6) || !(vol6 > 1e-12 * lmax2 * sqrt(lmax2))) return 0;
    double n[4][3], len[4];
    for (int f = 0; f < 4; f++) {
        const int *fn = fo[f];
        double u[3], v[3];
        vm__sub3(p[fn[1]], p[fn[0]], u);
        vm__sub3(p[fn[2]], p[fn[0]], v);
        vm__cross3(u, v, n[f]);
        len[f] = sqrt(vm__dot3(n[f], n[f]));
        if (!(len[f] > 0.0)) return 0;
    }
    vm__tet_normal_cosines((const double(*)[3])n, len, cmax, cmin);
    return 1;
}

/* The twelve face-angle cosines from the edge lengths el (el[i][j] = |p[j] - p[i]|), [out]
 * fc[3 f + k] the angle at corner k of face f (corner k is node VM__TET_FACE_NODES[f][k]);
 * [out] *cfmax and *cfmin their largest and smallest (the smallest angle's cosine and the
 * largest's). Not clamped; a zero edge gives NaN or infinities. */
static inline void vm__tet_face_cosines_el(const double p[4][3], const double el[4][4],
                                           double fc[12], double *cfmax, double *cfmin) {
    static const int fo[4][3] = VM__TET_FACE_NODES;
    double hi = -2.0, lo = 2.0;
    for (int f = 0; f < 4; f++)
        for (int k = 0; k < 3; k++) {
            int o = fo[f][k], i = fo[f][(k + 1) % 3], j = fo[f][(k + 2) % 3];
            double u[3], v[3];
            vm__sub3(p[i], p[o], u);
            vm__sub3(p[j], p[o], v);
            double cs = vm__dot3(u, v) / (el[o][i] * el[o][j]);
            fc[3 * f + k] = cs;
            if (cs > hi) hi = cs;
            if (cs < lo) lo = cs;
        }
    *cfmax = hi;
    *cfmin = lo;
}

/* vm__tet_face_cosines_el with the lengths measured here, one square root per edge. */
static inline void vm__tet_face_cosines(const double p[4][3], double fc[12], double *cfmax,
                                        double *cfmin) {
    double el[4][4];
    for (int i = 0; i < 4; i++) {
        el[i][i] = 0;
        for (int j = i + 1; j < 4; j++) {
            double e[3];
            vm__sub3(p[j], p[i], e);
            el[i][j] = el[j][i] = sqrt(vm__dot3(e, e));
        }
    }
    vm__tet_face_cosines_el(p, (const double(*)[4])el, fc, cfmax, cfmin);
}

/* A lower bound of cos x for every real x (x radians): the Taylor polynomial to x^6, below
 * cos x by at most x^8 / 8! (2.5e-5 at one radian, 1e-10 at 15 degrees). With it a caller
 * tells an angle clearly above (or, through cos(pi - x) = -cos x, clearly below) a limit
 * without a call to cos: a cosine below vm__cos_below(x) - 1e-12 belongs to an angle above
 * x. */
static inline double vm__cos_below(double x) {
    double x2 = x * x;
    return 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0)));
}

#endif
