/* SPDX-License-Identifier: BSD-3-Clause */
/* io/xdmf.c — XDMF 3 (.xdmf, light XML) with its heavy data in a sibling HDF5 file (.h5), in
 * the layout FEniCSx/dolfinx reads: Grid "mesh" (XDMFFile.read_mesh), and Grids "cell_tags"
 * (the regions) and "facet_tags" (outer boundary 1, interfaces 2, 3, ...) for
 * XDMFFile.read_meshtags. Follows the XDMF model (xdmf.org, "XDMF Model and Format") and the
 * HDF5 1.10 C API; node order is VTK's, which is XDMF's for every topology written. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

#ifdef VM_HAVE_HDF5
#include <hdf5.h>
#include <unistd.h>

int vm_xdmf_available(void) { return 1; }

/* The facets written as "facet_tags": cell * nfaces + local face and its tag. */
typedef struct xdmf_facets {
    uint64_t *face;
    int32_t *tag;
    size_t n;
    size_t ninterfaces; /* distinct region pairs: tags 2 .. 1 + ninterfaces */
} xdmf_facets;

/* Outer boundary faces (tag 1), then each pair of regions' interface (tags 2, 3, ... in the
 * order of vm__interface_faces: by lower region, then the other). */
static vm_status gather_facets(const char *path, const vm_mesh *m, xdmf_facets *xf,
                               vm_error *err) {
    uint64_t *bf = NULL;
    vm__iface *iff = NULL;
    size_t nb = 0, nif = 0;
    memset(xf, 0, sizeof *xf);
    vm_status st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (!st) st = vm__interface_faces(path, m, &iff, &nif, err);
    if (!st) {
        xf->face = malloc((nb + nif + 1) * sizeof *xf->face);
        xf->tag = malloc((nb + nif + 1) * sizeof *xf->tag);
        if (!xf->face || !xf->tag)
            st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for facets", path);
    }
    for (size_t i = 0; !st && i < nb; i++) {
        xf->face[xf->n] = bf[i];
        xf->tag[xf->n++] = 1;
    }
    for (size_t i = 0; !st && i < nif; i++) {
        if (i == 0 || iff[i].region != iff[i - 1].region || iff[i].other != iff[i - 1].other)
            xf->ninterfaces++;
        xf->face[xf->n] = iff[i].face;
        xf->tag[xf->n++] = (int32_t)(1 + xf->ninterfaces);
    }
    free(bf);
    free(iff);
    return st;
}

/* Local edge (of vm__tet_edges / vm__hex_edges) joining corners a and b, or -1. */
static int edge_of(vm_cell_kind kind, int a, int b) {
    int ne = kind == VM_TET4 ? 6 : 12;
    const int(*edges)[2] = kind == VM_TET4 ? vm__tet_edges : vm__hex_edges;
    for (int e = 0; e < ne; e++)
        if ((edges[e][0] == a && edges[e][1] == b) || (edges[e][0] == b && edges[e][1] == a))
            return e;
    return -1;
}

