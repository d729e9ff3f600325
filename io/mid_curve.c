/* SPDX-License-Identifier: BSD-3-Clause */
/* io/mid_curve.c — curved quadratic tets: the mid-edge nodes of boundary edges moved onto the
 * material's bounding level set of the volume's trilinear field (Newton steps along the
 * gradient), then pulled back toward the straight middle wherever the 10-node tet's Jacobian
 * determinant, sampled at its corners, edge middles, centroid and the 4-point Gauss points
 * (Keast), falls below a share of the straight element's (as in Lenoir, "Optimal
 * isoparametric finite elements", SIAM J. Numer. Anal. 23, 1986: boundary nodes on the exact
 * surface, interior nodes straight). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesh_util.h"

/* Newton steps per node before giving up (converged runs take 2 to 4). */
enum { CURVE_NEWTON_STEPS = 20, CURVE_PULL_ROUNDS = 12 };
/* A node is not moved farther than this share of its edge's length (a projection that goes
 * farther has found another piece of the surface). */
static const double CURVE_MAX_MOVE = 0.5;
/* Converged when |f - level| / |grad f| is below this share of the edge length. */
static const double CURVE_TOL = 1e-10;
/* Least Jacobian determinant kept, as a share of the straight tet's (6 x volume): curved
 * elements stay well inside positive, not only non-inverted. */
static const double CURVE_MIN_DET = 0.1;

/* The volume's world-to-index frame: idx = inv * (x - origin). */
typedef struct curve_frame {
    const vm_volume *v;
    double inv[3][3];
} curve_frame;

/* Inverts A = D * diag(spacing) into inv; 0 when singular. */
int vm__index_frame(const vm_volume *v, double inv[3][3]) {
    double a[3][3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) a[r][c] = v->direction[r][c] * v->spacing[c];
    double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                 a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                 a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
    if (!(fabs(det) > 0)) return 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            inv[r][c] = (a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]) / det;
        }
    return 1;
}

/* Index coordinates idx = inv * (x - origin) of world point x. */
void vm__to_index(const vm_volume *v, const double *inv, const double x[3],
                  double idx[3]) {
    double d[3] = {x[0] - v->origin[0], x[1] - v->origin[1], x[2] - v->origin[2]};
    for (int r = 0; r < 3; r++)
        idx[r] = inv[3 * r] * d[0] + inv[3 * r + 1] * d[1] + inv[3 * r + 2] * d[2];
}

static int frame_init(curve_frame *fr, const vm_volume *v) {
    fr->v = v;
    return vm__index_frame(v, fr->inv);
}

static void to_index(const curve_frame *fr, const double x[3], double idx[3]) {
    vm__to_index(fr->v, &fr->inv[0][0], x, idx);
}

/* The trilinear field and its world gradient at x; 0 outside the sampled box. */
static int sample(const curve_frame *fr, const double x[3], double *f, double g[3]) {
    const vm_volume *v = fr->v;
    double idx[3], t[3];
    int64_t i0[3];
    to_index(fr, x, idx);
    for (int a = 0; a < 3; a++) {
        if (v->dims[a] < 2 || idx[a] < 0 || idx[a] > (double)(v->dims[a] - 1)) return 0;
        i0[a] = (int64_t)floor(idx[a]);
        if (i0[a] > v->dims[a] - 2) i0[a] = v->dims[a] - 2;
        t[a] = idx[a] - (double)i0[a];
    }
    double c[2][2][2];
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++)
                c[k][j][i] = v->data[(i0[0] + i) + v->dims[0] * ((i0[1] + j) +
                                                                  v->dims[1] * (i0[2] + k))];
    double w[3][2] = {{1 - t[0], t[0]}, {1 - t[1], t[1]}, {1 - t[2], t[2]}};
    double val = 0, gi[3] = {0, 0, 0};
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < 2; i++) {
                double s = c[k][j][i];
                val += w[0][i] * w[1][j] * w[2][k] * s;
                gi[0] += (i ? 1 : -1) * w[1][j] * w[2][k] * s;
                gi[1] += (j ? 1 : -1) * w[0][i] * w[2][k] * s;
                gi[2] += (k ? 1 : -1) * w[0][i] * w[1][j] * s;
            }
    *f = val;
    for (int a = 0; a < 3; a++) /* d idx / dx = inv, so grad_x = inv^T grad_idx */
        g[a] = fr->inv[0][a] * gi[0] + fr->inv[1][a] * gi[1] + fr->inv[2][a] * gi[2];
    return 1;
}

