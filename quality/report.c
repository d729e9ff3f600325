/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/report.c — the quality report over a mesh: metric tables, per-metric statistics and
 * histograms, the ABAQUS element check, text/JSON/SVG/CSV output and per-cell quality fields.
 * Metric definitions and ranges: Verdict manual (SAND2007-1751); the ABAQUS thresholds are
 * those of ABAQUS/CAE's "Verify Mesh" for tetrahedra. */
#include "../core/core.h"
#include "../io/io_util.h"
#include "volmesh/quality.h"
#include "tet_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- metric tables ---------------------------------------------------------------------- */

#define INF INFINITY
#define M(name, label, unit, kind, fn, ideal, alo, ahi, flo, fhi, hlo, hhi)                 \
    { name, label, unit, kind, (vm_metric_fn)fn, ideal, alo, ahi, flo, fhi, hlo, hhi }

/* Histogram ranges are fixed where the metric has a natural scale, so that histograms of
 * different meshes compare; volume and Jacobian use the data's own range (hlo == hhi). */
static const vm_metric_info tet_metrics[] = {
    M("min_dihedral", "minimum dihedral angle", "deg", VM_TET4, vm_tet_min_dihedral,
      70.528779, 40.0, 70.528780, 0.0, 70.528780, 0.0, 80.0),
    M("max_dihedral", "maximum dihedral angle", "deg", VM_TET4, vm_tet_max_dihedral,
      70.528779, 70.528779, 165.0, 70.528779, 180.0, 60.0, 180.0),
    M("min_face_angle", "minimum face angle", "deg", VM_TET4, vm_tet_min_face_angle, 60.0,
      VM__ABAQUS_SMALL_FACE_ANGLE, 60.0, 0.0, 60.0, 0.0, 60.0),
    M("max_face_angle", "maximum face angle", "deg", VM_TET4, vm_tet_max_face_angle, 60.0,
      60.0, VM__ABAQUS_LARGE_FACE_ANGLE, 60.0, 180.0, 60.0, 180.0),
    M("radius_ratio", "radius ratio R/(3r)", "", VM_TET4, vm_tet_radius_ratio, 1.0, 1.0, 3.0,
      1.0, INF, 1.0, 5.0),
    M("aspect_ratio", "aspect ratio hmax/(2 sqrt6 r)", "", VM_TET4, vm_tet_aspect_ratio, 1.0,
      1.0, 3.0, 1.0, INF, 1.0, 5.0),
    M("edge_ratio", "edge ratio hmax/hmin", "", VM_TET4, vm_tet_edge_ratio, 1.0, 1.0, 3.0, 1.0,
      INF, 1.0, 5.0),
    M("scaled_jacobian", "scaled Jacobian", "", VM_TET4, vm_tet_scaled_jacobian, 1.0, 0.5, 1.0,
      -1.0, 1.0, -1.0, 1.0),
    M("volume_measure", "ABAQUS volume measure", "", VM_TET4, vm_tet_volume_measure, 1.0,
      VM__ABAQUS_VOLUME_MEASURE, 1.0, -1.0, 1.0, 0.0, 1.0),
    M("volume", "signed volume", "", VM_TET4, vm_tet_signed_volume, NAN, 0.0, INF, -INF, INF,
      0.0, 0.0),
};

static const vm_metric_info hex_metrics[] = {
    M("scaled_jacobian", "scaled Jacobian", "", VM_HEX8, vm_hex_scaled_jacobian, 1.0, 0.5, 1.0,
      -1.0, 1.0, -1.0, 1.0),
    M("jacobian", "Jacobian", "", VM_HEX8, vm_hex_jacobian, NAN, 0.0, INF, -INF, INF, 0.0,
      0.0),
    M("skew", "skew", "", VM_HEX8, vm_hex_skew, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 1.0),
    M("taper", "taper", "", VM_HEX8, vm_hex_taper, 0.0, 0.0, 0.5, 0.0, INF, 0.0, 2.0),
    M("edge_ratio", "edge ratio Lmax/Lmin", "", VM_HEX8, vm_hex_edge_ratio, 1.0, 1.0, 1.3, 1.0,
      INF, 1.0, 5.0),
    M("volume", "volume", "", VM_HEX8, vm_hex_volume, NAN, 0.0, INF, -INF, INF, 0.0, 0.0),
};

static const vm_metric_info tri_metrics[] = {
    M("aspect_ratio", "aspect ratio", "", VM_TRI3, vm_tri_aspect_ratio, 1.0, 1.0, 1.3, 1.0, INF,
      1.0, 5.0),
    M("min_angle", "minimum angle", "deg", VM_TRI3, vm_tri_min_angle, 60.0, 30.0, 60.0, 0.0,
      60.0, 0.0, 60.0),
    M("max_angle", "maximum angle", "deg", VM_TRI3, vm_tri_max_angle, 60.0, 60.0, 90.0, 60.0,
      180.0, 60.0, 180.0),
    M("scaled_jacobian", "scaled Jacobian", "", VM_TRI3, vm_tri_scaled_jacobian, 1.0, 0.5, 1.0,
      0.0, 1.0, 0.0, 1.0),
    M("edge_ratio", "edge ratio Lmax/Lmin", "", VM_TRI3, vm_tri_edge_ratio, 1.0, 1.0, 1.3, 1.0,
      INF, 1.0, 5.0),
};

static const vm_metric_info quad_metrics[] = {
    M("aspect_ratio", "aspect ratio", "", VM_QUAD4, vm_quad_aspect_ratio, 1.0, 1.0, 1.3, 1.0,
      INF, 1.0, 5.0),
    M("min_angle", "minimum angle", "deg", VM_QUAD4, vm_quad_min_angle, 90.0, 45.0, 90.0, 0.0,
      360.0, 0.0, 90.0),
    M("max_angle", "maximum angle", "deg", VM_QUAD4, vm_quad_max_angle, 90.0, 90.0, 135.0, 0.0,
      360.0, 90.0, 270.0),
    M("scaled_jacobian", "scaled Jacobian", "", VM_QUAD4, vm_quad_scaled_jacobian, 1.0, 0.3,
      1.0, -1.0, 1.0, -1.0, 1.0),
    M("edge_ratio", "edge ratio Lmax/Lmin", "", VM_QUAD4, vm_quad_edge_ratio, 1.0, 1.0, 1.3, 1.0,
      INF, 1.0, 5.0),
};

#undef M

size_t vm_quality_metrics(vm_cell_kind kind, const vm_metric_info **table) {
    switch (kind) {
    case VM_TET4:
        *table = tet_metrics;
        return sizeof tet_metrics / sizeof tet_metrics[0];
    case VM_HEX8:
        *table = hex_metrics;
        return sizeof hex_metrics / sizeof hex_metrics[0];
    case VM_TRI3:
        *table = tri_metrics;
        return sizeof tri_metrics / sizeof tri_metrics[0];
    case VM_QUAD4:
        *table = quad_metrics;
        return sizeof quad_metrics / sizeof quad_metrics[0];
    }
    *table = NULL;
    return 0;
}

const vm_metric_info *vm_quality_find_metric(vm_cell_kind kind, const char *name) {
    const vm_metric_info *t;
    size_t n = vm_quality_metrics(kind, &t);
    for (size_t i = 0; i < n; i++)
        if (strcmp(t[i].name, name) == 0) return &t[i];
    return NULL;
}

