/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/convert.c — `volmesh convert IN OUT`: reads any mesh format volmesh reads and writes
 * any it writes, with the FE deck options of the .inp writer. */
#include <string.h>
#include "cli.h"

static const char *convert_help =
    "usage: volmesh convert IN OUT [--format F] [--deck static] [--order 2] [--ascii]\n"
    "                              [--materials FILE] [--compress fast|best|none]\n"
    "\n"
    "Converts a mesh between formats, chosen by the file extensions:\n"
    "  read and write: .vtu .vtk (legacy) .inp (ABAQUS/CalculiX) .msh (Gmsh 4.1; reads 2.2)\n"
    "                  .msh2 (Gmsh 2.2) .mesh (MEDIT) .stl .off .ply .obj\n"
    "  write only:     .exo (Exodus II, when built with libexodusii); solver decks, one\n"
    "                  part and material per region: .bdf (Nastran), .k (LS-DYNA),\n"
    "                  .feb (FEBio 4.0), .mphtxt (COMSOL mesh, no materials); .xdmf + .h5\n"
    "                  (FEniCSx/dolfinx, with cell and facet tags; when built with libhdf5)\n"
    "Surface formats (stl, off, ply, obj) given a volume mesh write its boundary.\n"
    "  --format F      output format regardless of OUT's extension: vtu, vtk, inp, msh,\n"
    "                  msh2, mesh, stl, off, ply, obj, exo, bdf, k, mphtxt, feb, xdmf\n"
    "  --in-format F   input format regardless of IN's extension\n"
    "  --deck static   .inp, .feb: add a static step (lowest z slab fixed, top slab loaded\n"
    "                  in -z, displacements and stresses requested)\n"
    "  --order 2       .inp .vtu .msh .msh2 .feb .xdmf: second-order elements (C3D10 / C3D20,\n"
    "                  tetra10 / hexahedron20, tet10 / hex20), one shared mid-edge node\n"
    "                  per edge at its middle (straight edges)\n"
    "  --materials FILE  decks (.inp .bdf .k .feb): CSV rows label,name,E,nu,density, one\n"
    "                  material per region (placeholders for regions without a row)\n"
    "  --ascii         ASCII STL, PLY or legacy VTK instead of binary\n"
    "  --compress C    .vtu arrays: fast (zlib level 1, default), best (level 6) or none\n"
    "  -q, --quiet     no progress bar (shown on a terminal while writing)\n";

