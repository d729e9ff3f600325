/* SPDX-License-Identifier: BSD-3-Clause */
/* core/self_intersect.c — intersecting triangle pairs of a surface: a uniform grid over
 * the bounding boxes as broad phase, then a triangle–triangle test built from orientation
 * predicates as in Guigue & Devillers, "Fast and robust triangle-triangle overlap test using
 * orientation predicates" (J. Graphics Tools 8(1), 2003): plane-side rejection first, then
 * edge-against-triangle tests (Plücker signs), and a 2-D test for coplanar pairs. */
#include "self_intersect.h"
#include "core.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* --- predicates ------------------------------------------------------------------------ */

/* Sign of (b-a) . ((c-a) x (d-a)): positive when d lies on the side of the normal
 * (b-a) x (c-a). Double first; when |det| is within the rounding bound (Shewchuk's
 * orient3d bound is 7.8e-16 of the permanent; we use 1e-15), again in long double; still
 * uncertain counts as 0. */
static int orient3(const double *a, const double *b, const double *c, const double *d) {
    double u0 = b[0] - a[0], u1 = b[1] - a[1], u2 = b[2] - a[2];
    double v0 = c[0] - a[0], v1 = c[1] - a[1], v2 = c[2] - a[2];
    double w0 = d[0] - a[0], w1 = d[1] - a[1], w2 = d[2] - a[2];
    double x0 = v1 * w2 - v2 * w1, x1 = v2 * w0 - v0 * w2, x2 = v0 * w1 - v1 * w0;
    double det = u0 * x0 + u1 * x1 + u2 * x2;
    double perm = fabs(u0) * (fabs(v1 * w2) + fabs(v2 * w1)) +
                  fabs(u1) * (fabs(v2 * w0) + fabs(v0 * w2)) +
                  fabs(u2) * (fabs(v0 * w1) + fabs(v1 * w0));
    double bound = 1e-15 * perm;
    if (det > bound) return 1;
    if (det < -bound) return -1;
    if (perm == 0.0) return 0;
    long double U0 = (long double)b[0] - a[0], U1 = (long double)b[1] - a[1],
                U2 = (long double)b[2] - a[2];
    long double V0 = (long double)c[0] - a[0], V1 = (long double)c[1] - a[1],
                V2 = (long double)c[2] - a[2];
    long double W0 = (long double)d[0] - a[0], W1 = (long double)d[1] - a[1],
                W2 = (long double)d[2] - a[2];
    long double D = U0 * (V1 * W2 - V2 * W1) + U1 * (V2 * W0 - V0 * W2) +
                    U2 * (V0 * W1 - V1 * W0);
    long double lb = 16.0L * LDBL_EPSILON * (long double)perm;
    if (D > lb) return 1;
    if (D < -lb) return -1;
    return 0;
}

/* 2-D orientation of c against the line a->b in the plane of axes (i, j). */
static int orient2(const double *a, const double *b, const double *c, int i, int j) {
    double u0 = b[i] - a[i], u1 = b[j] - a[j], v0 = c[i] - a[i], v1 = c[j] - a[j];
    double det = u0 * v1 - u1 * v0;
    double bound = 1e-15 * (fabs(u0 * v1) + fabs(u1 * v0));
    if (det > bound) return 1;
    if (det < -bound) return -1;
    long double D = ((long double)b[i] - a[i]) * ((long double)c[j] - a[j]) -
                    ((long double)b[j] - a[j]) * ((long double)c[i] - a[i]);
    long double lb = 16.0L * LDBL_EPSILON * (long double)(fabs(u0 * v1) + fabs(u1 * v0));
    if (D > lb) return 1;
    if (D < -lb) return -1;
    return 0;
}

/* The two axes that keep the most of a triangle's area when it is projected. */
static void plane_axes(const double *a, const double *b, const double *c, int *i, int *j) {
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {fabs(u[1] * v[2] - u[2] * v[1]), fabs(u[2] * v[0] - u[0] * v[2]),
                   fabs(u[0] * v[1] - u[1] * v[0])};
    int k = n[0] >= n[1] ? (n[0] >= n[2] ? 0 : 2) : (n[1] >= n[2] ? 1 : 2);
    *i = (k + 1) % 3;
    *j = (k + 2) % 3;
}

/* Whether c, collinear with a-b, lies within their bounding box. */
static int within(const double *a, const double *b, const double *c, int i, int j) {
    return fmin(a[i], b[i]) <= c[i] && c[i] <= fmax(a[i], b[i]) && fmin(a[j], b[j]) <= c[j] &&
           c[j] <= fmax(a[j], b[j]);
}