/* ---- helpers ---------------------------------------------------------------------------- */

/* A known cell kind, and every cell's nodes in range (what names the caller). */
static vm_status check_nodes(const vm_mesh *m, const char *what, vm_error *err) {
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: unknown cell kind %d", what,
                            (int)m->kind);
    return vm__check_nodes(m, VM_ERR_ARG, what, err);
}

static void cell_points(const vm_mesh *m, size_t c, int nn, double p[8][3]) {
    const vm_index *cn = m->cells + c * (size_t)nn;
    for (int i = 0; i < nn; i++)
        memcpy(p[i], m->points + 3 * (size_t)cn[i], sizeof p[i]);
}

static double eval_cell(const vm_metric_info *mi, double p[8][3]) {
    return mi->eval((const double(*)[3])p);
}

static void add_to_histogram(vm_metric_stats *s, double q) {
    double w = (s->hi - s->lo) / VM_QUALITY_BINS;
    long b;
    if (q < s->lo) {
        s->below++;
        b = 0;
    } else if (q > s->hi) {
        s->above++;
        b = VM_QUALITY_BINS - 1;
    } else {
        b = w > 0.0 ? (long)((q - s->lo) / w) : 0;
        if (b >= VM_QUALITY_BINS) b = VM_QUALITY_BINS - 1;
        if (b < 0) b = 0;
    }
    s->bins[b]++;
}

/* ---- the report ------------------------------------------------------------------------- */

void vm_quality_options_init(vm_quality_options *o) { memset(o, 0, sizeof *o); }

vm_status vm_quality_report(const vm_mesh *m, vm_quality_summary *q, vm_error *err) {
    return vm_quality_report_with(m, NULL, q, err);
}

/* The cells are cut into chunks of a fixed size; threads take whole chunks, each chunk folds
 * its cells in order into its own statistics, and the chunks are merged in order. Neither
 * depends on the number of threads, so neither does the report. Chunks go in groups, with
 * the progress reported between groups. */
#define REPORT_CHUNK 16384
#define REPORT_GROUP 64

/* Where a tet's angle extremes sit in the metric table, so one evaluation of the six
 * dihedrals and one of the twelve face angles serve two metrics each (-1: not there). */
typedef struct angle_slots {
    int dmin, dmax, fmin, fmax;
} angle_slots;

/* v[k] = metric k of cell c, for the metrics with want[k] set. */
static void eval_metrics(const vm_mesh *m, const vm_metric_info *t, size_t nm, const int *want,
                         const angle_slots *as, size_t c, double *v) {
    int nn = vm_cell_nodes(m->kind), tets = m->kind == VM_TET4;
    double p[8][3];
    cell_points(m, c, nn, p);
    int done_d = 0, done_f = 0;
    for (size_t k = 0; k < nm; k++) {
        if (!want[k]) continue;
        int ki = (int)k;
        if (tets && (ki == as->dmin || ki == as->dmax)) {
            if (!done_d) {
                double lo, hi;
                vm__tet_dihedral_range((const double(*)[3])p, &lo, &hi);
                if (as->dmin >= 0) v[as->dmin] = lo;
                if (as->dmax >= 0) v[as->dmax] = hi;
                done_d = 1;
            }
        } else if (tets && (ki == as->fmin || ki == as->fmax)) {
            if (!done_f) {
                double lo, hi;
                vm__tet_face_angle_range((const double(*)[3])p, &lo, &hi);
                if (as->fmin >= 0) v[as->fmin] = lo;
                if (as->fmax >= 0) v[as->fmax] = hi;
                done_f = 1;
            }
        } else {
            v[k] = eval_cell(&t[k], p);
        }
    }
}

static int metric_slot(const vm_metric_info *t, size_t nm, const char *name) {
    for (size_t k = 0; k < nm; k++)
        if (strcmp(t[k].name, name) == 0) return (int)k;
    return -1;
}

/* What one chunk adds to the summary. */
typedef struct chunk_stats {
    vm_metric_stats s[VM_QUALITY_MAX_METRICS];
    double sum[VM_QUALITY_MAX_METRICS];
    size_t ab_volume, ab_small, ab_large, ab_failures, nlist;
    size_t list[VM_QUALITY_LIST];
} chunk_stats;

/* Everything a chunk needs to read. */
typedef struct report_job {
    const vm_mesh *m;
    const vm_metric_info *t;
    size_t nm;
    const int *want;
    angle_slots as;
    int iv, ia, ib;          /* ABAQUS metric slots (tets), -1 otherwise */
    const vm_quality_summary *q; /* histogram ranges (lo, hi) */
    int bins_only;           /* second pass: only the histograms of want[] */
} report_job;

static void fold_chunk(const report_job *j, size_t c0, size_t c1, chunk_stats *cs) {
    memset(cs, 0, sizeof *cs);
    for (size_t k = 0; k < j->nm; k++) {
        cs->s[k].min = INFINITY;
        cs->s[k].max = -INFINITY;
        cs->s[k].lo = j->q->metrics[k].lo;
        cs->s[k].hi = j->q->metrics[k].hi;
    }
    double v[VM_QUALITY_MAX_METRICS];
    for (size_t c = c0; c < c1; c++) {
        eval_metrics(j->m, j->t, j->nm, j->want, &j->as, c, v);
        for (size_t k = 0; k < j->nm; k++) {
            if (!j->want[k]) continue;
            vm_metric_stats *s = &cs->s[k];
            double x = v[k];
            if (j->bins_only) {
                add_to_histogram(s, x);
                continue;
            }
            cs->sum[k] += x;
            if (x < s->min) {
                s->min = x;
                s->argmin = c;
            }
            if (x > s->max) {
                s->max = x;
                s->argmax = c;
            }
            /* A hair beyond the ideal end of a range (60.0000000001 deg) is round-off. */
            const vm_metric_info *mi = &j->t[k];
            if (x < mi->acceptable_lo - 1e-9 * fmax(1.0, fabs(mi->acceptable_lo)) ||
                x > mi->acceptable_hi + 1e-9 * fmax(1.0, fabs(mi->acceptable_hi)))
                s->unacceptable++;
            if (s->hi > s->lo) add_to_histogram(s, x);
        }
        if (!j->bins_only && j->iv >= 0 && j->ia >= 0 && j->ib >= 0) {
            unsigned bad = vm__tet_abaqus_fails(v[j->iv], v[j->ia], v[j->ib]);
            cs->ab_volume += (size_t)((bad & VM__ABAQUS_FAILS_VOLUME) != 0);
            cs->ab_small += (size_t)((bad & VM__ABAQUS_FAILS_SMALL) != 0);
            cs->ab_large += (size_t)((bad & VM__ABAQUS_FAILS_LARGE) != 0);
            if (bad) {
                if (cs->nlist < VM_QUALITY_LIST) cs->list[cs->nlist++] = c;
                cs->ab_failures++;
            }
        }
    }
}

