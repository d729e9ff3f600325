/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded.c — the graded mesher: an octree sized in world units (distance bound, edge
 * bounds), balanced 2:1, its body-centred lattice, and isosurface stuffing (Labelle and
 * Shewchuk 2007) on the trilinear field; see docs/SIZING.md. */
#include "../core/core.h"
#include "../quality/quality_internal.h"
#include "graded_internal.h"
#include "mesher_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Rounds of measuring and refining after the first mesh. */
#define GR_REFINE_ROUNDS 3
/* A measure after the first looks only within blocks of this many voxels near the leaves
 * split since, GR_REGION_REACH of their edges around them (their parent's neighbours reach
 * two parent edges; the warps of their lattice vertices one more). */
#define GR_REGION_BLOCK 8
#define GR_REGION_REACH 6.0
/* --tets: meshes made again at the tets per leaf the last one showed, when it missed by 10%
 * (coarsening's repair flips and peels take some tets off a stuffed mesh at the count). */
#define GR_TETS_TRIES 3
/* Voxels longer than this ratio one way than another get near-cubic base cells. */
#define GR_ASPECT 3.0

/* The blocks of voxels where a mesh may differ from the one measured before: around the
 * octree nodes made since (index n0 on) and the base cells marked exact since (exact 2,
 * then 1), as far as the lattice tets of their parents' neighbours (up to twice a parent's
 * size) and a warp reach, and the distance bound beyond (a sample farther than that from the
 * change keeps its nearest point). [out] r, r->mask malloc'd. */
static vm_status changed_region(gr_tree *t, const gr_field *f, size_t n0, double D,
                                vm__sd_region *r, vm_error *err) {
    r->block = GR_REGION_BLOCK;
    size_t nb = 1;
    for (int d = 0; d < 3; d++) {
        r->nb[d] = (f->n[d] - 1) / GR_REGION_BLOCK + 1;
        nb *= (size_t)r->nb[d];
    }
    unsigned char *mask = calloc(nb, 1);
    if (!mask) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the distance");
    for (size_t i = 0; i < t->n; i++) {
        gr_node *q = &t->node[i];
        if (i < n0 && q->exact != 2) continue;
        if (q->exact == 2) q->exact = 1;
        int64_t lo[3], hi[3];
        double e = 0;
        for (int d = 0; d < 3; d++)
            e = fmax(e, t->h0[d] * (double)((int64_t)1 << q->level));
        double margin = GR_REGION_REACH * e + D;
        for (int d = 0; d < 3; d++) {
            double a = t->u0[d] + (double)q->a[d] * 0.5 * t->h0[d];
            double b = a + t->h0[d] * (double)((int64_t)1 << q->level);
            double x = floor((a - margin) / f->sp[d] / GR_REGION_BLOCK);
            double y = floor((b + margin) / f->sp[d] / GR_REGION_BLOCK);
            lo[d] = x < 0 ? 0 : x >= (double)r->nb[d] ? r->nb[d] - 1 : (int64_t)x;
            hi[d] = y < 0 ? 0 : y >= (double)r->nb[d] ? r->nb[d] - 1 : (int64_t)y;
        }
        for (int64_t z = lo[2]; z <= hi[2]; z++)
            for (int64_t y = lo[1]; y <= hi[1]; y++)
                memset(mask + (size_t)(lo[0] + r->nb[0] * (y + r->nb[1] * z)), 1,
                       (size_t)(hi[0] - lo[0] + 1));
    }
    r->mask = mask;
    return VM_OK;
}

/* Splits the leaves (above the base level) that hold a sample farther than the bound from
 * the other surface: boundary points of the mesh far from the isosurface, and isosurface
 * points far from the boundary. Measures only around the nodes made since the last measure
 * (*since on; 0: everywhere): elsewhere the mesh is the one measured. [in,out] *since: the
 * tree's node count as measured. [out] *split: leaves split. */
