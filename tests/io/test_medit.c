/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_medit.c — MEDIT .mesh writer and reader: exact round trips for every kind
 * with references = regions, files with the extra sections Mmg/MEDIT write, malformed files. */
#include "mesh_fixtures.h"

static void medit_round_trip_is_exact_for_every_kind(void) {
    static const char *const names[4] = {"rt_tet.mesh", "rt_hex.mesh", "rt_tri.mesh",
                                         "rt_quad.mesh"};
    for (int k = 0; k < 4; k++) {
        vm_mesh m;
        if (k < 2)
            fx_block(&m, 2, k);
        else
            fx_surface(&m, k == 3);
        fx_round_trip(&m, names[k], NULL, vm_mesh_read_medit, 1);
        vm_mesh_free(&m);
    }
}

static void medit_reader_takes_mmg_layouts(void) {
    const char *s = "MeshVersionFormatted 1\n# comment\nDimension\n3\nVertices\n4\n0 0 0 1\n"
                    "1 0 0 1\n0 1 0 1\n0 0 1 1\nCorners\n1\n1\nEdges\n1\n1 2 5\n"
                    "Triangles\n1\n1 2 3 4\nRequiredVertices\n1\n2\nNormals\n1\n0 0 1\n"
                    "Tetrahedra\n1\n1 2 3 4 -8\nEnd\n";
    const char *path = vm_test_tmp("mmg.mesh");
    vm_test_write_file(path, s, strlen(s));
    vm_mesh m;
    vm_error err;
    CHECK_OK(vm_mesh_read_medit(path, &m, &err), &err);
    CHECK(m.kind == VM_TET4 && m.npoints == 4 && m.ncells == 1 && m.ncells && m.region[0] == -8);
    vm_mesh_free(&m);
}

static void medit_reader_refuses_malformed_files(void) {
    static const char *const bad[] = {
        "",
        "Vertices 1 0 0 0 0",
        "MeshVersionFormatted 2\nDimension 2\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n2\n0 0 0 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nTetrahedra\n1\n1 1 1 2 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nTetrahedra\n1\n1 1 1 0 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nPrisms\n1\n1 1 1 1 1 1 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n1\nx 0 0 0\nTriangles\n1\n1 1 1 0\n",
        "MeshVersionFormatted 2\nDimension 3\nVertices\n123456789012\n0 0 0 0\n",
        ("MeshVersionFormatted 2\nDimension 3\nVertices\n1\n0 0 0 0\nTriangles\n1\n1 1 1 "
         "99999999999\n"),
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        fx_expect_error(vm_mesh_read_medit, "bad.mesh", bad[i], strlen(bad[i]));
}

static void medit_truncated_files_never_crash(void) {
    vm_mesh m;
    fx_block(&m, 1, 1);
    CHECK_OK(vm_mesh_write(vm_test_tmp("trunc_src.mesh"), &m, NULL), NULL);
    vm_mesh_free(&m);
    fx_truncations(vm_mesh_read_medit, "trunc_src.mesh", "trunc.mesh", 3);
    fx_write_fails_cleanly("mesh");
}

int main(void) {
    static const vm_test_case cases[] = {
        {"medit_round_trip_is_exact_for_every_kind", medit_round_trip_is_exact_for_every_kind},
        {"medit_reader_takes_mmg_layouts", medit_reader_takes_mmg_layouts},
        {"medit_reader_refuses_malformed_files", medit_reader_refuses_malformed_files},
        {"medit_truncated_files_never_crash", medit_truncated_files_never_crash},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
