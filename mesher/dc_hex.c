/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dc_hex.c — hexahedra by dual contouring: seed 001 (LBIE) §4.3, "each vertex is
 * shared by eight cells ... these eight minimizers can then be used to construct a
 * hexahedron": one hex per inside grid point, its corners the vertices of the eight cells
 * around it (the patch vertex of the point's component, or the centre of an interior cell). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "dc_internal.h"
#include "volmesh/quality.h"

/* For corner i of a VTK hexahedron, the three corners along its edges, ordered so that
 * det(p[a]-p[i], p[b]-p[i], p[c]-p[i]) > 0 for a valid element. */
static const int corner_nb[8][3] = {{1, 3, 4}, {2, 0, 5}, {3, 1, 6}, {0, 2, 7},
                                    {7, 5, 0}, {4, 6, 1}, {5, 7, 2}, {6, 4, 3}};
/* VTK corner offsets */
static const int hex_off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};

typedef struct hexes {
    int64_t *cells; /* 8 ids per hex */
    size_t n, cap;
    int32_t *centre_of; /* per padded cell: index of its centre vertex, -1 */
    size_t ncentres;
    int64_t *centre_cell;
    size_t centre_cap;
} hexes;

/* A hex is clearly valid when its worst scaled corner Jacobian is above this (a corner
 * about 0.06 degrees from flat); make_valid relaxes the others, at most VALID_ROUNDS times. */
static const double clear_sj = 1e-3;
enum { VALID_ROUNDS = 40 };
/* A pulled vertex is close enough to the isosurface within this many voxels (first order). */
static const double surface_tol = 0.35;

static void hex_pos(const dc *d, const hexes *h, int64_t id, double out[3]) {
    int64_t first = vm__dc_npoints_real(d) + (int64_t)d->nreps;
    if (id < first) {
        vm__dc_vertex_pos(d, id, 0, out);
        return;
    }
    int64_t cm[3];
    vm__dc_cell_coords(d, h->centre_cell[id - first], cm);
    for (int a = 0; a < 3; a++) out[a] = (double)cm[a] + 0.5;
}

/* Smallest scaled Jacobian of hex c (1 for a cube, <= 0 when inverted): its corners', and
 * when they are all clear, vm_hex_scaled_jacobian's (the centre and the Gauss points too,
 * the measure the mesh check uses). [out] *bad (NULL allowed): bit k set when corner k is one
 * of the four points of a corner at or below clear_sj; all eight when only the inside is. */
static double hex_quality(const dc *d, const hexes *h, const int64_t *c, unsigned *bad) {
    double p[8][3], worst = INFINITY;
    for (int k = 0; k < 8; k++) hex_pos(d, h, c[k], p[k]);
    for (int k = 0; k < 8; k++) {
        double e[3][3], len = 1;
        for (int j = 0; j < 3; j++) {
            double l2 = 0;
            for (int a = 0; a < 3; a++) {
                e[j][a] = p[corner_nb[k][j]][a] - p[k][a];
                l2 += e[j][a] * e[j][a];
            }
            len *= sqrt(l2);
        }
        double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                     e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                     e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
        double q = len > 0 ? det / len : -1;
        if (q < worst) worst = q;
        if (bad && q <= clear_sj)
            *bad |= 1u << k | 1u << corner_nb[k][0] | 1u << corner_nb[k][1] |
                    1u << corner_nb[k][2];
    }
    if (worst > clear_sj) {
        double inside = vm_hex_scaled_jacobian((const double(*)[3])p);
        if (inside <= clear_sj) {
            worst = inside;
            if (bad) *bad = 0xffu;
        }
    }
    return worst;
}