/* Converts as the options say; [out] *materials: --materials' rows (the caller frees). */
static int convert_run(int argc, char **argv, vm_material **materials) {
    const char *in = NULL, *out = NULL, *materials_path = NULL;
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    vm_mesh_format in_fmt = VM_MESH_AUTO;
    int quiet = 0;
    o.progress = vm_cli_progress;
    o.progress_user = &quiet;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(convert_help, stdout);
            return VM_EXIT_OK;
        }
        int takes_value = strcmp(a, "--format") == 0 || strcmp(a, "--in-format") == 0 ||
                          strcmp(a, "--deck") == 0 || strcmp(a, "--order") == 0 ||
                          strcmp(a, "--materials") == 0 || strcmp(a, "--compress") == 0;
        if (takes_value && vm_cli_need_value("convert", i, argc, argv)) return VM_EXIT_INPUT;
        if (strcmp(a, "--format") == 0 || strcmp(a, "--in-format") == 0) {
            vm_mesh_format f = vm_mesh_format_parse(argv[++i]);
            if (f == VM_MESH_AUTO)
                return vm_cli_fail("%s: unknown format '%s' (vtu, vtk, inp, msh, msh2, mesh, "
                                   "stl, off, ply, obj, exo, bdf, k, mphtxt, feb, xdmf)", a, argv[i]);
            if (a[2] == 'f') o.format = f;
            else in_fmt = f;
        } else if (strcmp(a, "--deck") == 0) {
            if (strcmp(argv[++i], "static") != 0)
                return vm_cli_fail("--deck: unknown deck '%s' (static)", argv[i]);
            o.deck = VM_DECK_STATIC;
        } else if (strcmp(a, "--order") == 0) {
            long v;
            if (vm_cli_int(a, argv[++i], 1, 2, &v)) return VM_EXIT_INPUT;
            o.order = (int)v;
        } else if (strcmp(a, "--materials") == 0) {
            materials_path = argv[++i];
        } else if (strcmp(a, "--compress") == 0) {
            if (vm_cli_compress(argv[++i], &o.compress)) return VM_EXIT_INPUT;
        } else if (strcmp(a, "--ascii") == 0) {
            o.ascii = 1;
        } else if (vm_cli_is(a, "-q", "--quiet")) {
            quiet = 1;
        } else if (a[0] == '-' && a[1]) {
            return vm_cli_fail("convert: unknown option %s (see volmesh convert --help)", a);
        } else if (!in) {
            in = a;
        } else if (!out) {
            out = a;
        } else {
            return vm_cli_fail("convert: one input and one output, not '%s' too", a);
        }
    }
    if (!in || !out) return vm_cli_fail("convert: needs IN and OUT (see volmesh convert --help)");
    vm_mesh_format of = o.format != VM_MESH_AUTO ? o.format : vm_mesh_format_of_path(out);
    if (of == VM_MESH_AUTO)
        return vm_cli_fail("%s: unknown output format (use a known extension or --format)", out);
    if (in_fmt == VM_MESH_AUTO && vm_mesh_format_of_path(in) == VM_MESH_AUTO) {
        vm_error unknown;
        vm_error_set(&unknown, VM_ERR_FORMAT,
                     "%s: unknown input format (use a known extension or --in-format)", in);
        return vm_cli_fail_mesh_read(in, &unknown);
    }
    vm_mesh_format inf = in_fmt != VM_MESH_AUTO ? in_fmt : vm_mesh_format_of_path(in);
    if (inf == VM_MESH_EXODUS)
        return vm_cli_fail("%s: volmesh writes Exodus II but does not read it", in);
    if (inf == VM_MESH_NASTRAN || inf == VM_MESH_LSDYNA || inf == VM_MESH_COMSOL ||
        inf == VM_MESH_FEBIO || inf == VM_MESH_XDMF)
        return vm_cli_fail("%s: volmesh writes .%s but does not read it", in,
                           vm_mesh_format_name(inf));
    /* Refuse option mismatches before reading a possibly large input. */
    if (o.order == 2 && of != VM_MESH_INP && of != VM_MESH_VTU && of != VM_MESH_MSH &&
        of != VM_MESH_MSH2 && of != VM_MESH_FEBIO && of != VM_MESH_XDMF)
        return vm_cli_fail("--order 2: second-order elements are written to .inp, .vtu, .msh, "
                           ".feb and .xdmf only");
    if (o.deck != VM_DECK_NONE && of != VM_MESH_INP && of != VM_MESH_FEBIO)
        return vm_cli_fail("--deck: an analysis deck needs an .inp or .feb output");
    if (o.ascii && of != VM_MESH_STL && of != VM_MESH_PLY && of != VM_MESH_VTK)
        return vm_cli_fail("--ascii applies to stl, ply and vtk output only");
    if (vm_cli_output_check("convert", out, NULL)) return VM_EXIT_INPUT;
    vm_error err;
    vm_error_clear(&err);
    if (materials_path) {
        if (vm_materials_read(materials_path, materials, &o.nmaterials, &err))
            return vm_cli_fail_err(&err);
        o.materials = *materials;
    }
    if (vm_mesh_write_check(out, &o, &err)) return vm_cli_fail_err(&err);
    vm_mesh m;
    vm_cli_status("reading", in, quiet);
    vm_status rs = vm_mesh_read_as(in, in_fmt, &m, &err);
    vm_cli_status_clear(quiet);
    if (rs) return vm_cli_fail_mesh_read(in, &err);
    vm_status s = vm_mesh_write_as(out, &m, &o, &err);
    if (s) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    printf("%s: %zu points, %zu %s cells -> %s (%s)\n", in, m.npoints, m.ncells,
           vm_cell_kind_name(m.kind), out, vm_mesh_format_name(of));
    vm_mesh_free(&m);
    return VM_EXIT_OK;
}

int vm_cmd_convert(int argc, char **argv) {
    vm_material *materials = NULL;
    int rc = convert_run(argc, argv, &materials);
    vm_materials_free(materials);
    return rc;
}