/* 2-D segments p-q and r-s have a common point (touching included). */
static int segs2(const double *p, const double *q, const double *r, const double *s, int i,
                 int j) {
    int o1 = orient2(p, q, r, i, j), o2 = orient2(p, q, s, i, j);
    int o3 = orient2(r, s, p, i, j), o4 = orient2(r, s, q, i, j);
    if (o1 * o2 < 0 && o3 * o4 < 0) return 1;
    if (o1 == 0 && within(p, q, r, i, j)) return 1;
    if (o2 == 0 && within(p, q, s, i, j)) return 1;
    if (o3 == 0 && within(r, s, p, i, j)) return 1;
    if (o4 == 0 && within(r, s, q, i, j)) return 1;
    return 0;
}

/* 2-D point p in triangle t (boundary included); a triangle with zero area contains
 * nothing. */
static int point_in2(const double *p, const double *const t[3], int i, int j) {
    int s0 = orient2(t[0], t[1], p, i, j), s1 = orient2(t[1], t[2], p, i, j);
    int s2 = orient2(t[2], t[0], p, i, j);
    if (orient2(t[0], t[1], t[2], i, j) == 0) return 0;
    return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

/* Segment p-q, lying in the plane of triangle t, meets t. */
static int seg_tri_coplanar(const double *p, const double *q, const double *const t[3]) {
    int i, j;
    plane_axes(t[0], t[1], t[2], &i, &j);
    if (point_in2(p, t, i, j) || point_in2(q, t, i, j)) return 1;
    for (int e = 0; e < 3; e++)
        if (segs2(p, q, t[e], t[(e + 1) % 3], i, j)) return 1;
    return 0;
}

/* Segment p-q meets triangle t; sp, sq are the sides of p and q against t's plane. */
static int seg_tri(const double *p, const double *q, int sp, int sq, const double *const t[3]) {
    if (sp * sq > 0) return 0;
    if (sp == 0 && sq == 0) return seg_tri_coplanar(p, q, t);
    int s0 = orient3(p, q, t[0], t[1]), s1 = orient3(p, q, t[1], t[2]);
    int s2 = orient3(p, q, t[2], t[0]);
    if (s0 == 0 && s1 == 0 && s2 == 0) return 0; /* a triangle of zero area */
    return (s0 >= 0 && s1 >= 0 && s2 >= 0) || (s0 <= 0 && s1 <= 0 && s2 <= 0);
}

/* Triangles with no common vertex. */
static int tri_tri(const double *const a[3], const double *const b[3]) {
    int sa[3], sb[3];
    for (int k = 0; k < 3; k++)
        sa[k] = orient3(b[0], b[1], b[2], a[k]);
    if ((sa[0] > 0 && sa[1] > 0 && sa[2] > 0) || (sa[0] < 0 && sa[1] < 0 && sa[2] < 0))
        return 0;
    for (int k = 0; k < 3; k++)
        sb[k] = orient3(a[0], a[1], a[2], b[k]);
    if ((sb[0] > 0 && sb[1] > 0 && sb[2] > 0) || (sb[0] < 0 && sb[1] < 0 && sb[2] < 0))
        return 0;
    if (sa[0] == 0 && sa[1] == 0 && sa[2] == 0) {
        /* coplanar: an edge of a crosses b, or b lies inside a */
        for (int e = 0; e < 3; e++)
            if (seg_tri_coplanar(a[e], a[(e + 1) % 3], b)) return 1;
        int i, j;
        plane_axes(a[0], a[1], a[2], &i, &j);
        return point_in2(b[0], a, i, j);
    }
    /* The intersection is a segment on the planes' common line; its ends lie on edges. */
    for (int e = 0; e < 3; e++) {
        int f = (e + 1) % 3;
        if (seg_tri(a[e], a[f], sa[e], sa[f], b)) return 1;
        if (seg_tri(b[e], b[f], sb[e], sb[f], a)) return 1;
    }
    return 0;
}

int vm__tri_pair_intersects(const double *const a[3], const vm_index ia[3],
                            const double *const b[3], const vm_index ib[3]) {
    /* A triangle that repeats a node is a segment or a point: the checks count it as
     * degenerate, and the shared-corner logic below needs three distinct corners. */
    if (ia[0] == ia[1] || ia[1] == ia[2] || ia[0] == ia[2] || ib[0] == ib[1] ||
        ib[1] == ib[2] || ib[0] == ib[2])
        return 0;
    int shared = 0, pa[3] = {-1, -1, -1}; /* pa[k]: corner of b equal to corner k of a */
    for (int k = 0; k < 3; k++)
        for (int l = 0; l < 3; l++)
            if (ia[k] == ib[l]) {
                pa[k] = l;
                shared++;
            }
    if (shared == 0) return tri_tri(a, b);
    if (shared >= 3) return 1; /* the same triangle twice */
    if (shared == 2) {
        /* Common edge u-v: apart from it they meet only when coplanar and on one side. */
        int ka = pa[0] < 0 ? 0 : pa[1] < 0 ? 1 : 2;
        int kb = 3 - pa[(ka + 1) % 3] - pa[(ka + 2) % 3];
        const double *u = a[(ka + 1) % 3], *v = a[(ka + 2) % 3], *p = a[ka], *q = b[kb];
        if (orient3(u, v, p, q) != 0) return 0;
        int i, j;
        plane_axes(u, v, p, &i, &j);
        int sp = orient2(u, v, p, i, j), sq = orient2(u, v, q, i, j);
        return sp * sq > 0;
    }
    /* One common vertex w: they meet elsewhere exactly when the edge opposite w in one
     * triangle meets the other triangle. */
    int ka = pa[0] >= 0 ? 0 : pa[1] >= 0 ? 1 : 2, kb = pa[ka];
    const double *a1 = a[(ka + 1) % 3], *a2 = a[(ka + 2) % 3];
    const double *b1 = b[(kb + 1) % 3], *b2 = b[(kb + 2) % 3];
    int s1 = orient3(b[0], b[1], b[2], a1), s2 = orient3(b[0], b[1], b[2], a2);
    if (seg_tri(a1, a2, s1, s2, b)) return 1;
    s1 = orient3(a[0], a[1], a[2], b1);
    s2 = orient3(a[0], a[1], a[2], b2);
    return seg_tri(b1, b2, s1, s2, a);
}

/* --- broad phase -------------------------------------------------------------------------- */

typedef struct box3 {
    double lo[3], hi[3];
} box3;

/* The cell (0..n-1) of coordinate x along an axis of cells of size h from lo. */
static size_t cell_of(double x, double lo, double h, size_t n) {
    double c = floor((x - lo) / h);
    if (!(c > 0)) return 0;
    if (c >= (double)(n - 1)) return n - 1;
    return (size_t)c;
}

#define GRID_MAX_SIDE 4096   /* cells per axis of the broad-phase grid at most */
#define GRID_GROWTH 1.25     /* the cell size grows by this until the grid is small enough */

/* The broad-phase grid: n cells of size h from glo per axis; the triangles of cell c are
 * ent[start[c] .. start[c+1]). */
typedef struct tri_grid {
    double glo[3], h;
    size_t n[3], ncell;
    size_t *start, *ent;
} tri_grid;

/* Triangles per chunk of tri_boxes: the chunks' sums of largest sides are added in chunk
 * order, so the grid is the same for any thread count. */
#define BOX_CHUNK 65536

/* The bounding boxes of triangles [t0, t1) into bx, their box into lo..hi (widened);
 * returns the sum of their largest box sides. */
static double chunk_boxes(const double *pts, const vm_index *tri, size_t t0, size_t t1,
                          box3 *bx, double lo3[3], double hi3[3]) {
    double ext = 0.0;
    for (size_t t = t0; t < t1; t++) {
        double big = 0.0;
        for (int a = 0; a < 3; a++) {
            double lo = INFINITY, hi = -INFINITY;
            for (int k = 0; k < 3; k++) {
                double x = pts[3 * (size_t)tri[3 * t + (size_t)k] + (size_t)a];
                lo = fmin(lo, x);
                hi = fmax(hi, x);
            }
            bx[t].lo[a] = lo;
            bx[t].hi[a] = hi;
            lo3[a] = fmin(lo3[a], lo);
            hi3[a] = fmax(hi3[a], hi);
            big = fmax(big, hi - lo);
        }
        ext += big;
    }
    return ext;
}

/* The bounding boxes of the nt triangles into bx, the box of them all into glo..ghi;
 * returns the sum over the triangles of their largest box side. Chunks on the threads when
 * there is room for their figures (else in one go: the same boxes, a sum in another
 * order). */
static double tri_boxes(const double *pts, const vm_index *tri, size_t nt, box3 *bx,
                        double glo[3], double ghi[3]) {
    for (int a = 0; a < 3; a++) {
        glo[a] = INFINITY;
        ghi[a] = -INFINITY;
    }
    size_t nch = (nt + BOX_CHUNK - 1) / BOX_CHUNK;
    double *part = nch > 1 ? malloc(nch * 7 * sizeof *part) : NULL;
    if (!part) return chunk_boxes(pts, tri, 0, nt, bx, glo, ghi);
    const ptrdiff_t pn = (ptrdiff_t)nch;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (ptrdiff_t c = 0; c < pn; c++) {
        double *f = part + 7 * c;
        size_t t0 = (size_t)c * BOX_CHUNK, t1 = t0 + BOX_CHUNK < nt ? t0 + BOX_CHUNK : nt;
        for (int a = 0; a < 3; a++) {
            f[1 + a] = INFINITY;
            f[4 + a] = -INFINITY;
        }
        f[0] = chunk_boxes(pts, tri, t0, t1, bx, f + 1, f + 4);
    }
    double ext = 0.0;
    for (size_t c = 0; c < nch; c++) {
        ext += part[7 * c];
        for (int a = 0; a < 3; a++) {
            glo[a] = fmin(glo[a], part[7 * c + 1 + (size_t)a]);
            ghi[a] = fmax(ghi[a], part[7 * c + 4 + (size_t)a]);
        }
    }
    free(part);
    return ext;
}

/* Sizes g for nt triangles of mean largest side ext / nt within glo..ghi: cells about the
 * size of a typical triangle, at most ~2 per triangle. */
static void grid_size(tri_grid *g, const double glo[3], const double ghi[3], double ext,
                      size_t nt) {
    double h = ext / (double)nt;
    double span = fmax(ghi[0] - glo[0], fmax(ghi[1] - glo[1], ghi[2] - glo[2]));
    if (!(h > 0) || !isfinite(h)) h = span > 0 && isfinite(span) ? span : 1.0;
    for (;;) {
        g->ncell = 1;
        for (int a = 0; a < 3; a++) {
            /* a side that overflows (coordinates near +-DBL_MAX) gets one cell: growing h
             * would never make it finite */
            double side = ghi[a] - glo[a], c = floor(side / h) + 1;
            g->n[a] = !isfinite(side)                ? 1
                      : c < (double)GRID_MAX_SIDE ? (size_t)c
                                                  : GRID_MAX_SIDE;
            g->ncell *= g->n[a];
        }
        if (g->ncell <= 2 * nt + 64 || !isfinite(h)) break;
        h *= GRID_GROWTH;
    }
    g->h = h;
    memcpy(g->glo, glo, sizeof g->glo);
}

/* The cells c0..c1 (per axis) that box b covers in g. */
static void box_cells(const tri_grid *g, const box3 *b, size_t c0[3], size_t c1[3]) {
    for (int a = 0; a < 3; a++) {
        c0[a] = cell_of(b->lo[a], g->glo[a], g->h, g->n[a]);
        c1[a] = cell_of(b->hi[a], g->glo[a], g->h, g->n[a]);
    }
}

/* Bins the nt boxes into the cells of g (g->start, g->ent; a counting sort): counted and
 * placed on the threads, then each cell's entries sorted, so every cell lists its
 * triangles in ascending order for any thread count. */
static vm_status grid_fill(tri_grid *g, const box3 *bx, size_t nt, vm_error *err) {
    const size_t n0 = g->n[0], n1 = g->n[1];
    g->start = calloc(g->ncell + 1, sizeof *g->start);
    if (!g->start) return vm_error_set(err, VM_ERR_NOMEM, "self-intersection: out of memory");
    size_t *start = g->start, total = 0, bytes;
    const ptrdiff_t pnt = (ptrdiff_t)nt;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096) reduction(+ : total)
#endif
    for (ptrdiff_t t = 0; t < pnt; t++) {
        size_t c0[3], c1[3];
        box_cells(g, &bx[t], c0, c1);
        for (size_t z = c0[2]; z <= c1[2]; z++)
            for (size_t y = c0[1]; y <= c1[1]; y++)
                for (size_t x = c0[0]; x <= c1[0]; x++) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
                    start[x + n0 * (y + n1 * z) + 1]++;
                    total++;
                }
    }
    if (vm__mul_overflows(total, sizeof *g->ent, &bytes) || bytes > vm__memory_limit() ||
        !(g->ent = malloc(bytes ? bytes : 1)))
        return vm_error_set(err, VM_ERR_NOMEM,
                            "self-intersection: out of memory for %zu entries", total);
    for (size_t c = 0; c < g->ncell; c++)
        start[c + 1] += start[c];
    size_t *ent = g->ent;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t t = 0; t < pnt; t++) { /* start[c] runs ahead while filling */
        size_t c0[3], c1[3];
        box_cells(g, &bx[t], c0, c1);
        for (size_t z = c0[2]; z <= c1[2]; z++)
            for (size_t y = c0[1]; y <= c1[1]; y++)
                for (size_t x = c0[0]; x <= c1[0]; x++) {
                    size_t at;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic capture
#endif
                    at = start[x + n0 * (y + n1 * z)]++;
                    ent[at] = (size_t)t;
                }
    }
    for (size_t c = g->ncell; c > 0; c--) /* shift back: start[c] is the cell's first entry */
        start[c] = start[c - 1];
    start[0] = 0;
    const ptrdiff_t pnc = (ptrdiff_t)g->ncell;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t c = 0; c < pnc; c++) {
        vm__sort_size(ent + start[c], start[c + 1] - start[c]);
    }
    return VM_OK;
}

