/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_mesh.c — the working mesh of the improvement pass: element quality, the
 * vertex-to-tet stars kept up to date under local changes, the volume field and the vertex
 * constraints (isosurface projection, border planes, tangent planes). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "improve_internal.h"
#include "../quality/tet_internal.h"
#include "../core/vec3.h"

#define PI 3.14159265358979323846
#define DEG (180.0 / PI)

/* Face-angle cosines within this of the extremes are measured (ties in round-off). */
#define COS_TIE 1e-12
/* Projection onto the isosurface (index space): at most NEWTON_ITERS Newton steps, each at
 * most NEWTON_STEP_MAX voxels, until the first-order distance is below NEWTON_TOL voxels; a
 * squared gradient below GRAD2_MIN (or a gradient below GRAD_MIN) is flat. */
#define NEWTON_ITERS 10
#define NEWTON_STEP_MAX 0.5
#define NEWTON_TOL 1e-6
#define GRAD2_MIN 1e-30
#define GRAD_MIN 1e-12
/* With surface_chords: the boundary faces' samples within this share of surface_tolerance
 * (the samples, at edge midpoints and centres, miss the farthest points between them: on
 * the 64^3 cut sphere a share of 1 left the isosurface 0.52 voxel from the boundary). */
#define CHORD_SHARE 0.8
/* Index units a surface vertex may leave the volume's box by (round-off). */
#define BOX_TOL 1e-9

