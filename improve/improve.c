/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve.c — the quality-improvement pass: rounds of edge contraction (seed 001 §6),
 * flips, optimisation-based smoothing and random perturbation over the tets below the targets
 * (schedule after Klingner and Shewchuk 2007, "Aggressive tetrahedral mesh improvement"). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "improve_internal.h"
#include "volmesh/quality.h"
#include "../quality/tet_internal.h"
#include "../core/vec3.h"

/* The defaults volmesh/improve.h documents (every other field 0 or NULL). */
static const vm_improve_options improve_defaults = {
    .lo = 0.0,
    .hi = 0.0,
    .has_lo = 1,
    .has_hi = 0,
    .max_surface_move = 0.8,
    .max_surface_move_free = 0.1,
    .max_interface_move = 0.1,
    .surface_tolerance = 0.5,
    .surface_band = 0.3,
    .target_min_dihedral = 15.0,
    .target_max_dihedral = 150.0,
    .target_volume_measure = 0.03,
    .max_edge = 0.0,
    .max_passes = 12,
    .contract = 1,
    .flip = 1,
    .smooth = 1,
    .perturb = 1,
    .seed = 1,
    .mark_unfixed = 0,
};

void vm_improve_options_default(vm_improve_options *o) {
    memset(o, 0, sizeof *o);
    *o = improve_defaults;
}

/* --- whole-mesh figures ------------------------------------------------------------------ */

typedef vm__imp_figures figures;

/* Sliver counts: tets whose smallest dihedral is below 5 and below 10 degrees. */
#define SLIVER_5 5.0
#define SLIVER_10 10.0
/* A tet still counts as unfixed with a dihedral below SLIVER_10 or above this, as with a
 * failed ABAQUS check or no volume. */
#define UNFIXED_MAX_DIHEDRAL 165.0

/* 1 when the tet fails the ABAQUS check or the bar; *abaqus tells whether it fails ABAQUS's. */
static int tet_figures(const double p[4][3], double vm_target, figures *f, int *abaqus) {
    double lo = vm_tet_min_dihedral(p), hi = vm_tet_max_dihedral(p);
    double vol = vm_tet_signed_volume(p), vm = vm__imp_volume_measure(p);
    f->vm_low += vm < vm_target;
    if (lo < f->dmin) f->dmin = lo;
    if (hi > f->dmax) f->dmax = hi;
    f->volume += vol;
    f->s5 += lo < SLIVER_5;
    f->s10 += lo < SLIVER_10;
    f->inverted += !(vol > 0.0);
    /* ABAQUS's element check, as the quality report counts it */
    double fa_lo, fa_hi;
    vm__tet_face_angle_range(p, &fa_lo, &fa_hi);
    *abaqus = vm__tet_abaqus_fails(vm, fa_lo, fa_hi) != 0;
    f->abaqus += (size_t)*abaqus;
    int bad = *abaqus || lo < SLIVER_10 || hi > UNFIXED_MAX_DIHEDRAL || !(vol > 0.0);
    f->unfixed += (size_t)bad;
    return bad;
}

/* The cosines of the thresholds above (the face angles': VM__ABAQUS_COS_*); a cosine this
 * close to one takes the exact path. */
#define COS5 0.9961946980917455
#define COS10 0.984807753012208
#define COS165 (-0.9659258262890682)
#define FIG_EPS 1e-9
/* A tet with 6 V below this times its longest edge cubed is measured exactly (its cosines
 * are not trusted). */
#define FIG_FLAT 1e-11
#define FIG_DEG (180.0 / 3.14159265358979323846)

static int near_cos(double c, double ref) { return fabs(c - ref) < FIG_EPS; }

/* The figures of tets [t0, t1): the same counts and extremes as tet_figures over each of them,
 * but the thresholds compared on cosines (no atan2) wherever a cosine is clearly on one side;
 * the extremes are measured exactly only for the tets that may hold them. */
/* below (when not NULL): per tet, 1 when its quality is below 1 (below->w's scales), told on
 * the cosines measured here as vm__imp_quality_above tells it. */
typedef struct below_out {
    const vm__imp *w;
    const vm__imp_bar *one; /* the bar just under 1: above it is q >= 1 */
    uint8_t *flag;
} below_out;

