/* mesher/improve_guard.c — the boundary guard of the improvement pass: before an operation
 * moves a boundary vertex or changes boundary faces, its new boundary triangles are tested
 * against each other and against the boundary triangles near them (vm__tri_pair_intersects),
 * and the operation is refused when a pair crosses. The boundary vertices sit in a hashed
 * uniform grid (cell = the longest boundary edge); a triangle crossing a query triangle has
 * a vertex within the longest boundary edge of the query's bounding box, so the grid cells of that box
 * grown by the longest edge hold all candidates. Each vertex's boundary faces are cached and
 * recomputed after a tet around it is added or removed. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../quality/self_intersect.h"
#include "improve_internal.h"

#define NOB SIZE_MAX
#define GLEV 4 /* levels of the grid: hs, 2 hs, 4 hs, then the longest edge */

typedef struct bflist {
    vm_index *e; /* pairs (c, d): faces (v, c, d) */
    int32_t n, cap;
} bflist;

struct vm__imp_guard {
    double h, lmax;
    size_t mask;
    vm_index *next, *prev;
    /* Levels: lv[v] bounds the longest edge of every boundary triangle at v ever proposed;
     * v sits in the first level l < GLEV - 1 with lv <= hs 2^l (cell and search radius
     * hs 2^l), else in the last (cell h, radius lmax). A crossing triangle has every vertex
     * within its own longest edge of the query, and that edge is at most the lv of each of
     * its vertices, so the search of its vertices' level finds one of them. */
    double hs;
    vm_index *head[GLEV];
    double *lv;
    uint8_t *lev;      /* level of each vertex; it only rises */
    size_t *bucket;   /* per vertex, NOB when not in the grid */
    uint8_t *valid;   /* per vertex: bf is current */
    bflist *bf;
    uint32_t *stamp, round;
    vm_index *cand;
    size_t ncand, cand_cap;
    vm_index *tmp;    /* link-edge scratch */
    size_t tmp_cap;
    vm_index (*nt)[3]; /* new-triangle scratch for moves */
    size_t nt_cap;
};

static size_t hash3(int64_t i, int64_t j, int64_t k, size_t mask) {
    uint64_t h = (uint64_t)i * 0x9E3779B97F4A7C15ull ^ (uint64_t)j * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)k * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    return (size_t)h & mask;
}

static int64_t cell_of(double x, double h) {
    double c = floor(x / h);
    if (!(c > -1e15)) c = -1e15;
    if (!(c < 1e15)) c = 1e15;
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
    vm_index *head = g->head[g->lev[v]];
    size_t b = bucket_at(g, w->p + 3 * (size_t)v, g->lev[v]);
    g->next[v] = head[b];
    g->prev[v] = -1;
    if (head[b] >= 0) g->prev[head[b]] = v;
    head[b] = v;
    g->bucket[v] = b;
}

static void g_remove(vm__imp *w, vm_index v) {
    struct vm__imp_guard *g = w->g;
    size_t b = g->bucket[v];
    if (b == NOB) return;
    if (g->prev[v] >= 0) g->next[g->prev[v]] = g->next[v];
    else g->head[g->lev[v]][b] = g->next[v];
    if (g->next[v] >= 0) g->prev[g->next[v]] = g->prev[v];
    g->bucket[v] = NOB;
}

void vm__imp_guard_moved(vm__imp *w, vm_index a) {
    struct vm__imp_guard *g = w->g;
    if (!g || g->bucket[a] == NOB) return;
    if (bucket_at(g, w->p + 3 * (size_t)a, g->lev[a]) == g->bucket[a]) return;
    g_remove(w, a);
    g_insert(w, a);
}

void vm__imp_guard_touch(vm__imp *w, vm_index v) {
    struct vm__imp_guard *g = w->g;
    if (!g) return;
    g->valid[v] = 0;
    if (g->bucket[v] == NOB) g_insert(w, v);
}

