/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/mesh_labels.c — `volmesh mesh --labels`: a label volume (segmentation) in, one
 * conforming multi-material mesh out, with a summary line per label. */
#include <errno.h>
#include <stdarg.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

int vm_cli_parse_labels(const char *s, int32_t **labels, size_t *n) {
    *labels = NULL;
    *n = 0;
    if (strcmp(s, "all") == 0) return 0;
    size_t cap = 0;
    const char *p = s;
    for (;;) {
        char *end;
        errno = 0;
        long a = strtol(p, &end, 10), b;
        if (end == p || errno || a < INT32_MIN || a > INT32_MAX) goto bad;
        b = a;
        if (*end == '-' && end > p) {
            const char *q = end + 1;
            b = strtol(q, &end, 10);
            if (end == q || errno || b < a || b > INT32_MAX || b - a > 65535) goto bad;
        }
        for (long x = a; x <= b; x++) {
            if (*n == cap) {
                cap = cap ? 2 * cap : 16;
                int32_t *t = realloc(*labels, cap * sizeof *t);
                if (!t) {
                    free(*labels);
                    *labels = NULL;
                    return vm_cli_fail("--labels: out of memory");
                }
                *labels = t;
            }
            (*labels)[(*n)++] = (int32_t)x;
        }
        if (*end == 0) return 0;
        if (*end != ',') goto bad;
        p = end + 1;
    }
bad:
    free(*labels);
    *labels = NULL;
    *n = 0;
    return vm_cli_fail("--labels: '%s' is not all or a list such as 1,3,7 or 2-5", s);
}

int vm_cli_parse_label_sizes(const char *s, vm_label_size **sizes, size_t *n) {
    *sizes = NULL;
    *n = 0;
    size_t cap = 0;
    const char *p = s;
    for (;;) {
        char *end;
        errno = 0;
        long l = strtol(p, &end, 10);
        if (end == p || errno || l < INT32_MIN || l > INT32_MAX || *end != ':') goto bad;
        const char *q = end + 1;
        double x = strtod(q, &end);
        if (end == q || errno || (*end != 0 && *end != ',')) goto bad;
        if (!(x > 0) || !isfinite(x)) {
            free(*sizes);
            *sizes = NULL;
            *n = 0;
            return vm_cli_fail("--size-per-label: size '%.*s' of label %ld is not a positive "
                               "number of voxels",
                               (int)(end - q), q, l);
        }
        if (*n == cap) {
            cap = cap ? 2 * cap : 8;
            vm_label_size *t = realloc(*sizes, cap * sizeof *t);
            if (!t) {
                free(*sizes);
                *sizes = NULL;
                *n = 0;
                return vm_cli_fail("--size-per-label: out of memory");
            }
            *sizes = t;
        }
        (*sizes)[*n].label = (int32_t)l;
        (*sizes)[(*n)++].size = x;
        if (*end == 0) return 0;
        p = end + 1;
    }
bad:
    free(*sizes);
    *sizes = NULL;
    *n = 0;
    return vm_cli_fail("--size-per-label: '%s' is not a list of LABEL:SIZE such as 3:0.5,7:2", s);
}

int vm_cli_parse_label_edges(const char *s, vm_label_edge **edges, size_t *n) {
    *edges = NULL;
    *n = 0;
    size_t cap = 0;
    const char *p = s;
    for (;;) {
        char *end;
        errno = 0;
        long l = strtol(p, &end, 10);
        if (end == p || errno || l < INT32_MIN || l > INT32_MAX || *end != '=') break;
        const char *q = end + 1;
        double x = strtod(q, &end);
        if (end == q || errno || (*end != 0 && *end != ',')) break;
        if (!(x > 0) || !isfinite(x)) {
            free(*edges);
            *edges = NULL;
            *n = 0;
            return vm_cli_fail("--label-edge: edge '%.*s' of label %ld is not a length > 0",
                               (int)(end - q), q, l);
        }
        if (*n == cap) {
            cap = cap ? 2 * cap : 8;
            vm_label_edge *t = realloc(*edges, cap * sizeof *t);
            if (!t) {
                free(*edges);
                *edges = NULL;
                *n = 0;
                return vm_cli_fail("--label-edge: out of memory");
            }
            *edges = t;
        }
        (*edges)[*n].label = (int32_t)l;
        (*edges)[(*n)++].edge = x;
        if (*end == 0) return 0;
        p = end + 1;
    }
    free(*edges);
    *edges = NULL;
    *n = 0;
    return vm_cli_fail("--label-edge: '%s' is not a list of LABEL=L such as 3=0.8,7=4 (L in "
                       "world units)",
                       s);
}

