/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_asc.c — adaptive skeleton climbing: iso points on grid edges (1-skeleton),
 * iso lines on rectangles (2-skeleton), surfaces in boxes (3-skeleton), after Poston, Wong,
 * Heng, "Multiresolution isosurface extraction with adaptive skeleton climbing" (EG 1998).
 *
 * The paper's pieces and where they are here:
 *  - dikes (grid segments of 2^a cells on the binary tree) are simple when crossed at most
 *    once: box_check counts the sign changes of every grid line of a box;
 *  - simple boxes (all dikes simple, sides on the binary tree, at most 2^max_level cells a
 *    side) are found per block of 2^max_level cells by climbing a k-d tree of binary boxes
 *    (build): a box is kept when it is simple, its iso points lie in a slab o->error voxels
 *    thick and no unit square inside it is ambiguous, otherwise it is split in halves along
 *    one axis (preferring a split whose two halves are already simple, so boxes stay as
 *    large as the geometry allows);
 *  - information sharing: on every plane that carries box faces, the faces of the boxes on
 *    both sides are overlaid and their intersections are the padis (simple rectangles) that
 *    both boxes use, so a face between a large and a small box carries the same iso line on
 *    both sides and the surface has no cracks (faces);
 *  - iso lines: each padi is a square of the marching squares table on its four corners,
 *    with its iso points where its sides' dikes are crossed; a padi with diagonal corners is
 *    resolved by the actual connectivity of its samples (the asymptotic decider on unit
 *    squares), the same answer for both boxes;
 *  - triangulation: the iso lines on a box's faces close into edge loops, and each loop is
 *    cut into triangles by removing ears (the paper's vertex removal), choosing the ear with
 *    the largest smallest angle, in the projection on the loop's mean plane; where the
 *    surface bulges more than o->error/4 away from a loop of a large box, the loop is fanned
 *    from the surface point inside the box instead (not in the paper: it halves the volume
 *    lost to chords), and a loop whose ears run out is fanned from its centroid.
 * Material outside the grid is outside (value -1), so the surface is closed at the border:
 * the grid is padded by one sample on every side, pressed onto the box at the output. */
#include "../core/core.h"
#include "../core/hash.h"
#include "surface_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* How far outside the box (in voxels, per voxel of the padding layer) the closing faces lie. */
#define BORDER_SQUEEZE 0.01
/* Loop triangulation, lengths in voxels: a loop whose Newell normal is shorter than
 * ASC_FLAT_LOOP has no plane (fanned from its centroid); ears are convex, and free of other
 * points, beyond ASC_EAR_EPS (rounding of the projected cross products, voxel^2). */
#define ASC_FLAT_LOOP 1e-12
#define ASC_EAR_EPS 1e-12
/* The bulge fan (file comment): the surface point found along the loop's normal at least
 * ASC_BULGE_TOL voxels inside the box, used when it lies more than ASC_BULGE_FRACTION of
 * the error (the header's o->error / 4) from the loop's plane and the loop is star-shaped
 * from it beyond ASC_STAR_EPS. */
#define ASC_BULGE_TOL 0.05
#define ASC_BULGE_FRACTION 0.25
#define ASC_STAR_EPS 1e-9

/* Padded grid: sample p (padded) is sample p-1 of g; everything outside g is outside. */
typedef struct asc_ctx {
    const vm__surface_grid *g;
    int64_t n[3];   /* padded samples per axis (g->n + 2) */
    int64_t dom[3]; /* cells per axis covered by blocks (multiple of the block size) */
    uint8_t *in;    /* n[0]*n[1]*n[2] flags: 1 inside */
    double error;
    size_t visited;
    /* scratch for box_check */
    double *pts;
    size_t pts_cap;
    uint8_t *mark; /* scratch for one_piece */
    size_t mark_cap;
    int64_t *queue;
    size_t queue_cap;
} asc_ctx;

typedef struct asc_box {
    int32_t lo[3], sz[3];
} asc_box;

/* A box face on a plane: axis w, plane coordinate c, rectangle in (u, v) = (w+1, w+2). */
typedef struct asc_face {
    int32_t w, c, box, above; /* above: the box lies on the +w side of the plane */
    int32_t u0, v0, su, sv;
} asc_face;

typedef struct asc_seg {
    int32_t box;
    int32_t a, b;
} asc_seg;

static int inside_at(const asc_ctx *c, int64_t i, int64_t j, int64_t k) {
    if (i < 0 || j < 0 || k < 0 || i >= c->n[0] || j >= c->n[1] || k >= c->n[2]) return 0;
    return c->in[i + c->n[0] * (j + c->n[1] * k)];
}

static double value_at(const asc_ctx *c, const int64_t p[3]) {
    return vm__surface_at(c->g, p[0] - 1, p[1] - 1, p[2] - 1);
}

/* Parameter of the crossing on the unit edge from p along axis a (p inside xor p+e_a).
 * Kept off the end samples so that no two iso points coincide. */
static double crossing_t(const asc_ctx *c, const int64_t p[3], int a) {
    int64_t q[3] = {p[0], p[1], p[2]};
    q[a]++;
    double f0 = value_at(c, p), f1 = value_at(c, q);
    double t = f0 / (f0 - f1);
    if (!(t >= 0.01)) t = 0.01;
    if (t > 0.99) t = 0.99;
    return t;
}

/* 1 when the inside samples of the grid part [b0, b1] of a box are one 6-connected piece
 * and so are the outside samples: one sheet through the box (two sheets would give two
 * loops, whose triangles nothing keeps apart). -1 on out of memory. */
static int one_piece(asc_ctx *c, const int64_t b0[3], const int64_t b1[3]) {
    int64_t d[3] = {b1[0] - b0[0] + 1, b1[1] - b0[1] + 1, b1[2] - b0[2] + 1};
    size_t n = (size_t)d[0] * (size_t)d[1] * (size_t)d[2];
    if (vm__grow((void **)&c->mark, &c->mark_cap, n, 1, NULL) ||
        vm__grow((void **)&c->queue, &c->queue_cap, n, sizeof(int64_t), NULL))
        return -1;
    uint8_t *m = c->mark;
    for (int64_t z = 0; z < d[2]; z++)
        for (int64_t y = 0; y < d[1]; y++)
            for (int64_t x = 0; x < d[0]; x++)
                m[x + d[0] * (y + d[1] * z)] =
                    (uint8_t)inside_at(c, b0[0] + x, b0[1] + y, b0[2] + z);
    int pieces[2] = {0, 0};
    for (size_t i = 0; i < n; i++) {
        if (m[i] & 2) continue;
        int side = m[i] & 1;
        if (++pieces[side] > 1) return 0;
        size_t qh = 0, qt = 0;
        c->queue[qt++] = (int64_t)i;
        m[i] |= 2;
        while (qh < qt) {
            int64_t at = c->queue[qh++];
            int64_t x = at % d[0], y = (at / d[0]) % d[1], z = at / (d[0] * d[1]);
            int64_t nb[6][3] = {{x - 1, y, z}, {x + 1, y, z}, {x, y - 1, z},
                                {x, y + 1, z}, {x, y, z - 1}, {x, y, z + 1}};
            for (int k = 0; k < 6; k++) {
                if (nb[k][0] < 0 || nb[k][1] < 0 || nb[k][2] < 0 || nb[k][0] >= d[0] ||
                    nb[k][1] >= d[1] || nb[k][2] >= d[2])
                    continue;
                int64_t j = nb[k][0] + d[0] * (nb[k][1] + d[1] * nb[k][2]);
                if (m[j] != side) continue;
                m[j] |= 2;
                c->queue[qt++] = j;
            }
        }
    }
    return 1;
}

/* The simplicity test of a box (lo, sz in padded cells): every grid line of the box along
 * every axis changes sign at most once (all dikes simple); and, for boxes larger than one
 * cell, the iso points on its unit edges lie in a slab of thickness c->error normal to
 * their mean gradient. The slab is convex, so the box's triangles, whose corners are some
 * of these iso points, lie in it too, and the surface is within about c->error of them. Returns
 * 1 when simple; *active = 1 when the surface crosses the box. Returns -1 on out of memory. */
static int box_check(asc_ctx *c, const int32_t lo[3], const int32_t sz[3], int *active) {
    c->visited++;
    *active = 0;
    size_t npts = 0;
    double grad[3] = {0, 0, 0};
    int unit = sz[0] == 1 && sz[1] == 1 && sz[2] == 1;
    if (unit) { /* a unit cell is always simple: it is active when its corners differ */
        int n_in = 0;
        for (int k = 0; k < 8; k++)
            n_in += inside_at(c, lo[0] + (k & 1), lo[1] + ((k >> 1) & 1), lo[2] + (k >> 2));
        *active = n_in != 0 && n_in != 8;
        return 1;
    }
    /* samples outside the padded grid are outside like its padding layer, so no line
     * changes sign there: scan only the part of the box within the grid */
    int64_t b0[3], b1[3];
    for (int a = 0; a < 3; a++) {
        b0[a] = lo[a] > 0 ? lo[a] : 0;
        b1[a] = (int64_t)lo[a] + sz[a] < c->n[a] - 1 ? (int64_t)lo[a] + sz[a] : c->n[a] - 1;
        if (b0[a] > b1[a]) return 1;
    }
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, d = (a + 2) % 3;
        for (int64_t y = b0[b]; y <= b1[b]; y++)
            for (int64_t z = b0[d]; z <= b1[d]; z++) {
                int64_t p[3];
                p[a] = b0[a];
                p[b] = y;
                p[d] = z;
                int prev = inside_at(c, p[0], p[1], p[2]), flips = 0;
                for (int64_t x = b0[a] + 1; x <= b1[a]; x++) {
                    p[a] = x;
                    int s = inside_at(c, p[0], p[1], p[2]);
                    if (s == prev) continue;
                    if (++flips > 1) return 0;
                    *active = 1;
                    prev = s;
                    grad[a] += s ? 1.0 : -1.0;
                    if (vm__grow((void **)&c->pts, &c->pts_cap, 3 * (npts + 1), sizeof(double),
                                 NULL))
                        return -1;
                    int64_t q[3] = {p[0], p[1], p[2]};
                    q[a]--;
                    double t = crossing_t(c, q, a);
                    double *o = c->pts + 3 * npts++;
                    o[0] = (double)q[0];
                    o[1] = (double)q[1];
                    o[2] = (double)q[2];
                    o[a] += t;
                }
            }
    }
    if (npts == 0) return 1;
    double gl = sqrt(grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2]);
    if (gl < 1e-9) return 0;
    double cen[3] = {0, 0, 0};
    for (size_t i = 0; i < npts; i++)
        for (int a = 0; a < 3; a++)
            cen[a] += c->pts[3 * i + a];
    for (int a = 0; a < 3; a++)
        cen[a] /= (double)npts;
    double dmin = 0, dmax = 0;
    for (size_t i = 0; i < npts; i++) {
        double dist = 0;
        for (int a = 0; a < 3; a++)
            dist += (c->pts[3 * i + a] - cen[a]) * grad[a];
        dist /= gl;
        if (dist < dmin) dmin = dist;
        if (dist > dmax) dmax = dist;
        if (dmax - dmin > c->error) return 0;
    }
    /* A unit square inside the box with diagonal corners is a choice the unit cells make
     * (asymptotic decider) and the box's loops cannot see: such a box could join or split
     * what the unit cells do not, so it is not simple. */
    for (int w = 0; w < 3; w++) {
        int u = (w + 1) % 3, v = (w + 2) % 3;
        int64_t p[3];
        for (int64_t x = b0[w] + 1; x < b1[w] && x < (int64_t)lo[w] + sz[w]; x++)
            for (int64_t y = b0[u]; y < b1[u]; y++)
                for (int64_t z = b0[v]; z < b1[v]; z++) {
                    p[w] = x;
                    p[u] = y;
                    p[v] = z;
                    int s00 = inside_at(c, p[0], p[1], p[2]);
                    p[u] = y + 1;
                    int s10 = inside_at(c, p[0], p[1], p[2]);
                    if (s10 == s00) continue;
                    p[v] = z + 1;
                    int s11 = inside_at(c, p[0], p[1], p[2]);
                    if (s11 != s00) continue;
                    p[u] = y;
                    int s01 = inside_at(c, p[0], p[1], p[2]);
                    if (s01 == s10) return 0;
                }
    }
    return one_piece(c, b0, b1);
}

