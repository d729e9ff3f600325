/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/demo.c — `volmesh demo`: a built-in phantom through the pipeline, no input needed. */
#include <string.h>
#include "cli.h"

static const char *demo_help =
    "usage: volmesh demo [--size N] [--shape NAME] [--quiet]\n"
    "\n"
    "Makes a phantom volume (default: torus, 48^3) and runs the pipeline on it, writing to\n"
    "the current folder: phantom.nrrd (the volume), demo.vtu (tetrahedra filling f >= 0)\n"
    "demo-surface.vtu (the boundary triangles) and demo-report.html (quality report with\n"
    "pictures). Open the meshes in ParaView or with meshio, the report in a browser.\n"
    "  --size N       grid size (8..512, default 48)\n"
    "  --shape NAME   sphere, torus, genus3, two-spheres, plate, cut-sphere\n"
    "  -q, --quiet    no progress bars (drawn on a terminal while each stage runs)\n";

int vm_cmd_demo(int argc, char **argv) {
    long n = 48;
    vm_phantom_kind kind = VM_PHANTOM_TORUS;
    int quiet = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(demo_help, stdout);
            return VM_EXIT_OK;
        }
        if ((strcmp(a, "--size") == 0 || strcmp(a, "--shape") == 0) &&
            vm_cli_need_value("demo", i, argc, argv))
            return VM_EXIT_INPUT;
        if (strcmp(a, "--size") == 0) {
            if (vm_cli_int(a, argv[++i], 8, 512, &n)) return VM_EXIT_INPUT;
        } else if (strcmp(a, "--shape") == 0) {
            if (vm_phantom_parse(argv[++i], &kind))
                return vm_cli_fail("--shape: unknown phantom '%s'", argv[i]);
        } else if (vm_cli_is(a, "-q", "--quiet")) {
            quiet = 1;
        } else {
            return vm_cli_fail("demo: unknown option %s (see volmesh demo --help)", a);
        }
    }
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    vm_phantom_info info;
    if (vm_phantom_make(kind, (int)n, 0.0, 1, &v, &info, &err)) return vm_cli_fail_err(&err);
    if (vm_volume_write_nrrd("phantom.nrrd", &v, 1, &err)) {
        vm_volume_free(&v);
        return vm_cli_fail_err(&err);
    }
    vm_cli_print_info(stdout, "phantom.nrrd", &v, 0);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.progress = vm_cli_progress;
    o.progress_user = &quiet;
    vm_mesh m, surf;
    vm_mesh_stats st;
    vm_status s = vm_mesh_volume(&v, &o, &m, &st, &err);
    if (!s) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        io.progress = vm_cli_progress;
        io.progress_user = &quiet;
        vm_improve_report ir;
        s = vm_mesh_improve(&m, &v, &io, &ir, &err); /* material f >= 0, as meshed */
        st.seconds += ir.seconds;
    }
    vm_volume_free(&v);
    if (s) return vm_cli_fail_err(&err);
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    wo.progress = vm_cli_progress;
    wo.progress_user = &quiet;
    s = vm_mesh_write_as("demo.vtu", &m, &wo, &err);
    if (!s) s = vm_mesh_boundary(&m, &surf, &err);
    if (!s) {
        s = vm_mesh_write_as("demo-surface.vtu", &surf, &wo, &err);
        vm_mesh_free(&surf);
    }
    vm_mesh_report checked;
    if (!s) s = vm_mesh_check_with(&m, vm_cli_progress, &quiet, &checked, &err);
    if (s) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    printf("\n%s phantom: expected boundary Euler characteristic %d, volume %.6g\n", info.name,
           info.euler, info.volume);
    int rc = vm_cli_report_checked(&m, &checked, &st, NULL, 0, "demo.vtu");
    if (!rc) rc = vm_cli_write_report("demo-report.html", &m, "demo.vtu", &checked, NULL, quiet);
    vm_mesh_free(&m);
    if (!rc) printf("wrote phantom.nrrd, demo.vtu, demo-surface.vtu, demo-report.html\n");
    return rc;
}