/* Adds a chunk to the summary (chunks come in cell order, so "first" stays first). */
static void merge_chunk(const report_job *j, const chunk_stats *cs, vm_quality_summary *q,
                        double *sum) {
    for (size_t k = 0; k < j->nm; k++) {
        if (!j->want[k]) continue;
        vm_metric_stats *s = &q->metrics[k];
        const vm_metric_stats *c = &cs->s[k];
        for (int b = 0; b < VM_QUALITY_BINS; b++)
            s->bins[b] += c->bins[b];
        s->below += c->below;
        s->above += c->above;
        if (j->bins_only) continue;
        sum[k] += cs->sum[k];
        if (c->min < s->min) {
            s->min = c->min;
            s->argmin = c->argmin;
        }
        if (c->max > s->max) {
            s->max = c->max;
            s->argmax = c->argmax;
        }
        s->unacceptable += c->unacceptable;
    }
    if (j->bins_only) return;
    q->abaqus_volume += cs->ab_volume;
    q->abaqus_small_angle += cs->ab_small;
    q->abaqus_large_angle += cs->ab_large;
    q->abaqus_failures += cs->ab_failures;
    for (size_t i = 0; i < cs->nlist && q->abaqus_nlist < VM_QUALITY_LIST; i++)
        q->abaqus_list[q->abaqus_nlist++] = cs->list[i];
}

/* One pass over all cells: chunks on threads, merged in order. */
static void report_pass(const report_job *j, chunk_stats *cs, vm_quality_summary *q,
                        double *sum, vm__meter *mt, double weight) {
    size_t nc = j->m->ncells, nchunks = (nc + REPORT_CHUNK - 1) / REPORT_CHUNK;
    for (size_t g0 = 0; g0 < nchunks; g0 += REPORT_GROUP) {
        size_t ng = nchunks - g0 < REPORT_GROUP ? nchunks - g0 : REPORT_GROUP;
        const ptrdiff_t ngs = (ptrdiff_t)ng;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (ptrdiff_t g = 0; g < ngs; g++) {
            size_t c0 = (g0 + (size_t)g) * REPORT_CHUNK;
            size_t c1 = nc - c0 < REPORT_CHUNK ? nc : c0 + REPORT_CHUNK;
            fold_chunk(j, c0, c1, &cs[g]);
        }
        size_t cells = 0;
        for (size_t g = 0; g < ng; g++) {
            merge_chunk(j, &cs[g], q, sum);
            size_t c0 = (g0 + g) * REPORT_CHUNK;
            cells += nc - c0 < REPORT_CHUNK ? nc - c0 : REPORT_CHUNK;
        }
        vm__meter_add(mt, weight * (double)cells);
    }
}

/* Cells per region: a counting array over the regions' span when it is small, else a sorted
 * copy. Fills q->nregions, q->regions and q->regions_more_cells. */
#define REGION_SPAN_ARRAY (1 << 20)

static int cmp_int32(const void *x, const void *y) {
    int32_t a = *(const int32_t *)x, b = *(const int32_t *)y;
    return a < b ? -1 : a > b;
}

static void add_region(vm_quality_summary *q, int32_t region, size_t cells) {
    if (q->nregions < VM_QUALITY_MAX_REGIONS) {
        q->regions[q->nregions].region = region;
        q->regions[q->nregions].cells = cells;
    } else {
        q->regions_more_cells += cells;
    }
    q->nregions++;
}

static vm_status count_regions(const vm_mesh *m, vm_quality_summary *q, vm_error *err) {
    size_t n = m->ncells;
    if (!n || !m->region) return VM_OK;
    int32_t lo = m->region[0], hi = m->region[0];
    for (size_t c = 1; c < n; c++) {
        if (m->region[c] < lo) lo = m->region[c];
        if (m->region[c] > hi) hi = m->region[c];
    }
    if ((int64_t)hi - (int64_t)lo < REGION_SPAN_ARRAY) {
        size_t span = (size_t)((int64_t)hi - (int64_t)lo + 1);
        size_t *cnt = calloc(span, sizeof *cnt);
        if (!cnt) return vm_error_set(err, VM_ERR_NOMEM, "quality report: out of memory");
        for (size_t c = 0; c < n; c++) cnt[(size_t)((int64_t)m->region[c] - lo)]++;
        for (size_t r = 0; r < span; r++)
            if (cnt[r]) add_region(q, (int32_t)((int64_t)lo + (int64_t)r), cnt[r]);
        free(cnt);
        return VM_OK;
    }
    int32_t *copy = malloc(n * sizeof *copy);
    if (!copy) return vm_error_set(err, VM_ERR_NOMEM, "quality report: out of memory");
    memcpy(copy, m->region, n * sizeof *copy);
    qsort(copy, n, sizeof *copy, cmp_int32);
    for (size_t i = 0; i < n;) {
        size_t j = i;
        while (j < n && copy[j] == copy[i]) j++;
        add_region(q, copy[i], j - i);
        i = j;
    }
    free(copy);
    return VM_OK;
}

vm_status vm_quality_report_with(const vm_mesh *m, const vm_quality_options *o,
                                 vm_quality_summary *q, vm_error *err) {
    vm_quality_options def;
    if (!o) {
        vm_quality_options_init(&def);
        o = &def;
    }
    memset(q, 0, sizeof *q);
    q->kind = m->kind;
    vm_status st;
    if (o->check) {
        st = check_nodes(m, "quality report", err);
        if (st) return st;
        q->check = *o->check;
    } else {
        st = vm_mesh_check_with(m, o->progress, o->progress_user, &q->check, err);
        if (st) return st;
    }
    const vm_metric_info *t;
    size_t nm = vm_quality_metrics(m->kind, &t);
    if (nm > VM_QUALITY_MAX_METRICS) nm = VM_QUALITY_MAX_METRICS;
    q->nmetrics = nm;
    double sum[VM_QUALITY_MAX_METRICS] = {0};
    int all[VM_QUALITY_MAX_METRICS], autos[VM_QUALITY_MAX_METRICS], auto_range = 0;
    for (size_t k = 0; k < nm; k++) {
        vm_metric_stats *s = &q->metrics[k];
        s->info = &t[k];
        s->min = INFINITY;
        s->max = -INFINITY;
        s->lo = t[k].hist_lo;
        s->hi = t[k].hist_hi;
        all[k] = 1;
        autos[k] = !(s->hi > s->lo);
        auto_range |= autos[k];
    }
    report_job j = {m, t, nm, all, {-1, -1, -1, -1}, -1, -1, -1, q, 0};
    if (m->kind == VM_TET4) {
        q->has_abaqus = 1;
        j.iv = metric_slot(t, nm, "volume_measure");
        j.ia = metric_slot(t, nm, "min_face_angle");
        j.ib = metric_slot(t, nm, "max_face_angle");
        j.as.dmin = metric_slot(t, nm, "min_dihedral");
        j.as.dmax = metric_slot(t, nm, "max_dihedral");
        j.as.fmin = j.ia;
        j.as.fmax = j.ib;
    }
    chunk_stats *cs = malloc(REPORT_GROUP * sizeof *cs);
    if (!cs) return vm_error_set(err, VM_ERR_NOMEM, "quality report: out of memory");
    vm__meter mt;
    double second = auto_range ? 0.2 : 0.0;
    vm__meter_start(&mt, o->progress, o->progress_user, "quality",
                    (double)m->ncells * (1.0 + second));
    report_pass(&j, cs, q, sum, &mt, 1.0);
    for (size_t k = 0; k < nm; k++) {
        vm_metric_stats *s = &q->metrics[k];
        if (m->ncells == 0) {
            s->min = s->max = s->mean = 0.0;
        } else {
            s->mean = sum[k] / (double)m->ncells;
            if (!isfinite(s->mean)) s->mean = s->mean > 0 ? VM_QUALITY_HUGE : -VM_QUALITY_HUGE;
        }
        if (!(s->hi > s->lo)) {
            s->lo = s->min;
            s->hi = s->max > s->min ? s->max : s->min + 1.0;
        }
    }
    /* Metrics without a fixed range are binned in a second pass over their own range. */
    if (auto_range) {
        j.want = autos;
        j.bins_only = 1;
        report_pass(&j, cs, q, sum, &mt, second);
    }
    free(cs);
    vm__meter_end(&mt);
    if (vm__meter_stopped(&mt)) return vm__cancelled(err, "quality report");
    st = vm_mesh_edge_lengths(m, &q->edges, err);
    if (!st) st = count_regions(m, q, err);
    return st;
}