static vm_status build(dc *d, hexes *h, vm_error *err) {
    size_t nc = (size_t)(d->C[0] * d->C[1] * d->C[2]);
    h->centre_of = malloc(nc * sizeof *h->centre_of);
    if (!h->centre_of) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t i = 0; i < nc; i++) h->centre_of[i] = -1;
    int64_t N = vm__dc_npoints_real(d);
    for (int64_t k = 0; k < d->n[2]; k++)
        for (int64_t j = 0; j < d->n[1]; j++)
            for (int64_t i = 0; i < d->n[0]; i++) {
                if (!vm__dc_in(d, vm__dc_pidx(d, i, j, k))) continue;
                vm_status s = vm__grow((void **)&h->cells, &h->cap, h->n + 1, 8 * sizeof(int64_t), err);
                if (s) return s;
                int64_t *c = h->cells + 8 * h->n++;
                for (int q = 0; q < 8; q++) {
                    /* the cell whose centre is corner q of the dual cube around (i,j,k) */
                    int64_t m[3] = {i + hex_off[q][0] - 1, j + hex_off[q][1] - 1, k + hex_off[q][2] - 1};
                    int64_t ci = vm__dc_cidx(d, m[0], m[1], m[2]);
                    int32_t code = vm__dc_code(d, ci);
                    if (code >= 0) {
                        const bcell *b = &d->bc[code];
                        int local = (1 - hex_off[q][0]) | (1 - hex_off[q][1]) << 1 | (1 - hex_off[q][2]) << 2;
                        c[q] = N + b->base + vm__dc_kind_of(b)->corner_patch[local];
                    } else {
                        if (h->centre_of[ci] < 0) {
                            s = vm__grow((void **)&h->centre_cell, &h->centre_cap, h->ncentres + 1,
                                         sizeof(int64_t), err);
                            if (s) return s;
                            h->centre_cell[h->ncentres] = ci;
                            h->centre_of[ci] = (int32_t)h->ncentres++;
                        }
                        c[q] = N + (int64_t)d->nreps + h->centre_of[ci];
                    }
                }
            }
    return VM_OK;
}

/* Trilinear value of the grid at index position x (inside the grid) and its gradient. */
static double grid_field(const dc *d, const double x[3], double g[3]) {
    int64_t i0[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double c = fmin(fmax(x[a], 0.0), (double)(d->n[a] - 1));
        int64_t i = (int64_t)floor(c);
        if (i > d->n[a] - 2) i = d->n[a] - 2;
        if (i < 0) i = 0;
        i0[a] = i;
        f[a] = c - (double)i;
    }
    double val = 0.0;
    g[0] = g[1] = g[2] = 0.0;
    for (int c = 0; c < 8; c++) {
        int o[3] = {c & 1, (c >> 1) & 1, c >> 2};
        int64_t q[3];
        for (int a = 0; a < 3; a++) q[a] = i0[a] + o[a] < d->n[a] ? i0[a] + o[a] : d->n[a] - 1;
        double s = vm__dc_fval(d, q[0], q[1], q[2]), w[3], dw[3];
        for (int a = 0; a < 3; a++) {
            w[a] = o[a] ? f[a] : 1.0 - f[a];
            dw[a] = o[a] ? 1.0 : -1.0;
        }
        val += s * w[0] * w[1] * w[2];
        g[0] += s * dw[0] * w[1] * w[2];
        g[1] += s * w[0] * dw[1] * w[2];
        g[2] += s * w[0] * w[1] * dw[2];
    }
    return val;
}

/* First-order distance (voxels) of index position x from the nearer material bound. */
static double bound_distance(const dc *d, const double x[3]) {
    const vm__grid *g = d->g;
    double gr[3], f = grid_field(d, x, gr);
    int lo = g->has_lo && (!g->has_hi || fabs(f - g->lo) <= fabs(f - g->hi));
    double bound = lo ? g->lo : g->hi;
    double gn = sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]), r = fabs(f - bound);
    return gn > 0.0 ? r / gn : (r > 0.0 ? INFINITY : 0.0);
}

/* The QEF minimiser trusts the crossings' normals, which noise and grid points lying on the
 * isovalue itself (crossings all clamped to one end of their edges) can turn until it sits
 * at the far side of its cell, up to 1.3 voxels off the isosurface (MR head). Such a vertex
 * is pulled toward its mass point (the mean of the crossings, which lie on the trilinear
 * isosurface), as little as brings it within 0.35 voxel of it to first order, or to where
 * it is nearest when no blend gets there. Returns the number of vertices pulled. */
