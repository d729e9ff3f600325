/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dc_hex_adaptive.c — adaptive hexahedra, one coarsening level per call: interior 3x3x3
 * blocks of cubes (the unit cubes, then the coarse hexes of the level before) become one hex;
 * the transition around them is made by pillowing (sheet
 * insertion, Mitchell and Tautges 1995), one shrink set per block layer and axis, so the
 * 3-refinement faces, edges and corners — concave ones included — are conforming by
 * construction (see docs/ALGORITHMS.md, "Adaptive hexahedra"). */
#include "../core/core.h"
#include "mesher_internal.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const int hex_off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
/* the six faces of a VTK hex, ordered counter-clockwise seen from outside */
static const int hex_face[6][4] = {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4},
                                   {3, 7, 6, 2}, {0, 3, 2, 1}, {4, 5, 6, 7}};
static const int hex_edge[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                    {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

enum { ROLE_NONE = 0, ROLE_COARSE = 1, ROLE_TRANS = 2, ROLE_FRAME = 3 };
/* At scale s, a cube is a hex with corners c + s*offset, c = s*i + 0.5 + org (i >= 0 integer:
 * the cube's index; org the level's block grid origin, in cells, a multiple of the level
 * before's scale); block b holds the cubes 3b .. 3b+2 per axis. At s = 1, org = 0 these are
 * the unit cubes round grid points i + 1. */

/* int64 -> int64 open-addressing map (keys >= 0). */
typedef struct imap {
    int64_t *key, *val;
    size_t cap, n;
} imap;

static size_t imap_slot(const imap *m, int64_t k) {
    uint64_t h = (uint64_t)k * 0x9E3779B97F4A7C15ull;
    size_t i = (size_t)(h >> 17) & (m->cap - 1);
    while (m->key[i] >= 0 && m->key[i] != k)
        i = (i + 1) & (m->cap - 1);
    return i;
}

static vm_status imap_init(imap *m, size_t expect, vm_error *err) {
    m->cap = 64;
    while (m->cap < 2 * expect + 16)
        m->cap *= 2;
    m->n = 0;
    m->key = malloc(m->cap * sizeof *m->key);
    m->val = malloc(m->cap * sizeof *m->val);
    if (!m->key || !m->val) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t i = 0; i < m->cap; i++)
        m->key[i] = -1;
    return VM_OK;
}

static void imap_free(imap *m) {
    free(m->key);
    free(m->val);
    memset(m, 0, sizeof *m);
}

static int64_t imap_get(const imap *m, int64_t k) {
    size_t i = imap_slot(m, k);
    return m->key[i] < 0 ? -1 : m->val[i];
}

static vm_status imap_put(imap *m, int64_t k, int64_t v, vm_error *err) {
    if (2 * (m->n + 1) > m->cap) {
        imap old = *m;
        vm_status s = imap_init(m, old.n + 1, err);
        if (s) {
            imap_free(&old);
            return s;
        }
        for (size_t i = 0; i < old.cap; i++)
            if (old.key[i] >= 0) {
                size_t j = imap_slot(m, old.key[i]);
                m->key[j] = old.key[i];
                m->val[j] = old.val[i];
                m->n++;
            }
        imap_free(&old);
    }
    size_t i = imap_slot(m, k);
    if (m->key[i] < 0) m->n++;
    m->key[i] = k;
    m->val[i] = v;
    return VM_OK;
}

/* The transition mesh under construction (index coordinates). */
typedef struct tmesh {
    int32_t *conn; /* 8 per hex */
    int32_t *blk;  /* per hex: its block (padded block index) */
    size_t nh, hcap;
    double *pos; /* 3 per node */
    size_t nn, ncap;
} tmesh;

static vm_status add_node(tmesh *t, const double p[3], vm_error *err) {
    vm_status s = vm__grow((void **)&t->pos, &t->ncap, t->nn + 1, 3 * sizeof(double), err);
    if (s) return s;
    memcpy(t->pos + 3 * t->nn++, p, 3 * sizeof(double));
    return VM_OK;
}

static vm_status add_hex(tmesh *t, const int32_t c[8], int32_t blk, vm_error *err) {
    size_t cap = t->hcap;
    vm_status s = vm__grow((void **)&t->conn, &t->hcap, t->nh + 1, 8 * sizeof(int32_t), err);
    if (s) return s;
    if (t->hcap != cap) {
        int32_t *b = realloc(t->blk, t->hcap * sizeof *b);
        if (!b) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        t->blk = b;
    }
    memcpy(t->conn + 8 * t->nh, c, 8 * sizeof(int32_t));
    t->blk[t->nh++] = blk;
    return VM_OK;
}

typedef struct face_rec {
    int32_t k[4]; /* sorted node ids */
    int64_t hf;   /* hex * 6 + face */
} face_rec;

static int face_cmp(const void *a, const void *b) {
    const face_rec *x = a, *y = b;
    for (int i = 0; i < 4; i++)
        if (x->k[i] != y->k[i]) return x->k[i] < y->k[i] ? -1 : 1;
    return 0;
}

static void sort4(int32_t k[4]) {
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && k[j - 1] > k[j]; j--) {
            int32_t t = k[j];
            k[j] = k[j - 1];
            k[j - 1] = t;
        }
}