/* The lines that say what was not kept, or kept only coarsely: a label without an element
 * (and why), the pieces --min-island relabelled, a label that --size kept as the one block
 * where it has the most voxels. */
typedef struct label_notes {
    char **line;
    size_t n;
    size_t kept; /* labels with at least one element */
} label_notes;

static void notes_free(label_notes *nt) {
    for (size_t i = 0; i < nt->n; i++) free(nt->line[i]);
    free(nt->line);
    memset(nt, 0, sizeof *nt);
}

static int notes_add(label_notes *nt, const char *fmt, ...) {
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    char **t = realloc(nt->line, (nt->n + 1) * sizeof *t);
    if (!t) return -1;
    nt->line = t;
    if (!(t[nt->n] = malloc(strlen(buf) + 1))) return -1;
    strcpy(t[nt->n++], buf);
    return 0;
}

static int make_notes(const vm_label_stats *st, const vm_label_options *lo, label_notes *nt) {
    memset(nt, 0, sizeof *nt);
    int rc = 0;
    for (size_t i = 0; i < st->nlabels && !rc; i++) {
        const vm_label_info *l = &st->labels[i];
        if (l->elements) nt->kept++;
        if (!l->elements) {
            const char *why;
            if (l->islands_removed)
                why = "--min-island relabelled all its pieces";
            else if (lo->cell_size > 1 && !l->rescued)
                why = "at --size it is most frequent in no block, and the block where it has "
                      "the most voxels is another label's only one";
            else
                why = "the topology repair relabelled its last cells";
            rc = notes_add(nt, "label %ld (%zu voxel%s in) has no element and is not in the "
                               "mesh: %s",
                           (long)l->label, l->input_voxels, l->input_voxels == 1 ? "" : "s",
                           why);
        } else if (l->islands_removed) {
            rc = notes_add(nt, "label %ld: %zu piece%s (%zu cell%s) below --min-island %zu "
                               "relabelled to their neighbours",
                           (long)l->label, l->islands_removed,
                           l->islands_removed == 1 ? "" : "s", l->island_cells_removed,
                           l->island_cells_removed == 1 ? "" : "s",
                           lo->min_island);
        }
        if (!rc && l->elements && l->rescued)
            rc = notes_add(nt, "label %ld (%zu voxel%s in) is most frequent in no %d^3 block "
                               "at --size %d: kept as the block where it has the most voxels "
                               "(%zu meshed cell%s; --size-per-label %ld:1 meshes it finer)",
                           (long)l->label, l->input_voxels, l->input_voxels == 1 ? "" : "s",
                           lo->cell_size, lo->cell_size,
                           l->meshed_voxels, l->meshed_voxels == 1 ? "" : "s", (long)l->label);
    }
    if (rc) {
        notes_free(nt);
        return vm_cli_fail("mesh: out of memory");
    }
    return 0;
}

