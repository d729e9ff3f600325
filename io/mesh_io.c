/* SPDX-License-Identifier: BSD-3-Clause */
/* io/mesh_io.c — picks the mesh reader/writer from the file name or a format name, and
 * checks that the write options apply to the chosen format. */
#include <string.h>
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/io.h"

static const struct {
    const char *name;
    vm_mesh_format f;
} format_names[] = {
    {"vtu", VM_MESH_VTU},    {"vtk", VM_MESH_VTK},     {"inp", VM_MESH_INP},
    {"abaqus", VM_MESH_INP}, {"calculix", VM_MESH_INP}, {"msh", VM_MESH_MSH},
    {"msh4", VM_MESH_MSH},   {"gmsh", VM_MESH_MSH},    {"msh2", VM_MESH_MSH2},
    {"gmsh2", VM_MESH_MSH2}, {"mesh", VM_MESH_MEDIT},  {"medit", VM_MESH_MEDIT},
    {"stl", VM_MESH_STL},    {"off", VM_MESH_OFF},     {"ply", VM_MESH_PLY},
    {"obj", VM_MESH_OBJ},    {"exo", VM_MESH_EXODUS},  {"exodus", VM_MESH_EXODUS},
    {"bdf", VM_MESH_NASTRAN}, {"nastran", VM_MESH_NASTRAN}, {"k", VM_MESH_LSDYNA},
    {"lsdyna", VM_MESH_LSDYNA}, {"mphtxt", VM_MESH_COMSOL}, {"comsol", VM_MESH_COMSOL},
    {"feb", VM_MESH_FEBIO},  {"febio", VM_MESH_FEBIO}, {"xdmf", VM_MESH_XDMF},
};

static const struct {
    const char *ext;
    vm_mesh_format f;
} format_exts[] = {
    {".vtu", VM_MESH_VTU},  {".vtk", VM_MESH_VTK},    {".inp", VM_MESH_INP},
    {".msh2", VM_MESH_MSH2}, {".msh", VM_MESH_MSH},   {".mesh", VM_MESH_MEDIT},
    {".stl", VM_MESH_STL},  {".off", VM_MESH_OFF},    {".ply", VM_MESH_PLY},
    {".obj", VM_MESH_OBJ},  {".exo", VM_MESH_EXODUS}, {".e", VM_MESH_EXODUS},
    {".bdf", VM_MESH_NASTRAN}, {".k", VM_MESH_LSDYNA}, {".mphtxt", VM_MESH_COMSOL},
    {".feb", VM_MESH_FEBIO}, {".xdmf", VM_MESH_XDMF},
};

vm_mesh_format vm_mesh_format_parse(const char *name) {
    for (size_t i = 0; i < sizeof format_names / sizeof format_names[0]; i++)
        if (vm__ends_with(name, format_names[i].name) &&
            strlen(name) == strlen(format_names[i].name))
            return format_names[i].f;
    return VM_MESH_AUTO;
}

vm_mesh_format vm_mesh_format_of_path(const char *path) {
    for (size_t i = 0; i < sizeof format_exts / sizeof format_exts[0]; i++)
        if (vm__ends_with(path, format_exts[i].ext)) return format_exts[i].f;
    return VM_MESH_AUTO;
}

const char *vm_mesh_format_name(vm_mesh_format f) {
    switch (f) {
    case VM_MESH_AUTO: return "auto";
    case VM_MESH_VTU: return "vtu";
    case VM_MESH_VTK: return "vtk";
    case VM_MESH_INP: return "inp";
    case VM_MESH_MSH: return "msh";
    case VM_MESH_MSH2: return "msh2";
    case VM_MESH_MEDIT: return "mesh";
    case VM_MESH_STL: return "stl";
    case VM_MESH_OFF: return "off";
    case VM_MESH_PLY: return "ply";
    case VM_MESH_OBJ: return "obj";
    case VM_MESH_EXODUS: return "exo";
    case VM_MESH_NASTRAN: return "bdf";
    case VM_MESH_LSDYNA: return "k";
    case VM_MESH_COMSOL: return "mphtxt";
    case VM_MESH_FEBIO: return "feb";
    case VM_MESH_XDMF: return "xdmf";
    }
    return "unknown";
}

static const char *known_exts =
    ".vtu .vtk .inp .msh .msh2 .mesh .stl .off .ply .obj .exo .bdf .k .mphtxt .feb .xdmf";

/* 1 when format f writes one material per region (a solver deck). */
static int has_materials(vm_mesh_format f) {
    return f == VM_MESH_INP || f == VM_MESH_NASTRAN || f == VM_MESH_LSDYNA ||
           f == VM_MESH_FEBIO;
}