/* nb[6*h+f]: the hex across face f of hex h, -1 on the boundary. */
static vm_status face_neighbours(const tmesh *t, int64_t **nb_out, vm_error *err) {
    size_t nf = 6 * t->nh;
    face_rec *r = malloc((nf ? nf : 1) * sizeof *r);
    int64_t *nb = malloc((nf ? nf : 1) * sizeof *nb);
    if (!r || !nb) {
        free(r);
        free(nb);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (size_t h = 0; h < t->nh; h++)
        for (int f = 0; f < 6; f++) {
            face_rec *x = r + 6 * h + f;
            for (int i = 0; i < 4; i++)
                x->k[i] = t->conn[8 * h + hex_face[f][i]];
            sort4(x->k);
            x->hf = (int64_t)(6 * h + f);
            nb[6 * h + f] = -1;
        }
    qsort(r, nf, sizeof *r, face_cmp);
    for (size_t i = 0; i + 1 < nf; i++)
        if (!face_cmp(r + i, r + i + 1)) {
            nb[r[i].hf] = r[i + 1].hf / 6;
            nb[r[i + 1].hf] = r[i].hf / 6;
            i++;
        }
    free(r);
    *nb_out = nb;
    return VM_OK;
}

typedef struct blocks {
    int64_t nb[3]; /* padded block grid (two frame blocks each side) */
    uint8_t *role;
    int64_t lay_stride[3];
} blocks;

static int64_t bidx(const blocks *B, int64_t x, int64_t y, int64_t z) {
    return x + B->nb[0] * (y + B->nb[1] * z);
}

static void bcoord(const blocks *B, int64_t b, int64_t c[3]) {
    c[0] = b % B->nb[0];
    c[1] = (b / B->nb[0]) % B->nb[1];
    c[2] = b / (B->nb[0] * B->nb[1]);
}

/* A copy node steps one cell along each axis carrying more than this share of its sheet
 * faces' summed normal (an axis-aligned face's normal has all of it, a diagonal's ~0.7). */
static const double copy_axis_share = 0.3;

/* The inward normal (into hex h) of its face f from the current positions, as the cross
 * product of the face's diagonals; returns its length. */
static double face_normal(const tmesh *t, size_t h, int f, double nrm[3]) {
    const int32_t *c = t->conn + 8 * h;
    double u[3], v[3];
    const double *p0 = t->pos + 3 * c[hex_face[f][0]], *p1 = t->pos + 3 * c[hex_face[f][1]],
                 *p2 = t->pos + 3 * c[hex_face[f][2]], *p3 = t->pos + 3 * c[hex_face[f][3]];
    for (int a = 0; a < 3; a++) {
        u[a] = p2[a] - p0[a];
        v[a] = p3[a] - p1[a];
    }
    nrm[0] = -(u[1] * v[2] - u[2] * v[1]);
    nrm[1] = -(u[2] * v[0] - u[0] * v[2]);
    nrm[2] = -(u[0] * v[1] - u[1] * v[0]);
    return sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
}

/* One pillowing round along axis d: every non-coarse hex of block layer k is in the shrink
 * set S_k; the sheet is the set's faces toward a coarse hex or another layer. */
static vm_status pillow_round(tmesh *t, const blocks *B, int d, double sc, vm_error *err) {
    int64_t *nb = NULL;
    vm_status s = face_neighbours(t, &nb, err);
    if (s) return s;
    imap copy;
    memset(&copy, 0, sizeof copy);
    int32_t *sheet = NULL; /* pairs (hex, face) */
    size_t ns = 0, scap = 0;
    double *acc = NULL;
    size_t acap = 0;
    s = imap_init(&copy, t->nn, err);
    size_t nh0 = t->nh, nn0 = t->nn;
    for (size_t h = 0; !s && h < nh0; h++) {
        if (B->role[t->blk[h]] == ROLE_COARSE) continue;
        int64_t bc[3];
        bcoord(B, t->blk[h], bc);
        for (int f = 0; !s && f < 6; f++) {
            int64_t o = nb[6 * h + f];
            if (o < 0) continue;
            int64_t oc[3];
            bcoord(B, t->blk[o], oc);
            if (B->role[t->blk[o]] != ROLE_COARSE && oc[d] == bc[d]) continue;
            s = vm__grow((void **)&sheet, &scap, ns + 1, 2 * sizeof(int32_t), err);
            if (s) break;
            sheet[2 * ns] = (int32_t)h;
            sheet[2 * ns + 1] = f;
            ns++;
            const int32_t *c = t->conn + 8 * h;
            double nrm[3], l = face_normal(t, h, f, nrm);
            for (int i = 0; !s && i < 4; i++) {
                int32_t node = c[hex_face[f][i]];
                int64_t key = (int64_t)node * B->nb[d] + bc[d];
                int64_t id = imap_get(&copy, key);
                if (id < 0) {
                    id = (int64_t)t->nn;
                    s = imap_put(&copy, key, id, err);
                    if (!s) {
                        double q[3];
                        memcpy(q, t->pos + 3 * node, sizeof q);
                        s = add_node(t, q, err);
                    }
                    if (!s) s = vm__grow((void **)&acc, &acap, t->nn, 3 * sizeof(double), err);
                    if (s) break;
                    for (int a = 0; a < 3; a++)
                        acc[3 * (id - (int64_t)nn0) + a] = 0;
                }
                if (l > 0)
                    for (int a = 0; a < 3; a++)
                        acc[3 * (id - (int64_t)nn0) + a] += nrm[a] / l;
            }
        }
    }
    /* copies step one cell into the set along each axis their sheet faces point */
    for (size_t i = nn0; !s && i < t->nn; i++) {
        const double *q = acc + 3 * (i - nn0);
        double l = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        for (int a = 0; a < 3 && l > 0; a++)
            if (fabs(q[a]) > copy_axis_share * l) t->pos[3 * i + a] += q[a] > 0 ? sc : -sc;
    }
    /* pillow hexes: the copy of each sheet face below, the face itself on top */
    for (size_t e = 0; !s && e < ns; e++) {
        size_t h = (size_t)sheet[2 * e];
        int f = sheet[2 * e + 1];
        int64_t bc[3];
        bcoord(B, t->blk[h], bc);
        int32_t c[8];
        for (int i = 0; i < 4; i++) {
            int32_t node = t->conn[8 * h + hex_face[f][i]];
            c[4 + i] = node;
            c[i] = (int32_t)imap_get(&copy, (int64_t)node * B->nb[d] + bc[d]);
        }
        s = add_hex(t, c, t->blk[h], err);
    }
    /* the set's hexes take the copies */
    for (size_t h = 0; !s && h < nh0; h++) {
        if (B->role[t->blk[h]] == ROLE_COARSE) continue;
        int64_t bc[3];
        bcoord(B, t->blk[h], bc);
        for (int q = 0; q < 8; q++) {
            int64_t id = imap_get(&copy, (int64_t)t->conn[8 * h + q] * B->nb[d] + bc[d]);
            if (id >= 0) t->conn[8 * h + q] = (int32_t)id;
        }
    }
    free(nb);
    free(sheet);
    free(acc);
    imap_free(&copy);
    return s;
}

/* The hex's scaled Jacobian, the one measure of validity (quality/: corners, centre and
 * Gauss points; 0 at a zero-length edge). The compass search below raises the corners only
 * (cheap, and what it must fix); what folds inside a transition hex is caught here. */
static double hex_min_sj(double p[8][3]) {
    return vm_hex_min_scaled_jacobian((const double(*)[3])p);
}

static void soup_pos(const vm__tet_soup *sp, const int64_t n[3], int64_t id, double out[3]) {
    if (id < sp->nlattice) {
        out[0] = (double)(id % n[0]);
        out[1] = (double)((id / n[0]) % n[1]);
        out[2] = (double)(id / (n[0] * n[1]));
    } else {
        memcpy(out, sp->rep_pos + 3 * (id - sp->nlattice), 3 * sizeof(double));
    }
}

/* Index of hex t when it is a cube at scale sc whose corners lie on the block grid with
 * origin org (1, else 0). */
static int cube_index(const vm__tet_soup *sp, const int64_t n[3], size_t t, double sc,
                      const int64_t org[3], int64_t p[3]) {
    const int64_t *c = sp->tets + 8 * t;
    double q[3], o[3];
    if (c[0] < sp->nlattice) return 0;
    soup_pos(sp, n, c[0], o);
    for (int a = 0; a < 3; a++) {
        double r = (o[a] - 0.5 - (double)org[a]) / sc;
        if (r != floor(r) || r < 0) return 0;
        p[a] = (int64_t)r;
    }
    for (int k = 1; k < 8; k++) {
        if (c[k] < sp->nlattice) return 0;
        soup_pos(sp, n, c[k], q);
        for (int a = 0; a < 3; a++)
            if (q[a] != o[a] + sc * hex_off[k][a]) return 0;
    }
    return 1;
}

/* The 3x3x3 block b of hex t when t is a unit cube (cube_index) inside the grid's whole
 * blocks (b[a] < real[a] on every axis); 0 otherwise. */
static int cube_block(const vm__tet_soup *sp, const int64_t n[3], size_t t, double sc,
                      const int64_t org[3], const int64_t real[3], int64_t b[3]) {
    int64_t p[3];
    if (!cube_index(sp, n, t, sc, org, p)) return 0;
    for (int a = 0; a < 3; a++) {
        b[a] = p[a] / 3;
        if (b[a] >= real[a]) return 0;
    }
    return 1;
}

/* Key of the cube corner at q (scale sc), -1 when q is not one. */
static int64_t corner_key(const int64_t n[3], double sc, const int64_t org[3],
                          const double q[3]) {
    int64_t c[3], m[3];
    for (int a = 0; a < 3; a++) {
        double r = (q[a] - 0.5 - (double)org[a]) / sc;
        m[a] = (int64_t)((double)n[a] / sc) + 3;
        if (r != floor(r) || r < -1 || r > (double)(m[a] - 2)) return -1;
        c[a] = (int64_t)r + 1;
    }
    return c[0] + m[0] * (c[1] + m[1] * c[2]);
}

/* The hexes round one node v while v alone moves: each hex's corners, v's slot in it, and
 * the worst of its four corners that v does not move (corner c moves with v when c is v's
 * slot or one of the slot's three neighbours). */
typedef struct star {
    double (*p)[8][3];
    int *slot;
    double *fixed;
    size_t n;
} star;

/* the three neighbours of each VTK hex corner */
static const int hex_nbr[8][3] = {{1, 3, 4}, {2, 0, 5}, {3, 1, 6}, {0, 2, 7},
                                  {7, 5, 0}, {4, 6, 1}, {5, 7, 2}, {6, 4, 3}};

static int moves_with(int slot, int c) {
    return c == slot || c == hex_nbr[slot][0] || c == hex_nbr[slot][1] || c == hex_nbr[slot][2];
}

/* Loads the star of v; returns its worst corner (the corner samples of
 * vm_hex_scaled_jacobian over its hexes). */
static double star_load(star *S, const tmesh *t, const int32_t *inc, const int32_t *start,
                        int32_t v) {
    double worst = 1.0;
    S->n = 0;
    for (int32_t i = start[v]; i < start[v + 1]; i++, S->n++) {
        const int32_t *c = t->conn + 8 * inc[i];
        double(*p)[3] = S->p[S->n];
        int slot = 0;
        for (int q = 0; q < 8; q++) {
            memcpy(p[q], t->pos + 3 * c[q], sizeof p[q]);
            if (c[q] == v) slot = q;
        }
        S->slot[S->n] = slot;
        double fixed = 1.0, moving = 1.0;
        for (int q = 0; q < 8; q++) {
            double j = vm_hex_corner_scaled_jacobian((const double(*)[3])p, q);
            if (moves_with(slot, q)) {
                if (j < moving) moving = j;
            } else if (j < fixed) {
                fixed = j;
            }
        }
        S->fixed[S->n] = fixed;
        if (fixed < worst) worst = fixed;
        if (moving < worst) worst = moving;
    }
    return worst < -1.0 ? -1.0 : worst;
}

/* The star's worst corner with v at x; stops early at a corner <= bound (a move that cannot
 * be kept) and returns that corner. */
static double star_eval(star *S, const double x[3], double bound) {
    double worst = 1.0;
    for (size_t h = 0; h < S->n; h++)
        if (S->fixed[h] <= bound) return S->fixed[h];
    for (size_t h = 0; h < S->n; h++) {
        int slot = S->slot[h];
        memcpy(S->p[h][slot], x, 3 * sizeof(double));
        const double(*p)[3] = (const double(*)[3])S->p[h];
        double j = vm_hex_corner_scaled_jacobian(p, slot);
        for (int k = 0; k < 3 && j > bound; k++) {
            double jk = vm_hex_corner_scaled_jacobian(p, hex_nbr[slot][k]);
            if (jk < j) j = jk;
        }
        if (j <= bound) return j;
        if (j < worst) worst = j;
        if (S->fixed[h] < worst) worst = S->fixed[h];
    }
    return worst < -1.0 ? -1.0 : worst;
}

/* The compass search: at most OPT_ROUNDS rounds, the first step a quarter cell shrinking by
 * 0.9 per round, halved down to a hundredth of a cell; nodes whose worst corner is already
 * above 0.3 stay; a move must gain more than round-off (1e-9). */
enum { OPT_ROUNDS = 20 };
static const double opt_first_step = 0.25, opt_step_decay = 0.9, opt_last_step = 0.01;
static const double opt_good_sj = 0.3, opt_gain = 1e-9;

/* Moves each free node (flag == 1) by compass search to raise the worst corner scaled
 * Jacobian of the hexes around it; a move is kept only if that worst corner goes up. Only
 * the four corners of each hex that move with the node are evaluated, and a trial stops at
 * its first corner not above the best so far (the same moves as evaluating every corner). */
static vm_status optimise(tmesh *t, const blocks *B, const uint8_t *flag, double sc,
                          vm_error *err) {
    int32_t *start = calloc(t->nn + 1, sizeof *start);
    if (!start) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t h = 0; h < t->nh; h++)
        if (B->role[t->blk[h]] != ROLE_FRAME)
            for (int q = 0; q < 8; q++)
                start[t->conn[8 * h + q] + 1]++;
    int32_t deg = 0;
    for (size_t i = 0; i < t->nn; i++) {
        if (start[i + 1] > deg) deg = start[i + 1];
        start[i + 1] += start[i];
    }
    int32_t *inc = malloc(((size_t)start[t->nn] + 1) * sizeof *inc);
    int32_t *fill = malloc((t->nn + 1) * sizeof *fill);
    star S;
    S.p = malloc(((size_t)deg + 1) * sizeof *S.p);
    S.slot = malloc(((size_t)deg + 1) * sizeof *S.slot);
    S.fixed = malloc(((size_t)deg + 1) * sizeof *S.fixed);
    vm_status s = VM_OK;
    if (!inc || !fill || !S.p || !S.slot || !S.fixed) {
        s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
        goto done;
    }
    memcpy(fill, start, t->nn * sizeof *fill);
    for (size_t h = 0; h < t->nh; h++)
        if (B->role[t->blk[h]] != ROLE_FRAME)
            for (int q = 0; q < 8; q++)
                inc[fill[t->conn[8 * h + q]]++] = (int32_t)h;
    static const int dir[26][3] = {
        {1, 0, 0},   {-1, 0, 0}, {0, 1, 0},   {0, -1, 0},  {0, 0, 1},   {0, 0, -1}, {1, 1, 0},
        {1, -1, 0},  {-1, 1, 0}, {-1, -1, 0}, {1, 0, 1},   {1, 0, -1},  {-1, 0, 1}, {-1, 0, -1},
        {0, 1, 1},   {0, 1, -1}, {0, -1, 1},  {0, -1, -1}, {1, 1, 1},   {1, 1, -1}, {1, -1, 1},
        {1, -1, -1}, {-1, 1, 1}, {-1, 1, -1}, {-1, -1, 1}, {-1, -1, -1}};
    for (int round = 0; round < OPT_ROUNDS; round++) {
        double stepmax = opt_first_step * sc * pow(opt_step_decay, round);
        size_t moved = 0;
        for (size_t v = 0; v < t->nn; v++) {
            if (!(flag[v] & 5) || (flag[v] & 2) || start[v] == start[v + 1]) continue;
            double best = star_load(&S, t, inc, start, (int32_t)v);
            if (best > opt_good_sj) continue;
            double *p = t->pos + 3 * v;
            for (double step = stepmax; step > opt_last_step * sc; step *= 0.5) {
                int improved = 1;
                while (improved) {
                    improved = 0;
                    for (int d = 0; d < 26; d++) {
                        double x[3];
                        memcpy(x, p, sizeof x);
                        for (int a = 0; a < 3; a++)
                            x[a] += step * dir[d][a];
                        double q = star_eval(&S, x, best + opt_gain);
                        if (q > best + opt_gain) {
                            best = q;
                            improved = 1;
                            moved++;
                            memcpy(p, x, sizeof x);
                        }
                    }
                }
            }
        }
        if (!moved) break;
    }
done:
    free(start);
    free(inc);
    free(fill);
    free(S.p);
    free(S.slot);
    free(S.fixed);
    return s;
}

