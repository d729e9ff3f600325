/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/mesh_fixtures.h — small hand-made meshes and checks shared by the mesh-format
 * tests (tests/io/test_inp.c, test_msh.c, test_medit.c, test_vtk_mesh.c,
 * test_surface_formats.c): exact round trips, malformed inputs, truncations. */
#ifndef VM_TEST_MESH_FIXTURES_H
#define VM_TEST_MESH_FIXTURES_H

#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "test.h"

/* An n x n x n block of cubes with awkward coordinates (not short decimals, one negative
 * zero), as hexes or 6 Kuhn tets per cube; region of a cube = a value from a table with
 * negative and zero ids. All elements have positive volume in VTK order. */
static void fx_block(vm_mesh *m, int n, int as_hex) {
    vm_mesh_init(m, as_hex ? VM_HEX8 : VM_TET4);
    int np1 = n + 1;
    for (int z = 0; z <= n; z++)
        for (int y = 0; y <= n; y++)
            for (int x = 0; x <= n; x++) {
                double p[3] = {x / 3.0 + 0.1, y * 0.7 - 1e-3 / 7.0, z * 1.1 + 100.0 / 3.0};
                if (x == 0 && y == 0 && z == 0) p[0] = -0.0;
                vm_mesh_add_point(m, p, NULL);
            }
    static const int32_t reg[8] = {1, 2, 2, 7, -3, 0, 1, 2};
    static const int off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    int q = 0;
    for (int z = 0; z < n; z++)
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++, q++) {
                vm_index c[8];
                for (int v = 0; v < 8; v++)
                    c[v] = (vm_index)((x + off[v][0]) + np1 * ((y + off[v][1]) + np1 * (z + off[v][2])));
                int32_t r = reg[q % 8];
                if (as_hex) {
                    vm_mesh_add_cell(m, c, r, NULL);
                    continue;
                }
                static const int path[6][2] = {{1, 2}, {1, 5}, {3, 2}, {3, 7}, {4, 5}, {4, 7}};
                static const int odd[6] = {0, 1, 1, 0, 0, 1};
                for (int t = 0; t < 6; t++) {
                    vm_index k[4] = {c[0], c[path[t][odd[t]]], c[path[t][1 - odd[t]]], c[6]};
                    vm_mesh_add_cell(m, k, r, NULL);
                }
            }
}

/* The boundary of a block (tri3 or quad4, outward, regions of the cells). */
static void fx_surface(vm_mesh *s, int as_quads) {
    vm_mesh b;
    fx_block(&b, 2, as_quads);
    CHECK(vm_mesh_boundary(&b, s, NULL) == VM_OK);
    vm_mesh_free(&b);
}

/* Renumbers the points of s in order of first use by its faces (what STL readers give). */
static void fx_first_use_order(vm_mesh *s) {
    size_t nn = (size_t)vm_cell_nodes(s->kind);
    vm_index *map = malloc(s->npoints * sizeof *map);
    double *pts = malloc(3 * s->npoints * sizeof *pts);
    for (size_t i = 0; i < s->npoints; i++)
        map[i] = -1;
    size_t k = 0;
    for (size_t i = 0; i < s->ncells * nn; i++) {
        vm_index v = s->cells[i];
        if (map[v] < 0) {
            map[v] = (vm_index)k;
            memcpy(pts + 3 * k, s->points + 3 * (size_t)v, 3 * sizeof(double));
            k++;
        }
        s->cells[i] = map[v];
    }
    memcpy(s->points, pts, 3 * k * sizeof(double));
    s->npoints = k;
    free(map);
    free(pts);
}

/* 1 when kinds, counts, coordinates (bit for bit when tol is 0, else within tol relative to
 * max(1, |x|)), connectivity and regions are equal. */
static int fx_same_mesh_within(const vm_mesh *a, const vm_mesh *b, int check_regions,
                               double tol) {
    size_t nn = (size_t)vm_cell_nodes(a->kind);
    if (a->kind != b->kind || a->npoints != b->npoints || a->ncells != b->ncells) {
        fprintf(stderr, "  kind %d/%d points %zu/%zu cells %zu/%zu\n", (int)a->kind,
                (int)b->kind, a->npoints, b->npoints, a->ncells, b->ncells);
        return 0;
    }
    if (tol == 0 && a->npoints &&
        memcmp(a->points, b->points, 3 * a->npoints * sizeof(double)) != 0) {
        fprintf(stderr, "  coordinates differ\n");
        return 0;
    }
    for (size_t i = 0; tol > 0 && i < 3 * a->npoints; i++) {
        double x = a->points[i], d = x - b->points[i], s = x < 0 ? -x : x;
        if ((d < 0 ? -d : d) > tol * (s > 1 ? s : 1)) {
            fprintf(stderr, "  coordinate %zu: %.17g against %.17g\n", i, x, b->points[i]);
            return 0;
        }
    }
    if (a->ncells && memcmp(a->cells, b->cells, nn * a->ncells * sizeof(vm_index)) != 0) {
        fprintf(stderr, "  connectivity differs\n");
        return 0;
    }
    if (check_regions && a->ncells &&
        memcmp(a->region, b->region, a->ncells * sizeof(int32_t)) != 0) {
        fprintf(stderr, "  regions differ\n");
        return 0;
    }
    return 1;
}

