/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dc_tets.c — tetrahedra filling the material by dual contouring: seed 001 (LBIE,
 * Zhang–Bajaj–Sohn) §4.1.2 and §4.2.2, over the cells analysed in dual_contour.c. */
#include "../core/core.h"
#include "../core/self_intersect.h"
#include "dc_internal.h"
#include "volmesh/volmesh.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A representative's smoothing (lambda, then mu) stops halving below this and drops to 0:
 * its vertex goes the rest of the way to the cell centre at once. */
static const double relax_floor = 1.0 / 64;
/* Rounds at most of relaxing non-positive tets, and of untangling crossing patches. */
enum { RELAX_ROUNDS = 24, UNTANGLE_ROUNDS = 40 };

static double orient(const double a[3], const double b[3], const double c[3],
                     const double e[3]) {
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
        w[k] = e[k] - a[k];
    }
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
            u[2] * (v[0] * w[1] - v[1] * w[0])) /
           6.0;
}

static double tet_volume(const dc *d, const int64_t t[4], int reference) {
    double p[4][3];
    for (int k = 0; k < 4; k++)
        vm__dc_vertex_pos(d, t[k], reference, p[k]);
    return orient(p[0], p[1], p[2], p[3]);
}

/* Elements that use surface vertices, as recorded per tet in d->src so that moving a vertex
 * re-emits only the elements around it: kind << 58 | payload. */
enum { SRC_NONE = 0, SRC_EDGE = 1, SRC_FACES = 2, SRC_COARSE = 3, SRC_GAPS = 4 };
#define SRC(kind, payload) (((int64_t)(kind) << 58) | (int64_t)(payload))
#define SRC_KIND(s) ((int)((s) >> 58))
#define SRC_PAYLOAD(s) ((s) & (((int64_t)1 << 58) - 1))
/* d->src keeps them in 32 bits (kind << 29 | payload) when every payload is below 2^29: 3
 * edges a grid point on grids below 179 M points (d->src_wide == 0, see emit_all). */
enum { SRC_NARROW_SHIFT = 29 };

static size_t src_bytes(const dc *d) {
    return d->src_wide ? sizeof(int64_t) : sizeof(uint32_t);
}

static int64_t src_get(const dc *d, size_t t) {
    if (d->src_wide) return ((const int64_t *)d->src)[t];
    uint32_t x = ((const uint32_t *)d->src)[t];
    return SRC(x >> SRC_NARROW_SHIFT, x & (((uint32_t)1 << SRC_NARROW_SHIFT) - 1));
}

static void src_set(dc *d, size_t t, int64_t s) {
    if (d->src_wide)
        ((int64_t *)d->src)[t] = s;
    else
        ((uint32_t *)d->src)[t] =
            (uint32_t)SRC_KIND(s) << SRC_NARROW_SHIFT | (uint32_t)SRC_PAYLOAD(s);
}

static int id_cmp(const void *x, const void *y) {
    int64_t a = *(const int64_t *)x, b = *(const int64_t *)y;
    return a < b ? -1 : a > b;
}

/* The tet list (d->tets) holds 32-bit ids until an id reaches d->id_limit, 64-bit ones
 * from then on: 16 bytes a tet instead of 32 on every grid below 2^32 points. */
static size_t tet_bytes(const dc *d) {
    return 4 * (d->wide ? sizeof(int64_t) : sizeof(uint32_t));
}

static void tet_get(const dc *d, size_t t, int64_t v[4]) {
    vm__dc_tet_get(d, t, v);
}

/* Makes the list 64-bit, keeping its capacity. */
static vm_status widen(dc *d, vm_error *err) {
    int64_t *w = malloc((d->tet_cap ? d->tet_cap : 1) * 4 * sizeof(int64_t));
    if (!w) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the tet list");
    const uint32_t *n = d->tets;
    for (size_t q = 0; q < 4 * d->ntets; q++)
        w[q] = (int64_t)n[q];
    free(d->tets);
    d->tets = w;
    d->wide = 1;
    return VM_OK;
}

/* Stores v as tet t (< tet_cap) in the list as wide as it is. */
static void tet_store(const dc *d, size_t t, const int64_t v[4]) {
    if (d->wide) {
        memcpy((int64_t *)d->tets + 4 * t, v, 4 * sizeof(int64_t));
    } else {
        uint32_t *p = (uint32_t *)d->tets + 4 * t;
        for (int k = 0; k < 4; k++)
            p[k] = (uint32_t)v[k];
    }
}

/* Stores v as tet t (< tet_cap), widening the list first when an id needs it. */
static vm_status tet_set(dc *d, size_t t, const int64_t v[4], vm_error *err) {
    if (!d->wide && (v[0] >= d->id_limit || v[1] >= d->id_limit || v[2] >= d->id_limit ||
                     v[3] >= d->id_limit)) {
        vm_status s = widen(d, err);
        if (s) return s;
    }
    tet_store(d, t, v);
    return VM_OK;
}

static vm_status emit(dc *d, int64_t a, int64_t b, int64_t c, int64_t e, vm_error *err) {
    /* Tets lying flat on one border plane are the closure of the padding: drop them. */
    if (vm__dc_vertex_planes(d, a) & vm__dc_vertex_planes(d, b) & vm__dc_vertex_planes(d, c) &
        vm__dc_vertex_planes(d, e))
        return VM_OK;
    const int64_t v[4] = {a, b, c, e};
    vm_status s = vm__grow(&d->tets, &d->tet_cap, d->ntets + 1, tet_bytes(d), err);
    if (!s) s = vm__grow(&d->src, &d->src_cap, d->ntets + 1, src_bytes(d), err);
    if (!s) s = tet_set(d, d->ntets, v, err);
    if (s) return s;
    src_set(d, d->ntets++, d->cur_src);
    return VM_OK;
}

/* Emits a tet whose orientation is decided on the reference geometry (lattice points and
 * mass points), for the few pieces whose order is not fixed by construction. */
static vm_status emit_oriented(dc *d, int64_t a, int64_t b, int64_t c, int64_t e,
                               vm_error *err) {
    int64_t t[4] = {a, b, c, e};
    if (tet_volume(d, t, 1) < 0) return emit(d, a, c, b, e, err);
    return emit(d, a, b, c, e, err);
}

/* The four cells around the edge from p along axis a, counter-clockwise seen from +a,
 * with the edge's local index in each. Returns their bcell (NULL for interior cells). */
static void cells_around(const dc *d, const int64_t p[3], int a, const bcell *cb[4], int le[4],
                         int32_t code[4], int64_t mins[4][3]) {
    static const int off[4][2] = {{0, 0}, {-1, 0}, {-1, -1}, {0, -1}};
    int b = (a + 1) % 3, c = (a + 2) % 3;
    for (int q = 0; q < 4; q++) {
        int64_t m[3] = {p[0], p[1], p[2]};
        m[b] += off[q][0];
        m[c] += off[q][1];
        code[q] = vm__dc_code(d, vm__dc_cidx(d, m[0], m[1], m[2]));
        memcpy(mins[q], m, sizeof m);
        cb[q] = code[q] >= 0 ? &d->bc[code[q]] : NULL;
        le[q] = 4 * a + (-off[q][0]) + 2 * (-off[q][1]);
    }
}

/* The element of a sign-change edge: a pyramid from its inside end over the polygon of
 * the four cells' vertices (counter-clockwise around +a), with the vertex of an ambiguous
 * face inserted between the two cells sharing it. The polygon is split as a fan from the
 * root that gives the largest smallest volume. */
static vm_status emit_polygon(dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                              const int *inserted, int np, vm_error *err);

static vm_status emit_pyramid(dc *d, int a, const int64_t apex_p[3], int apex_lower,
                              const bcell *cb[4], const int le[4], int64_t mins[4][3],
                              vm_error *err) {
    /* lower cell of the face shared by cells q and q+1, and that face's normal axis */
    static const int lower_of[4] = {1, 2, 2, 3};
    int b = (a + 1) % 3, c = (a + 2) % 3;
    const int axis_of[4] = {b, c, b, c};
    int64_t poly[8];
    int np = 0, inserted[8] = {0};
    for (int q = 0; q < 4; q++) {
        poly[np++] = vm__dc_rep_for_edge(d, cb[q], le[q]);
        if (d->namb) {
            int64_t fv = vm__dc_face_vertex(d, mins[lower_of[q]], axis_of[q], apex_p);
            if (fv >= 0) {
                inserted[np] = 1;
                poly[np++] = fv;
            }
        }
    }
    return emit_polygon(d, vm__dc_lattice_id(d, apex_p), apex_lower, poly, inserted, np, err);
}

/* Largest polygon round an edge: four cells and four ambiguous face vertices. */
enum { MAX_POLY = 8 };
/* Directions tried for a centre vertex: the centroid's, the normals' sum, up to seven side
 * normals, and the perceptron's. */
enum { MAX_CANDIDATES = 10 };
/* Perceptron steps at most; it stops when every side normal is within 5 % of the
 * direction's length of facing it, and steps half that length. */
enum { PERCEPTRON_STEPS = 64 };
static const double perceptron_margin = 0.05;
/* A later candidate centre counts as better only beyond round-off (relative and absolute). */
static const double better_rel = 1.000001, better_abs = 1e-12;
/* A worst tet volume above this fraction of len^3 (len: the apex-centroid distance) is fine:
 * no further candidate is taken. */
static const double fine_volume = 1e-4;

/* The root of the fan over poly with the largest smallest volume (*best), skipping roots next
 * to a face vertex (their fans would join the two cells it separates); -1 when none. */
static int best_fan_root(const dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                         const int *inserted, int np, double *best) {
    int best_root = -1;
    *best = -INFINITY;
    for (int root = 0; root < np; root++) {
        if (inserted[(root + 1) % np] || inserted[(root + np - 1) % np]) continue;
        double worst = INFINITY;
        for (int i = 1; i + 1 < np; i++) {
            int64_t t[4] = {apex, poly[root], poly[(root + i) % np], poly[(root + i + 1) % np]};
            if (!apex_lower) t[1] = poly[(root + i + 1) % np], t[3] = poly[root];
            worst = fmin(worst, tet_volume(d, t, 0));
        }
        if (worst > *best) *best = worst, best_root = root;
    }
    return best_root;
}

/* The side triangles' normals (apex at ap, poly[i], poly[i + 1]; signed so that a positive
 * tet's is positive along its centre's direction) and the sum of their unit vectors. */
