/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_report.c — vm_quality_report, its lookup keys and writers (text, JSON,
 * SVG, per-cell CSV), and vm_mesh_add_quality_fields, on meshes with known answers: a cube
 * cut into six Kuhn tets, the same with a sliver glued on, a hex block, a triangle fan, an
 * empty mesh and a mesh with a bad node index. */
#define _POSIX_C_SOURCE 200809L
#include "test.h"
#include <string.h>
#include <unistd.h>

/* --- builders ---------------------------------------------------------------------------- */

static const double cube_pts[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                      {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};

/* The unit cube as six Kuhn tets around the 0-6 diagonal, all positive. */
static void kuhn_cube(vm_mesh *m) {
    static const vm_index tets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                        {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    vm_mesh_init(m, VM_TET4);
    for (int i = 0; i < 8; i++) CHECK(vm_mesh_add_point(m, cube_pts[i], NULL) == i);
    for (int t = 0; t < 6; t++) {
        vm_index n[4];
        memcpy(n, tets[t], sizeof n);
        double p[4][3];
        for (int k = 0; k < 4; k++) memcpy(p[k], cube_pts[n[k]], sizeof p[k]);
        if (vm_tet_signed_volume((const double(*)[3])p) < 0) {
            vm_index s = n[1];
            n[1] = n[2];
            n[2] = s;
        }
        CHECK_OK(vm_mesh_add_cell(m, n, 1, NULL), NULL);
    }
}

/* Adds a separate sliver (four nearly coplanar points: min dihedral under 1 degree, ABAQUS
 * volume measure 0.013, face angles 45..90). */
static void add_sliver(vm_mesh *m) {
    const double s[4][3] = {{3, 0, 0}, {4, 0, 0}, {3.5, 0.5, 0.005}, {3.5, -0.5, 0.005}};
    vm_index base = (vm_index)m->npoints;
    for (int i = 0; i < 4; i++) vm_mesh_add_point(m, s[i], NULL);
    vm_index n[4] = {base, base + 1, base + 2, base + 3};
    if (vm_tet_signed_volume(s) < 0) {
        n[1] = base + 2;
        n[2] = base + 1;
    }
    CHECK_OK(vm_mesh_add_cell(m, n, 2, NULL), NULL);
}

static char *slurp(const char *path) {
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    char *s = malloc((size_t)n + 1);
    size_t got = fread(s, 1, (size_t)n, fp);
    s[got] = 0;
    fclose(fp);
    return s;
}

static size_t count_of(const char *s, const char *what) {
    size_t n = 0;
    for (const char *p = s; (p = strstr(p, what)) != NULL; p += strlen(what)) n++;
    return n;
}

static const vm_metric_stats *stats_of(const vm_quality_summary *q, const char *name) {
    for (size_t k = 0; k < q->nmetrics; k++)
        if (strcmp(q->metrics[k].info->name, name) == 0) return &q->metrics[k];
    return NULL;
}

/* --- the report -------------------------------------------------------------------------- */

static void reportOfKuhnCubeHasExactStatistics(void) {
    vm_mesh m;
    kuhn_cube(&m);
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.check.cells == 6 && q.check.inverted == 0 && q.check.boundary_closed);
    CHECK(q.check.boundary_euler == 2 && q.check.components == 1);
    CHECK_NEAR(q.check.volume, 1.0, 1e-14);
    CHECK(q.nmetrics == 10 && q.has_abaqus);
    /* Every Kuhn tet is congruent: dihedrals 45, 60 and 90 degrees, face angles 45..90. */
    const vm_metric_stats *d = stats_of(&q, "min_dihedral");
    CHECK(d != NULL);
    if (d) {
        CHECK_NEAR(d->min, 45.0, 1e-9);
        CHECK_NEAR(d->mean, 45.0, 1e-9);
        CHECK_NEAR(d->max, 45.0, 1e-9);
        /* 45 deg lies in bin 11 of 0..80 (4 deg bins) and is below Verdict's 40? no: above,
         * but 45 is inside 40..70.5, so nothing is unacceptable. */
        CHECK(d->bins[11] == 6 && d->unacceptable == 0 && d->below == 0 && d->above == 0);
    }
    const vm_metric_stats *v = stats_of(&q, "volume");
    CHECK(v != NULL);
    if (v) {
        CHECK_NEAR(v->mean, 1.0 / 6.0, 1e-15);
        /* Auto range: all values equal, so the range is min..min+1 and all land in bin 0. */
        CHECK(v->bins[0] == 6);
    }
    size_t total = 0;
    for (size_t k = 0; k < q.nmetrics; k++) {
        total = 0;
        for (int b = 0; b < VM_QUALITY_BINS; b++) total += q.metrics[k].bins[b];
        CHECK_MSG(total == 6, "%s histogram holds %zu cells", q.metrics[k].info->name, total);
    }
    CHECK(q.abaqus_failures == 0 && q.check.slivers_10 == 0);
    double x;
    CHECK(vm_quality_lookup(&q, "elements", &x) == VM_OK && x == 6);
    CHECK(vm_quality_lookup(&q, "min_dihedral", &x) == VM_OK && fabs(x - 45.0) < 1e-9);
    CHECK(vm_quality_lookup(&q, "radius_ratio.max", &x) == VM_OK && x > 1.0);
    CHECK(vm_quality_lookup(&q, "abaqus_failures", &x) == VM_OK && x == 0);
    CHECK(vm_quality_lookup(&q, "boundary_closed", &x) == VM_OK && x == 1);
    CHECK(vm_quality_lookup(&q, "radius_ratio.median", &x) == VM_ERR_ARG);
    CHECK(vm_quality_lookup(&q, "nonsense", &x) == VM_ERR_ARG);
    CHECK(vm_quality_lookup(&q, "skew.max", &x) == VM_ERR_ARG);
    vm_mesh_free(&m);
}

static void sliversAndAbaqusFailuresAreCounted(void) {
    vm_mesh m;
    kuhn_cube(&m);
    add_sliver(&m);
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.check.cells == 7 && q.check.components == 2);
    CHECK(q.check.slivers_5 == 1 && q.check.slivers_10 == 1);
    CHECK(q.abaqus_failures == 1 && q.abaqus_volume == 1);
    CHECK(q.abaqus_small_angle == 0 && q.abaqus_large_angle == 0);
    CHECK(q.abaqus_nlist == 1 && q.abaqus_list[0] == 6);
    const vm_metric_stats *d = stats_of(&q, "min_dihedral");
    CHECK(d && d->argmin == 6 && d->min < 5.0 && d->unacceptable == 1);
    const vm_metric_stats *r = stats_of(&q, "radius_ratio");
    CHECK(r && r->argmax == 6 && r->above == 1 && r->bins[VM_QUALITY_BINS - 1] >= 1);
    double x;
    CHECK(vm_quality_lookup(&q, "slivers_10", &x) == VM_OK && x == 1);
    vm_mesh_free(&m);
}

