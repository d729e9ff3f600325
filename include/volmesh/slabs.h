/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/slabs.h — meshing a volume by slabs along z, one slab in memory at a time.
 *
 * The cells of the sampling grid along z are cut into slabs of whole blocks (one cell, or
 * the coarsest octree leaf with adaptive meshes). Each slab is meshed as a cropped volume
 * (vm_mesh_options z_offset, full_nz) from its own planes plus a ghost band on each side;
 * away from the band's far edge its tets are bit for bit those of the whole volume's mesh,
 * and the slab keeps the tets whose centroid lies in its z range. So the kept tets of all
 * slabs, their shared points merged by exact coordinates, are the whole volume's mesh tet
 * for tet. vm_mesh_volume_slabs does this in one process (volmesh mesh --slabs); the pieces
 * below are what volmesh_mpi uses to do it on MPI ranks. See docs/ALGORITHMS.md, "Meshing
 * by slabs", and docs/MPI.md. */
#ifndef VOLMESH_SLABS_H
#define VOLMESH_SLABS_H

#include "error.h"
#include "mesh.h"
#include "mesher.h"
#include "volume.h"
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The z axis of a volume cut into blocks for options o (cell size, adaptive, max level). */
typedef struct vm_slab_grid {
    int64_t nz;     /* voxel planes of the whole volume */
    int64_t cells;  /* cells of the sampling grid along z (its planes - 1) */
    double step;    /* voxels per grid step along z (1 at cell size 1) */
    int64_t block;  /* cells per block: 2^max_level when adaptive, else 1 */
    int64_t blocks; /* blocks along z, the last one possibly partial */
    int64_t ghost;  /* ghost band in cells on each side of a slab */
} vm_slab_grid;

/* The default ghost band for o: 14 cells, 2 * 2^max_level + 22 when adaptive (the tets near
 * a cut are exact from 2 cells uniform and 4 adaptive at level 4 on the phantoms tested
 * before the lift; the lift's moves depend on up to 7 neighbours' in a chain, 8 cells
 * more; the rest is margin, docs/MPI.md). */
int64_t vm_slab_default_ghost(const vm_mesh_options *o);

/* [out] g for a volume of nz >= 2 planes meshed with o; ghost <= 0: the default. */
void vm_slab_grid_init(int64_t nz, const vm_mesh_options *o, int64_t ghost, vm_slab_grid *g);

/* One slab: what it owns and which planes it needs. */
typedef struct vm_slab {
    int64_t cell0, cell1;   /* its cells cell0 <= c < cell1 (none when cell1 <= cell0) */
    double z0, z1;          /* it keeps the tets whose centroid z, in index space, lies in
                               [z0, z1); -INFINITY and INFINITY at the volume's ends */
    int64_t plane0, plane1; /* the voxel planes plane0 <= k < plane1 it meshes: its cells,
                               the ghost band (the band below starting on a block) and the
                               voxel beyond for the resampling; empty with the cells */
    int whole;              /* it holds every block: mesh the whole volume, not a crop */
} vm_slab;

/* [out] s: the slab of blocks b0 <= b < b1 of g (0 <= b0 <= b1 <= g->blocks). */
void vm_slab_of_blocks(const vm_slab_grid *g, int64_t b0, int64_t b1, vm_slab *s);

/* [out] s: slab i of n (0 <= i < n) with equal numbers of blocks, blocks*i/n to
 * blocks*(i+1)/n; empty when there are more slabs than blocks. */
void vm_slab_part(const vm_slab_grid *g, int i, int n, vm_slab *s);

/* [in,out] o: the crop options for meshing slab s of g from a volume that holds only its
 * planes (z_offset, full_nz; untouched for a whole slab). */
void vm_slab_crop_options(const vm_slab_grid *g, const vm_slab *s, vm_mesh_options *o);

/* 1 when tet t of m (index space: the crop meshed in the whole volume's index frame) is
 * s's: its centroid z, summed as ((z0 + z1) + (z2 + z3)) / 4 so that every slab meeting
 * the tet computes the same double, lies in [s->z0, s->z1). */
int vm_slab_owns(const vm_slab *s, const vm_mesh *m, size_t t);

/* Voxel planes vm_mesh_volume_slabs holds while it meshes g in n slabs: the most planes of
 * one slab. */
