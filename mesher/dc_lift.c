/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dc_lift.c — quality by construction for the dual-contouring tets (issue 32): the
 * grid points at the corners of tets below the quality targets move, each within its own
 * star, to where the fewest tets of that star are below the targets (then where its worst
 * tet is best). Where the surface crosses a grid edge
 * near its inside end, the pyramid from that end over the edge's polygon of patch vertices
 * is flat; moving the grid point away from the polygon (as isosurface stuffing warps a
 * lattice vertex) makes it a tet again, with no change to the boundary: the grid points
 * moved are interior vertices and the patch vertices stay where untangling left them. */
#include "../core/core.h"
#include "../core/vec3.h"
#include "../quality/tet_internal.h"
#include "dc_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The quality targets of the quality pass's defaults (docs/IMPROVE.md): 1 meets them. */
#define PI 3.14159265358979323846
static const double q_dmin = PI / 12, q_dmax = PI / 6, q_fmin = PI / 12, q_fmax = PI / 6;
/* cos 15° and cos 150°: a tet whose angles' cosines are within them meets the targets */
static const double cos_min = 0.96592582628906831, cos_max = -0.86602540378443860;
/* Trial steps, in shortest cell edges, along each direction tried. */
static const double lift_steps[] = {0.4, 0.25, 0.1};
enum { LIFT_STEPS = sizeof lift_steps / sizeof lift_steps[0], LIFT_STAR = 96 };

typedef struct lift {
    const dc *d;
    double M[9];   /* index -> world, linear part (row-major) */
    double Mi[9];  /* its inverse */
    double h;      /* the shortest cell edge, world units */
    int64_t N;     /* grid points */
    uint64_t *bit; /* per grid point: a candidate */
    size_t *rank;  /* per word of bit: candidates before it */
    size_t nc;
    int64_t *ids;    /* candidates, increasing */
    double *pos;     /* per candidate: its position, index space */
    size_t *start;   /* per candidate: its star in star[] (CSR) */
    size_t *star;    /* tets */
    uint8_t *colour; /* per candidate: 0..7 by the parity of its whole-grid indices, 8:
                        stays (its star is not closed, or holds another candidate of its
                        colour) */
} lift;

static size_t cand_of(const lift *L, int64_t id) {
    uint64_t w = L->bit[id >> 6], b = (uint64_t)1 << (id & 63);
    if (!(w & b)) return (size_t)-1;
    return L->rank[id >> 6] + (size_t)__builtin_popcountll(w & (b - 1));
}

static void grid_coords(const dc *d, int64_t id, int64_t p[3]) {
    p[0] = id % d->n[0];
    p[1] = (id / d->n[0]) % d->n[1];
    p[2] = id / (d->n[0] * d->n[1]);
}

/* Index-space position of vertex id as the lift has it now. */
static void lift_pos(const lift *L, int64_t id, double out[3]) {
    if (id < L->N && L->pos) { /* (no candidate has a position before the stars) */
        size_t c = cand_of(L, id);
        if (c != (size_t)-1) {
            memcpy(out, L->pos + 3 * c, 3 * sizeof(double));
            return;
        }
    }
    vm__dc_vertex_pos(L->d, id, 0, out);
}

static void to_world(const lift *L, const double x[3], double out[3]) {
    for (int r = 0; r < 3; r++)
        out[r] = L->M[3 * r] * x[0] + L->M[3 * r + 1] * x[1] + L->M[3 * r + 2] * x[2];
}

/* The quality pass's measure of a tet on its dihedral and face angles (world corners),
 * capped at 1: min(1, dmin / 15°, (180° - dmax) / 30°, fmin / 15°, (180° - fmax) / 30°);
 * -1 when it is not clearly positive. A tet that meets the targets is told on the cosines
 * alone; only the others take inverse cosines. */