/* Face-connected pieces of the corners set in m (bit c: corner (c&1, c>>1&1, c>>2) of a
 * 2x2x2 window); 0 for none. */
static int window_pieces(unsigned m) {
    unsigned seen = 0;
    int pieces = 0;
    for (int c = 0; c < 8; c++) {
        if (!(m >> c & 1) || (seen >> c & 1)) continue;
        pieces++;
        unsigned front = 1u << c;
        seen |= front;
        while (front) {
            unsigned next = 0;
            for (int a = 0; a < 8; a++)
                if (front >> a & 1)
                    for (int bit = 1; bit < 8; bit <<= 1) {
                        int b = a ^ bit;
                        if ((m >> b & 1) && !(seen >> b & 1)) next |= 1u << b;
                    }
            seen |= next;
            front = next;
        }
    }
    return pieces;
}

/* 1 when the coarse blocks m of a 2x2x2 window, or the others, are in two or more pieces. */
static int window_pinches(unsigned m) {
    return window_pieces(m) > 1 || window_pieces(~m & 0xffu) > 1;
}

/* Drops coarse blocks until no two meet only along an edge within an axis plane or only at
 * a corner (the shrink sets' boundaries must be manifold), and with group set until they
 * come in 2x2x2 groups (the conservative rule: see build_modes). cube: nblk bytes of
 * scratch. */
