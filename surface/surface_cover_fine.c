/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_cover_fine.c — the candidate surface of the disk-covering mesher: the zero
 * set of the piecewise-linear interpolant on the Kuhn subdivision of the padded grid (marching
 * tetrahedra), with its half-edge adjacency, components and Euler characteristics. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "surface_cover_internal.h"

/* The six Kuhn tetrahedra of a cell: corners 0, e_a, e_a + e_b, 7 for every order (a, b, c)
 * of the axes (corner bits: 1 x, 2 y, 4 z). Every tet edge joins corner c to a corner c | d
 * with more bits, so it is the edge (p, p + d) of the grid for a 0/1 vector d. */
static const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                               {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};

typedef struct {
    const vm__surface_grid *g;
    int64_t p[3];   /* padded sample counts: n + 2 */
    double pad;     /* the value of the padding layer */
    int32_t *eid[2]; /* vertex on edge (sample, direction 1..7) of two sample layers, -1 none */
    double *x;
    size_t nv, xcap;
    int32_t *f;
    size_t nf, fcap;
} builder;

/* Signed value at padded sample (i, j, k) (the grid sample (i-1, j-1, k-1)). */
static double sval(const builder *b, int64_t i, int64_t j, int64_t k) {
    const vm__surface_grid *g = b->g;
    i--, j--, k--;
    if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2]) return b->pad;
    return vm__surface_value(g, (double)g->f[i + g->n[0] * (j + g->n[1] * k)]);
}

