/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_cover_improve.c — the improvement pass over the triangles the disk covering
 * kept from the fine surface (cell field cover_fine): edge contraction under the link
 * condition (Dey, Edelsbrunner, Guha, Nekhayev, "Topology preserving edge contraction",
 * 1999), edge flips, and vertex smoothing projected back onto the fine surface; every change
 * is accepted only within the error both ways, without a flip-over, a sharper crease or a
 * self-intersection. See docs/SURFACE_COVER.md, "The improvement pass". */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "surface_cover_internal.h"
#include "../core/self_intersect.h"

#define ASPECT 0.3      /* the paper's edge ratio: below it a triangle stays flagged */
#define MIN_ANGLE 15.0  /* degrees: the angle half of the quality (the ratio allows flat ones) */
#define TURN_COS 0.0    /* a changed triangle turns by at most 90 degrees */
#define BEND_FREE 0.293 /* 1 - cos 45 deg: bends up to 45 degrees are always allowed */
#define BEND_MAX 1.5    /* 1 - cos 120 deg: sharper only where a crease was already */
#define ROUNDS 8        /* contract, flip, smooth rounds at most */
#define MAXS 96         /* largest star a change may touch */
#define MAX_CELLS ((double)2e6) /* cells of the lookup grid at most */
/* The gain each change must bring to the star's worst quality q0 (else it only churns):
 * a contraction keeps CONTRACT_GAIN q0 (or 1), a flip reaches FLIP_GAIN q0, a move
 * q0 + MOVE_GAIN. */
#define CONTRACT_GAIN 1.02
#define FLIP_GAIN 1.05
#define MOVE_GAIN 1e-3
#define TINY 1e-9 /* rounding margin of lengths and qualities near 1 */
#define FLAT_NORMAL 1e-12 /* a normal shorter than this times the edges squared: degenerate */
#define BEND_ROUND 1e-12 /* a bend equal to the old one up to rounding is no sharper */
#define CROSS_PAD 1e-9   /* the box of a triangle looked up for crossings, padded for rounding */

typedef struct {
    int32_t *v;
    int32_t n, cap;
} vlist;

typedef struct {
    const vm__cover_fine *m;
    double eps;
    /* the mesh: positions in the scaled space of m, triangles, which may change */
    double *x;
    size_t nv, nt;
    int32_t *t;
    uint8_t *tdead, *fine, *smark;
    vlist *vt; /* live triangles at each vertex */
    /* one uniform grid for the fine faces, the fine vertices and the mesh triangles */
    double lo[3], h;
    int64_t gn[3];
    size_t *foff, *voff;
    int32_t *fitem, *vitem;
    vlist *cell; /* mesh triangles by bounding box (stale entries are harmless) */
    uint32_t *stamp;
    uint32_t now;
    /* the change under test: old star S is replaced by N, vertex ov moved to op */
    int32_t S[MAXS], N[3 * MAXS], norig[MAXS];
    double nref[3 * MAXS];
    int ns, nn;
    int32_t ov;
    double op[3], newq;
    int newbad; /* new triangles below the edge ratio 0.3 */
} imp;

/* The helpers below that allocate return VM_ERR_NOMEM without a message: the caller
 * sets it. Appends x to l. */
static vm_status vl_push(vlist *l, int32_t x) {
    if (l->n == l->cap) {
        int32_t cap = l->cap ? 2 * l->cap : 8;
        int32_t *p = realloc(l->v, (size_t)cap * sizeof *p);
        if (!p) return VM_ERR_NOMEM;
        l->v = p, l->cap = cap;
    }
    l->v[l->n++] = x;
    return VM_OK;
}

static void vl_remove(vlist *l, int32_t x) {
    for (int32_t i = 0; i < l->n; i++)
        if (l->v[i] == x) {
            l->v[i] = l->v[--l->n];
            return;
        }
}

/* -- geometry ------------------------------------------------------------------------ */

static const double *P(const imp *s, int32_t v) {
    return v == s->ov ? s->op : s->x + 3 * (size_t)v;
}

static double dist2(const double *a, const double *b) {
    double d = 0;
    for (int k = 0; k < 3; k++) d += (a[k] - b[k]) * (a[k] - b[k]);
    return d;
}

/* Unit normal of (a, b, c); 0 when degenerate. */
static int normal(const double *a, const double *b, const double *c, double n[3]) {
    double u[3], w[3];
    for (int k = 0; k < 3; k++) u[k] = b[k] - a[k], w[k] = c[k] - a[k];
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double scale =
        u[0] * u[0] + u[1] * u[1] + u[2] * u[2] + w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
    if (!(l > FLAT_NORMAL * scale) || !(l > 0)) return 0;
    for (int k = 0; k < 3; k++) n[k] /= l;
    return 1;
}

static double edge_ratio3(const double *a, const double *b, const double *c) {
    double l0 = dist2(a, b), l1 = dist2(b, c), l2 = dist2(c, a);
    double lo = fmin(l0, fmin(l1, l2)), hi = fmax(l0, fmax(l1, l2));
    return hi > 0 ? sqrt(lo / hi) : 0;
}

