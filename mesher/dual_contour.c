/* mesher/dual_contour.c — tetrahedra filling the material {lo <= f <= hi} by dual contouring
 * on a uniform grid: seed 001 (LBIE, Zhang–Bajaj–Sohn) §4.1.2, with one minimiser per surface
 * patch of a cell (so ambiguous cells stay manifold) and the volume border closed flat. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesher_internal.h"
#include "qef.h"

/* Cube corners c = x + 2y + 4z. Edge e = 4*a + u + 2*v runs along axis a from corner
 * edge_c0[e]; u, v are its offsets along axes (a+1)%3 and (a+2)%3. */
static int edge_c0[12], edge_c1[12], edge_of[8][8];
/* Face f = 2*a + s (corners with bit a == s), corners in cyclic order. */
static int face_corner[6][4];

static void init_tables(void) {
    static int done;
    if (done) return;
    memset(edge_of, -1, sizeof edge_of);
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        for (int uv = 0; uv < 4; uv++) {
            int e = 4 * a + uv, u = uv & 1, v = uv >> 1;
            edge_c0[e] = (u << b) | (v << c);
            edge_c1[e] = edge_c0[e] | (1 << a);
            edge_of[edge_c0[e]][edge_c1[e]] = edge_of[edge_c1[e]][edge_c0[e]] = e;
        }
        for (int s = 0; s < 2; s++) {
            static const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            for (int q = 0; q < 4; q++)
                face_corner[2 * a + s][q] = (s << a) | (cyc[q][0] << b) | (cyc[q][1] << c);
        }
    }
    done = 1;
}

#define NONE 0xff

typedef struct bcell {
    int64_t cell;            /* padded cell index */
    int32_t base;            /* first representative vertex */
    uint8_t npatch, special;
    uint8_t edge_patch[12];  /* patch of each crossing edge, NONE otherwise */
    uint8_t corner_patch[8]; /* patch of each inside corner's component, NONE outside */
} bcell;

typedef struct dc {
    const vm__grid *g;
    int64_t n[3], P[3], C[3]; /* real points, padded points, padded cells per axis */
    uint8_t *in;              /* padded inside flags */
    int32_t *cell_map;        /* per padded cell: bcell index, CELL_OUT or CELL_IN */
    bcell *bc;
    size_t nbc, bc_cap;
    size_t nreps;
    int64_t *amb;                 /* keys (3*lower cell + axis) of ambiguous faces, sorted */
    size_t namb, amb_cap;
    size_t amb_base;              /* representative index of the first face vertex */
    double *qpos, *mpos, *lambda; /* per rep: minimiser, mass point, blend factor */
    uint8_t *rep_planes;          /* per rep: box planes it lies on (bit 2a+side) */
    double *centre;               /* positions of polygon centres (ids after the reps) */
    size_t ncentre, centre_cap;
    vm__octree oct;               /* interior leaves (adaptive mode only) */
    int adaptive;
    int64_t *tets;                /* 4 global ids per tet */
    size_t ntets, tet_cap;
} dc;

enum { CELL_OUT = -1, CELL_IN = -2 };

static int64_t npoints_real(const dc *d);

static int64_t pidx(const dc *d, int64_t i, int64_t j, int64_t k) {
    return (i + 1) + d->P[0] * ((j + 1) + d->P[1] * (k + 1));
}
static int64_t cidx(const dc *d, int64_t i, int64_t j, int64_t k) {
    return (i + 1) + d->C[0] * ((j + 1) + d->C[1] * (k + 1));
}
static void cell_coords(const dc *d, int64_t c, int64_t out[3]) {
    out[0] = c % d->C[0] - 1;
    out[1] = (c / d->C[0]) % d->C[1] - 1;
    out[2] = c / (d->C[0] * d->C[1]) - 1;
}
static float fval(const dc *d, int64_t i, int64_t j, int64_t k) {
    return d->g->f[i + d->n[0] * (j + d->n[1] * k)];
}
static int real_point(const dc *d, const int64_t p[3]) {
    for (int a = 0; a < 3; a++)
        if (p[a] < 0 || p[a] >= d->n[a]) return 0;
    return 1;
}

/* Index-space gradient by central differences (one-sided on the border). */
static void gradient(const dc *d, const int64_t p[3], double gr[3]) {
    for (int a = 0; a < 3; a++) {
        int64_t lo[3] = {p[0], p[1], p[2]}, hi[3] = {p[0], p[1], p[2]};
        if (p[a] > 0) lo[a]--;
        if (p[a] < d->n[a] - 1) hi[a]++;
        double h = (double)(hi[a] - lo[a]);
        gr[a] = h > 0 ? (fval(d, hi[0], hi[1], hi[2]) - fval(d, lo[0], lo[1], lo[2])) / h : 0.0;
    }
}

/* Splits the crossing edges of a cell into surface patches: on each face the crossing
 * points are joined in pairs, and an ambiguous face (inside corners on a diagonal) keeps
 * its inside corners apart, so the inside is 6-connected. */
static int find(const int *parent, int x) {
    while (parent[x] != x) x = parent[x];
    return x;
}

