/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/report_html.c — the HTML quality report: one self-contained page (no network)
 * with the mesh summary, the quality histograms (inline SVG) and pictures of the mesh drawn
 * by the built-in renderer (inline PNG), the worst elements highlighted. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "../io/io_util.h"
#include "volmesh/quality.h"
#include "volmesh/render.h"

/* The worst elements drawn in red (the captions say the same): tets with a dihedral angle
 * below 10 degrees (the report's slivers_10), hexes with a scaled Jacobian
 * below 0.2 (verdict's acceptable range starts at 0.5; 0.2 leaves only the poor ones). */
#define WORST_TET_DIHEDRAL 10.0
#define WORST_HEX_JACOBIAN 0.2

/* Writes s with the HTML special characters escaped. */
static void put_escaped(FILE *fp, const char *s) {
    for (; s && *s; s++) {
        if (*s == '<') fputs("&lt;", fp);
        else if (*s == '>') fputs("&gt;", fp);
        else if (*s == '&') fputs("&amp;", fp);
        else if (*s == '"') fputs("&quot;", fp);
        else fputc(*s, fp);
    }
}

/* Writes b[0..n) in base64. */
static void put_base64(FILE *fp, const unsigned char *b, size_t n) {
    static const char tab[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)b[i] << 16;
        if (i + 1 < n) v |= (unsigned)b[i + 1] << 8;
        if (i + 2 < n) v |= b[i + 2];
        fputc(tab[(v >> 18) & 63], fp);
        fputc(tab[(v >> 12) & 63], fp);
        fputc(i + 1 < n ? tab[(v >> 6) & 63] : '=', fp);
        fputc(i + 2 < n ? tab[v & 63] : '=', fp);
    }
}

/* Renders one view and writes it as an <img> with a caption. */
static vm_status put_picture(FILE *fp, const vm_mesh *m, const vm_render_options *o,
                             const char *caption, vm_error *err) {
    vm_image img;
    vm_status s = vm_render_mesh(m, o, &img, err);
    if (s) return s;
    unsigned char *png = NULL;
    size_t len = 0;
    s = vm_image_encode_png(&img, &png, &len, err);
    if (!s) {
        fprintf(fp, "<figure><img alt=\"");
        put_escaped(fp, caption);
        fprintf(fp, "\" width=\"%d\" height=\"%d\" src=\"data:image/png;base64,", img.width,
                img.height);
        put_base64(fp, png, len);
        fprintf(fp, "\"><figcaption>");
        put_escaped(fp, caption);
        fprintf(fp, "</figcaption></figure>\n");
    }
    free(png);
    vm_image_free(&img);
    return s;
}

/* The histogram SVG, written by vm_quality_write_svg, copied inline without its prolog. */
static vm_status put_histograms(FILE *fp, const char *path, const char *name,
                                const vm_quality_summary *q, vm_error *err) {
    char tmp[4200];
    if (!vm__temp_path(path, "svg", tmp, sizeof tmp))
        return vm_error_set(err, VM_ERR_ARG, "%s: path too long", path);
    int tracked = vm__temp_track(tmp); /* a signal removes it too */
    vm_status s = vm_quality_write_svg(tmp, name, q, err);
    unsigned char *buf = NULL;
    size_t len = 0;
    if (!s) s = vm__read_file(tmp, (size_t)1 << 28, &buf, &len, err);
    remove(tmp);
    vm__temp_untrack(tracked);
    if (s) return s;
    char *svg = strstr((char *)buf, "<svg");
    if (svg) fputs(svg, fp);
    free(buf);
    return VM_OK;
}

static void row(FILE *fp, const char *key, const char *fmt, double v) {
    fprintf(fp, "<tr><th>%s</th><td>", key);
    fprintf(fp, fmt, v);
    fprintf(fp, "</td></tr>\n");
}

/* One distance row: world units, and voxels when the voxel length is known; a NaN mean and
 * no samples leave those cells empty. */
static void distance_row(FILE *fp, const char *what, double max, double mean, size_t samples,
                         double voxel) {
    fprintf(fp, "<tr><th>%s</th><td>%.6g</td><td>", what, max);
    if (!isnan(mean)) fprintf(fp, "%.6g", mean);
    fputs("</td><td>", fp);
    if (voxel > 0) fprintf(fp, "%.4g", max / voxel);
    fputs("</td><td>", fp);
    if (voxel > 0 && !isnan(mean)) fprintf(fp, "%.4g", mean / voxel);
    fputs("</td><td>", fp);
    if (samples) fprintf(fp, "%zu", samples);
    fputs("</td></tr>\n", fp);
}

