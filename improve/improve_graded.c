/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_graded.c — the quality pass for the graded mesher's meshes: their boundary
 * already has the fewest vertices the distance bound allows (mesher/graded_coarsen.c keeps
 * the distance both ways), and the pass's own surface operations keep it one way only, so a
 * first pass neither contracts edges nor lets surface vertices slide more than a fifth of a
 * voxel; only where tets stay below the targets does a second pass run with the caller's
 * options (docs/SIZING.md). A mesh that meets the targets already (the coarsening's repair
 * leaves most so) is not touched at all: the pass would still move vertices around its
 * nearly-bad tets, and each boundary move costs distance. */
#include "improve_internal.h"
#include "volmesh/improve.h"
#include <math.h>
#include <stddef.h>

/* A surface vertex slides at most this far (voxels) in the first pass. */
#define VM_GRADED_SURFACE_MOVE 0.2

/* The report of a pass that had nothing to do: the figures of m, before and after. [out] r.
 * Returns whether every tet meets o's targets and ABAQUS's check (one sweep of the pass's
 * own figures, vm__imp_mesh_figures: 0 as well when it finds no memory). */
static int meets_targets(const vm_mesh *m, const vm_improve_options *o, vm_improve_report *r) {
    if (m->kind != VM_TET4 || m->ncells == 0) return 0;
    vm__imp_figures f;
    if (vm__imp_mesh_figures(m->points, m->cells, m->ncells, o->target_volume_measure, &f) !=
        VM_OK)
        return 0;
    int ok = f.inverted == 0 && f.abaqus == 0 && f.vm_low == 0 &&
             !(f.dmin < o->target_min_dihedral) && !(f.dmax > o->target_max_dihedral);
    if (ok && r)
        *r = (vm_improve_report){.tets_before = m->ncells,
                                 .tets_after = m->ncells,
                                 .points_before = m->npoints,
                                 .points_after = m->npoints,
                                 .min_dihedral_before = f.dmin,
                                 .max_dihedral_before = f.dmax,
                                 .volume_before = f.volume,
                                 .min_dihedral_after = f.dmin,
                                 .max_dihedral_after = f.dmax,
                                 .volume_after = f.volume};
    return ok;
}

static int below_targets(const vm_improve_options *o, const vm_improve_report *r) {
    return r->unfixed > 0 || r->min_dihedral_after < o->target_min_dihedral ||
           r->max_dihedral_after > o->target_max_dihedral;
}

vm_status vm_mesh_improve_graded(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err) {
    vm_improve_options io, first;
    if (o)
        io = *o;
    else
        vm_improve_options_default(&io);
    if (meets_targets(m, &io, r)) return VM_OK;
    /* The pass's bounds are in voxels of index space; the graded mesher's distance is in
     * voxels of the geometric mean spacing (docs/SIZING.md). On anisotropic voxels (the CT
     * head's 3.2 x 3.2 x 1.5 mm) half an index voxel along the long axis is 0.64 of the
     * other: scale the bounds so that no axis allows more than they mean. */
    if (v) {
        double smax = 0, g = 1;
        for (int d = 0; d < 3; d++) {
            smax = fmax(smax, fabs(v->spacing[d]));
            g *= fabs(v->spacing[d]);
        }
        double k = smax > 0 ? cbrt(g) / smax : 1;
        if (k > 0 && k < 1) {
            io.surface_tolerance *= k;
            io.surface_band *= k;
            io.max_surface_move *= k;
        }
    }
    first = io;
    first.contract = 0;
    if (first.max_surface_move > VM_GRADED_SURFACE_MOVE)
        first.max_surface_move = VM_GRADED_SURFACE_MOVE;
    vm_improve_report r1, r2;
    vm_status s = vm_mesh_improve(m, v, &first, &r1, err);
    if (s || !below_targets(&io, &r1)) {
        if (r) *r = r1;
        return s;
    }
    s = vm_mesh_improve(m, v, &io, &r2, err);
    if (s) {
        if (r) *r = r1;
        return s;
    }
    /* one report: the input's figures, the output's, and the work of both */
    r2.tets_before = r1.tets_before;
    r2.points_before = r1.points_before;
    r2.min_dihedral_before = r1.min_dihedral_before;
    r2.max_dihedral_before = r1.max_dihedral_before;
    r2.slivers_5_before = r1.slivers_5_before;
    r2.slivers_10_before = r1.slivers_10_before;
    r2.abaqus_before = r1.abaqus_before;
    r2.volume_before = r1.volume_before;
    r2.max_surface_move += r1.max_surface_move;
    if (r1.max_interface_move > r2.max_interface_move)
        r2.max_interface_move = r1.max_interface_move;
    r2.collapses += r1.collapses;
    r2.flips23 += r1.flips23;
    r2.flips32 += r1.flips32;
    r2.edge_removals += r1.edge_removals;
    r2.moves += r1.moves;
    r2.perturbations += r1.perturbations;
    r2.peels += r1.peels;
    r2.boundary_flips += r1.boundary_flips;
    r2.passes += r1.passes;
    r2.seconds += r1.seconds;
    if (r) *r = r2;
    return VM_OK;
}