static void analyse_cell(int mask, bcell *b) {
    int parent[12];
    for (int e = 0; e < 12; e++) parent[e] = e;
    int cross[12];
    for (int e = 0; e < 12; e++) cross[e] = ((mask >> edge_c0[e]) & 1) != ((mask >> edge_c1[e]) & 1);
    for (int f = 0; f < 6; f++) {
        int fe[4], nc = 0, list[4];
        for (int q = 0; q < 4; q++) {
            fe[q] = edge_of[face_corner[f][q]][face_corner[f][(q + 1) & 3]];
            if (cross[fe[q]]) list[nc++] = fe[q];
        }
        if (nc == 2) {
            parent[find(parent, list[0])] = find(parent, list[1]);
        } else if (nc == 4) {
            for (int q = 0; q < 4; q++)
                if ((mask >> face_corner[f][q]) & 1) /* edges before and after corner q */
                    parent[find(parent, fe[(q + 3) & 3])] = find(parent, fe[q]);
        }
    }
    int label[12];
    b->npatch = 0;
    for (int e = 0; e < 12; e++) label[e] = -1;
    for (int e = 0; e < 12; e++) {
        b->edge_patch[e] = NONE;
        if (!cross[e]) continue;
        int r = find(parent, e);
        if (label[r] < 0) label[r] = b->npatch++;
        b->edge_patch[e] = (uint8_t)label[r];
    }
    for (int c = 0; c < 8; c++) b->corner_patch[c] = NONE;
    for (int e = 0; e < 12; e++)
        if (cross[e]) {
            int c = ((mask >> edge_c0[e]) & 1) ? edge_c0[e] : edge_c1[e];
            b->corner_patch[c] = b->edge_patch[e];
        }
    for (int pass = 0; pass < 4; pass++) /* spread along inside-inside edges */
        for (int e = 0; e < 12; e++) {
            int c0 = edge_c0[e], c1 = edge_c1[e];
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

static vm_status classify(dc *d, vm_mesh_stats *st, vm_error *err) {
    const vm__grid *g = d->g;
    size_t np = (size_t)(d->P[0] * d->P[1] * d->P[2]);
    d->in = calloc(np, 1);
    if (!d->in) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (%zu points)", np);
    size_t inside = 0;
    for (int64_t k = 0; k < d->n[2]; k++)
        for (int64_t j = 0; j < d->n[1]; j++)
            for (int64_t i = 0; i < d->n[0]; i++) {
                float f = fval(d, i, j, k);
                int is = (!g->has_lo || f >= g->lo) && (!g->has_hi || f <= g->hi);
                d->in[pidx(d, i, j, k)] = (uint8_t)is;
                inside += (size_t)is;
            }
    st->inside_voxels = inside;
    if (!inside) return vm_error_set(err, VM_ERR_EMPTY, "no grid point is in the material");
    return VM_OK;
}

static vm_status find_cells(dc *d, vm_mesh_stats *st, vm_error *err) {
    size_t nc = (size_t)(d->C[0] * d->C[1] * d->C[2]);
    d->cell_map = malloc(nc * sizeof *d->cell_map);
    if (!d->cell_map) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory (%zu cells)", nc);
    size_t reps = 0;
    for (int64_t k = -1; k < d->n[2]; k++)
        for (int64_t j = -1; j < d->n[1]; j++)
            for (int64_t i = -1; i < d->n[0]; i++) {
                int mask = 0;
                for (int c = 0; c < 8; c++)
                    mask |= d->in[pidx(d, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2))] << c;
                int64_t ci = cidx(d, i, j, k);
                if (mask == 0) {
                    d->cell_map[ci] = CELL_OUT;
                    continue;
                }
                if (mask == 0xff) {
                    d->cell_map[ci] = CELL_IN;
                    st->interior_cells++;
                    continue;
                }
                vm_status s = vm__grow((void **)&d->bc, &d->bc_cap, d->nbc + 1, sizeof(bcell), err);
                if (s) return s;
                bcell *b = &d->bc[d->nbc];
                b->cell = ci;
                analyse_cell(mask, b);
                b->base = (int32_t)reps;
                reps += b->npatch + b->special;
                if (reps > (size_t)INT32_MAX)
                    return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many surface vertices");
                st->special_cells += b->special;
                d->cell_map[ci] = (int32_t)d->nbc++;
                for (int a = 0; a < 3; a++) { /* the cell's upper face along a */
                    const int *fc = face_corner[2 * a + 1];
                    int q0 = (mask >> fc[0]) & 1, q1 = (mask >> fc[1]) & 1;
                    int q2 = (mask >> fc[2]) & 1, q3 = (mask >> fc[3]) & 1;
                    if (q0 == q2 && q1 == q3 && q0 != q1) {
                        s = vm__grow((void **)&d->amb, &d->amb_cap, d->namb + 1, sizeof(int64_t), err);
                        if (s) return s;
                        d->amb[d->namb++] = 3 * ci + a;
                    }
                }
            }
    st->boundary_cells = d->nbc;
    /* An ambiguous face needs its own vertices only when both cells put its two segments
     * in one patch: then the two cells' vertices would be joined twice. */
    size_t kept = 0;
    for (size_t fi = 0; fi < d->namb; fi++) {
        int64_t cm[3], um[3];
        int a = (int)(d->amb[fi] % 3);
        cell_coords(d, d->amb[fi] / 3, cm);
        memcpy(um, cm, sizeof um);
        um[a]++;
        const bcell *lo = &d->bc[d->cell_map[d->amb[fi] / 3]];
        const bcell *up = &d->bc[d->cell_map[cidx(d, um[0], um[1], um[2])]];
        const int *fc = face_corner[2 * a + 1];
        int e0 = edge_of[fc[0]][fc[1]], e2 = edge_of[fc[2]][fc[3]];
        int u0 = edge_of[fc[0] ^ (1 << a)][fc[1] ^ (1 << a)];
        int u2 = edge_of[fc[2] ^ (1 << a)][fc[3] ^ (1 << a)];
        /* edges 0-1 and 2-3 of the face belong to different segments */
        if (lo->edge_patch[e0] == lo->edge_patch[e2] && up->edge_patch[u0] == up->edge_patch[u2])
            d->amb[kept++] = d->amb[fi];
    }
    d->namb = kept;
    d->amb_base = reps;
    d->nreps = reps + 2 * d->namb;
    return VM_OK;
}

/* Where the material boundary crosses the grid edge p0-p1 (one end inside): linear
 * interpolation against the bound the outside end violates, kept 2% away from the ends;
 * the normal is the interpolated gradient. Absolute index coordinates. */
static void edge_crossing(const dc *d, const int64_t p0[3], const int64_t p1[3], double pt[3],
                          double nrm[3]) {
    const vm__grid *g = d->g;
    double f0 = fval(d, p0[0], p0[1], p0[2]), f1 = fval(d, p1[0], p1[1], p1[2]);
    int in0 = d->in[pidx(d, p0[0], p0[1], p0[2])];
    double fo = in0 ? f1 : f0;
    double bound = (g->has_hi && fo > g->hi) ? g->hi : g->lo;
    double t = (f1 != f0) ? (bound - f0) / (f1 - f0) : 0.5;
    if (!(t >= 0.02)) t = 0.02;
    if (t > 0.98) t = 0.98;
    double g0[3], g1[3];
    gradient(d, p0, g0);
    gradient(d, p1, g1);
    for (int a = 0; a < 3; a++) {
        pt[a] = (double)p0[a] + t * (double)(p1[a] - p0[a]);
        nrm[a] = (1 - t) * g0[a] + t * g1[a];
    }
    double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
    if (len > 0)
        for (int a = 0; a < 3; a++) nrm[a] /= len;
}

/* Places the minimiser and mass point of every patch (index coordinates). Cells reaching
 * into the padding pin the padded axes to the border plane and use only crossings between
 * real points, so the border faces are the 2-D dual contour of the material's section. */
static vm_status place_reps(dc *d, vm_error *err) {
    size_t n = d->nreps ? d->nreps : 1;
    d->qpos = malloc(3 * n * sizeof(double));
    d->mpos = malloc(3 * n * sizeof(double));
    d->lambda = malloc(n * sizeof(double));
    d->rep_planes = calloc(n, 1);
    if (!d->qpos || !d->mpos || !d->lambda || !d->rep_planes)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for %zu vertices", n);
    for (size_t bi = 0; bi < d->nbc; bi++) {
        const bcell *b = &d->bc[bi];
        int64_t cm[3];
        cell_coords(d, b->cell, cm);
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
        for (int p = 0; p < b->npatch; p++) {
            vm_qef q;
            vm__qef_init(&q);
            for (int e = 0; e < 12; e++) {
                if (b->edge_patch[e] != p) continue;
                int64_t p0[3], p1[3];
                for (int a = 0; a < 3; a++) {
                    p0[a] = cm[a] + ((edge_c0[e] >> a) & 1);
                    p1[a] = cm[a] + ((edge_c1[e] >> a) & 1);
                }
                if (!real_point(d, p0) || !real_point(d, p1)) continue;
                double pt[3], nrm[3];
                edge_crossing(d, p0, p1, pt, nrm);
                for (int a = 0; a < 3; a++) pt[a] -= (double)cm[a];
                vm__qef_add(&q, pt, nrm);
            }
            double x[3], m[3];
            if (q.count == 0) {
                for (int a = 0; a < 3; a++) x[a] = m[a] = fixed[a] ? fixval[a] : 0.5;
            } else {
                vm__qef_solve(&q, 0.05, fixed, fixval, x, m);
            }
            size_t r = (size_t)b->base + (size_t)p;
            for (int a = 0; a < 3; a++) {
                if (x[a] < 0) x[a] = 0;
                if (x[a] > 1) x[a] = 1;
                d->qpos[3 * r + a] = (double)cm[a] + x[a];
                d->mpos[3 * r + a] = (double)cm[a] + m[a];
            }
            d->lambda[r] = 1.0;
            d->rep_planes[r] = planes;
        }
        if (b->special) {
            size_t r = (size_t)b->base + b->npatch;
            for (int a = 0; a < 3; a++) d->qpos[3 * r + a] = d->mpos[3 * r + a] = (double)cm[a] + 0.5;
            d->lambda[r] = 1.0;
            d->rep_planes[r] = 0;
        }
    }
    /* Ambiguous faces: one vertex per boundary segment, midway between its two crossings. */
    for (size_t fi = 0; fi < d->namb; fi++) {
        int64_t cm[3];
        int a = (int)(d->amb[fi] % 3);
        cell_coords(d, d->amb[fi] / 3, cm);
        const int *fc = face_corner[2 * a + 1];
        int64_t pc[4][3];
        for (int q = 0; q < 4; q++)
            for (int k = 0; k < 3; k++) pc[q][k] = cm[k] + ((fc[q] >> k) & 1);
        int first = d->in[pidx(d, pc[0][0], pc[0][1], pc[0][2])] ? 0 : 1;
        for (int h = 0; h < 2; h++) {
            int q = first + 2 * h;
            double x0[3], x1[3], nrm[3];
            edge_crossing(d, pc[q], pc[(q + 1) & 3], x0, nrm);
            edge_crossing(d, pc[q], pc[(q + 3) & 3], x1, nrm);
            size_t r = d->amb_base + 2 * fi + (size_t)h;
            /* relaxation pulls it toward the corner it cuts off */
            for (int k = 0; k < 3; k++) {
                d->qpos[3 * r + k] = 0.5 * (x0[k] + x1[k]);
                d->mpos[3 * r + k] = (double)pc[q][k] + 0.35 * (d->qpos[3 * r + k] - (double)pc[q][k]);
            }
            d->lambda[r] = 1.0;
            uint8_t planes = 0;
            if (pc[0][a] == 0) planes |= (uint8_t)(1 << (2 * a));
            if (pc[0][a] == d->n[a] - 1) planes |= (uint8_t)(1 << (2 * a + 1));
            d->rep_planes[r] = planes;
        }
    }
    return VM_OK;
}

/* Vertex of the ambiguous face between the cells around an edge (lower cell lower_cm,
 * face normal along axis a) on the segment cutting off the inside corner v, or -1. */
static int64_t face_vertex(const dc *d, const int64_t lower_cm[3], int a, const int64_t v[3]) {
    int64_t key = 3 * cidx(d, lower_cm[0], lower_cm[1], lower_cm[2]) + a;
    size_t lo = 0, hi = d->namb;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (d->amb[mid] < key)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == d->namb || d->amb[lo] != key) return -1;
    int corner = 0;
    for (int k = 0; k < 3; k++) corner |= (int)(v[k] - lower_cm[k]) << k;
    const int *fc = face_corner[2 * a + 1];
    int pos = 0;
    while (fc[pos] != corner) pos++;
    return npoints_real(d) + (int64_t)(d->amb_base + 2 * lo + (size_t)(pos >> 1));
}

