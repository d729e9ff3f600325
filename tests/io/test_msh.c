/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_msh.c — Gmsh MSH 4.1 and 2.2 writer and reader: exact round trips for every
 * kind, physical groups named per region, files in gmsh's own layouts (points and lines
 * skipped, sparse tags, several node blocks), malformed files refused. (test_gmsh.sh has gmsh
 * itself read our files.) */
#include "mesh_fixtures.h"

static vm_mesh_write_options fmt(vm_mesh_format f) {
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.format = f;
    return o;
}

static void msh_round_trip_is_exact_in_both_versions(void) {
    static const char *const names[2][4] = {
        {"rt_tet.msh", "rt_hex.msh", "rt_tri.msh", "rt_quad.msh"},
        {"rt_tet.msh2", "rt_hex.msh2", "rt_tri.msh2", "rt_quad.msh2"}};
    for (int v = 0; v < 2; v++) {
        vm_mesh_write_options o = fmt(v ? VM_MESH_MSH2 : VM_MESH_MSH);
        for (int k = 0; k < 4; k++) {
            vm_mesh m;
            if (k < 2)
                fx_block(&m, 2, k);
            else
                fx_surface(&m, k == 3);
            fx_round_trip(&m, names[v][k], &o, vm_mesh_read_msh, 1);
            vm_mesh_free(&m);
        }
    }
}

static void msh_physical_tags_are_the_regions_when_positive(void) {
    vm_mesh m;
    fx_block(&m, 1, 1);
    m.region[0] = 42;
    const char *path = vm_test_tmp("phys.msh");
    CHECK_OK(vm_mesh_write(path, &m, NULL), NULL);
    FILE *fp = fopen(path, "rb");
    char buf[4096];
    size_t n = fread(buf, 1, sizeof buf - 1, fp);
    buf[n] = 0;
    fclose(fp);
    CHECK(strstr(buf, "$PhysicalNames\n1\n3 42 \"REGION_42\"\n") != NULL);
    CHECK(strstr(buf, "\n3 42 5 1\n1 ") != NULL);
    vm_mesh_free(&m);
}

static void msh_reader_takes_gmsh_layouts(void) {
    /* 4.1 as gmsh writes it: point and curve entities, two node blocks, parametric nodes,
     * a line element block, sparse tags, a physical without a REGION_ name. */
    const char *v41 =
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 7 \"bone\"\n$EndPhysicalNames\n"
        "$Entities\n1 1 0 1\n1 0 0 0 0\n1 0 0 0 1 0 0 0 2 1 -1\n"
        "5 0 0 0 1 1 1 1 7 0\n$EndEntities\n"
        "$Nodes\n2 5 1 40\n1 1 1 1\n40\n0 0 0 0.25\n3 5 0 4\n10\n20\n30\n11\n1 0 0\n0 1 0\n0 0 1\n"
        "1 1 1\n$EndNodes\n"
        "$Elements\n2 3 1 9\n1 1 1 1\n9 40 10\n3 5 4 2\n5 40 10 20 30\n3 10 20 30 11\n"
        "$EndElements\n$NodeData\n1\n\"x\"\n$EndNodeData\n";
    const char *path = vm_test_tmp("gmsh41.msh");
    vm_test_write_file(path, v41, strlen(v41));
    vm_mesh m;
    vm_error err;
    CHECK_OK(vm_mesh_read_msh(path, &m, &err), &err);
    CHECK(m.kind == VM_TET4 && m.npoints == 5 && m.ncells == 2);
    if (m.ncells == 2) {
        CHECK(m.cells[0] == 1 && m.cells[1] == 2 && m.cells[4] == 0 && m.region[0] == 7);
    }
    vm_mesh_free(&m);
    const char *v22 =
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
        "5 0 0 1\n$EndNodes\n$Elements\n3\n1 15 2 0 1 1\n2 2 2 3 4 1 2 3\n3 4 3 9 8 0 1 2 3 5\n"
        "$EndElements\n";
    path = vm_test_tmp("gmsh22.msh");
    vm_test_write_file(path, v22, strlen(v22));
    CHECK_OK(vm_mesh_read_msh(path, &m, &err), &err);
    CHECK(m.kind == VM_TET4 && m.ncells == 1 && m.ncells && m.region[0] == 9);
    vm_mesh_free(&m);
}

static void msh_reader_refuses_malformed_files(void) {
    static const char *const bad[] = {
        "",
        "hello",
        "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n",
        "$MeshFormat\n4.1 1 8\n$EndMeshFormat\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0\n$EndNodes\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n1\n"
        "1 4 0 1 1 1 2\n$EndElements\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n$Elements\n1\n"
        "1 6 0 1 1 1 1 1 1\n$EndElements\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n2\n1 0 0 0\n1 1 1 1\n$EndNodes\n$Elements\n"
        "1\n1 2 0 1 1 1\n$EndElements\n",
        "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n99999999999\n1 0 0 0\n$EndNodes\n",
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 3 1 3\n3 1 0 3\n1\n2\n3\n0 0 0\n"
        "$EndNodes\n",
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1 1 1\n3 1 0 1\n1\n0 0 0\n$EndNodes\n"
        "$Elements\n1 1 1 1\n2 1 4 1\n1 1 1 1 1\n$EndElements\n",
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n1\n3 1 REGION_1\n$EndPhysicalNames\n",
        "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Comments\nno end\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        fx_expect_error(vm_mesh_read_msh, "bad.msh", bad[i], strlen(bad[i]));
}

static void msh_truncated_files_never_crash(void) {
    vm_mesh m;
    fx_block(&m, 1, 0);
    CHECK_OK(vm_mesh_write(vm_test_tmp("trunc_src.msh"), &m, NULL), NULL);
    vm_mesh_write_options o = fmt(VM_MESH_MSH2);
    CHECK_OK(vm_mesh_write_as(vm_test_tmp("trunc_src.msh2"), &m, &o, NULL), NULL);
    vm_mesh_free(&m);
    fx_truncations(vm_mesh_read_msh, "trunc_src.msh", "trunc.msh", 5);
    fx_truncations(vm_mesh_read_msh, "trunc_src.msh2", "trunc.msh", 5);
    fx_write_fails_cleanly("msh");
}

int main(void) {
    static const vm_test_case cases[] = {
        {"msh_round_trip_is_exact_in_both_versions", msh_round_trip_is_exact_in_both_versions},
        {"msh_physical_tags_are_the_regions_when_positive",
         msh_physical_tags_are_the_regions_when_positive},
        {"msh_reader_takes_gmsh_layouts", msh_reader_takes_gmsh_layouts},
        {"msh_reader_refuses_malformed_files", msh_reader_refuses_malformed_files},
        {"msh_truncated_files_never_crash", msh_truncated_files_never_crash},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