static void prune_coarse(const blocks *Bp, int group, uint8_t *cube, size_t *ncoarse_p) {
    blocks B = *Bp; /* the same role array */
    size_t ncoarse = *ncoarse_p;
    size_t nblk = (size_t)(B.nb[0] * B.nb[1] * B.nb[2]);
    for (int changed = 1; changed;) {
        changed = 0;
        if (group) {
            memset(cube, 0, nblk); /* 1 where some 2x2x2 group of coarse blocks covers */
            for (int64_t z = 0; z + 1 < B.nb[2]; z++)
                for (int64_t y = 0; y + 1 < B.nb[1]; y++)
                    for (int64_t x = 0; x + 1 < B.nb[0]; x++) {
                        int all = 1;
                        for (int q = 0; q < 8 && all; q++)
                            all = B.role[bidx(&B, x + hex_off[q][0], y + hex_off[q][1],
                                              z + hex_off[q][2])] == ROLE_COARSE;
                        if (all)
                            for (int q = 0; q < 8; q++)
                                cube[bidx(&B, x + hex_off[q][0], y + hex_off[q][1],
                                          z + hex_off[q][2])] = 1;
                    }
            for (size_t b = 0; b < nblk; b++)
                if (B.role[b] == ROLE_COARSE && !cube[b]) {
                    B.role[b] = ROLE_NONE;
                    ncoarse--;
                    changed = 1;
                }
        }
        for (int64_t z = 0; z + 1 < B.nb[2]; z++)
            for (int64_t y = 0; y + 1 < B.nb[1]; y++)
                for (int64_t x = 0; x + 1 < B.nb[0]; x++)
                    for (int pl = 0; pl < 3; pl++) {
                        int64_t e1[3] = {0, 0, 0}, e2[3] = {0, 0, 0};
                        e1[pl] = 1;
                        e2[(pl + 1) % 3] = 1;
                        int64_t q[4];
                        q[0] = bidx(&B, x, y, z);
                        q[1] = bidx(&B, x + e1[0], y + e1[1], z + e1[2]);
                        q[2] = bidx(&B, x + e2[0], y + e2[1], z + e2[2]);
                        q[3] =
                            bidx(&B, x + e1[0] + e2[0], y + e1[1] + e2[1], z + e1[2] + e2[2]);
                        int c0 = B.role[q[0]] == ROLE_COARSE, c1 = B.role[q[1]] == ROLE_COARSE,
                            c2 = B.role[q[2]] == ROLE_COARSE, c3 = B.role[q[3]] == ROLE_COARSE;
                        if (c0 && c3 && !c1 && !c2) {
                            B.role[q[0]] = ROLE_NONE;
                            ncoarse--;
                            changed = 1;
                        } else if (c1 && c2 && !c0 && !c3) {
                            B.role[q[1]] = ROLE_NONE;
                            ncoarse--;
                            changed = 1;
                        }
                    }
        /* and no 2x2x2 window of blocks round a block corner may split its coarse blocks or
         * the others into two face-connected pieces (two blocks meeting only at a corner,
         * or its complement: the shrink set's boundary would pinch at that vertex) */
        for (int64_t z = 0; z + 1 < B.nb[2]; z++)
            for (int64_t y = 0; y + 1 < B.nb[1]; y++)
                for (int64_t x = 0; x + 1 < B.nb[0]; x++) {
                    unsigned m = 0;
                    int64_t q[8];
                    for (int c = 0; c < 8; c++) {
                        q[c] = bidx(&B, x + (c & 1), y + (c >> 1 & 1), z + (c >> 2));
                        if (B.role[q[c]] == ROLE_COARSE) m |= 1u << c;
                    }
                    if (window_pinches(m)) {
                        for (int c = 0; c < 8; c++)
                            if (m >> c & 1) {
                                B.role[q[c]] = ROLE_NONE;
                                ncoarse--;
                                changed = 1;
                                break;
                            }
                    }
                }
    }
    *ncoarse_p = ncoarse;
}