/* min(edge ratio / 0.3, smallest angle / 15 deg): 1 and above is good on both counts */
static double quality(const double *a, const double *b, const double *c) {
    const double *p[3] = {a, b, c};
    double l2[3], l[3];
    for (int e = 0; e < 3; e++) l2[e] = dist2(p[e], p[(e + 1) % 3]), l[e] = sqrt(l2[e]);
    double lo = fmin(l[0], fmin(l[1], l[2])), hi = fmax(l[0], fmax(l[1], l[2]));
    if (!(lo > 0)) return 0;
    double amin = INFINITY;
    for (int e = 0; e < 3; e++) {
        double u = l[(e + 1) % 3], w = l[(e + 2) % 3];
        double cs = (u * u + w * w - l2[e]) / (2 * u * w);
        amin = fmin(amin, acos(fmax(-1, fmin(1, cs))) * 180.0 / 3.14159265358979323846);
    }
    return fmin(lo / hi / ASPECT, amin / MIN_ANGLE);
}

/* Closest point q of triangle (a, b, c) to p (by the Voronoi regions of the triangle);
 * returns the squared distance. */
static double closest_tri(const double *p, const double *a, const double *b, const double *c,
                          double q[3]) {
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    for (int k = 0; k < 3; k++)
        ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k], bp[k] = p[k] - b[k],
        cp[k] = p[k] - c[k];
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap), d3 = DOT(ab, bp), d4 = DOT(ac, bp);
    double d5 = DOT(ab, cp), d6 = DOT(ac, cp);
#undef DOT
    double va = d3 * d6 - d5 * d4, vb = d5 * d2 - d1 * d6, vc = d1 * d4 - d3 * d2;
    double s = 0, t = 0; /* q = a + s ab + t ac */
    if (d1 <= 0 && d2 <= 0) {
        s = t = 0;
    } else if (d3 >= 0 && d4 <= d3) {
        s = 1, t = 0;
    } else if (d6 >= 0 && d5 <= d6) {
        s = 0, t = 1;
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        s = d1 / (d1 - d3);
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        t = d2 / (d2 - d6);
    } else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        s = 1 - t;
    } else {
        double den = va + vb + vc;
        s = den != 0 ? vb / den : 0, t = den != 0 ? vc / den : 0;
    }
    for (int k = 0; k < 3; k++) q[k] = a[k] + s * ab[k] + t * ac[k];
    return dist2(p, q);
}

/* -- the grid ------------------------------------------------------------------------ */

static int64_t gcell(const imp *s, int a, double x) {
    double f = floor((x - s->lo[a]) / s->h);
    if (f < 0) return 0;
    if (f >= (double)s->gn[a]) return s->gn[a] - 1;
    return (int64_t)f;
}

/* Cells of the box lo .. hi: i0[a] .. i1[a] */
static void grange(const imp *s, const double *lo, const double *hi, int64_t i0[3], int64_t i1[3]) {
    for (int a = 0; a < 3; a++) i0[a] = gcell(s, a, lo[a]), i1[a] = gcell(s, a, hi[a]);
}

static size_t gidx(const imp *s, int64_t i, int64_t j, int64_t k) {
    return (size_t)((k * s->gn[1] + j) * s->gn[0] + i);
}

#define FOR_CELLS(s, i0, i1, c)                                                                 \
    for (int64_t k_ = i0[2]; k_ <= i1[2]; k_++)                                               \
        for (int64_t j_ = i0[1]; j_ <= i1[1]; j_++)                                           \
            for (int64_t i_ = i0[0], c = gidx(s, i_, j_, k_); i_ <= i1[0]; i_++, c++)

static void tri_box(const double *const p[3], double r, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) {
        lo[a] = fmin(p[0][a], fmin(p[1][a], p[2][a])) - r;
        hi[a] = fmax(p[0][a], fmax(p[1][a], p[2][a])) + r;
    }
}

/* Enters triangle t in the cells of the lookup grid its box covers. */
static vm_status grid_insert(imp *s, int32_t t) {
    const int32_t *v = s->t + 3 * (size_t)t;
    const double *p[3] = {P(s, v[0]), P(s, v[1]), P(s, v[2])};
    double lo[3], hi[3];
    int64_t i0[3], i1[3];
    tri_box(p, 0, lo, hi);
    grange(s, lo, hi, i0, i1);
    FOR_CELLS(s, i0, i1, c) if (vl_push(&s->cell[c], t)) return VM_ERR_NOMEM;
    return VM_OK;
}

/* Static lists of the fine faces (by bounding box) or vertices per cell. */
static vm_status grid_static(imp *s, int faces, size_t **off_out, int32_t **item_out) {
    const vm__cover_fine *m = s->m;
    size_t ncell = (size_t)(s->gn[0] * s->gn[1] * s->gn[2]), n = faces ? m->nf : m->nv;
    size_t *off = calloc(ncell + 1, sizeof *off);
    if (!off) return VM_ERR_NOMEM;
    int32_t *item = NULL;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t f = 0; f < n; f++) {
            int64_t i0[3], i1[3];
            if (faces) {
                const int32_t *g = m->f + 3 * f;
                const double *p[3] = {m->x + 3 * (size_t)g[0], m->x + 3 * (size_t)g[1],
                                      m->x + 3 * (size_t)g[2]};
                double lo[3], hi[3];
                tri_box(p, 0, lo, hi);
                grange(s, lo, hi, i0, i1);
            } else {
                grange(s, m->x + 3 * f, m->x + 3 * f, i0, i1);
            }
            FOR_CELLS(s, i0, i1, c) {
                if (pass == 0) off[c + 1]++;
                else item[off[c]++] = (int32_t)f;
            }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++) off[c + 1] += off[c];
            if (!(item = malloc((off[ncell] + 1) * sizeof *item))) {
                free(off);
                return VM_ERR_NOMEM;
            }
        } else {
            for (size_t c = ncell; c > 0; c--) off[c] = off[c - 1];
            off[0] = 0;
        }
    }
    *off_out = off;
    *item_out = item;
    return VM_OK;
}

