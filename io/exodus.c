/* SPDX-License-Identifier: BSD-3-Clause */
/* io/exodus.c — Exodus II writer (through libexodusii, when the build found its header): one
 * element block per region, an element number map keeping the mesh's element numbers, a side
 * set and a node set of the outer boundary and of each interface between two regions. Follows "EXODUS II: A Finite Element Data Model" (Sandia,
 * SAND92-2137), element types TETRA/HEX/TRI3/SHELL4 and their side numbering.
 *
 * The library is opened with dlopen on the first .exo written, not linked: Debian's
 * libexoIIv2c pulls in netCDF, HDF5, Open MPI and curl (about 50 shared libraries, 13 MB of
 * resident memory in every process and their start-up cost), which no other format needs. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <errno.h>
#include <string.h>
#include "io_util.h"
#include "mesh_util.h"
#include "../core/core.h"

#ifdef VM_HAVE_EXODUS
#include <dlfcn.h>
#include <exodusII.h>
#include <unistd.h>

#ifndef VM_EXODUS_SONAME
#define VM_EXODUS_SONAME "libexoIIv2c.so"
#endif

/* The entry points used, with the prototypes of exodusII.h (ex_create is a macro over
 * ex_create_int that passes the header's API version). */
static struct {
    int tried, ok;
    int (*opts)(int);
    int (*create_int)(const char *, int, int *, int *, int);
    int (*put_init)(int, const char *, int64_t, int64_t, int64_t, int64_t, int64_t, int64_t);
    int (*put_coord)(int, const void *, const void *, const void *);
    int (*put_block)(int, ex_entity_type, ex_entity_id, const char *, int64_t, int64_t, int64_t,
                     int64_t, int64_t);
    int (*put_conn)(int, ex_entity_type, ex_entity_id, const void_int *, const void_int *,
                    const void_int *);
    int (*put_name)(int, ex_entity_type, ex_entity_id, const char *);
    int (*put_id_map)(int, ex_entity_type, const void_int *);
    int (*put_set_param)(int, ex_entity_type, ex_entity_id, int64_t, int64_t);
    int (*put_set)(int, ex_entity_type, ex_entity_id, const void_int *, const void_int *);
    int (*close)(int);
} exo;

/* Looks up name in lib into the function pointer fn (VM_ERR_UNSUPPORTED when missing). ISO C
 * cannot convert an object pointer (dlsym's) to a function pointer; POSIX guarantees the
 * representation, so the bytes are copied. */
static vm_status exo_sym(void *lib, const char *name, void *fn, size_t size) {
    void *p = dlsym(lib, name);
    if (!p) return VM_ERR_UNSUPPORTED;
    memcpy(fn, &p, size);
    return VM_OK;
}

/* The library to open: $VOLMESH_EXODUS_LIBRARY when set (a path or a name, for an
 * installation outside the loader's path), else the soname found at build time. */
static const char *exo_name(void) {
    const char *e = getenv("VOLMESH_EXODUS_LIBRARY");
    return e && *e ? e : VM_EXODUS_SONAME;
}

/* Opens the library once (the handle stays open for the process: Open MPI's libraries do
 * not unload cleanly). Not thread-safe on its first call, like the library itself. */
static int exo_load(void) {
    if (exo.tried) return exo.ok;
    exo.tried = 1;
    void *lib = dlopen(exo_name(), RTLD_NOW | RTLD_LOCAL);
    if (!lib) return 0;
#define EXO_SYM(field, name) (exo_sym(lib, name, &exo.field, sizeof exo.field) == VM_OK)
    exo.ok = EXO_SYM(opts, "ex_opts") && EXO_SYM(create_int, "ex_create_int") &&
             EXO_SYM(put_init, "ex_put_init") && EXO_SYM(put_coord, "ex_put_coord") &&
             EXO_SYM(put_block, "ex_put_block") && EXO_SYM(put_conn, "ex_put_conn") &&
             EXO_SYM(put_name, "ex_put_name") && EXO_SYM(put_id_map, "ex_put_id_map") &&
             EXO_SYM(put_set_param, "ex_put_set_param") && EXO_SYM(put_set, "ex_put_set") &&
             EXO_SYM(close, "ex_close");
#undef EXO_SYM
    return exo.ok;
}

int vm_exodus_available(void) {
    return exo_load();
}

vm_status vm__exodus_check(const char *path, vm_error *err) {
    if (exo_load()) return VM_OK;
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: cannot load the Exodus II library %s (install libexodusii)", path,
                        exo_name());
}

