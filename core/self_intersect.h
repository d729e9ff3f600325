/* SPDX-License-Identifier: BSD-3-Clause */
/* core/self_intersect.h — private: counting intersecting triangle pairs of a surface,
 * used by vm_mesh_check and by the mesher's own checks. Not part of the public API. */
#ifndef VM_QUALITY_SELF_INTERSECT_H
#define VM_QUALITY_SELF_INTERSECT_H

#include <stddef.h>
#include <stdint.h>
#include "volmesh/error.h"
#include "volmesh/mesh.h"

/* Counts the pairs of triangles (tri[3 t + 0..2] index pts[3 v + 0..2]) that intersect
 * other than along what they share: triangles with no common vertex intersect when they
 * have any point in common (touching counts); with one common vertex, when the edge
 * opposite it in either triangle meets the other triangle; with a common edge, only when
 * they are coplanar and lie on the same side of it (a fold). Orientation predicates are
 * evaluated in double with an error filter and a long-double fallback; a sign that stays
 * uncertain counts as zero (touching). [out] *pairs; [out] flags, when not NULL, has nt
 * entries set to 1 for triangles in at least one pair and 0 otherwise. Expected time
 * O(nt) (a uniform grid over the bounding boxes). Errors: out of memory. */
vm_status vm__self_intersections(const double *pts, const vm_index *tri, size_t nt,
                                 size_t *pairs, uint8_t *flags, vm_error *err);

/* Whether two triangles given by their corner positions and vertex ids intersect in the
 * sense of vm__self_intersections. */
int vm__tri_pair_intersects(const double *const a[3], const vm_index ia[3],
                            const double *const b[3], const vm_index ib[3]);

#endif
