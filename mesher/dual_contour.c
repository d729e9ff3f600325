/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dual_contour.c — the cell analysis of dual contouring shared by the tet and hex
 * meshers (seed 001, LBIE §4): grid classification against {lo <= f <= hi}, boundary cells
 * split into surface patches (one minimiser each, so ambiguous cells stay manifold), patch
 * vertices from the QEF, vertices of ambiguous faces, the padded border, the octree. */
#include "../core/core.h"
#include "dc_internal.h"
#include "qef.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Cube corners c = x + 2y + 4z. Edge e = 4*a + u + 2*v runs along axis a from corner
 * vm__dc_edge_c0[e]; u, v are its offsets along axes (a+1)%3 and (a+2)%3. */
int vm__dc_edge_c0[12], vm__dc_edge_c1[12], vm__dc_edge_of[8][8];
/* Face f = 2*a + s (corners with bit a == s), corners in cyclic order. */
int vm__dc_face_corner[6][4];
vm__dc_kind vm__dc_kinds[256];

static void analyse_cell(int mask, vm__dc_kind *b);

void vm__dc_init_tables(void) {
    static int done;
    if (done) return;
    memset(vm__dc_edge_of, -1, sizeof vm__dc_edge_of);
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int uv = 0; uv < 4; uv++) {
            int e = 4 * a + uv, u = uv & 1, v = uv >> 1;
            vm__dc_edge_c0[e] = (u << b) | (v << c);
            vm__dc_edge_c1[e] = vm__dc_edge_c0[e] | (1 << a);
            vm__dc_edge_of[vm__dc_edge_c0[e]][vm__dc_edge_c1[e]] =
                vm__dc_edge_of[vm__dc_edge_c1[e]][vm__dc_edge_c0[e]] = e;
        }
        for (int s = 0; s < 2; s++) {
            static const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            for (int q = 0; q < 4; q++)
                vm__dc_face_corner[2 * a + s][q] =
                    (s << a) | (cyc[q][0] << b) | (cyc[q][1] << c);
        }
    }
    for (int mask = 0; mask < 256; mask++)
        analyse_cell(mask, &vm__dc_kinds[mask]);
    done = 1;
}

/* Index-space gradient by central differences (one-sided on the border). */
static void gradient(const dc *d, const int64_t p[3], double gr[3]) {
    for (int a = 0; a < 3; a++) {
        int64_t lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0], p[1], p[2]};
        if (p[a] > 0) lo[a]--;
        if (p[a] < d->n[a] - 1) hi[a]++;
        double h = (double)(hi[a] - lo[a]);
        gr[a] =
            h > 0
                ? (vm__dc_fval(d, hi[0], hi[1], hi[2]) - vm__dc_fval(d, lo[0], lo[1], lo[2])) /
                      h
                : 0.0;
    }
}

/* Splits the crossing edges of a cell into surface patches: on each face the crossing
 * points are joined in pairs, and an ambiguous face (inside corners on a diagonal) keeps
 * its inside corners apart, so the inside is 6-connected. */
static int find(const int *parent, int x) {
    while (parent[x] != x)
        x = parent[x];
    return x;
}

static void analyse_cell(int mask, vm__dc_kind *b) {
    int parent[12];
    for (int e = 0; e < 12; e++)
        parent[e] = e;
    int cross[12];
    for (int e = 0; e < 12; e++)
        cross[e] = ((mask >> vm__dc_edge_c0[e]) & 1) != ((mask >> vm__dc_edge_c1[e]) & 1);
    for (int f = 0; f < 6; f++) {
        int fe[4], nc = 0, list[4];
        for (int q = 0; q < 4; q++) {
            fe[q] =
                vm__dc_edge_of[vm__dc_face_corner[f][q]][vm__dc_face_corner[f][(q + 1) & 3]];
            if (cross[fe[q]]) list[nc++] = fe[q];
        }
        if (nc == 2) {
            parent[find(parent, list[0])] = find(parent, list[1]);
        } else if (nc == 4) {
            for (int q = 0; q < 4; q++)
                if ((mask >> vm__dc_face_corner[f][q]) &
                    1) /* edges before and after corner q */
                    parent[find(parent, fe[(q + 3) & 3])] = find(parent, fe[q]);
        }
    }
    int label[12];
    b->npatch = 0;
    for (int e = 0; e < 12; e++)
        label[e] = -1;
    for (int e = 0; e < 12; e++) {
        b->edge_patch[e] = NONE;
        if (!cross[e]) continue;
        int r = find(parent, e);
        if (label[r] < 0) label[r] = b->npatch++;
        b->edge_patch[e] = (uint8_t)label[r];
    }
    for (int c = 0; c < 8; c++)
        b->corner_patch[c] = NONE;
    for (int e = 0; e < 12; e++)
        if (cross[e]) {
            int c = ((mask >> vm__dc_edge_c0[e]) & 1) ? vm__dc_edge_c0[e] : vm__dc_edge_c1[e];
            b->corner_patch[c] = b->edge_patch[e];
        }
    for (int pass = 0; pass < 4; pass++) /* spread along inside-inside edges */
        for (int e = 0; e < 12; e++) {
            int c0 = vm__dc_edge_c0[e], c1 = vm__dc_edge_c1[e];
            if (cross[e] || !((mask >> c0) & 1)) continue;
            if (b->corner_patch[c0] == NONE) b->corner_patch[c0] = b->corner_patch[c1];
            if (b->corner_patch[c1] == NONE) b->corner_patch[c1] = b->corner_patch[c0];
        }
    /* The one configuration where a component meets two patches: exactly two antipodal
     * corners outside. Its interior edges use an extra vertex at the cell centre. */
    int out = ~mask & 0xff;
    b->special = 0;
    for (int c = 0; c < 4; c++)
        if (out == ((1 << c) | (1 << (c ^ 7)))) b->special = 1;
}

/* Bit sets of n bits in 64-bit words. */
static uint64_t *bits_new(size_t n) {
    return calloc(n / 64 + 1, sizeof(uint64_t));
}

/* Coordinates (padded: 0 .. dims-1) of index i of a grid of dims, x fastest. */
static void unflatten(int64_t i, const int64_t dims[3], int64_t out[3]) {
    out[0] = i % dims[0];
    out[1] = (i / dims[0]) % dims[1];
    out[2] = i / (dims[0] * dims[1]);
}

/* Steps c to the next entry of a grid of dims, x fastest. */
static void step_coords(int64_t c[3], const int64_t dims[3]) {
    if (++c[0] < dims[0]) return;
    c[0] = 0;
    if (++c[1] < dims[1]) return;
    c[1] = 0;
    c[2]++;
}

/* Bit of padded grid point c in the material (counted in *inside); the padding is outside. */
static int point_in(const dc *d, const int64_t c[3], size_t *inside) {
    const vm__grid *g = d->g;
    int64_t i = c[0] - 1, j = c[1] - 1, k = c[2] - 1;
    if (i < 0 || j < 0 || k < 0 || i >= d->n[0] || j >= d->n[1] || k >= d->n[2]) return 0;
    float f = vm__dc_fval(d, i, j, k);
    int is = (!g->has_lo || f >= g->lo) && (!g->has_hi || f <= g->hi);
    *inside += (size_t)is;
    return is;
}

/* Word w of a bit set over a grid of dims (n entries, x fastest): bit b is bit(d, c, count)
 * at the coordinates c of entry 64 w + b, which may add to *count. */