/* 1 when the meshes are equal, coordinates bit for bit. */
static int fx_same_mesh(const vm_mesh *a, const vm_mesh *b, int check_regions) {
    return fx_same_mesh_within(a, b, check_regions, 0);
}

/* Relative error of a coordinate written with 15 significant digits (decks whose fields hold
 * 20 characters fall back to them when the exact text is wider). */
#define FX_DIGITS15_TOL 1e-14

typedef vm_status (*fx_reader)(const char *path, vm_mesh *m, vm_error *err);

/* Writes m with opt to name, reads it back with read and compares (coordinates within tol,
 * bit for bit when 0). */
static void fx_round_trip_within(const vm_mesh *m, const char *name,
                                 const vm_mesh_write_options *opt, fx_reader read,
                                 int check_regions, double tol) {
    vm_error err;
    const char *path = vm_test_tmp(name);
    CHECK_OK(vm_mesh_write_as(path, m, opt, &err), &err);
    vm_mesh back;
    vm_status st = read(path, &back, &err);
    CHECK_OK(st, &err);
    if (st) return;
    CHECK_MSG(fx_same_mesh_within(m, &back, check_regions, tol), "%s: round trip differs",
              name);
    vm_mesh_free(&back);
    /* the temp file was renamed away */
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    CHECK(!vm_test_exists(tmp));
}

/* Writes m with opt to name, reads it back with read and compares exactly. */
static void fx_round_trip(const vm_mesh *m, const char *name, const vm_mesh_write_options *opt,
                          fx_reader read, int check_regions) {
    fx_round_trip_within(m, name, opt, read, check_regions, 0);
}

/* A malformed file must give an error whose one-line message starts with the path. */
static void fx_expect_error(fx_reader read, const char *name, const char *content, size_t len) {
    const char *path = vm_test_tmp(name);
    CHECK(vm_test_write_file(path, content, len) == 0);
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = read(path, &m, &err);
    CHECK_MSG(st != VM_OK, "%s: malformed input was accepted: %.60s", name, content);
    if (st == VM_OK) {
        vm_mesh_free(&m);
        return;
    }
    CHECK_MSG(strncmp(err.message, path, strlen(path)) == 0 && strchr(err.message, '\n') == NULL,
              "message \"%s\" does not start with the path or spans lines", err.message);
    CHECK(m.npoints == 0 && m.ncells == 0);
}

/* Every prefix (in steps) of a valid file is read without crashing; a success must give a
 * valid mesh (node indices in range). */
static void fx_truncations(fx_reader read, const char *src_name, const char *name, size_t step) {
    unsigned char *buf = NULL;
    size_t len = 0;
    FILE *fp = fopen(vm_test_tmp(src_name), "rb");
    CHECK(fp != NULL);
    if (!fp) return;
    fseek(fp, 0, SEEK_END);
    len = (size_t)ftell(fp);
    fseek(fp, 0, SEEK_SET);
    buf = malloc(len + 1);
    CHECK(fread(buf, 1, len, fp) == len);
    fclose(fp);
    const char *path = vm_test_tmp(name);
    for (size_t cut = 0; cut < len; cut += step) {
        vm_test_write_file(path, buf, cut);
        vm_mesh m;
        vm_error err;
        if (read(path, &m, &err) == VM_OK) {
            size_t nn = (size_t)vm_cell_nodes(m.kind);
            for (size_t i = 0; i < m.ncells * nn; i++)
                CHECK(m.cells[i] >= 0 && (size_t)m.cells[i] < m.npoints);
            vm_mesh_free(&m);
        } else {
            CHECK(strchr(err.message, '\n') == NULL);
        }
    }
    free(buf);
}

/* Writing into a missing folder fails cleanly. */
static void fx_write_fails_cleanly(const char *ext) {
    vm_mesh m;
    fx_block(&m, 1, 0);
    char path[256];
    snprintf(path, sizeof path, "%s/no/such/folder/x.%s", vm_test_tmp(""), ext);
    vm_error err;
    CHECK(vm_mesh_write(path, &m, &err) == VM_ERR_IO);
    CHECK(strstr(err.message, "x.") != NULL);
    vm_mesh_free(&m);
}

#endif