vm_status vm_quality_add_distance(vm_quality_summary *q, const vm_mesh *m, const vm_volume *v,
                                  double lo, int has_lo, double hi, int has_hi, vm_error *err) {
    vm_surface_distance d;
    vm_status st = vm_mesh_surface_distance(m, v, lo, has_lo, hi, has_hi, &d, err);
    if (st) return st;
    q->distance = d;
    q->has_distance = 1;
    return VM_OK;
}

/* A distance of the report in voxels (NaN when the voxel length is unknown). */
static double in_voxels(const vm_quality_summary *q, double x) {
    return q->distance.voxel > 0 ? x / q->distance.voxel : NAN;
}

/* Whether the mesh holds no cell of region r (the table is ascending; a region beyond a
 * full table is not known to be missing). */
static int is_missing(const vm_quality_summary *q, int32_t r) {
    size_t shown = q->nregions < VM_QUALITY_MAX_REGIONS ? q->nregions : VM_QUALITY_MAX_REGIONS;
    size_t lo = 0, hi = shown;
    while (lo < hi) {
        size_t md = (lo + hi) / 2;
        if (q->regions[md].region < r)
            lo = md + 1;
        else
            hi = md;
    }
    if (lo < shown && q->regions[lo].region == r) return 0;
    return !(q->nregions > shown && r > q->regions[shown - 1].region);
}

/* How many of the expected regions the mesh holds no cell of. */
static size_t missing_regions(const vm_quality_summary *q) {
    size_t n = 0;
    for (size_t i = 0; i < q->nexpected_regions; i++)
        n += (size_t)is_missing(q, q->expected_regions[i]);
    return n;
}

vm_status vm_quality_lookup(const vm_quality_summary *q, const char *key, double *value) {
    const vm_mesh_report *r = &q->check;
    struct {
        const char *name;
        double v;
        int ok;
    } keys[] = {
        {"elements", (double)r->cells, 1},
        {"points", (double)r->points, 1},
        {"inverted", (double)r->inverted, 1},
        {"degenerate", (double)r->degenerate, 1},
        {"overshared_faces", (double)r->overshared_faces, 1},
        {"boundary_faces", (double)r->boundary_faces, 1},
        {"boundary_closed", (double)r->boundary_closed, 1},
        {"boundary_euler", (double)r->boundary_euler, 1},
        {"components", (double)r->components, 1},
        {"boundary_components", (double)r->boundary_components, 1},
        {"boundary_self_intersections", (double)r->boundary_self_intersections, 1},
        {"volume", r->volume, 1},
        {"min_dihedral", r->min_dihedral, q->kind == VM_TET4},
        {"max_dihedral", r->max_dihedral, q->kind == VM_TET4},
        {"slivers_5", (double)r->slivers_5, q->kind == VM_TET4},
        {"slivers_10", (double)r->slivers_10, q->kind == VM_TET4},
        {"min_scaled_jacobian", r->min_scaled_jacobian, q->kind == VM_TET4 || q->kind == VM_HEX8},
        {"abaqus_failures", (double)q->abaqus_failures, q->has_abaqus},
        {"edges", (double)q->edges.edges, 1},
        {"edge_length.min", q->edges.min, 1},
        {"edge_length.mean", q->edges.mean, 1},
        {"edge_length.max", q->edges.max, 1},
        {"regions", (double)q->nregions, 1},
        {"hausdorff", q->distance.hausdorff, q->has_distance},
        {"mesh_to_surface_max", q->distance.mesh_to_surface_max, q->has_distance},
        {"mesh_to_surface_mean", q->distance.mesh_to_surface_mean, q->has_distance},
        {"surface_to_mesh_max", q->distance.surface_to_mesh_max, q->has_distance},
        {"surface_to_mesh_mean", q->distance.surface_to_mesh_mean, q->has_distance},
        {"hausdorff_voxels", in_voxels(q, q->distance.hausdorff), q->has_distance},
        {"mesh_to_surface_max_voxels", in_voxels(q, q->distance.mesh_to_surface_max),
         q->has_distance},
        {"surface_to_mesh_max_voxels", in_voxels(q, q->distance.surface_to_mesh_max),
         q->has_distance},
        {"regions_missing", (double)missing_regions(q), 1},
    };
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        if (strcmp(key, keys[i].name) == 0) {
            if (!keys[i].ok) return VM_ERR_ARG;
            *value = keys[i].v;
            return VM_OK;
        }
    const char *dot = strrchr(key, '.');
    if (!dot) return VM_ERR_ARG;
    for (size_t k = 0; k < q->nmetrics; k++) {
        const vm_metric_stats *s = &q->metrics[k];
        size_t len = strlen(s->info->name);
        if ((size_t)(dot - key) != len || strncmp(key, s->info->name, len) != 0) continue;
        const char *f = dot + 1;
        if (strcmp(f, "min") == 0)
            *value = s->min;
        else if (strcmp(f, "mean") == 0)
            *value = s->mean;
        else if (strcmp(f, "max") == 0)
            *value = s->max;
        else if (strcmp(f, "unacceptable") == 0)
            *value = (double)s->unacceptable;
        else
            return VM_ERR_ARG;
        return VM_OK;
    }
    return VM_ERR_ARG;
}

/* ---- text ------------------------------------------------------------------------------- */

static const char *plural_kind(vm_cell_kind k) {
    switch (k) {
    case VM_TET4: return "tets";
    case VM_HEX8: return "hexes";
    case VM_TRI3: return "triangles";
    case VM_QUAD4: return "quads";
    }
    return "cells";
}

/* A range end for text: "inf", "-inf" or the number. */
static void fmt_num(char *buf, size_t cap, double x) {
    if (isnan(x))
        snprintf(buf, cap, "-");
    else if (isinf(x))
        snprintf(buf, cap, x > 0 ? "inf" : "-inf");
    else
        snprintf(buf, cap, "%.4g", x);
}