static uint64_t grid_word(const dc *d, int64_t w, const int64_t dims[3], size_t n,
                          int (*bit)(const dc *, const int64_t[3], size_t *), size_t *count) {
    int64_t c[3], first = 64 * w;
    unflatten(first, dims, c);
    uint64_t word = 0;
    for (int b = 0; b < 64 && first + b < (int64_t)n; b++, step_coords(c, dims))
        word |= (uint64_t)bit(d, c, count) << b;
    return word;
}

/* Fills the bit set bits over a grid of dims (n entries) with bit(d, c, count) per entry,
 * word by word in parallel (threads never share a word); returns the sum of the counts. */
static size_t fill_bits(const dc *d, uint64_t *bits, const int64_t dims[3], size_t n,
                        int (*bit)(const dc *, const int64_t[3], size_t *)) {
    size_t total = 0;
    int64_t nw = (int64_t)(n / 64 + 1);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : total)
#endif
    for (int64_t w = 0; w < nw; w++) {
        size_t cnt = 0;
        bits[w] = grid_word(d, w, dims, n, bit, &cnt);
        total += cnt;
    }
    return total;
}

/* Marks the grid points in the material (d->in), word by word in parallel. */
static vm_status classify(dc *d, vm_mesh_stats *st, vm_error *err) {
    size_t np = (size_t)(d->P[0] * d->P[1] * d->P[2]);
    d->in = bits_new(np);
    if (!d->in) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (%zu points)", np);
    size_t inside = fill_bits(d, d->in, d->P, np, point_in);
    st->inside_voxels = inside;
    if (!inside) return vm_error_set(err, VM_ERR_EMPTY, "no grid point is in the material");
    return VM_OK;
}

static int cell_mask(const dc *d, int64_t i, int64_t j, int64_t k) {
    int mask = 0;
    for (int c = 0; c < 8; c++)
        mask |= vm__dc_in(d, vm__dc_pidx(d, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)))
                << c;
    return mask;
}

static void free_cells(dc *d) {
    free(d->bnd);
    free(d->bnd_rank);
    d->bnd = NULL;
    d->bnd_rank = NULL;
}

/* Bit of padded cell c on the boundary (its corners mix); interior cells are counted in
 * *interior. The last plane along each axis holds no cell. */
static int cell_on_boundary(const dc *d, const int64_t c[3], size_t *interior) {
    if (c[0] == d->C[0] - 1 || c[1] == d->C[1] - 1 || c[2] == d->C[2] - 1) return 0;
    int mask = cell_mask(d, c[0] - 1, c[1] - 1, c[2] - 1);
    if (mask == 0xff) (*interior)++;
    return mask != 0 && mask != 0xff;
}

/* Marks the boundary cells (d->bnd) and ranks them (d->bnd_rank). */
static vm_status find_cells(dc *d, vm_mesh_stats *st, vm_error *err) {
    size_t nc = (size_t)(d->C[0] * d->C[1] * d->C[2]);
    int64_t nw = (int64_t)(nc / 64 + 1);
    d->bnd = bits_new(nc);
    d->bnd_rank = malloc((size_t)nw * sizeof *d->bnd_rank);
    if (!d->bnd || !d->bnd_rank)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (%zu cells)", nc);
    /* The cell kinds first, in parallel word by word, then the boundary cells in order. The
     * last plane along each axis holds no cell (cells share the points' strides). */
    size_t reps = 0, interior = fill_bits(d, d->bnd, d->C, nc, cell_on_boundary);
    st->interior_cells += interior;
    uint32_t before = 0;
    for (int64_t w = 0; w < nw; w++) {
        d->bnd_rank[w] = before;
        for (uint64_t bits = d->bnd[w]; bits; bits &= bits - 1) {
            int64_t ci = 64 * w + __builtin_ctzll(bits), cm[3];
            vm__dc_cell_coords(d, ci, cm);
            int mask = cell_mask(d, cm[0], cm[1], cm[2]);
            vm_status s =
                vm__grow((void **)&d->bc, &d->bc_cap, d->nbc + 1, sizeof(bcell), err);
            if (s) return s;
            bcell *b = &d->bc[d->nbc];
            const vm__dc_kind *kind = &vm__dc_kinds[mask];
            b->cell = ci;
            b->mask = (uint8_t)mask;
            b->base = (int32_t)reps;
            reps += kind->npatch + kind->special;
            if (reps > (size_t)INT32_MAX || d->nbc >= (size_t)INT32_MAX)
                return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many surface vertices");
            st->special_cells += kind->special;
            d->nbc++;
            for (int a = 0; a < 3; a++) { /* the cell's upper face along a */
                const int *fc = vm__dc_face_corner[2 * a + 1];
                int q0 = (mask >> fc[0]) & 1, q1 = (mask >> fc[1]) & 1;
                int q2 = (mask >> fc[2]) & 1, q3 = (mask >> fc[3]) & 1;
                if (q0 == q2 && q1 == q3 && q0 != q1) {
                    s = vm__grow((void **)&d->amb, &d->amb_cap, d->namb + 1, sizeof(int64_t),
                                 err);
                    if (s) return s;
                    d->amb[d->namb++] = 3 * ci + a;
                }
            }
        }
        before = (uint32_t)d->nbc;
    }
    st->boundary_cells = d->nbc;
    /* An ambiguous face needs its own vertices only when both cells put its two segments
     * in one patch: then the two cells' vertices would be joined twice. */
    size_t kept = 0;
    for (size_t fi = 0; fi < d->namb; fi++) {
        int64_t cm[3], um[3];
        int a = (int)(d->amb[fi] % 3);
        vm__dc_cell_coords(d, d->amb[fi] / 3, cm);
        memcpy(um, cm, sizeof um);
        um[a]++;
        const vm__dc_kind *lo = vm__dc_kind_of(&d->bc[vm__dc_code(d, d->amb[fi] / 3)]);
        const vm__dc_kind *up =
            vm__dc_kind_of(&d->bc[vm__dc_code(d, vm__dc_cidx(d, um[0], um[1], um[2]))]);
        const int *fc = vm__dc_face_corner[2 * a + 1];
        int e0 = vm__dc_edge_of[fc[0]][fc[1]], e2 = vm__dc_edge_of[fc[2]][fc[3]];
        int u0 = vm__dc_edge_of[fc[0] ^ (1 << a)][fc[1] ^ (1 << a)];
        int u2 = vm__dc_edge_of[fc[2] ^ (1 << a)][fc[3] ^ (1 << a)];
        /* edges 0-1 and 2-3 of the face belong to different segments */
        if (lo->edge_patch[e0] == lo->edge_patch[e2] &&
            up->edge_patch[u0] == up->edge_patch[u2])
            d->amb[kept++] = d->amb[fi];
    }
    d->namb = kept;
    d->amb_base = reps;
    d->nreps = reps + 2 * d->namb;
    return VM_OK;
}

/* Crossings keep this fraction of an edge away from its ends (2 %): no vertex on a grid
 * point, no zero-length edge. */
static const double crossing_margin = 0.02;

/* Where the material boundary crosses the grid edge p0-p1 (one end inside): linear
 * interpolation against the bound the outside end violates, kept 2% away from the ends;
 * the normal is the interpolated gradient. Absolute index coordinates. */
