/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/mesh_volume.c — vm_mesh_volume: checks the request, prepares the sampling grid,
 * runs dual contouring and returns the mesh in world coordinates. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesher_internal.h"
#include "volmesh/mesher.h"

void vm_mesh_options_default(vm_mesh_options *o) {
    memset(o, 0, sizeof *o);
    o->has_lo = 1;
    o->lo = 0.0;
    o->elements = VM_TET4;
    o->cell_size = 1;
    o->error = 0.5;
    o->max_level = 4;
}

/* Trilinear sample at continuous index position (x, y, z) inside a volume of nz planes of
 * which v holds planes z0 .. z0 + v->dims[2] - 1 (the whole volume: z0 = 0, nz = dims[2]);
 * the planes with a nonzero weight must be among them. */
static float sample(const vm_volume *v, int64_t z0, int64_t nz, double x, double y, double z) {
    int64_t i = (int64_t)floor(x), j = (int64_t)floor(y), k = (int64_t)floor(z);
    if (i > v->dims[0] - 2) i = v->dims[0] - 2;
    if (j > v->dims[1] - 2) j = v->dims[1] - 2;
    if (k > nz - 2) k = nz - 2;
    double fx = x - (double)i, fy = y - (double)j, fz = z - (double)k, s = 0;
    for (int c = 0; c < 8; c++) {
        int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
        if (w == 0) continue;
        s += w * v->data[(i + dx) + v->dims[0] * ((j + dy) + v->dims[1] * (k + dz - z0))];
    }
    return (float)s;
}

vm_status vm__material_check(const vm_volume *v, int has_lo, double lo, int has_hi, double hi,
                             int cell_size, const char *what, vm_error *err) {
    if (!has_lo && !has_hi)
        return vm_error_set(err, VM_ERR_ARG, "%s: no material bound given (--iso or --range)",
                            what);
    if (has_lo && has_hi && lo > hi)
        return vm_error_set(err, VM_ERR_ARG, "%s: empty range %g:%g (lower bound above upper)",
                            what, lo, hi);
    if (cell_size < 1)
        return vm_error_set(err, VM_ERR_ARG, "%s: cell size %d must be >= 1", what, cell_size);
    for (int a = 0; a < 3; a++)
        if (v->dims[a] < 2)
            return vm_error_set(err, VM_ERR_ARG,
                                "%s: the volume is %lld voxel(s) along axis %d; need at least 2",
                                what, (long long)v->dims[a], a);
    double vmin, vmax;
    size_t nonfinite = vm_volume_stats(v, &vmin, &vmax, NULL);
    if (nonfinite)
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: the volume has %zu non-finite values (NaN or infinity)", what,
                            nonfinite);
    return vm__material_range(has_lo, lo, has_hi, hi, vmin, vmax, what, err);
}

vm_status vm__material_range(int has_lo, double lo, int has_hi, double hi, double vmin,
                             double vmax, const char *what, vm_error *err) {
    if (has_lo && lo > vmax)
        return vm_error_set(err, VM_ERR_EMPTY,
                            "%s: no voxel >= %g (the data range is %g to %g): choose an "
                            "isovalue below %g",
                            what, lo, vmin, vmax, vmax);
    if (has_hi && hi < vmin)
        return vm_error_set(err, VM_ERR_EMPTY, "%s: no voxel <= %g (the data range is %g to %g)",
                            what, hi, vmin, vmax);
    return VM_OK;
}

/* The sampling grid along one axis of len samples at cell size S: *m points, *step
 * samples apart (S = 1: every sample, step 1). */
static void grid_axis(int64_t len, int64_t S, int64_t *m, double *step) {
    *m = (len - 1 + S - 1) / S + 1;
    if (*m < 2) *m = 2;
    *step = (double)(len - 1) / (double)(*m - 1);
}

/* The n[0] x n[1] x n[2] grid points from whole-grid plane k0 on, sampled in a volume of nz
 * planes of which v holds planes z0.. (see sample). [out] *f, owned by the caller. */
