/* SPDX-License-Identifier: BSD-3-Clause */
/* io/medit.c — MEDIT .mesh files (ASCII): Vertices and one element section with
 * references = region. Follows P. Frey, "MEDIT: an interactive mesh visualization software",
 * INRIA RT-0253 (2001), appendix on the .mesh format, and the libMeshb keyword list. */
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"

static const char *section_of(vm_cell_kind k) {
    switch (k) {
    case VM_TRI3: return "Triangles";
    case VM_QUAD4: return "Quadrilaterals";
    case VM_TET4: return "Tetrahedra";
    case VM_HEX8: return "Hexahedra";
    }
    return NULL;
}

vm_status vm_mesh_write_medit(const char *path, const vm_mesh *m, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    return vm__write_medit(path, m, &opt, err);
}

vm_status vm__write_medit(const char *path, const vm_mesh *m,
                          const vm_mesh_write_options *opt, vm_error *err) {
    const char *sec = section_of(m->kind);
    if (!sec)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) return st;
    FILE *fp = o.fp;
    vm__out_meter(&o, opt->progress, opt->progress_user, (double)m->npoints + m->ncells);
    fprintf(fp, "MeshVersionFormatted 2\n\nDimension 3\n\nVertices\n%zu\n", m->npoints);
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        fprintf(fp, "%.17g %.17g %.17g 0\n", p[0], p[1], p[2]);
        vm__out_step(&o, 1.0);
    }
    /* MEDIT's node order for all four kinds is VTK's (tets: positive det(p1-p0,p2-p0,p3-p0)). */
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    fprintf(fp, "\n%s\n%zu\n", sec, m->ncells);
    for (size_t c = 0; c < m->ncells; c++) {
        for (size_t k = 0; k < nn; k++)
            fprintf(fp, "%lld ", (long long)m->cells[c * nn + k] + 1);
        fprintf(fp, "%ld\n", (long)m->region[c]);
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "\nEnd\n");
    return vm__out_commit(&o, err);
}

/* Sections a reader may meet, with the numbers per entry (integers or reals). */
static const struct {
    const char *name;
    int ints, reals;
    int kind; /* 0: skipped; else the vm_cell_kind */
} sections[] = {
    {"Triangles", 4, 0, VM_TRI3},
    {"Quadrilaterals", 5, 0, VM_QUAD4},
    {"Tetrahedra", 5, 0, VM_TET4},
    {"Hexahedra", 9, 0, VM_HEX8},
    {"Edges", 3, 0, 0},
    {"Corners", 1, 0, 0},
    {"Ridges", 1, 0, 0},
    {"RequiredVertices", 1, 0, 0},
    {"RequiredEdges", 1, 0, 0},
    {"RequiredTriangles", 1, 0, 0},
    {"RequiredQuadrilaterals", 1, 0, 0},
    {"RequiredTetrahedra", 1, 0, 0},
    {"RequiredHexahedra", 1, 0, 0},
    {"Normals", 0, 3, 0},
    {"NormalAtVertices", 2, 0, 0},
    {"Tangents", 0, 3, 0},
    {"TangentAtVertices", 2, 0, 0},
    {"TangentAtEdges", 3, 0, 0},
};

/* Element kinds a MEDIT file may hold, in the slots the reader keeps them in. */
enum { SLOT_TRI, SLOT_QUAD, SLOT_TET, SLOT_HEX, NSLOTS };
static const vm_cell_kind slot_kinds[NSLOTS] = {VM_TRI3, VM_QUAD4, VM_TET4, VM_HEX8};

/* Elements of every kind as read (the highest dimension present is kept later). */
typedef struct medit_cells {
    vm_index *cells[NSLOTS];
    int32_t *regs[NSLOTS];
    size_t ncells[NSLOTS];
} medit_cells;

/* Smallest bytes of text per number in a section ("1 " or "1\n"), to bound counts. */
enum { MIN_BYTES_PER_NUMBER = 2 };

