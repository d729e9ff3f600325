/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_field.c — the material as a signed trilinear field in world lengths, with the
 * per-block minima and maxima that let the octree skip cells the surface does not cross. */
#include "../core/core.h"
#include "graded_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static double trilinear(const gr_field *f, double x, double y, double z) {
    const int64_t *n = f->n;
    int64_t i = (int64_t)floor(x), j = (int64_t)floor(y), k = (int64_t)floor(z);
    if (i > n[0] - 2) i = n[0] - 2;
    if (j > n[1] - 2) j = n[1] - 2;
    if (k > n[2] - 2) k = n[2] - 2;
    if (i < 0) i = 0;
    if (j < 0) j = 0;
    if (k < 0) k = 0;
    double fx = x - (double)i, fy = y - (double)j, fz = z - (double)k;
    const float *d = f->v->data + i + n[0] * (j + n[1] * k);
    int64_t sy = n[0], sz = n[0] * n[1];
    double c00 = d[0] + fx * (d[1] - d[0]);
    double c10 = d[sy] + fx * (d[sy + 1] - d[sy]);
    double c01 = d[sz] + fx * (d[sz + 1] - d[sz]);
    double c11 = d[sz + sy] + fx * (d[sz + sy + 1] - d[sz + sy]);
    double c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

double vm__gr_phi(const gr_field *f, const double u[3]) {
    double x[3];
    for (int d = 0; d < 3; d++) {
        x[d] = u[d] / f->sp[d];
        /* A hair of slack keeps points computed on the border plane inside. */
        double tol = 1e-9 * (double)f->n[d];
        if (x[d] < -tol || x[d] > (double)(f->n[d] - 1) + tol) return f->out;
        if (x[d] < 0) x[d] = 0;
        if (x[d] > (double)(f->n[d] - 1)) x[d] = (double)(f->n[d] - 1);
        /* A point on a voxel plane up to rounding (lattice points, computed in world units)
         * reads the voxels' values exactly: a voxel at the bound is inside, as the voxels'
         * topology counts it, where a rounding error of 1e-13 would read it outside. */
        double r = nearbyint(x[d]);
        if (fabs(x[d] - r) <= 1e-9 * (1 + r)) x[d] = r;
    }
    return vm__gr_phi_value(f, trilinear(f, x[0], x[1], x[2]));
}

static vm_status size_blocks(gr_field *f, const vm_volume *sf, vm_error *err);

vm_status vm__gr_field_init(gr_field *f, const vm_volume *v, const vm_mesh_options *o,
                            vm_error *err) {
    memset(f, 0, sizeof *f);
    f->v = v;
    f->size_scale = 1;
    for (int d = 0; d < 3; d++) {
        f->n[d] = v->dims[d];
        f->sp[d] = v->spacing[d];
        /* Block b holds voxels b*B .. b*B + B (the last one shared), so that every trilinear
         * cell lies in one block. */
        f->nb[d] = (f->n[d] - 1 + GR_BLOCK - 1) / GR_BLOCK;
        if (f->nb[d] < 1) f->nb[d] = 1;
    }
    f->lo = o->lo;
    f->hi = o->hi;
    f->has_lo = o->has_lo;
    f->has_hi = o->has_hi;
    size_t nb = (size_t)(f->nb[0] * f->nb[1] * f->nb[2]);
    f->bmin = malloc(nb * sizeof *f->bmin);
    f->bmax = malloc(nb * sizeof *f->bmax);
    if (!f->bmin || !f->bmax) {
        vm__gr_field_free(f);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the field's blocks");
    }
    double vmin = INFINITY, vmax = -INFINITY;
    for (int64_t bz = 0; bz < f->nb[2]; bz++)
        for (int64_t by = 0; by < f->nb[1]; by++)
            for (int64_t bx = 0; bx < f->nb[0]; bx++) {
                float mn = INFINITY, mx = -INFINITY;
                int64_t lo[3], hi[3];
                vm__gr_block_range(f, bx, by, bz, lo, hi);
                for (int64_t k = lo[2]; k <= hi[2]; k++)
                    for (int64_t j = lo[1]; j <= hi[1]; j++) {
                        const float *row = v->data + f->n[0] * (j + f->n[1] * k);
                        for (int64_t i = lo[0]; i <= hi[0]; i++) {
                            if (row[i] < mn) mn = row[i];
                            if (row[i] > mx) mx = row[i];
                        }
                    }
                size_t at = (size_t)(bx + f->nb[0] * (by + f->nb[1] * bz));
                f->bmin[at] = mn;
                f->bmax[at] = mx;
                if (mn < vmin) vmin = mn;
                if (mx > vmax) vmax = mx;
            }
    /* Outside the box: as far below the bound as the data reaches, so cuts next to the
     * border lie on the border plane. */
    double span = fabs(vm__gr_phi_value(f, vmin)) + fabs(vm__gr_phi_value(f, vmax));
    f->out = -(span > 0 ? span : 1.0);
    if (o->size_field) {
        vm_status s = size_blocks(f, o->size_field, err);
        if (s) {
            vm__gr_field_free(f);
            return s;
        }
    }
    if (o->min_layers > 0) {
        /* thicknesses up to 16 voxels (of the largest spacing) count, and none where the
         * bound would be above --max-edge */
        double smax = fmax(f->sp[0], fmax(f->sp[1], f->sp[2])), cap = 8 * smax;
        if (o->max_edge > 0) cap = fmin(cap, 0.5 * o->min_layers * o->max_edge);
        vm_status s = vm__gr_thickness_blocks(f, o->min_layers, cap, err);
        if (s) {
            vm__gr_field_free(f);
            return s;
        }
    }
    return VM_OK;
}

