/* SPDX-License-Identifier: BSD-3-Clause */
/* labels/labels.c — multi-material meshes of label volumes: one hex (or 6 tets) per labelled
 * voxel whose corners are the shared vertices of the dual cells between voxel centres (seed
 * 001, LBIE §4.3: "these eight minimizers can then be used to construct a hexahedron").
 * Each label's boundary is made a 2-manifold first by removing the critical configurations of
 * L. J. Latecki, "3D well-composed pictures" (Graph. Models Image Process. 59, 1997): a
 * picture is well-composed (its boundary a manifold) iff no 2x2 square holds a label on one
 * diagonal only (C1) and no 2x2x2 block holds it on exactly one antipodal pair, or on all
 * but one (C2). Tets split each hex along its main diagonal (Kuhn/Freudenthal), which is
 * translation invariant and so conforming across every shared face. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "volmesh/labels.h"
#include "volmesh/quality.h"

void vm_label_options_default(vm_label_options *o) {
    memset(o, 0, sizeof *o);
    o->max_level = 4;
    o->elements = VM_TET4;
    o->cell_size = 1;
    o->min_island = 1;
    o->smooth = 1;
}

void vm_label_stats_free(vm_label_stats *stats) {
    if (!stats) return;
    free(stats->labels);
    memset(stats, 0, sizeof *stats);
}

/* The floats that convert to an int32 label: -2^31, and the largest float below 2^31. */
static const float label_min_f = -2147483648.0f, label_max_f = 2147483520.0f;

/* ---- labels present and chosen ------------------------------------------------------- */

typedef struct label_set {
    int32_t *val;
    size_t *count;
    size_t n, cap;
} label_set;

