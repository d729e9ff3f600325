/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_guard.c — the boundary guard of the improvement pass: before an operation
 * moves a boundary vertex or changes boundary faces, its new boundary triangles are tested
 * against each other and against the boundary triangles near them (vm__tri_pair_intersects),
 * and the operation is refused when a pair crosses. The boundary vertices sit in hashed
 * uniform grids by level (the bound lv on their faces' longest edges); a face crossing a
 * query triangle has every vertex v within lv[v] of the query's bounding box, so a query
 * visits the cells of that box grown by the largest lv of each level and keeps the vertices
 * within their own lv of it: its reach is local. Each vertex's boundary faces are cached and
 * recomputed after a tet around it is added or removed; the faces gathered for a moving
 * vertex serve its next queries while nothing else changes. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "../core/hash.h"
#include "../core/self_intersect.h"
#include "improve_internal.h"

#define NOB SIZE_MAX
#define GUARD_MARGIN 0.3 /* of the moving vertex's shortest boundary edge */
#define GLEV 4 /* levels of the grid: hs, 2 hs, 4 hs, then the longest edge */

/* A gathered boundary face and its bounding box. */
typedef struct gface {
    vm_index v[3];
    double lo[3], hi[3];
} gface;

typedef struct bflist {
    vm_index *e; /* pairs (c, d): faces (v, c, d) */
    int32_t n, cap;
} bflist;

/* What the guard keeps per vertex, together, since a query touches all of it. Levels:
 * lv bounds the longest edge of every boundary triangle at the vertex ever proposed. */
typedef struct gvert {
    double lv;
    size_t bucket;     /* NOB when not in the grid */
    vm_index next, prev;
    uint32_t stamp;
    uint8_t valid;     /* bf is current */
    uint8_t lev;       /* level; it only rises */
    bflist bf;
} gvert;

struct vm__imp_guard {
    double h, lmax;
    size_t mask;
    /* Levels: lv[v] bounds the longest edge of every boundary triangle at v ever proposed;
     * v sits in the first level l < GLEV - 1 with lv <= hs 2^l (cell and search radius
     * hs 2^l), else in the last (cell h, radius lmax). A crossing triangle has every vertex
     * within its own longest edge of the query, and that edge is at most the lv of each of
     * its vertices, so the search of its vertices' level finds one of them. */
    double hs;
    vm_index *head[GLEV];
    gvert *vx;         /* per vertex */
    uint32_t round;
    /* per level: vertices in its grid, and the largest lv of any vertex that was ever in it
     * (the search radius of the level: at most hs 2^l, or lmax for the last) */
    size_t count[GLEV];
    double lvmax[GLEV];
    vm_index *cand;
    size_t ncand, cand_cap;
    vm_index *tmp;    /* link-edge scratch: a table of tmp_cap pairs and their counts */
    uint8_t *tcnt;
    size_t tmp_cap;
    vm_index (*nt)[3]; /* new-triangle scratch for moves */
    size_t nt_cap;
    /* the faces of the last gathering; for cache_v >= 0 those of the box [elo, ehi] less
     * the faces at cache_v, current while gen (bumped whenever a tet changes or another
     * boundary vertex moves) equals cache_gen */
    gface *cf;
    size_t ncf, cf_cap;
    vm_index cache_v;
    uint64_t gen, cache_gen;
    double elo[3], ehi[3];
};

/* Bucket of grid cell (i, j, k): core's hash of the three indices. */
static size_t hash3(int64_t i, int64_t j, int64_t k, size_t mask) {
    uint64_t h = vm__hash_add(vm__hash_add(vm__hash_add(0, (uint64_t)i), (uint64_t)j),
                              (uint64_t)k);
    return (size_t)h & mask;
}

/* Cell indices are clamped to +-CELL_CLAMP (far inside int64_t; NaN goes to the low end). */
#define CELL_CLAMP 1e15

/* Index of the grid cell of size h holding coordinate x. */
static int64_t cell_of(double x, double h) {
    double c = floor(x / h);
    if (!(c > -CELL_CLAMP)) c = -CELL_CLAMP;
    if (!(c < CELL_CLAMP)) c = CELL_CLAMP;
    return (int64_t)c;
}

/* Cell size (and search radius, but for the last level) of level l. */
static double level_h(const struct vm__imp_guard *g, int l) {
    return l == GLEV - 1 ? g->h : g->hs * (double)(1 << l);
}

static int level_of(const struct vm__imp_guard *g, double lv) {
    int l = 0;
    while (l < GLEV - 1 && !(lv <= g->hs * (double)(1 << l))) l++;
    return l;
}

static size_t bucket_at(const struct vm__imp_guard *g, const double *p, int l) {
    double h = level_h(g, l);
    return hash3(cell_of(p[0], h), cell_of(p[1], h), cell_of(p[2], h), g->mask);
}

static void g_insert(vm__imp *w, vm_index v) {
    struct vm__imp_guard *g = w->g;
    int l = g->vx[v].lev;
    vm_index *head = g->head[l];
    g->count[l]++;
    if (g->vx[v].lv > g->lvmax[l]) g->lvmax[l] = g->vx[v].lv;
    size_t b = bucket_at(g, w->p + 3 * (size_t)v, g->vx[v].lev);
    g->vx[v].next = head[b];
    g->vx[v].prev = -1;
    if (head[b] >= 0) g->vx[head[b]].prev = v;
    head[b] = v;
    g->vx[v].bucket = b;
}

static void g_remove(vm__imp *w, vm_index v) {
    struct vm__imp_guard *g = w->g;
    size_t b = g->vx[v].bucket;
    if (b == NOB) return;
    g->count[g->vx[v].lev]--;
    if (g->vx[v].prev >= 0) g->vx[g->vx[v].prev].next = g->vx[v].next;
    else g->head[g->vx[v].lev][b] = g->vx[v].next;
    if (g->vx[v].next >= 0) g->vx[g->vx[v].next].prev = g->vx[v].prev;
    g->vx[v].bucket = NOB;
}

void vm__imp_guard_moved(vm__imp *w, vm_index a) {
    struct vm__imp_guard *g = w->g;
    if (!g || g->vx[a].bucket == NOB) return;
    if (a != g->cache_v) g->gen++;
    if (bucket_at(g, w->p + 3 * (size_t)a, g->vx[a].lev) == g->vx[a].bucket) return;
    g_remove(w, a);
    g_insert(w, a);
}

void vm__imp_guard_touch(vm__imp *w, vm_index v) {
    struct vm__imp_guard *g = w->g;
    if (!g) return;
    g->gen++;
    g->vx[v].valid = 0;
    if (g->vx[v].bucket == NOB) g_insert(w, v);
}

static int pair_cmp(const void *pa, const void *pb) {
    const vm_index *a = pa, *b = pb;
    if (a[0] != b[0]) return a[0] < b[0] ? -1 : 1;
    return a[1] < b[1] ? -1 : a[1] > b[1];
}

int vm__imp_guard_faces(vm__imp *w, vm_index a, const vm_index **e) {
    struct vm__imp_guard *g = w->g;
    bflist *l = &g->vx[a].bf;
    if (g->vx[a].bucket == NOB) {
        /* never on the boundary: a vertex joins the grid when it gets boundary faces */
        *e = l->e;
        return 0;
    }
    if (!g->vx[a].valid) {
        const vm__imp_star *s = &w->star[a];
        size_t m = 3 * (size_t)s->n, ts = 32;
        while (ts < 2 * m) ts *= 2;
        if (ts > g->tmp_cap) {
            vm_index *nt = realloc(g->tmp, 2 * ts * sizeof *nt);
            uint8_t *nc = realloc(g->tcnt, ts);
            if (nt) g->tmp = nt;
            if (nc) g->tcnt = nc;
            if (!nt || !nc) return -1;
            g->tmp_cap = ts;
        }
        /* The link edges of a, counted in a small open-addressing table: the faces (a, c, d)
         * seen once are boundary faces. */
        memset(g->tcnt, 0, ts);
        size_t nuniq = 0;
        for (int32_t i = 0; i < s->n; i++) {
            const vm_index *n = w->tet + 4 * (size_t)s->t[i];
            vm_index o[3];
            int k2 = 0;
            for (int k = 0; k < 4; k++)
                if (n[k] != a && k2 < 3) o[k2++] = n[k];
            if (k2 != 3) continue;
            for (int k = 0; k < 3; k++) {
                vm_index x = o[k], y = o[(k + 1) % 3];
                vm_index x0 = x < y ? x : y, x1 = x < y ? y : x;
                uint64_t hh = (uint64_t)x0 * 0x9E3779B97F4A7C15ull ^
                              (uint64_t)x1 * 0xC2B2AE3D27D4EB4Full;
                size_t slot = (size_t)(hh ^ hh >> 31) & (ts - 1);
                while (g->tcnt[slot] &&
                       (g->tmp[2 * slot] != x0 || g->tmp[2 * slot + 1] != x1))
                    slot = (slot + 1) & (ts - 1);
                if (!g->tcnt[slot]) {
                    g->tmp[2 * slot] = x0;
                    g->tmp[2 * slot + 1] = x1;
                    g->tcnt[slot] = 1;
                    nuniq++;
                } else if (g->tcnt[slot] < 2) g->tcnt[slot] = 2;
            }
        }
        l->n = 0;
        for (size_t slot = 0; slot < ts && nuniq; slot++) {
            if (!g->tcnt[slot]) continue;
            nuniq--;
            if (g->tcnt[slot] != 1) continue;
            if (l->n == l->cap) {
                int32_t cap = l->cap ? 2 * l->cap : 8;
                vm_index *ne = realloc(l->e, 2 * (size_t)cap * sizeof *ne);
                if (!ne) return -1;
                l->e = ne;
                l->cap = cap;
            }
            /* in (c, d) order, as the faces were always listed: insertion sort of a few */
            vm_index x0 = g->tmp[2 * slot], x1 = g->tmp[2 * slot + 1];
            int32_t j = l->n;
            for (; j > 0 && pair_cmp(l->e + 2 * (j - 1), (vm_index[2]){x0, x1}) > 0; j--) {
                l->e[2 * j] = l->e[2 * (j - 1)];
                l->e[2 * j + 1] = l->e[2 * (j - 1) + 1];
            }
            l->e[2 * j] = x0;
            l->e[2 * j + 1] = x1;
            l->n++;
        }
        g->vx[a].valid = 1;
    }
    *e = l->e;
    return l->n;
}

static int push_cand(struct vm__imp_guard *g, vm_index v) {
    if (vm__grow((void **)&g->cand, &g->cand_cap, g->ncand + 1, sizeof *g->cand, NULL))
        return 0;
    g->cand[g->ncand++] = v;
    return 1;
}

static double dist2_box(const double *p, const double lo[3], const double hi[3]) {
    double d = 0.0;
    for (int k = 0; k < 3; k++) {
        double e = p[k] < lo[k] ? lo[k] - p[k] : p[k] > hi[k] ? p[k] - hi[k] : 0.0;
        d += e * e;
    }
    return d;
}

static void sort3(vm_index t[3]) {
    vm_index x;
    if (t[0] > t[1]) { x = t[0]; t[0] = t[1]; t[1] = x; }
    if (t[1] > t[2]) { x = t[1]; t[1] = t[2]; t[2] = x; }
    if (t[0] > t[1]) { x = t[0]; t[0] = t[1]; t[1] = x; }
}

static const double *pos(const vm__imp *w, vm_index v, vm_index mv, const double *x) {
    return v == mv ? x : w->p + 3 * (size_t)v;
}

/* A boundary triangle with longest edge d at v is proposed: v's bound grows to d, and v goes
 * up to the level that bound needs. */
static void raise_lv(vm__imp *w, vm_index v, double d) {
    struct vm__imp_guard *g = w->g;
    if (d <= g->vx[v].lv) return;
    g->vx[v].lv = d;
    int l = level_of(g, d);
    if (l <= g->vx[v].lev) {
        if (g->vx[v].bucket != NOB && d > g->lvmax[g->vx[v].lev]) g->lvmax[g->vx[v].lev] = d;
        return;
    }
    int in = g->vx[v].bucket != NOB;
    if (in) g_remove(w, v);
    g->vx[v].lev = (uint8_t)l;
    if (in) g_insert(w, v);
}

/* The new triangles' bounding box [lo, hi]; raises the longest edge and the vertices'
 * bounds with them. */
static void query_box(vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                      const double x[3], double lo[3], double hi[3]) {
    struct vm__imp_guard *g = w->g;
    for (int c = 0; c < 3; c++) {
        lo[c] = INFINITY;
        hi[c] = -INFINITY;
    }
    for (int i = 0; i < nn; i++) {
        double dt = 0.0; /* the triangle's longest edge */
        for (int k = 0; k < 3; k++) {
            const double *p = pos(w, nt[i][k], mv, x), *q = pos(w, nt[i][(k + 1) % 3], mv, x);
            double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                            (p[2] - q[2]) * (p[2] - q[2]));
            if (d > g->lmax) g->lmax = d;
            if (!(d <= dt)) dt = d;
            for (int c = 0; c < 3; c++) {
                if (p[c] < lo[c]) lo[c] = p[c];
                if (p[c] > hi[c]) hi[c] = p[c];
            }
        }
        for (int k = 0; k < 3; k++) raise_lv(w, nt[i][k], dt);
    }
}