void vm__gr_field_free(gr_field *f) {
    free(f->bmin);
    free(f->bmax);
    free(f->bsize);
    f->bmin = f->bmax = f->bsize = NULL;
}

/* The size image's value at world point x (trilinear, clamped to its box). */
static double size_at(const vm_volume *sf, double inv[3][3], const double x[3]) {
    double w[3], u[3];
    int64_t i0[3];
    for (int r = 0; r < 3; r++)
        w[r] = x[r] - sf->origin[r];
    for (int r = 0; r < 3; r++) {
        u[r] = inv[r][0] * w[0] + inv[r][1] * w[1] + inv[r][2] * w[2];
        double top = (double)(sf->dims[r] - 1);
        if (!(u[r] > 0)) u[r] = 0; /* NaN too */
        if (u[r] > top) u[r] = top;
        i0[r] = (int64_t)floor(u[r]);
        if (i0[r] > sf->dims[r] - 2) i0[r] = sf->dims[r] - 2;
        if (i0[r] < 0) i0[r] = 0;
        u[r] -= (double)i0[r];
    }
    double acc = 0;
    for (int c = 0; c < 8; c++) {
        int64_t p[3];
        double wt = 1;
        for (int r = 0; r < 3; r++) {
            int b = (c >> r) & 1;
            p[r] = i0[r] + b;
            if (p[r] > sf->dims[r] - 1) p[r] = sf->dims[r] - 1;
            wt *= b ? u[r] : 1 - u[r];
        }
        if (wt == 0) continue;
        acc += wt * (double)sf->data[p[0] + sf->dims[0] * (p[1] + sf->dims[1] * p[2])];
    }
    return acc;
}

/* The size field's least value per block, from its values at the voxels of the block. */
static vm_status size_blocks(gr_field *f, const vm_volume *sf, vm_error *err) {
    double inv[3][3], det;
    vm_status s = vm__frame_inverse(sf, "--size-field", inv, &det, err);
    if (s) return s;
    size_t nv = (size_t)(sf->dims[0] * sf->dims[1] * sf->dims[2]);
    for (size_t i = 0; i < nv; i++)
        if (!(sf->data[i] > 0 && sf->data[i] < 1e30))
            return vm_error_set(err, VM_ERR_ARG,
                                "--size-field: value %g at voxel %zu is not a length > 0",
                                (double)sf->data[i], i);
    size_t nb = (size_t)(f->nb[0] * f->nb[1] * f->nb[2]);
    f->bsize = malloc(nb * sizeof *f->bsize);
    if (!f->bsize)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the size field");
    for (int64_t bz = 0; bz < f->nb[2]; bz++)
        for (int64_t by = 0; by < f->nb[1]; by++)
            for (int64_t bx = 0; bx < f->nb[0]; bx++) {
                int64_t lo[3], hi[3];
                vm__gr_block_range(f, bx, by, bz, lo, hi);
                double mn = INFINITY;
                for (int64_t k = lo[2]; k <= hi[2]; k++)
                    for (int64_t j = lo[1]; j <= hi[1]; j++)
                        for (int64_t i = lo[0]; i <= hi[0]; i++) {
                            double ijk[3] = {(double)i, (double)j, (double)k}, x[3];
                            vm_volume_index_to_world(f->v, ijk, x);
                            double h = size_at(sf, inv, x);
                            if (h < mn) mn = h;
                        }
                f->bsize[(size_t)(bx + f->nb[0] * (by + f->nb[1] * bz))] = (float)mn;
            }
    return VM_OK;
}

double vm__gr_size_min(const gr_field *f, const double lo[3], const double hi[3]) {
    if (!f->bsize) return INFINITY;
    int64_t i0[3], i1[3];
    for (int d = 0; d < 3; d++) {
        double a = lo[d] / f->sp[d], b = hi[d] / f->sp[d];
        if (a < 0) a = 0;
        if (b > (double)(f->n[d] - 1)) b = (double)(f->n[d] - 1);
        if (b < a) b = a;
        i0[d] = (int64_t)floor(a) / GR_BLOCK;
        i1[d] = (int64_t)ceil(b) / GR_BLOCK;
        if (i0[d] >= f->nb[d]) i0[d] = f->nb[d] - 1;
        if (i1[d] >= f->nb[d]) i1[d] = f->nb[d] - 1;
    }
    double mn = INFINITY;
    for (int64_t z = i0[2]; z <= i1[2]; z++)
        for (int64_t y = i0[1]; y <= i1[1]; y++)
            for (int64_t x = i0[0]; x <= i1[0]; x++) {
                double h = f->bsize[(size_t)(x + f->nb[0] * (y + f->nb[1] * z))];
                if (h < mn) mn = h;
            }
    return mn * f->size_scale;
}