/* Tests the pairs of triangles in cell (x, y, z) of g whose boxes overlap, each pair in the
 * cell of the low corner of the overlap only (so once); counts them as
 * vm__self_intersections does. */
static void cell_pairs(const tri_grid *g, size_t x, size_t y, size_t z, const box3 *bx,
                       const double *pts, const vm_index *tri, size_t *pairs, uint8_t *flags) {
    const size_t *n = g->n;
    size_t c = x + n[0] * (y + n[1] * z);
    for (size_t p = g->start[c]; p < g->start[c + 1]; p++)
        for (size_t q = p + 1; q < g->start[c + 1]; q++) {
            size_t s = g->ent[p], t = g->ent[q];
            const box3 *A = &bx[s], *B = &bx[t];
            int apart = 0;
            double corner[3];
            for (int a = 0; a < 3; a++) {
                if (A->lo[a] > B->hi[a] || B->lo[a] > A->hi[a]) apart = 1;
                corner[a] = fmax(A->lo[a], B->lo[a]);
            }
            if (apart) continue;
            if (cell_of(corner[0], g->glo[0], g->h, n[0]) != x ||
                cell_of(corner[1], g->glo[1], g->h, n[1]) != y ||
                cell_of(corner[2], g->glo[2], g->h, n[2]) != z)
                continue;
            const double *pa[3], *pb[3];
            vm_index ia[3], ib[3];
            for (int k = 0; k < 3; k++) {
                ia[k] = tri[3 * s + (size_t)k];
                ib[k] = tri[3 * t + (size_t)k];
                pa[k] = pts + 3 * (size_t)ia[k];
                pb[k] = pts + 3 * (size_t)ib[k];
            }
            if (vm__tri_pair_intersects(pa, ia, pb, ib)) {
                (*pairs)++;
                if (flags) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic write
#endif
                    flags[s] = 1;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic write
#endif
                    flags[t] = 1;
                }
            }
        }
}

