/* SPDX-License-Identifier: BSD-3-Clause */
/* io/febio.c — FEBio input files (.feb, febio_spec 4.0): Module solid, a Material per region
 * (isotropic elastic), Mesh (Nodes, an Elements block per region, the outer Surface),
 * MeshDomains (a SolidDomain per region); with the static deck a fixed bottom and a loaded
 * top as in the .inp deck; order 2: tet10 / hex20 (straight mid-edge nodes). Follows the FEBio User's Manual 4.0, chapter 3 (the input file). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* Widest number text: no field width in XML, so the shortest exact one. */
enum { FEB_FIELD = 32 };
/* The static deck's total force in -z, spread over the loaded nodes (as the .inp deck). */
static const double FEB_TOTAL_FORCE = 100.0;

static const char *real(double v, char *buf, size_t cap) {
    vm__format_real(v, FEB_FIELD, 0, buf, cap);
    return buf;
}

/* Control (one static step) and the Materials, one per region. */
static void write_head(FILE *fp, const vm_mesh *m, const vm_mesh_write_options *opt,
                       const int32_t *regions, size_t nregions) {
    char a[40], b[40], c[40];
    fprintf(fp, "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n"
                "<!-- volmesh %s %s mesh: %zu nodes, %zu elements, %zu regions -->\n"
                "<febio_spec version=\"4.0\">\n\t<Module type=\"solid\"/>\n"
                "\t<Control>\n\t\t<analysis>STATIC</analysis>\n\t\t<time_steps>1</time_steps>\n"
                "\t\t<step_size>1</step_size>\n\t</Control>\n\t<Material>\n",
            vm_version(), vm_cell_kind_name(m->kind), m->npoints, m->ncells, nregions);
    for (size_t r = 0; r < nregions; r++) {
        vm_material mat;
        vm__material_of_region(opt, regions[r], &mat);
        fprintf(fp, "\t\t<material id=\"%zu\" name=\"%s\" type=\"isotropic elastic\">%s\n"
                    "\t\t\t<density>%s</density>\n\t\t\t<E>%s</E>\n\t\t\t<v>%s</v>\n"
                    "\t\t</material>\n",
                r + 1, mat.name,
                vm__material_is_placeholder(opt, regions[r]) ? "<!-- placeholder, N mm t -->"
                                                             : "",
                real(mat.density, a, sizeof a), real(mat.young, b, sizeof b),
                real(mat.poisson, c, sizeof c));
    }
    fprintf(fp, "\t</Material>\n");
}

/* Nodes, then one Elements block per region (ids run on across the blocks); m's cells have
 * nn nodes (10 or 20 for the second-order view). */
static void write_mesh(FILE *fp, vm_outfile *o, const vm_mesh *m, size_t nn,
                       const int32_t *regions, size_t nregions) {
    char x[40], y[40], z[40];
    fprintf(fp, "\t<Mesh>\n\t\t<Nodes name=\"NODES\">\n");
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        fprintf(fp, "\t\t\t<node id=\"%zu\">%s,%s,%s</node>\n", i + 1, real(p[0], x, sizeof x),
                real(p[1], y, sizeof y), real(p[2], z, sizeof z));
        vm__out_step(o, 1.0);
    }
    fprintf(fp, "\t\t</Nodes>\n");
    size_t id = 0;
    /* tet4, hex8 and their tet10, hex20 number corners and edges as VTK does */
    const char *type = m->kind == VM_TET4 ? (nn == 10 ? "tet10" : "tet4")
                                          : (nn == 20 ? "hex20" : "hex8");
    for (size_t r = 0; r < nregions; r++) {
        char rn[32];
        vm__region_name(regions[r], rn, sizeof rn);
        fprintf(fp, "\t\t<Elements type=\"%s\" name=\"%s\">\n", type, rn);
        for (size_t c = 0; c < m->ncells; c++) {
            if (m->region[c] != regions[r]) continue;
            fprintf(fp, "\t\t\t<elem id=\"%zu\">", ++id);
            for (size_t k = 0; k < nn; k++)
                fprintf(fp, "%lld%s", (long long)m->cells[c * nn + k] + 1, k + 1 < nn ? "," : "");
            fprintf(fp, "</elem>\n");
            vm__out_step(o, 1.0);
        }
        fprintf(fp, "\t\t</Elements>\n");
    }
}

