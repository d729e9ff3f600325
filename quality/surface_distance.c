/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/surface_distance.c — two-sided (Hausdorff) distance between a mesh's boundary and
 * the isosurface of the volume's trilinear field. Point-triangle distance: C. Ericson,
 * "Real-Time Collision Detection" (2005), 5.1.5; foot points on an implicit surface:
 * E. Hartmann, "On the curvature of curves and surfaces defined by normalforms", CAGD 16
 * (1999), section 4 (tangent-plane projection, then Newton steps onto the surface). */
#include "../core/core.h"
#include "quality_internal.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Samples per parallel chunk: sums are made per chunk and added in chunk order, so the
 * means do not depend on the thread count. */
#define CHUNK 2048
/* Largest triangles (points) per BVH leaf. */
#define LEAF 4
/* A face vertex closer than this (index units) to a box plane lies on it: the mesher puts
 * border vertices exactly on the plane, so only round-off of the index-to-world map is left. */
#define ON_PLANE_TOL 1e-6
/* Foot-point iterations and Newton steps per projection (both converge in a few). */
#define FOOT_ITERS 12
#define NEWTON_ITERS 10

/* ---- the trilinear field in world coordinates --------------------------------------------- */

typedef struct field {
    const float *f;
    int64_t n[3];
    double o[3], A[3][3], Ai[3][3]; /* world = o + A u; u = Ai (world - o) */
    double lo, hi;
    int has_lo, has_hi;
    double tol;  /* Newton convergence (world units) */
    double ftol; /* foot-point convergence: a step this short ends it (world units) */
    double h;   /* largest spacing between mesh samples (world units) */
} field;

static int inside(const field *F, double v) {
    return (!F->has_lo || v >= F->lo) && (!F->has_hi || v <= F->hi);
}

static double level_value(const field *F, int level) {
    return level ? F->hi : F->lo;
}

/* The level crossed between an inside value and an outside one b (0: lo, 1: hi). */
static int crossing_level(const field *F, double b) {
    return F->has_lo && b < F->lo ? 0 : 1;
}

static void to_index(const field *F, const double x[3], double u[3]) {
    double d[3] = {x[0] - F->o[0], x[1] - F->o[1], x[2] - F->o[2]};
    for (int r = 0; r < 3; r++) u[r] = F->Ai[r][0] * d[0] + F->Ai[r][1] * d[1] + F->Ai[r][2] * d[2];
}

static void to_world(const field *F, const double u[3], double x[3]) {
    for (int r = 0; r < 3; r++)
        x[r] = F->o[r] + F->A[r][0] * u[0] + F->A[r][1] * u[1] + F->A[r][2] * u[2];
}

/* Value and world gradient of the trilinear field at world x; 0 when x is outside the box. */
static int eval(const field *F, const double x[3], double *val, double gw[3]) {
    double u[3], t[3];
    int64_t c[3];
    to_index(F, x, u);
    for (int a = 0; a < 3; a++) {
        if (!(u[a] >= -1e-9 && u[a] <= (double)(F->n[a] - 1) + 1e-9)) return 0;
        c[a] = (int64_t)u[a]; /* the floor, or 0 for u in [-1e-9, 0): clamped to 0 below */
        if (c[a] > F->n[a] - 2) c[a] = F->n[a] - 2;
        if (c[a] < 0) c[a] = 0;
        t[a] = u[a] - (double)c[a];
    }
    const float *p = F->f + c[0] + F->n[0] * (c[1] + F->n[1] * c[2]);
    int64_t sy = F->n[0], sz = F->n[0] * F->n[1];
    double v000 = p[0], v100 = p[1], v010 = p[sy], v110 = p[sy + 1];
    double v001 = p[sz], v101 = p[sz + 1], v011 = p[sz + sy], v111 = p[sz + sy + 1];
    /* bilinear along x at the four (y, z) edges, then y, then z */
    double e00 = v000 + t[0] * (v100 - v000), e10 = v010 + t[0] * (v110 - v010);
    double e01 = v001 + t[0] * (v101 - v001), e11 = v011 + t[0] * (v111 - v011);
    double f0 = e00 + t[1] * (e10 - e00), f1 = e01 + t[1] * (e11 - e01);
    *val = f0 + t[2] * (f1 - f0);
    double gu[3];
    double dx00 = v100 - v000, dx10 = v110 - v010, dx01 = v101 - v001, dx11 = v111 - v011;
    double dx0 = dx00 + t[1] * (dx10 - dx00), dx1 = dx01 + t[1] * (dx11 - dx01);
    gu[0] = dx0 + t[2] * (dx1 - dx0);
    gu[1] = (e10 - e00) + t[2] * ((e11 - e01) - (e10 - e00));
    gu[2] = f1 - f0;
    /* d/dx f(Ai (x - o)) = Ai^T grad_u */
    for (int r = 0; r < 3; r++)
        gw[r] = F->Ai[0][r] * gu[0] + F->Ai[1][r] * gu[1] + F->Ai[2][r] * gu[2];
    return 1;
}

/* Moves world point x into the volume's box (the nearest point of the box in index space),
 * where the isosurface ends: a foot point on its rim lies on a box plane. */
static void clamp_box(const field *F, double x[3]) {
    double u[3];
    int out = 0;
    to_index(F, x, u);
    for (int a = 0; a < 3; a++) {
        double top = (double)(F->n[a] - 1);
        if (u[a] < 0) {
            u[a] = 0;
            out = 1;
        } else if (u[a] > top) {
            u[a] = top;
            out = 1;
        }
    }
    if (out) to_world(F, u, x);
}

/* Newton steps from x onto f = level along the gradient. Returns 1 when converged (x then
 * lies on the isosurface within F->tol), with the world gradient there in g. */
static int newton(const field *F, int level, double x[3], double g[3]) {
    double L = level_value(F, level);
    for (int it = 0; it <= NEWTON_ITERS; it++) {
        double val;
        if (!eval(F, x, &val, g)) return 0;
        double gg = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
        if (!(gg > 0)) return 0;
        double r = val - L, step = r / gg;
        if (fabs(r) <= F->tol * sqrt(gg)) return 1;
        if (it == NEWTON_ITERS) break;
        for (int a = 0; a < 3; a++) x[a] -= step * g[a];
        clamp_box(F, x); /* along a box plane where the step leaves the box */
    }
    return 0;
}

/* Newton steps from x onto f = level within the box plane of unit world normal N (the
 * gradient's part along the plane), for foot points on the isosurface's rim. Returns 1
 * when converged, with the full world gradient at x in g. */
static int newton_on_plane(const field *F, int level, const double N[3], double x[3],
                           double g[3]) {
    double L = level_value(F, level);
    for (int it = 0; it <= NEWTON_ITERS; it++) {
        double val;
        if (!eval(F, x, &val, g)) return 0;
        double gN = g[0] * N[0] + g[1] * N[1] + g[2] * N[2];
        double gp[3] = {g[0] - gN * N[0], g[1] - gN * N[1], g[2] - gN * N[2]};
        double gg = gp[0] * gp[0] + gp[1] * gp[1] + gp[2] * gp[2];
        if (!(gg > 0)) return 0;
        double r = val - L;
        if (fabs(r) <= F->tol * sqrt(gg)) return 1;
        if (it == NEWTON_ITERS) break;
        for (int a = 0; a < 3; a++) x[a] -= r / gg * gp[a];
        clamp_box(F, x);
    }
    return 0;
}

static double dist2(const double a[3], const double b[3]) {
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
}

