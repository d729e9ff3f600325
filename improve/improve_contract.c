/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_contract.c — edge contraction of bad tets: seed 001 (LBIE) §6 (contract the
 * shortest edge of a tet failing the ABAQUS check), made safe by the link condition of
 * Dey–Edelsbrunner–Guha–Nekhayev (1999) on the mesh closed by a vertex at infinity, so the
 * boundary keeps its topology, and by accepting only contractions that raise the worst quality. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "improve_internal.h"

#define INF INT64_MAX
#define NONE (INT64_MAX - 1)

/* A vertex (k[1] = k[2] = NONE), an edge (k[2] = NONE) or a triangle of a link, sorted. */
typedef struct key3 {
    int64_t k[3];
} key3;

static int key3_cmp(const void *pa, const void *pb) {
    const key3 *a = pa, *b = pb;
    for (int i = 0; i < 3; i++)
        if (a->k[i] != b->k[i]) return a->k[i] < b->k[i] ? -1 : 1;
    return 0;
}

static key3 mk(int64_t a, int64_t b, int64_t c) {
    key3 r;
    if (a > b) { int64_t t = a; a = b; b = t; }
    if (b > c) { int64_t t = b; b = c; c = t; }
    if (a > b) { int64_t t = a; a = b; b = t; }
    r.k[0] = a;
    r.k[1] = b;
    r.k[2] = c;
    return r;
}

typedef struct kset {
    key3 *e;
    size_t n, cap;
} kset;

static int kpush(kset *s, key3 k) {
    if (vm__grow((void **)&s->e, &s->cap, s->n + 1, sizeof *s->e, NULL)) return 0;
    s->e[s->n++] = k;
    return 1;
}

static int key3_less(const key3 *a, const key3 *b) {
    return a->k[0] < b->k[0] ||
           (a->k[0] == b->k[0] && (a->k[1] < b->k[1] || (a->k[1] == b->k[1] && a->k[2] < b->k[2])));
}

/* Sorts e[0..n) by insertion (runs of a few dozen). */
static void ksort_ins(key3 *e, size_t n) {
    for (size_t i = 1; i < n; i++) {
        key3 x = e[i];
        size_t j = i;
        while (j > 0 && key3_less(&x, &e[j - 1])) {
            e[j] = e[j - 1];
            j--;
        }
        e[j] = x;
    }
}

/* Runs of KSORT_RUN sorted by insertion, then merged pairwise through tmp (n keys). */
#define KSORT_RUN 32
static void ksort_merge(key3 *e, size_t n, key3 *tmp) {
    for (size_t i = 0; i < n; i += KSORT_RUN) ksort_ins(e + i, n - i < KSORT_RUN ? n - i : KSORT_RUN);
    key3 *src = e, *dst = tmp;
    for (size_t w = KSORT_RUN; w < n; w *= 2) {
        for (size_t lo = 0; lo < n; lo += 2 * w) {
            size_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            size_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi) dst[k++] = key3_less(&src[j], &src[i]) ? src[j++] : src[i++];
            while (i < mid) dst[k++] = src[i++];
            while (j < hi) dst[k++] = src[j++];
        }
        key3 *t = src;
        src = dst;
        dst = t;
    }
    if (src != e) memcpy(e, src, n * sizeof *e);
}

/* Sorts n keys: by insertion up to a few dozen, else by merging (a link's sets hold a few
 * dozen to a few hundred, where qsort's calls through a pointer cost more); qsort when the
 * merge finds no memory. The same order either way (equal keys are equal values). */
#define KSORT_STACK 512
static void ksort(key3 *e, size_t n) {
    if (n <= 48) {
        ksort_ins(e, n);
        return;
    }
    key3 stack[KSORT_STACK];
    key3 *tmp = n <= KSORT_STACK ? stack : malloc(n * sizeof *tmp);
    if (!tmp) {
        qsort(e, n, sizeof *e, key3_cmp);
        return;
    }
    ksort_merge(e, n, tmp);
    if (tmp != stack) free(tmp);
}

static void kunique(kset *s) {
    if (s->n == 0) return;
    ksort(s->e, s->n);
    size_t m = 1;
    for (size_t i = 1; i < s->n; i++)
        if (key3_cmp(&s->e[i], &s->e[m - 1]) != 0) s->e[m++] = s->e[i];
    s->n = m;
}

static int kfind(const kset *s, key3 k) {
    if (s->n == 0) return 0;
    return bsearch(&k, s->e, s->n, sizeof *s->e, key3_cmp) != NULL;
}

/* Every element of a ∩ b is in c (all sorted and unique). */
static int inter_within(const kset *a, const kset *b, const kset *c) {
    size_t i = 0, j = 0;
    while (i < a->n && j < b->n) {
        int r = key3_cmp(&a->e[i], &b->e[j]);
        if (r < 0) i++;
        else if (r > 0) j++;
        else {
            if (!kfind(c, a->e[i])) return 0;
            i++;
            j++;
        }
    }
    return 1;
}

/* The link of vertex a in the mesh closed at infinity: vertices V, edges E and triangles T
 * (only the triangles not containing other; the ones that do cannot be shared). Returns 0 on
 * out-of-memory. bedge receives the boundary edges of the link (faces a-c-d on the boundary). */