/* 1 when the straight middle x lies on a face of the sampled box (the flat faces that close
 * material cut by the border are not curved). */
static int on_box(const curve_frame *fr, const double x[3]) {
    double idx[3];
    to_index(fr, x, idx);
    for (int a = 0; a < 3; a++)
        if (fabs(idx[a]) < 1e-6 || fabs(idx[a] - (double)(fr->v->dims[a] - 1)) < 1e-6) return 1;
    return 0;
}

/* Newton projection of x onto the level set nearest f(x) among the bounds; [out] x moved.
 * 0 (x unchanged) when it does not converge within the allowed move. */
static int project(const curve_frame *fr, const vm_mesh_write_options *opt, double len,
                   double x[3]) {
    double f, g[3], p[3] = {x[0], x[1], x[2]};
    if (!sample(fr, p, &f, g)) return 0;
    double level = opt->curve_lo;
    if (!opt->curve_has_lo || (opt->curve_has_hi && fabs(f - opt->curve_hi) < fabs(f - level)))
        level = opt->curve_hi;
    for (int it = 0; it < CURVE_NEWTON_STEPS; it++) {
        double gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (!(gg > 0)) return 0;
        double r = (f - level) / gg;
        if (fabs(f - level) / sqrt(gg) <= CURVE_TOL * len) {
            double d2 = 0;
            for (int a = 0; a < 3; a++) d2 += (p[a] - x[a]) * (p[a] - x[a]);
            if (sqrt(d2) > CURVE_MAX_MOVE * len) return 0;
            memcpy(x, p, sizeof p);
            return 1;
        }
        for (int a = 0; a < 3; a++) p[a] -= r * g[a];
        if (!sample(fr, p, &f, g)) return 0;
    }
    return 0;
}

/* Jacobian determinant of the 10-node tet x (VTK order) at barycentric point l. */
static double tet10_det(double x[10][3], const double l[4]) {
    /* d L_i / d (xi, eta, zeta): L0 = 1 - xi - eta - zeta, L1 = xi, L2 = eta, L3 = zeta */
    static const double dl[4][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    double j[3][3] = {{0}};
    for (int n = 0; n < 10; n++) {
        double dn[3];
        if (n < 4) {
            for (int b = 0; b < 3; b++) dn[b] = (4 * l[n] - 1) * dl[n][b];
        } else {
            int p = vm__tet_edges[n - 4][0], q = vm__tet_edges[n - 4][1];
            for (int b = 0; b < 3; b++) dn[b] = 4 * (l[q] * dl[p][b] + l[p] * dl[q][b]);
        }
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) j[a][b] += x[n][a] * dn[b];
    }
    return j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1]) -
           j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0]) +
           j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
}

/* 1 when the curved tet keeps det J >= CURVE_MIN_DET times the straight one's at every
 * sample point (corners, edge middles, centroid, Keast's 4 Gauss points). */
static int tet10_valid(double x[10][3]) {
    static const double ga = 0.5854101966249685, gb = 0.1381966011250105;
    static const double pts[15][4] = {
        {1, 0, 0, 0},       {0, 1, 0, 0},       {0, 0, 1, 0},       {0, 0, 0, 1},
        {.5, .5, 0, 0},     {0, .5, .5, 0},     {.5, 0, .5, 0},     {.5, 0, 0, .5},
        {0, .5, 0, .5},     {0, 0, .5, .5},     {.25, .25, .25, .25}, {ga, gb, gb, gb},
        {gb, ga, gb, gb},   {gb, gb, ga, gb},   {gb, gb, gb, ga}};
    double e[3][3];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) e[a][b] = x[b + 1][a] - x[0][a];
    double straight = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                      e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                      e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    if (straight == 0) return 1; /* a flat tet stays as the mesh has it */
    for (int k = 0; k < 15; k++)
        if (tet10_det(x, pts[k]) / straight < CURVE_MIN_DET) return 0;
    return 1;
}