static double tet_score(const double p[4][3]) {
    double dcmax, dcmin, fc[12], fcmax, fcmin;
    if (!vm__tet_dihedral_cosines(p, &dcmax, &dcmin)) return -1.0;
    vm__tet_face_cosines(p, fc, &fcmax, &fcmin);
    if (dcmax <= cos_min && dcmin >= cos_max && fcmax <= cos_min && fcmin >= cos_max)
        return 1.0;
    double q = 1.0, t;
    if ((t = acos(fmin(1.0, dcmax)) / q_dmin) < q) q = t;
    if ((t = (PI - acos(fmax(-1.0, dcmin))) / q_dmax) < q) q = t;
    if ((t = acos(fmin(1.0, fcmax)) / q_fmin) < q) q = t;
    if ((t = (PI - acos(fmax(-1.0, fcmin))) / q_fmax) < q) q = t;
    return q;
}

/* World corners of tet ids v, vertex `self` (an id of v, or -1) at x (index space). */
static void tet_world(const lift *L, const int64_t v[4], int64_t self, const double x[3],
                      double p[4][3]) {
    for (int k = 0; k < 4; k++) {
        double y[3];
        if (v[k] == self)
            memcpy(y, x, sizeof y);
        else
            lift_pos(L, v[k], y);
        to_world(L, y, p[k]);
    }
}

/* Candidate c's star, its other corners in world coordinates (they do not move while c
 * does: no other candidate of its colour is in it). */
typedef struct star {
    int n;
    double p[LIFT_STAR][4][3];
    int self[LIFT_STAR];    /* the corner that is c */
    int lattice[LIFT_STAR]; /* grid points among the corners */
    int order[LIFT_STAR];   /* tets in the order to measure them: the last one to fail first */
} star;

static void star_load(const lift *L, size_t c, star *S) {
    S->n = (int)(L->start[c + 1] - L->start[c]);
    for (int i = 0; i < S->n; i++) {
        int64_t v[4];
        vm__dc_tet_get(L->d, L->star[L->start[c] + (size_t)i], v);
        S->lattice[i] = 0;
        for (int k = 0; k < 4; k++) {
            S->lattice[i] += v[k] < L->N;
            if (v[k] == L->ids[c]) S->self[i] = k;
            double y[3];
            lift_pos(L, v[k], y);
            to_world(L, y, S->p[i][k]);
        }
        S->order[i] = i;
    }
}

/* The star with its centre at w (world): *below, its tets under the targets, and its worst
 * score. Stops as soon as *below passes `most` or a score is under `floor` (the tet that
 * made it is measured first next); returns 0 then. */
static int star_score(star *S, const double w[3], int most, double floor, int *below,
                      double *worst) {
    *below = 0;
    *worst = 1e300;
    for (int j = 0; j < S->n; j++) {
        int i = S->order[j];
        memcpy(S->p[i][S->self[i]], w, 3 * sizeof(double));
        double q = tet_score((const double(*)[3])S->p[i]);
        if (q < *worst) *worst = q;
        if (q < floor || (q < 1.0 && ++*below > most)) {
            memmove(S->order + 1, S->order, (size_t)j * sizeof(int));
            S->order[0] = i;
            return 0;
        }
    }
    return 1;
}

/* Unit normal (world) of the face of star tet i opposite the centre at w, pointing to w's
 * side; 0 when degenerate. */
static int away_normal(const star *S, int i, const double w[3], double n[3]) {
    const double(*p)[3] = S->p[i];
    int f[3], nf = 0;
    for (int j = 0; j < 4; j++)
        if (j != S->self[i]) f[nf++] = j;
    double u1[3], u2[3], o[3];
    vm__sub3(p[f[1]], p[f[0]], u1);
    vm__sub3(p[f[2]], p[f[0]], u2);
    vm__cross3(u1, u2, n);
    double l = sqrt(vm__dot3(n, n));
    if (!(l > 0)) return 0;
    vm__sub3(w, p[f[0]], o);
    double s = vm__dot3(o, n) < 0 ? -1.0 / l : 1.0 / l;
    for (int a = 0; a < 3; a++)
        n[a] *= s;
    return 1;
}