/* 1 when two of the new triangles cross. */
static int new_cross(const vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                     const double x[3]) {
    for (int i = 0; i < nn; i++)
        for (int j = i + 1; j < nn; j++) {
            const double *A[3], *B[3];
            for (int k = 0; k < 3; k++) {
                A[k] = pos(w, nt[i][k], mv, x);
                B[k] = pos(w, nt[j][k], mv, x);
            }
            if (vm__tri_pair_intersects(A, nt[i], B, nt[j])) return 1;
        }
    return 0;
}

static double min3(double a, double b, double c) {
    double m = a < b ? a : b;
    return m < c ? m : c;
}
static double max3(double a, double b, double c) {
    double m = a > b ? a : b;
    return m > c ? m : c;
}

/* Gathers into g->cf the current boundary faces whose boxes meet [lo, hi] — each once, with
 * its box — less those with a vertex in exv[0..nexv) and the faces rem[0..nrem). A face
 * crossing a triangle inside [lo, hi] has every vertex v within its own longest edge, at
 * most lv[v], of the box: the grid cells of the box grown by the largest lv of each level
 * hold one of its vertices, and that vertex passes the lv test below. 0 on nomem. */
static int gather(vm__imp *w, const double lo[3], const double hi[3], const vm_index *exv,
                  int nexv, const vm_index (*rem)[3], int nrem) {
    struct vm__imp_guard *g = w->g;
    if (g->round >= UINT32_MAX / 2 - 2) {
        for (size_t i = 0; i < w->npt; i++) g->vx[i].stamp = 0;
        g->round = 0;
    }
    g->round++;
    uint32_t inc = 2 * g->round, seen = 2 * g->round + 1;
    g->ncand = 0;
    g->ncf = 0;
    for (int level = 0; level < GLEV; level++) {
        if (!g->count[level]) continue;
        double h = level_h(g, level), L = g->lvmax[level];
        vm_index *head = g->head[level];
        int64_t c0[3], c1[3];
        double ncell = 1.0;
        for (int k = 0; k < 3; k++) {
            c0[k] = cell_of(lo[k] - L, h);
            c1[k] = cell_of(hi[k] + L, h);
            ncell *= (double)(c1[k] - c0[k] + 1);
        }
        size_t nb = g->mask + 1;
        int all = !(ncell <= (double)nb);
        size_t nbk = all ? nb : (size_t)ncell;
        int64_t ci = c0[0], cj = c0[1], ck = c0[2];
        for (size_t it = 0; it < nbk; it++) {
            size_t b;
            if (all) b = it;
            else {
                b = hash3(ci, cj, ck, g->mask);
                if (++ci > c1[0]) {
                    ci = c0[0];
                    if (++cj > c1[1]) {
                        cj = c0[1];
                        ck++;
                    }
                }
            }
            for (vm_index v = head[b]; v >= 0; v = g->vx[v].next) {
                if (g->vx[v].stamp == inc || g->vx[v].stamp == seen) continue;
                if (w->pdead[v] || dist2_box(w->p + 3 * (size_t)v, lo, hi) > g->vx[v].lv * g->vx[v].lv) {
                    g->vx[v].stamp = seen;
                    continue;
                }
                g->vx[v].stamp = inc;
                if (!push_cand(g, v)) return 0;
            }
        }
    }
    for (size_t ic = 0; ic < g->ncand; ic++) {
        vm_index v = g->cand[ic];
        int skip = 0;
        for (int k = 0; k < nexv; k++) skip |= exv[k] == v;
        if (skip) continue;
        const vm_index *e;
        int nf = vm__imp_guard_faces(w, v, &e);
        if (nf < 0) return 0;
        if (nf == 0) {
            /* Not on the boundary (now): out of the grid until a tet around it changes. */
            g_remove(w, v);
            continue;
        }
        for (int f = 0; f < nf; f++) {
            vm_index tri[3] = {v, e[2 * f], e[2 * f + 1]};
            /* each face once: from its smallest candidate vertex */
            if ((g->vx[tri[1]].stamp == inc && tri[1] < v) || (g->vx[tri[2]].stamp == inc && tri[2] < v))
                continue;
            int ex = 0;
            for (int k = 0; k < nexv; k++) ex |= exv[k] == tri[1] || exv[k] == tri[2];
            if (ex) continue;
            if (nrem) {
                vm_index st[3] = {tri[0], tri[1], tri[2]};
                sort3(st);
                for (int r = 0; r < nrem && !ex; r++) {
                    vm_index sr[3] = {rem[r][0], rem[r][1], rem[r][2]};
                    sort3(sr);
                    ex = sr[0] == st[0] && sr[1] == st[1] && sr[2] == st[2];
                }
                if (ex) continue;
            }
            const double *B0 = w->p + 3 * (size_t)tri[0], *B1 = w->p + 3 * (size_t)tri[1],
                         *B2 = w->p + 3 * (size_t)tri[2];
            gface fc;
            for (int c = 0; c < 3; c++) {
                fc.lo[c] = min3(B0[c], B1[c], B2[c]);
                fc.hi[c] = max3(B0[c], B1[c], B2[c]);
            }
            if (fc.lo[0] > hi[0] || fc.lo[1] > hi[1] || fc.lo[2] > hi[2] || fc.hi[0] < lo[0] ||
                fc.hi[1] < lo[1] || fc.hi[2] < lo[2])
                continue;
            memcpy(fc.v, tri, sizeof tri);
            if (vm__grow((void **)&g->cf, &g->cf_cap, g->ncf + 1, sizeof *g->cf, NULL)) return 0;
            g->cf[g->ncf++] = fc;
        }
    }
    return 1;
}

