/* SPDX-License-Identifier: BSD-3-Clause */
/* preprocess/spectrum.c — the contour spectrum: area, enclosed volume, gradient integral and
 * component count for many isovalues in one pass. Bajaj, Pascucci, Schikore, IEEE Vis 1997. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "volmesh/preprocess.h"
#include "preprocess_internal.h"

/* Index of the last isovalue <= x, or -1 when x is below them all. iso is increasing. */
static int last_at_or_below(const double *iso, int n, double lo, double hi, double x) {
    double t = (x - lo) / (hi - lo) * (n - 1);
    int k;
    if (!(t >= 0))
        k = -1;
    else if (t >= n - 1)
        k = n - 1;
    else
        k = (int)t;
    while (k + 1 < n && iso[k + 1] <= x) k++;
    while (k >= 0 && iso[k] > x) k--;
    return k;
}

typedef struct {
    const double *iso;
    int n;
    double lo, hi;
    double *area, *volume, *grad, *full; /* full[k]: whole tets whose last isovalue is k */
} accum;

/* Adds w to the volume of every isovalue <= x: w is stored at the last such isovalue and
 * summed from the top down at the end (sums of non-negative terms, no cancellation). */
static void add_full(accum *ac, double x, double w) {
    int k = last_at_or_below(ac->iso, ac->n, ac->lo, ac->hi, x);
    if (k >= 0) ac->full[k] += w;
}

/* One tetrahedron of world volume vt with sorted vertex values f[0] <= .. <= f[3] and world
 * gradient magnitude squared g2. The part with f >= v has volume vt * (1 - B(v)), B the
 * volume fraction below v, and the cross-section {f = v} has area sqrt(g2) * vt * B'(v)
 * (coarea: d volume / dv = area / |grad f|). Each isovalue is taken as v - 0 (the limit from
 * below): a tet counts for f0 < v <= f3, and a surface lying on a face where the field is
 * exactly v (integer data, plateaus) is counted once, by the tets below it. On each piece
 * B is a sum of products of edge parameters whose denominators are then all > 0. */
static void add_tet(accum *ac, const double f[4], double vt, double g2) {
    add_full(ac, f[0], vt);
    if (!(f[3] > f[0])) return;
    int k = last_at_or_below(ac->iso, ac->n, ac->lo, ac->hi, f[0]) + 1;
    const double g = sqrt(g2);
    for (; k < ac->n && ac->iso[k] <= f[3]; k++) {
        const double v = ac->iso[k];
        double below, dbelow;
        if (v <= f[1]) { /* f0 < v <= f1: a small tet around vertex 0 lies below v */
            double d1 = f[1] - f[0], d2 = f[2] - f[0], d3 = f[3] - f[0];
            double t1 = (v - f[0]) / d1, t2 = (v - f[0]) / d2, t3 = (v - f[0]) / d3;
            below = t1 * t2 * t3;
            dbelow = 3.0 * t1 * t2 / d3;
        } else if (v > f[2]) { /* f2 < v <= f3: a small tet around vertex 3 lies above v */
            double d0 = f[3] - f[0], d1 = f[3] - f[1], d2 = f[3] - f[2];
            double s0 = (f[3] - v) / d0, s1 = (f[3] - v) / d1, s2 = (f[3] - v) / d2;
            below = 1.0 - s0 * s1 * s2;
            dbelow = 3.0 * s0 * s1 / d2;
        } else { /* f1 < v <= f2: a prism split into three tets with 0 and 1 below */
            double e02 = f[2] - f[0], e03 = f[3] - f[0], e12 = f[2] - f[1], e13 = f[3] - f[1];
            double a = (v - f[0]) / e02, b = (v - f[0]) / e03;
            double c = (v - f[1]) / e12, d = (v - f[1]) / e13;
            below = a * b + a * (1.0 - b) * d + (1.0 - a) * c * d;
            /* da/dv = 1/e02, db/dv = 1/e03, dc/dv = 1/e12, dd/dv = 1/e13 */
            dbelow = b / e02 + a / e03                                       /* ab */
                     + (1.0 - b) * d / e02 - a * d / e03 + a * (1.0 - b) / e13 /* a(1-b)d */
                     - c * d / e02 + (1.0 - a) * (d / e12 + c / e13);        /* (1-a)cd */
        }
        double area = g * vt * dbelow;
        ac->volume[k] += vt * (1.0 - below);
        ac->area[k] += area;
        ac->grad[k] += g * area;
    }
}