static int pair_cmp(const void *pa, const void *pb) {
    const vm_index *a = pa, *b = pb;
    if (a[0] != b[0]) return a[0] < b[0] ? -1 : 1;
    return a[1] < b[1] ? -1 : a[1] > b[1];
}

int vm__imp_guard_faces(vm__imp *w, vm_index a, const vm_index **e) {
    struct vm__imp_guard *g = w->g;
    bflist *l = &g->bf[a];
    if (g->bucket[a] == NOB) {
        /* never on the boundary: a vertex joins the grid when it gets boundary faces */
        *e = l->e;
        return 0;
    }
    if (!g->valid[a]) {
        const vm__imp_star *s = &w->star[a];
        size_t m = 3 * (size_t)s->n;
        if (m > g->tmp_cap) {
            vm_index *nt = realloc(g->tmp, 2 * m * sizeof *nt);
            if (!nt) return -1;
            g->tmp = nt;
            g->tmp_cap = m;
        }
        /* The link edges of a: the faces (a, c, d) seen once are boundary faces. */
        size_t c = 0;
        for (int32_t i = 0; i < s->n; i++) {
            const vm_index *n = w->tet + 4 * (size_t)s->t[i];
            vm_index o[3];
            int k2 = 0;
            for (int k = 0; k < 4; k++)
                if (n[k] != a && k2 < 3) o[k2++] = n[k];
            if (k2 != 3) continue;
            for (int k = 0; k < 3; k++) {
                vm_index x = o[k], y = o[(k + 1) % 3];
                g->tmp[2 * c] = x < y ? x : y;
                g->tmp[2 * c + 1] = x < y ? y : x;
                c++;
            }
        }
        /* insertion sort: a star has a few dozen link edges */
        for (size_t i = 1; i < c; i++) {
            vm_index x0 = g->tmp[2 * i], x1 = g->tmp[2 * i + 1];
            size_t j = i;
            for (; j > 0 && pair_cmp(g->tmp + 2 * (j - 1), (vm_index[2]){x0, x1}) > 0; j--) {
                g->tmp[2 * j] = g->tmp[2 * (j - 1)];
                g->tmp[2 * j + 1] = g->tmp[2 * (j - 1) + 1];
            }
            g->tmp[2 * j] = x0;
            g->tmp[2 * j + 1] = x1;
        }
        l->n = 0;
        for (size_t i = 0; i < c; i++) {
            const vm_index *q = g->tmp + 2 * i;
            if ((i > 0 && q[-2] == q[0] && q[-1] == q[1]) ||
                (i + 1 < c && q[2] == q[0] && q[3] == q[1]))
                continue;
            if (l->n == l->cap) {
                int32_t cap = l->cap ? 2 * l->cap : 8;
                vm_index *ne = realloc(l->e, 2 * (size_t)cap * sizeof *ne);
                if (!ne) return -1;
                l->e = ne;
                l->cap = cap;
            }
            l->e[2 * l->n] = g->tmp[2 * i];
            l->e[2 * l->n + 1] = g->tmp[2 * i + 1];
            l->n++;
        }
        g->valid[a] = 1;
    }
    *e = l->e;
    return l->n;
}

static int push_cand(struct vm__imp_guard *g, vm_index v) {
    if (g->ncand == g->cand_cap) {
        size_t cap = g->cand_cap ? 2 * g->cand_cap : 256;
        vm_index *nc = realloc(g->cand, cap * sizeof *nc);
        if (!nc) return 0;
        g->cand = nc;
        g->cand_cap = cap;
    }
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
    if (d <= g->lv[v]) return;
    g->lv[v] = d;
    int l = level_of(g, d);
    if (l <= g->lev[v]) return;
    int in = g->bucket[v] != NOB;
    if (in) g_remove(w, v);
    g->lev[v] = (uint8_t)l;
    if (in) g_insert(w, v);
}