typedef struct vlink {
    kset V, E, T, B;
} vlink;

static void vlink_free(vlink *l) {
    free(l->V.e);
    free(l->E.e);
    free(l->T.e);
    free(l->B.e);
}

/* Adds tet n (holding a) to a's link: its opposite triangle, vertices and edges (all). */
static int vlink_tet(vlink *l, kset *all, const vm_index n[4], vm_index a) {
    int64_t o[3], m = 0;
    for (int k = 0; k < 4; k++)
        if (n[k] != a) o[m++] = n[k];
    if (!kpush(&l->T, mk(o[0], o[1], o[2]))) return 0;
    for (int k = 0; k < 3; k++)
        if (!kpush(&l->V, mk(o[k], NONE, NONE)) || !kpush(all, mk(o[k], o[(k + 1) % 3], NONE)))
            return 0;
    return 1;
}

/* Closes a link whose tets are in: link edges seen once bound it (the faces a-c-d there are
 * boundary faces), and they join the vertex at infinity. Frees all. */
static int vlink_close(vlink *l, kset *all) {
    if (all->n) ksort(all->e, all->n);
    for (size_t i = 0; i < all->n;) {
        size_t j = i + 1;
        while (j < all->n && key3_cmp(&all->e[j], &all->e[i]) == 0) j++;
        if (!kpush(&l->E, all->e[i])) goto nomem;
        if (j - i == 1) {
            if (!kpush(&l->B, all->e[i])) goto nomem;
            int64_t c = all->e[i].k[0], d = all->e[i].k[1];
            if (!kpush(&l->T, mk(c, d, INF))) goto nomem;
            if (!kpush(&l->E, mk(c, INF, NONE)) || !kpush(&l->E, mk(d, INF, NONE))) goto nomem;
        }
        i = j;
    }
    if (l->B.n && !kpush(&l->V, mk(INF, NONE, NONE))) goto nomem;
    kunique(&l->V);
    kunique(&l->E);
    kunique(&l->T);
    kunique(&l->B);
    free(all->e);
    return 1;
nomem:
    free(all->e);
    return 0;
}

static int vlink_build(const vm__imp *w, vm_index a, vlink *l) {
    const vm__imp_star *s = &w->star[a];
    kset all;
    memset(&all, 0, sizeof all);
    l->V.n = l->E.n = l->T.n = l->B.n = 0;
    for (int32_t i = 0; i < s->n; i++)
        if (!vlink_tet(l, &all, w->tet + 4 * (size_t)s->t[i], a)) {
            free(all.e);
            return 0;
        }
    return vlink_close(l, &all);
}

/* The same from a list of tets (n of them, dead ones with node 0 < 0 skipped) that holds
 * every tet at a. */
static int vlink_list(const vm_index (*tl)[4], size_t n, vm_index a, vlink *l) {
    kset all;
    memset(&all, 0, sizeof all);
    l->V.n = l->E.n = l->T.n = l->B.n = 0;
    for (size_t i = 0; i < n; i++) {
        const vm_index *c = tl[i];
        if (c[0] < 0 || (c[0] != a && c[1] != a && c[2] != a && c[3] != a)) continue;
        if (!vlink_tet(l, &all, c, a)) {
            free(all.e);
            return 0;
        }
    }
    return vlink_close(l, &all);
}

/* Link condition Lk(a) ∩ Lk(b) = Lk(ab), given the links of a and b and the tets holding
 * both (their nodes other than a and b in o[i][0..1], i < nab). -1 on out-of-memory. */
static int link_holds(const vlink *la, const vlink *lb, vm_index b, const int64_t (*o)[2],
                      size_t nab) {
    kset V, E;
    memset(&V, 0, sizeof V);
    memset(&E, 0, sizeof E);
    int ok = -1;
    for (size_t i = 0; i < nab; i++)
        if (!kpush(&V, mk(o[i][0], NONE, NONE)) || !kpush(&V, mk(o[i][1], NONE, NONE)) ||
            !kpush(&E, mk(o[i][0], o[i][1], NONE)))
            goto done;
    /* ab on the boundary: the boundary faces a-b-c put c-inf into Lk(ab). */
    for (size_t i = 0; i < la->B.n; i++) {
        const int64_t *k = la->B.e[i].k;
        if (k[0] == b || k[1] == b) {
            int64_t c = k[0] == b ? k[1] : k[0];
            if (!kpush(&V, mk(INF, NONE, NONE)) || !kpush(&E, mk(c, INF, NONE))) goto done;
        }
    }
    kunique(&V);
    kunique(&E);
    ok = 0;
    if (!inter_within(&la->V, &lb->V, &V)) goto done;
    if (!inter_within(&la->E, &lb->E, &E)) goto done;
    kset none;
    memset(&none, 0, sizeof none);
    if (!inter_within(&la->T, &lb->T, &none)) goto done;
    ok = 1;
done:
    free(V.e);
    free(E.e);
    return ok;
}

