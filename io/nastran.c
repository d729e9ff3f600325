/* SPDX-License-Identifier: BSD-3-Clause */
/* io/nastran.c — Nastran bulk data (.bdf): GRID* in large-field format, CTETRA / CHEXA in
 * small-field format, one PSOLID and MAT1* per region. Follows the MSC Nastran Quick
 * Reference Guide (bulk data entry formats: small field 8 columns, large field 16 with a
 * '*' continuation; real numbers carry a decimal point). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* Largest id a small-field (8-column) integer field holds. */
#define NASTRAN_MAX_ID 99999999LL

/* A large-field real: 16 columns, with a decimal point. */
static const char *wide_real(double v, char *buf, size_t cap) {
    vm__format_real(v, VM__WIDE_FIELD, 1, buf, cap);
    return buf;
}

/* One PSOLID and one MAT1* per region: property and material id = the region's ordinal. */
static void write_properties(FILE *fp, const vm_mesh_write_options *opt,
                             const int32_t *regions, size_t nregions) {
    char e[32], nu[32], rho[32];
    for (size_t r = 0; r < nregions; r++) {
        vm_material mat;
        char rn[32];
        vm__material_of_region(opt, regions[r], &mat);
        vm__region_name(regions[r], rn, sizeof rn);
        fprintf(fp, "$ %s: PSOLID %zu, MAT1 %zu = %s%s\n", rn, r + 1, r + 1, mat.name,
                vm__material_is_placeholder(opt, regions[r]) ? " (placeholder, N mm t)" : "");
        fprintf(fp, "%-8s%8zu%8zu\n", "PSOLID", r + 1, r + 1);
        /* MAT1* MID E G NU, continued by RHO (G left blank: from E and NU) */
        fprintf(fp, "%-8s%16zu%16s%16s%16s\n", "MAT1*", r + 1,
                wide_real(mat.young, e, sizeof e), "", wide_real(mat.poisson, nu, sizeof nu));
        fprintf(fp, "%-8s%16s\n", "*", wide_real(mat.density, rho, sizeof rho));
    }
}

vm_status vm__write_nastran(const char *path, const vm_mesh *m,
                            const vm_mesh_write_options *opt, vm_error *err) {
    int32_t *regions = NULL;
    size_t nregions = 0;
    vm_outfile o;
    vm_status st = vm__solid_deck_open(path, m, "Nastran bulk data is written", NASTRAN_MAX_ID,
                                       opt, &regions, &nregions, &o, err);
    if (st) return st;
    FILE *fp = o.fp;
    int tet = m->kind == VM_TET4;
    fprintf(fp, "$ volmesh %s mesh: %zu nodes, %zu %s elements, %zu regions (volmesh %s)\n",
            vm_cell_kind_name(m->kind), m->npoints, m->ncells, tet ? "CTETRA" : "CHEXA",
            nregions, vm_version());
    fprintf(fp, "BEGIN BULK\n");
    write_properties(fp, opt, regions, nregions);
    char x[32], y[32], z[32];
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        /* GRID* ID CP X1 X2, continued by X3 (CP blank: the basic system) */
        fprintf(fp, "%-8s%16zu%16s%16s%16s\n%-8s%16s\n", "GRID*", i + 1, "",
                wide_real(p[0], x, sizeof x), wide_real(p[1], y, sizeof y), "*",
                wide_real(p[2], z, sizeof z));
        vm__out_step(&o, 1.0);
    }
    /* CTETRA and CHEXA number their corners as VTK does (G1..G4 the base, G5..G8 the top) */
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    for (size_t c = 0; c < m->ncells; c++) {
        long pid = vm__region_slot(regions, nregions, m->region[c]) + 1;
        const vm_index *v = m->cells + c * nn;
        fprintf(fp, "%-8s%8zu%8ld", tet ? "CTETRA" : "CHEXA", c + 1, pid);
        for (size_t k = 0; k < nn; k++) {
            if (k == 6) fprintf(fp, "\n%-8s", "+"); /* fields 4..9 hold six nodes */
            fprintf(fp, "%8lld", (long long)v[k] + 1);
        }
        fputc('\n', fp);
        vm__out_step(&o, 1.0);
    }
    fprintf(fp, "ENDDATA\n");
    free(regions);
    return vm__out_commit(&o, err);
}
