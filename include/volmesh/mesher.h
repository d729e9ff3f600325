/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/mesher.h — volume to mesh: material selection, octree dual contouring, phantoms.
 *
 * The material is {x : lo <= f(x) <= hi} where either bound may be open. Meshes come out in
 * the world coordinates of the volume (spacing, origin, direction applied). */
#ifndef VOLMESH_MESHER_H
#define VOLMESH_MESHER_H

#include <stddef.h>
#include "error.h"
#include "mesh.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vm_mesh_options {
    double lo, hi;          /* material bounds */
    int has_lo, has_hi;     /* which bounds apply (at least one must) */
    vm_cell_kind elements;  /* VM_TET4 or VM_HEX8 */
    int cell_size;          /* uniform cell size in voxels (>= 1) */
    int adaptive;           /* coarse cells in the interior where the octree allows */
    double error;           /* adaptive error tolerance (EDerror), in voxels */
    int max_level;          /* adaptive: largest cell is 2^max_level voxels */
    /* Graded sizing in world units (mm for medical data; docs/SIZING.md). graded = 1 meshes
     * by isosurface stuffing over an octree sized by these (tets only); 0 keeps the dual
     * contouring mesher above. */
    int graded;
    double max_edge;        /* no edge longer than this; 0: no bound */
    double min_edge;        /* smallest cell edge; 0: one voxel (the smallest spacing) */
    double distance;        /* boundary within this of the isosurface; 0: half a voxel */
    /* The largest edge at each point (world units), as an image with its own geometry,
     * resampled trilinearly at the voxels (its nearest value beyond its box); NULL: none.
     * Sizes below the base cell (one voxel, or --min-edge) are met by base cells. */
    const vm_volume *size_field;
    /* Grading (graded): neighbouring cells differ by 2x at most; R in [1.1, 2) asks that
     * sizes grow by R per cell on average (ceil(ln 2 / ln R) cells of a size before the
     * next). 0: 2. */
    double grading;
    /* About this many tets (graded): the distance bound, the edge bound and the size field
     * are scaled together until the octree gives it; the distance is then not refined.
     * vm_mesh_stats.size_scale says the scale used. 0: none. */
    size_t tets;
    /* Graded: thin parts at least this many elements thick: no edge longer than the local
     * thickness of the material over N (the diameter of the largest ball of inside voxels
     * holding the point, measured between voxel centres; parts over 16 voxels thick, or
     * over N times --max-edge, get no bound). Sizes below the base cell are met by base
     * cells (--min-edge lowers them). 0 (the default): none. */
    int min_layers;
    /* Graded: 1 keeps the stuffed mesh as it is; 0 (the default) coarsens it by edge
     * collapse within the same bounds (vm_mesh_stats.coarsened counts the vertices it
     * removes). */
    int no_coarsen;
    /* A cropped volume (tets only; full_nz 0: v is the whole volume). v holds the planes
     * z_offset .. z_offset + v->dims[2] - 1 of a whole volume of full_nz planes, and v's
     * index-to-world mapping is the whole volume's (plane 0 at its origin). The mesh covers
     * the crop only, closed on its first and last planes as on a border, and its grid
     * structures span only the crop; but every vertex, element and coordinate that does
     * not depend on samples beyond the crop is bit for bit the one meshing the whole volume
     * makes (the sampling grid, octree blocks and tet splits are those of the whole grid;
     * adaptive meshes leave out the first few planes of the crop to align on its octree
     * blocks). A crop of material far enough inside its planes is meshed exactly. */
    int64_t z_offset, full_nz;
    /* The frame in which the mesher measures its elements' quality (the lift of
     * docs/ALGORITHMS.md moves grid points by those measures), as direction times spacing
     * (row r, column c: direction[r][c] * spacing[c]). For a volume given in another frame
     * than the one it will be shown in: the slab drivers mesh their crops in index space
     * and give the whole volume's frame here, so that a crop's tets are the whole run's.
     * NULL (the default): v's own frame. */
    const double *crop_frame;
    vm_progress_fn progress;
    void *progress_user;
} vm_mesh_options;