vm_status vm_quality_write_text(FILE *out, const char *name, const vm_quality_summary *q,
                          int abaqus) {
    const vm_mesh_report *r = &q->check;
    int vol = q->kind == VM_TET4 || q->kind == VM_HEX8;
    fprintf(out, "mesh         %s (%s)\n", name ? name : "-", vm_cell_kind_name(q->kind));
    fprintf(out, "elements     %zu %s, %zu points\n", r->cells, plural_kind(q->kind), r->points);
    if (vol) {
        fprintf(out, "inverted     %zu\n", r->inverted);
        fprintf(out, "degenerate   %zu (|volume| <= 1e-12 of the mean)\n", r->degenerate);
        fprintf(out, "conformity   %s (%zu faces shared by more than two cells)\n",
                r->overshared_faces ? "NOT conforming" : "conforming", r->overshared_faces);
    } else {
        fprintf(out, "degenerate   %zu (area <= 1e-12 of the mean)\n", r->degenerate);
    }
    fprintf(out,
            "boundary     %s, %zu faces, Euler characteristic %ld, %zu component%s "
            "(%zu open edges, %zu non-manifold edges, %zu non-manifold vertices)\n",
            r->boundary_closed ? "closed" : "OPEN", r->boundary_faces, r->boundary_euler,
            r->boundary_components, r->boundary_components == 1 ? "" : "s",
            r->boundary_open_edges, r->boundary_nonmanifold_edges,
            r->boundary_nonmanifold_vertices);
    fprintf(out, "self-cut     %zu pairs of boundary triangles intersect%s\n",
            r->boundary_self_intersections,
            q->kind == VM_TET4 || q->kind == VM_TRI3 ? "" : " (not checked for this kind)");
    fprintf(out, "components   %zu\n", r->components);
    fprintf(out, "volume       %.10g\n", r->volume);
    if (q->kind == VM_TET4) {
        fprintf(out, "dihedral     %.3f .. %.3f deg\n", r->min_dihedral, r->max_dihedral);
        fprintf(out, "slivers      %zu below 5 deg, %zu below 10 deg (min dihedral)\n",
                r->slivers_5, r->slivers_10);
    }
    if (q->has_abaqus) {
        fprintf(out,
                "ABAQUS       %zu tet%s fail: %zu volume measure < 0.02, %zu face angle < 10 "
                "deg, %zu face angle > 160 deg\n",
                q->abaqus_failures, q->abaqus_failures == 1 ? "" : "s", q->abaqus_volume,
                q->abaqus_small_angle, q->abaqus_large_angle);
        if (abaqus && q->abaqus_nlist) {
            fprintf(out, "             failing tets (first %zu, 0-based):", q->abaqus_nlist);
            for (size_t i = 0; i < q->abaqus_nlist; i++) fprintf(out, " %zu", q->abaqus_list[i]);
            fputc('\n', out);
        }
    }
    const vm_edge_stats *e = &q->edges;
    fprintf(out, "edges        %zu, length %.6g .. %.6g, mean %.6g (mesh units)\n", e->edges,
            e->min, e->max, e->mean);
    if (q->has_distance) {
        const vm_surface_distance *d = &q->distance;
        fprintf(out,
                "distance     Hausdorff %.6g to the isosurface: boundary -> surface max %.6g "
                "mean %.6g, surface -> boundary max %.6g mean %.6g (%zu + %zu samples)\n",
                d->hausdorff, d->mesh_to_surface_max, d->mesh_to_surface_mean,
                d->surface_to_mesh_max, d->surface_to_mesh_mean, d->mesh_samples,
                d->surface_samples);
        if (d->voxel > 0)
            fprintf(out,
                    "             in voxels (%.6g each): Hausdorff %.4g, boundary -> surface "
                    "max %.4g mean %.4g, surface -> boundary max %.4g mean %.4g\n",
                    d->voxel, d->hausdorff / d->voxel, d->mesh_to_surface_max / d->voxel,
                    d->mesh_to_surface_mean / d->voxel, d->surface_to_mesh_max / d->voxel,
                    d->surface_to_mesh_mean / d->voxel);
        if (isfinite(d->mesh_to_surface_ijk[0]))
            fprintf(out, "             farthest boundary point at voxel (%.2f, %.2f, %.2f)\n",
                    d->mesh_to_surface_ijk[0], d->mesh_to_surface_ijk[1],
                    d->mesh_to_surface_ijk[2]);
        if (isfinite(d->surface_to_mesh_ijk[0]))
            fprintf(out, "             farthest isosurface point at voxel (%.2f, %.2f, %.2f)\n",
                    d->surface_to_mesh_ijk[0], d->surface_to_mesh_ijk[1],
                    d->surface_to_mesh_ijk[2]);
    }
    if (q->nregions >= 2 || q->nexpected_regions) {
        size_t shown = q->nregions < VM_QUALITY_MAX_REGIONS ? q->nregions : VM_QUALITY_MAX_REGIONS;
        fprintf(out, "regions      %zu\n", q->nregions);
        for (size_t i = 0; i < shown; i++)
            fprintf(out, "  region %-8ld %12zu %s\n", (long)q->regions[i].region,
                    q->regions[i].cells, plural_kind(q->kind));
        if (q->nregions > shown)
            fprintf(out, "  %zu more regions %6zu %s\n", q->nregions - shown,
                    q->regions_more_cells, plural_kind(q->kind));
    }
    size_t nmiss = missing_regions(q);
    if (nmiss) {
        fprintf(out, "missing      %zu of %zu regions asked for have no cell:", nmiss,
                q->nexpected_regions);
        for (size_t i = 0; i < q->nexpected_regions; i++)
            if (is_missing(q, q->expected_regions[i]))
                fprintf(out, " %ld", (long)q->expected_regions[i]);
        fputc('\n', out);
    }
    for (size_t i = 0; i < q->nwarnings; i++) fprintf(out, "warning      %s\n", q->warnings[i]);
    fprintf(out, "\n%-16s %12s %12s %12s %9s %19s %10s\n", "metric", "min", "mean", "max",
            "ideal", "acceptable", "outside");
    for (size_t k = 0; k < q->nmetrics; k++) {
        const vm_metric_stats *s = &q->metrics[k];
        char ideal[32], lo[32], hi[32], acc[70];
        fmt_num(ideal, sizeof ideal, s->info->ideal);
        fmt_num(lo, sizeof lo, s->info->acceptable_lo);
        fmt_num(hi, sizeof hi, s->info->acceptable_hi);
        snprintf(acc, sizeof acc, "%s..%s", lo, hi);
        fprintf(out, "%-16s %12.6g %12.6g %12.6g %9s %19s %10zu\n", s->info->name, s->min,
                s->mean, s->max, ideal, acc, s->unacceptable);
    }
    fprintf(out, "\nhistograms (%d bins; values outside a range are counted in its end bins)\n",
            VM_QUALITY_BINS);
    for (size_t k = 0; k < q->nmetrics; k++) {
        const vm_metric_stats *s = &q->metrics[k];
        size_t most = 1;
        for (int b = 0; b < VM_QUALITY_BINS; b++)
            if (s->bins[b] > most) most = s->bins[b];
        fprintf(out, "\n%s%s%s%s (%s)", s->info->name, s->info->unit[0] ? " [" : "",
                s->info->unit, s->info->unit[0] ? "]" : "", s->info->label);
        if (s->below || s->above)
            fprintf(out, ": %zu below %.4g, %zu above %.4g", s->below, s->lo, s->above, s->hi);
        fputc('\n', out);
        double w = (s->hi - s->lo) / VM_QUALITY_BINS;
        for (int b = 0; b < VM_QUALITY_BINS; b++) {
            double a = s->lo + w * b, z = s->lo + w * (b + 1);
            int inside = !(z <= s->info->acceptable_lo || a >= s->info->acceptable_hi);
            int len = (int)(40.0 * (double)s->bins[b] / (double)most + 0.5);
            if (s->bins[b] && len == 0) len = 1;
            fprintf(out, "  %11.5g .. %-11.5g %c %10zu %.*s\n", a, z, inside ? ' ' : '!',
                    s->bins[b], len, "########################################");
        }
    }
    if (e->edges) {
        size_t most = 1;
        for (int b = 0; b < VM_QUALITY_BINS; b++)
            if (e->bins[b] > most) most = e->bins[b];
        fprintf(out, "\nedge_length (each edge once, mesh units)\n");
        double w = (e->hi - e->lo) / VM_QUALITY_BINS;
        for (int b = 0; b < VM_QUALITY_BINS; b++) {
            int len = (int)(40.0 * (double)e->bins[b] / (double)most + 0.5);
            if (e->bins[b] && len == 0) len = 1;
            fprintf(out, "  %11.5g .. %-11.5g   %10zu %.*s\n", e->lo + w * b, e->lo + w * (b + 1),
                    e->bins[b], len, "########################################");
        }
    }
    fflush(out);
    return ferror(out) ? VM_ERR_IO : VM_OK;
}