/* 1 when a gathered face meeting [lo, hi] crosses one of the new triangles. */
static int faces_cross(const vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                       const double x[3], const double lo[3], const double hi[3]) {
    const struct vm__imp_guard *g = w->g;
    for (size_t f = 0; f < g->ncf; f++) {
        const gface *fc = &g->cf[f];
        if (fc->lo[0] > hi[0] || fc->lo[1] > hi[1] || fc->lo[2] > hi[2] || fc->hi[0] < lo[0] ||
            fc->hi[1] < lo[1] || fc->hi[2] < lo[2])
            continue;
        const double *B[3];
        for (int k = 0; k < 3; k++) B[k] = w->p + 3 * (size_t)fc->v[k];
        for (int i = 0; i < nn; i++) {
            const double *A[3];
            int out = 0;
            for (int k = 0; k < 3; k++) A[k] = pos(w, nt[i][k], mv, x);
            for (int c = 0; c < 3 && !out; c++)
                out = min3(A[0][c], A[1][c], A[2][c]) > fc->hi[c] ||
                      max3(A[0][c], A[1][c], A[2][c]) < fc->lo[c];
            if (out) continue;
            if (vm__tri_pair_intersects(A, nt[i], B, fc->v)) return 1;
        }
    }
    return 0;
}

