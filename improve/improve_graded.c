/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_graded.c — the quality pass for the graded mesher's meshes: their boundary
 * already has the fewest vertices the distance bound allows (mesher/graded_coarsen.c keeps
 * the distance both ways). So a mesh with only a few tets below the targets first gets a pass
 * with every surface vertex fixed (its boundary stays as it is); where that is not enough, or
 * there are many, a pass that neither contracts edges nor lets surface vertices slide more
 * than a tenth of a voxel runs on the mesh as it came; only where tets stay below the targets
 * do passes with the caller's options run. These passes first keep the boundary triangles
 * near the isosurface between their vertices too (surface_chords: the pass's own bound is at
 * the vertices, one way), so that the distance holds both ways; where they end below the
 * targets, the full passes run again without that check from the slide pass's mesh, and as
 * a last resort the whole sequence without it from the input (docs/SIZING.md). A mesh that
 * meets the targets already (the coarsening's repair leaves most so) is not touched at all:
 * the pass would still move vertices around its nearly-bad tets, and each boundary move
 * costs distance. */
#include "../mesher/graded_internal.h"
#include "improve_internal.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

/* A surface vertex slides at most this far (voxels) in the first pass: a fifth let the
 * slides add 0.05 voxel to the distance (genus 3, 64^3: 0.476 to 0.525 voxel). */
#define VM_GRADED_SURFACE_MOVE 0.1
/* The first pass, surface vertices fixed, runs one round, and only on a mesh with at most
 * one tet in this many (plus 8) outside the dihedral targets: it mends a few tets left here
 * and there (the phantoms: 0 to 1), not the thousands round thin bone (the CT head: 3,513 of
 * 64,881, where it took 8 s and failed). */
#define VM_GRADED_FIXED_PASSES 1
#define VM_GRADED_FIXED_SHARE 100
/* The full pass again, with other seeds for its random moves, while tets stay below: with
 * the boundary triangles' check, and without it. */
#define VM_GRADED_CHORD_RETRIES 1
/* The looser check's surface_chords: the boundary triangles' samples within twice the
 * check's share of surface_tolerance (0.8 voxel at the default tolerance). */
#define VM_GRADED_LOOSE 2
#define VM_GRADED_RETRIES 2
/* The flips and mean sweeps after the pass keep the boundary within this share of the
 * distance bound (both ways, or no farther than it was): with the whole bound they took the
 * 64^3 phantoms from 0.44..0.50 voxel to 0.49..0.4998, against a bound of 0.5. */
#define VM_GRADED_POLISH_SHARE 0.9

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

/* A copy of a mesh's points, tets and regions (the graded mesh before the pass). */
typedef struct snapshot {
    size_t np, nc;
    double *points;
    vm_index *cells;
    int32_t *region;
} snapshot;

static void snap_free(snapshot *q) {
    free(q->points);
    free(q->cells);
    free(q->region);
    *q = (snapshot){0};
}

/* Copies m into q; 0 when out of memory (then q holds nothing). */
static int take(snapshot *q, const vm_mesh *m) {
    q->np = m->npoints;
    q->nc = m->ncells;
    q->points = malloc(3 * q->np * sizeof *q->points + 1);
    q->cells = malloc(4 * q->nc * sizeof *q->cells + 1);
    q->region = m->region ? malloc(q->nc * sizeof *q->region + 1) : NULL;
    if (!q->points || !q->cells || (m->region && !q->region)) {
        snap_free(q);
        return 0;
    }
    memcpy(q->points, m->points, 3 * q->np * sizeof *q->points);
    memcpy(q->cells, m->cells, 4 * q->nc * sizeof *q->cells);
    if (m->region) memcpy(q->region, m->region, q->nc * sizeof *q->region);
    return 1;
}

/* m back to q's copy. */
static vm_status restore(const snapshot *q, vm_mesh *m, vm_error *err) {
    vm_status s = vm_mesh_reserve(m, q->np, q->nc, err);
    if (s) return s;
    memcpy(m->points, q->points, 3 * q->np * sizeof *q->points);
    memcpy(m->cells, q->cells, 4 * q->nc * sizeof *q->cells);
    if (q->region && m->region) memcpy(m->region, q->region, q->nc * sizeof *q->region);
    m->npoints = q->np;
    m->ncells = q->nc;
    return VM_OK;
}

/* How many tets of m are outside o's dihedral targets. */
static size_t count_below(const vm_mesh *m, const vm_improve_options *o) {
    size_t n = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + k], sizeof p[k]);
        if (!(vm_tet_min_dihedral((const double(*)[3])p) >= o->target_min_dihedral) ||
            !(vm_tet_max_dihedral((const double(*)[3])p) <= o->target_max_dihedral))
            n++;
    }
    return n;
}