/* A cube's index from the level's origin. */
typedef struct cube_pos {
    int64_t p[3];
} cube_pos;

/* Marks the coarse blocks (roles) with the block grid shifted by off cubes per axis: a block
 * whose 27 cubes are all there, as in its 26 neighbours, then pruned; returns their count.
 * count and cube are scratch (nblk bytes). */
static size_t classify(const blocks *B, const cube_pos *ci, size_t ncube, const int64_t off[3],
                       const int64_t real[3], int group, uint8_t *count, uint8_t *cube,
                       size_t nblk) {
    memset(count, 0, nblk);
    memset(B->role, 0, nblk);
    for (size_t i = 0; i < ncube; i++) {
        int64_t b[3];
        int in = 1;
        for (int a = 0; a < 3 && in; a++) {
            int64_t q = ci[i].p[a] - off[a];
            b[a] = q >= 0 ? q / 3 : -1;
            in = b[a] >= 0 && b[a] < real[a];
        }
        if (in) count[bidx(B, b[0] + 2, b[1] + 2, b[2] + 2)]++;
    }
    for (size_t b = 0; b < nblk; b++)
        cube[b] = count[b] == 27;
    size_t ncoarse = 0;
    for (int64_t z = 1; z + 1 < B->nb[2]; z++)
        for (int64_t y = 1; y + 1 < B->nb[1]; y++)
            for (int64_t x = 1; x + 1 < B->nb[0]; x++) {
                int ok = 1;
                for (int dz = -1; dz <= 1 && ok; dz++)
                    for (int dy = -1; dy <= 1 && ok; dy++)
                        for (int dx = -1; dx <= 1 && ok; dx++)
                            ok = cube[bidx(B, x + dx, y + dy, z + dz)];
                if (ok) {
                    B->role[bidx(B, x, y, z)] = ROLE_COARSE;
                    ncoarse++;
                }
            }
    prune_coarse(B, group, cube, &ncoarse);
    return ncoarse;
}

/* Laplacian sweeps at most per smoothing; it converges well before (about 8x per 25 sweeps). */
enum { SMOOTH_SWEEPS = 400 };
/* Smoothing stops when no node moved more than this many cells: far below the compass
 * search's smallest step. */
static const double smooth_tol = 1e-7;
/* Rebuilds after dropping the coarse blocks round an inverted transition hex, at most. */
enum { MAX_REBUILDS = 3 };
/* Relative tolerance of the check that the hexes fill their blocks' volume (round-off of the
 * trilinear volumes, far below a wrong fill's error). */
static const double fill_rel_tol = 1e-6;
/* Initial capacity of the cell -> fine vertex map (it grows). */
enum { CELLS_EXPECT = 1024 };

/* One level's adaptation: the block grid with its scratch, and the coarse mesh being built. */
typedef struct adapt {
    const int64_t *n; /* the lattice's grid size */
    int64_t scale;    /* this level's cube size, in cells */
    double sc;        /* scale, as a double */
    int64_t *org;     /* [in,out] the block grid's origin; moved by the chosen offset */
    int64_t real[3];  /* whole blocks of cubes per axis */
    blocks B;         /* the block grid, two frame blocks each side */
    size_t nblk;
    uint8_t *count, *cube; /* nblk bytes of scratch each */
    size_t ncoarse;        /* coarse blocks marked in B */
    tmesh t;               /* the coarse, transition and frame hexes */
    int32_t *corner;       /* block grid corner -> node of t */
    uint8_t *flag;         /* per node of t: 1 kept, 2 frame, 4 coarse */
} adapt;