/* Counters and timings of one meshing run. */
typedef struct vm_mesh_stats {
    size_t inside_voxels;
    size_t boundary_cells, interior_cells, special_cells;
    size_t surface_vertices;
    size_t relaxed_vertices;   /* vertices pulled back to keep every element positive */
    size_t untangled_vertices; /* tets: vertices pulled back where the boundary crossed itself */
    size_t boundary_crossings; /* tets: pairs of boundary triangles still crossing after that
                                  (0 on every volume tested; see vm_mesh_check) */
    size_t lifted_vertices;    /* tets: grid points moved off the grid to mend tets below
                                  the quality targets (docs/ALGORITHMS.md, "The lift") */
    size_t repaired_points;    /* hexes: outside grid points taken in (see docs) */
    size_t inverted_cells;     /* hexes left inverted (vm_mesh_improve_hexes untangles them) */
    size_t octree_leaves;      /* graded: leaves of the sizing octree */
    size_t warped_vertices;    /* graded: lattice vertices moved onto the surface */
    size_t refine_rounds;      /* graded: rounds of refining where the distance was over */
    size_t topology_rounds;    /* graded: rounds of refining where the topology differed */
    double size_scale;         /* graded with a tet target: the sizes' scale found (else 1) */
    double distance;           /* graded: the distance bound the boundary was coarsened to
                                  (world units, with size_scale; vm_improve_options.distance) */
    size_t coarsened;          /* graded: vertices removed by coarsening */
    int refine_undone;         /* graded: the last distance refinement changed the topology
                                  and was undone (the distance may be over the bound) */
    double seconds;
    /* graded: seconds per step, summed over the rounds (volmesh mesh --verbose prints them):
       the octree (build, balance, splits), the voxels' and the meshes' topology counts, the
       lattice, the stuffing, the distance measured for refinement, and coarsening; and the
       lattices built and stuffed (one per round) */
    double graded_octree_s, graded_topology_s, graded_lattice_s, graded_stuff_s,
        graded_distance_s, graded_coarsen_s;
    size_t graded_meshes;
} vm_mesh_stats;

/* Defaults: material f >= 0, tets, cell size 1, uniform. */
void vm_mesh_options_default(vm_mesh_options *o);

/* Meshes the material of v. [out] mesh (initialised here; free with vm_mesh_free),
 * [out] stats may be NULL. VM_ERR_EMPTY when no voxel is in the material. */
vm_status vm_mesh_volume(const vm_volume *v, const vm_mesh_options *o, vm_mesh *mesh,
                         vm_mesh_stats *stats, vm_error *err);

/* Analytic test shapes, as signed fields (positive inside, in voxel units, iso 0). */
typedef enum vm_phantom_kind {
    VM_PHANTOM_SPHERE,
    VM_PHANTOM_TORUS,
    VM_PHANTOM_GENUS3,
    VM_PHANTOM_TWO_SPHERES,
    VM_PHANTOM_PLATE,
    VM_PHANTOM_CUT_SPHERE
} vm_phantom_kind;

/* Known answers for a phantom at resolution n. */
typedef struct vm_phantom_info {
    const char *name;
    int euler;           /* Euler characteristic of the boundary surface */
    int components;
    double volume;       /* in voxel^3 (index space) */
} vm_phantom_info;

/* Makes an n^3 phantom; noise > 0 adds seeded Gaussian noise of that standard deviation.
 * [out] v, [out] info may be NULL. */
vm_status vm_phantom_make(vm_phantom_kind kind, int n, double noise, unsigned seed,
                          vm_volume *v, vm_phantom_info *info, vm_error *err);

/* Parses "sphere", "torus", "genus3", "two-spheres", "plate", "cut-sphere". 0 on success. */
int vm_phantom_parse(const char *name, vm_phantom_kind *kind);

#ifdef __cplusplus
}
#endif
#endif
