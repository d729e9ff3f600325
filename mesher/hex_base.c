/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/hex_base.c — the sampling grid of adaptive hexahedra: the coarsest of a few steps
 * (voxels between grid points) at which the uniform dual-contouring hexes still have the
 * shape of the full-resolution ones — the same boundary Euler characteristic, components and
 * boundary components, a closed boundary, the volume within base_volume_tol and the boundary
 * within base_distance_tol voxel of the isosurface — so that the boundary layer, which the
 * interior coarsening (dc_hex_adaptive.c) never touches, is coarse too where the surface is
 * smooth and thick enough (see docs/ALGORITHMS.md, "Adaptive hexahedra"). */
#include "../core/core.h"
#include "mesher_internal.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The steps tried, coarsest first: 1.5^3 = 3.4, 1.4^3 = 2.7 and 1.3^3 = 2.2 times fewer grid
 * points (hexes) than the voxels; the first that keeps the shape is taken. */
static const double base_steps[] = {1.5, 1.4, 1.3};
/* A step keeps the shape when, after the quality pass, its mesh has the topology of the
 * full-resolution raw mesh, no inverted hex, min scaled Jacobian at least base_min_sj (the
 * pass's target, which the uniform phantoms reach), the volume within base_volume_tol of the
 * full-resolution raw mesh's (coarse boundary quads cut inside convex parts: torus 64^3 at
 * step 1.5 -0.46% raw, the genus-3 tubes, 3.5 voxels thick, -1.4%; the pass keeps the
 * volume to a tenth of a percent; the voxel grid's own mesh is up to 0.5% below the
 * analytic volume on the genus-3 solid, so 0.4% keeps both within 1%) and its boundary within base_distance_tol voxel of the
 * isosurface both ways. The pass is run because the raw distance does not tell: the
 * dual-contouring relaxation of tangled hexes moves vertices toward their cells' centres,
 * and the pass brings them back on some meshes and not on others (torus 96^3: raw 0.61 voxel
 * at step 1, 0.36 after the pass; 1.04 at step 1.5, 1.04 after the pass). The pass here is
 * the one `volmesh mesh` runs after, with the same options, so the mesh it checks is the
 * mesh made (genus-3 96^3 at step 1.5: 0.4989 voxel). */
static const double base_min_sj = 0.5, base_volume_tol = 0.004, base_distance_tol = 0.499;

/* The volume's slope is measured with the material grown by shift_probe voxels; a shift
 * larger than shift_max (voxels) is not tried. */
static const double shift_probe = 0.1, shift_max = 0.25;
/* A volume off by more than this share is mended (torus 64^3 at step 1.5: -0.46% plain). */
static const double base_volume_aim = 0.002;

/* The grid of one axis of len samples at step s exactly, from sample 0 on: *m points, the
 * last at or below len - 1 (so that padding the volume past the material gives the same
 * points: tests/mesher/test_mesh_padded.c; material touching the far face loses the sliver
 * past the last point, and the volume check then rules the step out). */
static void base_axis(int64_t len, double s, int64_t *m, double *step) {
    *m = (int64_t)floor((double)(len - 1) / s + 1e-9) + 1;
    *step = s;
    if (*m < 2) {
        *m = 2;
        *step = (double)(len - 1);
    }
}

/* v's trilinear field at index position p (inside its box) and its gradient g. */
static double base_field(const vm_volume *v, const double p[3], double g[3]) {
    double f[3];
    int64_t i[3];
    for (int a = 0; a < 3; a++) {
        i[a] = (int64_t)floor(p[a]);
        if (i[a] > v->dims[a] - 2) i[a] = v->dims[a] - 2;
        if (i[a] < 0) i[a] = 0;
        f[a] = p[a] - (double)i[a];
    }
    double val = 0;
    g[0] = g[1] = g[2] = 0;
    for (int c = 0; c < 8; c++) {
        int d[3] = {c & 1, (c >> 1) & 1, c >> 2};
        double s =
            v->data[(i[0] + d[0]) + v->dims[0] * ((i[1] + d[1]) + v->dims[1] * (i[2] + d[2]))];
        double w[3], dw[3];
        for (int a = 0; a < 3; a++) {
            w[a] = d[a] ? f[a] : 1 - f[a];
            dw[a] = d[a] ? 1 : -1;
        }
        val += s * w[0] * w[1] * w[2];
        g[0] += s * dw[0] * w[1] * w[2];
        g[1] += s * w[0] * dw[1] * w[2];
        g[2] += s * w[0] * w[1] * dw[2];
    }
    return val;
}