static void edge_crossing(const dc *d, const int64_t p0[3], const int64_t p1[3], double pt[3],
                          double nrm[3]) {
    const vm__grid *g = d->g;
    double f0 = vm__dc_fval(d, p0[0], p0[1], p0[2]), f1 = vm__dc_fval(d, p1[0], p1[1], p1[2]);
    int in0 = vm__dc_in(d, vm__dc_pidx(d, p0[0], p0[1], p0[2]));
    double fo = in0 ? f1 : f0;
    double bound = (g->has_hi && fo > g->hi) ? g->hi : g->lo;
    double t = (f1 != f0) ? (bound - f0) / (f1 - f0) : 0.5;
    if (!(t >= crossing_margin)) t = crossing_margin;
    if (t > 1 - crossing_margin) t = 1 - crossing_margin;
    double g0[3], g1[3];
    gradient(d, p0, g0);
    gradient(d, p1, g1);
    for (int a = 0; a < 3; a++) {
        pt[a] = vm__dc_coord(d, p0[a], a) + t * (double)(p1[a] - p0[a]);
        nrm[a] = (1 - t) * g0[a] + t * g1[a];
    }
    double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    if (len > 0)
        for (int a = 0; a < 3; a++)
            nrm[a] /= len;
}

/* Eigenvalues of a patch's QEF below this fraction of the largest are dropped: flat and
 * cylindrical patches keep their vertex near the mass point. */
static const double qef_cutoff = 0.05;
/* An ambiguous face's vertex relaxes toward the corner it cuts off, to this fraction of the
 * way from that corner to its crossings' midpoint. */
static const double amb_pull = 0.35;

/* The minimiser and mass point of each patch of boundary cell bi (and the centre of a
 * special cell); writes only its own representatives. */
static void place_cell_reps(dc *d, size_t bi) {
    const bcell *b = &d->bc[bi];
    const vm__dc_kind *kind = vm__dc_kind_of(b);
    int64_t cm[3];
    vm__dc_cell_coords(d, b->cell, cm);
    int fixed[3] = {0, 0, 0};
    double fixval[3] = {0, 0, 0};
    uint8_t planes = 0;
    for (int a = 0; a < 3; a++) {
        if (cm[a] < 0) { /* spans [-1, 0]: pinned to plane 0, relative 1 */
            fixed[a] = 1;
            fixval[a] = 1.0;
            planes |= (uint8_t)(1 << (2 * a));
        } else if (cm[a] + 1 >= d->n[a]) { /* spans [n-1, n] */
            fixed[a] = 1;
            fixval[a] = 0.0;
            planes |= (uint8_t)(1 << (2 * a + 1));
        }
    }
    for (int p = 0; p < kind->npatch; p++) {
        vm_qef q;
        vm__qef_init(&q);
        for (int e = 0; e < 12; e++) {
            if (kind->edge_patch[e] != p) continue;
            int64_t p0[3], p1[3];
            for (int a = 0; a < 3; a++) {
                p0[a] = cm[a] + ((vm__dc_edge_c0[e] >> a) & 1);
                p1[a] = cm[a] + ((vm__dc_edge_c1[e] >> a) & 1);
            }
            if (!vm__dc_real_point(d, p0) || !vm__dc_real_point(d, p1)) continue;
            double pt[3], nrm[3];
            edge_crossing(d, p0, p1, pt, nrm);
            for (int a = 0; a < 3; a++)
                pt[a] -= vm__dc_coord(d, cm[a], a);
            vm__qef_add(&q, pt, nrm);
        }
        double x[3], m[3];
        if (q.count == 0) {
            for (int a = 0; a < 3; a++)
                x[a] = m[a] = fixed[a] ? fixval[a] : 0.5;
        } else {
            vm__qef_solve(&q, qef_cutoff, fixed, fixval, x, m);
        }
        size_t r = (size_t)b->base + (size_t)p;
        for (int a = 0; a < 3; a++) {
            if (x[a] < 0) x[a] = 0;
            if (x[a] > 1) x[a] = 1;
            d->qpos[3 * r + a] = vm__dc_coord(d, cm[a], a) + x[a];
            d->mpos[3 * r + a] = vm__dc_coord(d, cm[a], a) + m[a];
        }
        d->lambda[r] = 1.0f;
        d->rep_planes[r] = planes;
        d->mu[r] = 1.0f;
    }
    if (kind->special) {
        size_t r = (size_t)b->base + kind->npatch;
        for (int a = 0; a < 3; a++)
            d->qpos[3 * r + a] = d->mpos[3 * r + a] = vm__dc_coord(d, cm[a], a) + 0.5;
        d->lambda[r] = 1.0f;
        d->rep_planes[r] = 0;
        d->mu[r] = 1.0f;
    }
}

/* The vertices of ambiguous face fi: one per boundary segment, midway between its two
 * crossings; writes only its own representatives. */
static void place_face_reps(dc *d, size_t fi) {
    int64_t cm[3];
    int a = (int)(d->amb[fi] % 3);
    vm__dc_cell_coords(d, d->amb[fi] / 3, cm);
    const int *fc = vm__dc_face_corner[2 * a + 1];
    int64_t pc[4][3];
    for (int q = 0; q < 4; q++)
        for (int k = 0; k < 3; k++)
            pc[q][k] = cm[k] + ((fc[q] >> k) & 1);
    int first = vm__dc_in(d, vm__dc_pidx(d, pc[0][0], pc[0][1], pc[0][2])) ? 0 : 1;
    for (int h = 0; h < 2; h++) {
        int q = first + 2 * h;
        double x0[3], x1[3], nrm[3];
        edge_crossing(d, pc[q], pc[(q + 1) & 3], x0, nrm);
        edge_crossing(d, pc[q], pc[(q + 3) & 3], x1, nrm);
        size_t r = d->amb_base + 2 * fi + (size_t)h;
        /* relaxation pulls it toward the corner it cuts off */
        for (int k = 0; k < 3; k++) {
            d->qpos[3 * r + k] = 0.5 * (x0[k] + x1[k]);
            d->mpos[3 * r + k] =
                vm__dc_coord(d, pc[q][k], k) +
                amb_pull * (d->qpos[3 * r + k] - vm__dc_coord(d, pc[q][k], k));
        }
        d->lambda[r] = 1.0f;
        d->mu[r] = 1.0f;
        uint8_t planes = 0;
        if (pc[0][a] == 0) planes |= (uint8_t)(1 << (2 * a));
        if (pc[0][a] == d->n[a] - 1) planes |= (uint8_t)(1 << (2 * a + 1));
        d->rep_planes[r] = planes;
    }
}

/* Places the minimiser and mass point of every patch (index coordinates). Cells reaching
 * into the padding pin the padded axes to the border plane and use only crossings between
 * real points, so the border faces are the 2-D dual contour of the material's section. */
static vm_status place_reps(dc *d, const double *coarse_pos, vm_error *err) {
    size_t n = d->nreps ? d->nreps : 1;
    d->qpos = malloc(3 * n * sizeof(double));
    d->mpos = malloc(3 * n * sizeof(double));
    d->lambda = malloc(n * sizeof(float));
    d->rep_planes = calloc(n, 1);
    d->mu = malloc(n * sizeof(float));
    if (!d->qpos || !d->mpos || !d->lambda || !d->rep_planes || !d->mu)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for %zu vertices", n);
    /* each cell and each ambiguous face writes only its own representatives */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 4096)