static void hexReportHasNoDihedralsOrAbaqus(void) {
    vm_mesh m;
    vm_mesh_init(&m, VM_HEX8);
    for (int i = 0; i < 8; i++) vm_mesh_add_point(&m, cube_pts[i], NULL);
    const vm_index n[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    CHECK_OK(vm_mesh_add_cell(&m, n, 1, NULL), NULL);
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.nmetrics == 6 && !q.has_abaqus);
    double x;
    CHECK(vm_quality_lookup(&q, "min_dihedral", &x) == VM_ERR_ARG);
    CHECK(vm_quality_lookup(&q, "abaqus_failures", &x) == VM_ERR_ARG);
    CHECK(vm_quality_lookup(&q, "skew.max", &x) == VM_OK && x == 0);
    CHECK(vm_quality_lookup(&q, "min_scaled_jacobian", &x) == VM_OK && x == 1);
    FILE *fp = fopen(vm_test_tmp("report_hex.json"), "w");
    CHECK(fp && vm_quality_write_json(fp, "cube", &q) == 0);
    if (fp) fclose(fp);
    char *s = slurp(vm_test_tmp("report_hex.json"));
    CHECK(s && strstr(s, "\"min_dihedral\": null") && strstr(s, "\"abaqus_failures\": null"));
    CHECK(s && strstr(s, "\"kind\": \"hex8\""));
    free(s);
    vm_mesh_free(&m);
}

