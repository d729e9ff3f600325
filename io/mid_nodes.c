/* SPDX-License-Identifier: BSD-3-Clause */
/* io/mid_nodes.c — the mid-edge nodes of second-order elements (C3D10 / C3D20 in .inp,
 * tetra10 / hexahedron20 in .vtu, tet10 / hex20 in .msh): one shared node per distinct edge,
 * numbered after the corners, placed at the edge's middle (then curved onto the surface by
 * io/mid_curve.c where the write options carry the volume). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesh_util.h"

typedef struct edge_rec {
    vm_index a, b; /* a < b */
    uint64_t slot; /* cell * nedges + local edge */
} edge_rec;

static int cmp_edge(const void *x, const void *y) {
    const edge_rec *p = x, *q = y;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    if (p->b != q->b) return p->b < q->b ? -1 : 1;
    return (p->slot > q->slot) - (p->slot < q->slot);
}

/* Numbers the distinct edges after the corners (edges sorted by their end nodes). */
vm_status vm__mid_nodes(const char *path, const vm_mesh *m, vm_index **mid, size_t *nmid,
                        vm_error *err) {
    int ne = m->kind == VM_TET4 ? 6 : 12;
    const int(*edges)[2] = m->kind == VM_TET4 ? vm__tet_edges : vm__hex_edges;
    size_t nn = (size_t)vm_cell_nodes(m->kind), total, bytes;
    *mid = NULL;
    *nmid = 0;
    if (vm__mul_overflows(m->ncells, (size_t)ne, &total) ||
        vm__mul_overflows(total ? total : 1, sizeof(edge_rec), &bytes) ||
        bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "%s: too many edges", path);
    edge_rec *e = malloc(bytes);
    vm_index *out = malloc((total ? total : 1) * sizeof *out);
    if (!e || !out) {
        free(e);
        free(out);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for %zu edges", path, total);
    }
    for (size_t c = 0; c < m->ncells; c++)
        for (int k = 0; k < ne; k++) {
            vm_index a = m->cells[c * nn + (size_t)edges[k][0]];
            vm_index b = m->cells[c * nn + (size_t)edges[k][1]];
            edge_rec *r = &e[c * (size_t)ne + (size_t)k];
            r->a = a < b ? a : b;
            r->b = a < b ? b : a;
            r->slot = (uint64_t)c * (uint64_t)ne + (uint64_t)k;
        }
    qsort(e, total, sizeof *e, cmp_edge);
    size_t next = m->npoints;
    for (size_t i = 0; i < total; i++) {
        if (i > 0 && (e[i].a != e[i - 1].a || e[i].b != e[i - 1].b)) next++;
        out[e[i].slot] = (vm_index)next;
    }
    *nmid = total ? next + 1 - m->npoints : 0;
    free(e);
    *mid = out;
    return VM_OK;
}

/* Each mid-edge node's value: the mean of its edge's two end values. */
void vm__mid_average(const vm_mesh *m, const vm_index *mid, const double *vals, int ncomp,
                     double *out) {
    int ne = m->kind == VM_TET4 ? 6 : 12;
    const int(*edges)[2] = m->kind == VM_TET4 ? vm__tet_edges : vm__hex_edges;
    size_t nn = (size_t)vm_cell_nodes(m->kind), nc = (size_t)ncomp;
    memcpy(out, vals, m->npoints * nc * sizeof *out);
    for (size_t c = 0; c < m->ncells; c++)
        for (int k = 0; k < ne; k++) {
            size_t a = (size_t)m->cells[c * nn + (size_t)edges[k][0]];
            size_t b = (size_t)m->cells[c * nn + (size_t)edges[k][1]];
            size_t t = (size_t)mid[c * (size_t)ne + (size_t)k];
            for (size_t d = 0; d < nc; d++)
                out[t * nc + d] = 0.5 * (vals[a * nc + d] + vals[b * nc + d]);
        }
}

/* Frees what vm__quadratic_make allocated. */
void vm__quadratic_free(vm__quadratic *q) {
    free(q->mid);
    free(q->view.points);
    free(q->view.cells);
    for (size_t f = 0; q->view.point_fields && f < q->view.npoint_fields; f++)
        free(q->view.point_fields[f].data);
    free(q->view.point_fields);
}

/* Mid-edge nodes, then the extended points, point fields and cells. */
vm_status vm__quadratic_make(const char *path, const vm_mesh *m, const int *order,
                             const vm_mesh_write_options *opt, vm__quadratic *q,
                             vm_error *err) {
    memset(q, 0, sizeof *q);
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: second-order elements are written for tet4 and hex8 meshes, "
                            "not %s", path, vm_cell_kind_name(m->kind));
    size_t nmid = 0, nn = (size_t)vm_cell_nodes(m->kind), ne = m->kind == VM_TET4 ? 6 : 12;
    vm_status st = vm__mid_nodes(path, m, &q->mid, &nmid, err);
    if (st) return st;
    q->view = *m;
    q->view.npoints = m->npoints + nmid;
    q->view.points = malloc(3 * (q->view.npoints + 1) * sizeof(double));
    q->view.cells = malloc((m->ncells * (nn + ne) + 1) * sizeof(vm_index));
    q->view.point_fields = calloc(m->npoint_fields + 1, sizeof(vm_field));
    int ok = q->view.points && q->view.cells && q->view.point_fields;
    for (size_t f = 0; ok && f < m->npoint_fields; f++) {
        q->view.point_fields[f] = m->point_fields[f];
        q->view.point_fields[f].data =
            malloc((q->view.npoints * (size_t)m->point_fields[f].ncomp + 1) * sizeof(double));
        ok = q->view.point_fields[f].data != NULL;
        if (ok)
            vm__mid_average(m, q->mid, m->point_fields[f].data, m->point_fields[f].ncomp,
                            q->view.point_fields[f].data);
    }
    if (!ok) {
        q->view.npoint_fields = m->npoint_fields;
        vm__quadratic_free(q);
        memset(q, 0, sizeof *q);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for mid-edge nodes", path);
    }
    vm__mid_average(m, q->mid, m->points, 3, q->view.points);
    st = vm__mid_curve(path, m, q->mid, nmid, opt, q->view.points, err);
    if (st) {
        q->view.npoint_fields = m->npoint_fields;
        vm__quadratic_free(q);
        memset(q, 0, sizeof *q);
        return st;
    }
    for (size_t c = 0; c < m->ncells; c++) {
        vm_index *dst = q->view.cells + c * (nn + ne);
        for (size_t k = 0; k < nn + ne; k++) {
            size_t j = order ? (size_t)order[k] : k; /* corners, then mid-edge nodes */
            dst[k] = j < nn ? m->cells[c * nn + j] : q->mid[c * ne + (j - nn)];
        }
    }
    return VM_OK;
}