static void side_normals(const dc *d, const double ap[3], int apex_lower, const int64_t *poly,
                         int np, double nrm[MAX_POLY][3], double sum[3]) {
    for (int k = 0; k < 3; k++)
        sum[k] = 0;
    for (int i = 0; i < np; i++) {
        double x[3], y[3], u[3], w[3];
        vm__dc_vertex_pos(d, poly[i], 0, x);
        vm__dc_vertex_pos(d, poly[(i + 1) % np], 0, y);
        for (int k = 0; k < 3; k++)
            u[k] = x[k] - ap[k], w[k] = y[k] - ap[k];
        double sgn = apex_lower ? 1.0 : -1.0;
        nrm[i][0] = sgn * (u[1] * w[2] - u[2] * w[1]);
        nrm[i][1] = sgn * (u[2] * w[0] - u[0] * w[2]);
        nrm[i][2] = sgn * (u[0] * w[1] - u[1] * w[0]);
        double nl = sqrt(nrm[i][0] * nrm[i][0] + nrm[i][1] * nrm[i][1] + nrm[i][2] * nrm[i][2]);
        for (int k = 0; k < 3; k++)
            sum[k] += nl > 0 ? nrm[i][k] / nl : 0;
    }
}

/* A direction w that faces every side normal, by perceptron steps from sum toward the worst
 * one. */
static void perceptron_direction(const double nrm[MAX_POLY][3], int np, const double sum[3],
                                 double w[3]) {
    memcpy(w, sum, 3 * sizeof *w);
    for (int it = 0; it < PERCEPTRON_STEPS; it++) {
        int wi = -1;
        double wv = INFINITY;
        for (int i = 0; i < np; i++) {
            double nl =
                sqrt(nrm[i][0] * nrm[i][0] + nrm[i][1] * nrm[i][1] + nrm[i][2] * nrm[i][2]);
            double dv =
                nl > 0 ? (w[0] * nrm[i][0] + w[1] * nrm[i][1] + w[2] * nrm[i][2]) / nl : 0;
            if (dv < wv) wv = dv, wi = i;
        }
        double wl = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        if (wi < 0 || wv > perceptron_margin * wl) break;
        double nl =
            sqrt(nrm[wi][0] * nrm[wi][0] + nrm[wi][1] * nrm[wi][1] + nrm[wi][2] * nrm[wi][2]);
        for (int k = 0; k < 3; k++)
            w[k] += (wl > 0 ? 0.5 * wl : 1.0) * nrm[wi][k] / (nl > 0 ? nl : 1);
    }
}

/* A new centre vertex cpos for a fan over poly, at the centroid's distance from the apex:
 * the signs of its tets depend only on its direction from the apex, so the centroid's is
 * tried, then directions along the side triangles' normals. Returns its fan's worst tet
 * volume. */
static double place_centre(const dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                           int np, double cpos[3]) {
    for (int k = 0; k < 3; k++)
        cpos[k] = 0;
    for (int i = 0; i < np; i++) {
        double p[3];
        vm__dc_vertex_pos(d, poly[i], 0, p);
        for (int k = 0; k < 3; k++)
            cpos[k] += p[k] / np;
    }
    double ap[3], nrm[MAX_POLY][3], sum[3], len = 0;
    vm__dc_vertex_pos(d, apex, 0, ap);
    side_normals(d, ap, apex_lower, poly, np, nrm, sum);
    for (int k = 0; k < 3; k++)
        len += (cpos[k] - ap[k]) * (cpos[k] - ap[k]);
    len = sqrt(len);
    double worst_c = -INFINITY, cand[MAX_CANDIDATES][3];
    int ncand = 0;
    for (int k = 0; k < 3; k++)
        cand[ncand][k] = cpos[k] - ap[k];
    ncand++;
    memcpy(cand[ncand++], sum, sizeof sum);
    for (int i = 0; i < np && ncand < MAX_CANDIDATES - 1; i++)
        memcpy(cand[ncand++], nrm[i], sizeof nrm[i]);
    perceptron_direction((const double(*)[3])nrm, np, sum, cand[ncand++]);
    for (int ci = 0; ci < ncand; ci++) {
        double cl = sqrt(cand[ci][0] * cand[ci][0] + cand[ci][1] * cand[ci][1] +
                         cand[ci][2] * cand[ci][2]);
        if (!(cl > 0)) continue;
        double worst = INFINITY;
        for (int i = 0; i < np; i++)
            worst = fmin(worst, (cand[ci][0] * nrm[i][0] + cand[ci][1] * nrm[i][1] +
                                 cand[ci][2] * nrm[i][2]) *
                                    len / cl / 6.0);
        if (worst > worst_c * better_rel + better_abs || ci == 0) {
            if (ci > 0 && worst_c > fine_volume * len * len * len)
                break; /* the centroid is fine */
            worst_c = worst;
            for (int k = 0; k < 3; k++)
                cpos[k] = ap[k] + cand[ci][k] * len / cl;
        }
    }
    return worst_c;
}

/* The fan from poly[root] over poly, each triangle joined to apex. */
static vm_status emit_fan(dc *d, int64_t apex, int apex_lower, const int64_t *poly, int np,
                          int root, vm_error *err) {
    vm_status s = VM_OK;
    for (int i = 1; i + 1 < np && !s; i++) {
        int64_t x = poly[root], y = poly[(root + i) % np];
        int64_t z = poly[(root + i + 1) % np];
        s = apex_lower ? emit(d, apex, x, y, z, err) : emit(d, apex, z, y, x, err);
    }
    return s;
}

/* The fan from a new centre vertex at cpos over poly's edges, each triangle joined to apex. */
static vm_status emit_centre_fan(dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                                 int np, const double cpos[3], vm_error *err) {
    vm_status s =
        vm__grow((void **)&d->centre, &d->centre_cap, d->ncentre + 1, 3 * sizeof(double), err);
    if (s) return s;
    memcpy(d->centre + 3 * d->ncentre, cpos, 3 * sizeof *cpos);
    int64_t cid = vm__dc_npoints_real(d) + (int64_t)(d->nreps + d->ncentre++);
    for (int i = 0; i < np && !s; i++) {
        int64_t x = poly[i], y = poly[(i + 1) % np];
        s = apex_lower ? emit(d, apex, cid, x, y, err) : emit(d, apex, y, x, cid, err);
    }
    return s;
}

/* The quad poly's pyramid: the diagonal split whose smaller tet is larger. */
static vm_status emit_quad(dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                           vm_error *err) {
    vm_status s = VM_OK;
    int64_t ta[2][4] = {{apex, poly[0], poly[1], poly[2]}, {apex, poly[0], poly[2], poly[3]}};
    int64_t tb[2][4] = {{apex, poly[1], poly[2], poly[3]}, {apex, poly[1], poly[3], poly[0]}};
    if (!apex_lower)
        for (int t = 0; t < 2; t++) {
            int64_t x = ta[t][1], y = tb[t][1];
            ta[t][1] = ta[t][3], ta[t][3] = x;
            tb[t][1] = tb[t][3], tb[t][3] = y;
        }
    double qa = fmin(tet_volume(d, ta[0], 0), tet_volume(d, ta[1], 0));
    double qb = fmin(tet_volume(d, tb[0], 0), tet_volume(d, tb[1], 0));
    int64_t(*best)[4] = qa >= qb ? ta : tb;
    for (int t = 0; t < 2 && !s; t++)
        s = emit(d, best[t][0], best[t][1], best[t][2], best[t][3], err);
    return s;
}

/* The pyramid from apex over the polygon poly (counter-clockwise around the edge's axis;
 * inserted[i]: poly[i] is the vertex of an ambiguous face), split as a fan from the root
 * that gives the largest smallest volume, or from a new centre vertex. */
static vm_status emit_polygon(dc *d, int64_t apex, int apex_lower, const int64_t *poly,
                              const int *inserted, int np, vm_error *err) {
    if (np == 3)
        return apex_lower ? emit(d, apex, poly[0], poly[1], poly[2], err)
                          : emit(d, apex, poly[2], poly[1], poly[0], err);
    if (np <= 4) return emit_quad(d, apex, apex_lower, poly, err);
    double best, cpos[3];
    int best_root = best_fan_root(d, apex, apex_lower, poly, inserted, np, &best);
    double worst_c = place_centre(d, apex, apex_lower, poly, np, cpos);
    if (best_root >= 0 && best >= worst_c)
        return emit_fan(d, apex, apex_lower, poly, np, best_root, err);
    return emit_centre_fan(d, apex, apex_lower, poly, np, cpos, err);
}

/* A leaf seen from a position around an edge: 0 exterior cell, 1 fine boundary cell, 2 coarse
 * boundary leaf, 3 interior leaf; id tells leaves of one kind apart; rep is the vertex a
 * boundary leaf gives the edge (local edge le of a fine cell). */
typedef struct leafref {
    int kind;
    int64_t id, rep;
} leafref;

static leafref leaf_at(const dc *d, const int64_t m[3], int le) {
    leafref r = {0, 0, -1};
    int64_t ci = vm__dc_cidx(d, m[0], m[1], m[2]);
    int32_t cl = vm__dc_coarse(d, ci), code = vm__dc_code(d, ci);
    if (cl >= 0) {
        r.kind = 2;
        r.id = cl;
        r.rep = vm__dc_npoints_real(d) + (int64_t)(d->coarse_base + (size_t)cl);
    } else if (code >= 0) {
        r.kind = 1;
        r.id = ci;
        r.rep = vm__dc_rep_for_edge(d, &d->bc[code], le);
    } else if (code == CELL_IN) {
        int64_t org[3];
        vm__octree_leaf(&d->oct, m, org);
        r.kind = 3;
        r.id = vm__dc_cidx(d, org[0], org[1], org[2]);
    } else {
        r.id = ci;
    }
    return r;
}

/* A grid edge next to a coarse boundary leaf (LBIE §4.2.2: only minimal edges count). The
 * distinct leaves around it, in order, are its neighbours; with fewer than three it lies
 * inside a leaf face and is no leaf edge. An end that no leaf has as a corner is the
 * midpoint of an undivided coarse edge: that edge is handled once, from its lower half.
 * A sign-change edge gives the pyramid from its inside end over its leaves' vertices (a
 * triangle or a quad), an inside edge one tet per pair of neighbouring boundary leaves. */