/* ---- component counts: union-find over the grid points in decreasing value --------------- */

#define UF_NONE UINT32_MAX

static uint32_t uf_find(uint32_t *parent, uint32_t x) {
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* components[k] = number of 6-connected components of {f >= iso[k]}. */
static vm_status count_components(const vm_volume *vol, const double *iso, int n, double lo,
                                  double hi, int64_t *components, vm_error *err) {
    const int64_t nx = vol->dims[0], ny = vol->dims[1], nz = vol->dims[2];
    size_t count = vm_volume_count(vol);
    if (count >= UF_NONE)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "spectrum: component counts need fewer than 2^32-1 voxels");
    uint32_t *parent = malloc(count * sizeof *parent);
    uint32_t *order = malloc(count * sizeof *order);
    uint8_t *rank = calloc(count, 1);
    size_t *start = calloc((size_t)n + 1, sizeof *start);
    size_t *fill = malloc((size_t)n * sizeof *fill);
    if (!parent || !order || !rank || !start || !fill) {
        free(parent);
        free(order);
        free(rank);
        free(start);
        free(fill);
        return vm_error_set(err, VM_ERR_NOMEM, "spectrum: out of memory for %zu voxels", count);
    }
    /* Counting sort of the points by the last isovalue at or below their value (computed
     * twice rather than stored: 4 bytes a voxel saved). */
    for (size_t p = 0; p < count; p++) {
        float f = vol->data[p];
        parent[p] = UF_NONE;
        int b = isfinite(f) ? last_at_or_below(iso, n, lo, hi, f) : -1;
        if (b >= 0) start[b + 1]++;
    }
    for (int k = 0; k < n; k++) start[k + 1] += start[k];
    memcpy(fill, start, (size_t)n * sizeof *fill);
    for (size_t p = 0; p < count; p++) {
        float f = vol->data[p];
        int b = isfinite(f) ? last_at_or_below(iso, n, lo, hi, f) : -1;
        if (b >= 0) order[fill[b]++] = (uint32_t)p;
    }
    free(fill);
    int64_t comps = 0;
    for (int k = n - 1; k >= 0; k--) {
        for (size_t q = start[k]; q < start[k + 1]; q++) {
            uint32_t p = order[q];
            parent[p] = p;
            comps++;
            int64_t i = p % nx, j = (p / nx) % ny, kk = p / ((size_t)nx * ny);
            uint32_t nb[6];
            int m = 0;
            if (i > 0) nb[m++] = p - 1;
            if (i < nx - 1) nb[m++] = p + 1;
            if (j > 0) nb[m++] = p - (uint32_t)nx;
            if (j < ny - 1) nb[m++] = p + (uint32_t)nx;
            if (kk > 0) nb[m++] = p - (uint32_t)(nx * ny);
            if (kk < nz - 1) nb[m++] = p + (uint32_t)(nx * ny);
            for (int e = 0; e < m; e++) {
                if (parent[nb[e]] == UF_NONE) continue;
                uint32_t a = uf_find(parent, p), b = uf_find(parent, nb[e]);
                if (a == b) continue;
                if (rank[a] < rank[b]) {
                    uint32_t t = a;
                    a = b;
                    b = t;
                }
                parent[b] = a;
                if (rank[a] == rank[b]) rank[a]++;
                comps--;
            }
        }
        components[k] = comps;
    }
    free(parent);
    free(order);
    free(rank);
    free(start);
    return VM_OK;
}

/* ---- suggestions --------------------------------------------------------------------------- */

/* Gaussian smoothing of x[0..n-1] with standard deviation s samples (truncated at 3 s,
 * renormalised at the ends) into y. */
static void smooth(const double *x, int n, double s, double *y) {
    int r = (int)ceil(3.0 * s);
    for (int k = 0; k < n; k++) {
        double sw = 0, sx = 0;
        for (int d = -r; d <= r; d++) {
            int q = k + d;
            if (q < 0 || q >= n) continue;
            double w = exp(-0.5 * d * d / (s * s));
            sw += w;
            sx += w * x[q];
        }
        y[k] = sx / sw;
    }
}

