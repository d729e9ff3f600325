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
    vm_progress_fn progress;
    void *progress_user;
} vm__grid;

/* Cells (4 nodes: tets, 8: hexes in VTK order) over two kinds of vertices: ids below
 * nlattice are grid points (i + nx*(j + ny*k)), ids from nlattice on are surface/centre
 * vertices with positions rep_pos (grid index coordinates). Positive orientation in grid
 * index space. */
typedef struct vm__tet_soup {
    int64_t *tets;
    size_t ntets;
    int nodes;
    int64_t nlattice;
    size_t nreps;
    double *rep_pos;
} vm__tet_soup;

/* Octree of interior cells over the real grid cells (nc = n - 1 per axis). */
enum { VM_KIND_EXTERIOR = 0, VM_KIND_BOUNDARY = 1, VM_KIND_INTERIOR = 2 };
enum { VM_LEAF_BOUNDARY = -1, VM_LEAF_NONE = -2 };
typedef struct vm__octree {
    int64_t nc[3];
    int8_t *lvl;  /* per cell: level of its interior leaf, VM_LEAF_BOUNDARY or VM_LEAF_NONE */
    int8_t *blvl; /* per cell: level of its boundary leaf (0 or 1; NULL: all 0) */
} vm__octree;

/* kind: one VM_KIND_* per cell, x fastest; blevel (NULL: all 0): per boundary cell the
 * level of its boundary leaf (1: an aligned 2x2x2 block), taken over (freed with the octree,
 * also when the build fails: one grid-sized array less at the peak). Neighbouring leaves
 * differ by at most two levels; 2x2x2 interior leaves are returned to single cells.
 * [out] leaves: interior leaves. */
vm_status vm__octree_build(vm__octree *o, const int64_t nc[3], const uint8_t *kind,
                           int8_t *blevel, int max_level, size_t *leaves, vm_error *err);
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

/* The sampling grid of cell size S: v's own samples for S == 1 (*owned = NULL), else a
 * trilinear resampling (*owned, free it) with index step[a] voxels between samples.
 * [out] n, f, owned, step. */
vm_status vm__sampling_grid(const vm_volume *v, int cell_size, const char *what, int64_t n[3],
                            const float **f, float **owned, double step[3], vm_error *err);

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

#endif