/* v resampled on n points per axis, step[] voxels apart (*out, owned by the caller), its
 * material grown by about shift voxels: f + shift |grad f| with a lower bound only, f - shift
 * |grad f| with an upper bound only (shift 0: the plain trilinear samples). */
static vm_status base_resample(const vm_volume *v, const vm_mesh_options *o, const int64_t n[3],
                               const double step[3], double shift, float **out, vm_error *err) {
    size_t count;
    vm_status s = vm__check_dims(n, sizeof(float), "mesh", &count, err);
    if (s) return s;
    float *r = malloc(count * sizeof *r);
    if (!r) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    double sg = o->has_lo ? 1 : -1;
    size_t idx = 0;
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            for (int64_t i = 0; i < n[0]; i++) {
                double p[3] = {(double)i * step[0], (double)j * step[1], (double)k * step[2]}, g[3];
                double f = base_field(v, p, g);
                if (shift != 0) f += sg * shift * sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
                r[idx++] = (float)f;
            }
    *out = r;
    return VM_OK;
}

/* The uniform hexes of grid g (points step[] voxels apart) as a mesh, checked: *raw; with
 * pass set, the quality pass (vm_mesh_improve_hexes, default options, v's material) run on it
 * too, checked again: *done, and its boundary's distance to v's isosurface *dist. */
static vm_status base_trial(const vm_volume *v, const vm__grid *g, const double step[3],
                            const vm_mesh_options *o, vm_mesh_report *raw, int pass,
                            vm_mesh_report *done, vm_surface_distance *dist, vm_error *err) {
    vm__tet_soup soup;
    memset(&soup, 0, sizeof soup);
    vm_mesh_stats st;
    memset(&st, 0, sizeof st);
    vm_mesh m;
    vm_mesh_init(&m, VM_HEX8);
    vm_status s = vm__dual_contour_hexes(g, &soup, &st, err);
    if (s) {
        free(soup.tets);
        free(soup.tets32);
        free(soup.rep_pos);
        return s;
    }
    s = vm__soup_to_mesh(&soup, v, g->n, 0, step, &m, err);
    if (!s) s = vm_mesh_check(&m, raw, err);
    if (!s && pass) {
        vm_hex_improve_options io;
        vm_hex_improve_options_default(&io);
        io.lo = o->lo;
        io.hi = o->hi;
        io.has_lo = o->has_lo;
        io.has_hi = o->has_hi;
        vm_hex_improve_report ir;
        s = vm_mesh_improve_hexes(&m, v, &io, &ir, err);
        if (!s) s = vm_mesh_check(&m, done, err);
        if (!s)
            s = vm_mesh_surface_distance(&m, v, o->lo, o->has_lo, o->hi, o->has_hi, dist, err);
    }
    vm_mesh_free(&m);
    return s;
}

/* 1 when a raw trial t has the topology of the full-resolution raw mesh r. */
static int base_topology(const vm_mesh_report *r, const vm_mesh_report *t) {
    return t->cells > 0 && t->boundary_closed && t->boundary_euler == r->boundary_euler &&
           t->components == r->components && t->boundary_components == r->boundary_components;
}

/* 1 when a trial after the pass (d: its report, dist) keeps the shape of the
 * full-resolution raw mesh r: its topology, no inverted hex, min scaled Jacobian at least
 * base_min_sj, volume within base_volume_tol, boundary within base_distance_tol; and saves
 * hexes: fewer than r has (a plate 1.2 voxels thick at 64^3 kept its shape at step 1.4 in
 * 1 024 raw hexes, but only with the pass's pillow layer round all of them: 3 200 hexes
 * against 1 936 uniform, which need no layer). */
static int base_keeps(const vm_mesh_report *r, const vm_mesh_report *d,
                      const vm_surface_distance *dist) {
    if (!base_topology(r, d) || d->inverted || !(d->min_scaled_jacobian >= base_min_sj))
        return 0;
    if (d->cells >= r->cells) return 0;
    if (!(fabs(d->volume - r->volume) <= base_volume_tol * fabs(r->volume))) return 0;
    double vox = dist->voxel > 0 ? dist->voxel : 1;
    return dist->hausdorff / vox <= base_distance_tol;
}