static size_t pull_to_surface(dc *d) {
    size_t pulled = 0;
    for (size_t bi = 0; bi < d->nbc; bi++) {
        const bcell *b = &d->bc[bi];
        for (int p = 0; p < vm__dc_kind_of(b)->npatch; p++) {
            size_t r = (size_t)b->base + (size_t)p;
            const double *q = d->qpos + 3 * r, *m = d->mpos + 3 * r;
            double best_l = 1.0, best_e = INFINITY;
            for (int k = 8; k >= 0; k--) {
                double l = k / 8.0, x[3];
                for (int a = 0; a < 3; a++) x[a] = m[a] + l * (q[a] - m[a]);
                double e = bound_distance(d, x);
                if (e <= surface_tol) {
                    best_l = l;
                    break;
                }
                if (e < best_e) {
                    best_e = e;
                    best_l = l;
                }
            }
            if (best_l < 1.0) {
                d->lambda[r] = (float)best_l;
                pulled++;
            }
        }
    }
    return pulled;
}

/* Pulls patch vertices of every hex that is not clearly valid toward their mass points, then
 * toward their cell centres (where the hex becomes the voxel's cube): only the four points of
 * each corner that is not (pulling all eight took 2.7 times as many vertices off the surface
 * on the MR head, the centres up to 0.87 voxel from it, for as many hexes left inverted). */
static size_t make_valid(dc *d, const hexes *h, size_t *relaxed) {
    int64_t N = vm__dc_npoints_real(d);
    size_t bad = 0, moved = 0;
    for (int round = 0; round < VALID_ROUNDS; round++) {
        bad = 0;
        for (size_t t = 0; t < h->n; t++) {
            const int64_t *c = h->cells + 8 * t;
            unsigned worst = 0;
            if (hex_quality(d, h, c, &worst) > clear_sj) continue;
            bad++;
            for (int k = 0; k < 8; k++) {
                if (!((worst >> k) & 1)) continue;
                if (c[k] < N || (size_t)(c[k] - N) >= d->nreps) continue;
                size_t r = (size_t)(c[k] - N);
                if (d->lambda[r] > 0) {
                    d->lambda[r] = d->lambda[r] > 1.0 / 16 ? d->lambda[r] * 0.5f : 0.0f;
                    moved++;
                } else if (vm__dc_rep_centre(d, r, NULL) && d->mu[r] > 0) {
                    d->mu[r] = d->mu[r] > 1.0 / 16 ? d->mu[r] * 0.5f : 0.0f;
                    moved++;
                }
            }
        }
        if (!bad || vm__progress_poll(d->g->progress, d->g->progress_user)) break;
    }
    *relaxed = moved;
    return bad;
}

vm_status vm__dual_contour_hexes(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                 vm_error *err) {
    dc d;
    hexes h;
    memset(&h, 0, sizeof h);
    vm_status s = vm__dc_setup(&d, g, st, err);
    size_t pulled = 0;
    if (!s) pulled = pull_to_surface(&d);
    if (!s) s = build(&d, &h, err);
    if (!s && g->progress) g->progress("contour", 3, 4, g->progress_user);
    size_t relaxed = 0, bad = 0;
    if (!s) bad = make_valid(&d, &h, &relaxed);
    /* What relaxation leaves inverted is untangled by vm_mesh_improve_hexes. */
    st->inverted_cells = bad;
    if (!s) {
        out->nodes = 8;
        out->ntets = h.n;
        out->tets = h.cells;
        h.cells = NULL;
        out->nlattice = vm__dc_npoints_real(&d);
        out->nreps = d.nreps + h.ncentres;
        out->rep_pos = malloc(3 * (out->nreps ? out->nreps : 1) * sizeof(double));
        if (!out->rep_pos) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        for (size_t r = 0; !s && r < out->nreps; r++)
            hex_pos(&d, &h, out->nlattice + (int64_t)r, out->rep_pos + 3 * r);
        st->relaxed_vertices = relaxed + pulled;
        st->surface_vertices = d.nreps;
    }
    if (!s && g->progress) g->progress("contour", 4, 4, g->progress_user);
    free(h.cells);
    free(h.centre_of);
    free(h.centre_cell);
    vm__dc_free(&d);
    return s;
}
