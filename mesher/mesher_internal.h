/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/mesher_internal.h — data passed between the mesher's stages (private). */
#ifndef VM_MESHER_INTERNAL_H
#define VM_MESHER_INTERNAL_H

#include <stdint.h>
#include "volmesh/mesher.h"

/* A uniform grid of samples in the material test's hands: n points per axis, x fastest. */
typedef struct vm__grid {
    int64_t n[3];
    int64_t off[3]; /* index of point 0 in the whole grid (a cropped grid; 0: whole): every
                       coordinate the mesher computes is in the whole grid's frame */
    const float *f;
    double lo, hi;
    int has_lo, has_hi;
    int max_level;          /* 0: uniform; > 0: interior cells merged up to 2^max_level */
    int hexes;              /* 1: the cells are prepared for hexahedra */
    double error;           /* adaptive: boundary cells merge below this error (voxels) */
    int64_t id_limit;       /* tets: soup ids below it are kept in 32 bits (0: 2^32; tests
                               set less to take the 64-bit path) */
    int lift;               /* tets: move the grid points of bad tets (dc_lift.c) in frame */
    double frame[9]; /* index to world, linear part (row-major), for the lift's measures */
    vm_progress_fn progress;
    void *progress_user;
} vm__grid;

/* Cells (4 nodes: tets, 8: hexes in VTK order) over two kinds of vertices: ids below
 * nlattice are grid points (i + nx*(j + ny*k)), ids from nlattice on are surface/centre
 * vertices with positions rep_pos (grid index coordinates). Positive orientation in grid
 * index space. The ids are in tets32 when every one fits in 32 bits (then tets is NULL),
 * else in tets (tets32 NULL). */
typedef struct vm__tet_soup {
    int64_t *tets;
    uint32_t *tets32;
    size_t ntets;
    int nodes;
    int64_t nlattice;
    size_t nreps;
    double *rep_pos;
    size_t nlift;     /* grid points that do not sit on their grid position: */
    int64_t *lift_id; /* their ids, increasing */
    double *lift_pos; /* their positions (grid index coordinates, as rep_pos) */
} vm__tet_soup;

/* Octree of interior cells over the real grid cells (nc = n - 1 per axis), one 4-bit code
 * per cell: VM_OCT_NONE (exterior), VM_OCT_FINE / VM_OCT_COARSE (boundary leaf of level
 * 0 / 1: an aligned 2x2x2 block), or VM_OCT_LEVEL + l (interior leaf of level l <= 12).
 * While it is built the codes are dense, two cells a byte (rows start on a byte, so z
 * layers never share one); vm__octree_build then stores them per aligned block of 8^3
 * cells: one code for a block whose cells agree (most of them: outside, or inside large
 * leaves), a 256-byte page of codes for the others (near the surface). */
enum { VM_KIND_EXTERIOR = 0, VM_KIND_BOUNDARY = 1, VM_KIND_INTERIOR = 2 };
enum { VM_LEAF_BOUNDARY = -1, VM_LEAF_NONE = -2 };
enum { VM_OCT_NONE = 0, VM_OCT_FINE = 1, VM_OCT_COARSE = 2, VM_OCT_LEVEL = 3 };
enum { VM_OCT_PAGE = 16 }; /* block entries >= this: VM_OCT_PAGE + page index */
typedef struct vm__octree {
    int64_t nc[3];
    int64_t row;     /* dense codes: bytes per row of cells, (nc[0] + 1) / 2 */
    uint8_t *code;   /* dense codes, row * nc[1] * nc[2] bytes (NULL once in blocks) */
    int64_t nb[3];   /* blocks per axis */
    uint32_t *block; /* per block: its code, or VM_OCT_PAGE + page */
    uint8_t *pages;  /* 256 bytes per page: codes of 8^3 cells, two a byte, x fastest */
} vm__octree;

static inline size_t vm__octree_byte(const vm__octree *o, const int64_t c[3], int *shift) {
    *shift = (int)(c[0] & 1) * 4;
    return (size_t)((c[0] >> 1) + o->row * (c[1] + o->nc[1] * c[2]));
}
static inline int vm__octree_get(const vm__octree *o, const int64_t c[3]) {
    if (o->code) {
        int sh;
        size_t b = vm__octree_byte(o, c, &sh);
        return (o->code[b] >> sh) & 15;
    }
    uint32_t e = o->block[(c[0] >> 3) + o->nb[0] * ((c[1] >> 3) + o->nb[1] * (c[2] >> 3))];
    if (e < VM_OCT_PAGE) return (int)e;
    size_t in = (size_t)((c[0] & 7) + 8 * ((c[1] & 7) + 8 * (c[2] & 7)));
    return (o->pages[256 * (size_t)(e - VM_OCT_PAGE) + in / 2] >> (4 * (in & 1))) & 15;
}
/* Dense codes only (before vm__octree_build returns). */
static inline void vm__octree_put(vm__octree *o, const int64_t c[3], int code) {
    int sh;
    size_t b = vm__octree_byte(o, c, &sh);
    o->code[b] = (uint8_t)((o->code[b] & ~(15 << sh)) | (code << sh));
}

/* Allocates o over nc cells, every code VM_OCT_NONE; the caller then puts VM_OCT_FINE or
 * VM_OCT_COARSE on boundary cells and VM_OCT_LEVEL on interior cells (disjoint z layers
 * may be filled in parallel). */
