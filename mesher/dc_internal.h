/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/dc_internal.h — state shared by the dual-contouring stages (private): grid
 * classification, boundary cells with their patches and vertices, the interior octree. */
#ifndef VM_DC_INTERNAL_H
#define VM_DC_INTERNAL_H

#include "mesher_internal.h"
#include <stddef.h>
#include <stdint.h>

/* Cube corners c = x + 2y + 4z. Edge e = 4*a + u + 2*v runs along axis a from corner
 * vm__dc_edge_c0[e]; u, v are its offsets along axes (a+1)%3 and (a+2)%3. Face f = 2*a + s
 * holds the corners with bit a == s, in cyclic order. Filled by vm__dc_init_tables. */
extern int vm__dc_edge_c0[12], vm__dc_edge_c1[12], vm__dc_edge_of[8][8];
extern int vm__dc_face_corner[6][4];
void vm__dc_init_tables(void);

#define NONE 0xff /* no patch */

/* What the signs of its corners make of a boundary cell: the same for every cell with one
 * mask of inside corners, so kept once per mask (vm__dc_kinds, filled by
 * vm__dc_init_tables) rather than per cell. */
typedef struct vm__dc_kind {
    uint8_t npatch, special; /* surface patches; special: an extra vertex at the centre */
    uint8_t edge_patch[12];  /* patch of each crossing edge, NONE otherwise */
    uint8_t corner_patch[8]; /* patch of each inside corner's component, NONE outside */
} vm__dc_kind;
extern vm__dc_kind vm__dc_kinds[256];

typedef struct bcell {
    int64_t cell; /* padded cell index */
    int32_t base; /* first representative vertex */
    uint8_t mask; /* inside corners (bit c): the cell's kind is vm__dc_kinds[mask] */
} bcell;

static inline const vm__dc_kind *vm__dc_kind_of(const bcell *b) {
    return &vm__dc_kinds[b->mask];
}

typedef struct dc {
    const vm__grid *g;
    /* real points, padded points, padded cells per axis: the cells are indexed with the
     * points' strides (C == P; a cell's index is that of its lowest corner, the last plane
     * along each axis holds no cell) */
    int64_t n[3], P[3], C[3];
    int64_t off[3];           /* g->off: grid index i is i + off in the whole grid */
    /* Per padded point and cell, one bit each (read through the accessors below): */
    uint64_t *in;       /* per padded point: inside the material */
    uint64_t *bnd;      /* per padded cell: a boundary cell (corners mixed); a cell that
                           is not has every corner as its lowest one, in or out */
    uint32_t *bnd_rank; /* per word of bnd: boundary cells before it (their bcell index) */
    bcell *bc;          /* boundary cells in increasing cell order */
    size_t nbc, bc_cap;
    size_t nreps;
    int64_t *amb; /* keys (3*lower cell + axis) of ambiguous faces, sorted */
    size_t namb, amb_cap;
    size_t amb_base;              /* representative index of the first face vertex */
    double *qpos, *mpos; /* per rep: minimiser, mass point */
    /* Per rep: blend factors toward the mass point (lambda), then toward the centre of
     * vm__dc_rep_centre (mu). Floats hold them exactly: from 1 (or k/8) relaxation only
     * multiplies them by 3/4, 1/2 or 1/4 and sets them to 0 below 1/64. */
    float *lambda, *mu;
    uint8_t *rep_planes; /* per rep: box planes it lies on (bit 2a+side) */
    double *centre;      /* positions of polygon centres (ids after the reps) */
    size_t ncentre, centre_cap;
    vm__octree oct; /* interior leaves (adaptive mode only) */
    int adaptive;
    /* Coarse boundary leaves (adaptive mode): aligned 2x2x2 blocks of cells with one surface
     * patch, one representative each (index coarse_base + leaf). */
    int64_t *coarse_org; /* 3 per leaf: lowest cell */
    size_t ncoarse, coarse_cap, coarse_base;
    uint64_t *coarse;    /* per padded cell, one bit: in a coarse leaf (NULL: none) */
    int64_t *coarse_key; /* per leaf: padded index of its lowest cell, increasing */
    double error;       /* merge tolerance, voxels */
    /* The tet list, 4 global ids per tet: uint32_t while every id is below id_limit, then
     * int64_t (wide != 0; dc_tets.c widens it when an id needs it). */
    void *tets;
    int wide;
    int64_t id_limit;
    size_t ntets, tet_cap;
    void *src;    /* per tet: the element that made it (see dc_tets.c), for re-emission */
    int src_wide; /* src: int64_t, else uint32_t */
    size_t src_cap;
    int64_t cur_src; /* element being emitted */
} dc;

enum { CELL_OUT = -1, CELL_IN = -2 };

/* VM_ERR_CANCELLED (err filled) when the run's progress callback asked to stop (polled). */
vm_status vm__dc_check(const dc *d, vm_error *err);

static inline int64_t vm__dc_pidx(const dc *d, int64_t i, int64_t j, int64_t k) {
    return (i + 1) + d->P[0] * ((j + 1) + d->P[1] * (k + 1));
}
static inline int64_t vm__dc_cidx(const dc *d, int64_t i, int64_t j, int64_t k) {
    return (i + 1) + d->C[0] * ((j + 1) + d->C[1] * (k + 1));
}
static inline void vm__dc_cell_coords(const dc *d, int64_t c, int64_t out[3]) {
    out[0] = c % d->C[0] - 1;
    out[1] = (c / d->C[0]) % d->C[1] - 1;
    out[2] = c / (d->C[0] * d->C[1]) - 1;
}
static inline float vm__dc_fval(const dc *d, int64_t i, int64_t j, int64_t k) {
    return d->g->f[i + d->n[0] * (j + d->n[1] * k)];
}
/* Index coordinate of grid index i along axis a, in the whole grid's frame (so a cropped
 * grid computes the same doubles as the whole one). */