/* Vertices: count, then x y z ref per vertex (the reference is read and dropped). */
static vm_status read_vertices(vm__cursor *c, vm_mesh *m) {
    int64_t nv;
    vm_status st = vm__cur_int(c, 0, INT64_MAX, "number of vertices", &nv);
    if (!st) st = vm__check_count(c, (uint64_t)nv, 8, "vertices");
    if (!st) st = vm_mesh_reserve(m, (size_t)nv, 0, c->err);
    for (int64_t i = 0; i < nv && !st; i++) {
        double p[3];
        int64_t ref;
        for (int d = 0; d < 3 && !st; d++)
            st = vm__cur_double(c, "vertex coordinate", &p[d]);
        if (!st) st = vm__cur_int(c, INT64_MIN, INT64_MAX, "vertex reference", &ref);
        if (!st) vm_mesh_add_point(m, p, NULL);
    }
    return st;
}

/* The entries of section s: element sections fill their slot of d, others are skipped. */
static vm_status read_section(vm__cursor *c, size_t s, const vm_mesh *m, medit_cells *d) {
    int64_t ne;
    vm_status st = vm__cur_int(c, 0, INT64_MAX, "number of entries", &ne);
    if (!st)
        st = vm__check_count(c, (uint64_t)ne,
                             MIN_BYTES_PER_NUMBER *
                                 (size_t)(sections[s].ints + sections[s].reals),
                             sections[s].name);
    if (st) return st;
    int slot = -1;
    for (int k = 0; k < NSLOTS; k++)
        if ((int)slot_kinds[k] == sections[s].kind) slot = k;
    if (slot >= 0 && d->ncells[slot])
        return vm__cur_fail(c, VM_ERR_FORMAT, "%s given twice", sections[s].name);
    size_t nn = slot >= 0 ? (size_t)vm_cell_nodes(slot_kinds[slot]) : 0;
    if (slot >= 0 && ne > 0) {
        size_t total;
        if (vm__mul_overflows((size_t)ne, nn * sizeof(vm_index), &total) ||
            !(d->cells[slot] = malloc(total)) ||
            !(d->regs[slot] = malloc((size_t)ne * sizeof(int32_t))))
            return vm__cur_fail(c, VM_ERR_NOMEM, "out of memory for %" PRId64 " %s", ne,
                                sections[s].name);
    }
    for (int64_t i = 0; i < ne && !st; i++) {
        for (int k = 0; k < sections[s].ints && !st; k++) {
            int64_t v;
            int is_ref = slot >= 0 && k == sections[s].ints - 1;
            st = vm__cur_int(c, is_ref ? INT32_MIN : 1, is_ref ? INT32_MAX : INT64_MAX,
                             is_ref ? "reference" : "vertex number", &v);
            if (st || slot < 0) continue;
            if (is_ref)
                d->regs[slot][i] = (int32_t)v;
            else if (v > (int64_t)m->npoints)
                st = vm__cur_fail(c, VM_ERR_FORMAT, "vertex %" PRId64 " of %zu", v,
                                  m->npoints);
            else
                d->cells[slot][(size_t)i * nn + (size_t)k] = (vm_index)(v - 1);
        }
        for (int k = 0; k < sections[s].reals && !st; k++) {
            double v;
            st = vm__cur_double(c, "value", &v);
        }
    }
    if (!st && slot >= 0) d->ncells[slot] = (size_t)ne;
    return st;
}