/* Our (ABAQUS) face numbers S1.. to Exodus side numbers. */
static const int tet_side[4] = {4, 1, 2, 3};
static const int hex_side[6] = {5, 6, 1, 2, 3, 4};

static int cmp_int(const void *a, const void *b) {
    int x = *(const int *)a, y = *(const int *)b;
    return (x > y) - (x < y);
}

/* Writes side set id and node set id named name: the n faces face(i) (cell * nf + local
 * face), elements numbered by rank, and their distinct nodes. elist, slist, nodes: scratch
 * of n, n and n * 4 ints. Returns nonzero when the library fails. */
static int put_face_sets(int exoid, ex_entity_id id, const char *name, const vm_mesh *m,
                         const uint64_t *faces, const vm__iface *iff, size_t n, const int *rank,
                         int *elist, int *slist, int *nodes) {
    int tet = m->kind == VM_TET4;
    size_t nf = tet ? 4 : 6, fk = tet ? 3 : 4, nn = tet ? 4 : 8, nnodes = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t fc = faces ? faces[i] : iff[i].face;
        size_t c = (size_t)(fc / nf), f = (size_t)(fc % nf);
        elist[i] = rank[c];
        slist[i] = tet ? tet_side[f] : hex_side[f];
        for (size_t k = 0; k < fk; k++) {
            int local = tet ? vm__tet_faces[f][k] : vm__hex_faces[f][k];
            nodes[nnodes++] = (int)m->cells[c * nn + (size_t)local] + 1;
        }
    }
    qsort(nodes, nnodes, sizeof *nodes, cmp_int);
    size_t u = 0;
    for (size_t i = 0; i < nnodes; i++)
        if (u == 0 || nodes[i] != nodes[u - 1]) nodes[u++] = nodes[i];
    return exo.put_set_param(exoid, EX_SIDE_SET, id, (int64_t)n, 0) < 0 ||
           exo.put_set(exoid, EX_SIDE_SET, id, elist, slist) < 0 ||
           exo.put_name(exoid, EX_SIDE_SET, id, name) < 0 ||
           exo.put_set_param(exoid, EX_NODE_SET, id, (int64_t)u, 0) < 0 ||
           exo.put_set(exoid, EX_NODE_SET, id, nodes, NULL) < 0 ||
           exo.put_name(exoid, EX_NODE_SET, id, name) < 0;
}