static void chunk_figures(const double *pts, const vm_index *cells, size_t t0, size_t t1,
                          double vm_target, figures *f, double *unfixed_field,
                          const below_out *below) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    memset(f, 0, sizeof *f);
    f->dmin = 180.0;
    f->dmax = 0.0;
    double cdmin = -1.0, cdmax = 1.0; /* cosines of f->dmin and f->dmax */
    for (size_t t = t0; t < t1; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++) memcpy(p[k], pts + 3 * (size_t)cells[4 * t + k], sizeof p[k]);
        const double(*cp)[3] = (const double(*)[3])p;
        double vol = vm_tet_signed_volume(cp), el[4][4], lmax2 = 0.0;
        for (int i = 0; i < 4; i++)
            for (int j = i + 1; j < 4; j++) {
                double e[3] = {p[j][0] - p[i][0], p[j][1] - p[i][1], p[j][2] - p[i][2]};
                double l2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
                if (l2 > lmax2) lmax2 = l2;
                el[i][j] = el[j][i] = sqrt(l2);
            }
        int exact = !isfinite(vol) || !isfinite(lmax2) ||
                    !(6.0 * vol > FIG_FLAT * lmax2 * sqrt(lmax2));
        double cmax = -2.0, cmin = 2.0, fcmax = -2.0, fcmin = 2.0, n[4][3], dc[6];
        if (!exact) {
            double len[4];
            for (int g = 0; g < 4; g++) {
                double u[3], w[3];
                vm__sub3(p[fo[g][1]], p[fo[g][0]], u);
                vm__sub3(p[fo[g][2]], p[fo[g][0]], w);
                vm__cross3(u, w, n[g]);
                len[g] = sqrt(vm__dot3(n[g], n[g]));
                for (int k = 0; k < 3; k++) {
                    int o = fo[g][k], i = fo[g][(k + 1) % 3], j = fo[g][(k + 2) % 3];
                    vm__sub3(p[i], p[o], u);
                    vm__sub3(p[j], p[o], w);
                    double cs = vm__dot3(u, w) / (el[o][i] * el[o][j]);
                    if (cs > fcmax) fcmax = cs;
                    if (cs < fcmin) fcmin = cs;
                }
            }
            for (int g = 0, k = 0; g < 4; g++)
                for (int h = g + 1; h < 4; h++, k++) {
                    double cs = -vm__dot3(n[g], n[h]) / (len[g] * len[h]);
                    dc[k] = cs;
                    if (cs > cmax) cmax = cs;
                    if (cs < cmin) cmin = cs;
                }
            exact = !isfinite(cmax) || !isfinite(cmin) || !isfinite(fcmax) ||
                    !isfinite(fcmin) || near_cos(cmax, COS5) || near_cos(cmax, COS10) ||
                    near_cos(cmin, COS165) ||
                    near_cos(fcmax, VM__ABAQUS_COS_SMALL_FACE_ANGLE) ||
                    near_cos(fcmin, VM__ABAQUS_COS_LARGE_FACE_ANGLE);
        }
        /* the volume measure, when the cosines are trusted (both tests below read it) */
        double vmq = exact ? 0.0 : vm__imp_volume_measure(cp);
        if (below) {
            /* the cosine tests of vm__imp_quality_above on the cosines above (the same
             * formulas); the quality itself when the tet is flat or a cosine is near */
            const vm__imp_bar *b = below->one;
            int fast = !exact && b->fast;
            int s1 = fast ? vm__imp_cos_side(cmax, b->c_dmin) : 0,
                s2 = fast ? -vm__imp_cos_side(cmin, b->c_dmax) : 0,
                s4 = fast ? vm__imp_cos_side(fcmax, b->c_fmin) : 0,
                s5 = fast ? -vm__imp_cos_side(fcmin, b->c_fmax) : 0;
            int above;
            if (fast && (s1 < 0 || s2 < 0 || s4 < 0 || s5 < 0 ||
                         !(vmq / below->w->s_vm > b->f)))
                above = 0;
            else if (fast && s1 > 0 && s2 > 0 && s4 > 0 && s5 > 0)
                above = 1;
            else
                above = vm__imp_quality_above(below->w, cp, b);
            below->flag[t] = (uint8_t)!above;
        }
        int bad;
        if (exact) {
            int ab;
            bad = tet_figures(cp, vm_target, f, &ab);
            cdmin = cos(f->dmin / FIG_DEG);
            cdmax = cos(f->dmax / FIG_DEG);
        } else {
            /* here vol > 0 */
            f->volume += vol;
            f->vm_low += vmq < vm_target;
            f->s5 += cmax > COS5;
            f->s10 += cmax > COS10;
            /* ABAQUS's check (vm__tet_abaqus_fails) on the face angles' cosines */
            int ab = vmq < VM__ABAQUS_VOLUME_MEASURE ||
                     fcmax > VM__ABAQUS_COS_SMALL_FACE_ANGLE ||
                     fcmin < VM__ABAQUS_COS_LARGE_FACE_ANGLE;
            f->abaqus += (size_t)ab;
            bad = ab || cmax > COS10 || cmin < COS165;
            f->unfixed += (size_t)bad;
            /* Only the dihedrals that may be the chunk's extremes, measured as
             * vm_tet_min_dihedral and vm_tet_max_dihedral measure them. */
            if (cmax > cdmin - FIG_EPS || cmin < cdmax + FIG_EPS)
                for (int g = 0, k = 0; g < 4; g++)
                    for (int h = g + 1; h < 4; h++, k++) {
                        if (!(dc[k] > cdmin - FIG_EPS) && !(dc[k] < cdmax + FIG_EPS)) continue;
                        double ng[3] = {-n[h][0], -n[h][1], -n[h][2]};
                        double a = vm__angle_deg(n[g], ng);
                        if (a < f->dmin) {
                            f->dmin = a;
                            cdmin = cos(a / FIG_DEG);
                        }
                        if (a > f->dmax) {
                            f->dmax = a;
                            cdmax = cos(a / FIG_DEG);
                        }
                    }
        }
        if (unfixed_field) unfixed_field[t] = bad;
    }
}