static vm_status emit_edge_mixed(dc *d, int a, const int64_t p0[3], int64_t mins[4][3],
                                 const int le[4], vm_error *err) {
    leafref all[4], l[4];
    int n = 0;
    for (int q = 0; q < 4; q++)
        all[q] = leaf_at(d, mins[q], le[q]);
    for (int q = 0; q < 4; q++)
        if (n == 0 || all[q].kind != l[n - 1].kind || all[q].id != l[n - 1].id) l[n++] = all[q];
    if (n > 1 && l[n - 1].kind == l[0].kind && l[n - 1].id == l[0].id) n--;
    if (n < 3) return VM_OK;
    if (!vm__octree_is_vertex(&d->oct, p0)) return VM_OK;
    int64_t p1[3] = {p0[0], p0[1], p0[2]};
    p1[a]++;
    if (!vm__dc_in(d, vm__dc_pidx(d, p0[0], p0[1], p0[2])) &&
        !vm__dc_in(d, vm__dc_pidx(d, p1[0], p1[1], p1[2]))) {
        /* outside at both ends: only the lower half of an undivided edge of a coarse leaf
         * (one that touches the edge in one quadrant) can make elements */
        int on_edge = 0;
        for (int q = 0; q < 4; q++) {
            int count = 0;
            for (int r = 0; r < 4; r++)
                count += all[r].kind == 2 && all[r].id == all[q].id;
            if (all[q].kind == 2 && count == 1) on_edge = 1;
        }
        if (!on_edge || vm__octree_is_vertex(&d->oct, p1)) return VM_OK;
    }
    if (!vm__octree_is_vertex(&d->oct, p1)) p1[a]++;
    int in0 = vm__dc_in(d, vm__dc_pidx(d, p0[0], p0[1], p0[2]));
    int in1 = vm__dc_in(d, vm__dc_pidx(d, p1[0], p1[1], p1[2]));
    if (!in0 && !in1) return VM_OK;
    int64_t v0 = vm__dc_lattice_id(d, p0), v1 = vm__dc_lattice_id(d, p1);
    if (in0 && in1) {
        for (int i = 0; i < n; i++) {
            const leafref *x = &l[i], *y = &l[(i + 1) % n];
            if ((x->kind != 1 && x->kind != 2) || (y->kind != 1 && y->kind != 2)) continue;
            vm_status s = emit(d, v0, v1, x->rep, y->rep, err);
            if (s) return s;
        }
        return VM_OK;
    }
    int64_t poly[4];
    int inserted[4] = {0, 0, 0, 0};
    for (int i = 0; i < n; i++) {
        if (l[i].kind != 1 && l[i].kind != 2)
            return vm_error_set(err, VM_ERR_INTERNAL,
                                "mesh: a crossing edge next to a coarse boundary leaf has a "
                                "non-boundary neighbour");
        poly[i] = l[i].rep;
    }
    return emit_polygon(d, in0 ? v0 : v1, in0, poly, inserted, n, err);
}

/* 8 bits of the bit set w from bit i on (bit i + 7 must exist). */
static unsigned bits8(const uint64_t *w, int64_t i) {
    int sh = (int)(i & 63);
    uint64_t x = w[i >> 6] >> sh;
    if (sh > 56) x |= w[(i + 7) >> 6] << (64 - sh);
    return (unsigned)(x & 0xff);
}

/* Whether padded cell ci is a boundary cell or in a coarse leaf. */
static unsigned active1(const dc *d, int64_t ci) {
    return (unsigned)(vm__dc_bit(d->bnd, ci) | (d->coarse ? vm__dc_bit(d->coarse, ci) : 0));
}

static unsigned active8(const dc *d, int64_t ci) {
    return bits8(d->bnd, ci) | (d->coarse ? bits8(d->coarse, ci) : 0);
}

/* The elements of the grid edges {axis, i, j, k} with lo <= (axis, i, j, k) < hi. skip != 0:
 * an edge none of whose four cells is a boundary cell or in a coarse leaf makes no element,
 * and is skipped early. */
static vm_status emit_edge_box(dc *d, const int64_t lo[4], const int64_t hi[4], int skip,
                               vm_error *err) {
    for (int a = (int)lo[0]; a < (int)hi[0]; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        const int64_t stride[3] = {1, d->C[0], d->C[0] * d->C[1]};
        const int64_t sb = stride[b], sc = stride[c];
        for (int64_t k = lo[3]; k < hi[3]; k++)
            for (int64_t j = lo[2]; j < hi[2]; j++)
                for (int64_t i = lo[1]; i < hi[1]; i++) {
                    int64_t p0[3] = {i, j, k}, p1[3] = {i, j, k};
                    if (++p1[a] >= d->n[a]) continue;
                    if (skip) {
                        int64_t c0 = vm__dc_cidx(d, i, j, k);
                        if (i + 8 <= hi[1]) { /* eight edges at once (the rows run along x) */
                            if (!(active8(d, c0) | active8(d, c0 - sb) |
                                  active8(d, c0 - sb - sc) | active8(d, c0 - sc))) {
                                i += 7;
                                continue;
                            }
                        }
                        if (!(active1(d, c0) | active1(d, c0 - sb) | active1(d, c0 - sb - sc) |
                              active1(d, c0 - sc)))
                            continue;
                    }
                    d->cur_src = SRC(SRC_EDGE, a + 3 * vm__dc_lattice_id(d, p0));
                    int in0 = vm__dc_in(d, vm__dc_pidx(d, i, j, k)),
                        in1 = vm__dc_in(d, vm__dc_pidx(d, p1[0], p1[1], p1[2]));
                    /* an edge next to a coarse leaf may be the lower half of a longer edge
                     * whose upper end is inside */
                    if (!in0 && !in1 && !d->coarse) continue;
                    const bcell *cb[4];
                    int le[4];
                    int32_t code[4];
                    int64_t mins[4][3];
                    cells_around(d, p0, a, cb, le, code, mins);
                    if (d->coarse) {
                        int mixed = 0;
                        for (int q = 0; q < 4; q++)
                            mixed |= vm__dc_coarse(d, vm__dc_cidx(d, mins[q][0], mins[q][1],
                                                                  mins[q][2])) >= 0;
                        if (mixed) {
                            vm_status s = emit_edge_mixed(d, a, p0, mins, le, err);
                            if (s) return s;
                            continue;
                        }
                    }
                    if (!in0 && !in1) continue;
                    int64_t v0 = vm__dc_lattice_id(d, p0), v1 = vm__dc_lattice_id(d, p1);
                    vm_status s = VM_OK;
                    if (in0 != in1) { /* sign change: pyramid from the inside end */
                        s = emit_pyramid(d, a, in0 ? p0 : p1, in0, cb, le, mins, err);
                    } else { /* inside edge: one tet per pair of neighbouring boundary cells */
                        for (int q = 0; q < 4 && !s; q++) {
                            const bcell *x = cb[q], *y = cb[(q + 1) & 3];
                            if (!x || !y) continue;
                            s = emit(d, v0, v1, vm__dc_rep_for_edge(d, x, le[q]),
                                     vm__dc_rep_for_edge(d, y, le[(q + 1) & 3]), err);
                        }
                    }
                    if (s) return s;
                }
    }
    return VM_OK;
}

/* The elements of the edge only = {axis, i, j, k}. */
static vm_status emit_edge_one(dc *d, const int64_t only[4], vm_error *err) {
    int64_t lo[4], hi[4];
    for (int q = 0; q < 4; q++)
        lo[q] = only[q], hi[q] = only[q] + 1;
    return emit_edge_box(d, lo, hi, 0, err);
}

/* A slab of edges emitted on its own: a shallow copy of the state with its own tet, source
 * and centre lists. Centre ids count from N + nreps within the slab and are shifted when
 * the slab is appended, so the result is the serial one for any thread count. */
/* The elements of the interior cells of z layers k0..k1-1. */
static vm_status emit_interior(dc *d, int64_t k0, int64_t k1, vm_error *err);

typedef struct edge_slab {
    int interior; /* 1: the interior cells of z layers lo[3]..hi[3]-1; 0: the edges lo..hi */
    int64_t lo[4], hi[4];
    void *tets; /* 32-bit ids, or 64-bit (wide) */
    int wide;
    void *src;
    size_t ntets;
    double *centre;
    size_t ncentre;
    vm_status status;
    vm_error err;
} edge_slab;

static void emit_slab(const dc *d, edge_slab *sl) {
    dc local = *d;
    local.tets = NULL;
    local.src = NULL;
    local.ntets = local.tet_cap = local.src_cap = 0;
    local.centre = NULL;
    local.ncentre = local.centre_cap = 0;
    vm_error_clear(&sl->err);
    local.cur_src = SRC(SRC_NONE, 0);
    sl->status = sl->interior ? emit_interior(&local, sl->lo[3], sl->hi[3], &sl->err)
                              : emit_edge_box(&local, sl->lo, sl->hi, 1, &sl->err);
    sl->tets = local.tets;
    sl->wide = local.wide;
    sl->src = local.src;
    sl->ntets = local.ntets;
    sl->centre = local.centre;
    sl->ncentre = local.ncentre;
}

/* Frees what a slab emitted (appended or not). */
static void slab_free(edge_slab *sl) {
    free(sl->tets);
    free(sl->src);
    free(sl->centre);
    sl->tets = NULL;
    sl->src = NULL;
    sl->centre = NULL;
}

/* Appends the batch sl[0..count) in order: the arrays grown once, the list widened first if
 * a shifted id needs it, then each slab copied to its place on the threads (its centres'
 * ids shifted past the centres before it). A batch with a failed slab returns the first
 * failure's error. The slabs' buffers are freed either way. */
