/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_flip.c — 2-3 and 3-2 flips of interior faces and edges around bad tets,
 * accepted when they raise the worst quality of the tets they replace (Freitag and
 * Ollivier-Gooch 1997, §3; Klingner and Shewchuk 2007, §3); in later rounds also boundary edges. */
#include <math.h>
#include <string.h>
#include "improve_internal.h"
#include "../core/vec3.h"

/* 1 when (s0, s1, s2, s3), a permutation of tet t's nodes, has t's (positive) orientation. */
static int same_orientation(const vm__imp *w, size_t t, const vm_index s[4]) {
    int pos[4];
    for (int i = 0; i < 4; i++) {
        pos[i] = -1;
        for (int k = 0; k < 4; k++)
            if (w->tet[4 * t + k] == s[i]) pos[i] = k;
    }
    int inv = 0;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) inv += pos[i] > pos[j];
    return (inv & 1) == 0;
}

static double quality_of(const vm__imp *w, const vm_index n[4]) {
    double p[4][3];
    for (int k = 0; k < 4; k++) memcpy(p[k], w->p + 3 * (size_t)n[k], sizeof p[k]);
    return vm__imp_quality(w, (const double(*)[3])p);
}

static int adjacent(const vm__imp *w, vm_index a, vm_index b) {
    const vm__imp_star *s = &w->star[a];
    for (int32_t i = 0; i < s->n; i++)
        if (vm__imp_has(w, (size_t)s->t[i], b)) return 1;
    return 0;
}

/* Replaces the nold tets by the nnew tets (all positive, checked by the caller). */
static int replace(vm__imp *w, const size_t *old, int nold, vm_index nw[][4], int nnew) {
    for (int i = 0; i < nold; i++)
        if (vm__imp_locked(w, old[i])) return 0;
    int32_t reg = w->region[old[0]];
    vm_index par = w->parent ? w->parent[old[0]] : 0;
    for (int i = 0; i < nnew; i++)
        if (vm__imp_add_tet(w, nw[i], reg, par) < 0) {
            for (int j = 0; j < i; j++) vm__imp_kill_tet(w, w->ntet - 1 - (size_t)j);
            return 0;
        }
    for (int i = 0; i < nold; i++) vm__imp_kill_tet(w, old[i]);
    return 1;
}

/* 2-3 flip of the face of t opposite its node i. */
static int flip23(vm__imp *w, size_t t, int i) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const vm_index *n = w->tet + 4 * t;
    /* (a, b, c, d) positive: the outward face order reversed. */
    vm_index a = n[fo[i][0]], b = n[fo[i][2]], c = n[fo[i][1]], d = n[i];
    long u = vm__imp_face_other(w, t, a, b, c);
    if (u < 0 || w->region[u] != w->region[t] || vm__imp_locked(w, (size_t)u)) return 0;
    vm_index e = 0;
    for (int k = 0; k < 4; k++) {
        vm_index x = w->tet[4 * (size_t)u + k];
        if (x != a && x != b && x != c) e = x;
    }
    if (adjacent(w, d, e)) return 0;
    double old = vm__imp_q(w, t) < vm__imp_q(w, u) ? vm__imp_q(w, t) : vm__imp_q(w, u);
    vm_index nw[3][4] = {{a, b, e, d}, {b, c, e, d}, {c, a, e, d}};
    vm__imp_bar bar;
    vm__imp_bar_set(w, old + VM__IMP_GAIN, &bar);
    for (int k = 0; k < 3; k++) {
        double p[4][3];
        for (int j = 0; j < 4; j++) memcpy(p[j], w->p + 3 * (size_t)nw[k][j], sizeof p[j]);
        if (!vm__imp_quality_above(w, (const double(*)[3])p, &bar)) return 0;
    }
    size_t oldt[2] = {t, (size_t)u};
    if (!replace(w, oldt, 2, nw, 3)) return 0;
    w->flips23++;
    return 1;
}

#define RING_MAX 8

/* Outward normal (unnormalised) of face (f0, f1, f2) of the positive tet with fourth node o. */
static void outward(const vm__imp *w, vm_index f0, vm_index f1, vm_index f2, vm_index o,
                    double n[3]) {
    const double *p0 = w->p + 3 * (size_t)f0, *p1 = w->p + 3 * (size_t)f1,
                 *p2 = w->p + 3 * (size_t)f2, *po = w->p + 3 * (size_t)o;
    double u[3], v[3], c[3];
    vm__sub3(p1, p0, u);
    vm__sub3(p2, p0, v);
    vm__cross3(u, v, n);
    vm__sub3(po, p0, c);
    if (vm__dot3(n, c) > 0.0)
        for (int k = 0; k < 3; k++) n[k] = -n[k];
}