/* Fixed chunks summed in their order: the same figures for any thread count. */
#define FIG_CHUNK ((size_t)1 << 15)

static vm_status mesh_figures(const double *pts, const vm_index *cells, size_t n,
                              double vm_target, figures *f, double *unfixed_field,
                              const below_out *below, vm__meter *pm) {
    size_t nc = (n + FIG_CHUNK - 1) / FIG_CHUNK;
    figures *part = malloc((nc ? nc : 1) * sizeof *part);
    if (!part) return VM_ERR_NOMEM;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (size_t c = 0; c < nc; c++) {
        size_t t1 = (c + 1) * FIG_CHUNK < n ? (c + 1) * FIG_CHUNK : n;
        if (vm__progress_poll_team(vm__meter_forward, pm)) continue; /* cancelled */
        chunk_figures(pts, cells, c * FIG_CHUNK, t1, vm_target, &part[c], unfixed_field, below);
    }
    if (vm__meter_stopped(pm)) {
        free(part);
        return VM_ERR_CANCELLED;
    }
    memset(f, 0, sizeof *f);
    f->dmin = 180.0;
    f->dmax = 0.0;
    for (size_t c = 0; c < nc; c++) {
        const figures *g = &part[c];
        if (g->dmin < f->dmin) f->dmin = g->dmin;
        if (g->dmax > f->dmax) f->dmax = g->dmax;
        f->volume += g->volume;
        f->s5 += g->s5;
        f->s10 += g->s10;
        f->abaqus += g->abaqus;
        f->inverted += g->inverted;
        f->unfixed += g->unfixed;
        f->vm_low += g->vm_low;
    }
    free(part);
    return VM_OK;
}

vm_status vm__imp_mesh_figures(const double *pts, const vm_index *cells, size_t n,
                               double vm_target, vm__imp_figures *f) {
    vm__meter pm;
    vm__meter_wrap(&pm, NULL, NULL, "improve", 1.0);
    return mesh_figures(pts, cells, n, vm_target, f, NULL, NULL, &pm);
}

/* --- writing back ------------------------------------------------------------------------- */