static void edgeLengthsCountEachEdgeOnce(void) {
    /* The Kuhn cube: 12 cube edges (1), 6 face diagonals (sqrt 2), the body diagonal (sqrt 3),
     * shared among six tets that list 36 edges. */
    vm_mesh m;
    kuhn_cube(&m);
    vm_edge_stats e;
    vm_error err;
    CHECK_OK(vm_mesh_edge_lengths(&m, &e, &err), &err);
    CHECK(e.edges == 19);
    CHECK_NEAR(e.min, 1.0, 1e-15);
    CHECK_NEAR(e.max, sqrt(3.0), 1e-15);
    CHECK_NEAR(e.mean, (12.0 + 6.0 * sqrt(2.0) + sqrt(3.0)) / 19.0, 1e-15);
    CHECK(e.lo == e.min && e.hi == e.max);
    size_t total = 0;
    for (int b = 0; b < VM_QUALITY_BINS; b++) total += e.bins[b];
    CHECK(total == 19 && e.bins[0] == 12 && e.bins[VM_QUALITY_BINS - 1] == 1);
    /* sqrt 2 is at (sqrt2 - 1) / (sqrt3 - 1) = 0.566 of the range: bin 11 */
    CHECK(e.bins[11] == 6);
    /* the report carries them, with the lookup keys */
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(memcmp(&q.edges, &e, sizeof e) == 0);
    double x;
    CHECK(vm_quality_lookup(&q, "edges", &x) == VM_OK && x == 19);
    CHECK(vm_quality_lookup(&q, "edge_length.max", &x) == VM_OK && x == e.max);
    CHECK(vm_quality_lookup(&q, "hausdorff", &x) == VM_ERR_ARG);
    vm_mesh_free(&m);
    /* one hex: its 12 edges; a quad: 4; a repeated node makes no edge */
    vm_mesh_init(&m, VM_HEX8);
    for (int i = 0; i < 8; i++) vm_mesh_add_point(&m, cube_pts[i], NULL);
    const vm_index h[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    CHECK_OK(vm_mesh_add_cell(&m, h, 1, NULL), NULL);
    CHECK_OK(vm_mesh_edge_lengths(&m, &e, &err), &err);
    CHECK(e.edges == 12 && e.min == 1 && e.max == 1 && e.hi == 2 && e.bins[0] == 12);
    vm_mesh_free(&m);
    vm_mesh_init(&m, VM_TRI3);
    for (int i = 0; i < 3; i++) vm_mesh_add_point(&m, cube_pts[i], NULL);
    const vm_index t[3] = {0, 1, 1};
    CHECK_OK(vm_mesh_add_cell(&m, t, 1, NULL), NULL);
    CHECK_OK(vm_mesh_edge_lengths(&m, &e, &err), &err);
    CHECK(e.edges == 1 && e.min == 1);
    vm_mesh_free(&m);
}

static void cellsPerRegionAreCountedAndListed(void) {
    vm_mesh m;
    kuhn_cube(&m); /* six tets of region 1 */
    add_sliver(&m); /* one of region 2 */
    m.region[3] = -5;
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.nregions == 3 && q.regions_more_cells == 0);
    CHECK(q.regions[0].region == -5 && q.regions[0].cells == 1);
    CHECK(q.regions[1].region == 1 && q.regions[1].cells == 5);
    CHECK(q.regions[2].region == 2 && q.regions[2].cells == 1);
    /* regions far apart take the sorting path, with the same answer */
    m.region[3] = -2000000000;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.nregions == 3 && q.regions[0].region == -2000000000 && q.regions[1].cells == 5);
    FILE *fp = fopen(vm_test_tmp("report_regions.txt"), "w");
    CHECK(fp && vm_quality_write_text(fp, "r", &q, 0) == 0);
    if (fp) fclose(fp);
    char *s = slurp(vm_test_tmp("report_regions.txt"));
    CHECK(s && strstr(s, "regions      3") && strstr(s, "  region 2 "));
    free(s);
    fp = fopen(vm_test_tmp("report_regions.json"), "w");
    CHECK(fp && vm_quality_write_json(fp, "r", &q) == 0);
    if (fp) fclose(fp);
    s = slurp(vm_test_tmp("report_regions.json"));
    CHECK(s && strstr(s, "\"regions\": 3, \"cells_per_region\": [{\"region\": -2000000000, "
                         "\"cells\": 1}, {\"region\": 1, \"cells\": 5}"));
    CHECK(s && strstr(s, "\"surface_distance\": null"));
    free(s);
    vm_mesh_free(&m);
}

static void emptyMeshReportsZeros(void) {
    vm_mesh m;
    vm_mesh_init(&m, VM_TET4);
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(q.check.cells == 0 && q.abaqus_failures == 0);
    for (size_t k = 0; k < q.nmetrics; k++)
        CHECK(q.metrics[k].min == 0 && q.metrics[k].max == 0 && q.metrics[k].mean == 0);
    FILE *fp = fopen(vm_test_tmp("report_empty.txt"), "w");
    CHECK(fp && vm_quality_write_text(fp, "empty", &q, 1) == 0);
    if (fp) fclose(fp);
    CHECK_OK(vm_quality_write_svg(vm_test_tmp("report_empty.svg"), "empty", &q, &err), &err);
    vm_mesh_free(&m);
}

static void badNodeIndexIsAnError(void) {
    vm_mesh m;
    kuhn_cube(&m);
    m.cells[5] = 99;
    vm_quality_summary q;
    vm_error err;
    CHECK(vm_quality_report(&m, &q, &err) == VM_ERR_ARG);
    CHECK(vm_mesh_add_quality_fields(&m, NULL, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "99") != NULL);
    CHECK(vm_quality_write_cell_csv(vm_test_tmp("bad.csv"), &m, &err) == VM_ERR_ARG);
    CHECK(!vm_test_exists(vm_test_tmp("bad.csv")));
    vm_mesh_free(&m);
}