/* 1 when a fine face lies within r of p */
static int fine_near(const imp *s, const double *p, double r) {
    double lo[3] = {p[0] - r, p[1] - r, p[2] - r}, hi[3] = {p[0] + r, p[1] + r, p[2] + r}, q[3];
    int64_t i0[3], i1[3];
    grange(s, lo, hi, i0, i1);
    const vm__cover_fine *m = s->m;
    FOR_CELLS(s, i0, i1, c) for (size_t r_ = s->foff[c]; r_ < s->foff[c + 1]; r_++) {
        const int32_t *g = m->f + 3 * (size_t)s->fitem[r_];
        if (closest_tri(p, m->x + 3 * (size_t)g[0], m->x + 3 * (size_t)g[1],
                        m->x + 3 * (size_t)g[2], q) <= r * r)
            return 1;
    }
    return 0;
}

/* Closest point q on the fine surface within r of p, and the normal there; 0 when none. */
static int fine_project(const imp *s, const double *p, double r, double q[3], double n[3]) {
    double lo[3] = {p[0] - r, p[1] - r, p[2] - r}, hi[3] = {p[0] + r, p[1] + r, p[2] + r}, y[3];
    int64_t i0[3], i1[3];
    grange(s, lo, hi, i0, i1);
    const vm__cover_fine *m = s->m;
    double best = r * r;
    int32_t bf = -1;
    FOR_CELLS(s, i0, i1, c) for (size_t r_ = s->foff[c]; r_ < s->foff[c + 1]; r_++) {
        int32_t f = s->fitem[r_];
        const int32_t *g = m->f + 3 * (size_t)f;
        double d = closest_tri(p, m->x + 3 * (size_t)g[0], m->x + 3 * (size_t)g[1],
                               m->x + 3 * (size_t)g[2], y);
        if (d < best || (d == best && bf >= 0 && f < bf)) best = d, bf = f, memcpy(q, y, sizeof y);
    }
    if (bf < 0) return 0;
    const int32_t *g = m->f + 3 * (size_t)bf;
    return normal(m->x + 3 * (size_t)g[0], m->x + 3 * (size_t)g[1], m->x + 3 * (size_t)g[2], n);
}

/* -- the checks of a change ------------------------------------------------------------ */

/* Triangle t contains the directed edge u -> w */
static int has_dir(const int32_t *v, int32_t u, int32_t w) {
    for (int e = 0; e < 3; e++)
        if (v[e] == u && v[(e + 1) % 3] == w) return 1;
    return 0;
}

/* Live triangles outside S with the directed edge u -> w: how many, and the last. */
static int outside_dir(const imp *s, int32_t u, int32_t w, int32_t *which) {
    int n = 0;
    const vlist *l = &s->vt[u];
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        if (!s->smark[t] && has_dir(s->t + 3 * (size_t)t, u, w)) n++, *which = t;
    }
    return n;
}

/* The live triangle across the directed edge u -> w (the one with w -> u), -1 none. */
static int32_t across(const imp *s, int32_t u, int32_t w) {
    const vlist *l = &s->vt[w];
    for (int32_t j = 0; j < l->n; j++)
        if (has_dir(s->t + 3 * (size_t)l->v[j], w, u)) return l->v[j];
    return -1;
}

static int tri_normal(const imp *s, int32_t t, double n[3]) {
    const int32_t *v = s->t + 3 * (size_t)t;
    return normal(s->x + 3 * (size_t)v[0], s->x + 3 * (size_t)v[1], s->x + 3 * (size_t)v[2], n);
}

/* The bends (1 - cos of the angle between normals) of the old star: *one, the largest
 * across its edges; *two, the largest from its triangles to the neighbours of their
 * neighbours (a crease split in two by a sliver counts whole there). */
static void old_bend(const imp *s, double *one, double *two) {
    *one = *two = 0;
    for (int i = 0; i < s->ns; i++) {
        const int32_t *v = s->t + 3 * (size_t)s->S[i];
        double n[3], n2[3];
        if (!tri_normal(s, s->S[i], n)) {
            *one = *two = 2;
            return;
        }
        for (int e = 0; e < 3; e++) {
            int32_t g = across(s, v[e], v[(e + 1) % 3]);
            if (g < 0 || !tri_normal(s, g, n2)) continue;
            double b = 1 - (n[0] * n2[0] + n[1] * n2[1] + n[2] * n2[2]);
            *one = fmax(*one, b), *two = fmax(*two, b);
            const int32_t *w = s->t + 3 * (size_t)g;
            for (int f = 0; f < 3; f++) {
                int32_t h = across(s, w[f], w[(f + 1) % 3]);
                if (h < 0 || h == s->S[i] || !tri_normal(s, h, n2)) continue;
                *two = fmax(*two, 1 - (n[0] * n2[0] + n[1] * n2[1] + n[2] * n2[2]));
            }
        }
    }
}

/* Distance from p to the triangles of N (new positions), or of S (old) when old. */
static double star_dist(const imp *s, const double *p, int old) {
    double best = INFINITY, q[3];
    int n = old ? s->ns : s->nn;
    for (int i = 0; i < n; i++) {
        const int32_t *v = old ? s->t + 3 * (size_t)s->S[i] : s->N + 3 * i;
        const double *a = old ? s->x + 3 * (size_t)v[0] : P(s, v[0]);
        const double *b = old ? s->x + 3 * (size_t)v[1] : P(s, v[1]);
        const double *c = old ? s->x + 3 * (size_t)v[2] : P(s, v[2]);
        best = fmin(best, closest_tri(p, a, b, c, q));
    }
    return sqrt(best);
}

