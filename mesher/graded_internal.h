/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_internal.h — the graded octree mesher's stages (private): the field, the
 * octree sized in world units, the body-centred lattice over its leaves, and the stuffing. */
#ifndef VM_GRADED_INTERNAL_H
#define VM_GRADED_INTERNAL_H

#include "volmesh/mesher.h"
#include <stddef.h>
#include <stdint.h>

/* The material as a signed field phi (>= 0 inside) over the volume's scaled index frame:
 * u = ijk * spacing (world lengths, before the direction and the origin apply). Outside the
 * box [0, (n-1) spacing] phi is `out` (negative), so material touching the border is closed
 * on the border plane. */
typedef struct gr_field {
    const vm_volume *v;
    int64_t n[3];
    double sp[3];
    double lo, hi;
    int has_lo, has_hi;
    double out;
    /* Min and max of the values per block of GR_BLOCK^3 voxels (nb blocks per axis). */
    int64_t nb[3];
    float *bmin, *bmax;
    /* The size field's least value per block (NULL: no size field), times size_scale. */
    float *bsize;
    double size_scale;
} gr_field;

enum { GR_BLOCK = 4 };

/* The voxels of block (bx, by, bz): lo..hi per axis, inclusive (a block shares its last plane
 * with the next, so that every trilinear cell lies in one block). */
static inline void vm__gr_block_range(const gr_field *f, int64_t bx, int64_t by, int64_t bz,
                                      int64_t lo[3], int64_t hi[3]) {
    int64_t b[3] = {bx, by, bz};
    for (int d = 0; d < 3; d++) {
        lo[d] = b[d] * GR_BLOCK;
        hi[d] = lo[d] + GR_BLOCK;
        if (hi[d] > f->n[d] - 1) hi[d] = f->n[d] - 1;
    }
}

/* Union-find root of x in parent (halving the path), for the small local sets of the
 * configuration table and the stuffing's link and fan tests. */
static inline int vm__gr_root(int *parent, int x) {
    while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
    return x;
}

/* phi of a sample value. */
static inline double vm__gr_phi_value(const gr_field *f, double x) {
    if (f->has_lo && f->has_hi) {
        double a = x - f->lo, b = f->hi - x;
        return a < b ? a : b;
    }
    return f->has_lo ? x - f->lo : f->hi - x;
}
/* phi at a voxel point (in range). */
static inline double vm__gr_phi_point(const gr_field *f, int64_t i, int64_t j, int64_t k) {
    return vm__gr_phi_value(f, f->v->data[i + f->n[0] * (j + f->n[1] * k)]);
}
/* phi at u (scaled index frame): trilinear inside the box, `out` outside. */
double vm__gr_phi(const gr_field *f, const double u[3]);

/* The least size-field value over the blocks that meet the box [lo, hi] (scaled index
 * frame); INFINITY without a size field. */
double vm__gr_size_min(const gr_field *f, const double lo[3], const double hi[3]);

/* Joins the local thickness over `layers` to the per-block sizes (bsize, made when there is
 * no size field): mesher/graded_thickness.c. Balls of radius over cap (world) are not
 * painted. VM_ERR_NOMEM. */
vm_status vm__gr_thickness_blocks(gr_field *f, int layers, double cap, vm_error *err);

vm_status vm__gr_field_init(gr_field *f, const vm_volume *v, const vm_mesh_options *o,
                            vm_error *err);
void vm__gr_field_free(gr_field *f);

/* Octree nodes: a cell of level l has edge 2^l base cells, i.e. 2^(l+1) lattice units (a
 * lattice unit is half the base edge h0 along each axis, so every cell centre is a lattice
 * point). Anchor: its lowest corner in lattice units, >= 0; lattice point x sits at u = u0 + x
 * * h0 / 2 (per axis). Base cells are voxels, or near-cubic parts or multiples of voxels
 * (docs/SIZING.md). */
typedef struct gr_node {
    int32_t child; /* first of 8 children (x fastest), or -1 for a leaf */
    int32_t a[3];
    int32_t level;
    int32_t exact; /* a base cell where the distance was missed (2 until measured again): warps
                    * keep their cuts there */
} gr_node;

typedef struct gr_tree {
    gr_node *node;
    size_t n, cap;
    int root_level;
    double h0[3];    /* base cell edges (world) */
    double u0[3];    /* position of lattice point 0 in the scaled index frame */
    int max_level;   /* leaves are at most this level (the --max-edge bound) */
    double distance; /* the distance bound (world) */
    int layers;      /* cells of one size at least this deep before the next (--grading) */
    size_t leaves;
} gr_tree;

