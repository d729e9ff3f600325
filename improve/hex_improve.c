/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/hex_improve.c — hexahedral mesh improvement: a pillow layer on the boundary (Mitchell
 * and Tautges 1995, "Pillowing doublets"), then untangling and smoothing by local max-min
 * optimisation of the scaled Jacobians (after Knupp 2001, "Hexahedral and tetrahedral mesh
 * untangling": one vertex at a time, the worst Jacobian of its hexes raised; each hex sampled
 * at its corners, centre and Gauss points, as vm_hex_scaled_jacobian and the report do); where
 * the whole layer fails, selective pillowing of the hexes still below the bar (a shrink set,
 * Mitchell and Tautges 1995 §3). */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"
#include "../quality/quality_internal.h"

/* For each VTK hex corner: itself and its three edge neighbours in right-handed order, so
 * that det(p[a]-p[c], p[b]-p[c], p[d]-p[c]) > 0 on a valid hex (as quality/hex_metrics.c). */
static const int corner_tab[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                     {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};
/* Faces with their right-hand normal pointing out of a valid hex. */
static const int face_tab[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                   {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

enum { CLS_FREE = 0, CLS_ISO = 1, CLS_PLANE = 2, CLS_FIXED = 3 };

/* ---- the pass's targets (scaled Jacobians, vm_hex_scaled_jacobian) ---- */
/* The bar: a hex whose scaled Jacobian is below it counts as poor (the report's below_02); the
 * pass works on such hexes first and pillows selectively round them. */
#define SJ_BAR 0.2
/* The polish's target, and the first of stage 1's rising targets. */
#define POLISH_TARGET 0.3
/* Stage 1 raises its target by this much a step, from POLISH_TARGET to o->target. */
#define TARGET_STEP 0.1
/* The untangling sweeps work on the hexes below this: inverted or nearly flat. */
#define UNTANGLE_TARGET 0.02

/* ---- distances from the isosurface (voxels) ---- */
/* Below this first-order estimate, iso_distance takes it as it is. */
#define ISO_EXACT_BELOW 0.05
/* iso_distance walks the gradient line in steps of ISO_WALK_STEP up to ISO_WALK_MAX. */
#define ISO_WALK_STEP 0.02
#define ISO_WALK_MAX 2.0
/* MOVE_TANGENT keeps a surface point within this of the isosurface (or within its starting
 * estimate plus ISO_TANGENT_SLACK); snap_in brings points beyond it back within it. */
#define ISO_TANGENT_MAX 0.45
#define ISO_TANGENT_SLACK 0.01
/* Past ISO_CHECK_FROM by the estimate, the measured distance must stay within ISO_CHECK_MAX
 * (or where it was): the estimate can miss a crossing the gradient does not point at. */
#define ISO_CHECK_FROM 0.2
#define ISO_CHECK_MAX 0.5
/* A surface point's move keeps the centres and edge midpoints of its boundary quads within
 * this of the isosurface (or no farther than they were). */
#define ISO_QUAD_MAX 0.45
/* Isosurface samples: each boundary quad off the box planes keeps the isosurface points its
 * bilinear samples at (u, v) in {1/6, 1/2, 5/6}^2 project onto where the run starts
 * (iso_samples); a move keeps each within ISO_QUAD_MAX of the quads round the point (or no
 * farther than it was). */
#define ISO_SAMPLES 9
/* MOVE_LOOSE lets a surface point go anywhere within this of the isosurface. */
#define ISO_LOOSE_MAX 0.4
/* A box-plane point moves at most this far (it need not follow the isosurface), one on the
 * rim (in a boundary face off the box too) stays within ISO_RIM_MAX of the isosurface (or
 * where it was); the bit of w->planes that marks the rim. */
#define PLANE_MOVE_MAX 0.5
#define ISO_RIM_MAX 0.35
#define PLANE_RIM 0x40u
/* MOVE_PROJECT: Newton steps (at most PROJECT_ITERS, each at most PROJECT_STEP_MAX long)
 * until the estimate is below PROJECT_TOL; a point that does not converge is still kept
 * within PROJECT_ACCEPT. */
#define PROJECT_ITERS 8
#define PROJECT_STEP_MAX 0.5
#define PROJECT_TOL 1e-4
#define PROJECT_ACCEPT 0.02

/* A volume whose metric (see hx) is within this of the identity is taken as a cube voxel's. */
#define METRIC_UNIT_TOL 1e-9

/* ---- compass searches ---- */
/* Steps from STEP_FIRST to STEP_LAST (STEP_LAST_FINE for the patch repair, which starts the
 * group moves at GROUP_STEP_FIRST) times the mean edge length at the point, halving. */
#define STEP_FIRST 0.25
#define STEP_LAST 0.01
#define STEP_LAST_FINE 0.005
#define GROUP_STEP_FIRST 0.2
/* Margins a candidate must beat the current figures by (round-off would otherwise count as
 * progress): relative on the determinant, absolute on the penalty, the worst scaled
 * Jacobian, the sum of scaled Jacobians and the patch energy. */
#define DET_REL_MARGIN 1e-12
#define PEN_MARGIN 1e-9
#define SJ_MARGIN 1e-6
#define SUM_MARGIN 1e-4
#define ENERGY_MARGIN 1e-12
/* A sweep whose worst hex rises by less than this makes no progress. */
#define SWEEP_PROGRESS 1e-4
/* Smallest edge-length product a corner's determinant is normalised by (a degenerate
 * corner would divide by zero). */
#define NORM_FLOOR 1e-300
/* A vertex within this of a grid face (index units) lies on that border plane. */
#define GRID_FACE_TOL 1e-6

typedef struct hx {
    size_t np, nh;
    double *p, *p0; /* world positions: current, and where the mesher put them */
    vm_index *h;    /* 8 nodes per hex */
    int32_t *region;
    size_t *vs, *vi; /* incidences of point i: vi[vs[i] .. vs[i+1]) = 8 * hex + corner */
    uint8_t *cls, *planes;
    double *nrm; /* unit outward normal of each boundary point (world) */
    double *est0; /* iso_estimate of each boundary point where the run starts (voxels) */
    /* the boundary quads (4 points each, nq of them) and, per point i, those it is a corner
     * of: bqi[bqs[i] .. bqs[i+1]) = 4 * quad + corner */
    vm_index *bq;
    size_t nq, *bqs, *bqi;
    uint8_t *focus; /* NULL, or the points a selective run may move */
    const vm_volume *v;
    double A[3][3], Ainv[3][3], org[3];
    /* Distances from the isosurface are world distances over the cube root of a voxel's
     * volume, the unit of the report and of --distance-check: a step dy in index space is
     * sqrt(dy^T M dy) long with M = A^T A / cbrt(|det A|)^2, and G = M^-1 turns index-space
     * gradients into steepest-descent steps. aniso 0: M is the identity (a cube voxel),
     * where the index-space formulas are used as they are. */
    double G[3][3], M[3][3];
    int aniso;
    double mscale; /* cbrt(|det A|): world distances over it are the metric's */
    /* isosurface samples, ISO_SAMPLES per boundary quad (3 coordinates each, in the
     * distance's frame: see dist_frame), NaN where a quad has none; NULL when unbounded */
    double *isp;
    double lo, hi;
    int has_lo, has_hi;
    double max_move;
    int pillowed; /* the mesh has the pillow layer: untangling by the penalty */
    int fit;      /* the mesher's mesh was valid: far boundary points are snapped in */
    /* measure's cache: qc[t] is hex t's scaled Jacobian with its points at pc; chg is
     * scratch over the points. NULL until the first measure, dropped when the mesh is
     * (re)loaded or pillowed. */
    double *qc, *pc;
    uint8_t *chg;
    vm_progress_fn progress;
    void *progress_user;
} hx;

/* The defaults volmesh/improve.h documents (every other field 0 or NULL). */
static const vm_hex_improve_options hex_defaults = {
    .has_lo = 1, .target = 0.5, .max_surface_move = 1.0, .pillow = 1, .max_sweeps = 8};

void vm_hex_improve_options_default(vm_hex_improve_options *o) {
    memset(o, 0, sizeof *o);
    *o = hex_defaults;
}

/* ---- geometry ---- */

static void hex_points(const hx *w, size_t t, double p[8][3]) {
    for (int k = 0; k < 8; k++) memcpy(p[k], w->p + 3 * (size_t)w->h[8 * t + k], sizeof p[k]);
}

/* The pass's one measure, the one vm_mesh_check and the report use: the scaled Jacobian at
 * the corners, the centre and the Gauss points (vm_hex_scaled_jacobian). */
static double hex_q(const hx *w, size_t t) {
    double p[8][3];
    hex_points(w, t, p);
    return vm_hex_scaled_jacobian((const double(*)[3])p);
}

/* Drops measure's cache (the mesh changed). */
static void cache_drop(hx *w) {
    free(w->qc);
    free(w->pc);
    free(w->chg);
    w->qc = w->pc = NULL;
    w->chg = NULL;
}

/* The samples of vm__hex_jacobian_samples that move with the node in corner slot k: its own
 * corner, its three neighbours' and the nine inside (the centre and the Gauss points). */
#define MOVING_SAMPLES 13
static void moving_samples(int k, int out[MOVING_SAMPLES]) {
    out[0] = k;
    for (int j = 1; j < 4; j++) out[j] = corner_tab[k][j];
    for (int s = 8; s < VM_HEX_SAMPLES; s++) out[s - 4] = s;
}

/* Figures of the samples that depend on point i, with i at x: the worst scaled Jacobian, the
 * sum of them, and the worst determinant. Every determinant is affine in x, so their minimum
 * is concave in x: the untangling objective (Knupp 2001) without local optima. */
typedef struct lq {
    double min, sum, det, pen;
} lq;

/* Samples whose normalised determinant is below this are penalised while untangling. */
#define UNTANGLE_BETA 0.1

/* Where local_q may stop: a candidate with a sample below min_below, a determinant at or
 * below det_at, or a penalty above pen_above cannot be better (the figures only fall or, for
 * the penalty, rise as more samples come in). */
typedef struct lq_stop {
    double min_below, det_at, pen_above;
} lq_stop;

static const lq_stop no_stop = {-INFINITY, -INFINITY, INFINITY};

/* local_q's keys of samples: WORST_KEY * hex + sample. */
#define WORST_KEY 32

/* One hex round a moving point, set up once per search: every column of the hex (the edges,
 * the centre's and the Gauss points' derivatives, vm__hex_columns) is affine in the point,
 * col = r + b dx, and every sample's determinant too, det = det0 + g . dx (the terms with dx
 * twice hold two parallel columns), dx the move from where the point was at set-up. A
 * trial position then costs a dot product per sample and a norm per column that moves. */
typedef struct star_hex {
    double r[VM_HEX_COLUMNS][3], b[VM_HEX_COLUMNS], n0[VM_HEX_COLUMNS];
    double det0[VM_HEX_SAMPLES], g[VM_HEX_SAMPLES][3], len0[VM_HEX_SAMPLES];
    unsigned char var[VM_HEX_COLUMNS]; /* the columns with b != 0 */
    int nvar, slot;
} star_hex;

/* Sets S up for hex t with the moving point in corner slot k. */
static void star_hex_load(const hx *w, size_t t, int k, star_hex *S) {
    double p4[8][4], col[VM_HEX_COLUMNS][4];
    for (int q = 0; q < 8; q++) {
        memcpy(p4[q], w->p + 3 * (size_t)w->h[8 * t + (size_t)q], 3 * sizeof(double));
        p4[q][3] = q == k ? 1.0 : 0.0;
    }
    vm__hex_columns((const double(*)[4])p4, col);
    S->nvar = 0;
    S->slot = k;
    for (int c = 0; c < VM_HEX_COLUMNS; c++) {
        memcpy(S->r[c], col[c], sizeof S->r[c]);
        S->b[c] = col[c][3];
        S->n0[c] = sqrt(col[c][0] * col[c][0] + col[c][1] * col[c][1] + col[c][2] * col[c][2]);
        if (S->b[c] != 0.0) S->var[S->nvar++] = (unsigned char)c;
    }
    for (int s = 0; s < VM_HEX_SAMPLES; s++) {
        const unsigned char *cs = vm__hex_sample_col[s];
        const double *ra = S->r[cs[0]], *rb = S->r[cs[1]], *rc = S->r[cs[2]];
        double x[3][3]; /* rb x rc, rc x ra, ra x rb */
        const double *u[3][2] = {{rb, rc}, {rc, ra}, {ra, rb}};
        for (int j = 0; j < 3; j++) {
            x[j][0] = u[j][0][1] * u[j][1][2] - u[j][0][2] * u[j][1][1];
            x[j][1] = u[j][0][2] * u[j][1][0] - u[j][0][0] * u[j][1][2];
            x[j][2] = u[j][0][0] * u[j][1][1] - u[j][0][1] * u[j][1][0];
        }
        S->det0[s] = ra[0] * x[0][0] + ra[1] * x[0][1] + ra[2] * x[0][2];
        for (int d = 0; d < 3; d++)
            S->g[s][d] = S->b[cs[0]] * x[0][d] + S->b[cs[1]] * x[1][d] + S->b[cs[2]] * x[2][d];
        S->len0[s] = S->n0[cs[0]] * S->n0[cs[1]] * S->n0[cs[2]];
    }
}

/* The length of S's column c with the point moved by dx. */
static inline double star_hex_norm(const star_hex *S, int c, const double dx[3]) {
    if (S->b[c] == 0.0) return S->n0[c];
    double v0 = S->r[c][0] + S->b[c] * dx[0], v1 = S->r[c][1] + S->b[c] * dx[1],
           v2 = S->r[c][2] + S->b[c] * dx[2];
    return sqrt(v0 * v0 + v1 * v1 + v2 * v2);
}

/* Sample sm of S with the point moved by dx: [out] *det its determinant; returns its
 * scaled Jacobian. n caches the column lengths, *have (a bit per column) says which are
 * in it: a search that stops at the first poor sample computes few of them. */
static inline double star_hex_sample(const star_hex *S, int sm, const double dx[3],
                              double n[VM_HEX_COLUMNS], uint32_t *have, double *det) {
    const unsigned char *cs = vm__hex_sample_col[sm];
    for (int j = 0; j < 3; j++)
        if (!(*have & (1u << cs[j]))) {
            n[cs[j]] = star_hex_norm(S, cs[j], dx);
            *have |= 1u << cs[j];
        }
    double d = S->det0[sm] + S->g[sm][0] * dx[0] + S->g[sm][1] * dx[1] + S->g[sm][2] * dx[2];
    *det = d;
    return vm__hex_sample_sj(d, n[cs[0]] * n[cs[1]] * n[cs[2]]);
}

/* The star of point i, set up at its current position; x0 is that position. At most
 * STAR_STACK hexes live on the stack, more are allocated (free with star_free). */
#define STAR_STACK 24
typedef struct star {
    star_hex buf[STAR_STACK], *h;
    size_t n;
    double x0[3];
} star;

static int star_load(const hx *w, size_t i, star *S) {
    S->n = w->vs[i + 1] - w->vs[i];
    S->h = S->n <= STAR_STACK ? S->buf : malloc(S->n * sizeof *S->h);
    if (!S->h) return 0;
    memcpy(S->x0, w->p + 3 * i, sizeof S->x0);
    for (size_t a = 0; a < S->n; a++) {
        size_t u = w->vs[i] + a;
        star_hex_load(w, w->vi[u] / 8, (int)(w->vi[u] % 8), &S->h[a]);
    }
    return 1;
}

static void star_free(star *S) {
    if (S->h != S->buf) free(S->h);
    S->h = NULL;
}

/* With pen: also the untangling penalty, the sum over the samples round the point of
 * max(0, beta - det / L), L the sample's column-length product where the star was set up.
 * Each det is affine in x, so the penalty is convex in x (Knupp 2001's untangling function,
 * normalised so that small and large hexes count alike). `first` names a sample as
 * WORST_KEY * hex + sample (the worst one last time): with a stop, that sample is tried
 * alone first (a poor candidate usually fails there: the full figures could only be lower),
 * and the hexes are visited from its hex on. Returns 0 when it stopped at stop (r is then
 * partial), else 1, and sets *worst (NULL allowed) to the key of the sample holding the
 * minimum. */
static int local_q(const star *S, const double x[3], int pen, lq *r, const lq_stop *stop,
                   size_t first_key, size_t *worst) {
    r->min = r->det = INFINITY;
    r->sum = r->pen = 0.0;
    double dx[3] = {x[0] - S->x0[0], x[1] - S->x0[1], x[2] - S->x0[2]};
    size_t first = first_key / WORST_KEY, fs = first_key % WORST_KEY;
    if (first >= S->n) {
        first = 0;
        fs = WORST_KEY;
    }
    if (fs < VM_HEX_SAMPLES && (stop->min_below > -INFINITY || stop->det_at > -INFINITY)) {
        double n[VM_HEX_COLUMNS], d;
        uint32_t have = 0;
        double q = star_hex_sample(&S->h[first], (int)fs, dx, n, &have, &d);
        if (q < stop->min_below || d <= stop->det_at) return 0;
    }
    for (size_t a = 0; a < S->n; a++) {
        size_t ui = (first + a) % S->n;
        const star_hex *H = &S->h[ui];
        int ms[MOVING_SAMPLES];
        double n[VM_HEX_COLUMNS];
        uint32_t have = 0;
        moving_samples(H->slot, ms);
        for (int j = 0; j < MOVING_SAMPLES; j++) {
            int sm = ms[j];
            double d, q = star_hex_sample(H, sm, dx, n, &have, &d);
            if (q < r->min) {
                r->min = q;
                if (worst) *worst = WORST_KEY * ui + (size_t)sm;
            }
            if (d < r->det) r->det = d;
            r->sum += q;
            if (pen) {
                double L = H->len0[sm] > NORM_FLOOR ? H->len0[sm] : NORM_FLOOR;
                double over = UNTANGLE_BETA - d / L; /* (fmax is a library call) */
                if (over > 0.0) r->pen += over;
            }
            /* the minima only fall and the penalty only rises from here */
            if (r->min < stop->min_below || r->det <= stop->det_at ||
                r->pen > stop->pen_above)
                return 0;
        }
    }
    return 1;
}

static void to_index(const hx *w, const double x[3], double ijk[3]) {
    double d[3] = {x[0] - w->org[0], x[1] - w->org[1], x[2] - w->org[2]};
    for (int r = 0; r < 3; r++)
        ijk[r] = w->Ainv[r][0] * d[0] + w->Ainv[r][1] * d[1] + w->Ainv[r][2] * d[2];
}

static void to_world(const hx *w, const double ijk[3], double x[3]) {
    for (int r = 0; r < 3; r++)
        x[r] = w->org[r] + w->A[r][0] * ijk[0] + w->A[r][1] * ijk[1] + w->A[r][2] * ijk[2];
}

static double det3(double a[3][3]) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}

static int invert3(double a[3][3], double b[3][3]) {
    double det = det3(a);
    if (!(fabs(det) > 0.0) || !isfinite(det)) return 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            b[r][c] = (a[r1][c1] * a[r2][c2] - a[r1][c2] * a[r2][c1]) / det;
        }
    return 1;
}

/* The cell of index position x (clamped to the box): [out] i0 its lowest corner, f the
 * position in it. */
static void field_cell(const vm_volume *v, const double x[3], int64_t i0[3], double f[3]) {
    for (int a = 0; a < 3; a++) {
        double c = x[a];
        double top = (double)(v->dims[a] - 1);
        if (c < 0.0) c = 0.0;
        if (c > top) c = top;
        int64_t i = (int64_t)c; /* c >= 0: the floor (floor() is a library call) */
        if (i > v->dims[a] - 2) i = v->dims[a] - 2;
        i0[a] = i;
        f[a] = c - (double)i;
    }
}

/* Trilinear field of the volume at index position x (clamped to the box) and its gradient
 * in index space. */
static double field(const vm_volume *v, const double x[3], double g[3]) {
    int64_t i0[3];
    double f[3];
    field_cell(v, x, i0, f);
    double val = 0.0;
    g[0] = g[1] = g[2] = 0.0;
    for (int c = 0; c < 8; c++) {
        int d[3] = {c & 1, (c >> 1) & 1, c >> 2};
        double s = v->data[(i0[0] + d[0]) +
                           v->dims[0] * ((i0[1] + d[1]) + v->dims[1] * (i0[2] + d[2]))];
        double wgt[3], dw[3];
        for (int a = 0; a < 3; a++) {
            wgt[a] = d[a] ? f[a] : 1.0 - f[a];
            dw[a] = d[a] ? 1.0 : -1.0;
        }
        val += s * wgt[0] * wgt[1] * wgt[2];
        g[0] += s * dw[0] * wgt[1] * wgt[2];
        g[1] += s * wgt[0] * dw[1] * wgt[2];
        g[2] += s * wgt[0] * wgt[1] * dw[2];
    }
    return val;
}

/* field's value alone (the same sum, term by term) in cell i0 at f. */
static double field_value(const vm_volume *v, const int64_t i0[3], const double f[3]) {
    double val = 0.0;
    for (int c = 0; c < 8; c++) {
        int d[3] = {c & 1, (c >> 1) & 1, c >> 2};
        double s = v->data[(i0[0] + d[0]) +
                           v->dims[0] * ((i0[1] + d[1]) + v->dims[1] * (i0[2] + d[2]))];
        double wgt[3];
        for (int a = 0; a < 3; a++) wgt[a] = d[a] ? f[a] : 1.0 - f[a];
        val += s * wgt[0] * wgt[1] * wgt[2];
    }
    return val;
}

/* Whether the field stays strictly on the side of iso that `above` says in the whole cell
 * i0 (its trilinear values lie between its corners' extremes; the margin covers the
 * round-off of field_value's sum). */
static int cell_one_side(const vm_volume *v, const int64_t i0[3], double iso, int above) {
    double mn = INFINITY, mx = -INFINITY, big = fabs(iso);
    for (int c = 0; c < 8; c++) {
        double s = v->data[(i0[0] + (c & 1)) +
                           v->dims[0] * ((i0[1] + ((c >> 1) & 1)) + v->dims[1] * (i0[2] + (c >> 2)))];
        /* (comparisons, not fmin/fmax: those are library calls here) */
        if (s < mn) mn = s;
        if (s > mx) mx = s;
        if (fabs(s) > big) big = fabs(s);
    }
    double margin = 1e-9 * big;
    return above ? mn > iso + margin : mx < iso - margin;
}

/* The material bound nearest to the field value f. */
static double iso_for(const hx *w, double f) {
    if (w->has_lo && w->has_hi) return fabs(f - w->lo) <= fabs(f - w->hi) ? w->lo : w->hi;
    return w->has_lo ? w->lo : w->hi;
}

/* Whether distances use the metric (see hx): on volumes whose voxels are not cubes, in a
 * run on a mesh that came out of the mesher valid. A folded mesh's run (the heads) keeps
 * index units: there the far points are the mesher's, which the bound in the check's voxel
 * did not bring in (CT head at 500: boundary -> isosurface 0.90 -> 1.09 voxels), and its
 * tighter bound across x and y left the adaptive CT head's worst hex at 0.322 against 0.451
 * (docs/BENCHMARKS.md). */
static int metric_on(const hx *w) {
    return w->aniso && w->fit;
}

/* The length of index-space gradient g in the distance metric (1 / the distance per unit of
 * field): sqrt(g^T G g); [out] dir = G g, the index-space step of steepest ascent (g
 * itself on a cube voxel's grid). */
static double grad_metric(const hx *w, const double g[3], double dir[3]) {
    if (!metric_on(w)) {
        for (int a = 0; a < 3; a++) dir[a] = g[a];
        return sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    }
    for (int a = 0; a < 3; a++) dir[a] = w->G[a][0] * g[0] + w->G[a][1] * g[1] + w->G[a][2] * g[2];
    double q = g[0] * dir[0] + g[1] * dir[1] + g[2] * dir[2];
    return q > 0.0 ? sqrt(q) : 0.0;
}

#define R3 0.57735026918962576 /* 1 / sqrt(3) */
#define R2 0.70710678118654752 /* 1 / sqrt(2) */
/* 6 axis and 8 diagonal directions (unit length), then 12 face diagonals: smoothing uses the
 * first 14, untangling all 26 (its penalty is piecewise linear, and a descent direction
 * at a kink can lie in a narrow cone). */
static const double dirs[26][3] = {
    {1, 0, 0},     {-1, 0, 0},     {0, 1, 0},      {0, -1, 0},      {0, 0, 1},
    {0, 0, -1},    {R3, R3, R3},   {-R3, R3, R3},  {R3, -R3, R3},   {-R3, -R3, R3},
    {R3, R3, -R3}, {-R3, R3, -R3}, {R3, -R3, -R3}, {-R3, -R3, -R3}, {R2, R2, 0},
    {-R2, R2, 0},  {R2, -R2, 0},   {-R2, -R2, 0},  {R2, 0, R2},     {-R2, 0, R2},
    {R2, 0, -R2},  {-R2, 0, -R2},  {0, R2, R2},    {0, -R2, R2},    {0, R2, -R2},
    {0, -R2, -R2}};

/* The trilinear field of cell i0 along the ray x + t u (index space, no clamping) as the
 * cubic k[0] + k[1] t + k[2] t^2 + k[3] t^3, and [out] *margin, more than the round-off
 * between it and field_value's sum within the cell (1e-9 of the largest magnitude of its
 * values; the cubic's coefficients carry a few ulps of it). 0 when the terms are not finite. */
static int ray_cubic(const vm_volume *v, const int64_t i0[3], const double x[3],
                     const double u[3], double k[4], double *margin) {
    double p[3], big = 0.0;
    for (int a = 0; a < 3; a++)
        p[a] = x[a] - (double)i0[a];
    /* along x: e[dy + 2 dz] = e0 + e1 t; along y: q[dz] quadratic; along z: the cubic */
    double e[4][2], q[2][3];
    for (int j = 0; j < 4; j++) {
        int dy = j & 1, dz = j >> 1;
        size_t base = (size_t)(i0[0] + v->dims[0] * ((i0[1] + dy) + v->dims[1] * (i0[2] + dz)));
        double s0 = v->data[base], s1 = v->data[base + 1];
        if (fabs(s0) > big) big = fabs(s0);
        if (fabs(s1) > big) big = fabs(s1);
        e[j][0] = s0 + (s1 - s0) * p[0];
        e[j][1] = (s1 - s0) * u[0];
    }
    for (int dz = 0; dz < 2; dz++) {
        const double *a0 = e[2 * dz], *a1 = e[2 * dz + 1];
        double d0 = a1[0] - a0[0], d1 = a1[1] - a0[1]; /* a0 + (a1 - a0) (p1 + u1 t) */
        q[dz][0] = a0[0] + d0 * p[1];
        q[dz][1] = a0[1] + d0 * u[1] + d1 * p[1];
        q[dz][2] = d1 * u[1];
    }
    double d[3] = {q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]};
    k[0] = q[0][0] + d[0] * p[2];
    k[1] = q[0][1] + d[0] * u[2] + d[1] * p[2];
    k[2] = q[0][2] + d[1] * u[2] + d[2] * p[2];
    k[3] = d[2] * u[2];
    *margin = 1e-9 * big;
    return isfinite(k[0]) && isfinite(k[1]) && isfinite(k[2]) && isfinite(k[3]) && big > 0.0;
}