/* Sets up the block grid of the cubes of this scale from org and its scratch. */
static vm_status adapt_init(adapt *A, const int64_t n[3], int64_t scale, int64_t org[3],
                            vm_error *err) {
    memset(A, 0, sizeof *A);
    A->n = n;
    A->scale = scale;
    A->sc = (double)scale;
    A->org = org;
    for (int a = 0; a < 3; a++) {
        A->real[a] = n[a] - 1 > org[a] ? (n[a] - 1 - org[a]) / scale / 3 : 0;
        A->B.nb[a] = A->real[a] + 4;
    }
    A->nblk = (size_t)(A->B.nb[0] * A->B.nb[1] * A->B.nb[2]);
    A->count = calloc(A->nblk, 1);
    A->B.role = calloc(A->nblk, 1);
    A->cube = calloc(A->nblk, 1);
    if (!A->count || !A->B.role || !A->cube)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    return VM_OK;
}

/* Frees what adapt_init and the builds allocated. */
static void adapt_free(adapt *A) {
    free(A->flag);
    free(A->count);
    free(A->cube);
    free(A->B.role);
    free(A->corner);
    free(A->t.conn);
    free(A->t.blk);
    free(A->t.pos);
}

/* The cubes of this scale in the soup, as indices from org (*out, *ncube of them). */
static vm_status list_cubes(const vm__tet_soup *sp, const adapt *A, cube_pos **out,
                            size_t *ncube, vm_error *err) {
    cube_pos *cidx = malloc((sp->ntets ? sp->ntets : 1) * sizeof *cidx);
    *out = cidx;
    *ncube = 0;
    if (!cidx) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t h = 0; h < sp->ntets; h++)
        if (cube_index(sp, A->n, h, A->sc, A->org, cidx[*ncube].p)) (*ncube)++;
    return VM_OK;
}

/* Marks the coarse blocks with the block grid's offset (0..2 cubes per axis; only 0 with
 * group) that makes the most of them, and moves org (from org0) by that offset. */
static void choose_offset(adapt *A, const cube_pos *cidx, size_t ncube, const int64_t org0[3],
                          int group) {
    int best_k = -1;
    A->ncoarse = 0;
    for (int pass = 0; pass < 2; pass++)
        for (int k = 0; k < 27; k++) {
            if ((pass && k != best_k) || (group && k)) continue;
            int64_t off[3] = {k % 3, (k / 3) % 3, k / 9};
            size_t nc =
                classify(&A->B, cidx, ncube, off, A->real, group, A->count, A->cube, A->nblk);
            if (!pass && (best_k < 0 || nc > A->ncoarse)) {
                best_k = k;
                A->ncoarse = nc;
            }
        }
    for (int a = 0; a < 3; a++)
        A->org[a] = org0[a] + A->scale * (best_k / (a == 0 ? 1 : a == 1 ? 3 : 9) % 3);
}

/* Marks the transition blocks round the coarse ones, then a frame of virtual blocks round
 * those. */
static void mark_transition(blocks *B) {
    for (int pass = 0; pass < 2; pass++) {
        uint8_t from = pass ? ROLE_TRANS : ROLE_COARSE, to = pass ? ROLE_FRAME : ROLE_TRANS;
        for (int64_t z = 1; z + 1 < B->nb[2]; z++)
            for (int64_t y = 1; y + 1 < B->nb[1]; y++)
                for (int64_t x = 1; x + 1 < B->nb[0]; x++) {
                    if (B->role[bidx(B, x, y, z)] != from) continue;
                    for (int dz = -1; dz <= 1; dz++)
                        for (int dy = -1; dy <= 1; dy++)
                            for (int dx = -1; dx <= 1; dx++) {
                                int64_t o = bidx(B, x + dx, y + dy, z + dz);
                                if (B->role[o] == ROLE_NONE) B->role[o] = to;
                            }
                }
    }
}

/* Builds the coarse mesh, one hex per coarse, transition and frame block, and pillows it. */
static vm_status build_coarse_mesh(adapt *A, vm_error *err) {
    blocks *B = &A->B;
    size_t ncorner = (size_t)((B->nb[0] + 1) * (B->nb[1] + 1) * (B->nb[2] + 1));
    A->corner = malloc(ncorner * sizeof *A->corner);
    if (!A->corner) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t i = 0; i < ncorner; i++)
        A->corner[i] = -1;
    vm_status s = VM_OK;
    for (int64_t b = 0; !s && b < (int64_t)A->nblk; b++) {
        if (B->role[b] == ROLE_NONE) continue;
        int64_t bc[3];
        bcoord(B, b, bc);
        int32_t c[8];
        for (int q = 0; !s && q < 8; q++) {
            int64_t k[3];
            for (int a = 0; a < 3; a++)
                k[a] = bc[a] + hex_off[q][a];
            size_t ci = (size_t)(k[0] + (B->nb[0] + 1) * (k[1] + (B->nb[1] + 1) * k[2]));
            if (A->corner[ci] < 0) {
                double p[3];
                for (int a = 0; a < 3; a++)
                    p[a] = A->sc * (double)(3 * (k[a] - 2)) + 0.5 + (double)A->org[a];
                A->corner[ci] = (int32_t)A->t.nn;
                s = add_node(&A->t, p, err);
            }
            c[q] = A->corner[ci];
        }
        if (!s) s = add_hex(&A->t, c, (int32_t)b, err);
    }
    for (int d = 0; !s && d < 3; d++)
        s = pillow_round(&A->t, B, d, A->sc, err);
    return s;
}

/* Flags the nodes kept: fixed where coarse or shared with the frame (they are fine cube
 * corners). */
static vm_status flag_nodes(adapt *A, vm_error *err) {
    const tmesh *t = &A->t;
    A->flag = calloc(t->nn ? t->nn : 1, 1);
    if (!A->flag) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t h = 0; h < t->nh; h++) {
        uint8_t r = A->B.role[t->blk[h]];
        uint8_t f = r == ROLE_FRAME ? 2 : r == ROLE_COARSE ? 4 : 1;
        for (int q = 0; q < 8; q++)
            A->flag[t->conn[8 * h + q]] |= f;
    }
    return VM_OK;
}