/* The smaller of best2 and the squared distance from p to the foot point on the crease
 * where the isosurface meets the plane (unit world normal N) through xs: a voxel face,
 * where the trilinear surface bends (its gradient jumps), or the box, where it ends. The
 * foot point condition there is a step along the crease's tangent, N x gradient (the same
 * from both sides), then Newton within the plane. */
static double crease_foot(const field *F, int level, const double p[3], const double xs[3],
                          const double N[3], double best2) {
    double x[3] = {xs[0], xs[1], xs[2]}, g[3];
    if (!newton_on_plane(F, level, N, x, g)) return best2;
    double b = fmin(best2, dist2(p, x));
    for (int it = 0; it < FOOT_ITERS; it++) {
        double t[3] = {N[1] * g[2] - N[2] * g[1], N[2] * g[0] - N[0] * g[2],
                       N[0] * g[1] - N[1] * g[0]};
        double tl2 = t[0] * t[0] + t[1] * t[1] + t[2] * t[2];
        if (!(tl2 > 0)) break;
        double dt = ((p[0] - x[0]) * t[0] + (p[1] - x[1]) * t[1] + (p[2] - x[2]) * t[2]) / tl2;
        double y[3];
        for (int a = 0; a < 3; a++) y[a] = x[a] + dt * t[a];
        clamp_box(F, y);
        if (!newton_on_plane(F, level, N, y, g)) break;
        double moved = dist2(x, y);
        b = fmin(b, dist2(p, y));
        memcpy(x, y, sizeof x);
        if (moved <= F->ftol * F->ftol) break;
    }
    return b;
}

/* For a foot-point step from x to y: the crease feet (crease_foot) on the voxel-face planes
 * the step meets first along each axis (the one x lies on included), best2 lowered to the
 * nearest. A foot point on a crease is no stationary point of the smooth iteration, which
 * steps across it; this catches it. */
static double crease_feet(const field *F, int level, const double p[3], const double x[3],
                          const double y[3], double best2) {
    double ux[3], uy[3], up[3];
    to_index(F, x, ux);
    to_index(F, y, uy);
    to_index(F, p, up);
    for (int a = 0; a < 3; a++) {
        double P;
        if (uy[a] > ux[a]) {
            P = ceil(ux[a] - 1e-9);
            if (P > uy[a]) continue;
        } else if (uy[a] < ux[a]) {
            P = floor(ux[a] + 1e-9);
            if (P < uy[a]) continue;
        } else {
            continue;
        }
        if (P < 0 || P > (double)(F->n[a] - 1)) continue;
        double len = sqrt(F->Ai[a][0] * F->Ai[a][0] + F->Ai[a][1] * F->Ai[a][1] +
                          F->Ai[a][2] * F->Ai[a][2]);
        double plane = (up[a] - P) / len; /* p's distance to the plane bounds the crease's */
        if (plane * plane >= best2) continue;
        double s = (P - ux[a]) / (uy[a] - ux[a]), xs[3], N[3];
        if (s < 0) s = 0;
        if (s > 1) s = 1;
        for (int k = 0; k < 3; k++) xs[k] = x[k] + s * (y[k] - x[k]);
        for (int k = 0; k < 3; k++) N[k] = F->Ai[a][k] / len; /* u_a = Ai[a] . (x - o) */
        best2 = crease_foot(F, level, p, xs, N, best2);
    }
    return best2;
}

/* Distance from p to the isosurface of `level`, starting on it at s (a surface sample):
 * the smallest |p - y| over the surface points y of a foot-point iteration, and with
 * creases != 0 over the crease feet its steps meet (crease_feet). *converged: 1 when the
 * iteration came to rest (a smooth foot point), 0 when it stopped or ran out of steps (it
 * keeps stepping across a crease). */
static double foot_point(const field *F, int level, const double p[3], const double s[3],
                         int creases, int *converged) {
    double x[3] = {s[0], s[1], s[2]}, best = dist2(p, s), g[3], val;
    *converged = 0;
    if (!eval(F, x, &val, g)) return sqrt(best);
    for (int it = 0; it < FOOT_ITERS; it++) {
        double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
        if (!(gn > 0)) break;
        double nrm[3] = {g[0] / gn, g[1] / gn, g[2] / gn};
        double d[3] = {p[0] - x[0], p[1] - x[1], p[2] - x[2]};
        double dn = d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2];
        double y[3];
        for (int a = 0; a < 3; a++) y[a] = x[a] + d[a] - dn * nrm[a];
        if (creases) best = crease_feet(F, level, p, x, y, best);
        clamp_box(F, y);
        /* newton leaves the gradient at y in g: the next step's normal */
        if (!newton(F, level, y, g)) break;
        double dy = dist2(p, y), moved = dist2(x, y);
        if (dy < best) best = dy;
        memcpy(x, y, sizeof x);
        if (moved <= F->ftol * F->ftol) {
            *converged = 1;
            break;
        }
    }
    return sqrt(best);
}

/* ---- a bounding-volume hierarchy over points or triangles ---------------------------------- */

typedef struct bnode {
    double lo[3], hi[3];
    size_t begin, end;   /* items order[begin..end) */
    size_t left, right;  /* children (0: a leaf; the root is node 0, never a child) */
} bnode;

typedef struct bvh {
    bnode *node;
    size_t nnodes;
    size_t *order; /* item ids in tree order */
} bvh;

typedef struct keyed {
    uint64_t key;
    size_t id;
} keyed;

static int cmp_keyed(const void *a, const void *b) {
    const keyed *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->id < y->id ? -1 : x->id > y->id;
}

/* The bits of v (21 of them) spread three apart. */
static uint64_t spread3(uint64_t v) {
    v &= 0x1fffff;
    v = (v | v << 32) & 0x1f00000000ffffULL;
    v = (v | v << 16) & 0x1f0000ff0000ffULL;
    v = (v | v << 8) & 0x100f00f00f00f00fULL;
    v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
    v = (v | v << 2) & 0x1249249249249249ULL;
    return v;
}

/* Bounding box of item `id`: a point (tri == NULL) or triangle tri[3 id..3 id+2]. */
static void item_box(const double *pts, const size_t *tri, size_t id, double lo[3],
                     double hi[3]) {
    if (!tri) {
        memcpy(lo, pts + 3 * id, 3 * sizeof(double));
        memcpy(hi, pts + 3 * id, 3 * sizeof(double));
        return;
    }
    for (int a = 0; a < 3; a++) lo[a] = hi[a] = pts[3 * tri[3 * id] + (size_t)a];
    for (int k = 1; k < 3; k++)
        for (int a = 0; a < 3; a++) {
            double c = pts[3 * tri[3 * id + (size_t)k] + (size_t)a];
            if (c < lo[a]) lo[a] = c;
            if (c > hi[a]) hi[a] = c;
        }
}