/* The longest edge the mesh may have in a cell whose longest edge is s, with distance bound
 * D: the stuffing moves a lattice vertex onto the surface by at most D/2 and at most 0.15 of
 * an edge at the vertex (a neighbour's edge is at most 2s), so an edge grows by at most
 * min(D, 0.6 s). */
static inline double vm__gr_edge_bound(double s, double D) {
    return s + (D < 0.6 * s ? D : 0.6 * s);
}

/* Sizing of the octree (world units). */
typedef struct gr_sizing {
    double h0[3], max_edge, distance;
    int layers; /* --grading R: ceil(ln 2 / ln R) cells of a size before the next (1: 2:1) */
} gr_sizing;

vm_status vm__gr_tree_build(gr_tree *t, const gr_field *f, const gr_sizing *s, vm_error *err);
/* Splits leaf `leaf` into 8 children. */
vm_status vm__gr_tree_split(gr_tree *t, size_t leaf, vm_error *err);
/* 2:1 balance over faces, edges and corners (neighbouring leaves differ by one level at
 * most), by splitting the coarser side until it holds; with t->layers = m > 1, every leaf
 * within m cells of its own size (faces, edges, corners) is at most one level coarser. */
vm_status vm__gr_tree_balance(gr_tree *t, vm_error *err);
/* Splits every leaf above the base level that the surface may cross and, with boxes (6 per
 * box: lo, hi in the scaled index frame), that meets one of them. [out] *split: leaves
 * split. */
vm_status vm__gr_tree_refine_crossed(gr_tree *t, const gr_field *f, const double *boxes,
                                     size_t nboxes, size_t *split, vm_error *err);
/* The node that holds lattice point p, descending no further than `level` (a leaf, or an
 * inner node of that level when the region there is finer); -1 outside the root. */
int64_t vm__gr_tree_find(const gr_tree *t, const int64_t p[3], int level);
void vm__gr_tree_free(gr_tree *t);

static inline void vm__gr_lattice_pos(const gr_tree *t, const int64_t p[3], double u[3]) {
    for (int d = 0; d < 3; d++)
        u[d] = t->u0[d] + (double)p[d] * 0.5 * t->h0[d];
}

/* An entry of the lattice's vertex table: a packed lattice point and its vertex id (-1:
 * empty), side by side so that a probe reads one cache line. */
typedef struct gr_slot {
    int64_t key, id;
} gr_slot;

/* The lattice: vertices (leaf corners and centres, and the face centres some faces need),
 * tets over them, positive in lattice coordinates. A lattice built before may be given to
 * vm__gr_lattice_build again: its arrays are reused. */
typedef struct gr_lattice {
    int64_t *key; /* packed lattice coordinates per vertex */
    double *phi;  /* value per vertex */
    size_t nv, vcap;
    gr_slot *slot; /* open-addressing table of vertex ids, size tcap (power of two) */
    size_t tcap;
    int32_t (*tet)[4];
    size_t nt, tcap4;
    int64_t *centre; /* per octree node: the vertex id of a leaf's centre (while building) */
    size_t ccap;
} gr_lattice;

static inline int64_t vm__gr_key(const int64_t p[3]) {
    return p[0] | (p[1] << 21) | (p[2] << 42);
}
static inline void vm__gr_unkey(int64_t k, int64_t p[3]) {
    p[0] = k & 0x1fffff;
    p[1] = (k >> 21) & 0x1fffff;
    p[2] = (k >> 42) & 0x1fffff;
}

/* Builds the lattice of t's leaves into L, which is zeroed memory or a lattice built before
 * (its arrays are reused). */
vm_status vm__gr_lattice_build(gr_lattice *L, const gr_tree *t, const gr_field *f,
                               vm_error *err);
/* Vertex id of lattice point p, or -1. */
int64_t vm__gr_lattice_find(const gr_lattice *L, const int64_t p[3]);
void vm__gr_lattice_free(gr_lattice *L);

/* Stuffing counters. */
typedef struct gr_stuff_stats {
    size_t warped, cut_vertices, unwarped, rounds;
    int no_warps; /* the last round dropped every warp (the stuffing's last resort) */
} gr_stuff_stats;

/* Cuts the lattice tets by the surface (warping lattice vertices onto it where a cut comes
 * close, when that changes no topology) and writes the inside pieces to `mesh`, in world
 * coordinates. */
/* Buffers a caller may keep between stuffings, so that a next one reuses them instead of
 * having the kernel clear fresh pages (vm__mesh_graded gives them back after each round: kept,
 * they raised the peak memory more than they saved): zeroed at first, freed by
 * vm__gr_stuff_work_free. */