/* A live triangle outside S within r of p */
static int other_near(imp *s, const double *p, double r) {
    double lo[3] = {p[0] - r, p[1] - r, p[2] - r}, hi[3] = {p[0] + r, p[1] + r, p[2] + r}, q[3];
    int64_t i0[3], i1[3];
    grange(s, lo, hi, i0, i1);
    s->now++;
    FOR_CELLS(s, i0, i1, c) for (int32_t i = 0; i < s->cell[c].n; i++) {
        int32_t t = s->cell[c].v[i];
        if (s->tdead[t] || s->smark[t] || s->stamp[t] == s->now) continue;
        s->stamp[t] = s->now;
        const int32_t *v = s->t + 3 * (size_t)t;
        if (closest_tri(p, P(s, v[0]), P(s, v[1]), P(s, v[2]), q) <= r * r) return 1;
    }
    return 0;
}

static int crosses(const imp *s, const double *const a[3], const int32_t *ia,
                   const double *const b[3], const int32_t *ib) {
    vm_index ja[3] = {(vm_index)ia[0], (vm_index)ia[1], (vm_index)ia[2]};
    vm_index jb[3] = {(vm_index)ib[0], (vm_index)ib[1], (vm_index)ib[2]};
    (void)s;
    return vm__tri_pair_intersects(a, ja, b, jb);
}

/* The new triangles N: 1 when none is degenerate, turned past TURN_COS from its reference
 * normal or below qfloor, and the covered ones keep the edge ratio ASPECT; their unit
 * normals into nn, s->newq and s->newbad set. */
static int new_triangles_ok(imp *s, double qfloor, double *nn) {
    s->newq = INFINITY;
    s->newbad = 0;
    for (int i = 0; i < s->nn; i++) {
        const int32_t *v = s->N + 3 * i;
        const double *a = P(s, v[0]), *b = P(s, v[1]), *c = P(s, v[2]);
        if (!normal(a, b, c, nn + 3 * i)) return 0;
        const double *r = s->nref + 3 * i, *n = nn + 3 * i;
        if (n[0] * r[0] + n[1] * r[1] + n[2] * r[2] < TURN_COS) return 0;
        double q = quality(a, b, c);
        if (q < qfloor) return 0;
        double er = edge_ratio3(a, b, c);
        if (!s->fine[s->norig[i]] && er < ASPECT) return 0;
        s->newbad += er < ASPECT;
        s->newq = fmin(s->newq, q);
    }
    return 1;
}

/* 1 when every edge of N is there once each way (with the triangles outside the star) and
 * the sharpest bend across them (1 - cos, normals nn) is no sharper than the old star's
 * where above BEND_FREE, and above BEND_MAX only where the old star bent as much. */
static int manifold_no_sharper(imp *s, const double *nn) {
    double bend = 0;
    for (int i = 0; i < s->nn; i++) {
        const int32_t *v = s->N + 3 * i;
        for (int e = 0; e < 3; e++) {
            int32_t u = v[e], w = v[(e + 1) % 3], other = -1, twins = 0, same = 0;
            const double *n2 = NULL;
            double n3[3];
            for (int j = 0; j < s->nn; j++) {
                if (j != i && has_dir(s->N + 3 * j, u, w)) same++;
                if (has_dir(s->N + 3 * j, w, u)) twins++, n2 = nn + 3 * j;
            }
            same += outside_dir(s, u, w, &other);
            if (outside_dir(s, w, u, &other)) {
                twins++;
                const int32_t *g = s->t + 3 * (size_t)other;
                if (!normal(P(s, g[0]), P(s, g[1]), P(s, g[2]), n3)) return 0;
                n2 = n3;
            }
            if (same || twins != 1) return 0;
            const double *n = nn + 3 * i;
            bend = fmax(bend, 1 - (n[0] * n2[0] + n[1] * n2[1] + n[2] * n2[2]));
        }
    }
    if (bend > BEND_FREE) {
        double one, two;
        old_bend(s, &one, &two);
        if (bend > two + BEND_ROUND || (bend > BEND_MAX && bend > one + BEND_ROUND)) return 0;
    }
    return 1;
}

/* 1 when N lies within eps of the fine surface (sampled as in the refinement) and the fine
 * vertices the old star covered lie within eps of N or of the triangles around. */
static int within_error(imp *s) {
    static const double bary[7][3] = {{1. / 3, 1. / 3, 1. / 3}, {.5, .5, 0}, {0, .5, .5},
                                      {.5, 0, .5}, {2. / 3, 1. / 6, 1. / 6},
                                      {1. / 6, 2. / 3, 1. / 6}, {1. / 6, 1. / 6, 2. / 3}};
    for (int i = 0; i < s->nn; i++) {
        const int32_t *v = s->N + 3 * i;
        const double *p[3] = {P(s, v[0]), P(s, v[1]), P(s, v[2])};
        for (int b = 0; b < 7; b++) {
            double q[3];
            for (int k = 0; k < 3; k++)
                q[k] = bary[b][0] * p[0][k] + bary[b][1] * p[1][k] + bary[b][2] * p[2][k];
            if (!fine_near(s, q, s->eps)) return 0;
        }
    }
    /* the fine surface within eps of the mesh: the fine vertices the old star covered */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < s->ns; i++)
        for (int e = 0; e < 3; e++) {
            const double *x = s->x + 3 * (size_t)s->t[3 * (size_t)s->S[i] + e];
            for (int a = 0; a < 3; a++)
                lo[a] = fmin(lo[a], x[a] - s->eps), hi[a] = fmax(hi[a], x[a] + s->eps);
        }
    int64_t i0[3], i1[3];
    grange(s, lo, hi, i0, i1);
    FOR_CELLS(s, i0, i1, c) for (size_t r = s->voff[c]; r < s->voff[c + 1]; r++) {
        const double *p = s->m->x + 3 * (size_t)s->vitem[r];
        if (star_dist(s, p, 0) > s->eps && star_dist(s, p, 1) <= s->eps &&
            !other_near(s, p, s->eps))
            return 0;
    }
    return 1;
}