/* Prints the summary of m, whose vm_mesh_check is *checked. */
static int report(const vm_mesh *m, const vm_mesh_report *checked, const vm_label_stats *st,
                  const label_notes *nt, int json, const char *out,
                  const vm_improve_report *ir) {
    const vm_mesh_report r = *checked;
    const char *kind = m->kind == VM_HEX8 ? "hexes" : "tets";
    if (json) {
        vm_cli_json_summary_open(out);
        printf("\"elements\": %zu, \"points\": %zu, \"inverted\": %zu, "
               "\"overshared_faces\": %zu, \"boundary_faces\": %zu, \"boundary_closed\": %s, "
               "\"boundary_euler\": %ld, \"components\": %zu, \"volume\": %.17g, "
               "\"min_scaled_jacobian\": %.6f, \"island_voxels\": %zu, "
               "\"topology_voxels\": %zu, \"relaxed_vertices\": %zu, \"seconds\": %.3f, "
               "\"cell_size\": %.6g, \"coarse_cells\": %zu, ",
               m->ncells, m->npoints, r.inverted, r.overshared_faces, r.boundary_faces,
               r.boundary_closed ? "true" : "false", r.boundary_euler, r.components, r.volume,
               r.min_scaled_jacobian, st->island_voxels, st->topology_voxels,
               st->relaxed_vertices, st->seconds, st->cell_size, st->coarse_cells);
        if (ir)
            printf("\"improve\": {\"min_dihedral_before\": %.4f, \"max_dihedral_before\": %.4f, "
                   "\"min_dihedral_after\": %.4f, \"max_dihedral_after\": %.4f, "
                   "\"abaqus_before\": %zu, \"abaqus_after\": %zu, "
                   "\"max_interface_move\": %.6g, \"seconds\": %.3f}, ",
                   ir->min_dihedral_before, ir->max_dihedral_before, ir->min_dihedral_after,
                   ir->max_dihedral_after, ir->abaqus_before, ir->abaqus_after,
                   ir->max_interface_move, ir->seconds);
        printf("\"labels_meshed\": %zu, \"labels_asked\": %zu, \"labels_lost\": [", nt->kept,
               st->nlabels);
        for (size_t i = 0, k = 0; i < st->nlabels; i++)
            if (!st->labels[i].elements)
                printf("%s%ld", k++ ? ", " : "", (long)st->labels[i].label);
        printf("], \"warnings\": [");
        for (size_t i = 0; i < nt->n; i++) {
            printf("%s\"", i ? ", " : "");
            for (const char *c = nt->line[i]; *c; c++)
                printf(*c == '"' || *c == '\\' ? "\\%c" : "%c", *c);
            printf("\"");
        }
        printf("], \"labels\": [");
        for (size_t i = 0; i < st->nlabels; i++) {
            const vm_label_info *l = &st->labels[i];
            printf("%s{\"label\": %ld, \"elements\": %zu, \"volume\": %.17g, "
                   "\"voxel_volume\": %.17g, \"input_voxels\": %zu, \"meshed_voxels\": %zu, "
                   "\"size\": %.6g, \"rescued\": %s, \"islands_removed\": %zu, "
                   "\"island_cells_removed\": %zu}",
                   i ? ", " : "", (long)l->label, l->elements, l->mesh_volume, l->voxel_volume,
                   l->input_voxels, l->meshed_voxels, l->size, l->rescued ? "true" : "false",
                   l->islands_removed, l->island_cells_removed);
        }
        printf("]}\n");
        return VM_EXIT_OK;
    }
    char count[64];
    if (nt->kept == st->nlabels)
        snprintf(count, sizeof count, "%zu label%s", nt->kept, nt->kept == 1 ? "" : "s");
    else
        snprintf(count, sizeof count, "%zu labels (of %zu asked for)", nt->kept, st->nlabels);
    printf("%s: %zu %s, %zu points, %s, boundary %s (Euler %ld), volume %.6g, "
           "%zu inverted, min scaled Jacobian %.3f, %.2f s\n",
           out, m->ncells, kind, m->npoints, count, r.boundary_closed ? "closed" : "OPEN",
           r.boundary_euler, r.volume, r.inverted, r.min_scaled_jacobian, st->seconds);
    for (size_t i = 0; i < st->nlabels; i++) {
        const vm_label_info *l = &st->labels[i];
        double rel = l->voxel_volume > 0 ? 100.0 * (l->mesh_volume / l->voxel_volume - 1) : 0;
        printf("  label %ld: %zu %s, volume %.6g (voxels %.6g, %+.2f%%), %zu voxels in, "
               "%zu meshed%s\n",
               (long)l->label, l->elements, kind, l->mesh_volume, l->voxel_volume, rel,
               l->input_voxels, l->meshed_voxels,
               !l->elements ? " (LOST)" : l->rescued ? " (kept as one block)" : "");
    }
    if (st->coarse_cells || st->cell_size != 1.0)
        printf("cells: %.4g voxels along interfaces and boundary, %zu larger leaves within "
               "materials\n",
               st->cell_size, st->coarse_cells);
    if (ir)
        printf("quality pass: dihedral %.1f..%.1f -> %.1f..%.1f degrees, ABAQUS failures %zu "
               "-> %zu, interface vertices moved at most %.3g\n",
               ir->min_dihedral_before, ir->max_dihedral_before, ir->min_dihedral_after,
               ir->max_dihedral_after, ir->abaqus_before, ir->abaqus_after,
               ir->max_interface_move);
    if (st->island_voxels || st->topology_voxels)
        printf("relabelled voxels: %zu by --min-island, %zu to keep each label's boundary a "
               "manifold\n",
               st->island_voxels, st->topology_voxels);
    return VM_EXIT_OK;
}