/* Curves pts' mid-edge nodes (see mesh_util.h). */
vm_status vm__mid_curve(const char *path, const vm_mesh *m, const vm_index *mid, size_t nmid,
                        const vm_mesh_write_options *opt, double *pts, vm_error *err) {
    curve_frame fr;
    if (!opt || !opt->curve_volume || m->kind != VM_TET4 || !nmid) return VM_OK;
    if (!opt->curve_has_lo && !opt->curve_has_hi) return VM_OK;
    if (!frame_init(&fr, opt->curve_volume))
        return vm_error_set(err, VM_ERR_ARG, "%s: the volume's frame is singular", path);
    uint64_t *bf = NULL;
    size_t nb = 0;
    vm_status st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (st) return st;
    double *target = malloc(3 * nmid * sizeof *target);
    double *share = malloc(nmid * sizeof *share);
    unsigned char *moved = calloc(nmid, 1);
    if (!target || !share || !moved) {
        free(bf), free(target), free(share), free(moved);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for curved nodes", path);
    }
    size_t np = m->npoints;
    /* the boundary edges' nodes, projected once each */
    for (size_t i = 0; i < nb; i++) {
        size_t c = (size_t)(bf[i] / 4), f = (size_t)(bf[i] % 4);
        for (int k = 0; k < 3; k++) {
            int a = vm__tet_faces[f][k], b = vm__tet_faces[f][(k + 1) % 3];
            for (int e = 0; e < 6; e++) {
                if (!((vm__tet_edges[e][0] == a && vm__tet_edges[e][1] == b) ||
                      (vm__tet_edges[e][0] == b && vm__tet_edges[e][1] == a)))
                    continue;
                size_t t = (size_t)mid[c * 6 + (size_t)e] - np;
                if (moved[t]) break;
                moved[t] = 2; /* visited */
                const double *pa = m->points + 3 * (size_t)m->cells[c * 4 + (size_t)a];
                const double *pb = m->points + 3 * (size_t)m->cells[c * 4 + (size_t)b];
                double x[3], len2 = 0;
                for (int d = 0; d < 3; d++) {
                    x[d] = pts[3 * (np + t) + (size_t)d];
                    len2 += (pa[d] - pb[d]) * (pa[d] - pb[d]);
                }
                if (on_box(&fr, x) || !project(&fr, opt, sqrt(len2), x)) break;
                memcpy(target + 3 * t, x, sizeof x);
                moved[t] = 1;
                share[t] = 1.0;
                break;
            }
        }
    }
    double *straight = malloc(3 * nmid * sizeof *straight);
    if (!straight) {
        free(bf), free(target), free(share), free(moved);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for curved nodes", path);
    }
    memcpy(straight, pts + 3 * np, 3 * nmid * sizeof *straight);
    /* place, check every tet that has a moved node, halve the move of a failing tet's nodes */
    for (int round = 0; round <= CURVE_PULL_ROUNDS; round++) {
        for (size_t t = 0; t < nmid; t++)
            if (moved[t] == 1)
                for (int d = 0; d < 3; d++)
                    pts[3 * (np + t) + (size_t)d] =
                        straight[3 * t + (size_t)d] +
                        share[t] * (target[3 * t + (size_t)d] - straight[3 * t + (size_t)d]);
        size_t bad = 0;
        for (size_t c = 0; c < m->ncells; c++) {
            int any = 0;
            for (int e = 0; e < 6; e++) any |= moved[(size_t)mid[c * 6 + (size_t)e] - np] == 1;
            if (!any) continue;
            double x[10][3];
            for (int n = 0; n < 10; n++) {
                size_t node = n < 4 ? (size_t)m->cells[c * 4 + (size_t)n]
                                    : (size_t)mid[c * 6 + (size_t)(n - 4)];
                memcpy(x[n], pts + 3 * node, sizeof x[n]);
            }
            if (tet10_valid(x)) continue;
            bad++;
            for (int e = 0; e < 6; e++) {
                size_t t = (size_t)mid[c * 6 + (size_t)e] - np;
                if (moved[t] == 1) share[t] = round < CURVE_PULL_ROUNDS - 1 ? share[t] * 0.5 : 0;
            }
        }
        if (!bad) break;
    }
    free(bf), free(target), free(share), free(moved), free(straight);
    return VM_OK;
}