int vm__imp_guard_ok(vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                     const double x[3], const vm_index *exv, int nexv,
                     const vm_index (*rem)[3], int nrem) {
    struct vm__imp_guard *g = w->g;
    if (!g || nn <= 0) return 1;
    /* Bounding boxes of the new triangles; the longest boundary edge grows with them. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
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
    /* The new triangles among themselves. */
    for (int i = 0; i < nn; i++)
        for (int j = i + 1; j < nn; j++) {
            const double *A[3], *B[3];
            for (int k = 0; k < 3; k++) {
                A[k] = pos(w, nt[i][k], mv, x);
                B[k] = pos(w, nt[j][k], mv, x);
            }
            if (vm__tri_pair_intersects(A, nt[i], B, nt[j])) return 0;
        }
    /* Candidate vertices: in the grid cells of the box grown by the longest edge. */
    if (g->round >= UINT32_MAX / 2 - 2) {
        memset(g->stamp, 0, w->npt * sizeof *g->stamp);
        g->round = 0;
    }
    g->round++;
    uint32_t inc = 2 * g->round, seen = 2 * g->round + 1;
    g->ncand = 0;
    for (int level = 0; level < GLEV; level++) {
        double h = level_h(g, level), L = level == GLEV - 1 ? g->lmax : h, glo[3], ghi[3];
        vm_index *head = g->head[level];
        int64_t c0[3], c1[3];
        double ncell = 1.0;
        for (int k = 0; k < 3; k++) {
            glo[k] = lo[k] - L;
            ghi[k] = hi[k] + L;
            c0[k] = cell_of(glo[k], h);
            c1[k] = cell_of(ghi[k], h);
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
            for (vm_index v = head[b]; v >= 0; v = g->next[v]) {
                if (g->stamp[v] == inc || g->stamp[v] == seen) continue;
                if (w->pdead[v] || dist2_box(w->p + 3 * (size_t)v, lo, hi) > L * L) {
                    g->stamp[v] = seen;
                    continue;
                }
                g->stamp[v] = inc;
                if (!push_cand(g, v)) {
                    w->nomem = 1;
                    return 0;
                }
            }
        }
    }
    /* Their boundary faces (each once: from its smallest candidate vertex), minus the
     * removed ones, against the new triangles. */
    for (size_t ic = 0; ic < g->ncand; ic++) {
        vm_index v = g->cand[ic];
        int skip = 0;
        for (int k = 0; k < nexv; k++) skip |= exv[k] == v;
        if (skip) continue;
        const vm_index *e;
        int nf = vm__imp_guard_faces(w, v, &e);
        if (nf < 0) {
            w->nomem = 1;
            return 0;
        }
        if (nf == 0) {
            /* Not on the boundary (now): out of the grid until a tet around it changes. */
            g_remove(w, v);
            continue;
        }
        for (int f = 0; f < nf; f++) {
            vm_index tri[3] = {v, e[2 * f], e[2 * f + 1]};
            if ((g->stamp[tri[1]] == inc && tri[1] < v) || (g->stamp[tri[2]] == inc && tri[2] < v))
                continue;
            int ex = 0;
            for (int k = 0; k < nexv; k++) ex |= exv[k] == tri[1] || exv[k] == tri[2];
            if (ex) continue;
            vm_index st[3] = {tri[0], tri[1], tri[2]};
            sort3(st);
            for (int r = 0; r < nrem && !ex; r++) {
                vm_index sr[3] = {rem[r][0], rem[r][1], rem[r][2]};
                sort3(sr);
                ex = sr[0] == st[0] && sr[1] == st[1] && sr[2] == st[2];
            }
            if (ex) continue;
            const double *B[3];
            double blo[3], bhi[3];
            for (int k = 0; k < 3; k++) B[k] = w->p + 3 * (size_t)tri[k];
            for (int c = 0; c < 3; c++) {
                blo[c] = fmin(B[0][c], fmin(B[1][c], B[2][c]));
                bhi[c] = fmax(B[0][c], fmax(B[1][c], B[2][c]));
            }
            if (blo[0] > hi[0] || blo[1] > hi[1] || blo[2] > hi[2] || bhi[0] < lo[0] ||
                bhi[1] < lo[1] || bhi[2] < lo[2])
                continue;
            for (int i = 0; i < nn; i++) {
                const double *A[3];
                int out = 0;
                for (int k = 0; k < 3; k++) A[k] = pos(w, nt[i][k], mv, x);
                for (int c = 0; c < 3 && !out; c++)
                    out = fmin(A[0][c], fmin(A[1][c], A[2][c])) > bhi[c] ||
                          fmax(A[0][c], fmax(A[1][c], A[2][c])) < blo[c];
                if (out) continue;
                if (vm__tri_pair_intersects(A, nt[i], B, tri)) return 0;
            }
        }
    }
    return 1;
}