/* Link condition Lk(a) ∩ Lk(b) = Lk(ab) in the closed mesh. -1 on out-of-memory. */
static int link_ok(const vm__imp *w, vm_index a, vm_index b, vlink *la, vlink *lb) {
    if (!vlink_build(w, a, la) || !vlink_build(w, b, lb)) return -1;
    const vm__imp_star *s = &w->star[a];
    int64_t ob[32][2]; /* the tets around an edge: a few, on the heap past 32 */
    int64_t(*o)[2] = s->n <= 32 ? ob : malloc(((size_t)s->n + 1) * sizeof *o);
    if (!o) return -1;
    size_t nab = 0;
    for (int32_t i = 0; i < s->n; i++) {
        const vm_index *n = w->tet + 4 * (size_t)s->t[i];
        if (!vm__imp_has(w, (size_t)s->t[i], b)) continue;
        int m = 0;
        for (int k = 0; k < 4; k++)
            if (n[k] != a && n[k] != b) o[nab][m++] = n[k];
        nab++;
    }
    int ok = link_holds(la, lb, b, (const int64_t(*)[2])o, nab);
    if (o != ob) free(o);
    return ok;
}

/* The same on a list of tets (see vlink_list). */
static int link_ok_list(const vm_index (*tl)[4], size_t n, vm_index a, vm_index b) {
    vlink la, lb;
    memset(&la, 0, sizeof la);
    memset(&lb, 0, sizeof lb);
    int64_t(*o)[2] = malloc((n + 1) * sizeof *o);
    int ok = -1;
    if (o && vlink_list(tl, n, a, &la) && vlink_list(tl, n, b, &lb)) {
        size_t nab = 0;
        for (size_t i = 0; i < n; i++) {
            const vm_index *c = tl[i];
            int ha = 0, hb = 0;
            for (int k = 0; k < 4; k++) {
                ha |= c[k] == a;
                hb |= c[k] == b;
            }
            if (c[0] < 0 || !ha || !hb) continue;
            int m = 0;
            for (int k = 0; k < 4; k++)
                if (c[k] != a && c[k] != b) o[nab][m++] = c[k];
            nab++;
        }
        ok = link_holds(&la, &lb, b, (const int64_t(*)[2])o, nab);
    }
    vlink_free(&la);
    vlink_free(&lb);
    free(o);
    return ok;
}

/* May b be merged into a (a keeps its position and constraints)? */
static int may_merge(const vm__imp *w, vm_index a, vm_index b) {
    if (w->cls[b] == VM__IMP_INTERIOR) return 1;
    if (w->cls[a] == VM__IMP_INTERIOR) return 0; /* never pull the boundary inside */
    return (w->planes[b] & ~w->planes[a]) == 0;
}

static void tri_normal(const double *p, const double *q, const double *r, double n[3]) {
    double u[3], v[3];
    for (int k = 0; k < 3; k++) {
        u[k] = q[k] - p[k];
        v[k] = r[k] - p[k];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
}

/* cos 30 degrees: how far a surviving boundary face may turn when a vertex moves. */
#define COS_30 0.866

/* Boundary faces of tets around b that survive keep their orientation within 30 degrees
 * when b moves to x (no fold or crease of the surface). */
static int boundary_keeps_normals(const vm__imp *w, vm_index b, vm_index a, const double x[3]) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const vm__imp_star *s = &w->star[b];
    for (int32_t i = 0; i < s->n; i++) {
        size_t t = (size_t)s->t[i];
        if (vm__imp_has(w, t, a)) continue;
        const vm_index *n = w->tet + 4 * t;
        for (int f = 0; f < 4; f++) {
            if (n[f] == b) continue; /* the face opposite b does not move */
            vm_index c[3] = {n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]};
            if (vm__imp_face_other(w, t, c[0], c[1], c[2]) >= 0) continue;
            const double *P[3], *Q[3];
            for (int k = 0; k < 3; k++) {
                P[k] = w->p + 3 * (size_t)c[k];
                Q[k] = c[k] == b ? x : P[k];
            }
            double n0[3], n1[3];
            tri_normal(P[0], P[1], P[2], n0);
            tri_normal(Q[0], Q[1], Q[2], n1);
            double d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
            double l = sqrt((n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]) *
                            (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]));
            if (!(d > COS_30 * l)) return 0;
        }
    }
    return 1;
}

/* 1 when every tet left after merging a and b at x has a quality above the bar, and then
 * [out] *qmin their worst quality (a's tets and b's tets, those with both die). The first tet that moves is tried on its
 * cosines (vm__imp_tet_above_moved: most options that fail end there); the others are
 * measured, which gives the same answer, so that an option that passes has its worst quality
 * without a second sweep. */
static int merged_above(const vm__imp *w, vm_index a, vm_index b, const double x[3],
                        const vm__imp_bar *bar, double *qmin) {
    double m = INFINITY;
    size_t first = SIZE_MAX; /* the tet tried on its cosines */
    vm_index fu = -1;
    for (int side = 0; side < 2; side++) {
        vm_index u = side ? b : a, other = side ? a : b;
        const vm__imp_star *s = &w->star[u];
        int moved = memcmp(x, w->p + 3 * (size_t)u, 3 * sizeof(double)) != 0;
        for (int32_t i = 0; i < s->n; i++) {
            size_t t = (size_t)s->t[i];
            if (vm__imp_has(w, t, other)) continue;
            double q;
            if (!moved) {
                q = vm__imp_q(w, t);
            } else if (first == SIZE_MAX) {
                if (!vm__imp_tet_above_moved(w, t, u, x, bar)) return 0;
                first = t;
                fu = u;
                continue;
            } else {
                q = vm__imp_tet_q_moved(w, t, u, x);
            }
            if (!(q > bar->f)) return 0;
            if (q < m) m = q;
        }
    }
    if (first != SIZE_MAX) {
        double q = vm__imp_tet_q_moved(w, first, fu, x);
        if (q < m) m = q;
    }
    *qmin = m;
    return 1;
}