#define SUGGEST_MIN_AREA 0.05  /* of the largest smoothed area */
#define SUGGEST_MIN_DEPTH 0.05 /* of the range of the smoothed mean gradient */

typedef struct {
    int k, e;           /* the class's run of samples (a plateau when e > k) */
    double depth;       /* absolute depth of the valley */
    double edge[2];     /* sub-sample positions where the class ends; NAN when none */
    double rise[2];     /* how far m rises on each side before the next class or the end */
} material_class;

/* Walks from sample `from` in direction dir (-1, +1) while m is defined and >= level; returns
 * the maximum seen in *top and 1 when it stopped on a value below level. */
static int walk(const double *m, int n, int from, int dir, double level, double *top) {
    *top = level;
    for (int q = from; q >= 0 && q < n && !isnan(m[q]); q += dir) {
        if (m[q] < level) return 1;
        *top = fmax(*top, m[q]);
    }
    return 0;
}

/* Position (in samples) where m first reaches level walking from `from` in direction dir,
 * stopping at `stop` (exclusive) or an undefined sample; NAN when it does not. */
static double crossing(const double *m, int n, int from, int dir, int stop, double level) {
    for (int q = from; q >= 0 && q < n && q != stop && !isnan(m[q]); q += dir) {
        if (m[q] >= level) {
            int p = q - dir;
            if (p < 0 || p >= n || isnan(m[p]) || m[p] >= level) return q;
            return p + dir * (level - m[p]) / (m[q] - m[p]);
        }
    }
    return NAN;
}

static int by_strength(const void *pa, const void *pb) {
    const vm_spectrum_suggestion *a = pa, *b = pb;
    return (a->strength < b->strength) - (a->strength > b->strength);
}

static int by_isovalue(const void *pa, const void *pb) {
    const vm_spectrum_suggestion *a = pa, *b = pb;
    return (a->isovalue > b->isovalue) - (a->isovalue < b->isovalue);
}

static void fill_suggestion(const vm_spectrum *s, double pos, double strength,
                            vm_spectrum_suggestion *out) {
    double step = (s->hi - s->lo) / (s->n - 1);
    out->isovalue = s->lo + pos * step;
    out->area = vm_spectrum_at(s, s->area, out->isovalue);
    double g = vm_spectrum_at(s, s->gradient_integral, out->isovalue);
    out->mean_gradient = out->area > 0 ? g / out->area : 0.0;
    int k = (int)floor(pos + 0.5);
    out->components = s->components[k < 0 ? 0 : k >= s->n ? s->n - 1 : k];
    out->strength = strength;
}

/* The smoothing's standard deviation is n / smooth_div samples (at least one): wide enough
 * to drop noise, narrow enough to keep the valleys of a few percent of the range. */
static const double smooth_div = 128.0;

/* The smoothed mean gradient m (NAN where the smoothed area is below SUGGEST_MIN_AREA of its
 * largest); returns its range (0 when flat). sa, sg: scratch of n doubles each. */
static double mean_gradient(const vm_spectrum *s, double *sa, double *sg, double *m) {
    const int n = s->n;
    double sigma = n / smooth_div > 1.0 ? n / smooth_div : 1.0;
    smooth(s->area, n, sigma, sa);
    smooth(s->gradient_integral, n, sigma, sg);
    double amax = 0, mmax = -INFINITY, mmin = INFINITY;
    for (int k = 0; k < n; k++) amax = fmax(amax, sa[k]);
    for (int k = 0; k < n; k++) {
        m[k] = (amax > 0 && sa[k] >= SUGGEST_MIN_AREA * amax) ? sg[k] / sa[k] : NAN;
        if (!isnan(m[k])) {
            mmax = fmax(mmax, m[k]);
            mmin = fmin(mmin, m[k]);
        }
    }
    return mmax > mmin ? mmax - mmin : 0.0;
}

/* The material classes: the local minima (runs) of m at least SUGGEST_MIN_DEPTH of its range
 * deep, into cls; returns their count. */