static size_t bvh_build_range(bvh *b, const double *pts, const size_t *tri, size_t begin,
                              size_t end) {
    size_t me = b->nnodes++;
    bnode *nd = &b->node[me];
    nd->begin = begin;
    nd->end = end;
    nd->left = nd->right = 0;
    if (end - begin <= LEAF) {
        item_box(pts, tri, b->order[begin], nd->lo, nd->hi);
        for (size_t i = begin + 1; i < end; i++) {
            double lo[3], hi[3];
            item_box(pts, tri, b->order[i], lo, hi);
            for (int a = 0; a < 3; a++) {
                if (lo[a] < nd->lo[a]) nd->lo[a] = lo[a];
                if (hi[a] > nd->hi[a]) nd->hi[a] = hi[a];
            }
        }
        return me;
    }
    size_t mid = begin + (end - begin) / 2;
    size_t l = bvh_build_range(b, pts, tri, begin, mid);
    size_t r = bvh_build_range(b, pts, tri, mid, end);
    nd = &b->node[me];
    nd->left = l;
    nd->right = r;
    for (int a = 0; a < 3; a++) {
        nd->lo[a] = fmin(b->node[l].lo[a], b->node[r].lo[a]);
        nd->hi[a] = fmax(b->node[l].hi[a], b->node[r].hi[a]);
    }
    return me;
}

/* Builds a hierarchy over n items (n >= 1) in Morton order of their box centres. */
static vm_status bvh_build(bvh *b, const double *pts, const size_t *tri, size_t n,
                           vm_error *err) {
    memset(b, 0, sizeof *b);
    keyed *k = malloc(n * sizeof *k);
    b->order = malloc(n * sizeof *b->order);
    b->node = malloc(2 * (n / LEAF + 1) * 2 * sizeof *b->node);
    if (!k || !b->order || !b->node) {
        free(k);
        return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    }
    double glo[3] = {INFINITY, INFINITY, INFINITY}, ghi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++) {
        double lo[3], hi[3];
        item_box(pts, tri, i, lo, hi);
        for (int a = 0; a < 3; a++) {
            double c = 0.5 * (lo[a] + hi[a]);
            if (c < glo[a]) glo[a] = c;
            if (c > ghi[a]) ghi[a] = c;
        }
    }
    const ptrdiff_t nn = (ptrdiff_t)n;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t ii = 0; ii < nn; ii++) {
        size_t i = (size_t)ii;
        double lo[3], hi[3];
        item_box(pts, tri, i, lo, hi);
        uint64_t key = 0;
        for (int a = 0; a < 3; a++) {
            double ext = ghi[a] - glo[a];
            double q = ext > 0 ? (0.5 * (lo[a] + hi[a]) - glo[a]) / ext : 0;
            uint64_t qi = (uint64_t)(q * 2097151.0);
            key |= spread3(qi) << a;
        }
        k[i].key = key;
        k[i].id = i;
    }
    qsort(k, n, sizeof *k, cmp_keyed);
    for (size_t i = 0; i < n; i++) b->order[i] = k[i].id;
    free(k);
    bvh_build_range(b, pts, tri, 0, n);
    return VM_OK;
}

static void bvh_free(bvh *b) {
    free(b->node);
    free(b->order);
    memset(b, 0, sizeof *b);
}

static double box_dist2(const bnode *nd, const double p[3]) {
    double s = 0;
    for (int a = 0; a < 3; a++) {
        double d = p[a] < nd->lo[a] ? nd->lo[a] - p[a] : p[a] > nd->hi[a] ? p[a] - nd->hi[a] : 0;
        s += d * d;
    }
    return s;
}

/* Squared distance from p to item id: a point (tri == NULL) or a triangle. */
static double item_dist2(const double *pts, const size_t *tri, size_t id, const double p[3]) {
    if (!tri) return dist2(p, pts + 3 * id);
    return vm__point_triangle_dist2(p, pts + 3 * tri[3 * id], pts + 3 * tri[3 * id + 1],
                                    pts + 3 * tri[3 * id + 2]);
}

/* Keeps the nearer of (d, id) and (*best, *bid); equal distances keep the lower id, so the
 * answer does not depend on the order items are visited in. */
static void keep_nearest(double d, size_t id, double *best, size_t *bid) {
    if (d < *best || (d == *best && id < *bid)) {
        *best = d;
        *bid = id;
    }
}

/* The nearest item to p, starting from the candidate (*best, *bid) (INFINITY and SIZE_MAX
 * for none): updates them to the squared distance and the lowest id of the nearest. */
static void bvh_nearest(const bvh *b, const double *pts, const size_t *tri, const double p[3],
                        double *best, size_t *bid) {
    size_t stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0) {
        const bnode *nd = &b->node[stack[--sp]];
        if (box_dist2(nd, p) > *best) continue;
        if (!nd->left) {
            for (size_t i = nd->begin; i < nd->end; i++)
                keep_nearest(item_dist2(pts, tri, b->order[i], p), b->order[i], best, bid);
            continue;
        }
        double dl = box_dist2(&b->node[nd->left], p), dr = box_dist2(&b->node[nd->right], p);
        /* the nearer child on top; the stack holds one sibling per level (depth < 64) */
        size_t first = dl <= dr ? nd->left : nd->right, second = dl <= dr ? nd->right : nd->left;
        if (fmax(dl, dr) <= *best) stack[sp++] = second;
        if (fmin(dl, dr) <= *best) stack[sp++] = first;
    }
}

/* ---- a uniform grid in index space: the fast path of both searches ------------------------ */

/* Rings searched in the grid before a query goes to the hierarchy (far points only). */
#define GRID_RINGS 3

typedef struct grid {
    double org[3];   /* index position of the corner of cell (0,0,0) */
    double cs;       /* cell size in index units */
    int64_t dim[3];
    uint32_t *start; /* per cell, its first entry in items; ncells + 1 */
    uint32_t *items;
    double rn[3];    /* |row a of Ai|: an index gap g along a is at least g / rn[a] in the world */
    double irn[3];   /* 1 / rn */
} grid;

/* The cells (inclusive ranges) that the index box lo..hi overlaps. */
static void grid_range(const grid *G, const double lo[3], const double hi[3], int64_t c0[3],
                       int64_t c1[3]) {
    for (int a = 0; a < 3; a++) {
        double l = floor((lo[a] - G->org[a]) / G->cs), h = floor((hi[a] - G->org[a]) / G->cs);
        c0[a] = l < 0 ? 0 : l > (double)(G->dim[a] - 1) ? G->dim[a] - 1 : (int64_t)l;
        c1[a] = h < 0 ? 0 : h > (double)(G->dim[a] - 1) ? G->dim[a] - 1 : (int64_t)h;
    }
}

/* Index-space box of item id. */
static void item_index_box(const field *F, const double *pts, const size_t *tri, size_t id,
                           double lo[3], double hi[3]) {
    int nv = tri ? 3 : 1;
    for (int q = 0; q < nv; q++) {
        double u[3];
        to_index(F, pts + 3 * (tri ? tri[3 * id + (size_t)q] : id), u);
        for (int a = 0; a < 3; a++) {
            if (q == 0 || u[a] < lo[a]) lo[a] = u[a];
            if (q == 0 || u[a] > hi[a]) hi[a] = u[a];
        }
    }
}

static void grid_free(grid *G) {
    free(G->start);
    free(G->items);
    memset(G, 0, sizeof *G);
}

