/* mesher/improve_smooth.c — optimisation-based vertex smoothing: raise the worst quality of
 * the tets around a vertex by line searches along the gradient of a soft minimum (after
 * Freitag and Ollivier-Gooch 1997, §2, and Klingner and Shewchuk 2007, §3), and random
 * perturbations for what that leaves; moves are projected onto the vertex's constraint. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "improve_internal.h"

/* Worst quality of the star of a (ids in ids[0..n)) with a at x; stops at floor_q. */
static double star_min(const vm__imp *w, const vm_index *ids, int32_t n, vm_index a,
                       const double x[3], double floor_q) {
    double m = INFINITY;
    for (int32_t i = 0; i < n; i++) {
        double q = vm__imp_tet_q_moved(w, (size_t)ids[i], a, x);
        if (q < m) m = q;
        if (m <= floor_q) break;
    }
    return m;
}

static double shortest_edge(const vm__imp *w, vm_index a) {
    const vm__imp_star *s = &w->star[a];
    const double *pa = w->p + 3 * (size_t)a;
    double best = INFINITY;
    for (int32_t i = 0; i < s->n; i++)
        for (int k = 0; k < 4; k++) {
            vm_index b = w->tet[4 * (size_t)s->t[i] + k];
            if (b == a) continue;
            const double *pb = w->p + 3 * (size_t)b;
            double d = (pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                       (pa[2] - pb[2]) * (pa[2] - pb[2]);
            if (d < best) best = d;
        }
    return sqrt(best);
}

/* Removes from g its component along the constraint normal of a (tangent moves only). */
static void tangent(const vm__imp *w, vm_index a, double g[3]) {
    if (w->cls[a] == VM__IMP_INTERIOR) return;
    /* Surface vertices with a volume and a band may leave the isosurface a little. */
    if (w->cls[a] == VM__IMP_SURF && w->v && w->o->surface_band > 0.0) return;
    double n[3];
    vm__imp_normal(w, a, n);
    double s = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
    for (int k = 0; k < 3; k++) g[k] -= s * n[k];
}

/* The line searches of vertex a (iters at most): each accepted step moves w->p[a] in place and
 * refreshes qs[0..n), the qualities of the star ids[0..n) (on entry, their current values).
 * With guard, a step must also pass the boundary guard, which is kept current; without it
 * (a colour class on threads) nothing but p[a] and qs is written. Returns 1 when a moved. */
static int smooth_core(vm__imp *w, vm_index a, int iters, const vm_index *ids, int32_t n,
                       double *qs, int guard) {
    double *pa = w->p + 3 * (size_t)a;
    double cur = INFINITY;
    for (int32_t i = 0; i < n; i++)
        if (qs[i] < cur) cur = qs[i];
    double L = shortest_edge(w, a);
    if (!(L > 0.0)) return 0;
    int moved = 0;
    const double tau = 0.05;
    for (int it = 0; it < iters; it++) {
        /* Soft-min gradient by forward differences on the tets near the minimum. */
        double g[3] = {0, 0, 0}, h = 1e-5 * L, gw[3] = {0, 0, 0}, worst_q = INFINITY;
        for (int32_t i = 0; i < n; i++) {
            double q = qs[i];
            if (q > cur + 4 * tau) continue;
            double wt = exp(-(q - cur) / tau), gq[3];
            for (int k = 0; k < 3; k++) {
                double x[3] = {pa[0], pa[1], pa[2]};
                x[k] += h;
                gq[k] = (vm__imp_tet_q_moved(w, (size_t)ids[i], a, x) - q) / h;
                g[k] += wt * gq[k];
            }
            if (q < worst_q) {
                worst_q = q;
                memcpy(gw, gq, sizeof gw);
            }
        }
        int accepted = 0;
        for (int dir = 0; dir < 2 && !accepted; dir++) {
            double d[3];
            memcpy(d, dir ? gw : g, sizeof d);
            tangent(w, a, d);
            double gl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!(gl > 0.0) || !isfinite(gl)) continue;
            for (double step = 0.3 * L; step > 1e-4 * L; step *= 0.5) {
                double x[3];
                for (int k = 0; k < 3; k++) x[k] = pa[k] + step * d[k] / gl;
                if (!vm__imp_constrain(w, a, x)) continue;
                double m = star_min(w, ids, n, a, x, cur + 1e-7);
                if (m > cur + 1e-7 && (!guard || vm__imp_guard_move_ok(w, a, x))) {
                    memcpy(pa, x, sizeof x);
                    if (guard) vm__imp_guard_moved(w, a);
                    for (int32_t i = 0; i < n; i++) qs[i] = vm__imp_tet_q(w, (size_t)ids[i]);
                    cur = m;
                    accepted = 1;
                    break;
                }
            }
        }
        if (!accepted) break;
        moved = 1;
    }
    return moved;
}