/* ---- vertices: global id = lattice index (0..N-1) or N + representative index ---- */

static int64_t npoints_real(const dc *d) { return d->n[0] * d->n[1] * d->n[2]; }

static int64_t lattice_id(const dc *d, const int64_t p[3]) {
    return p[0] + d->n[0] * (p[1] + d->n[1] * p[2]);
}

static void vertex_pos(const dc *d, int64_t id, int reference, double out[3]) {
    int64_t N = npoints_real(d);
    if (id < N) {
        out[0] = (double)(id % d->n[0]);
        out[1] = (double)((id / d->n[0]) % d->n[1]);
        out[2] = (double)(id / (d->n[0] * d->n[1]));
        return;
    }
    size_t r = (size_t)(id - N);
    if (r >= d->nreps) {
        memcpy(out, d->centre + 3 * (r - d->nreps), 3 * sizeof(double));
        return;
    }
    const double *m = d->mpos + 3 * r, *q = d->qpos + 3 * r;
    double l = reference ? 0.0 : d->lambda[r];
    for (int a = 0; a < 3; a++) out[a] = m[a] + l * (q[a] - m[a]);
}

static uint8_t vertex_planes(const dc *d, int64_t id) {
    int64_t N = npoints_real(d);
    if (id >= N) return (size_t)(id - N) < d->nreps ? d->rep_planes[id - N] : 0;
    int64_t p[3] = {id % d->n[0], (id / d->n[0]) % d->n[1], id / (d->n[0] * d->n[1])};
    uint8_t m = 0;
    for (int a = 0; a < 3; a++) {
        if (p[a] == 0) m |= (uint8_t)(1 << (2 * a));
        if (p[a] == d->n[a] - 1) m |= (uint8_t)(1 << (2 * a + 1));
    }
    return m;
}