/* Whether ray_cubic's cubic k at t is clearly (by margin) on the side of iso that f is on. */
static inline int cubic_clear(const double k[4], double t, double f, double iso,
                              double margin) {
    double e = ((k[3] * t + k[2]) * t + k[1]) * t + k[0] - iso;
    return f > iso ? e > margin : e < -margin;
}

/* How far (t) the ray x + t u stays in cell i0 as field_cell finds it: a point of the ray
 * before the returned t lies at least CELL_STAY_MARGIN voxels inside the cell's planes that
 * the ray heads for (field_cell clamps beyond the box, so the outer cells reach on to
 * infinity), which round-off of x + t u cannot cross; the ray's coordinates run
 * monotonically, so the planes behind it are not crossed either. */
#define CELL_STAY_MARGIN 1e-9
static double cell_stay(const vm_volume *v, const int64_t i0[3], const double x[3],
                        const double u[3], const double y[3], int strict) {
    double t = INFINITY;
    for (int a = 0; a < 3; a++) {
        double b;
        if (u[a] > 0.0 && (strict || i0[a] < v->dims[a] - 2))
            b = ((double)i0[a] + 1.0 - CELL_STAY_MARGIN - x[a]) / u[a];
        else if (u[a] < 0.0 && (strict || i0[a] > 0))
            b = ((double)i0[a] + CELL_STAY_MARGIN - x[a]) / u[a];
        else
            continue;
        if (b < t) t = b;
    }
    /* strict: y, the ray's point now, must be in the cell too (beyond the box field_cell
     * clamps, and ray_cubic's cubic does not) */
    if (strict)
        for (int a = 0; a < 3; a++)
            if (!(y[a] >= (double)i0[a] && y[a] <= (double)i0[a] + 1.0)) return -INFINITY;
    return t;
}

/* The first crossing of the isosurface (value f at x, bound iso) on the ray from index
 * position x along index-space step u (one voxel long in the distance's metric), in steps of
 * ISO_WALK_STEP up to tmax; INFINITY when there is none. */