static vm_status grid_build(grid *G, const field *F, const double *pts, const size_t *tri,
                            size_t n, vm_error *err) {
    memset(G, 0, sizeof *G);
    if (n >= UINT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "surface distance: %zu samples (over 2^32)", n);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n; i++) {
        double l[3], h[3];
        item_index_box(F, pts, tri, i, l, h);
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], l[a]);
            hi[a] = fmax(hi[a], h[a]);
        }
    }
    for (int a = 0; a < 3; a++)
        if (!isfinite(lo[a]) || !isfinite(hi[a]))
            return vm_error_set(err, VM_ERR_ARG, "surface distance: non-finite coordinates");
    for (int a = 0; a < 3; a++) {
        G->rn[a] = sqrt(F->Ai[a][0] * F->Ai[a][0] + F->Ai[a][1] * F->Ai[a][1] +
                        F->Ai[a][2] * F->Ai[a][2]);
        G->irn[a] = 1.0 / G->rn[a];
    }
    /* cells of 1 voxel, larger when that would make more cells than 4 per item + 2^20 */
    double cap = 4.0 * (double)n + 1048576.0, cs = 1.0;
    for (;;) {
        double cells = 1;
        for (int a = 0; a < 3; a++) cells *= floor((hi[a] - lo[a]) / cs) + 1;
        if (cells <= cap) break;
        cs *= 1.25;
    }
    G->cs = cs;
    size_t ncells = 1;
    for (int a = 0; a < 3; a++) {
        G->org[a] = lo[a];
        G->dim[a] = (int64_t)floor((hi[a] - lo[a]) / cs) + 1;
        ncells *= (size_t)G->dim[a];
    }
    G->start = calloc(ncells + 1, sizeof *G->start);
    if (!G->start) return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    size_t total = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < n; i++) {
            double l[3], h[3];
            int64_t c0[3], c1[3];
            item_index_box(F, pts, tri, i, l, h);
            grid_range(G, l, h, c0, c1);
            for (int64_t z = c0[2]; z <= c1[2]; z++)
                for (int64_t y = c0[1]; y <= c1[1]; y++)
                    for (int64_t x = c0[0]; x <= c1[0]; x++) {
                        size_t c = (size_t)(x + G->dim[0] * (y + G->dim[1] * z));
                        if (pass == 0) G->start[c + 1]++;
                        else G->items[G->start[c]++] = (uint32_t)i;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncells; c++) {
                if (G->start[c + 1] > UINT32_MAX - G->start[c]) {
                    grid_free(G);
                    return vm_error_set(err, VM_ERR_NOMEM,
                                        "surface distance: over 2^32 grid entries");
                }
                G->start[c + 1] += G->start[c];
            }
            total = G->start[ncells];
            G->items = malloc((total ? total : 1) * sizeof *G->items);
            if (!G->items) {
                free(G->start);
                G->start = NULL;
                return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
            }
        }
    }
    /* the fill advanced every start to the next cell's: shift back */
    for (size_t c = ncells; c > 0; c--) G->start[c] = G->start[c - 1];
    G->start[0] = 0;
    return VM_OK;
}

/* Lower bound of the squared world distance from index position u to the index box of
 * cells lo..hi (inclusive): the largest gap along one axis, scaled to the world. */
static double cells_lb2(const grid *G, const double u[3], const int64_t lo[3],
                        const int64_t hi[3]) {
    double lb = 0;
    for (int a = 0; a < 3; a++) {
        double b0 = G->org[a] + (double)lo[a] * G->cs, b1 = G->org[a] + (double)(hi[a] + 1) * G->cs;
        double gap = (u[a] < b0 ? b0 - u[a] : u[a] > b1 ? u[a] - b1 : 0) * G->irn[a];
        if (gap > lb) lb = gap;
    }
    return lb * lb;
}

/* Nearest item to world point p by rings of cells around it: updates (*best, *bid) as
 * bvh_nearest does. Returns 1 when the answer is final, 0 when `rings` rings did not settle
 * it (then the hierarchy goes on from the candidate); rings < 0: no limit. */
static int grid_nearest(const grid *G, const field *F, const double *pts, const size_t *tri,
                        const double p[3], int64_t rings, double *best, size_t *bid) {
    double u[3];
    int64_t c[3];
    to_index(F, p, u);
    for (int a = 0; a < 3; a++) {
        double f = floor((u[a] - G->org[a]) / G->cs);
        c[a] = f < 0 ? 0 : f > (double)(G->dim[a] - 1) ? G->dim[a] - 1 : (int64_t)f;
    }
    for (int64_t r = 0;; r++) {
        int64_t lo[3], hi[3];
        int beyond = 1;
        for (int a = 0; a < 3; a++) {
            lo[a] = c[a] - r;
            hi[a] = c[a] + r;
            if (lo[a] >= 0 || hi[a] < G->dim[a]) beyond = 0;
        }
        if (beyond && r > 0) return 1;
        /* every cell of this ring and beyond lies outside the block of the rings before */
        if (r > 0) {
            double ring = INFINITY;
            for (int a = 0; a < 3; a++) {
                double b0 = G->org[a] + (double)(c[a] - r + 1) * G->cs;
                double b1 = G->org[a] + (double)(c[a] + r) * G->cs;
                double gap = fmin(u[a] - b0 > 0 ? u[a] - b0 : 0, b1 - u[a] > 0 ? b1 - u[a] : 0);
                ring = fmin(ring, gap / G->rn[a]);
            }
            if (ring * ring > *best) return 1;
        }
        if (rings >= 0 && r > rings) return 0;
        for (int64_t z = lo[2] < 0 ? 0 : lo[2]; z <= hi[2] && z < G->dim[2]; z++)
            for (int64_t y = lo[1] < 0 ? 0 : lo[1]; y <= hi[1] && y < G->dim[1]; y++) {
                int shell = z == lo[2] || z == hi[2] || y == lo[1] || y == hi[1];
                int64_t step = shell || r == 0 ? 1 : 2 * r;
                for (int64_t x = lo[0]; x <= hi[0]; x += step) {
                    if (x < 0 || x >= G->dim[0]) continue;
                    const int64_t k[3] = {x, y, z};
                    if (cells_lb2(G, u, k, k) > *best) continue;
                    size_t cell = (size_t)(x + G->dim[0] * (y + G->dim[1] * z));
                    for (size_t e = G->start[cell]; e < G->start[cell + 1]; e++)
                        keep_nearest(item_dist2(pts, tri, G->items[e], p), G->items[e], best,
                                     bid);
                }
            }
    }
}

/* ---- accumulation over chunks of samples --------------------------------------------------- */

typedef struct acc {
    double max, sum;
    size_t count;
    double *pts; /* collected points above the limit */
    size_t npts, cap;
    int nomem;
    double at[3]; /* where max was first reached */
} acc;

static void acc_add(acc *c, double d, const double p[3], int collect, double limit) {
    if (d > c->max) {
        c->max = d;
        memcpy(c->at, p, sizeof c->at);
    }
    c->sum += d;
    c->count++;
    if (!collect || !(d > limit)) return;
    if (c->npts == c->cap) {
        size_t cap = c->cap ? 2 * c->cap : 64;
        double *np = realloc(c->pts, 3 * cap * sizeof(double));
        if (!np) {
            c->nomem = 1;
            return;
        }
        c->pts = np;
        c->cap = cap;
    }
    memcpy(c->pts + 3 * c->npts, p, 3 * sizeof(double));
    c->npts++;
}

/* The results of a side, merged in chunk order. */
typedef struct side_acc {
    double max, sum;
    size_t count;
    double *pts;
    size_t npts;
    double at[3]; /* where max was first reached (in chunk order) */
} side_acc;