typedef struct asc_boxes {
    asc_box *v;
    size_t n, cap;
} asc_boxes;

/* Climbs the k-d tree of binary boxes below (lo, sz): keeps simple boxes, splits the
 * others. known: -1 unknown, else the result of box_check for this box (with *act). */
static vm_status build(asc_ctx *c, const int32_t lo[3], const int32_t sz[3], int known, int act,
                       asc_boxes *out, vm_error *err) {
    int ok = known, active = act;
    if (ok < 0) ok = box_check(c, lo, sz, &active);
    if (ok < 0) return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    if (ok) {
        if (!active) return VM_OK;
        if (vm__grow((void **)&out->v, &out->cap, out->n + 1, sizeof(asc_box), err))
            return VM_ERR_NOMEM;
        asc_box *b = out->v + out->n++;
        memcpy(b->lo, lo, sizeof b->lo);
        memcpy(b->sz, sz, sizeof b->sz);
        return VM_OK;
    }
    /* Candidate axes, longest first (x before y before z among equals). */
    int order[3] = {0, 1, 2}, na = 0;
    for (int a = 0; a < 3; a++)
        if (sz[a] > 1) order[na++] = a;
    for (int i = 1; i < na; i++)
        for (int j = i; j > 0 && sz[order[j]] > sz[order[j - 1]]; j--) {
            int t = order[j];
            order[j] = order[j - 1];
            order[j - 1] = t;
        }
    int32_t L1[3], L2[3], S[3];
    int pick = order[0], r1 = -1, r2 = -1, a1 = 0, a2 = 0;
    for (int i = 0; i < na; i++) {
        int a = order[i];
        memcpy(L1, lo, sizeof L1);
        memcpy(L2, lo, sizeof L2);
        memcpy(S, sz, sizeof S);
        S[a] = sz[a] / 2;
        L2[a] = lo[a] + S[a];
        int x1, x2;
        int k1 = box_check(c, L1, S, &x1);
        int k2 = k1 > 0 ? box_check(c, L2, S, &x2) : 0;
        if (k1 < 0 || k2 < 0)
            return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
        if (k1 > 0 && k2 > 0) {
            pick = a;
            r1 = r2 = 1;
            a1 = x1;
            a2 = x2;
            break;
        }
    }
    memcpy(L1, lo, sizeof L1);
    memcpy(L2, lo, sizeof L2);
    memcpy(S, sz, sizeof S);
    S[pick] = sz[pick] / 2;
    L2[pick] = lo[pick] + S[pick];
    vm_status s = build(c, L1, S, r1, a1, out, err);
    if (!s) s = build(c, L2, S, r2, a2, out, err);
    return s;
}