#endif
    for (size_t bi = 0; bi < d->nbc; bi++) {
        /* cancelled: the remaining cells are skipped (the run then stops) */
        if ((bi & 4095) == 0 ? vm__progress_poll_team(d->g->progress, d->g->progress_user)
                             : vm__progress_stopped(d->g->progress, d->g->progress_user))
            continue;
        place_cell_reps(d, bi);
    }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (size_t fi = 0; fi < d->namb; fi++)
        place_face_reps(d, fi);
    for (size_t l = 0; l < d->ncoarse; l++) { /* coarse boundary leaves: one patch each */
        size_t r = d->coarse_base + l;
        for (int a = 0; a < 3; a++) {
            d->qpos[3 * r + (size_t)a] = coarse_pos[6 * l + (size_t)a];
            d->mpos[3 * r + (size_t)a] = coarse_pos[6 * l + 3 + (size_t)a];
        }
        d->lambda[r] = 1.0f;
        d->mu[r] = 1.0f;
        d->rep_planes[r] = 0;
    }
    return vm__progress_stopped(d->g->progress, d->g->progress_user) ? vm__cancelled(err, "mesh")
                                                                      : VM_OK;
}

/* Index of the first of the n increasing keys that is >= key (n when none is). */
static size_t first_at_least(const int64_t *keys, size_t n, int64_t key) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (keys[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* Vertex of the ambiguous face between the cells around an edge (lower cell lower_cm,
 * face normal along axis a) on the segment cutting off the inside corner v, or -1. */
int64_t vm__dc_face_vertex(const dc *d, const int64_t lower_cm[3], int a, const int64_t v[3]) {
    int64_t key = 3 * vm__dc_cidx(d, lower_cm[0], lower_cm[1], lower_cm[2]) + a;
    size_t lo = first_at_least(d->amb, d->namb, key);
    if (lo == d->namb || d->amb[lo] != key) return -1;
    int corner = 0;
    for (int k = 0; k < 3; k++)
        corner |= (int)(v[k] - lower_cm[k]) << k;
    const int *fc = vm__dc_face_corner[2 * a + 1];
    int pos = 0;
    while (fc[pos] != corner)
        pos++;
    return vm__dc_npoints_real(d) + (int64_t)(d->amb_base + 2 * lo + (size_t)(pos >> 1));
}

/* ---- vertices: global id = lattice index (0..N-1) or N + representative index ---- */

void vm__dc_vertex_pos(const dc *d, int64_t id, int reference, double out[3]) {
    int64_t N = vm__dc_npoints_real(d);
    if (id < N) {
        out[0] = vm__dc_coord(d, id % d->n[0], 0);
        out[1] = vm__dc_coord(d, (id / d->n[0]) % d->n[1], 1);
        out[2] = vm__dc_coord(d, id / (d->n[0] * d->n[1]), 2);
        return;
    }
    size_t r = (size_t)(id - N);
    if (r >= d->nreps) {
        memcpy(out, d->centre + 3 * (r - d->nreps), 3 * sizeof(double));
        return;
    }
    const double *m = d->mpos + 3 * r, *q = d->qpos + 3 * r;
    double l = reference ? 0.0 : d->lambda[r], u = reference ? 1.0 : d->mu[r];
    for (int a = 0; a < 3; a++)
        out[a] = m[a] + l * (q[a] - m[a]);
    if (u < 1.0) {
        double c[3] = {NAN, NAN, NAN};
        vm__dc_rep_centre(d, r, c);
        for (int a = 0; a < 3; a++)
            out[a] = c[a] + u * (out[a] - c[a]);
    }
}

int vm__dc_rep_centre(const dc *d, size_t r, double c[3]) {
    if (d->ncoarse && r >= d->coarse_base) {
        const int64_t *o = d->coarse_org + 3 * (r - d->coarse_base);
        for (int a = 0; c && a < 3; a++)
            c[a] = vm__dc_coord(d, o[a], a) + 1.0;
        return 1;
    }
    if (r >= d->amb_base || !d->nbc) return 0;
    size_t lo = 0, hi = d->nbc; /* the last cell whose vertices start at or below r */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if ((size_t)d->bc[mid].base <= r)
            lo = mid;
        else
            hi = mid;
    }
    const bcell *b = &d->bc[lo];
    if (vm__dc_kind_of(b)->npatch != 1 || r != (size_t)b->base) return 0;
    int64_t cm[3];
    vm__dc_cell_coords(d, b->cell, cm);
    for (int a = 0; c && a < 3; a++) /* padded axes: pinned to the border plane */
        c[a] = vm__dc_coord(d, cm[a], a) + (cm[a] < 0 ? 1.0 : cm[a] + 1 >= d->n[a] ? 0.0 : 0.5);
    return 1;
}

uint8_t vm__dc_vertex_planes(const dc *d, int64_t id) {
    int64_t N = vm__dc_npoints_real(d);
    if (id >= N) return (size_t)(id - N) < d->nreps ? d->rep_planes[id - N] : 0;
    int64_t p[3] = {id % d->n[0], (id / d->n[0]) % d->n[1], id / (d->n[0] * d->n[1])};
    uint8_t m = 0;
    for (int a = 0; a < 3; a++) {
        if (p[a] == 0) m |= (uint8_t)(1 << (2 * a));
        if (p[a] == d->n[a] - 1) m |= (uint8_t)(1 << (2 * a + 1));
    }
    return m;
}

/* Representative vertex of cell b for its local edge e. */
int64_t vm__dc_rep_for_edge(const dc *d, const bcell *b, int e) {
    int64_t N = vm__dc_npoints_real(d);
    const vm__dc_kind *k = vm__dc_kind_of(b);
    if (k->edge_patch[e] != NONE) return N + b->base + k->edge_patch[e];
    if (k->special) return N + b->base + k->npatch;
    return N + b->base + k->corner_patch[vm__dc_edge_c0[e]];
}

static int has_ambiguous_face(int mask) {
    for (int f = 0; f < 6; f++) {
        const int *fc = vm__dc_face_corner[f];
        int q0 = (mask >> fc[0]) & 1, q1 = (mask >> fc[1]) & 1;
        int q2 = (mask >> fc[2]) & 1, q3 = (mask >> fc[3]) & 1;
        if (q0 == q2 && q1 == q3 && q0 != q1) return 1;
    }
    return 0;
}

static int in_material(const dc *d, double f) {
    return (!d->g->has_lo || f >= d->g->lo) && (!d->g->has_hi || f <= d->g->hi);
}

/* Floor of a gradient's length (per voxel) in the EDerror terms: a flat spot is no divide by
 * zero, its term just large. */
static const double min_gradient = 1e-12;
/* The crossings' mean unit normal must be at least this long: below, they face every way
 * and the block is no flat patch. */
static const double min_mean_normal = 0.5;
/* Fine edges of a 2x2x2 block: 3 axes x 3 x 3 lines x 2 edges, each crossed at most once. */
enum { BLOCK_EDGES = 54 };

/* The corner mask of the 2x2x2 block of cells at o (bit c: its corner c is in the material). */
static int block_mask(const dc *d, const int64_t o[3]) {
    int mask = 0;
    for (int c = 0; c < 8; c++)
        mask |= vm__dc_in(d, vm__dc_pidx(d, o[0] + 2 * (c & 1), o[1] + 2 * ((c >> 1) & 1),
                                         o[2] + 2 * (c >> 2)))
                << c;
    return mask;
}

/* 1 when every coarse edge of the block's signs s crosses at most once. */
static int edges_cross_once(const int s[3][3][3]) {
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int u = 0; u <= 2; u += 2)
            for (int v = 0; v <= 2; v += 2) {
                int p[3][3];
                for (int t = 0; t < 3; t++) {
                    p[t][a] = t;
                    p[t][b] = u;
                    p[t][c] = v;
                }
                int s0 = s[p[0][0]][p[0][1]][p[0][2]], s1 = s[p[1][0]][p[1][1]][p[1][2]];
                int s2 = s[p[2][0]][p[2][1]][p[2][2]];
                if (s0 == s2 && s1 != s0) return 0;
            }
    }
    return 1;
}