/* The mid-edge node of the edge between local corners a and b of cell c (mid: NULL at order
 * 1, else vm__mid_nodes'). */
static long long edge_node(const vm_mesh *m, const vm_index *mid, size_t c, int a, int b) {
    int tet = m->kind == VM_TET4, ne = tet ? 6 : 12;
    const int(*edges)[2] = tet ? vm__tet_edges : vm__hex_edges;
    for (int k = 0; k < ne; k++)
        if ((edges[k][0] == a && edges[k][1] == b) || (edges[k][0] == b && edges[k][1] == a))
            return (long long)mid[c * (size_t)ne + (size_t)k];
    return -1;
}

/* The outer boundary as Surface OUTER (tri3 / quad4, outward; at order 2 tri6 / quad8 with
 * the mid-edge nodes of the face's edges 0-1, 1-2, ... after its corners). */
static void write_outer(FILE *fp, const vm_mesh *m, const vm_index *mid, const uint64_t *bf,
                        size_t nb) {
    int tet = m->kind == VM_TET4;
    size_t nn = (size_t)vm_cell_nodes(m->kind), fk = tet ? 3 : 4, nf = tet ? 4 : 6;
    const char *type = tet ? (mid ? "tri6" : "tri3") : (mid ? "quad8" : "quad4");
    fprintf(fp, "\t\t<Surface name=\"OUTER\">\n");
    for (size_t i = 0; i < nb; i++) {
        size_t c = (size_t)(bf[i] / nf);
        int f = (int)(bf[i] % nf), pos[4];
        fprintf(fp, "\t\t\t<%s id=\"%zu\">", type, i + 1);
        for (size_t j = 0; j < fk; j++) {
            pos[j] = tet ? vm__tet_faces[f][j] : vm__hex_faces[f][j];
            fprintf(fp, "%s%lld", j ? "," : "", (long long)m->cells[c * nn + (size_t)pos[j]] + 1);
        }
        for (size_t j = 0; mid && j < fk; j++)
            fprintf(fp, ",%lld", edge_node(m, mid, c, pos[j], pos[(j + 1) % fk]) + 1);
        fprintf(fp, "</%s>\n", type);
    }
    fprintf(fp, "\t\t</Surface>\n");
}

static void write_node_set(FILE *fp, const char *name, const int64_t *ids, size_t n) {
    fprintf(fp, "\t\t<NodeSet name=\"%s\">", name);
    for (size_t i = 0; i < n; i++)
        fprintf(fp, "%s%lld", i ? "," : "", (long long)ids[i]);
    fprintf(fp, "</NodeSet>\n");
}

/* The static deck: FIXED held in x, y, z; LOADED carrying the total force in -z. */
static void write_deck(FILE *fp, const vm__deck_nodes *d) {
    char f[40];
    fprintf(fp, "\t<Boundary>\n\t\t<bc name=\"FIXED\" node_set=\"FIXED\" "
                "type=\"zero displacement\">\n\t\t\t<x_dof>1</x_dof>\n\t\t\t<y_dof>1</y_dof>\n"
                "\t\t\t<z_dof>1</z_dof>\n\t\t</bc>\n\t</Boundary>\n");
    fprintf(fp, "\t<Loads>\n\t\t<nodal_load name=\"LOADED\" node_set=\"LOADED\" "
                "type=\"nodal_force\">\n\t\t\t<relative>0</relative>\n"
                "\t\t\t<value lc=\"1\">0,0,%s</value>\n\t\t</nodal_load>\n\t</Loads>\n",
            real(-FEB_TOTAL_FORCE / (double)d->nloaded, f, sizeof f));
    fprintf(fp, "\t<LoadData>\n\t\t<load_controller id=\"1\" name=\"LC1\" type=\"loadcurve\">\n"
                "\t\t\t<interpolate>LINEAR</interpolate>\n\t\t\t<points>\n"
                "\t\t\t\t<pt>0,0</pt>\n\t\t\t\t<pt>1,1</pt>\n\t\t\t</points>\n"
                "\t\t</load_controller>\n\t</LoadData>\n");
    fprintf(fp, "\t<Output>\n\t\t<plotfile type=\"febio\">\n\t\t\t<var type=\"displacement\"/>\n"
                "\t\t\t<var type=\"stress\"/>\n\t\t</plotfile>\n\t</Output>\n");
}