/* The gathering for a move of vertex a: the positions a line search or a perturbation tries
 * for a come in a row with the rest of the boundary unchanged, so the faces gathered (less
 * those at a) for the query's box grown by margin serve every later query whose box lies
 * inside it. The answer is the same as a fresh gathering's: a face that can cross lies in
 * both. (Doing the same for the options of one contraction gathered more faces than it
 * saved walks: MR head, 2 000 fewer gatherings, 25 % more faces fetched.) */
static int gather_cached(vm__imp *w, vm_index a, const double lo[3], const double hi[3],
                         double margin) {
    struct vm__imp_guard *g = w->g;
    int hit = g->cache_v == a && g->cache_gen == g->gen;
    for (int c = 0; c < 3 && hit; c++) hit = lo[c] >= g->elo[c] && hi[c] <= g->ehi[c];
    if (hit) return 1;
    for (int c = 0; c < 3; c++) {
        g->elo[c] = lo[c] - margin;
        g->ehi[c] = hi[c] + margin;
    }
    g->cache_v = -1;
    if (!gather(w, g->elo, g->ehi, &a, 1, NULL, 0)) return 0;
    g->cache_v = a;
    g->cache_gen = g->gen;
    return 1;
}

static double dist(const double *p, const double *q) {
    return sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                (p[2] - q[2]) * (p[2] - q[2]));
}