static double iso_walk(const hx *w, const double x[3], double f, double iso, const double u[3],
                       double tmax) {
    /* the steps in a cell the field does not cross iso in are skipped: most of a walk; the
     * steps before the ray surely leaves such a cell (safe_until) are not even placed. In a
     * cell it crosses iso in, the field along the ray is a cubic in t (ray_cubic): until the
     * ray surely leaves that cell (cub_until), a step where the cubic is clearly on f's side
     * is passed without placing it (151 million steps in 5.6 million walks on ironProt's
     * hexes, 1.4 million of them measured) */
    int64_t safe[3] = {-1, -1, -1};
    double safe_until = -INFINITY, cub_until = -INFINITY, k[4] = {0, 0, 0, 0}, margin = 0.0;
    for (double t = ISO_WALK_STEP; t <= tmax; t += ISO_WALK_STEP) {
        if (t < safe_until) continue;
        if (t < cub_until) {
            if (cubic_clear(k, t, f, iso, margin)) continue;
        }
        double y[3], fr[3];
        int64_t c[3];
        for (int a = 0; a < 3; a++)
            y[a] = x[a] + t * u[a];
        field_cell(w->v, y, c, fr);
        if (c[0] == safe[0] && c[1] == safe[1] && c[2] == safe[2]) continue;
        if (cell_one_side(w->v, c, iso, f > iso)) {
            memcpy(safe, c, sizeof safe);
            safe_until = cell_stay(w->v, c, x, u, y, 0);
            continue;
        }
        if (!(t < cub_until) && f != iso) { /* (f on iso: every step measured, as it was) */
            cub_until = ray_cubic(w->v, c, x, u, k, &margin) ? cell_stay(w->v, c, x, u, y, 1)
                                                             : -INFINITY;
            /* (the step itself, as any: clearly on f's side, or measured) */
            if (t < cub_until) {
                if (cubic_clear(k, t, f, iso, margin)) continue;
            }
        }
        double fy = field_value(w->v, c, fr);
        if ((fy - iso) * (f - iso) <= 0.0) return t;
    }
    return INFINITY;
}

/* Distance of index position x from the isosurface, in voxels (the cube root of a voxel's
 * volume, world): the first crossing on the gradient line toward it (within 2 voxels); where
 * that line finds none (it runs along a ridge or into a saddle: ironProt, 0.40 by the
 * estimate, 0.52 in fact), on a mesh that came out of the mesher valid, the nearest
 * crossing along the 26 compass directions within as far (a folded mesh's far points, the CT
 * head's, made that search cost 1.7 times the pass), else the first-order estimate
 * |f - iso| / |grad f|, which is also the answer near the isosurface. */
static double iso_distance(const hx *w, const double x[3]) {
    double g[3], dir[3];
    double f = field(w->v, x, g);
    double iso = iso_for(w, f);
    double gn = grad_metric(w, g, dir);
    double d = fabs(f - iso);
    double est = gn > 0.0 ? d / gn : (d > 0.0 ? INFINITY : 0.0);
    if (est < ISO_EXACT_BELOW) return est;
    double sgn = f > iso ? -1.0 : 1.0, u[3], best = INFINITY;
    if (gn > 0.0) {
        for (int a = 0; a < 3; a++)
            u[a] = sgn * dir[a] / gn;
        best = iso_walk(w, x, f, iso, u, ISO_WALK_MAX);
        if (best < INFINITY || !w->fit) return best < INFINITY ? best : est;
    }
    for (int k = 0; k < 26 && w->fit; k++) {
        double l2 = 0.0;
        for (int a = 0; a < 3; a++)
            for (int c = 0; c < 3; c++)
                l2 += dirs[k][a] * (metric_on(w) ? w->M[a][c] : (double)(a == c)) * dirs[k][c];
        for (int a = 0; a < 3; a++)
            u[a] = dirs[k][a] / sqrt(l2);
        double t = iso_walk(w, x, f, iso, u, fmin(best, ISO_WALK_MAX));
        if (t < best) best = t;
    }
    return best < INFINITY ? best : est;
}

/* First-order distance |f - iso| / |grad f| of index position y from the isosurface
 * (voxels, as iso_distance). */
static double iso_estimate(const hx *w, const double y[3]) {
    double g[3], dir[3];
    double f = field(w->v, y, g);
    double gn = grad_metric(w, g, dir);
    double d = fabs(f - iso_for(w, f));
    return gn > 0.0 ? d / gn : (d > 0.0 ? INFINITY : 0.0);
}

/* Puts index position y on the isosurface by Newton steps along the gradient (at most
 * PROJECT_ITERS, each at most PROJECT_STEP_MAX voxels long); 0 when the gradient vanishes or
 * y ends more than PROJECT_ACCEPT from it. */
static int project_iso(const hx *w, double y[3]) {
    for (int it = 0; it < PROJECT_ITERS; it++) {
        double g[3], dir[3];
        double f = field(w->v, y, g);
        double r = f - iso_for(w, f);
        double gl = grad_metric(w, g, dir);
        double g2 = gl * gl;
        if (!metric_on(w)) g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (!(g2 > 0.0)) return 0;
        if (fabs(r) / sqrt(g2) < PROJECT_TOL) return 1;
        double step = r / g2, len = fabs(step) * sqrt(g2);
        if (len > PROJECT_STEP_MAX) step *= PROJECT_STEP_MAX / len;
        for (int a = 0; a < 3; a++) y[a] -= step * dir[a];
    }
    return iso_distance(w, y) <= PROJECT_ACCEPT;
}

enum { MOVE_TANGENT, MOVE_LOOSE, MOVE_PROJECT };

/* Distance (voxels) from the isosurface of the sample of boundary quad q whose weights on
 * its points, from corner j on, are wt, with point i at world position x. */
static double quad_sample_distance(const hx *w, size_t q, int j, size_t i, const double x[3],
                                   const double wt[4]) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 4; k++) {
        size_t pk = (size_t)w->bq[4 * q + (size_t)((j + k) % 4)];
        const double *xk = pk == i ? x : w->p + 3 * pk;
        for (int a = 0; a < 3; a++)
            c[a] += wt[k] * xk[a];
    }
    double y[3];
    to_index(w, c, y);
    if (iso_estimate(w, y) <= ISO_CHECK_FROM) return 0.0;
    return iso_distance(w, y);
}

/* The samples of a boundary quad that a move of its corner a moves, as weights on the points
 * a, b, c, d in the quad's order from a: on the bilinear face (its centre, the midpoints and
 * quarter points of the edges at a, the quarter point at a), and on the triangles either
 * diagonal splits it into (a writer, the report and VTK draw a quad as two of them): the
 * diagonal from a's midpoint and quarter point, and the three triangles' centroids at a. */
#define QUAD_SAMPLES 11
static const double quad_wt[QUAD_SAMPLES][4] = {{0.25, 0.25, 0.25, 0.25},
                                                {0.5, 0.5, 0.0, 0.0},
                                                {0.5, 0.0, 0.0, 0.5},
                                                {0.75, 0.25, 0.0, 0.0},
                                                {0.75, 0.0, 0.0, 0.25},
                                                {0.5625, 0.1875, 0.0625, 0.1875},
                                                {0.5, 0.0, 0.5, 0.0},
                                                {0.75, 0.0, 0.25, 0.0},
                                                {1.0 / 3, 1.0 / 3, 0.0, 1.0 / 3},
                                                {1.0 / 3, 1.0 / 3, 1.0 / 3, 0.0},
                                                {1.0 / 3, 0.0, 1.0 / 3, 1.0 / 3}};

/* Whether point i (a surface point) may move to world position x as far as its boundary
 * quads say: each quad's samples that the move moves (quad_wt) stay within ISO_QUAD_MAX of
 * the isosurface, or no farther from it than with i where it is. */
static int quads_near(const hx *w, size_t i, const double x[3]) {
    for (size_t e = w->bqs[i]; e < w->bqs[i + 1]; e++) {
        size_t q = w->bqi[e] / 4;
        int j = (int)(w->bqi[e] % 4);
        for (int k = 0; k < QUAD_SAMPLES; k++) {
            double d = quad_sample_distance(w, q, j, i, x, quad_wt[k]);
            if (d > ISO_QUAD_MAX &&
                d > quad_sample_distance(w, q, j, i, w->p + 3 * i, quad_wt[k]))
                return 0;
        }
    }
    return 1;
}

/* The frame distances are measured in: the world over mscale where the metric is on (see
 * hx), index space elsewhere. */
static void dist_frame(const hx *w, const double x[3], double f[3]) {
    if (!metric_on(w)) {
        to_index(w, x, f);
        return;
    }
    for (int a = 0; a < 3; a++)
        f[a] = x[a] / w->mscale;
}

/* Boundary quad q with point i at world position x, in the distance frame: its corners and
 * their mean (the four triangles round the centre that quad_dist2 measures). */
typedef struct quad_frame {
    double c[4][3], m[3];
} quad_frame;

static void quad_frame_of(const hx *w, size_t q, size_t i, const double x[3], quad_frame *F) {
    F->m[0] = F->m[1] = F->m[2] = 0;
    for (int j = 0; j < 4; j++) {
        size_t k = (size_t)w->bq[4 * q + (size_t)j];
        dist_frame(w, k == i ? x : w->p + 3 * k, F->c[j]);
        for (int a = 0; a < 3; a++)
            F->m[a] += 0.25 * F->c[j][a];
    }
}

/* Squared distance of s (distance frame) from the quad F. */
static double quad_dist2(const quad_frame *F, const double s[3]) {
    double best = INFINITY;
    for (int j = 0; j < 4; j++) {
        double d2 = vm__point_triangle_dist2(s, F->c[j], F->c[(j + 1) % 4], F->m);
        if (d2 < best) best = d2;
    }
    return best;
}

/* Distance (voxels) of sample s (distance frame) of quad F[q0] from the quads F[0..n) (the
 * boundary quads of a point, as placed), F[q0] first; stops early once it is within enough. */
static double quads_distance(const quad_frame *F, size_t n, const double s[3], size_t q0,
                             double enough) {
    double e2 = enough * enough, best = quad_dist2(&F[q0], s);
    for (size_t e = 0; e < n && best > e2; e++) {
        if (e == q0) continue;
        double d2 = quad_dist2(&F[e], s);
        if (d2 < best) best = d2;
    }
    return sqrt(best);
}

/* Whether point i may move to world position x as far as the isosurface samples of its
 * boundary quads say: each stays within ISO_QUAD_MAX of those quads, or no farther from
 * them than with i where it is. The quads are placed once for x and, when a sample needs
 * it, once for where i is. */
static int samples_near(const hx *w, size_t i, const double x[3]) {
    if (!w->isp) return 1;
    enum { QF_HERE = 32 };
    quad_frame here[2 * QF_HERE], *F = here;
    size_t n = w->bqs[i + 1] - w->bqs[i];
    if (n > QF_HERE && !(F = malloc(2 * n * sizeof *F))) return 0;
    quad_frame *G = F + n; /* i where it is, placed on first need */
    int placed = 0, ok = 1;
    for (size_t e = 0; e < n; e++)
        quad_frame_of(w, w->bqi[w->bqs[i] + e] / 4, i, x, &F[e]);
    for (size_t e = 0; e < n && ok; e++) {
        size_t q = w->bqi[w->bqs[i] + e] / 4;
        const double *sq = w->isp + 3 * ISO_SAMPLES * q;
        for (int k = 0; k < ISO_SAMPLES && ok; k++) {
            const double *s = sq + 3 * k;
            if (isnan(s[0])) continue;
            double d = quads_distance(F, n, s, e, ISO_QUAD_MAX);
            if (!(d > ISO_QUAD_MAX)) continue;
            if (!placed) {
                for (size_t g = 0; g < n; g++)
                    quad_frame_of(w, w->bqi[w->bqs[i] + g] / 4, i, w->p + 3 * i, &G[g]);
                placed = 1;
            }
            if (d > quads_distance(G, n, s, e, 0.0)) ok = 0;
        }
    }
    if (F != here) free(F);
    return ok;
}

/* Moves a trial position x of point i onto its constraint; 0 when that fails or takes it more
 * than the allowed distance from p0 (where the mesher put it). Box-plane points stay in their
 * plane(s). Surface points: MOVE_TANGENT keeps them in the tangent plane at p0 and within 0.45
 * voxel of the isosurface (smoothing: the mesher's points sit on sharp features, which the
 * smooth trilinear isosurface rounds off, so sliding on it would shave volume); MOVE_LOOSE
 * lets them anywhere within 0.4 voxel of it (untangling needs the room); MOVE_PROJECT puts
 * them on it (Newton steps along the gradient). */
static int constrain(const hx *w, size_t i, double x[3], int mode) {
    if (w->cls[i] == CLS_FREE) return 1;
    if (w->cls[i] == CLS_FIXED) return 0;
    double y[3], y0[3];
    to_index(w, w->p0 + 3 * i, y0);
    double limit = w->max_move;
    if (w->cls[i] == CLS_ISO && mode == MOVE_TANGENT) {
        const double *n = w->nrm + 3 * i, *x0 = w->p0 + 3 * i;
        double dn = (x[0] - x0[0]) * n[0] + (x[1] - x0[1]) * n[1] + (x[2] - x0[2]) * n[2];
        for (int a = 0; a < 3; a++) x[a] -= dn * n[a];
    }
    to_index(w, x, y);
    if (w->cls[i] == CLS_PLANE) {
        for (int a = 0; a < 3; a++)
            if (w->planes[i] & (3u << (2 * a))) y[a] = y0[a];
        limit = fmin(limit, PLANE_MOVE_MAX);
        /* a point of the rim, where the isosurface meets the box, stays near the isosurface
         * (on a valid mesh: on the CT head, whose rim points start up to a voxel off, the
         * bound left the worst hex at 0.42 instead of 0.45) */
        if (w->fit && (w->planes[i] & PLANE_RIM)) {
            double d = iso_distance(w, y);
            if (d > ISO_RIM_MAX && d > iso_distance(w, y0)) return 0;
        }
    } else if (mode == MOVE_TANGENT) {
        double est = iso_estimate(w, y);
        if (!(est <= fmax(ISO_TANGENT_MAX, w->est0[i] + ISO_TANGENT_SLACK))) return 0;
        /* the first-order estimate can miss a crossing the gradient does not point at (the
         * genus-3 tubes: 0.45 by it, 0.68 along the gradient): past 0.2, the distance the
         * report measures must stay within 0.5 or where it was */
        if (est > ISO_CHECK_FROM) {
            double d = iso_distance(w, y);
            if (d > ISO_CHECK_MAX && d > iso_distance(w, y0)) return 0;
        }
    } else if (mode == MOVE_LOOSE) {
        if (!(iso_distance(w, y) <= ISO_LOOSE_MAX)) return 0;
    } else if (!project_iso(w, y)) {
        return 0;
    }
    double d2 = 0.0;
    for (int a = 0; a < 3; a++) d2 += (y[a] - y0[a]) * (y[a] - y0[a]);
    if (d2 > limit * limit) return 0;
    to_world(w, y, x);
    return 1;
}

/* Whether a move of point i to x (constrained in mode) keeps its boundary quads near the
 * isosurface where the pass bounds them, on a mesh that came out of the mesher valid
 * (docs/ALGORITHMS.md, hex section, step 4, "Quads"): a surface point's quad samples near
 * the isosurface (quads_near), and the isosurface samples near the quads (samples_near)
 * for surface and box-plane points alike. */
static int quads_ok(const hx *w, size_t i, const double x[3], int mode) {
    if (!w->fit || mode == MOVE_PROJECT || w->cls[i] == CLS_FREE) return 1;
    if (w->cls[i] == CLS_ISO && !quads_near(w, i, x)) return 0;
    return samples_near(w, i, x);
}

/* ---- connectivity ---- */

