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

static void kunique(kset *s) {
    if (s->n == 0) return;
    qsort(s->e, s->n, sizeof *s->e, key3_cmp);
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

static int vlink_build(const vm__imp *w, vm_index a, vlink *l) {
    const vm__imp_star *s = &w->star[a];
    kset all;
    memset(&all, 0, sizeof all);
    l->V.n = l->E.n = l->T.n = l->B.n = 0;
    for (int32_t i = 0; i < s->n; i++) {
        const vm_index *n = w->tet + 4 * (size_t)s->t[i];
        int64_t o[3], m = 0;
        for (int k = 0; k < 4; k++)
            if (n[k] != a) o[m++] = n[k];
        if (!kpush(&l->T, mk(o[0], o[1], o[2]))) goto nomem;
        for (int k = 0; k < 3; k++) {
            if (!kpush(&l->V, mk(o[k], NONE, NONE))) goto nomem;
            if (!kpush(&all, mk(o[k], o[(k + 1) % 3], NONE))) goto nomem;
        }
    }
    /* Link edges seen once bound the link: the faces a-c-d there are boundary faces. */
    if (all.n) qsort(all.e, all.n, sizeof *all.e, key3_cmp);
    for (size_t i = 0; i < all.n;) {
        size_t j = i + 1;
        while (j < all.n && key3_cmp(&all.e[j], &all.e[i]) == 0) j++;
        if (!kpush(&l->E, all.e[i])) goto nomem;
        if (j - i == 1) {
            if (!kpush(&l->B, all.e[i])) goto nomem;
            int64_t c = all.e[i].k[0], d = all.e[i].k[1];
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
    free(all.e);
    return 1;
nomem:
    free(all.e);
    return 0;
}

/* Link condition Lk(a) ∩ Lk(b) = Lk(ab) in the closed mesh. -1 on out-of-memory. */
static int link_ok(const vm__imp *w, vm_index a, vm_index b, vlink *la, vlink *lb) {
    if (!vlink_build(w, a, la) || !vlink_build(w, b, lb)) return -1;
    kset V, E;
    memset(&V, 0, sizeof V);
    memset(&E, 0, sizeof E);
    int ok = -1;
    const vm__imp_star *s = &w->star[a];
    for (int32_t i = 0; i < s->n; i++) {
        const vm_index *n = w->tet + 4 * (size_t)s->t[i];
        if (!vm__imp_has(w, (size_t)s->t[i], b)) continue;
        int64_t o[2], m = 0;
        for (int k = 0; k < 4; k++)
            if (n[k] != a && n[k] != b) o[m++] = n[k];
        if (!kpush(&V, mk(o[0], NONE, NONE)) || !kpush(&V, mk(o[1], NONE, NONE)) ||
            !kpush(&E, mk(o[0], o[1], NONE)))
            goto done;
    }
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

/* Worst quality after merging a and b at x (a's tets and b's tets, those with both die);
 * returns as soon as it falls to floor or below. */
static double merged_min(const vm__imp *w, vm_index a, vm_index b, const double x[3],
                         double floor_q) {
    double qmin = INFINITY;
    for (int side = 0; side < 2; side++) {
        vm_index u = side ? b : a, other = side ? a : b;
        const vm__imp_star *s = &w->star[u];
        int moved = memcmp(x, w->p + 3 * (size_t)u, 3 * sizeof(double)) != 0;
        for (int32_t i = 0; i < s->n; i++) {
            size_t t = (size_t)s->t[i];
            if (vm__imp_has(w, t, other)) continue;
            double q = moved ? vm__imp_tet_q_moved(w, t, u, x) : w->q[t];
            if (q < qmin) qmin = q;
            if (qmin <= floor_q) return qmin;
        }
    }
    return qmin;
}

/* 1 when every tet left after merging a and b at x has a quality above the bar (merged_min
 * > b->f, without measuring the qualities). */
static int merged_above(const vm__imp *w, vm_index a, vm_index b, const double x[3],
                        const vm__imp_bar *bar) {
    for (int side = 0; side < 2; side++) {
        vm_index u = side ? b : a, other = side ? a : b;
        const vm__imp_star *s = &w->star[u];
        int moved = memcmp(x, w->p + 3 * (size_t)u, 3 * sizeof(double)) != 0;
        for (int32_t i = 0; i < s->n; i++) {
            size_t t = (size_t)s->t[i];
            if (vm__imp_has(w, t, other)) continue;
            if (moved ? !vm__imp_tet_above_moved(w, t, u, x, bar) : !(w->q[t] > bar->f))
                return 0;
        }
    }
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

static int fkey_cmp(const void *pa, const void *pb) {
    const fkey *a = pa, *b = pb;
    for (int i = 0; i < 3; i++)
        if (a->k[i] != b->k[i]) return a->k[i] < b->k[i] ? -1 : 1;
    return a->at < b->at ? -1 : a->at > b->at;
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
    fkey *fk = malloc((4 * ns + 1) * sizeof *fk);
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
    if (nf) qsort(fk, nf, sizeof *fk, fkey_cmp);
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
            if (w->q[t] < old) old = w->q[t];
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
    for (int opt = 0; opt < 4; opt++) {
        double x[3];
        if (opt == 0 && keep_a) memcpy(x, pa, sizeof x);
        else if (opt == 1 && keep_b) memcpy(x, pb, sizeof x);
        else if (opt == 2 && mid)
            for (int k = 0; k < 3; k++) x[k] = 0.5 * (pa[k] + pb[k]);
        else if (opt == 3 && smid) {
            for (int k = 0; k < 3; k++) x[k] = 0.5 * (pa[k] + pb[k]);
            if (!vm__imp_project(w, a, x)) continue;
        } else continue;
        if (!merged_above(w, a, b, x, &bar)) continue;
        if (opt != 1 && w->cls[b] != VM__IMP_INTERIOR && !boundary_keeps_normals(w, b, a, x))
            continue;
        if (opt != 0 && w->cls[a] != VM__IMP_INTERIOR && !boundary_keeps_normals(w, a, b, x))
            continue;
        /* the link condition holds or not whatever the position: before the guard, which
         * costs more */
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
        if (!contract_guard_ok(w, a, b, opt == 1 ? b : a, opt == 1 ? a : b, x)) continue;
        best = merged_min(w, a, b, x, -INFINITY);
        vm__imp_bar_set(w, best, &bar);
        choice = opt;
        memcpy(bx, x, sizeof bx);
    }
    if (choice < 0) return 0;
    /* Apply: keep = survivor, gone = removed vertex. */
    vm_index keep = choice == 1 ? b : a, gone = choice == 1 ? a : b;
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
    memcpy(w->p + 3 * (size_t)keep, bx, sizeof bx);
    vm__imp_guard_moved(w, keep);
    const vm__imp_star *sk = &w->star[keep];
    for (int32_t i = 0; i < sk->n; i++) {
        vm__imp_requal(w, (size_t)sk->t[i]);
        for (int k = 0; k < 4; k++) vm__imp_guard_touch(w, w->tet[4 * (size_t)sk->t[i] + k]);
    }
    w->collapses++;
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
    return 0;
}