static double orient(const double a[3], const double b[3], const double c[3], const double e[3]) {
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
        w[k] = e[k] - a[k];
    }
    return (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
            u[2] * (v[0] * w[1] - v[1] * w[0])) / 6.0;
}

static double tet_volume(const dc *d, const int64_t t[4], int reference) {
    double p[4][3];
    for (int k = 0; k < 4; k++) vertex_pos(d, t[k], reference, p[k]);
    return orient(p[0], p[1], p[2], p[3]);
}

static vm_status emit(dc *d, int64_t a, int64_t b, int64_t c, int64_t e, vm_error *err) {
    /* Tets lying flat on one border plane are the closure of the padding: drop them. */
    if (vertex_planes(d, a) & vertex_planes(d, b) & vertex_planes(d, c) & vertex_planes(d, e))
        return VM_OK;
    vm_status s = vm__grow((void **)&d->tets, &d->tet_cap, d->ntets + 1, 4 * sizeof(int64_t), err);
    if (s) return s;
    int64_t *t = d->tets + 4 * d->ntets++;
    t[0] = a;
    t[1] = b;
    t[2] = c;
    t[3] = e;
    return VM_OK;
}

/* Emits a tet whose orientation is decided on the reference geometry (lattice points and
 * mass points), for the few pieces whose order is not fixed by construction. */
static vm_status emit_oriented(dc *d, int64_t a, int64_t b, int64_t c, int64_t e, vm_error *err) {
    int64_t t[4] = {a, b, c, e};
    if (tet_volume(d, t, 1) < 0) return emit(d, a, c, b, e, err);
    return emit(d, a, b, c, e, err);
}

/* Representative vertex of cell b for its local edge e. */
static int64_t rep_for_edge(const dc *d, const bcell *b, int e) {
    int64_t N = npoints_real(d);
    if (b->edge_patch[e] != NONE) return N + b->base + b->edge_patch[e];
    if (b->special) return N + b->base + b->npatch;
    return N + b->base + b->corner_patch[edge_c0[e]];
}

/* The four cells around the edge from p along axis a, counter-clockwise seen from +a,
 * with the edge's local index in each. Returns their bcell (NULL for interior cells). */
static void cells_around(const dc *d, const int64_t p[3], int a, const bcell *cb[4], int le[4],
                         int32_t code[4], int64_t mins[4][3]) {
    static const int off[4][2] = {{0, 0}, {-1, 0}, {-1, -1}, {0, -1}};
    int b = (a + 1) % 3, c = (a + 2) % 3;
    for (int q = 0; q < 4; q++) {
        int64_t m[3] = {p[0], p[1], p[2]};
        m[b] += off[q][0];
        m[c] += off[q][1];
        code[q] = d->cell_map[cidx(d, m[0], m[1], m[2])];
        memcpy(mins[q], m, sizeof m);
        cb[q] = code[q] >= 0 ? &d->bc[code[q]] : NULL;
        le[q] = 4 * a + (-off[q][0]) + 2 * (-off[q][1]);
    }
}

/* The element of a sign-change edge: a pyramid from its inside end over the polygon of
 * the four cells' vertices (counter-clockwise around +a), with the vertex of an ambiguous
 * face inserted between the two cells sharing it. The polygon is split as a fan from the
 * root that gives the largest smallest volume. */