/* --- writers ----------------------------------------------------------------------------- */

static void writersProduceTheDocumentedKeysAndFiles(void) {
    vm_mesh m;
    kuhn_cube(&m);
    add_sliver(&m);
    vm_quality_summary q;
    vm_error err;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);

    FILE *fp = fopen(vm_test_tmp("report.json"), "w");
    CHECK(fp && vm_quality_write_json(fp, "a \"quoted\" name", &q) == 0);
    if (fp) fclose(fp);
    char *s = slurp(vm_test_tmp("report.json"));
    static const char *keys[] = {"\"elements\": 7", "\"inverted\": 0", "\"min_dihedral\": ",
                                 "\"max_dihedral\": ", "\"slivers_5\": 1", "\"slivers_10\": 1",
                                 "\"abaqus_failures\": 1", "\"boundary_euler\": 4",
                                 "\"volume\": ", "\"min_scaled_jacobian\": ",
                                 "\"metrics\": {", "\"histogram\": {", "\"counts\": [",
                                 "\"file\": \"a \\\"quoted\\\" name\""};
    for (size_t i = 0; s && i < sizeof keys / sizeof keys[0]; i++)
        CHECK_MSG(strstr(s, keys[i]) != NULL, "JSON lacks %s", keys[i]);
    CHECK(s && !strstr(s, "nan") && !strstr(s, "inf"));
    free(s);

    fp = fopen(vm_test_tmp("report.txt"), "w");
    CHECK(fp && vm_quality_write_text(fp, "mesh.vtu", &q, 1) == 0);
    if (fp) fclose(fp);
    s = slurp(vm_test_tmp("report.txt"));
    CHECK(s && strstr(s, "slivers      1 below 5 deg, 1 below 10 deg"));
    CHECK(s && strstr(s, "ABAQUS       1 tet fail"));
    CHECK(s && strstr(s, "failing tets (first 1, 0-based): 6"));
    for (size_t k = 0; s && k < q.nmetrics; k++) CHECK(strstr(s, q.metrics[k].info->name));
    free(s);

    const char *svg = vm_test_tmp("report.svg");
    CHECK_OK(vm_quality_write_svg(svg, "m<&>.vtu", &q, &err), &err);
    s = slurp(svg);
    CHECK(s && strncmp(s, "<?xml", 5) == 0 && strstr(s, "</svg>"));
    /* one panel per metric, and one for the edge lengths */
    CHECK(s && count_of(s, "<g transform") == q.nmetrics + 1);
    CHECK(s && strstr(s, "edge_length"));
    CHECK(s && count_of(s, "acceptable range</title>") >= q.nmetrics - 1);
    CHECK(s && strstr(s, "m&lt;&amp;&gt;.vtu") && !strstr(s, "m<&>"));
    free(s);
    CHECK(vm_quality_write_svg("/nonexistent-dir/x.svg", "m", &q, &err) == VM_ERR_IO);

    const char *csv = vm_test_tmp("cells.csv");
    CHECK_OK(vm_quality_write_cell_csv(csv, &m, &err), &err);
    s = slurp(csv);
    const char *head = "cell,region,min_dihedral,max_dihedral,";
    CHECK(s && strncmp(s, head, strlen(head)) == 0);
    CHECK(s && count_of(s, "\n") == 8);
    CHECK(s && strstr(s, "\n6,2,"));
    free(s);
    vm_mesh_free(&m);
}

/* --- quality fields ---------------------------------------------------------------------- */