static vm_status append_slabs(dc *d, edge_slab *sl, int64_t count, vm_error *err) {
    size_t nt = 0, nc = 0;
    int failed = 0;
    for (int64_t q = 0; q < count; q++) {
        failed |= sl[q].status != VM_OK;
        nt += sl[q].ntets;
        nc += sl[q].ncentre;
    }
    vm_status s = VM_OK;
    for (int64_t q = 0; q < count && failed && !s; q++)
        if ((s = sl[q].status) && err) *err = sl[q].err;
    if (!s) s = vm__grow(&d->tets, &d->tet_cap, d->ntets + nt, tet_bytes(d), err);
    if (!s) s = vm__grow(&d->src, &d->src_cap, d->ntets + nt, src_bytes(d), err);
    if (!s)
        s = vm__grow((void **)&d->centre, &d->centre_cap, d->ncentre + nc, 3 * sizeof(double),
                     err);
    if (s) {
        for (int64_t q = 0; q < count; q++)
            slab_free(&sl[q]);
        return s;
    }
    int64_t first = vm__dc_npoints_real(d) + (int64_t)d->nreps;
    size_t t0[64], c0[64]; /* each slab's first tet and centre (count <= 64: see below) */
    for (int64_t q = 0, tq = (int64_t)d->ntets, cq = (int64_t)d->ncentre; q < count; q++) {
        t0[q] = (size_t)tq;
        c0[q] = (size_t)cq;
        tq += (int64_t)sl[q].ntets;
        cq += (int64_t)sl[q].ncentre;
    }
    /* 64-bit ids from the start if a shifted id needs them: a slab's ids are below first
     * plus its centres, so only a batch whose centres reach the limit is looked through */
    int need = 0;
    if (!d->wide && first + (int64_t)(d->ncentre + nc) > d->id_limit)
        for (int64_t q = 0; q < count && !need; q++) {
            const dc from = {.tets = sl[q].tets, .wide = sl[q].wide};
            int64_t shift = (int64_t)c0[q];
            for (size_t t = 0; t < sl[q].ntets && !need; t++) {
                int64_t v[4];
                tet_get(&from, t, v);
                for (int k = 0; k < 4; k++)
                    if ((v[k] >= first ? v[k] + shift : v[k]) >= d->id_limit) need = 1;
            }
        }
    if (need && (s = widen(d, err))) {
        for (int64_t q = 0; q < count; q++)
            slab_free(&sl[q]);
        return s;
    }
    const dc *cd = d;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (int64_t q = 0; q < count; q++) {
        edge_slab *x = &sl[q];
        if (x->ntets) memcpy((char *)cd->src + src_bytes(cd) * t0[q], x->src, x->ntets * src_bytes(cd));
        const dc from = {.tets = x->tets, .wide = x->wide};
        int64_t shift = (int64_t)c0[q];
        for (size_t t = 0; t < x->ntets; t++) {
            int64_t v[4];
            tet_get(&from, t, v);
            for (int k = 0; k < 4; k++)
                if (v[k] >= first) v[k] += shift;
            tet_store(cd, t0[q] + t, v);
        }
        if (x->ncentre) memcpy(cd->centre + 3 * c0[q], x->centre, 3 * x->ncentre * sizeof(double));
    }
    for (int64_t q = 0; q < count; q++)
        slab_free(&sl[q]);
    d->ntets += nt;
    d->ncentre += nc;
    return VM_OK;
}

/* The elements of every grid edge, axis by axis (interior: of the interior cells), in slabs
 * of z layers run in parallel and appended in order. */
static vm_status emit_slabs(dc *d, int interior, vm_error *err) {
    /* A batch's slabs hold their tets twice until appended: four per thread keep the
     * threads busy without holding a large part of the mesh twice (the order, and so the
     * mesh, is the same for any batch). */
    enum { LAYERS = 4 };
    const int64_t batch = vm_threads() < 16 ? 4 * (int64_t)vm_threads() : 64;
    int64_t per_axis = (d->n[2] + LAYERS - 1) / LAYERS, total = (interior ? 1 : 3) * per_axis;
    edge_slab *sl = calloc((size_t)batch, sizeof *sl);
    vm_status s = sl ? VM_OK : vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (int64_t first = 0; first < total && !s; first += batch) {
        int64_t count = total - first < batch ? total - first : batch;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int64_t q = 0; q < count; q++) {
            int64_t id = first + q, a = id / per_axis, z0 = (id % per_axis) * LAYERS;
            edge_slab *x = &sl[q];
            int64_t lo[4] = {a, 0, 0, z0}, hi[4] = {a + 1, d->n[0], d->n[1], z0 + LAYERS};
            int64_t top = interior ? d->n[2] - 1 : d->n[2];
            if (hi[3] > top) hi[3] = top;
            x->interior = interior;
            memcpy(x->lo, lo, sizeof lo);
            memcpy(x->hi, hi, sizeof hi);
            emit_slab(d, x);
        }
        s = append_slabs(d, sl, count, err);
        if (!s) s = vm__dc_check(d, err);
    }
    free(sl);
    return s;
}

/* Faces of boundary cells whose four corners are inside and whose neighbour is an interior
 * cell: a pyramid to the cell's minimiser, split along the face's even-parity diagonal
 * (the diagonal the neighbour's five-tet split uses). */
static vm_status emit_faces(dc *d, size_t first, size_t end, vm_error *err) {
    int64_t N = vm__dc_npoints_real(d);
    for (size_t bi = first; bi < end; bi++) {
        const bcell *b = &d->bc[bi];
        d->cur_src = SRC(SRC_FACES, bi);
        if (vm__dc_coarse(d, b->cell) >= 0) continue;
        int64_t cm[3];
        vm__dc_cell_coords(d, b->cell, cm);
        for (int f = 0; f < 6; f++) {
            int a = f >> 1, s = f & 1, all = 1;
            for (int q = 0; q < 4; q++)
                if (vm__dc_kind_of(b)->corner_patch[vm__dc_face_corner[f][q]] == NONE) all = 0;
            if (!all) continue;
            int64_t nb[3] = {cm[0], cm[1], cm[2]};
            nb[a] += s ? 1 : -1;
            int64_t nci = vm__dc_cidx(d, nb[0], nb[1], nb[2]);
            if (vm__dc_code(d, nci) != CELL_IN || vm__dc_coarse(d, nci) >= 0) continue;
            int64_t v[4];
            int even0 = 0;
            for (int q = 0; q < 4; q++) {
                int c = vm__dc_face_corner[f][q];
                int64_t p[3] = {cm[0] + (c & 1), cm[1] + ((c >> 1) & 1), cm[2] + (c >> 2)};
                v[q] = vm__dc_lattice_id(d, p);
                if (q == 0) even0 = (vm__dc_gsum(d, p) & 1) == 0;
            }
            int64_t apex =
                N + b->base + vm__dc_kind_of(b)->corner_patch[vm__dc_face_corner[f][0]];
            int o = even0 ? 0 : 1; /* diagonal v[o] - v[o+2] */
            vm_status st = emit_oriented(d, apex, v[o], v[o + 1], v[(o + 2) & 3], err);
            if (!st) st = emit_oriented(d, apex, v[o], v[(o + 2) & 3], v[(o + 3) & 3], err);
            if (st) return st;
        }
    }
    return VM_OK;
}

/* Interior cells: five tets, the central one on the four even-parity corners. */
static vm_status emit_five(dc *d, int64_t i, int64_t j, int64_t k, vm_error *err) {
    int64_t v[8];
    int64_t p0[3] = {i, j, k};
    int odd_first = (int)(vm__dc_gsum(d, p0) & 1); /* corner 0 is odd */
    for (int c = 0; c < 8; c++) {
        int64_t p[3] = {i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)};
        v[c] = vm__dc_lattice_id(d, p);
    }
    int ev[4], od[4], ne = 0, no = 0;
    for (int c = 0; c < 8; c++) {
        int par = ((c & 1) + ((c >> 1) & 1) + (c >> 2) + odd_first) & 1;
        if (par)
            od[no++] = c;
        else
            ev[ne++] = c;
    }
    vm_status s = emit_oriented(d, v[ev[0]], v[ev[1]], v[ev[2]], v[ev[3]], err);
    for (int q = 0; q < 4 && !s; q++) {
        int c = od[q];
        s = emit_oriented(d, v[c], v[c ^ 1], v[c ^ 2], v[c ^ 4], err);
    }
    return s;
}

/* One face square of a coarse leaf (min corner q, size sz, normal axis a; the leaf lies on
 * side `below` of the plane when below != 0): tets from the leaf centre over the face's
 * triangles. The square splits into four when the leaf across it is finer; an unsplit
 * square with grid vertices on its edges (corners of smaller leaves touching the edge) is
 * fanned from its centre (a grid point no leaf uses as a corner), otherwise it is cut along
 * its even-parity diagonal, as the leaf across does (LBIE §4.2.2, "decompose each face of
 * the cube into triangles ... then insert a Steiner point at the cell center"). */
static vm_status emit_coarse_face(dc *d, int64_t centre, int a, const int64_t q[3], int64_t sz,
                                  int below, vm_error *err) {
    int b = (a + 1) % 3, c = (a + 2) % 3;
    int64_t across[3] = {q[0], q[1], q[2]};
    if (!below) across[a]--;
    int64_t asz = vm__octree_size(&d->oct, across);
    int across_size_ok = asz == 0 || asz >= sz;
    if (!across_size_ok && sz > 1) {
        int64_t h = sz / 2;
        for (int k = 0; k < 4; k++) {
            int64_t r[3] = {q[0], q[1], q[2]};
            r[b] += h * (k & 1);
            r[c] += h * (k >> 1);
            vm_status s = emit_coarse_face(d, centre, a, r, h, below, err);
            if (s) return s;
        }
        return VM_OK;
    }
    static const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    int64_t corner[4], ring_buf[64], *ring = ring_buf;
    size_t nr = 0, ring_cap = 64, mids = 0;
    int even0 = 0;
    for (int k = 0; k < 4; k++) {
        int64_t p[3] = {q[0], q[1], q[2]};
        p[b] += sz * cyc[k][0];
        p[c] += sz * cyc[k][1];
        corner[k] = vm__dc_lattice_id(d, p);
        if (k == 0) even0 = ((vm__dc_gsum(d, p) / sz) & 1) == 0;
        if (nr + (size_t)sz >= ring_cap) { /* room for this corner and its edge */
            size_t ncap = 2 * (nr + (size_t)sz + 1);
            int64_t *nb = malloc(ncap * sizeof *nb);
            if (!nb) {
                if (ring != ring_buf) free(ring);
                return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
            }
            memcpy(nb, ring, nr * sizeof *nb);
            if (ring != ring_buf) free(ring);
            ring = nb;
            ring_cap = ncap;
        }
        ring[nr++] = corner[k];
        /* grid points along the edge that corners of smaller leaves put there */
        int db = cyc[(k + 1) & 3][0] - cyc[k][0], dc2 = cyc[(k + 1) & 3][1] - cyc[k][1];
        for (int64_t t = 1; t < sz; t++) {
            int64_t m[3] = {p[0], p[1], p[2]};
            m[b] += t * db;
            m[c] += t * dc2;
            if (vm__octree_is_vertex(&d->oct, m)) {
                ring[nr++] = vm__dc_lattice_id(d, m);
                mids++;
            }
        }
    }
    if (mids) {
        int64_t fc[3] = {q[0], q[1], q[2]};
        fc[b] += sz / 2;
        fc[c] += sz / 2;
        int64_t f = vm__dc_lattice_id(d, fc);
        vm_status s = VM_OK;
        for (size_t k = 0; k < nr && !s; k++)
            s = emit_oriented(d, centre, f, ring[k], ring[(k + 1) % nr], err);
        if (ring != ring_buf) free(ring);
        return s;
    }
    if (ring != ring_buf) free(ring);
    int o = even0 ? 0 : 1; /* diagonal corner[o] - corner[o+2] */
    vm_status s = emit_oriented(d, centre, corner[o], corner[o + 1], corner[(o + 2) & 3], err);
    if (!s)
        s = emit_oriented(d, centre, corner[o], corner[(o + 2) & 3], corner[(o + 3) & 3], err);
    return s;
}

