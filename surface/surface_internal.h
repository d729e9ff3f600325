/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_internal.h — what the surface methods share (private): the sampled field
 * as a signed material value, and one entry point per method in grid index coordinates. */
#ifndef VM_SURFACE_INTERNAL_H
#define VM_SURFACE_INTERNAL_H

#include <stdint.h>
#include "volmesh/surface.h"

/* The samples a method contours: n points per axis, x fastest, grid index coordinates
 * (sample (i,j,k) sits at (i,j,k)). */
typedef struct vm__surface_grid {
    int64_t n[3];
    const float *f;
    double lo, hi;
    int has_lo, has_hi;
} vm__surface_grid;

/* Signed material value of a sample value x: positive inside {lo <= x <= hi}, negative
 * outside, zero on a bound; min(x - lo, hi - x) over the bounds that apply. A method
 * contours the zero level of this value (interpolating it linearly along grid edges), and
 * treats every point outside the grid as outside, so material on the border is closed
 * there. A value of exactly 0 counts as inside (as vm_mesh_volume does: f >= lo). */
static inline double vm__surface_value(const vm__surface_grid *g, double x) {
    double s = 0;
    int first = 1;
    if (g->has_lo) {
        s = x - g->lo;
        first = 0;
    }
    if (g->has_hi) {
        double t = g->hi - x;
        if (first || t < s) s = t;
    }
    return s;
}

/* Signed material value of sample (i,j,k); points outside the grid return -1 (outside). */
static inline double vm__surface_at(const vm__surface_grid *g, int64_t i, int64_t j, int64_t k) {
    if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2]) return -1;
    return vm__surface_value(g, (double)g->f[i + g->n[0] * (j + g->n[1] * k)]);
}

/* Each method appends to surf (already initialised as tri3) points in grid index
 * coordinates and faces oriented outward in index space (counter-clockwise seen from
 * outside the material), region 1. The caller maps the points to the world and fixes the
 * orientation for left-handed frames. st->cells_visited may be filled. */
vm_status vm__surface_mc(const vm__surface_grid *g, const vm_surface_options *o, vm_mesh *surf,
                         vm_surface_stats *st, vm_error *err);
vm_status vm__surface_asc(const vm__surface_grid *g, const vm_surface_options *o, vm_mesh *surf,
                          vm_surface_stats *st, vm_error *err);
vm_status vm__surface_cover(const vm__surface_grid *g, const vm_surface_options *o,
                            vm_mesh *surf, vm_surface_stats *st, vm_error *err);

#endif
