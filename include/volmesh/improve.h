/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/improve.h — the quality-improvement pass over tetrahedral meshes.
 *
 * vm_mesh_improve raises the worst element quality of a tet4 mesh in place by edge
 * contraction (seed 001 §6, with the ABAQUS thresholds), optimisation-based vertex smoothing,
 * 2-3 / 3-2 / 4-4 flips of interior faces and edges, flips of boundary edges and peeling of
 * bad tets with two or three boundary faces, and random vertex perturbations. Every accepted
 * operation raises the worst quality of the tets it touches, so the worst quality of the mesh
 * never goes down. It never changes the topology of the boundary (link condition of the mesh
 * closed by a vertex at infinity for contractions; new surface edges must be new, no fold, for
 * flips and peels), keeps the boundary within surface_tolerance of the isosurface, keeps flat
 * faces on the volume border on their plane, keeps the region of every tet (faces between two
 * regions are constrained surfaces, see max_interface_move) and reports the elements it could
 * not fix (a result, not an error).
 * See docs/IMPROVE.md for the algorithms and the measured figures. */
#ifndef VOLMESH_IMPROVE_H
#define VOLMESH_IMPROVE_H

#include "error.h"
#include "mesh.h"
#include "mesher.h"
#include "slabs.h"
#include "volume.h"
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct vm_improve_options {
    /* Material bounds of the mesh, as in vm_mesh_options (used only when a volume is given):
     * boundary vertices are projected back onto {f = lo} or {f = hi}, whichever is nearer. */
    double lo, hi;
    int has_lo, has_hi;
    /* Largest distance a boundary vertex may move from its original position, in voxels
     * (index space) when a volume is given: it slides along the isosurface, so this bounds
     * how far the mesh drifts along the surface, not how far the surface moves. Default 0.8.
     * Without a volume, boundary vertices move only in their tangent plane and at most
     * max_surface_move_free times the length of their shortest incident edge (default 0.1). */
    double max_surface_move;
    double max_surface_move_free;
    /* Multi-material meshes (cells of several regions): faces between two regions are
     * constrained like the boundary. No operation changes the region of the space around an
     * interface; a vertex where three or more regions meet (or an interface meets the
     * boundary) stays fixed, as does one on a crease of its interface (face normals more than
     * 25 degrees apart); any other interface vertex slides in the tangent plane of its
     * interface by at most max_interface_move times its shortest incident edge at the start
     * (default 0.1; 0 keeps every interface vertex fixed). */
    double max_interface_move;
    /* With a volume: the boundary stays within surface_tolerance voxels of the isosurface
     * (default 0.5). Isosurface vertices may leave the isosurface by up to surface_band
     * voxels (first-order distance |f - iso| / |grad f|, index space; default 0.3), so that
     * sheets thinner than a voxel can thicken (0 keeps them on it); surface edge flips and
     * peeled tets may move the surface by the rest, surface_tolerance - surface_band. */
    double surface_tolerance;
    double surface_band;
    /* With a volume, 1: a surface vertex's move and an edge contraction also keep the
     * boundary triangles around the vertex within 0.8 surface_tolerance of the isosurface at
     * their edge midpoints and centres (the same first-order distance), or no farther than
     * they were; k > 1: within 0.8 k surface_tolerance (a looser check, which
     * vm_mesh_improve_graded tries with 2 before none at all; negative: VM_ERR_ARG). On a coarse boundary the triangles' interiors are what lies far from the
     * surface (a chord under a curved cap), so this keeps the isosurface near the boundary
     * too: the distance both ways. vm_mesh_improve_graded sets it. Default 0. (With or
     * without it, no surface vertex ends farther outside the volume's box than it began.) */
    int surface_chords;
    /* What counts as "good": min dihedral >= target_min_dihedral (default 15 degrees), max
     * dihedral <= target_max_dihedral (default 150) and ABAQUS volume measure >=
     * target_volume_measure (default 0.03). Tets below these are worked on. */
    double target_min_dihedral, target_max_dihedral, target_volume_measure;
    /* No operation makes an edge longer than this (world units; 0, the default: no bound):
     * the mesher's --max-edge, which flips, contractions and moves would otherwise exceed. */
    double max_edge;
    /* vm_mesh_improve_graded: the graded mesher's distance bound (world units). After the
     * pass, flips and mean sweeps raise the mean of each tet's smallest dihedral angle; they
     * move boundary vertices and flip boundary edges only where the boundary triangles stay
     * within it of the isosurface and each isosurface sample within it of the boundary (or
     * no farther than it was). 0, the default: they leave the boundary as the pass left it
     * (interior vertices move, nothing flips); negative: VM_ERR_ARG. */
    double distance;
    int max_passes;          /* rounds of contract + flip + smooth; default 12 */
    int contract, flip, smooth, perturb; /* enable each operation (all 1 by default) */
    unsigned seed;           /* random perturbations are reproducible for a given seed */
    /* 1: add a cell field "improve_unfixed" (1 for tets still failing the ABAQUS check or
     * below 10 degrees, else 0). Default 0. */
    int mark_unfixed;
    /* One flag per input cell (NULL, the default: none): a nonzero flag keeps that tet off
     * the pass's work lists, so no operation is tried for it (it changes only when an
     * operation on another tet reaches it and its region and vertices allow). For tets
     * that cannot change anyway, e.g. held by regions of their own (volmesh_mpi's
     * neighbour rings), whose attempts would cost time for nothing. */
    const unsigned char *frozen;
    /* How the pass runs. 0 (default): the local pass (issue #32): only the tets below the
     * targets and two rings of tets around them are set up and worked on, in jobs by blocks
     * of space, the blocks of one colour at a time on OpenMP threads, each job with the tets
     * around it locked (never changed, their vertices never moved); a mesh with no tet below
     * the targets costs one sweep. 1: one pass over the whole mesh. N > 1: N slabs along z
     * (issue #12; fewer when the mesh is too thin for N slabs a few tets thick each), two at
     * a time on threads, then bands around the slab borders, so that only one slab's working
     * data is held per thread. The output is the same for any thread count; the three modes
     * give different (similar) meshes. With frozen set, or without regions, the pass runs in
     * one piece. */
    int parts;
    /* Called during the rounds ("improve", done, 1.0; done grows, the first round taking the
     * first half) and once at the end with done == total == 1; NULL (default) for none. */
    vm_progress_fn progress;
    void *progress_user;
} vm_improve_options;