/* ---- iso points: one per crossed unit edge, found through an open-addressing hash ---- */

typedef struct asc_points {
    uint64_t *keys; /* edge key + 1, 0 = empty */
    int32_t *ids;
    size_t cap, count;
    double *xyz; /* padded coordinates, 3 per point */
    size_t xyz_cap, n;
} asc_points;

/* Appends point x to P; *id is its index. */
static vm_status add_xyz(asc_points *P, const double x[3], int32_t *id, vm_error *err) {
    if (P->n >= (size_t)INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "surface asc: too many points");
    if (vm__grow((void **)&P->xyz, &P->xyz_cap, 3 * (P->n + 1), sizeof(double), err))
        return VM_ERR_NOMEM;
    memcpy(P->xyz + 3 * P->n, x, 3 * sizeof(double));
    *id = (int32_t)P->n++;
    return VM_OK;
}

/* Id of the iso point on the unit edge from padded sample p along axis a. */
static vm_status edge_point(asc_ctx *c, asc_points *P, const int64_t p[3], int a, int32_t *id,
                            vm_error *err) {
    if (2 * (P->count + 1) > P->cap) {
        size_t ncap = P->cap ? 2 * P->cap : 1024;
        uint64_t *nk = calloc(ncap, sizeof *nk);
        int32_t *ni = malloc(ncap * sizeof *ni);
        if (!nk || !ni) {
            free(nk);
            free(ni);
            return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
        }
        for (size_t i = 0; i < P->cap; i++) {
            if (!P->keys[i]) continue;
            size_t h = vm__hash_mix(P->keys[i]) & (ncap - 1);
            while (nk[h])
                h = (h + 1) & (ncap - 1);
            nk[h] = P->keys[i];
            ni[h] = P->ids[i];
        }
        free(P->keys);
        free(P->ids);
        P->keys = nk;
        P->ids = ni;
        P->cap = ncap;
    }
    uint64_t key = ((uint64_t)(p[0] + c->n[0] * (p[1] + c->n[1] * p[2])) * 3 + (uint64_t)a) + 1;
    size_t h = vm__hash_mix(key) & (P->cap - 1);
    while (P->keys[h]) {
        if (P->keys[h] == key) {
            *id = P->ids[h];
            return VM_OK;
        }
        h = (h + 1) & (P->cap - 1);
    }
    double x[3] = {(double)p[0], (double)p[1], (double)p[2]};
    x[a] += crossing_t(c, p, a);
    vm_status s = add_xyz(P, x, id, err);
    if (s) return s;
    P->keys[h] = key;
    P->ids[h] = *id;
    P->count++;
    return VM_OK;
}

/* ---- padis: iso lines on the rectangles both sides of a plane agree on ---------------- */

/* Signed value of the padded sample at plane coordinates (w, c, u, v). */
static void plane_point(int w, int32_t cw, int64_t u, int64_t v, int64_t p[3]) {
    p[w] = cw;
    p[(w + 1) % 3] = u;
    p[(w + 2) % 3] = v;
}

/* Whether the two inside corners of a diagonal padi are joined through its samples:
 * 4-connected inside samples, and diagonal steps across unit squares that are themselves
 * diagonal and whose bilinear saddle (asymptotic decider) is inside. */
static int padi_joined(asc_ctx *c, int w, int32_t cw, int32_t u0, int32_t v0, int32_t su,
                       int32_t sv, int from_corner, uint8_t **scratch, size_t *scap,
                       int32_t **queue, size_t *qcap, int *fail) {
    int64_t p[3];
    if (su == 1 && sv == 1) {
        double f[4];
        int64_t cu[4] = {u0, u0 + 1, u0 + 1, u0}, cv[4] = {v0, v0, v0 + 1, v0 + 1};
        for (int k = 0; k < 4; k++) {
            plane_point(w, cw, cu[k], cv[k], p);
            f[k] = value_at(c, p);
        }
        double den = f[0] + f[2] - f[1] - f[3];
        double saddle =
            den != 0 ? (f[0] * f[2] - f[1] * f[3]) / den : 0.25 * (f[0] + f[1] + f[2] + f[3]);
        return saddle >= 0;
    }
    size_t W = (size_t)su + 1, H = (size_t)sv + 1, N = W * H;
    if (vm__grow((void **)scratch, scap, N, 1, NULL) ||
        vm__grow((void **)queue, qcap, N, sizeof(int32_t), NULL)) {
        *fail = 1;
        return 0;
    }
    uint8_t *m = *scratch; /* bit 0 inside, bit 1 seen */
    for (size_t y = 0; y < H; y++)
        for (size_t x = 0; x < W; x++) {
            plane_point(w, cw, u0 + (int64_t)x, v0 + (int64_t)y, p);
            m[x + W * y] = (uint8_t)inside_at(c, p[0], p[1], p[2]);
        }
    size_t start = from_corner == 0 ? 0 : W - 1; /* corner 0 (0,0) or corner 1 (W-1,0) */
    size_t goal = from_corner == 0 ? N - 1 : W * (H - 1);
    int32_t *q = *queue;
    size_t qh = 0, qt = 0;
    q[qt++] = (int32_t)start;
    m[start] |= 2;
    while (qh < qt) {
        size_t at = (size_t)q[qh++];
        if (at == goal) return 1;
        int64_t x = (int64_t)(at % W), y = (int64_t)(at / W);
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                if (!dx && !dy) continue;
                int64_t nx = x + dx, ny = y + dy;
                if (nx < 0 || ny < 0 || nx >= (int64_t)W || ny >= (int64_t)H) continue;
                size_t nb = (size_t)nx + W * (size_t)ny;
                if (m[nb] != 1) continue;
                if (dx && dy) {
                    /* across the unit square: only when the other diagonal is outside
                     * and the decider joins */
                    if ((m[(size_t)nx + W * (size_t)y] & 1) ||
                        (m[(size_t)x + W * (size_t)ny] & 1))
                        continue; /* reached by a 4-step anyway */
                    int32_t qu = (int32_t)(u0 + (dx < 0 ? nx : x)),
                            qv = (int32_t)(v0 + (dy < 0 ? ny : y));
                    if (!padi_joined(c, w, cw, qu, qv, 1, 1, 0, NULL, NULL, NULL, NULL, fail))
                        continue;
                }
                m[nb] |= 2;
                q[qt++] = (int32_t)nb;
            }
    }
    return 0;
}