static void qualityFieldsHoldEachCellsMetric(void) {
    vm_mesh m;
    kuhn_cube(&m);
    add_sliver(&m);
    vm_error err;
    CHECK_OK(vm_mesh_add_quality_fields(&m, NULL, &err), &err);
    CHECK(m.ncell_fields == 6);
    static const char *names[] = {"min_dihedral", "max_dihedral", "radius_ratio",
                                  "aspect_ratio", "scaled_jacobian", "volume_measure"};
    for (int i = 0; i < 6; i++) {
        const vm_field *f = vm_mesh_find_field(&m, 1, names[i]);
        CHECK_MSG(f && f->ncomp == 1, "no field %s", names[i]);
        if (!f) continue;
        const vm_metric_info *mi = vm_quality_find_metric(VM_TET4, names[i]);
        for (size_t c = 0; c < m.ncells; c++) {
            double p[4][3];
            for (int k = 0; k < 4; k++)
                memcpy(p[k], m.points + 3 * (size_t)m.cells[4 * c + (size_t)k], sizeof p[k]);
            CHECK(f->data[c] == mi->eval((const double(*)[3])p));
        }
    }
    /* Again: replaced, not duplicated; a chosen list adds just those. */
    CHECK_OK(vm_mesh_add_quality_fields(&m, NULL, &err), &err);
    CHECK(m.ncell_fields == 6);
    const char *const more[] = {"edge_ratio", "min_face_angle", NULL};
    CHECK_OK(vm_mesh_add_quality_fields(&m, more, &err), &err);
    CHECK(m.ncell_fields == 8 && vm_mesh_find_field(&m, 1, "edge_ratio"));
    const char *const wrong[] = {"edge_ratio", "skew", NULL};
    CHECK(vm_mesh_add_quality_fields(&m, wrong, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "skew") != NULL && m.ncell_fields == 8);
    /* The fields survive a VTU round trip. */
    const char *path = vm_test_tmp("fields.vtu");
    CHECK_OK(vm_mesh_write(path, &m, &err), &err);
    vm_mesh back;
    CHECK_OK(vm_mesh_read(path, &back, &err), &err);
    const vm_field *f = vm_mesh_find_field(&back, 1, "radius_ratio");
    const vm_field *g = vm_mesh_find_field(&m, 1, "radius_ratio");
    CHECK(f && g && back.ncells == m.ncells);
    if (f && g)
        for (size_t c = 0; c < m.ncells; c++) CHECK(f->data[c] == g->data[c]);
    vm_mesh_free(&back);
    vm_mesh_free(&m);

    vm_mesh h;
    vm_mesh_init(&h, VM_HEX8);
    for (int i = 0; i < 8; i++) vm_mesh_add_point(&h, cube_pts[i], NULL);
    const vm_index n[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    CHECK_OK(vm_mesh_add_cell(&h, n, 1, NULL), NULL);
    CHECK_OK(vm_mesh_add_quality_fields(&h, NULL, &err), &err);
    CHECK(h.ncell_fields == 5 && vm_mesh_find_field(&h, 1, "taper"));
    vm_mesh_free(&h);
}

/* Under a tiny memory limit the fields are refused with VM_ERR_NOMEM and the mesh is
 * left as it was. */
static void qualityFieldsRespectTheMemoryLimit(void) {
    vm_mesh m;
    kuhn_cube(&m);
    vm_error err;
    setenv("VOLMESH_MAX_MEMORY", "16", 1);
    CHECK(vm_mesh_add_quality_fields(&m, NULL, &err) == VM_ERR_NOMEM);
    unsetenv("VOLMESH_MAX_MEMORY");
    CHECK(m.ncell_fields == 0);
    vm_mesh_free(&m);
}

/* A triangle surface: the boundary of the cube. */
static void surfaceReportUsesTriangleMetrics(void) {
    vm_mesh m, s;
    kuhn_cube(&m);
    vm_error err;
    CHECK_OK(vm_mesh_boundary(&m, &s, &err), &err);
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&s, &q, &err), &err);
    CHECK(q.kind == VM_TRI3 && q.nmetrics == 5 && !q.has_abaqus);
    CHECK(q.check.cells == 12 && q.check.boundary_closed && q.check.boundary_euler == 2);
    const vm_metric_stats *a = stats_of(&q, "max_angle");
    CHECK(a && fabs(a->min - 90.0) < 1e-9 && fabs(a->max - 90.0) < 1e-9);
    vm_mesh_free(&s);
    vm_mesh_free(&m);
}


/* --- big meshes: blocks on threads against a plain loop ---------------------------------- */

/* A noisy genus-3 mesh without the quality pass (tens of thousands of tets: several report
 * blocks), with some points pushed so that slivers, ABAQUS failures and inverted tets occur. */
static void rough_mesh(vm_mesh *m, vm_cell_kind kind) {
    vm_volume v;
    vm_error err;
    vm_mesh_options o;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, kind == VM_TET4 ? 64 : 48, 0.3, 5, &v, NULL, &err),
             &err);
    vm_mesh_options_default(&o);
    o.elements = kind;
    CHECK_OK(vm_mesh_volume(&v, &o, m, NULL, &err), &err);
    vm_volume_free(&v);
    unsigned r = 12345u;
    for (size_t i = 0; i < m->npoints; i += 97) {
        for (int d = 0; d < 3; d++) {
            r = r * 1103515245u + 12345u;
            m->points[3 * i + (size_t)d] += 0.6 * ((double)(r >> 8) / 16777216.0 - 0.5);
        }
    }
}