/* The achieved distance to the isosurface, both ways, when it was measured. */
static void put_distance(FILE *fp, const vm_quality_summary *q) {
    if (!q->has_distance) return;
    const vm_surface_distance *d = &q->distance;
    fprintf(fp,
            "<h2>Distance to the isosurface</h2>\n<p>Two-sided (Hausdorff) distance "
            "between the mesh boundary and the isosurface of the volume's trilinear field, "
            "measured by volmesh, in world units and in voxels (one voxel: %.6g, the edge "
            "of a cube of one voxel's volume; the flat faces that close material on the "
            "volume's border count within its sections of the box planes; "
            "docs/QUALITY.md).</p><table>\n"
            "<tr><th></th><th>max</th><th>mean</th><th>max (voxels)</th>"
            "<th>mean (voxels)</th><th>samples</th></tr>\n",
            d->voxel);
    distance_row(fp, "boundary &rarr; isosurface", d->mesh_to_surface_max,
                 d->mesh_to_surface_mean, d->mesh_samples, d->voxel);
    distance_row(fp, "isosurface &rarr; boundary", d->surface_to_mesh_max,
                 d->surface_to_mesh_mean, d->surface_samples, d->voxel);
    distance_row(fp, "Hausdorff (the larger max)", d->hausdorff, NAN, 0, d->voxel);
    fprintf(fp, "</table>\n");
    if (isfinite(d->mesh_to_surface_ijk[0]) || isfinite(d->surface_to_mesh_ijk[0])) {
        fputs("<p>Where the maxima are (voxel index i, j, k):", fp);
        if (isfinite(d->mesh_to_surface_ijk[0]))
            fprintf(fp, " the farthest boundary point at (%.2f, %.2f, %.2f);",
                    d->mesh_to_surface_ijk[0], d->mesh_to_surface_ijk[1],
                    d->mesh_to_surface_ijk[2]);
        if (isfinite(d->surface_to_mesh_ijk[0]))
            fprintf(fp, " the farthest isosurface point at (%.2f, %.2f, %.2f).",
                    d->surface_to_mesh_ijk[0], d->surface_to_mesh_ijk[1],
                    d->surface_to_mesh_ijk[2]);
        fputs("</p>\n", fp);
    }
}

/* The edge-length histogram as a table (the picture below draws it too). */
static void put_edges(FILE *fp, const vm_quality_summary *q) {
    const vm_edge_stats *e = &q->edges;
    if (!e->edges) return;
    fprintf(fp, "<h2>Edge lengths</h2>\n<p>%zu edges, each counted once, in world units: "
                "%.6g .. %.6g, mean %.6g.</p><table>\n<tr><th>length</th><th>edges</th></tr>\n",
            e->edges, e->min, e->max, e->mean);
    double w = (e->hi - e->lo) / VM_QUALITY_BINS;
    for (int b = 0; b < VM_QUALITY_BINS; b++)
        fprintf(fp, "<tr><td>%.5g .. %.5g</td><td>%zu</td></tr>\n", e->lo + w * b,
                e->lo + w * (b + 1), e->bins[b]);
    fprintf(fp, "</table>\n");
}

/* Whether the mesh holds a cell of region r. */
static int has_region(const vm_quality_summary *q, int32_t r) {
    size_t shown = q->nregions < VM_QUALITY_MAX_REGIONS ? q->nregions : VM_QUALITY_MAX_REGIONS;
    for (size_t i = 0; i < shown; i++)
        if (q->regions[i].region == r) return 1;
    return q->nregions > shown && r > q->regions[shown - 1].region;
}

/* Cells per region, for a mesh with two or more (or regions asked for); the regions asked
 * for and missing; the caller's warnings. */
static void put_regions(FILE *fp, const vm_quality_summary *q) {
    if (q->nregions >= 2 || q->nexpected_regions) {
        size_t shown =
            q->nregions < VM_QUALITY_MAX_REGIONS ? q->nregions : VM_QUALITY_MAX_REGIONS;
        fprintf(fp, "<h2>Regions</h2>\n<table><tr><th>region</th><th>%s</th></tr>\n",
                q->kind == VM_TET4 ? "tets" : q->kind == VM_HEX8 ? "hexes" : "cells");
        for (size_t i = 0; i < shown; i++)
            fprintf(fp, "<tr><td>%ld</td><td>%zu</td></tr>\n", (long)q->regions[i].region,
                    q->regions[i].cells);
        if (q->nregions > shown)
            fprintf(fp, "<tr><td>%zu more</td><td>%zu</td></tr>\n", q->nregions - shown,
                    q->regions_more_cells);
        for (size_t i = 0; i < q->nexpected_regions; i++)
            if (!has_region(q, q->expected_regions[i]))
                fprintf(fp, "<tr class=\"bad\"><td>%ld</td><td>0 (asked for, not in the "
                            "mesh)</td></tr>\n",
                        (long)q->expected_regions[i]);
        fprintf(fp, "</table>\n");
    }
    if (q->nwarnings) {
        fprintf(fp, "<h2>Warnings</h2>\n<ul>\n");
        for (size_t i = 0; i < q->nwarnings; i++) {
            fputs("<li class=\"bad\">", fp);
            put_escaped(fp, q->warnings[i]);
            fputs("</li>\n", fp);
        }
        fprintf(fp, "</ul>\n");
    }
}

