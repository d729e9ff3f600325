/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_octree.c — the octree of the graded mesher, sized in world units: a cell the
 * surface crosses stays coarse only when its whole subtree passes the topology-safety test of
 * Ju et al. (2002, §4.2: simple corner configurations, midpoints agreeing with a corner) and
 * the fine surface lies within the distance bound of the plane fitting its crossings of the
 * cell's edges (the chord error stuffing makes); then 2:1 balance over faces, edges and
 * corners (Sundar, Sampath and Biros 2008). */
#include "../core/core.h"
#include "graded_config.h"
#include "graded_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static vm_status grow(gr_tree *t, size_t more, vm_error *err) {
    if (t->n + more <= t->cap) return VM_OK;
    size_t cap = t->cap ? t->cap : 1024;
    while (cap < t->n + more)
        cap *= 2;
    if (cap > (size_t)INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: the octree needs over 2^31 cells");
    gr_node *nn = realloc(t->node, cap * sizeof *nn);
    if (!nn) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    t->node = nn;
    t->cap = cap;
    return VM_OK;
}

vm_status vm__gr_tree_split(gr_tree *t, size_t leaf, vm_error *err) {
    vm_status s = grow(t, 8, err);
    if (s) return s;
    gr_node *p = &t->node[leaf];
    int32_t half = (int32_t)1 << p->level; /* child edge in lattice units */
    p->child = (int32_t)t->n;
    for (int c = 0; c < 8; c++) {
        gr_node *q = &t->node[t->n + (size_t)c];
        q->child = -1;
        q->level = p->level - 1;
        q->exact = 0;
        for (int d = 0; d < 3; d++)
            q->a[d] = p->a[d] + ((c >> d) & 1) * half;
    }
    t->n += 8;
    t->leaves += 7;
    return VM_OK;
}

int64_t vm__gr_tree_find(const gr_tree *t, const int64_t p[3], int level) {
    int64_t size = (int64_t)2 << t->root_level;
    for (int d = 0; d < 3; d++)
        if (p[d] < 0 || p[d] >= size) return -1;
    int64_t at = 0;
    while (t->node[at].child >= 0 && t->node[at].level > level) {
        const gr_node *q = &t->node[at];
        int64_t half = (int64_t)1 << q->level;
        int c = 0;
        for (int d = 0; d < 3; d++)
            if (p[d] >= q->a[d] + half) c |= 1 << d;
        at = q->child + c;
    }
    return at;
}

/* World box of a node in the scaled index frame. */
static void node_box(const gr_tree *t, const gr_node *q, double lo[3], double hi[3]) {
    for (int d = 0; d < 3; d++) {
        lo[d] = t->u0[d] + (double)q->a[d] * 0.5 * t->h0[d];
        hi[d] = lo[d] + t->h0[d] * (double)((int64_t)1 << q->level);
    }
}

/* 1: every point of the box is inside, -1: every point is outside, 0: mixed or unknown. */
static int classify(const gr_field *f, const double lo[3], const double hi[3]) {
    int64_t i0[3], i1[3];
    int whole = 1;
    for (int d = 0; d < 3; d++) {
        double a = lo[d] / f->sp[d], b = hi[d] / f->sp[d];
        if (b < 0 || a > (double)(f->n[d] - 1)) return -1;
        if (a < 0 || b > (double)(f->n[d] - 1)) whole = 0;
        i0[d] = a < 0 ? 0 : (int64_t)floor(a);
        i1[d] = b > (double)(f->n[d] - 1) ? f->n[d] - 1 : (int64_t)ceil(b);
        i0[d] /= GR_BLOCK;
        i1[d] /= GR_BLOCK;
        if (i1[d] >= f->nb[d]) i1[d] = f->nb[d] - 1;
        if (i0[d] > i1[d]) i0[d] = i1[d];
    }
    float mn = INFINITY, mx = -INFINITY;
    for (int64_t z = i0[2]; z <= i1[2]; z++)
        for (int64_t y = i0[1]; y <= i1[1]; y++)
            for (int64_t x = i0[0]; x <= i1[0]; x++) {
                size_t at = (size_t)(x + f->nb[0] * (y + f->nb[1] * z));
                if (f->bmin[at] < mn) mn = f->bmin[at];
                if (f->bmax[at] > mx) mx = f->bmax[at];
            }
    int all_in = (!f->has_lo || mn >= f->lo) && (!f->has_hi || mx <= f->hi);
    int all_out = (f->has_lo && mx < f->lo) || (f->has_hi && mn > f->hi);
    if (all_out) return -1;
    if (all_in) return whole ? 1 : 0;
    return 0;
}