/* The summary computed the plain way: each metric function over the cells in order. */
static void plain_summary(const vm_mesh *m, vm_quality_summary *q) {
    vm_error err;
    memset(q, 0, sizeof *q);
    q->kind = m->kind;
    CHECK_OK(vm_mesh_check(m, &q->check, &err), &err);
    const vm_metric_info *t;
    size_t nm = vm_quality_metrics(m->kind, &t);
    q->nmetrics = nm;
    int nn = vm_cell_nodes(m->kind);
    for (size_t k = 0; k < nm; k++) {
        vm_metric_stats *s = &q->metrics[k];
        s->info = &t[k];
        s->min = INFINITY;
        s->max = -INFINITY;
        double sum = 0.0;
        for (int pass = 0; pass < 2; pass++) {
            if (pass == 1) {
                s->lo = t[k].hist_lo;
                s->hi = t[k].hist_hi;
                if (!(s->hi > s->lo)) {
                    s->lo = s->min;
                    s->hi = s->max > s->min ? s->max : s->min + 1.0;
                }
            }
            for (size_t c = 0; c < m->ncells; c++) {
                double p[8][3];
                for (int i = 0; i < nn; i++)
                    memcpy(p[i], m->points + 3 * (size_t)m->cells[c * (size_t)nn + (size_t)i],
                           sizeof p[i]);
                double x = t[k].eval((const double(*)[3])p);
                if (pass == 0) {
                    sum += x;
                    if (x < s->min) {
                        s->min = x;
                        s->argmin = c;
                    }
                    if (x > s->max) {
                        s->max = x;
                        s->argmax = c;
                    }
                    continue;
                }
                double w = (s->hi - s->lo) / VM_QUALITY_BINS;
                long b = x < s->lo ? 0 : x > s->hi ? VM_QUALITY_BINS - 1 : (long)((x - s->lo) / w);
                if (b >= VM_QUALITY_BINS) b = VM_QUALITY_BINS - 1;
                if (b < 0) b = 0;
                s->bins[b]++;
                s->below += x < s->lo;
                s->above += x > s->hi;
            }
        }
        s->mean = sum / (double)m->ncells;
    }
}

static void reportOnThreadsEqualsThePlainLoopForAnyThreadCount(void) {
    vm_cell_kind kinds[2] = {VM_TET4, VM_HEX8};
    for (int ki = 0; ki < 2; ki++) {
        vm_mesh m;
        vm_error err;
        rough_mesh(&m, kinds[ki]);
        if (kinds[ki] == VM_TET4) /* two blocks of 16384 and a part */
            CHECK_MSG(m.ncells > 32768, "%zu cells", m.ncells);
        vm_quality_summary plain, first;
        plain_summary(&m, &plain);
        int before = vm_set_threads(1);
        int counts[3] = {1, 2, 3};
        for (int ti = 0; ti < 3; ti++) {
            vm_set_threads(counts[ti]);
            vm_quality_summary q;
            CHECK_OK(vm_quality_report(&m, &q, &err), &err);
            CHECK(q.check.inverted > 0);
            for (size_t k = 0; k < q.nmetrics; k++) {
                const vm_metric_stats *a = &q.metrics[k], *b = &plain.metrics[k];
                CHECK_MSG(a->min == b->min && a->max == b->max && a->argmin == b->argmin &&
                              a->argmax == b->argmax,
                          "%s: min %.17g/%.17g max %.17g/%.17g", a->info->name, a->min, b->min,
                          a->max, b->max);
                CHECK_MSG(fabs(a->mean - b->mean) <= 1e-12 * fmax(1.0, fabs(b->mean)),
                          "%s: mean %.17g, plain %.17g", a->info->name, a->mean, b->mean);
                CHECK(a->lo == b->lo && a->hi == b->hi && a->below == b->below &&
                      a->above == b->above);
                CHECK_MSG(memcmp(a->bins, b->bins, sizeof a->bins) == 0, "%s: histogram differs",
                          a->info->name);
            }
            if (ti == 0)
                first = q;
            else
                CHECK_MSG(memcmp(&q, &first, sizeof q) == 0, "%d threads: summary differs",
                          counts[ti]);
        }
        if (kinds[ki] == VM_TET4) CHECK(first.abaqus_failures > 0);
        vm_set_threads(before);
        vm_mesh_free(&m);
    }
}

typedef struct progress_log {
    char stages[8][16];
    int nstages;
    double last;
    int backwards, ended;
} progress_log;

static int log_progress(const char *stage, double done, double total, void *user) {
    progress_log *pl = user;
    if (pl->nstages == 0 || strcmp(pl->stages[pl->nstages - 1], stage) != 0) {
        if (pl->nstages < 8) snprintf(pl->stages[pl->nstages++], 16, "%s", stage);
        pl->last = -1.0;
    }
    if (done < pl->last) pl->backwards++;
    pl->last = done;
    if (done >= total) pl->ended++;
    return 0;
}

