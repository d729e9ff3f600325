/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_surface_formats.c — STL, OFF, PLY and OBJ writers and readers: exact round
 * trips for triangle and quad surfaces (regions where the format holds them), a volume mesh
 * written as its boundary, other writers' layouts, malformed files. */
#include "mesh_fixtures.h"

static vm_mesh_write_options ascii_opt(int ascii) {
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.ascii = ascii;
    return o;
}

static void ply_obj_off_round_trips_are_exact(void) {
    for (int q = 0; q < 2; q++) {
        vm_mesh s;
        fx_surface(&s, q);
        vm_mesh_write_options b = ascii_opt(0), a = ascii_opt(1);
        fx_round_trip(&s, q ? "rt_quad_b.ply" : "rt_tri_b.ply", &b, vm_mesh_read_ply, 1);
        fx_round_trip(&s, q ? "rt_quad_a.ply" : "rt_tri_a.ply", &a, vm_mesh_read_ply, 1);
        fx_round_trip(&s, q ? "rt_quad.obj" : "rt_tri.obj", NULL, vm_mesh_read_obj, 1);
        fx_round_trip(&s, q ? "rt_quad.off" : "rt_tri.off", NULL, vm_mesh_read_off, 0);
        vm_mesh_free(&s);
    }
}

/* Faces ordered by region (stable), points in first-use order, coordinates as floats. */
static void stl_shape(vm_mesh *s, int to_float, int sort_regions) {
    if (to_float)
        for (size_t i = 0; i < 3 * s->npoints; i++)
            s->points[i] = (double)(float)s->points[i];
    for (size_t c = 0; c < s->ncells; c++)
        if (s->region[c] < 0) s->region[c] = -s->region[c];
    if (sort_regions)
        for (size_t i = 1; i < s->ncells; i++)
            for (size_t j = i; j > 0 && s->region[j - 1] > s->region[j]; j--) {
                int32_t r = s->region[j];
                s->region[j] = s->region[j - 1];
                s->region[j - 1] = r;
                for (int k = 0; k < 3; k++) {
                    vm_index t = s->cells[3 * j + (size_t)k];
                    s->cells[3 * j + (size_t)k] = s->cells[3 * (j - 1) + (size_t)k];
                    s->cells[3 * (j - 1) + (size_t)k] = t;
                }
            }
    fx_first_use_order(s);
}

static void stl_round_trips_are_exact(void) {
    vm_mesh s;
    fx_surface(&s, 0);
    stl_shape(&s, 1, 0);
    vm_mesh_write_options b = ascii_opt(0), a = ascii_opt(1);
    fx_round_trip(&s, "rt_tri_b.stl", &b, vm_mesh_read_stl, 1);
    vm_mesh_free(&s);
    fx_surface(&s, 0);
    stl_shape(&s, 0, 1); /* ASCII keeps doubles; faces are grouped by region */
    fx_round_trip(&s, "rt_tri_a.stl", &a, vm_mesh_read_stl, 1);
    vm_mesh_free(&s);
}

static void volume_meshes_are_written_as_their_boundary(void) {
    static const char *const names[4] = {"vol.ply", "vol.obj", "vol.off", "vol.stl"};
    static const fx_reader readers[4] = {vm_mesh_read_ply, vm_mesh_read_obj, vm_mesh_read_off,
                                         vm_mesh_read_stl};
    for (int hex = 0; hex < 2; hex++) {
        vm_mesh m, b;
        fx_block(&m, 2, hex);
        CHECK(vm_mesh_boundary(&m, &b, NULL) == VM_OK);
        for (int f = 0; f < 4; f++) {
            vm_mesh back;
            vm_error err;
            CHECK_OK(vm_mesh_write(vm_test_tmp(names[f]), &m, &err), &err);
            CHECK_OK(readers[f](vm_test_tmp(names[f]), &back, &err), &err);
            if (f < 3)
                CHECK(fx_same_mesh(&b, &back, f < 2));
            else /* STL: quads split, points merged */
                CHECK(back.ncells == b.ncells * (hex ? 2 : 1) && back.npoints == b.npoints);
            vm_mesh_free(&back);
        }
        vm_mesh_free(&m);
        vm_mesh_free(&b);
    }
}

