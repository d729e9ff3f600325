/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/surface.h — volume to surface mesh: the boundary of the material as triangles
 * (or quads), by one of four methods.
 *
 * The material is chosen as for vm_mesh_volume ({lo <= f <= hi}, either bound open). Every
 * method returns a closed, consistently oriented surface (normals point out of the
 * material) in the world coordinates of the volume; material touching the volume border is
 * closed by faces on the box. */
#ifndef VOLMESH_SURFACE_H
#define VOLMESH_SURFACE_H

#include <stddef.h>
#include "error.h"
#include "mesh.h"
#include "mesher.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vm_surface_method {
    VM_SURFACE_DC = 0,    /* dual contouring: the boundary of the volume mesher's output
                             (tri3 from the tet mesh, quad4 from the hex mesh) */
    VM_SURFACE_MC = 1,    /* marching cubes with the topology of the trilinear interpolant:
                             faces by the asymptotic decider, tunnels inside a cube by a
                             plane sweep (docs/ALGORITHMS.md); one vertex per crossed grid
                             edge; slivers where crossings fall near grid points */
    VM_SURFACE_ASC = 2,   /* adaptive skeleton climbing (Poston, Wong, Heng) */
    VM_SURFACE_COVER = 3  /* disk covering with guaranteed genus and triangle aspect ratio
                             (Gavriliu, Carranza, Breen, Barr) */
} vm_surface_method;

typedef struct vm_surface_options {
    double lo, hi;           /* material bounds, as in vm_mesh_options */
    int has_lo, has_hi;      /* which bounds apply (at least one must) */
    vm_surface_method method;
    vm_cell_kind elements;   /* VM_TRI3, or VM_QUAD4 (dual contouring only) */
    int cell_size;           /* sampling cell size in voxels (>= 1) */
    double error;            /* asc, cover: allowed geometric error, in voxels (> 0) */
    int max_level;           /* asc: largest box 2^max_level cells; cover: finest octree
                                level below the whole volume is chosen from the data */
    int improve;             /* dc: run the volume quality pass before taking the boundary */
    vm_progress_fn progress;
    void *progress_user;
} vm_surface_options;

/* Counters of one extraction. */
typedef struct vm_surface_stats {
    size_t faces, points;
    size_t cells_visited;    /* grid cells or boxes the method examined */
    size_t centre_vertices;  /* mc: vertices added inside cubes (tunnels, and polygons no
                                triangulation of which avoids chords in a cube face) */
    int supersample[3];      /* cover: how many times finer than the sampling grid the
                                interpolant was sampled along each axis (1 1 1 if not);
                                0 0 0 for the other methods */
    double seconds;
} vm_surface_stats;

/* Defaults: material f >= 0, dual contouring, triangles, cell size 1, error 0.5 voxel,
 * max level 4, improve on. */
void vm_surface_options_default(vm_surface_options *o);

/* Extracts the boundary surface of the material of v. [out] surf (initialised here, tri3 or
 * quad4; free with vm_mesh_free); [out] stats may be NULL. Every face has region 1.
 * VM_ERR_EMPTY when no voxel is in the material, VM_ERR_ARG for bad options (quads with a
 * method other than dc, error <= 0, ...), VM_ERR_FORMAT for non-finite values. */
vm_status vm_surface_extract(const vm_volume *v, const vm_surface_options *o, vm_mesh *surf,
                             vm_surface_stats *stats, vm_error *err);

/* Parses "dc", "mc", "asc", "cover". VM_OK, or VM_ERR_ARG for an unknown name (no message:
 * the caller names the option). */
vm_status vm_surface_method_parse(const char *name, vm_surface_method *method);

/* Name of a method ("dc", ...); "?" for an unknown value. */
const char *vm_surface_method_name(vm_surface_method method);

#ifdef __cplusplus
}
#endif
#endif