/* 1 when every coarse face of the signs s is uniform or carries one crossing curve, and the
 * block centre agrees with a face centre (no bubble). */
static int faces_plain(const int s[3][3][3]) {
    int face_centre[6];
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int side = 0; side < 2; side++) {
            int pts[3][3], all = 1;
            for (int v = 0; v < 3; v++)
                for (int u = 0; u < 3; u++) {
                    int p[3];
                    p[a] = 2 * side;
                    p[b] = u;
                    p[c] = v;
                    pts[u][v] = s[p[0]][p[1]][p[2]];
                }
            int c0 = pts[0][0];
            if (pts[2][0] != c0 || pts[0][2] != c0 || pts[2][2] != c0) all = 0;
            int ctr = pts[1][1];
            face_centre[2 * a + side] = ctr;
            if (all) {
                for (int v = 0; v < 3; v++)
                    for (int u = 0; u < 3; u++)
                        if (pts[u][v] != c0) return 0;
            } else if (pts[1][0] != ctr && pts[0][1] != ctr && pts[2][1] != ctr &&
                       pts[1][2] != ctr) {
                return 0;
            }
        }
    }
    int ok = 0;
    for (int f = 0; f < 6; f++)
        ok |= face_centre[f] == s[1][1][1];
    return ok;
}

/* 1 when no cell of the block at o or around it (the 4x4x4 cells) is special or has an
 * ambiguous face. */
static int around_plain(const dc *d, const int64_t o[3]) {
    for (int64_t k = o[2] - 1; k <= o[2] + 2; k++)
        for (int64_t j = o[1] - 1; j <= o[1] + 2; j++)
            for (int64_t i = o[0] - 1; i <= o[0] + 2; i++) {
                int32_t code = vm__dc_code(d, vm__dc_cidx(d, i, j, k));
                if (code < 0) continue;
                if (vm__dc_kind_of(&d->bc[code])->special ||
                    has_ambiguous_face(cell_mask(d, i, j, k)))
                    return 0;
            }
    return 1;
}

/* The largest EDerror of the block's trilinear coarse cell at its non-corner points that it
 * puts on the other side of the material bound. */
static double trilinear_error(const dc *d, const int64_t o[3]) {
    double fc[8], edmax = 0;
    for (int c = 0; c < 8; c++)
        fc[c] =
            vm__dc_fval(d, o[0] + 2 * (c & 1), o[1] + 2 * ((c >> 1) & 1), o[2] + 2 * (c >> 2));
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++) {
                if (!(i & 1) && !(j & 1) && !(k & 1)) continue;
                double tx = i / 2.0, ty = j / 2.0, tz = k / 2.0, ft = 0;
                for (int c = 0; c < 8; c++)
                    ft += fc[c] * ((c & 1) ? tx : 1 - tx) * ((c >> 1) & 1 ? ty : 1 - ty) *
                          ((c >> 2) ? tz : 1 - tz);
                int64_t p[3] = {o[0] + i, o[1] + j, o[2] + k};
                double gr[3], f = vm__dc_fval(d, p[0], p[1], p[2]);
                gradient(d, p, gr);
                double gn = sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
                if (!(gn > min_gradient)) gn = min_gradient;
                if (in_material(d, f) == in_material(d, ft)) continue;
                if (fabs(f - ft) / gn > edmax) edmax = fabs(f - ft) / gn;
            }
    return edmax;
}

/* The fine crossings of the block at o with signs s (relative to o), their normals, and the
 * QEF over them; returns their count. */
static int block_crossings(const dc *d, const int64_t o[3], const int s[3][3][3],
                           double pts[BLOCK_EDGES][3], double nrms[BLOCK_EDGES][3], vm_qef *q) {
    int np = 0;
    vm__qef_init(q);
    for (int a = 0; a < 3; a++)
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                for (int i = 0; i < 3; i++) {
                    int64_t p0[3] = {o[0] + i, o[1] + j, o[2] + k}, p1[3];
                    int r[3] = {i, j, k};
                    if (r[a] == 2) continue;
                    memcpy(p1, p0, sizeof p1);
                    p1[a]++;
                    r[a]++;
                    if (s[i][j][k] == s[r[0]][r[1]][r[2]]) continue;
                    edge_crossing(d, p0, p1, pts[np], nrms[np]);
                    for (int t = 0; t < 3; t++)
                        pts[np][t] -= vm__dc_coord(d, o[t], t);
                    vm__qef_add(q, pts[np], nrms[np]);
                    np++;
                }
    return np;
}

/* The leaf's vertex x and mass point m from the np crossings: the mass point moved along the
 * crossings' mean normal onto the plane that fits their tangent planes best (the QEF
 * restricted to that line). A full QEF minimiser slides along a curved patch toward the
 * tangent planes' intersection, off the surface; the flat patches that merge need no
 * sharp-feature placement. Returns the flatness (the crossings' largest distance from the
 * plane through x normal to the mean), or -1 when the crossings face every way. */
static double fit_leaf_vertex(const double pts[][3], const double nrms[][3], int np,
                              const vm_qef *q, double x[3], double m[3]) {
    double nm[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++)
        m[a] = q->mass[a] / q->count;
    for (int i = 0; i < np; i++)
        for (int a = 0; a < 3; a++)
            nm[a] += nrms[i][a];
    double nl = sqrt(nm[0] * nm[0] + nm[1] * nm[1] + nm[2] * nm[2]);
    if (!(nl > min_mean_normal)) return -1;
    for (int a = 0; a < 3; a++)
        nm[a] /= nl;
    double num = 0, den = 0;
    for (int i = 0; i < np; i++) {
        double nn = 0, np_ = 0;
        for (int a = 0; a < 3; a++) {
            nn += nrms[i][a] * nm[a];
            np_ += nrms[i][a] * (pts[i][a] - m[a]);
        }
        num += nn * np_;
        den += nn * nn;
    }
    double t = den > 0 ? num / den : 0;
    for (int a = 0; a < 3; a++) {
        x[a] = m[a] + t * nm[a];
        x[a] = x[a] < 0 ? 0 : x[a] > 2 ? 2 : x[a];
    }
    double flat = 0;
    for (int i = 0; i < np; i++) {
        double dist = 0;
        for (int a = 0; a < 3; a++)
            dist += nm[a] * (pts[i][a] - x[a]);
        if (fabs(dist) > flat) flat = fabs(dist);
    }
    return flat;
}