/* Moves candidate c to the best trial position, when that raises its star's worst score. */
static int lift_one(lift *L, size_t c) {
    star S;
    star_load(L, c, &S);
    double *x = L->pos + 3 * c, w[3];
    to_world(L, x, w);
    /* its worst score, and the directions: away from the faces opposite it in the tets
     * where it is the only grid point (the pyramids over patch polygons), and away from
     * its worst tet's */
    double dir[2][3] = {{0, 0, 0}, {0, 0, 0}}, base = 1e300;
    int worst = 0, nbelow = 0;
    for (int i = 0; i < S.n; i++) {
        double q = tet_score((const double(*)[3])S.p[i]), n[3];
        nbelow += q < 1.0;
        if (q < base) {
            base = q;
            worst = i;
        }
        if (S.lattice[i] == 1 && away_normal(&S, i, w, n))
            for (int a = 0; a < 3; a++)
                dir[0][a] += n[a];
    }
    if (base >= 1.0 || !away_normal(&S, worst, w, dir[1])) return 0;
    S.order[0] = worst;
    S.order[worst] = 0;
    /* the best trial: fewest tets below the targets, then the highest worst score */
    double best = base, bw[3];
    int moved = 0;
    for (int k = 0; k < 2; k++) {
        double l = sqrt(vm__dot3(dir[k], dir[k]));
        if (!(l > 0)) continue;
        for (int s = 0; s < LIFT_STEPS; s++) {
            double y[3], t = lift_steps[s] * L->h / l, q;
            int nb;
            for (int a = 0; a < 3; a++)
                y[a] = w[a] + t * dir[k][a];
            if (!star_score(&S, y, nbelow, base > 1e-12 ? base : 1e-12, &nb, &q)) continue;
            /* never below the star's worst at the start */
            if ((nb < nbelow && q >= base) || q > best + 1e-9) {
                nbelow = nb;
                best = q;
                memcpy(bw, y, sizeof bw);
                moved = 1;
            }
        }
    }
    if (!moved) return 0;
    for (int r = 0; r < 3; r++) /* back to index space */
        x[r] = L->Mi[3 * r] * bw[0] + L->Mi[3 * r + 1] * bw[1] + L->Mi[3 * r + 2] * bw[2];
    return 1;
}

static int pair_cmp(const void *a, const void *b) {
    const int64_t *x = a, *y = b;
    return x[0] != y[0] ? (x[0] < y[0] ? -1 : 1) : (x[1] > y[1]) - (x[1] < y[1]);
}

/* 1 when candidate c's star is closed around it (each of its faces through the vertex is
 * shared by two of its tets) and holds no other candidate of its colour. */
static int lift_free(const lift *L, size_t c) {
    size_t ns = L->start[c + 1] - L->start[c];
    if (ns < 4 || ns > LIFT_STAR) return 0;
    int64_t pr[3 * LIFT_STAR][2], self = L->ids[c];
    size_t np = 0;
    for (size_t s = L->start[c]; s < L->start[c + 1]; s++) {
        int64_t v[4], o[3];
        int no = 0;
        vm__dc_tet_get(L->d, L->star[s], v);
        for (int k = 0; k < 4; k++) {
            if (v[k] == self) continue;
            o[no++] = v[k];
            size_t oc = v[k] < L->N ? cand_of(L, v[k]) : (size_t)-1;
            if (oc != (size_t)-1 && (L->colour[oc] & 7) == (L->colour[c] & 7)) return 0;
        }
        if (no != 3) return 0;
        for (int a = 0; a < 3; a++) {
            int64_t u = o[a], w = o[(a + 1) % 3];
            pr[np][0] = u < w ? u : w;
            pr[np][1] = u < w ? w : u;
            np++;
        }
    }
    qsort(pr, np, sizeof pr[0], pair_cmp);
    for (size_t i = 0; i < np; i += 2)
        if (i + 1 >= np || pair_cmp(pr[i], pr[i + 1]) ||
            (i + 2 < np && !pair_cmp(pr[i], pr[i + 2])))
            return 0;
    return 1;
}

