/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/tet_internal.h — tet metrics shared inside quality/ and with improve/ (private). */
#ifndef VM_TET_INTERNAL_H
#define VM_TET_INTERNAL_H

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

#endif