/* Number of boundary faces around vertex v. */
static int boundary_valence(const vm__imp *w, vm_index v) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const vm__imp_star *s = &w->star[v];
    int c = 0;
    for (int32_t i = 0; i < s->n; i++) {
        size_t u = (size_t)s->t[i];
        const vm_index *nd = w->tet + 4 * u;
        for (int f = 0; f < 4; f++) {
            if (nd[f] == v) continue;
            if (vm__imp_face_other(w, u, nd[fo[f][0]], nd[fo[f][1]], nd[fo[f][2]]) < 0) c++;
        }
    }
    return c;
}

/* A flip of boundary edge de to the new surface edge a0-an (the ends of the open ring):
 * allowed when the old surface faces are not on a border plane, the surface moves by at most
 * the slack left by the surface band (the distance between lines de and a0-an) and the new
 * boundary faces face the way the old ones did (no fold). */
static int boundary_flip_ok(const vm__imp *w, vm_index d, vm_index e, vm_index a0, vm_index an,
                            vm_index o0, vm_index on, vm_index ak) {
    if ((w->planes[d] & w->planes[e] & (w->planes[a0] | w->planes[an])) != 0) return 0;
    double bound;
    double x[4][3];
    const vm_index v4[4] = {d, e, a0, an};
    if (w->v) {
        bound = w->o->surface_tolerance - w->o->surface_band;
        for (int k = 0; k < 4; k++) vm__imp_to_index(w, w->p + 3 * (size_t)v4[k], x[k]);
    } else {
        double de[3];
        vm__sub3(w->p + 3 * (size_t)e, w->p + 3 * (size_t)d, de);
        bound = w->o->max_surface_move_free * sqrt(vm__dot3(de, de));
        for (int k = 0; k < 4; k++) memcpy(x[k], w->p + 3 * (size_t)v4[k], sizeof x[k]);
    }
    double u[3], v[3], m[3], c[3];
    vm__sub3(x[1], x[0], u);
    vm__sub3(x[3], x[2], v);
    vm__sub3(x[2], x[0], c);
    vm__cross3(u, v, m);
    double ml = sqrt(vm__dot3(m, m));
    if (!(ml > 0.0) || fabs(vm__dot3(c, m)) / ml > bound) return 0;
    /* Old faces (a0, d, e) and (an, d, e) with inner nodes o0 and on; new faces (a0, an, d)
     * and (a0, an, e), both with inner node ak (the apex over a0-an). */
    double n1[3], n2[3], m1[3], m2[3], sum[3];
    outward(w, a0, d, e, o0, n1);
    outward(w, an, d, e, on, n2);
    outward(w, a0, an, d, ak, m1);
    outward(w, a0, an, e, ak, m2);
    for (int k = 0; k < 3; k++) sum[k] = n1[k] + n2[k];
    return vm__dot3(m1, sum) > 0.0 && vm__dot3(m2, sum) > 0.0 && vm__dot3(m1, n1) > 0.0 &&
           vm__dot3(m1, n2) > 0.0 && vm__dot3(m2, n1) > 0.0 && vm__dot3(m2, n2) > 0.0;
}

/* The grade of triangle (a[i], a[k], a[j]) of an edge removal's ring: the worse quality of
 * its tets to d and to e (the second not measured once the first is at or below bar). */
typedef struct ring_ctx {
    vm__imp *w;
    const vm_index *a;
    vm_index d, e;
} ring_ctx;
static double ring_grade(void *user, int i, int k, int j, double bar) {
    const ring_ctx *c = user;
    vm_index t1[4] = {c->a[i], c->a[k], c->a[j], c->d},
             t2[4] = {c->a[k], c->a[i], c->a[j], c->e};
    double q1 = quality_of(c->w, t1);
    if (q1 <= bar) return q1;
    double q2 = quality_of(c->w, t2);
    return q2 < q1 ? q2 : q1;
}

/* Edge removal (Shewchuk 2002, "Two discrete optimization algorithms for the topological
 * improvement of tetrahedral meshes"): the n tets around interior edge de (3 <= n <= 8) are
 * replaced by 2(n-2) tets over the best triangulation of their ring, found by dynamic
 * programming over the ring's polygon; n = 3 is the 3-2 flip, n = 4 the 4-4 flip. In later
 * rounds a boundary edge de too (open ring a0..an, 2 <= n <= 7): its polygon is closed by the
 * new surface edge a0-an and the n tets become 2(n-1); n = 2 is the surface 2-2 flip. */