/* Whether the aligned 2x2x2 block of cells at o (its 3x3x3 grid points s) can be one
 * boundary leaf without changing the topology of the boundary, and the coarse leaf's
 * QEF minimiser and mass point (relative to o) when it can. The criterion, on the signs:
 *  - the eight corners mix; the coarse cell has one patch, is not special and has no
 *    ambiguous face;
 *  - every coarse edge crosses at most once (a midpoint differs from its ends only when
 *    the ends differ);
 *  - on a coarse face whose corners agree all nine points agree; otherwise the face centre
 *    agrees with one of the face's edge midpoints (so each side of the one crossing curve
 *    is 4-connected and the face carries the same curve as the coarse face);
 *  - the block centre agrees with one of the face centres (no bubble);
 *  - no cell of the block or around it (the 4x4x4 cells) is special or has an ambiguous
 *    face, so only one-patch cells and plain faces meet the coarse leaf.
 * Then the inside points on the block's surface form one disk and the outside points the
 * other, the fine surface inside the block is one disk with the same boundary curve as the
 * coarse leaf's fan, and dropping the block's inner points keeps the topology.
 * The error (voxels) is the larger of two distances, and the block merges when it is at
 * most d->error:
 *  - the seed's EDerror terms |f - f_tri| / |grad f| (f_tri: the coarse cell's trilinear
 *    interpolant) at those of the 19 non-corner points that f_tri puts on the other side
 *    of the material bound: features (thin plates, tips) the coarse cell would cut off.
 *    Elsewhere the coarse leaf keeps the fine crossings (its vertex is their QEF
 *    minimiser), so EDerror there measures the trilinear cell, not the mesh;
 *  - the flatness (a curvature measure): the largest distance of a fine crossing from the
 *    plane through the minimiser normal to the crossings' mean normal, which bounds how
 *    far the fine surface lies from the leaf's fan. */
static int block_mergeable(const dc *d, const int64_t o[3], double x[3], double m[3]) {
    int mask = block_mask(d, o);
    if (mask == 0 || mask == 0xff || has_ambiguous_face(mask)) return 0;
    int s[3][3][3];
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++)
                s[i][j][k] = vm__dc_in(d, vm__dc_pidx(d, o[0] + i, o[1] + j, o[2] + k));
    const vm__dc_kind *cb = &vm__dc_kinds[mask];
    if (cb->npatch != 1 || cb->special) return 0;
    if (!edges_cross_once((const int(*)[3][3])s) || !faces_plain((const int(*)[3][3])s) ||
        !around_plain(d, o))
        return 0;
    if (trilinear_error(d, o) > d->error) return 0;
    /* the coarse QEF over every fine crossing of the block, and its flatness */
    vm_qef q;
    double pts[BLOCK_EDGES][3], nrms[BLOCK_EDGES][3];
    int np = block_crossings(d, o, (const int(*)[3][3])s, pts, nrms, &q);
    if (!np) return 0;
    double flat = fit_leaf_vertex((const double(*)[3])pts, (const double(*)[3])nrms, np, &q,
                                  x, m);
    return flat >= 0 && flat <= d->error;
}

/* Adaptive mode: merges aligned 2x2x2 blocks of boundary cells into coarse boundary leaves
 * where block_mergeable allows. Blocks keep one cell away from the padding. */
static vm_status merge_boundary(dc *d, double **coarse_pos, vm_error *err) {
    size_t nc = (size_t)(d->C[0] * d->C[1] * d->C[2]);
    d->coarse = bits_new(nc);
    if (!d->coarse) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    size_t cap = 0, key_cap = 0;
    /* block_mergeable reads only the classification: the blocks are tested in parallel,
     * then the mergeable ones are taken in order (their vertex recomputed). */
    int64_t nb[3];
    for (int a = 0; a < 3; a++)
        nb[a] = d->n[a] >= 6 ? (d->n[a] - 6) / 2 + 1 : 0;
    size_t nblocks = (size_t)(nb[0] * nb[1] * nb[2]);
    uint8_t *ok = malloc(nblocks ? nblocks : 1);
    if (!ok) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (int64_t bk = 0; bk < nb[2]; bk++)
        for (int64_t bj = 0; bj < nb[1]; bj++)
            for (int64_t bi = 0; bi < nb[0]; bi++) {
                int64_t o[3] = {2 + 2 * bi, 2 + 2 * bj, 2 + 2 * bk};
                double x[3], m[3];
                ok[bi + nb[0] * (bj + nb[1] * bk)] = (uint8_t)block_mergeable(d, o, x, m);
            }
    size_t bidx = 0;
    for (int64_t k = 2; k + 4 <= d->n[2]; k += 2)
        for (int64_t j = 2; j + 4 <= d->n[1]; j += 2)
            for (int64_t i = 2; i + 4 <= d->n[0]; i += 2) {
                int64_t o[3] = {i, j, k};
                double x[3], m[3];
                if (!ok[bidx++] || !block_mergeable(d, o, x, m)) continue;
                vm_status s = vm__grow((void **)&d->coarse_org, &d->coarse_cap, d->ncoarse + 1,
                                       3 * sizeof(int64_t), err);
                if (!s)
                    s = vm__grow((void **)&d->coarse_key, &key_cap, d->ncoarse + 1,
                                 sizeof(int64_t), err);
                if (!s)
                    s = vm__grow((void **)coarse_pos, &cap, d->ncoarse + 1, 6 * sizeof(double),
                                 err);
                if (s) {
                    free(ok);
                    return s;
                }
                memcpy(d->coarse_org + 3 * d->ncoarse, o, sizeof o);
                for (int a = 0; a < 3; a++) {
                    (*coarse_pos)[6 * d->ncoarse + (size_t)a] = vm__dc_coord(d, o[a], a) + x[a];
                    (*coarse_pos)[6 * d->ncoarse + 3 + (size_t)a] =
                        vm__dc_coord(d, o[a], a) + m[a];
                }
                /* blocks come in raster order of their lowest cell: the keys increase */
                d->coarse_key[d->ncoarse] = vm__dc_cidx(d, i, j, k);
                for (int c = 0; c < 8; c++)
                    vm__dc_set_bit(d->coarse, vm__dc_cidx(d, i + (c & 1), j + ((c >> 1) & 1),
                                                          k + (c >> 2)));
                if (d->ncoarse >= (size_t)INT32_MAX) {
                    free(ok);
                    return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many coarse leaves");
                }
                d->ncoarse++;
            }
    free(ok);
    d->coarse_base = d->nreps;
    d->nreps += d->ncoarse;

    return VM_OK;
}

int32_t vm__dc_coarse_find(const dc *d, int64_t ci) {
    int64_t c[3];
    vm__dc_cell_coords(d, ci, c);
    int64_t key = vm__dc_cidx(d, c[0] & ~(int64_t)1, c[1] & ~(int64_t)1, c[2] & ~(int64_t)1);
    size_t lo = first_at_least(d->coarse_key, d->ncoarse, key);
    return lo < d->ncoarse && d->coarse_key[lo] == key ? (int32_t)lo : -1;
}

/* Puts cell c's code into the octree: coarse or fine boundary, interior, or none. */
static void put_cell_code(void *ctx, const int64_t c[3]) {
    dc *d = ctx;
    int64_t ci = vm__dc_cidx(d, c[0], c[1], c[2]);
    int code = d->coarse && vm__dc_bit(d->coarse, ci) ? VM_OCT_COARSE
               : vm__dc_bit(d->bnd, ci)               ? VM_OCT_FINE
               : vm__dc_in(d, ci)                     ? VM_OCT_LEVEL
                                                      : VM_OCT_NONE;
    if (code != VM_OCT_NONE) vm__octree_put(&d->oct, c, code);
}