/* A face by its sorted nodes, and where it was found (4 tet + face). */
typedef struct fkey {
    int64_t k[3];
    size_t at;
} fkey;

static int fkey_same(const fkey *a, const fkey *b) {
    return a->k[0] == b->k[0] && a->k[1] == b->k[1] && a->k[2] == b->k[2];
}

/* By nodes, then by where found: a total order. */
static int fkey_less(const fkey *a, const fkey *b) {
    for (int i = 0; i < 3; i++)
        if (a->k[i] != b->k[i]) return a->k[i] < b->k[i];
    return a->at < b->at;
}

/* Sorts n faces by fkey_less (a total order: the same result as any sort): by
 * insertion in runs, then merging through tmp (room for n faces). */
static void fsort(fkey *e, size_t n, fkey *tmp) {
    for (size_t r = 0; r < n; r += KSORT_RUN) {
        fkey *b = e + r;
        size_t m = n - r < KSORT_RUN ? n - r : KSORT_RUN;
        for (size_t i = 1; i < m; i++) {
            fkey x = b[i];
            size_t j = i;
            while (j > 0 && fkey_less(&x, &b[j - 1])) {
                b[j] = b[j - 1];
                j--;
            }
            b[j] = x;
        }
    }
    fkey *src = e, *dst = tmp;
    for (size_t w = KSORT_RUN; w < n; w *= 2) {
        for (size_t lo = 0; lo < n; lo += 2 * w) {
            size_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            size_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi) dst[k++] = fkey_less(&src[j], &src[i]) ? src[j++] : src[i++];
            while (i < mid) dst[k++] = src[i++];
            while (j < hi) dst[k++] = src[j++];
        }
        fkey *t = src;
        src = dst;
        dst = t;
    }
    if (src != e) memcpy(e, src, n * sizeof *e);
}

/* 1 when merging gone into keep at x (edge ab = {keep, gone}) makes no boundary triangles
 * cross: the boundary faces around the merged vertex, found among the tets that survive,
 * against each other and the boundary near them. */
static int contract_guard_ok(vm__imp *w, vm_index a, vm_index b, vm_index keep, vm_index gone,
                             const double x[3]) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const vm_index *e;
    int fa = vm__imp_guard_faces(w, a, &e), fb = vm__imp_guard_faces(w, b, &e);
    if (fa < 0 || fb < 0) {
        w->nomem = 1;
        return 0;
    }
    if (fa == 0 && fb == 0) return 1; /* no boundary face moves or changes */
    size_t ns = (size_t)w->star[a].n + (size_t)w->star[b].n;
    vm_index(*s)[4] = malloc((ns + 1) * sizeof *s);
    vm_index(*nt)[3] = malloc((4 * ns + 1) * sizeof *nt);
    fkey *fk = malloc((8 * ns + 2) * sizeof *fk); /* and as many for sorting them */
    uint8_t *one = calloc(4 * ns + 1, 1);
    if (!s || !nt || !fk || !one) {
        free(s);
        free(nt);
        free(fk);
        free(one);
        w->nomem = 1;
        return 0;
    }
    size_t n = 0;
    for (int side = 0; side < 2; side++) {
        vm_index u = side ? b : a, other = side ? a : b;
        const vm__imp_star *st = &w->star[u];
        for (int32_t i = 0; i < st->n; i++) {
            size_t t = (size_t)st->t[i];
            if (vm__imp_has(w, t, other)) continue;
            for (int k = 0; k < 4; k++) {
                vm_index v = w->tet[4 * t + k];
                s[n][k] = v == gone ? keep : v;
            }
            n++;
        }
    }
    /* The faces at keep of the merged tets; one no other merged tet has is on the boundary
     * (sorted by their nodes, a shared face sits next to its twin). */
    size_t nf = 0;
    for (size_t i = 0; i < n; i++)
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {s[i][fo[f][0]], s[i][fo[f][1]], s[i][fo[f][2]]};
            if (c[0] != keep && c[1] != keep && c[2] != keep) continue;
            key3 k = mk(c[0], c[1], c[2]);
            fk[nf].k[0] = k.k[0];
            fk[nf].k[1] = k.k[1];
            fk[nf].k[2] = k.k[2];
            fk[nf].at = 4 * i + (size_t)f;
            nf++;
        }
    fsort(fk, nf, fk + 4 * ns + 1);
    for (size_t i = 0; i < nf; i++)
        one[fk[i].at] = !(i > 0 && fkey_same(&fk[i], &fk[i - 1])) &&
                        !(i + 1 < nf && fkey_same(&fk[i], &fk[i + 1]));
    int nn = 0;
    for (size_t i = 0; i < n; i++)
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {s[i][fo[f][0]], s[i][fo[f][1]], s[i][fo[f][2]]};
            if (c[0] != keep && c[1] != keep && c[2] != keep) continue;
            if (!one[4 * i + (size_t)f]) continue;
            memcpy(nt[nn++], c, sizeof c);
        }
    vm_index exv[2] = {a, b};
    int ok = vm__imp_guard_ok(w, (const vm_index(*)[3])nt, nn, keep, x, exv, 2, NULL, 0);
    free(s);
    free(nt);
    free(fk);
    free(one);
    return ok;
}

