/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/quality_internal.h — measures of quality/ that the mesher's refinement loop and
 * the hex pass use (private to the library: quality/, mesher/ and improve/). */
#ifndef VM_QUALITY_INTERNAL_H
#define VM_QUALITY_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include "volmesh/quality.h"
#include "volmesh/volume.h"
#include <stdint.h>

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

/* Where a measure looks: blocks of `block` voxels (index space, nb[a] along axis a, x
 * fastest), mask 1 where samples count. */
typedef struct vm__sd_region {
    const unsigned char *mask;
    int64_t nb[3];
    int block;
} vm__sd_region;

/* The isosurface's samples, kept between measures of meshes of one volume and bounds
 * (zeroed before the first; vm__sd_cache_free frees them). */
typedef struct vm__sd_cache {
    double *p;
    uint8_t *level;
    size_t n;
    int filled;
} vm__sd_cache;
void vm__sd_cache_free(vm__sd_cache *c);

/* vm__surface_distance_points counting only the samples (of the boundary and of the
 * isosurface) in region r (NULL: all): the counts, means and maxima are the region's; with
 * cache (may be NULL), the isosurface is sampled once for all the calls that share it. The
 * graded mesher measures again only where its refinement changed the mesh. sections: 1 to
 * measure a boundary point against the material's sections of the box planes too (the
 * flat faces that close material touching the border, as vm_mesh_surface_distance does);
 * 0 against the isosurface alone (stricter near the border: the graded mesher's refinement,
 * which so splits the cells along the section's outline down to base cells). */
vm_status vm__surface_distance_region(const vm_mesh *m, const vm_volume *v, double lo,
                                      int has_lo, double hi, int has_hi, double limit,
                                      int sections, const vm__sd_region *r, vm__sd_cache *cache,
                                      vm_surface_distance *out, double **points,
                                      size_t *npoints, vm_error *err);

/* The points a hex's Jacobian is sampled at (vm_hex_scaled_jacobian): the 8 corners (in
 * VTK order), the centre, then the 8 Gauss points of the unit cube (u fastest). */
#define VM_HEX_SAMPLES 17

/* The Jacobian determinant of the map from the unit cube at each sample point (det, unit-
 * cube units: a corner's is the determinant of its three edges) and the product of the
 * lengths of its three columns (len), so that det / len is the scaled Jacobian there. The
 * determinant at any point is affine in the position of any one node (two columns holding
 * the node's term would be parallel), so max-min and penalty searches over one node keep
 * Knupp's convexity at every sample. */
void vm__hex_jacobian_samples(const double p[8][3], double det[VM_HEX_SAMPLES],
                              double len[VM_HEX_SAMPLES]);

/* The 27 columns the samples take their determinants of: the 12 edges (0-1, 3-2, 4-5, 7-6
 * along u; 0-3, 1-2, 4-7, 5-6 along v; 0-4, 1-5, 2-6, 3-7 along w), the centre's du, dv, dw
 * (12-14), and the Gauss points' du (15-18, by (v, w)), dv (19-22, by (u, w)) and dw
 * (23-26, by (u, v)). Sample s is det(col[vm__hex_sample_col[s][0..2]]). */
#define VM_HEX_COLUMNS 27
extern const unsigned char vm__hex_sample_col[VM_HEX_SAMPLES][3];

/* The columns of a hex whose points carry a fourth component, blended as the first three
 * (the map's derivatives are linear in the points): with 1 at one node and 0 elsewhere the
 * fourth component of each column is that node's coefficient in it, so a column is
 * col + coefficient * (move of the node). [in] p: 8 points of 4 components; [out] col. */
void vm__hex_columns(const double p[8][4], double col[VM_HEX_COLUMNS][4]);

/* det / len as vm_hex_scaled_jacobian takes it at one sample point: 0 where len is 0 or
 * either is not finite. */
static inline double vm__hex_sample_sj(double det, double len) {
    if (!(len > 0.0) || !isfinite(len)) return 0.0;
    double s = det / len;
    return isfinite(s) ? s : 0.0;
}

#endif
