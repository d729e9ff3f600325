/* SPDX-License-Identifier: BSD-3-Clause */
/* io/lsdyna.c — LS-DYNA keyword decks (.k): *NODE, per region a *PART with its
 * *SECTION_SOLID and *MAT_ELASTIC, *ELEMENT_SOLID, *END. Follows the LS-DYNA Keyword User's
 * Manual, volume I (fixed columns: *NODE I8 3E16, *ELEMENT_SOLID 10I8, *PART / *SECTION /
 * *MAT cards I10 and E10; a tetrahedron is N1 N2 N3 N4 with N4 repeated to N8). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* Largest id an 8-column field holds. */
#define DYNA_MAX_ID 99999999LL
/* Columns of the material card's reals (E10). */
enum { DYNA_CARD_FIELD = 10 };
/* ELFORM of *SECTION_SOLID: 10 the one-point tetrahedron, 1 the constant-stress hexahedron. */
enum { ELFORM_TET = 10, ELFORM_HEX = 1 };

/* A real in w columns. */
static const char *real_in(double v, int w, char *buf, size_t cap) {
    vm__format_real(v, w, 1, buf, cap);
    return buf;
}

/* Per region r (id = its ordinal k): *PART titled after it, *SECTION_SOLID k, *MAT_ELASTIC k. */
static void write_parts(FILE *fp, const vm_mesh *m, const vm_mesh_write_options *opt,
                        const int32_t *regions, size_t nregions) {
    char e[32], nu[32], rho[32];
    for (size_t r = 0; r < nregions; r++) {
        vm_material mat;
        char rn[32];
        vm__material_of_region(opt, regions[r], &mat);
        vm__region_name(regions[r], rn, sizeof rn);
        fprintf(fp, "*PART\n%s %s%s\n", rn, mat.name,
                vm__material_is_placeholder(opt, regions[r]) ? " (placeholder, N mm t)" : "");
        fprintf(fp, "$#     pid     secid       mid\n%10zu%10zu%10zu\n", r + 1, r + 1, r + 1);
        fprintf(fp, "*SECTION_SOLID\n$#   secid    elform\n%10zu%10d\n", r + 1,
                m->kind == VM_TET4 ? ELFORM_TET : ELFORM_HEX);
        fprintf(fp, "*MAT_ELASTIC\n$#     mid        ro         e        pr\n%10zu%10s%10s%10s\n",
                r + 1, real_in(mat.density, DYNA_CARD_FIELD, rho, sizeof rho),
                real_in(mat.young, DYNA_CARD_FIELD, e, sizeof e),
                real_in(mat.poisson, DYNA_CARD_FIELD, nu, sizeof nu));
    }
}

vm_status vm__write_lsdyna(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err) {
    int32_t *regions = NULL;
    size_t nregions = 0;
    vm_outfile o;
    vm_status st = vm__solid_deck_open(path, m, "LS-DYNA solids are written", DYNA_MAX_ID, opt,
                                       &regions, &nregions, &o, err);
    if (st) return st;
    FILE *fp = o.fp;
    fprintf(fp, "*KEYWORD\n*TITLE\nvolmesh %s mesh: %zu nodes, %zu elements, %zu parts\n",
            vm_cell_kind_name(m->kind), m->npoints, m->ncells, nregions);
    fprintf(fp, "$ written by volmesh %s; one part, section and material per region\n",
            vm_version());
    write_parts(fp, m, opt, regions, nregions);
    fprintf(fp, "*NODE\n$#   nid               x               y               z\n");
    char x[32], y[32], z[32];
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        fprintf(fp, "%8zu%16s%16s%16s\n", i + 1, real_in(p[0], VM__WIDE_FIELD, x, sizeof x),
                real_in(p[1], VM__WIDE_FIELD, y, sizeof y),
                real_in(p[2], VM__WIDE_FIELD, z, sizeof z));
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "*ELEMENT_SOLID\n$#   eid     pid      n1      n2      n3      n4      n5      "
                "n6      n7      n8\n");
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    for (size_t c = 0; c < m->ncells; c++) {
        long pid = vm__region_slot(regions, nregions, m->region[c]) + 1;
        const vm_index *v = m->cells + c * nn;
        fprintf(fp, "%8zu%8ld", c + 1, pid);
        /* VTK's corner order is LS-DYNA's; a tet repeats N4 */
        for (size_t k = 0; k < 8; k++)
            fprintf(fp, "%8lld", (long long)v[k < nn ? k : nn - 1] + 1);
        fputc('\n', fp);
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "*END\n");
    free(regions);
    return vm__out_commit(&o, err);
}