/* Vertex on the grid edge from padded sample (i, j, k) along direction bits d. */
static vm_status edge_vertex(builder *b, int64_t i, int64_t j, int64_t k, int d, int32_t *out,
                             vm_error *err) {
    int32_t *slot = b->eid[k & 1] + 7 * (i + b->p[0] * j) + (d - 1);
    if (*slot >= 0) {
        *out = *slot;
        return VM_OK;
    }
    int64_t q[3] = {i + (d & 1), j + ((d >> 1) & 1), k + ((d >> 2) & 1)};
    double sa = sval(b, i, j, k), sb = sval(b, q[0], q[1], q[2]);
    /* The two ends have opposite signs. A sample exactly on the level (integer data at an
     * integer iso) counts as inside; the crossing stays 1/100 of the edge away from either
     * end so that the vertices of the edges around such a sample stay apart. */
    double t = sa / (sa - sb);
    if (t < 0.01) t = 0.01;
    if (t > 0.99) t = 0.99;
    if (b->nv >= INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: more than 2^31 fine vertices");
    vm_status s = vm__grow((void **)&b->x, &b->xcap, 3 * (b->nv + 1), sizeof(double), err);
    if (s) return s;
    double *x = b->x + 3 * b->nv;
    x[0] = (double)(i - 1) + t * (double)(d & 1);
    x[1] = (double)(j - 1) + t * (double)((d >> 1) & 1);
    x[2] = (double)(k - 1) + t * (double)((d >> 2) & 1);
    *slot = *out = (int32_t)b->nv++;
    return VM_OK;
}

static vm_status add_face(builder *b, int32_t a, int32_t c, int32_t d, vm_error *err) {
    vm_status s = vm__grow((void **)&b->f, &b->fcap, 3 * (b->nf + 1), sizeof(int32_t), err);
    if (s) return s;
    b->f[3 * b->nf] = a;
    b->f[3 * b->nf + 1] = c;
    b->f[3 * b->nf + 2] = d;
    b->nf++;
    return VM_OK;
}

static void corner_xyz(int c, double p[3]) {
    p[0] = c & 1;
    p[1] = (c >> 1) & 1;
    p[2] = (c >> 2) & 1;
}

/* Orientation of a polygon given by tet edges (u[e], w[e]) (corners), taken through the edge
 * midpoints: +1 when its Newell normal points from the inside corners to the outside ones. */
static int polygon_sign(int npts, const int *u, const int *w, const int *in) {
    double m[4][3], nrm[3] = {0, 0, 0}, ci[3] = {0, 0, 0}, co[3] = {0, 0, 0};
    int ni = 0, no = 0;
    for (int e = 0; e < npts; e++) {
        double a[3], c[3];
        corner_xyz(u[e], a);
        corner_xyz(w[e], c);
        for (int k = 0; k < 3; k++) m[e][k] = 0.5 * (a[k] + c[k]);
    }
    for (int e = 0; e < npts; e++) {
        const double *p = m[e], *q = m[(e + 1) % npts];
        nrm[0] += (p[1] - q[1]) * (p[2] + q[2]);
        nrm[1] += (p[2] - q[2]) * (p[0] + q[0]);
        nrm[2] += (p[0] - q[0]) * (p[1] + q[1]);
    }
    for (int c = 0; c < 8; c++) {
        if (in[c] < 0) continue;
        double p[3];
        corner_xyz(c, p);
        for (int k = 0; k < 3; k++) {
            if (in[c]) ci[k] += p[k];
            else co[k] += p[k];
        }
        if (in[c]) ni++;
        else no++;
    }
    double dot = 0;
    for (int k = 0; k < 3; k++) dot += nrm[k] * (co[k] / no - ci[k] / ni);
    return dot > 0 ? 1 : -1;
}

/* Marching tetrahedra over the cells of padded layer k (samples k and k+1). */
static vm_status cell_layer(builder *b, int64_t k, vm_error *err) {
    for (int64_t j = 0; j + 1 < b->p[1]; j++)
        for (int64_t i = 0; i + 1 < b->p[0]; i++) {
            double v[8];
            int nin = 0;
            for (int c = 0; c < 8; c++) {
                v[c] = sval(b, i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1));
                nin += v[c] >= 0;
            }
            if (nin == 0 || nin == 8) continue;
            for (int t = 0; t < 6; t++) {
                const int *q = kuhn[t];
                int in[8], ins[4], outs[4], a = 0, o = 0;
                for (int c = 0; c < 8; c++) in[c] = -1;
                for (int e = 0; e < 4; e++) {
                    in[q[e]] = v[q[e]] >= 0;
                    if (in[q[e]]) ins[a++] = q[e];
                    else outs[o++] = q[e];
                }
                if (a == 0 || a == 4) continue;
                int u[4], w[4], npts;
                if (a == 1 || a == 3) {
                    int lone = a == 1 ? ins[0] : outs[0];
                    const int *rest = a == 1 ? outs : ins;
                    npts = 3;
                    for (int e = 0; e < 3; e++) u[e] = lone, w[e] = rest[e];
                } else {
                    npts = 4;
                    u[0] = ins[0], w[0] = outs[0];
                    u[1] = ins[0], w[1] = outs[1];
                    u[2] = ins[1], w[2] = outs[1];
                    u[3] = ins[1], w[3] = outs[0];
                }
                int32_t id[4];
                for (int e = 0; e < npts; e++) {
                    int lo = u[e] < w[e] ? u[e] : w[e], hi = u[e] < w[e] ? w[e] : u[e];
                    vm_status s = edge_vertex(b, i + (lo & 1), j + ((lo >> 1) & 1),
                                              k + ((lo >> 2) & 1), hi ^ lo, id + e, err);
                    if (s) return s;
                }
                int sg = polygon_sign(npts, u, w, in);
                vm_status s;
                if (npts == 3) {
                    s = sg > 0 ? add_face(b, id[0], id[1], id[2], err)
                               : add_face(b, id[0], id[2], id[1], err);
                } else {
                    /* the shorter diagonal of the quad */
                    const double *x = b->x;
                    double d02 = 0, d13 = 0;
                    for (int c = 0; c < 3; c++) {
                        double e1 = x[3 * id[0] + c] - x[3 * id[2] + c];
                        double e2 = x[3 * id[1] + c] - x[3 * id[3] + c];
                        d02 += e1 * e1, d13 += e2 * e2;
                    }
                    int r = d02 <= d13 ? 0 : 1;
                    int32_t p0 = id[r], p1 = id[r + 1], p2 = id[(r + 2) % 4], p3 = id[(r + 3) % 4];
                    if (sg > 0) {
                        s = add_face(b, p0, p1, p2, err);
                        if (!s) s = add_face(b, p0, p2, p3, err);
                    } else {
                        s = add_face(b, p0, p2, p1, err);
                        if (!s) s = add_face(b, p0, p3, p2, err);
                    }
                }
                if (s) return s;
            }
        }
    return VM_OK;
}

void vm__cover_fine_free(vm__cover_fine *m) {
    free(m->x);
    free(m->f);
    free(m->fadj);
    free(m->off);
    free(m->nbr);
    free(m->hface);
    free(m->len);
    free(m->comp);
    free(m->comp_euler);
    memset(m, 0, sizeof *m);
}