int vm__imp_smooth_vertex(vm__imp *w, vm_index a, int iters) {
    if (w->cls[a] == VM__IMP_FIXED || w->pdead[a]) return 0;
    const vm__imp_star *s = &w->star[a];
    int32_t n = s->n;
    if (n == 0) return 0;
    double qbuf[64], *qs = n <= 64 ? qbuf : malloc((size_t)n * sizeof *qs);
    if (!qs) {
        w->nomem = 1;
        return 0;
    }
    /* the guard never changes the star: it is read in place */
    for (int32_t i = 0; i < n; i++) qs[i] = w->q[s->t[i]];
    int moved = smooth_core(w, a, iters, s->t, n, qs, 1);
    if (moved) {
        for (int32_t i = 0; i < n; i++) vm__imp_requal(w, (size_t)s->t[i]);
        w->moves++;
    }
    if (qs != qbuf) free(qs);
    return moved;
}

/* Greedy colours of the movable vertices of vs[0..nv) in their order: the smallest colour
 * (1..255) no earlier vertex of the list sharing a tet with it has; 0 when all are taken. */
static void colour(const vm__imp *w, const vm_index *vs, size_t nv, uint8_t *col, uint8_t *c) {
    for (size_t i = 0; i < nv; i++) {
        vm_index a = vs[i];
        c[i] = 0;
        if (w->cls[a] == VM__IMP_FIXED || w->pdead[a] || w->star[a].n == 0) continue;
        uint64_t used[4] = {1, 0, 0, 0}; /* colour 0 is "none" */
        const vm__imp_star *s = &w->star[a];
        for (int32_t j = 0; j < s->n; j++)
            for (int k = 0; k < 4; k++) {
                uint8_t x = col[w->tet[4 * (size_t)s->t[j] + k]];
                used[x >> 6] |= (uint64_t)1 << (x & 63);
            }
        for (int x = 1; x < 256; x++)
            if (!(used[x >> 6] >> (x & 63) & 1)) {
                c[i] = (uint8_t)x;
                break;
            }
        col[a] = c[i];
    }
    for (size_t i = 0; i < nv; i++) col[vs[i]] = 0;
}