/* Orders int32 values ascending (qsort, bsearch). */
static int cmp_i32(const void *a, const void *b) {
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

/* Index of label x among the n distinct ascending labels val, -1 when absent. */
static long find_label(const int32_t *val, size_t n, int32_t x) {
    const int32_t *at = n ? bsearch(&x, val, n, sizeof *val, cmp_i32) : NULL;
    return at ? (long)(at - val) : -1;
}

static vm_status set_add(label_set *s, int32_t x, size_t *slot, vm_error *err) {
    size_t lo = 0, hi = s->n;
    while (lo < hi) {
        size_t md = (lo + hi) / 2;
        if (s->val[md] < x)
            lo = md + 1;
        else
            hi = md;
    }
    if (lo == s->n || s->val[lo] != x) {
        size_t cap = s->cap;
        vm_status st = vm__grow((void **)&s->val, &cap, s->n + 1, sizeof *s->val, err);
        if (!st) st = vm__grow((void **)&s->count, &s->cap, s->n + 1, sizeof *s->count, err);
        if (st) return st;
        memmove(s->val + lo + 1, s->val + lo, (s->n - lo) * sizeof *s->val);
        memmove(s->count + lo + 1, s->count + lo, (s->n - lo) * sizeof *s->count);
        s->val[lo] = x;
        s->count[lo] = 0;
        s->n++;
    }
    *slot = lo;
    return VM_OK;
}

/* Distinct labels of v with their voxel counts; refuses values that are not labels. */
static vm_status collect_labels(const vm_volume *v, label_set *s, vm_error *err) {
    size_t n = vm_volume_count(v), last = 0;
    int have_last = 0;
    float last_value = 0;
    for (size_t i = 0; i < n; i++) {
        float f = v->data[i];
        if (have_last && f == last_value) {
            s->count[last]++;
            continue;
        }
        if (!(f == floorf(f)) || f < label_min_f || f > label_max_f) {
            size_t nx = (size_t)v->dims[0], ny = (size_t)v->dims[1];
            return vm_error_set(err, VM_ERR_FORMAT,
                                "mesh: voxel (%zu, %zu, %zu) holds %g, not an integer label "
                                "(--labels needs a label volume)",
                                i % nx, (i / nx) % ny, i / (nx * ny), (double)f);
        }
        vm_status st = set_add(s, (int32_t)f, &last, err);
        if (st) return st;
        s->count[last]++;
        have_last = 1;
        last_value = f;
    }
    return VM_OK;
}

/* "0-17, 20, 21" into out (cut with "..." when long). */
static void format_labels(const label_set *s, char *out, size_t cap) {
    size_t used = 0;
    out[0] = 0;
    for (size_t i = 0; i < s->n && used + 24 < cap; i++) {
        size_t j = i;
        while (j + 1 < s->n && s->val[j + 1] == s->val[j] + 1) j++;
        int w = j > i + 1 ? snprintf(out + used, cap - used, "%s%ld-%ld", i ? ", " : "",
                                     (long)s->val[i], (long)s->val[j])
                          : snprintf(out + used, cap - used, "%s%ld", i ? ", " : "",
                                     (long)s->val[i]);
        if (w < 0) break;
        used += (size_t)w;
        if (j > i + 1) i = j;
    }
    if (used + 24 >= cap && used + 4 < cap) strcpy(out + used, "...");
}

/* ---- the padded code grid ------------------------------------------------------------ */

/* Codes: 0 background, 1..K the chosen labels in ascending order. One voxel of background
 * all around, so that material touching the volume border is closed there. */
typedef struct lgrid {
    int64_t m[3];
    uint16_t *code;
    int K;
    int *rank; /* per code: who wins a topology repair (lower wins) */
} lgrid;

static size_t gidx(const lgrid *g, int64_t i, int64_t j, int64_t k) {
    return (size_t)(i + g->m[0] * (j + g->m[1] * k));
}

static int is_pad(const lgrid *g, size_t p) {
    int64_t i = (int64_t)(p % (size_t)g->m[0]), j = (int64_t)((p / (size_t)g->m[0]) % (size_t)g->m[1]),
            k = (int64_t)(p / (size_t)(g->m[0] * g->m[1]));
    return i == 0 || j == 0 || k == 0 || i == g->m[0] - 1 || j == g->m[1] - 1 || k == g->m[2] - 1;
}

/* Smaller labels rank first, so repairs grow thin and small tissues rather than erode them;
 * background ranks last, so gaps fill with material. */
static int rank_of(const lgrid *g, int code) {
    return g->rank[code];
}

typedef struct code_count {
    size_t count;
    int code;
} code_count;

static int cmp_code_count(const void *a, const void *b) {
    const code_count *x = a, *y = b;
    if (x->count != y->count) return x->count < y->count ? -1 : 1;
    return (x->code > y->code) - (x->code < y->code);
}

static vm_status make_ranks(lgrid *g, vm_error *err) {
    size_t total = (size_t)(g->m[0] * g->m[1] * g->m[2]), K = (size_t)g->K;
    code_count *cc = calloc(K + 1, sizeof *cc);
    g->rank = malloc((K + 1) * sizeof *g->rank);
    if (!cc || !g->rank) {
        free(cc);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (size_t c = 0; c <= K; c++) cc[c].code = (int)c;
    for (size_t p = 0; p < total; p++) cc[g->code[p]].count++;
    qsort(cc + 1, K, sizeof *cc, cmp_code_count);
    for (size_t c = 1; c <= K; c++) g->rank[cc[c].code] = (int)c;
    g->rank[0] = g->K + 1;
    free(cc);
    return VM_OK;
}

/* Gives each label that won no block (S > 1) the block where it has the most voxels, unless
 * that block's winner has no other block; rescued[code] = 1 for those given one. best[code]:
 * that block, bestv[code]: its voxels of the label (0: none anywhere). */
static void rescue_labels(lgrid *g, const size_t *best, const uint32_t *bestv,
                          uint8_t *rescued) {
    size_t total = (size_t)(g->m[0] * g->m[1] * g->m[2]), K = (size_t)g->K, n = 0;
    size_t *wins = calloc(K + 1, sizeof *wins);
    code_count *lost = malloc((K + 1) * sizeof *lost);
    if (!wins || !lost) { /* nothing rescued: the caller reports the labels lost */
        free(wins);
        free(lost);
        return;
    }
    for (size_t p = 0; p < total; p++) wins[g->code[p]]++;
    for (size_t c = 1; c <= K; c++)
        if (!wins[c] && bestv[c]) lost[n++] = (code_count){bestv[c], (int)c};
    /* the labels with fewest voxels in their best block first */
    qsort(lost, n, sizeof *lost, cmp_code_count);
    for (size_t i = 0; i < n; i++) {
        int c = lost[i].code;
        uint16_t owner = g->code[best[c]];
        if (owner != 0 && wins[owner] <= 1) continue;
        wins[owner]--;
        wins[c] = 1;
        g->code[best[c]] = (uint16_t)c;
        rescued[c] = 1;
    }
    free(wins);
    free(lost);
}

/* S >= 1: each S^3 block votes, and labels that win no block are rescued (rescue_labels;
 * rescued: K + 1 flags, may be NULL); U > 1 (with S == 1): each voxel becomes U^3 cells. */
static vm_status build_grid(const vm_volume *v, const int32_t *chosen, int K, int S, int U,
                            lgrid *g, uint8_t *rescued, vm_error *err) {
    int64_t c[3];
    for (int a = 0; a < 3; a++) {
        c[a] = U > 1 ? v->dims[a] * U : (v->dims[a] + S - 1) / S;
        g->m[a] = c[a] + 2;
    }
    g->K = K;
    size_t count;
    vm_status st = vm__check_dims(g->m, sizeof(uint16_t), "mesh", &count, err);
    if (st) return st;
    g->code = calloc(count, sizeof(uint16_t));
    uint32_t *votes = calloc((size_t)K + 1, sizeof(uint32_t));
    uint16_t *touched = malloc((size_t)S * (size_t)S * (size_t)S * sizeof(uint16_t));
    uint32_t *bestv = calloc((size_t)K + 1, sizeof(uint32_t));
    size_t *bestb = calloc((size_t)K + 1, sizeof(size_t));
    if (!g->code || !votes || !touched || !bestv || !bestb) {
        free(votes);
        free(touched);
        free(bestv);
        free(bestb);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the label grid");
    }
    const int64_t *n = v->dims;
    int32_t last_value = 0;
    uint16_t last_code = 0;
    int have_last = 0;
    if (U > 1) {
        for (int64_t K2 = 0; K2 < c[2]; K2++)
            for (int64_t J = 0; J < c[1]; J++)
                for (int64_t I = 0; I < c[0]; I++) {
                    int32_t x = (int32_t)v->data[I / U + n[0] * (J / U + n[1] * (K2 / U))];
                    if (!have_last || x != last_value) {
                        last_code = (uint16_t)(find_label(chosen, (size_t)K, x) + 1);
                        last_value = x;
                        have_last = 1;
                    }
                    g->code[gidx(g, I + 1, J + 1, K2 + 1)] = last_code;
                }
        free(votes);
        free(touched);
        free(bestv);
        free(bestb);
        return VM_OK;
    }
    for (int64_t K2 = 0; K2 < c[2]; K2++)
        for (int64_t J = 0; J < c[1]; J++)
            for (int64_t I = 0; I < c[0]; I++) {
                size_t nt = 0;
                for (int64_t k = K2 * S; k < K2 * S + S && k < n[2]; k++)
                    for (int64_t j = J * S; j < J * S + S && j < n[1]; j++)
                        for (int64_t i = I * S; i < I * S + S && i < n[0]; i++) {
                            int32_t x = (int32_t)v->data[i + n[0] * (j + n[1] * k)];
                            if (!have_last || x != last_value) {
                                long f = find_label(chosen, (size_t)K, x);
                                last_code = (uint16_t)(f + 1);
                                last_value = x;
                                have_last = 1;
                            }
                            if (votes[last_code]++ == 0) touched[nt++] = last_code;
                        }
                /* most frequent; ties go to material, then to the lower label */
                uint16_t winner = touched[0];
                for (size_t t = 1; t < nt; t++) {
                    uint16_t q = touched[t];
                    if (votes[q] > votes[winner] ||
                        (votes[q] == votes[winner] && (winner == 0 || (q != 0 && q < winner))))
                        winner = q;
                }
                size_t at = gidx(g, I + 1, J + 1, K2 + 1);
                for (size_t t = 0; t < nt; t++) {
                    uint16_t q = touched[t];
                    if (votes[q] > bestv[q]) {
                        bestv[q] = votes[q];
                        bestb[q] = at;
                    }
                    votes[q] = 0;
                }
                g->code[at] = winner;
            }
    if (S > 1 && rescued) rescue_labels(g, bestb, bestv, rescued);
    free(votes);
    free(touched);
    free(bestv);
    free(bestb);
    return VM_OK;
}

/* ---- island floor -------------------------------------------------------------------- */

static const int nb6[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

/* Relabels the face-connected pieces below floor_voxels cells; per code (K + 1 entries each)
 * counts the pieces and cells relabelled. */
static vm_status remove_islands(lgrid *g, size_t floor_voxels, size_t *relabelled,
                                size_t *pieces, size_t *cells, vm_error *err) {
    size_t total = (size_t)(g->m[0] * g->m[1] * g->m[2]);
    uint8_t *seen = calloc(total, 1);
    uint32_t *votes = calloc((size_t)g->K + 1, sizeof(uint32_t));
    size_t *list = NULL, cap = 0;
    if (!seen || !votes) {
        free(seen);
        free(votes);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for --min-island");
    }
    vm_status st = VM_OK;
    int64_t step[3] = {1, g->m[0], g->m[0] * g->m[1]};
    for (size_t p = 0; p < total && !st; p++) {
        if (seen[p] || g->code[p] == 0) continue;
        uint16_t c = g->code[p];
        size_t n = 0;
        if ((st = vm__grow((void **)&list, &cap, 1, sizeof *list, err))) break;
        list[n++] = p;
        seen[p] = 1;
        for (size_t h = 0; h < n && !st; h++)
            for (int d = 0; d < 6; d++) {
                size_t q = (size_t)((int64_t)list[h] + nb6[d][0] * step[0] + nb6[d][1] * step[1] +
                                    nb6[d][2] * step[2]);
                if (seen[q] || g->code[q] != c) continue; /* padding is background: no wrap */
                if ((st = vm__grow((void **)&list, &cap, n + 1, sizeof *list, err))) break;
                seen[q] = 1;
                list[n++] = q;
            }
        if (st || n >= floor_voxels) continue;
        int best = -1;
        for (size_t h = 0; h < n; h++)
            for (int d = 0; d < 6; d++) {
                size_t q = (size_t)((int64_t)list[h] + nb6[d][0] * step[0] + nb6[d][1] * step[1] +
                                    nb6[d][2] * step[2]);
                uint16_t x = g->code[q];
                if (x == c) continue;
                votes[x]++;
                if (best < 0 || votes[x] > votes[best] || (votes[x] == votes[best] && x < best))
                    best = x;
            }
        memset(votes, 0, ((size_t)g->K + 1) * sizeof(uint32_t));
        for (size_t h = 0; h < n; h++) g->code[list[h]] = (uint16_t)(best < 0 ? 0 : best);
        *relabelled += n;
        pieces[c]++;
        cells[c] += n;
    }
    free(seen);
    free(votes);
    free(list);
    return st;
}

/* ---- well-composedness repair -------------------------------------------------------- */

/* Corners of a 2x2x2 block are bit-indexed (x | y<<1 | z<<2); the six 2x2 squares, each in
 * cyclic order so that (0,2) and (1,3) are its diagonals. */
static const int square[6][4] = {{0, 2, 6, 4}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                 {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 5, 7, 6}};

typedef struct repair {
    lgrid *g;
    size_t bm[3];      /* blocks per axis (m - 1) */
    uint8_t *queued;   /* per block */
    size_t *queue, n, cap;
    size_t changes, forced;
} repair;

static vm_status set_code(repair *r, size_t p, uint16_t code, vm_error *err) {
    lgrid *g = r->g;
    g->code[p] = code;
    r->changes++;
    int64_t i = (int64_t)(p % (size_t)g->m[0]), j = (int64_t)((p / (size_t)g->m[0]) % (size_t)g->m[1]),
            k = (int64_t)(p / (size_t)(g->m[0] * g->m[1]));
    for (int d = 0; d < 8; d++) {
        int64_t a = i - (d & 1), b = j - ((d >> 1) & 1), c = k - (d >> 2);
        if (a < 0 || b < 0 || c < 0 || a >= (int64_t)r->bm[0] || b >= (int64_t)r->bm[1] ||
            c >= (int64_t)r->bm[2])
            continue;
        size_t blk = (size_t)a + r->bm[0] * ((size_t)b + r->bm[1] * (size_t)c);
        if (r->queued[blk]) continue;
        vm_status st = vm__grow((void **)&r->queue, &r->cap, r->n + 1, sizeof *r->queue, err);
        if (st) return st;
        r->queued[blk] = 1;
        r->queue[r->n++] = blk;
    }
    return VM_OK;
}

/* Tries to give voxel p (corner `at` of the block) the code `to`: only when it is not
 * padding and the change lowers its rank (so repairs terminate: the sum of ranks falls). */
static void try_set(repair *r, const size_t vox[8], const uint16_t cd[8], int at, int to,
                    int *done, vm_status *st, vm_error *err) {
    if (*done || cd[at] == to || is_pad(r->g, vox[at])) return;
    if (rank_of(r->g, to) >= rank_of(r->g, cd[at])) return;
    *st = set_code(r, vox[at], (uint16_t)to, err);
    *done = 1;
}

/* Same without the rank condition, for the (never observed) case of no decreasing choice. */
static void force_set(repair *r, const size_t vox[8], const uint16_t cd[8], int at, int to,
                      int *done, vm_status *st, vm_error *err) {
    if (*done || cd[at] == to || is_pad(r->g, vox[at])) return;
    *st = set_code(r, vox[at], (uint16_t)to, err);
    r->forced++;
    *done = 1;
}

/* Finds one critical configuration in the block with lowest corner (a,b,c) and removes it by
 * one relabelling; *changed: whether something changed. */
static vm_status fix_block(repair *r, size_t a, size_t b, size_t c, int *changed,
                           vm_error *err) {
    lgrid *g = r->g;
    vm_status status = VM_OK, *st = &status;
    size_t vox[8];
    uint16_t cd[8];
    for (int q = 0; q < 8; q++) {
        vox[q] = gidx(g, (int64_t)a + (q & 1), (int64_t)b + ((q >> 1) & 1), (int64_t)c + (q >> 2));
        cd[q] = g->code[vox[q]];
    }
    int done = 0;
    for (int q0 = 0; q0 < 8 && !done; q0++) {
        int L = cd[q0], first = 1;
        for (int q = 0; q < q0; q++)
            if (cd[q] == L) first = 0;
        if (!first) continue;
        int mask = 0;
        for (int q = 0; q < 8; q++)
            if (cd[q] == L) mask |= 1 << q;
        int rL = rank_of(g, L);
        /* C1: L on one diagonal of a square only */
        for (int s = 0; s < 6 && !done; s++)
            for (int d = 0; d < 2 && !done; d++) {
                int pa = square[s][d], pb = square[s][d + 2];
                int pc = square[s][1 - d], pd = square[s][3 - d];
                if (!(mask >> pa & 1) || !(mask >> pb & 1) || (mask >> pc & 1) || (mask >> pd & 1))
                    continue;
                int hi = rank_of(g, cd[pc]) >= rank_of(g, cd[pd]) ? pc : pd, lo = hi == pc ? pd : pc;
                try_set(r, vox, cd, hi, L, &done, st, err);
                try_set(r, vox, cd, lo, L, &done, st, err);
                if (rank_of(g, cd[lo]) < rL) {
                    try_set(r, vox, cd, pa, cd[lo], &done, st, err);
                    try_set(r, vox, cd, pb, cd[lo], &done, st, err);
                }
                force_set(r, vox, cd, pc, L, &done, st, err);
                force_set(r, vox, cd, pd, L, &done, st, err);
                force_set(r, vox, cd, pa, cd[lo], &done, st, err);
                if (!done) r->forced++; /* unresolvable here: counted, left */
            }
        if (done) break;
        /* C2: L on exactly one antipodal pair, or everywhere but one antipodal pair */
        int pop = __builtin_popcount((unsigned)mask);
        if (pop != 2 && pop != 6) continue;
        int pair = pop == 2 ? mask : (~mask & 0xff);
        int p = __builtin_ctz((unsigned)pair);
        if (pair != (1 << p | 1 << (p ^ 7))) continue;
        int pq[2] = {p, p ^ 7};
        if (pop == 2) {
            /* grow L into the highest-ranked other corner, else shrink L */
            int best = -1, low = -1;
            for (int q = 0; q < 8; q++) {
                if (q == pq[0] || q == pq[1] || is_pad(g, vox[q])) continue;
                if (best < 0 || rank_of(g, cd[q]) > rank_of(g, cd[best])) best = q;
                if (low < 0 || rank_of(g, cd[q]) < rank_of(g, cd[low])) low = q;
            }
            if (best >= 0) try_set(r, vox, cd, best, L, &done, st, err);
            for (int q = 0; q < 8 && !done; q++)
                if (q != pq[0] && q != pq[1] && rank_of(g, cd[q]) < rL) {
                    try_set(r, vox, cd, pq[0], cd[q], &done, st, err);
                    try_set(r, vox, cd, pq[1], cd[q], &done, st, err);
                }
            if (best >= 0) force_set(r, vox, cd, best, L, &done, st, err);
        } else {
            try_set(r, vox, cd, pq[0], L, &done, st, err);
            try_set(r, vox, cd, pq[1], L, &done, st, err);
            for (int e = 0; e < 2 && !done; e++)
                for (int bit = 1; bit < 8 && !done; bit <<= 1)
                    try_set(r, vox, cd, pq[e] ^ bit, cd[pq[e]], &done, st, err);
            force_set(r, vox, cd, pq[0], L, &done, st, err);
            force_set(r, vox, cd, pq[1], L, &done, st, err);
        }
        if (!done) r->forced++;
    }
    *changed = done;
    return status;
}

/* Fixes the block with lowest corner (a, b, c) until it holds no critical configuration. */
static vm_status fix_until_clean(repair *r, size_t a, size_t b, size_t c, vm_error *err) {
    for (int changed = 1; changed;) {
        vm_status st = fix_block(r, a, b, c, &changed, err);
        if (st) return st;
    }
    return VM_OK;
}

/* The topology repair's change budget: changes per voxel, and slack for tiny grids. */
enum { REPAIR_CHANGES_PER_VOXEL = 4, REPAIR_CHANGES_SLACK = 1000 };

/* Removes every critical configuration (C1, C2) by relabelling voxels, block by block, then
 * the blocks the changes queued; *relabelled: the changes. */
static vm_status make_well_composed(lgrid *g, size_t *relabelled, vm_error *err) {
    repair r;
    memset(&r, 0, sizeof r);
    r.g = g;
    for (int a = 0; a < 3; a++) r.bm[a] = (size_t)g->m[a] - 1;
    size_t nb = r.bm[0] * r.bm[1] * r.bm[2];
    r.queued = calloc(nb, 1);
    if (!r.queued) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (topology)");
    vm_status st = VM_OK;
    /* the change budget guards the forced (rank-raising) moves from cycling */
    size_t budget = REPAIR_CHANGES_PER_VOXEL * (size_t)(g->m[0] * g->m[1] * g->m[2]) +
                    REPAIR_CHANGES_SLACK;
    for (size_t c = 0; c < r.bm[2] && !st; c++)
        for (size_t b = 0; b < r.bm[1] && !st; b++)
            for (size_t a = 0; a < r.bm[0] && !st; a++)
                st = fix_until_clean(&r, a, b, c, err);
    while (!st && r.n > 0 && r.changes < budget) {
        size_t blk = r.queue[--r.n];
        r.queued[blk] = 0;
        size_t a = blk % r.bm[0], b = (blk / r.bm[0]) % r.bm[1], c = blk / (r.bm[0] * r.bm[1]);
        st = fix_until_clean(&r, a, b, c, err);
    }
    if (!st && r.n > 0)
        st = vm_error_set(err, VM_ERR_INTERNAL,
                          "mesh: the label topology repair did not settle after %zu changes",
                          r.changes);
    *relabelled = r.changes;
    free(r.queued);
    free(r.queue);
    return st;
}

/* ---- vertices and elements ----------------------------------------------------------- */

/* VTK hex corner q at bit-indexed corner vtk_bit[q]. */
static const int vtk_bit[8] = {0, 1, 3, 2, 4, 5, 7, 6};

typedef struct lmesh {
    const lgrid *g;
    size_t cm[3];        /* dual cells per axis (m - 1) */
    int32_t *vid;        /* per dual cell: vertex id or -1 */
    size_t *vcell;       /* per vertex: its dual cell */
    double *target;      /* per vertex: smooth position (coarse index space) */
    double *lambda;      /* per vertex: 1 at target, 0 at the cell centre */
    size_t nv, vcap, tcap, lcap; /* capacities of vcell, target, lambda */
    int32_t *hex;        /* 8 vertex ids per labelled voxel, VTK order */
    uint16_t *hcode;     /* per hex */
    size_t nh, hcap, ccap; /* capacities of hex (ids), hcode */
    const int8_t *lvl;   /* per padded cell: octree level (see build_leaves); NULL: all 0 */
    int64_t sh[3];       /* the octree's origin (choose_shift) */
    int32_t *ct;         /* 4 vertex ids per tet of a coarse leaf */
    uint16_t *ctcode;    /* per coarse tet */
    size_t nct, ctcap, ctccap;
    int kuhn[6][4];      /* bit-indexed corners of the 6 positive tets of a cube */
    double scale[3];     /* world length of one coarse voxel per axis (quality is judged there) */
} lmesh;

static void vertex_pos(const lmesh *lm, size_t v, double out[3]) {
    size_t cell = lm->vcell[v];
    size_t a[3] = {cell % lm->cm[0], (cell / lm->cm[0]) % lm->cm[1], cell / (lm->cm[0] * lm->cm[1])};
    for (int d = 0; d < 3; d++) {
        double centre = (double)a[d] - 0.5;
        out[d] = centre + lm->lambda[v] * (lm->target[3 * v + d] - centre);
    }
}

/* Mean of the midpoints of the cell's label-change edges; the centre when there are none. */
static void smooth_target(const lgrid *g, const size_t a[3], double out[3]) {
    uint16_t cd[8];
    for (int q = 0; q < 8; q++)
        cd[q] = g->code[gidx(g, (int64_t)a[0] + (q & 1), (int64_t)a[1] + ((q >> 1) & 1),
                             (int64_t)a[2] + (q >> 2))];
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int q = 0; q < 8; q++)
        for (int bit = 1; bit < 8; bit <<= 1) {
            int o = q | bit;
            if (o == q || cd[o] == cd[q]) continue;
            for (int d = 0; d < 3; d++) {
                double x = (q >> d) & 1;
                s[d] += (1 << d) == bit ? 0.5 : x;
            }
            n++;
        }
    for (int d = 0; d < 3; d++) out[d] = (double)a[d] - 1.0 + (n ? s[d] / n : 0.5);
}

static vm_status add_vertex(lmesh *lm, size_t cell, int smooth, int32_t *id, vm_error *err) {
    if (lm->vid[cell] >= 0) {
        *id = lm->vid[cell];
        return VM_OK;
    }
    if (lm->nv >= (size_t)INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: more than 2^31 vertices");
    vm_status st = vm__grow((void **)&lm->target, &lm->tcap, 3 * (lm->nv + 1), sizeof(double), err);
    if (!st) st = vm__grow((void **)&lm->lambda, &lm->lcap, lm->nv + 1, sizeof(double), err);
    if (!st) st = vm__grow((void **)&lm->vcell, &lm->vcap, lm->nv + 1, sizeof(size_t), err);
    if (st) return st;
    size_t a[3] = {cell % lm->cm[0], (cell / lm->cm[0]) % lm->cm[1], cell / (lm->cm[0] * lm->cm[1])};
    smooth_target(lm->g, a, lm->target + 3 * lm->nv);
    lm->lambda[lm->nv] = smooth ? 1.0 : 0.0;
    lm->vcell[lm->nv] = cell;
    lm->vid[cell] = (int32_t)lm->nv;
    *id = (int32_t)lm->nv++;
    return VM_OK;
}

static vm_status build_hexes(lmesh *lm, int smooth, vm_error *err) {
    const lgrid *g = lm->g;
    for (int a = 0; a < 3; a++) lm->cm[a] = (size_t)g->m[a] - 1;
    size_t ncell = lm->cm[0] * lm->cm[1] * lm->cm[2];
    lm->vid = malloc(ncell * sizeof *lm->vid);
    if (!lm->vid) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (vertices)");
    for (size_t i = 0; i < ncell; i++) lm->vid[i] = -1;
    for (int64_t k = 1; k < g->m[2] - 1; k++)
        for (int64_t j = 1; j < g->m[1] - 1; j++)
            for (int64_t i = 1; i < g->m[0] - 1; i++) {
                uint16_t c = g->code[gidx(g, i, j, k)];
                if (!c || (lm->lvl && lm->lvl[gidx(g, i, j, k)] > 0)) continue;
                vm_status st = vm__grow((void **)&lm->hex, &lm->hcap, 8 * (lm->nh + 1), sizeof(int32_t), err);
                if (!st) st = vm__grow((void **)&lm->hcode, &lm->ccap, lm->nh + 1, sizeof(uint16_t), err);
                if (st) return st;
                for (int q = 0; q < 8; q++) {
                    int b = vtk_bit[q];
                    size_t cell = (size_t)(i - 1 + (b & 1)) +
                                  lm->cm[0] * ((size_t)(j - 1 + ((b >> 1) & 1)) +
                                               lm->cm[1] * (size_t)(k - 1 + (b >> 2)));
                    st = add_vertex(lm, cell, smooth, lm->hex + 8 * lm->nh + q, err);
                    if (st) return st;
                }
                lm->hcode[lm->nh++] = c;
            }
    return VM_OK;
}

/* ---- per-label sizes: an octree of interior leaves ---------------------------------- */

/* 1 when the vertex of dual cell a (the point between padded cells a .. a + 1) stays at its
 * lattice point: its eight cells hold one code, smooth is 0, or the mean of its
 * label-change edge midpoints is the point itself (a flat interface or boundary there). */
static int dual_fixed(const lgrid *g, const size_t a[3], int smooth) {
    if (!smooth) return 1;
    double t[3];
    smooth_target(g, a, t);
    return t[0] == (double)a[0] - 0.5 && t[1] == (double)a[1] - 0.5 &&
           t[2] == (double)a[2] - 0.5;
}

/* 1 when padded cell (i, j, k) of code x may join a leaf: every point of the cell (its eight
 * corners, so its faces and edges) is a dual vertex at its lattice point, never moved by the
 * smoothing. Inside a label that is every cell whose 26 neighbours hold x; on a flat part of
 * an interface or of the boundary it is true as well, so leaves reach flat faces. */
static int leaf_safe(const lgrid *g, int64_t i, int64_t j, int64_t k, uint16_t x, int smooth) {
    int same = 1;
    for (int d = 0; d < 27 && same; d++)
        same = g->code[gidx(g, i + d % 3 - 1, j + (d / 3) % 3 - 1, k + d / 9 - 1)] == x;
    if (same) return 1;
    for (int q = 0; q < 8; q++) {
        size_t a[3] = {(size_t)(i - 1 + (q & 1)), (size_t)(j - 1 + ((q >> 1) & 1)),
                       (size_t)(k - 1 + (q >> 2))};
        if (!dual_fixed(g, a, smooth)) return 0;
    }
    return 1;
}

/* Trailing zero bits of x, at most cap (cap for 0). */
static int low_zeros(int64_t x, int cap) {
    int n = 0;
    while (n < cap && x % 2 == 0) {
        x /= 2;
        n++;
    }
    return n;
}

/* The octree's origin along each axis: leaves of size sz start at padded cells o with
 * (o - 1 + sh) % sz == 0. Chosen per axis among 0 .. 2^maxl - 1 so that the planes where a
 * coarse label meets anything else lie on the boundaries of the largest blocks (each such
 * face counts the levels whose blocks it bounds); ties keep 0. */
static vm_status choose_shift(const lgrid *g, const int *lmax, int maxl, int64_t sh[3],
                              vm_error *err) {
    const int64_t *m = g->m;
    int64_t step[3] = {1, m[0], m[0] * m[1]};
    for (int a = 0; a < 3; a++) {
        sh[a] = 0;
        size_t *hist = calloc((size_t)m[a], sizeof *hist);
        if (!hist) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the label octree");
        size_t total = (size_t)(m[0] * m[1] * m[2]);
        for (size_t p = 0; p + (size_t)step[a] < total; p++) {
            uint16_t x = g->code[p], y = g->code[p + (size_t)step[a]];
            if (x == y || (lmax[x] < 1 && lmax[y] < 1)) continue;
            hist[(p / (size_t)step[a]) % (size_t)m[a]]++; /* the plane after this cell */
        }
        uint64_t best = 0;
        for (int64_t t = 0; t < ((int64_t)1 << maxl); t++) {
            uint64_t score = 0;
            for (int64_t i = 0; i < m[a]; i++)
                score += (uint64_t)hist[i] * (uint64_t)low_zeros(i + t, maxl);
            if (score > best) {
                best = score;
                sh[a] = t;
            }
        }
        free(hist);
    }
    return VM_OK;
}

/* The first padded cell at or after 1 where a leaf of size sz may start (see choose_shift). */
static int64_t first_start(int64_t sz, int64_t sh) {
    return 1 + (sz - sh % sz) % sz;
}

/* Level of the leaf of every padded cell: -1 background, 0 a cell of size h, l > 0 a leaf of
 * 2^l cells per axis. A cell may join a leaf only when lmax of its label allows and every
 * point of it is a dual vertex at its lattice position (leaf_safe: inside its label, or on a
 * flat face of it), never moved by the interface smoothing, so that a leaf is an exact cube.
 * Leaves are aligned and grown bottom-up, then split until cells touching at a face, edge or
 * corner, of any label, differ by at most one level (2:1). [out] *out (free it), *nleaves:
 * leaves of level > 0. */
static vm_status build_leaves(const lgrid *g, const int *lmax, int smooth, int64_t sh[3],
                              int8_t **out, size_t *nleaves, vm_error *err) {
    const int64_t *m = g->m;
    size_t total = (size_t)(m[0] * m[1] * m[2]);
    int64_t c[3] = {m[0] - 2, m[1] - 2, m[2] - 2};
    int maxl = 0;
    for (int q = 1; q <= g->K; q++)
        if (lmax[q] > maxl) maxl = lmax[q];
    vm_status st = choose_shift(g, lmax, maxl, sh, err);
    if (st) return st;
    int8_t *lv = malloc(total);
    uint8_t *safe = calloc(total, 1);
    if (!lv || !safe) {
        free(lv);
        free(safe);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the label octree");
    }
    for (size_t p = 0; p < total; p++) lv[p] = g->code[p] ? 0 : -1;
    *nleaves = 0;
    for (int64_t k = 1; k <= c[2] && maxl > 0; k++)
        for (int64_t j = 1; j <= c[1]; j++)
            for (int64_t i = 1; i <= c[0]; i++) {
                size_t p = gidx(g, i, j, k);
                uint16_t x = g->code[p];
                if (!x || lmax[x] < 1) continue;
                safe[p] = (uint8_t)leaf_safe(g, i, j, k, x, smooth);
            }
    for (int l = 1; l <= maxl; l++) {
        int64_t sz = (int64_t)1 << l;
        for (int64_t oz = first_start(sz, sh[2]); oz + sz - 1 <= c[2]; oz += sz)
            for (int64_t oy = first_start(sz, sh[1]); oy + sz - 1 <= c[1]; oy += sz)
                for (int64_t ox = first_start(sz, sh[0]); ox + sz - 1 <= c[0]; ox += sz) {
                    int64_t o[3] = {ox, oy, oz};
                    uint16_t x = g->code[gidx(g, o[0], o[1], o[2])];
                    if (!x || lmax[x] < l) continue;
                    int ok = 1;
                    for (int64_t k = 0; k < sz && ok; k++)
                        for (int64_t j = 0; j < sz && ok; j++)
                            for (int64_t i = 0; i < sz && ok; i++) {
                                size_t p = gidx(g, o[0] + i, o[1] + j, o[2] + k);
                                ok = g->code[p] == x && (l == 1 ? safe[p] : lv[p] == l - 1);
                            }
                    if (!ok) continue;
                    for (int64_t k = 0; k < sz; k++)
                        for (int64_t j = 0; j < sz; j++)
                            for (int64_t i = 0; i < sz; i++)
                                lv[gidx(g, o[0] + i, o[1] + j, o[2] + k)] = (int8_t)l;
                }
    }
    free(safe);
    /* 2:1 balance: split every leaf with a neighbour two or more levels finer */
    for (int changed = maxl > 1; changed;) {
        changed = 0;
        for (int64_t k = 1; k <= c[2]; k++)
            for (int64_t j = 1; j <= c[1]; j++)
                for (int64_t i = 1; i <= c[0]; i++) {
                    int l = lv[gidx(g, i, j, k)];
                    int64_t sz = (int64_t)1 << (l > 0 ? l : 0);
                    if (l < 2 || (i - 1 + sh[0]) % sz || (j - 1 + sh[1]) % sz ||
                        (k - 1 + sh[2]) % sz)
                        continue;
                    int split = 0;
                    for (int64_t z = -1; z <= sz && !split; z++)
                        for (int64_t y = -1; y <= sz && !split; y++)
                            for (int64_t x = -1; x <= sz && !split; x++) {
                                if (x >= 0 && x < sz && y >= 0 && y < sz && z >= 0 && z < sz)
                                    x = sz - 1; /* skip the inside of the leaf */
                                else {
                                    int q = lv[gidx(g, i + x, j + y, k + z)];
                                    split = q >= 0 && q < l - 1;
                                }
                            }
                    if (!split) continue;
                    for (int64_t z = 0; z < sz; z++)
                        for (int64_t y = 0; y < sz; y++)
                            for (int64_t x = 0; x < sz; x++)
                                lv[gidx(g, i + x, j + y, k + z)] = (int8_t)(l - 1);
                    changed = 1;
                }
    }
    for (int64_t k = 1; k <= c[2]; k++)
        for (int64_t j = 1; j <= c[1]; j++)
            for (int64_t i = 1; i <= c[0]; i++) {
                int l = lv[gidx(g, i, j, k)];
                int64_t sz = (int64_t)1 << (l > 0 ? l : 0);
                if (l > 0 && (i - 1 + sh[0]) % sz == 0 && (j - 1 + sh[1]) % sz == 0 &&
                    (k - 1 + sh[2]) % sz == 0)
                    (*nleaves)++;
            }
    *out = lv;
    return VM_OK;
}

/* 1 when dual point p (unpadded point coordinates: the corner between cells p - 1 and p) is a
 * corner of some leaf. */
static int is_leaf_corner(const lmesh *lm, const int64_t p[3]) {
    const lgrid *g = lm->g;
    for (int q = 0; q < 8; q++) {
        int64_t cc[3] = {p[0] + (q & 1), p[1] + ((q >> 1) & 1), p[2] + (q >> 2)}; /* padded */
        if (cc[0] >= g->m[0] || cc[1] >= g->m[1] || cc[2] >= g->m[2]) continue;
        int l = lm->lvl[gidx(g, cc[0], cc[1], cc[2])];
        if (l < 0) continue;
        if (l == 0) return 1;
        int64_t sz = (int64_t)1 << l;
        int corner = 1;
        for (int a = 0; a < 3 && corner; a++) {
            int64_t u = cc[a] - 1 + lm->sh[a], o = u - u % sz;
            corner = p[a] + lm->sh[a] == o || p[a] + lm->sh[a] == o + sz;
        }
        if (corner) return 1;
    }
    return 0;
}

static vm_status point_vertex(lmesh *lm, const int64_t p[3], int32_t *id, vm_error *err) {
    size_t cell = (size_t)p[0] + lm->cm[0] * ((size_t)p[1] + lm->cm[1] * (size_t)p[2]);
    return add_vertex(lm, cell, 0, id, err);
}

static vm_status leaf_tet(lmesh *lm, const int64_t pts[4][3], uint16_t code, vm_error *err) {
    int32_t n[4];
    double x[4][3];
    for (int q = 0; q < 4; q++) {
        vm_status st = point_vertex(lm, pts[q], &n[q], err);
        if (st) return st;
        for (int d = 0; d < 3; d++) x[q][d] = (double)pts[q][d];
    }
    if (vm_tet_signed_volume((const double(*)[3])x) < 0) {
        int32_t sw = n[1];
        n[1] = n[2];
        n[2] = sw;
    }
    vm_status st =
        vm__grow((void **)&lm->ct, &lm->ctcap, 4 * (lm->nct + 1), sizeof(int32_t), err);
    if (!st)
        st = vm__grow((void **)&lm->ctcode, &lm->ctccap, lm->nct + 1, sizeof(uint16_t), err);
    if (st) return st;
    memcpy(lm->ct + 4 * lm->nct, n, sizeof n);
    lm->ctcode[lm->nct++] = code;
    return VM_OK;
}

/* The face square of a leaf in plane p[a] = pa from (u0, v0) (axes a+1, a+2) with side sz,
 * coned to the leaf centre cpos. Its triangulation depends only on which points of the
 * square are leaf corners, so the leaves on both sides cut it alike: with a corner at its
 * centre (a finer neighbour: then its edge midpoints are corners too) it is four squares;
 * with corners at some edge midpoints only, a fan from its centre (a new point inside the
 * face, which no other face sees) over its corners and those midpoints; else the diagonal
 * from its lowest corner (the diagonal a Kuhn cube cuts its faces along). */
static vm_status leaf_square(lmesh *lm, int a, int64_t pa, int64_t u0, int64_t v0, int64_t sz,
                             const int64_t cpos[3], uint16_t code, vm_error *err) {
    int u = (a + 1) % 3, v = (a + 2) % 3;
    /* boundary walk: corner, midpoint, corner, ... counterclockwise in (u, v) */
    static const int ring[8][2] = {{0, 0}, {1, 0}, {2, 0}, {2, 1},
                                   {2, 2}, {1, 2}, {0, 2}, {0, 1}};
    int64_t pt[8][3], mid[3];
    int have[8], nmid = 0;
    int64_t h = sz / 2;
    for (int q = 0; q < 8; q++) {
        pt[q][a] = pa;
        pt[q][u] = u0 + ring[q][0] * sz / 2; /* corners exact for sz = 1 too */
        pt[q][v] = v0 + ring[q][1] * sz / 2;
        have[q] = (q & 1) == 0 || (sz >= 2 && is_leaf_corner(lm, pt[q]));
        nmid += (q & 1) && have[q];
    }
    mid[a] = pa;
    mid[u] = u0 + h;
    mid[v] = v0 + h;
    if (sz >= 2 && is_leaf_corner(lm, mid)) {
        for (int q = 0; q < 4; q++) {
            vm_status st = leaf_square(lm, a, pa, u0 + (q & 1) * h, v0 + (q >> 1) * h, h, cpos,
                                       code, err);
            if (st) return st;
        }
        return VM_OK;
    }
    int64_t t[4][3];
    memcpy(t[0], cpos, sizeof t[0]);
    if (nmid == 0) {
        static const int tri[2][2] = {{2, 4}, {4, 6}}; /* with ring[0]: diagonal 0-4 */
        for (int k = 0; k < 2; k++) {
            memcpy(t[1], pt[0], sizeof t[1]);
            memcpy(t[2], pt[tri[k][0]], sizeof t[2]);
            memcpy(t[3], pt[tri[k][1]], sizeof t[3]);
            vm_status st = leaf_tet(lm, (const int64_t(*)[3])t, code, err);
            if (st) return st;
        }
        return VM_OK;
    }
    memcpy(t[1], mid, sizeof t[1]);
    for (int q = 0; q < 8; q++) {
        if (!have[q]) continue;
        int r = (q + 1) % 8;
        if (!have[r]) r = (r + 1) % 8;
        memcpy(t[2], pt[q], sizeof t[2]);
        memcpy(t[3], pt[r], sizeof t[3]);
        vm_status st = leaf_tet(lm, (const int64_t(*)[3])t, code, err);
        if (st) return st;
    }
    return VM_OK;
}

/* Tets of every leaf of level > 0: its six faces (conforming with the neighbours' cuts) coned
 * to its centre. All their points are at their lattice positions, so no tet is inverted. */
static vm_status build_leaf_tets(lmesh *lm, vm_error *err) {
    const lgrid *g = lm->g;
    for (int64_t k = 1; k < g->m[2] - 1; k++)
        for (int64_t j = 1; j < g->m[1] - 1; j++)
            for (int64_t i = 1; i < g->m[0] - 1; i++) {
                int l = lm->lvl[gidx(g, i, j, k)];
                if (l <= 0) continue;
                int64_t sz = (int64_t)1 << l, o[3] = {i - 1, j - 1, k - 1};
                if ((o[0] + lm->sh[0]) % sz || (o[1] + lm->sh[1]) % sz ||
                    (o[2] + lm->sh[2]) % sz)
                    continue;
                int64_t cpos[3] = {o[0] + sz / 2, o[1] + sz / 2, o[2] + sz / 2};
                vm_status st = VM_OK;
                uint16_t code = g->code[gidx(g, i, j, k)];
                for (int a = 0; a < 3 && !st; a++)
                    for (int side = 0; side < 2 && !st; side++)
                        st = leaf_square(lm, a, o[a] + side * sz, o[(a + 1) % 3], o[(a + 2) % 3],
                                         sz, cpos, code, err);
                if (st) return st;
            }
    return VM_OK;
}

static void kuhn_table(int t[6][4]) {
    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    for (int p = 0; p < 6; p++) {
        t[p][0] = 0;
        t[p][1] = 1 << perm[p][0];
        t[p][2] = (1 << perm[p][0]) | (1 << perm[p][1]);
        t[p][3] = 7;
        double x[4][3];
        for (int v = 0; v < 4; v++)
            for (int d = 0; d < 3; d++) x[v][d] = (t[p][v] >> d) & 1;
        if (vm_tet_signed_volume((const double(*)[3])x) < 0) {
            int s = t[p][1];
            t[p][1] = t[p][2];
            t[p][2] = s;
        }
    }
}

/* VTK position of bit-indexed corner b. */
static int bit_to_vtk(int b) {
    for (int q = 0; q < 8; q++)
        if (vtk_bit[q] == b) return q;
    return 0;
}

/* Smallest scaled Jacobian (world frame) an element may keep; below it its vertices move
 * back toward the staircase, where a hex is a box (1) and a Kuhn tet has about 0.7. */
#define VM_LABEL_MIN_HEX_SJ 0.2
#define VM_LABEL_MIN_TET_SJ 0.2

/* 1 when hex h (or its six tets) is clearly valid at the current positions. */
static int hex_ok(const lmesh *lm, size_t h, int tets) {
    double p[8][3];
    for (int q = 0; q < 8; q++) {
        vertex_pos(lm, (size_t)lm->hex[8 * h + q], p[q]);
        for (int d = 0; d < 3; d++) p[q][d] *= lm->scale[d];
    }
    if (!tets) return vm_hex_min_scaled_jacobian((const double(*)[3])p) > VM_LABEL_MIN_HEX_SJ;
    for (int t = 0; t < 6; t++) {
        double x[4][3];
        for (int v = 0; v < 4; v++) memcpy(x[v], p[bit_to_vtk(lm->kuhn[t][v])], sizeof x[v]);
        if (vm_tet_scaled_jacobian((const double(*)[3])x) <= VM_LABEL_MIN_TET_SJ) return 0;
    }
    return 1;
}

/* Volume of hex h in coarse index units, as the output will have it (6 tets or trilinear). */
static double hex_volume_now(const lmesh *lm, size_t h, int tets) {
    double p[8][3];
    for (int q = 0; q < 8; q++) vertex_pos(lm, (size_t)lm->hex[8 * h + q], p[q]);
    if (!tets) return vm_hex_volume((const double(*)[3])p);
    double s = 0;
    for (int t = 0; t < 6; t++) {
        double x[4][3];
        for (int v = 0; v < 4; v++) memcpy(x[v], p[bit_to_vtk(lm->kuhn[t][v])], sizeof x[v]);
        s += vm_tet_signed_volume((const double(*)[3])x);
    }
    return s;
}

/* Volume-keeping rounds (the last only applies the scales), and how far each aims below the
 * tolerance (90 %: the error is only close to linear in the smoothing). */
enum { KEEP_ROUNDS = 6 };
static const double undershoot = 0.9;

/* Smoothing rounds convex corners and thins 1-voxel structures, so it costs volume. Per label,
 * scale the smoothing of the vertices it touches until its volume is within tol of its voxel
 * count (the error is close to linear in the smoothing amount); a vertex shared by several
 * labels takes the smallest scale. */
static vm_status keep_volumes(lmesh *lm, int K, int tets, double tol, vm_error *err) {
    double *g = malloc(((size_t)K + 1) * sizeof *g), *vol = malloc(((size_t)K + 1) * sizeof *vol);
    size_t *cnt = malloc(((size_t)K + 1) * sizeof *cnt);
    if (!g || !vol || !cnt) {
        free(g);
        free(vol);
        free(cnt);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (int L = 0; L <= K; L++) {
        g[L] = 1;
        cnt[L] = 0;
    }
    for (size_t h = 0; h < lm->nh; h++) cnt[lm->hcode[h]]++;
    for (int round = 0; round < KEEP_ROUNDS; round++) {
        for (size_t v = 0; v < lm->nv; v++)
            if (lm->lambda[v] > 0) lm->lambda[v] = 1;
        for (size_t h = 0; h < lm->nh; h++)
            for (int q = 0; q < 8; q++) {
                size_t v = (size_t)lm->hex[8 * h + q];
                if (lm->lambda[v] > g[lm->hcode[h]]) lm->lambda[v] = g[lm->hcode[h]];
            }
        if (round == KEEP_ROUNDS - 1) break;
        for (int L = 0; L <= K; L++) vol[L] = 0;
        for (size_t h = 0; h < lm->nh; h++) vol[lm->hcode[h]] += hex_volume_now(lm, h, tets);
        int again = 0;
        for (int L = 1; L <= K; L++) {
            if (!cnt[L]) continue;
            double e = fabs(vol[L] - (double)cnt[L]) / (double)cnt[L];
            if (e <= tol) continue;
            g[L] *= undershoot * tol / e;
            again = 1;
        }
        if (!again) break;
    }
    free(g);
    free(vol);
    free(cnt);
    return VM_OK;
}

/* Relaxation rounds at most; the first RELAX_HALVINGS halve a vertex's smoothing, down to
 * relax_floor (1/16), then it goes all the way to the cell centre. */
enum { RELAX_ROUNDS = 64, RELAX_HALVINGS = 8 };
static const double relax_floor = 1.0 / 16;

/* Pulls the vertices of every element that is not clearly valid toward their cell centres
 * (halving, then all the way), where every element is a positive cube. */
static size_t relax(lmesh *lm, int tets) {
    uint8_t *moved = calloc(lm->nv ? lm->nv : 1, 1);
    for (int round = 0; round < RELAX_ROUNDS; round++) {
        size_t bad = 0;
        for (size_t h = 0; h < lm->nh; h++) {
            if (hex_ok(lm, h, tets)) continue;
            bad++;
            for (int q = 0; q < 8; q++) {
                size_t v = (size_t)lm->hex[8 * h + q];
                if (lm->lambda[v] <= 0) continue;
                lm->lambda[v] =
                    round < RELAX_HALVINGS && lm->lambda[v] > relax_floor ? lm->lambda[v] * 0.5 : 0.0;
                if (moved) moved[v] = 1;
            }
        }
        if (!bad) break;
    }
    size_t n = 0;
    for (size_t v = 0; moved && v < lm->nv; v++) n += moved[v];
    free(moved);
    return n;
}

/* ---- the public entry ---------------------------------------------------------------- */

/* Largest cell size, and largest size of one label, in voxels. */
enum { MAX_CELL_SIZE = 1024 };
/* Most labels: codes are uint16_t with 0 the background (one value kept spare). */
enum { MAX_LABELS = 65534 };
/* Deepest octree level a label may reach. */
enum { MAX_LEVEL = 10 };
/* Finest refinement of a voxel per axis (sizes down to 1/8 voxel). */
enum { MAX_REFINE = 8 };
/* Round-off guard when sizes given as decimals are rounded to whole ratios (1/0.2 is 5). */
static const double ratio_eps = 1e-9;
/* Each label's volume is kept to within this fraction by the smoothing (1 %). */
static const double keep_volume_tol = 0.01;
/* A vertex this close (in cells) to its cell centre counts as not smoothed. */
static const double centre_eps = 1e-12;

/* One vm_mesh_labels run: what each stage hands to the next. */
typedef struct lrun {
    const vm_volume *v;
    const vm_label_options *o;
    int tets;          /* tets, else hexes */
    label_set present; /* the labels in the volume, with their voxel counts */
    int32_t *chosen;   /* the K labels meshed, ascending (code c is chosen[c - 1]) */
    size_t K;
    double *lsize;    /* per code: the label's cell size, in voxels */
    int *lmax;        /* per code: the deepest octree level the label may reach */
    int S, U, coarse; /* voxels per cell (S) or cells per voxel (U); some label coarser */
    double h;         /* the finest cell size, in voxels */
    lgrid g;
    int8_t *lvl; /* octree levels (build_leaves); NULL when nothing is coarser */
    int64_t sh[3]; /* the octree's origin (choose_shift) */
    lmesh lm;
    uint8_t *rescued;            /* per code: given a block by rescue_labels */
    size_t *isl_pieces, *isl_cells; /* per code: what --min-island relabelled */
    vm_label_info *info; /* per code - 1 */
    size_t islands, topo, nleaves, relaxed, smoothed;
} lrun;

/* Frees what the stages allocated (not the mesh). */
static void lrun_free(lrun *R) {
    free(R->present.val);
    free(R->present.count);
    free(R->chosen);
    free(R->g.code);
    free(R->g.rank);
    free(R->lm.vid);
    free(R->lm.vcell);
    free(R->lm.target);
    free(R->lm.lambda);
    free(R->lm.hex);
    free(R->lm.hcode);
    free(R->lm.ct);
    free(R->lm.ctcode);
    free(R->lvl);
    free(R->lsize);
    free(R->lmax);
    free(R->info);
    free(R->rescued);
    free(R->isl_pieces);
    free(R->isl_cells);
}

/* Checks the options that need no volume. */
static vm_status check_options(const vm_label_options *o, vm_error *err) {
    if (o->elements != VM_TET4 && o->elements != VM_HEX8)
        return vm_error_set(err, VM_ERR_ARG, "mesh: elements must be tetrahedra or hexahedra");
    if (o->cell_size < 1 || o->cell_size > MAX_CELL_SIZE)
        return vm_error_set(err, VM_ERR_ARG, "mesh: cell size %d is outside 1..1024",
                            o->cell_size);
    if (o->labels == NULL && o->nlabels > 0)
        return vm_error_set(err, VM_ERR_ARG, "mesh: %zu labels given without a list",
                            o->nlabels);
    return VM_OK;
}

/* The labels to mesh (R->chosen, R->K of them, ascending): the listed ones, each of which
 * must be in the volume, or else every label in it but 0. */
static vm_status choose_labels(lrun *R, vm_error *err) {
    const vm_label_options *o = R->o;
    const label_set *present = &R->present;
    vm_status st = collect_labels(R->v, &R->present, err);
    if (st) return st;
    size_t K = 0;
    if (o->labels) {
        R->chosen = malloc((o->nlabels ? o->nlabels : 1) * sizeof *R->chosen);
        if (!R->chosen) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        int32_t *chosen = R->chosen;
        memcpy(chosen, o->labels, o->nlabels * sizeof *chosen);
        qsort(chosen, o->nlabels, sizeof *chosen, cmp_i32);
        for (size_t i = 0; i < o->nlabels; i++) {
            if (K > 0 && chosen[K - 1] == chosen[i]) continue;
            if (find_label(present->val, present->n, chosen[i]) < 0) {
                char list[300];
                format_labels(present, list, sizeof list);
                return vm_error_set(err, VM_ERR_EMPTY,
                                    "mesh: label %ld is not in the volume (labels present: %s)",
                                    (long)chosen[i], list);
            }
            chosen[K++] = chosen[i];
        }
    } else {
        R->chosen = malloc((present->n ? present->n : 1) * sizeof *R->chosen);
        if (!R->chosen) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        for (size_t i = 0; i < present->n; i++)
            if (present->val[i] != 0) R->chosen[K++] = present->val[i];
    }
    R->K = K;
    if (K == 0)
        return vm_error_set(err, VM_ERR_EMPTY, "mesh: the volume holds no label other than 0");
    if (K > MAX_LABELS)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "mesh: %zu labels chosen; at most 65534",
                            K);
    return VM_OK;
}

/* The world diagonal of one voxel: a cell of s voxels has the diagonal s times this. */
static double voxel_diagonal(const vm_volume *v) {
    const double *sp = v->spacing;
    return sqrt(sp[0] * sp[0] + sp[1] * sp[1] + sp[2] * sp[2]);
}

/* Sets the size of label (voxels) in R->lsize, refusing a label not meshed and a second
 * size; what: the option that gave it, for the messages. */
static vm_status set_size(lrun *R, int32_t label, double size, const char *what,
                          vm_error *err) {
    long f = find_label(R->chosen, R->K, label);
    if (f < 0) {
        char list[300];
        format_labels(&R->present, list, sizeof list);
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: %s names label %ld, which is not meshed (not in the volume "
                            "or not chosen; labels present: %s)",
                            what, (long)label, list);
    }
    if (R->lsize[f + 1] > 0)
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: label %ld has two sizes (--size-per-label and --label-edge "
                            "may name a label once between them)",
                            (long)label);
    R->lsize[f + 1] = size;
    return VM_OK;
}

/* Reads the per-label sizes and edges into R->lsize (-1 where none is given); *hmin: the
 * smallest size, the cell size when it is smaller. */
static vm_status read_sizes(lrun *R, double *hmin, vm_error *err) {
    const vm_label_options *o = R->o;
    for (size_t c = 0; c <= R->K; c++)
        R->lsize[c] = -1;
    *hmin = o->cell_size;
    for (size_t i = 0; i < o->nsizes; i++) {
        const vm_label_size *ls = &o->sizes[i];
        if (find_label(R->chosen, R->K, ls->label) >= 0 &&
            (!(ls->size > 0) || !isfinite(ls->size) || ls->size > MAX_CELL_SIZE))
            return vm_error_set(err, VM_ERR_ARG,
                                "mesh: size %g of label %ld is not in (0, 1024]", ls->size,
                                (long)ls->label);
        vm_status st = set_size(R, ls->label, ls->size, "--size-per-label", err);
        if (st) return st;
        if (ls->size < *hmin) *hmin = ls->size;
    }
    double d = voxel_diagonal(R->v);
    for (size_t i = 0; i < o->nedges; i++) {
        const vm_label_edge *le = &o->edges[i];
        if (!(le->edge > 0) || !isfinite(le->edge))
            return vm_error_set(err, VM_ERR_ARG,
                                "mesh: --label-edge %g of label %ld is not a length > 0",
                                le->edge, (long)le->label);
        double size = fmin(le->edge / d, (double)MAX_CELL_SIZE);
        if (size * MAX_REFINE < 1 - ratio_eps)
            return vm_error_set(err, VM_ERR_ARG,
                                "mesh: --label-edge %g of label %ld is below 1/8 of the voxel "
                                "diagonal (%g): cells that fine are not supported",
                                le->edge, (long)le->label, d);
        vm_status st = set_size(R, le->label, size, "--label-edge", err);
        if (st) return st;
        if (size < *hmin) *hmin = size;
    }
    return VM_OK;
}

/* The finest cell size R->h (from S voxels per cell or U cells per voxel), then each label's
 * size and the octree level it may reach (R->lmax; R->coarse when some is above 0). */
static vm_status label_sizes(lrun *R, vm_error *err) {
    const vm_label_options *o = R->o;
    if (o->adaptive && (o->max_level < 1 || o->max_level > MAX_LEVEL))
        return vm_error_set(err, VM_ERR_ARG, "mesh: max level %d is outside 1..10",
                            o->max_level);
    if (o->nsizes && !o->sizes)
        return vm_error_set(err, VM_ERR_ARG, "mesh: %zu label sizes given without a list",
                            o->nsizes);
    if (o->nedges && !o->edges)
        return vm_error_set(err, VM_ERR_ARG, "mesh: %zu label edges given without a list",
                            o->nedges);
    if (!(o->max_edge >= 0) || !isfinite(o->max_edge))
        return vm_error_set(err, VM_ERR_ARG, "mesh: --max-edge %g is not a length > 0",
                            o->max_edge);
    if (o->max_edge > 0 && o->adaptive)
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: give adaptive (--adaptive) or max_edge (--max-edge), not "
                            "both");
    R->lsize = malloc((R->K + 1) * sizeof *R->lsize);
    R->lmax = calloc(R->K + 1, sizeof *R->lmax);
    if (!R->lsize || !R->lmax) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    double hmin;
    vm_status st = read_sizes(R, &hmin, err);
    if (st) return st;
    int S = o->cell_size, U = 1;
    double h = S;
    if (hmin < 1) {
        U = (int)ceil(1.0 / hmin - ratio_eps);
        if (U > MAX_REFINE)
            return vm_error_set(err, VM_ERR_ARG,
                                "mesh: sizes below 1/8 voxel (%g) are not supported", hmin);
        S = 1;
        h = 1.0 / U;
    } else if (hmin < S) {
        S = (int)floor(hmin + ratio_eps);
        h = S;
    }
    R->S = S;
    R->U = U;
    R->h = h;
    for (size_t c = 1; c <= R->K; c++) {
        if (R->lsize[c] < 0 && o->max_edge > 0) /* never finer than the grid */
            R->lsize[c] = fmax(fmin(o->max_edge / voxel_diagonal(R->v), MAX_CELL_SIZE), h);
        else if (R->lsize[c] < 0)
            R->lsize[c] = o->adaptive ? h * (double)(1 << o->max_level) : (double)o->cell_size;
        int l = (int)floor(log2(R->lsize[c] / h) + ratio_eps);
        R->lmax[c] = l < 0 ? 0 : l > MAX_LEVEL ? MAX_LEVEL : l;
        R->coarse |= R->lmax[c] > 0;
    }
    if (R->coarse && !R->tets)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "mesh: labels with cells coarser than the finest (per-label sizes, "
                            "adaptive) need tets, not hexes");
    return VM_OK;
}

/* Stage 1 (stats->seconds_grid): the labels and their sizes, and the code grid without the
 * islands below min_island voxels. */
static vm_status stage_grid(lrun *R, vm_error *err) {
    const vm_label_options *o = R->o;
    vm_status st = choose_labels(R, err);
    if (!st) st = label_sizes(R, err);
    if (st) return st;
    if (o->progress && o->progress("labels", 0, 4, o->progress_user)) return vm__cancelled(err, "mesh");
    R->rescued = calloc(R->K + 1, 1);
    R->isl_pieces = calloc(R->K + 1, sizeof *R->isl_pieces);
    R->isl_cells = calloc(R->K + 1, sizeof *R->isl_cells);
    if (!R->rescued || !R->isl_pieces || !R->isl_cells)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    st = build_grid(R->v, R->chosen, (int)R->K, R->S, R->U, &R->g, R->rescued, err);
    if (!st && o->min_island > 1)
        st = remove_islands(&R->g, o->min_island, &R->islands, R->isl_pieces, R->isl_cells,
                            err);
    return st;
}

/* Stage 2 (stats->seconds_repair): the repair ranks, the well-composed repair, and the octree
 * leaves of the coarser labels. */
static vm_status stage_repair(lrun *R, vm_error *err) {
    vm_status st = make_ranks(&R->g, err);
    if (!st) st = make_well_composed(&R->g, &R->topo, err);
    if (!st && R->coarse) st = build_leaves(&R->g, R->lmax, R->o->smooth, R->sh, &R->lvl, &R->nleaves, err);
    return st;
}

/* The elements: one hex per labelled voxel (split into tets when written), the tets of the
 * coarse leaves. */
static vm_status build_elements(lrun *R, vm_error *err) {
    lmesh *lm = &R->lm;
    lm->g = &R->g;
    kuhn_table(lm->kuhn);
    lm->lvl = R->lvl;
    memcpy(lm->sh, R->sh, sizeof lm->sh);
    for (int d = 0; d < 3; d++)
        lm->scale[d] = R->h * R->v->spacing[d];
    vm_status st = build_hexes(lm, R->o->smooth, err);
    if (!st && R->lvl) st = build_leaf_tets(lm, err);
    if (st) return st;
    if (lm->nh == 0 && lm->nct == 0)
        return vm_error_set(
            err, VM_ERR_EMPTY,
            "mesh: no voxel of the chosen labels is left (--size or --min-island "
            "removed them all)");
    return VM_OK;
}

/* Writes the vertices in world coordinates (room reserved for the cells too); counts in
 * R->smoothed those that smoothing moved off their cell centre. */
static vm_status write_points(lrun *R, vm_mesh *mesh, vm_error *err) {
    const lmesh *lm = &R->lm;
    double h = R->h;
    size_t ncells = R->tets ? 6 * lm->nh + lm->nct : lm->nh;
    vm_status st = vm_mesh_reserve(mesh, lm->nv, ncells, err);
    if (st) return st;
    for (size_t i = 0; i < lm->nv; i++) {
        double x[3], ijk[3];
        vertex_pos(lm, i, x);
        if (lm->lambda[i] > 0) {
            size_t cell = lm->vcell[i];
            size_t a[3] = {cell % lm->cm[0], (cell / lm->cm[0]) % lm->cm[1],
                           cell / (lm->cm[0] * lm->cm[1])};
            for (int d = 0; d < 3; d++)
                if (fabs(x[d] - ((double)a[d] - 0.5)) > centre_eps) {
                    R->smoothed++;
                    break;
                }
        }
        for (int d = 0; d < 3; d++)
            ijk[d] = h * x[d] + 0.5 * (h - 1);
        vm_volume_index_to_world(R->v, ijk, mesh->points + 3 * i);
    }
    mesh->npoints = lm->nv;
    return VM_OK;
}

/* Appends the hexes (6 Kuhn tets each with tets), adding to each label's elements and
 * volume; flip: the volume's frame is left-handed. */
static void write_hexes(const lrun *R, vm_mesh *mesh, int flip) {
    const lmesh *lm = &R->lm;
    int tets = R->tets;
    for (size_t e = 0; e < lm->nh; e++) {
        const int32_t *c = lm->hex + 8 * e;
        int32_t region = R->chosen[lm->hcode[e] - 1];
        vm_label_info *li = &R->info[lm->hcode[e] - 1];
        for (int t = 0; t < (tets ? 6 : 1); t++) {
            vm_index *dst = mesh->cells + (size_t)vm_cell_nodes(mesh->kind) * mesh->ncells;
            double p[8][3];
            if (tets) {
                for (int q = 0; q < 4; q++)
                    dst[q] = c[bit_to_vtk(lm->kuhn[t][q])];
                if (flip) {
                    vm_index s = dst[1];
                    dst[1] = dst[2];
                    dst[2] = s;
                }
                for (int q = 0; q < 4; q++)
                    memcpy(p[q], mesh->points + 3 * (size_t)dst[q], sizeof p[q]);
                li->mesh_volume += vm_tet_signed_volume((const double(*)[3])p);
            } else {
                for (int q = 0; q < 8; q++)
                    dst[q] = c[q];
                if (flip) {
                    vm_index s = dst[1];
                    dst[1] = dst[3];
                    dst[3] = s;
                    s = dst[5];
                    dst[5] = dst[7];
                    dst[7] = s;
                }
                for (int q = 0; q < 8; q++)
                    memcpy(p[q], mesh->points + 3 * (size_t)dst[q], sizeof p[q]);
                li->mesh_volume += vm_hex_volume((const double(*)[3])p);
            }
            mesh->region[mesh->ncells++] = region;
            li->elements++;
        }
    }
}

/* Appends the coarse leaves' tets, adding to each label's elements and volume. */
static void write_leaf_tets(const lrun *R, vm_mesh *mesh, int flip) {
    const lmesh *lm = &R->lm;
    for (size_t e = 0; e < lm->nct; e++) {
        vm_index *dst = mesh->cells + 4 * mesh->ncells;
        for (int q = 0; q < 4; q++)
            dst[q] = lm->ct[4 * e + q];
        if (flip) {
            vm_index sw = dst[1];
            dst[1] = dst[2];
            dst[2] = sw;
        }
        double p[4][3];
        for (int q = 0; q < 4; q++)
            memcpy(p[q], mesh->points + 3 * (size_t)dst[q], sizeof p[q]);
        vm_label_info *li = &R->info[lm->ctcode[e] - 1];
        li->mesh_volume += vm_tet_signed_volume((const double(*)[3])p);
        mesh->region[mesh->ncells++] = R->chosen[lm->ctcode[e] - 1];
        li->elements++;
    }
}

/* Stage 3 (stats->seconds_mesh): the elements, smoothed keeping each label's volume and
 * relaxed where not valid, written to mesh with each label's counts in R->info. */
static vm_status stage_mesh(lrun *R, vm_mesh *mesh, vm_error *err) {
    const vm_label_options *o = R->o;
    if (o->progress && o->progress("labels", 1, 4, o->progress_user)) return vm__cancelled(err, "mesh");
    vm_status st = build_elements(R, err);
    if (st) return st;
    if (o->progress && o->progress("labels", 2, 4, o->progress_user)) return vm__cancelled(err, "mesh");
    if (o->smooth) st = keep_volumes(&R->lm, (int)R->K, R->tets, keep_volume_tol, err);
    if (st) return st;
    R->relaxed = relax(&R->lm, R->tets);
    if (o->progress && o->progress("labels", 3, 4, o->progress_user)) return vm__cancelled(err, "mesh");
    st = write_points(R, mesh, err);
    if (st) return st;
    int flip = vm_volume_frame_determinant(R->v) < 0;
    R->info = calloc(R->K, sizeof *R->info);
    if (!R->info) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    write_hexes(R, mesh, flip);
    write_leaf_tets(R, mesh, flip);
    const lgrid *g = &R->g;
    for (size_t p = 0; p < (size_t)(g->m[0] * g->m[1] * g->m[2]); p++)
        if (g->code[p]) R->info[g->code[p] - 1].meshed_voxels++;
    return VM_OK;
}

/* Fills stats from the run (it takes R->info); t0..t2: the stages' start times. */
static void fill_stats(lrun *R, vm_label_stats *stats, double t0, double t1, double t2) {
    vm_label_info *info = R->info;
    double h = R->h;
    double vox = fabs(vm_volume_frame_determinant(R->v)) * h * h * h;
    for (size_t i = 0; i < R->K; i++) {
        info[i].label = R->chosen[i];
        long f = find_label(R->present.val, R->present.n, R->chosen[i]);
        info[i].input_voxels = f >= 0 ? R->present.count[f] : 0;
        info[i].voxel_volume = (double)info[i].meshed_voxels * vox;
        info[i].size = R->lsize[i + 1];
        info[i].rescued = R->rescued[i + 1];
        info[i].islands_removed = R->isl_pieces[i + 1];
        info[i].island_cells_removed = R->isl_cells[i + 1];
    }
    stats->nlabels = R->K;
    stats->labels = info;
    R->info = NULL;
    stats->island_voxels = R->islands;
    stats->topology_voxels = R->topo;
    stats->smoothed_vertices = R->smoothed;
    stats->relaxed_vertices = R->relaxed;
    stats->cell_size = h;
    stats->coarse_cells = R->nleaves;
    stats->seconds = vm__now() - t0;
    stats->seconds_grid = t1 - t0;
    stats->seconds_repair = t2 - t1;
    stats->seconds_mesh = stats->seconds - (t2 - t0);
}

/* Meshes the chosen labels of v (see volmesh/labels.h), in three timed stages. */
vm_status vm_mesh_labels(const vm_volume *v, const vm_label_options *o, vm_mesh *mesh,
                         vm_label_stats *stats, vm_error *err) {
    double t0 = vm__now();
    int tets = o->elements != VM_HEX8;
    vm_mesh_init(mesh, tets ? VM_TET4 : VM_HEX8);
    if (stats) memset(stats, 0, sizeof *stats);
    vm_status st = check_options(o, err);
    if (st) return st;
    lrun R;
    memset(&R, 0, sizeof R);
    R.v = v;
    R.o = o;
    R.tets = tets;
    st = stage_grid(&R, err);
    double t1 = vm__now();
    if (!st) st = stage_repair(&R, err);
    double t2 = vm__now();
    if (!st) st = stage_mesh(&R, mesh, err);
    if (!st && o->progress && o->progress("labels", 4, 4, o->progress_user)) st = vm__cancelled(err, "mesh");
    if (!st && stats) fill_stats(&R, stats, t0, t1, t2);
    lrun_free(&R);
    if (st) vm_mesh_free(mesh);
    return st;
}