static vm_status emit_coarse_leaf(dc *d, const int64_t o[3], int l, vm_error *err) {
    int64_t sz = (int64_t)1 << l, ctr[3] = {o[0] + sz / 2, o[1] + sz / 2, o[2] + sz / 2};
    int64_t centre = vm__dc_lattice_id(d, ctr);
    for (int f = 0; f < 6; f++) {
        int a = f >> 1, side = f & 1;
        int64_t q[3] = {o[0], o[1], o[2]};
        q[a] += side ? sz : 0;
        vm_status s = emit_coarse_face(d, centre, a, q, sz, side, err);
        if (s) return s;
    }
    return VM_OK;
}

static vm_status emit_interior(dc *d, int64_t k0, int64_t k1, vm_error *err) {
    for (int64_t k = k0; k < k1; k++)
        for (int64_t j = 0; j + 1 < d->n[1]; j++)
            for (int64_t i = 0; i + 1 < d->n[0]; i++) {
                int64_t ci = vm__dc_cidx(d, i, j, k);
                if (vm__dc_code(d, ci) != CELL_IN || vm__dc_coarse(d, ci) >= 0) continue;
                vm_status s = VM_OK;
                if (d->adaptive) {
                    int64_t c[3] = {i, j, k}, org[3];
                    int l = vm__octree_leaf(&d->oct, c, org);
                    if (l > 0) {
                        if (org[0] == i && org[1] == j && org[2] == k)
                            s = emit_coarse_leaf(d, org, l, err);
                        if (s) return s;
                        continue;
                    }
                }
                s = emit_five(d, i, j, k, err);
                if (s) return s;
            }
    return VM_OK;
}

/* Faces of coarse boundary leaves toward interior leaves: the face (or each quarter of it
 * next to an interior cell) triangulated as the interior side does, with the leaf's
 * vertex as apex (LBIE §4.2.2, 3: "identify all middle points on the four edges"). */
static vm_status emit_coarse_boundary(dc *d, size_t first, size_t end, vm_error *err) {
    for (size_t l = first; l < end; l++) {
        const int64_t *o = d->coarse_org + 3 * l;
        d->cur_src = SRC(SRC_COARSE, l);
        int64_t rep = vm__dc_npoints_real(d) + (int64_t)(d->coarse_base + l);
        for (int f = 0; f < 6; f++) {
            int a = f >> 1, side = f & 1, b = (a + 1) % 3, c = (a + 2) % 3;
            int64_t q[3] = {o[0], o[1], o[2]}, ac[3];
            q[a] += side ? 2 : 0;
            memcpy(ac, q, sizeof ac);
            if (!side) ac[a]--;
            int64_t aci = vm__dc_cidx(d, ac[0], ac[1], ac[2]);
            if (vm__dc_coarse(d, aci) >= 0) continue;
            vm_status s = VM_OK;
            if (vm__dc_code(d, aci) == CELL_IN && vm__octree_size(&d->oct, ac) >= 2) {
                s = emit_coarse_face(d, rep, a, q, 2, side, err);
            } else {
                for (int k = 0; k < 4 && !s; k++) {
                    int64_t sq[3] = {q[0], q[1], q[2]}, sc[3] = {ac[0], ac[1], ac[2]};
                    sq[b] += k & 1;
                    sq[c] += k >> 1;
                    sc[b] += k & 1;
                    sc[c] += k >> 1;
                    if (vm__dc_code(d, vm__dc_cidx(d, sc[0], sc[1], sc[2])) == CELL_IN)
                        s = emit_coarse_face(d, rep, a, sq, 1, side, err);
                }
            }
            if (s) return s;
        }
    }
    return VM_OK;
}

/* Around a special cell the elements of the two face edges at an inside corner use
 * different vertices in one of the two cells; the gap between their triangles is filled
 * with one tet, or two (a pyramid) when both cells differ. */
static vm_status emit_gaps(dc *d, size_t first, size_t end, vm_error *err) {
    for (size_t bi = first; bi < end; bi++) {
        const bcell *b = &d->bc[bi];
        if (!vm__dc_kind_of(b)->special) continue;
        d->cur_src = SRC(SRC_GAPS, bi);
        int64_t cm[3];
        vm__dc_cell_coords(d, b->cell, cm);
        for (int f = 0; f < 6; f++) {
            int a = f >> 1, s = f & 1;
            int64_t nb[3] = {cm[0], cm[1], cm[2]};
            nb[a] += s ? 1 : -1;
            int32_t code = vm__dc_code(d, vm__dc_cidx(d, nb[0], nb[1], nb[2]));
            if (code < 0)
                return vm_error_set(err, VM_ERR_INTERNAL,
                                    "mesh: special cell next to a uniform cell");
            const bcell *o = &d->bc[code];
            if (vm__dc_kind_of(o)->special && (size_t)code < bi) continue; /* done from the other side */
            for (int q = 0; q < 4; q++) {
                int c = vm__dc_face_corner[f][q];
                if (vm__dc_kind_of(b)->corner_patch[c] == NONE) continue;
                int e1 = vm__dc_edge_of[c][vm__dc_face_corner[f][(q + 1) & 3]];
                int e2 = vm__dc_edge_of[c][vm__dc_face_corner[f][(q + 3) & 3]];
                /* the same edges seen from the neighbour: flip bit a of both corners */
                int o1 = vm__dc_edge_of[vm__dc_edge_c0[e1] ^ (1 << a)]
                                       [vm__dc_edge_c1[e1] ^ (1 << a)];
                int o2 = vm__dc_edge_of[vm__dc_edge_c0[e2] ^ (1 << a)]
                                       [vm__dc_edge_c1[e2] ^ (1 << a)];
                int64_t x1 = vm__dc_rep_for_edge(d, b, e1), x2 = vm__dc_rep_for_edge(d, b, e2);
                int64_t y1 = vm__dc_rep_for_edge(d, o, o1), y2 = vm__dc_rep_for_edge(d, o, o2);
                int64_t p[3] = {cm[0] + (c & 1), cm[1] + ((c >> 1) & 1), cm[2] + (c >> 2)};
                int64_t n = vm__dc_lattice_id(d, p);
                vm_status st = VM_OK;
                if (x1 != x2 && y1 == y2) {
                    st = emit_oriented(d, n, x1, x2, y1, err);
                } else if (x1 == x2 && y1 != y2) {
                    st = emit_oriented(d, n, y1, y2, x1, err);
                } else if (x1 != x2 && y1 != y2) {
                    int64_t quad[4] = {x1, x2, y2, y1};
                    int lo = 0;
                    for (int k = 1; k < 4; k++)
                        if (quad[k] < quad[lo]) lo = k;
                    st = emit_oriented(d, n, quad[lo], quad[(lo + 1) & 3], quad[(lo + 2) & 3],
                                       err);
                    if (!st)
                        st = emit_oriented(d, n, quad[lo], quad[(lo + 2) & 3],
                                           quad[(lo + 3) & 3], err);
                }
                if (st) return st;
            }
        }
    }
    return VM_OK;
}

static vm_status emit_all(dc *d, vm_error *err) {
    d->ntets = 0;
    d->ncentre = 0;
    /* payloads: a + 3 * lattice id of an edge, a boundary cell, a coarse leaf (a grid
     * whose ids need 64 bits, which tests force with d->g->id_limit, goes wide too) */
    int64_t most = 3 * vm__dc_npoints_real(d);
    if ((int64_t)d->nbc > most) most = (int64_t)d->nbc;
    d->src_wide = most >= ((int64_t)1 << SRC_NARROW_SHIFT) || d->g->id_limit > 0;
    vm_status s = emit_slabs(d, 0, err);
    if (!s) s = emit_faces(d, 0, d->nbc, err);
    d->cur_src = SRC(SRC_NONE, 0);
    if (!s) s = vm__dc_check(d, err);
    if (!s) s = emit_slabs(d, 1, err);
    if (!s) s = emit_coarse_boundary(d, 0, d->ncoarse, err);
    if (!s) s = vm__dc_check(d, err);
    if (!s) s = emit_gaps(d, 0, d->nbc, err);
    return s;
}

/* What emit_local's compaction reads: the sources to drop (sorted, unique). */
typedef struct redo_set {
    dc *d;
    const int64_t *src;
    size_t n, tb;
} redo_set;

/* Tet t stays unless its element is to be emitted again. */
static int redo_keep(size_t t, void *user) {
    const redo_set *R = user;
    int64_t src = src_get(R->d, t);
    return SRC_KIND(src) == SRC_NONE || !bsearch(&src, R->src, R->n, sizeof *R->src, id_cmp);
}

/* Moves count tets (and their sources) from `from` down to `to`. */
static void redo_move(size_t to, size_t from, size_t count, void *user) {
    const redo_set *R = user;
    dc *d = R->d;
    size_t sb = d->src_wide ? sizeof(int64_t) : sizeof(uint32_t);
    memmove((char *)d->tets + R->tb * to, (char *)d->tets + R->tb * from, R->tb * count);
    memmove((char *)d->src + sb * to, (char *)d->src + sb * from, sb * count);
}