static vm_status emit_pyramid(dc *d, int a, const int64_t apex_p[3], int apex_lower,
                              const bcell *cb[4], const int le[4], int64_t mins[4][3],
                              vm_error *err) {
    /* lower cell of the face shared by cells q and q+1, and that face's normal axis */
    static const int lower_of[4] = {1, 2, 2, 3};
    int b = (a + 1) % 3, c = (a + 2) % 3;
    const int axis_of[4] = {b, c, b, c};
    int64_t poly[8];
    int np = 0, inserted[8] = {0};
    for (int q = 0; q < 4; q++) {
        poly[np++] = rep_for_edge(d, cb[q], le[q]);
        if (d->namb) {
            int64_t fv = face_vertex(d, mins[lower_of[q]], axis_of[q], apex_p);
            if (fv >= 0) {
                inserted[np] = 1;
                poly[np++] = fv;
            }
        }
    }
    int64_t apex = lattice_id(d, apex_p);
    vm_status s = VM_OK;
    if (np > 4) {
        /* Fans from a neighbour of a face vertex would join the two cells it separates; try
         * the other roots, and a fan from a new vertex at the polygon's centre. */
        int best_root = -1;
        double best = -INFINITY;
        for (int root = 0; root < np; root++) {
            if (inserted[(root + 1) % np] || inserted[(root + np - 1) % np]) continue;
            double worst = INFINITY;
            for (int i = 1; i + 1 < np; i++) {
                int64_t t[4] = {apex, poly[root], poly[(root + i) % np], poly[(root + i + 1) % np]};
                if (!apex_lower) t[1] = poly[(root + i + 1) % np], t[3] = poly[root];
                worst = fmin(worst, tet_volume(d, t, 0));
            }
            if (worst > best) best = worst, best_root = root;
        }
        double cpos[3] = {0, 0, 0};
        for (int i = 0; i < np; i++) {
            double p[3];
            vertex_pos(d, poly[i], 0, p);
            for (int k = 0; k < 3; k++) cpos[k] += p[k] / np;
        }
        /* The signs of the centre's tets depend only on its direction from the apex: try
         * the centroid, then directions along the side triangles' normals. */
        double ap[3], nrm[8][3], sum[3] = {0, 0, 0}, len = 0;
        vertex_pos(d, apex, 0, ap);
        for (int i = 0; i < np; i++) {
            double x[3], y[3], u[3], w[3];
            vertex_pos(d, poly[i], 0, x);
            vertex_pos(d, poly[(i + 1) % np], 0, y);
            for (int k = 0; k < 3; k++) u[k] = x[k] - ap[k], w[k] = y[k] - ap[k];
            double sgn = apex_lower ? 1.0 : -1.0;
            nrm[i][0] = sgn * (u[1] * w[2] - u[2] * w[1]);
            nrm[i][1] = sgn * (u[2] * w[0] - u[0] * w[2]);
            nrm[i][2] = sgn * (u[0] * w[1] - u[1] * w[0]);
            double nl = sqrt(nrm[i][0] * nrm[i][0] + nrm[i][1] * nrm[i][1] + nrm[i][2] * nrm[i][2]);
            for (int k = 0; k < 3; k++) sum[k] += nl > 0 ? nrm[i][k] / nl : 0;
        }
        for (int k = 0; k < 3; k++) len += (cpos[k] - ap[k]) * (cpos[k] - ap[k]);
        len = sqrt(len);
        double worst_c = -INFINITY, cand[10][3];
        int ncand = 0;
        for (int k = 0; k < 3; k++) cand[ncand][k] = cpos[k] - ap[k];
        ncand++;
        memcpy(cand[ncand++], sum, sizeof sum);
        for (int i = 0; i < np && ncand < 9; i++) memcpy(cand[ncand++], nrm[i], sizeof nrm[i]);
        { /* perceptron steps toward the worst side normal */
            double w[3];
            memcpy(w, sum, sizeof w);
            for (int it = 0; it < 64; it++) {
                int wi = -1;
                double wv = INFINITY;
                for (int i = 0; i < np; i++) {
                    double nl = sqrt(nrm[i][0] * nrm[i][0] + nrm[i][1] * nrm[i][1] + nrm[i][2] * nrm[i][2]);
                    double dv = nl > 0 ? (w[0] * nrm[i][0] + w[1] * nrm[i][1] + w[2] * nrm[i][2]) / nl : 0;
                    if (dv < wv) wv = dv, wi = i;
                }
                double wl = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
                if (wi < 0 || wv > 0.05 * wl) break;
                double nl = sqrt(nrm[wi][0] * nrm[wi][0] + nrm[wi][1] * nrm[wi][1] + nrm[wi][2] * nrm[wi][2]);
                for (int k = 0; k < 3; k++) w[k] += (wl > 0 ? 0.5 * wl : 1.0) * nrm[wi][k] / (nl > 0 ? nl : 1);
            }
            memcpy(cand[ncand++], w, sizeof w);
        }
        for (int ci = 0; ci < ncand; ci++) {
            double cl = sqrt(cand[ci][0] * cand[ci][0] + cand[ci][1] * cand[ci][1] + cand[ci][2] * cand[ci][2]);
            if (!(cl > 0)) continue;
            double worst = INFINITY;
            for (int i = 0; i < np; i++)
                worst = fmin(worst, (cand[ci][0] * nrm[i][0] + cand[ci][1] * nrm[i][1] + cand[ci][2] * nrm[i][2]) * len / cl / 6.0);
            if (worst > worst_c * 1.000001 + 1e-12 || ci == 0) {
                if (ci > 0 && worst_c > 1e-4 * len * len * len) break; /* the centroid is fine */
                worst_c = worst;
                for (int k = 0; k < 3; k++) cpos[k] = ap[k] + cand[ci][k] * len / cl;
            }
        }
        if (best_root >= 0 && best >= worst_c) {
            for (int i = 1; i + 1 < np && !s; i++) {
                int64_t x = poly[best_root], y = poly[(best_root + i) % np];
                int64_t z = poly[(best_root + i + 1) % np];
                s = apex_lower ? emit(d, apex, x, y, z, err) : emit(d, apex, z, y, x, err);
            }
            return s;
        }
        s = vm__grow((void **)&d->centre, &d->centre_cap, d->ncentre + 1, 3 * sizeof(double), err);
        if (s) return s;
        memcpy(d->centre + 3 * d->ncentre, cpos, sizeof cpos);
        int64_t cid = npoints_real(d) + (int64_t)(d->nreps + d->ncentre++);
        for (int i = 0; i < np && !s; i++) {
            int64_t x = poly[i], y = poly[(i + 1) % np];
            s = apex_lower ? emit(d, apex, cid, x, y, err) : emit(d, apex, y, x, cid, err);
        }
        return s;
    }
    int64_t ta[2][4] = {{apex, poly[0], poly[1], poly[2]}, {apex, poly[0], poly[2], poly[3]}};
    int64_t tb[2][4] = {{apex, poly[1], poly[2], poly[3]}, {apex, poly[1], poly[3], poly[0]}};
    if (!apex_lower)
        for (int t = 0; t < 2; t++) {
            int64_t x = ta[t][1], y = tb[t][1];
            ta[t][1] = ta[t][3], ta[t][3] = x;
            tb[t][1] = tb[t][3], tb[t][3] = y;
        }
    double qa = fmin(tet_volume(d, ta[0], 0), tet_volume(d, ta[1], 0));
    double qb = fmin(tet_volume(d, tb[0], 0), tet_volume(d, tb[1], 0));
    int64_t(*best)[4] = qa >= qb ? ta : tb;
    for (int t = 0; t < 2 && !s; t++) s = emit(d, best[t][0], best[t][1], best[t][2], best[t][3], err);
    return s;
}