static void readers_take_other_writers_layouts(void) {
    vm_mesh m;
    vm_error err;
    /* OBJ with normals, texture coordinates, slashes, negative indices and a pentagon */
    const char *obj = "mtllib a.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\n"
                      "vn 0 0 1\nvt 0 0\ng REGION_4\nusemtl m\ns off\nf 1/1/1 2/1/1 3//1\n"
                      "f -5 -2 -1 4 3\n";
    vm_test_write_file(vm_test_tmp("other.obj"), obj, strlen(obj));
    CHECK_OK(vm_mesh_read_obj(vm_test_tmp("other.obj"), &m, &err), &err);
    CHECK(m.kind == VM_TRI3 && m.npoints == 5 && m.ncells == 4 && m.ncells && m.region[3] == 4);
    vm_mesh_free(&m);
    /* OFF with comments, counts on the OFF line, a face color */
    const char *off = "OFF 4 1 0\n# c\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n";
    vm_test_write_file(vm_test_tmp("other.off"), off, strlen(off));
    CHECK_OK(vm_mesh_read_off(vm_test_tmp("other.off"), &m, &err), &err);
    CHECK(m.kind == VM_QUAD4 && m.ncells == 1);
    vm_mesh_free(&m);
    /* PLY big endian float with an extra vertex property and an edge element */
    unsigned char ply[512];
    const char *h = "ply\nformat binary_big_endian 1.0\ncomment x\nelement vertex 3\n"
                    "property float x\nproperty float y\nproperty float z\nproperty uchar red\n"
                    "element face 1\nproperty list uchar uint vertex_index\nelement edge 1\n"
                    "property int vertex1\nproperty int vertex2\nend_header\n";
    size_t n = strlen(h);
    memcpy(ply, h, n);
    static const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    for (int i = 0; i < 3; i++) {
        for (int d = 0; d < 3; d++) {
            uint32_t u;
            memcpy(&u, &xyz[3 * i + d], 4);
            for (int b = 0; b < 4; b++)
                ply[n++] = (unsigned char)(u >> (24 - 8 * b));
        }
        ply[n++] = 200;
    }
    ply[n++] = 3;
    for (int i = 0; i < 3; i++) {
        ply[n++] = 0, ply[n++] = 0, ply[n++] = 0, ply[n++] = (unsigned char)i;
    }
    for (int i = 0; i < 8; i++)
        ply[n++] = 0;
    vm_test_write_file(vm_test_tmp("other.ply"), ply, n);
    CHECK_OK(vm_mesh_read_ply(vm_test_tmp("other.ply"), &m, &err), &err);
    CHECK(m.kind == VM_TRI3 && m.npoints == 3 && m.ncells == 1 && m.npoints == 3 &&
          m.points[3] == 1.0);
    vm_mesh_free(&m);
    /* binary STL whose header starts with "solid" */
    unsigned char stl[84 + 50];
    memset(stl, 0, sizeof stl);
    memcpy(stl, "solid but binary", 16);
    stl[80] = 1;
    float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    memcpy(stl + 84 + 12, v, sizeof v); /* little-endian host assumed by this fixture */
    vm_test_write_file(vm_test_tmp("other.stl"), stl, sizeof stl);
    CHECK_OK(vm_mesh_read_stl(vm_test_tmp("other.stl"), &m, &err), &err);
    CHECK(m.ncells == 1 && m.npoints == 3);
    vm_mesh_free(&m);
}