size_t vm__imp_smooth_set(vm__imp *w, const vm_index *vs, size_t nv, int iters, uint8_t *col) {
    size_t ops = 0;
    uint8_t *c = malloc(nv + 1);
    size_t *order = malloc((nv + 1) * sizeof *order), start[257];
    double *x = malloc((3 * nv + 1) * sizeof *x);
    uint8_t *mv = malloc(nv + 1);
    if (!c || !order || !x || !mv) {
        free(c);
        free(order);
        free(x);
        free(mv);
        w->nomem = 1;
        return 0;
    }
    colour(w, vs, nv, col, c);
    /* the classes in colour order, each in list order */
    memset(start, 0, sizeof start);
    for (size_t i = 0; i < nv; i++) start[c[i] + 1]++;
    for (int k = 1; k < 257; k++) start[k] += start[k - 1];
    size_t fill[256];
    memcpy(fill, start, sizeof fill);
    for (size_t i = 0; i < nv; i++) order[fill[c[i]]++] = i;
    for (int k = 1; k < 256 && !w->nomem; k++) {
        size_t i0 = start[k], i1 = start[k + 1];
        if (i0 == i1) continue;
        int fail = 0;
        /* No two vertices of a class share a tet, so each reads only positions and
         * qualities no other one writes: the moves are the same on any thread count. */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 16) reduction(| : fail)
#endif
        for (size_t j = i0; j < i1; j++) {
            size_t i = order[j];
            vm_index a = vs[i];
            const vm__imp_star *s = &w->star[a];
            double qbuf[64], *qs = s->n <= 64 ? qbuf : malloc((size_t)s->n * sizeof *qs);
            mv[i] = 0;
            if (!qs) {
                fail = 1;
                continue;
            }
            for (int32_t t = 0; t < s->n; t++) qs[t] = w->q[s->t[t]];
            double *pa = w->p + 3 * (size_t)a, p0[3];
            memcpy(p0, pa, sizeof p0);
            mv[i] = (uint8_t)smooth_core(w, a, iters, s->t, s->n, qs, 0);
            memcpy(x + 3 * i, pa, 3 * sizeof *x);
            memcpy(pa, p0, sizeof p0);
            if (qs != qbuf) free(qs);
        }
        if (fail) w->nomem = 1;
        /* Commits in list order: the boundary guard sees each move after the ones before
         * it; a move it refuses is searched again step by step with the guard. */
        for (size_t j = i0; j < i1 && !w->nomem; j++) {
            size_t i = order[j];
            vm_index a = vs[i];
            if (!mv[i]) continue;
            if (vm__imp_guard_move_ok(w, a, x + 3 * i)) {
                memcpy(w->p + 3 * (size_t)a, x + 3 * i, 3 * sizeof *x);
                vm__imp_guard_moved(w, a);
                const vm__imp_star *s = &w->star[a];
                for (int32_t t = 0; t < s->n; t++) vm__imp_requal(w, (size_t)s->t[t]);
                w->moves++;
                ops++;
            } else if (!w->nomem) {
                ops += (size_t)vm__imp_smooth_vertex(w, a, iters);
            }
        }
    }
    /* vertices left without a colour (more than 254 coloured neighbours), one by one */
    for (size_t j = start[0]; j < start[1] && !w->nomem; j++)
        ops += (size_t)vm__imp_smooth_vertex(w, vs[order[j]], iters);
    free(c);
    free(order);
    free(x);
    free(mv);
    return ops;
}

int vm__imp_perturb_vertex(vm__imp *w, vm_index a, int tries) {
    if (w->cls[a] == VM__IMP_FIXED || w->pdead[a]) return 0;
    const vm__imp_star *s = &w->star[a];
    int32_t n = s->n;
    if (n == 0 || !vm__imp_scratch(w, (size_t)n)) return 0;
    vm_index *ids = w->buf;
    memcpy(ids, s->t, (size_t)n * sizeof *ids);
    double *pa = w->p + 3 * (size_t)a;
    double cur = INFINITY;
    for (int32_t i = 0; i < n; i++)
        if (w->q[ids[i]] < cur) cur = w->q[ids[i]];
    double L = shortest_edge(w, a);
    int moved = 0;
    for (int k = 0; k < tries; k++) {
        double d[3], r = L * (k % 3 == 0 ? 0.3 : k % 3 == 1 ? 0.1 : 0.03);
        for (int c = 0; c < 3; c++) d[c] = 2.0 * vm__imp_rand01(w) - 1.0;
        tangent(w, a, d);
        double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(dl > 1e-6)) continue;
        double x[3];
        for (int c = 0; c < 3; c++) x[c] = pa[c] + r * d[c] / dl;
        if (!vm__imp_constrain(w, a, x)) continue;
        double m = star_min(w, ids, n, a, x, cur + 1e-7);
        if (m > cur + 1e-7 && vm__imp_guard_move_ok(w, a, x)) {
            memcpy(pa, x, sizeof x);
            vm__imp_guard_moved(w, a);
            for (int32_t i = 0; i < n; i++) vm__imp_requal(w, (size_t)ids[i]);
            cur = m;
            moved = 1;
        }
    }
    if (moved) w->perturbations++;
    return moved;
}