/* Merges gone into keep, which goes to x; 0 (nothing changed) when the stars find no
 * memory. */
static int merge_apply(vm__imp *w, vm_index keep, vm_index gone, const double x[3]) {
    const vm__imp_star *sg = &w->star[gone];
    if (vm__imp_scratch(w, (size_t)sg->n) != VM_OK) return 0;
    int32_t ng = sg->n;
    memcpy(w->buf, sg->t, (size_t)ng * sizeof *w->buf);
    /* Make room in the survivor's star first, so nothing fails half-way. */
    for (int32_t i = 0; i < ng; i++)
        if (!vm__imp_star_add(w, keep, -1)) {
            while (i-- > 0) vm__imp_star_remove(w, keep, -1); /* no -1 left in the star */
            return 0;
        }
    for (int32_t i = 0; i < ng; i++) vm__imp_star_remove(w, keep, -1);
    for (int32_t i = 0; i < ng; i++) {
        size_t t = (size_t)w->buf[i];
        if (vm__imp_has(w, t, keep)) vm__imp_kill_tet(w, t);
    }
    for (int32_t i = 0; i < ng; i++) {
        size_t t = (size_t)w->buf[i];
        if (w->dead[t]) continue;
        for (int k = 0; k < 4; k++)
            if (w->tet[4 * t + k] == gone) w->tet[4 * t + k] = keep;
        vm__imp_star_add(w, keep, (vm_index)t);
    }
    w->star[gone].n = 0;
    w->pdead[gone] = 1;
    memcpy(w->p + 3 * (size_t)keep, x, 3 * sizeof *x);
    vm__imp_guard_moved(w, keep);
    const vm__imp_star *sk = &w->star[keep];
    for (int32_t i = 0; i < sk->n; i++) vm__imp_requal(w, (size_t)sk->t[i]);
    /* The boundary faces change only around the vertices whose stars changed: those of the
     * tets that died (vm__imp_kill_tet told the guard) and of the tets that had gone. */
    for (int32_t i = 0; i < ng; i++) {
        size_t t = (size_t)w->buf[i];
        if (w->dead[t]) continue;
        for (int k = 0; k < 4; k++) vm__imp_guard_touch(w, w->tet[4 * t + k]);
    }
    w->collapses++;
    return 1;
}

/* Tries to contract edge ab; returns 1 when done. */
static int try_edge(vm__imp *w, vm_index a, vm_index b) {
    /* A locked vertex neither moves nor goes: it can only be the survivor, in place (so no
     * locked tet dies either: one with both ends would have both locked). */
    int lka = vm__imp_vlocked(w, a), lkb = vm__imp_vlocked(w, b);
    int keep_a = !lkb && may_merge(w, a, b), keep_b = !lka && may_merge(w, b, a);
    int mid = !lka && !lkb && w->cls[a] == VM__IMP_INTERIOR && w->cls[b] == VM__IMP_INTERIOR;
    if (!keep_a && !keep_b) return 0;
    /* Old worst quality and region of the cavity. */
    double old = INFINITY;
    int32_t reg = 0;
    int first = 1;
    for (int side = 0; side < 2; side++) {
        const vm__imp_star *s = &w->star[side ? b : a];
        for (int32_t i = 0; i < s->n; i++) {
            size_t t = (size_t)s->t[i];
            if (first) reg = w->region[t], first = 0;
            if (w->region[t] != reg) return 0;
            if (vm__imp_q(w, t) < old) old = vm__imp_q(w, t);
        }
    }
    double floor_q = old + VM__IMP_GAIN;
    double best = floor_q, bx[3];
    vm__imp_bar bar;
    vm__imp_bar_set(w, best, &bar);
    int choice = -1, link = -1; /* link: not known yet */
    const double *pa = w->p + 3 * (size_t)a, *pb = w->p + 3 * (size_t)b;
    /* Surface edges may also meet at their midpoint put back on the isosurface. */
    int smid = !lka && !lkb && w->v && w->cls[a] == VM__IMP_SURF && w->cls[b] == VM__IMP_SURF &&
               w->iso_hi[a] == w->iso_hi[b];
    /* The options above the old worst, each with its worst quality; then the guard, which
     * costs most, from the best down (ties: the lower option) until one passes: the option
     * of highest quality among those that pass every test. */
    double cq[4], cx[4][3];
    int cand[4], nc = 0;
    for (int opt = 0; opt < 4; opt++) {
        double *x = cx[opt];
        if (opt == 0 && keep_a) memcpy(x, pa, 3 * sizeof *x);
        else if (opt == 1 && keep_b) memcpy(x, pb, 3 * sizeof *x);
        else if (opt == 2 && mid)
            for (int k = 0; k < 3; k++) x[k] = 0.5 * (pa[k] + pb[k]);
        else if (opt == 3 && smid) {
            for (int k = 0; k < 3; k++) x[k] = 0.5 * (pa[k] + pb[k]);
            if (!vm__imp_project(w, a, x)) continue;
        } else continue;
        double qm;
        if (!merged_above(w, a, b, x, &bar, &qm)) continue;
        if (opt != 1 && w->cls[b] != VM__IMP_INTERIOR && !boundary_keeps_normals(w, b, a, x))
            continue;
        if (opt != 0 && w->cls[a] != VM__IMP_INTERIOR && !boundary_keeps_normals(w, a, b, x))
            continue;
        /* the link condition holds or not whatever the position */
        if (link < 0) {
            vlink la, lb;
            memset(&la, 0, sizeof la);
            memset(&lb, 0, sizeof lb);
            link = link_ok(w, a, b, &la, &lb);
            vlink_free(&la);
            vlink_free(&lb);
            if (link < 0) w->nomem = 1;
            if (link <= 0) return 0;
        }
        cq[opt] = qm;
        int j = nc++;
        while (j > 0 && cq[cand[j - 1]] < cq[opt]) {
            cand[j] = cand[j - 1];
            j--;
        }
        cand[j] = opt;
    }
    for (int i = 0; i < nc && choice < 0; i++) {
        int opt = cand[i];
        if (!vm__imp_chord_ok(w, a, b, cx[opt]) || !vm__imp_kept_near(w, a, b, cx[opt]) ||
            !contract_guard_ok(w, a, b, opt == 1 ? b : a, opt == 1 ? a : b, cx[opt]))
            continue;
        choice = opt;
        memcpy(bx, cx[opt], sizeof bx);
    }
    if (choice < 0) return 0;
    /* Apply: keep = survivor, gone = removed vertex. */
    return merge_apply(w, choice == 1 ? b : a, choice == 1 ? a : b, bx);
}