/* ---- JSON ------------------------------------------------------------------------------- */

static void json_string(FILE *out, const char *s) {
    fputc('"', out);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(out, "\\%c", c);
        else if (c < 0x20)
            fprintf(out, "\\u%04x", c);
        else
            fputc(c, out);
    }
    fputc('"', out);
}

static void json_num(FILE *out, double x) {
    if (isfinite(x))
        fprintf(out, "%.17g", x);
    else
        fputs("null", out);
}

vm_status vm_quality_write_json(FILE *out, const char *name, const vm_quality_summary *q) {
    const vm_mesh_report *r = &q->check;
    int tet = q->kind == VM_TET4;
    fputs("{\"file\": ", out);
    if (name)
        json_string(out, name);
    else
        fputs("null", out);
    fprintf(out, ", \"kind\": \"%s\", \"elements\": %zu, \"points\": %zu, \"inverted\": %zu, "
                 "\"degenerate\": %zu, \"overshared_faces\": %zu, \"boundary_faces\": %zu, "
                 "\"boundary_closed\": %s, \"boundary_open_edges\": %zu, "
                 "\"boundary_nonmanifold_edges\": %zu, \"boundary_nonmanifold_vertices\": %zu, "
                 "\"boundary_euler\": %ld, \"components\": %zu, \"boundary_components\": %zu, "
                 "\"boundary_self_intersections\": %zu, \"volume\": ",
            vm_cell_kind_name(q->kind), r->cells, r->points, r->inverted, r->degenerate,
            r->overshared_faces, r->boundary_faces, r->boundary_closed ? "true" : "false",
            r->boundary_open_edges, r->boundary_nonmanifold_edges,
            r->boundary_nonmanifold_vertices, r->boundary_euler, r->components,
            r->boundary_components, r->boundary_self_intersections);
    json_num(out, r->volume);
    fputs(", \"min_dihedral\": ", out);
    json_num(out, tet ? r->min_dihedral : NAN);
    fputs(", \"max_dihedral\": ", out);
    json_num(out, tet ? r->max_dihedral : NAN);
    if (tet)
        fprintf(out, ", \"slivers_5\": %zu, \"slivers_10\": %zu", r->slivers_5, r->slivers_10);
    else
        fputs(", \"slivers_5\": null, \"slivers_10\": null", out);
    fputs(", \"min_scaled_jacobian\": ", out);
    json_num(out, (tet || q->kind == VM_HEX8) ? r->min_scaled_jacobian : NAN);
    if (q->has_abaqus) {
        fprintf(out, ", \"abaqus_failures\": %zu, \"abaqus\": {\"volume_measure_below_0.02\": %zu, "
                     "\"face_angle_below_10\": %zu, \"face_angle_above_160\": %zu, \"first\": [",
                q->abaqus_failures, q->abaqus_volume, q->abaqus_small_angle,
                q->abaqus_large_angle);
        for (size_t i = 0; i < q->abaqus_nlist; i++)
            fprintf(out, "%s%zu", i ? ", " : "", q->abaqus_list[i]);
        fputs("]}", out);
    } else {
        fputs(", \"abaqus_failures\": null, \"abaqus\": null", out);
    }
    const vm_edge_stats *e = &q->edges;
    fprintf(out, ", \"edges\": %zu, \"edge_length\": {\"min\": ", e->edges);
    json_num(out, e->min);
    fputs(", \"mean\": ", out);
    json_num(out, e->mean);
    fputs(", \"max\": ", out);
    json_num(out, e->max);
    fputs(", \"histogram\": {\"lo\": ", out);
    json_num(out, e->lo);
    fputs(", \"hi\": ", out);
    json_num(out, e->hi);
    fputs(", \"counts\": [", out);
    for (int b = 0; b < VM_QUALITY_BINS; b++) fprintf(out, "%s%zu", b ? ", " : "", e->bins[b]);
    fprintf(out, "]}}, \"regions\": %zu, \"cells_per_region\": [", q->nregions);
    size_t shown = q->nregions < VM_QUALITY_MAX_REGIONS ? q->nregions : VM_QUALITY_MAX_REGIONS;
    for (size_t i = 0; i < shown; i++)
        fprintf(out, "%s{\"region\": %ld, \"cells\": %zu}", i ? ", " : "",
                (long)q->regions[i].region, q->regions[i].cells);
    fprintf(out, "], \"cells_in_regions_not_listed\": %zu, \"regions_missing\": [",
            q->regions_more_cells);
    for (size_t i = 0, n = 0; i < q->nexpected_regions; i++)
        if (is_missing(q, q->expected_regions[i]))
            fprintf(out, "%s%ld", n++ ? ", " : "", (long)q->expected_regions[i]);
    fputs("], \"warnings\": [", out);
    for (size_t i = 0; i < q->nwarnings; i++) {
        if (i) fputs(", ", out);
        json_string(out, q->warnings[i]);
    }
    fputc(']', out);
    if (q->has_distance) {
        const vm_surface_distance *d = &q->distance;
        fputs(", \"surface_distance\": {\"hausdorff\": ", out);
        json_num(out, d->hausdorff);
        fputs(", \"mesh_to_surface_max\": ", out);
        json_num(out, d->mesh_to_surface_max);
        fputs(", \"mesh_to_surface_mean\": ", out);
        json_num(out, d->mesh_to_surface_mean);
        fputs(", \"surface_to_mesh_max\": ", out);
        json_num(out, d->surface_to_mesh_max);
        fputs(", \"surface_to_mesh_mean\": ", out);
        json_num(out, d->surface_to_mesh_mean);
        fprintf(out, ", \"mesh_samples\": %zu, \"surface_samples\": %zu", d->mesh_samples,
                d->surface_samples);
        const char *key[4] = {"mesh_to_surface_at", "mesh_to_surface_ijk", "surface_to_mesh_at",
                              "surface_to_mesh_ijk"};
        const double *val[4] = {d->mesh_to_surface_at, d->mesh_to_surface_ijk,
                                d->surface_to_mesh_at, d->surface_to_mesh_ijk};
        for (int k = 0; k < 4; k++) {
            fprintf(out, ", \"%s\": ", key[k]);
            if (!isfinite(val[k][0])) {
                fputs("null", out);
                continue;
            }
            for (int a = 0; a < 3; a++) {
                fputs(a ? ", " : "[", out);
                json_num(out, val[k][a]);
            }
            fputc(']', out);
        }
        fputs(", \"voxel\": ", out);
        if (d->voxel > 0) {
            json_num(out, d->voxel);
            fputs(", \"voxels\": {\"hausdorff\": ", out);
            json_num(out, d->hausdorff / d->voxel);
            fputs(", \"mesh_to_surface_max\": ", out);
            json_num(out, d->mesh_to_surface_max / d->voxel);
            fputs(", \"mesh_to_surface_mean\": ", out);
            json_num(out, d->mesh_to_surface_mean / d->voxel);
            fputs(", \"surface_to_mesh_max\": ", out);
            json_num(out, d->surface_to_mesh_max / d->voxel);
            fputs(", \"surface_to_mesh_mean\": ", out);
            json_num(out, d->surface_to_mesh_mean / d->voxel);
            fputs("}}", out);
        } else {
            fputs("null, \"voxels\": null}", out);
        }
    } else {
        fputs(", \"surface_distance\": null", out);
    }
    fprintf(out, ", \"histogram_bins\": %d, \"metrics\": {", VM_QUALITY_BINS);
    for (size_t k = 0; k < q->nmetrics; k++) {
        const vm_metric_stats *s = &q->metrics[k];
        const vm_metric_info *mi = s->info;
        fprintf(out, "%s\"%s\": {\"label\": ", k ? ", " : "", mi->name);
        json_string(out, mi->label);
        fputs(", \"unit\": ", out);
        json_string(out, mi->unit);
        fputs(", \"ideal\": ", out);
        json_num(out, mi->ideal);
        fputs(", \"acceptable\": [", out);
        json_num(out, mi->acceptable_lo);
        fputs(", ", out);
        json_num(out, mi->acceptable_hi);
        fputs("], \"full\": [", out);
        json_num(out, mi->full_lo);
        fputs(", ", out);
        json_num(out, mi->full_hi);
        fputs("], \"min\": ", out);
        json_num(out, s->min);
        fputs(", \"mean\": ", out);
        json_num(out, s->mean);
        fputs(", \"max\": ", out);
        json_num(out, s->max);
        fprintf(out, ", \"argmin\": %zu, \"argmax\": %zu, \"unacceptable\": %zu", s->argmin,
                s->argmax, s->unacceptable);
        fputs(", \"histogram\": {\"lo\": ", out);
        json_num(out, s->lo);
        fputs(", \"hi\": ", out);
        json_num(out, s->hi);
        fprintf(out, ", \"below\": %zu, \"above\": %zu, \"counts\": [", s->below, s->above);
        for (int b = 0; b < VM_QUALITY_BINS; b++)
            fprintf(out, "%s%zu", b ? ", " : "", s->bins[b]);
        fputs("]}}", out);
    }
    fputs("}}\n", out);
    fflush(out);
    return ferror(out) ? VM_ERR_IO : VM_OK;
}