static void lift_free_all(lift *L) {
    free(L->bit);
    free(L->rank);
    free(L->ids);
    free(L->pos);
    free(L->start);
    free(L->star);
    free(L->colour);
}

/* Every tet at each of its candidate corners c: counted in at[c + 1] (fill 0), or stored in
 * L->star at at[c], which then moves on (fill 1); on the threads. */
static void star_walk(lift *L, size_t *at, int fill) {
#pragma omp parallel for schedule(static, 4096)
    for (size_t t = 0; t < L->d->ntets; t++) {
        int64_t v[4];
        vm__dc_tet_get(L->d, t, v);
        for (int k = 0; k < 4; k++) {
            size_t c = v[k] < L->N ? cand_of(L, v[k]) : (size_t)-1;
            if (c == (size_t)-1) continue;
            if (fill)
                L->star[__atomic_fetch_add(&at[c], 1, __ATOMIC_RELAXED)] = t;
            else
                __atomic_fetch_add(&at[c + 1], 1, __ATOMIC_RELAXED);
        }
    }
}

/* 1 when grid point p lies strictly inside the grid (not on a border plane, of the volume
 * or of a crop). */
static int inner_point(const dc *d, int64_t id) {
    int64_t p[3];
    grid_coords(d, id, p);
    for (int a = 0; a < 3; a++)
        if (p[a] <= 0 || p[a] >= d->n[a] - 1) return 0;
    return 1;
}