static vm_status build_incidence(hx *w, vm_error *err) {
    free(w->vs);
    free(w->vi);
    w->vs = calloc(w->np + 1, sizeof *w->vs);
    w->vi = malloc((8 * w->nh + 1) * sizeof *w->vi);
    if (!w->vs || !w->vi) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t u = 0; u < 8 * w->nh; u++) w->vs[(size_t)w->h[u] + 1]++;
    for (size_t i = 0; i < w->np; i++) w->vs[i + 1] += w->vs[i];
    size_t *fill = malloc((w->np + 1) * sizeof *fill);
    if (!fill) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    memcpy(fill, w->vs, (w->np + 1) * sizeof *fill);
    for (size_t u = 0; u < 8 * w->nh; u++) w->vi[fill[w->h[u]]++] = u;
    free(fill);
    return VM_OK;
}

typedef struct face_rec {
    vm_index key[4]; /* sorted nodes */
    size_t hf;       /* 6 * hex + face */
} face_rec;

static int cmp_face(const void *a, const void *b) {
    const face_rec *x = a, *y = b;
    for (int k = 0; k < 4; k++)
        if (x->key[k] != y->key[k]) return x->key[k] < y->key[k] ? -1 : 1;
    return 0;
}

/* The boundary faces of the hexes t with in[t] (all hexes when in is NULL): the faces used
 * by one of them, as 6 * hex + face. [out] *out (free it), *nout. */
static vm_status boundary_faces(const hx *w, const uint8_t *in, size_t **out, size_t *nout,
                                vm_error *err) {
    size_t nf = 0;
    face_rec *f = malloc((6 * w->nh + 1) * sizeof *f);
    size_t *b = malloc((6 * w->nh + 1) * sizeof *b);
    if (!f || !b) {
        free(f);
        free(b);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t hf = 0; hf < 6 * w->nh; hf++) {
        if (in && !in[hf / 6]) continue;
        size_t u = nf++;
        vm_index *k = f[u].key;
        for (int j = 0; j < 4; j++) k[j] = w->h[8 * (hf / 6) + (size_t)face_tab[hf % 6][j]];
        for (int a = 1; a < 4; a++) /* insertion sort of four */
            for (int c = a; c > 0 && k[c - 1] > k[c]; c--) {
                vm_index tmp = k[c];
                k[c] = k[c - 1];
                k[c - 1] = tmp;
            }
        f[u].hf = hf;
    }
    qsort(f, nf, sizeof *f, cmp_face);
    size_t n = 0;
    for (size_t u = 0; u < nf;) {
        size_t e = u + 1;
        while (e < nf && cmp_face(&f[u], &f[e]) == 0) e++;
        if (e - u == 1) b[n++] = f[u].hf;
        u = e;
    }
    free(f);
    *out = b;
    *nout = n;
    return VM_OK;
}

/* Which points are on the boundary, and how each may move. */
static vm_status classify(hx *w, vm_error *err) {
    size_t *bf = NULL, nb = 0;
    vm_status s = boundary_faces(w, NULL, &bf, &nb, err);
    if (s) return s;
    free(w->cls);
    free(w->planes);
    w->cls = calloc(w->np + 1, 1);
    w->planes = calloc(w->np + 1, 1);
    if (!w->cls || !w->planes) {
        free(bf);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    free(w->nrm);
    free(w->est0);
    w->nrm = calloc(3 * w->np + 1, sizeof *w->nrm);
    w->est0 = calloc(w->np + 1, sizeof *w->est0);
    if (!w->nrm || !w->est0) {
        free(bf);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    free(w->bq);
    free(w->bqs);
    free(w->bqi);
    w->nq = nb;
    w->bq = malloc((4 * nb + 1) * sizeof *w->bq);
    w->bqs = calloc(w->np + 1, sizeof *w->bqs);
    w->bqi = malloc((4 * nb + 1) * sizeof *w->bqi);
    if (!w->bq || !w->bqs || !w->bqi) {
        free(bf);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t u = 0; u < nb; u++)
        for (int j = 0; j < 4; j++) {
            w->bq[4 * u + (size_t)j] = w->h[8 * (bf[u] / 6) + (size_t)face_tab[bf[u] % 6][j]];
            w->bqs[(size_t)w->bq[4 * u + (size_t)j] + 1]++;
        }
    for (size_t i = 0; i < w->np; i++) w->bqs[i + 1] += w->bqs[i];
    {
        size_t *fill = malloc((w->np + 1) * sizeof *fill);
        if (!fill) {
            free(bf);
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        }
        memcpy(fill, w->bqs, (w->np + 1) * sizeof *fill);
        for (size_t u = 0; u < 4 * nb; u++) w->bqi[fill[w->bq[u]]++] = u;
        free(fill);
    }
    for (size_t u = 0; u < nb; u++) {
        const vm_index *c = w->h + 8 * (bf[u] / 6);
        const int *fc = face_tab[bf[u] % 6];
        const double *P0 = w->p + 3 * (size_t)c[fc[0]], *P1 = w->p + 3 * (size_t)c[fc[1]],
                     *P2 = w->p + 3 * (size_t)c[fc[2]], *P3 = w->p + 3 * (size_t)c[fc[3]];
        double d1[3], d2[3], n[3];
        for (int a = 0; a < 3; a++) {
            d1[a] = P2[a] - P0[a];
            d2[a] = P3[a] - P1[a];
        }
        n[0] = d1[1] * d2[2] - d1[2] * d2[1];
        n[1] = d1[2] * d2[0] - d1[0] * d2[2];
        n[2] = d1[0] * d2[1] - d1[1] * d2[0];
        for (int j = 0; j < 4; j++) {
            size_t i = (size_t)c[fc[j]];
            w->cls[i] = CLS_ISO;
            for (int a = 0; a < 3; a++) w->nrm[3 * i + a] += n[a];
        }
    }
    for (size_t i = 0; i < w->np; i++) {
        double *n = w->nrm + 3 * i, l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int a = 0; a < 3; a++) n[a] = l > 0.0 ? n[a] / l : 0.0;
    }
    for (size_t i = 0; i < w->np; i++) {
        if (w->cls[i] == CLS_FREE) continue;
        if (!w->v) {
            w->cls[i] = CLS_FIXED;
            continue;
        }
        double y[3];
        to_index(w, w->p + 3 * i, y);
        uint8_t bits = 0;
        for (int a = 0; a < 3; a++) {
            if (fabs(y[a]) < GRID_FACE_TOL) bits |= (uint8_t)(1u << (2 * a));
            if (fabs(y[a] - (double)(w->v->dims[a] - 1)) < GRID_FACE_TOL)
                bits |= (uint8_t)(2u << (2 * a));
        }
        w->planes[i] |= bits;
        if (bits) w->cls[i] = CLS_PLANE;
        w->est0[i] = iso_estimate(w, y);
    }
    /* the rim: box-plane points of a boundary face that is not on one box plane */
    for (size_t u = 0; u < nb && w->v; u++) {
        const vm_index *c = w->h + 8 * (bf[u] / 6);
        const int *fc = face_tab[bf[u] % 6];
        unsigned common = 0x3fu;
        for (int j = 0; j < 4; j++) common &= w->planes[c[fc[j]]];
        if (common & 0x3fu) continue;
        for (int j = 0; j < 4; j++)
            if (w->planes[c[fc[j]]] & 0x3fu) w->planes[c[fc[j]]] |= PLANE_RIM;
    }
    free(bf);
    return VM_OK;
}

/* Where the run starts: the isosurface samples of the boundary quads (see hx->isp) on a mesh
 * that came out of the mesher valid (the distances are bounded there only). A quad on one box
 * plane has none (the isosurface does not close the box). */
static vm_status iso_samples(hx *w, vm_error *err) {
    static const double uv[3] = {1.0 / 6.0, 0.5, 5.0 / 6.0};
    free(w->isp);
    w->isp = NULL;
    if (!w->fit || !w->v || !w->nq) return VM_OK;
    w->isp = malloc(3 * ISO_SAMPLES * w->nq * sizeof *w->isp);
    if (!w->isp) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t q = 0; q < w->nq; q++) {
        double *sq = w->isp + 3 * ISO_SAMPLES * q;
        unsigned common = 0x3fu;
        for (int j = 0; j < 4; j++)
            common &= w->planes[w->bq[4 * q + (size_t)j]];
        for (int k = 0; k < ISO_SAMPLES; k++) {
            double u = uv[k % 3], v = uv[k / 3], y[3], c[3] = {0, 0, 0};
            double wt[4] = {(1.0 - u) * (1.0 - v), u * (1.0 - v), u * v, (1.0 - u) * v};
            for (int j = 0; j < 4; j++) {
                const double *pk = w->p + 3 * (size_t)w->bq[4 * q + (size_t)j];
                for (int a = 0; a < 3; a++)
                    c[a] += wt[j] * pk[a];
            }
            to_index(w, c, y);
            if ((common & 0x3fu) || !project_iso(w, y)) {
                for (int a = 0; a < 3; a++)
                    sq[3 * k + a] = NAN;
                continue;
            }
            to_world(w, y, c);
            dist_frame(w, c, sq + 3 * k);
        }
    }
    return VM_OK;
}

/* ---- pillowing ---- */

/* Where the boundary of the shrink set (the sheet) is not a manifold surface: a vertex with
 * a sheet edge not in exactly two sheet faces, or with its sheet faces in more than one fan.
 * The hexes of the set at such vertices leave it (in[t] = 0). Returns the number of such
 * vertices. [in] bf, nb: the sheet faces, as 6 * hex + face; open: the sheet leaves out the
 * faces on the box (pillow's open), so an edge of two points on one box plane (the rim) may
 * be in one sheet face. */
static size_t sheet_defects(const hx *w, const size_t *bf, size_t nb, uint8_t *in, int open) {
    size_t *start = calloc(w->np + 2, sizeof *start), *list = malloc((4 * nb + 1) * sizeof *list);
    uint8_t *bad = calloc(w->np + 1, 1);
    size_t nbad = 0;
    if (!start || !list || !bad) {
        free(start);
        free(list);
        free(bad);
        for (size_t t = 0; t < w->nh; t++) in[t] = 0; /* out of memory: no layer */
        return 1;
    }
    for (size_t u = 0; u < nb; u++)
        for (int j = 0; j < 4; j++)
            start[(size_t)w->h[8 * (bf[u] / 6) + (size_t)face_tab[bf[u] % 6][j]] + 2]++;
    for (size_t i = 0; i < w->np; i++) start[i + 2] += start[i + 1];
    for (size_t u = 0; u < nb; u++)
        for (int j = 0; j < 4; j++)
            list[start[(size_t)w->h[8 * (bf[u] / 6) + (size_t)face_tab[bf[u] % 6][j]] + 1]++] = u;
    for (size_t v = 0; v < w->np; v++) {
        size_t k = start[v + 1] - start[v];
        if (!k) continue;
        if (k > 64) {
            bad[v] = 1;
            continue;
        }
        vm_index q[64][4];
        int at[64], par[64];
        for (size_t a = 0; a < k; a++) {
            size_t u = list[start[v] + a];
            for (int j = 0; j < 4; j++) {
                q[a][j] = w->h[8 * (bf[u] / 6) + (size_t)face_tab[bf[u] % 6][j]];
                if ((size_t)q[a][j] == v) at[a] = j;
            }
            par[a] = (int)a;
        }
        int ok = 1;
        for (size_t a = 0; a < k && ok; a++)
            for (int side = 1; side <= 3; side += 2) {
                vm_index nbr = q[a][(at[a] + side) % 4];
                int count = 0;
                for (size_t b = 0; b < k; b++) {
                    if (q[b][(at[b] + 1) % 4] != nbr && q[b][(at[b] + 3) % 4] != nbr) continue;
                    count++;
                    int x = (int)a, y = (int)b;
                    while (par[x] != x) x = par[x];
                    while (par[y] != y) y = par[y];
                    par[x] = y;
                }
                if (count != 2 &&
                    !(open && count == 1 && (w->planes[v] & w->planes[nbr] & 0x3fu)))
                    ok = 0;
            }
        int roots = 0;
        for (size_t a = 0; a < k; a++) roots += par[a] == (int)a;
        if (!ok || roots != 1) bad[v] = 1;
    }
    for (size_t v = 0; v < w->np; v++) nbad += bad[v];
    if (nbad)
        for (size_t t = 0; t < w->nh; t++)
            for (int c = 0; c < 8; c++)
                if (bad[w->h[8 * t + (size_t)c]]) in[t] = 0;
    free(start);
    free(list);
    free(bad);
    return nbad;
}

/* Pillowing (Mitchell and Tautges 1995) of the shrink set: the hexes t with in[t], all when
 * in is NULL. Every point on the set's boundary (the sheet: its faces on the mesh boundary
 * and those it shares with hexes outside it) gets an inner copy, the set's hexes take the
 * copies, and one new hex joins each sheet face to its copy. With the whole mesh as the set,
 * every hex touching the boundary afterwards has exactly one face on it, and the boundary
 * itself (points, quads) is unchanged; with a smaller set, the sheet leaves the boundary and
 * goes round the hexes outside the set, which keep their points (the mesh stays conforming).
 * in is shrunk where its sheet would not be a manifold surface. With open set (w->planes
 * known), the faces on a box plane stay out of the sheet: it ends on the box along the rim,
 * the rim points' copies stay in their box plane, and the layer's hexes at the rim put a
 * strip of box quads between the rim and the old box quads (which take the copies), so that
 * the box face's own quad mesh gets a layer along its edge too; the boundary is otherwise
 * unchanged. */