/* Sign of phi at the corners of a node's box and the mask of inside corners. */
static int corner_values(const gr_tree *t, const gr_field *f, const gr_node *q, double c[8]) {
    double lo[3], hi[3];
    node_box(t, q, lo, hi);
    int mask = 0;
    for (int k = 0; k < 8; k++) {
        double u[3] = {(k & 1) ? hi[0] : lo[0], (k & 2) ? hi[1] : lo[1],
                       (k & 4) ? hi[2] : lo[2]};
        c[k] = vm__gr_phi(f, u);
        if (c[k] >= 0) mask |= 1 << k;
    }
    return mask;
}

/* The topology-safety test of Ju et al. (2002, §4.2) at the 19 points between the corners:
 * the middle of each edge agrees in sign with one end, the middle of each face with one of
 * its corners, the centre with one corner. */
static int midpoints_agree(const gr_tree *t, const gr_field *f, const gr_node *q, int mask) {
    double lo[3], hi[3];
    node_box(t, q, lo, hi);
    for (int m = 0; m < 27; m++) {
        int x[3] = {m % 3, (m / 3) % 3, m / 9}, mids = 0;
        for (int d = 0; d < 3; d++)
            mids += x[d] == 1;
        if (mids == 0) continue;
        double u[3];
        for (int d = 0; d < 3; d++)
            u[d] = lo[d] + 0.5 * (double)x[d] * (hi[d] - lo[d]);
        int in = vm__gr_phi(f, u) >= 0, agree = 0;
        for (int k = 0; k < 8 && !agree; k++) {
            int on = 1; /* corner k belongs to the edge, face or cube of point m */
            for (int d = 0; d < 3; d++)
                if (x[d] != 1 && x[d] / 2 != ((k >> d) & 1)) on = 0;
            if (on && ((mask >> k) & 1) == in) agree = 1;
        }
        if (!agree) return 0;
    }
    return 1;
}

/* Where the field (constant `out` beyond the box) crosses zero between a and b (values fa,
 * fb of opposite signs), by bisection. */
static void crossing(const gr_field *f, const double a[3], const double b[3], double fa,
                     double p[3]) {
    double lo = 0, hi = 1;
    for (int it = 0; it < 40; it++) {
        double m = 0.5 * (lo + hi), u[3];
        for (int d = 0; d < 3; d++)
            u[d] = a[d] + m * (b[d] - a[d]);
        if ((vm__gr_phi(f, u) >= 0) == (fa >= 0))
            lo = m;
        else
            hi = m;
    }
    double m = 0.5 * (lo + hi);
    for (int d = 0; d < 3; d++)
        p[d] = a[d] + m * (b[d] - a[d]);
}

/* The distance test: the surface crosses the cell's edges at points whose plane (through
 * their centroid, normal to the field's gradient there) stands for the coarse surface; every
 * crossing of the fine surface on a voxel edge in the cell lies within the bound of it. This
 * is the chord error the stuffed triangles make (they join exact surface points on the
 * lattice's edges), where the trilinear reading of the corners alone would overstate it. */