/* Clusters: a bad tet whose shortest edge is below CLUSTER_REL times its longest, whose
 * ends have other vertices within CLUSTER_REACH times that edge (at most CLUSTER_MAX in
 * all, none farther than CLUSTER_REL longest edges from the survivor), goes with the whole
 * cluster merged into one of its vertices. Where the isosurface passes within a hundredth of
 * a voxel of a lattice point on a box edge, the point, the surface's corner on that edge and
 * the rims on both border planes sit within 0.02 of each other: every single contraction
 * there fails the link condition (the three around the corner close a cycle through the
 * fourth) or inverts a tet, but all four into one point keep the topology. */
#define CLUSTER_REL 0.1
#define CLUSTER_REACH 2.0
#define CLUSTER_MAX 5

static double dist2(const vm__imp *w, vm_index a, vm_index b) {
    const double *p = w->p + 3 * (size_t)a, *q = w->p + 3 * (size_t)b;
    return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
           (p[2] - q[2]) * (p[2] - q[2]);
}

static int in_set(const vm_index *K, int nk, vm_index v) {
    for (int i = 0; i < nk; i++)
        if (K[i] == v) return 1;
    return 0;
}

/* Maps the cluster K onto s in the copy tl (a tet holding two of them dies: node 0 = -1);
 * returns the worst quality left, or -INFINITY when a tet is not above floor_q. */
static double cluster_mapped_min(const vm__imp *w, const vm_index (*tl)[4], size_t nu,
                                 const vm_index *K, int nk, vm_index s, double floor_q) {
    double qmin = INFINITY;
    for (size_t i = 0; i < nu; i++) {
        int cnt = 0;
        double p[4][3];
        for (int k = 0; k < 4; k++) {
            vm_index v = tl[i][k];
            if (in_set(K, nk, v)) {
                cnt++;
                v = s;
            }
            memcpy(p[k], w->p + 3 * (size_t)v, sizeof p[k]);
        }
        if (cnt >= 2) continue;
        double q = vm__imp_quality(w, (const double(*)[3])p);
        if (!(q > floor_q)) return -INFINITY;
        if (q < qmin) qmin = q;
    }
    return qmin;
}

/* The boundary faces of the tets of tl at k keep their orientation within 30 degrees when
 * every vertex of K goes to s's position. */
static int cluster_keeps_normals(const vm__imp *w, const size_t *U, size_t nu, const vm_index *K,
                                 int nk, vm_index s) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const double *ps = w->p + 3 * (size_t)s;
    for (size_t i = 0; i < nu; i++) {
        const vm_index *n = w->tet + 4 * U[i];
        int cnt = 0;
        for (int k = 0; k < 4; k++) cnt += in_set(K, nk, n[k]);
        if (cnt != 1) continue;
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]};
            int moved = 0;
            for (int k = 0; k < 3; k++) moved |= c[k] != s && in_set(K, nk, c[k]);
            if (!moved || vm__imp_face_other(w, U[i], c[0], c[1], c[2]) >= 0) continue;
            const double *P[3], *Q[3];
            for (int k = 0; k < 3; k++) {
                P[k] = w->p + 3 * (size_t)c[k];
                Q[k] = in_set(K, nk, c[k]) ? ps : P[k];
            }
            double n0[3], n1[3];
            tri_normal(P[0], P[1], P[2], n0);
            tri_normal(Q[0], Q[1], Q[2], n1);
            double d = n0[0] * n1[0] + n0[1] * n1[1] + n0[2] * n1[2];
            double l = sqrt((n0[0] * n0[0] + n0[1] * n0[1] + n0[2] * n0[2]) *
                            (n1[0] * n1[0] + n1[1] * n1[1] + n1[2] * n1[2]));
            if (!(d > COS_30 * l)) return 0;
        }
    }
    return 1;
}