int vm__imp_guard_move_ok(vm__imp *w, vm_index a, const double x[3]) {
    struct vm__imp_guard *g = w->g;
    if (!g || g->bucket[a] == NOB) return 1;
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
    for (int f = 0; f < nf; f++) {
        g->nt[f][0] = a;
        g->nt[f][1] = e[2 * f];
        g->nt[f][2] = e[2 * f + 1];
    }
    return vm__imp_guard_ok(w, (const vm_index(*)[3])g->nt, nf, a, x, &a, 1, NULL, 0);
}

void vm__imp_guard_free(vm__imp *w) {
    struct vm__imp_guard *g = w->g;
    if (!g) return;
    if (g->bf)
        for (size_t i = 0; i < w->npt; i++) free(g->bf[i].e);
    free(g->bf);
    for (int l = 0; l < GLEV; l++) free(g->head[l]);
    free(g->lv);
    free(g->lev);
    free(g->next);
    free(g->prev);
    free(g->bucket);
    free(g->valid);
    free(g->stamp);
    free(g->cand);
    free(g->tmp);
    free(g->nt);
    free(g);
    w->g = NULL;
}

int vm__imp_guard_init(vm__imp *w) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    struct vm__imp_guard *g = calloc(1, sizeof *g);
    if (!g) return 0;
    w->g = g;
    size_t np = w->npt;
    g->next = malloc((np + 1) * sizeof *g->next);
    g->prev = malloc((np + 1) * sizeof *g->prev);
    g->bucket = malloc((np + 1) * sizeof *g->bucket);
    g->valid = calloc(np + 1, 1);
    g->bf = calloc(np + 1, sizeof *g->bf);
    g->stamp = calloc(np + 1, sizeof *g->stamp);
    g->lv = calloc(np + 1, sizeof *g->lv);
    g->lev = calloc(np + 1, 1);
    uint8_t *on = calloc(np + 1, 1);
    if (!g->next || !g->prev || !g->bucket || !g->valid || !g->bf || !g->stamp || !g->lv ||
        !g->lev || !on) {
        free(on);
        vm__imp_guard_free(w);
        return 0;
    }
    for (size_t i = 0; i < np; i++) g->bucket[i] = NOB;
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
            if (!(dt <= g->lv[c[k]])) g->lv[c[k]] = dt;
    }
    /* Cells as large as the longest edge: a query then visits a few cells only. */
    g->h = ne && lmax > 0.0 ? lmax : ne && sum > 0.0 ? sum / (double)ne : 1.0;
    g->lmax = lmax;
    /* The first level: twice the mean boundary edge (all of the boundary of a uniform mesh,
     * where that is about the longest edge; the skin of an adaptive one, whose faces on the
     * volume border are long, while those go up the levels). */
    g->hs = ne && sum > 0.0 ? 2.0 * sum / (double)ne : g->h;
    if (g->hs > g->h) g->hs = g->h;
    for (size_t i = 0; i < np; i++) g->lev[i] = (uint8_t)(on[i] ? level_of(g, g->lv[i]) : 0);
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