vm_status vm__dc_lift(const dc *d, const double M[9], size_t *nout, int64_t **ids_out,
                      double **pos_out, vm_error *err) {
    *nout = 0;
    *ids_out = NULL;
    *pos_out = NULL;
    lift L;
    memset(&L, 0, sizeof L);
    L.d = d;
    memcpy(L.M, M, sizeof L.M);
    double det = vm__mat3_det((const double(*)[3])L.M);
    if (!(fabs(det) > 0) || !isfinite(det)) return VM_OK;
    vm__mat3_inverse((const double(*)[3])L.M, det, (double(*)[3])L.Mi);
    L.h = 1e300;
    for (int a = 0; a < 3; a++) {
        double l = sqrt(M[a] * M[a] + M[3 + a] * M[3 + a] + M[6 + a] * M[6 + a]);
        if (l < L.h) L.h = l;
    }
    L.N = vm__dc_npoints_real(d);
    size_t nw = (size_t)L.N / 64 + 1, nt = d->ntets;
    /* candidates: the inner grid points of tets with a patch vertex below the targets */
    L.bit = calloc(nw, sizeof *L.bit);
    L.rank = malloc(nw * sizeof *L.rank);
    if (!L.bit || !L.rank) goto nomem;
#pragma omp parallel for schedule(static, 4096)
    for (size_t t = 0; t < nt; t++) {
        int64_t v[4];
        vm__dc_tet_get(d, t, v);
        int lattice = 0;
        for (int k = 0; k < 4; k++)
            lattice += v[k] < L.N;
        if (lattice == 0 || lattice == 4) continue;
        double p[4][3];
        tet_world(&L, v, -1, NULL, p);
        if (tet_score((const double(*)[3])p) >= 1.0) continue;
        for (int k = 0; k < 4; k++)
            if (v[k] < L.N && inner_point(d, v[k]))
                __atomic_fetch_or(&L.bit[v[k] >> 6], (uint64_t)1 << (v[k] & 63),
                                  __ATOMIC_RELAXED);
    }
    for (size_t w = 0; w < nw; w++) {
        L.rank[w] = L.nc;
        L.nc += (size_t)__builtin_popcountll(L.bit[w]);
    }
    if (!L.nc) {
        lift_free_all(&L);
        return VM_OK;
    }
    L.ids = malloc(L.nc * sizeof *L.ids);
    L.pos = malloc(3 * L.nc * sizeof *L.pos);
    L.start = calloc(L.nc + 1, sizeof *L.start);
    L.colour = malloc(L.nc);
    if (!L.ids || !L.pos || !L.start || !L.colour) goto nomem;
    for (size_t w = 0, c = 0; w < nw; w++)
        for (uint64_t b = L.bit[w]; b; b &= b - 1) {
            int64_t id = 64 * (int64_t)w + __builtin_ctzll(b), g[3];
            L.ids[c] = id;
            vm__dc_vertex_pos(d, id, 0, L.pos + 3 * c);
            grid_coords(d, id, g);
            L.colour[c] = (uint8_t)(((g[0] + d->off[0]) & 1) | (((g[1] + d->off[1]) & 1) << 1) |
                                    (((g[2] + d->off[2]) & 1) << 2));
            c++;
        }
    /* stars (CSR): counted and filled on the threads, each then put in tet order */
    star_walk(&L, L.start, 0);
    for (size_t c = 0; c < L.nc; c++)
        L.start[c + 1] += L.start[c];
    L.star = malloc((L.start[L.nc] ? L.start[L.nc] : 1) * sizeof *L.star);
    size_t *fill = malloc(L.nc * sizeof *fill);
    if (!L.star || !fill) {
        free(fill);
        goto nomem;
    }
    memcpy(fill, L.start, L.nc * sizeof *fill);
    star_walk(&L, fill, 1);
    free(fill);
#pragma omp parallel for schedule(dynamic, 256)
    for (size_t c = 0; c < L.nc; c++) /* insertion sort: a star holds a few dozen tets */
        for (size_t i = L.start[c] + 1; i < L.start[c + 1]; i++) {
            size_t x = L.star[i], j = i;
            for (; j > L.start[c] && L.star[j - 1] > x; j--)
                L.star[j] = L.star[j - 1];
            L.star[j] = x;
        }
    /* a candidate that shares a tet with another of its colour, or whose star is open,
     * stays (decided before any moves, so on the same stars whatever the threads) */
    uint8_t *stay = calloc(L.nc, 1);
    if (!stay) goto nomem;
#pragma omp parallel for schedule(dynamic, 256)
    for (size_t c = 0; c < L.nc; c++)
        stay[c] = !lift_free(&L, c);
    for (size_t c = 0; c < L.nc; c++)
        if (stay[c]) L.colour[c] = 8;
    free(stay);
    /* colour by colour: no two candidates of one colour share a tet, so each move reads only
     * the positions of the colours before (the same result on any number of threads) */
    uint8_t *moved = calloc(L.nc, 1);
    if (!moved) goto nomem;
    for (int col = 0; col < 8; col++) {
#pragma omp parallel for schedule(dynamic, 64)
        for (size_t c = 0; c < L.nc; c++)
            if (L.colour[c] == col) moved[c] = (uint8_t)lift_one(&L, c);
    }
    size_t nm = 0;
    for (size_t c = 0; c < L.nc; c++)
        nm += moved[c];
    int64_t *ids = malloc((nm ? nm : 1) * sizeof *ids);
    double *pos = malloc((nm ? nm : 1) * 3 * sizeof *pos);
    if (!ids || !pos) {
        free(ids);
        free(pos);
        free(moved);
        goto nomem;
    }
    for (size_t c = 0, k = 0; c < L.nc; c++)
        if (moved[c]) {
            ids[k] = L.ids[c];
            memcpy(pos + 3 * k, L.pos + 3 * c, 3 * sizeof(double));
            k++;
        }
    free(moved);
    lift_free_all(&L);
    *nout = nm;
    *ids_out = ids;
    *pos_out = pos;
    return VM_OK;
nomem:
    lift_free_all(&L);
    return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
}