/* Whether the members of K other than s, merged into s one by one in the order ord, each
 * meet the link condition, on a copy of the tets (tl, nu; restored after). -1 on nomem. */
static int cluster_links(const vm_index (*tl0)[4], size_t nu, const vm_index *ord, int no,
                         vm_index s) {
    vm_index(*tl)[4] = malloc((nu + 1) * sizeof *tl);
    if (!tl) return -1;
    memcpy(tl, tl0, nu * sizeof *tl);
    int ok = 1;
    for (int i = 0; i < no && ok == 1; i++) {
        vm_index g = ord[i];
        ok = link_ok_list((const vm_index(*)[4])tl, nu, s, g);
        for (size_t j = 0; j < nu && ok == 1; j++) {
            if (tl[j][0] < 0) continue;
            int hs = 0, hg = 0;
            for (int k = 0; k < 4; k++) {
                hs |= tl[j][k] == s;
                hg |= tl[j][k] == g;
            }
            if (hs && hg) tl[j][0] = -1;
            else if (hg)
                for (int k = 0; k < 4; k++)
                    if (tl[j][k] == g) tl[j][k] = s;
        }
    }
    free(tl);
    return ok;
}

/* The boundary triangles at s once K is merged into it (the faces at s that one tet of the
 * merged copy has) make no boundary triangles cross. */
static int cluster_guard_ok(vm__imp *w, const vm_index (*tl)[4], size_t nu, const vm_index *K,
                            int nk, vm_index s) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    fkey *fk = malloc((8 * nu + 2) * sizeof *fk); /* and as many for sorting them */
    vm_index(*nt)[3] = malloc((4 * nu + 1) * sizeof *nt);
    vm_index(*m)[4] = malloc((nu + 1) * sizeof *m);
    if (!fk || !nt || !m) {
        free(fk);
        free(nt);
        free(m);
        w->nomem = 1;
        return 0;
    }
    size_t nm = 0, nf = 0;
    for (size_t i = 0; i < nu; i++) {
        int cnt = 0;
        for (int k = 0; k < 4; k++) {
            m[nm][k] = in_set(K, nk, tl[i][k]) ? s : tl[i][k];
            cnt += in_set(K, nk, tl[i][k]);
        }
        if (cnt < 2) nm++;
    }
    for (size_t i = 0; i < nm; i++)
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {m[i][fo[f][0]], m[i][fo[f][1]], m[i][fo[f][2]]};
            if (c[0] != s && c[1] != s && c[2] != s) continue;
            key3 k = mk(c[0], c[1], c[2]);
            memcpy(fk[nf].k, k.k, sizeof k.k);
            fk[nf].at = 4 * i + (size_t)f;
            nf++;
        }
    fsort(fk, nf, fk + 4 * nu + 1);
    int nn = 0;
    for (size_t i = 0; i < nf; i++) {
        if ((i > 0 && fkey_same(&fk[i], &fk[i - 1])) || (i + 1 < nf && fkey_same(&fk[i], &fk[i + 1])))
            continue;
        size_t t = fk[i].at / 4;
        int f = (int)(fk[i].at % 4);
        for (int k = 0; k < 3; k++) nt[nn][k] = m[t][fo[f][k]];
        nn++;
    }
    int ok = vm__imp_guard_ok(w, (const vm_index(*)[3])nt, nn, s, w->p + 3 * (size_t)s, K, nk,
                              NULL, 0);
    free(fk);
    free(nt);
    free(m);
    return ok;
}

static int key_cmp64(const void *pa, const void *pb) {
    int64_t a = *(const int64_t *)pa, b = *(const int64_t *)pb;
    return a < b ? -1 : a > b;
}

static int key_cmp32(const void *pa, const void *pb) {
    int32_t a = *(const int32_t *)pa, b = *(const int32_t *)pb;
    return a < b ? -1 : a > b;
}

static int next_perm(vm_index *a, int n) {
    int i = n - 2;
    while (i >= 0 && a[i] >= a[i + 1]) i--;
    if (i < 0) return 0;
    int j = n - 1;
    while (a[j] <= a[i]) j--;
    vm_index t = a[i];
    a[i] = a[j];
    a[j] = t;
    for (int l = i + 1, r = n - 1; l < r; l++, r--) {
        t = a[l];
        a[l] = a[r];
        a[r] = t;
    }
    return 1;
}

static int slot_cmp(const void *pa, const void *pb) {
    size_t a = *(const size_t *)pa, b = *(const size_t *)pb;
    return a < b ? -1 : a > b;
}

/* Merges the cluster of tet t's shortest edge into one of its vertices when that raises the
 * worst quality of the tets around it; 1 when done. */