static int merge_chunks(acc *c, size_t nchunks, side_acc *s) {
    int nomem = 0;
    size_t total = s->npts;
    for (size_t i = 0; i < nchunks; i++) {
        if (c[i].max > s->max) {
            s->max = c[i].max;
            memcpy(s->at, c[i].at, sizeof s->at);
        }
        s->sum += c[i].sum;
        s->count += c[i].count;
        total += c[i].npts;
        nomem |= c[i].nomem;
    }
    if (total > s->npts) {
        double *np = realloc(s->pts, 3 * total * sizeof(double));
        if (!np) nomem = 1;
        else {
            s->pts = np;
            for (size_t i = 0; i < nchunks; i++) {
                if (!c[i].npts) continue; /* its list is NULL */
                memcpy(s->pts + 3 * s->npts, c[i].pts, 3 * c[i].npts * sizeof(double));
                s->npts += c[i].npts;
            }
        }
    }
    for (size_t i = 0; i < nchunks; i++) free(c[i].pts);
    return nomem;
}

/* ---- isosurface samples ---------------------------------------------------------------------- */

typedef struct samples {
    double *p;      /* 3 per sample, world */
    uint8_t *level; /* 0: lo, 1: hi */
    size_t n, cap;
    int nomem;
} samples;

static void samples_add(samples *s, const field *F, const double u[3], int level) {
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 256;
        double *np = realloc(s->p, 3 * cap * sizeof(double));
        if (np) s->p = np;
        uint8_t *nl = realloc(s->level, cap);
        if (nl) s->level = nl;
        if (!np || !nl) {
            s->nomem = 1;
            return;
        }
        s->cap = cap;
    }
    to_world(F, u, s->p + 3 * s->n);
    s->level[s->n++] = (uint8_t)level;
}

/* The crossing between index points ua (value fa) and ub (value fb) when exactly one is in
 * the material. The field is linear along the segment (an axis-parallel line in a cell). */
static void segment_crossing(samples *s, const field *F, const double ua[3], double fa,
                             const double ub[3], double fb) {
    int ia = inside(F, fa), ib = inside(F, fb);
    if (ia == ib) return;
    int level = crossing_level(F, ia ? fb : fa);
    double L = level_value(F, level), t = fb != fa ? (L - fa) / (fb - fa) : 0.5;
    if (t < 0) t = 0;
    if (t > 1) t = 1;
    double u[3];
    for (int a = 0; a < 3; a++) u[a] = ua[a] + t * (ub[a] - ua[a]);
    samples_add(s, F, u, level);
}

/* The samples of point plane k: crossings on the voxel edges from its points along +x, +y,
 * +z; on the half-edges of the finer lattice in the faces whose lowest corner is on it
 * (from the face centre to its edges' midpoints); and in the cells whose lowest corner is on
 * it (from the cell centre to its face centres). */
static void sample_plane(const field *F, int64_t k, samples *s) {
    const int64_t nx = F->n[0], ny = F->n[1], nz = F->n[2];
    const int64_t st[3] = {1, nx, nx * ny};
    for (int64_t j = 0; j < ny; j++)
        for (int64_t i = 0; i < nx; i++) {
            const int64_t ijk[3] = {i, j, k};
            const float *p = F->f + i + nx * (j + ny * k);
            double u0[3] = {(double)i, (double)j, (double)k};
            double f0 = p[0];
            int in0 = inside(F, f0);
            /* voxel edges */
            for (int a = 0; a < 3; a++) {
                if (ijk[a] + 1 >= F->n[a]) continue;
                double f1 = p[st[a]];
                if (inside(F, f1) == in0) continue;
                double u1[3] = {u0[0], u0[1], u0[2]};
                u1[a] += 1;
                segment_crossing(s, F, u0, f0, u1, f1);
            }
            /* faces: normal axis a, spanned by b = a+1 and c = a+2 */
            for (int a = 0; a < 3; a++) {
                int b = (a + 1) % 3, c = (a + 2) % 3;
                if (ijk[b] + 1 >= F->n[b] || ijk[c] + 1 >= F->n[c]) continue;
                double v[4] = {f0, p[st[b]], p[st[b] + st[c]], p[st[c]]}; /* (0,0) (1,0) (1,1) (0,1) */
                int mixed = 0;
                for (int q = 1; q < 4; q++) mixed |= inside(F, v[q]) != in0;
                if (!mixed) continue;
                double fc = 0.25 * (v[0] + v[1] + v[2] + v[3]);
                double uc[3] = {u0[0], u0[1], u0[2]};
                uc[b] += 0.5;
                uc[c] += 0.5;
                static const double off[4][2] = {{0.5, 0}, {1, 0.5}, {0.5, 1}, {0, 0.5}};
                for (int q = 0; q < 4; q++) {
                    double fm = 0.5 * (v[q] + v[(q + 1) % 4]);
                    double um[3] = {u0[0], u0[1], u0[2]};
                    um[b] += off[q][0];
                    um[c] += off[q][1];
                    segment_crossing(s, F, uc, fc, um, fm);
                }
            }
            /* cell interior */
            if (i + 1 < nx && j + 1 < ny && k + 1 < nz) {
                double v[8];
                int mixed = 0;
                for (int q = 0; q < 8; q++) {
                    v[q] = p[(q & 1) * st[0] + ((q >> 1) & 1) * st[1] + (q >> 2) * st[2]];
                    mixed |= inside(F, v[q]) != in0;
                }
                if (!mixed) continue;
                double fc = 0;
                for (int q = 0; q < 8; q++) fc += v[q];
                fc *= 0.125;
                double uc[3] = {u0[0] + 0.5, u0[1] + 0.5, u0[2] + 0.5};
                for (int a = 0; a < 3; a++)
                    for (int side = 0; side < 2; side++) {
                        double ff = 0; /* face centre: mean of the 4 corners with bit a == side */
                        for (int q = 0; q < 8; q++)
                            if (((q >> a) & 1) == side) ff += v[q];
                        ff *= 0.25;
                        double uf[3] = {uc[0], uc[1], uc[2]};
                        uf[a] = u0[a] + side;
                        segment_crossing(s, F, uc, fc, uf, ff);
                    }
            }
        }
}

static vm_status sample_surface(const field *F, samples *out, vm_error *err) {
    const int64_t nz = F->n[2];
    samples *sl = calloc((size_t)nz, sizeof *sl);
    if (!sl) return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (int64_t k = 0; k < nz; k++) sample_plane(F, k, &sl[k]);
    size_t total = 0;
    int nomem = 0;
    for (int64_t k = 0; k < nz; k++) {
        total += sl[k].n;
        nomem |= sl[k].nomem;
    }
    memset(out, 0, sizeof *out);
    if (!nomem && total) {
        out->p = malloc(3 * total * sizeof(double));
        out->level = malloc(total);
        if (!out->p || !out->level) nomem = 1;
    }
    for (int64_t k = 0; k < nz; k++) {
        if (!nomem && sl[k].n) {
            memcpy(out->p + 3 * out->n, sl[k].p, 3 * sl[k].n * sizeof(double));
            memcpy(out->level + out->n, sl[k].level, sl[k].n);
            out->n += sl[k].n;
        }
        free(sl[k].p);
        free(sl[k].level);
    }
    free(sl);
    if (nomem) {
        free(out->p);
        free(out->level);
        memset(out, 0, sizeof *out);
        return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    }
    return VM_OK;
}

/* ---- the mesh's boundary triangles ------------------------------------------------------------ */

typedef struct tris {
    const double *pts; /* the surface's points (world) */
    size_t *t;         /* 3 point ids per triangle */
    size_t n;
    vm_mesh surf;      /* the boundary, when extracted from a volume mesh */
} tris;

