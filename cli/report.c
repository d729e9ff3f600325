/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/report.c — `volmesh report`: the HTML quality report of any mesh we read. */
#include <string.h>
#include "cli.h"

static const char *report_help =
    "usage: volmesh report MESH -o REPORT.html [--volume FILE (--iso V | --range A:B)]\n"
    "\n"
    "Writes one self-contained HTML page (no network needed): the mesh checks, the quality\n"
    "metrics, pictures of the mesh (its boundary, and a cut-away with the worst elements in\n"
    "red) and the quality histograms. MESH is any mesh volmesh reads. On a terminal, bars\n"
    "show the checks and the metrics of big meshes.\n"
    "\n"
    "  -o, --output FILE       the HTML file\n"
    "  --volume FILE           also measure the distance between the mesh boundary and the\n"
    "                          isosurface of this volume, both ways (world units; see\n"
    "                          docs/QUALITY.md), with the material given by:\n"
    "  --iso V | --range A:B   as for volmesh mesh (--invert: f <= V)\n"
    "  -q, --quiet             no progress bars\n";

int vm_cli_write_report(const char *path, const vm_mesh *m, const char *name,
                        const vm_mesh_report *check, const vm_surface_distance *dist,
                        int quiet) {
    return vm_cli_write_report_with(path, m, name, check, dist, NULL, quiet);
}

int vm_cli_write_report_with(const char *path, const vm_mesh *m, const char *name,
                             const vm_mesh_report *check, const vm_surface_distance *dist,
                             const vm_cli_report_notes *notes, int quiet) {
    vm_error err;
    vm_error_clear(&err);
    vm_quality_summary q;
    vm_quality_options o;
    vm_quality_options_init(&o);
    o.check = check;
    o.progress = vm_cli_progress;
    o.progress_user = &quiet;
    if (vm_quality_report_with(m, &o, &q, &err)) return vm_cli_fail_err(&err);
    if (dist) {
        q.has_distance = 1;
        q.distance = *dist;
    }
    if (notes) {
        q.expected_regions = notes->regions;
        q.nexpected_regions = notes->nregions;
        q.warnings = notes->warnings;
        q.nwarnings = notes->nwarnings;
    }
    vm_cli_status("drawing", path, quiet);
    vm_status s = vm_quality_write_html(path, m, name, &q, &err);
    vm_cli_status_clear(quiet);
    return s ? vm_cli_fail_err(&err) : VM_EXIT_OK;
}

int vm_cmd_report(int argc, char **argv) {
    const char *in = NULL, *out = NULL;
    int quiet = 0;
    vm_cli_surface surf;
    vm_cli_surface_init(&surf);
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int taken = 0;
        if (vm_cli_surface_arg(&surf, "report", argc, argv, &i, &taken)) return VM_EXIT_INPUT;
        if (taken) continue;
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(report_help, stdout);
            return VM_EXIT_OK;
        }
        if (vm_cli_is(a, "-o", "--output")) {
            if (vm_cli_need_value("report", i, argc, argv)) return VM_EXIT_INPUT;
            out = argv[++i];
        } else if (vm_cli_is(a, "-q", "--quiet")) {
            quiet = 1;
        } else if (a[0] == '-' && a[1]) {
            return vm_cli_fail("report: unknown option %s", a);
        } else if (in) {
            return vm_cli_fail("report: more than one input file ('%s', '%s')", in, a);
        } else {
            in = a;
        }
    }
    if (!in) return vm_cli_fail("report: no mesh file (see volmesh report --help)");
    if (!out) return vm_cli_fail("report: no output file (-o REPORT.html)");
    if (vm_cli_surface_check(&surf, "report")) return VM_EXIT_INPUT;
    static const char *const html[] = {".html", ".htm", NULL};
    if (vm_cli_output_check("report", out, html)) return VM_EXIT_INPUT;
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_cli_status("reading", in, quiet);
    vm_status rs = vm_mesh_read(in, &m, &err);
    vm_cli_status_clear(quiet);
    if (rs) return vm_cli_fail_mesh_read(in, &err);
    vm_surface_distance d;
    int rc = surf.volume ? vm_cli_surface_measure(&surf, &m, &d, quiet) : VM_EXIT_OK;
    if (!rc) rc = vm_cli_write_report(out, &m, in, NULL, surf.volume ? &d : NULL, quiet);
    vm_mesh_free(&m);
    if (!rc) printf("wrote %s\n", out);
    return rc;
}
