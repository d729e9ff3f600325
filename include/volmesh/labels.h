/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/labels.h — multi-material meshing of a label volume (a segmentation): one
 * conforming mesh of all chosen labels, each element's region = its label.
 *
 * Every voxel of a chosen label becomes one hexahedron (or 6 tetrahedra); the corners are
 * the vertices of the dual cells between voxel centres, shared by all materials, so two
 * materials meet on exactly matching faces. Interface vertices sit at the mean of the
 * label-change edge midpoints of their cell (smooth interfaces), pulled back toward the cell
 * centre wherever that would invert an element. Before meshing, the labels are made
 * well-composed (no two voxels of one label touching only along an edge or at a corner) by
 * relabelling a few voxels, so that each label's boundary is a closed 2-manifold. See
 * docs/LABELS.md. */
#ifndef VOLMESH_LABELS_H
#define VOLMESH_LABELS_H

#include <stddef.h>
#include <stdint.h>
#include "error.h"
#include "mesh.h"
#include "mesher.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A cell size for one label (--size-per-label 3:0.5,7:2). */
typedef struct vm_label_size {
    int32_t label;
    double size; /* voxels; > 0 */
} vm_label_size;

/* A largest edge for one label, in world units (--label-edge 3=0.8,7=4). */
typedef struct vm_label_edge {
    int32_t label;
    double edge; /* world units (those of the volume's spacing, e.g. mm); > 0 */
} vm_label_edge;

typedef struct vm_label_options {
    const int32_t *labels;  /* labels to mesh (not owned); NULL: every non-zero label present */
    size_t nlabels;         /* entries of labels (0 with labels NULL) */
    vm_cell_kind elements;  /* VM_TET4 (default) or VM_HEX8 */
    int cell_size;          /* >= 1: element size in voxels; S > 1 takes the most frequent
                               label of each S^3 block, and a label most frequent in none
                               gets the block where it has the most voxels (kept, coarse) */
    size_t min_island;      /* face-connected pieces of one label smaller than this many
                               (coarse) voxels go to their most common neighbour; 1: keep all */
    int smooth;             /* 1 (default): smooth interfaces; 0: voxel staircase */
    /* Per-label sizes (not owned; labels must be chosen, each at most once). The grid is
     * built at the finest size h asked for (cell_size and every size here: h < 1 is rounded
     * to 1/n, refining every voxel into n^3 cells by nearest upsampling); a label of size S
     * gets cells of h * 2^floor(log2(S / h)) in its interior and on the flat parts of its
     * faces, one fine layer along curved interfaces and boundaries and their edges, 2:1
     * balanced and conforming (tets only). */
    const vm_label_size *sizes;
    size_t nsizes;
    /* 1: every label without a size of its own gets interior cells up to 2^max_level * h
     * (tets only); max_level 1..10, default 4. */
    int adaptive;
    int max_level;
    /* Sizes in world units. A label of edge L gets the per-label size L / d voxels, where d
     * is the world diagonal of one voxel (|spacing|): its interior leaves are the largest
     * whose diagonal is at most L, so no edge of their tets is longer than L, and L below d
     * refines the grid as a size below 1 does (down to d / 8). Its cells along interfaces
     * and the boundary have the finest size h of all labels, with the smoothed vertices of
     * the label mesh. edges: not owned; labels must be chosen, each at most once, and not
     * in sizes too. max_edge > 0: every label without a size or an edge of its own gets
     * interior leaves of diagonal at most max_edge (never finer than h; goes instead of
     * adaptive, which must then be 0). */
    const vm_label_edge *edges;
    size_t nedges;
    double max_edge;
    vm_progress_fn progress;
    void *progress_user;
} vm_label_options;

/* What happened to one chosen label. Volumes are in world units. */
typedef struct vm_label_info {
    int32_t label;
    size_t input_voxels;   /* voxels of the label in the volume */
    size_t meshed_voxels;  /* cells of size h meshed as this label after islands, topology */
    double size;           /* the cell size asked for this label (voxels; from an edge L:
                              L / the voxel's world diagonal) */
    size_t elements;       /* cells of the mesh with region == label; 0: the label was lost
                              (--min-island, or the topology repair took its last cells) */
    double voxel_volume;   /* meshed_voxels * h^3 * voxel volume */
    double mesh_volume;    /* sum of the signed volumes of its cells */
    int rescued;           /* 1: with cell_size S > 1 the label is most frequent in no S^3
                              block, and was given the block where it has the most voxels
                              (unless that block was its winner's only one) */
    size_t islands_removed;      /* its face-connected pieces relabelled by min_island */
    size_t island_cells_removed; /* their cells (of size h) */
} vm_label_info;

typedef struct vm_label_stats {
    size_t nlabels;
    vm_label_info *labels;     /* nlabels entries, ascending label; free with vm_label_stats_free */
    size_t island_voxels;      /* voxels relabelled by the island floor */
    size_t topology_voxels;    /* voxels relabelled to make every label well-composed */
    size_t smoothed_vertices;  /* vertices off their cell centre in the result */
    double cell_size;          /* h: the size of the finest cells, in voxels */
    size_t coarse_cells;       /* octree leaves larger than h (sizes, adaptive) */
    size_t relaxed_vertices;   /* vertices pulled back toward the centre to avoid inversion */
    double seconds;
    /* the stages of seconds: the label grid (reading the labels, --size, --min-island), the
     * topology repair, and the mesh (vertices, elements, smoothing, volume guard) */
    double seconds_grid, seconds_repair, seconds_mesh;
} vm_label_stats;

/* Defaults: all non-zero labels, tets, cell size 1, min island 1, smooth. */
void vm_label_options_default(vm_label_options *o);

/* Meshes the labels of v (values must be integers; 0 or any label not chosen is background).
 * [out] mesh (initialised here; free with vm_mesh_free); [out] stats may be NULL, else free it
 * with vm_label_stats_free. Errors: VM_ERR_FORMAT for a non-integer or out-of-range value,
 * VM_ERR_EMPTY when a requested label is absent or nothing is left to mesh, VM_ERR_ARG for
 * bad options, VM_ERR_NOMEM. The message is one line. */
vm_status vm_mesh_labels(const vm_volume *v, const vm_label_options *o, vm_mesh *mesh,
                         vm_label_stats *stats, vm_error *err);

/* Frees stats->labels and zeroes stats. stats may be NULL. */
void vm_label_stats_free(vm_label_stats *stats);

/* Makes an n^3 label phantom (n >= 16) for tests and demos: kind 0 three concentric balls
 * (labels 1 inside, 2, 3 outside), 1 two blocks sharing a face (1, 2), 2 three blocks meeting
 * along one line (1, 2, 3), 3 two cubes of label 1 touching only along an edge plus a cube of
 * label 2 touching one of them only at a corner. [out] v. */
vm_status vm_label_phantom_make(int kind, int n, vm_volume *v, vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
