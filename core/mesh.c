/* SPDX-License-Identifier: BSD-3-Clause */
/* core/mesh.c — vm_mesh storage: points, cells, regions and named fields. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "core.h"
#include "volmesh/mesh.h"

int vm_cell_nodes(vm_cell_kind kind) {
    switch (kind) {
    case VM_TRI3: return 3;
    case VM_QUAD4: return 4;
    case VM_TET4: return 4;
    case VM_HEX8: return 8;
    }
    return 0;
}

const char *vm_cell_kind_name(vm_cell_kind kind) {
    switch (kind) {
    case VM_TRI3: return "tri3";
    case VM_QUAD4: return "quad4";
    case VM_TET4: return "tet4";
    case VM_HEX8: return "hex8";
    }
    return "unknown";
}

vm_status vm__check_nodes(const vm_mesh *m, vm_status code, const char *what, vm_error *err) {
    /* Points first: a coordinate beyond VM_COORD_MAX makes the bounding box's span, the
     * squared lengths and the volumes of the metrics overflow to inf and NaN. */
    for (size_t i = 0; i < 3 * m->npoints; i++) {
        double x = m->points[i];
        if (!(fabs(x) <= VM_COORD_MAX))
            return vm_error_set(err, code,
                                "%s: point %zu, coordinate %c, is %g (coordinates must be "
                                "finite, within +-%g)",
                                what, i / 3, "xyz"[i % 3], x, VM_COORD_MAX);
    }
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    for (size_t i = 0; i < m->ncells * nn; i++)
        if (m->cells[i] < 0 || (uint64_t)m->cells[i] >= (uint64_t)m->npoints)
            return vm_error_set(err, code, "%s: cell %zu uses node %lld, outside 0..%zu", what,
                                i / nn, (long long)m->cells[i], m->npoints ? m->npoints - 1 : 0);
    return VM_OK;
}

void vm_mesh_init(vm_mesh *m, vm_cell_kind kind) {
    memset(m, 0, sizeof *m);
    m->kind = kind;
}

static void free_fields(vm_field *f, size_t n) {
    for (size_t i = 0; i < n; i++) free(f[i].data);
    free(f);
}

void vm_mesh_free(vm_mesh *m) {
    if (!m) return;
    vm_cell_kind kind = m->kind;
    free(m->points);
    free(m->cells);
    free(m->region);
    free_fields(m->point_fields, m->npoint_fields);
    free_fields(m->cell_fields, m->ncell_fields);
    vm_mesh_init(m, kind);
}

vm_status vm_mesh_reserve(vm_mesh *m, size_t npoints, size_t ncells, vm_error *err) {
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    if (npoints > m->point_cap) {
        size_t cap = m->point_cap;
        vm_status st = vm__grow((void **)&m->points, &cap, npoints, 3 * sizeof(double), err);
        if (st) return st;
        m->point_cap = cap;
    }
    if (ncells > m->cell_cap) {
        size_t cap = m->cell_cap, cap2 = m->cell_cap;
        vm_status st = vm__grow((void **)&m->cells, &cap, ncells, nn * sizeof(vm_index), err);
        if (st) return st;
        st = vm__grow((void **)&m->region, &cap2, cap, sizeof(int32_t), err);
        if (st) return st;
        m->cell_cap = cap;
    }
    return VM_OK;
}

vm_index vm_mesh_add_point(vm_mesh *m, const double xyz[3], vm_error *err) {
    if (vm_mesh_reserve(m, m->npoints + 1, m->ncells, err)) return -1;
    memcpy(m->points + 3 * m->npoints, xyz, 3 * sizeof(double));
    return (vm_index)m->npoints++;
}

vm_status vm_mesh_add_cell(vm_mesh *m, const vm_index *nodes, int32_t region, vm_error *err) {
    vm_status st = vm_mesh_reserve(m, m->npoints, m->ncells + 1, err);
    if (st) return st;
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    memcpy(m->cells + nn * m->ncells, nodes, nn * sizeof(vm_index));
    m->region[m->ncells++] = region;
    return VM_OK;
}

vm_status vm_mesh_set_field(vm_mesh *m, int on_cells, const char *name, int ncomp,
                            const double *data, vm_error *err) {
    vm_field **list = on_cells ? &m->cell_fields : &m->point_fields;
    size_t *count = on_cells ? &m->ncell_fields : &m->npoint_fields;
    size_t n = on_cells ? m->ncells : m->npoints, bytes;
    if (ncomp < 1 || vm__mul_overflows(n, (size_t)ncomp * sizeof(double), &bytes))
        return vm_error_set(err, VM_ERR_ARG, "field %s: bad size", name);
    double *copy = malloc(bytes ? bytes : 1);
    if (!copy) return vm_error_set(err, VM_ERR_NOMEM, "field %s: out of memory", name);
    memcpy(copy, data, bytes);
    for (size_t i = 0; i < *count; i++)
        if (strcmp((*list)[i].name, name) == 0) {
            free((*list)[i].data);
            (*list)[i].data = copy;
            (*list)[i].ncomp = ncomp;
            return VM_OK;
        }
    vm_field *nl = realloc(*list, (*count + 1) * sizeof **list);
    if (!nl) {
        free(copy);
        return vm_error_set(err, VM_ERR_NOMEM, "field %s: out of memory", name);
    }
    *list = nl;
    vm_field *f = &nl[(*count)++];
    memset(f, 0, sizeof *f);
    strncpy(f->name, name, sizeof f->name - 1);
    f->ncomp = ncomp;
    f->data = copy;
    return VM_OK;
}

const vm_field *vm_mesh_find_field(const vm_mesh *m, int on_cells, const char *name) {
    const vm_field *list = on_cells ? m->cell_fields : m->point_fields;
    size_t count = on_cells ? m->ncell_fields : m->npoint_fields;
    for (size_t i = 0; i < count; i++)
        if (strcmp(list[i].name, name) == 0) return &list[i];
    return NULL;
}