static int within_distance(const gr_tree *t, const gr_field *f, const gr_sizing *sz,
                           const gr_node *q, const double c[8]) {
    double lo[3], hi[3], ctr[3] = {0, 0, 0}, n[3] = {0, 0, 0}, pt[12][3];
    node_box(t, q, lo, hi);
    int np = 0;
    for (int k = 0; k < 8; k++)
        for (int d = 0; d < 3; d++) {
            int k2 = k | 1 << d;
            if (k2 == k || (c[k] >= 0) == (c[k2] >= 0)) continue;
            double a[3], b[3], p[3];
            for (int x = 0; x < 3; x++) {
                a[x] = (k >> x & 1) ? hi[x] : lo[x];
                b[x] = (k2 >> x & 1) ? hi[x] : lo[x];
            }
            crossing(f, a, b, c[k], p);
            for (int x = 0; x < 3; x++) {
                ctr[x] += p[x];
                pt[np][x] = p[x];
            }
            np++;
        }
    int64_t i0[3], i1[3];
    for (int d = 0; d < 3; d++) {
        double a = ceil(lo[d] / f->sp[d] - 1e-9), b = floor(hi[d] / f->sp[d] + 1e-9);
        if (a < 0) a = 0;
        if (b > (double)(f->n[d] - 1)) b = (double)(f->n[d] - 1);
        i0[d] = (int64_t)a;
        i1[d] = (int64_t)b;
        if (i0[d] > i1[d]) return 1; /* no voxel in the cell */
    }
    if (np >= 3) {
        /* The plane that fits the crossings best: the covariance's null direction, taken
         * from the cofactor row of the largest 2x2 determinant. */
        double cv[3][3] = {{0}};
        for (int d = 0; d < 3; d++)
            ctr[d] /= np;
        for (int k = 0; k < np; k++)
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    cv[a][b] += (pt[k][a] - ctr[a]) * (pt[k][b] - ctr[b]);
        double dx = cv[1][1] * cv[2][2] - cv[1][2] * cv[1][2];
        double dy = cv[0][0] * cv[2][2] - cv[0][2] * cv[0][2];
        double dz = cv[0][0] * cv[1][1] - cv[0][1] * cv[0][1];
        if (dx >= dy && dx >= dz) {
            n[0] = dx;
            n[1] = cv[0][2] * cv[1][2] - cv[0][1] * cv[2][2];
            n[2] = cv[0][1] * cv[1][2] - cv[0][2] * cv[1][1];
        } else if (dy >= dz) {
            n[0] = cv[0][2] * cv[1][2] - cv[0][1] * cv[2][2];
            n[1] = dy;
            n[2] = cv[0][1] * cv[0][2] - cv[1][2] * cv[0][0];
        } else {
            n[0] = cv[0][1] * cv[1][2] - cv[0][2] * cv[1][1];
            n[1] = cv[0][1] * cv[0][2] - cv[1][2] * cv[0][0];
            n[2] = dz;
        }
        double gn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (!(gn > 0)) return 0;
        for (int d = 0; d < 3; d++)
            n[d] /= gn;
        for (int k = 0; k < np; k++) {
            double dist = 0;
            for (int d = 0; d < 3; d++)
                dist += n[d] * (pt[k][d] - ctr[d]);
            if (fabs(dist) > sz->distance) return 0;
        }
    }
    for (int64_t k = i0[2]; k <= i1[2]; k++)
        for (int64_t j = i0[1]; j <= i1[1]; j++)
            for (int64_t i = i0[0]; i <= i1[0]; i++) {
                double ph = vm__gr_phi_point(f, i, j, k);
                for (int d = 0; d < 3; d++) {
                    int64_t p2[3] = {i, j, k};
                    p2[d]++;
                    if (p2[d] > i1[d]) continue;
                    double ph2 = vm__gr_phi_point(f, p2[0], p2[1], p2[2]);
                    if ((ph >= 0) == (ph2 >= 0)) continue;
                    if (np < 3) return 0; /* the corners do not see this surface */
                    double s = ph / (ph - ph2), dist = 0;
                    double x[3] = {(double)i * f->sp[0], (double)j * f->sp[1],
                                   (double)k * f->sp[2]};
                    x[d] += s * f->sp[d];
                    for (int e = 0; e < 3; e++)
                        dist += n[e] * (x[e] - ctr[e]);
                    if (fabs(dist) > sz->distance) return 0;
                }
            }
    return 1;
}