static vm_status pillow(hx *w, uint8_t *in, int open, size_t *added, vm_error *err) {
    size_t *bf = NULL, nb = 0;
    vm_status s = VM_OK;
    for (int round = 0;; round++) {
        free(bf);
        bf = NULL;
        s = boundary_faces(w, in, &bf, &nb, err);
        if (s) return s;
        if (open) { /* the faces on one box plane stay out of the sheet */
            size_t kept = 0;
            for (size_t u = 0; u < nb; u++) {
                const vm_index *c = w->h + 8 * (bf[u] / 6);
                const int *fc = face_tab[bf[u] % 6];
                unsigned common = 0x3fu;
                for (int j = 0; j < 4; j++) common &= w->planes[c[fc[j]]];
                if (!(common & 0x3fu)) bf[kept++] = bf[u];
            }
            nb = kept;
        }
        if (!in || !sheet_defects(w, bf, nb, in, open)) break;
        if (round == 50) {
            free(bf);
            *added = 0;
            return VM_OK; /* no clean sheet: no layer */
        }
    }
    size_t np = w->np;
    cache_drop(w);
    vm_index *copy = malloc((np + 1) * sizeof *copy);
    double *ctr = calloc(3 * np + 1, sizeof *ctr);
    size_t *cnt = calloc(np + 1, sizeof *cnt);
    if (!copy || !ctr || !cnt) {
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        goto done;
    }
    for (size_t i = 0; i < np; i++) copy[i] = -1;
    size_t ncopy = 0;
    for (size_t u = 0; u < nb; u++)
        for (int j = 0; j < 4; j++) {
            size_t i = (size_t)w->h[8 * (bf[u] / 6) + (size_t)face_tab[bf[u] % 6][j]];
            if (copy[i] < 0) copy[i] = (vm_index)(np + ncopy++);
        }
    size_t nh = w->nh;
    double *p = realloc(w->p, 3 * (np + ncopy) * sizeof *p);
    if (p) w->p = p;
    double *p0 = realloc(w->p0, 3 * (np + ncopy) * sizeof *p0);
    if (p0) w->p0 = p0;
    vm_index *h = realloc(w->h, 8 * (nh + nb) * sizeof *h);
    if (h) w->h = h;
    int32_t *reg = realloc(w->region, (nh + nb) * sizeof *reg);
    if (reg) w->region = reg;
    if (!p || !p0 || !h || !reg) {
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for the pillow layer");
        goto done;
    }
    /* Each copy goes a third of the way from its point toward the mean centre of the hexes
     * around it: inside the material even where it is one cell thick, unlike a step along
     * the normal. */
    const double HEX_CORNER_WEIGHT = 0.125; /* 1/8: the centre is the mean of 8 corners */
    for (size_t t = 0; t < nh; t++) {
        if (in && !in[t]) continue;
        double c[3] = {0, 0, 0};
        for (int k = 0; k < 8; k++)
            for (int a = 0; a < 3; a++)
                c[a] += HEX_CORNER_WEIGHT * w->p[3 * (size_t)w->h[8 * t + k] + a];
        for (int k = 0; k < 8; k++) {
            size_t i = (size_t)w->h[8 * t + k];
            if (copy[i] < 0) continue;
            for (int a = 0; a < 3; a++) ctr[3 * i + a] += c[a];
            cnt[i]++;
        }
    }
    for (size_t i = 0; i < np; i++) {
        if (copy[i] < 0) continue;
        double *q = w->p + 3 * (size_t)copy[i];
        for (int a = 0; a < 3; a++)
            q[a] = w->p[3 * i + a] + (ctr[3 * i + a] / (double)cnt[i] - w->p[3 * i + a]) / 3.0;
        if (open && (w->planes[i] & 0x3fu)) {
            /* a rim point's copy stays in the point's box plane(s): the layer's side faces
             * there close the box face round the old box quads, which take the copies */
            double y[3], yq[3];
            to_index(w, w->p + 3 * i, y);
            to_index(w, q, yq);
            for (int a = 0; a < 3; a++)
                if (w->planes[i] & (3u << (2 * a))) yq[a] = y[a];
            to_world(w, yq, q);
        }
        memcpy(w->p0 + 3 * (size_t)copy[i], q, 3 * sizeof *q);
    }
    for (size_t u = 0; u < 8 * nh; u++)
        if (copy[w->h[u]] >= 0 && (!in || in[u / 8])) w->h[u] = copy[w->h[u]];
    for (size_t u = 0; u < nb; u++) {
        size_t t = bf[u] / 6;
        const int *fc = face_tab[bf[u] % 6];
        vm_index *c = w->h + 8 * t, *n = w->h + 8 * (nh + u);
        /* The quad's right-hand normal points out, from the copies (bottom) to the boundary
         * (top): the VTK order of a positive hex. c now holds the copies. */
        for (int j = 0; j < 4; j++) n[j] = c[fc[j]];
        w->region[nh + u] = w->region[t];
    }
    /* Original point of each copy, to fill the top quads. */
    vm_index *orig = malloc((ncopy + 1) * sizeof *orig);
    if (!orig) {
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        goto done;
    }
    for (size_t i = 0; i < np; i++)
        if (copy[i] >= 0) orig[(size_t)copy[i] - np] = (vm_index)i;
    for (size_t u = 0; u < nb; u++) {
        vm_index *n = w->h + 8 * (nh + u);
        for (int j = 0; j < 4; j++) n[4 + j] = orig[(size_t)n[j] - np];
    }
    free(orig);
    w->np = np + ncopy;
    w->nh = nh + nb;
    *added = nb;
done:
    free(bf);
    free(copy);
    free(ctr);
    free(cnt);
    return s;
}

/* ---- vertex moves ---- */

/* Mean length of the edges at point i. */
static double edge_scale(const hx *w, size_t i) {
    double sum = 0.0;
    size_t n = 0;
    for (size_t u = w->vs[i]; u < w->vs[i + 1]; u++) {
        size_t t = w->vi[u] / 8;
        int k = (int)(w->vi[u] % 8);
        for (int j = 1; j < 4; j++) {
            const double *q = w->p + 3 * (size_t)w->h[8 * t + (size_t)corner_tab[k][j]];
            double d2 = 0.0;
            for (int a = 0; a < 3; a++) d2 += (q[a] - w->p[3 * i + a]) * (q[a] - w->p[3 * i + a]);
            sum += sqrt(d2);
            n++;
        }
    }
    return n ? sum / (double)n : 0.0;
}

/* Untangling without the layer (1): a higher worst determinant, the worst scaled Jacobian
 * kept above floor (or where it was). Untangling the pillowed mesh (2): a lower penalty, or
 * the same and a higher worst scaled Jacobian (the max-min determinant stalls there just
 * below zero: several points share the worst corner). Smoothing (0): a higher worst scaled
 * Jacobian, or the same and a higher sum. */
static int better(const lq *n, const lq *o, double floor, int untangle) {
    if (untangle == 1)
        return n->det > o->det + DET_REL_MARGIN * fabs(o->det) && n->min >= fmin(o->min, floor);
    if (untangle == 2)
        return n->pen < o->pen - PEN_MARGIN ||
               (n->pen <= o->pen && n->min > o->min + SJ_MARGIN);
    return n->min > o->min + SJ_MARGIN || (n->min >= o->min && n->sum > o->sum + SUM_MARGIN);
}

/* Compass search from point i's position for better figures around it; a surface point is
 * first put back on its constraint when that costs at most down to floor. Returns 1 when it
 * moved. */
static int optimise(hx *w, size_t i, double floor, int untangle) {
    if (w->cls[i] == CLS_FIXED || w->vs[i] == w->vs[i + 1]) return 0;
    star S;
    if (!star_load(w, i, &S)) return 0;
    double x[3];
    int pen = untangle == 2;
    lq cur;
    size_t first = 0;
    memcpy(x, w->p + 3 * i, sizeof x);
    local_q(&S, x, pen, &cur, &no_stop, 0, &first);
    int moved = 0, d0 = 0; /* the directions are tried from the last one taken */
    double L = edge_scale(w, i);
    int mode = untangle == 3 ? 0 : untangle;
    for (double h = STEP_FIRST * L; h > STEP_LAST * L; h *= 0.5) {
        for (int rep = 0; rep < 4; rep++) {
            int best = -1;
            double bx[3];
            lq bq = cur;
            size_t bfirst = first;
            int slide = untangle == 3 && w->cls[i] == CLS_ISO;
            int nd = untangle >= 2 ? 26 : 14;
            for (int dd = 0; dd < nd; dd++)
                for (int v = 0, d = (dd + d0) % nd; v <= slide; v++) {
                    double y[3];
                    lq n;
                    for (int a = 0; a < 3; a++) y[a] = x[a] + h * dirs[d][a];
                    int cmode = untangle == 1 || untangle == 2 ? MOVE_LOOSE
                                : v                            ? MOVE_PROJECT
                                                               : MOVE_TANGENT;
                    if (!constrain(w, i, y, cmode)) continue;
                    /* what bq rules out (better() below, mode by mode) */
                    lq_stop stop = no_stop;
                    if (mode == 0) stop.min_below = bq.min;
                    if (mode == 1) {
                        stop.min_below = fmin(bq.min, floor);
                        stop.det_at = bq.det + DET_REL_MARGIN * fabs(bq.det);
                    }
                    if (mode == 2) stop.pen_above = bq.pen;
                    size_t wf = first;
                    if (!local_q(&S, y, pen, &n, &stop, first, &wf)) continue;
                    /* the quads' bound only for a candidate that would be kept: the same
                     * choice as bounding every candidate, at a fraction of the cost */
                    if (better(&n, &bq, floor, mode) && quads_ok(w, i, y, cmode)) {
                        best = d;
                        bq = n;
                        bfirst = wf;
                        memcpy(bx, y, sizeof bx);
                    }
                }
            if (best < 0) break;
            d0 = best;
            memcpy(x, bx, sizeof x);
            cur = bq;
            first = bfirst;
            moved = 1;
        }
    }
    if (moved) memcpy(w->p + 3 * i, x, sizeof x);
    star_free(&S);
    return moved;
}

/* ---- sweeps on threads, with the sequential sweep's result ---- */

/* A move of point i (optimise, patch_move) reads and writes only the points of the hexes
 * round i. A Gauss-Seidel sweep over a list of points therefore splits into levels: a
 * point's level is one more than the highest level of the points sharing a hex with it
 * that come before it in the list. Points of one level share no hex, so they move on
 * threads in any order, and level by level every point sees exactly the moves it would
 * see in the list's order: the same positions, bytes and counts for any thread count. */
typedef int (*point_move_fn)(hx *w, size_t i, void *user);

/* Levels with fewer points than this run on the calling thread: a level costs a barrier
 * (the big sweeps have 50 to 100 points a level, the late ones a handful), and on a busy
 * machine every barrier waits for a descheduled thread. */
#define LEVEL_THREADS_FROM 32

/* Runs fn on the points seq[0..n) (each at most once) as the sweep in that order would;
 * returns how many calls returned 1. Without memory for the levels it runs in order. */
static size_t sweep_points(hx *w, const size_t *seq, size_t n, point_move_fn fn, void *user) {
    size_t mv = 0;
    size_t *pos = malloc((w->np + 1) * sizeof *pos), *lev = malloc((n + 1) * sizeof *lev);
    size_t *start = NULL, *order = malloc((n + 1) * sizeof *order);
    size_t nlev = 0;
    if (pos && lev && order) {
        for (size_t i = 0; i < w->np; i++) pos[i] = SIZE_MAX;
        for (size_t k = 0; k < n; k++) pos[seq[k]] = k;
        for (size_t k = 0; k < n; k++) {
            size_t i = seq[k], l = 0;
            for (size_t u = w->vs[i]; u < w->vs[i + 1]; u++) {
                const vm_index *c = w->h + 8 * (w->vi[u] / 8);
                for (int j = 0; j < 8; j++) {
                    size_t pj = pos[c[j]];
                    if (pj < k && lev[pj] + 1 > l) l = lev[pj] + 1;
                }
            }
            lev[k] = l;
            if (l + 1 > nlev) nlev = l + 1;
        }
        start = calloc(nlev + 2, sizeof *start);
    }
    if (!start) {
        for (size_t k = 0; k < n; k++) mv += (size_t)(fn(w, seq[k], user) != 0);
        free(pos);
        free(lev);
        free(order);
        return mv;
    }
    for (size_t k = 0; k < n; k++) start[lev[k] + 2]++;
    for (size_t l = 0; l < nlev; l++) start[l + 2] += start[l + 1];
    for (size_t k = 0; k < n; k++) order[start[lev[k] + 1]++] = seq[k];
    for (size_t l = 0; l < nlev; l++) {
        ptrdiff_t a = (ptrdiff_t)start[l], b = (ptrdiff_t)start[l + 1];
        size_t lm = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 2) reduction(+ : lm) if (b - a >= LEVEL_THREADS_FROM)
#endif
        for (ptrdiff_t k = a; k < b; k++) lm += (size_t)(fn(w, order[k], user) != 0);
        mv += lm;
    }
    free(pos);
    free(lev);
    free(order);
    free(start);
    return mv;
}

/* The points i with flag[i] (and, when `not` is given, not not[i]) appended to seq in
 * ascending order. Returns the new length. */
static size_t list_points(const hx *w, const uint8_t *flag, const uint8_t *not, size_t *seq,
                          size_t n) {
    for (size_t i = 0; i < w->np; i++)
        if (flag[i] && (!not || !not[i])) seq[n++] = i;
    return n;
}

typedef struct figs {
    double min_sj, volume;
    size_t inverted, below;
} figs;

/* Brings the cache up to date: only the hexes with a point that moved since the last call
 * are measured again (a sweep moves a few thousand of the points). 0 when out of memory. */
static int cache_update(hx *w) {
    if (!w->qc) {
        w->qc = malloc((w->nh + 1) * sizeof *w->qc);
        w->pc = malloc((3 * w->np + 1) * sizeof *w->pc);
        w->chg = malloc(w->np + 1);
        if (!w->qc || !w->pc || !w->chg) {
            cache_drop(w);
            return 0;
        }
        for (size_t t = 0; t < w->nh; t++) w->qc[t] = hex_q(w, t);
        memcpy(w->pc, w->p, 3 * w->np * sizeof *w->pc);
        return 1;
    }
    int any = 0;
    for (size_t i = 0; i < w->np; i++) {
        w->chg[i] = memcmp(w->p + 3 * i, w->pc + 3 * i, 3 * sizeof *w->p) != 0;
        any |= w->chg[i];
    }
    if (!any) return 1;
    for (size_t t = 0; t < w->nh; t++) {
        const vm_index *c = w->h + 8 * t;
        if (w->chg[c[0]] | w->chg[c[1]] | w->chg[c[2]] | w->chg[c[3]] | w->chg[c[4]] |
            w->chg[c[5]] | w->chg[c[6]] | w->chg[c[7]])
            w->qc[t] = hex_q(w, t);
    }
    memcpy(w->pc, w->p, 3 * w->np * sizeof *w->pc);
    return 1;
}

/* The mesh's figures ([out] q[t], NULL allowed: each hex's scaled Jacobian); the volume
 * (a sum over every hex) only when vol. */
static void measure(hx *w, figs *f, double *q, int vol) {
    f->min_sj = 1.0;
    f->volume = 0.0;
    f->inverted = f->below = 0;
    int cached = cache_update(w);
    for (size_t t = 0; t < w->nh; t++) {
        double s = cached ? w->qc[t] : hex_q(w, t);
        if (q) q[t] = s;
        if (s < f->min_sj) f->min_sj = s;
        if (s <= 0.0) f->inverted++;
        if (s < SJ_BAR) f->below++;
    }
    for (size_t t = 0; t < w->nh && vol; t++) {
        double p[8][3];
        hex_points(w, t, p);
        f->volume += vm_hex_volume((const double(*)[3])p);
    }
}

/* A sweep's moves may lower the worst hex round a point down to this share of the target
 * (or the worst hex of the mesh, if higher). */
#define FLOOR_SHARE 0.5

/* Rounds of compass moves over the points of hexes below target, until the worst hex and
 * the count below target stop improving. Surface points are put back on the surface first
 * (at a cost down to floor at most). */
typedef struct smooth_job {
    uint8_t *dirty; /* something round the point moved since it last failed to move */
    double floor;
    int untangle;
} smooth_job;

/* sweep_stage's move of point i: optimise, when something round it moved since it last
 * failed to; a move flags the points of its hexes (its level's other points share none of
 * them with it, but may flag the same points: the writes are atomic). */
static int smooth_one(hx *w, size_t i, void *user) {
    smooth_job *J = user;
    if (!J->dirty[i]) return 0;
    J->dirty[i] = 0;
    if (!optimise(w, i, J->floor, J->untangle)) return 0;
    for (size_t u = w->vs[i]; u < w->vs[i + 1]; u++)
        for (int k = 0; k < 8; k++) {
            uint8_t *d = J->dirty + w->h[8 * (w->vi[u] / 8) + (size_t)k];
#ifdef VM_HAVE_OPENMP
#pragma omp atomic write
#endif
            *d = 1;
        }
    return 1;
}