/* Figures of one run; *_before are measured on the input, *_after on the output. */
typedef struct vm_improve_report {
    size_t tets_before, tets_after, points_before, points_after;
    double min_dihedral_before, max_dihedral_before; /* degrees */
    double min_dihedral_after, max_dihedral_after;
    size_t slivers_5_before, slivers_10_before;      /* min dihedral below 5 / 10 degrees */
    size_t slivers_5_after, slivers_10_after;
    /* ABAQUS element check, as volmesh quality counts it: volume measure < 0.02, or a face
     * angle below 10 or above 160 degrees. */
    size_t abaqus_before, abaqus_after;
    size_t inverted_after;                           /* signed volume <= 0 (always 0) */
    /* Tets that still fail the ABAQUS check or the bar (min dihedral < 10, max > 165). */
    size_t unfixed;
    double volume_before, volume_after;              /* sum of signed volumes */
    /* Largest displacement of a vertex on the isosurface (voxels with a volume, world units
     * without). Vertices on flat border faces slide within their plane and are not counted. */
    double max_surface_move;
    /* Largest displacement of an interface vertex (world units). */
    double max_interface_move;
    size_t collapses, flips23, flips32;
    size_t edge_removals;     /* edges with 4..8 tets around them removed (4-4 and larger) */
    size_t moves, perturbations;
    size_t peels;             /* bad tets with 2 or 3 boundary faces removed (surface 2-2 flips) */
    size_t boundary_flips;    /* boundary edges removed (surface edge flips, 2-2 and larger) */
    int passes;
    double seconds;
} vm_improve_report;