static vm_status emit_edges(dc *d, vm_error *err) {
    for (int a = 0; a < 3; a++)
        for (int64_t k = 0; k < d->n[2]; k++)
            for (int64_t j = 0; j < d->n[1]; j++)
                for (int64_t i = 0; i < d->n[0]; i++) {
                    int64_t p0[3] = {i, j, k}, p1[3] = {i, j, k};
                    if (++p1[a] >= d->n[a]) continue;
                    int in0 = d->in[pidx(d, i, j, k)], in1 = d->in[pidx(d, p1[0], p1[1], p1[2])];
                    if (!in0 && !in1) continue;
                    const bcell *cb[4];
                    int le[4];
                    int32_t code[4];
                    int64_t mins[4][3];
                    cells_around(d, p0, a, cb, le, code, mins);
                    int64_t v0 = lattice_id(d, p0), v1 = lattice_id(d, p1);
                    vm_status s = VM_OK;
                    if (in0 != in1) { /* sign change: pyramid from the inside end */
                        s = emit_pyramid(d, a, in0 ? p0 : p1, in0, cb, le, mins, err);
                    } else { /* inside edge: one tet per pair of neighbouring boundary cells */
                        for (int q = 0; q < 4 && !s; q++) {
                            const bcell *x = cb[q], *y = cb[(q + 1) & 3];
                            if (!x || !y) continue;
                            s = emit(d, v0, v1, rep_for_edge(d, x, le[q]),
                                     rep_for_edge(d, y, le[(q + 1) & 3]), err);
                        }
                    }
                    if (s) return s;
                }
    return VM_OK;
}

/* Faces of boundary cells whose four corners are inside and whose neighbour is an interior
 * cell: a pyramid to the cell's minimiser, split along the face's even-parity diagonal
 * (the diagonal the neighbour's five-tet split uses). */
static vm_status emit_faces(dc *d, vm_error *err) {
    int64_t N = npoints_real(d);
    for (size_t bi = 0; bi < d->nbc; bi++) {
        const bcell *b = &d->bc[bi];
        int64_t cm[3];
        cell_coords(d, b->cell, cm);
        for (int f = 0; f < 6; f++) {
            int a = f >> 1, s = f & 1, all = 1;
            for (int q = 0; q < 4; q++)
                if (b->corner_patch[face_corner[f][q]] == NONE) all = 0;
            if (!all) continue;
            int64_t nb[3] = {cm[0], cm[1], cm[2]};
            nb[a] += s ? 1 : -1;
            if (d->cell_map[cidx(d, nb[0], nb[1], nb[2])] != CELL_IN) continue;
            int64_t v[4];
            int even0 = 0;
            for (int q = 0; q < 4; q++) {
                int c = face_corner[f][q];
                int64_t p[3] = {cm[0] + (c & 1), cm[1] + ((c >> 1) & 1), cm[2] + (c >> 2)};
                v[q] = lattice_id(d, p);
                if (q == 0) even0 = ((p[0] + p[1] + p[2]) & 1) == 0;
            }
            int64_t apex = N + b->base + b->corner_patch[face_corner[f][0]];
            int o = even0 ? 0 : 1; /* diagonal v[o] - v[o+2] */
            vm_status st = emit_oriented(d, apex, v[o], v[o + 1], v[(o + 2) & 3], err);
            if (!st) st = emit_oriented(d, apex, v[o], v[(o + 2) & 3], v[(o + 3) & 3], err);
            if (st) return st;
        }
    }
    return VM_OK;
}

/* Interior cells: five tets, the central one on the four even-parity corners. */
static vm_status emit_five(dc *d, int64_t i, int64_t j, int64_t k, vm_error *err) {
    int64_t v[8];
    int odd_first = (int)((i + j + k) & 1); /* corner 0 is odd */
    for (int c = 0; c < 8; c++) {
        int64_t p[3] = {i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2)};
        v[c] = lattice_id(d, p);
    }
    int ev[4], od[4], ne = 0, no = 0;
    for (int c = 0; c < 8; c++) {
        int par = ((c & 1) + ((c >> 1) & 1) + (c >> 2) + odd_first) & 1;
        if (par)
            od[no++] = c;
        else
            ev[ne++] = c;
    }
    vm_status s = emit_oriented(d, v[ev[0]], v[ev[1]], v[ev[2]], v[ev[3]], err);
    for (int q = 0; q < 4 && !s; q++) {
        int c = od[q];
        s = emit_oriented(d, v[c], v[c ^ 1], v[c ^ 2], v[c ^ 4], err);
    }
    return s;
}

/* One face square of a coarse leaf (min corner q, size sz, normal axis a; the leaf lies on
 * side `below` of the plane when below != 0): tets from the leaf centre over the face's
 * triangles. The square splits into four when the leaf across it is finer; an unsplit
 * square with grid vertices on its edges (corners of smaller leaves touching the edge) is
 * fanned from its centre (a grid point no leaf uses as a corner), otherwise it is cut along
 * its even-parity diagonal, as the leaf across does (LBIE §4.2.2, "decompose each face of
 * the cube into triangles ... then insert a Steiner point at the cell center"). */