static int below_targets(const vm_improve_options *o, const vm_improve_report *r) {
    return r->unfixed > 0 || r->min_dihedral_after < o->target_min_dihedral ||
           r->max_dihedral_after > o->target_max_dihedral;
}

/* Runs the pass on m with options t and folds its report into *sum: the input's figures of
 * the first run, the output's of this one, the work of all (*runs counts them). */
static vm_status run_pass(vm_mesh *m, const vm_volume *v, const vm_improve_options *t,
                          vm_improve_report *sum, int *runs, vm_error *err) {
    vm_improve_report one;
    vm_status s = vm_mesh_improve(m, v, t, &one, err);
    if (s) return s;
    if (*runs) {
        one.tets_before = sum->tets_before;
        one.points_before = sum->points_before;
        one.min_dihedral_before = sum->min_dihedral_before;
        one.max_dihedral_before = sum->max_dihedral_before;
        one.slivers_5_before = sum->slivers_5_before;
        one.slivers_10_before = sum->slivers_10_before;
        one.abaqus_before = sum->abaqus_before;
        one.volume_before = sum->volume_before;
        one.max_surface_move += sum->max_surface_move;
        if (sum->max_interface_move > one.max_interface_move)
            one.max_interface_move = sum->max_interface_move;
        one.collapses += sum->collapses;
        one.flips23 += sum->flips23;
        one.flips32 += sum->flips32;
        one.edge_removals += sum->edge_removals;
        one.moves += sum->moves;
        one.perturbations += sum->perturbations;
        one.peels += sum->peels;
        one.boundary_flips += sum->boundary_flips;
        one.passes += sum->passes;
        one.seconds += sum->seconds;
    }
    *sum = one;
    (*runs)++;
    return VM_OK;
}

/* The pass without contraction, surface vertices sliding at most VM_GRADED_SURFACE_MOVE,
 * with the boundary triangles' check or not; *below: tets are still below io's targets. */
static vm_status slide_pass(vm_mesh *m, const vm_volume *v, const vm_improve_options *io,
                            int chords, vm_improve_report *sum, int *runs, int *below,
                            vm_error *err) {
    vm_improve_options t = *io;
    t.contract = 0;
    t.surface_chords = chords;
    if (t.max_surface_move > VM_GRADED_SURFACE_MOVE) t.max_surface_move = VM_GRADED_SURFACE_MOVE;
    vm_status s = run_pass(m, v, &t, sum, runs, err);
    *below = !s && below_targets(io, sum);
    return s;
}

/* The pass with io's options (the check or not), up to n times with seeds io->seed + k while
 * tets stay below the targets (*below). */
static vm_status full_passes(vm_mesh *m, const vm_volume *v, const vm_improve_options *io,
                             int chords, int n, vm_improve_report *sum, int *runs, int *below,
                             vm_error *err) {
    vm_status s = VM_OK;
    for (int k = 0; k < n && !s; k++) {
        vm_improve_options t = *io;
        t.surface_chords = chords;
        t.seed = io->seed + (unsigned)k;
        s = run_pass(m, v, &t, sum, runs, err);
        *below = !s && below_targets(io, sum);
        if (!*below) break;
    }
    return s;
}