/* Defaults: bounds f >= 0 (has_lo), 0.8 voxel, 0.1 edge (surface and interface), tolerance
 * 0.5 and band 0.3 voxel, targets 15 / 150 / 0.03, 12 passes, every operation on, seed 1, no
 * unfixed field. [out] o. */
void vm_improve_options_default(vm_improve_options *o);

/* Improves the tet4 mesh m in place. [in,out] m: points may move, points and cells may be
 * removed or replaced (cells keep their region; cell fields of new cells are copied from
 * the cell they replace; point fields follow their points). [in] v may be NULL: when given it
 * must be the volume m was meshed from (same index-to-world mapping) and o->lo/hi/has_lo/
 * has_hi its material bounds. [in] o may be NULL (defaults). [out] r may be NULL.
 * Errors: VM_ERR_UNSUPPORTED for a kind other than tet4, VM_ERR_EMPTY for a mesh without
 * cells, VM_ERR_ARG for a node index out of range or an inverted input tet (it cannot
 * improve what it cannot orient), VM_ERR_NOMEM. On error m is unchanged, except that a
 * pass by parts (o->parts) may have improved some parts of it already (still valid).
 * Time O(n log n) per pass; memory about 150 bytes per tet in one pass (by parts: the
 * mesh, 28 bytes per point and 1 to 9 per tet more, and the working data of one part per
 * thread). */
vm_status vm_mesh_improve(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                          vm_improve_report *r, vm_error *err);

/* vm_mesh_improve for a mesh of the graded mesher (vm_mesh_options.graded), whose boundary
 * already meets the distance bound both ways (the pass's surface moves would loosen it): a
 * mesh meeting the targets is left as it is; one with at most 1% of its tets (plus 8) outside
 * the dihedral targets first gets one round with every surface vertex fixed and no
 * contraction, kept when it meets the targets; otherwise, on the mesh as it came, a pass that
 * neither contracts edges nor slides surface vertices over 0.1 voxel, then, only if tets are
 * still below the targets, a pass with o, once more with another seed while they are; these
 * with surface_chords set (the boundary triangles bounded too). Should tets stay below, the
 * same with surface_chords 2 (the looser bound): the pass with o twice from what the first
 * of those passes made, then both from the input; then the pass with o without
 * surface_chords from what the first pass made, up to three times with other seeds, and
 * last the whole sequence without it from the input. Then, with v and a bound, up to three
 * sweeps over the interior vertices raise the mean of each tet's smallest dihedral angle:
 * each goes towards the mean of its neighbours or the volume-weighted centre of its tets'
 * circumcentres where that raises the sum of its tets' smallest angles, no tet of its star
 * falling below the star's worst or leaving 15..150 degrees and ABAQUS's check, no edge
 * over o->max_edge and the star's longest edge not growing (the boundary does not move;
 * skipped on a mesh with fields). r sums every pass run (its *_before figures are the
 * input's, its *_after ones the mesh's at the end; moves counts the sweeps' too). Arguments
 * and errors as vm_mesh_improve; v must be given for the bound to mean anything. */
vm_status vm_mesh_improve_graded(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err);

/* vm_mesh_improve with the volume read by planes instead of held whole (for meshes made by
 * slabs, vm_mesh_volume_slabs): info gives the dims and geometry (its data is not used and
 * may be NULL). By parts or the local pass (o->parts != 1), each part or job reads from
 * source the planes its vertices can sample (its z reach, twice the surface bound and 3 planes
 * more each side) while it runs, and frees them after: the volume is never held whole (on
 * the 2-core machine, two parts' planes at a time). Otherwise (the one pass, a mesh without
 * regions, o->frozen) it reads all the planes at once. source is called one call at a
 * time, from any thread, in any order of z (vm_volume_reader_read goes back to the start
 * of a compressed stream for a slab before the last one). The result is vm_mesh_improve's
 * with the whole volume, byte for byte. Errors as vm_mesh_improve, VM_ERR_ARG without info
 * or source, and the source's own (naming its file). */
vm_status vm_mesh_improve_planes(vm_mesh *m, const vm_volume *info, vm_plane_source source,
                                 void *source_user, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err);