/* Re-emits only the elements with a tet on a representative flagged in moved[]: their tets
 * are removed and they are emitted again at the end of the list (their splits may change).
 * Interior elements use no representative and stay. The tets are flagged and compacted on
 * the threads. */
static vm_status emit_local(dc *d, const uint8_t *moved, vm_error *err) {
    int64_t N = vm__dc_npoints_real(d);
    int64_t *redo = NULL;
    size_t nredo = 0, cap = 0;
    vm_status s = VM_OK;
    uint8_t *hit = malloc(d->ntets + 1);
    if (!hit) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    const ptrdiff_t pnt = (ptrdiff_t)d->ntets;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t t = 0; t < pnt; t++) {
        int64_t v[4];
        tet_get(d, (size_t)t, v);
        uint8_t h = 0;
        for (int k = 0; k < 4; k++)
            if (v[k] >= N && (size_t)(v[k] - N) < d->nreps && moved[v[k] - N]) h = 1;
        hit[t] = h && SRC_KIND(src_get(d, (size_t)t)) != SRC_NONE;
    }
    for (size_t t = 0; t < d->ntets && !s; t++) {
        if (!hit[t]) continue;
        int64_t src = src_get(d, t);
        if (nredo && redo[nredo - 1] == src) continue;
        s = vm__grow((void **)&redo, &cap, nredo + 1, sizeof *redo, err);
        if (!s) redo[nredo++] = src;
    }
    free(hit);
    if (s || !nredo) {
        free(redo);
        return s;
    }
    qsort(redo, nredo, sizeof *redo, id_cmp);
    size_t u = 0;
    for (size_t i = 0; i < nredo; i++)
        if (u == 0 || redo[u - 1] != redo[i]) redo[u++] = redo[i];
    nredo = u;
    redo_set R = {d, redo, nredo, tet_bytes(d)};
    d->ntets = vm__compact(d->ntets, redo_keep, redo_move, &R);
    for (size_t i = 0; i < nredo && !s; i++) {
        int64_t pl = SRC_PAYLOAD(redo[i]);
        switch (SRC_KIND(redo[i])) {
        case SRC_EDGE: {
            int64_t id = pl / 3;
            int64_t only[4] = {pl % 3, id % d->n[0], (id / d->n[0]) % d->n[1],
                               id / (d->n[0] * d->n[1])};
            s = emit_edge_one(d, only, err);
            break;
        }
        case SRC_FACES: s = emit_faces(d, (size_t)pl, (size_t)pl + 1, err); break;
        case SRC_COARSE: s = emit_coarse_boundary(d, (size_t)pl, (size_t)pl + 1, err); break;
        default: s = emit_gaps(d, (size_t)pl, (size_t)pl + 1, err); break;
        }
    }
    free(redo);
    return s;
}

/* Pulls the minimisers of every tet that is not clearly positive back toward their mass
 * points, halving the step each round, then re-emits (the quad splits may change).
 * Returns the number of tets still not positive. */