static vm_status resample(const vm_volume *v, int64_t z0, int64_t nz, const int64_t n[3],
                          int64_t k0, const double step[3], const char *what, float **f,
                          vm_error *err) {
    size_t count;
    vm_status s = vm__check_dims(n, sizeof(float), what, &count, err);
    if (s) return s;
    float *r = malloc(count * sizeof(float));
    if (!r) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", what);
    size_t idx = 0;
    for (int64_t k = k0; k < k0 + n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            for (int64_t i = 0; i < n[0]; i++)
                r[idx++] = sample(v, z0, nz, (double)i * step[0], (double)j * step[1],
                                  (double)k * step[2]);
    *f = r;
    return VM_OK;
}

vm_status vm__sampling_grid(const vm_volume *v, int cell_size, const char *what, int64_t n[3],
                            const float **f, float **owned, double step[3], vm_error *err) {
    *owned = NULL;
    for (int a = 0; a < 3; a++) step[a] = 1;
    if (cell_size == 1) {
        for (int a = 0; a < 3; a++) n[a] = v->dims[a];
        *f = v->data;
        return VM_OK;
    }
    for (int a = 0; a < 3; a++) grid_axis(v->dims[a], cell_size, &n[a], &step[a]);
    vm_status s = resample(v, 0, v->dims[2], n, 0, step, what, owned, err);
    if (!s) *f = *owned;
    return s;
}

/* The sampling grid of a cropped volume (o->full_nz > 0): the points of the whole volume's
 * sampling grid whose samples need only v's planes, from the first one at a multiple of
 * `align` (or 0) on. [out] n, f, owned (may be NULL for cell size 1: f points into v),
 * step (of the whole grid), g0: the whole grid's index of point 0 along z. */
static vm_status crop_grid(const vm_volume *v, const vm_mesh_options *o, int64_t align,
                           int64_t n[3], const float **f, float **owned, double step[3],
                           int64_t *g0, vm_error *err) {
    int64_t z0 = o->z_offset, nz = o->full_nz, top = z0 + v->dims[2] - 1;
    *owned = NULL;
    if (o->elements != VM_TET4)
        return vm_error_set(err, VM_ERR_ARG, "mesh: a cropped volume is meshed with tets only");
    if (z0 < 0 || top >= nz || v->dims[2] < 2)
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: crop planes %lld..%lld are not inside the %lld planes of "
                            "the whole volume",
                            (long long)z0, (long long)top, (long long)nz);
    int64_t S = o->cell_size, m[3];
    for (int a = 0; a < 3; a++) grid_axis(a < 2 ? v->dims[a] : nz, S, &m[a], &step[a]);
    /* grid planes [ga, gb] along z: their samples read only planes z0..top */
    int64_t ga = 0, gb = m[2] - 1;
    if (z0 > 0) {
        while (ga < m[2] && (double)ga * step[2] < (double)z0)
            ga++;
        ga = (ga + align - 1) / align * align;
    }
    if (top < nz - 1)
        while (gb >= 0 && (double)gb * step[2] > (double)top)
            gb--;
    if (gb - ga + 1 < 2)
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: crop planes %lld..%lld hold fewer than two aligned grid "
                            "planes",
                            (long long)z0, (long long)top);
    *g0 = ga;
    n[0] = m[0];
    n[1] = m[1];
    n[2] = gb - ga + 1;
    if (S == 1) {
        *f = v->data + (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)(ga - z0);
        return VM_OK;
    }
    vm_status s = resample(v, z0, nz, n, ga, step, "mesh", owned, err);
    if (!s) *f = *owned;
    return s;
}

vm_status vm__mesh_options_check(const vm_mesh_options *o, vm_error *err) {
    if (o->elements != VM_TET4 && o->elements != VM_HEX8)
        return vm_error_set(err, VM_ERR_ARG, "mesh: elements must be tetrahedra or hexahedra");
    if (o->cell_size < 1)
        return vm_error_set(err, VM_ERR_ARG, "mesh: cell size %d must be >= 1", o->cell_size);
    if (o->adaptive && (o->max_level < 1 || o->max_level > 10))
        return vm_error_set(err, VM_ERR_ARG, "mesh: adaptive max level %d is outside 1..10",
                            o->max_level);
    if (o->graded && o->elements != VM_TET4)
        return vm_error_set(err, VM_ERR_ARG, "mesh: graded sizing makes tetrahedra only");
    if (!(o->max_edge >= 0 && o->max_edge <= 1e30) || !(o->min_edge >= 0 && o->min_edge <= 1e30) ||
        !(o->distance >= 0 && o->distance <= 1e30))
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: --max-edge, --min-edge and --distance must be >= 0 and finite");
    if (o->grading != 0 && !(o->grading >= 1.1 && o->grading <= 1e30))
        return vm_error_set(err, VM_ERR_ARG, "mesh: --grading %g must be >= 1.1", o->grading);
    if (o->min_layers != 0 && (!o->graded || o->min_layers < 1 || o->min_layers > 100))
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: --min-layers %d needs graded sizing and 1..100 layers",
                            o->min_layers);
    if (o->tets > 0 && !o->graded)
        return vm_error_set(err, VM_ERR_ARG, "mesh: a tet target needs graded sizing");
    if (o->size_field && (!o->graded || !o->size_field->data))
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: a size field needs graded sizing and its voxels read");
    if (o->max_edge > 0 && o->min_edge > o->max_edge)
        return vm_error_set(err, VM_ERR_ARG, "mesh: --min-edge %g is above --max-edge %g",
                            o->min_edge, o->max_edge);
    if (o->adaptive && !(o->error >= 0 && o->error < 1e30))
        return vm_error_set(err, VM_ERR_ARG, "mesh: adaptive error %g must be >= 0 (voxels)",
                            o->error);
    return VM_OK;
}