/* Hexahedral meshes (hex8): vm_mesh_improve_hexes first inserts a pillow layer (one hex on
 * every boundary quad, between the boundary and an inner copy of it), so that no hex keeps two
 * faces on the smooth boundary, then untangles (compass search on a convex penalty of the
 * normalised Jacobian determinants) and smooths by moving one vertex at a time to raise the
 * smallest scaled Jacobian of the hexes around it (compass search on the max-min objective).
 * Hexes are measured as vm_hex_scaled_jacobian does, and as vm_mesh_check and the report count
 * them: at the corners, the centre and the 2x2x2 Gauss points. Interior vertices move freely;
 * boundary vertices slide on the isosurface (re-projected onto the trilinear field of the
 * volume) or, on a face of the volume's box, within that plane. A move is kept only when the
 * worst sample around the vertex does not get worse, so the worst scaled Jacobian of the mesh
 * never goes down. See docs/IMPROVE.md. */
typedef struct vm_hex_improve_options {
    double lo, hi;      /* material bounds, as in vm_mesh_options (used with a volume) */
    int has_lo, has_hi;
    double target;      /* hexes with a min scaled Jacobian below this are worked on; 0.5 */
    /* Largest distance a boundary vertex may slide from where the mesher put it, in voxels
     * (index space). Default 1.0. Without a volume, boundary vertices stay fixed. */
    double max_surface_move;
    int pillow;         /* 1 (default): insert the boundary layer first */
    int max_sweeps;     /* most rounds over the points of poor hexes per stage; 8 */
    /* Called after each sweep (stage "hex pass", done/total rising towards 1: the number of
     * sweeps is not known in advance) and once with done == total at the end; may be NULL. */
    vm_progress_fn progress;
    void *progress_user;
} vm_hex_improve_options;

typedef struct vm_hex_improve_report {
    size_t hexes_before, hexes_after, points_before, points_after;
    size_t pillow_hexes;                  /* hexes added by the boundary layer */
    int pillow_undone; /* 1: the layer left inverted hexes, so the pass ran without it */
    double min_sj_before, min_sj_after;   /* smallest vm_hex_scaled_jacobian (-1..1) */
    size_t inverted_before, inverted_after; /* hexes with vm_hex_scaled_jacobian <= 0 */
    size_t below_02_before, below_02_after; /* hexes with a min scaled Jacobian below 0.2 */
    double volume_before, volume_after;   /* sum of trilinear hex volumes (world units) */
    /* Largest distance of a boundary vertex from the isosurface after the pass (the first
     * crossing along the gradient, else |f - iso| / |grad f|), in voxels: world distance
     * over the cube root of a voxel's volume, as --distance-check (0 without a volume;
     * box-face vertices skipped). */
    double max_surface_distance;
    double max_surface_distance_before; /* the same for the points as the mesher put them */
    size_t moves;
    int sweeps;
    double seconds;
} vm_hex_improve_report;

/* Defaults: f >= 0 (has_lo), target 0.5, 1 voxel, pillow on, 8 sweeps. [out] o. */
void vm_hex_improve_options_default(vm_hex_improve_options *o);

/* Improves the hex8 mesh m in place. [in,out] m: points move; with o->pillow, points and
 * cells are appended (the new cells take the region of the hex they border). [in] v may be
 * NULL (boundary vertices then stay fixed); when given it must be the volume m was meshed
 * from, with o->lo/hi/has_lo/has_hi its material bounds. [in] o may be NULL (defaults).
 * [out] r may be NULL. Errors: VM_ERR_UNSUPPORTED for a kind other than hex8 or a mesh with
 * point or cell fields (pillowing would have to extend them), VM_ERR_EMPTY without cells,
 * VM_ERR_ARG for a node out of range, VM_ERR_NOMEM. Inverted input hexes are allowed (the
 * pass untangles them); report what stays inverted in r->inverted_after. */
vm_status vm_mesh_improve_hexes(vm_mesh *m, const vm_volume *v, const vm_hex_improve_options *o,
                                vm_hex_improve_report *r, vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