static vm_status make_positive(dc *d, size_t *bad_left, size_t *relaxed, vm_error *err) {
    const double eps = 1e-9; /* index units: a 0.02-voxel tet is ~1e-6 */
    int64_t N = vm__dc_npoints_real(d);
    uint8_t *touched = calloc(d->nreps ? d->nreps : 1, 1);
    uint8_t *now = calloc(d->nreps ? d->nreps : 1, 1);
    if (!touched || !now) {
        free(touched);
        free(now);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    size_t bad = 0;
    uint8_t *flat = NULL; /* per tet: not clearly positive with the round's first positions */
    for (int round = 0; round < RELAX_ROUNDS; round++) {
        bad = 0;
        memset(now, 0, d->nreps);
        vm_status s = VM_OK;
        /* On threads, the volumes first; the loop below takes them for the tets none of
         * whose corners has moved yet in this round, and measures the others again: so it
         * reads what the serial loop would (the same mesh for any thread count). */
        int ahead = vm_threads() > 1;
        uint8_t *fl = ahead ? realloc(flat, d->ntets + 1) : flat;
        if (ahead && !fl) {
            free(flat);
            free(touched);
            free(now);
            return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        }
        flat = fl;
        const ptrdiff_t pnt = ahead ? (ptrdiff_t)d->ntets : 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
        for (ptrdiff_t t = 0; t < pnt; t++) {
            int64_t v[4];
            tet_get(d, (size_t)t, v);
            flat[t] = !(tet_volume(d, v, 0) > eps);
        }
        for (size_t t = 0; t < d->ntets && !s; t++) {
            int64_t v[4];
            if ((t & 0xfffff) == 0) s = vm__dc_check(d, err);
            tet_get(d, t, v);
            int measure = !ahead; /* (one thread: every tet measured here) */
            for (int k = 0; k < 4 && !measure; k++)
                if (v[k] >= N && (size_t)(v[k] - N) < d->nreps && now[v[k] - N]) measure = 1;
            if (measure ? tet_volume(d, v, 0) > eps : !flat[t]) continue;
            bad++;
            for (int k = 0; k < 4; k++)
                if (v[k] >= N && (size_t)(v[k] - N) < d->nreps) {
                    size_t r = (size_t)(v[k] - N);
                    d->lambda[r] = d->lambda[r] > relax_floor ? d->lambda[r] * 0.5f : 0.0f;
                    /* A coarse leaf's vertex also moves toward the block centre: its mass
                     * point may lie outside the wedge that the grid edges on its faces
                     * leave it (the centre lies inside every one of them). */
                    if (d->ncoarse && r >= d->coarse_base)
                        d->mu[r] = d->mu[r] > relax_floor ? d->mu[r] * 0.5f : 0.0f;
                    touched[r] = now[r] = 1;
                }
        }
        if (!s && !bad) break;
        if (!s) s = emit_local(d, now, err);
        if (s) {
            free(flat);
            free(touched);
            free(now);
            return s;
        }
    }
    free(flat);
    size_t nt = 0;
    for (size_t r = 0; r < d->nreps; r++)
        nt += touched[r];
    free(touched);
    free(now);
    *relaxed = nt;
    *bad_left = bad;
    return VM_OK;
}

/* A boundary candidate: a tet face, its sorted corners (key) and where each corner of its
 * outward order is in the key (32 bytes, not 48 with the order spelt out). */
typedef struct bface {
    int64_t key[3];
    uint8_t at[3];
} bface;

/* Corner k of face b in its outward order. */
static int64_t bface_v(const bface *b, int k) {
    return b->key[b->at[k]];
}

static int bface_cmp(const void *x, const void *y) {
    const int64_t *a = ((const bface *)x)->key, *b = ((const bface *)y)->key;
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* 1 when vertex id is a surface vertex: a representative, or a grid point on the box's
 * border (vm__dc_vertex_planes != 0, in 32-bit arithmetic where the grid allows it: this test
 * runs for every corner of every tet each untangling round). */
static int surface_vertex(const dc *d, int64_t N, int64_t id) {
    if (id >= N) return 1;
    if (N <= (int64_t)UINT32_MAX) {
        uint32_t u = (uint32_t)id, n0 = (uint32_t)d->n[0], n1 = (uint32_t)d->n[1];
        uint32_t x = u % n0, r = u / n0, y = r % n1, z = r / n1;
        return x == 0 || x == n0 - 1 || y == 0 || y == n1 - 1 || z == 0 ||
               (int64_t)z == d->n[2] - 1;
    }
    return vm__dc_vertex_planes(d, id) != 0;
}

/* Which faces of tet t (bit q: the face opposite node q) have three surface corners (the
 * candidates of boundary_faces). */
static const int bf_tf[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
static unsigned surface_faces(const dc *d, int64_t N, size_t t, int64_t v[4]) {
    tet_get(d, t, v);
    int surf[4];
    for (int k = 0; k < 4; k++)
        surf[k] = surface_vertex(d, N, v[k]);
    unsigned m = 0;
    for (int q = 0; q < 4; q++)
        if (surf[bf_tf[q][0]] && surf[bf_tf[q][1]] && surf[bf_tf[q][2]]) m |= 1u << q;
    return m;
}

#define BF_CHUNK ((size_t)1 << 14)

/* The boundary faces of the tets (the faces of surface vertices that occur once), *nb of
 * them, in *out (the caller frees it). The candidates are counted and then written by
 * chunks of tets on the threads, each chunk at its prefix sum: the list of the serial
 * loop, for any thread count. */
static vm_status boundary_faces(const dc *d, bface **out, size_t *nb_out, vm_error *err) {
    int64_t N = vm__dc_npoints_real(d);
    size_t nt = d->ntets, nc = (nt + BF_CHUNK - 1) / BF_CHUNK, nf = 0, nb = 0;
    *out = NULL;
    *nb_out = 0;
    size_t *at = calloc(nc + 1, sizeof *at);
    uint8_t *fm = malloc(nt + 1); /* each tet's candidate faces, from the count to the fill */
    if (!at || !fm) {
        free(at);
        free(fm);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    const ptrdiff_t pnc = (ptrdiff_t)nc;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 4)
#endif
    for (ptrdiff_t c = 0; c < pnc; c++) {
        size_t t1 = ((size_t)c + 1) * BF_CHUNK < nt ? ((size_t)c + 1) * BF_CHUNK : nt, k = 0;
        for (size_t t = (size_t)c * BF_CHUNK; t < t1; t++) {
            int64_t v[4];
            unsigned m = surface_faces(d, N, t, v);
            fm[t] = (uint8_t)m;
            k += (m & 1) + (m >> 1 & 1) + (m >> 2 & 1) + (m >> 3 & 1);
        }
        at[c + 1] = k;
    }
    for (size_t c = 0; c < nc; c++) at[c + 1] += at[c];
    nf = at[nc];
    bface *f = malloc((nf ? nf : 1) * sizeof *f);
    if (!f) {
        free(at);
        free(fm);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 4)
#endif
    for (ptrdiff_t c = 0; c < pnc; c++) {
        size_t t1 = ((size_t)c + 1) * BF_CHUNK < nt ? ((size_t)c + 1) * BF_CHUNK : nt;
        size_t k = at[c];
        for (size_t t = (size_t)c * BF_CHUNK; t < t1; t++) {
            unsigned m = fm[t];
            if (!m) continue;
            int64_t v[4];
            tet_get(d, t, v);
            for (int q = 0; q < 4; q++) {
                if (!(m >> q & 1)) continue;
                bface *b = &f[k++];
                int ord[3] = {0, 1, 2}; /* corners in increasing id order */
                for (int i = 1; i < 3; i++)
                    for (int j = i; j > 0 && v[bf_tf[q][ord[j - 1]]] > v[bf_tf[q][ord[j]]]; j--) {
                        int x = ord[j];
                        ord[j] = ord[j - 1];
                        ord[j - 1] = x;
                    }
                for (int i = 0; i < 3; i++) {
                    b->key[i] = v[bf_tf[q][ord[i]]];
                    b->at[ord[i]] = (uint8_t)i;
                }
            }
        }
    }
    free(at);
    free(fm);
    /* (faces with the same key are dropped together, so their order does not matter) */
    vm__psort(f, nf, sizeof *f, bface_cmp);
    for (size_t i = 0; i < nf;) { /* keep the faces that occur once, in place */
        size_t j = i + 1;
        while (j < nf && bface_cmp(&f[i], &f[j]) == 0)
            j++;
        if (j == i + 1) f[nb++] = f[i];
        i = j;
    }
    if (nb >= 2 && nb < nf) { /* give back the faces dropped before the check's arrays come */
        bface *fit = realloc(f, nb * sizeof *f);
        if (fit) f = fit;
    }
    *out = f;
    *nb_out = nb;
    return VM_OK;
}

/* The boundary of the last round, kept for the next one: its faces (sorted), their corners'
 * distinct ids (sorted) and positions, and its crossing pairs. A pair of faces that are both
 * still there with the same corners at the same positions crosses or not as before, so a
 * round tests again only the pairs with a face that is new or moved. */
typedef struct xprev {
    bface *f;
    size_t nb;
    int64_t *ids;
    double *pos;
    size_t nv;
    size_t *pr; /* 2 face indices per pair, the lower first, sorted */
    size_t npr;
    int valid;
} xprev;

static void xprev_free(xprev *X) {
    free(X->f);
    free(X->ids);
    free(X->pos);
    free(X->pr);
    memset(X, 0, sizeof *X);
}

/* A growing list of pairs (2 size_t each). */
typedef struct plist {
    size_t *a;
    size_t n, cap;
} plist;

static int plist_push(plist *l, size_t i, size_t j) {
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 256;
        size_t *na = realloc(l->a, 2 * cap * sizeof *na);
        if (!na) return 0;
        l->a = na;
        l->cap = cap;
    }
    l->a[2 * l->n] = i;
    l->a[2 * l->n + 1] = j;
    l->n++;
    return 1;
}

static int pair_cmp(const void *x, const void *y) {
    const size_t *a = x, *b = y;
    if (a[0] != b[0]) return a[0] < b[0] ? -1 : 1;
    return (a[1] > b[1]) - (a[1] < b[1]);
}

/* The box of face i (corners tri[3 i + k] into pos). */
static void face_box(const double *pos, const vm_index *tri, size_t i, double lo[3],
                     double hi[3]) {
    for (int a = 0; a < 3; a++) {
        lo[a] = INFINITY;
        hi[a] = -INFINITY;
        for (int k = 0; k < 3; k++) {
            double x = pos[3 * (size_t)tri[3 * i + (size_t)k] + (size_t)a];
            lo[a] = fmin(lo[a], x);
            hi[a] = fmax(hi[a], x);
        }
    }
}

#define XGRID_MAX_SIDE 4096

static size_t xcell(double x, double lo, double h, size_t n) {
    double c = floor((x - lo) / h);
    if (!(c > 0)) return 0;
    if (c >= (double)(n - 1)) return n - 1;
    return (size_t)c;
}

/* The crossing pairs of the nb faces (tri into pos) with at least one face in q[0..nq)
 * (face indices, increasing; isq[i] marks them) go to *out, each once as (lower, higher):
 * a uniform grid over the boxes of the q faces, every face's box looked up in it, a pair
 * tested in the grid cell of the low corner of the two boxes' overlap only, with
 * vm__tri_pair_intersects (the lower face first) — the test and the order of
 * vm__self_intersections, so the same pairs. 0 on out-of-memory. */
static int pairs_with(const double *pos, const vm_index *tri, size_t nb, const size_t *q,
                      size_t nq, const uint8_t *isq, plist *out) {
    if (nq == 0) return 1;
    double *bx = malloc(6 * nq * sizeof *bx), glo[3], ghi[3], ext = 0.0;
    if (!bx) return 0;
    for (int a = 0; a < 3; a++) {
        glo[a] = INFINITY;
        ghi[a] = -INFINITY;
    }
    for (size_t j = 0; j < nq; j++) {
        double *b = bx + 6 * j, big = 0.0;
        face_box(pos, tri, q[j], b, b + 3);
        for (int a = 0; a < 3; a++) {
            glo[a] = fmin(glo[a], b[a]);
            ghi[a] = fmax(ghi[a], b[3 + a]);
            big = fmax(big, b[3 + a] - b[a]);
        }
        ext += big;
    }
    /* cells about the size of a q face, at most about 2 per q face */
    double h = ext / (double)nq;
    double span = fmax(ghi[0] - glo[0], fmax(ghi[1] - glo[1], ghi[2] - glo[2]));
    if (!(h > 0) || !isfinite(h)) h = span > 0 && isfinite(span) ? span : 1.0;
    size_t n[3], ncell;
    for (;;) {
        ncell = 1;
        for (int a = 0; a < 3; a++) {
            double side = ghi[a] - glo[a], c = floor(side / h) + 1;
            n[a] = !isfinite(side) ? 1 : c < (double)XGRID_MAX_SIDE ? (size_t)c : XGRID_MAX_SIDE;
            ncell *= n[a];
        }
        if (ncell <= 2 * nq + 64 || !isfinite(h)) break;
        h *= 1.25;
    }
    size_t *start = calloc(ncell + 1, sizeof *start), *ent = NULL, total = 0;
    int ok = start != NULL;
    for (int pass = 0; ok && pass < 2; pass++) {
        for (size_t j = 0; j < nq; j++) {
            const double *b = bx + 6 * j;
            size_t c0[3], c1[3];
            for (int a = 0; a < 3; a++) {
                c0[a] = xcell(b[a], glo[a], h, n[a]);
                c1[a] = xcell(b[3 + a], glo[a], h, n[a]);
            }
            for (size_t z = c0[2]; z <= c1[2]; z++)
                for (size_t y = c0[1]; y <= c1[1]; y++)
                    for (size_t x = c0[0]; x <= c1[0]; x++) {
                        size_t c = x + n[0] * (y + n[1] * z);
                        if (pass == 0) {
                            start[c + 1]++;
                            total++;
                        } else {
                            ent[start[c]++] = j;
                        }
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++) start[c + 1] += start[c];
            ent = malloc((total + 1) * sizeof *ent);
            ok = ent != NULL;
        } else {
            for (size_t c = ncell; c > 0; c--) start[c] = start[c - 1];
            start[0] = 0;
        }
    }
    int fail = !ok;
    const ptrdiff_t nf = ok ? (ptrdiff_t)nb : 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1024) reduction(|| : fail)
#endif
    for (ptrdiff_t ii = 0; ii < nf; ii++) {
        size_t i = (size_t)ii;
        double lo[3], hi[3];
        face_box(pos, tri, i, lo, hi);
        int out_of = 0;
        for (int a = 0; a < 3; a++)
            if (lo[a] > ghi[a] || glo[a] > hi[a]) out_of = 1;
        if (out_of) continue;
        size_t c0[3], c1[3];
        for (int a = 0; a < 3; a++) {
            c0[a] = xcell(lo[a], glo[a], h, n[a]);
            c1[a] = xcell(hi[a], glo[a], h, n[a]);
        }
        for (size_t z = c0[2]; z <= c1[2]; z++)
            for (size_t y = c0[1]; y <= c1[1]; y++)
                for (size_t x = c0[0]; x <= c1[0]; x++) {
                    size_t c = x + n[0] * (y + n[1] * z);
                    for (size_t e = start[c]; e < start[c + 1]; e++) {
                        size_t j = q[ent[e]];
                        /* a pair of two q faces is taken from its lower face's side */
                        if (j == i || (isq[i] && j < i)) continue;
                        const double *B = bx + 6 * ent[e];
                        int apart = 0;
                        double corner[3];
                        for (int a = 0; a < 3; a++) {
                            if (lo[a] > B[3 + a] || B[a] > hi[a]) apart = 1;
                            corner[a] = fmax(lo[a], B[a]);
                        }
                        if (apart || xcell(corner[0], glo[0], h, n[0]) != x ||
                            xcell(corner[1], glo[1], h, n[1]) != y ||
                            xcell(corner[2], glo[2], h, n[2]) != z)
                            continue;
                        size_t s0 = i < j ? i : j, s1 = i < j ? j : i;
                        const double *pa[3], *pb[3];
                        vm_index ia[3], ib[3];
                        for (int k = 0; k < 3; k++) {
                            ia[k] = tri[3 * s0 + (size_t)k];
                            ib[k] = tri[3 * s1 + (size_t)k];
                            pa[k] = pos + 3 * (size_t)ia[k];
                            pb[k] = pos + 3 * (size_t)ib[k];
                        }
                        if (!vm__tri_pair_intersects(pa, ia, pb, ib)) continue;
                        int pushed;
#ifdef VM_HAVE_OPENMP
#pragma omp critical(vm_dc_pairs)
#endif
                        pushed = plist_push(out, s0, s1);
                        if (!pushed) fail = 1;
                    }
                }
    }
    free(bx);
    free(start);
    free(ent);
    return !fail;
}

/* Counts the intersecting pairs of boundary triangles of the current tets (index space)
 * and marks the representatives at the corners of those triangles in mark[]. A grid point
 * off the box border is surrounded by tets, so only faces without such a corner are
 * candidates; of those, the ones used by a single tet are the boundary. The pairs are those
 * of vm__self_intersections; with X valid (the last round's boundary) only the pairs with a
 * face that is new or has a corner that moved are tested, the others kept from X. X is set
 * to this round's boundary. */
static vm_status boundary_crossings(const dc *d, uint8_t *mark, size_t *pairs, xprev *X,
                                    vm_error *err) {
    int64_t N = vm__dc_npoints_real(d);
    bface *f = NULL;
    int64_t *ids = NULL;
    vm_index *tri = NULL;
    double *pos = NULL;
    uint8_t *isq = NULL;
    size_t *q = NULL, *map = NULL;
    plist pl = {NULL, 0, 0};
    size_t nb = 0, nv = 0;
    *pairs = 0;
    vm_status s = boundary_faces(d, &f, &nb, err);
    if (s || nb < 2) goto done;
    /* The faces' corners as indices into their sorted distinct ids (a corner's id is
     * ids[index]). */
    ids = malloc(3 * nb * sizeof *ids);
    tri = malloc(3 * nb * sizeof *tri);
    if (!ids || !tri) goto nomem;
    for (size_t i = 0; i < nb; i++)
        for (int k = 0; k < 3; k++)
            ids[3 * i + (size_t)k] = bface_v(&f[i], k);
    vm__psort(ids, 3 * nb, sizeof *ids, id_cmp);
    for (size_t i = 0; i < 3 * nb; i++)
        if (nv == 0 || ids[nv - 1] != ids[i]) ids[nv++] = ids[i];
    int64_t *distinct = realloc(ids, nv * sizeof *ids);
    if (distinct) ids = distinct;
    const ptrdiff_t pnb = (ptrdiff_t)nb;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t i = 0; i < pnb; i++)
        for (int k = 0; k < 3; k++) {
            int64_t id = bface_v(&f[i], k);
            const int64_t *hit = bsearch(&id, ids, nv, sizeof *ids, id_cmp);
            tri[3 * (size_t)i + (size_t)k] = (vm_index)(hit - ids);
        }
    pos = malloc(3 * nv * sizeof *pos);
    isq = calloc(nb, 1);
    q = malloc(nb * sizeof *q);
    if (!pos || !isq || !q) goto nomem;
    const ptrdiff_t pnv = (ptrdiff_t)nv;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t i = 0; i < pnv; i++)
        vm__dc_vertex_pos(d, ids[i], 0, pos + 3 * (size_t)i);
    /* Which faces are new or moved: a vertex moved when its position differs from the last
     * round's (bit for bit); the faces of both rounds are sorted, so they pair up in one
     * walk, which also maps the last round's faces to this round's (SIZE_MAX: gone or
     * changed). */
    if (X->valid) {
        uint8_t *moved = calloc(nv + 1, 1);
        map = malloc((X->nb + 1) * sizeof *map);
        if (!moved || !map) {
            free(moved);
            goto nomem;
        }
        for (size_t i = 0, j = 0; i < nv; i++) {
            while (j < X->nv && X->ids[j] < ids[i]) j++;
            moved[i] = j == X->nv || X->ids[j] != ids[i] ||
                       memcmp(X->pos + 3 * j, pos + 3 * i, 3 * sizeof *pos) != 0;
        }
        for (size_t j = 0; j < X->nb; j++) map[j] = SIZE_MAX;
        for (size_t i = 0, j = 0; i < nb; i++) {
            while (j < X->nb && bface_cmp(&X->f[j], &f[i]) < 0) j++;
            int same = j < X->nb && bface_cmp(&X->f[j], &f[i]) == 0 &&
                       memcmp(X->f[j].at, f[i].at, sizeof f[i].at) == 0;
            for (int k = 0; same && k < 3; k++)
                if (moved[tri[3 * i + (size_t)k]]) same = 0;
            if (same)
                map[j] = i;
            else
                isq[i] = 1;
        }
        free(moved);
        for (size_t p = 0; p < X->npr; p++) {
            size_t a = map[X->pr[2 * p]], b = map[X->pr[2 * p + 1]];
            if (a != SIZE_MAX && b != SIZE_MAX && !plist_push(&pl, a, b)) goto nomem;
        }
    } else {
        memset(isq, 1, nb);
    }
    size_t nq = 0;
    for (size_t i = 0; i < nb; i++)
        if (isq[i]) q[nq++] = i;
    if (!pairs_with(pos, tri, nb, q, nq, isq, &pl)) goto nomem;
    if (pl.n) qsort(pl.a, pl.n, 2 * sizeof *pl.a, pair_cmp);
    *pairs = pl.n;
    for (size_t p = 0; p < 2 * pl.n; p++)
        for (int k = 0; k < 3; k++) {
            int64_t id = ids[tri[3 * pl.a[p] + (size_t)k]];
            if (id >= N && (size_t)(id - N) < d->nreps) mark[id - N] = 1;
        }
    /* this round's boundary for the next */
    xprev_free(X);
    X->f = f;
    X->nb = nb;
    X->ids = ids;
    X->pos = pos;
    X->nv = nv;
    X->pr = pl.a;
    X->npr = pl.n;
    X->valid = 1;
    f = NULL;
    ids = NULL;
    pos = NULL;
    pl.a = NULL;
    goto done;