/* The static deck's node sets from the z of the nodes (q: the second-order view, or NULL). */
static vm_status deck_nodes(const char *path, const vm_mesh *m, const vm__quadratic *q,
                            vm__deck_nodes *d, vm_error *err) {
    const vm_mesh *all = q ? &q->view : m;
    double *zs = malloc((all->npoints ? all->npoints : 1) * sizeof *zs);
    if (!zs) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    for (size_t i = 0; i < all->npoints; i++)
        zs[i] = all->points[3 * i + 2];
    vm_status st = vm__deck_sets(path, m, zs, q ? q->mid : NULL,
                                 q ? (m->kind == VM_TET4 ? 6 : 12) : 0, all->npoints, d, err);
    free(zs);
    if (!st && !(d->nfixed > 0 && d->nloaded > 0))
        st = vm_error_set(err, VM_ERR_EMPTY, "%s: the mesh has no elements to load", path);
    return st;
}

vm_status vm__write_febio(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                          vm_error *err) {
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: FEBio solids are written for tet4 and hex8 meshes, not %s",
                            path, vm_cell_kind_name(m->kind));
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    int32_t *regions = NULL;
    uint64_t *bf = NULL;
    size_t nregions = 0, nb = 0;
    vm__deck_nodes d;
    memset(&d, 0, sizeof d);
    vm__quadratic q;
    memset(&q, 0, sizeof q);
    int order2 = opt->order == 2;
    size_t nn = (size_t)vm_cell_nodes(m->kind) + (order2 ? (m->kind == VM_TET4 ? 6 : 12) : 0);
    vm_outfile o;
    st = vm__distinct_regions(path, m, &regions, &nregions, err);
    if (!st) st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (!st && order2) st = vm__quadratic_make(path, m, NULL, opt, &q, err);
    if (!st && opt->deck == VM_DECK_STATIC) st = deck_nodes(path, m, order2 ? &q : NULL, &d, err);
    if (!st) st = vm__out_open(&o, path, err);
    if (!st) {
        FILE *fp = o.fp;
        const vm_mesh *w = order2 ? &q.view : m;
        vm__out_meter(&o, opt->progress, opt->progress_user, (double)w->npoints + m->ncells);
        write_head(fp, m, opt, regions, nregions);
        write_mesh(fp, &o, w, nn, regions, nregions);
        write_outer(fp, m, order2 ? q.mid : NULL, bf, nb);
        if (opt->deck == VM_DECK_STATIC) {
            write_node_set(fp, "FIXED", d.fixed, d.nfixed);
            write_node_set(fp, "LOADED", d.loaded, d.nloaded);
        }
        fprintf(fp, "\t</Mesh>\n\t<MeshDomains>\n");
        for (size_t r = 0; r < nregions; r++) {
            char rn[32];
            vm_material mat;
            vm__region_name(regions[r], rn, sizeof rn);
            vm__material_of_region(opt, regions[r], &mat);
            fprintf(fp, "\t\t<SolidDomain name=\"%s\" mat=\"%s\"/>\n", rn, mat.name);
        }
        fprintf(fp, "\t</MeshDomains>\n");
        if (opt->deck == VM_DECK_STATIC) write_deck(fp, &d);
        fprintf(fp, "</febio_spec>\n");
        st = vm__out_commit(&o, err);
    }
    free(regions);
    free(bf);
    free(d.fixed);
    free(d.loaded);
    if (order2) vm__quadratic_free(&q);
    return st;
}
