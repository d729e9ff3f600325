/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/quality.c — `volmesh quality`: element metrics, histograms and mesh checks of any mesh
 * vm_mesh_read reads, as text, JSON, SVG or per-cell CSV, with --require checks. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static const char *quality_help =
    "usage: volmesh quality MESH [--json] [--svg FILE] [--abaqus] [--require EXPR]...\n"
    "                            [--per-cell-csv FILE] [--volume FILE (--iso V | --range A:B)]\n"
    "\n"
    "Element quality and mesh checks of a tet, hex, triangle or quad mesh (any format volmesh\n"
    "reads). Prints the checks (inverted and degenerate cells, conformity, boundary closed,\n"
    "Euler characteristic, components, volume), slivers (min dihedral < 5 and < 10 deg) and\n"
    "the ABAQUS check for tets (volume measure < 0.02, face angle < 10 or > 160 deg), then per\n"
    "metric min/mean/max, the ideal value, Verdict's acceptable range, the count outside it\n"
    "and a 20-bin histogram. Metrics follow the Verdict manual (docs/QUALITY.md). Also the\n"
    "edge lengths (each edge once, mesh units) with a histogram, and the cells per region\n"
    "when there are two or more (a label mesh).\n"
    "\n"
    "  --json                one JSON object instead of the table (keys: elements, inverted,\n"
    "                        min_dihedral, max_dihedral, slivers_5, slivers_10,\n"
    "                        abaqus_failures, boundary_euler, volume, min_scaled_jacobian,\n"
    "                        ..., metrics: {NAME: {min, mean, max, histogram, ...}})\n"
    "  --svg FILE            draw the histograms (one panel per metric) as an SVG picture\n"
    "  --abaqus              list the tets failing the ABAQUS check; exit 1 if any fail\n"
    "  --require EXPR        KEY OP NUMBER with OP one of >= <= > < ==, e.g. \"min_dihedral>=10\",\n"
    "                        \"inverted==0\", \"radius_ratio.max<=3\" (METRIC.min/.mean/.max/\n"
    "                        .unacceptable); repeatable; exit 1 naming each unmet one\n"
    "  --per-cell-csv FILE   write every metric of every cell (cell,region,METRIC,...)\n"
    "  --volume FILE         also measure the distance between the mesh boundary and the\n"
    "                        isosurface of this volume, both ways, in world units (keys\n"
    "                        hausdorff, mesh_to_surface_max/_mean, surface_to_mesh_max/_mean)\n"
    "                        and in voxels (hausdorff_voxels, mesh_to_surface_max_voxels,\n"
    "                        surface_to_mesh_max_voxels)\n"
    "  --iso V, --range A:B  with --volume: the material, as for volmesh mesh (--invert: f <= V)\n"
    "  -q, --quiet           no progress bars (shown on a terminal for big meshes)\n"
    "\n"
    "exit status: 0 ok, 1 a requirement or the ABAQUS check failed, 2 bad usage or input\n";

#define MAX_REQUIRE 64

typedef struct requirement {
    const char *text;
    char key[128];
    char op[3];
    double value;
} requirement;

/* Parses "KEY OP NUMBER" (spaces allowed around OP). Returns 0 or prints and returns -1. */
static int parse_requirement(const char *s, requirement *r) {
    static const char *ops[] = {">=", "<=", "==", ">", "<"};
    r->text = s;
    const char *at = NULL;
    size_t oplen = 0;
    for (const char *c = s; *c && !at; c++)
        for (int i = 0; i < 5; i++) {
            size_t l = strlen(ops[i]);
            if (strncmp(c, ops[i], l) == 0) {
                at = c;
                oplen = l;
                memcpy(r->op, ops[i], l + 1);
                break;
            }
        }
    if (!at) {
        vm_cli_fail("--require: '%s' has no comparison (use >= <= > < ==)", s);
        return -1;
    }
    const char *k0 = s, *k1 = at;
    while (k0 < k1 && (*k0 == ' ' || *k0 == '\t')) k0++;
    while (k1 > k0 && (k1[-1] == ' ' || k1[-1] == '\t')) k1--;
    if (k1 == k0 || (size_t)(k1 - k0) >= sizeof r->key) {
        vm_cli_fail("--require: '%s' has no key before %s", s, r->op);
        return -1;
    }
    memcpy(r->key, k0, (size_t)(k1 - k0));
    r->key[k1 - k0] = 0;
    const char *num = at + oplen;
    while (*num == ' ' || *num == '\t') num++;
    char *end;
    errno = 0;
    r->value = strtod(num, &end);
    while (*end == ' ' || *end == '\t') end++;
    if (end == num || *end || errno == ERANGE || !isfinite(r->value)) {
        vm_cli_fail("--require: '%s' does not end in a number", s);
        return -1;
    }
    return 0;
}

static int requirement_met(const requirement *r, double v) {
    if (strcmp(r->op, ">=") == 0) return v >= r->value;
    if (strcmp(r->op, "<=") == 0) return v <= r->value;
    if (strcmp(r->op, ">") == 0) return v > r->value;
    if (strcmp(r->op, "<") == 0) return v < r->value;
    return v == r->value;
}