nomem:
    s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the boundary check");
done:
    free(f);
    free(ids);
    free(tri);
    free(pos);
    free(isq);
    free(q);
    free(map);
    free(pl.a);
    return s;
}

/* Where the boundary cuts itself, pulls the representatives at the corners of the crossing
 * triangles toward their mass points, then toward their cell centres, by a quarter of the
 * remaining step the first time (gentler than halving: fewer vertices end far from their
 * minimisers, which leaves the quality pass more to work with), half and then three
 * quarters when they keep crossing, keeping every tet positive.
 * The crossings come from QEF minimisers far from their patch's crossing points (often
 * clamped to a face of the cell): their triangles fold over the neighbouring patches while
 * every tet stays positive. [out] *left: pairs still crossing (as last counted); *bad: tets
 * not positive (0 unless relaxation failed); *moved: representatives moved. */
static vm_status untangle(dc *d, size_t *left, size_t *bad, size_t *moved, vm_error *err) {
    size_t nr = d->nreps ? d->nreps : 1;
    uint8_t *mark = calloc(nr, 1), *ever = calloc(nr, 1);
    vm_status s = VM_OK;
    size_t pairs = 0;
    xprev X;
    memset(&X, 0, sizeof X);
    *bad = 0;
    if (!mark || !ever) {
        s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        goto done;
    }
    for (int round = 0; round < UNTANGLE_ROUNDS; round++) {
        memset(mark, 0, nr);
        if ((s = boundary_crossings(d, mark, &pairs, &X, err)) || !pairs) break;
        size_t step = 0;
        for (size_t r = 0; r < d->nreps; r++) {
            if (!mark[r]) continue;
            /* a quarter of the way at first; vertices that keep crossing go faster */
            float keep = ever[r] == 0 ? 0.75f : ever[r] == 1 ? 0.5f : 0.25f;
            if (d->lambda[r] > 0) {
                d->lambda[r] = d->lambda[r] > relax_floor ? d->lambda[r] * keep : 0.0f;
            } else if (d->mu[r] > 0 && vm__dc_rep_centre(d, r, NULL)) {
                d->mu[r] = d->mu[r] > relax_floor ? d->mu[r] * keep : 0.0f;
            } else {
                continue;
            }
            if (ever[r] < 255) ever[r]++;
            step++;
        }
        if (!step) break;
        size_t touched = 0;
        if ((s = emit_local(d, mark, err)) || (s = make_positive(d, bad, &touched, err)) ||
            *bad || (s = vm__dc_check(d, err)))
            break;
    }
    *moved = 0;
    for (size_t r = 0; r < d->nreps; r++)
        *moved += ever[r] != 0;
done:
    xprev_free(&X);
    free(mark);
    free(ever);
    *left = pairs;
    return s;
}

vm_status vm__dual_contour_tets(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                vm_error *err) {
    dc d;
    vm_status s = vm__dc_setup(&d, g, st, err);
    if (!s) s = emit_all(&d, err);
    if (!s && g->progress && g->progress("contour", 3, 4, g->progress_user))
        s = vm__cancelled(err, "mesh");
    size_t bad = 0, relaxed = 0;
    if (!s) s = make_positive(&d, &bad, &relaxed, err);
    size_t crossing = 0, untangled = 0;
    if (!s && !bad) s = untangle(&d, &crossing, &bad, &untangled, err);
    if (!s && bad)
        s = vm_error_set(err, VM_ERR_INTERNAL,
                         "mesh: %zu tetrahedra stay flat or inverted after relaxation", bad);
    if (!s && g->lift) {
        s = vm__dc_lift(&d, g->frame, &out->nlift, &out->lift_id, &out->lift_pos, err);
        st->lifted_vertices = out->nlift;
    }
    if (!s && g->progress && g->progress("contour", 4, 4, g->progress_user))
        s = vm__cancelled(err, "mesh");
    if (s) {
        vm__dc_free(&d);
        return s;
    }
    st->relaxed_vertices = relaxed;
    st->untangled_vertices = untangled;
    st->boundary_crossings = crossing;
    st->surface_vertices = d.nreps;
    /* Hand over tets and the positions of the vertices they use. The representatives'
     * positions are written over their minimisers (each reads only its own values and its
     * cell), the rest of the state goes, and the tet list is cut to its length. */
    free(d.src);
    d.src = NULL;
    int64_t N = vm__dc_npoints_real(&d);
    for (size_t r = 0; r < d.nreps; r++) {
        double p[3];
        vm__dc_vertex_pos(&d, N + (int64_t)r, 0, p);
        memcpy(d.qpos + 3 * r, p, sizeof p);
    }
    double *pos = d.qpos;
    d.qpos = NULL;
    size_t nreps = d.nreps, ncentre = d.ncentre;
    double *centre = d.centre;
    d.centre = NULL;
    void *tets = d.tets;
    size_t ntets = d.ntets;
    int wide = d.wide;
    d.tets = NULL;
    vm__dc_free(&d);
    if (ntets) {
        void *t = realloc(tets, ntets * 4 * (wide ? sizeof(int64_t) : sizeof(uint32_t)));
        if (t) tets = t;
    }
    out->nodes = 4;
    out->ntets = ntets;
    if (wide)
        out->tets = tets;
    else
        out->tets32 = tets;
    out->nlattice = N;
    out->nreps = nreps + ncentre;
    if (ncentre) {
        double *all = realloc(pos, 3 * out->nreps * sizeof(double));
        if (!all) {
            free(centre);
            free(pos);
            return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        }
        pos = all;
        memcpy(pos + 3 * nreps, centre, 3 * ncentre * sizeof(double));
    }
    free(centre);
    out->rep_pos = pos;
    return VM_OK;
}