/* The format opt asks for (or path's), and whether opt's options fit it. [out] *fmt. */
static vm_status check_options(const char *path, const vm_mesh_write_options *opt,
                               vm_mesh_format *fmt, vm_error *err) {
    vm_mesh_format f = opt->format != VM_MESH_AUTO ? opt->format : vm_mesh_format_of_path(path);
    *fmt = f;
    if (f == VM_MESH_AUTO)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: unknown mesh format (expected one of %s)", path, known_exts);
    if (f == VM_MESH_XDMF && !vm_xdmf_available())
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: this volmesh was built without XDMF (needs libhdf5-dev at "
                            "configure time)", path);
    if (opt->order != 1 && opt->order != 2)
        return vm_error_set(err, VM_ERR_ARG, "%s: element order %d (expected 1 or 2)", path,
                            opt->order);
    if (f != VM_MESH_INP && f != VM_MESH_VTU && f != VM_MESH_MSH && f != VM_MESH_MSH2 &&
        f != VM_MESH_FEBIO && f != VM_MESH_XDMF && opt->order != 1)
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: second-order elements are written to .inp, .vtu, .msh, "
                            ".feb and .xdmf, not %s", path, vm_mesh_format_name(f));
    if (f != VM_MESH_INP && f != VM_MESH_FEBIO && opt->deck != VM_DECK_NONE)
        return vm_error_set(err, VM_ERR_ARG, "%s: an analysis deck needs .inp or .feb, not %s",
                            path, vm_mesh_format_name(f));
    if (opt->nmaterials && !has_materials(f))
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: materials are written to the solver decks (.inp .bdf .k .feb), "
                            "not %s",
                            path, vm_mesh_format_name(f));
    if (opt->split && f != VM_MESH_INP)
        return vm_error_set(err, VM_ERR_ARG, "%s: --split writes .inp decks, not %s", path,
                            vm_mesh_format_name(f));
    if (opt->compress != VM_COMPRESS_NONE && opt->compress != VM_COMPRESS_FAST &&
        opt->compress != VM_COMPRESS_BEST)
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: compress is %d: none (0), fast (1) or best (2)", path,
                            opt->compress);
    if (opt->ascii && f != VM_MESH_STL && f != VM_MESH_PLY && f != VM_MESH_VTK)
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: --ascii applies to stl, ply and vtk, not %s (always ASCII or "
                            "always binary)", path, vm_mesh_format_name(f));
    return VM_OK;
}

vm_status vm_mesh_write_check(const char *path, const vm_mesh_write_options *opt,
                              vm_error *err) {
    vm_mesh_write_options def;
    if (!opt) {
        vm_mesh_write_options_init(&def);
        opt = &def;
    }
    vm_mesh_format f;
    vm_status st = vm_output_check(path, err);
    if (!st) st = check_options(path, opt, &f, err);
    if (!st && f == VM_MESH_EXODUS) st = vm__exodus_check(path, err);
    return st;
}

vm_status vm_mesh_write_as(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err) {
    vm_mesh_write_options def;
    if (!opt) {
        vm_mesh_write_options_init(&def);
        opt = &def;
    }
    vm_mesh_format f;
    vm_status st = check_options(path, opt, &f, err);
    if (st) return st;
    vm_mesh_write_options o = *opt;
    o.format = f;
    switch (f) {
    case VM_MESH_VTU: return vm__write_vtu(path, m, &o, err);
    case VM_MESH_VTK: return vm__write_vtk(path, m, &o, err);
    case VM_MESH_INP: return vm_mesh_write_inp(path, m, &o, err);
    case VM_MESH_MSH:
    case VM_MESH_MSH2: return vm__write_msh(path, m, &o, err);
    case VM_MESH_MEDIT: return vm__write_medit(path, m, &o, err);
    case VM_MESH_STL: return vm__write_stl(path, m, &o, err);
    case VM_MESH_OFF: return vm__write_off(path, m, &o, err);
    case VM_MESH_PLY: return vm__write_ply(path, m, &o, err);
    case VM_MESH_OBJ: return vm__write_obj(path, m, &o, err);
    case VM_MESH_EXODUS: return vm_mesh_write_exodus(path, m, err);
    case VM_MESH_NASTRAN: return vm__write_nastran(path, m, &o, err);
    case VM_MESH_LSDYNA: return vm__write_lsdyna(path, m, &o, err);
    case VM_MESH_COMSOL: return vm__write_comsol(path, m, &o, err);
    case VM_MESH_FEBIO: return vm__write_febio(path, m, &o, err);
    case VM_MESH_XDMF: return vm_mesh_write_xdmf(path, m, &o, err);
    case VM_MESH_AUTO: break;
    }
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: unknown mesh format", path);
}

vm_status vm_mesh_write(const char *path, const vm_mesh *m, vm_error *err) {
    return vm_mesh_write_as(path, m, NULL, err);
}

vm_status vm_mesh_read_as(const char *path, vm_mesh_format f, vm_mesh *m, vm_error *err) {
    if (f == VM_MESH_AUTO) f = vm_mesh_format_of_path(path);
    switch (f) {
    case VM_MESH_VTU: return vm_mesh_read_vtu(path, m, err);
    case VM_MESH_VTK: return vm_mesh_read_vtk(path, m, err);
    case VM_MESH_INP: return vm_mesh_read_inp(path, m, err);
    case VM_MESH_MSH:
    case VM_MESH_MSH2: return vm_mesh_read_msh(path, m, err);
    case VM_MESH_MEDIT: return vm_mesh_read_medit(path, m, err);
    case VM_MESH_STL: return vm_mesh_read_stl(path, m, err);
    case VM_MESH_OFF: return vm_mesh_read_off(path, m, err);
    case VM_MESH_PLY: return vm_mesh_read_ply(path, m, err);
    case VM_MESH_OBJ: return vm_mesh_read_obj(path, m, err);
    case VM_MESH_EXODUS:
    case VM_MESH_NASTRAN:
    case VM_MESH_LSDYNA:
    case VM_MESH_COMSOL:
    case VM_MESH_FEBIO:
    case VM_MESH_XDMF:
        vm_mesh_init(m, VM_TET4);
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: reading %s is not supported (volmesh writes it only)", path,
                            vm_mesh_format_name(f));
    case VM_MESH_AUTO: break;
    }
    vm_mesh_init(m, VM_TET4);
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: unknown mesh format (expected one of %s)",
                        path, known_exts);
}

vm_status vm_mesh_read(const char *path, vm_mesh *m, vm_error *err) {
    return vm_mesh_read_as(path, VM_MESH_AUTO, m, err);
}