/* 1 when the face's corners all lie on one of the box's planes. */
static int on_border(const field *F, const double *pts, const vm_index *c, int nc) {
    for (int a = 0; a < 3; a++)
        for (int sd = 0; sd < 2; sd++) {
            double plane = sd ? (double)(F->n[a] - 1) : 0.0;
            int all = 1;
            for (int q = 0; q < nc && all; q++) {
                double u[3];
                to_index(F, pts + 3 * (size_t)c[q], u);
                all = fabs(u[a] - plane) <= ON_PLANE_TOL * (1 + fabs(plane));
            }
            if (all) return 1;
        }
    return 0;
}

/* The boundary's triangles (quads split in two); skip_border leaves out the faces lying on a
 * box plane. */
static vm_status boundary_triangles(const vm_mesh *m, const field *F, int skip_border, tris *T,
                                    vm_error *err) {
    memset(T, 0, sizeof *T);
    const vm_mesh *s = m;
    if (m->kind == VM_TET4 || m->kind == VM_HEX8) {
        vm_status st = vm_mesh_boundary(m, &T->surf, err);
        if (st) return st;
        s = &T->surf;
    } else if (m->kind != VM_TRI3 && m->kind != VM_QUAD4) {
        return vm_error_set(err, VM_ERR_ARG, "surface distance: unknown cell kind %d",
                            (int)m->kind);
    } else {
        vm_status st = vm__check_nodes(m, VM_ERR_ARG, "surface distance", err);
        if (st) return st;
    }
    int nc = vm_cell_nodes(s->kind);
    size_t cap = s->ncells * (nc == 4 ? 2 : 1);
    T->t = malloc((cap ? cap : 1) * 3 * sizeof(size_t));
    if (!T->t) {
        vm_mesh_free(&T->surf);
        return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    }
    T->pts = s->points;
    for (size_t c = 0; c < s->ncells; c++) {
        const vm_index *cn = s->cells + (size_t)nc * c;
        if (skip_border && on_border(F, s->points, cn, nc)) continue;
        size_t *t = T->t + 3 * T->n;
        t[0] = (size_t)cn[0];
        t[1] = (size_t)cn[1];
        t[2] = (size_t)cn[2];
        T->n++;
        if (nc == 4) {
            t += 3;
            t[0] = (size_t)cn[0];
            t[1] = (size_t)cn[2];
            t[2] = (size_t)cn[3];
            T->n++;
        }
    }
    return VM_OK;
}

static void tris_free(tris *T) {
    free(T->t);
    vm_mesh_free(&T->surf);
    memset(T, 0, sizeof *T);
}

/* ---- mesh samples -------------------------------------------------------------------------------- */

typedef struct edge {
    size_t a, b;
} edge;

static int cmp_edge(const void *x, const void *y) {
    const edge *p = x, *q = y;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    return p->b < q->b ? -1 : p->b > q->b;
}

/* Subdivisions of a segment of length len so that pieces are at most h (at least 2). */
static size_t pieces(double len, double h) {
    double m = ceil(len / h);
    if (!(m >= 2)) return 2;
    if (m > 1e6) return 1000000;
    return (size_t)m;
}

/* A hierarchy built when the first far query needs it (most runs never do). */
typedef struct lazy_bvh {
    bvh b;
    const double *pts;
    const size_t *tri;
    size_t n;
    int ready;       /* 1 once built (or failed) */
    vm_status status;
} lazy_bvh;

/* The hierarchy, built on first use by one thread while the others wait; NULL when it
 * could not be built (out of memory: the caller then searches the grid without limit).
 * Only far queries come here, so the lock (which also makes the built tree visible to every
 * thread) costs little. */
static const bvh *lazy_get(lazy_bvh *L) {
    vm_status st;
#ifdef VM_HAVE_OPENMP
#pragma omp critical(vm_surface_distance_bvh)
#endif
    {
        if (!L->ready) {
            L->status = bvh_build(&L->b, L->pts, L->tri, L->n, NULL);
            L->ready = 1;
        }
        st = L->status;
    }
    return st ? NULL : &L->b;
}

/* The nearest item to p: the grid, then (far points) the hierarchy. *bid holds a hint on
 * entry (an item likely near, such as the previous query's answer; SIZE_MAX for none): it
 * only prunes the search, the answer is the same without it. */
static double nearest(const grid *G, lazy_bvh *L, const field *F, const double p[3],
                      size_t *bid) {
    double b2 = *bid != SIZE_MAX ? item_dist2(L->pts, L->tri, *bid, p) : INFINITY;
    if (!grid_nearest(G, F, L->pts, L->tri, p, GRID_RINGS, &b2, bid)) {
        const bvh *b = lazy_get(L);
        if (b)
            bvh_nearest(b, L->pts, L->tri, p, &b2, bid);
        else
            grid_nearest(G, F, L->pts, L->tri, p, -1, &b2, bid);
    }
    return b2;
}

typedef struct ctx {
    const field *F;
    const samples *S;
    lazy_bvh *sb; /* over the surface samples */
    const grid *sg;
    const tris *T;
    lazy_bvh *tb; /* over the boundary triangles */
    const grid *tg;
    int collect;
    double limit;
    const vm__sd_region *region; /* NULL: everywhere */
    int sections;                /* measure against the box planes' sections too */
} ctx;

/* Whether world point p lies in the region measured. */
static int wanted(const ctx *x, const double p[3]) {
    const vm__sd_region *r = x->region;
    if (!r) return 1;
    double u[3];
    to_index(x->F, p, u);
    int64_t b[3];
    for (int a = 0; a < 3; a++) {
        double q = floor(u[a] / r->block);
        b[a] = q < 0 ? 0 : q >= (double)r->nb[a] ? r->nb[a] - 1 : (int64_t)q;
    }
    return r->mask[b[0] + r->nb[0] * (b[1] + r->nb[1] * b[2])];
}

/* Distance from world point p to the flat faces that close the material on the box: for
 * each box plane, to p's foot on it (in index space, inside the box) where the field there
 * is material; INFINITY when none is. The mesher closes material touching the border with
 * faces on those planes and keeps boundary faces near them within the distance bound, so a
 * boundary point is measured against the isosurface together with these faces. */
static double section_distance(const field *F, const double p[3]) {
    double u[3], best = INFINITY;
    to_index(F, p, u);
    for (int a = 0; a < 3; a++)
        for (int sd = 0; sd < 2; sd++) {
            double q[3], y[3], val, g[3];
            for (int b = 0; b < 3; b++) {
                double top = (double)(F->n[b] - 1);
                q[b] = u[b] < 0 ? 0 : u[b] > top ? top : u[b];
            }
            q[a] = sd ? (double)(F->n[a] - 1) : 0.0;
            to_world(F, q, y);
            if (eval(F, y, &val, g) && inside(F, val)) best = fmin(best, sqrt(dist2(p, y)));
        }
    return best;
}

/* Distance from mesh point p to the isosurface, or to the material's section of a box plane
 * where that is nearer (section_distance); *hint: the nearest sample of the previous point
 * (see nearest), updated. */
static double mesh_point_distance(const ctx *x, const double p[3], size_t *hint) {
    size_t id = *hint;
    double d0 = sqrt(nearest(x->sg, x->sb, x->F, p, &id));
    *hint = id;
    int level = x->S->level[id], c1, c2 = 1;
    const double *s = x->S->p + 3 * id;
    double d = foot_point(x->F, level, p, s, 0, &c1);
    /* A second start: p itself, taken onto the surface along the gradient. It finds the
     * foot point where the nearest sample leads to another local minimum (a fold or bump of
     * the trilinear surface between samples). */
    double y[3] = {p[0], p[1], p[2]}, g[3];
    clamp_box(x->F, y);
    int onto = newton(x->F, level, y, g);
    if (onto) d = fmin(d, foot_point(x->F, level, p, y, 0, &c2));
    /* A start that did not come to rest keeps stepping across a crease: again, searching
     * the creases (only then: that costs more). */
    if (!c1) d = fmin(d, foot_point(x->F, level, p, s, 1, &c1));
    if (onto && !c2) d = fmin(d, foot_point(x->F, level, p, y, 1, &c2));
    d = fmin(d, d0);
    return x->sections ? fmin(d, section_distance(x->F, p)) : d;
}