/* The sample where the dike from a to b (padded, along axis a, |b-a| cells) changes sign:
 * the lower end of the crossed unit edge. */
static void dike_crossing(const asc_ctx *c, const int64_t from[3], int axis, int64_t len,
                          int64_t out[3]) {
    int64_t p[3] = {from[0], from[1], from[2]};
    int s0 = inside_at(c, p[0], p[1], p[2]);
    for (int64_t t = 1; t <= len; t++) {
        p[axis] = from[axis] + t;
        if (inside_at(c, p[0], p[1], p[2]) != s0) break;
    }
    out[0] = p[0];
    out[1] = p[1];
    out[2] = p[2];
    out[axis] -= 1;
}

typedef struct asc_segs {
    asc_seg *v;
    size_t n, cap;
} asc_segs;

static vm_status push_seg(asc_segs *S, int32_t box, int32_t a, int32_t b, vm_error *err) {
    if (vm__grow((void **)&S->v, &S->cap, S->n + 1, sizeof(asc_seg), err)) return VM_ERR_NOMEM;
    S->v[S->n].box = box;
    S->v[S->n].a = a;
    S->v[S->n].b = b;
    S->n++;
    return VM_OK;
}

typedef struct asc_scratch {
    uint8_t *m;
    size_t mcap;
    int32_t *q;
    size_t qcap;
} asc_scratch;

/* Iso lines of the padi (u0, v0, su, sv) on plane (w, cw) between box `up` (+w side) and box
 * `down`: segments oriented with the material on their left seen from +w, given as is to
 * the box above and reversed to the box below. */
static vm_status padi_lines(asc_ctx *c, asc_points *P, asc_segs *S, asc_scratch *sc, int w,
                            int32_t cw, int32_t u0, int32_t v0, int32_t su, int32_t sv,
                            int32_t up, int32_t down, vm_error *err) {
    int64_t cu[4] = {u0, u0 + su, u0 + su, u0}, cv[4] = {v0, v0, v0 + sv, v0 + sv};
    int sgn[4], n_in = 0;
    int64_t p[3];
    for (int k = 0; k < 4; k++) {
        plane_point(w, cw, cu[k], cv[k], p);
        sgn[k] = inside_at(c, p[0], p[1], p[2]);
        n_in += sgn[k];
    }
    if (n_in == 0 || n_in == 4) return VM_OK;
    int32_t id[4];
    int kind[4]; /* per side k (corner k -> k+1): 0 none, 1 in->out, 2 out->in */
    for (int k = 0; k < 4; k++) {
        int k1 = (k + 1) & 3;
        kind[k] = sgn[k] == sgn[k1] ? 0 : sgn[k] ? 1 : 2;
        if (!kind[k]) continue;
        /* the dike of side k, walked from its lower end */
        int along = (k == 0 || k == 2) ? (w + 1) % 3 : (w + 2) % 3;
        static const int lower_corner[4] = {0, 1, 3, 0};
        int lowc = lower_corner[k];
        int64_t from[3], at[3];
        plane_point(w, cw, cu[lowc], cv[lowc], from);
        dike_crossing(c, from, along, (k == 0 || k == 2) ? su : sv, at);
        vm_status s = edge_point(c, P, at, along, &id[k], err);
        if (s) return s;
    }
    int joined = 1;
    if (n_in == 2 && sgn[0] == sgn[2]) {
        int fail = 0;
        joined = padi_joined(c, w, cw, u0, v0, su, sv, sgn[0] ? 0 : 1, &sc->m, &sc->mcap,
                             &sc->q, &sc->qcap, &fail);
        if (fail) return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    }
    for (int k = 0; k < 4; k++) {
        if (kind[k] != 1) continue;
        int o = k;
        do
            o = joined ? (o + 1) & 3 : (o + 3) & 3;
        while (kind[o] != 2);
        vm_status s = VM_OK;
        if (up >= 0) s = push_seg(S, up, id[k], id[o], err);
        if (!s && down >= 0) s = push_seg(S, down, id[o], id[k], err);
        if (s) return s;
    }
    return VM_OK;
}

static int face_cmp(const void *pa, const void *pb) {
    const asc_face *a = pa, *b = pb;
    if (a->w != b->w) return a->w < b->w ? -1 : 1;
    if (a->c != b->c) return a->c < b->c ? -1 : 1;
    return 0;
}

/* ---- loops and triangles ------------------------------------------------------------- */

typedef struct asc_tris {
    int32_t *v;
    size_t n, cap; /* triangles */
} asc_tris;

static vm_status push_tri(asc_tris *T, int32_t a, int32_t b, int32_t c, vm_error *err) {
    if (vm__grow((void **)&T->v, &T->cap, 3 * (T->n + 1), sizeof(int32_t), err))
        return VM_ERR_NOMEM;
    T->v[3 * T->n] = a;
    T->v[3 * T->n + 1] = b;
    T->v[3 * T->n + 2] = c;
    T->n++;
    return VM_OK;
}

/* 1 when padded points x and y lie on a common face plane of box b. */
static int on_common_face(const asc_box *b, const double *x, const double *y) {
    for (int a = 0; a < 3; a++) {
        double p0 = b->lo[a], p1 = (double)b->lo[a] + b->sz[a];
        if ((x[a] == p0 && y[a] == p0) || (x[a] == p1 && y[a] == p1)) return 1;
    }
    return 0;
}