int64_t vm_slab_planes_held(const vm_slab_grid *g, int n);

/* The fewest slabs (1 .. g->blocks) for which vm_slab_planes_held stays within max_planes;
 * 0 when even g->blocks slabs hold more. */
int vm_slab_count_within(const vm_slab_grid *g, int64_t max_planes);

/* ---- Merging pieces by exact coordinates ----------------------------------------------
 *
 * An index of points by their exact coordinates (the bits of the three doubles, -0 and +0
 * alike) over a points array the caller owns: the slots hold point numbers, and each lookup
 * reads the array the caller passes (it may have grown or moved since). The index does not
 * grow: it is sized for `room` points when built. One implementation (core/point_index.c)
 * serves the slab and MPI merges and the STL readers. */
typedef struct vm_point_index {
    size_t cap;     /* slots, a power of two, at least 2 * room + 16 */
    vm_index *slot; /* point numbers; -1: empty */
} vm_point_index;

/* Sizes pi for at least room points (room >= n) and enters points 0..n-1 of points (3
 * doubles each), the first of equal coordinates winning. [out] pi, free with
 * vm_point_index_free. */
vm_status vm_point_index_build(vm_point_index *pi, const double *points, size_t n, size_t room,
                               vm_error *err);

/* The number of the point entered with exactly p's coordinates (points: the array the
 * numbers refer to), or -1; then [out] *at is the free slot where to enter it:
 * pi->slot[*at] = its number. */
vm_index vm_point_index_find(const vm_point_index *pi, const double *points, const double p[3],
                             size_t *at);

/* Frees the slots; pi may be NULL. */
void vm_point_index_free(vm_point_index *pi);

/* Maps every point of m from index coordinates to the world coordinates of frame
 * (vm_volume_index_to_world) and, when frame is left-handed, swaps two nodes of every tet
 * or hex (as vm_mesh_volume does), so that element volumes stay positive. */
void vm_mesh_index_to_world(vm_mesh *m, const vm_volume *frame);

/* ---- One process, slab after slab ------------------------------------------------------ */

/* A source of planes: fills out->data with the voxel planes z0 <= k < z1 of the volume.
 * out arrives with dims nx, ny, z1 - z0 and data pointing to room for exactly those floats
 * (x fastest), which the driver owns; the rest of out is to be ignored. Returns VM_OK, or an
 * error with err naming the file and the problem. vm_mesh_volume_slabs asks for each plane
 * once, in increasing z: every call starts where the previous one ended, the first at 0,
 * the last ending at nz (vm_volume_reader_read reads so without going back). */
typedef vm_status (*vm_plane_source)(int64_t z0, int64_t z1, vm_volume *out, void *user,
                                     vm_error *err);

typedef struct vm_slab_options {
    int slabs;              /* slabs along z, >= 1 (more than the blocks: some stay empty) */
    int64_t ghost;          /* ghost band in cells; <= 0: vm_slab_default_ghost */
    vm_plane_source source; /* required */
    void *source_user;
} vm_slab_options;

/* Meshes the volume described by info (dims and geometry; data unused, may be NULL) with
 * tetrahedra, slab after slab: reads the slab's planes from so->source (keeping the ghost
 * planes it shares with the previous slab), meshes them as a crop, appends the tets it owns
 * to mesh with the points shared with earlier slabs merged by exact coordinates, and frees
 * the slab. The result is vm_mesh_volume's mesh of the whole volume tet for tet (the same
 * point coordinates, the same tets with the same node order and regions), in another order:
 * slab after slab. Only tets (o->elements VM_TET4, no crop options in o): VM_ERR_ARG
 * otherwise. o->progress gets stage "slabs", one step per slab. [out] mesh (initialised
 * here; free with vm_mesh_free; empty on error), [out] stats may be NULL: its counters are
 * summed over the slabs' crops (ghost bands counted in each), seconds the whole run.
 * VM_ERR_EMPTY when no slab has material (with the whole volume's data range); a source's
 * error is returned as it is. */
vm_status vm_mesh_volume_slabs(const vm_volume *info, const vm_mesh_options *o,
                               const vm_slab_options *so, vm_mesh *mesh, vm_mesh_stats *stats,
                               vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