int vm__imp_guard_ok(vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                     const double x[3], const vm_index *exv, int nexv,
                     const vm_index (*rem)[3], int nrem) {
    struct vm__imp_guard *g = w->g;
    if (!g || nn <= 0) return 1;
    double lo[3], hi[3];
    query_box(w, nt, nn, mv, x, lo, hi);
    if (new_cross(w, nt, nn, mv, x)) return 0;
    g->cache_v = -1; /* the gathered faces are this query's */
    int ok = gather(w, lo, hi, exv, nexv, rem, nrem);
    if (!ok) {
        w->nomem = 1;
        return 0;
    }
    return !faces_cross(w, nt, nn, mv, x, lo, hi);
}

int vm__imp_guard_move_ok(vm__imp *w, vm_index a, const double x[3]) {
    struct vm__imp_guard *g = w->g;
    if (!g || g->vx[a].bucket == NOB) return 1;
    const vm_index *e;
    int nf = vm__imp_guard_faces(w, a, &e);
    if (nf < 0) {
        w->nomem = 1;
        return 0;
    }
    if (nf == 0) return 1;
    if ((size_t)nf > g->nt_cap) {
        vm_index(*n2)[3] = realloc(g->nt, 2 * (size_t)nf * sizeof *n2);
        if (!n2) {
            w->nomem = 1;
            return 0;
        }
        g->nt = n2;
        g->nt_cap = 2 * (size_t)nf;
    }
    double m = INFINITY; /* a's shortest boundary edge */
    const double *pa = w->p + 3 * (size_t)a;
    for (int f = 0; f < nf; f++) {
        g->nt[f][0] = a;
        g->nt[f][1] = e[2 * f];
        g->nt[f][2] = e[2 * f + 1];
        for (int k = 1; k < 3; k++) {
            double d = dist(pa, w->p + 3 * (size_t)g->nt[f][k]);
            if (d < m) m = d;
        }
    }
    const vm_index(*nt)[3] = (const vm_index(*)[3])g->nt;
    double lo[3], hi[3];
    query_box(w, nt, nf, a, x, lo, hi);
    if (new_cross(w, nt, nf, a, x)) return 0;
    /* the margin: what the line searches and perturbations of a usually move it */
    if (!gather_cached(w, a, lo, hi, GUARD_MARGIN * m)) {
        w->nomem = 1;
        return 0;
    }
    return !faces_cross(w, nt, nf, a, x, lo, hi);
}