/* Whether a crossed node may stand for its whole subtree (bottom up, as in the
 * simplification of Ju et al.): every crossed child may, the corners form a simple
 * configuration, the midpoints agree, and the cell is within the distance bound. */
static int collapsible(const gr_tree *t, const gr_field *f, const gr_sizing *sz,
                       const gr_node *q) {
    double c[8];
    int mask = corner_values(t, f, q, c);
    if (!vm__gr_config[mask].simple) return 0;
    if (q->level == 0) return 1;
    if (!midpoints_agree(t, f, q, mask)) return 0;
    int32_t half = (int32_t)1 << q->level;
    for (int k = 0; k < 8; k++) {
        gr_node ch = {-1,
                      {q->a[0] + (k & 1) * half, q->a[1] + ((k >> 1) & 1) * half,
                       q->a[2] + (k >> 2) * half},
                      q->level - 1, 0};
        double lo[3], hi[3];
        node_box(t, &ch, lo, hi);
        if (classify(f, lo, hi) == 0 && !collapsible(t, f, sz, &ch)) return 0;
    }
    return within_distance(t, f, sz, q, c);
}

static int wants_split(const gr_tree *t, const gr_field *f, const gr_sizing *sz,
                       const gr_node *q) {
    if (q->level == 0) return 0;
    double lo[3], hi[3];
    node_box(t, q, lo, hi);
    int c = classify(f, lo, hi);
    if (c < 0) return 0;
    if (q->level > t->max_level) return 1;
    /* the size field bounds the cell's longest edge */
    double edge = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    if (f->bsize &&
        vm__gr_edge_bound(edge, sz->distance) > vm__gr_size_min(f, lo, hi) * (1 + 1e-9))
        return 1;
    if (c != 0) return 0;
    return !collapsible(t, f, sz, q);
}

vm_status vm__gr_tree_build(gr_tree *t, const gr_field *f, const gr_sizing *sz, vm_error *err) {
    memset(t, 0, sizeof *t);
    vm__gr_config_init();
    t->distance = sz->distance;
    t->layers = sz->layers > 1 ? sz->layers : 1;
    double need = 0, hmax = 0;
    for (int d = 0; d < 3; d++) {
        t->h0[d] = sz->h0[d];
        t->u0[d] = -sz->h0[d];
        /* cells along this axis to cover the volume and a margin of one on each side */
        double ext = (double)(f->n[d] - 1) * f->sp[d] / sz->h0[d] + 2;
        if (ext > need) need = ext;
        if (sz->h0[d] > hmax) hmax = sz->h0[d];
    }
    int K = 0;
    while ((double)((int64_t)1 << K) < need - 1e-9) {
        if (++K > 19)
            return vm_error_set(err, VM_ERR_ARG,
                                "mesh: the volume spans over 2^19 cells of the smallest size; "
                                "raise --min-edge");
    }
    t->root_level = K;
    int ml = 0;
    while (ml < K && vm__gr_edge_bound(hmax * (double)((int64_t)2 << ml), sz->distance) <=
                         sz->max_edge * (1 + 1e-9))
        ml++;
    t->max_level = ml;
    vm_status s = grow(t, 1, err);
    if (s) return s;
    t->node[0] = (gr_node){-1, {0, 0, 0}, K, 0};
    t->n = 1;
    t->leaves = 1;
    /* Top down: a node's children are decided after it (the stack holds nodes to decide). */
    size_t *stack = malloc(64 * sizeof *stack), depth = 0, cap = 64;
    if (!stack) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    stack[depth++] = 0;
    while (depth) {
        size_t at = stack[--depth];
        if (!wants_split(t, f, sz, &t->node[at])) continue;
        if ((s = vm__gr_tree_split(t, at, err))) break;
        if (depth + 8 > cap) {
            size_t *ns = realloc(stack, 2 * cap * sizeof *ns);
            if (!ns) {
                s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
                break;
            }
            stack = ns;
            cap *= 2;
        }
        for (int c = 7; c >= 0; c--)
            stack[depth++] = (size_t)t->node[at].child + (size_t)c;
    }
    free(stack);
    return s;
}

