/* SPDX-License-Identifier: BSD-3-Clause */
/* io/comsol.c — COMSOL Multiphysics text mesh (.mphtxt, mesh version 4): the mesh vertices,
 * then two element types, the boundary faces (tri / quad) and the volume elements (tet /
 * hex), each with its geometric entity indices: domain = the region's ordinal (1, 2, ...),
 * boundary = one entity per region's outer boundary and per interface between two regions
 * (0, 1, ...). Follows the COMSOL Multiphysics Reference Manual, "The COMSOL Multiphysics
 * Text File Format" (tensor vertex order for quads and hexes). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* COMSOL's tensor order of a hex's corners, as VTK positions (VTK goes round each face). */
static const int HEX_TENSOR[8] = {0, 1, 3, 2, 4, 5, 7, 6};
/* The same for a quad face given round its corners. */
static const int QUAD_TENSOR[4] = {0, 1, 3, 2};

/* The faces written as boundary elements, each with its entity index. */
typedef struct comsol_faces {
    uint64_t *face;  /* cell * nf + local face */
    size_t *entity;  /* boundary entity, 0-based */
    size_t n, nentities;
} comsol_faces;

/* Outer faces grouped by the region of their cell, then the interfaces pair by pair. */
static vm_status gather_faces(const char *path, const vm_mesh *m, const int32_t *regions,
                              size_t nregions, comsol_faces *cf, vm_error *err) {
    uint64_t *bf = NULL;
    vm__iface *iff = NULL;
    size_t nb = 0, nif = 0;
    uint64_t nf = m->kind == VM_TET4 ? 4 : 6;
    memset(cf, 0, sizeof *cf);
    vm_status st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (!st && nregions > 1) st = vm__interface_faces(path, m, &iff, &nif, err);
    if (!st) {
        cf->face = malloc((nb + nif + 1) * sizeof *cf->face);
        cf->entity = malloc((nb + nif + 1) * sizeof *cf->entity);
        if (!cf->face || !cf->entity)
            st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for faces", path);
    }
    for (size_t r = 0; !st && r < nregions; r++) {
        size_t before = cf->n;
        for (size_t i = 0; i < nb; i++)
            if (m->region[bf[i] / nf] == regions[r]) {
                cf->face[cf->n] = bf[i];
                cf->entity[cf->n++] = cf->nentities;
            }
        if (cf->n > before) cf->nentities++;
    }
    for (size_t i = 0; !st && i < nif; i++) {
        if (i > 0 && (iff[i].region != iff[i - 1].region || iff[i].other != iff[i - 1].other))
            cf->nentities++;
        cf->face[cf->n] = iff[i].face;
        cf->entity[cf->n++] = cf->nentities;
    }
    if (nif) cf->nentities++;
    free(bf);
    free(iff);
    return st;
}

/* One "Type" block: name, vertices per element, the elements, their entity indices. */
static void type_header(FILE *fp, int index, const char *name, int nv, size_t n) {
    fprintf(fp, "\n# Type #%d\n\n%zu %s # type name\n\n\n%d # number of vertices per "
                "element\n%zu # number of elements\n# Elements\n",
            index, strlen(name), name, nv, n);
}

vm_status vm__write_comsol(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err) {
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: COMSOL meshes are written for tet4 and hex8 meshes, not %s",
                            path, vm_cell_kind_name(m->kind));
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    int32_t *regions = NULL;
    size_t nregions = 0;
    comsol_faces cf;
    memset(&cf, 0, sizeof cf);
    st = vm__distinct_regions(path, m, &regions, &nregions, err);
    if (!st) st = gather_faces(path, m, regions, nregions, &cf, err);
    vm_outfile o;
    if (!st) st = vm__out_open(&o, path, err);
    if (st) {
        free(regions);
        free(cf.face);
        free(cf.entity);
        return st;
    }
    FILE *fp = o.fp;
    int tet = m->kind == VM_TET4;
    size_t nn = (size_t)vm_cell_nodes(m->kind), fk = tet ? 3 : 4, nf = tet ? 4 : 6;
    vm__out_meter(&o, opt->progress, opt->progress_user,
                  (double)m->npoints + m->ncells + (double)cf.n);
    fprintf(fp, "# Created by volmesh %s: %zu domains (regions), %zu boundaries\n", vm_version(),
            nregions, cf.nentities);
    fprintf(fp, "# Major & minor version\n0 1\n1 # number of tags\n# Tags\n5 mesh1\n"
                "1 # number of types\n# Types\n3 obj\n\n# --------- Object 0 ----------\n\n"
                "0 0 1\n4 Mesh # class\n4 # version\n3 # sdim\n%zu # number of mesh vertices\n"
                "0 # lowest mesh vertex index\n\n# Mesh vertex coordinates\n", m->npoints);
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        fprintf(fp, "%.17g %.17g %.17g\n", p[0], p[1], p[2]);
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "\n2 # number of element types\n");
    type_header(fp, 0, tet ? "tri" : "quad", (int)fk, cf.n);
    for (size_t i = 0; i < cf.n; i++) {
        size_t c = (size_t)(cf.face[i] / nf);
        int f = (int)(cf.face[i] % nf);
        for (size_t j = 0; j < fk; j++) {
            int pos = tet ? vm__tet_faces[f][j] : vm__hex_faces[f][QUAD_TENSOR[j]];
            fprintf(fp, "%lld%c", (long long)m->cells[c * nn + (size_t)pos],
                    j + 1 < fk ? ' ' : '\n');
        }
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "\n%zu # number of geometric entity indices\n# Geometric entity indices\n",
            cf.n);
    for (size_t i = 0; i < cf.n; i++)
        fprintf(fp, "%zu\n", cf.entity[i]);
    type_header(fp, 1, tet ? "tet" : "hex", (int)nn, m->ncells);
    for (size_t c = 0; c < m->ncells; c++) {
        for (size_t k = 0; k < nn; k++)
            fprintf(fp, "%lld%c", (long long)m->cells[c * nn + (size_t)(tet ? (int)k : HEX_TENSOR[k])],
                    k + 1 < nn ? ' ' : '\n');
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "\n%zu # number of geometric entity indices\n# Geometric entity indices\n",
            m->ncells);
    for (size_t c = 0; c < m->ncells; c++)
        fprintf(fp, "%ld\n", vm__region_slot(regions, nregions, m->region[c]) + 1);
    free(regions);
    free(cf.face);
    free(cf.entity);
    return vm__out_commit(&o, err);
}