void vm__imp_guard_free(vm__imp *w) {
    struct vm__imp_guard *g = w->g;
    if (!g) return;
    if (g->vx)
        for (size_t i = 0; i < w->npt; i++) free(g->vx[i].bf.e);
    free(g->vx);
    for (int l = 0; l < GLEV; l++) free(g->head[l]);
    free(g->cand);
    free(g->tmp);
    free(g->tcnt);
    free(g->nt);
    free(g->cf);
    free(g);
    w->g = NULL;
}

int vm__imp_guard_init(vm__imp *w) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    struct vm__imp_guard *g = calloc(1, sizeof *g);
    if (!g) return 0;
    w->g = g;
    g->cache_v = -1;
    size_t np = w->npt;
    g->vx = calloc(np + 1, sizeof *g->vx);
    uint8_t *on = calloc(np + 1, 1);
    if (!g->vx || !on) {
        free(on);
        vm__imp_guard_free(w);
        return 0;
    }
    for (size_t i = 0; i < np; i++) g->vx[i].bucket = NOB;
    double sum = 0.0, lmax = 0.0;
    size_t ne = 0, nbv = 0;
    /* the boundary faces as the set-up found them (in tet order) */
    for (size_t e = 0; e < w->nbfaces; e++) {
        size_t t = w->bfaces[e] / 4;
        int f = (int)(w->bfaces[e] % 4);
        const vm_index *n = w->tet + 4 * t;
        vm_index c[3] = {n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]};
        double dt = 0.0;
        for (int k = 0; k < 3; k++) {
            const double *p = w->p + 3 * (size_t)c[k], *q = w->p + 3 * (size_t)c[(k + 1) % 3];
            double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                            (p[2] - q[2]) * (p[2] - q[2]));
            sum += d;
            ne++;
            if (d > lmax) lmax = d;
            if (!(d <= dt)) dt = d;
            if (!on[c[k]]) nbv++;
            on[c[k]] = 1;
        }
        for (int k = 0; k < 3; k++)
            if (!(dt <= g->vx[c[k]].lv)) g->vx[c[k]].lv = dt;
    }
    /* Cells as large as the longest edge: a query then visits a few cells only. */
    g->h = ne && lmax > 0.0 ? lmax : ne && sum > 0.0 ? sum / (double)ne : 1.0;
    g->lmax = lmax;
    /* The first level: twice the mean boundary edge (all of the boundary of a uniform mesh,
     * where that is about the longest edge; the skin of an adaptive one, whose faces on the
     * volume border are long, while those go up the levels). */
    g->hs = ne && sum > 0.0 ? 2.0 * sum / (double)ne : g->h;
    if (g->hs > g->h) g->hs = g->h;
    for (size_t i = 0; i < np; i++) g->vx[i].lev = (uint8_t)(on[i] ? level_of(g, g->vx[i].lv) : 0);
    size_t nb = 1024;
    while (nb < 2 * nbv) nb *= 2;
    g->mask = nb - 1;
    int hfail = 0;
    for (int l = 0; l < GLEV; l++) {
        g->head[l] = malloc(nb * sizeof *g->head[l]);
        hfail |= !g->head[l];
    }
    if (hfail) {
        free(on);
        vm__imp_guard_free(w);
        return 0;
    }
    for (int l = 0; l < GLEV; l++)
        for (size_t b = 0; b < nb; b++) g->head[l][b] = -1;
    for (size_t i = 0; i < np; i++)
        if (on[i]) g_insert(w, (vm_index)i);
    free(on);
    return 1;
}