static int find_classes(const double *m, int n, double range, material_class *cls) {
    int nc = 0;
    for (int k = 0; k < n && range > 0; k++) {
        if (isnan(m[k]) || (k > 0 && !isnan(m[k - 1]) && m[k - 1] <= m[k])) continue;
        int e = k;
        while (e + 1 < n && m[e + 1] == m[k]) e++;
        if (e + 1 < n && !isnan(m[e + 1]) && m[e + 1] < m[k]) continue;
        double ltop, rtop;
        int lfound = walk(m, n, k - 1, -1, m[k], &ltop);
        int rfound = walk(m, n, e + 1, +1, m[k], &rtop);
        double depth;
        if (lfound && rfound)
            depth = fmin(ltop, rtop);
        else if (lfound)
            depth = ltop;
        else if (rfound)
            depth = rtop;
        else
            depth = fmax(ltop, rtop);
        depth -= m[k];
        if (depth >= SUGGEST_MIN_DEPTH * range) {
            material_class c = {k, e, depth, {NAN, NAN}, {0, 0}};
            cls[nc++] = c;
        }
        k = e;
    }
    return nc;
}

/* Each class ends where m has risen by half of min(depth, the rise toward the next class). */
static void class_edges(const double *m, int n, material_class *cls, int nc) {
    for (int c = 0; c < nc; c++) {
        for (int side = 0; side < 2; side++) {
            int dir = side ? +1 : -1;
            int from = side ? cls[c].e + 1 : cls[c].k - 1;
            int stop = side ? (c + 1 < nc ? cls[c + 1].k : n) : (c > 0 ? cls[c - 1].e : -1);
            double base = m[cls[c].k], top = base;
            for (int q = from; q != stop && q >= 0 && q < n && !isnan(m[q]); q += dir)
                top = fmax(top, m[q]);
            cls[c].rise[side] = top - base;
            double level = base + 0.5 * fmin(top - base, cls[c].depth);
            if (level > base) cls[c].edge[side] = crossing(m, n, from, dir, stop, level);
        }
    }
}

/* One suggestion per gap between classes (and below the first, above the last) that has an
 * edge, into cand; returns their count. */
static int gap_suggestions(const vm_spectrum *s, const material_class *cls, int nc,
                           double range, vm_spectrum_suggestion *cand) {
    int ns = 0;
    for (int c = 0; c <= nc; c++) {
        /* The gap below class c (or above the last class). */
        double lo_edge = c > 0 ? cls[c - 1].edge[1] : NAN;
        double hi_edge = c < nc ? cls[c].edge[0] : NAN;
        double strength;
        if (c > 0 && c < nc)
            strength = fmin(cls[c - 1].depth, cls[c].depth);
        else
            strength = c > 0 ? cls[c - 1].depth : (nc > 0 ? cls[0].depth : 0.0);
        /* A gap bounded by one class only (the top of soft tissue in CT, below the widely
         * spread bone values) is a boundary when m rises beyond the edge at least as much as
         * the class is deep; a mild rise (noise at the very ends of the range) is not. */
        if (c == 0 && c < nc && cls[c].rise[0] < cls[c].depth) hi_edge = NAN;
        if (c == nc && c > 0 && cls[c - 1].rise[1] < cls[c - 1].depth) lo_edge = NAN;
        double pos;
        if (!isnan(lo_edge) && !isnan(hi_edge))
            pos = 0.5 * (lo_edge + hi_edge);
        else if (!isnan(lo_edge))
            pos = lo_edge;
        else if (!isnan(hi_edge))
            pos = hi_edge;
        else
            continue;
        fill_suggestion(s, pos, strength / range, &cand[ns++]);
    }
    return ns;
}

/* The intervals between the ns suggestions, each with its volume and the centre of the
 * class inside it (NAN when none). */
static void fill_intervals(vm_spectrum *s, const material_class *cls, int nc, int ns) {
    double step = (s->hi - s->lo) / (s->n - 1);
    for (int q = 0; q <= ns; q++) {
        vm_spectrum_interval *iv = &s->intervals[q];
        iv->lo = q == 0 ? s->lo : s->suggestions[q - 1].isovalue;
        iv->hi = q == ns ? s->hi : s->suggestions[q].isovalue;
        double top =
            (q == ns && s->hi >= s->value_max) ? 0.0 : vm_spectrum_at(s, s->volume, iv->hi);
        iv->volume = vm_spectrum_at(s, s->volume, iv->lo) - top;
        iv->center = NAN;
        for (int c = 0; c < nc; c++) {
            double v = s->lo + 0.5 * (cls[c].k + cls[c].e) * step;
            if (v >= iv->lo && v <= iv->hi) iv->center = v;
        }
    }
}