int vm_cmd_quality(int argc, char **argv) {
    const char *path = NULL, *svg = NULL, *csv = NULL;
    int json = 0, abaqus = 0, quiet = 0;
    requirement req[MAX_REQUIRE];
    int nreq = 0;
    vm_cli_surface surf;
    vm_cli_surface_init(&surf);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int taken = 0;
        if (vm_cli_surface_arg(&surf, "quality", argc, argv, &i, &taken)) return VM_EXIT_INPUT;
        if (taken) continue;
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(quality_help, stdout);
            return VM_EXIT_OK;
        }
        int needs = vm_cli_is(a, "--svg", NULL) || vm_cli_is(a, "--require", NULL) ||
                    vm_cli_is(a, "--per-cell-csv", NULL);
        if (needs && vm_cli_need_value("quality", i, argc, argv)) return VM_EXIT_INPUT;
        if (vm_cli_is(a, "--json", NULL)) {
            json = 1;
        } else if (vm_cli_is(a, "--abaqus", NULL)) {
            abaqus = 1;
        } else if (vm_cli_is(a, "-q", "--quiet")) {
            quiet = 1;
        } else if (vm_cli_is(a, "--svg", NULL)) {
            svg = argv[++i];
        } else if (vm_cli_is(a, "--per-cell-csv", NULL)) {
            csv = argv[++i];
        } else if (vm_cli_is(a, "--require", NULL)) {
            if (nreq == MAX_REQUIRE)
                return vm_cli_fail("quality: more than %d --require options", MAX_REQUIRE);
            if (parse_requirement(argv[++i], &req[nreq])) return VM_EXIT_INPUT;
            nreq++;
        } else if (a[0] == '-' && a[1]) {
            return vm_cli_fail("quality: unknown option %s", a);
        } else {
            if (path) return vm_cli_fail("quality: more than one mesh ('%s', '%s')", path, a);
            path = a;
        }
    }
    if (!path) return vm_cli_fail("quality: no mesh file (see volmesh quality --help)");
    if (vm_cli_surface_check(&surf, "quality")) return VM_EXIT_INPUT;
    static const char *const svg_tails[] = {".svg", NULL}, *const csv_tails[] = {".csv", NULL};
    if ((svg && vm_cli_output_check("--svg", svg, svg_tails)) ||
        (csv && vm_cli_output_check("--per-cell-csv", csv, csv_tails)))
        return VM_EXIT_INPUT;
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_cli_status("reading", path, quiet);
    vm_status rs = vm_mesh_read(path, &m, &err);
    vm_cli_status_clear(quiet);
    if (rs) return vm_cli_fail_mesh_read(path, &err);
    vm_quality_summary q;
    vm_quality_options qo;
    vm_quality_options_init(&qo);
    qo.progress = vm_cli_progress;
    qo.progress_user = &quiet;
    vm_status st = vm_quality_report_with(&m, &qo, &q, &err);
    if (st) {
        vm_mesh_free(&m);
        return vm_cli_fail("%s: %s", path, err.message);
    }
    if (surf.volume) {
        int rc = vm_cli_surface_measure(&surf, &m, &q.distance, quiet);
        if (rc) {
            vm_mesh_free(&m);
            return rc;
        }
        q.has_distance = 1;
    }
    /* Unknown keys are usage errors: check them all before printing anything. */
    for (int i = 0; i < nreq; i++) {
        double v;
        if (vm_quality_lookup(&q, req[i].key, &v)) {
            vm_mesh_free(&m);
            return vm_cli_fail("--require: no key '%s' for a %s mesh (see volmesh quality "
                               "--help)",
                               req[i].key, vm_cell_kind_name(m.kind));
        }
    }
    if (csv && vm_quality_write_cell_csv(csv, &m, &err)) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    vm_mesh_free(&m);
    if (svg && vm_quality_write_svg(svg, path, &q, &err)) return vm_cli_fail_err(&err);
    int bad = json ? vm_quality_write_json(stdout, path, &q)
                   : vm_quality_write_text(stdout, path, &q, abaqus);
    if (bad) return vm_cli_fail("quality: cannot write the report to standard output");
    int rc = VM_EXIT_OK;
    for (int i = 0; i < nreq; i++) {
        double v = 0.0;
        vm_quality_lookup(&q, req[i].key, &v);
        if (!requirement_met(&req[i], v)) {
            fprintf(stderr, "volmesh: requirement not met: %s (%s is %.10g)\n", req[i].text,
                    req[i].key, v);
            rc = VM_EXIT_CHECK;
        }
    }
    if (abaqus && q.has_abaqus && q.abaqus_failures) {
        fprintf(stderr, "volmesh: ABAQUS check: %zu tet%s fail\n", q.abaqus_failures,
                q.abaqus_failures == 1 ? "" : "s");
        rc = VM_EXIT_CHECK;
    }
    return rc;
}
