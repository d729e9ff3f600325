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
static void tangent(const vm__imp *w, vm_index a, const double pa[3], double g[3]) {
    if (w->cls[a] == VM__IMP_INTERIOR) return;
    /* Surface vertices with a volume and a band may leave the isosurface a little. */
    if (w->cls[a] == VM__IMP_SURF && w->v && w->o->surface_band > 0.0) return;
    double n[3];
    vm__imp_normal_at(w, a, pa, n);
    double s = g[0] * n[0] + g[1] * n[1] + g[2] * n[2];
    for (int k = 0; k < 3; k++) g[k] -= s * n[k];
}

/* The line searches of vertex a (iters at most): each accepted step moves a and
 * refreshes qs[0..n), the qualities of the star ids[0..n) (on entry, their current values).
 * With guard, a step must also pass the boundary guard, which is kept current; without it
 * (a probe on threads) only qs is written, the mesh is not, and the accepted positions go to
 * steps (iters of them at most). Returns the number of accepted steps. */
static int smooth_core(vm__imp *w, vm_index a, int iters, const vm_index *ids, int32_t n,
                       double *qs, int guard, double *steps) {
    /* a's position is kept here: a probe never writes w->p, which other probes read */
    double pa[3];
    memcpy(pa, w->p + 3 * (size_t)a, sizeof pa);
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
            tangent(w, a, pa, d);
            double gl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (!(gl > 0.0) || !isfinite(gl)) continue;
            for (double step = 0.3 * L; step > 1e-4 * L; step *= 0.5) {
                double x[3];
                for (int k = 0; k < 3; k++) x[k] = pa[k] + step * d[k] / gl;
                if (!vm__imp_constrain(w, a, x)) continue;
                double m = star_min(w, ids, n, a, x, cur + 1e-7);
                if (m > cur + 1e-7 && (!guard || vm__imp_guard_move_ok(w, a, x))) {
                    memcpy(pa, x, sizeof x);
                    if (guard) {
                        memcpy(w->p + 3 * (size_t)a, x, sizeof x);
                        vm__imp_guard_moved(w, a);
                    } else {
                        memcpy(steps + 3 * moved, x, sizeof x);
                    }
                    for (int32_t i = 0; i < n; i++)
                        qs[i] = vm__imp_tet_q_moved(w, (size_t)ids[i], a, pa);
                    cur = m;
                    accepted = 1;
                    break;
                }
            }
        }
        if (!accepted) break;
        moved++;
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
    int moved = smooth_core(w, a, iters, s->t, n, qs, 1, NULL) > 0;
    if (moved) {
        for (int32_t i = 0; i < n; i++) vm__imp_requal(w, (size_t)s->t[i]);
        w->moves++;
    }
    if (qs != qbuf) free(qs);
    return moved;
}

/* 1 when a vertex of a tet around a carries mark r (a neighbour of a moved). */
static int near_mark(const vm__imp *w, vm_index a, const uint32_t *mark, uint32_t r) {
    const vm__imp_star *s = &w->star[a];
    for (int32_t j = 0; j < s->n; j++)
        for (int k = 0; k < 4; k++)
            if (mark[w->tet[4 * (size_t)s->t[j] + k]] == r) return 1;
    return 0;
}

#define SBATCH 1024
#define SITERS 8 /* steps stored per vertex: iters at most */

size_t vm__imp_smooth_set(vm__imp *w, const vm_index *vs, size_t nv, int iters, uint32_t *mark,
                          uint32_t *round) {
    size_t ops = 0;
    if (iters > SITERS) iters = SITERS;
    double *steps = malloc(SBATCH * 3 * SITERS * sizeof *steps);
    int *ns = malloc(SBATCH * sizeof *ns);
    if (!steps || !ns) {
        free(steps);
        free(ns);
        w->nomem = 1;
        return 0;
    }
    for (size_t i0 = 0; i0 < nv && !w->nomem; i0 += SBATCH) {
        size_t i1 = i0 + SBATCH < nv ? i0 + SBATCH : nv;
        int fail = 0;
        /* Probes on the unchanged mesh (they write nothing but their own results). */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 16) reduction(| : fail)
#endif
        for (size_t i = i0; i < i1; i++) {
            vm_index a = vs[i];
            const vm__imp_star *s = &w->star[a];
            ns[i - i0] = 0;
            if (w->cls[a] == VM__IMP_FIXED || w->pdead[a] || s->n == 0) continue;
            double qbuf[64], *qs = s->n <= 64 ? qbuf : malloc((size_t)s->n * sizeof *qs);
            if (!qs) {
                fail = 1;
                continue;
            }
            for (int32_t t = 0; t < s->n; t++) qs[t] = w->q[s->t[t]];
            ns[i - i0] = smooth_core(w, a, iters, s->t, s->n, qs, 0,
                                     steps + 3 * SITERS * (i - i0));
            if (qs != qbuf) free(qs);
        }
        if (fail) {
            w->nomem = 1;
            break;
        }
        /* In list order, as the plain loop: a probe whose neighbours have not moved since
         * is what the plain search computes, but for the guard, asked here at each of its
         * steps (its answer does not depend on where the vertex is now); anything else is
         * searched again with the guard. */
        uint32_t r = ++*round;
        for (size_t i = i0; i < i1 && !w->nomem; i++) {
            vm_index a = vs[i];
            if (w->cls[a] == VM__IMP_FIXED || w->pdead[a] || w->star[a].n == 0) continue;
            int n = ns[i - i0], moved;
            const double *st = steps + 3 * SITERS * (i - i0);
            if (near_mark(w, a, mark, r)) {
                moved = vm__imp_smooth_vertex(w, a, iters);
            } else if (n == 0) {
                moved = 0;
            } else {
                int ok = 1;
                for (int k = 0; k < n && ok; k++) ok = vm__imp_guard_move_ok(w, a, st + 3 * k);
                if (ok) {
                    memcpy(w->p + 3 * (size_t)a, st + 3 * (n - 1), 3 * sizeof *st);
                    vm__imp_guard_moved(w, a);
                    const vm__imp_star *s = &w->star[a];
                    for (int32_t t = 0; t < s->n; t++) vm__imp_requal(w, (size_t)s->t[t]);
                    w->moves++;
                    moved = 1;
                } else {
                    moved = w->nomem ? 0 : vm__imp_smooth_vertex(w, a, iters);
                }
            }
            if (moved) {
                mark[a] = r;
                ops++;
            }
        }
    }
    free(steps);
    free(ns);
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
        tangent(w, a, pa, d);
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