static vm_status measure_mesh(const ctx *x, side_acc *sd, vm_error *err) {
    const tris *T = x->T;
    const field *F = x->F;
    /* the boundary's vertices, once each */
    size_t np = 0;
    for (size_t i = 0; i < 3 * T->n; i++)
        if (T->t[i] + 1 > np) np = T->t[i] + 1;
    uint8_t *used = calloc(np ? np : 1, 1);
    edge *e = malloc((3 * T->n + 1) * sizeof *e);
    size_t *verts = malloc((np ? np : 1) * sizeof *verts);
    if (!used || !e || !verts) {
        free(used);
        free(e);
        free(verts);
        return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    }
    size_t nv = 0, ne = 0;
    for (size_t i = 0; i < 3 * T->n; i++) used[T->t[i]] = 1;
    for (size_t i = 0; i < np; i++)
        if (used[i]) verts[nv++] = i;
    free(used);
    for (size_t t = 0; t < T->n; t++)
        for (int q = 0; q < 3; q++) {
            size_t a = T->t[3 * t + (size_t)q], b = T->t[3 * t + (size_t)(q + 1) % 3];
            e[ne].a = a < b ? a : b;
            e[ne].b = a < b ? b : a;
            ne++;
        }
    qsort(e, ne, sizeof *e, cmp_edge);
    size_t nu = 0;
    for (size_t i = 0; i < ne; i++)
        if (nu == 0 || cmp_edge(&e[nu - 1], &e[i]) != 0) e[nu++] = e[i];
    ne = nu;
    /* three passes: vertices, edges, triangle interiors */
    size_t counts[3] = {nv, ne, T->n};
    int nomem = 0;
    for (int pass = 0; pass < 3 && !nomem; pass++) {
        size_t n = counts[pass], nchunks = (n + CHUNK - 1) / CHUNK;
        if (!n) continue;
        acc *c = calloc(nchunks, sizeof *c);
        if (!c) {
            nomem = 1;
            break;
        }
        const ptrdiff_t nck = (ptrdiff_t)nchunks;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (ptrdiff_t ci = 0; ci < nck; ci++) {
            acc *a = &c[ci];
            size_t i0 = (size_t)ci * CHUNK, i1 = i0 + CHUNK < n ? i0 + CHUNK : n;
            size_t hint = SIZE_MAX;
            for (size_t i = i0; i < i1; i++) {
                if (pass == 0) {
                    const double *p = T->pts + 3 * verts[i];
                    if (!wanted(x, p)) continue;
                    acc_add(a, mesh_point_distance(x, p, &hint), p, x->collect, x->limit);
                } else if (pass == 1) {
                    const double *pa = T->pts + 3 * e[i].a, *pb = T->pts + 3 * e[i].b;
                    size_t m = pieces(sqrt(dist2(pa, pb)), F->h);
                    for (size_t s = 1; s < m; s++) {
                        double t = (double)s / (double)m, p[3];
                        for (int k = 0; k < 3; k++) p[k] = pa[k] + t * (pb[k] - pa[k]);
                        if (!wanted(x, p)) continue;
                        acc_add(a, mesh_point_distance(x, p, &hint), p, x->collect, x->limit);
                    }
                } else {
                    const double *pa = T->pts + 3 * T->t[3 * i], *pb = T->pts + 3 * T->t[3 * i + 1],
                                 *pc = T->pts + 3 * T->t[3 * i + 2];
                    double len = fmax(dist2(pa, pb), fmax(dist2(pb, pc), dist2(pc, pa)));
                    size_t m = pieces(sqrt(len), F->h);
                    if (m < 3) m = 3; /* at least the centroid */
                    for (size_t s = 1; s + 1 < m; s++)
                        for (size_t r = 1; s + r < m; r++) {
                            double bs = (double)s / (double)m, br = (double)r / (double)m, p[3];
                            for (int k = 0; k < 3; k++)
                                p[k] = pa[k] + bs * (pb[k] - pa[k]) + br * (pc[k] - pa[k]);
                            if (!wanted(x, p)) continue;
                            acc_add(a, mesh_point_distance(x, p, &hint), p, x->collect, x->limit);
                        }
                }
            }
        }
        nomem |= merge_chunks(c, nchunks, sd);
        free(c);
    }
    free(e);
    free(verts);
    if (nomem) return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    return VM_OK;
}

static vm_status measure_surface(const ctx *x, side_acc *sd, vm_error *err) {
    size_t n = x->S->n, nchunks = (n + CHUNK - 1) / CHUNK;
    if (!n) return VM_OK;
    acc *c = calloc(nchunks, sizeof *c);
    if (!c) return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    const ptrdiff_t nck = (ptrdiff_t)nchunks;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (ptrdiff_t ci = 0; ci < nck; ci++) {
        size_t i0 = (size_t)ci * CHUNK, i1 = i0 + CHUNK < n ? i0 + CHUNK : n;
        size_t id = SIZE_MAX; /* the previous sample's triangle: a hint */
        for (size_t i = i0; i < i1; i++) {
            const double *p = x->S->p + 3 * i;
            if (!wanted(x, p)) continue;
            double d = sqrt(nearest(x->tg, x->tb, x->F, p, &id));
            acc_add(&c[ci], d, p, x->collect, x->limit);
        }
    }
    int nomem = merge_chunks(c, nchunks, sd);
    free(c);
    if (nomem) return vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
    return VM_OK;
}

/* ---- the entry points ----------------------------------------------------------------------- */

/* Inverse of a 3x3 matrix; 0 when singular. */
static int invert3(double A[3][3], double B[3][3]) {
    double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                 A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                 A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    if (!(fabs(det) > 0) || !isfinite(det)) return 0;
    B[0][0] = (A[1][1] * A[2][2] - A[1][2] * A[2][1]) / det;
    B[0][1] = (A[0][2] * A[2][1] - A[0][1] * A[2][2]) / det;
    B[0][2] = (A[0][1] * A[1][2] - A[0][2] * A[1][1]) / det;
    B[1][0] = (A[1][2] * A[2][0] - A[1][0] * A[2][2]) / det;
    B[1][1] = (A[0][0] * A[2][2] - A[0][2] * A[2][0]) / det;
    B[1][2] = (A[0][2] * A[1][0] - A[0][0] * A[1][2]) / det;
    B[2][0] = (A[1][0] * A[2][1] - A[1][1] * A[2][0]) / det;
    B[2][1] = (A[0][1] * A[2][0] - A[0][0] * A[2][1]) / det;
    B[2][2] = (A[0][0] * A[1][1] - A[0][1] * A[1][0]) / det;
    return 1;
}