static inline double vm__dc_coord(const dc *d, int64_t i, int a) {
    return (double)(i + d->off[a]);
}
/* i + j + k of grid point p in the whole grid (the parity of the tet splits). */
static inline int64_t vm__dc_gsum(const dc *d, const int64_t p[3]) {
    return p[0] + p[1] + p[2] + d->off[0] + d->off[1] + d->off[2];
}
static inline int vm__dc_real_point(const dc *d, const int64_t p[3]) {
    for (int a = 0; a < 3; a++)
        if (p[a] < 0 || p[a] >= d->n[a]) return 0;
    return 1;
}

static inline int vm__dc_bit(const uint64_t *w, int64_t i) {
    return (int)((w[i >> 6] >> (i & 63)) & 1);
}
static inline void vm__dc_set_bit(uint64_t *w, int64_t i) {
    w[i >> 6] |= (uint64_t)1 << (i & 63);
}
/* 1 when padded grid point p (vm__dc_pidx) is in the material. */
static inline int vm__dc_in(const dc *d, int64_t p) {
    return vm__dc_bit(d->in, p);
}
/* Per padded cell (vm__dc_cidx): its bcell index, CELL_OUT or CELL_IN (the rank of its bit
 * among the boundary cells: the bcells are in cell order). */
static inline int32_t vm__dc_code(const dc *d, int64_t ci) {
    uint64_t w = d->bnd[ci >> 6], bit = (uint64_t)1 << (ci & 63);
    if (w & bit) return (int32_t)(d->bnd_rank[ci >> 6] + (uint32_t)__builtin_popcountll(w & (bit - 1)));
    return vm__dc_in(d, ci) ? CELL_IN : CELL_OUT; /* ci is its lowest corner's index */
}
/* The coarse boundary leaf holding padded cell ci, or -1. */
int32_t vm__dc_coarse_find(const dc *d, int64_t ci);
static inline int32_t vm__dc_coarse(const dc *d, int64_t ci) {
    return d->coarse && vm__dc_bit(d->coarse, ci) ? vm__dc_coarse_find(d, ci) : -1;
}

static inline int64_t vm__dc_npoints_real(const dc *d) {
    return d->n[0] * d->n[1] * d->n[2];
}

static inline int64_t vm__dc_lattice_id(const dc *d, const int64_t p[3]) {
    return p[0] + d->n[0] * (p[1] + d->n[1] * p[2]);
}

/* The 4 vertex ids of tet t of the list (either width). */
static inline void vm__dc_tet_get(const dc *d, size_t t, int64_t v[4]) {
    if (d->wide) {
        const int64_t *p = (const int64_t *)d->tets + 4 * t;
        for (int k = 0; k < 4; k++)
            v[k] = p[k];
    } else {
        const uint32_t *p = (const uint32_t *)d->tets + 4 * t;
        for (int k = 0; k < 4; k++)
            v[k] = (int64_t)p[k];
    }
}

/* Classifies the grid, finds and analyses the boundary cells, builds the interior octree
 * when g->max_level > 0, and places every patch vertex. [out] d (free with vm__dc_free). */
vm_status vm__dc_setup(dc *d, const vm__grid *g, vm_mesh_stats *st, vm_error *err);
void vm__dc_free(dc *d);

/* Quality by construction (dc_lift.c): moves the inner grid points at the corners of tets
 * below the quality targets within their stars, measuring in the world frame M (index to
 * world, linear part, row-major). [out] the moved points' ids (increasing) and index
 * positions (whole-grid frame, as the representatives'); *n 0 and NULL arrays when none. */
vm_status vm__dc_lift(const dc *d, const double M[9], size_t *n, int64_t **ids, double **pos,
                      vm_error *err);

/* Hexahedra need every cell's inside components to meet one patch each and no face to join
 * two cells twice: flips outside grid points inside until that holds. [out] *flipped. */
vm_status vm__dc_repair_for_hexes(dc *d, vm_mesh_stats *st, size_t *flipped, vm_error *err);

/* Vertex ids: grid points 0..N-1 (N = vm__dc_npoints_real), then N + representative index
 * (patch vertices, cell centres of special cells, ambiguous-face vertices), then polygon
 * centres made while emitting. reference != 0 gives the mass-point position. */
void vm__dc_vertex_pos(const dc *d, int64_t id, int reference, double out[3]);
/* The centre representative r is pulled toward once at its mass point: its cell's centre
 * (on the border plane along padded axes) for the vertex of a one-patch cell, the block's
 * centre for a coarse leaf. Returns 0 when it has none (c, which may be NULL, untouched). */
int vm__dc_rep_centre(const dc *d, size_t r, double c[3]);
/* Box planes (bit 2a + side) the vertex lies on. */
uint8_t vm__dc_vertex_planes(const dc *d, int64_t id);
/* Vertex of boundary cell b for its local edge e. */
int64_t vm__dc_rep_for_edge(const dc *d, const bcell *b, int e);
/* Vertex of the ambiguous face (lower cell lower_cm, normal axis a) on the segment cutting
 * off inside corner v, or -1 when the face has none. */
int64_t vm__dc_face_vertex(const dc *d, const int64_t lower_cm[3], int a, const int64_t v[3]);

#endif