/* Laplacian smoothing of the free transition nodes (a fixed-boundary linear system, so the
 * initial copy positions only speed it up). */
static vm_status smooth_transition(adapt *A, vm_error *err) {
    tmesh *t = &A->t;
    const uint8_t *flag = A->flag;
    size_t ne = 0;
    int32_t *ed = malloc((12 * t->nh + 1) * 2 * sizeof *ed);
    double *sum = malloc(4 * (t->nn ? t->nn : 1) * sizeof *sum);
    if (!ed || !sum) {
        free(ed);
        free(sum);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (size_t h = 0; h < t->nh; h++) {
        if (A->B.role[t->blk[h]] == ROLE_FRAME) continue;
        for (int e = 0; e < 12; e++) {
            /* an edge between two fixed nodes moves nothing */
            if (flag[t->conn[8 * h + hex_edge[e][0]]] != 1 &&
                flag[t->conn[8 * h + hex_edge[e][1]]] != 1)
                continue;
            ed[2 * ne] = t->conn[8 * h + hex_edge[e][0]];
            ed[2 * ne + 1] = t->conn[8 * h + hex_edge[e][1]];
            ne++;
        }
    }
    for (int it = 0; it < SMOOTH_SWEEPS; it++) {
        memset(sum, 0, 4 * t->nn * sizeof *sum);
        for (size_t e = 0; e < ne; e++)
            for (int side = 0; side < 2; side++) {
                int32_t a = ed[2 * e + side], b = ed[2 * e + 1 - side];
                for (int x = 0; x < 3; x++)
                    sum[4 * a + x] += t->pos[3 * b + x];
                sum[4 * a + 3] += 1;
            }
        double moved = 0;
        for (size_t i = 0; i < t->nn; i++)
            if (flag[i] == 1 && sum[4 * i + 3] > 0)
                for (int x = 0; x < 3; x++) {
                    double nv = sum[4 * i + x] / sum[4 * i + 3];
                    if (fabs(nv - t->pos[3 * i + x]) > moved)
                        moved = fabs(nv - t->pos[3 * i + x]);
                    t->pos[3 * i + x] = nv;
                }
        if (moved < smooth_tol * A->sc) break;
    }
    free(ed);
    free(sum);
    return VM_OK;
}

/* Drops the coarse blocks round every inverted transition hex; returns how many there are. */
static size_t drop_inverted(adapt *A) {
    const tmesh *t = &A->t;
    blocks *B = &A->B;
    size_t inverted = 0;
    for (size_t h = 0; h < t->nh; h++) {
        if (B->role[t->blk[h]] == ROLE_FRAME) continue;
        double p[8][3];
        for (int q = 0; q < 8; q++)
            memcpy(p[q], t->pos + 3 * t->conn[8 * h + q], sizeof p[q]);
        if (hex_min_sj(p) > 0) continue;
        inverted++;
        int64_t bc[3];
        bcoord(B, t->blk[h], bc);
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int64_t o = bidx(B, bc[0] + dx, bc[1] + dy, bc[2] + dz);
                    if (B->role[o] == ROLE_COARSE) {
                        B->role[o] = ROLE_NONE;
                        A->ncoarse--;
                    }
                }
    }
    return inverted;
}

/* Builds, smooths and optimises the level's hexes; where a transition hex stays inverted,
 * drops the coarse blocks round it and builds again (at most MAX_REBUILDS times).
 * *inverted: the last build's inverted hexes; *none set when no coarse block is left. */
static vm_status build_level(adapt *A, int group, size_t *inverted, int *none, vm_error *err) {
    for (int attempt = 0;; attempt++) {
        for (size_t b = 0; b < A->nblk; b++)
            if (A->B.role[b] != ROLE_COARSE) A->B.role[b] = ROLE_NONE;
        free(A->corner);
        A->corner = NULL;
        free(A->flag);
        A->flag = NULL;
        A->t.nh = A->t.nn = 0;
        if (!A->ncoarse) {
            *none = 1;
            return VM_OK;
        }
        mark_transition(&A->B);
        vm_status s = build_coarse_mesh(A, err);
        if (!s) s = flag_nodes(A, err);
        if (!s) s = smooth_transition(A, err);
        if (!s) s = optimise(&A->t, &A->B, A->flag, A->sc, err);
        if (s) return s;
        *inverted = drop_inverted(A);
        if (!*inverted || attempt == MAX_REBUILDS) break;
        prune_coarse(&A->B, group, A->cube, &A->ncoarse);
    }
    return VM_OK;
}

/* 1 when the coarse and transition hexes fill their blocks exactly (trilinear volumes of
 * hexes sharing faces add up to the region's). */
static int fills_blocks(const adapt *A) {
    const tmesh *t = &A->t;
    double vol = 0, blocks_vol = 0, side = 3 * A->sc;
    for (size_t h = 0; h < t->nh; h++) {
        if (A->B.role[t->blk[h]] == ROLE_FRAME) continue;
        double p[8][3];
        for (int q = 0; q < 8; q++)
            memcpy(p[q], t->pos + 3 * t->conn[8 * h + q], sizeof p[q]);
        vol += vm_hex_volume((const double(*)[3])p);
    }
    for (size_t b = 0; b < A->nblk; b++)
        if (A->B.role[b] == ROLE_COARSE || A->B.role[b] == ROLE_TRANS)
            blocks_vol += side * side * side;
    return fabs(vol - blocks_vol) <= fill_rel_tol * blocks_vol;
}

/* Two modes: first the permissive one (lone coarse blocks allowed, the best of the 27
 * offsets); when its transition keeps an inverted hex or does not fill its blocks' volume
 * exactly (thin coarse configurations can pillow badly), the conservative one of the first
 * version (coarse blocks only in 2x2x2 groups, offset 0) instead. *none: no coarse block. */
static vm_status build_modes(adapt *A, const cube_pos *cidx, size_t ncube, int *none,
                             vm_error *err) {
    const int64_t org0[3] = {A->org[0], A->org[1], A->org[2]};
    for (int mode = 0; mode < 2; mode++) {
        int group = mode == 1;
        choose_offset(A, cidx, ncube, org0, group);
        size_t inverted = 0;
        vm_status s = build_level(A, group, &inverted, none, err);
        if (s || *none) return s;
        if (inverted || !fills_blocks(A)) continue;
        break;
    }
    return VM_OK;
}