vm_status vm__gr_tree_refine_crossed(gr_tree *t, const gr_field *f, const double *boxes,
                                     size_t nboxes, size_t *split, vm_error *err) {
    size_t n = t->n;
    *split = 0;
    for (size_t i = 0; i < n; i++) {
        if (t->node[i].child >= 0 || t->node[i].level == 0) continue;
        double lo[3], hi[3];
        node_box(t, &t->node[i], lo, hi);
        int meets = !boxes;
        for (size_t b = 0; b < nboxes && !meets; b++) {
            const double *B = boxes + 6 * b;
            meets = 1;
            for (int d = 0; d < 3; d++)
                if (hi[d] < B[d] || lo[d] > B[3 + d]) meets = 0;
        }
        if (!meets || classify(f, lo, hi) != 0) continue;
        vm_status s = vm__gr_tree_split(t, i, err);
        if (s) return s;
        ++*split;
    }
    return VM_OK;
}

vm_status vm__gr_tree_balance(gr_tree *t, vm_error *err) {
    size_t cap = t->leaves + 1024, n = 0;
    size_t *work = malloc(cap * sizeof *work);
    if (!work) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the balance");
    for (size_t i = 0; i < t->n; i++)
        if (t->node[i].child < 0) work[n++] = i;
    vm_status s = VM_OK;
    int64_t root = (int64_t)2 << t->root_level;
    /* Each leaf checks its 26 neighbours (out to t->layers cells); one two or more levels
     * coarser is split (its children join the work, as they may be too coarse for their own
     * neighbours). */
    while (n && !s) {
        size_t at = work[--n];
        if (t->node[at].child >= 0) continue;
        int lev = t->node[at].level;
        int64_t e = (int64_t)2 << lev;
        int m = t->layers, w = 2 * m + 1;
        for (int dir = 0; dir < w * w * w && !s; dir++) {
            if (dir == (w * w * w) / 2) continue;
            int64_t q[3];
            for (int d = 0, r = dir; d < 3; d++, r /= w)
                q[d] = t->node[at].a[d] + (int64_t)(r % w - m) * e + e / 2;
            if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= root || q[1] >= root ||
                q[2] >= root)
                continue;
            for (;;) {
                int64_t nb = vm__gr_tree_find(t, q, lev + 1);
                if (nb < 0 || t->node[nb].child >= 0 || t->node[nb].level <= lev + 1) break;
                if ((s = vm__gr_tree_split(t, (size_t)nb, err))) break;
                if (n + 8 > cap) {
                    size_t *nw = realloc(work, 2 * cap * sizeof *nw);
                    if (!nw) {
                        s = vm_error_set(err, VM_ERR_NOMEM,
                                         "mesh: out of memory for the balance");
                        break;
                    }
                    work = nw;
                    cap *= 2;
                }
                for (int c = 0; c < 8; c++)
                    work[n++] = (size_t)t->node[nb].child + (size_t)c;
            }
        }
    }
    free(work);
    return s;
}

void vm__gr_tree_free(gr_tree *t) {
    free(t->node);
    memset(t, 0, sizeof *t);
}
