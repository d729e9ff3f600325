/* quality/tet_internal.h — tet metrics shared inside quality/ (private). */
#ifndef VM_TET_INTERNAL_H
#define VM_TET_INTERNAL_H

/* Smallest and largest dihedral angle of a tet in degrees, from one evaluation of the six
 * angles: the values of vm_tet_min_dihedral and vm_tet_max_dihedral (0 and 180 for a
 * degenerate tet). */
void vm__tet_dihedral_range(const double p[4][3], double *min_deg, double *max_deg);

/* Smallest and largest face angle in degrees from one evaluation of the twelve: the values
 * of vm_tet_min_face_angle and vm_tet_max_face_angle (0 and 180 for a degenerate tet). */
void vm__tet_face_angle_range(const double p[4][3], double *min_deg, double *max_deg);

#endif