/* Element counts and volumes per label, measured again after the quality pass. */
static void recount(const vm_mesh *m, vm_label_stats *st) {
    for (size_t i = 0; i < st->nlabels; i++) {
        st->labels[i].elements = 0;
        st->labels[i].mesh_volume = 0;
    }
    for (size_t c = 0; c < m->ncells; c++) {
        size_t lo = 0, hi = st->nlabels;
        while (lo < hi) {
            size_t md = (lo + hi) / 2;
            if (st->labels[md].label < m->region[c])
                lo = md + 1;
            else
                hi = md;
        }
        if (lo == st->nlabels || st->labels[lo].label != m->region[c]) continue;
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * c + k], sizeof p[k]);
        st->labels[lo].elements++;
        st->labels[lo].mesh_volume += vm_tet_signed_volume((const double(*)[3])p);
    }
}

/* --labels: meshes, improves per material, writes, checks and sums up per label. */
int vm_cli_mesh_labels(const vm_volume *v, const char *in, const char *out, const char *surface,
                       const vm_label_options *lo, const vm_mesh_write_options *wo, int json,
                       int quality_fields, const char *html, int improve, int verbose) {
    vm_mesh m;
    vm_label_stats st;
    vm_error err;
    vm_error_clear(&err);
    if (vm_mesh_labels(v, lo, &m, &st, &err)) return vm_cli_fail("%s: %s", in, err.message);
    label_notes nt;
    vm_cli_stage_line(verbose, "labels", st.seconds_grid);
    vm_cli_stage_line(verbose, "repair", st.seconds_repair);
    vm_cli_stage_line(verbose, "mesh", st.seconds_mesh);
    vm_status s = VM_OK;
    vm_improve_report ir;
    int improved = 0;
    if (improve && m.kind == VM_TET4) {
        /* per material: interfaces are constrained surfaces (see docs/LABELS.md) */
        vm_improve_options io;
        vm_improve_options_default(&io);
        io.progress = lo->progress;
        io.progress_user = lo->progress_user;
        io.max_edge = lo->max_edge;
        s = vm_mesh_improve(&m, NULL, &io, &ir, &err);
        if (s) {
            vm_label_stats_free(&st);
            vm_mesh_free(&m);
            return vm_cli_fail("%s: %s", in, err.message);
        }
        improved = 1;
        st.seconds += ir.seconds;
        recount(&m, &st);
        vm_cli_stage_line(verbose, "improve", ir.seconds);
    }
    double t = vm_cli_clock();
    if (quality_fields) s = vm_mesh_add_quality_fields(&m, NULL, &err);
    if (!s) s = vm_mesh_write_as(out, &m, wo, &err);
    if (!s && surface) {
        vm_mesh surf;
        vm_mesh_write_options so;
        vm_mesh_write_options_init(&so);
        so.progress = wo->progress;
        so.progress_user = wo->progress_user;
        s = vm_mesh_boundary(&m, &surf, &err);
        if (!s) s = vm_mesh_write_as(surface, &surf, &so, &err);
        vm_mesh_free(&surf);
    }
    if (!s) vm_cli_stage_line(verbose, "write", vm_cli_clock() - t);
    /* one check serves the summary and the HTML report */
    vm_mesh_report checked;
    if (!s) s = vm_mesh_check_with(&m, lo->progress, lo->progress_user, &checked, &err);
    int rc = s ? vm_cli_fail_err(&err) : make_notes(&st, lo, &nt);
    if (rc) {
        vm_label_stats_free(&st);
        vm_mesh_free(&m);
        return rc;
    }
    /* what was not kept, on stderr whatever the output format */
    for (size_t i = 0; i < nt.n; i++)
        fprintf(stderr, "volmesh: %s: warning: %s\n", out, nt.line[i]);
    rc = report(&m, &checked, &st, &nt, json, out, improved ? &ir : NULL);
    int quiet = lo->progress_user ? *(const int *)lo->progress_user : 0;
    int32_t *asked = malloc((st.nlabels ? st.nlabels : 1) * sizeof *asked);
    if (!rc && html && !asked) rc = vm_cli_fail("mesh: out of memory");
    if (!rc && html) {
        for (size_t i = 0; i < st.nlabels; i++) asked[i] = st.labels[i].label;
        vm_cli_report_notes notes = {asked, st.nlabels, (const char *const *)nt.line, nt.n};
        rc = vm_cli_write_report_with(html, &m, out, &checked, NULL, &notes, quiet);
    }
    free(asked);
    notes_free(&nt);
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    return rc;
}