static void sweep_stage(hx *w, double target, int untangle, int max_sweeps, int snap, double *q,
                        uint8_t *active, size_t *moves, int *sweeps) {
    size_t *seq = malloc((w->np + 1) * sizeof *seq);
    if (!seq) return; /* out of memory: no sweep (the mesh stays as it is, valid or not) */
    /* active[np + i]: something around point i moved since it last failed to move */
    uint8_t *dirty = active + w->np;
    memset(dirty, 1, w->np);
    double last = -INFINITY;
    size_t last_below = SIZE_MAX;
    int stale = 0;
    for (int sw = 0; sw < max_sweeps; sw++) {
        figs f;
        measure(w, &f, q, 0);
        size_t below = 0;
        memset(active, 0, w->np);
        for (size_t t = 0; t < w->nh; t++)
            if (q[t] < target) {
                below++;
                for (int k = 0; k < 8; k++) active[w->h[8 * t + k]] = 1;
            }
        if (w->focus)
            for (size_t i = 0; i < w->np; i++) active[i] &= w->focus[i];
        if (!below) break;
        if (f.min_sj > last + SWEEP_PROGRESS || below + below / 100 < last_below) {
            stale = 0;
        } else if (++stale >= 3) {
            break;
        }
        if (f.min_sj > last) last = f.min_sj;
        if (below < last_below) last_below = below;
        if (snap && sw == 0)
            for (size_t i = 0; i < w->np; i++)
                if ((w->cls[i] == CLS_ISO || w->cls[i] == CLS_PLANE) &&
                    (!w->focus || w->focus[i]))
                    active[i] = 1;
        smooth_job J = {dirty, fmax(f.min_sj, FLOOR_SHARE * target), untangle};
        size_t mv = 0, n = list_points(w, active, NULL, seq, 0);
        mv = sweep_points(w, seq, n, smooth_one, &J);
        *moves += mv;
        (*sweeps)++;
        if (w->progress) /* half way after 8 sweeps, 3/4 after 16, ... */
            w->progress("hex pass", 1.0 - pow(0.5, *sweeps / 8.0), 1.0, w->progress_user);
        if (!mv) break;
    }
    free(seq);
}

/* Stage 0 untangles (the points of inverted hexes: by the concave max-min determinant, or on
 * the pillowed mesh by the convex penalty, with more rounds and a second go after smoothing)
 * and smooths to 0.2; stage 1 raises the bar a step at a time from 0.3 to the target: moves
 * made for a high target too early lock poor hexes into worse local optima. */
static void smooth(hx *w, const vm_hex_improve_options *o, int stage, double *q,
                   uint8_t *active, size_t *moves, int *sweeps) {
    if (stage == 0) {
        if (!w->pillowed) {
            sweep_stage(w, UNTANGLE_TARGET, 1, o->max_sweeps, 0, q, active, moves, sweeps);
            sweep_stage(w, fmin(SJ_BAR, o->target), 0, o->max_sweeps, 1, q, active, moves,
                        sweeps);
            return;
        }
        sweep_stage(w, UNTANGLE_TARGET, 2, 5 * o->max_sweeps, 0, q, active, moves, sweeps);
        sweep_stage(w, fmin(SJ_BAR, o->target), 0, o->max_sweeps, 1, q, active, moves, sweeps);
        figs f;
        measure(w, &f, q, 0);
        if (f.inverted) { /* the smoothing can free what the penalty could not reach */
            sweep_stage(w, UNTANGLE_TARGET, 2, 5 * o->max_sweeps, 0, q, active, moves, sweeps);
            sweep_stage(w, fmin(SJ_BAR, o->target), 0, o->max_sweeps, 0, q, active, moves,
                        sweeps);
        }
        return;
    }
    /* (the 1e-9 keeps round-off in the sum from adding a step past the target) */
    for (double t = POLISH_TARGET; t < o->target + TARGET_STEP - 1e-9; t += TARGET_STEP)
        sweep_stage(w, fmin(t, o->target), 0, o->max_sweeps, 0, q, active, moves, sweeps);
}

/* (Re)loads the points and hexes of m. */
static vm_status load(hx *w, const vm_mesh *m, vm_error *err) {
    cache_drop(w);
    free(w->p);
    free(w->p0);
    free(w->h);
    free(w->region);
    w->np = m->npoints;
    w->nh = m->ncells;
    w->p = malloc(3 * w->np * sizeof *w->p);
    w->p0 = malloc(3 * w->np * sizeof *w->p0);
    w->h = malloc(8 * w->nh * sizeof *w->h);
    w->region = malloc(w->nh * sizeof *w->region);
    if (!w->p || !w->p0 || !w->h || !w->region)
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    memcpy(w->p, m->points, 3 * w->np * sizeof *w->p);
    memcpy(w->p0, m->points, 3 * w->np * sizeof *w->p0);
    memcpy(w->h, m->cells, 8 * w->nh * sizeof *w->h);
    for (size_t t = 0; t < w->nh; t++) w->region[t] = m->region ? m->region[t] : 0;
    return VM_OK;
}

/* snap_in tries the way to the isosurface in steps of this share of it, from the whole way
 * down. */
#define SNAP_STEP 0.25
/* After the untangling and the first smoothing, boundary points farther than SNAP_FROM from
 * the isosurface (voxels, the report's measure) are brought toward it, the hexes round them
 * kept at or above SNAP_FLOOR (or where they were); issue 34's bar for the boundary is half
 * a voxel, and the faces between the points bulge or sag a little more than their points. */
#define SNAP_FROM 0.3
#define SNAP_FLOOR SJ_BAR
/* The snap before the layer keeps every hex round the point above this. */
#define SNAP_RAW_FLOOR 1e-3

/* On a folded mesh's run (w->fit 0): brings surface points that are more than 0.45 voxel
 * off the isosurface the smallest part of the way to it that puts them within 0.45, where
 * the hexes around allow (their worst sample kept at or above floor, or where it was). */
static void final_snap(hx *w, double floor) {
    for (size_t i = 0; i < w->np; i++) {
        if (w->cls[i] != CLS_ISO) continue;
        double y[3], x[3];
        to_index(w, w->p + 3 * i, y);
        if (iso_distance(w, y) <= ISO_TANGENT_MAX) continue;
        memcpy(x, w->p + 3 * i, sizeof x);
        double target[3] = {x[0], x[1], x[2]};
        if (!constrain(w, i, target, MOVE_PROJECT)) continue;
        lq cur, n;
        star S;
        if (!star_load(w, i, &S)) continue;
        local_q(&S, x, 0, &cur, &no_stop, 0, NULL);
        for (double frac = SNAP_STEP; frac < 1.01; frac += SNAP_STEP) {
            double z[3], zi[3];
            for (int a = 0; a < 3; a++) z[a] = x[a] + frac * (target[a] - x[a]);
            to_index(w, z, zi);
            if (iso_distance(w, zi) > ISO_TANGENT_MAX) continue;
            local_q(&S, z, 0, &n, &no_stop, 0, NULL);
            if (n.min >= fmin(cur.min, floor)) memcpy(w->p + 3 * i, z, sizeof z);
            break;
        }
        star_free(&S);
    }
}

/* The worst scaled Jacobian of the hexes at the points pts[0..n). */
static double points_q(const hx *w, const size_t *pts, int n) {
    double mn = INFINITY;
    for (int j = 0; j < n; j++)
        for (size_t u = w->vs[pts[j]]; u < w->vs[pts[j] + 1]; u++) {
            double q = hex_q(w, w->vi[u] / 8);
            if (q < mn) mn = q;
        }
    return mn;
}

/* The most interior points snap_in carries along with a surface point. */
#define SNAP_CARRY 15

/* Brings each surface point farther than `from` off the isosurface (the mesher's relaxation
 * pulls the points of folded corners to their cell centres, up to a half-diagonal off: 0.6
 * voxel on the torus) the largest part of the way to it (a quarter at a time) that keeps the
 * worst hex round it at or above floor, or where it was: first alone, then with its interior
 * edge neighbours carried by the same step (under a pillow layer the point's copy sits a
 * tenth of a voxel inside it, and the point alone cannot cross it). The new position becomes
 * the point's start (p0, est0): tangent moves keep a point in its tangent plane through p0
 * and near its starting distance, which would take it back out. */
static void snap_in(hx *w, double from, double floor) {
    for (size_t i = 0; i < w->np; i++) {
        if (w->cls[i] != CLS_ISO || w->vs[i] == w->vs[i + 1]) continue;
        if (w->focus && !w->focus[i]) continue;
        double y[3], x[3];
        to_index(w, w->p + 3 * i, y);
        double d0 = iso_distance(w, y);
        if (d0 <= from) continue;
        memcpy(x, w->p + 3 * i, sizeof x);
        double target[3] = {x[0], x[1], x[2]};
        if (!constrain(w, i, target, MOVE_PROJECT)) continue;
        size_t pts[SNAP_CARRY + 1];
        int n = 1;
        pts[0] = i;
        for (size_t u = w->vs[i]; u < w->vs[i + 1]; u++) {
            size_t t = w->vi[u] / 8;
            int k = (int)(w->vi[u] % 8);
            for (int e = 1; e < 4; e++) {
                size_t j = (size_t)w->h[8 * t + (size_t)corner_tab[k][e]];
                int seen = w->cls[j] != CLS_FREE || (w->focus && !w->focus[j]);
                for (int a = 0; a < n && !seen; a++) seen = pts[a] == j;
                if (!seen && n <= SNAP_CARRY) pts[n++] = j;
            }
        }
        double old[SNAP_CARRY + 1][3];
        for (int a = 0; a < n; a++) memcpy(old[a], w->p + 3 * pts[a], sizeof old[a]);
        double keep = fmin(points_q(w, pts, 1), floor);
        int done = 0;
        for (int carry = 0; carry < 2 && !done && (carry == 0 || n > 1); carry++) {
            int m = carry ? n : 1;
            if (carry) keep = fmin(points_q(w, pts, n), floor);
            for (double frac = 1.0; frac > 0.5 * SNAP_STEP && !done; frac -= SNAP_STEP) {
                double zi[3], dz[3];
                for (int a = 0; a < 3; a++) dz[a] = frac * (target[a] - x[a]);
                for (int b = 0; b < m; b++)
                    for (int a = 0; a < 3; a++) w->p[3 * pts[b] + a] = old[b][a] + dz[a];
                to_index(w, w->p + 3 * i, zi);
                done = iso_distance(w, zi) < d0 && points_q(w, pts, m) >= keep;
                if (done) {
                    memcpy(w->p0 + 3 * i, w->p + 3 * i, 3 * sizeof *w->p0);
                    w->est0[i] = iso_estimate(w, zi);
                } else {
                    for (int b = 0; b < m; b++) memcpy(w->p + 3 * pts[b], old[b], sizeof old[b]);
                }
            }
        }
    }
}

/* Loads m, pillowed (shrink set in) or not (in NULL), and runs stage 0 of the smoothing.
 * [out] *q, *active (free them). */
static vm_status start(hx *w, const vm_mesh *m, const vm_hex_improve_options *o, uint8_t *in,
                       const double *init, double **q, uint8_t **active, size_t *added,
                       size_t *moves, int *sweeps, vm_error *err) {
    free(*q);
    free(*active);
    *q = NULL;
    *active = NULL;
    *added = 0;
    vm_status s = load(w, m, err);
    /* On a valid mesh, the far boundary points first go in before the layer, whose copies
     * would sit in their way, as far as no hex folds (a folded mesh, the heads', keeps
     * them: snapping there left the CT head at 0.38 instead of 0.45 and took twice as
     * long). */
    figs f0 = {0};
    if (!s && w->v) measure(w, &f0, NULL, 0);
    if (!s && init) memcpy(w->p, init, 3 * w->np * sizeof *w->p);
    w->fit = w->v && !f0.inverted;
    if (!s && w->fit) {
        s = build_incidence(w, err);
        if (!s) s = classify(w, err);
        if (!s) snap_in(w, ISO_TANGENT_MAX, SNAP_RAW_FLOOR);
    }
    size_t np0 = w->np, nh0 = w->nh;
    /* the whole layer on a valid mesh (classified: its box planes known) leaves the box
     * faces out: the layer then ends on the box, and a box face's quad at the rim gets a
     * layer quad beside it instead of a corner angle near 180 degrees (cut sphere 96^3 at
     * step 1.5, the rim point of one box quad only: 0.472) */
    if (!s && in) s = pillow(w, in, w->fit && !init, added, err);
    w->pillowed = *added > 0;
    free(w->focus);
    w->focus = NULL;
    if (!s && init && *added) {
        /* a selective run: only the layer, the set's hexes and three rings of points round
         * them move (the rest is at the local optimum the run without the layer found) */
        w->focus = calloc(w->np + 1, 1);
        if (!w->focus) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        for (size_t t = 0; t < w->nh; t++)
            if (t >= nh0 || in[t])
                for (int k = 0; k < 8; k++) w->focus[w->h[8 * t + (size_t)k]] = 1;
        for (size_t i = np0; i < w->np; i++) w->focus[i] = 1;
        for (int r = 0; r < 3; r++) {
            uint8_t *grow = calloc(w->np + 1, 1);
            if (!grow) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            for (size_t t = 0; t < w->nh; t++) {
                int hit = 0;
                for (int k = 0; k < 8; k++) hit |= w->focus[w->h[8 * t + (size_t)k]];
                if (hit)
                    for (int k = 0; k < 8; k++) grow[w->h[8 * t + (size_t)k]] = 1;
            }
            free(w->focus);
            w->focus = grow;
        }
    }
    if (!s) s = build_incidence(w, err);
    if (!s) s = classify(w, err);
    if (!s) s = iso_samples(w, err);
    if (s) return s;
    *q = malloc((w->nh + 1) * sizeof **q);
    *active = malloc(2 * w->np + 1);
    if (!*q || !*active) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    smooth(w, o, 0, *q, *active, moves, sweeps);
    return VM_OK;
}

/* Grows the hex set in by rings layers (the hexes sharing a point with it). [in,out] in:
 * one flag per hex; mark: room for one flag per point. */
static void dilate(const hx *w, uint8_t *in, int rings, uint8_t *mark) {
    for (int r = 0; r < rings; r++) {
        memset(mark, 0, w->np);
        for (size_t t = 0; t < w->nh; t++)
            if (in[t])
                for (int k = 0; k < 8; k++) mark[w->h[8 * t + (size_t)k]] = 1;
        for (size_t t = 0; t < w->nh; t++)
            for (int k = 0; k < 8 && !in[t]; k++)
                if (mark[w->h[8 * t + (size_t)k]]) in[t] = 1;
    }
}

