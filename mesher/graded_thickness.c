/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_thickness.c — sizes from the local thickness of the material (--min-layers
 * N): no edge longer than the thickness over N, so that no element spans a thin part.
 *
 * The thickness at a voxel is the diameter of the largest ball of inside voxels that holds
 * it (Hildebrand and Rüegsegger's local thickness), measured on voxel centres: the distance
 * from each inside voxel to the nearest outside voxel (an exact Euclidean distance transform
 * with the volume's spacing, by lower envelopes of parabolas, Felzenszwalb and Huttenlocher
 * 2012) gives each voxel's ball; every ball that no neighbour's ball holds paints twice its
 * radius on the voxels inside it, the largest winning. Balls as wide as the cap (N times
 * half the largest size that can matter) are not painted: the voxels within the cap of a
 * voxel at least the cap deep (the material opened by a ball of that radius, by a second
 * distance transform) get no bound. The bound joins the size field's per-block minima
 * (gr_field.bsize). */
#include "../core/core.h"
#include "graded_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The squared distance transform along one line of n samples (stride st) with spacing s:
 * d[q] = min over p of f[p] + ((q - p) s)^2. v, z, g: scratch of n, n + 1, n entries. */
static void edt_line(float *d, int64_t n, int64_t st, double s, int64_t *v, double *z,
                     double *g) {
    for (int64_t q = 0; q < n; q++)
        g[q] = d[q * st];
    int64_t k = -1;
    for (int64_t q = 0; q < n; q++) {
        if (!isfinite(g[q])) continue;
        double xq = (double)q * s;
        for (;;) {
            if (k < 0) {
                v[0] = q;
                z[0] = -INFINITY;
                z[1] = INFINITY;
                k = 0;
                break;
            }
            double xv = (double)v[k] * s;
            double x = ((g[q] + xq * xq) - (g[v[k]] + xv * xv)) / (2 * (xq - xv));
            if (x <= z[k]) {
                k--;
                continue;
            }
            k++;
            v[k] = q;
            z[k] = x;
            z[k + 1] = INFINITY;
            break;
        }
    }
    if (k < 0) return; /* no finite sample on the line: all stay infinite */
    int64_t j = 0;
    for (int64_t q = 0; q < n; q++) {
        double xq = (double)q * s;
        while (z[j + 1] < xq)
            j++;
        double dx = xq - (double)v[j] * s;
        d[q * st] = (float)(g[v[j]] + dx * dx);
    }
}

/* The squared distance transform of a whole grid of f's dims and spacing, in place: the three
 * axes' lines in turn (the transform is separable). */
static void edt(const gr_field *f, float *d, int64_t *v, double *z, double *g) {
    const int64_t *n = f->n;
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            edt_line(d + n[0] * (j + n[1] * k), n[0], 1, f->sp[0], v, z, g);
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t i = 0; i < n[0]; i++)
            edt_line(d + i + n[0] * n[1] * k, n[1], n[0], f->sp[1], v, z, g);
    for (int64_t j = 0; j < n[1]; j++)
        for (int64_t i = 0; i < n[0]; i++)
            edt_line(d + i + n[0] * j, n[2], n[0] * n[1], f->sp[2], v, z, g);
}