/* 1 when no triangle of N crosses a live triangle around (outside the star) or another
 * triangle of N. */
static int no_crossing(imp *s) {
    for (int i = 0; i < s->nn; i++) {
        const int32_t *v = s->N + 3 * i;
        const double *p[3] = {P(s, v[0]), P(s, v[1]), P(s, v[2])};
        double blo[3], bhi[3];
        int64_t i0[3], i1[3];
        tri_box(p, CROSS_PAD, blo, bhi);
        grange(s, blo, bhi, i0, i1);
        s->now++;
        FOR_CELLS(s, i0, i1, c) for (int32_t j = 0; j < s->cell[c].n; j++) {
            int32_t t = s->cell[c].v[j];
            if (s->tdead[t] || s->smark[t] || s->stamp[t] == s->now) continue;
            s->stamp[t] = s->now;
            const int32_t *g = s->t + 3 * (size_t)t;
            const double *pg[3] = {P(s, g[0]), P(s, g[1]), P(s, g[2])};
            if (crosses(s, p, v, pg, g)) return 0;
        }
        for (int j = i + 1; j < s->nn; j++) {
            const int32_t *g = s->N + 3 * j;
            const double *pg[3] = {P(s, g[0]), P(s, g[1]), P(s, g[2])};
            if (crosses(s, p, v, pg, g)) return 0;
        }
    }
    return 1;
}

/* Whether the change S -> N passes: no degenerate or turned triangle, every new triangle's
 * quality at least qfloor (covered ones also keep the edge ratio 0.3), a manifold without
 * duplicate edges, no sharper crease; when full, also the error both ways and no crossing
 * (the costly part). Sets s->newq and s->newbad. */
static int acceptable(imp *s, double qfloor, int full) {
    double nn[3 * MAXS];
    if (!new_triangles_ok(s, qfloor, nn) || !manifold_no_sharper(s, nn)) return 0;
    if (!full) return 1;
    return within_error(s) && no_crossing(s);
}

/* -- the changes ------------------------------------------------------------------------ */

/* Adds the live triangles at v to S (once each); 0 when S would overflow. */
static int star_add(imp *s, int32_t v) {
    const vlist *l = &s->vt[v];
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        if (s->smark[t]) continue;
        if (s->ns == MAXS) return 0;
        s->smark[t] = 1;
        s->S[s->ns++] = t;
    }
    return 1;
}

static void star_clear(imp *s) {
    for (int i = 0; i < s->ns; i++) s->smark[s->S[i]] = 0;
    s->ns = s->nn = 0;
    s->ov = -1;
}

static double star_quality(const imp *s) {
    double q = INFINITY;
    for (int i = 0; i < s->ns; i++) {
        const int32_t *v = s->t + 3 * (size_t)s->S[i];
        q = fmin(q, quality(s->x + 3 * (size_t)v[0], s->x + 3 * (size_t)v[1],
                            s->x + 3 * (size_t)v[2]));
    }
    return q;
}

/* Triangles of S below the edge ratio 0.3 */
static int star_bad(const imp *s) {
    int n = 0;
    for (int i = 0; i < s->ns; i++) {
        const int32_t *v = s->t + 3 * (size_t)s->S[i];
        n += edge_ratio3(s->x + 3 * (size_t)v[0], s->x + 3 * (size_t)v[1],
                         s->x + 3 * (size_t)v[2]) < ASPECT;
    }
    return n;
}

/* The two triangles at edge a-b (a -> b in *t1), 0 when not an edge. */
static int edge_tris(const imp *s, int32_t a, int32_t b, int32_t *t1, int32_t *t2) {
    *t1 = *t2 = -1;
    const vlist *l = &s->vt[a];
    for (int32_t i = 0; i < l->n; i++) {
        const int32_t *v = s->t + 3 * (size_t)l->v[i];
        if (has_dir(v, a, b)) *t1 = l->v[i];
        if (has_dir(v, b, a)) *t2 = l->v[i];
    }
    return *t1 >= 0 && *t2 >= 0;
}

static int32_t third(const int32_t *v, int32_t a, int32_t b) {
    for (int e = 0; e < 3; e++)
        if (v[e] != a && v[e] != b) return v[e];
    return -1;
}

/* The link condition for contracting a-b with opposite vertices c, d: the vertices next to
 * both are exactly c and d, and a-b is not an edge of a tetrahedron. */
static int link_ok(const imp *s, int32_t a, int32_t b, int32_t c, int32_t d) {
    const vlist *la = &s->vt[a], *lb = &s->vt[b];
    if (la->n == 3 && lb->n == 3) return 0;
    for (int32_t i = 0; i < la->n; i++)
        for (int e = 0; e < 3; e++) {
            int32_t u = s->t[3 * (size_t)la->v[i] + e];
            if (u == a || u == b || u == c || u == d) continue;
            for (int32_t j = 0; j < lb->n; j++) {
                const int32_t *g = s->t + 3 * (size_t)lb->v[j];
                if (g[0] == u || g[1] == u || g[2] == u) return 0;
            }
        }
    return 1;
}

