/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_smooth.c — optimisation-based vertex smoothing: raise the worst quality of
 * the tets around a vertex by line searches along the gradient of a soft minimum (after
 * Freitag and Ollivier-Gooch 1997, §2, and Klingner and Shewchuk 2007, §3), and random
 * perturbations for what that leaves; moves are projected onto the vertex's constraint. */
#include <math.h>
#include <string.h>
#include "improve_internal.h"

/* Soft-minimum temperature (quality units): tets within 4 tau of the worst steer the
 * gradient, with weight exp(-(q - worst) / tau). */
#define SOFTMIN_TAU 0.05
/* Forward-difference step of the gradient, times the shortest edge at the vertex. */
#define GRAD_STEP 1e-5
/* Line search: from LINE_FIRST down to LINE_LAST times the shortest edge, halving. */
#define LINE_FIRST 0.3
#define LINE_LAST 1e-4
/* A move must raise the star's worst quality by more than this (round-off is no gain). */
#define GAIN_MIN 1e-7
/* Perturbation radii, times the shortest edge: tries cycle through the three. */
#define PERTURB_FAR 0.3
#define PERTURB_MID 0.1
#define PERTURB_NEAR 0.03
/* A random direction shorter than this (after the tangent projection) is skipped. */
#define DIR_MIN 1e-6

/* 1 when every tet of the star of a (ids[0..n)) with a at x has a quality above the bar;
 * then w->qbuf[i] holds the quality there of tet ids[n + i]. The tets are tried in the order
 * ids[n..2n) (the same tets): one that fails goes to the front, since the next try most
 * likely fails on it too (the order changes no answer). The first is tried on its cosines
 * (vm__imp_tet_above_moved: most tries end there); the others are measured, which gives the
 * same answer (vm__imp_quality_above is vm__imp_quality above the bar), and a move that
 * passes keeps their qualities instead of measuring its star again (move_vertex). */
static int star_above(vm__imp *w, vm_index *ids, int32_t n, vm_index a, const double x[3],
                      const vm__imp_bar *b) {
    vm_index *ord = ids + n;
    double *qs = w->qbuf;
    for (int32_t i = 0; i < n; i++) {
        int above;
        if (i == 0) {
            above = vm__imp_tet_above_moved(w, (size_t)ord[0], a, x, b);
        } else {
            qs[i] = vm__imp_tet_q_moved(w, (size_t)ord[i], a, x);
            above = qs[i] > b->f;
        }
        if (!above) {
            vm_index t = ord[i];
            memmove(ord + 1, ord, (size_t)i * sizeof *ord);
            ord[0] = t;
            return 0;
        }
    }
    qs[0] = vm__imp_tet_q_moved(w, (size_t)ord[0], a, x);
    return 1;
}

/* Length of the shortest edge at vertex a. */
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

/* Copies the star of vertex a into w->buf twice (the moves change the stars' tets' qualities,
 * not the stars; the second copy is the order star_above tries them in) and sets *cur to its
 * worst quality; returns its size, 0 when a may not move or
 * the copy found no memory. */
static int32_t star_begin(vm__imp *w, vm_index a, double *cur) {
    if (w->cls[a] == VM__IMP_FIXED || w->pdead[a] || vm__imp_vlocked(w, a)) return 0;
    const vm__imp_star *s = &w->star[a];
    int32_t n = s->n;
    if (n == 0 || vm__imp_scratch(w, 2 * (size_t)n) != VM_OK ||
        vm__imp_qscratch(w, (size_t)n) != VM_OK)
        return 0;
    vm_index *ids = w->buf;
    memcpy(ids, s->t, (size_t)n * sizeof *ids);
    memcpy(ids + n, s->t, (size_t)n * sizeof *ids);
    *cur = INFINITY;
    for (int32_t i = 0; i < n; i++)
        if (vm__imp_q(w, ids[i]) < *cur) *cur = vm__imp_q(w, ids[i]);
    return n;
}

/* Moves vertex a to x and updates the guard and the qualities of its star: tet ord[i] has
 * quality qs[i] there (as star_above measured them on the same points). */