/* Material classes (valleys of the smoothed mean gradient), the boundaries between them and
 * the intervals they delimit; see preprocess.h. */
static vm_status suggest(vm_spectrum *s, vm_error *err) {
    const int n = s->n;
    double *sa = malloc((size_t)n * sizeof *sa), *sg = malloc((size_t)n * sizeof *sg);
    double *m = malloc((size_t)n * sizeof *m);
    material_class *cls = malloc((size_t)n * sizeof *cls);
    vm_spectrum_suggestion *cand = malloc((size_t)(n + 1) * sizeof *cand);
    vm_status st = VM_OK;
    if (!sa || !sg || !m || !cls || !cand) {
        st = vm_error_set(err, VM_ERR_NOMEM, "spectrum: out of memory");
        goto done;
    }
    double range = mean_gradient(s, sa, sg, m);
    int nc = find_classes(m, n, range, cls);
    class_edges(m, n, cls, nc);
    int ns = gap_suggestions(s, cls, nc, range, cand);
    qsort(cand, (size_t)ns, sizeof *cand, by_strength);
    if (ns > VM_SPECTRUM_MAX_SUGGESTIONS) ns = VM_SPECTRUM_MAX_SUGGESTIONS;
    qsort(cand, (size_t)ns, sizeof *cand, by_isovalue);
    s->suggestions = malloc((size_t)(ns > 0 ? ns : 1) * sizeof *s->suggestions);
    s->intervals = malloc((size_t)(ns + 1) * sizeof *s->intervals);
    if (!s->suggestions || !s->intervals) {
        st = vm_error_set(err, VM_ERR_NOMEM, "spectrum: out of memory");
        goto done;
    }
    memcpy(s->suggestions, cand, (size_t)ns * sizeof *cand);
    s->n_suggestions = ns;
    s->n_intervals = ns + 1;
    fill_intervals(s, cls, nc, ns);
done:
    free(sa);
    free(sg);
    free(m);
    free(cls);
    free(cand);
    return st;
}

/* ---- the pass over the cells ----------------------------------------------------------------- */

double vm_spectrum_at(const vm_spectrum *s, const double *curve, double v) {
    if (!(v > s->lo)) return curve[0];
    if (!(v < s->hi)) return curve[s->n - 1];
    double t = (v - s->lo) / (s->hi - s->lo) * (s->n - 1);
    int k = (int)t;
    if (k >= s->n - 1) k = s->n - 2;
    double u = t - k;
    return (1.0 - u) * curve[k] + u * curve[k + 1];
}

void vm_spectrum_free(vm_spectrum *s) {
    if (!s) return;
    free(s->isovalue);
    free(s->area);
    free(s->volume);
    free(s->gradient_integral);
    free(s->components);
    free(s->suggestions);
    free(s->intervals);
    memset(s, 0, sizeof *s);
}

/* The volume's smallest and largest finite samples (*lo, *hi); an error when it has none or
 * they are equal (no isosurface). */
static vm_status value_range(const vm_volume *v, double *lo, double *hi, vm_error *err) {
    vm_volume_stats(v, lo, hi, NULL);
    if (!isfinite(*lo))
        return vm_error_set(err, VM_ERR_EMPTY, "spectrum: the volume has no finite sample");
    if (!(*hi > *lo))
        return vm_error_set(err, VM_ERR_EMPTY,
                            "spectrum: the volume is constant (every sample is %g): it has no "
                            "isosurfaces",
                            *lo);
    return VM_OK;
}

/* The spectrum over the volume's whole value range (see volmesh/preprocess.h). */
vm_status vm_spectrum_compute(const vm_volume *v, int n, vm_spectrum *out, vm_error *err) {
    double lo, hi;
    memset(out, 0, sizeof *out);
    vm_status st = value_range(v, &lo, &hi, err);
    if (st) return st;
    return vm_spectrum_compute_range(v, n, lo, hi, NULL, NULL, out, err);
}