static void hx_free(hx *w) {
    cache_drop(w);
    free(w->p);
    free(w->p0);
    free(w->h);
    free(w->region);
    free(w->vs);
    free(w->vi);
    free(w->cls);
    free(w->planes);
    free(w->nrm);
    free(w->est0);
    free(w->focus);
    free(w->bq);
    free(w->bqs);
    free(w->bqi);
    free(w->isp);
    w->isp = NULL;
    w->bq = NULL;
    w->bqs = w->bqi = NULL;
    w->nq = 0;
    w->nrm = w->est0 = NULL;
    w->focus = NULL;
    w->p = w->p0 = NULL;
    w->h = NULL;
    w->region = NULL;
    w->vs = w->vi = NULL;
    w->cls = w->planes = NULL;
}

/* Runs with more hexes than this below the bar are left to the selective layer unpolished
 * (the polish is meant for a few spots). */
#define POLISH_MAX 1000

/* Flags (in act, cleared first) the points of the hexes whose quality q is below bar. */
static void mark_below(const hx *w, const double *q, double bar, uint8_t *act) {
    memset(act, 0, w->np);
    for (size_t t = 0; t < w->nh; t++)
        if (q[t] < bar)
            for (int k = 0; k < 8; k++) act[w->h[8 * t + (size_t)k]] = 1;
}

/* Adds to `to` the points of every hex that has a point flagged in `from`. */
static void grow_points(const hx *w, const uint8_t *from, uint8_t *to) {
    for (size_t t = 0; t < w->nh; t++) {
        int hit = 0;
        for (int k = 0; k < 8; k++) hit |= from[w->h[8 * t + (size_t)k]];
        if (hit)
            for (int k = 0; k < 8; k++) to[w->h[8 * t + (size_t)k]] = 1;
    }
}

/* A last stage, on the few hexes still below target: their points and one ring round
 * them move by max-min compass search as in smoothing, except that boundary points may also
 * slide along the surface, a step being put back on the isosurface (within the allowed
 * distance of where the mesher put the point) instead of kept in its tangent plane: the
 * boundary quads of valence 3 to 6 points need their points moved further than the tangent
 * plane allows. Returns 0, or VM_ERR_NOMEM. */
typedef struct polish_job {
    double floor;
} polish_job;

static int polish_one(hx *w, size_t i, void *user) {
    return optimise(w, i, ((const polish_job *)user)->floor, 3);
}

static vm_status polish(hx *w, double target, size_t *moves, int *sweeps) {
    double *q = malloc((w->nh + 1) * sizeof *q);
    uint8_t *act = malloc(w->np + 1), *ring = malloc(w->np + 1);
    size_t *seq = malloc((w->np + 1) * sizeof *seq);
    if (!q || !act || !ring || !seq) {
        free(q);
        free(act);
        free(ring);
        free(seq);
        return VM_ERR_NOMEM;
    }
    double last = -INFINITY;
    for (int sw = 0; sw < 16; sw++) {
        figs f;
        measure(w, &f, q, 0);
        if (f.min_sj >= target || f.min_sj <= last + SWEEP_PROGRESS) break;
        last = f.min_sj;
        mark_below(w, q, target, act);
        memcpy(ring, act, w->np);
        grow_points(w, act, ring);
        /* the worst hexes' own points first, then the ring */
        size_t n = list_points(w, act, NULL, seq, 0);
        n = list_points(w, ring, act, seq, n);
        polish_job J = {f.min_sj};
        size_t mv = sweep_points(w, seq, n, polish_one, &J);
        *moves += mv;
        (*sweeps)++;
        if (!mv) break;
    }
    free(q);
    free(act);
    free(ring);
    free(seq);
    return VM_OK;
}

/* ---- repair of the last hexes below the bar ---- */

/* The repair works on the hexes below this, when there are at most POLISH_MAX of them. */
#define REPAIR_BAR POLISH_TARGET
/* Then the bar rises from REPAIR_BAR to the target by RAISE_STEP, while at most
 * RAISE_MAX_SHARE of the hexes are below it, the last bar taken up to RAISE_LAST_ROUNDS
 * times while the worst hex rises or a tenth of those below it come above. */
#define RAISE_STEP 0.05
#define RAISE_MAX_SHARE 0.25
#define RAISE_LAST_ROUNDS 4
/* The last bar is this much over the target: the energy then also lifts the hexes just
 * over the target round the last ones below it, which frees their points. */
#define RAISE_OVERSHOOT 0.02
/* After the raise, at most this many hexes below the target get up to FINAL_GROUP_ROUNDS
 * rounds of group moves and the polish. */
#define FINAL_GROUP_MAX 64
#define FINAL_GROUP_ROUNDS 8

/* Corners around point i with i at x: [out] *mn the worst scaled Jacobian, and the energy
 * sum over them of (max(0, bar - sj))^2, which couples the moves of the points of a patch
 * where the max-min search stalls (several points share the worst corner). */
static double patch_energy(const star *S, const double x[3], double bar, double *mn,
                           double e_stop, double mn_stop) {
    double e = 0.0, dx[3] = {x[0] - S->x0[0], x[1] - S->x0[1], x[2] - S->x0[2]};
    *mn = INFINITY;
    for (size_t a = 0; a < S->n; a++) {
        const star_hex *H = &S->h[a];
        double n[VM_HEX_COLUMNS];
        uint32_t have = 0;
        for (int c = 0; c < VM_HEX_SAMPLES; c++) {
            double d, q = star_hex_sample(H, c, dx, n, &have, &d);
            if (q < *mn) *mn = q;
            if (q < bar) e += (bar - q) * (bar - q);
            /* the energy only grows and the minimum only falls from here */
            if (e >= e_stop || *mn < mn_stop) return e;
        }
    }
    return e;
}

/* Compass search on patch_energy for point i, its worst corner kept at or above floor (or
 * where it was). A boundary point may stay in its tangent plane, slide along the isosurface
 * (as in the polish) or go anywhere within 0.4 voxel of it (as in untangling): the valence 3
 * and 5 to 6 boundary points at the last hexes below 0.2 on avg152T1 need room off the
 * trilinear isosurface (measured: 0.186 on it or in the tangent plane, 0.300 with the room).
 * Returns 1 when it moved. */
static int patch_move(hx *w, size_t i, double bar, double floor) {
    if (w->cls[i] == CLS_FIXED || w->vs[i] == w->vs[i + 1]) return 0;
    star S;
    if (!star_load(w, i, &S)) return 0;
    double x[3], mn;
    memcpy(x, w->p + 3 * i, sizeof x);
    double e = patch_energy(&S, x, bar, &mn, INFINITY, -INFINITY);
    if (!(e > ENERGY_MARGIN)) { /* nothing round the point below the bar */
        star_free(&S);
        return 0;
    }
    double keep = fmin(mn, floor);
    int moved = 0;
    double L = edge_scale(w, i);
    for (double h = STEP_FIRST * L; h > STEP_LAST_FINE * L; h *= 0.5) {
        for (int rep = 0; rep < 4; rep++) {
            int best = -1;
            double bx[3], be = e;
            int slide = w->cls[i] == CLS_ISO;
            for (int d = 0; d < 26; d++)
                for (int v = 0; v <= 2 * slide; v++) {
                    double y[3], m2;
                    for (int a = 0; a < 3; a++) y[a] = x[a] + h * dirs[d][a];
                    int mode = v == 2 ? MOVE_LOOSE : v ? MOVE_PROJECT : MOVE_TANGENT;
                    if (!constrain(w, i, y, mode)) continue;
                    double ne = patch_energy(&S, y, bar, &m2, be - ENERGY_MARGIN, keep);
                    /* the quads' bound only for a candidate that would be kept (as in
                     * optimise) */
                    if (ne < be - ENERGY_MARGIN && m2 >= keep && quads_ok(w, i, y, mode)) {
                        best = d;
                        be = ne;
                        memcpy(bx, y, sizeof bx);
                    }
                }
            if (best < 0) break;
            memcpy(x, bx, sizeof x);
            e = be;
            moved = 1;
        }
    }
    if (moved) memcpy(w->p + 3 * i, x, sizeof x);
    star_free(&S);
    return moved;
}

/* The worst scaled Jacobian of the hexes at the points pts[0..n) (and their sum). */
static double group_q(const hx *w, const size_t *pts, int n, double *sum) {
    double mn = INFINITY;
    *sum = 0.0;
    for (int j = 0; j < n; j++)
        for (size_t u = w->vs[pts[j]]; u < w->vs[pts[j] + 1]; u++) {
            double q = hex_q(w, w->vi[u] / 8);
            *sum += q;
            if (q < mn) mn = q;
        }
    return mn;
}

/* Compass search moving the points pts[0..n) of one hex together (the same step for all,
 * each then put back on its own constraint, with patch_move's three modes), for a
 * higher worst hex round them: where the points of a patch share its worst corner, no move
 * of one point alone raises it. Returns 1 when they moved. */
static int group_move(hx *w, const size_t *pts, int n) {
    double old[8][3], sum;
    for (int j = 0; j < n; j++) {
        if (w->cls[pts[j]] == CLS_FIXED) return 0;
        memcpy(old[j], w->p + 3 * pts[j], sizeof old[j]);
    }
    double cur = group_q(w, pts, n, &sum), L = 0.0;
    for (int j = 0; j < n; j++) L += edge_scale(w, pts[j]) / n;
    int moved = 0;
    double base[8][3];
    for (int j = 0; j < n; j++) memcpy(base[j], old[j], sizeof base[j]);
    for (double h = GROUP_STEP_FIRST * L; h > STEP_LAST_FINE * L; h *= 0.5)
        for (int rep = 0; rep < 4; rep++) {
            int best = -1;
            double bq = cur, bs = sum, bp[8][3];
            for (int d = 0; d < 26; d++)
                for (int v = 0; v < 3; v++) {
                    int ok = 1, modes[8];
                    for (int j = 0; j < n && ok; j++) {
                        double y[3];
                        for (int a = 0; a < 3; a++) y[a] = base[j][a] + h * dirs[d][a];
                        int mode = w->cls[pts[j]] != CLS_ISO || !v ? MOVE_TANGENT
                                   : v == 2                         ? MOVE_LOOSE
                                                                    : MOVE_PROJECT;
                        ok = constrain(w, pts[j], y, mode);
                        if (ok) memcpy(w->p + 3 * pts[j], y, sizeof y);
                        modes[j] = mode;
                    }
                    double s2, q2 = ok ? group_q(w, pts, n, &s2) : -INFINITY;
                    ok = ok && (q2 > bq + SJ_MARGIN || (q2 >= bq && s2 > bs + SUM_MARGIN));
                    /* the quads' bound, with the whole group moved, for a candidate that
                     * would be kept: each point's move as from the others' new places */
                    for (int j = 0; j < n && ok; j++) {
                        double y[3];
                        memcpy(y, w->p + 3 * pts[j], sizeof y);
                        memcpy(w->p + 3 * pts[j], base[j], sizeof y);
                        ok = quads_ok(w, pts[j], y, modes[j]);
                        memcpy(w->p + 3 * pts[j], y, sizeof y);
                    }
                    if (ok) {
                        best = d;
                        bq = q2;
                        bs = s2;
                        for (int j = 0; j < n; j++) memcpy(bp[j], w->p + 3 * pts[j], sizeof bp[j]);
                    }
                    for (int j = 0; j < n; j++) memcpy(w->p + 3 * pts[j], base[j], sizeof base[j]);
                }
            if (best < 0) break;
            for (int j = 0; j < n; j++) {
                memcpy(base[j], bp[j], sizeof base[j]);
                memcpy(w->p + 3 * pts[j], bp[j], sizeof bp[j]);
            }
            cur = bq;
            sum = bs;
            moved = 1;
        }
    return moved;
}

/* Group moves on each hex below bar: its edges' point pairs, its faces' quads and the whole
 * hex. Returns the number of groups moved. */
static size_t group_sweep(hx *w, double bar) {
    static const int edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                     {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    size_t mv = 0;
    for (size_t t = 0; t < w->nh; t++) {
        if (hex_q(w, t) >= bar) continue;
        const vm_index *c = w->h + 8 * t;
        size_t pts[8];
        for (int e = 0; e < 12; e++) {
            pts[0] = (size_t)c[edges[e][0]];
            pts[1] = (size_t)c[edges[e][1]];
            mv += (size_t)group_move(w, pts, 2);
        }
        for (int f = 0; f < 6; f++) {
            for (int j = 0; j < 4; j++) pts[j] = (size_t)c[face_tab[f][j]];
            mv += (size_t)group_move(w, pts, 4);
        }
        for (int k = 0; k < 8; k++) pts[k] = (size_t)c[k];
        mv += (size_t)group_move(w, pts, 8);
    }
    return mv;
}

/* The hexes below bar and rings of hexes round them: their points get Gauss-Seidel sweeps
 * of patch_move (the mesh's worst hex never gets worse), then the max-min polish. */
typedef struct patch_job {
    double bar, floor;
} patch_job;

static int patch_one(hx *w, size_t i, void *user) {
    const patch_job *J = user;
    return patch_move(w, i, J->bar, J->floor);
}

static vm_status repair(hx *w, double bar, int rings, int nsweeps, size_t *moves, int *sweeps) {
    double *q = malloc((w->nh + 1) * sizeof *q);
    uint8_t *act = malloc(w->np + 1), *ring = malloc(w->np + 1);
    size_t *seq = malloc((w->np + 1) * sizeof *seq);
    if (!q || !act || !ring || !seq) {
        free(q);
        free(act);
        free(ring);
        free(seq);
        return VM_ERR_NOMEM;
    }
    for (int sw = 0; sw < nsweeps; sw++) {
        figs f;
        measure(w, &f, q, 0);
        mark_below(w, q, bar, act);
        for (int r = 0; r < rings; r++) {
            memcpy(ring, act, w->np);
            grow_points(w, ring, act);
        }
        patch_job J = {bar, f.min_sj};
        size_t mv = sweep_points(w, seq, list_points(w, act, NULL, seq, 0), patch_one, &J);
        *moves += mv;
        (*sweeps)++;
        if (!mv) break;
    }
    free(q);
    free(act);
    free(ring);
    free(seq);
    vm_status s = polish(w, bar, moves, sweeps);
    for (int r = 0; r < 4 && !s; r++) {
        size_t mv = group_sweep(w, SJ_BAR);
        *moves += mv;
        (*sweeps)++;
        if (!mv) break;
        s = polish(w, bar, moves, sweeps);
    }
    return s;
}

/* The whole pass on a copy of m, with or without the pillow layer. [out] f: its figures. */
static vm_status run(hx *w, const vm_mesh *m, const vm_hex_improve_options *o, int with_pillow,
                     const uint8_t *set, const double *init, size_t *added, size_t *moves,
                     int *sweeps, figs *f, vm_error *err) {
    double *q = NULL;
    uint8_t *active = NULL, *in = NULL;
    if (set) {
        in = malloc(m->ncells + 1);
        if (!in) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        memcpy(in, set, m->ncells);
    } else if (with_pillow) {
        in = malloc(m->ncells + 1);
        if (!in) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        memset(in, 1, m->ncells);
    }
    vm_status s = start(w, m, o, in, init, &q, &active, added, moves, sweeps, err);
    free(in);
    if (!s && *added) {
        /* a layer still tangled after untangling will not come right: stop here */
        measure(w, f, NULL, 1);
        if (f->inverted) {
            free(q);
            free(active);
            return VM_OK;
        }
    }
    if (!s) {
        if (w->fit) snap_in(w, SNAP_FROM, SNAP_FLOOR);
        smooth(w, o, 1, q, active, moves, sweeps);
        measure(w, f, NULL, 0);
        if (w->v && f->min_sj < fmin(SJ_BAR, o->target) && f->below <= POLISH_MAX) {
            free(w->focus); /* the polish reaches past a selective run's focus */
            w->focus = NULL;
            s = polish(w, fmin(POLISH_TARGET, o->target), moves, sweeps);
            if (s) s = vm_error_set(err, s, "improve: out of memory");
            measure(w, f, NULL, 0);
        }
        if (w->fit) snap_in(w, ISO_TANGENT_MAX, fmax(f->min_sj, SJ_BAR));
        else if (w->v) final_snap(w, fmax(f->min_sj, SJ_BAR));
        measure(w, f, NULL, 1);
    }
    free(q);
    free(active);
    return s;
}

/* The hex pass's arguments: a hex8 mesh with cells, nodes in range, sensible targets. */
static vm_status hex_check(const vm_mesh *m, const vm_volume *v,
                           const vm_hex_improve_options *o, vm_error *err) {
    if (m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "improve: hex improvement needs hex8, not %s",
                            vm_cell_kind_name(m->kind));
    if (o->pillow && (m->npoint_fields || m->ncell_fields))
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "improve: pillowing a hex mesh with fields is not supported");
    if (m->ncells == 0) return vm_error_set(err, VM_ERR_EMPTY, "improve: the mesh has no cells");
    if (v && !o->has_lo && !o->has_hi)
        return vm_error_set(err, VM_ERR_ARG, "improve: a volume needs lo or hi material bounds");
    if (!(o->target > 0.0) || !(o->max_surface_move >= 0.0))
        return vm_error_set(err, VM_ERR_ARG, "improve: target and bounds must be positive");
    return vm__check_nodes(m, VM_ERR_ARG, "improve", err);
}