static int edge_remove(vm__imp *w, size_t t, vm_index d, vm_index e) {
    size_t ring[RING_MAX];
    int n = 0;
    const vm__imp_star *s = &w->star[d];
    for (int32_t i = 0; i < s->n; i++) {
        size_t u = (size_t)s->t[i];
        if (!vm__imp_has(w, u, e)) continue;
        if (n == RING_MAX || vm__imp_locked(w, u)) return 0;
        ring[n++] = u;
    }
    if (n < 2) return 0;
    vm_index x[RING_MAX], y[RING_MAX];
    double old = INFINITY;
    for (int r = 0; r < n; r++) {
        if (w->region[ring[r]] != w->region[t]) return 0;
        if (vm__imp_q(w, ring[r]) < old) old = vm__imp_q(w, ring[r]);
        int k2 = 0;
        vm_index o[2] = {0, 0};
        for (int k = 0; k < 4; k++) {
            vm_index v = w->tet[4 * ring[r] + k];
            if (v != d && v != e) o[k2++] = v;
        }
        vm_index sq[4] = {o[0], o[1], e, d};
        int same = same_orientation(w, ring[r], sq);
        x[r] = same ? o[0] : o[1];
        y[r] = same ? o[1] : o[0];
    }
    /* Chain the ring a[0] -> a[1] -> ...: closed around an interior edge; open around a
     * boundary edge, from the tet whose x is no tet's y. */
    int r0 = 0, open = 0;
    for (int r = 0; r < n && !open; r++) {
        int found = 0;
        for (int q = 0; q < n; q++) found |= y[q] == x[r];
        if (!found) {
            r0 = r;
            open = 1;
        }
    }
    if (open ? !w->deep || n > RING_MAX - 1 : n < 3) return 0;
    int np = open ? n + 1 : n; /* polygon vertices */
    vm_index a[RING_MAX + 1];
    int used[RING_MAX] = {0};
    a[0] = x[r0];
    a[1] = y[r0];
    used[r0] = 1;
    for (int i = 2; i <= n; i++) {
        int r;
        for (r = 0; r < n; r++)
            if (!used[r] && x[r] == a[i - 1]) break;
        if (r == n) return 0;
        used[r] = 1;
        if (i == n && !open) {
            if (y[r] != a[0]) return 0;
        } else {
            a[i] = y[r];
        }
    }
    for (int i = 0; i < np; i++)
        for (int j = i + 1; j < np; j++)
            if (a[i] == a[j]) return 0;
    if (open) {
        /* The new surface edge must be new, and the surface may move only a little. */
        if (adjacent(w, a[0], a[n])) return 0;
        if (boundary_valence(w, d) < 4 || boundary_valence(w, e) < 4) return 0;
    }
    ring_ctx rc = {w, a, d, e};
    int tri[RING_MAX][3];
    double q = vm__ring_triangulate(np, old, ring_grade, &rc, NULL, tri);
    if (!(q > old + VM__IMP_GAIN)) return 0;
    if (open && !boundary_flip_ok(w, d, e, a[0], a[n], a[1], a[n - 1], a[tri[0][1]])) return 0;
    if (open) {
        /* Faces a0-an-d and a0-an-e replace a0-d-e and an-d-e. */
        vm_index nf[2][3] = {{a[0], a[n], d}, {a[0], a[n], e}};
        vm_index rf[2][3] = {{a[0], d, e}, {a[n], d, e}};
        if (!vm__imp_guard_ok(w, (const vm_index(*)[3])nf, 2, -1, NULL, NULL, 0,
                              (const vm_index(*)[3])rf, 2))
            return 0;
    }
    /* The tets over the triangles; chords must not be edges of the mesh already. */
    vm_index nw[2 * RING_MAX][4];
    int nn = 0;
    for (int r = 0; r < np - 2; r++) {
        int i = tri[r][0], k = tri[r][1], j = tri[r][2];
        if (j - i >= 2 && (i != 0 || j != np - 1) && adjacent(w, a[i], a[j])) return 0;
        vm_index t1[4] = {a[i], a[k], a[j], d}, t2[4] = {a[k], a[i], a[j], e};
        memcpy(nw[nn++], t1, sizeof t1);
        memcpy(nw[nn++], t2, sizeof t2);
    }
    if (!replace(w, ring, n, nw, nn)) return 0;
    if (open) w->boundary_flips++;
    else if (n == 3) w->flips32++;
    else w->edge_removals++;
    return 1;
}

int vm__imp_flip_tet(vm__imp *w, size_t t) {
    static const int ed[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
    for (int e = 0; e < 6; e++)
        if (edge_remove(w, t, w->tet[4 * t + ed[e][0]], w->tet[4 * t + ed[e][1]])) return 1;
    for (int i = 0; i < 4; i++)
        if (flip23(w, t, i)) return 1;
    return 0;
}