/* Kuhn split: tet (a, b, c) runs 0 -> e_a -> e_a + e_b -> (1,1,1); corner bit 0 is x. */
static const int kuhn_perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                    {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

/* Adds the cells of z layer k (between grid planes k and k + 1) to ac; returns the world
 * volume of its cells with finite corners. inv: the inverse of the index-to-world matrix. */
static double add_layer(const vm_volume *v, accum *ac, const double inv[3][3],
                        double cell_volume, int64_t k) {
    const int64_t nx = v->dims[0], ny = v->dims[1];
    const int n = ac->n;
    const double lo = ac->lo, hi = ac->hi, tet_volume = cell_volume / 6.0;
    const int64_t corner_off[8] = {0,           1,           nx,          nx + 1,
                                   nx * ny,     nx * ny + 1, nx * ny + nx, nx * ny + nx + 1};
    double total = 0.0;
    for (int64_t j = 0; j + 1 < ny; j++)
        for (int64_t i = 0; i + 1 < nx; i++) {
            const float *base = v->data + (i + nx * (j + ny * k));
            double c[8], cmin = INFINITY, cmax = -INFINITY;
            int finite = 1;
            for (int q = 0; q < 8; q++) {
                c[q] = base[corner_off[q]];
                if (!isfinite(c[q])) finite = 0;
                cmin = fmin(cmin, c[q]);
                cmax = fmax(cmax, c[q]);
            }
            if (!finite) continue;
            total += cell_volume;
            int kmin = last_at_or_below(ac->iso, n, lo, hi, cmin);
            if (kmin + 1 >= n || !(ac->iso[kmin + 1] <= cmax)) {
                /* No isovalue in (cmin, cmax]: the cell counts whole or not at all. */
                add_full(ac, cmin, cell_volume);
                continue;
            }
            for (int t = 0; t < 6; t++) {
                int a = kuhn_perm[t][0], b = kuhn_perm[t][1], cc = kuhn_perm[t][2];
                int v1 = 1 << a, v2 = v1 | (1 << b);
                double f[4] = {c[0], c[v1], c[v2], c[7]};
                double gi[3];
                gi[a] = f[1] - f[0];
                gi[b] = f[2] - f[1];
                gi[cc] = f[3] - f[2];
                double g2 = 0;
                for (int r = 0; r < 3; r++) { /* world gradient = M^-T * index gradient */
                    double gw = inv[0][r] * gi[0] + inv[1][r] * gi[1] + inv[2][r] * gi[2];
                    g2 += gw * gw;
                }
                /* sort the four values */
                for (int p = 1; p < 4; p++) {
                    double x = f[p];
                    int q = p - 1;
                    while (q >= 0 && f[q] > x) {
                        f[q + 1] = f[q];
                        q--;
                    }
                    f[q + 1] = x;
                }
                add_tet(ac, f, tet_volume, g2);
            }
        }
    return total;
}

/* Most isovalues of a spectrum (the limit volmesh/preprocess.h documents). */
enum { MAX_ISOVALUES = 1000000 };
/* Layers summed per parallel batch, at most, and the bytes their partial sums may take. */
enum { LAYER_BATCH = 16 };
#define BATCH_BYTES ((size_t)64 << 20)

/* Adds every z layer's cells to ac; *total: the world volume of the cells with finite
 * corners. cell_volume: one cell's world volume. */
static vm_status sum_layers(const vm_volume *v, accum *ac, const double inv[3][3],
                            double cell_volume, vm_progress_fn progress, void *user,
                            double *total, vm_error *err) {
    const int64_t nz = v->dims[2];
    const int n = ac->n;
    const size_t sz = (size_t)n;
    const double lo = ac->lo, hi = ac->hi;
    /* Layers in parallel, each into its own sums, added in layer order: the same bits for any
     * thread count. A batch of layers at a time (16, fewer when 4 n + 1 doubles per layer would
     * pass 64 MB; never depending on the threads) bounds the memory and gives the progress
     * reports (from this thread only). */
    const size_t per = 4 * sz + 1;
    size_t fit = BATCH_BYTES / (per * sizeof(double));
    const int64_t batch = fit >= LAYER_BATCH ? LAYER_BATCH : fit >= 1 ? (int64_t)fit : 1;
    double *part = malloc((size_t)batch * per * sizeof *part);
    if (!part)
        return vm_error_set(err, VM_ERR_NOMEM, "spectrum: out of memory for %d isovalues", n);
    double sum = 0.0;
    for (int64_t k0 = 0; k0 + 1 < nz; k0 += batch) {
        int64_t k1 = k0 + batch < nz - 1 ? k0 + batch : nz - 1;
        memset(part, 0, (size_t)(k1 - k0) * per * sizeof *part);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int64_t k = k0; k < k1; k++) {
            double *q = part + (size_t)(k - k0) * per;
            accum lac = {ac->iso, n, lo, hi, q, q + sz, q + 2 * sz, q + 3 * sz};
            q[4 * sz] = add_layer(v, &lac, inv, cell_volume, k);
        }
        for (int64_t k = k0; k < k1; k++) {
            const double *q = part + (size_t)(k - k0) * per;
            for (size_t i = 0; i < sz; i++) {
                ac->area[i] += q[i];
                ac->volume[i] += q[sz + i];
                ac->grad[i] += q[2 * sz + i];
                ac->full[i] += q[3 * sz + i];
            }
            sum += q[4 * sz];
        }
        if (progress && progress("spectrum", (double)k1, (double)(nz - 1), user)) {
            free(part);
            return vm__cancelled(err, "spectrum");
        }
    }
    free(part);
    *total = sum;
    return VM_OK;
}