/* The intersecting pairs (self_intersect.h): boxes, a uniform grid over them, the pairs
 * tested cell by cell, the cells on the threads (each pair is tested in one cell only, so
 * the count and the flags are the same for any thread count). */
vm_status vm__self_intersections(const double *pts, const vm_index *tri, size_t nt,
                                 size_t *pairs, uint8_t *flags, vm_error *err) {
    *pairs = 0;
    if (flags) memset(flags, 0, nt);
    if (nt < 2) return VM_OK;
    size_t bytes;
    if (vm__mul_overflows(nt, sizeof(box3), &bytes) || bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "self-intersection: %zu triangles", nt);
    box3 *bx = malloc(bytes);
    if (!bx) return vm_error_set(err, VM_ERR_NOMEM, "self-intersection: out of memory");
    double glo[3], ghi[3];
    double ext = tri_boxes(pts, tri, nt, bx, glo, ghi);
    tri_grid g;
    memset(&g, 0, sizeof g);
    grid_size(&g, glo, ghi, ext, nt);
    vm_status st = grid_fill(&g, bx, nt, err);
    size_t found = 0;
    const ptrdiff_t ncell = st ? 0 : (ptrdiff_t)g.ncell;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 256) reduction(+ : found)
#endif
    for (ptrdiff_t c = 0; c < ncell; c++) {
        size_t x = (size_t)c % g.n[0], y = (size_t)c / g.n[0] % g.n[1],
               z = (size_t)c / g.n[0] / g.n[1];
        cell_pairs(&g, x, y, z, bx, pts, tri, &found, flags);
    }
    *pairs = found;
    free(bx);
    free(g.start);
    free(g.ent);
    return st;
}
