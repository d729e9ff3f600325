/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/quality_internal.h — measures of quality/ that the mesher's refinement loop uses
 * (private to the library: quality/ and mesher/). */
#ifndef VM_QUALITY_INTERNAL_H
#define VM_QUALITY_INTERNAL_H

#include <stddef.h>
#include "volmesh/quality.h"
#include "volmesh/volume.h"

/* Like vm_mesh_surface_distance, and also returns (malloc'd, caller frees) the world-space
 * sample points whose distance exceeds `limit` in either direction (for a mesh point: the
 * point; for a surface point: the surface point). [out] *points: 3 * *npoints doubles, mesh
 * points first (in sample order), then surface points; NULL when none. points and npoints
 * may both be NULL (then nothing is collected). limit <= 0 collects every sample whose
 * distance is above 0. Deterministic: the same lists for any thread count. */
vm_status vm__surface_distance_points(const vm_mesh *m, const vm_volume *v, double lo,
                                      int has_lo, double hi, int has_hi, double limit,
                                      vm_surface_distance *out, double **points,
                                      size_t *npoints, vm_error *err);

#endif