/* The spectrum over [lo, hi] (see volmesh/preprocess.h). */
vm_status vm_spectrum_compute_range(const vm_volume *v, int n, double lo, double hi,
                                    vm_progress_fn progress, void *user, vm_spectrum *out,
                                    vm_error *err) {
    double t0 = vm__now();
    memset(out, 0, sizeof *out);
    if (n < 2 || n > MAX_ISOVALUES)
        return vm_error_set(err, VM_ERR_ARG, "spectrum: %d isovalues (2 to 1000000)", n);
    if (!isfinite(lo) || !isfinite(hi) || !(lo < hi))
        return vm_error_set(err, VM_ERR_ARG, "spectrum: range %g:%g is empty (need lo < hi)",
                            lo, hi);
    double dmin, dmax;
    vm_status st = value_range(v, &dmin, &dmax, err);
    if (st) return st;
    double inv[3][3], det;
    st = vm__frame_inverse(v, "spectrum", inv, &det, err);
    if (st) return st;
    out->n = n;
    out->lo = lo;
    out->hi = hi;
    out->value_min = dmin;
    out->value_max = dmax;
    size_t sz = (size_t)n;
    out->isovalue = malloc(sz * sizeof *out->isovalue);
    out->area = calloc(sz, sizeof *out->area);
    out->volume = calloc(sz, sizeof *out->volume);
    out->gradient_integral = calloc(sz, sizeof *out->gradient_integral);
    out->components = calloc(sz, sizeof *out->components);
    double *full = calloc(sz + 1, sizeof *full);
    if (!out->isovalue || !out->area || !out->volume || !out->gradient_integral ||
        !out->components || !full) {
        free(full);
        return vm_error_set(err, VM_ERR_NOMEM, "spectrum: out of memory for %d isovalues", n);
    }
    for (int k = 0; k < n; k++) out->isovalue[k] = lo + (hi - lo) * k / (n - 1);
    out->isovalue[n - 1] = hi;
    accum ac = {out->isovalue, n, lo, hi, out->area, out->volume, out->gradient_integral, full};

    double total = 0.0;
    st = sum_layers(v, &ac, (const double(*)[3])inv, fabs(det), progress, user, &total, err);
    if (st) {
        free(full);
        return st;
    }
    double run = 0;
    for (int k = n - 1; k >= 0; k--) {
        run += full[k];
        out->volume[k] += run;
    }
    free(full);
    out->total_volume = total;
    st = count_components(v, out->isovalue, n, lo, hi, out->components, err);
    if (st) return st;
    st = suggest(out, err);
    if (st) return st;
    out->seconds = vm__now() - t0;
    return VM_OK;
}