enum { GR_STUFF_BUFFERS = 17 };
typedef struct gr_stuff_work {
    void *buf[GR_STUFF_BUFFERS];
    size_t cap[GR_STUFF_BUFFERS]; /* bytes */
} gr_stuff_work;
void vm__gr_stuff_work_free(gr_stuff_work *w);

/* work (may be NULL: buffers of this call only) keeps the buffers for the next call. */
vm_status vm__gr_stuff(const gr_lattice *L, const gr_tree *t, const gr_field *f, vm_mesh *mesh,
                       gr_stuff_stats *st, gr_stuff_work *work, vm_error *err);

/* The topology of the voxels as dual contouring reads them (configuration table of
 * graded_config.c): the Euler characteristic of the boundary and the components of the
 * 6-connected inside points. */
vm_status vm__gr_digital_topology(const gr_field *f, long *euler, size_t *comps,
                                  vm_error *err);
/* The same for a tet mesh: the boundary's V - E + F and the components of its points; with
 * root and part (npoints each, or NULL), each point's component (its root point) and, at
 * each root, that component's V - E + F. */
vm_status vm__gr_mesh_topology(const vm_mesh *m, long *euler, size_t *comps, uint32_t *root,
                               long *part, vm_error *err);
/* Where a mesh's topology differs from the voxels': for each component of the voxels whose
 * mesh part has another Euler characteristic, or is split or missing, and for each mesh
 * component over no inside voxel, a box (lo[3], hi[3] in the octree's scaled index frame:
 * index times spacing) around both. [out] *boxes (6 per box, freed by the caller), *nboxes. */
vm_status vm__gr_topology_misfits(const gr_field *f, const vm_mesh *m, double **boxes,
                                  size_t *nboxes, vm_error *err);

/* Coarsens the stuffed mesh by edge collapse (graded_coarsen.c), keeping its topology, the
 * dihedral angles of the changed tets within the stuffing's, the edge bound and the size
 * field, and the distance bound both ways; stops at `target` tets when nonzero. With `merge`,
 * interior edges whose collapse fails both ways are merged at a point between (the interior
 * then as coarse as the angles allow: off for --grading below 2, which keeps the octree's
 * grading). pm (may be NULL) is polled for cancellation (VM_ERR_CANCELLED; the mesh is then
 * left valid but partly coarsened). [out] *removed: vertices removed. */
struct vm__meter;
vm_status vm__gr_coarsen(vm_mesh *m, const gr_field *f, double distance, double max_edge,
                         size_t target, int merge, struct vm__meter *pm, size_t *removed,
                         vm_error *err);

/* The coarsening's mean sweeps (graded_coarsen.c, mean_sweep) over a graded mesh after its
 * quality pass: each vertex goes towards the mean of its neighbours where that raises the
 * sum of its tets' smallest dihedral angles and lowers none below the star's worst, every
 * changed tet within 15..150 degrees (or no worse than the star was) and ABAQUS's check, no
 * edge over max_edge (0: none) nor longer than the star's longest. With distance > 0 (world
 * units) boundary vertices move too, and each sweep follows flip sweeps (flip_sweep:
 * 2-3, 3-2, edge removals, boundary edge removals), both keeping the distance both ways as
 * the coarsening does; with 0 only interior vertices move and nothing flips. The material
 * is {lo <= f <= hi} of v (its border planes). [out] *moved: vertex moves; flips: the 2-3
 * flips, 3-2 flips, edge removals and boundary edge removals made (the mesh comes back
 * compacted when there are any). */
vm_status vm__gr_mean_smooth(vm_mesh *m, const vm_volume *v, double lo, int has_lo, double hi,
                             int has_hi, double max_edge, double distance, size_t *moved,
                             size_t flips[4], vm_error *err);

/* The coarsening's flip sweeps (graded_coarsen.c, flip_sweep: 2-3 and 3-2 flips, edge
 * removal and boundary edge removal, each where it betters the worst tet it replaces) over
 * the tets of m graded below GR_CO_FLIP_BAR; for tests. The boundary stays where distance
 * is 0; else its edges flip where the new triangles keep within distance (world units) of
 * the isosurface, as the coarsening's do. [out] *flips: flips made, *removals: how many of
 * them were edge removals, *bremovals: boundary edge removals. The mesh comes back
 * compacted. */
vm_status vm__gr_flips(vm_mesh *m, const vm_volume *v, double lo, int has_lo, double hi,
                       int has_hi, double max_edge, double distance, size_t *flips,
                       size_t *removals, size_t *bremovals, vm_error *err);

#endif
