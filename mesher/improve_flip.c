/* mesher/improve_flip.c — 2-3 and 3-2 flips of interior faces and edges around bad tets,
 * accepted when they raise the worst quality of the tets they replace (Freitag and
 * Ollivier-Gooch 1997, §3; Klingner and Shewchuk 2007, §3). Boundary faces never flip. */
#include <math.h>
#include <string.h>
#include "improve_internal.h"

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
    int32_t reg = w->region[old[0]];
    vm_index par = w->parent[old[0]];
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
    if (u < 0 || w->region[u] != w->region[t]) return 0;
    vm_index e = 0;
    for (int k = 0; k < 4; k++) {
        vm_index x = w->tet[4 * (size_t)u + k];
        if (x != a && x != b && x != c) e = x;
    }
    if (adjacent(w, d, e)) return 0;
    double old = w->q[t] < w->q[u] ? w->q[t] : w->q[u];
    vm_index nw[3][4] = {{a, b, e, d}, {b, c, e, d}, {c, a, e, d}};
    for (int k = 0; k < 3; k++)
        if (!(quality_of(w, nw[k]) > old + 1e-9)) return 0;
    size_t oldt[2] = {t, (size_t)u};
    if (!replace(w, oldt, 2, nw, 3)) return 0;
    w->flips23++;
    return 1;
}

#define RING_MAX 8

/* Edge removal (Shewchuk 2002, "Two discrete optimization algorithms for the topological
 * improvement of tetrahedral meshes"): the n tets around interior edge de (3 <= n <= 8) are
 * replaced by 2(n-2) tets over the best triangulation of their ring, found by dynamic
 * programming over the ring's polygon; n = 3 is the 3-2 flip, n = 4 the 4-4 flip. */
static int edge_remove(vm__imp *w, size_t t, vm_index d, vm_index e) {
    size_t ring[RING_MAX];
    int n = 0;
    const vm__imp_star *s = &w->star[d];
    for (int32_t i = 0; i < s->n; i++) {
        size_t u = (size_t)s->t[i];
        if (!vm__imp_has(w, u, e)) continue;
        if (n == RING_MAX) return 0;
        ring[n++] = u;
    }
    if (n < 3) return 0;
    vm_index x[RING_MAX], y[RING_MAX];
    double old = INFINITY;
    for (int r = 0; r < n; r++) {
        if (w->region[ring[r]] != w->region[t]) return 0;
        if (w->q[ring[r]] < old) old = w->q[ring[r]];
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
    /* Chain the ring a[0] -> a[1] -> ... -> a[0]; an open chain means a boundary edge. */
    vm_index a[RING_MAX];
    int used[RING_MAX] = {0};
    a[0] = x[0];
    a[1] = y[0];
    used[0] = 1;
    for (int i = 2; i <= n; i++) {
        int r;
        for (r = 0; r < n; r++)
            if (!used[r] && x[r] == a[i - 1]) break;
        if (r == n) return 0;
        used[r] = 1;
        if (i == n) {
            if (y[r] != a[0]) return 0;
        } else {
            a[i] = y[r];
        }
    }
    for (int i = 0; i < n; i++)
        for (int j = i + 1; j < n; j++)
            if (a[i] == a[j]) return 0;
    /* best[i][j]: best worst quality triangulating the sub-polygon a[i..j]; cut[i][j] the apex. */
    double best[RING_MAX][RING_MAX];
    int cut[RING_MAX][RING_MAX];
    for (int len = 2; len < n; len++)
        for (int i = 0; i + len < n; i++) {
            int j = i + len;
            best[i][j] = -INFINITY;
            cut[i][j] = -1;
            for (int k = i + 1; k < j; k++) {
                double m = INFINITY;
                if (k - i >= 2 && best[i][k] < m) m = best[i][k];
                if (j - k >= 2 && best[k][j] < m) m = best[k][j];
                if (m <= best[i][j] || m <= old) continue;
                vm_index t1[4] = {a[i], a[k], a[j], d}, t2[4] = {a[k], a[i], a[j], e};
                double q1 = quality_of(w, t1);
                if (q1 < m) m = q1;
                if (m <= best[i][j]) continue;
                double q2 = quality_of(w, t2);
                if (q2 < m) m = q2;
                if (m > best[i][j]) {
                    best[i][j] = m;
                    cut[i][j] = k;
                }
            }
        }
    if (!(best[0][n - 1] > old + 1e-9)) return 0;
    /* Collect the triangles; chords must not be edges of the mesh already. */
    vm_index nw[2 * RING_MAX][4];
    int nn = 0, stack[RING_MAX][2], sp = 0;
    stack[sp][0] = 0;
    stack[sp][1] = n - 1;
    sp++;
    while (sp > 0) {
        sp--;
        int i = stack[sp][0], j = stack[sp][1], k = cut[i][j];
        if (k < 0) return 0;
        if (j - i >= 2 && (i != 0 || j != n - 1) && adjacent(w, a[i], a[j])) return 0;
        vm_index t1[4] = {a[i], a[k], a[j], d}, t2[4] = {a[k], a[i], a[j], e};
        memcpy(nw[nn++], t1, sizeof t1);
        memcpy(nw[nn++], t2, sizeof t2);
        if (k - i >= 2) {
            stack[sp][0] = i;
            stack[sp][1] = k;
            sp++;
        }
        if (j - k >= 2) {
            stack[sp][0] = k;
            stack[sp][1] = j;
            sp++;
        }
    }
    if (!replace(w, ring, n, nw, nn)) return 0;
    if (n == 3) w->flips32++;
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