static vm_status refine_far(gr_tree *t, const gr_field *f, const vm_mesh_options *o,
                            const vm_mesh *mesh, const gr_sizing *sz, size_t *since,
                            vm__sd_cache *cache, size_t *split, vm_error *err) {
    double inv[3][3], det, *pts = NULL;
    size_t np = 0;
    vm_surface_distance d;
    vm__sd_region region = {NULL, {0, 0, 0}, 0};
    vm_status s = vm__frame_inverse(f->v, "mesh", inv, &det, err);
    if (!s && *since) s = changed_region(t, f, *since, sz->distance, &region, err);
    if (!s)
        s = vm__surface_distance_region(mesh, f->v, o->lo, o->has_lo, o->hi, o->has_hi,
                                        sz->distance, 0, *since ? &region : NULL, cache, &d,
                                        &pts, &np, err);
    free((void *)region.mask);
    *since = t->n;
    if (s) return s;
    for (size_t i = 0; i < np && !s; i++) {
        double w[3], ijk[3];
        for (int r = 0; r < 3; r++)
            w[r] = pts[3 * i + (size_t)r] - f->v->origin[r];
        for (int r = 0; r < 3; r++)
            ijk[r] = inv[r][0] * w[0] + inv[r][1] * w[1] + inv[r][2] * w[2];
        int64_t p[3];
        for (int r = 0; r < 3; r++)
            p[r] = (int64_t)floor((ijk[r] * f->sp[r] - t->u0[r]) / (0.5 * t->h0[r]));
        /* Down to base cells around the sample: a chord too far from the surface at one
         * size is seldom close enough at the next, and each round costs a whole mesh. */
        int64_t leaf = vm__gr_tree_find(t, p, 0);
        for (; leaf > 0 && t->node[leaf].child < 0 && t->node[leaf].level > 0 && !s;
             leaf = vm__gr_tree_find(t, p, 0)) {
            s = vm__gr_tree_split(t, (size_t)leaf, err);
            ++*split;
        }
        /* A base cell still too far: its warps must keep their other cuts (the stuffing's
         * keeps_cuts; a warp goes up to 0.4 of an edge, and across a one-voxel cavity or
         * thin bone the cut it replaces can be the surface's only point there). */
        if (!s && leaf >= 0 && t->node[leaf].child < 0 && t->node[leaf].level == 0 &&
            !t->node[leaf].exact) {
            t->node[leaf].exact = 2; /* (changed_region takes it as new) */
            ++*split;
        }
    }
    free(pts);
    return s;
}

/* Leaves of the balanced octree at sizes scaled by k. [out] t (freed by the caller). */
static vm_status leaves_at(gr_field *f, const gr_sizing *sz, double k, gr_tree *t,
                           vm_error *err) {
    gr_sizing s2 = *sz;
    s2.distance *= k;
    s2.max_edge *= k;
    f->size_scale = k;
    vm__gr_tree_free(t);
    vm_status s = vm__gr_tree_build(t, f, &s2, err);
    if (!s) s = vm__gr_tree_balance(t, err);
    return s;
}

/* The scale k in [1/64, 64] whose octree gives about `want` tets, by bisection on log k
 * (fewer leaves as k grows), at *per tets per leaf (0: the lattice's tets per leaf at k = 1,
 * returned); sz (at scale 1) and f take the scale found. [out] t: its octree. */
static vm_status search_scale(gr_field *f, gr_sizing *sz, size_t want, int coarsening,
                              double *per, gr_tree *t, vm_error *err) {
    vm_status s = VM_OK;
    if (!(*per > 0)) {
        gr_lattice L;
        memset(&L, 0, sizeof L);
        s = leaves_at(f, sz, 1.0, t, err);
        if (!s) s = vm__gr_lattice_build(&L, t, f, err);
        /* lattice tets per leaf; the stuffing's pieces add some more at the surface */
        *per = s || !t->leaves ? 12.0 : (double)L.nt / (double)t->leaves;
        vm__gr_lattice_free(&L);
    }
    /* the coarsest octree whose stuffed mesh has at least `want` tets (coarsening then
     * takes it down to want), else the nearest */
    double lo = log(1.0 / 64), hi = log(64.0), best = 0, best_err = INFINITY, above = 0,
           above_est = INFINITY;
    for (int it = 0; it < 14 && !s; it++) {
        double lk = 0.5 * (lo + hi);
        if ((s = leaves_at(f, sz, exp(lk), t, err))) break;
        double est = *per * (double)t->leaves, e = fabs(log(est / (double)want));
        if (e < best_err) best_err = e, best = lk;
        if (est >= (double)want && est < above_est) above_est = est, above = lk;
        if (est > (double)want)
            lo = lk;
        else
            hi = lk;
    }
    if (s) return s;
    double k = exp(coarsening && above_est < INFINITY ? above : best);
    sz->distance *= k;
    sz->max_edge *= k;
    gr_sizing one = *sz;
    one.distance /= k;
    one.max_edge /= k;
    return leaves_at(f, &one, k, t, err);
}