static vm_status setup_field(const vm_volume *v, double lo, int has_lo, double hi, int has_hi,
                             field *F, vm_error *err) {
    memset(F, 0, sizeof *F);
    if (!has_lo && !has_hi)
        return vm_error_set(err, VM_ERR_ARG, "surface distance: no material bound given");
    if (has_lo && has_hi && lo > hi)
        return vm_error_set(err, VM_ERR_ARG,
                            "surface distance: empty range %g:%g (lower bound above upper)", lo,
                            hi);
    for (int a = 0; a < 3; a++)
        if (v->dims[a] < 2)
            return vm_error_set(err, VM_ERR_ARG,
                                "surface distance: the volume is %lld voxel(s) along axis %d; "
                                "need at least 2",
                                (long long)v->dims[a], a);
    size_t nonfinite = vm_volume_stats(v, NULL, NULL, NULL);
    if (nonfinite)
        return vm_error_set(err, VM_ERR_FORMAT,
                            "surface distance: the volume has %zu non-finite values", nonfinite);
    F->f = v->data;
    double smin = INFINITY;
    for (int a = 0; a < 3; a++) {
        F->n[a] = v->dims[a];
        F->o[a] = v->origin[a];
        if (v->spacing[a] < smin) smin = v->spacing[a];
        for (int r = 0; r < 3; r++) F->A[r][a] = v->direction[r][a] * v->spacing[a];
    }
    if (!invert3(F->A, F->Ai) || !(smin > 0))
        return vm_error_set(err, VM_ERR_ARG,
                            "surface distance: the volume's direction and spacing are singular");
    F->lo = lo;
    F->hi = hi;
    F->has_lo = has_lo;
    F->has_hi = has_hi;
    F->tol = 1e-9 * smin;
    /* the distance is stationary at the foot point: a foot 1e-4 off changes it by ~1e-8 */
    F->ftol = 1e-4 * smin;
    F->h = 0.5 * smin;
    return VM_OK;
}

vm_status vm__surface_distance_points(const vm_mesh *m, const vm_volume *v, double lo,
                                      int has_lo, double hi, int has_hi, double limit,
                                      vm_surface_distance *out, double **points,
                                      size_t *npoints, vm_error *err) {
    return vm__surface_distance_region(m, v, lo, has_lo, hi, has_hi, limit, 1, NULL, NULL, out,
                                       points, npoints, err);
}

void vm__sd_cache_free(vm__sd_cache *c) {
    free(c->p);
    free(c->level);
    memset(c, 0, sizeof *c);
}

vm_status vm__surface_distance_region(const vm_mesh *m, const vm_volume *v, double lo,
                                      int has_lo, double hi, int has_hi, double limit,
                                      int sections, const vm__sd_region *r, vm__sd_cache *cache,
                                      vm_surface_distance *out, double **points,
                                      size_t *npoints, vm_error *err) {
    memset(out, 0, sizeof *out);
    if (points) *points = NULL;
    if (npoints) *npoints = 0;
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_ARG, "surface distance: unknown cell kind %d",
                            (int)m->kind);
    field F;
    vm_status st = setup_field(v, lo, has_lo, hi, has_hi, &F, err);
    if (st) return st;
    tris T;
    st = boundary_triangles(m, &F, !sections, &T, err);
    if (st) return st;
    samples S;
    if (cache && cache->filled) {
        memset(&S, 0, sizeof S);
        S.p = cache->p;
        S.level = cache->level;
        S.n = cache->n;
    } else {
        st = sample_surface(&F, &S, err);
        if (st) {
            tris_free(&T);
            return st;
        }
        if (cache) *cache = (vm__sd_cache){S.p, S.level, S.n, 1};
    }
    lazy_bvh sb, tb;
    grid sg, tg;
    memset(&sb, 0, sizeof sb);
    memset(&tb, 0, sizeof tb);
    sb.pts = S.p;
    sb.n = S.n;
    tb.pts = T.pts;
    tb.tri = T.t;
    tb.n = T.n;
    memset(&sg, 0, sizeof sg);
    memset(&tg, 0, sizeof tg);
    side_acc ms = {0, 0, 0, NULL, 0, {NAN, NAN, NAN}}, ss = {0, 0, 0, NULL, 0, {NAN, NAN, NAN}};
    ctx x = {&F, &S, &sb, &sg, &T, &tb, &tg, points != NULL, limit, r, sections};
    if (T.n && S.n) {
        st = grid_build(&sg, &F, S.p, NULL, S.n, err);
        if (!st) st = grid_build(&tg, &F, T.pts, T.t, T.n, err);
        if (!st) st = measure_mesh(&x, &ms, err);
        if (!st) st = measure_surface(&x, &ss, err);
    }
    if (!st) {
        out->mesh_samples = ms.count;
        out->surface_samples = ss.count;
        out->mesh_to_surface_max = ms.max;
        out->mesh_to_surface_mean = ms.count ? ms.sum / (double)ms.count : 0;
        out->surface_to_mesh_max = ss.max;
        out->surface_to_mesh_mean = ss.count ? ss.sum / (double)ss.count : 0;
        if (T.n && !S.n) {
            out->mesh_to_surface_max = out->mesh_to_surface_mean = INFINITY;
        } else if (S.n && !T.n) {
            out->surface_samples = S.n;
            out->surface_to_mesh_max = out->surface_to_mesh_mean = INFINITY;
        }
        out->hausdorff = fmax(out->mesh_to_surface_max, out->surface_to_mesh_max);
        memcpy(out->mesh_to_surface_at, ms.at, sizeof ms.at);
        memcpy(out->surface_to_mesh_at, ss.at, sizeof ss.at);
        if (!(ms.max > 0 && isfinite(ms.max)))
            for (int a = 0; a < 3; a++)
                out->mesh_to_surface_at[a] = NAN;
        if (!(ss.max > 0 && isfinite(ss.max)))
            for (int a = 0; a < 3; a++)
                out->surface_to_mesh_at[a] = NAN;
        to_index(&F, out->mesh_to_surface_at, out->mesh_to_surface_ijk);
        to_index(&F, out->surface_to_mesh_at, out->surface_to_mesh_ijk);
        /* the edge of a cube of one voxel's volume; a cube voxel's own edge, exactly */
        out->voxel = cbrt(fabs(vm_volume_frame_determinant(v)));
        if (v->spacing[0] == v->spacing[1] && v->spacing[1] == v->spacing[2] &&
            fabs(out->voxel - v->spacing[0]) <= 1e-12 * v->spacing[0])
            out->voxel = v->spacing[0];
        if (points) {
            size_t n = ms.npts + ss.npts;
            if (n) {
                double *p = malloc(3 * n * sizeof(double));
                if (!p) {
                    st = vm_error_set(err, VM_ERR_NOMEM, "surface distance: out of memory");
                } else {
                    if (ms.npts) memcpy(p, ms.pts, 3 * ms.npts * sizeof(double));
                    if (ss.npts) memcpy(p + 3 * ms.npts, ss.pts, 3 * ss.npts * sizeof(double));
                    *points = p;
                    if (npoints) *npoints = n;
                }
            }
        }
    }
    free(ms.pts);
    free(ss.pts);
    bvh_free(&sb.b);
    bvh_free(&tb.b);
    grid_free(&sg);
    grid_free(&tg);
    if (!cache) {
        free(S.p);
        free(S.level);
    }
    tris_free(&T);
    if (st) memset(out, 0, sizeof *out);
    return st;
}

vm_status vm_mesh_surface_distance(const vm_mesh *m, const vm_volume *v, double lo, int has_lo,
                                   double hi, int has_hi, vm_surface_distance *out,
                                   vm_error *err) {
    return vm__surface_distance_points(m, v, lo, has_lo, hi, has_hi, 0, out, NULL, NULL, err);
}