static vm_status write_back(vm__imp *w, vm_mesh *m, const vm_improve_options *o,
                            vm_error *err) {
    size_t nt = 0, np = 0;
    vm_index *map = malloc((w->npt + 1) * sizeof *map);
    if (!map) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t i = 0; i < w->npt; i++) map[i] = -1;
    for (size_t t = 0; t < w->ntet; t++) {
        if (w->dead[t]) continue;
        nt++;
        for (int k = 0; k < 4; k++) {
            vm_index a = w->tet[4 * t + k];
            if (map[a] < 0) map[a] = 0;
        }
    }
    /* Points keep their input order. */
    for (size_t i = 0; i < w->npt; i++)
        if (map[i] >= 0) map[i] = (vm_index)np++;
    vm_index *par = m->ncell_fields ? malloc((nt + 1) * sizeof *par) : NULL;
    size_t npf = m->npoint_fields;
    double **pf_new = calloc(npf + 1, sizeof *pf_new);
    double **cf_new = calloc(m->ncell_fields + 1, sizeof *cf_new);
    int fail = (m->ncell_fields && !par) || !cf_new || !pf_new;
    for (size_t f = 0; f < npf; f++) {
        pf_new[f] = fail ? NULL : malloc((np + 1) * (size_t)m->point_fields[f].ncomp * sizeof(double));
        if (!pf_new[f]) fail = 1;
    }
    for (size_t f = 0; !fail && f < m->ncell_fields; f++) {
        cf_new[f] = malloc((nt + 1) * (size_t)m->cell_fields[f].ncomp * sizeof(double));
        if (!cf_new[f]) fail = 1;
    }
    if (!fail && vm_mesh_reserve(m, np, nt, err) != VM_OK) fail = 2;
    if (fail) {
        if (pf_new)
            for (size_t f = 0; f < npf; f++) free(pf_new[f]);
        free(pf_new);
        free(map);
        free(par);
        if (cf_new)
            for (size_t f = 0; f < m->ncell_fields; f++) free(cf_new[f]);
        free(cf_new);
        return fail == 2 ? err->status
                         : vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t f = 0; f < npf; f++) {
        int nc = m->point_fields[f].ncomp;
        for (size_t i = 0; i < w->npt; i++)
            if (map[i] >= 0)
                memcpy(pf_new[f] + (size_t)map[i] * (size_t)nc,
                       m->point_fields[f].data + i * (size_t)nc, (size_t)nc * sizeof(double));
        free(m->point_fields[f].data);
        m->point_fields[f].data = pf_new[f];
    }
    for (size_t i = 0; i < w->npt; i++)
        if (map[i] >= 0) memcpy(m->points + 3 * (size_t)map[i], w->p + 3 * i, 3 * sizeof(double));
    size_t c = 0;
    for (size_t t = 0; t < w->ntet; t++) {
        if (w->dead[t]) continue;
        for (int k = 0; k < 4; k++) m->cells[4 * c + k] = map[w->tet[4 * t + k]];
        m->region[c] = w->region[t];
        if (par) par[c] = w->parent[t];
        c++;
    }
    for (size_t f = 0; f < m->ncell_fields; f++) {
        int nc = m->cell_fields[f].ncomp;
        for (size_t i = 0; i < nt; i++)
            memcpy(cf_new[f] + i * (size_t)nc, m->cell_fields[f].data + (size_t)par[i] * (size_t)nc,
                   (size_t)nc * sizeof(double));
        free(m->cell_fields[f].data);
        m->cell_fields[f].data = cf_new[f];
    }
    m->npoints = np;
    m->ncells = nt;
    free(cf_new);
    free(pf_new);
    free(par);
    free(map);
    (void)o;
    return VM_OK;
}

/* The pass over the whole mesh at once (the only way before parts). */
static vm_status one_pass(vm__imp *w, vm_mesh *m, const vm_volume *v,
                          const vm_improve_options *o, int *passes, double *maxmove,
                          double *maxiface, vm_error *err) {
    vm_status s = vm__imp_run(w, m, v, o, NULL, passes, maxmove, maxiface, err);
    return s == VM_OK ? write_back(w, m, o, err) : s;
}

/* The one pass over a volume given by its planes: reads them all first. */
static vm_status one_pass_planes(vm__imp *w, vm_mesh *m, const vm_volume *info,
                                 vm_plane_source src, void *user, const vm_improve_options *o,
                                 int *passes, double *maxmove, double *maxiface,
                                 vm_error *err) {
    vm_volume whole = *info;
    vm_status s = vm__imp_read_planes(info, src, user, 0, info->dims[2], &whole.data, err);
    if (s == VM_OK) s = one_pass(w, m, &whole, o, passes, maxmove, maxiface, err);
    free(whole.data);
    return s;
}