/* Adds the seconds since *clk to *acc; *clk becomes now (the --verbose step times). */
static void lap(double *clk, double *acc) {
    double now = vm__now();
    *acc += now - *clk;
    *clk = now;
}

/* A progress call ("mesh", k / (k + 1) of 1) at the k-th step; nonzero: cancelled. */
static int tick(vm__meter *pm, unsigned *k) {
    ++*k;
    return vm__meter_forward("mesh", (double)*k / (*k + 1.0), 1.0, pm);
}

/* Copies the points, cells and regions of a tet mesh. */
static vm_status copy_mesh(const vm_mesh *m, vm_mesh *out, vm_error *err) {
    vm_mesh_init(out, VM_TET4);
    vm_status s = vm_mesh_reserve(out, m->npoints, m->ncells, err);
    if (s) return s;
    memcpy(out->points, m->points, 3 * m->npoints * sizeof *m->points);
    memcpy(out->cells, m->cells, 4 * m->ncells * sizeof *m->cells);
    memcpy(out->region, m->region, m->ncells * sizeof *m->region);
    out->npoints = m->npoints;
    out->ncells = m->ncells;
    return VM_OK;
}

/* Coarsens the stuffed mesh (graded_coarsen.c); should its topology change all the same
 * (the link condition keeps it; this is a second line), the stuffed mesh stays. */
static vm_status coarsen(vm_mesh *mesh, const gr_field *f, const vm_mesh_options *o,
                         const gr_sizing *sz, vm__meter *pm, vm_mesh_stats *st,
                         vm_error *err) {
    long e0 = 0, e1 = 0;
    size_t c0 = 0, c1 = 0, removed = 0;
    vm_mesh keep;
    vm_status s = vm__gr_mesh_topology(mesh, &e0, &c0, NULL, NULL, err);
    if (!s) s = copy_mesh(mesh, &keep, err);
    if (s) return s;
    s = vm__gr_coarsen(mesh, f, sz->distance, sz->max_edge, o->tets, sz->layers <= 1, pm,
                       &removed, err);
    if (!s) s = vm__gr_mesh_topology(mesh, &e1, &c1, NULL, NULL, err);
    if (!s && (e1 != e0 || c1 != c0)) {
        vm_mesh_free(mesh);
        *mesh = keep;
        vm_mesh_init(&keep, VM_TET4);
        removed = 0;
    }
    vm_mesh_free(&keep);
    st->coarsened = removed;
    return s;
}