vm_status vm_mesh_volume(const vm_volume *v, const vm_mesh_options *o, vm_mesh *mesh,
                         vm_mesh_stats *stats, vm_error *err) {
    double t0 = vm__now();
    vm_mesh_stats st;
    memset(&st, 0, sizeof st);
    vm_mesh_init(mesh, o->elements == VM_HEX8 ? VM_HEX8 : VM_TET4);
    vm_status s = vm__mesh_options_check(o, err);
    if (s) return s;
    s = vm__material_check(v, o->has_lo, o->lo, o->has_hi, o->hi, o->cell_size, "mesh", err);
    if (s) return s;
    if (o->graded) {
        s = vm__mesh_graded(v, o, mesh, &st, err);
        st.seconds = vm__now() - t0;
        if (stats) *stats = st;
        return s;
    }

    /* Sampling grid: the volume itself, or a trilinear resampling with cell size ~S. */
    vm__grid g;
    memset(&g, 0, sizeof g);
    float *resampled = NULL;
    double step[3];
    if (o->full_nz > 0) {
        /* An adaptive crop starts on a whole-grid plane where the octree's blocks are those
         * of the whole grid (the tet splits take their parity in the whole grid's frame). */
        int64_t align = o->adaptive ? (int64_t)1 << o->max_level : 1;
        s = crop_grid(v, o, align, g.n, &g.f, &resampled, step, &g.off[2], err);
    } else if (o->z_offset) {
        s = vm_error_set(err, VM_ERR_ARG, "mesh: a z offset needs the whole volume's planes");
    } else {
        s = vm__sampling_grid(v, o->cell_size, "mesh", g.n, &g.f, &resampled, step, err);
    }
    if (s) return s;
    g.lo = o->lo;
    g.hi = o->hi;
    g.has_lo = o->has_lo;
    g.has_hi = o->has_hi;
    /* adaptive hexes: uniform hexes first, then one coarsening level (dc_hex_adaptive.c) */
    g.max_level = o->adaptive && o->elements != VM_HEX8 ? o->max_level : 0;
    g.hexes = o->elements == VM_HEX8;
    g.error = o->error;
    /* the lift's frame: index to world, linear part, with the sampling step */
    g.lift = !g.hexes;
    double vf[3][3];
    vm__volume_frame(v, vf);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            g.frame[3 * r + c] =
                (o->crop_frame ? o->crop_frame[3 * r + c] : vf[r][c]) * step[c];
    /* the caller's progress, forwarded through a meter that the stages below poll */
    vm__meter pm;
    vm__meter_wrap(&pm, o->progress, o->progress_user, "contour", 4.0);
    g.progress = o->progress ? vm__meter_forward : NULL;
    g.progress_user = &pm;
    /* adaptive hexes: the coarsest sampling grid that keeps the shape (hex_base.c); on it
     * no interior coarsening (its transitions stay below 0.5 after the pass) */
    double base_step = 1;
    if (g.hexes && o->adaptive && o->full_nz <= 0 && o->cell_size == 1 && !resampled)
        s = vm__hex_base_grid(v, o, &g, &resampled, step, &base_step, err);
    if (s) return s;

    vm__tet_soup soup;
    memset(&soup, 0, sizeof soup);
    s = g.hexes ? vm__dual_contour_hexes(&g, &soup, &st, err)
                : vm__dual_contour_tets(&g, &soup, &st, err);
    /* --max-level L: up to L coarsening levels, blocks of 3^L cells */
    int64_t org[3] = {0, 0, 0}; /* each level's block grid origin (cells), from the last */
    for (int64_t l = 1, sc = 1; !s && g.hexes && o->adaptive && base_step == 1 && l <= o->max_level;
         l++, sc *= 3) {
        size_t before = soup.ntets;
        if ((s = vm__progress_check(g.progress, g.progress_user, "mesh", err))) break;
        s = vm__hex_adapt(&soup, g.n, sc, org, &st, err);
        if (soup.ntets == before) break;
    }
    free(resampled);
    /* (a stage may have gone on after a request it did not read) */
    if (!s && vm__meter_poll(&pm)) s = vm__cancelled(err, "mesh");
    if (s == VM_ERR_EMPTY)
        s = vm_error_set(err, VM_ERR_EMPTY, "mesh: no grid point is in the material");
    if (s) {
        free(soup.tets);
        free(soup.tets32);
        free(soup.rep_pos);
        free(soup.lift_id);
        free(soup.lift_pos);
        return s;
    }

    s = vm__soup_to_mesh(&soup, v, g.n, g.off[2], step, mesh, err);
    if (s) return s;
    st.seconds = vm__now() - t0;
    if (stats) *stats = st;
    return VM_OK;
}