/* The pass's arguments: a tet4 mesh with cells whose nodes are in range, positive targets
 * and bounds, and material bounds with a volume. */
static vm_status check_args(const vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                            vm_error *err) {
    if (m->kind != VM_TET4)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "improve: only tet4 meshes can be improved, not %s",
                            vm_cell_kind_name(m->kind));
    if (m->ncells == 0)
        return vm_error_set(err, VM_ERR_EMPTY, "improve: the mesh has no cells");
    if (!(o->target_min_dihedral > 0.0) || !(o->target_max_dihedral < 180.0) ||
        !(o->target_volume_measure > 0.0) || !(o->max_surface_move >= 0.0) ||
        !(o->max_surface_move_free >= 0.0) || !(o->max_interface_move >= 0.0) ||
        !(o->surface_band >= 0.0) || o->surface_chords < 0 || !(o->distance >= 0.0) ||
        !(o->surface_tolerance >= o->surface_band))
        return vm_error_set(err, VM_ERR_ARG, "improve: targets and bounds must be positive");
    if (v && !o->has_lo && !o->has_hi)
        return vm_error_set(err, VM_ERR_ARG, "improve: a volume needs lo or hi material bounds");
    return vm__check_nodes(m, VM_ERR_ARG, "improve", err);
}

/* The operation counters of run w, into the same fields of c. */
static void counters_of(const vm__imp *w, vm_improve_report *c) {
    c->collapses = w->collapses;
    c->flips23 = w->flips23;
    c->flips32 = w->flips32;
    c->edge_removals = w->edge_removals;
    c->moves = w->moves;
    c->perturbations = w->perturbations;
    c->peels = w->peels;
    c->boundary_flips = w->boundary_flips;
}

/* The figures after the pass (fa) and, with o->mark_unfixed, the cell field of the tets
 * still unfixed. */
