/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_cover_internal.h — what the two files of the disk-covering mesher share
 * (private): the fine candidate surface and its adjacency. */
#ifndef VM_SURFACE_COVER_INTERNAL_H
#define VM_SURFACE_COVER_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include "surface_internal.h"

/* The fine candidate surface: the zero set of the piecewise-linear interpolant of the
 * padded samples on the Kuhn (Freudenthal) subdivision of every cell into 6 tetrahedra. A
 * closed, oriented 2-manifold by construction. Its vertices are the candidate vertices of
 * the paper, its edges the candidate connectivity graph. */
typedef struct vm__cover_fine {
    size_t nv, nf;
    double *x;        /* 3 nv, grid index coordinates */
    int32_t *f;       /* 3 nf, counter-clockwise seen from outside */
    int32_t *fadj;    /* 3 nf: the face across edge (f[e], f[e+1]) */
    size_t *off;      /* nv + 1: outgoing half-edges of vertex v are off[v] .. off[v+1]-1 */
    int32_t *nbr;     /* the head of each outgoing half-edge (the 1-ring, each once) */
    int32_t *hface;   /* the face of each outgoing half-edge (the faces at v, each once) */
    double *len;      /* the length of each outgoing half-edge */
    int32_t *comp;    /* nv: edge-connected component of each vertex */
    size_t ncomp;
    long *comp_euler; /* ncomp: V - E + F of each component */
    size_t cells_visited;
} vm__cover_fine;

/* Builds the fine surface of g; the border is closed by a padding layer far outside
 * (see surface_cover_fine.c). Points are in grid index coordinates times scale[a] per axis
 * (NULL: 1, 1, 1). */
vm_status vm__cover_fine_build(const vm__surface_grid *g, const double *scale, vm__cover_fine *m,
                               vm_error *err);

/* vm__surface_cover measuring lengths (disk radii, edge ratios, the error) with index steps
 * of length scale[a] / min(scale) voxels along axis a, for volumes with anisotropic
 * spacing: pass |spacing[a]| * step[a]. vm__surface_cover is this with scale 1, 1, 1. The
 * output is in grid index coordinates, as for every method. */
vm_status vm__surface_cover_scaled(const vm__surface_grid *g, const vm_surface_options *o,
                                   const double scale[3], vm_mesh *surf, vm_surface_stats *st,
                                   vm_error *err);
void vm__cover_fine_free(vm__cover_fine *m);

/* The trilinear interpolant of g sampled k[a] times finer along axis a: out has
 * (n[a] - 1) k[a] + 1 samples, sample i at i / k[a] of the original index; *buf holds them
 * (free it; NULL when every k is 1 and out is g itself). Bounds are copied. */
vm_status vm__cover_supersample(const vm__surface_grid *g, const int k[3], vm__surface_grid *out,
                                float **buf, vm_error *err);

/* The improvement pass (surface_cover_improve.c) over the triangles kept from the fine
 * surface. [in,out] x (3 nv, positions in the scaled space of m), tri (3 nt, vertex
 * indices), fine (nt: 1 where a triangle may change, i.e. it was kept fine) are rewritten in
 * place and *nv, *nt shrink: edge contractions under the link condition, flips and moves
 * projected onto the fine surface, each kept only when the mesh stays within eps of the fine
 * surface and the fine surface within eps of the mesh, with no flip-over, sharper crease,
 * duplicate edge or crossing, and the covered triangles keep their edge ratio 0.3. On
 * return fine[t] is 1 only for a kept-fine triangle still below the edge ratio 0.3.
 * [out] st may be NULL. Deterministic (one thread, a fixed order). Errors: out of memory. */
typedef struct vm__cover_improve_stats {
    size_t contractions, flips, moves, rounds;
} vm__cover_improve_stats;
vm_status vm__cover_improve(const vm__cover_fine *m, double eps, double *x, size_t *nv,
                            int32_t *tri, size_t *nt, uint8_t *fine, vm__cover_improve_stats *st,
                            vm_error *err);

#endif