static int cluster_collapse(vm__imp *w, size_t t) {
    static const int ed[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    const vm_index *n = w->tet + 4 * t;
    double lmin = INFINITY, lmax = 0.0;
    int emin = 0;
    for (int e = 0; e < 6; e++) {
        double l = dist2(w, n[ed[e][0]], n[ed[e][1]]);
        if (l < lmin) lmin = l, emin = e;
        if (l > lmax) lmax = l;
    }
    if (!(lmin < CLUSTER_REL * CLUSTER_REL * lmax)) return 0;
    vm_index K[CLUSTER_MAX];
    int nk = 2;
    K[0] = n[ed[emin][0]];
    K[1] = n[ed[emin][1]];
    double reach2 = CLUSTER_REACH * CLUSTER_REACH * lmin;
    for (int i = 0; i < nk; i++) {
        const vm__imp_star *st = &w->star[K[i]];
        for (int32_t j = 0; j < st->n; j++)
            for (int k = 0; k < 4; k++) {
                vm_index v = w->tet[4 * (size_t)st->t[j] + k];
                if (in_set(K, nk, v) || dist2(w, K[i], v) > reach2) continue;
                if (nk == CLUSTER_MAX) return 0;
                K[nk++] = v;
            }
    }
    if (nk < 3) return 0; /* the plain contraction has tried it */
    /* the tets around the cluster, one region, and their worst quality */
    size_t cap = 0;
    for (int i = 0; i < nk; i++) cap += (size_t)w->star[K[i]].n;
    size_t *U = malloc((cap + 1) * sizeof *U);
    vm_index(*tl)[4] = malloc((cap + 1) * sizeof *tl);
    if (!U || !tl) {
        free(U);
        free(tl);
        w->nomem = 1;
        return 0;
    }
    size_t nu = 0;
    for (int i = 0; i < nk; i++)
        for (int32_t j = 0; j < w->star[K[i]].n; j++) U[nu++] = (size_t)w->star[K[i]].t[j];
    qsort(U, nu, sizeof *U, slot_cmp);
    size_t u = 0;
    for (size_t i = 0; i < nu; i++)
        if (u == 0 || U[i] != U[u - 1]) U[u++] = U[i];
    nu = u;
    double old = INFINITY;
    int ok = 1;
    for (size_t i = 0; i < nu; i++) {
        memcpy(tl[i], w->tet + 4 * U[i], sizeof tl[i]);
        if (w->region[U[i]] != w->region[U[0]]) ok = 0;
        if (vm__imp_q(w, U[i]) < old) old = vm__imp_q(w, U[i]);
    }
    double best = old + VM__IMP_GAIN;
    vm_index bs = -1, bord[CLUSTER_MAX];
    for (int si = 0; ok && si < nk; si++) {
        vm_index s = K[si], ord[CLUSTER_MAX];
        int no = 0, fit = 1;
        for (int i = 0; i < nk && fit; i++) {
            if (K[i] == s) continue;
            fit = !vm__imp_vlocked(w, K[i]) && may_merge(w, s, K[i]) &&
                  dist2(w, s, K[i]) <= CLUSTER_REL * CLUSTER_REL * lmax;
            ord[no++] = K[i];
        }
        if (!fit) continue;
        double q = cluster_mapped_min(w, (const vm_index(*)[4])tl, nu, K, nk, s, best);
        if (!(q > best) || !cluster_keeps_normals(w, U, nu, K, nk, s)) continue;
        /* an order of the merges that keeps the topology at every step */
        int lk = 0;
        qsort(ord, (size_t)no, sizeof *ord, sizeof(vm_index) == 8 ? key_cmp64 : key_cmp32);
        do {
            lk = cluster_links((const vm_index(*)[4])tl, nu, ord, no, s);
        } while (lk == 0 && next_perm(ord, no));
        if (lk < 0) w->nomem = 1;
        if (lk != 1) continue;
        if (!cluster_guard_ok(w, (const vm_index(*)[4])tl, nu, K, nk, s)) continue;
        best = q;
        bs = s;
        memcpy(bord, ord, sizeof ord);
    }
    free(U);
    free(tl);
    if (bs < 0) return 0;
    double x[3];
    memcpy(x, w->p + 3 * (size_t)bs, sizeof x);
    for (int i = 0; i < nk - 1; i++)
        if (!merge_apply(w, bs, bord[i], x)) return i > 0;
    return 1;
}

int vm__imp_contract_tet(vm__imp *w, size_t t) {
    static const int ed[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    double len[6];
    int order[6];
    for (int e = 0; e < 6; e++) {
        const double *p = w->p + 3 * (size_t)w->tet[4 * t + ed[e][0]];
        const double *q = w->p + 3 * (size_t)w->tet[4 * t + ed[e][1]];
        len[e] = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                 (p[2] - q[2]) * (p[2] - q[2]);
        order[e] = e;
    }
    for (int i = 1; i < 6; i++)
        for (int j = i; j > 0 && len[order[j]] < len[order[j - 1]]; j--) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    for (int i = 0; i < 6; i++) {
        vm_index a = w->tet[4 * t + ed[order[i]][0]], b = w->tet[4 * t + ed[order[i]][1]];
        if (try_edge(w, a, b)) return 1;
        if (w->nomem) return 0;
    }
    return cluster_collapse(w, t);
}