/* What the hex pass carries from one phase to the next. */
typedef struct hex_pass {
    hx w;      /* the result kept so far */
    hx base;   /* w as set up, before a mesh is loaded: each rerun starts from it */
    figs before, after;
    size_t added, moves;
    int sweeps, undone;
} hex_pass;

/* w->G and w->aniso from w->A (see hx). */
static void metric_setup(hx *w) {
    double M[3][3], A[3][3];
    memcpy(A, w->A, sizeof A);
    double h2 = pow(fabs(det3(A)), 2.0 / 3.0);
    w->mscale = sqrt(h2);
    int unit = 1;
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++) {
            double dot = A[0][a] * A[0][c] + A[1][a] * A[1][c] + A[2][a] * A[2][c];
            M[a][c] = dot / h2;
            if (fabs(M[a][c] - (a == c ? 1.0 : 0.0)) > METRIC_UNIT_TOL) unit = 0;
        }
    memcpy(w->M, M, sizeof M);
    w->aniso = !unit && invert3(M, w->G);
}

/* Sets w up for the options and the volume's index frame (no mesh loaded yet). */
static vm_status hx_setup(hx *w, const vm_mesh *m, const vm_volume *v,
                          const vm_hex_improve_options *o, vm_error *err) {
    memset(w, 0, sizeof *w);
    w->np = m->npoints;
    w->nh = m->ncells;
    w->v = v;
    w->lo = o->lo;
    w->hi = o->hi;
    w->has_lo = o->has_lo;
    w->has_hi = o->has_hi;
    w->max_move = o->max_surface_move;
    w->progress = o->progress;
    w->progress_user = o->progress_user;
    if (v) {
        for (int a = 0; a < 3; a++) {
            w->org[a] = v->origin[a];
            for (int c = 0; c < 3; c++) w->A[a][c] = v->direction[a][c] * v->spacing[c];
        }
        if (!invert3(w->A, w->Ainv))
            return vm_error_set(err, VM_ERR_ARG, "improve: the volume's index frame is singular");
        metric_setup(w);
    }
    return VM_OK;
}

/* The first run, with the whole layer where it may help, and, when the layer stays tangled
 * or below the bar, a second run without it: the better mesh is kept. */
static vm_status first_runs(hex_pass *P, const vm_mesh *m, const vm_hex_improve_options *o,
                            vm_error *err) {
    measure(&P->w, &P->before, NULL, 1);
    /* A mesh the mesher could not make valid has folded boundaries (the heads), where the
     * whole layer was measured to tangle or smooth worse than none: it goes straight to the
     * run without it, then the selective layer below. */
    int whole = o->pillow && P->before.min_sj < o->target && P->before.inverted == 0;
    vm_status s = run(&P->w, m, o, whole, NULL, NULL, &P->added, &P->moves, &P->sweeps,
                      &P->after, err);
    if (s || !P->added || !(P->after.inverted || P->after.min_sj < fmin(SJ_BAR, o->target)))
        return s;
    /* Where the boundary folds (thin noisy features) some pillow corners have no valid
     * position, or the layer smooths worse than none: when it stays tangled or below the
     * bar, the pass runs again without the layer and keeps the better mesh. */
    hx w2 = P->base;
    figs f2;
    size_t added2 = 0;
    s = run(&w2, m, o, 0, NULL, NULL, &added2, &P->moves, &P->sweeps, &f2, err);
    if (!s && (f2.inverted < P->after.inverted ||
               (f2.inverted == P->after.inverted && f2.min_sj > P->after.min_sj))) {
        hx_free(&P->w);
        P->w = w2;
        P->after = f2;
        P->added = 0;
        P->undone = 1;
    } else {
        hx_free(&w2);
    }
    return s;
}

/* Grows the selective set round the hexes of w still below the bar (mark: scratch over the
 * points of plain, the mesh without the layer the set indexes). */
static void grow_set(const hx *w, const hx *plain, uint8_t *set, uint8_t *mark) {
    size_t np0 = plain->np, nh0 = plain->nh;
    memset(mark, 0, np0);
    for (size_t t = 0; t < w->nh; t++) {
        if (hex_q(w, t) >= SJ_BAR) continue;
        if (t < nh0) set[t] = 1;
        for (int k = 0; k < 8; k++)
            if ((size_t)w->h[8 * t + (size_t)k] < np0) mark[w->h[8 * t + (size_t)k]] = 1;
    }
    for (size_t t = 0; t < nh0; t++)
        for (int k = 0; k < 8 && !set[t]; k++)
            if (mark[plain->h[8 * t + (size_t)k]]) set[t] = 1;
    dilate(plain, set, 1, mark);
}

/* Selective pillowing starts the run again at most this many times. */
#define SELECTIVE_ROUNDS 3

/* Selective pillowing: only the spots still below the bar get the layer, from the positions
 * the pass without it reached; where the layer leaves hexes below the bar (at the sheet's
 * edge, or on its own hexes) the set grows round them and the run starts again from those
 * positions, up to three times. */
static vm_status selective_pillow(hex_pass *P, const vm_mesh *m,
                                  const vm_hex_improve_options *o, vm_error *err) {
    hx plain = P->w;
    size_t np0 = plain.np, nh0 = plain.nh;
    uint8_t *set = malloc(nh0 + 1), *mark = malloc(np0 + 1);
    if (!set || !mark) {
        free(set);
        free(mark);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t t = 0; t < nh0; t++) set[t] = hex_q(&plain, t) < SJ_BAR;
    dilate(&plain, set, 1, mark);
    int have = 0; /* P->w holds a selective result (else it is plain) */
    vm_status s = VM_OK;
    for (int round = 0; round < SELECTIVE_ROUNDS && !s; round++) {
        hx w3 = P->base;
        figs f3;
        size_t added3 = 0;
        s = run(&w3, m, o, 1, set, plain.p, &added3, &P->moves, &P->sweeps, &f3, err);
        int good = !s && added3 && !f3.inverted && f3.min_sj > P->after.min_sj;
        if (good) {
            if (have) hx_free(&P->w);
            P->w = w3;
            P->after = f3;
            P->added = added3;
            P->undone = 0;
            have = 1;
        } else {
            hx_free(&w3);
        }
        if (!good || P->after.min_sj >= fmin(SJ_BAR, o->target)) break;
        grow_set(&P->w, &plain, set, mark);
    }
    if (have) hx_free(&plain);
    free(set);
    free(mark);
    return s;
}

/* With a volume, on the kept result: the polish once more, then the patch repair of the last
 * hexes below REPAIR_BAR (coupled moves, then the polish), then the same repair with the bar
 * raised step by step to the target (CT head at iso 500: the worst hex 0.300 -> 0.45, the
 * hexes below 0.5 7 972 -> 21; ironProt 0.300 -> 0.494). */
static vm_status last_repairs(hex_pass *P, const vm_hex_improve_options *o, vm_error *err) {
    hx *w = &P->w;
    if (P->after.min_sj < fmin(SJ_BAR, o->target) && P->after.below <= POLISH_MAX) {
        /* the selective rounds' focus is gone */
        free(w->focus);
        w->focus = NULL;
        if (polish(w, fmin(POLISH_TARGET, o->target), &P->moves, &P->sweeps))
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        measure(w, &P->after, NULL, 0);
    }
    if (P->after.min_sj < fmin(REPAIR_BAR, o->target)) {
        size_t below = 0;
        for (size_t t = 0; t < w->nh; t++) below += hex_q(w, t) < REPAIR_BAR;
        free(w->focus);
        w->focus = NULL;
        if (below <= POLISH_MAX &&
            repair(w, fmin(REPAIR_BAR, o->target), 1, 10, &P->moves, &P->sweeps))
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        measure(w, &P->after, NULL, 0);
    }
    /* then the bar rises toward the target, a step at a time, the last bar again while it
     * gains (patch_move keeps the mesh's worst hex from getting worse) */
    int rounds = 0;
    size_t last_below = SIZE_MAX;
    double was = -INFINITY;
    double top = o->target + RAISE_OVERSHOOT;
    for (double bar = REPAIR_BAR + RAISE_STEP; P->after.min_sj < o->target;) {
        if (bar > top) bar = top;
        int last = bar >= top - 1e-9;
        if (P->after.min_sj >= bar) {
            if (last) break;
            bar += RAISE_STEP;
            continue;
        }
        size_t below = 0;
        for (size_t t = 0; t < w->nh; t++) below += hex_q(w, t) < bar;
        if ((double)below > RAISE_MAX_SHARE * (double)w->nh) break;
        if (last) {
            if (rounds++ >= RAISE_LAST_ROUNDS ||
                (P->after.min_sj <= was + SWEEP_PROGRESS && below + below / 10 >= last_below))
                break;
            was = P->after.min_sj;
            last_below = below;
        }
        free(w->focus);
        w->focus = NULL;
        if (repair(w, bar, 1, 10, &P->moves, &P->sweeps))
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        measure(w, &P->after, NULL, 0);
        if (!last) bar += RAISE_STEP;
    }
    /* the last few hexes below the target: their point groups move together (the repair
     * does that below SJ_BAR only), alternating with the polish to the target */
    for (int r = 0; r < FINAL_GROUP_ROUNDS && P->after.min_sj < o->target; r++) {
        size_t below = 0;
        for (size_t t = 0; t < w->nh; t++) below += hex_q(w, t) < o->target;
        if (below > FINAL_GROUP_MAX) break;
        size_t mv = group_sweep(w, o->target);
        P->moves += mv;
        P->sweeps++;
        if (!mv) break;
        if (polish(w, o->target, &P->moves, &P->sweeps))
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        measure(w, &P->after, NULL, 0);
    }
    return VM_OK;
}

/* The largest distances of isosurface points from the isosurface (voxels), now and where
 * the mesher put them. */
static void surface_distances(const hx *w, double *maxd, double *maxd0) {
    for (size_t i = 0; i < w->np; i++) {
        if (w->cls[i] != CLS_ISO) continue;
        double y[3];
        to_index(w, w->p + 3 * i, y);
        *maxd = fmax(*maxd, iso_distance(w, y));
        to_index(w, w->p0 + 3 * i, y);
        *maxd0 = fmax(*maxd0, iso_distance(w, y));
    }
}

/* Writes the kept result into m and, when r is given, the figures into r. */
static vm_status write_result(hex_pass *P, vm_mesh *m, vm_hex_improve_report *r,
                              vm_error *err) {
    const hx *w = &P->w;
    double maxd = 0.0, maxd0 = 0.0;
    if (w->v) surface_distances(w, &maxd, &maxd0);
    vm_status s = vm_mesh_reserve(m, w->np, w->nh, err);
    if (s) return s;
    memcpy(m->points, w->p, 3 * w->np * sizeof *w->p);
    memcpy(m->cells, w->h, 8 * w->nh * sizeof *w->h);
    memcpy(m->region, w->region, w->nh * sizeof *w->region);
    if (r)
        *r = (vm_hex_improve_report){.hexes_before = m->ncells,
                                     .points_before = m->npoints,
                                     .hexes_after = w->nh,
                                     .points_after = w->np,
                                     .pillow_hexes = P->added,
                                     .pillow_undone = P->undone,
                                     .min_sj_before = P->before.min_sj,
                                     .min_sj_after = P->after.min_sj,
                                     .inverted_before = P->before.inverted,
                                     .inverted_after = P->after.inverted,
                                     .below_02_before = P->before.below,
                                     .below_02_after = P->after.below,
                                     .volume_before = P->before.volume,
                                     .volume_after = P->after.volume,
                                     .max_surface_distance = maxd,
                                     .max_surface_distance_before = maxd0,
                                     .moves = P->moves,
                                     .sweeps = P->sweeps};
    m->npoints = w->np;
    m->ncells = w->nh;
    return VM_OK;
}

vm_status vm_mesh_improve_hexes(vm_mesh *m, const vm_volume *v, const vm_hex_improve_options *o,
                                vm_hex_improve_report *r, vm_error *err) {
    double t0 = vm__now();
    vm_hex_improve_options def;
    if (!o) {
        vm_hex_improve_options_default(&def);
        o = &def;
    }
    vm_status s = hex_check(m, v, o, err);
    if (s) return s;
    hex_pass P;
    memset(&P, 0, sizeof P);
    s = hx_setup(&P.w, m, v, o, err);
    P.base = P.w;
    if (!s) s = load(&P.w, m, err);
    if (!s) s = first_runs(&P, m, o, err);
    if (!s && o->pillow && !P.added && P.after.min_sj < fmin(SJ_BAR, o->target))
        s = selective_pillow(&P, m, o, err);
    if (!s && v) s = last_repairs(&P, o, err);
    if (!s && v) {
        /* last, the far boundary points in as far as no hex falls below the target, the
         * worst hex or where it is: neither the worst hex nor the count below the target
         * gets worse */
        free(P.w.focus);
        P.w.focus = NULL;
        snap_in(&P.w, SNAP_FROM, fmax(o->target, P.after.min_sj));
        measure(&P.w, &P.after, NULL, 1);
    }
    if (!s) s = write_result(&P, m, r, err);
    if (!s && r) r->seconds = vm__now() - t0;
    hx_free(&P.w);
    if (o->progress) o->progress("hex pass", 1.0, 1.0, o->progress_user);
    return s;
}