static void reportReusesAGivenCheckAndShowsProgressForEachStage(void) {
    vm_mesh m;
    vm_error err;
    rough_mesh(&m, VM_TET4);
    vm_quality_summary full, reused;
    progress_log pl = {0};
    vm_quality_options o;
    vm_quality_options_init(&o);
    o.progress = log_progress;
    o.progress_user = &pl;
    CHECK_OK(vm_quality_report_with(&m, &o, &full, &err), &err);
    CHECK(pl.nstages == 2 && strcmp(pl.stages[0], "check") == 0 &&
          strcmp(pl.stages[1], "quality") == 0);
    CHECK(pl.backwards == 0 && pl.ended == 2);
    vm_mesh_report r;
    progress_log pc = {0};
    CHECK_OK(vm_mesh_check_with(&m, log_progress, &pc, &r, &err), &err);
    CHECK(pc.nstages == 1 && pc.backwards == 0 && pc.ended == 1);
    CHECK(memcmp(&r, &full.check, sizeof r) == 0);
    memset(&pl, 0, sizeof pl);
    o.check = &r;
    CHECK_OK(vm_quality_report_with(&m, &o, &reused, &err), &err);
    CHECK(pl.nstages == 1 && strcmp(pl.stages[0], "quality") == 0 && pl.ended == 1);
    CHECK(memcmp(&reused, &full, sizeof full) == 0);
    /* A given check does not excuse a bad node index. */
    m.cells[5] = (vm_index)m.npoints;
    CHECK(vm_quality_report_with(&m, &o, &reused, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "node") != NULL);
    vm_mesh_free(&m);
}

/* --- what a sized mesh is judged by (issue 33) -------------------------------------------- */

/* A 32^3 sphere of 0.5 mm voxels meshed by the default mesher: the report measures its
 * boundary within half a voxel of the isosurface both ways, gives that in mm and in voxels
 * (the voxel length 0.5 mm) in every writer, and the edge histogram counts every edge once. */