vm_status vm__mesh_graded(const vm_volume *v, const vm_mesh_options *o, vm_mesh *mesh,
                          vm_mesh_stats *st, vm_error *err) {
    double voxel = fmin(v->spacing[0], fmin(v->spacing[1], v->spacing[2]));
    double vmax = fmax(v->spacing[0], fmax(v->spacing[1], v->spacing[2]));
    gr_sizing sz;
    sz.max_edge = o->max_edge > 0 ? o->max_edge : INFINITY;
    /* Half a voxel; for anisotropic voxels, half the edge of the cube of a voxel's volume. */
    double mean = cbrt(v->spacing[0] * v->spacing[1] * v->spacing[2]);
    sz.distance = o->distance > 0 ? o->distance : 0.5 * mean;
    /* --grading R: sizes double every ceil(ln 2 / ln R) cells (at least one: 2:1) */
    sz.layers = o->grading > 1 && o->grading < 2 ? (int)ceil(log(2.0) / log(o->grading) - 1e-9)
                                                 : 1;
    /* Base cells: voxels, unless --min-edge asks otherwise or the voxels are over 3 times
     * longer one way than another; then each voxel edge is cut into (or, above a voxel,
     * joined from) a whole number of pieces near the asked length, so that base cells are
     * near cubes and voxel points stay lattice points. */
    double want = o->min_edge > 0 ? o->min_edge : vmax > GR_ASPECT * voxel ? voxel : 0;
    if (want > sz.max_edge) want = sz.max_edge;
    for (int d = 0; d < 3; d++) {
        double sp = v->spacing[d];
        if (want <= 0)
            sz.h0[d] = sp;
        else if (want < sp)
            sz.h0[d] = sp / fmax(1, floor(sp / want + 0.5));
        else
            sz.h0[d] = sp * fmax(1, floor(want / sp + 0.5));
    }
    gr_field f;
    gr_tree t;
    gr_lattice L;
    gr_stuff_work work; /* the stuffing's buffers (one round's) */
    memset(&t, 0, sizeof t);
    memset(&L, 0, sizeof L);
    memset(&work, 0, sizeof work);
    vm_status s = vm__gr_field_init(&f, v, o, err);
    if (s) return s;
    /* the caller's progress, polled for cancellation between and inside the stages */
    vm__meter pm;
    vm__meter_wrap(&pm, o->progress, o->progress_user, "mesh", 1.0);
    unsigned ticks = 0;
    /* --tets N: the size scale k (multiplying the distance bound, the edge bound and the size
     * field) whose octree gives about N tets, at the tets per leaf of a first mesh. */
    int measured = 1, corrected = 0;
    double d0 = sz.distance, per = 0;
    gr_sizing sz1 = sz;
    double clk = vm__now();
    if (o->tets > 0) {
        s = search_scale(&f, &sz, o->tets, !o->no_coarsen, &per, &t, err);
        measured = 0; /* the count asked for wins over the distance */
    } else if (!(s = vm__gr_tree_build(&t, &f, &sz, err))) {
        s = vm__gr_tree_balance(&t, err);
    }
    lap(&clk, &st->graded_octree_s);
    gr_stuff_stats ss;
    memset(&ss, 0, sizeof ss);
    /* The topology the mesh must have: the voxels' as dual contouring reads them. */
    long want_euler = 0;
    size_t want_comps = 0;
    if (!s) s = vm__gr_digital_topology(&f, &want_euler, &want_comps, err);
    lap(&clk, &st->graded_topology_s);
    /* Mesh; where the topology of the first mesh differs (the octree's tests are local and
     * sufficient only where the field is smooth), split every crossed leaf a level and mesh
     * again. Then measure the distance both ways and refine the leaves where it is over the
     * bound, until it holds (or only base cells are left there); a refinement that changes
     * the topology is undone, and the last mesh with the right topology stays. */
    vm_mesh good;
    vm_mesh_init(&good, VM_TET4);
    gr_node *saved = NULL;
    size_t saved_n = 0, saved_leaves = 0, measured_n = 0;
    vm__sd_cache samples; /* the isosurface's samples, for every round's measure */
    memset(&samples, 0, sizeof samples);
    for (int round = 0; !s;) {
        if (tick(&pm, &ticks)) {
            s = vm__cancelled(err, "mesh");
            break;
        }
        vm_mesh_free(mesh);
        vm_mesh_init(mesh, VM_TET4);
        st->graded_meshes++;
        s = vm__gr_lattice_build(&L, &t, &f, err);
        lap(&clk, &st->graded_lattice_s);
        if (!s) s = vm__gr_stuff(&L, &t, &f, mesh, &ss, &work, err);
        /* Given back at once: kept for the next round, they stayed resident through the
         * topology count and the distance measure (1 GB more at the organ's peak, for no
         * measurable gain in system time). */
        vm__gr_lattice_free(&L);
        vm__gr_stuff_work_free(&work);
        lap(&clk, &st->graded_stuff_s);
        long euler = 0;
        size_t comps = 0, split = 0;
        if (!s) s = vm__gr_mesh_topology(mesh, &euler, &comps, NULL, NULL, err);
        lap(&clk, &st->graded_topology_s);
        if (s) break;
        if (euler != want_euler || comps != want_comps) {
            if (round > 0) { /* undo the last refinement */
                vm_mesh_free(mesh);
                *mesh = good;
                vm_mesh_init(&good, VM_TET4);
                memcpy(t.node, saved, saved_n * sizeof *saved);
                t.n = saved_n;
                t.leaves = saved_leaves;
                st->refine_rounds--;
                st->refine_undone = 1;
                break;
            }
            /* where the parts that differ are (the whole surface when none is found) */
            double *boxes = NULL;
            size_t nb = 0;
            s = vm__gr_topology_misfits(&f, mesh, &boxes, &nb, err);
            if (!s) s = vm__gr_tree_refine_crossed(&t, &f, nb ? boxes : NULL, nb, &split, err);
            if (!s && !split && nb) s = vm__gr_tree_refine_crossed(&t, &f, NULL, 0, &split, err);
            free(boxes);
            if (s || !split) break;
            st->topology_rounds++;
        } else if (!measured) {
            /* --tets: again at the tets per leaf this mesh shows, when 10% off */
            double got = (double)mesh->ncells, asked = (double)o->tets;
            /* (with coarsening, a mesh over the count is taken down to it) */
            if (corrected == GR_TETS_TRIES || !t.leaves ||
                (o->no_coarsen ? fabs(got / asked - 1) <= 0.1 : got >= 0.9 * asked))
                break;
            corrected++;
            per = got / (double)t.leaves;
            sz = sz1;
            if ((s = search_scale(&f, &sz, o->tets, !o->no_coarsen, &per, &t, err))) break;
            continue;
        } else {
            if (round == GR_REFINE_ROUNDS) break;
            /* keep this mesh and its tree until the refinement proves its topology */
            gr_node *ns = realloc(saved, t.n * sizeof *ns);
            if (!ns) {
                s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
                break;
            }
            saved = ns;
            memcpy(saved, t.node, t.n * sizeof *saved);
            saved_n = t.n;
            saved_leaves = t.leaves;
            /* the whole mesh when the stuffing had to drop every warp (its last resort) */
            if (ss.no_warps) measured_n = 0;
            s = refine_far(&t, &f, o, mesh, &sz, &measured_n, &samples, &split, err);
            lap(&clk, &st->graded_distance_s);
            if (s || !split) break;
            vm_mesh_free(&good);
            good = *mesh;
            vm_mesh_init(mesh, VM_TET4);
            st->refine_rounds = (size_t)++round;
        }
        s = vm__gr_tree_balance(&t, err);
        lap(&clk, &st->graded_octree_s);
    }
    free(saved);
    vm__sd_cache_free(&samples);
    vm__gr_lattice_free(&L);
    vm__gr_stuff_work_free(&work);
    vm_mesh_free(&good);
    if (!s && tick(&pm, &ticks)) s = vm__cancelled(err, "mesh");
    lap(&clk, &st->graded_octree_s);
    if (!s && !o->no_coarsen && mesh->ncells) s = coarsen(mesh, &f, o, &sz, &pm, st, err);
    lap(&clk, &st->graded_coarsen_s);
    if (!s && tick(&pm, &ticks)) s = vm__cancelled(err, "mesh");
    st->size_scale = sz.distance / d0;
    st->distance = sz.distance;
    st->octree_leaves = t.leaves;
    st->warped_vertices = ss.warped;
    st->surface_vertices = ss.cut_vertices + ss.warped;
    vm__gr_tree_free(&t);
    vm__gr_field_free(&f);
    if (!s && mesh->ncells == 0)
        s = vm_error_set(err, VM_ERR_EMPTY, "mesh: the material holds no element");
    if (!s && vm__meter_poll(&pm)) s = vm__cancelled(err, "mesh");
    if (s == VM_ERR_CANCELLED) vm_mesh_free(mesh);
    return s;
}