vm_status vm_quality_write_html(const char *path, const vm_mesh *m, const char *name,
                                const vm_quality_summary *q, vm_error *err) {
    vm_outfile out;
    vm_status s = vm__out_open(&out, path, err);
    if (s) return s;
    FILE *fp = out.fp;
    const vm_mesh_report *r = &q->check;
    int tets = m->kind == VM_TET4, hexes = m->kind == VM_HEX8;
    fprintf(fp, "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
                "<title>volmesh report: ");
    put_escaped(fp, name);
    fprintf(fp, "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;"
                "color:#222}table{border-collapse:collapse}th,td{padding:.25em .8em;border-bottom:"
                "1px solid #ddd;text-align:left}td{font-variant-numeric:tabular-nums}figure{"
                "display:inline-block;margin:.5em}figcaption{color:#555;font-size:90%%}.ok{color:"
                "#176c2d}.bad{color:#b3261e;font-weight:bold}</style></head><body>\n");
    fprintf(fp, "<h1>Mesh quality: ");
    put_escaped(fp, name);
    fprintf(fp, "</h1>\n<p>%zu %s, %zu points. ", m->ncells, vm_cell_kind_name(m->kind),
            m->npoints);
    int valid = r->inverted == 0 && r->overshared_faces == 0 && r->boundary_closed;
    fprintf(fp, "<span class=\"%s\">%s</span></p>\n", valid ? "ok" : "bad",
            valid ? "Valid: no inverted elements, conforming, closed boundary."
                  : "Not valid: see the checks below.");
    fprintf(fp, "<h2>Checks</h2><table>\n");
    row(fp, "inverted elements", "%.0f", (double)r->inverted);
    row(fp, "faces shared by more than two elements", "%.0f", (double)r->overshared_faces);
    fprintf(fp, "<tr><th>boundary</th><td>%s, %zu faces, Euler characteristic %ld, %zu "
                "components</td></tr>\n",
            r->boundary_closed ? "closed" : "OPEN", r->boundary_faces, r->boundary_euler,
            r->boundary_components);
    row(fp, "boundary self-intersections (triangle pairs)", "%.0f",
        (double)r->boundary_self_intersections);
    row(fp, "connected components", "%.0f", (double)r->components);
    row(fp, "volume", "%.9g", r->volume);
    if (tets) {
        fprintf(fp, "<tr><th>dihedral angles</th><td>%.2f&deg; .. %.2f&deg;</td></tr>\n",
                r->min_dihedral, r->max_dihedral);
        fprintf(fp, "<tr><th>slivers</th><td>%zu below 5&deg;, %zu below 10&deg;</td></tr>\n",
                r->slivers_5, r->slivers_10);
    }
    if (q->has_abaqus)
        fprintf(fp, "<tr><th>ABAQUS element check</th><td class=\"%s\">%zu failures (volume "
                    "measure &lt; 0.02: %zu, face angle &lt; 10&deg;: %zu, &gt; 160&deg;: "
                    "%zu)</td></tr>\n",
                q->abaqus_failures ? "bad" : "ok", q->abaqus_failures, q->abaqus_volume,
                q->abaqus_small_angle, q->abaqus_large_angle);
    if (hexes) row(fp, "min scaled Jacobian", "%.4f", r->min_scaled_jacobian);
    fprintf(fp, "<tr><th>edge length (each edge once)</th><td>%.6g .. %.6g, mean %.6g, %zu "
                "edges</td></tr>\n",
            q->edges.min, q->edges.max, q->edges.mean, q->edges.edges);
    fprintf(fp, "</table>\n");
    put_distance(fp, q);
    put_regions(fp, q);
    put_edges(fp, q);
    fprintf(fp, "<h2>Metrics</h2><table><tr><th>metric</th><th>min</th><th>mean"
                "</th><th>max</th><th>outside the acceptable range</th></tr>\n");
    for (size_t i = 0; i < q->nmetrics; i++) {
        const vm_metric_stats *ms = &q->metrics[i];
        fprintf(fp, "<tr><th>%s</th><td>%.6g</td><td>%.6g</td><td>%.6g</td><td>%zu</td></tr>\n",
                ms->info->name, ms->min, ms->mean, ms->max, ms->unacceptable);
    }
    fprintf(fp, "</table>\n<h2>Pictures</h2>\n");
    vm_render_options o;
    vm_render_options_default(&o);
    o.width = 640;
    o.height = 480;
    s = put_picture(fp, m, &o, "the boundary", err);
    if (!s && (tets || hexes)) {
        o.cut = VM_CUT_AUTO;
        o.highlight = tets ? "min_dihedral" : "scaled_jacobian";
        o.highlight_threshold = tets ? WORST_TET_DIHEDRAL : WORST_HEX_JACOBIAN;
        o.highlight_hidden = 1;
        s = put_picture(fp, m, &o,
                        tets ? "cut-away; red: tets with a dihedral angle below 10 degrees"
                             : "cut-away; red: hexes with scaled Jacobian below 0.2",
                        err);
    }
    if (!s) {
        fprintf(fp, "<h2>Histograms</h2>\n");
        s = put_histograms(fp, path, name, q, err);
    }
    if (!s) fprintf(fp, "\n<p><small>volmesh</small></p></body></html>\n");
    if (s) {
        vm__out_abort(&out);
        return s;
    }
    return vm__out_commit(&out, err);
}