vm_status vm__gr_thickness_blocks(gr_field *f, int layers, double cap, vm_error *err) {
    const int64_t *n = f->n;
    size_t nv = (size_t)(n[0] * n[1] * n[2]);
    int64_t nmax = n[0] > n[1] ? n[0] : n[1];
    if (n[2] > nmax) nmax = n[2];
    float *d = malloc(nv * sizeof *d + 1), *t = malloc(nv * sizeof *t + 1);
    int64_t *v = malloc((size_t)nmax * sizeof *v + 1);
    double *z = malloc((size_t)(nmax + 1) * sizeof *z), *g = malloc((size_t)nmax * sizeof *g);
    size_t nb = (size_t)(f->nb[0] * f->nb[1] * f->nb[2]);
    if (!f->bsize) {
        f->bsize = malloc(nb * sizeof *f->bsize);
        if (f->bsize)
            for (size_t i = 0; i < nb; i++)
                f->bsize[i] = INFINITY;
    }
    if (!d || !t || !v || !z || !g || !f->bsize) {
        free(d), free(t), free(v), free(z), free(g);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for --min-layers");
    }
    /* outside voxels 0, inside infinite; then the three passes */
    for (size_t i = 0; i < nv; i++) {
        d[i] = vm__gr_phi_value(f, f->v->data[i]) >= 0 ? INFINITY : 0.0f;
    }
    edt(f, d, v, z, g);
    double smin = fmin(f->sp[0], fmin(f->sp[1], f->sp[2]));
    /* the voxels of balls wider than the cap: those within cap of a voxel at least cap deep
     * (the opening of the material by a ball of radius cap), marked -INFINITY in t (a
     * diameter beyond any bound) */
    for (size_t i = 0; i < nv; i++)
        t[i] = d[i] >= cap * cap && isfinite(d[i]) ? 0.0f : INFINITY;
    edt(f, t, v, z, g);
    double reach = cap + 0.5 * smin;
    for (size_t i = 0; i < nv; i++)
        t[i] = d[i] > 0 && t[i] <= reach * reach ? -INFINITY : INFINITY;
    /* each maximal ball (no 26-neighbour's ball holds it, with half a voxel of slack for the
     * grid) paints its diameter over its voxels; the largest wins (kept as -diameter in t,
     * INFINITY where no ball reached) */
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            for (int64_t i = 0; i < n[0]; i++) {
                size_t at = (size_t)(i + n[0] * (j + n[1] * k));
                if (!(d[at] > 0) || !isfinite(d[at])) continue;
                double r = sqrt((double)d[at]);
                if (r >= cap) continue; /* within the opening */
                int held = 0;
                for (int c = 0; c < 27 && !held; c++) {
                    int64_t di = c % 3 - 1, dj = c / 3 % 3 - 1, dk = c / 9 - 1;
                    int64_t x = i + di, y = j + dj, w = k + dk;
                    if (c == 13 || x < 0 || y < 0 || w < 0 || x >= n[0] || y >= n[1] || w >= n[2])
                        continue;
                    double ex = (double)di * f->sp[0], ey = (double)dj * f->sp[1],
                           ez = (double)dk * f->sp[2];
                    double q = d[(size_t)(x + n[0] * (y + n[1] * w))];
                    if (isfinite(q) && sqrt(q) >= r + sqrt(ex * ex + ey * ey + ez * ez) - 0.5 * smin)
                        held = 1;
                }
                if (held) continue;
                int64_t lo[3], hi[3], c0[3] = {i, j, k};
                for (int a = 0; a < 3; a++) {
                    int64_t m = (int64_t)floor(r / f->sp[a]);
                    lo[a] = c0[a] - m < 0 ? 0 : c0[a] - m;
                    hi[a] = c0[a] + m > n[a] - 1 ? n[a] - 1 : c0[a] + m;
                }
                float dia = (float)(2 * r);
                for (int64_t w = lo[2]; w <= hi[2]; w++)
                    for (int64_t y = lo[1]; y <= hi[1]; y++)
                        for (int64_t x = lo[0]; x <= hi[0]; x++) {
                            double ex = (double)(x - i) * f->sp[0], ey = (double)(y - j) * f->sp[1],
                                   ez = (double)(w - k) * f->sp[2];
                            /* (the ball's rim holds the outside voxel nearest its centre) */
                            size_t to = (size_t)(x + n[0] * (y + n[1] * w));
                            if (ex * ex + ey * ey + ez * ez >= r * r || !(d[to] > 0)) continue;
                            float *tt = &t[to];
                            if (!(*tt <= 0) || -*tt < dia) *tt = -dia;
                        }
            }
    /* per block: the least thickness over N, scaled as the size field is */
    for (int64_t bz = 0; bz < f->nb[2]; bz++)
        for (int64_t by = 0; by < f->nb[1]; by++)
            for (int64_t bx = 0; bx < f->nb[0]; bx++) {
                int64_t lo[3], hi[3];
                vm__gr_block_range(f, bx, by, bz, lo, hi);
                double mn = INFINITY;
                for (int64_t w = lo[2]; w <= hi[2]; w++)
                    for (int64_t y = lo[1]; y <= hi[1]; y++)
                        for (int64_t x = lo[0]; x <= hi[0]; x++) {
                            float tt = t[(size_t)(x + n[0] * (y + n[1] * w))];
                            if (tt <= 0 && -tt < mn) mn = -tt;
                        }
                float *bs = &f->bsize[(size_t)(bx + f->nb[0] * (by + f->nb[1] * bz))];
                double h = mn / layers;
                if (h < *bs) *bs = (float)h;
            }
    free(d), free(t), free(v), free(z), free(g);
    return VM_OK;
}
