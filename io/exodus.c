/* io/exodus.c — Exodus II writer (through libexodusii, when the build found it): one element
 * block per region, an element number map keeping the mesh's element numbers, and one side
 * set of the boundary faces. Follows "EXODUS II: A Finite Element Data Model" (Sandia,
 * SAND92-2137), element types TETRA/HEX/TRI3/SHELL4 and their side numbering. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "io_util.h"
#include "mesh_util.h"

#ifdef VM_HAVE_EXODUS
#include <exodusII.h>
#include <unistd.h>

int vm_exodus_available(void) {
    return 1;
}

/* Our (ABAQUS) face numbers S1.. to Exodus side numbers. */
static const int tet_side[4] = {4, 1, 2, 3};
static const int hex_side[6] = {5, 6, 1, 2, 3, 4};

vm_status vm_mesh_write_exodus(const char *path, const vm_mesh *m, vm_error *err) {
    int nn = vm_cell_nodes(m->kind);
    if (!nn)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__check_cells(path, m, err);
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
    size_t nreg = 0, nb = 0;
    uint64_t *bf = NULL;
    st = vm__distinct_regions(path, m, &regions, &nreg, err);
    if (!st && volume) st = vm__boundary_faces(path, m, &bf, &nb, err);
    if (st) {
        free(regions);
        return st;
    }
    size_t np = m->npoints ? m->npoints : 1, nc = m->ncells ? m->ncells : 1;
    double *xyz = malloc(3 * np * sizeof *xyz);
    int *conn = malloc(nc * (size_t)nn * sizeof *conn);
    int *order = malloc(nc * sizeof *order);  /* cells sorted by region: file element i */
    int *rank = malloc(nc * sizeof *rank);    /* cell -> 1-based file element number */
    int *elist = malloc((nb ? nb : 1) * sizeof *elist), *slist = malloc((nb ? nb : 1) * sizeof *slist);
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    int exoid = -1;
    if (!xyz || !conn || !order || !rank || !elist || !slist) {
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
    ex_opts(0); /* the library reports through our status, never prints or aborts */
    int cws = 8, iows = 8;
    exoid = ex_create(tmp, EX_CLOBBER, &cws, &iows);
    if (exoid < 0) {
        st = vm_error_set(err, VM_ERR_IO, "%s: cannot create the Exodus file", path);
        goto done;
    }
    int bad = ex_put_init(exoid, "volmesh mesh", 3, (int64_t)m->npoints, (int64_t)m->ncells,
                          (int64_t)nreg, 0, volume && nb ? 1 : 0) < 0;
    bad = bad || ex_put_coord(exoid, xyz, xyz + m->npoints, xyz + 2 * m->npoints) < 0;
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
        bad = ex_put_block(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), etype, (int64_t)n, nn,
                           0, 0, 0) < 0 ||
              ex_put_conn(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), conn, NULL, NULL) < 0 ||
              ex_put_name(exoid, EX_ELEM_BLOCK, (ex_entity_id)(r + 1), name) < 0;
    }
    if (!bad) {
        for (size_t i = 0; i < m->ncells; i++)
            order[i] += 1; /* element number map: file element i is mesh element order[i]+1 */
        bad = ex_put_id_map(exoid, EX_ELEM_MAP, order) < 0;
    }
    if (!bad && volume && nb) {
        int nf = m->kind == VM_TET4 ? 4 : 6;
        for (size_t i = 0; i < nb; i++) {
            size_t c = (size_t)(bf[i] / (uint64_t)nf);
            int f = (int)(bf[i] % (uint64_t)nf);
            elist[i] = rank[c];
            slist[i] = nf == 4 ? tet_side[f] : hex_side[f];
        }
        bad = ex_put_set_param(exoid, EX_SIDE_SET, 1, (int64_t)nb, 0) < 0 ||
              ex_put_set(exoid, EX_SIDE_SET, 1, elist, slist) < 0 ||
              ex_put_name(exoid, EX_SIDE_SET, 1, "BOUNDARY") < 0;
    }
    if (ex_close(exoid) < 0) bad = 1;
    exoid = -1;
    if (bad) {
        st = vm_error_set(err, VM_ERR_IO, "%s: writing the Exodus file failed", path);
        remove(tmp);
    } else if (rename(tmp, path) != 0) {
        st = vm_error_set(err, VM_ERR_IO, "%s: cannot write", path);
        remove(tmp);
    }
done:
    free(regions);
    free(bf);
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

vm_status vm_mesh_write_exodus(const char *path, const vm_mesh *m, vm_error *err) {
    (void)m;
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: this volmesh was built without Exodus II (install libexodusii-dev "
                        "and rebuild)", path);
}

#endif