/* N := S with b renamed a, except the triangles t1, t2 (reference normals: the old ones). */
static void contract_star(imp *s, int32_t a, int32_t b, int32_t t1, int32_t t2) {
    s->nn = 0;
    for (int i = 0; i < s->ns; i++) {
        int32_t t = s->S[i];
        if (t == t1 || t == t2) continue;
        const int32_t *v = s->t + 3 * (size_t)t;
        for (int e = 0; e < 3; e++) s->N[3 * s->nn + e] = v[e] == b ? a : v[e];
        normal(s->x + 3 * (size_t)v[0], s->x + 3 * (size_t)v[1], s->x + 3 * (size_t)v[2],
               s->nref + 3 * s->nn);
        s->norig[s->nn++] = t;
    }
}

/* Makes N the triangles norig (they replace S; the others of S die). */
static vm_status apply(imp *s) {
    for (int i = 0; i < s->ns; i++) {
        int32_t t = s->S[i];
        for (int e = 0; e < 3; e++) vl_remove(&s->vt[s->t[3 * (size_t)t + e]], t);
        s->tdead[t] = 1;
    }
    if (s->ov >= 0) memcpy(s->x + 3 * (size_t)s->ov, s->op, sizeof s->op);
    s->ov = -1;
    for (int i = 0; i < s->nn; i++) {
        int32_t t = s->norig[i];
        memcpy(s->t + 3 * (size_t)t, s->N + 3 * i, 3 * sizeof(int32_t));
        s->tdead[t] = 0;
        for (int e = 0; e < 3; e++)
            if (vl_push(&s->vt[s->N[3 * i + e]], t)) return VM_ERR_NOMEM;
        if (grid_insert(s, t)) return VM_ERR_NOMEM;
    }
    return VM_OK;
}

/* Tries to contract a-b (both triangles at it kept fine) into the best of a, b and the
 * midpoint projected onto the fine surface. 1 when done, -1 out of memory. */
static int try_contract(imp *s, int32_t a, int32_t b) {
    int32_t t1, t2;
    if (!edge_tris(s, a, b, &t1, &t2) || !s->fine[t1] || !s->fine[t2]) return 0;
    int32_t c = third(s->t + 3 * (size_t)t1, a, b), d = third(s->t + 3 * (size_t)t2, a, b);
    if (!link_ok(s, a, b, c, d)) return 0;
    star_clear(s);
    if (!star_add(s, a) || !star_add(s, b)) {
        star_clear(s);
        return 0;
    }
    /* a contraction replaces every triangle of the star: below the good quality 1 it must
     * raise the worst one, or leave fewer triangles below the edge ratio 0.3 and the worst
     * one nearly as good (it removes a vertex, so this cannot cycle) */
    int bad0 = star_bad(s);
    double q0 = star_quality(s), qfloor = fmin(1, 0.95 * q0);
    double mid[3], q[3], fn[3], sn[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) mid[k] = 0.5 * (s->x[3 * (size_t)a + k] + s->x[3 * (size_t)b + k]);
    for (int i = 0; i < s->ns; i++) {
        const int32_t *v = s->t + 3 * (size_t)s->S[i];
        double n[3];
        if (normal(s->x + 3 * (size_t)v[0], s->x + 3 * (size_t)v[1], s->x + 3 * (size_t)v[2], n))
            for (int k = 0; k < 3; k++) sn[k] += n[k];
    }
    double reach = fmax(s->eps, sqrt(dist2(mid, s->x + 3 * (size_t)a)));
    int have_mid = fine_project(s, mid, reach, q, fn) &&
                   fn[0] * sn[0] + fn[1] * sn[1] + fn[2] * sn[2] > 0;
    /* the cheap checks for the three places, then the costly ones from the best down */
    double cq[3] = {-1, -1, -1};
    for (int cand = 0; cand < 3; cand++) {
        if (cand == 2 && !have_mid) continue;
        int32_t keep = cand == 1 ? b : a, gone = cand == 1 ? a : b;
        contract_star(s, keep, gone, t1, t2);
        s->ov = keep;
        memcpy(s->op, cand == 0 ? s->x + 3 * (size_t)a : cand == 1 ? s->x + 3 * (size_t)b : q,
               sizeof s->op);
        if (acceptable(s, qfloor, 0) && (s->newq >= fmin(1, CONTRACT_GAIN * q0) || s->newbad < bad0))
            cq[cand] = s->newq;
        s->ov = -1;
    }
    int done = 0;
    for (int round = 0; round < 3 && !done; round++) {
        int bk = -1;
        for (int cand = 0; cand < 3; cand++)
            if (cq[cand] >= 0 && (bk < 0 || cq[cand] > cq[bk])) bk = cand;
        if (bk < 0) break;
        cq[bk] = -1;
        int32_t keep = bk == 1 ? b : a, gone = bk == 1 ? a : b;
        contract_star(s, keep, gone, t1, t2);
        s->ov = keep;
        memcpy(s->op, bk == 0 ? s->x + 3 * (size_t)a : bk == 1 ? s->x + 3 * (size_t)b : q,
               sizeof s->op);
        if (acceptable(s, qfloor, 1)) done = apply(s) ? -1 : 1;
        s->ov = -1;
    }
    star_clear(s);
    return done;
}