static vm_status graded_pass(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                             vm_improve_report *r, vm_error *err) {
    vm_improve_options io;
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
    /* First with every surface vertex where it is (no contraction either): the boundary,
     * and so the distance both ways, stays as coarsening left it. Where that is not enough
     * the mesh goes back to what it was (its points, tets and regions: the graded mesh has
     * no fields yet) and the rungs below run on it: the first pass's moves would otherwise
     * leave them a different mesh to work on (on the CT head, tets the later passes fail).
     * A mesh with fields, or no memory for the copy, gets the last rung alone. */
    snapshot in = {0}, mid = {0};
    int snaps = !m->npoint_fields && !m->ncell_fields && take(&in, m);
    vm_status s = VM_OK;
    if (snaps && count_below(m, &io) <= m->ncells / VM_GRADED_FIXED_SHARE + 8) {
        vm_improve_options t = io;
        t.contract = 0;
        t.max_surface_move = 0;
        if (t.max_passes > VM_GRADED_FIXED_PASSES) t.max_passes = VM_GRADED_FIXED_PASSES;
        vm_improve_report r0;
        s = vm_mesh_improve(m, v, &t, &r0, err);
        if (s || !below_targets(&io, &r0)) {
            snap_free(&in);
            if (r && !s) *r = r0;
            return s;
        }
        s = restore(&in, m, err);
    }
    /* Then the rungs, each only while tets are below the targets: the slide pass and the
     * full passes with the boundary triangles' check; the full passes with the looser check
     * (VM_GRADED_LOOSE), from the slide pass's mesh, then the slide and full passes with it
     * from the input; the full passes without any check, from the slide pass's mesh; and,
     * from the input, both without it (what the pass was before the check: the last resort
     * keeps every mesh that it brought to the targets there). The looser check before none:
     * on the CT head, where the first rungs end below the targets, the passes without a
     * check left the isosurface up to 0.92 voxel from the boundary, where the coarsening
     * left it at 0.77 (docs/SIZING.md). */
    vm_improve_report sum = {0};
    int runs = 0, below = 1;
    if (!s && snaps) {
        s = slide_pass(m, v, &io, 1, &sum, &runs, &below, err);
        if (!s && below) {
            int have_mid = take(&mid, m);
            s = full_passes(m, v, &io, 1, 1 + VM_GRADED_CHORD_RETRIES, &sum, &runs, &below, err);
            if (!s && below && have_mid) {
                s = restore(&mid, m, err);
                if (!s)
                    s = full_passes(m, v, &io, VM_GRADED_LOOSE, 1 + VM_GRADED_CHORD_RETRIES, &sum,
                                    &runs, &below, err);
            }
            if (!s && below) {
                s = restore(&in, m, err);
                if (!s) s = slide_pass(m, v, &io, VM_GRADED_LOOSE, &sum, &runs, &below, err);
                if (!s && below)
                    s = full_passes(m, v, &io, VM_GRADED_LOOSE, 1 + VM_GRADED_CHORD_RETRIES, &sum,
                                    &runs, &below, err);
            }
            if (!s && below && have_mid) {
                s = restore(&mid, m, err);
                if (!s) s = full_passes(m, v, &io, 0, 1 + VM_GRADED_RETRIES, &sum, &runs, &below, err);
            }
            snap_free(&mid);
        }
        if (!s && below) s = restore(&in, m, err);
    }
    if (!s && below) {
        s = slide_pass(m, v, &io, 0, &sum, &runs, &below, err);
        if (!s && below) s = full_passes(m, v, &io, 0, 1 + VM_GRADED_RETRIES, &sum, &runs, &below, err);
    }
    snap_free(&in);
    if (r && runs) *r = sum;
    return s;
}

vm_status vm_mesh_improve_graded(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err) {
    if (o && !(o->distance >= 0.0))
        return vm_error_set(err, VM_ERR_ARG, "improve: targets and bounds must be positive");
    vm_improve_report rr;
    if (r)
        rr = *r;
    else
        memset(&rr, 0, sizeof rr);
    vm_status s = graded_pass(m, v, o, &rr, err);
    /* Then the coarsening's flips and mean sweeps (vm__gr_mean_smooth): the mean of each
     * tet's smallest dihedral angle rises, no tet falls below its star's worst or leaves
     * 15..150 degrees, no star's longest edge grows; the boundary moves and flips within
     * o->distance both ways, or stays where the pass left it without one. */
    vm_improve_options io;
    if (o)
        io = *o;
    else
        vm_improve_options_default(&io);
    size_t moved = 0, flips[4] = {0, 0, 0, 0};
    if (!s && v && m->kind == VM_TET4 && m->ncells && (io.has_lo || io.has_hi) &&
        !m->npoint_fields && !m->ncell_fields)
        s = vm__gr_mean_smooth(m, v, io.lo, io.has_lo, io.hi, io.has_hi, io.max_edge,
                               VM_GRADED_POLISH_SHARE * io.distance, &moved, flips, err);
    if (!s && (moved || flips[0] || flips[1] || flips[2] || flips[3])) {
        vm__imp_figures f;
        s = vm__imp_mesh_figures(m->points, m->cells, m->ncells, io.target_volume_measure, &f);
        if (s) {
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        } else {
            rr.min_dihedral_after = f.dmin;
            rr.max_dihedral_after = f.dmax;
            rr.volume_after = f.volume;
            rr.tets_after = m->ncells;
            rr.points_after = m->npoints;
            rr.moves += moved;
            rr.flips23 += flips[0];
            rr.flips32 += flips[1];
            rr.edge_removals += flips[2];
            rr.boundary_flips += flips[3];
        }
    }
    if (r && !s) *r = rr;
    return s;
}