static void move_vertex(vm__imp *w, vm_index a, const double x[3], const vm_index *ord,
                        const double *qs, int32_t n) {
    memcpy(w->p + 3 * (size_t)a, x, 3 * sizeof *x);
    vm__imp_guard_moved(w, a);
    for (int32_t i = 0; i < n; i++) vm__imp_set_q(w, (size_t)ord[i], qs[i]);
}

/* The bar a move of a vertex whose star's worst quality is cur must pass. */
static void move_bar(const vm__imp *w, double cur, vm__imp_bar *b) {
    vm__imp_bar_set(w, cur + GAIN_MIN, b);
}

/* Tries vertex a at x: kept (1) when x satisfies a's constraint (x is projected onto it),
 * raises the star's worst quality *cur by more than GAIN_MIN (the bar b; *cur and b are
 * updated) and makes no boundary triangles cross. */
static int try_move(vm__imp *w, vm_index a, double x[3], vm_index *ids, int32_t n,
                    double *cur, vm__imp_bar *b) {
    if (!vm__imp_constrain(w, a, x)) return 0;
    if (!star_above(w, ids, n, a, x, b) || !vm__imp_guard_move_ok(w, a, x)) return 0;
    if (!vm__imp_chord_ok(w, a, -1, x)) return 0;
    move_vertex(w, a, x, ids + n, w->qbuf, n);
    double m = INFINITY;
    for (int32_t i = 0; i < n; i++)
        if (vm__imp_q(w, ids[i]) < m) m = vm__imp_q(w, ids[i]);
    *cur = m;
    move_bar(w, m, b);
    return 1;
}

int vm__imp_smooth_vertex(vm__imp *w, vm_index a, int iters) {
    double cur;
    int32_t n = star_begin(w, a, &cur);
    if (n == 0) return 0;
    vm_index *ids = w->buf;
    double *pa = w->p + 3 * (size_t)a;
    double L = shortest_edge(w, a);
    if (!(L > 0.0)) return 0;
    vm__imp_bar bar;
    move_bar(w, cur, &bar);
    int moved = 0;
    const double tau = SOFTMIN_TAU;
    for (int it = 0; it < iters; it++) {
        /* Soft-min gradient by forward differences on the tets near the minimum. */
        double g[3] = {0, 0, 0}, h = GRAD_STEP * L, gw[3] = {0, 0, 0}, worst_q = INFINITY;
        for (int32_t i = 0; i < n; i++) {
            double q = vm__imp_q(w, ids[i]);
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
            for (double step = LINE_FIRST * L; step > LINE_LAST * L; step *= 0.5) {
                double x[3];
                for (int k = 0; k < 3; k++) x[k] = pa[k] + step * d[k] / gl;
                if (try_move(w, a, x, ids, n, &cur, &bar)) {
                    accepted = 1;
                    break;
                }
            }
        }
        if (!accepted) break;
        moved = 1;
    }
    if (moved) w->moves++;
    return moved;
}

int vm__imp_perturb_vertex(vm__imp *w, vm_index a, int tries) {
    double cur;
    int32_t n = star_begin(w, a, &cur);
    if (n == 0) return 0;
    vm_index *ids = w->buf;
    double *pa = w->p + 3 * (size_t)a;
    double L = shortest_edge(w, a);
    vm__imp_bar bar;
    move_bar(w, cur, &bar);
    int moved = 0;
    for (int k = 0; k < tries; k++) {
        double d[3],
            r = L * (k % 3 == 0 ? PERTURB_FAR : k % 3 == 1 ? PERTURB_MID : PERTURB_NEAR);
        for (int c = 0; c < 3; c++) d[c] = 2.0 * vm__imp_rand01(w) - 1.0;
        tangent(w, a, d);
        double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (!(dl > DIR_MIN)) continue;
        double x[3];
        for (int c = 0; c < 3; c++) x[c] = pa[c] + r * d[c] / dl;
        if (try_move(w, a, x, ids, n, &cur, &bar)) moved = 1;
    }
    if (moved) w->perturbations++;
    return moved;
}
