/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/improve/test_improve_frozen.c — vm_improve_options.frozen: with every tet frozen the
 * quality pass tries nothing and returns the mesh as it was (while without flags it changes
 * it); flags that are all zero give exactly the one pass without flags (flags run the one
 * pass); freezing the tets of one half of a sphere (a region of its own) improves the other
 * half only, and the mesh stays valid. */
#include <string.h>
#include "test.h"

static int mesh_phantom(vm_phantom_kind kind, int n, vm_volume *v, vm_mesh *m) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh_init(m, VM_TET4);
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, v, NULL, &err), &err);
    if (!v->data) return 0;
    vm_status s = vm_mesh_volume(v, &o, m, NULL, &err);
    CHECK_OK(s, &err);
    return s == VM_OK;
}

static int copy_mesh(const vm_mesh *a, vm_mesh *b) {
    vm_error err;
    vm_mesh_init(b, VM_TET4);
    if (vm_mesh_reserve(b, a->npoints, a->ncells, &err)) return 0;
    memcpy(b->points, a->points, 3 * a->npoints * sizeof(double));
    memcpy(b->cells, a->cells, 4 * a->ncells * sizeof(vm_index));
    memcpy(b->region, a->region, a->ncells * sizeof(int32_t));
    b->npoints = a->npoints;
    b->ncells = a->ncells;
    return 1;
}

static int same_mesh(const vm_mesh *a, const vm_mesh *b) {
    return a->npoints == b->npoints && a->ncells == b->ncells &&
           memcmp(a->points, b->points, 3 * a->npoints * sizeof(double)) == 0 &&
           memcmp(a->cells, b->cells, 4 * a->ncells * sizeof(vm_index)) == 0;
}

static void improve(vm_mesh *m, const vm_volume *v, const unsigned char *frozen,
                    vm_improve_report *r) {
    vm_error err;
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.frozen = frozen;
    o.parts = 1; /* frozen flags run the one pass: without flags too, to compare */
    CHECK_OK(vm_mesh_improve(m, v, &o, r, &err), &err);
}

static void everyTetFrozenLeavesTheMeshAsItWas(void) {
    vm_volume v;
    vm_mesh m, a, b;
    if (!mesh_phantom(VM_PHANTOM_SPHERE, 24, &v, &m)) return;
    unsigned char *all = malloc(m.ncells), *none = calloc(m.ncells, 1);
    CHECK(all && none && copy_mesh(&m, &a) && copy_mesh(&m, &b));
    if (all && none) {
        memset(all, 1, m.ncells);
        vm_improve_report r;
        improve(&a, &v, all, &r);
        CHECK_MSG(same_mesh(&a, &m) && r.moves == 0 && r.collapses == 0 && r.flips23 == 0,
                  "all frozen: %zu -> %zu tets, %zu moves, %zu collapses", m.ncells, a.ncells,
                  r.moves, r.collapses);
        improve(&b, &v, NULL, &r); /* the pass has work here */
        CHECK_MSG(!same_mesh(&b, &m) && r.moves + r.collapses > 0, "no flags: nothing done");
        vm_mesh_free(&a);
        CHECK(copy_mesh(&m, &a));
        improve(&a, &v, none, NULL);
        CHECK_MSG(same_mesh(&a, &b), "zero flags differ from no flags");
    }
    free(all);
    free(none);
    vm_mesh_free(&a);
    vm_mesh_free(&b);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Tets below 10 degrees in region 1 ([0]) and 2 ([1]). */
static void count_slivers(const vm_mesh *m, size_t n[2]) {
    n[0] = n[1] = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + (size_t)k], sizeof p[k]);
        if (vm_tet_min_dihedral((const double(*)[3])p) < 10) n[m->region[t] == 2]++;
    }
}

static void halfFrozenImprovesTheOtherHalf(void) {
    vm_volume v;
    vm_mesh m;
    /* (the genus-3 solid: the sphere comes out of the mesher with no tet under 10 degrees) */
    if (!mesh_phantom(VM_PHANTOM_GENUS3, 32, &v, &m)) return;
    double mid = 0.5 * (double)(v.dims[2] - 1);
    unsigned char *fz = malloc(m.ncells);
    CHECK(fz != NULL);
    if (fz) {
        for (size_t t = 0; t < m.ncells; t++) {
            double z = 0;
            for (int k = 0; k < 4; k++)
                z += m.points[3 * (size_t)m.cells[4 * t + (size_t)k] + 2];
            fz[t] = z < 4 * mid;
            m.region[t] = 1 + fz[t]; /* two materials: the frozen half stays as it is */
        }
        size_t before[2], after[2];
        count_slivers(&m, before);
        vm_error err;
        vm_improve_options o;
        vm_improve_options_default(&o);
        o.frozen = fz;
        o.max_interface_move = 0;
        vm_improve_report r;
        CHECK_OK(vm_mesh_improve(&m, &v, &o, &r, &err), &err);
        count_slivers(&m, after);
        /* the upper half is improved (but for a few tets held by the fixed vertices of the
         * interface); the lower one keeps its raw tets */
        CHECK_MSG(before[0] > 20 && after[0] * 10 <= before[0] && after[1] * 2 > before[1],
                  "tets below 10 degrees, upper half %zu -> %zu, lower half %zu -> %zu",
                  before[0], after[0], before[1], after[1]);
        vm_mesh_report c;
        CHECK_OK(vm_mesh_check(&m, &c, &err), &err);
        CHECK(c.inverted == 0 && c.overshared_faces == 0 && c.boundary_closed &&
              c.boundary_euler == -4); /* genus 3 */
    }
    free(fz);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(everyTetFrozenLeavesTheMeshAsItWas), T(halfFrozenImprovesTheOtherHalf))