/* Half-edge adjacency, components and their Euler characteristics. */
static vm_status adjacency(vm__cover_fine *m, vm_error *err) {
    size_t nv = m->nv, nf = m->nf;
    m->off = calloc(nv + 1, sizeof *m->off);
    m->nbr = malloc((3 * nf + 1) * sizeof *m->nbr);
    m->hface = malloc((3 * nf + 1) * sizeof *m->hface);
    m->len = malloc((3 * nf + 1) * sizeof *m->len);
    m->fadj = malloc((3 * nf + 1) * sizeof *m->fadj);
    m->comp = malloc((nv + 1) * sizeof *m->comp);
    if (!m->off || !m->nbr || !m->hface || !m->len || !m->fadj || !m->comp)
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (adjacency)");
    for (size_t t = 0; t < 3 * nf; t++) m->off[m->f[t] + 1]++;
    for (size_t v = 0; v < nv; v++) m->off[v + 1] += m->off[v];
    size_t *fill = malloc((nv + 1) * sizeof *fill);
    if (!fill) return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
    memcpy(fill, m->off, nv * sizeof *fill);
    for (size_t t = 0; t < nf; t++)
        for (int e = 0; e < 3; e++) {
            int32_t a = m->f[3 * t + e], c = m->f[3 * t + (e + 1) % 3];
            size_t h = fill[a]++;
            m->nbr[h] = c;
            m->hface[h] = (int32_t)t;
            double l2 = 0;
            for (int k = 0; k < 3; k++) {
                double d = m->x[3 * a + k] - m->x[3 * c + k];
                l2 += d * d;
            }
            m->len[h] = sqrt(l2);
        }
    free(fill);
    for (size_t t = 0; t < nf; t++)
        for (int e = 0; e < 3; e++) {
            int32_t a = m->f[3 * t + e], c = m->f[3 * t + (e + 1) % 3];
            m->fadj[3 * t + e] = -1;
            for (size_t h = m->off[c]; h < m->off[c + 1]; h++)
                if (m->nbr[h] == a) m->fadj[3 * t + e] = m->hface[h];
            if (m->fadj[3 * t + e] < 0)
                return vm_error_set(err, VM_ERR_INTERNAL,
                                    "surface cover: the fine surface has an open edge");
        }
    /* components by a breadth-first walk over the 1-rings */
    for (size_t v = 0; v < nv; v++) m->comp[v] = -1;
    int32_t *queue = malloc((nv + 1) * sizeof *queue);
    if (!queue) return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
    size_t nc = 0;
    for (size_t s = 0; s < nv; s++) {
        if (m->comp[s] >= 0) continue;
        size_t head = 0, tail = 0;
        queue[tail++] = (int32_t)s;
        m->comp[s] = (int32_t)nc;
        while (head < tail) {
            int32_t v = queue[head++];
            for (size_t h = m->off[v]; h < m->off[v + 1]; h++)
                if (m->comp[m->nbr[h]] < 0) {
                    m->comp[m->nbr[h]] = (int32_t)nc;
                    queue[tail++] = m->nbr[h];
                }
        }
        nc++;
    }
    free(queue);
    m->ncomp = nc;
    m->comp_euler = calloc(nc + 1, sizeof *m->comp_euler);
    if (!m->comp_euler) return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
    /* V - E + F = V - 3F/2 + F = V - F/2 on a closed surface */
    for (size_t v = 0; v < nv; v++) m->comp_euler[m->comp[v]] += 2;
    for (size_t t = 0; t < nf; t++) m->comp_euler[m->comp[m->f[3 * t]]] -= 1;
    for (size_t c = 0; c < nc; c++) m->comp_euler[c] /= 2;
    return VM_OK;
}