static void readers_refuse_malformed_files(void) {
    static const char *const bad_stl[] = {
        "", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n",
        "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 nan\n",
        "solid x\nsolid y\n", "solid x\nbanana\n"};
    for (size_t i = 0; i < sizeof bad_stl / sizeof bad_stl[0]; i++)
        fx_expect_error(vm_mesh_read_stl, "bad.stl", bad_stl[i], strlen(bad_stl[i]));
    unsigned char lying[100];
    memset(lying, 0, sizeof lying);
    lying[80] = 200; /* 200 triangles announced, 16 bytes present */
    fx_expect_error(vm_mesh_read_stl, "bad.stl", (const char *)lying, sizeof lying);
    static const char *const bad_off[] = {
        "", "COFF\n1 0 0\n0 0 0 1 1 1 1\n", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "OFF\n300000000 1 0\n0 0 0\n",
        "OFF\n3 1 0\n0 0 0\n1 0 0\n"};
    for (size_t i = 0; i < sizeof bad_off / sizeof bad_off[0]; i++)
        fx_expect_error(vm_mesh_read_off, "bad.off", bad_off[i], strlen(bad_off[i]));
    static const char *const bad_ply[] = {
        "", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
        "ply\nformat ascii 2.0x\nend_header\n",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n3 0 0 1\n",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        "0 0 0\n200 0 0 0\n",
        ("ply\nformat binary_little_endian 1.0\nelement vertex 9999999\nproperty float x\n"
         "property float y\nproperty float z\nend_header\n"),
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n"};
    for (size_t i = 0; i < sizeof bad_ply / sizeof bad_ply[0]; i++)
        fx_expect_error(vm_mesh_read_ply, "bad.ply", bad_ply[i], strlen(bad_ply[i]));
    static const char *const bad_obj[] = {"", "v 0 0\n", "v 0 0 0\nf 1 2 3\n",
                                          "v 0 0 0\nv 1 0 0\nf 1 2\n", "f -1 -2 -3\n",
                                          "v 0 0 0\nf 0 1 1\n"};
    for (size_t i = 0; i < sizeof bad_obj / sizeof bad_obj[0]; i++)
        fx_expect_error(vm_mesh_read_obj, "bad.obj", bad_obj[i], strlen(bad_obj[i]));
}

static void truncated_files_never_crash(void) {
    vm_mesh s;
    fx_surface(&s, 0);
    vm_mesh_write_options a = ascii_opt(1);
    CHECK_OK(vm_mesh_write(vm_test_tmp("tr_src.stl"), &s, NULL), NULL);
    CHECK_OK(vm_mesh_write_as(vm_test_tmp("tr_src_a.stl"), &s, &a, NULL), NULL);
    CHECK_OK(vm_mesh_write(vm_test_tmp("tr_src.ply"), &s, NULL), NULL);
    CHECK_OK(vm_mesh_write_as(vm_test_tmp("tr_src_a.ply"), &s, &a, NULL), NULL);
    CHECK_OK(vm_mesh_write(vm_test_tmp("tr_src.off"), &s, NULL), NULL);
    CHECK_OK(vm_mesh_write(vm_test_tmp("tr_src.obj"), &s, NULL), NULL);
    vm_mesh_free(&s);
    fx_truncations(vm_mesh_read_stl, "tr_src.stl", "tr.stl", 13);
    fx_truncations(vm_mesh_read_stl, "tr_src_a.stl", "tr.stl", 97);
    fx_truncations(vm_mesh_read_ply, "tr_src.ply", "tr.ply", 11);
    fx_truncations(vm_mesh_read_ply, "tr_src_a.ply", "tr.ply", 17);
    fx_truncations(vm_mesh_read_off, "tr_src.off", "tr.off", 17);
    fx_truncations(vm_mesh_read_obj, "tr_src.obj", "tr.obj", 17);
    fx_write_fails_cleanly("stl");
    fx_write_fails_cleanly("ply");
    fx_write_fails_cleanly("off");
    fx_write_fails_cleanly("obj");
}

int main(void) {
    static const vm_test_case cases[] = {
        {"ply_obj_off_round_trips_are_exact", ply_obj_off_round_trips_are_exact},
        {"stl_round_trips_are_exact", stl_round_trips_are_exact},
        {"volume_meshes_are_written_as_their_boundary",
         volume_meshes_are_written_as_their_boundary},
        {"readers_take_other_writers_layouts", readers_take_other_writers_layouts},
        {"readers_refuse_malformed_files", readers_refuse_malformed_files},
        {"truncated_files_never_crash", truncated_files_never_crash},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