static void sphereReportGivesTheDistanceInWorldUnitsAndVoxels(void) {
    vm_volume v;
    vm_error err;
    vm_status s = vm_phantom_make(VM_PHANTOM_SPHERE, 32, 0.0, 1u, &v, NULL, &err);
    CHECK_OK(s, &err);
    if (s) return;
    for (int a = 0; a < 3; a++) v.spacing[a] = 0.5;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = 0;
    o.has_lo = 1;
    o.has_hi = 0;
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK_OK(vm_quality_add_distance(&q, &m, &v, o.lo, o.has_lo, o.hi, o.has_hi, &err), &err);
    const vm_surface_distance *d = &q.distance;
    printf("  sphere: %zu tets, %zu edges, Hausdorff %.4g mm = %.4g voxels (%.4g / %.4g)\n",
           m.ncells, q.edges.edges, d->hausdorff, d->hausdorff / d->voxel,
           d->mesh_to_surface_max, d->surface_to_mesh_max);
    CHECK(q.has_distance);
    CHECK_NEAR(d->voxel, 0.5, 1e-12);
    CHECK(d->mesh_samples > 0 && d->surface_samples > 0);
    CHECK(d->mesh_to_surface_max > 0 && d->surface_to_mesh_max > 0);
    CHECK(d->hausdorff == fmax(d->mesh_to_surface_max, d->surface_to_mesh_max));
    CHECK_MSG(d->hausdorff <= 0.5 * d->voxel, "sphere Hausdorff %.4g voxels",
              d->hausdorff / d->voxel);
    double x;
    CHECK(vm_quality_lookup(&q, "hausdorff_voxels", &x) == VM_OK);
    CHECK_NEAR(x, d->hausdorff / 0.5, 1e-12);
    CHECK(vm_quality_lookup(&q, "surface_to_mesh_max_voxels", &x) == VM_OK);
    CHECK_NEAR(x, d->surface_to_mesh_max / 0.5, 1e-12);
    size_t total = 0;
    for (int b = 0; b < VM_QUALITY_BINS; b++) total += q.edges.bins[b];
    CHECK(q.edges.edges > 0 && total == q.edges.edges);
    /* edges of a mesh of 0.5 mm voxels: in mm, not in voxels */
    CHECK(q.edges.max < 2.0 && q.edges.min > 0);

    FILE *fp = fopen(vm_test_tmp("sphere.txt"), "w");
    CHECK(fp && vm_quality_write_text(fp, "sphere.vtu", &q, 0) == 0);
    if (fp) fclose(fp);
    char *t = slurp(vm_test_tmp("sphere.txt"));
    CHECK(t && strstr(t, "distance     Hausdorff "));
    CHECK(t && strstr(t, "in voxels (0.5 each): Hausdorff "));
    CHECK(t && strstr(t, "edge_length (each edge once, mesh units)"));
    free(t);
    fp = fopen(vm_test_tmp("sphere.json"), "w");
    CHECK(fp && vm_quality_write_json(fp, "sphere.vtu", &q) == 0);
    if (fp) fclose(fp);
    t = slurp(vm_test_tmp("sphere.json"));
    CHECK(t && strstr(t, "\"voxel\": 0.5, \"voxels\": {\"hausdorff\": "));
    CHECK(t && strstr(t, "\"edge_length\": {\"min\": "));
    CHECK(t && strstr(t, "\"regions_missing\": [], \"warnings\": []"));
    free(t);
    const char *html = vm_test_tmp("sphere.html");
    CHECK_OK(vm_quality_write_html(html, &m, "sphere.vtu", &q, &err), &err);
    t = slurp(html);
    CHECK(t && strstr(t, "<th>max (voxels)</th>"));
    CHECK(t && strstr(t, "<tr><th>boundary &rarr; isosurface</th>"));
    CHECK(t && strstr(t, "<tr><th>isosurface &rarr; boundary</th>"));
    CHECK(t && strstr(t, "<h2>Edge lengths</h2>"));
    CHECK(t && count_of(t, "<tr><td>") >= VM_QUALITY_BINS);
    free(t);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* A label mesh: the tets per label sum to the total; a label asked for and absent is named
 * as missing, and the mesher's warnings are carried, in every writer. */
static void labelReportCountsTetsPerLabelAndNamesTheMissing(void) {
    vm_volume v;
    vm_error err;
    vm_status s = vm_label_phantom_make(0, 16, &v, &err);
    CHECK_OK(s, &err);
    if (s) return;
    vm_label_options lo;
    vm_label_options_default(&lo);
    vm_mesh m;
    CHECK_OK(vm_mesh_labels(&v, &lo, &m, NULL, &err), &err);
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    static const int32_t asked[] = {1, 2, 3, 99};
    static const char *const warn[] = {"label 99 (4 voxels in) has no element"};
    q.expected_regions = asked;
    q.nexpected_regions = 4;
    q.warnings = warn;
    q.nwarnings = 1;
    size_t total = 0;
    for (size_t i = 0; i < q.nregions; i++) total += q.regions[i].cells;
    CHECK(q.nregions == 3 && total == m.ncells);
    double x;
    CHECK(vm_quality_lookup(&q, "regions_missing", &x) == VM_OK && x == 1);
    FILE *fp = fopen(vm_test_tmp("labels.txt"), "w");
    CHECK(fp && vm_quality_write_text(fp, "l.vtu", &q, 0) == 0);
    if (fp) fclose(fp);
    char *t = slurp(vm_test_tmp("labels.txt"));
    CHECK(t && strstr(t, "regions      3\n  region 1 "));
    CHECK(t && strstr(t, "missing      1 of 4 regions asked for have no cell: 99\n"));
    CHECK(t && strstr(t, "warning      label 99 (4 voxels in) has no element\n"));
    free(t);
    fp = fopen(vm_test_tmp("labels.json"), "w");
    CHECK(fp && vm_quality_write_json(fp, "l.vtu", &q) == 0);
    if (fp) fclose(fp);
    t = slurp(vm_test_tmp("labels.json"));
    CHECK(t && strstr(t, "\"regions_missing\": [99], \"warnings\": [\"label 99 (4 voxels in) "
                         "has no element\"]"));
    CHECK(t && strstr(t, "\"surface_distance\": null"));
    free(t);
    const char *html = vm_test_tmp("labels.html");
    CHECK_OK(vm_quality_write_html(html, &m, "l.vtu", &q, &err), &err);
    t = slurp(html);
    CHECK(t && strstr(t, "<tr class=\"bad\"><td>99</td><td>0 (asked for, not in the mesh)"));
    CHECK(t && strstr(t, "<li class=\"bad\">label 99 (4 voxels in) has no element</li>"));
    CHECK(t && !strstr(t, "Distance to the isosurface"));
    free(t);
    /* one region asked for and present: listed, nothing missing */
    q.nexpected_regions = 1;
    q.nwarnings = 0;
    CHECK(vm_quality_lookup(&q, "regions_missing", &x) == VM_OK && x == 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(reportOfKuhnCubeHasExactStatistics), T(sliversAndAbaqusFailuresAreCounted),
          T(hexReportHasNoDihedralsOrAbaqus), T(edgeLengthsCountEachEdgeOnce),
          T(cellsPerRegionAreCountedAndListed), T(emptyMeshReportsZeros),
          T(badNodeIndexIsAnError), T(writersProduceTheDocumentedKeysAndFiles),
          T(qualityFieldsHoldEachCellsMetric), T(qualityFieldsRespectTheMemoryLimit),
          T(surfaceReportUsesTriangleMetrics),
          T(reportOnThreadsEqualsThePlainLoopForAnyThreadCount),
          T(reportReusesAGivenCheckAndShowsProgressForEachStage),
          T(sphereReportGivesTheDistanceInWorldUnitsAndVoxels),
          T(labelReportCountsTetsPerLabelAndNamesTheMissing))
