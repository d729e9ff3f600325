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
    vm_status st = vm__check_cells(path, m, err);
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

vm_status vm_mesh_read_medit(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    vm__cursor c;
    vm__cur_init(&c, path, buf, len, '#', err);
    const char *t;
    size_t n;
    int version = 0, dim = 0, seen_vertices = 0;
    /* Elements of every kind are gathered; the highest dimension present is kept. */
    vm_index *cells[4] = {NULL, NULL, NULL, NULL};
    int32_t *regs[4] = {NULL, NULL, NULL, NULL};
    size_t ncells[4] = {0, 0, 0, 0};
    static const vm_cell_kind kinds[4] = {VM_TRI3, VM_QUAD4, VM_TET4, VM_HEX8};
    while (!st && vm__cur_token(&c, &t, &n)) {
        if (!version) {
            if (!vm__tok_is(t, n, "MeshVersionFormatted")) {
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "not a MEDIT mesh (no "
                                  "MeshVersionFormatted)");
                break;
            }
            int64_t v;
            st = vm__cur_int(&c, 1, 4, "MeshVersionFormatted", &v);
            version = (int)v;
            continue;
        }
        if (vm__tok_is(t, n, "Dimension")) {
            int64_t d;
            st = vm__cur_int(&c, 2, 3, "dimension", &d);
            if (!st && d != 3)
                st = vm__cur_fail(&c, VM_ERR_UNSUPPORTED, "2-D meshes are not supported");
            dim = 3;
            continue;
        }
        if (vm__tok_is(t, n, "End")) break;
        if (!dim) {
            st = vm__cur_fail(&c, VM_ERR_FORMAT, "\"%.*s\" before Dimension",
                              (int)(n > 40 ? 40 : n), t);
            break;
        }
        if (vm__tok_is(t, n, "Vertices")) {
            int64_t nv;
            if (seen_vertices++) {
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "Vertices given twice");
                break;
            }
            st = vm__cur_int(&c, 0, INT64_MAX, "number of vertices", &nv);
            if (!st) st = vm__check_count(&c, (uint64_t)nv, 8, "vertices");
            if (!st) st = vm_mesh_reserve(m, (size_t)nv, 0, err);
            for (int64_t i = 0; i < nv && !st; i++) {
                double p[3];
                int64_t ref;
                for (int d = 0; d < 3 && !st; d++)
                    st = vm__cur_double(&c, "vertex coordinate", &p[d]);
                if (!st) st = vm__cur_int(&c, INT64_MIN, INT64_MAX, "vertex reference", &ref);
                if (!st) vm_mesh_add_point(m, p, NULL);
            }
            continue;
        }
        size_t s = 0;
        for (; s < sizeof sections / sizeof sections[0]; s++)
            if (vm__tok_is(t, n, sections[s].name)) break;
        if (s == sizeof sections / sizeof sections[0]) {
            st = vm__cur_fail(&c, VM_ERR_UNSUPPORTED, "section \"%.*s\" is not supported",
                              (int)(n > 40 ? 40 : n), t);
            break;
        }
        int64_t ne;
        st = vm__cur_int(&c, 0, INT64_MAX, "number of entries", &ne);
        if (!st) st = vm__check_count(&c, (uint64_t)ne, 2 * (size_t)(sections[s].ints + sections[s].reals), sections[s].name);
        if (st) break;
        int slot = -1;
        for (int k = 0; k < 4; k++)
            if ((int)kinds[k] == sections[s].kind) slot = k;
        if (slot >= 0 && ncells[slot]) {
            st = vm__cur_fail(&c, VM_ERR_FORMAT, "%s given twice", sections[s].name);
            break;
        }
        if (slot >= 0 && ne > 0) {
            size_t nn = (size_t)vm_cell_nodes(kinds[slot]), total;
            if (!vm__mul_size((size_t)ne, nn * sizeof(vm_index), &total) ||
                !(cells[slot] = malloc(total)) ||
                !(regs[slot] = malloc((size_t)ne * sizeof(int32_t)))) {
                st = vm__cur_fail(&c, VM_ERR_NOMEM, "out of memory for %" PRId64 " %s", ne,
                                  sections[s].name);
                break;
            }
        }
        for (int64_t i = 0; i < ne && !st; i++) {
            for (int k = 0; k < sections[s].ints && !st; k++) {
                int64_t v;
                int is_ref = slot >= 0 && k == sections[s].ints - 1;
                st = vm__cur_int(&c, is_ref ? INT32_MIN : 1,
                                 is_ref ? INT32_MAX : INT64_MAX,
                                 is_ref ? "reference" : "vertex number", &v);
                if (st || slot < 0) continue;
                size_t nn = (size_t)vm_cell_nodes(kinds[slot]);
                if (is_ref)
                    regs[slot][i] = (int32_t)v;
                else if (v > (int64_t)m->npoints)
                    st = vm__cur_fail(&c, VM_ERR_FORMAT, "vertex %" PRId64 " of %zu", v,
                                      m->npoints);
                else
                    cells[slot][(size_t)i * nn + (size_t)k] = (vm_index)(v - 1);
            }
            for (int k = 0; k < sections[s].reals && !st; k++) {
                double v;
                st = vm__cur_double(&c, "value", &v);
            }
        }
        if (!st && slot >= 0) ncells[slot] = (size_t)ne;
    }
    if (!st && !version)
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: not a MEDIT mesh (empty)", path);
    int pick = -1;
    if (!st) {
        if (ncells[2] && ncells[3])
            st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes tetrahedra and hexahedra "
                              "(one element kind per mesh)", path);
        else
            pick = ncells[2] ? 2 : ncells[3] ? 3 : ncells[0] ? 0 : ncells[1] ? 1 : -1;
        if (!st && pick < 0)
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: no Tetrahedra, Hexahedra, Triangles or "
                              "Quadrilaterals", path);
    }
    if (!st && pick <= 1 && ncells[0] && ncells[1]) {
        /* Triangles and quads together: one tri3 mesh, quads split. */
        vm__polys polys;
        memset(&polys, 0, sizeof polys);
        for (int k = 0; k < 2 && !st; k++)
            for (size_t i = 0; i < ncells[k] && !st; i++)
                st = vm__polys_add(&polys, cells[k] + i * (size_t)(k ? 4 : 3), k ? 4 : 3,
                                   regs[k][i], err);
        if (!st) st = vm__polys_finish(path, &polys, m, err);
        else vm__polys_free(&polys);
    } else if (!st) {
        m->kind = kinds[pick];
        st = vm_mesh_reserve(m, m->npoints, ncells[pick], err);
        for (size_t i = 0; i < ncells[pick] && !st; i++)
            st = vm_mesh_add_cell(m, cells[pick] + i * (size_t)vm_cell_nodes(m->kind),
                                  regs[pick][i], err);
    }
    for (int k = 0; k < 4; k++) {
        free(cells[k]);
        free(regs[k]);
    }
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}
