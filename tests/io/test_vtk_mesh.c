/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_vtk_mesh.c — legacy VTK UNSTRUCTURED_GRID writer and reader: exact round
 * trips (ASCII and binary, with point and cell fields), the 5.1 OFFSETS/CONNECTIVITY layout
 * VTK 9 writes, malformed files. */
#include "mesh_fixtures.h"

static void add_fields(vm_mesh *m) {
    double *p = malloc(2 * m->npoints * sizeof *p), *c = malloc(m->ncells * sizeof *c);
    for (size_t i = 0; i < m->npoints; i++) {
        p[2 * i] = m->points[3 * i] / 7.0;
        p[2 * i + 1] = -(double)i;
    }
    for (size_t i = 0; i < m->ncells; i++)
        c[i] = 1.0 / (double)(i + 3);
    vm_mesh_set_field(m, 0, "temperature", 2, p, NULL);
    vm_mesh_set_field(m, 1, "quality", 1, c, NULL);
    free(p);
    free(c);
}

static void vtk_round_trip_is_exact_ascii_and_binary(void) {
    static const char *const names[2][4] = {
        {"rt_tet_b.vtk", "rt_hex_b.vtk", "rt_tri_b.vtk", "rt_quad_b.vtk"},
        {"rt_tet_a.vtk", "rt_hex_a.vtk", "rt_tri_a.vtk", "rt_quad_a.vtk"}};
    for (int a = 0; a < 2; a++) {
        vm_mesh_write_options o;
        vm_mesh_write_options_init(&o);
        o.ascii = a;
        for (int k = 0; k < 4; k++) {
            vm_mesh m;
            if (k < 2)
                fx_block(&m, 2, k);
            else
                fx_surface(&m, k == 3);
            add_fields(&m);
            fx_round_trip(&m, names[a][k], &o, vm_mesh_read_vtk, 1);
            vm_mesh back;
            vm_error err;
            CHECK_OK(vm_mesh_read_vtk(vm_test_tmp(names[a][k]), &back, &err), &err);
            const vm_field *f = vm_mesh_find_field(&back, 0, "temperature");
            const vm_field *q = vm_mesh_find_field(&back, 1, "quality");
            CHECK(f && f->ncomp == 2 &&
                  memcmp(f->data, m.point_fields[0].data, 2 * m.npoints * sizeof(double)) == 0);
            CHECK(q && q->ncomp == 1 &&
                  memcmp(q->data, m.cell_fields[0].data, m.ncells * sizeof(double)) == 0);
            vm_mesh_free(&back);
            vm_mesh_free(&m);
        }
    }
}

static void vtk_reader_takes_the_version_5_layout(void) {
    const char *s = "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\n"
                    "POINTS 5 float\n0 0 0 1 0 0 0 1 0\n0 0 1 9 9 9\n"
                    "METADATA\nINFORMATION 0\n\n"
                    "CELLS 3 5\nOFFSETS vtktypeint64\n0 1 5\nCONNECTIVITY vtktypeint64\n4\n0 1 2 3\n"
                    "CELL_TYPES 2\n1\n10\n\nCELL_DATA 2\nFIELD FieldData 1\nregion 1 2 int\n5 6\n"
                    "POINT_DATA 5\nSCALARS s double 1\nLOOKUP_TABLE default\n1 2 3 4 5\n";
    const char *path = vm_test_tmp("v51.vtk");
    vm_test_write_file(path, s, strlen(s));
    vm_mesh m;
    vm_error err;
    CHECK_OK(vm_mesh_read_vtk(path, &m, &err), &err);
    CHECK(m.kind == VM_TET4 && m.npoints == 5 && m.ncells == 1 && m.ncells && m.region[0] == 6);
    CHECK(vm_mesh_find_field(&m, 0, "s") != NULL);
    vm_mesh_free(&m);
}

static void vtk_reader_refuses_malformed_files(void) {
    static const char *const bad[] = {
        "",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET STRUCTURED_POINTS\n",
        "# vtk DataFile Version 4.2\nx\nTEXT\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 2 double\n0 0 0\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 0 0\n"
        "CELLS 1 5\n4 0 0 0 1\nCELL_TYPES 1\n10\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 0 0\n"
        "CELLS 1 5\n9 0 0 0 0\nCELL_TYPES 1\n10\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 0 0\n"
        "CELLS 1 7\n6 0 0 0 0 0 0\nCELL_TYPES 1\n13\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 0 0\n"
        "CELLS 1 5\n4 0 0 0 0\nCELL_TYPES 2\n10 10\n",
        "# vtk DataFile Version 4.2\nx\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 100 double\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 double\n0 0 0\n"
        "CELLS 1 5\n4 0 0 0 0\nCELL_TYPES 1\n10\nCELL_DATA 1\nSCALARS region double\n0.5\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 bit\n0 0 0\n",
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1000000000000 "
        "double\n0 0 0\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        fx_expect_error(vm_mesh_read_vtk, "bad.vtk", bad[i], strlen(bad[i]));
}

static void vtk_truncated_files_never_crash(void) {
    vm_mesh m;
    fx_block(&m, 1, 0);
    add_fields(&m);
    CHECK_OK(vm_mesh_write(vm_test_tmp("trunc_src_b.vtk"), &m, NULL), NULL);
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.ascii = 1;
    CHECK_OK(vm_mesh_write_as(vm_test_tmp("trunc_src_a.vtk"), &m, &o, NULL), NULL);
    vm_mesh_free(&m);
    fx_truncations(vm_mesh_read_vtk, "trunc_src_b.vtk", "trunc.vtk", 3);
    fx_truncations(vm_mesh_read_vtk, "trunc_src_a.vtk", "trunc.vtk", 5);
    fx_write_fails_cleanly("vtk");
}

static void exodus_writes_or_says_it_was_not_built(void) {
    vm_mesh m;
    fx_block(&m, 2, 1);
    vm_error err;
    const char *path = vm_test_tmp("block.exo");
    vm_status st = vm_mesh_write(path, &m, &err);
    if (vm_exodus_available()) {
        CHECK_OK(st, &err);
        CHECK(vm_test_exists(path));
    } else {
        CHECK(st == VM_ERR_UNSUPPORTED && strstr(err.message, "without Exodus") != NULL);
    }
    vm_mesh_free(&m);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"vtk_round_trip_is_exact_ascii_and_binary", vtk_round_trip_is_exact_ascii_and_binary},
        {"vtk_reader_takes_the_version_5_layout", vtk_reader_takes_the_version_5_layout},
        {"vtk_reader_refuses_malformed_files", vtk_reader_refuses_malformed_files},
        {"vtk_truncated_files_never_crash", vtk_truncated_files_never_crash},
        {"exodus_writes_or_says_it_was_not_built", exodus_writes_or_says_it_was_not_built},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