/* Adaptive mode: the octree of interior leaves over the cells' kinds (d->oct). */
static vm_status build_octree(dc *d, int max_level, vm_mesh_stats *st, vm_error *err) {
    int64_t nc[3] = {d->n[0] - 1, d->n[1] - 1, d->n[2] - 1};
    vm_status s = vm__octree_init(&d->oct, nc, err);
    if (s) return s;
    vm__octree_each_cell(nc, put_cell_code, d); /* z layers in parallel */
    size_t leaves = 0;
    s = vm__octree_build(&d->oct, max_level, &leaves, err);
    d->adaptive = s == VM_OK;
    st->interior_cells = leaves;
    return s;
}

void vm__dc_free(dc *d) {
    free(d->in);
    free_cells(d);
    free(d->bc);
    free(d->qpos);
    free(d->mpos);
    free(d->lambda);
    free(d->rep_planes);
    free(d->mu);
    free(d->amb);
    free(d->centre);
    free(d->coarse_org);
    free(d->coarse);
    free(d->coarse_key);
    vm__octree_free(&d->oct);
    free(d->tets);
    free(d->src);
}

/* 1 when grid point (i, j, k) is in the material; points off the grid are outside. */
static int point_set(const dc *d, int64_t i, int64_t j, int64_t k) {
    if (i < 0 || j < 0 || k < 0 || i >= d->n[0] || j >= d->n[1] || k >= d->n[2]) return 0;
    return vm__dc_in(d, vm__dc_pidx(d, i, j, k));
}

/* The components, among the neighbours of the centre of the 3x3x3 block nb (index
 * (x+1) + 3(y+1) + 9(z+1)) whose value is v, under k-adjacency (k = 6, 18 or 26: points
 * sharing a face; a face or an edge; a face, an edge or a corner) that are k-adjacent to
 * the centre, over the 18 face and edge neighbours when k is 6, else over all 26. */
static int block_components(const uint8_t nb[27], int v, int k) {
    int lab[27], count = 0;
    int reach = k == 6 ? 2 : 3, step = k == 6 ? 1 : k == 18 ? 2 : 3;
    for (int c = 0; c < 27; c++) {
        int far = abs(c % 3 - 1) + abs(c / 3 % 3 - 1) + abs(c / 9 - 1);
        lab[c] = nb[c] == v && far > 0 && far <= reach ? 0 : -1;
    }
    for (int c0 = 0; c0 < 27; c0++) {
        if (lab[c0] != 0) continue;
        int stack[27], top = 0, touch = 0;
        stack[top++] = c0;
        lab[c0] = ++count;
        while (top) {
            int c = stack[--top];
            int x = c % 3, y = c / 3 % 3, z = c / 9;
            touch |= abs(x - 1) + abs(y - 1) + abs(z - 1) <= step;
            for (int n = 0; n < 27; n++) {
                int dx = abs(n % 3 - x), dy = abs(n / 3 % 3 - y), dz = abs(n / 9 - z);
                if (lab[n] != 0 || dx > 1 || dy > 1 || dz > 1 || dx + dy + dz > step) continue;
                lab[n] = count;
                stack[top++] = n;
            }
        }
        if (!touch) count--;
    }
    return count;
}

/* 1 when flipping grid point p (grid coordinates) in or out of the material keeps the
 * topology of the material, 6-connected, and of its complement, 18-connected: p is a simple
 * point (Bertrand and Malandain 1994, "A new characterization of three-dimensional simple
 * points": one 6-component of the material among its 18 face and edge neighbours touches
 * a face of p, one 18-component of the complement among its 26 neighbours touches a face
 * or an edge). That pair is the one the tets' surface follows on the CT head: with the
 * material 26-connected and the complement 6-connected the hexes' boundary Euler
 * characteristic went 24 -> 30 (tets -12), with (6, 26) 14, with (6, 18) -10. */
static int simple_point(const dc *d, const int64_t p[3]) {
    uint8_t nb[27];
    for (int c = 0; c < 27; c++)
        nb[c] = (uint8_t)point_set(d, p[0] + c % 3 - 1, p[1] + c / 3 % 3 - 1, p[2] + c / 9 - 1);
    return block_components(nb, 1, 6) == 1 && block_components(nb, 0, 18) == 1;
}

/* Makes the material well composed for the hexes (no cell with two antipodal corners out,
 * no face with its corners alternating), one grid point at a time: a special cell gets one
 * of its two outside corners, an ambiguous face one of its outside corners or loses one of
 * its inside corners, the first whose flip is a simple point (so the boundary keeps the
 * material's topology: filling the first outside corner always, as before, closed thin air
 * gaps, CT head at iso 500 boundary Euler characteristic 24 against the tets' -12, then
 * -10); where no flip is simple, a simple flip next to them after which one is (detour: the
 * head now -12), and where there is none, the cell's or face's first outside corner is
 * filled. */
/* A point is flipped by the simple-point choice at most this many times; past that it is
 * only ever filled, so every point flips a bounded number of times and the loop settles. */
enum { FLIPS_CHOSEN = 2 };

static void flip_point(dc *d, int64_t p) {
    d->in[p >> 6] ^= (uint64_t)1 << (p & 63);
}

/* How far grid point p's value lies from the material's nearer bound: flipping a point near
 * the bound moves the surface least. */
static double bound_gap(const dc *d, const int64_t p[3]) {
    const vm__grid *g = d->g;
    double f = vm__dc_fval(d, p[0], p[1], p[2]), gap = INFINITY;
    if (g->has_lo) gap = fabs(f - g->lo);
    if (g->has_hi) gap = fmin(gap, fabs(f - g->hi));
    return gap;
}

/* Where no corner's flip is simple: a grid point within one of the corners' box (not a
 * corner) whose flip is simple, and after which a wanted corner's flip is; of those pairs,
 * the one whose values lie nearest the bound (the larger gap of the two, then the sum), so
 * that the surface moves least (the first pair found took the MR head's raw boundary to
 * 1.49 voxels from the isosurface). The point is flipped (and counted in done) and that
 * corner returned (its index in g), or -1 with nothing changed. want: bit q when corner q
 * may flip. Of 60 random pictures of 4^3 to 7^3 voxels the raw hexes missed the voxels'
 * topology in 27 with the fallback alone (fill the first outside corner), in 12 with this
 * first. */
static int detour(dc *d, uint8_t *done, const int64_t (*g)[3], int n, unsigned want) {
    int64_t lo[3], hi[3], r[3], best_r = -1;
    int best_q = -1;
    double best[2] = {INFINITY, INFINITY};
    for (int a = 0; a < 3; a++) {
        lo[a] = hi[a] = g[0][a];
        for (int q = 1; q < n; q++) {
            if (g[q][a] < lo[a]) lo[a] = g[q][a];
            if (g[q][a] > hi[a]) hi[a] = g[q][a];
        }
    }
    for (r[2] = lo[2] - 1; r[2] <= hi[2] + 1; r[2]++)
        for (r[1] = lo[1] - 1; r[1] <= hi[1] + 1; r[1]++)
            for (r[0] = lo[0] - 1; r[0] <= hi[0] + 1; r[0]++) {
                int corner = 0;
                for (int q = 0; q < n; q++)
                    corner |= r[0] == g[q][0] && r[1] == g[q][1] && r[2] == g[q][2];
                if (corner || !vm__dc_real_point(d, r)) continue;
                int64_t pr = vm__dc_pidx(d, r[0], r[1], r[2]);
                double gr = bound_gap(d, r);
                if (done[pr] >= FLIPS_CHOSEN || gr > best[0] || !simple_point(d, r)) continue;
                flip_point(d, pr);
                for (int q = 0; q < n; q++) {
                    int64_t pq = vm__dc_pidx(d, g[q][0], g[q][1], g[q][2]);
                    if (!((want >> q) & 1) || done[pq] >= FLIPS_CHOSEN ||
                        !vm__dc_real_point(d, g[q]))
                        continue;
                    double gq = bound_gap(d, g[q]), key[2] = {fmax(gr, gq), gr + gq};
                    if (key[0] > best[0] || (key[0] == best[0] && key[1] >= best[1])) continue;
                    if (!simple_point(d, g[q])) continue;
                    best[0] = key[0];
                    best[1] = key[1];
                    best_r = pr;
                    best_q = q;
                }
                flip_point(d, pr);
            }
    if (best_q < 0) return -1;
    flip_point(d, best_r);
    if (done[best_r] < UINT8_MAX) done[best_r]++;
    return best_q;
}