/* One trial of step k's grid (n points, st apart) with the material grown by shift:
 * *f its samples (NULL when the trial failed), *topo whether its raw mesh has the topology
 * of the full-resolution raw mesh full, *vol its raw volume; with pass set, *keeps whether
 * it keeps the shape after the quality pass (base_keeps).
 * Only running out of memory or a cancel is an error. */
static vm_status base_try(const vm_volume *v, const vm_mesh_options *o, vm__grid *t,
                          const int64_t n[3], const double st[3], double shift, int pass,
                          const vm_mesh_report *full, float **f, int *keeps, int *topo,
                          double *vol, vm_error *err) {
    *f = NULL;
    *keeps = *topo = 0;
    vm_status s = base_resample(v, o, n, st, shift, f, err);
    if (s) return s;
    memcpy(t->n, n, sizeof t->n);
    t->f = *f;
    vm_mesh_report raw, done;
    vm_surface_distance d;
    vm_error terr;
    /* a trial that fails (no grid point inside, say) only rules the grid out */
    vm_status ts = base_trial(v, t, st, o, &raw, pass, &done, &d, &terr);
    if (ts == VM_OK) {
        *topo = base_topology(full, &raw);
        *vol = raw.volume;
        *keeps = pass && *topo && base_keeps(full, &done, &d);
    }
    if (ts == VM_ERR_NOMEM || ts == VM_ERR_CANCELLED) {
        free(*f);
        *f = NULL;
        if (err) *err = terr;
        return ts;
    }
    if (ts != VM_OK || !*topo) {
        free(*f);
        *f = NULL;
    }
    return VM_OK;
}

vm_status vm__hex_base_grid(const vm_volume *v, const vm_mesh_options *o, vm__grid *g,
                            float **owned, double step[3], double *chosen, vm_error *err) {
    if (chosen) *chosen = 1;
    vm__grid t = *g;
    t.progress = NULL;
    t.progress_user = NULL;
    t.max_level = 0;
    vm_mesh_report full, unused;
    vm_surface_distance ud;
    const double one[3] = {1, 1, 1};
    vm_status s = base_trial(v, &t, one, o, &full, 0, &unused, &ud, err);
    if (s || !full.cells) return s;
    /* the volume can be mended with a lower or an upper bound alone */
    int mend = o->has_lo != o->has_hi;
    for (size_t k = 0; k < sizeof base_steps / sizeof base_steps[0]; k++) {
        int64_t n[3];
        double st[3];
        for (int a = 0; a < 3; a++)
            base_axis(v->dims[a], base_steps[k], &n[a], &st[a]);
        /* the plain samples; where the raw volume is off by more than base_volume_aim, first
         * the material grown by the secant's shift (a raw trial at shift_probe gives the
         * volume's slope); the first that keeps the shape after the pass is taken */
        float *f = NULL, *fp = NULL;
        int keeps = 0, topo = 0, kp = 0, tp = 0;
        double v0 = 0, v1 = 0;
        s = base_try(v, o, &t, n, st, 0, 0, &full, &f, &keeps, &topo, &v0, err);
        if (s) return s;
        free(f);
        if (!topo) continue;
        int plain = 1;
        if (mend && fabs(v0 - full.volume) > base_volume_aim * fabs(full.volume)) {
            s = base_try(v, o, &t, n, st, shift_probe, 0, &full, &fp, &kp, &tp, &v1, err);
            free(fp);
            fp = NULL;
            double shift = v1 > v0 ? shift_probe * (full.volume - v0) / (v1 - v0) : 0;
            if (!s && v1 > v0 && fabs(shift) <= shift_max) {
                s = base_try(v, o, &t, n, st, shift, 1, &full, &fp, &kp, &tp, &v1, err);
                if (!s && fp && kp) {
                    f = fp;
                    keeps = 1;
                    plain = 0;
                } else {
                    free(fp);
                }
            }
            if (s) return s;
        }
        if (plain) {
            s = base_try(v, o, &t, n, st, 0, 1, &full, &f, &keeps, &topo, &v0, err);
            if (s) return s;
        }
        if (f && keeps) {
            memcpy(g->n, n, sizeof g->n);
            g->f = f;
            *owned = f;
            memcpy(step, st, 3 * sizeof(double));
            if (chosen) *chosen = base_steps[k];
            return VM_OK;
        }
        free(f);
    }
    return VM_OK;
}