static vm_status figures_after(vm_mesh *m, const vm_improve_options *o, figures *fa,
                               vm__meter *pm, vm_error *err) {
    vm_status s = VM_OK;
    double *uf = NULL;
    if (o->mark_unfixed) {
        uf = malloc((m->ncells + 1) * sizeof *uf);
        if (!uf) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    if (s == VM_OK) s = mesh_figures(m->points, m->cells, m->ncells, 0.0, fa, uf, NULL, pm);
    if (s == VM_ERR_CANCELLED) s = vm__cancelled(err, "improve");
    if (s == VM_ERR_NOMEM) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    if (uf && s == VM_OK) s = vm_mesh_set_field(m, 1, "improve_unfixed", 1, uf, err);
    free(uf);
    return s;
}

/* The report: sizes before (nt0 tets, np0 points) and after (m), figures before (fb) and
 * after (fa), and the run's counters, passes and moves (c). */
static void fill_report(vm_improve_report *r, const vm_improve_report *c, const figures *fb,
                        const figures *fa, size_t nt0, size_t np0, const vm_mesh *m) {
    *r = (vm_improve_report){.tets_before = nt0,
                             .points_before = np0,
                             .min_dihedral_before = fb->dmin,
                             .max_dihedral_before = fb->dmax,
                             .slivers_5_before = fb->s5,
                             .slivers_10_before = fb->s10,
                             .abaqus_before = fb->abaqus,
                             .volume_before = fb->volume,
                             .min_dihedral_after = fa->dmin,
                             .max_dihedral_after = fa->dmax,
                             .slivers_5_after = fa->s5,
                             .slivers_10_after = fa->s10,
                             .abaqus_after = fa->abaqus,
                             .inverted_after = fa->inverted,
                             .unfixed = fa->unfixed,
                             .volume_after = fa->volume,
                             .max_surface_move = c->max_surface_move,
                             .max_interface_move = c->max_interface_move,
                             .collapses = c->collapses,
                             .flips23 = c->flips23,
                             .flips32 = c->flips32,
                             .edge_removals = c->edge_removals,
                             .moves = c->moves,
                             .perturbations = c->perturbations,
                             .peels = c->peels,
                             .boundary_flips = c->boundary_flips,
                             .passes = c->passes,
                             .tets_after = m->ncells,
                             .points_after = m->npoints};
}

/* vm_mesh_improve, with the volume in memory (src NULL) or given by its planes (v: its dims
 * and geometry). */
static vm_status improve(vm_mesh *m, const vm_volume *v, vm_plane_source src, void *user,
                         const vm_improve_options *o, vm_improve_report *r, vm_error *err) {
    double t0 = vm__now();
    vm_improve_options def;
    if (!o) {
        vm_improve_options_default(&def);
        o = &def;
    }
    vm_status s = check_args(m, v, o, err);
    if (s != VM_OK) return s;
    /* the caller's progress, forwarded through a meter that the stages below poll */
    vm__meter pm;
    vm__meter_wrap(&pm, o->progress, o->progress_user, "improve", 1.0);
    vm_improve_options wo = *o;
    if (o->progress) {
        wo.progress = vm__meter_forward;
        wo.progress_user = &pm;
    }
    o = &wo;
    /* the local pass starts from the tets below the targets: told in the same sweep */
    size_t nparts = vm__imp_parts_count(m, o);
    vm__imp qw;
    memset(&qw, 0, sizeof qw);
    vm__imp_scales(&qw, o);
    vm__imp_bar one;
    vm__imp_bar_set(&qw, nextafter(1.0, 0.0), &one);
    below_out bo = {&qw, &one, nparts == 0 ? malloc(m->ncells + 1) : NULL};
    if (nparts == 0 && !bo.flag) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    figures fb;
    s = mesh_figures(m->points, m->cells, m->ncells, 0.0, &fb, NULL,
                     nparts == 0 ? &bo : NULL, &pm);
    if (s != VM_OK) {
        free(bo.flag);
        return s == VM_ERR_CANCELLED ? vm__cancelled(err, "improve")
                                     : vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    if (fb.inverted) {
        free(bo.flag);
        return vm_error_set(err, VM_ERR_ARG, "improve: %zu tets are inverted or flat",
                            fb.inverted);
    }
    vm__imp_show(o, 0.1 * VM__IMP_SETUP_SHARE);
    if (vm__meter_stopped(&pm)) {
        free(bo.flag);
        return vm__cancelled(err, "improve");
    }
    size_t nt0 = m->ncells, np0 = m->npoints;
    vm__imp w;
    memset(&w, 0, sizeof w);
    vm_improve_report c; /* the run's counters, passes and moves */
    memset(&c, 0, sizeof c);
    if (nparts == 0) {
        s = vm__imp_local_run(m, v, src, user, o, bo.flag, &c, err);
        free(bo.flag);
        bo.flag = NULL;
        vm__imp_show(o, 1.0 - VM__IMP_FINAL_SHARE);
    } else if (nparts > 1) {
        s = vm__imp_parts_run(m, v, src, user, o, nparts, &c, err);
        vm__imp_show(o, 1.0 - VM__IMP_FINAL_SHARE);
    } else {
        if (src)
            s = one_pass_planes(&w, m, v, src, user, o, &c.passes, &c.max_surface_move,
                                &c.max_interface_move, err);
        else
            s = one_pass(&w, m, v, o, &c.passes, &c.max_surface_move, &c.max_interface_move,
                         err);
        counters_of(&w, &c);
    }
    /* (a stage may have gone on after a request it did not read) */
    if (s == VM_OK && vm__meter_stopped(&pm)) s = vm__cancelled(err, "improve");
    figures fa;
    memset(&fa, 0, sizeof fa);
    if (s == VM_OK) s = figures_after(m, o, &fa, &pm, err);
    if (r) {
        fill_report(r, &c, &fb, &fa, nt0, np0, m);
        r->seconds = vm__now() - t0;
    }
    vm__imp_free(&w);
    if (s != VM_ERR_CANCELLED) vm__imp_show(o, 1.0);
    if (s == VM_OK && vm__meter_stopped(&pm)) s = vm__cancelled(err, "improve");
    return s;
}

vm_status vm_mesh_improve(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                          vm_improve_report *r, vm_error *err) {
    return improve(m, v, NULL, NULL, o, r, err);
}

vm_status vm_mesh_improve_planes(vm_mesh *m, const vm_volume *info, vm_plane_source source,
                                 void *source_user, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err) {
    if (!info || !source)
        return vm_error_set(err, VM_ERR_ARG, "improve: a plane source needs the volume's info");
    if (info->dims[0] < 1 || info->dims[1] < 1 || info->dims[2] < 1)
        return vm_error_set(err, VM_ERR_ARG, "improve: the volume has no voxels");
    return improve(m, info, source, source_user, o, r, err);
}