/* Marks (drop) the fine hexes inside the coarse and transition blocks, *dropped of them, and
 * maps their corners by cell (cells), to share the frame-side nodes. */
static vm_status drop_fine(const adapt *A, const vm__tet_soup *sp, imap *cells, uint8_t *drop,
                           size_t *dropped, vm_error *err) {
    vm_status s = VM_OK;
    for (size_t h = 0; !s && h < sp->ntets; h++) {
        int64_t b[3];
        if (!cube_block(sp, A->n, h, A->sc, A->org, A->real, b)) continue;
        uint8_t r = A->B.role[bidx(&A->B, b[0] + 2, b[1] + 2, b[2] + 2)];
        if (r != ROLE_COARSE && r != ROLE_TRANS) continue;
        drop[h] = 1;
        (*dropped)++;
        for (int q = 0; !s && q < 8; q++) {
            double qp[3];
            soup_pos(sp, A->n, sp->tets[8 * h + q], qp);
            s = imap_put(cells, corner_key(A->n, A->sc, A->org, qp), sp->tets[8 * h + q], err);
        }
    }
    return s;
}

/* Numbers the kept nodes (id, per node of t): frame-side ones are existing fine vertices
 * (from cells), the *nnew others new vertices from first on. */
static vm_status number_nodes(const adapt *A, const imap *cells, int64_t first, int64_t *id,
                              size_t *nnew, vm_error *err) {
    size_t missing = 0;
    for (size_t i = 0; i < A->t.nn; i++) {
        id[i] = -1;
        if (!(A->flag[i] & 5)) continue;
        if (A->flag[i] & 2) {
            int64_t k = corner_key(A->n, A->sc, A->org, A->t.pos + 3 * i);
            id[i] = k < 0 ? -1 : imap_get(cells, k);
            if (id[i] < 0) missing++;
        } else {
            id[i] = first + (int64_t)(*nnew)++;
        }
    }
    if (missing)
        return vm_error_set(err, VM_ERR_INTERNAL,
                            "mesh: adaptive hexes: %zu transition nodes match no fine vertex",
                            missing);
    return VM_OK;
}

/* Replaces the dropped fine hexes in the soup by the coarse and transition ones (ids from
 * number_nodes, new vertices from first on) — unless the level saves nothing (a few coarse
 * blocks whose transitions cost more). */
static vm_status replace_hexes(const adapt *A, vm__tet_soup *sp, const uint8_t *drop,
                               size_t dropped, const int64_t *id, int64_t first, size_t nnew,
                               vm_mesh_stats *st, vm_error *err) {
    const tmesh *t = &A->t;
    size_t nkept = 0;
    for (size_t h = 0; h < t->nh; h++)
        if (A->B.role[t->blk[h]] != ROLE_FRAME) nkept++;
    if (!(sp->ntets - dropped + nkept < sp->ntets)) return VM_OK;
    size_t nt = sp->ntets - dropped + nkept, w = 0;
    int64_t *cells_out = malloc(8 * nt * sizeof *cells_out);
    double *rp = realloc(sp->rep_pos, 3 * (sp->nreps + nnew + 1) * sizeof *rp);
    if (rp) sp->rep_pos = rp;
    if (!cells_out || !rp) {
        free(cells_out);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    }
    for (size_t h = 0; h < sp->ntets; h++)
        if (!drop[h]) memcpy(cells_out + 8 * w++, sp->tets + 8 * h, 8 * sizeof(int64_t));
    size_t bad = 0;
    for (size_t h = 0; h < t->nh; h++) {
        if (A->B.role[t->blk[h]] == ROLE_FRAME) continue;
        double p[8][3];
        for (int q = 0; q < 8; q++) {
            int32_t v = t->conn[8 * h + q];
            cells_out[8 * w + q] = id[v];
            memcpy(p[q], t->pos + 3 * v, sizeof p[q]);
        }
        if (hex_min_sj(p) <= 0) bad++;
        w++;
    }
    for (size_t i = 0; i < t->nn; i++)
        if (id[i] >= first)
            memcpy(sp->rep_pos + 3 * (sp->nreps + (size_t)(id[i] - first)), t->pos + 3 * i,
                   3 * sizeof(double));
    sp->nreps += nnew;
    free(sp->tets);
    sp->tets = cells_out;
    sp->ntets = w;
    if (st) st->inverted_cells += bad;
    return VM_OK;
}

/* Rebuilds the soup with the level's hexes: drops the fine hexes they cover, numbers their
 * nodes, and replaces. */
static vm_status rebuild_soup(const adapt *A, vm__tet_soup *sp, vm_mesh_stats *st,
                              vm_error *err) {
    imap cells;
    memset(&cells, 0, sizeof cells);
    vm_status s = imap_init(&cells, CELLS_EXPECT, err);
    uint8_t *drop = calloc(sp->ntets ? sp->ntets : 1, 1);
    if (!s && !drop) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    size_t dropped = 0, nnew = 0;
    if (!s) s = drop_fine(A, sp, &cells, drop, &dropped, err);
    int64_t *id = malloc((A->t.nn ? A->t.nn : 1) * sizeof *id);
    if (!s && !id) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    int64_t first = sp->nlattice + (int64_t)sp->nreps;
    if (!s) s = number_nodes(A, &cells, first, id, &nnew, err);
    if (!s) s = replace_hexes(A, sp, drop, dropped, id, first, nnew, st, err);
    free(id);
    free(drop);
    imap_free(&cells);
    return s;
}

/* One coarsening level of the soup's hexes at this scale (see mesher_internal.h). */
vm_status vm__hex_adapt(vm__tet_soup *sp, const int64_t n[3], int64_t scale, int64_t org[3],
                        vm_mesh_stats *st, vm_error *err) {
    adapt A;
    cube_pos *cidx = NULL;
    size_t ncube = 0;
    int none = 0;
    vm_status s = adapt_init(&A, n, scale, org, err);
    if (!s) s = list_cubes(sp, &A, &cidx, &ncube, err);
    if (!s) s = build_modes(&A, cidx, ncube, &none, err);
    if (!s && !none) s = rebuild_soup(&A, sp, st, err);
    free(cidx);
    adapt_free(&A);
    return s;
}