/* ---- SVG -------------------------------------------------------------------------------- */

static void svg_text(FILE *out, const char *s) {
    for (; s && *s; s++) {
        if (*s == '<')
            fputs("&lt;", out);
        else if (*s == '>')
            fputs("&gt;", out);
        else if (*s == '&')
            fputs("&amp;", out);
        else if (*s == '"')
            fputs("&quot;", out);
        else if ((unsigned char)*s >= 0x20)
            fputc(*s, out);
    }
}

/* Panel geometry (pixels). */
#define PANEL_W 460.0
#define PANEL_H 250.0
#define PLOT_X0 64.0  /* left edge of the plot inside the panel */
#define PLOT_X1 440.0
#define PLOT_Y0 40.0  /* top */
#define PLOT_Y1 200.0 /* bottom (the x axis) */

static void svg_panel(FILE *out, const vm_metric_stats *s, double ox, double oy) {
    const vm_metric_info *mi = s->info;
    double lo = s->lo, hi = s->hi, span = hi - lo;
    size_t most = 1;
    for (int b = 0; b < VM_QUALITY_BINS; b++)
        if (s->bins[b] > most) most = s->bins[b];
    fprintf(out, "<g transform=\"translate(%.1f,%.1f)\">\n", ox, oy);
    fprintf(out, "<rect x=\"0.5\" y=\"0.5\" width=\"%.1f\" height=\"%.1f\" fill=\"#fff\" "
                 "stroke=\"#ccc\"/>\n",
            PANEL_W - 9.0, PANEL_H - 9.0);
    fprintf(out, "<text x=\"%.1f\" y=\"20\" font-size=\"13\" font-weight=\"bold\">", PLOT_X0);
    svg_text(out, mi->name);
    fputs(" — ", out);
    svg_text(out, mi->label);
    fputs("</text>\n", out);
    fprintf(out, "<text x=\"%.1f\" y=\"34\" font-size=\"10\" fill=\"#555\">min %.4g  mean %.4g  "
                 "max %.4g  outside acceptable %zu",
            PLOT_X0, s->min, s->mean, s->max, s->unacceptable);
    if (s->below || s->above)
        fprintf(out, "  (%zu below, %zu above the axis, drawn in the end bins)", s->below,
                s->above);
    fputs("</text>\n", out);
    double pw = PLOT_X1 - PLOT_X0, ph = PLOT_Y1 - PLOT_Y0;
    /* Acceptable range, clipped to the axis. */
    double a = fmax(mi->acceptable_lo, lo), z = fmin(mi->acceptable_hi, hi);
    if (z > a)
        fprintf(out, "<rect x=\"%.2f\" y=\"%.1f\" width=\"%.2f\" height=\"%.1f\" "
                     "fill=\"#d8f0d8\"><title>acceptable range</title></rect>\n",
                PLOT_X0 + pw * (a - lo) / span, PLOT_Y0, pw * (z - a) / span, ph);
    double bw = pw / VM_QUALITY_BINS;
    for (int b = 0; b < VM_QUALITY_BINS; b++) {
        if (!s->bins[b]) continue;
        double h = ph * (double)s->bins[b] / (double)most;
        if (h < 1.0) h = 1.0;
        fprintf(out, "<rect x=\"%.2f\" y=\"%.2f\" width=\"%.2f\" height=\"%.2f\" fill=\"#4a78b0\">"
                     "<title>%zu</title></rect>\n",
                PLOT_X0 + bw * b + 0.5, PLOT_Y1 - h, bw - 1.0, h, s->bins[b]);
    }
    if (isfinite(mi->ideal) && mi->ideal >= lo && mi->ideal <= hi)
        fprintf(out, "<line x1=\"%.2f\" y1=\"%.1f\" x2=\"%.2f\" y2=\"%.1f\" stroke=\"#c33\" "
                     "stroke-dasharray=\"4,3\"><title>ideal %.4g</title></line>\n",
                PLOT_X0 + pw * (mi->ideal - lo) / span, PLOT_Y0, PLOT_X0 + pw * (mi->ideal - lo) / span,
                PLOT_Y1, mi->ideal);
    /* Axes, ticks and labels. */
    fprintf(out, "<path d=\"M%.1f %.1fV%.1fH%.1f\" fill=\"none\" stroke=\"#000\"/>\n", PLOT_X0,
            PLOT_Y0, PLOT_Y1, PLOT_X1);
    for (int i = 0; i <= 4; i++) {
        double x = PLOT_X0 + pw * i / 4.0, v = lo + span * i / 4.0;
        fprintf(out, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>"
                     "<text x=\"%.1f\" y=\"%.1f\" font-size=\"10\" text-anchor=\"middle\">%.4g</text>\n",
                x, PLOT_Y1, x, PLOT_Y1 + 4, x, PLOT_Y1 + 15, v);
    }
    for (int i = 0; i <= 2; i++) {
        double y = PLOT_Y1 - ph * i / 2.0;
        fprintf(out, "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#000\"/>"
                     "<text x=\"%.1f\" y=\"%.1f\" font-size=\"10\" text-anchor=\"end\">%.4g</text>\n",
                PLOT_X0 - 4, y, PLOT_X0, y, PLOT_X0 - 6, y + 3, (double)most * i / 2.0);
    }
    fprintf(out, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"11\" text-anchor=\"middle\">",
            (PLOT_X0 + PLOT_X1) / 2, PLOT_Y1 + 32);
    svg_text(out, mi->name);
    if (mi->unit[0]) {
        fputs(" (", out);
        svg_text(out, mi->unit);
        fputc(')', out);
    }
    fputs("</text>\n", out);
    fprintf(out, "<text transform=\"translate(14,%.1f) rotate(-90)\" font-size=\"11\" "
                 "text-anchor=\"middle\">cells</text>\n",
            (PLOT_Y0 + PLOT_Y1) / 2);
    fputs("</g>\n", out);
}