/* Faces opposite node i with outward normals for a positive tet. */
static const int face_of[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

double vm__imp_volume_measure(const double p[4][3]) {
    double a[3], bc[3], w12[3];
    vm__tet_circum_vector(p, a, bc, w12);
    double vol6 = vm__dot3(a, bc);
    if (!(vol6 > 0.0) || !isfinite(vol6)) return 0.0;
    double o[3];
    for (int k = 0; k < 3; k++) o[k] = w12[k] / (2.0 * vol6);
    double R = sqrt(vm__dot3(o, o));
    if (!(R > 0.0)) return 0.0;
    /* Regular tet of circumradius R: volume 8 R^3 / (9 sqrt 3). */
    double r = (vol6 / 6.0) * 9.0 * sqrt(3.0) / (8.0 * R * R * R);
    return isfinite(r) ? r : 0.0;
}

/* The angle (degrees) at corner k % 3 of face k / 3, exactly as atan2 gives it. */
static double corner_angle(const double p[4][3], int k) {
    int f = k / 3, c = k % 3;
    double u[3], v[3], cr[3];
    vm__sub3(p[face_of[f][(c + 1) % 3]], p[face_of[f][c]], u);
    vm__sub3(p[face_of[f][(c + 2) % 3]], p[face_of[f][c]], v);
    vm__cross3(u, v, cr);
    return atan2(sqrt(vm__dot3(cr, cr)), vm__dot3(u, v)) * DEG;
}

/* What the quality terms are made of: the extreme dihedral cosines (clamped to [-1, 1]) and
 * face-angle cosines of a tet, and the face cosines themselves. */
typedef struct qcos {
    double cmax, cmin;   /* dihedral angles' cosines: the smallest angle's, the largest's */
    double cfmax, cfmin; /* face angles' cosines: the same */
    double fc[12];       /* corner k % 3 of face k / 3 */
} qcos;

/* The dihedral cosines; 0 when the tet is not clearly positive (its quality is -1). */
static int dihedral_cosines(const double p[4][3], qcos *c) {
    return vm__tet_dihedral_cosines(p, &c->cmax, &c->cmin);
}

/* The twelve face-angle cosines (one square root per edge) and their extremes. */
static void face_cosines(const double p[4][3], qcos *c) {
    vm__tet_face_cosines(p, c->fc, &c->cfmax, &c->cfmin);
}

/* The smallest (want_min) and the largest (want_max) face angle: only the corners within
 * round-off of the extreme cosines are measured with atan2, so they are the minimum (maximum)
 * of the twelve atan2 angles. One not wanted is left at 180 (the smallest) or 0. */
static void face_angle_range(const double p[4][3], const qcos *c, int want_min, int want_max,
                             double *fmin, double *fmax) {
    *fmin = 180.0;
    *fmax = 0.0;
    for (int k = 0; k < 12; k++) {
        int lo = want_min && c->fc[k] >= c->cfmax - COS_TIE;
        int hi = want_max && c->fc[k] <= c->cfmin + COS_TIE;
        if (!lo && !hi) continue;
        double ang = corner_angle(p, k);
        if (lo && ang < *fmin) *fmin = ang;
        if (hi && ang > *fmax) *fmax = ang;
    }
}

/* A term of the quality is left unmeasured when its angle's cosine puts it above the
 * smallest term measured so far by more than this (degrees): far beyond the round-off
 * between a cosine and the atan2 the term would take, so the quality is the same value. */
#define SKIP_SLACK 1e-6
/* A cosine compared with a vm__cos_below bound keeps this much clear of it. */
#define SKIP_COS 1e-12

/* 1 when the angle whose cosine is c is above a degrees by round-off at least: its term
 * could not be the smallest (0 < a < 180). */
static int clearly_above(double c, double a) {
    return a > 0.0 && a < 180.0 && c < vm__cos_below(a / DEG) - SKIP_COS;
}

/* 1 when the angle whose cosine is c is below 180 - a degrees by round-off at least. */
static int clearly_below_180_minus(double c, double a) {
    return a > 0.0 && a < 180.0 && c > SKIP_COS - vm__cos_below(a / DEG);
}

/* What vm__imp_quality measures, in one pass over the tet: the six edge vectors and their
 * squared lengths serve the positivity test, the face normals, the volume measure and the
 * face cosines, each value computed by the same operations as dihedral_cosines,
 * vm__imp_volume_measure and face_cosines compute it (so the quality is the same to the
 * bit). Edge k joins nodes qe[k][0] < qe[k][1] and is p[qe[k][1]] - p[qe[k][0]]. */
static const int qe[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
/* The two edges each face normal crosses (face_of's u and v). */
static const int qnorm[4][2] = {{3, 4}, {2, 1}, {0, 2}, {1, 0}};
/* Edge index of the node pair (i, j), i != j. */
static const int qpair[4][4] = {{-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};

double vm__imp_quality(const vm__imp *w, const double p[4][3]) {
    double e[6][3], l2[6], lmax2 = 0.0;
    for (int k = 0; k < 6; k++) {
        vm__sub3(p[qe[k][1]], p[qe[k][0]], e[k]);
        l2[k] = vm__dot3(e[k], e[k]);
        if (l2[k] > lmax2) lmax2 = l2[k];
    }
    /* dihedral_cosines */
    const double *a = e[0], *b = e[1], *c = e[2];
    double bc[3];
    vm__cross3(b, c, bc);
    double vol6 = vm__dot3(a, bc);
    if (!isfinite(vol6) || !(vol6 > 1e-12 * lmax2 * sqrt(lmax2))) return -1.0;
    if (lmax2 > w->max_edge2) return 0.0; /* an edge over o->max_edge: below any bar */
    double n[4][3], len[4];
    for (int f = 0; f < 4; f++) {
        vm__cross3(e[qnorm[f][0]], e[qnorm[f][1]], n[f]);
        len[f] = sqrt(vm__dot3(n[f], n[f]));
        if (!(len[f] > 0.0)) return -1.0;
    }
    qcos cq;
    vm__tet_normal_cosines((const double(*)[3])n, len, &cq.cmax, &cq.cmin);
    double dmin = acos(cq.cmax) * DEG;
    double q = dmin / w->s_min;
    /* vm__imp_volume_measure (vol6 > 0 and finite here) */
    double vmq = 0.0;
    {
        double ca[3], ab[3], wv[3], o[3];
        vm__cross3(c, a, ca);
        vm__cross3(a, b, ab);
        for (int d = 0; d < 3; d++) wv[d] = l2[0] * bc[d] + l2[1] * ca[d] + l2[2] * ab[d];
        for (int k = 0; k < 3; k++) o[k] = wv[k] / (2.0 * vol6);
        double R = sqrt(vm__dot3(o, o));
        if (R > 0.0) {
            double r = (vol6 / 6.0) * 9.0 * sqrt(3.0) / (8.0 * R * R * R);
            vmq = isfinite(r) ? r : 0.0;
        }
    }
    double q3 = vmq / w->s_vm;
    if (q3 < q) q = q3;
    /* Each further term is measured only when its cosine does not put it clearly above q:
     * the minimum is the same as with every term measured. */
    if (!clearly_below_180_minus(cq.cmin, q * w->s_max + SKIP_SLACK)) {
        double dmax = acos(cq.cmin) * DEG, q2 = (180.0 - dmax) / w->s_max;
        if (q2 < q) q = q2;
    }
    /* face cosines, on the edge lengths above */
    double el[4][4];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) el[i][j] = i == j ? 0.0 : sqrt(l2[qpair[i][j]]);
    vm__tet_face_cosines_el(p, (const double(*)[4])el, cq.fc, &cq.cfmax, &cq.cfmin);
    int want_min = !clearly_above(cq.cfmax, q * w->s_fmin + SKIP_SLACK),
        want_max = !clearly_below_180_minus(cq.cfmin, q * w->s_fmax + SKIP_SLACK);
    if (!want_min && !want_max) return q;
    double fmin, fmax;
    face_angle_range(p, &cq, want_min, want_max, &fmin, &fmax);
    double q4 = fmin / w->s_fmin, q5 = (180.0 - fmax) / w->s_fmax;
    if (want_min && q4 < q) q = q4;
    if (want_max && q5 < q) q = q5;
    return q;
}

/* Angle limits (radians) the cosine tests take: nearer 0 or 180 degrees the cosine is too
 * flat to stand for the angle. */
#define BAR_ANGLE_MIN 1e-3
/* A cosine within this of its limit is measured as the quality measures it. */
#define BAR_COS_TIE 1e-9

/* The cosine of the limit angle a (degrees), or NAN when a is out of the cosine tests'
 * range. */
static double bar_cos(double a) {
    double r = a / DEG;
    return r >= BAR_ANGLE_MIN && r <= PI - BAR_ANGLE_MIN ? cos(r) : NAN;
}

void vm__imp_bar_set(const vm__imp *w, double f, vm__imp_bar *b) {
    b->f = f;
    b->c_dmin = bar_cos(f * w->s_min);
    b->c_dmax = bar_cos(180.0 - f * w->s_max);
    b->c_fmin = bar_cos(f * w->s_fmin);
    b->c_fmax = bar_cos(180.0 - f * w->s_fmax);
    b->fast = f > 0.0 && isfinite(b->c_dmin) && isfinite(b->c_dmax) && isfinite(b->c_fmin) &&
              isfinite(b->c_fmax);
}

int vm__imp_cos_side(double c, double l) {
    return c < l - BAR_COS_TIE ? 1 : c > l + BAR_COS_TIE ? -1 : 0;
}

int vm__imp_quality_above(const vm__imp *w, const double p[4][3], const vm__imp_bar *b) {
    if (!b->fast) return vm__imp_quality(w, p) > b->f;
    if (w->max_edge2 < INFINITY) { /* an edge over o->max_edge: q is 0 (or -1), not > f > 0 */
        for (int k = 0; k < 6; k++) {
            double e[3];
            vm__sub3(p[qe[k][1]], p[qe[k][0]], e);
            if (vm__dot3(e, e) > w->max_edge2) return 0;
        }
    }
    qcos c;
    if (!dihedral_cosines(p, &c)) return 0; /* quality -1 */
    /* q > f when every term is: min dihedral > f s_min (its cosine below the limit's), max
     * dihedral < 180 - f s_max (its cosine above), and so on; a cosine within the tie of its
     * limit decides by the quality itself. */
    int s1 = vm__imp_cos_side(c.cmax, b->c_dmin), s2 = -vm__imp_cos_side(c.cmin, b->c_dmax);
    if (s1 < 0 || s2 < 0) return 0;
    if (!(vm__imp_volume_measure(p) / w->s_vm > b->f)) return 0;
    face_cosines(p, &c);
    int s4 = vm__imp_cos_side(c.cfmax, b->c_fmin), s5 = -vm__imp_cos_side(c.cfmin, b->c_fmax);
    if (s4 < 0 || s5 < 0) return 0;
    if (s1 == 0 || s2 == 0 || s4 == 0 || s5 == 0) return vm__imp_quality(w, p) > b->f;
    return 1;
}

static void tet_points(const vm__imp *w, size_t t, double p[4][3]) {
    for (int k = 0; k < 4; k++) memcpy(p[k], w->p + 3 * (size_t)w->tet[4 * t + k], sizeof p[k]);
}

double vm__imp_tet_q(const vm__imp *w, size_t t) {
    double p[4][3];
    tet_points(w, t, p);
    return vm__imp_quality(w, (const double(*)[3])p);
}

void vm__imp_requal(vm__imp *w, size_t t) {
    vm__imp_set_q(w, t, vm__imp_tet_q(w, t));
}

void vm__imp_set_q(vm__imp *w, size_t t, double q) {
    w->q[t] = q;
    if (q >= 1.0) return;
    if (w->ntouched == w->touched_cap) {
        size_t cap = w->touched_cap ? 2 * w->touched_cap : 4096;
        vm_index *nt = realloc(w->touched, cap * sizeof *nt);
        if (!nt) {
            w->nomem = 1;
            return;
        }
        w->touched = nt;
        w->touched_cap = cap;
    }
    w->touched[w->ntouched++] = (vm_index)t;
}

double vm__imp_tet_q_moved(const vm__imp *w, size_t t, vm_index a, const double x[3]) {
    double p[4][3];
    tet_points(w, t, p);
    for (int k = 0; k < 4; k++)
        if (w->tet[4 * t + k] == a) memcpy(p[k], x, sizeof p[k]);
    return vm__imp_quality(w, (const double(*)[3])p);
}

int vm__imp_tet_above_moved(const vm__imp *w, size_t t, vm_index a, const double x[3],
                            const vm__imp_bar *b) {
    double p[4][3];
    tet_points(w, t, p);
    for (int k = 0; k < 4; k++)
        if (w->tet[4 * t + k] == a) memcpy(p[k], x, sizeof p[k]);
    return vm__imp_quality_above(w, (const double(*)[3])p, b);
}

int vm__imp_star_add(vm__imp *w, vm_index v, vm_index t) {
    vm__imp_star *s = &w->star[v];
    if (s->n == s->cap) {
        int32_t cap = s->cap ? 2 * s->cap : 16;
        vm_index *nt = realloc(s->t, (size_t)cap * sizeof *nt);
        if (!nt) {
            w->nomem = 1;
            return 0;
        }
        s->t = nt;
        s->cap = cap;
    }
    s->t[s->n++] = t;
    return 1;
}

void vm__imp_star_remove(vm__imp *w, vm_index v, vm_index t) {
    vm__imp_star *s = &w->star[v];
    for (int32_t i = 0; i < s->n; i++)
        if (s->t[i] == t) {
            s->t[i] = s->t[--s->n];
            return;
        }
}

long vm__imp_add_tet(vm__imp *w, const vm_index n[4], int32_t region, vm_index parent) {
    if (w->ntet == w->tet_cap) {
        size_t cap = w->tet_cap + w->tet_cap / 2 + 1024;
        vm_index *nt = realloc(w->tet, 4 * cap * sizeof *nt);
        if (nt) w->tet = nt;
        int32_t *nr = realloc(w->region, cap * sizeof *nr);
        if (nr) w->region = nr;
        vm_index *np = w->parent ? realloc(w->parent, cap * sizeof *np) : NULL;
        if (np) w->parent = np;
        double *nq = realloc(w->q, cap * sizeof *nq);
        if (nq) w->q = nq;
        uint8_t *nd = realloc(w->dead, cap);
        if (nd) w->dead = nd;
        if (!nt || !nr || (w->parent && !np) || !nq || !nd) {
            w->nomem = 1;
            return -1;
        }
        w->tet_cap = cap;
    }
    size_t t = w->ntet;
    for (int k = 0; k < 4; k++) {
        w->tet[4 * t + k] = n[k];
        if (!vm__imp_star_add(w, n[k], (vm_index)t)) {
            for (int j = 0; j < k; j++) vm__imp_star_remove(w, n[j], (vm_index)t);
            return -1;
        }
    }
    w->region[t] = region;
    if (w->parent) w->parent[t] = parent;
    w->dead[t] = 0;
    w->ntet++;
    vm__imp_requal(w, t);
    for (int k = 0; k < 4; k++) vm__imp_guard_touch(w, n[k]);
    return (long)t;
}

void vm__imp_kill_tet(vm__imp *w, size_t t) {
    if (w->dead[t]) return;
    for (int k = 0; k < 4; k++) {
        vm__imp_star_remove(w, w->tet[4 * t + k], (vm_index)t);
        vm__imp_guard_touch(w, w->tet[4 * t + k]);
    }
    w->dead[t] = 1;
}

int vm__imp_has(const vm__imp *w, size_t t, vm_index a) {
    const vm_index *n = w->tet + 4 * t;
    return n[0] == a || n[1] == a || n[2] == a || n[3] == a;
}

long vm__imp_face_other(const vm__imp *w, size_t t, vm_index a, vm_index b, vm_index c) {
    /* Scan the smallest of the three stars. */
    vm_index s = a, o1 = b, o2 = c;
    if (w->star[b].n < w->star[s].n) { s = b; o1 = a; o2 = c; }
    if (w->star[c].n < w->star[s].n) { s = c; o1 = a; o2 = b; }
    const vm__imp_star *st = &w->star[s];
    for (int32_t i = 0; i < st->n; i++) {
        size_t u = (size_t)st->t[i];
        if (u != t && vm__imp_has(w, u, o1) && vm__imp_has(w, u, o2)) return (long)u;
    }
    return -1;
}

vm_status vm__imp_qscratch(vm__imp *w, size_t n) {
    if (n <= w->qbuf_cap) return VM_OK;
    size_t cap = n + n / 2 + 64;
    double *b = realloc(w->qbuf, cap * sizeof *b);
    if (!b) {
        w->nomem = 1;
        return VM_ERR_NOMEM;
    }
    w->qbuf = b;
    w->qbuf_cap = cap;
    return VM_OK;
}

/* Grows w->buf to hold n indices (by half again, plus 64, to amortise). */
vm_status vm__imp_scratch(vm__imp *w, size_t n) {
    if (n <= w->buf_cap) return VM_OK;
    size_t cap = n + n / 2 + 64;
    vm_index *b = realloc(w->buf, cap * sizeof *b);
    if (!b) {
        w->nomem = 1;
        return VM_ERR_NOMEM;
    }
    w->buf = b;
    w->buf_cap = cap;
    return VM_OK;
}

unsigned vm__imp_rand(vm__imp *w) {
    /* xorshift32: reproducible, enough for random directions. */
    unsigned x = w->rng ? w->rng : 2463534242u;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    w->rng = x;
    return x;
}

double vm__imp_rand01(vm__imp *w) { return (vm__imp_rand(w) >> 8) * (1.0 / 16777216.0); }

void vm__imp_to_index(const vm__imp *w, const double x[3], double ijk[3]) {
    double d[3];
    vm__sub3(x, w->org, d);
    for (int r = 0; r < 3; r++) ijk[r] = vm__dot3(w->Ainv[r], d);
}

void vm__imp_to_world(const vm__imp *w, const double ijk[3], double x[3]) {
    for (int r = 0; r < 3; r++) x[r] = w->org[r] + vm__dot3(w->A[r], ijk);
}

/* Trilinear value and index-space gradient of the volume at ijk (clamped to the grid). */
static double field(const vm__imp *w, const double ijk[3], double g[3]) {
    const vm_volume *v = w->v;
    int64_t i0[3];
    double t[3];
    for (int a = 0; a < 3; a++) {
        double x = ijk[a], hi = (double)(v->dims[a] - 1);
        if (x < 0.0) x = 0.0;
        if (x > hi) x = hi;
        int64_t k = (int64_t)floor(x);
        if (k > v->dims[a] - 2) k = v->dims[a] - 2;
        if (k < 0) k = 0;
        i0[a] = k;
        t[a] = v->dims[a] > 1 ? x - (double)k : 0.0;
    }
    double c[8];
    for (int q = 0; q < 8; q++) {
        int64_t ii = i0[0] + ((q & 1) && v->dims[0] > 1);
        int64_t jj = i0[1] + (((q >> 1) & 1) && v->dims[1] > 1);
        int64_t kk = i0[2] + ((q >> 2) && v->dims[2] > 1);
        c[q] = vm__imp_voxel(w, ii, jj, kk);
    }
    double x0 = t[0], y0 = t[1], z0 = t[2];
    double c00 = c[0] + (c[1] - c[0]) * x0, c10 = c[2] + (c[3] - c[2]) * x0;
    double c01 = c[4] + (c[5] - c[4]) * x0, c11 = c[6] + (c[7] - c[6]) * x0;
    double c0 = c00 + (c10 - c00) * y0, c1 = c01 + (c11 - c01) * y0;
    if (g) {
        double dx0 = (c[1] - c[0]) * (1 - y0) + (c[3] - c[2]) * y0;
        double dx1 = (c[5] - c[4]) * (1 - y0) + (c[7] - c[6]) * y0;
        g[0] = dx0 * (1 - z0) + dx1 * z0;
        g[1] = (c10 - c00) * (1 - z0) + (c11 - c01) * z0;
        g[2] = c1 - c0;
    }
    return c0 + (c1 - c0) * z0;
}

/* How far index-space point ijk lies outside the volume's box (0 inside). */
static double box_excess(const vm__imp *w, const double ijk[3]) {
    double e = 0;
    for (int k = 0; k < 3; k++) {
        double hi = (double)(w->v->dims[k] - 1);
        if (-ijk[k] > e) e = -ijk[k];
        if (ijk[k] - hi > e) e = ijk[k] - hi;
    }
    return e;
}

/* 1 when surface vertex a at x (world) is no farther outside the volume's box than where it
 * started (the field is clamped to the grid, so outside the box its isosurface runs on
 * along the border: a vertex on the rim where the surface meets a border plane would slide
 * out along it). */
static int box_ok(const vm__imp *w, vm_index a, const double x[3]) {
    double ijk[3], ijk0[3];
    vm__imp_to_index(w, x, ijk);
    vm__imp_to_index(w, vm__imp_p0(w, a), ijk0);
    return box_excess(w, ijk) <= box_excess(w, ijk0) + BOX_TOL;
}

int vm__imp_project(const vm__imp *w, vm_index a, double x[3]) {
    double ijk[3], ijk0[3], g[3];
    vm__imp_to_index(w, x, ijk);
    vm__imp_to_index(w, vm__imp_p0(w, a), ijk0);
    double iso = w->iso_hi[a] ? w->hi : w->lo;
    int ok = 0;
    for (int it = 0; it < NEWTON_ITERS; it++) {
        double f = field(w, ijk, g) - iso;
        double g2 = vm__dot3(g, g);
        if (!(g2 > GRAD2_MIN) || !isfinite(f)) return 0;
        double step = f / g2, len = fabs(f) / sqrt(g2);
        if (len < NEWTON_TOL) {
            ok = 1;
            break;
        }
        if (len > NEWTON_STEP_MAX) step *= NEWTON_STEP_MAX / len;
        for (int k = 0; k < 3; k++) ijk[k] -= step * g[k];
    }
    if (!ok) return 0;
    double d[3];
    vm__sub3(ijk, ijk0, d);
    if (vm__dot3(d, d) > vm__imp_bound(w, a) * vm__imp_bound(w, a)) return 0;
    vm__imp_to_world(w, ijk, x);
    return box_ok(w, a, x);
}

/* With a surface band: x is kept as it is when it lies within the band around the
 * isosurface of a (first-order distance |f - iso| / |grad f|, index space) and within a's
 * bound; otherwise it goes back onto the isosurface. */
static int band_constrain(const vm__imp *w, vm_index a, double x[3]) {
    double band = w->o->surface_band;
    if (band > 0.0) {
        double ijk[3], ijk0[3], g[3], d[3];
        vm__imp_to_index(w, x, ijk);
        double f = field(w, ijk, g) - (w->iso_hi[a] ? w->hi : w->lo);
        double gl = sqrt(vm__dot3(g, g));
        if (gl > GRAD_MIN && isfinite(f) && fabs(f) <= band * gl) {
            vm__imp_to_index(w, vm__imp_p0(w, a), ijk0);
            vm__sub3(ijk, ijk0, d);
            return vm__dot3(d, d) <= vm__imp_bound(w, a) * vm__imp_bound(w, a) &&
                   box_ok(w, a, x);
        }
    }
    return vm__imp_project(w, a, x);
}

/* First-order distance (index voxels) of point x (world) from the isosurface iso;
 * infinity where the field is flat. */
static double iso_distance(const vm__imp *w, double iso, const double x[3]) {
    double ijk[3], g[3];
    vm__imp_to_index(w, x, ijk);
    double f = field(w, ijk, g) - iso, gl = sqrt(vm__dot3(g, g));
    if (!(gl > GRAD_MIN) || !isfinite(f)) return INFINITY;
    return fabs(f) / gl;
}

/* The largest iso_distance from u's isosurface at the samples (edge midpoints and centres)
 * of the boundary faces around vertex u with u at x, less those with vertex skip, with a
 * vertex inside a flat border face, or lying in a border plane (those lie on the plane, not
 * the isosurface), into *worst; 0 when out of memory. */
static int chord_faces(vm__imp *w, vm_index u, vm_index skip, const double x[3],
                       double *worst) {
    double iso = w->iso_hi[u] ? w->hi : w->lo;
    const vm_index *e;
    int nf = vm__imp_guard_faces(w, u, &e);
    if (nf < 0) return 0;
    for (int i = 0; i < nf; i++) {
        vm_index c = e[2 * i], d = e[2 * i + 1];
        if (c == skip || d == skip || w->cls[c] == VM__IMP_FLAT || w->cls[d] == VM__IMP_FLAT ||
            (w->planes[u] & w->planes[c] & w->planes[d]))
            continue;
        const double *pc = w->p + 3 * (size_t)c, *pd = w->p + 3 * (size_t)d;
        double s[3][3];
        for (int k = 0; k < 3; k++) {
            s[0][k] = 0.5 * (x[k] + pc[k]);
            s[1][k] = 0.5 * (x[k] + pd[k]);
            s[2][k] = (x[k] + pc[k] + pd[k]) / 3.0;
        }
        for (int j = 0; j < 3; j++) {
            double dist = iso_distance(w, iso, s[j]);
            if (dist > *worst) *worst = dist;
        }
    }
    return 1;
}

/* Whether the boundary faces around vertex i are bounded: an isosurface vertex, or one on
 * the rim of a border plane (fixed there, but a contraction may merge it into a neighbour on
 * the plane, and its faces off the plane are the isosurface's). */
static int chorded(const vm__imp *w, vm_index i) {
    return w->cls[i] == VM__IMP_SURF || (w->cls[i] == VM__IMP_FIXED && w->planes[i]);
}

/* The largest of chord_faces over the bounded vertices (chorded) among a and b (b < 0:
 * none), both at x, each without the faces holding the other; infinity when out of
 * memory. */
static double chord_error(vm__imp *w, vm_index a, vm_index b, const double x[3]) {
    double worst = 0;
    if (chorded(w, a) && !chord_faces(w, a, b, x, &worst)) return INFINITY;
    if (b >= 0 && chorded(w, b) && !chord_faces(w, b, a, x, &worst)) return INFINITY;
    return worst;
}

int vm__imp_chord_ok(vm__imp *w, vm_index a, vm_index b, const double x[3]) {
    if (!w->o->surface_chords || !w->v) return 1;
    if (!chorded(w, a) && (b < 0 || !chorded(w, b))) return 1;
    double after = chord_error(w, a, b, x);
    if (after <= CHORD_SHARE * w->o->surface_chords * w->o->surface_tolerance) return 1;
    /* before: every face around a and b as it is now */
    double before = 0;
    if (chorded(w, a) && !chord_faces(w, a, -1, w->p + 3 * (size_t)a, &before)) return 0;
    if (b >= 0 && chorded(w, b) && !chord_faces(w, b, -1, w->p + 3 * (size_t)b, &before))
        return 0;
    return after <= before;
}

int vm__imp_kept_near(vm__imp *w, vm_index a, vm_index b, const double x[3]) {
    if (!w->v) return 1;
    int chords = w->o->surface_chords > 1 ? w->o->surface_chords : 1;
    double bound = CHORD_SHARE * chords * w->o->surface_tolerance, worst = 0;
    for (int side = 0; side < 2; side++) {
        vm_index u = side ? b : a;
        const double *pu = w->p + 3 * (size_t)u;
        if (!chorded(w, u) || (pu[0] == x[0] && pu[1] == x[1] && pu[2] == x[2])) continue;
        double g[3], xi[3], best = INFINITY;
        vm__imp_to_index(w, pu, g);
        vm__imp_to_index(w, x, xi);
        for (int s2 = 0; s2 < 2 && best > bound * bound; s2++) {
            vm_index v = s2 ? b : a, o = s2 ? a : b;
            const vm_index *e;
            int nf = vm__imp_guard_faces(w, v, &e);
            if (nf < 0) return 0;
            for (int i = 0; i < nf && best > bound * bound; i++) {
                vm_index c = e[2 * i], d = e[2 * i + 1];
                if (c == o || d == o) continue;
                double ci[3], di[3];
                vm__imp_to_index(w, w->p + 3 * (size_t)c, ci);
                vm__imp_to_index(w, w->p + 3 * (size_t)d, di);
                double d2 = vm__point_triangle_dist2(g, xi, ci, di);
                if (d2 < best) best = d2;
            }
        }
        if (best > worst) worst = best;
    }
    return worst <= bound * bound;
}

int vm__imp_constrain(const vm__imp *w, vm_index a, double x[3]) {
    if (w->cls[a] == VM__IMP_INTERIOR) return 1;
    if (w->cls[a] == VM__IMP_FIXED) return 0;
    const double *p0 = vm__imp_p0(w, a), *n = vm__imp_nrm(w, a);
    double d[3];
    switch (w->cls[a]) {
    case VM__IMP_FLAT:
        vm__sub3(x, p0, d);
        {
            double s = vm__dot3(d, n);
            for (int k = 0; k < 3; k++) x[k] -= s * n[k];
        }
        return 1;
    case VM__IMP_SURF:
    case VM__IMP_IFACE:
        if (w->v && w->cls[a] == VM__IMP_SURF) return band_constrain(w, a, x);
        vm__sub3(x, p0, d);
        {
            double s = vm__dot3(d, n);
            for (int k = 0; k < 3; k++) {
                x[k] -= s * n[k];
                d[k] -= s * n[k];
            }
        }
        return vm__dot3(d, d) <= vm__imp_bound(w, a) * vm__imp_bound(w, a);
    default:
        return 0;
    }
}

void vm__imp_normal(const vm__imp *w, vm_index a, double n[3]) {
    memcpy(n, vm__imp_nrm(w, a), 3 * sizeof(double));
    if (w->cls[a] != VM__IMP_SURF || !w->v) return;
    double ijk[3], g[3], x[3];
    vm__imp_to_index(w, w->p + 3 * (size_t)a, ijk);
    field(w, ijk, g);
    /* d f / d x = Ainv^T d f / d ijk */
    for (int c = 0; c < 3; c++) x[c] = w->Ainv[0][c] * g[0] + w->Ainv[1][c] * g[1] + w->Ainv[2][c] * g[2];
    double l = sqrt(vm__dot3(x, x));
    if (l > 0.0 && isfinite(l))
        for (int c = 0; c < 3; c++) n[c] = x[c] / l;
}