vm_status vm__octree_init(vm__octree *o, const int64_t nc[3], vm_error *err);
/* Calls fn(ctx, c) on every cell c of a grid of nc cells, z layers in parallel: fn writes only
 * what belongs to c (the octree's codes of one z layer share no byte with another's), so the
 * result is the same for any thread count. */
void vm__octree_each_cell(const int64_t nc[3], void (*fn)(void *ctx, const int64_t c[3]),
                          void *ctx);
/* Builds the interior leaves from the codes put after vm__octree_init: neighbouring leaves
 * differ by at most two levels; 2x2x2 interior leaves are returned to single cells.
 * max_level <= 10. [out] leaves: interior leaves. On failure o stays to be freed. */
vm_status vm__octree_build(vm__octree *o, int max_level, size_t *leaves, vm_error *err);
/* Edge length in cells of the leaf holding cell c (interior or boundary), 0 for exterior
 * cells and cells out of range. */
int64_t vm__octree_size(const vm__octree *o, const int64_t c[3]);
/* Level of the leaf holding cell c (>= 0 interior, VM_LEAF_BOUNDARY, VM_LEAF_NONE for
 * exterior or out of range); [out] origin: its lowest cell. */
int vm__octree_leaf(const vm__octree *o, const int64_t c[3], int64_t origin[3]);
/* 1 when grid point p is a corner of a boundary cell or of an interior leaf. */
int vm__octree_is_vertex(const vm__octree *o, const int64_t p[3]);
void vm__octree_free(vm__octree *o);

/* Checks a material request against v (bounds given and ordered, cell size >= 1, dims >= 2,
 * finite values, some voxel in range); messages start with what. */
vm_status vm__material_check(const vm_volume *v, int has_lo, double lo, int has_hi, double hi,
                             int cell_size, const char *what, vm_error *err);

/* Checks the options of vm_mesh_volume that need no volume (elements, cell size, adaptive
 * level and error); messages start with "mesh: ". */
vm_status vm__mesh_options_check(const vm_mesh_options *o, vm_error *err);

/* Swaps two nodes of a tet (nodes 4) or two pairs of a hex (8), mirroring it: the cells of a
 * left-handed frame keep positive volumes. */
void vm__mirror_cell(vm_index *c, int nodes);

/* The graded mesher (mesher/graded.c): options already checked. */
vm_status vm__mesh_graded(const vm_volume *v, const vm_mesh_options *o, vm_mesh *mesh,
                          vm_mesh_stats *st, vm_error *err);

/* VM_ERR_EMPTY ("WHAT: no voxel >= lo (the data range is ...)") when no value of the data
 * range vmin..vmax is in the material, else VM_OK. */
vm_status vm__material_range(int has_lo, double lo, int has_hi, double hi, double vmin,
                             double vmax, const char *what, vm_error *err);

/* The sampling grid of cell size S: v's own samples for S == 1 (*owned = NULL), else a
 * trilinear resampling (*owned, free it) with index step[a] voxels between samples.
 * [out] n, f, owned, step. */
vm_status vm__sampling_grid(const vm_volume *v, int cell_size, const char *what, int64_t n[3],
                            const float **f, float **owned, double step[3], vm_error *err);

/* The mesh of soup's cells (mesh initialised to their kind): the used vertices numbered in
 * order of first use, at index position id * step (grid index i, j, k of a grid of n points,
 * k shifted by z_off) mapped to v's world frame; the cells take over soup's id buffer, which
 * is renumbered in place. soup is emptied (its buffers freed or taken) either way. */
vm_status vm__soup_to_mesh(vm__tet_soup *soup, const vm_volume *v, const int64_t n[3],
                           int64_t z_off, const double step[3], vm_mesh *mesh, vm_error *err);

vm_status vm__dual_contour_tets(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                vm_error *err);
vm_status vm__dual_contour_hexes(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                 vm_error *err);

/* Adaptive hexahedra (dc_hex_adaptive.c): replaces the cubes of side `scale` (1: the unit
 * cubes of dc_hex.c; 3, 9, ...: those of the previous call) in interior 3x3x3 blocks well
 * inside the material by one hex each, with a conforming all-hex transition round them; a
 * soup without such blocks is left as it is. n: the grid's points per axis. org [in,out]: the
 * block grid's origin in cells ({0,0,0} before the first call); the call shifts it by 0..2
 * cubes per axis to the offset with the most coarse blocks, for the next call to build on. */
vm_status vm__hex_adapt(vm__tet_soup *soup, const int64_t n[3], int64_t scale,
                        int64_t org[3], vm_mesh_stats *st, vm_error *err);

/* Adaptive hexahedra's sampling grid (hex_base.c): g is v's own grid (step 1); when the
 * uniform hexes of a coarser resampling of v keep their shape (topology, volume, distance to
 * the isosurface), g takes the coarsest such grid (g->n, g->f = *owned, to free) and step
 * its spacing in voxels; *chosen (NULL allowed): the step taken (1: g left as it is). */
vm_status vm__hex_base_grid(const vm_volume *v, const vm_mesh_options *o, vm__grid *g,
                            float **owned, double step[3], double *chosen, vm_error *err);

#endif