vm_status vm__cover_fine_build(const vm__surface_grid *g, const double *scale, vm__cover_fine *m,
                               vm_error *err) {
    memset(m, 0, sizeof *m);
    builder b;
    memset(&b, 0, sizeof b);
    b.g = g;
    for (int a = 0; a < 3; a++) b.p[a] = g->n[a] + 2;
    /* The padding is outside by far more than any sample is inside, so the crossing on an
     * edge to it sits 1/100 of the edge from the border sample: the material is closed by
     * flat faces on the box, 0.01 voxel outside it. */
    double amax = 0;
    size_t count = (size_t)(g->n[0] * g->n[1] * g->n[2]);
    for (size_t q = 0; q < count; q++) {
        double s = fabs(vm__surface_value(g, (double)g->f[q]));
        if (s > amax) amax = s;
    }
    b.pad = -(1e3 * amax + 1.0);
    size_t layer = (size_t)(b.p[0] * b.p[1]) * 7;
    b.eid[0] = malloc(layer * sizeof(int32_t));
    b.eid[1] = malloc(layer * sizeof(int32_t));
    vm_status s = VM_OK;
    if (!b.eid[0] || !b.eid[1]) s = vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
    if (!s) {
        memset(b.eid[0], 0xff, layer * sizeof(int32_t));
        memset(b.eid[1], 0xff, layer * sizeof(int32_t));
    }
    for (int64_t k = 0; !s && k + 1 < b.p[2]; k++) {
        s = cell_layer(&b, k, err);
        /* layer k is done: its slots become those of layer k + 2 */
        memset(b.eid[k & 1], 0xff, layer * sizeof(int32_t));
    }
    free(b.eid[0]);
    free(b.eid[1]);
    if (scale)
        for (size_t v = 0; v < b.nv; v++)
            for (int a = 0; a < 3; a++) b.x[3 * v + a] *= scale[a];
    m->x = b.x;
    m->f = b.f;
    m->nv = b.nv;
    m->nf = b.nf;
    m->cells_visited = (size_t)((b.p[0] - 1) * (b.p[1] - 1) * (b.p[2] - 1));
    if (!s) s = adjacency(m, err);
    if (s) vm__cover_fine_free(m);
    return s;
}

vm_status vm__cover_supersample(const vm__surface_grid *g, const int k[3], vm__surface_grid *out,
                                float **buf, vm_error *err) {
    *out = *g;
    *buf = NULL;
    if (k[0] == 1 && k[1] == 1 && k[2] == 1) return VM_OK;
    int64_t n[3];
    size_t total = 1;
    for (int a = 0; a < 3; a++) {
        if (k[a] < 1 || g->n[a] < 1)
            return vm_error_set(err, VM_ERR_ARG, "surface cover: supersampling %d along axis %d",
                                k[a], a);
        n[a] = (g->n[a] - 1) * k[a] + 1;
        if ((size_t)n[a] > SIZE_MAX / sizeof(float) / total)
            return vm_error_set(err, VM_ERR_NOMEM, "surface cover: supersampled grid too large");
        total *= (size_t)n[a];
    }
    float *f = malloc(total * sizeof *f);
    if (!f)
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (%zu supersamples)",
                            total);
    /* per axis: the lower sample and the weight of the upper one for each fine index */
    int64_t *lo[3] = {NULL, NULL, NULL};
    double *w[3] = {NULL, NULL, NULL};
    int ok = 1;
    for (int a = 0; a < 3; a++) {
        lo[a] = malloc((size_t)n[a] * sizeof *lo[a]);
        w[a] = malloc((size_t)n[a] * sizeof *w[a]);
        if (!lo[a] || !w[a]) ok = 0;
        for (int64_t i = 0; ok && i < n[a]; i++) {
            int64_t q = i / k[a], r = i % k[a];
            if (q >= g->n[a] - 1) q = g->n[a] - 1, r = 0; /* the last sample (or a 1-sample axis) */
            lo[a][i] = q;
            w[a][i] = (double)r / k[a];
        }
    }
    if (ok) {
        const int64_t sx = 1, sy = g->n[0], sz = g->n[0] * g->n[1];
        size_t p = 0;
        for (int64_t z = 0; z < n[2]; z++)
            for (int64_t y = 0; y < n[1]; y++)
                for (int64_t x = 0; x < n[0]; x++, p++) {
                    double wx = w[0][x], wy = w[1][y], wz = w[2][z];
                    const float *c = g->f + lo[0][x] * sx + lo[1][y] * sy + lo[2][z] * sz;
                    /* the upper neighbours only where their weight is non-zero (never past
                     * the last sample) */
                    int64_t dx = wx > 0 ? sx : 0, dy = wy > 0 ? sy : 0, dz = wz > 0 ? sz : 0;
                    double c00 = c[0] + wx * (c[dx] - c[0]);
                    double c10 = c[dy] + wx * (c[dy + dx] - c[dy]);
                    double c01 = c[dz] + wx * (c[dz + dx] - c[dz]);
                    double c11 = c[dz + dy] + wx * (c[dz + dy + dx] - c[dz + dy]);
                    double c0 = c00 + wy * (c10 - c00), c1 = c01 + wy * (c11 - c01);
                    f[p] = (float)(c0 + wz * (c1 - c0));
                }
    }
    for (int a = 0; a < 3; a++) free(lo[a]), free(w[a]);
    if (!ok) {
        free(f);
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (supersampling)");
    }
    for (int a = 0; a < 3; a++) out->n[a] = n[a];
    out->f = f;
    *buf = f;
    return VM_OK;
}