/* The smallest angle (radians) of triangle a b c. */
static double tri_min_angle(const double *a, const double *b, const double *c) {
    const double *p[3] = {a, b, c};
    double best = 4;
    for (int i = 0; i < 3; i++) {
        const double *o = p[i], *q = p[(i + 1) % 3], *r = p[(i + 2) % 3];
        double u[3], v[3], uu = 0, vv = 0, uv = 0;
        for (int k = 0; k < 3; k++) {
            u[k] = q[k] - o[k];
            v[k] = r[k] - o[k];
            uu += u[k] * u[k];
            vv += v[k] * v[k];
            uv += u[k] * v[k];
        }
        double den = sqrt(uu * vv);
        double cs = den > 0 ? uv / den : 1;
        if (cs > 1) cs = 1;
        if (cs < -1) cs = -1;
        double ang = acos(cs);
        if (ang < best) best = ang;
    }
    return best;
}

/* Twice the signed area of the 2-D triangle o a b (positive counter-clockwise). */
static double cross2(const double *o, const double *a, const double *b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

typedef struct asc_loopbuf {
    int32_t *ids;
    size_t cap;
    double *uv;
    size_t uvcap;
    int32_t *live;
    size_t livecap;
} asc_loopbuf;

/* Trilinear value of the padded field at x (padded coordinates). */
static double field_at(const asc_ctx *c, const double x[3]) {
    int64_t i0[3];
    double t[3];
    for (int a = 0; a < 3; a++) {
        double f = floor(x[a]);
        i0[a] = (int64_t)f;
        t[a] = x[a] - f;
    }
    double s = 0;
    for (int k = 0; k < 8; k++) {
        int64_t p[3];
        double w = 1;
        for (int a = 0; a < 3; a++) {
            int bit = (k >> a) & 1;
            p[a] = i0[a] + bit;
            w *= bit ? t[a] : 1 - t[a];
        }
        if (w != 0) s += w * value_at(c, p);
    }
    return s;
}

/* Moves x along the unit vector d onto the zero of the trilinear field, staying at least
 * `margin` inside box b. Returns the signed distance moved, or NAN when no zero is found. */
static double project_inside(const asc_ctx *c, const asc_box *b, double x[3], const double d[3],
                             double margin) {
    double tmin = -INFINITY, tmax = INFINITY;
    for (int a = 0; a < 3; a++) {
        double lo = b->lo[a] + margin, hi = (double)b->lo[a] + b->sz[a] - margin;
        if (x[a] < lo || x[a] > hi) return NAN;
        if (fabs(d[a]) < 1e-12) continue;
        double t1 = (lo - x[a]) / d[a], t2 = (hi - x[a]) / d[a];
        if (t1 > t2) {
            double t = t1;
            t1 = t2;
            t2 = t;
        }
        if (t1 > tmin) tmin = t1;
        if (t2 < tmax) tmax = t2;
    }
    double y[3];
    enum { STEPS = 8 };
    double best = NAN;
    double fp = field_at(c, x);
    if (fp == 0) return 0;
    /* march outward from t = 0 in both directions, nearest sign change first */
    for (int side = 0; side < 2; side++) {
        double lim = side ? tmin : tmax;
        double prev_t = 0, prev_f = fp;
        for (int k = 1; k <= STEPS; k++) {
            double t = lim * k / STEPS;
            for (int a = 0; a < 3; a++)
                y[a] = x[a] + t * d[a];
            double f = field_at(c, y);
            if ((f >= 0) != (prev_f >= 0)) {
                double lo_t = prev_t, hi_t = t, lo_f = prev_f;
                for (int it = 0; it < 24; it++) {
                    double m = 0.5 * (lo_t + hi_t);
                    for (int a = 0; a < 3; a++)
                        y[a] = x[a] + m * d[a];
                    double fm = field_at(c, y);
                    if ((fm >= 0) == (lo_f >= 0)) {
                        lo_t = m;
                        lo_f = fm;
                    } else {
                        hi_t = m;
                    }
                }
                double r = 0.5 * (lo_t + hi_t);
                if (isnan(best) || fabs(r) < fabs(best)) best = r;
                break;
            }
            prev_t = t;
            prev_f = f;
        }
    }
    if (isnan(best)) return NAN;
    for (int a = 0; a < 3; a++)
        x[a] += best * d[a];
    return best;
}

/* The Newell normal nrm (not normalised; its length is returned) and the centroid cen of
 * loop ids[0..n). */
static double loop_normal(const asc_points *P, const int32_t *ids, size_t n, double nrm[3],
                          double cen[3]) {
    for (int a = 0; a < 3; a++)
        nrm[a] = cen[a] = 0;
    for (size_t i = 0; i < n; i++) {
        const double *p = P->xyz + 3 * ids[i], *q = P->xyz + 3 * ids[(i + 1) % n];
        nrm[0] += (p[1] - q[1]) * (p[2] + q[2]);
        nrm[1] += (p[2] - q[2]) * (p[0] + q[0]);
        nrm[2] += (p[0] - q[0]) * (p[1] + q[1]);
        for (int a = 0; a < 3; a++)
            cen[a] += p[a];
    }
    for (int a = 0; a < 3; a++)
        cen[a] /= (double)n;
    return sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
}

/* The loop's points projected on the plane through cen with unit normal nrm, in an
 * orthonormal frame (e1, e2, nrm): lb->uv (2 n); lb->live = 0..n-1. */
static vm_status loop_project(const asc_points *P, const int32_t *ids, size_t n,
                              const double nrm[3], const double cen[3], asc_loopbuf *lb,
                              vm_error *err) {
    double e1[3], e2[3];
    int m = fabs(nrm[0]) < fabs(nrm[1]) ? (fabs(nrm[0]) < fabs(nrm[2]) ? 0 : 2)
                                        : (fabs(nrm[1]) < fabs(nrm[2]) ? 1 : 2);
    double ax[3] = {0, 0, 0};
    ax[m] = 1;
    e1[0] = ax[1] * nrm[2] - ax[2] * nrm[1];
    e1[1] = ax[2] * nrm[0] - ax[0] * nrm[2];
    e1[2] = ax[0] * nrm[1] - ax[1] * nrm[0];
    double l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    for (int a = 0; a < 3; a++)
        e1[a] /= l1;
    e2[0] = nrm[1] * e1[2] - nrm[2] * e1[1];
    e2[1] = nrm[2] * e1[0] - nrm[0] * e1[2];
    e2[2] = nrm[0] * e1[1] - nrm[1] * e1[0];
    if (vm__grow((void **)&lb->uv, &lb->uvcap, 2 * n, sizeof(double), err) ||
        vm__grow((void **)&lb->live, &lb->livecap, n, sizeof(int32_t), err))
        return VM_ERR_NOMEM;
    for (size_t i = 0; i < n; i++) {
        const double *p = P->xyz + 3 * ids[i];
        double d[3] = {p[0] - cen[0], p[1] - cen[1], p[2] - cen[2]};
        lb->uv[2 * i] = d[0] * e1[0] + d[1] * e1[1] + d[2] * e1[2];
        lb->uv[2 * i + 1] = d[0] * e2[0] + d[1] * e2[1] + d[2] * e2[2];
        lb->live[i] = (int32_t)i;
    }
    return VM_OK;
}

/* The live ear (index into lb->live[0..m_live)) whose triangle has the largest smallest
 * angle: convex in the projection, not a chord along one box face, no other live point
 * inside; -1 when there is none. */
static long best_ear(const asc_points *P, const asc_box *b, const int32_t *ids,
                     const asc_loopbuf *lb, size_t m_live) {
    double best = -1;
    size_t bi = 0;
    for (size_t i = 0; i < m_live; i++) {
        int32_t ia = lb->live[(i + m_live - 1) % m_live], ib = lb->live[i],
                ic = lb->live[(i + 1) % m_live];
        const double *A = lb->uv + 2 * ia, *B = lb->uv + 2 * ib, *C = lb->uv + 2 * ic;
        if (cross2(A, B, C) <= ASC_EAR_EPS) continue;
        if (on_common_face(b, P->xyz + 3 * ids[ia], P->xyz + 3 * ids[ic])) continue;
        int clear = 1;
        for (size_t j = 0; j < m_live && clear; j++) {
            int32_t ij = lb->live[j];
            if (ij == ia || ij == ib || ij == ic) continue;
            const double *Q = lb->uv + 2 * ij;
            if (cross2(A, B, Q) >= -ASC_EAR_EPS && cross2(B, C, Q) >= -ASC_EAR_EPS &&
                cross2(C, A, Q) >= -ASC_EAR_EPS)
                clear = 0;
        }
        if (!clear) continue;
        double q =
            tri_min_angle(P->xyz + 3 * ids[ia], P->xyz + 3 * ids[ib], P->xyz + 3 * ids[ic]);
        if (q > best) {
            best = q;
            bi = i;
        }
    }
    return best < 0 ? -1 : (long)bi;
}

/* Ear removal on the projected loop (loop_project): triangles into T; *ok = 0 when the ears
 * run out or the last one is flat (T then holds a partial triangulation). */
static vm_status clip_ears(const asc_points *P, const asc_box *b, const int32_t *ids, size_t n,
                           asc_loopbuf *lb, asc_tris *T, int *ok, vm_error *err) {
    size_t m_live = n;
    while (*ok && m_live > 3) {
        long e = best_ear(P, b, ids, lb, m_live);
        if (e < 0) {
            *ok = 0;
            break;
        }
        size_t bi = (size_t)e;
        int32_t ia = lb->live[(bi + m_live - 1) % m_live], ib = lb->live[bi],
                ic = lb->live[(bi + 1) % m_live];
        vm_status s = push_tri(T, ids[ia], ids[ib], ids[ic], err);
        if (s) return s;
        memmove(lb->live + bi, lb->live + bi + 1, (m_live - bi - 1) * sizeof(int32_t));
        m_live--;
    }
    if (*ok && cross2(lb->uv + 2 * lb->live[0], lb->uv + 2 * lb->live[1],
                      lb->uv + 2 * lb->live[2]) <= ASC_EAR_EPS)
        *ok = 0;
    if (*ok) return push_tri(T, ids[lb->live[0]], ids[lb->live[1]], ids[lb->live[2]], err);
    return VM_OK;
}

/* Fans loop ids[0..n) from a new point at x. */
static vm_status fan_from(asc_points *P, const double x[3], const int32_t *ids, size_t n,
                          asc_tris *T, vm_error *err) {
    int32_t cid = -1;
    vm_status s = add_xyz(P, x, &cid, err);
    for (size_t i = 0; !s && i < n; i++)
        s = push_tri(T, cid, ids[i], ids[(i + 1) % n], err);
    return s;
}

/* Triangulates loop ids[0..n) (counter-clockwise seen from outside the material) inside
 * box b: ears in the projection on the loop's Newell plane, or a fan from the centroid. */
static vm_status triangulate(const asc_ctx *c, asc_points *P, const asc_box *b,
                             const int32_t *ids, size_t n, asc_loopbuf *lb, asc_tris *T,
                             vm_error *err) {
    if (n < 3) return vm_error_set(err, VM_ERR_INTERNAL, "surface asc: loop of %zu points", n);
    int unit = b->sz[0] == 1 && b->sz[1] == 1 && b->sz[2] == 1;
    if (n == 3 && unit) return push_tri(T, ids[0], ids[1], ids[2], err);
    double nrm[3], cen[3];
    double nl = loop_normal(P, ids, n, nrm, cen);
    size_t t0 = T->n;
    int ok = nl > ASC_FLAT_LOOP;
    if (ok) {
        for (int a = 0; a < 3; a++)
            nrm[a] /= nl;
        vm_status s = loop_project(P, ids, n, nrm, cen, lb, err);
        if (s) return s;
        /* where the surface bulges away from the loop, a vertex on the surface inside the
         * box, fanned to the loop, follows it better than the loop's own triangles */
        double sp[3] = {cen[0], cen[1], cen[2]};
        double moved = project_inside(c, b, sp, nrm, ASC_BULGE_TOL);
        if (!unit && !isnan(moved) && fabs(moved) > ASC_BULGE_FRACTION * c->error) {
            int star = 1;
            for (size_t i = 0; i < n && star; i++)
                star = cross2((const double[2]){0, 0}, lb->uv + 2 * i,
                              lb->uv + 2 * ((i + 1) % n)) > ASC_STAR_EPS;
            if (star) return fan_from(P, sp, ids, n, T, err);
        }
        s = clip_ears(P, b, ids, n, lb, T, &ok, err);
        if (s) return s;
    }
    if (ok) return VM_OK;
    /* fan from the centroid, which lies inside the box: a loop never runs on one face */
    T->n = t0;
    return fan_from(P, cen, ids, n, T, err);
}

/* ---- the driver ------------------------------------------------------------------------ */

/* Sets up c for grid g: the padded sizes, the block-aligned domain and the inside flags;
 * *B is the block size 2^max_level. */
static vm_status asc_grid_init(asc_ctx *c, const vm__surface_grid *g,
                               const vm_surface_options *o, int32_t *B, vm_error *err) {
    memset(c, 0, sizeof *c);
    c->g = g;
    c->error = o->error;
    int level = o->max_level < 0 ? 0 : o->max_level;
    *B = (int32_t)1 << level;
    size_t count = 1;
    for (int a = 0; a < 3; a++) {
        c->n[a] = g->n[a] + 2;
        if (c->n[a] > INT32_MAX / 2)
            return vm_error_set(err, VM_ERR_UNSUPPORTED, "surface asc: grid too large");
        c->dom[a] = ((c->n[a] - 1 + *B - 1) / *B) * *B;
    }
    if (vm__check_dims(c->n, 1, "surface asc", &count, err)) return VM_ERR_NOMEM;
    c->in = malloc(count);
    if (!c->in) return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    for (int64_t k = 0; k < c->n[2]; k++)
        for (int64_t j = 0; j < c->n[1]; j++)
            for (int64_t i = 0; i < c->n[0]; i++)
                c->in[i + c->n[0] * (j + c->n[1] * k)] =
                    vm__surface_at(g, i - 1, j - 1, k - 1) >= 0;
    return VM_OK;
}

/* 3-skeleton: the simple boxes of every block of B^3 cells, appended to boxes. */
static vm_status climb_blocks(asc_ctx *c, int32_t B, asc_boxes *boxes, vm_error *err) {
    vm_status s = VM_OK;
    for (int32_t bz = 0; !s && bz < c->dom[2]; bz += B)
        for (int32_t by = 0; !s && by < c->dom[1]; by += B)
            for (int32_t bx = 0; !s && bx < c->dom[0]; bx += B) {
                int32_t lo[3] = {bx, by, bz}, sz[3] = {B, B, B};
                s = build(c, lo, sz, -1, 0, boxes, err);
            }
    if (!s && boxes->n > (size_t)INT32_MAX / 6)
        s = vm_error_set(err, VM_ERR_NOMEM, "surface asc: too many boxes");
    return s;
}

/* The six faces of every box, sorted by plane (face_cmp) into *faces (6 boxes->n). */
static vm_status box_faces(const asc_boxes *boxes, asc_face **faces, size_t *nf,
                           vm_error *err) {
    *nf = 0;
    *faces = malloc((6 * boxes->n + 1) * sizeof **faces);
    if (!*faces) return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    for (size_t i = 0; i < boxes->n; i++) {
        const asc_box *b = boxes->v + i;
        for (int w = 0; w < 3; w++)
            for (int side = 0; side < 2; side++) {
                asc_face *f = *faces + (*nf)++;
                f->w = w;
                f->c = b->lo[w] + (side ? b->sz[w] : 0);
                f->box = (int32_t)i;
                f->above = !side;
                f->u0 = b->lo[(w + 1) % 3];
                f->v0 = b->lo[(w + 2) % 3];
                f->su = b->sz[(w + 1) % 3];
                f->sv = b->sz[(w + 2) % 3];
            }
    }
    qsort(*faces, *nf, sizeof **faces, face_cmp);
    return VM_OK;
}

/* Writes value (the face's index, or -1 to clear) into the cells of faces f0..f1 of one
 * plane: mapA for faces above the plane, mapB below; du is the map's row length. */
static void paint_faces(const asc_face *faces, size_t f0, size_t f1, int64_t du, int32_t *mapA,
                        int32_t *mapB, int clear) {
    for (size_t f = f0; f < f1; f++) {
        int32_t *map = faces[f].above ? mapA : mapB;
        for (int32_t v = 0; v < faces[f].sv; v++)
            for (int32_t u = 0; u < faces[f].su; u++)
                map[(faces[f].u0 + u) + du * (faces[f].v0 + v)] = clear ? -1 : (int32_t)f;
    }
}

/* The padis of one plane (faces f0..f1, painted into mapB): every face pair (above, below)
 * meets in one rectangle, visited at its corner, whose iso lines go to S. */
static vm_status plane_padis(asc_ctx *c, asc_points *P, asc_segs *S, asc_scratch *sc,
                             const asc_face *faces, size_t f0, size_t f1, int64_t du,
                             const int32_t *mapB, vm_error *err) {
    vm_status s = VM_OK;
    int w = faces[f0].w;
    for (size_t f = f0; !s && f < f1; f++) {
        const asc_face *fa = faces + f;
        if (!fa->above) continue;
        for (int32_t v = 0; !s && v < fa->sv; v++)
            for (int32_t u = 0; !s && u < fa->su; u++) {
                int64_t cell = (fa->u0 + u) + du * (fa->v0 + v);
                int32_t ib = mapB[cell];
                if (ib < 0) continue;
                const asc_face *fb = faces + ib;
                int32_t pu = fa->u0 > fb->u0 ? fa->u0 : fb->u0;
                int32_t pv = fa->v0 > fb->v0 ? fa->v0 : fb->v0;
                if (fa->u0 + u != pu || fa->v0 + v != pv) continue;
                int32_t eu =
                    fa->u0 + fa->su < fb->u0 + fb->su ? fa->u0 + fa->su : fb->u0 + fb->su;
                int32_t ev =
                    fa->v0 + fa->sv < fb->v0 + fb->sv ? fa->v0 + fa->sv : fb->v0 + fb->sv;
                s = padi_lines(c, P, S, sc, w, fa->c, pu, pv, eu - pu, ev - pv, fa->box,
                               fb->box, err);
            }
    }
    return s;
}

/* Information sharing: the box faces on each plane overlaid, the iso lines of their padis
 * appended to S (points to P). */
static vm_status share_faces(asc_ctx *c, const asc_boxes *boxes, asc_points *P, asc_segs *S,
                             asc_scratch *sc, vm_error *err) {
    asc_face *faces = NULL;
    int32_t *mapA = NULL, *mapB = NULL;
    size_t nf = 0;
    vm_status s = box_faces(boxes, &faces, &nf, err);
    int64_t mapn = 0;
    for (int w = 0; w < 3; w++) {
        int64_t area = c->dom[(w + 1) % 3] * c->dom[(w + 2) % 3];
        if (area > mapn) mapn = area;
    }
    if (!s) {
        mapA = malloc((size_t)mapn * sizeof *mapA);
        mapB = malloc((size_t)mapn * sizeof *mapB);
        if (!mapA || !mapB)
            s = vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
        else {
            for (int64_t i = 0; i < mapn; i++)
                mapA[i] = mapB[i] = -1;
        }
    }
    for (size_t f0 = 0; !s && f0 < nf;) {
        size_t f1 = f0;
        while (f1 < nf && faces[f1].w == faces[f0].w && faces[f1].c == faces[f0].c)
            f1++;
        int64_t du = c->dom[(faces[f0].w + 1) % 3];
        paint_faces(faces, f0, f1, du, mapA, mapB, 0);
        s = plane_padis(c, P, S, sc, faces, f0, f1, du, mapB, err);
        /* a face region with no box on the other side borders a box without surface,
         * whose samples all have one sign: no iso line there */
        paint_faces(faces, f0, f1, du, mapA, mapB, 1);
        f0 = f1;
    }
    free(faces);
    free(mapA);
    free(mapB);
    return s;
}

/* The segments of S bucketed by box: those of box b are sorted[start[b] .. start[b+1]). */
static vm_status bucket_segs(const asc_segs *S, size_t nboxes, int32_t *start, asc_seg *sorted,
                             vm_error *err) {
    for (size_t i = 0; i < S->n; i++)
        start[S->v[i].box + 1]++;
    for (size_t i = 0; i < nboxes; i++)
        start[i + 1] += start[i];
    int32_t *fill = malloc((nboxes + 1) * sizeof *fill);
    if (!fill) return vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    memcpy(fill, start, (nboxes + 1) * sizeof *fill);
    for (size_t i = 0; i < S->n; i++)
        sorted[fill[S->v[i].box]++] = S->v[i];
    free(fill);
    return VM_OK;
}

/* Closes the segments sg[0..n) of box b into loops (next: all -1 on entry and on return)
 * and triangulates each loop into T. */
static vm_status box_loops(const asc_ctx *c, asc_points *P, const asc_box *b,
                           const asc_seg *sg, int32_t n, int32_t *next, asc_loopbuf *lb,
                           asc_tris *T, vm_error *err) {
    vm_status s = VM_OK;
    for (int32_t i = 0; i < n && !s; i++) {
        if (next[sg[i].a] >= 0)
            s = vm_error_set(err, VM_ERR_INTERNAL, "surface asc: two iso lines leave a point");
        next[sg[i].a] = sg[i].b;
    }
    for (int32_t i = 0; i < n && !s; i++) {
        int32_t v0 = sg[i].a;
        if (next[v0] < 0) continue; /* already on a loop */
        size_t m = 0;
        int32_t v = v0;
        while (v >= 0 && next[v] >= 0) {
            if (vm__grow((void **)&lb->ids, &lb->cap, m + 1, sizeof(int32_t), err)) {
                s = VM_ERR_NOMEM;
                break;
            }
            lb->ids[m++] = v;
            int32_t nx = next[v];
            next[v] = -1;
            v = nx;
        }
        if (s) break;
        if (v != v0) {
            s = vm_error_set(err, VM_ERR_INTERNAL, "surface asc: open iso line in a box");
            break;
        }
        s = triangulate(c, P, b, lb->ids, m, lb, T, err);
    }
    for (int32_t i = 0; i < n; i++)
        next[sg[i].a] = -1;
    return s;
}

/* Loops per box, then their triangles into T. */
static vm_status all_loops(const asc_ctx *c, const asc_boxes *boxes, asc_points *P,
                           const asc_segs *S, asc_tris *T, asc_loopbuf *lb, vm_error *err) {
    vm_status s = VM_OK;
    int32_t *start = calloc(boxes->n + 1, sizeof *start);
    int32_t *next = malloc((P->n + 1) * sizeof *next);
    asc_seg *sorted = NULL;
    if (!start || !next) s = vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    if (!s) {
        sorted = malloc((S->n + 1) * sizeof *sorted);
        if (!sorted) s = vm_error_set(err, VM_ERR_NOMEM, "surface asc: out of memory");
    }
    if (!s) {
        s = bucket_segs(S, boxes->n, start, sorted, err);
        for (size_t i = 0; i < P->n; i++)
            next[i] = -1;
    }
    /* P grows in triangulate, past the P->n that sized next, only by points on no segment */
    for (size_t bi = 0; !s && bi < boxes->n; bi++) {
        int32_t s0 = start[bi], s1 = start[bi + 1];
        if (s0 == s1) continue;
        s = box_loops(c, P, boxes->v + bi, sorted + s0, s1 - s0, next, lb, T, err);
    }
    free(sorted);
    free(next);
    free(start);
    return s;
}

/* Appends the points of P (back to unpadded grid index coordinates) and the triangles of T
 * to surf. */
static vm_status emit_surface(const vm__surface_grid *g, const asc_points *P, const asc_tris *T,
                              vm_mesh *surf, vm_error *err) {
    vm_status s = vm_mesh_reserve(surf, surf->npoints + P->n, surf->ncells + T->n, err);
    size_t base = surf->npoints;
    for (size_t i = 0; !s && i < P->n; i++) {
        double x[3] = {P->xyz[3 * i] - 1, P->xyz[3 * i + 1] - 1, P->xyz[3 * i + 2] - 1};
        /* The points between the border samples and the padding close the material; the
         * padding layer is pressed onto the box, x -> BORDER_SQUEEZE x outside [0, n-1]
         * per axis (monotone, so the surface stays embedded), and the closing faces lie
         * within BORDER_SQUEEZE voxels of the box planes (DESIGN: flat faces on the box). */
        for (int a = 0; a < 3; a++) {
            double top = (double)(g->n[a] - 1);
            if (x[a] < 0) x[a] *= BORDER_SQUEEZE;
            else if (x[a] > top) x[a] = top + BORDER_SQUEEZE * (x[a] - top);
        }
        if (vm_mesh_add_point(surf, x, err) < 0) s = VM_ERR_NOMEM;
    }
    for (size_t t = 0; !s && t < T->n; t++) {
        vm_index f[3];
        for (int k = 0; k < 3; k++)
            f[k] = (vm_index)(base + (size_t)T->v[3 * t + k]);
        s = vm_mesh_add_cell(surf, f, 1, err);
    }
    return s;
}

/* The surface of g by adaptive skeleton climbing, appended to surf: simple boxes, the iso
 * lines they share, their loops triangulated. */
vm_status vm__surface_asc(const vm__surface_grid *g, const vm_surface_options *o, vm_mesh *surf,
                          vm_surface_stats *st, vm_error *err) {
    asc_ctx c;
    int32_t B = 1;
    vm_status s = asc_grid_init(&c, g, o, &B, err);
    if (s) return s;
    asc_boxes boxes = {0};
    asc_points P;
    memset(&P, 0, sizeof P);
    asc_segs S = {0};
    asc_tris T = {0};
    asc_scratch sc;
    memset(&sc, 0, sizeof sc);
    asc_loopbuf lb;
    memset(&lb, 0, sizeof lb);

    s = climb_blocks(&c, B, &boxes, err);
    if (!s) s = share_faces(&c, &boxes, &P, &S, &sc, err);
    if (!s) s = all_loops(&c, &boxes, &P, &S, &T, &lb, err);
    if (!s) s = emit_surface(g, &P, &T, surf, err);
    if (st) st->cells_visited = c.visited;

    free(c.in);
    free(c.pts);
    free(c.mark);
    free(c.queue);
    free(boxes.v);
    free(P.keys);
    free(P.ids);
    free(P.xyz);
    free(S.v);
    free(T.v);
    free(sc.m);
    free(sc.q);
    free(lb.ids);
    free(lb.uv);
    free(lb.live);
    return s;
}