/* Tries to flip a-b (both triangles kept fine) when that raises the pair's quality. */
static int try_flip(imp *s, int32_t a, int32_t b) {
    int32_t t1, t2;
    if (!edge_tris(s, a, b, &t1, &t2) || !s->fine[t1] || !s->fine[t2]) return 0;
    if (s->vt[a].n <= 3 || s->vt[b].n <= 3) return 0;
    int32_t c = third(s->t + 3 * (size_t)t1, a, b), d = third(s->t + 3 * (size_t)t2, a, b);
    star_clear(s);
    s->S[0] = t1, s->S[1] = t2, s->ns = 2;
    s->smark[t1] = s->smark[t2] = 1;
    double q0 = star_quality(s);
    /* (a, b, c), (b, a, d) -> (c, a, d), (d, b, c) */
    int32_t nv[6] = {c, a, d, d, b, c};
    memcpy(s->N, nv, sizeof nv);
    s->norig[0] = t1, s->norig[1] = t2, s->nn = 2;
    double n1[3], n2[3];
    int ok = tri_normal(s, t1, n1) && tri_normal(s, t2, n2);
    double avg[3] = {n1[0] + n2[0], n1[1] + n2[1], n1[2] + n2[2]};
    double l = sqrt(avg[0] * avg[0] + avg[1] * avg[1] + avg[2] * avg[2]);
    int done = 0;
    if (ok && l > TINY) {
        for (int k = 0; k < 3; k++) s->nref[k] = s->nref[3 + k] = avg[k] / l;
        if (acceptable(s, q0 * FLIP_GAIN + TINY, 1)) done = apply(s) ? -1 : 1;
    }
    star_clear(s);
    return done;
}

/* Tries to move v (on a kept-fine triangle) to the centroid of its ring projected onto the
 * fine surface, when that raises the star's quality. */
static int try_move(imp *s, int32_t v) {
    const vlist *l = &s->vt[v];
    int any = 0;
    for (int32_t i = 0; i < l->n; i++) any |= s->fine[l->v[i]];
    if (!any || l->n > MAXS) return 0;
    star_clear(s);
    star_add(s, v);
    double cen[3] = {0, 0, 0}, sn[3] = {0, 0, 0}, emean = 0;
    for (int i = 0; i < s->ns; i++) {
        const int32_t *g = s->t + 3 * (size_t)s->S[i];
        int32_t u = g[0] == v ? g[1] : g[1] == v ? g[2] : g[0]; /* each ring vertex once */
        for (int k = 0; k < 3; k++) cen[k] += s->x[3 * (size_t)u + k] / s->ns;
        emean += sqrt(dist2(s->x + 3 * (size_t)u, s->x + 3 * (size_t)v)) / s->ns;
        normal(s->x + 3 * (size_t)g[0], s->x + 3 * (size_t)g[1], s->x + 3 * (size_t)g[2],
               s->nref + 3 * i);
        for (int k = 0; k < 3; k++) sn[k] += s->nref[3 * i + k];
        memcpy(s->N + 3 * i, g, 3 * sizeof *g);
        s->norig[i] = s->S[i];
    }
    s->nn = s->ns;
    double q[3], fn[3], q0 = star_quality(s), tgt[3];
    int done = 0;
    /* the centroid, else halfway, else a quarter of the way there, projected; a vertex of
     * a triangle below the edge ratio 0.3 may also stay off the fine surface, within half
     * the error (a neck of a few hundredths of a voxel is widened so) */
    int thin = star_bad(s) > 0;
    for (int k = 0; !done && k < (thin ? 5 : 3); k++) {
        double frac = k < 3 ? ldexp(1, -k) : ldexp(1, 3 - k);
        for (int a = 0; a < 3; a++)
            tgt[a] = s->x[3 * (size_t)v + a] + frac * (cen[a] - s->x[3 * (size_t)v + a]);
        double step = sqrt(dist2(tgt, s->x + 3 * (size_t)v));
        if (!(step > 1e-6 * emean)) continue;
        if (k < 3) {
            /* a step of at most half the mean edge: the projection must not jump to
             * another sheet */
            if (!fine_project(s, tgt, fmax(s->eps, step), q, fn) ||
                fn[0] * sn[0] + fn[1] * sn[1] + fn[2] * sn[2] <= 0 ||
                dist2(q, s->x + 3 * (size_t)v) >= 0.25 * emean * emean)
                continue;
        } else {
            if (!fine_near(s, tgt, 0.5 * s->eps)) continue;
            memcpy(q, tgt, sizeof q);
        }
        s->ov = v;
        memcpy(s->op, q, sizeof q);
        if (acceptable(s, q0 + MOVE_GAIN, 1)) done = apply(s) ? -1 : 1;
        s->ov = -1;
    }
    star_clear(s);
    return done;
}

/* -- the passes ----------------------------------------------------------------------- */

typedef struct {
    double len;
    int32_t a, b;
} cand;