static vm_status emit_coarse_face(dc *d, int64_t centre, int a, const int64_t q[3], int64_t sz,
                                  int below, vm_error *err) {
    int b = (a + 1) % 3, c = (a + 2) % 3;
    int64_t across[3] = {q[0], q[1], q[2]}, org[3];
    if (!below) across[a]--;
    int lvl = vm__octree_leaf(&d->oct, across, org);
    int across_size_ok = lvl == VM_LEAF_NONE || (lvl >= 0 && ((int64_t)1 << lvl) >= sz);
    if (!across_size_ok && sz > 1) {
        int64_t h = sz / 2;
        for (int k = 0; k < 4; k++) {
            int64_t r[3] = {q[0], q[1], q[2]};
            r[b] += h * (k & 1);
            r[c] += h * (k >> 1);
            vm_status s = emit_coarse_face(d, centre, a, r, h, below, err);
            if (s) return s;
        }
        return VM_OK;
    }
    static const int cyc[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    int64_t corner[4], ring_buf[64], *ring = ring_buf;
    size_t nr = 0, ring_cap = 64, mids = 0;
    int even0 = 0;
    for (int k = 0; k < 4; k++) {
        int64_t p[3] = {q[0], q[1], q[2]};
        p[b] += sz * cyc[k][0];
        p[c] += sz * cyc[k][1];
        corner[k] = lattice_id(d, p);
        if (k == 0) even0 = (((p[0] + p[1] + p[2]) / sz) & 1) == 0;
        if (nr + (size_t)sz >= ring_cap) { /* room for this corner and its edge */
            size_t ncap = 2 * (nr + (size_t)sz + 1);
            int64_t *nb = malloc(ncap * sizeof *nb);
            if (!nb) {
                if (ring != ring_buf) free(ring);
                return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
            }
            memcpy(nb, ring, nr * sizeof *nb);
            if (ring != ring_buf) free(ring);
            ring = nb;
            ring_cap = ncap;
        }
        ring[nr++] = corner[k];
        /* grid points along the edge that corners of smaller leaves put there */
        int db = cyc[(k + 1) & 3][0] - cyc[k][0], dc2 = cyc[(k + 1) & 3][1] - cyc[k][1];
        for (int64_t t = 1; t < sz; t++) {
            int64_t m[3] = {p[0], p[1], p[2]};
            m[b] += t * db;
            m[c] += t * dc2;
            if (vm__octree_is_vertex(&d->oct, m)) {
                ring[nr++] = lattice_id(d, m);
                mids++;
            }
        }
    }
    if (mids) {
        int64_t fc[3] = {q[0], q[1], q[2]};
        fc[b] += sz / 2;
        fc[c] += sz / 2;
        int64_t f = lattice_id(d, fc);
        vm_status s = VM_OK;
        for (size_t k = 0; k < nr && !s; k++) s = emit_oriented(d, centre, f, ring[k], ring[(k + 1) % nr], err);
        if (ring != ring_buf) free(ring);
        return s;
    }
    if (ring != ring_buf) free(ring);
    int o = even0 ? 0 : 1; /* diagonal corner[o] - corner[o+2] */
    vm_status s = emit_oriented(d, centre, corner[o], corner[o + 1], corner[(o + 2) & 3], err);
    if (!s) s = emit_oriented(d, centre, corner[o], corner[(o + 2) & 3], corner[(o + 3) & 3], err);
    return s;
}

static vm_status emit_coarse_leaf(dc *d, const int64_t o[3], int l, vm_error *err) {
    int64_t sz = (int64_t)1 << l, ctr[3] = {o[0] + sz / 2, o[1] + sz / 2, o[2] + sz / 2};
    int64_t centre = lattice_id(d, ctr);
    for (int f = 0; f < 6; f++) {
        int a = f >> 1, side = f & 1;
        int64_t q[3] = {o[0], o[1], o[2]};
        q[a] += side ? sz : 0;
        vm_status s = emit_coarse_face(d, centre, a, q, sz, side, err);
        if (s) return s;
    }
    return VM_OK;
}

static vm_status emit_interior(dc *d, vm_error *err) {
    for (int64_t k = 0; k + 1 < d->n[2]; k++)
        for (int64_t j = 0; j + 1 < d->n[1]; j++)
            for (int64_t i = 0; i + 1 < d->n[0]; i++) {
                if (d->cell_map[cidx(d, i, j, k)] != CELL_IN) continue;
                vm_status s = VM_OK;
                if (d->adaptive) {
                    int64_t c[3] = {i, j, k}, org[3];
                    int l = vm__octree_leaf(&d->oct, c, org);
                    if (l > 0) {
                        if (org[0] == i && org[1] == j && org[2] == k)
                            s = emit_coarse_leaf(d, org, l, err);
                        if (s) return s;
                        continue;
                    }
                }
                s = emit_five(d, i, j, k, err);
                if (s) return s;
            }
    return VM_OK;
}

/* Around a special cell the elements of the two face edges at an inside corner use
 * different vertices in one of the two cells; the gap between their triangles is filled
 * with one tet, or two (a pyramid) when both cells differ. */
static vm_status emit_gaps(dc *d, vm_error *err) {
    for (size_t bi = 0; bi < d->nbc; bi++) {
        const bcell *b = &d->bc[bi];
        if (!b->special) continue;
        int64_t cm[3];
        cell_coords(d, b->cell, cm);
        for (int f = 0; f < 6; f++) {
            int a = f >> 1, s = f & 1;
            int64_t nb[3] = {cm[0], cm[1], cm[2]};
            nb[a] += s ? 1 : -1;
            int32_t code = d->cell_map[cidx(d, nb[0], nb[1], nb[2])];
            if (code < 0) return vm_error_set(err, VM_ERR_INTERNAL, "mesh: special cell next to a uniform cell");
            const bcell *o = &d->bc[code];
            if (o->special && (size_t)code < bi) continue; /* done from the other side */
            for (int q = 0; q < 4; q++) {
                int c = face_corner[f][q];
                if (b->corner_patch[c] == NONE) continue;
                int e1 = edge_of[c][face_corner[f][(q + 1) & 3]];
                int e2 = edge_of[c][face_corner[f][(q + 3) & 3]];
                /* the same edges seen from the neighbour: flip bit a of both corners */
                int o1 = edge_of[edge_c0[e1] ^ (1 << a)][edge_c1[e1] ^ (1 << a)];
                int o2 = edge_of[edge_c0[e2] ^ (1 << a)][edge_c1[e2] ^ (1 << a)];
                int64_t x1 = rep_for_edge(d, b, e1), x2 = rep_for_edge(d, b, e2);
                int64_t y1 = rep_for_edge(d, o, o1), y2 = rep_for_edge(d, o, o2);
                int64_t p[3] = {cm[0] + (c & 1), cm[1] + ((c >> 1) & 1), cm[2] + (c >> 2)};
                int64_t n = lattice_id(d, p);
                vm_status st = VM_OK;
                if (x1 != x2 && y1 == y2) {
                    st = emit_oriented(d, n, x1, x2, y1, err);
                } else if (x1 == x2 && y1 != y2) {
                    st = emit_oriented(d, n, y1, y2, x1, err);
                } else if (x1 != x2 && y1 != y2) {
                    int64_t quad[4] = {x1, x2, y2, y1};
                    int lo = 0;
                    for (int k = 1; k < 4; k++)
                        if (quad[k] < quad[lo]) lo = k;
                    st = emit_oriented(d, n, quad[lo], quad[(lo + 1) & 3], quad[(lo + 2) & 3], err);
                    if (!st)
                        st = emit_oriented(d, n, quad[lo], quad[(lo + 2) & 3], quad[(lo + 3) & 3], err);
                }
                if (st) return st;
            }
        }
    }
    return VM_OK;
}

static vm_status emit_all(dc *d, vm_error *err) {
    d->ntets = 0;
    d->ncentre = 0;
    vm_status s = emit_edges(d, err);
    if (!s) s = emit_faces(d, err);
    if (!s) s = emit_interior(d, err);
    if (!s) s = emit_gaps(d, err);
    return s;
}

/* Pulls the minimisers of every tet that is not clearly positive back toward their mass
 * points, halving the step each round, then re-emits (the quad splits may change).
 * Returns the number of tets still not positive. */
static vm_status make_positive(dc *d, size_t *bad_left, size_t *relaxed, vm_error *err) {
    const double eps = 1e-9; /* index units: a 0.02-voxel tet is ~1e-6 */
    int64_t N = npoints_real(d);
    uint8_t *touched = calloc(d->nreps ? d->nreps : 1, 1);
    if (!touched) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    size_t bad = 0;
    for (int round = 0; round < 24; round++) {
        bad = 0;
        for (size_t t = 0; t < d->ntets; t++) {
            const int64_t *v = d->tets + 4 * t;
            if (tet_volume(d, v, 0) > eps) continue;
            bad++;
            for (int k = 0; k < 4; k++)
                if (v[k] >= N && (size_t)(v[k] - N) < d->nreps) {
                    size_t r = (size_t)(v[k] - N);
                    d->lambda[r] = d->lambda[r] > 1.0 / 64 ? d->lambda[r] * 0.5 : 0.0;
                    touched[r] = 1;
                }
        }
        if (!bad) break;
        vm_status s = emit_all(d, err);
        if (s) {
            free(touched);
            return s;
        }
    }
    size_t nt = 0;
    for (size_t r = 0; r < d->nreps; r++) nt += touched[r];
    free(touched);
    *relaxed = nt;
    *bad_left = bad;
    return VM_OK;
}

static vm_status build_octree(dc *d, int max_level, vm_mesh_stats *st, vm_error *err) {
    int64_t nc[3] = {d->n[0] - 1, d->n[1] - 1, d->n[2] - 1};
    size_t n = (size_t)(nc[0] * nc[1] * nc[2]);
    uint8_t *kind = malloc(n ? n : 1);
    if (!kind) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    size_t idx = 0;
    for (int64_t k = 0; k < nc[2]; k++)
        for (int64_t j = 0; j < nc[1]; j++)
            for (int64_t i = 0; i < nc[0]; i++) {
                int32_t code = d->cell_map[cidx(d, i, j, k)];
                kind[idx++] = code == CELL_IN    ? VM_KIND_INTERIOR
                              : code == CELL_OUT ? VM_KIND_EXTERIOR
                                                 : VM_KIND_BOUNDARY;
            }
    size_t leaves = 0;
    vm_status s = vm__octree_build(&d->oct, nc, kind, max_level, &leaves, err);
    free(kind);
    d->adaptive = s == VM_OK;
    st->interior_cells = leaves;
    return s;
}

static void dc_free(dc *d) {
    free(d->in);
    free(d->cell_map);
    free(d->bc);
    free(d->qpos);
    free(d->mpos);
    free(d->lambda);
    free(d->rep_planes);
    free(d->amb);
    free(d->centre);
    vm__octree_free(&d->oct);
    free(d->tets);
}

vm_status vm__dual_contour_tets(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                vm_error *err) {
    init_tables();
    dc d;
    memset(&d, 0, sizeof d);
    d.g = g;
    for (int a = 0; a < 3; a++) {
        d.n[a] = g->n[a];
        d.P[a] = g->n[a] + 2;
        d.C[a] = g->n[a] + 1;
    }
    size_t tmp;
    vm_status s = vm__check_dims(d.P, 1 + sizeof(int32_t) + 2 * sizeof(int64_t), "mesh", &tmp, err);
    if (!s) s = classify(&d, st, err);
    if (!s && g->progress) g->progress("contour", 1, 4, g->progress_user);
    if (!s) s = find_cells(&d, st, err);
    if (!s && g->max_level > 0) s = build_octree(&d, g->max_level, st, err);
    if (!s) s = place_reps(&d, err);
    if (!s && g->progress) g->progress("contour", 2, 4, g->progress_user);
    if (!s) s = emit_all(&d, err);
    if (!s && g->progress) g->progress("contour", 3, 4, g->progress_user);
    size_t bad = 0, relaxed = 0;
    if (!s) s = make_positive(&d, &bad, &relaxed, err);
    if (!s && bad)
        s = vm_error_set(err, VM_ERR_INTERNAL,
                         "mesh: %zu tetrahedra stay flat or inverted after relaxation", bad);
    if (!s && g->progress) g->progress("contour", 4, 4, g->progress_user);
    if (s) {
        dc_free(&d);
        return s;
    }
    st->relaxed_vertices = relaxed;
    st->surface_vertices = d.nreps;
    /* Hand over tets and the positions of the vertices they use. */
    out->ntets = d.ntets;
    out->tets = d.tets;
    d.tets = NULL;
    out->nlattice = npoints_real(&d);
    out->nreps = d.nreps + d.ncentre;
    out->rep_pos = malloc(3 * (out->nreps ? out->nreps : 1) * sizeof(double));
    if (!out->rep_pos) {
        dc_free(&d);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (size_t r = 0; r < out->nreps; r++) vertex_pos(&d, out->nlattice + (int64_t)r, 0, out->rep_pos + 3 * r);
    dc_free(&d);
    return VM_OK;
}