vm_status vm__dc_repair_for_hexes(dc *d, vm_mesh_stats *st, size_t *flipped, vm_error *err) {
    *flipped = 0;
    size_t np = (size_t)(d->P[0] * d->P[1] * d->P[2]);
    uint8_t *done = calloc(np, 1);
    if (!done) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (int round = 0; round < 1000; round++) {
        size_t flips = 0;
        for (size_t bi = 0; bi < d->nbc; bi++) {
            const bcell *b = &d->bc[bi];
            if (!vm__dc_kind_of(b)->special) continue;
            int64_t cm[3], first = -1, pick = -1;
            vm__dc_cell_coords(d, b->cell, cm);
            if (!vm__dc_kinds[cell_mask(d, cm[0], cm[1], cm[2])].special)
                continue; /* an earlier flip this round changed the cell */
            int64_t g[8][3];
            unsigned out = 0;
            for (int c = 0; c < 8; c++) {
                g[c][0] = cm[0] + (c & 1);
                g[c][1] = cm[1] + ((c >> 1) & 1);
                g[c][2] = cm[2] + (c >> 2);
                int64_t p = vm__dc_pidx(d, g[c][0], g[c][1], g[c][2]);
                if (vm__dc_in(d, p)) continue;
                out |= 1u << c;
                if (first < 0) first = p;
                if (pick < 0 && done[p] < FLIPS_CHOSEN && vm__dc_real_point(d, g[c]) &&
                    simple_point(d, g[c]))
                    pick = p;
            }
            if (pick < 0) {
                int q = detour(d, done, (const int64_t(*)[3])g, 8, out);
                if (q >= 0) {
                    pick = vm__dc_pidx(d, g[q][0], g[q][1], g[q][2]);
                    flips++;
                }
            }
            if (pick < 0) pick = first;
            vm__dc_set_bit(d->in, pick);
            if (done[pick] < UINT8_MAX) done[pick]++;
            flips++;
        }
        for (size_t fi = 0; fi < d->namb; fi++) {
            int64_t cm[3], first = -1, pick = -1;
            int a = (int)(d->amb[fi] % 3), fill = 1;
            vm__dc_cell_coords(d, d->amb[fi] / 3, cm);
            const int *fc = vm__dc_face_corner[2 * a + 1];
            int64_t g[4][3], p[4];
            int ins[4], n_in = 0;
            for (int q = 0; q < 4; q++) {
                g[q][0] = cm[0] + (fc[q] & 1);
                g[q][1] = cm[1] + ((fc[q] >> 1) & 1);
                g[q][2] = cm[2] + (fc[q] >> 2);
                p[q] = vm__dc_pidx(d, g[q][0], g[q][1], g[q][2]);
                ins[q] = vm__dc_in(d, p[q]);
                n_in += ins[q];
            }
            if (n_in != 2 || ins[0] != ins[2]) continue; /* no longer alternating */
            for (int q = 0; q < 4; q++)
                if (!ins[q] && first < 0) first = p[q];
            for (int pass = 0; pass < 2 && pick < 0; pass++)
                for (int q = 0; q < 4 && pick < 0; q++) {
                    if (ins[q] != pass || !vm__dc_real_point(d, g[q])) continue;
                    if (done[p[q]] >= FLIPS_CHOSEN) continue;
                    if (simple_point(d, g[q])) {
                        pick = p[q];
                        fill = !pass;
                    }
                }
            if (pick < 0) {
                int q = detour(d, done, (const int64_t(*)[3])g, 4, 0xfu);
                if (q >= 0) {
                    pick = p[q];
                    fill = !ins[q];
                    flips++;
                }
            }
            if (pick < 0) pick = first;
            if (fill) vm__dc_set_bit(d->in, pick);
            else d->in[pick >> 6] &= ~((uint64_t)1 << (pick & 63));
            if (done[pick] < UINT8_MAX) done[pick]++;
            flips++;
        }
        if (!flips) {
            free(done);
            return VM_OK;
        }
        *flipped += flips;
        free_cells(d);
        d->nbc = d->namb = 0;
        st->special_cells = st->interior_cells = st->boundary_cells = 0;
        vm_status s = find_cells(d, st, err);
        if (s) {
            free(done);
            return s;
        }
    }
    free(done);
    return vm_error_set(err, VM_ERR_INTERNAL, "mesh: hexahedral repair did not settle");
}

vm_status vm__dc_setup(dc *d, const vm__grid *g, vm_mesh_stats *st, vm_error *err) {
    vm__dc_init_tables();
    memset(d, 0, sizeof *d);
    d->g = g;
    d->id_limit = g->id_limit > 0 ? g->id_limit : (int64_t)1 << 32;
    for (int a = 0; a < 3; a++) {
        d->n[a] = g->n[a];
        d->off[a] = g->off[a];
        d->P[a] = g->n[a] + 2;
        d->C[a] = g->n[a] + 2; /* as P: a cell's index is that of its lowest corner */
    }
    /* A byte per padded grid point bounds the largest per-point array (the octree's codes,
     * half a byte per cell; the rest are bit sets): the grid must fit in a size_t and
     * within the memory limit at that. */
    size_t tmp;
    vm_status s = vm__check_dims(d->P, 1, "mesh", &tmp, err);
    if (!s) s = classify(d, st, err);
    if (!s && g->progress && g->progress("contour", 1, 4, g->progress_user))
        s = vm__cancelled(err, "mesh");
    if (!s) s = find_cells(d, st, err);
    if (!s) s = vm__dc_check(d, err);
    if (!s && g->hexes) s = vm__dc_repair_for_hexes(d, st, &st->repaired_points, err);
    double *coarse_pos = NULL;
    d->error = g->error;
    if (!s && g->max_level > 0 && !g->hexes) s = merge_boundary(d, &coarse_pos, err);
    if (!s) s = vm__dc_check(d, err);
    if (!s && g->max_level > 0) s = build_octree(d, g->max_level, st, err);
    if (!s) s = vm__dc_check(d, err);
    if (!s) s = place_reps(d, coarse_pos, err);
    free(coarse_pos);
    if (!s && g->progress && g->progress("contour", 2, 4, g->progress_user))
        s = vm__cancelled(err, "mesh");
    return s;
}

vm_status vm__dc_check(const dc *d, vm_error *err) {
    return vm__progress_check(d->g->progress, d->g->progress_user, "mesh", err);
}