vm_status vm_mesh_write_exodus(const char *path, const vm_mesh *m, vm_error *err) {
    int nn = vm_cell_nodes(m->kind);
    if (!nn)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__exodus_check(path, err);
    if (st) return st;
    st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    if (m->npoints > INT32_MAX || m->ncells > INT32_MAX)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: too large for 32-bit Exodus ids",
                            path);
    int volume = m->kind == VM_TET4 || m->kind == VM_HEX8;
    const char *etype = m->kind == VM_TET4   ? "TETRA"
                        : m->kind == VM_HEX8 ? "HEX"
                        : m->kind == VM_TRI3 ? "TRI3"
                                             : "SHELL4";
    int32_t *regions = NULL;
    size_t nreg = 0, nb = 0, nif = 0, npairs = 0;
    uint64_t *bf = NULL;
    vm__iface *iff = NULL;
    st = vm__distinct_regions(path, m, &regions, &nreg, err);
    if (!st && volume) st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (!st && volume && nreg > 1) st = vm__interface_faces(path, m, &iff, &nif, err);
    if (st) {
        free(regions);
        free(bf);
        return st;
    }
    for (size_t i = 0; i < nif; i++)
        npairs += i == 0 || iff[i].region != iff[i - 1].region || iff[i].other != iff[i - 1].other;
    size_t nset = nb > nif ? nb : nif; /* the largest face set */
    size_t np = m->npoints ? m->npoints : 1, nc = m->ncells ? m->ncells : 1;
    double *xyz = malloc(3 * np * sizeof *xyz);
    int *conn = malloc(nc * (size_t)nn * sizeof *conn);
    int *order = malloc(nc * sizeof *order);  /* cells sorted by region: file element i */
    int *rank = malloc(nc * sizeof *rank);    /* cell -> 1-based file element number */
    int *elist = malloc((nset + 1) * sizeof *elist), *slist = malloc((nset + 1) * sizeof *slist);
    int *setnodes = malloc((4 * nset + 1) * sizeof *setnodes);
    char tmp[4200];
    int exoid = -1;
    if (!vm__temp_path(path, "tmp", tmp, sizeof tmp)) {
        st = vm_error_set(err, VM_ERR_ARG, "%s: path too long", path);
        goto done;
    }
    if (!xyz || !conn || !order || !rank || !elist || !slist || !setnodes) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    for (size_t i = 0; i < m->npoints; i++)
        for (int d = 0; d < 3; d++)
            xyz[(size_t)d * m->npoints + i] = m->points[3 * i + (size_t)d];
    size_t k = 0;
    for (size_t r = 0; r < nreg; r++)
        for (size_t c = 0; c < m->ncells; c++)
            if (m->region[c] == regions[r]) {
                order[k] = (int)c;
                rank[c] = (int)++k;
            }
    exo.opts(0); /* the library reports through our status, never prints or aborts */
    int cws = 8, iows = 8;
    exoid = exo.create_int(tmp, EX_CLOBBER, &cws, &iows, EX_API_VERS_NODOT);
    if (exoid < 0) {
        st = vm_error_set(err, VM_ERR_IO, "%s: cannot create the Exodus file", path);
        goto done;
    }
    int bad = exo.put_init(exoid, "volmesh mesh", 3, (int64_t)m->npoints, (int64_t)m->ncells,
                          (int64_t)nreg, (int64_t)((nb ? 1 : 0) + npairs),
                          (int64_t)((nb ? 1 : 0) + npairs)) < 0;
    bad = bad || exo.put_coord(exoid, xyz, xyz + m->npoints, xyz + 2 * m->npoints) < 0;
    k = 0;
    for (size_t r = 0; r < nreg && !bad; r++) {
        size_t n = 0;
        for (size_t c = 0; c < m->ncells; c++)
            if (m->region[c] == regions[r]) {
                for (int j = 0; j < nn; j++)
                    conn[n * (size_t)nn + (size_t)j] = (int)m->cells[c * (size_t)nn + (size_t)j] + 1;
                n++;
            }
        char name[32];
        vm__region_name(regions[r], name, sizeof name);
        bad = exo.put_block(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), etype, (int64_t)n, nn,
                           0, 0, 0) < 0 ||
              exo.put_conn(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), conn, NULL, NULL) < 0 ||
              exo.put_name(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), name) < 0;
    }
    if (!bad) {
        for (size_t i = 0; i < m->ncells; i++)
            order[i] += 1; /* element number map: file element i is mesh element order[i]+1 */
        bad = exo.put_id_map(exoid, EX_ELEM_MAP, order) < 0;
    }
    if (!bad && volume && nb)
        bad = put_face_sets(exoid, 1, "BOUNDARY", m, bf, NULL, nb, rank, elist, slist,
                            setnodes);
    /* each interface, from the side of its lower region: sets 2, 3, ... */
    ex_entity_id id = nb ? 2 : 1;
    for (size_t i = 0; i < nif && !bad;) {
        size_t j = i;
        while (j < nif && iff[j].region == iff[i].region && iff[j].other == iff[i].other) j++;
        char a[32], b[32], name[80];
        vm__region_name(iff[i].region, a, sizeof a);
        vm__region_name(iff[i].other, b, sizeof b);
        snprintf(name, sizeof name, "IFACE_%s_%s", a, b);
        bad = put_face_sets(exoid, id++, name, m, NULL, iff + i, j - i, rank, elist, slist,
                            setnodes);
        i = j;
    }
    if (exo.close(exoid) < 0) bad = 1;
    exoid = -1;
    if (bad) {
        st = vm_error_set(err, VM_ERR_IO, "%s: writing the Exodus file failed", path);
        remove(tmp);
    } else if (rename(tmp, path) != 0) {
        st = vm_error_set(err, VM_ERR_IO, "%s: cannot write (%s)", path, strerror(errno));
        remove(tmp);
    }
done:
    free(regions);
    free(bf);
    free(iff);
    free(setnodes);
    free(xyz);
    free(conn);
    free(order);
    free(rank);
    free(elist);
    free(slist);
    return st;
}

#else

int vm_exodus_available(void) {
    return 0;
}

vm_status vm__exodus_check(const char *path, vm_error *err) {
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: this volmesh was built without Exodus II (install libexodusii-dev "
                        "and rebuild)", path);
}

vm_status vm_mesh_write_exodus(const char *path, const vm_mesh *m, vm_error *err) {
    (void)m;
    return vm__exodus_check(path, err);
}

#endif