/* MeshVersionFormatted, Dimension 3, then sections up to End (or the end of the file). */
static vm_status read_keywords(vm__cursor *c, vm_mesh *m, medit_cells *d) {
    const char *t;
    size_t n;
    int version = 0, dim = 0, seen_vertices = 0;
    vm_status st = VM_OK;
    while (!st && vm__cur_token(c, &t, &n)) {
        if (!version) {
            if (!vm__tok_is(t, n, "MeshVersionFormatted"))
                return vm__cur_fail(c, VM_ERR_FORMAT, "not a MEDIT mesh (no "
                                    "MeshVersionFormatted)");
            int64_t v;
            st = vm__cur_int(c, 1, 4, "MeshVersionFormatted", &v);
            version = (int)v;
            continue;
        }
        if (vm__tok_is(t, n, "Dimension")) {
            int64_t dd;
            st = vm__cur_int(c, 2, 3, "dimension", &dd);
            if (!st && dd != 3)
                st = vm__cur_fail(c, VM_ERR_UNSUPPORTED, "2-D meshes are not supported");
            dim = 3;
            continue;
        }
        if (vm__tok_is(t, n, "End")) break;
        if (!dim)
            return vm__cur_fail(c, VM_ERR_FORMAT, "\"%.*s\" before Dimension",
                                (int)(n > 40 ? 40 : n), t);
        if (vm__tok_is(t, n, "Vertices")) {
            if (seen_vertices++) return vm__cur_fail(c, VM_ERR_FORMAT, "Vertices given twice");
            st = read_vertices(c, m);
            continue;
        }
        size_t s = 0;
        for (; s < sizeof sections / sizeof sections[0]; s++)
            if (vm__tok_is(t, n, sections[s].name)) break;
        if (s == sizeof sections / sizeof sections[0])
            return vm__cur_fail(c, VM_ERR_UNSUPPORTED, "section \"%.*s\" is not supported",
                                (int)(n > 40 ? 40 : n), t);
        st = read_section(c, s, m, d);
    }
    if (!st && !version)
        st = vm_error_set(c->err, VM_ERR_FORMAT, "%s: not a MEDIT mesh (empty)", c->path);
    return st;
}

/* Keeps the elements of the highest dimension: tets or hexes, else triangles and quads (both
 * together as one tri3 mesh, quads split). */
static vm_status assemble_cells(const char *path, const medit_cells *d, vm_mesh *m,
                                vm_error *err) {
    const size_t *nc = d->ncells;
    if (nc[SLOT_TET] && nc[SLOT_HEX])
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes tetrahedra and hexahedra "
                            "(one element kind per mesh)", path);
    int pick = nc[SLOT_TET]    ? SLOT_TET
               : nc[SLOT_HEX]  ? SLOT_HEX
               : nc[SLOT_TRI]  ? SLOT_TRI
               : nc[SLOT_QUAD] ? SLOT_QUAD
                               : -1;
    if (pick < 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: no Tetrahedra, Hexahedra, Triangles or "
                            "Quadrilaterals", path);
    vm_status st = VM_OK;
    if (pick <= SLOT_QUAD && nc[SLOT_TRI] && nc[SLOT_QUAD]) {
        vm__polys polys;
        memset(&polys, 0, sizeof polys);
        for (int k = SLOT_TRI; k <= SLOT_QUAD && !st; k++)
            for (size_t i = 0; i < nc[k] && !st; i++)
                st = vm__polys_add(&polys, d->cells[k] + i * (size_t)(k ? 4 : 3), k ? 4 : 3,
                                   d->regs[k][i], err);
        if (!st)
            st = vm__polys_finish(path, &polys, m, err);
        else
            vm__polys_free(&polys);
        return st;
    }
    m->kind = slot_kinds[pick];
    st = vm_mesh_reserve(m, m->npoints, nc[pick], err);
    for (size_t i = 0; i < nc[pick] && !st; i++)
        st = vm_mesh_add_cell(m, d->cells[pick] + i * (size_t)vm_cell_nodes(m->kind),
                              d->regs[pick][i], err);
    return st;
}

/* Reads the keywords and sections, then keeps one element kind. */
vm_status vm_mesh_read_medit(const char *path, vm_mesh *m, vm_error *err) {
    unsigned char *buf = NULL;
    vm__cursor c;
    vm_status st = vm__mesh_read_begin(path, m, VM_TET4, '#', &buf, &c, err);
    if (st) return st;
    medit_cells d;
    memset(&d, 0, sizeof d);
    st = read_keywords(&c, m, &d);
    if (!st) st = assemble_cells(path, &d, m, err);
    for (int k = 0; k < NSLOTS; k++) {
        free(d.cells[k]);
        free(d.regs[k]);
    }
    return vm__mesh_read_end(m, buf, st);
}