/* Writes a 2-D dataset rows x cols of type ftype at name in loc from buf (memory type mtype). */
static int h5_put(hid_t loc, const char *name, hid_t ftype, hid_t mtype, size_t rows,
                  size_t cols, const void *buf) {
    hsize_t dims[2] = {(hsize_t)rows, (hsize_t)cols};
    hid_t space = H5Screate_simple(2, dims, NULL);
    if (space < 0) return -1;
    hid_t ds = H5Dcreate2(loc, name, ftype, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    int bad = ds < 0;
    if (!bad && rows && cols) bad = H5Dwrite(ds, mtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) < 0;
    if (ds >= 0 && H5Dclose(ds) < 0) bad = 1;
    if (H5Sclose(space) < 0) bad = 1;
    return bad ? -1 : 0;
}

/* Creates group path (its parents first, each "/"-separated prefix). */
static int h5_group(hid_t file, const char *gpath) {
    char buf[128];
    size_t n = strlen(gpath);
    if (n >= sizeof buf) return -1;
    for (size_t i = 1; i <= n; i++) {
        if (gpath[i] != '/' && gpath[i] != '\0') continue;
        memcpy(buf, gpath, i);
        buf[i] = '\0';
        htri_t exists = H5Lexists(file, buf, H5P_DEFAULT);
        if (exists < 0) return -1;
        if (exists) continue;
        hid_t g = H5Gcreate2(file, buf, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
        if (g < 0 || H5Gclose(g) < 0) return -1;
    }
    return 0;
}

/* The arrays written: the (possibly second-order) mesh and its tags. */
typedef struct xdmf_data {
    const vm_mesh *mesh;       /* corners plus mid-edge nodes when quadratic */
    size_t npe, fpe;           /* nodes per cell and per facet */
    int64_t *topo, *ftopo;     /* ncells * npe, nfacets * fpe */
    int32_t *ctag;             /* ncells */
    xdmf_facets facets;
    const char *cell_type, *facet_type; /* XDMF TopologyType names */
} xdmf_data;

/* Fills d from m (and q's view when second-order). */
static vm_status xdmf_prepare(const char *path, const vm_mesh *m, const vm__quadratic *q,
                              int order, xdmf_data *d, vm_error *err) {
    int tet = m->kind == VM_TET4;
    size_t nn = (size_t)vm_cell_nodes(m->kind), nf = tet ? 4 : 6, fc = tet ? 3 : 4;
    size_t ne = tet ? 6 : 12;
    d->mesh = order == 2 ? &q->view : m;
    d->npe = order == 2 ? nn + ne : nn;
    d->fpe = order == 2 ? 2 * fc : fc;
    d->cell_type = tet ? (order == 2 ? "Tetrahedron_10" : "Tetrahedron")
                       : (order == 2 ? "Hexahedron_20" : "Hexahedron");
    d->facet_type = tet ? (order == 2 ? "Triangle_6" : "Triangle")
                        : (order == 2 ? "Quadrilateral_8" : "Quadrilateral");
    vm_status st = gather_facets(path, m, &d->facets, err);
    if (st) return st;
    size_t nt, nft, bytes;
    if (vm__mul_overflows(m->ncells, d->npe, &nt) ||
        vm__mul_overflows(d->facets.n, d->fpe, &nft) ||
        vm__mul_overflows(nt + nft + m->ncells + 1, sizeof(int64_t), &bytes) ||
        bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "%s: mesh too large for memory", path);
    d->topo = malloc((nt ? nt : 1) * sizeof *d->topo);
    d->ftopo = malloc((nft ? nft : 1) * sizeof *d->ftopo);
    d->ctag = malloc((m->ncells ? m->ncells : 1) * sizeof *d->ctag);
    if (!d->topo || !d->ftopo || !d->ctag)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for the topology", path);
    for (size_t i = 0; i < nt; i++) d->topo[i] = (int64_t)d->mesh->cells[i];
    for (size_t c = 0; c < m->ncells; c++) d->ctag[c] = m->region[c];
    const int *faces = tet ? &vm__tet_faces[0][0] : &vm__hex_faces[0][0];
    for (size_t i = 0; i < d->facets.n; i++) {
        size_t c = (size_t)(d->facets.face[i] / nf), f = (size_t)(d->facets.face[i] % nf);
        const int *lf = faces + f * fc;
        int64_t *out = d->ftopo + i * d->fpe;
        for (size_t k = 0; k < fc; k++) out[k] = (int64_t)m->cells[c * nn + (size_t)lf[k]];
        if (order == 2)
            for (size_t k = 0; k < fc; k++) {
                int e = edge_of(m->kind, lf[k], lf[(k + 1) % fc]);
                out[fc + k] = (int64_t)q->view.cells[c * d->npe + nn + (size_t)e];
            }
    }
    return VM_OK;
}

static void xdmf_data_free(xdmf_data *d) {
    free(d->topo);
    free(d->ftopo);
    free(d->ctag);
    free(d->facets.face);
    free(d->facets.tag);
}

/* The heavy data: /Mesh/mesh/{geometry,topology}, /MeshTags/{cell_tags,facet_tags}/
 * {topology,values}, /Fields/{point,cell}/NAME (the mesh's fields). */
static int h5_write_all(const char *tmp, const xdmf_data *d) {
    const vm_mesh *v = d->mesh;
    hid_t f = H5Fcreate(tmp, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
    if (f < 0) return -1;
    int bad = h5_group(f, "/Mesh/mesh") || h5_group(f, "/MeshTags/cell_tags") ||
              h5_group(f, "/MeshTags/facet_tags");
    bad = bad || h5_put(f, "/Mesh/mesh/geometry", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                        v->npoints, 3, v->points);
    bad = bad || h5_put(f, "/Mesh/mesh/topology", H5T_STD_I64LE, H5T_NATIVE_INT64, v->ncells,
                        d->npe, d->topo);
    bad = bad || h5_put(f, "/MeshTags/cell_tags/topology", H5T_STD_I64LE, H5T_NATIVE_INT64,
                        v->ncells, d->npe, d->topo);
    bad = bad || h5_put(f, "/MeshTags/cell_tags/values", H5T_STD_I32LE, H5T_NATIVE_INT32,
                        v->ncells, 1, d->ctag);
    bad = bad || h5_put(f, "/MeshTags/facet_tags/topology", H5T_STD_I64LE, H5T_NATIVE_INT64,
                        d->facets.n, d->fpe, d->ftopo);
    bad = bad || h5_put(f, "/MeshTags/facet_tags/values", H5T_STD_I32LE, H5T_NATIVE_INT32,
                        d->facets.n, 1, d->facets.tag);
    if (!bad && (v->npoint_fields || v->ncell_fields))
        bad = h5_group(f, "/Fields/point") || h5_group(f, "/Fields/cell");
    for (int on = 0; on < 2 && !bad; on++) {
        size_t nfield = on ? v->ncell_fields : v->npoint_fields;
        for (size_t i = 0; i < nfield && !bad; i++) {
            const vm_field *fl = on ? &v->cell_fields[i] : &v->point_fields[i];
            char name[96];
            snprintf(name, sizeof name, "/Fields/%s/%zu", on ? "cell" : "point", i);
            bad = h5_put(f, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE,
                         on ? v->ncells : v->npoints, (size_t)fl->ncomp, fl->data);
        }
    }
    if (H5Fclose(f) < 0) bad = 1;
    return bad ? -1 : 0;
}

/* A DataItem referring to h5:/dset. */
static void put_item(FILE *fp, const char *indent, size_t rows, size_t cols, const char *type,
                     int precision, const char *h5, const char *dset) {
    fprintf(fp,
            "%s<DataItem Dimensions=\"%zu %zu\" NumberType=\"%s\" Precision=\"%d\" "
            "Format=\"HDF\">%s:%s</DataItem>\n",
            indent, rows, cols, type, precision, h5, dset);
}

/* Writes the XML text of name in XML-escaped form (field names are free text). */
static void put_escaped(FILE *fp, const char *s) {
    for (; *s; s++) {
        switch (*s) {
        case '&': fputs("&amp;", fp); break;
        case '<': fputs("&lt;", fp); break;
        case '>': fputs("&gt;", fp); break;
        case '"': fputs("&quot;", fp); break;
        default: fputc(*s, fp);
        }
    }
}

/* One Grid: its topology from dataset topo (count x npe of type), the mesh's geometry. */
static void put_grid(FILE *fp, const char *name, const char *type, size_t count, size_t npe,
                     const char *h5, const char *topo, size_t npoints) {
    fprintf(fp, "    <Grid Name=\"%s\" GridType=\"Uniform\">\n", name);
    fprintf(fp, "      <Topology TopologyType=\"%s\" NumberOfElements=\"%zu\" "
                "NodesPerElement=\"%zu\">\n", type, count, npe);
    put_item(fp, "        ", count, npe, "Int", 8, h5, topo);
    fputs("      </Topology>\n      <Geometry GeometryType=\"XYZ\">\n", fp);
    put_item(fp, "        ", npoints, 3, "Float", 8, h5, "/Mesh/mesh/geometry");
    fputs("      </Geometry>\n", fp);
}

static void put_xml(FILE *fp, const char *h5, const xdmf_data *d, const vm_mesh *m) {
    const vm_mesh *v = d->mesh;
    fputs("<?xml version=\"1.0\"?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
          "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n  <Domain>\n",
          fp);
    fprintf(fp, "    <!-- written by volmesh: %zu nodes, %zu %s cells; facet_tags: 1 = outer "
                "boundary, 2.. = interfaces between regions -->\n",
            v->npoints, v->ncells, d->cell_type);
    put_grid(fp, "mesh", d->cell_type, v->ncells, d->npe, h5, "/Mesh/mesh/topology",
             v->npoints);
    for (int on = 0; on < 2; on++) {
        size_t nfield = on ? v->ncell_fields : v->npoint_fields;
        for (size_t i = 0; i < nfield; i++) {
            const vm_field *fl = on ? &v->cell_fields[i] : &v->point_fields[i];
            char dset[96];
            snprintf(dset, sizeof dset, "/Fields/%s/%zu", on ? "cell" : "point", i);
            fputs("      <Attribute Name=\"", fp);
            put_escaped(fp, fl->name);
            fprintf(fp, "\" AttributeType=\"%s\" Center=\"%s\">\n",
                    fl->ncomp == 1 ? "Scalar" : fl->ncomp == 3 ? "Vector" : "Matrix",
                    on ? "Cell" : "Node");
            put_item(fp, "        ", on ? v->ncells : v->npoints, (size_t)fl->ncomp, "Float", 8,
                     h5, dset);
            fputs("      </Attribute>\n", fp);
        }
    }
    fputs("    </Grid>\n", fp);
    put_grid(fp, "cell_tags", d->cell_type, m->ncells, d->npe, h5,
             "/MeshTags/cell_tags/topology", v->npoints);
    fputs("      <Attribute Name=\"cell_tags\" AttributeType=\"Scalar\" Center=\"Cell\">\n",
          fp);
    put_item(fp, "        ", m->ncells, 1, "Int", 4, h5, "/MeshTags/cell_tags/values");
    fputs("      </Attribute>\n    </Grid>\n", fp);
    put_grid(fp, "facet_tags", d->facet_type, d->facets.n, d->fpe, h5,
             "/MeshTags/facet_tags/topology", v->npoints);
    fputs("      <Attribute Name=\"facet_tags\" AttributeType=\"Scalar\" Center=\"Cell\">\n",
          fp);
    put_item(fp, "        ", d->facets.n, 1, "Int", 4, h5, "/MeshTags/facet_tags/values");
    fputs("      </Attribute>\n    </Grid>\n  </Domain>\n</Xdmf>\n", fp);
}

vm_status vm_mesh_write_xdmf(const char *path, const vm_mesh *m,
                             const vm_mesh_write_options *opt, vm_error *err) {
    vm_mesh_write_options def;
    if (!opt) {
        vm_mesh_write_options_init(&def);
        opt = &def;
    }
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: XDMF is written for tet4 and hex8 meshes, not %s", path,
                            vm_cell_kind_name(m->kind));
    /* the heavy data's name: path with .xdmf replaced by .h5; the XML names it relative */
    size_t len = strlen(path);
    char h5path[4096], tmp[4200];
    if (len < 5 || len + 4 > sizeof h5path)
        return vm_error_set(err, VM_ERR_ARG, "%s: path too long", path);
    memcpy(h5path, path, len - 5);
    memcpy(h5path + len - 5, ".h5", 4);
    const char *slash = strrchr(h5path, '/');
    const char *h5name = slash ? slash + 1 : h5path;
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", h5path, (long)getpid());

    vm__quadratic q;
    memset(&q, 0, sizeof q);
    xdmf_data d;
    memset(&d, 0, sizeof d);
    vm_status st = VM_OK;
    if (opt->order == 2) st = vm__quadratic_make(path, m, NULL, opt, &q, err);
    if (!st) st = xdmf_prepare(path, m, &q, opt->order, &d, err);
    vm_outfile o;
    int h5_made = 0;
    if (!st) {
        H5Eset_auto2(H5E_DEFAULT, NULL, NULL); /* errors become one status, not a trace */
        h5_made = 1;
        if (h5_write_all(tmp, &d))
            st = vm_error_set(err, VM_ERR_IO, "%s: cannot write the HDF5 file %s", path, tmp);
    }
    if (!st) st = vm__out_open(&o, path, err);
    if (!st) {
        /* the HDF5 arrays are written in one call each: progress is the XML's one step */
        vm__out_meter(&o, opt->progress, opt->progress_user, 1.0);
        put_xml(o.fp, h5name, &d, m);
        vm__out_step(&o, 1.0);
        if (rename(tmp, h5path) != 0) {
            vm__out_abort(&o);
            st = vm_error_set(err, VM_ERR_IO, "%s: cannot rename %s to %s", path, tmp, h5path);
        } else {
            h5_made = 0;
            st = vm__out_commit(&o, err);
            if (st) remove(h5path);
        }
    }
    if (h5_made) remove(tmp);
    xdmf_data_free(&d);
    if (opt->order == 2) vm__quadratic_free(&q);
    return st;
}

#else

int vm_xdmf_available(void) { return 0; }

vm_status vm_mesh_write_xdmf(const char *path, const vm_mesh *m,
                             const vm_mesh_write_options *opt, vm_error *err) {
    (void)m;
    (void)opt;
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: this volmesh was built without XDMF (needs libhdf5-dev at "
                        "configure time)", path);
}

#endif