static int cmp_cand(const void *x, const void *y) {
    const cand *p = x, *q = y;
    if (p->len != q->len) return p->len < q->len ? -1 : 1;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

/* The edges (a < b) of live kept-fine triangles, shortest first. */
static cand *fine_edges(const imp *s, size_t *n) {
    cand *c = malloc((3 * s->nt + 1) * sizeof *c);
    if (!c) return NULL;
    size_t k = 0;
    for (size_t t = 0; t < s->nt; t++) {
        if (s->tdead[t] || !s->fine[t]) continue;
        const int32_t *v = s->t + 3 * t;
        for (int e = 0; e < 3; e++) {
            int32_t a = v[e], b = v[(e + 1) % 3];
            if (a < b)
                c[k].a = a, c[k].b = b,
                c[k++].len = dist2(s->x + 3 * (size_t)a, s->x + 3 * (size_t)b);
        }
    }
    qsort(c, k, sizeof *c, cmp_cand);
    *n = k;
    return c;
}

static int pass_edges(imp *s, int flip, size_t *changes) {
    size_t n;
    cand *c = fine_edges(s, &n);
    if (!c) return -1;
    for (size_t i = 0; i < n; i++) {
        int r = flip ? try_flip(s, c[i].a, c[i].b) : try_contract(s, c[i].a, c[i].b);
        if (r < 0) {
            free(c);
            return -1;
        }
        *changes += (size_t)r;
    }
    free(c);
    return 0;
}

static void imp_free(imp *s) {
    if (s->vt)
        for (size_t v = 0; v < s->nv; v++) free(s->vt[v].v);
    size_t ncell = (size_t)(s->gn[0] * s->gn[1] * s->gn[2]);
    if (s->cell)
        for (size_t c = 0; c < ncell; c++) free(s->cell[c].v);
    free(s->vt), free(s->cell), free(s->tdead), free(s->smark), free(s->stamp);
    free(s->foff), free(s->fitem), free(s->voff), free(s->vitem);
}

static vm_status setup(imp *s, vm_error *err) {
    const vm__cover_fine *m = s->m;
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int a = 0; a < 3; a++) s->lo[a] = INFINITY;
    for (size_t v = 0; v < m->nv; v++)
        for (int a = 0; a < 3; a++)
            s->lo[a] = fmin(s->lo[a], m->x[3 * v + a]), hi[a] = fmax(hi[a], m->x[3 * v + a]);
    double vol = 1;
    for (int a = 0; a < 3; a++) vol *= hi[a] - s->lo[a] + 1;
    s->h = fmax(fmax(1.0, s->eps), cbrt(vol / MAX_CELLS));
    for (int a = 0; a < 3; a++) s->gn[a] = (int64_t)((hi[a] - s->lo[a]) / s->h) + 1;
    size_t ncell = (size_t)(s->gn[0] * s->gn[1] * s->gn[2]);
    s->vt = calloc(s->nv + 1, sizeof *s->vt);
    s->cell = calloc(ncell, sizeof *s->cell);
    s->tdead = calloc(s->nt + 1, 1);
    s->smark = calloc(s->nt + 1, 1);
    s->stamp = calloc(s->nt + 1, sizeof *s->stamp);
    s->ov = -1;
    if (!s->vt || !s->cell || !s->tdead || !s->smark || !s->stamp ||
        grid_static(s, 1, &s->foff, &s->fitem) ||
        grid_static(s, 0, &s->voff, &s->vitem))
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (improvement pass)");
    for (size_t t = 0; t < s->nt; t++) {
        for (int e = 0; e < 3; e++)
            if (vl_push(&s->vt[s->t[3 * t + e]], (int32_t)t))
                return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
        if (grid_insert(s, (int32_t)t))
            return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
    }
    return VM_OK;
}

vm_status vm__cover_improve(const vm__cover_fine *m, double eps, double *x, size_t *nv,
                            int32_t *tri, size_t *nt, uint8_t *fine, vm__cover_improve_stats *st,
                            vm_error *err) {
    imp s;
    memset(&s, 0, sizeof s);
    s.m = m, s.eps = eps, s.x = x, s.nv = *nv, s.t = tri, s.nt = *nt, s.fine = fine;
    vm__cover_improve_stats z = {0, 0, 0, 0};
    if (st) *st = z;
    vm_status r = setup(&s, err);
    for (int round = 0; !r && round < ROUNDS; round++) {
        size_t c = 0, f = 0, mv = 0;
        if (pass_edges(&s, 0, &c) || pass_edges(&s, 1, &f)) {
            r = vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (improvement pass)");
            break;
        }
        for (size_t v = 0; v < s.nv; v++) {
            int k = try_move(&s, (int32_t)v);
            if (k < 0) {
                r = vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
                break;
            }
            mv += (size_t)k;
        }
        if (st) st->contractions += c, st->flips += f, st->moves += mv, st->rounds++;
        if (c + f + mv == 0) break;
    }
    if (!r) { /* compact: live vertices and triangles in their order */
        int32_t *map = malloc((s.nv + 1) * sizeof *map);
        if (!map) {
            r = vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
        } else {
            size_t k = 0;
            for (size_t v = 0; v < s.nv; v++) {
                map[v] = -1;
                if (s.vt[v].n == 0) continue;
                memmove(x + 3 * k, x + 3 * v, 3 * sizeof *x);
                map[v] = (int32_t)k++;
            }
            *nv = k;
            k = 0;
            for (size_t t = 0; t < s.nt; t++) {
                if (s.tdead[t]) continue;
                for (int e = 0; e < 3; e++) tri[3 * k + e] = map[tri[3 * t + e]];
                const int32_t *g = tri + 3 * k;
                /* still flagged: kept fine and below the paper's edge ratio (a relative
                 * millionth above it too, so that the ratio recomputed from the output's
                 * rounded world coordinates cannot fall below 0.3 unflagged) */
                fine[k] = s.fine[t] && edge_ratio3(x + 3 * (size_t)g[0], x + 3 * (size_t)g[1],
                                                   x + 3 * (size_t)g[2]) < ASPECT * (1 + 1e-6);
                k++;
            }
            *nt = k;
            free(map);
        }
    }
    imp_free(&s);
    return r;
}