vm_status vm_quality_write_svg(const char *path, const char *name, const vm_quality_summary *q,
                               vm_error *err) {
    vm_outfile o;
    vm_status st = vm__out_open(&o, path, err);
    if (st) return st;
    FILE *out = o.fp;
    int cols = 2;
    size_t panels = q->nmetrics + (q->edges.edges ? 1 : 0);
    size_t rows = (panels + 1) / 2;
    double width = cols * PANEL_W + 10.0, height = 50.0 + (double)rows * PANEL_H;
    fprintf(out, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                 "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
                 "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\">\n",
            width, height, width, height);
    fprintf(out, "<rect width=\"100%%\" height=\"100%%\" fill=\"#f6f6f6\"/>\n");
    fputs("<text x=\"10\" y=\"22\" font-size=\"15\" font-weight=\"bold\">volmesh quality: ", out);
    svg_text(out, name ? name : "mesh");
    fprintf(out, " (%zu %s)</text>\n", q->check.cells, plural_kind(q->kind));
    fputs("<text x=\"10\" y=\"40\" font-size=\"11\" fill=\"#555\">green: acceptable range; red "
          "dashes: ideal value; bars: cells per bin</text>\n",
          out);
    for (size_t k = 0; k < q->nmetrics; k++)
        svg_panel(out, &q->metrics[k], 10.0 + (double)(k % 2) * PANEL_W,
                  50.0 + (double)(k / 2) * PANEL_H);
    if (q->edges.edges) {
        /* the edge lengths drawn as a metric without an ideal, and an empty acceptable
         * range (nothing shaded) */
        static const vm_metric_info edge_info = {
            "edge_length", "edge length, each edge once", "mesh units", VM_TET4, NULL, NAN,
            INFINITY, -INFINITY, 0.0, INFINITY, 0.0, 0.0};
        vm_metric_stats es;
        memset(&es, 0, sizeof es);
        es.info = &edge_info;
        es.min = q->edges.min;
        es.mean = q->edges.mean;
        es.max = q->edges.max;
        es.lo = q->edges.lo;
        es.hi = q->edges.hi;
        memcpy(es.bins, q->edges.bins, sizeof es.bins);
        size_t k = q->nmetrics;
        svg_panel(out, &es, 10.0 + (double)(k % 2) * PANEL_W, 50.0 + (double)(k / 2) * PANEL_H);
    }
    fputs("</svg>\n", out);
    return vm__out_commit(&o, err);
}

/* ---- per-cell values -------------------------------------------------------------------- */

vm_status vm_quality_write_cell_csv(const char *path, const vm_mesh *m, vm_error *err) {
    vm_status st = check_nodes(m, path, err);
    if (st) return st;
    const vm_metric_info *t;
    size_t nm = vm_quality_metrics(m->kind, &t);
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) return st;
    fputs("cell,region", o.fp);
    for (size_t k = 0; k < nm; k++) fprintf(o.fp, ",%s", t[k].name);
    fputc('\n', o.fp);
    int nn = vm_cell_nodes(m->kind);
    for (size_t c = 0; c < m->ncells; c++) {
        double p[8][3];
        cell_points(m, c, nn, p);
        fprintf(o.fp, "%zu,%ld", c, m->region ? (long)m->region[c] : 0L);
        for (size_t k = 0; k < nm; k++) fprintf(o.fp, ",%.17g", eval_cell(&t[k], p));
        fputc('\n', o.fp);
    }
    return vm__out_commit(&o, err);
}

static const char *const default_tet_fields[] = {"min_dihedral", "max_dihedral",
                                                 "radius_ratio", "aspect_ratio",
                                                 "scaled_jacobian", "volume_measure", NULL};
static const char *const default_hex_fields[] = {"scaled_jacobian", "jacobian", "skew",
                                                 "taper", "edge_ratio", NULL};
static const char *const default_surface_fields[] = {"aspect_ratio", "min_angle", "max_angle",
                                                     "scaled_jacobian", NULL};

vm_status vm_mesh_add_quality_fields(vm_mesh *m, const char *const *names, vm_error *err) {
    vm_status st = check_nodes(m, "quality fields", err);
    if (st) return st;
    if (!names)
        names = m->kind == VM_TET4   ? default_tet_fields
                : m->kind == VM_HEX8 ? default_hex_fields
                                     : default_surface_fields;
    for (size_t i = 0; names[i]; i++)
        if (!vm_quality_find_metric(m->kind, names[i]))
            return vm_error_set(err, VM_ERR_ARG, "quality fields: no metric '%s' for %s cells",
                                names[i], vm_cell_kind_name(m->kind));
    size_t bytes;
    if (vm__mul_overflows(m->ncells, sizeof(double), &bytes) || bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "quality fields: %zu cells are too many",
                            m->ncells);
    double *d = malloc(bytes ? bytes : 1);
    if (!d) return vm_error_set(err, VM_ERR_NOMEM, "quality fields: out of memory");
    int nn = vm_cell_nodes(m->kind);
    for (size_t i = 0; names[i] && st == VM_OK; i++) {
        const vm_metric_info *mi = vm_quality_find_metric(m->kind, names[i]);
        for (size_t c = 0; c < m->ncells; c++) {
            double p[8][3];
            cell_points(m, c, nn, p);
            d[c] = eval_cell(mi, p);
        }
        st = vm_mesh_set_field(m, 1, mi->name, 1, d, err);
    }
    free(d);
    return st;
}
