/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_vtu.c — VTU writer/reader: exact round trips, files in the encodings other
 * VTK writers use (built here by an independent little generator), malformed files, atomic
 * output. Also leaves vtu_judge_*.vtu in VM_TEST_TMP for tests/io/test_vtu_vtk.py. */
#define _POSIX_C_SOURCE 200809L
#include "test.h"
#include <dirent.h>
#include <stdarg.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>

/* --- meshes ------------------------------------------------------------------------------ */

/* Unit cubes at the given lattice positions (at most 63 a side), shifted by origin; hexes or
 * 6 Kuhn tets per cube. region = cube number; point field "temperature" = x+2y+3z; cell field
 * "vec" = (c, -c, 0.5c). */
static void build_cubes(vm_mesh *m, const int (*cubes)[3], int ncubes, int as_hex,
                        const double origin[3]) {
    vm_mesh_init(m, as_hex ? VM_HEX8 : VM_TET4);
    static vm_index id[64][64][64];
    memset(id, -1, sizeof id);
    static const int off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    for (int q = 0; q < ncubes; q++) {
        vm_index c[8];
        for (int v = 0; v < 8; v++) {
            int x = cubes[q][0] + off[v][0], y = cubes[q][1] + off[v][1],
                z = cubes[q][2] + off[v][2];
            if (id[z][y][x] < 0) {
                double p[3] = {origin[0] + x, origin[1] + y, origin[2] + z};
                id[z][y][x] = vm_mesh_add_point(m, p, NULL);
            }
            c[v] = id[z][y][x];
        }
        if (as_hex) {
            CHECK(vm_mesh_add_cell(m, c, q, NULL) == VM_OK);
            continue;
        }
        /* Kuhn tets (0, a, a+b, 6); odd axis orders get two nodes swapped. */
        static const int path[6][2] = {{1, 2}, {1, 5}, {3, 2}, {3, 7}, {4, 5}, {4, 7}};
        static const int odd[6] = {0, 1, 1, 0, 0, 1};
        for (int t = 0; t < 6; t++) {
            vm_index n[4] = {c[0], c[path[t][0]], c[path[t][1]], c[6]};
            if (odd[t]) {
                n[1] = c[path[t][1]];
                n[2] = c[path[t][0]];
            }
            CHECK(vm_mesh_add_cell(m, n, q, NULL) == VM_OK);
        }
    }
    double *pf = malloc(m->npoints * sizeof *pf), *cf = malloc(3 * m->ncells * sizeof *cf);
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        pf[i] = p[0] + 2 * p[1] + 3 * p[2];
    }
    for (size_t c = 0; c < m->ncells; c++) {
        cf[3 * c] = (double)c;
        cf[3 * c + 1] = -(double)c;
        cf[3 * c + 2] = 0.5 * (double)c;
    }
    CHECK(vm_mesh_set_field(m, 0, "temperature", 1, pf, NULL) == VM_OK);
    CHECK(vm_mesh_set_field(m, 1, "vec", 3, cf, NULL) == VM_OK);
    free(pf);
    free(cf);
}

/* The cubes of an n x n x n box, x fastest (malloc'd; n at most 63). */
static int (*box_cubes(int n))[3] {
    int(*c)[3] = malloc((size_t)n * (size_t)n * (size_t)n * sizeof *c);
    for (int q = 0; q < n * n * n; q++) {
        c[q][0] = q % n;
        c[q][1] = q / n % n;
        c[q][2] = q / (n * n);
    }
    return c;
}

/* The bytes of a file (malloc'd), or NULL; [out] *len. */
static unsigned char *file_bytes(const char *path, size_t *len) {
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *b = malloc(n > 0 ? (size_t)n : 1);
    *len = b ? fread(b, 1, (size_t)n, fp) : 0;
    fclose(fp);
    return b;
}

static const int ring_cubes[8][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {2, 1, 0},
                                     {2, 2, 0}, {1, 2, 0}, {0, 2, 0}, {0, 1, 0}};
static const int slab_cubes[6][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0},
                                     {0, 1, 0}, {1, 1, 0}, {2, 1, 0}};

/* A larger mesh with awkward coordinates (so arrays span several 32 KiB blocks). */
static void build_noisy(vm_mesh *m, size_t np, size_t nc) {
    vm_mesh_init(m, VM_TET4);
    uint64_t s = 88172645463325252ull;
    for (size_t i = 0; i < np; i++) {
        double p[3];
        for (int d = 0; d < 3; d++) {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            p[d] = ((double)(s >> 11) / 9007199254740992.0 - 0.5) * 1e3 / 3.0;
        }
        vm_mesh_add_point(m, p, NULL);
    }
    for (size_t c = 0; c < nc; c++) {
        vm_index n[4];
        for (int k = 0; k < 4; k++)
            n[k] = (vm_index)((c * 7 + (size_t)k * 13) % np);
        vm_mesh_add_cell(m, n, (int32_t)(c % 5) - 2, NULL);
    }
}

static int fields_equal(const vm_field *a, size_t na, const vm_field *b, size_t nb,
                        size_t count) {
    if (na != nb) return 0;
    for (size_t i = 0; i < na; i++) {
        if (strcmp(a[i].name, b[i].name) != 0 || a[i].ncomp != b[i].ncomp) return 0;
        if (count && memcmp(a[i].data, b[i].data, count * (size_t)a[i].ncomp * sizeof(double)))
            return 0;
    }
    return 1;
}

static int meshes_equal(const vm_mesh *a, const vm_mesh *b) {
    size_t nn = (size_t)vm_cell_nodes(a->kind);
    return a->kind == b->kind && a->npoints == b->npoints && a->ncells == b->ncells &&
           (!a->npoints ||
            memcmp(a->points, b->points, 3 * a->npoints * sizeof(double)) == 0) &&
           (!a->ncells || memcmp(a->cells, b->cells, nn * a->ncells * sizeof(vm_index)) == 0) &&
           (!a->ncells || memcmp(a->region, b->region, a->ncells * sizeof(int32_t)) == 0) &&
           fields_equal(a->point_fields, a->npoint_fields, b->point_fields, b->npoint_fields,
                        a->npoints) &&
           fields_equal(a->cell_fields, a->ncell_fields, b->cell_fields, b->ncell_fields,
                        a->ncells);
}

static void round_trip(const vm_mesh *m, const char *name, int compress) {
    vm_error eb, *err = &eb;
    vm_mesh back;
    const char *path = vm_test_tmp(name);
    CHECK_OK(vm_mesh_write_vtu(path, m, compress, err), err);
    CHECK_OK(vm_mesh_read_vtu(path, &back, err), err);
    CHECK_MSG(meshes_equal(m, &back), "%s (compress %d) differs after reading back", name,
              compress);
    vm_mesh_free(&back);
}

/* --- round trips ------------------------------------------------------------------------- */

static void tetsAndHexesRoundTripExactlyCompressedOrNot(void) {
    const double o[3] = {0.1, -2.25, 1e-7};
    vm_mesh t, h;
    build_cubes(&t, ring_cubes, 8, 0, o);
    build_cubes(&h, slab_cubes, 6, 1, o);
    for (int z = 0; z < 2; z++) {
        round_trip(&t, "rt_tets.vtu", z);
        round_trip(&h, "rt_hex.vtu", z);
    }
    vm_mesh_free(&t);
    vm_mesh_free(&h);
}

static void multiBlockArraysAndAwkwardDoublesRoundTripBitExact(void) {
    vm_mesh m;
    build_noisy(&m, 20000, 30000);
    m.points[0] = -0.0;
    m.points[1] = 1e-308;
    m.points[2] = 9.8765432109876543e29; /* coordinates stop at VM_COORD_MAX (issue 31) */
    double *f = malloc(m.npoints * 2 * sizeof *f);
    for (size_t i = 0; i < 2 * m.npoints; i++)
        f[i] = m.points[i] * 3.3;
    f[2] = 1.7976931348623157e308; /* fields are values, not geometry: any double */
    CHECK(vm_mesh_set_field(&m, 0, "two<comp>&\"x\"", 2, f, NULL) == VM_OK);
    free(f);
    round_trip(&m, "rt_big.vtu", 1);
    round_trip(&m, "rt_big_raw.vtu", 0);
    vm_mesh_free(&m);
}

/* A 30^3 box of Kuhn tets: its connectivity is 159 blocks of 32 KiB, compressed in groups of
 * 64 on the threads. Each level writes the same bytes on 1 and 2 threads, and reads back
 * exactly; vtu_judge_blocks.vtu is left for tests/io/test_vtu_vtk.py (VTK, meshio). */
static void multiBlockFilesAreTheSameBytesOnOneAndTwoThreads(void) {
    vm_error eb, *err = &eb;
    const int n = 30;
    int(*cubes)[3] = box_cubes(n);
    const double zero[3] = {0, 0, 0};
    vm_mesh m;
    build_cubes(&m, (const int(*)[3])cubes, n * n * n, 0, zero);
    free(cubes);
    CHECK(m.ncells * 4 * 8 > 2 * 64 * 32768);
    const int levels[3] = {VM_COMPRESS_FAST, VM_COMPRESS_BEST, VM_COMPRESS_NONE};
    int before = vm_threads();
    for (int l = 0; l < 3; l++) {
        unsigned char *b[2] = {NULL, NULL};
        size_t len[2] = {0, 0};
        for (int t = 0; t < 2; t++) {
            vm_set_threads(t + 1);
            const char *path = vm_test_tmp(t ? "blocks_t2.vtu" : "blocks_t1.vtu");
            CHECK_OK(vm_mesh_write_vtu(path, &m, levels[l], err), err);
            b[t] = file_bytes(path, &len[t]);
            vm_mesh back;
            CHECK_OK(vm_mesh_read_vtu(path, &back, err), err);
            CHECK_MSG(meshes_equal(&m, &back), "compress %d, %d threads: differs read back",
                      levels[l], t + 1);
            vm_mesh_free(&back);
        }
        CHECK(b[0] && b[1]);
        /* every index fits in 32 bits: connectivity and offsets are Int32 */
        if (b[0]) {
            const char *xml = (const char *)b[0];
            CHECK(strstr(xml, "type=\"Int32\" Name=\"connectivity\"") != NULL &&
                  strstr(xml, "type=\"Int32\" Name=\"offsets\"") != NULL);
        }
        CHECK_MSG(len[0] == len[1] && b[0] && b[1] && memcmp(b[0], b[1], len[0]) == 0,
                  "compress %d: 1 and 2 threads write different bytes (%zu, %zu)", levels[l],
                  len[0], len[1]);
        free(b[0]);
        free(b[1]);
    }
    CHECK_OK(vm_mesh_write_vtu(vm_test_tmp("vtu_judge_blocks.vtu"), &m, VM_COMPRESS_FAST, err),
             err);
    vm_set_threads(before);
    vm_mesh_free(&m);
}

/* compress is none, fast or best: anything else is refused before a file is made. */
static void compressLevelsAreNamedAndOthersRefused(void) {
    vm_error eb, *err = &eb;
    vm_compress c = VM_COMPRESS_NONE;
    CHECK(vm_compress_parse("fast", &c) && c == VM_COMPRESS_FAST);
    CHECK(vm_compress_parse("best", &c) && c == VM_COMPRESS_BEST);
    CHECK(vm_compress_parse("none", &c) && c == VM_COMPRESS_NONE);
    CHECK(!vm_compress_parse("9", &c) && !vm_compress_parse("FAST", &c) &&
          !vm_compress_parse("", &c));
    vm_mesh m;
    const double zero[3] = {0, 0, 0};
    build_cubes(&m, ring_cubes, 8, 0, zero);
    const char *path = vm_test_tmp("bad_level.vtu");
    remove(path);
    CHECK(vm_mesh_write_vtu(path, &m, 3, err) == VM_ERR_ARG);
    CHECK(strstr(err->message, "compress is 3") != NULL);
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    CHECK(o.compress == VM_COMPRESS_FAST);
    o.compress = -1;
    CHECK(vm_mesh_write_as(path, &m, &o, err) == VM_ERR_ARG);
    CHECK(vm_mesh_write_check(path, &o, err) == VM_ERR_ARG);
    CHECK(!vm_test_exists(path));
    vm_mesh_free(&m);
}

static void surfacesAndEmptyMeshesRoundTrip(void) {
    vm_mesh m;
    vm_mesh_init(&m, VM_TRI3);
    const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int i = 0; i < 4; i++)
        vm_mesh_add_point(&m, p[i], NULL);
    const vm_index tri[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
    for (int i = 0; i < 4; i++)
        vm_mesh_add_cell(&m, tri[i], 100 + i, NULL);
    round_trip(&m, "rt_tri.vtu", 1);
    round_trip(&m, "rt_tri.vtu", 0);
    vm_mesh_free(&m);
    vm_mesh_init(&m, VM_QUAD4);
    for (int i = 0; i < 4; i++)
        vm_mesh_add_point(&m, p[i], NULL);
    const vm_index quad[4] = {0, 1, 3, 2};
    vm_mesh_add_cell(&m, quad, -1, NULL);
    round_trip(&m, "rt_quad.vtu", 1);
    vm_mesh_free(&m);
    vm_mesh_init(&m, VM_TET4);
    round_trip(&m, "rt_empty.vtu", 1);
    round_trip(&m, "rt_empty.vtu", 0);
    vm_mesh_free(&m);
}

static void judgeFilesForVtkAreWritten(void) {
    /* Read by tests/io/test_vtu_vtk.py: keep these shapes in step with it. */
    vm_error eb, *err = &eb;
    vm_mesh t, h;
    const double zero[3] = {0, 0, 0}, shift[3] = {10, 20, 30};
    build_cubes(&t, ring_cubes, 8, 0, zero);
    build_cubes(&h, slab_cubes, 6, 1, shift);
    CHECK_OK(vm_mesh_write_vtu(vm_test_tmp("vtu_judge_tets.vtu"), &t, 1, err), err);
    CHECK_OK(vm_mesh_write_vtu(vm_test_tmp("vtu_judge_hex.vtu"), &h, 0, err), err);
    vm_mesh_free(&t);
    vm_mesh_free(&h);
}

/* --- files in other encodings ------------------------------------------------------------ */

typedef struct gen_opts {
    const char *format; /* "ascii", "binary", "appended-raw", "appended-base64" */
    int header64, compressed, big_endian, float32_points, int32_cells, split_base64;
    size_t block; /* compression block size */
} gen_opts;

typedef struct sbuf {
    char *p;
    size_t n, cap;
} sbuf;

static void sb_add(sbuf *b, const void *data, size_t n) {
    if (b->n + n + 1 > b->cap) {
        while (b->n + n + 1 > b->cap)
            b->cap = b->cap ? 2 * b->cap : 4096;
        b->p = realloc(b->p, b->cap);
    }
    memcpy(b->p + b->n, data, n);
    b->n += n;
    b->p[b->n] = 0;
}

static void sb_printf(sbuf *b, const char *fmt, ...) {
    char tmp[1024];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    sb_add(b, tmp, (size_t)n);
}

static void b64_encode(sbuf *out, const unsigned char *d, size_t n) {
    static const char al[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        unsigned v = (unsigned)d[i] << 16;
        if (i + 1 < n) v |= (unsigned)d[i + 1] << 8;
        if (i + 2 < n) v |= d[i + 2];
        char q[4] = {al[(v >> 18) & 63], al[(v >> 12) & 63],
                     i + 1 < n ? al[(v >> 6) & 63] : '=', i + 2 < n ? al[v & 63] : '='};
        sb_add(out, q, 4);
    }
}

/* Appends value v as an unsigned header integer in the file's byte order. */
static void put_uint(sbuf *b, uint64_t v, const gen_opts *o) {
    int nb = o->header64 ? 8 : 4;
    unsigned char t[8];
    for (int i = 0; i < nb; i++) {
        int shift = 8 * (o->big_endian ? nb - 1 - i : i);
        t[i] = (unsigned char)(v >> shift);
    }
    sb_add(b, t, (size_t)nb);
}

/* Payload of one array: header (+ compressed blocks) and data, in header/data parts. */
static void make_payload(const unsigned char *data, size_t n, size_t esize, const gen_opts *o,
                         sbuf *head, sbuf *body) {
    unsigned char *d = malloc(n ? n : 1);
    for (size_t i = 0; i < n; i++) /* host is little endian in this test */
        d[i] = o->big_endian ? data[(i / esize) * esize + esize - 1 - i % esize] : data[i];
    if (!o->compressed) {
        put_uint(head, n, o);
        sb_add(body, d, n);
    } else {
        size_t bs = o->block, nblocks = (n + bs - 1) / bs;
        put_uint(head, nblocks, o);
        put_uint(head, bs, o);
        put_uint(head, n % bs, o);
        for (size_t k = 0; k < nblocks; k++) {
            size_t len = n - k * bs < bs ? n - k * bs : bs;
            uLongf zl = compressBound(len);
            unsigned char *z = malloc(zl);
            compress2(z, &zl, d + k * bs, len, 6);
            put_uint(head, zl, o);
            sb_add(body, z, zl);
            free(z);
        }
    }
    free(d);
}

/* Two tets sharing a face: points 5, regions {7, -3}, point field f = 0.5*i. */
static char *generate_vtu(const gen_opts *o, size_t *len) {
    static const double pts[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    static const int64_t conn[8] = {0, 1, 2, 3, 1, 2, 3, 4};
    static const int64_t offs[2] = {4, 8};
    static const unsigned char types[2] = {10, 10};
    static const int32_t region[2] = {7, -3}, ints[2] = {1, 2};
    double f[5];
    for (int i = 0; i < 5; i++)
        f[i] = 0.5 * i;
    float p32[15];
    for (int i = 0; i < 15; i++)
        p32[i] = (float)pts[i / 3][i % 3];
    int32_t c32[8], o32[2] = {4, 8};
    for (int i = 0; i < 8; i++)
        c32[i] = (int32_t)conn[i];

    struct {
        const char *section, *name, *type;
        int ncomp;
        const void *data;
        size_t n, esize;
        const char *ascii;
    } arr[] = {
        {"PointData", "f", "Float64", 1, f, 5, 8, "0 0.5 1 1.5 2"},
        {"CellData", "region", "Int32", 1, region, 2, 4, "7 -3"},
        {"CellData", "ints", "Int32", 1, ints, 2, 4, "1 2"},
        {"Points", "Points", o->float32_points ? "Float32" : "Float64", 3,
         o->float32_points ? (const void *)p32 : (const void *)pts, 15,
         o->float32_points ? 4u : 8u, "0 0 0 1 0 0\n 0 1 0 0 0 1 1 1 1"},
        {"Cells", "connectivity", o->int32_cells ? "Int32" : "Int64", 1,
         o->int32_cells ? (const void *)c32 : (const void *)conn, 8, o->int32_cells ? 4u : 8u,
         "0 1 2 3 1 2 3 4"},
        {"Cells", "offsets", o->int32_cells ? "Int32" : "Int64", 1,
         o->int32_cells ? (const void *)o32 : (const void *)offs, 2, o->int32_cells ? 4u : 8u,
         "4 8"},
        {"Cells", "types", "UInt8", 1, types, 2, 1, "10 10"},
    };
    const int na = (int)(sizeof arr / sizeof arr[0]);
    sbuf x = {0, 0, 0}, app = {0, 0, 0};
    sb_printf(&x,
              "<?xml version=\"1.0\"?>\n<!-- made by test_vtu.c -->\n<VTKFile "
              "type=\"UnstructuredGrid\" version=\"%s\" byte_order=\"%s\"%s%s>\n",
              o->header64 ? "1.0" : "0.1", o->big_endian ? "BigEndian" : "LittleEndian",
              o->header64 ? " header_type=\"UInt64\"" : "",
              o->compressed ? " compressor=\"vtkZLibDataCompressor\"" : "");
    sb_printf(&x, "<UnstructuredGrid>\n<FieldData><DataArray type=\"Float64\" "
                  "Name=\"TimeValue\" NumberOfTuples=\"1\" format=\"ascii\">0.5</DataArray>"
                  "</FieldData>\n<Piece NumberOfPoints='5' NumberOfCells='2'>\n");
    const char *open = NULL;
    for (int i = 0; i < na; i++) {
        if (!open || strcmp(open, arr[i].section) != 0) {
            if (open) sb_printf(&x, "</%s>\n", open);
            open = arr[i].section;
            sb_printf(&x, "<%s>\n", open);
        }
        const char *fmt = strncmp(o->format, "appended", 8) == 0 ? "appended" : o->format;
        sb_printf(&x,
                  "  <DataArray type=\"%s\" Name=\"%s\" NumberOfComponents=\"%d\" "
                  "format=\"%s\" RangeMin=\"0\"",
                  arr[i].type, arr[i].name, arr[i].ncomp, fmt);
        if (strcmp(fmt, "appended") == 0) {
            sb_printf(&x, " offset=\"%zu\"/>\n", app.n);
        } else {
            sb_printf(&x, ">\n    ");
        }
        sbuf head = {0, 0, 0}, body = {0, 0, 0};
        if (strcmp(o->format, "ascii") != 0)
            make_payload(arr[i].data, arr[i].n * arr[i].esize, arr[i].esize, o, &head, &body);
        if (strcmp(o->format, "ascii") == 0) {
            sb_printf(&x, "%s\n", arr[i].ascii);
        } else if (strcmp(o->format, "binary") == 0 ||
                   strcmp(o->format, "appended-base64") == 0) {
            sbuf *dst = strcmp(o->format, "binary") == 0 ? &x : &app;
            if (o->split_base64) {
                b64_encode(dst, (const unsigned char *)head.p, head.n);
                b64_encode(dst, (const unsigned char *)body.p, body.n);
            } else {
                sb_add(&head, body.p, body.n);
                b64_encode(dst, (const unsigned char *)head.p, head.n);
            }
            if (dst == &x) sb_printf(&x, "\n");
        } else {
            sb_add(&app, head.p, head.n);
            sb_add(&app, body.p, body.n);
        }
        if (strcmp(fmt, "appended") != 0) {
            if (strcmp(arr[i].name, "Points") == 0)
                sb_printf(&x, "    <InformationKey name=\"L2_NORM_RANGE\" length=\"2\">"
                              "<Value index=\"0\">0</Value></InformationKey>\n");
            sb_printf(&x, "  </DataArray>\n");
        }
        free(head.p);
        free(body.p);
    }
    sb_printf(&x, "</%s>\n</Piece>\n</UnstructuredGrid>\n", open);
    if (strncmp(o->format, "appended", 8) == 0) {
        sb_printf(&x, "<AppendedData encoding=\"%s\">\n _",
                  strcmp(o->format, "appended-raw") == 0 ? "raw" : "base64");
        sb_add(&x, app.p, app.n);
        sb_printf(&x, "\n</AppendedData>\n");
    }
    sb_printf(&x, "</VTKFile>\n");
    free(app.p);
    *len = x.n;
    return x.p;
}

static void check_generated_mesh(const vm_mesh *m, const char *what) {
    CHECK_MSG(m->kind == VM_TET4 && m->npoints == 5 && m->ncells == 2, "%s: shape", what);
    if (m->npoints != 5 || m->ncells != 2) return;
    static const double pts[15] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    static const vm_index conn[8] = {0, 1, 2, 3, 1, 2, 3, 4};
    CHECK_MSG(memcmp(m->points, pts, sizeof pts) == 0, "%s: points", what);
    CHECK_MSG(memcmp(m->cells, conn, sizeof conn) == 0, "%s: cells", what);
    CHECK_MSG(m->region[0] == 7 && m->region[1] == -3, "%s: regions", what);
    const vm_field *f = vm_mesh_find_field(m, 0, "f");
    CHECK_MSG(f && f->ncomp == 1 && f->data[4] == 2.0 && f->data[1] == 0.5, "%s: field", what);
    CHECK_MSG(m->ncell_fields == 0, "%s: integer cell arrays are not fields", what);
}

static void filesInEveryVtkEncodingAreRead(void) {
    static const gen_opts variants[] = {
        {"ascii", 0, 0, 0, 0, 0, 0, 0},
        {"ascii", 1, 1, 1, 1, 1, 0, 0},
        {"binary", 0, 0, 0, 0, 0, 1, 0},
        {"binary", 0, 0, 0, 0, 0, 0, 0},
        {"binary", 1, 0, 0, 1, 1, 1, 0},
        {"binary", 0, 1, 0, 0, 0, 1, 16},
        {"binary", 1, 1, 0, 0, 1, 0, 24},
        {"binary", 0, 1, 1, 1, 0, 1, 8},
        {"appended-raw", 0, 0, 0, 0, 0, 0, 0},
        {"appended-raw", 1, 0, 1, 0, 1, 0, 0},
        {"appended-raw", 0, 1, 0, 1, 0, 0, 32},
        {"appended-raw", 1, 1, 1, 0, 0, 0, 40},
        {"appended-base64", 0, 0, 0, 0, 0, 1, 0},
        {"appended-base64", 1, 0, 0, 0, 1, 0, 0},
        {"appended-base64", 0, 1, 0, 0, 0, 1, 16},
        {"appended-base64", 1, 1, 1, 1, 1, 0, 8},
    };
    for (size_t i = 0; i < sizeof variants / sizeof variants[0]; i++) {
        const gen_opts *o = &variants[i];
        char what[160];
        snprintf(what, sizeof what, "%s header%d z%d be%d f32 %d i32 %d split %d", o->format,
                 o->header64 ? 64 : 32, o->compressed, o->big_endian, o->float32_points,
                 o->int32_cells, o->split_base64);
        size_t len;
        char *text = generate_vtu(o, &len);
        const char *path = vm_test_tmp("variant.vtu");
        CHECK(vm_test_write_file(path, text, len) == 0);
        vm_mesh m;
        vm_error eb, *err = &eb;
        vm_status st = vm_mesh_read_vtu(path, &m, err);
        CHECK_MSG(st == VM_OK, "%s: %s", what, err->message);
        if (st == VM_OK) check_generated_mesh(&m, what);
        vm_mesh_free(&m);
        free(text);
    }
}

/* --- malformed files ---------------------------------------------------------------------- */

static void expect_error(const char *path, vm_status want, const char *needle) {
    vm_mesh m;
    vm_error eb, *err = &eb;
    vm_status st = vm_mesh_read_vtu(path, &m, err);
    CHECK_MSG(st < 0 && (want == 0 || st == want), "%s: status %d, expected %d (%s)", path,
              (int)st, (int)want, err->message);
    CHECK_MSG(strncmp(err->message, path, strlen(path)) == 0 &&
                  err->message[strlen(path)] == ':',
              "message does not start with the path: %s", err->message);
    CHECK_MSG(!needle || strstr(err->message, needle), "message \"%s\" lacks \"%s\"",
              err->message, needle);
    CHECK_MSG(strchr(err->message, '\n') == NULL, "message has a newline: %s", err->message);
    CHECK(m.npoints == 0 && m.ncells == 0 && m.points == NULL);
}

static void write_text(const char *path, const char *text) {
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
}

static void emptyGarbageMissingAndDirectoryPathsAreErrors(void) {
    const char *p = vm_test_tmp("bad_empty.vtu");
    write_text(p, "");
    expect_error(p, VM_ERR_FORMAT, "empty");
    p = vm_test_tmp("bad_garbage.vtu");
    write_text(p, "\x01\x02garbage \xff\xfe not xml at all");
    expect_error(p, VM_ERR_FORMAT, NULL);
    p = vm_test_tmp("bad_polydata.vtu");
    write_text(p, "<VTKFile type=\"PolyData\"><PolyData/></VTKFile>");
    expect_error(p, VM_ERR_UNSUPPORTED, "PolyData");
    p = vm_test_tmp("bad_unclosed.vtu");
    write_text(p, "<VTKFile type=\"UnstructuredGrid\"><Piece NumberOfPoints=\"1");
    expect_error(p, VM_ERR_FORMAT, NULL);
    p = vm_test_tmp("no_such_file.vtu");
    remove(p);
    expect_error(p, VM_ERR_IO, NULL);
    p = vm_test_tmp("a_directory.vtu");
    mkdir(p, 0755);
    expect_error(p, VM_ERR_IO, "directory");
}

/* Prefixes of a valid file that cut into its data are errors, never crashes. */
static void truncatedFilesAreErrorsAtEveryLength(void) {
    static const gen_opts kinds[] = {{"appended-raw", 1, 1, 0, 0, 0, 0, 16},
                                     {"appended-raw", 0, 0, 0, 0, 0, 0, 0},
                                     {"binary", 0, 1, 0, 0, 0, 1, 16},
                                     {"ascii", 0, 0, 0, 0, 0, 0, 0}};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        size_t len;
        char *text = generate_vtu(&kinds[k], &len);
        /* The data ends before "\n</AppendedData>" (or the last </DataArray>). */
        const char *tail = strstr(text, "</AppendedData>");
        if (!tail) tail = strstr(text, "</Cells>");
        size_t data_end = (size_t)(tail - text) - 1;
        const char *path = vm_test_tmp("bad_truncated.vtu");
        /* Every 11th length, and every length near the end of the data (the file system
         * may be slow, so not all of them). */
        for (size_t n = 0; n < data_end; n += (n + 48 < data_end) ? 11 : 1) {
            CHECK(vm_test_write_file(path, text, n) == 0);
            vm_mesh m;
            vm_error eb, *err = &eb;
            vm_status st = vm_mesh_read_vtu(path, &m, err);
            CHECK_MSG(st != VM_OK, "%s truncated to %zu bytes was accepted", kinds[k].format,
                      n);
            if (st == VM_OK)
                vm_mesh_free(&m);
            else
                CHECK(strncmp(err->message, path, strlen(path)) == 0);
        }
        free(text);
    }
}

static void replace_once(char *text, const char *from, const char *to) {
    char *p = strstr(text, from);
    CHECK(p != NULL);
    if (!p) return;
    CHECK(strlen(from) == strlen(to));
    memcpy(p, to, strlen(to));
}

static void lyingOffsetsSizesAndCellsAreErrors(void) {
    const gen_opts raw = {"appended-raw", 1, 0, 0, 0, 0, 0, 0};
    const gen_opts zraw = {"appended-raw", 1, 1, 0, 0, 0, 0, 16};
    size_t len;
    const char *p = vm_test_tmp("bad_lying.vtu");
    struct {
        const gen_opts *o;
        const char *from, *to;
        vm_status want;
        const char *needle;
    } cases[] = {
        {&raw, "offset=\"0\"", "offset=\"9\"", VM_ERR_FORMAT, NULL},
        {&raw, "NumberOfPoints='5'", "NumberOfPoints='9'", VM_ERR_FORMAT, "Points"},
        {&raw, "NumberOfCells='2'", "NumberOfCells='3'", VM_ERR_FORMAT, NULL},
        {&raw, "type=\"UInt8\"", "type=\"UInt7\"", VM_ERR_UNSUPPORTED, "UInt7"},
        {&raw, "encoding=\"raw\"", "encoding=\"rot\"", VM_ERR_FORMAT, "encoding"},
        {&zraw, "vtkZLibDataCompressor", "vtkLZMADataCompressor", VM_ERR_UNSUPPORTED, "LZMA"},
        {&raw, "NumberOfComponents=\"3\"", "NumberOfComponents=\"0\"", VM_ERR_FORMAT, NULL},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char *text = generate_vtu(cases[i].o, &len);
        replace_once(text, cases[i].from, cases[i].to);
        CHECK(vm_test_write_file(p, text, len) == 0);
        expect_error(p, cases[i].want, cases[i].needle);
        free(text);
    }
    /* An offset far past the end, a header claiming terabytes, a block count beyond the
     * file, a connectivity index out of range, a mixed and an unknown cell type. */
    char *text = generate_vtu(&raw, &len);
    char *big = strstr(text, "offset=\"0\"");
    char *data = strstr(text, "\n _") + 3;
    CHECK(big && data);
    {
        char *t2 = malloc(len + 64);
        size_t pre = (size_t)(big - text);
        memcpy(t2, text, pre);
        size_t n = (size_t)sprintf(t2 + pre, "offset=\"99999999999999999\"");
        memcpy(t2 + pre + n, big + 10, len - pre - 10);
        CHECK(vm_test_write_file(p, t2, len - 10 + n) == 0);
        expect_error(p, VM_ERR_FORMAT, "offset");
        free(t2);
    }
    {
        char *t2 = malloc(len);
        memcpy(t2, text, len);
        uint64_t huge = (uint64_t)1 << 41;
        memcpy(t2 + (data - text), &huge, 8); /* first array's byte count */
        CHECK(vm_test_write_file(p, t2, len) == 0);
        expect_error(p, VM_ERR_FORMAT, "more than the file holds");
        free(t2);
    }
    free(text);
    text = generate_vtu(&zraw, &len);
    data = strstr(text, "\n _") + 3;
    {
        uint64_t huge = (uint64_t)1 << 40;
        memcpy(data, &huge, 8); /* block count */
        CHECK(vm_test_write_file(p, text, len) == 0);
        expect_error(p, VM_ERR_FORMAT, "blocks");
    }
    free(text);
    text = generate_vtu(&zraw, &len);
    data = strstr(text, "\n _") + 3;
    {
        uint64_t bs = (uint64_t)1 << 30; /* block size: 1 GiB from a few bytes */
        memcpy(data + 8, &bs, 8);
        CHECK(vm_test_write_file(p, text, len) == 0);
        expect_error(p, VM_ERR_FORMAT, NULL);
    }
    free(text);
    const gen_opts asc = {"ascii", 0, 0, 0, 0, 0, 0, 0};
    struct {
        const char *from, *to;
        vm_status want;
        const char *needle;
    } acases[] = {
        {"0 1 2 3 1 2 3 4", "0 1 2 3 1 2 3 5", VM_ERR_FORMAT, "connectivity"},
        {"0 1 2 3 1 2 3 4", "0 1 2 3 1 2 3 x", VM_ERR_FORMAT, "bad number"},
        {"10 10", "10 12", VM_ERR_UNSUPPORTED, "mixed"},
        {"10 10", "24 24", VM_ERR_UNSUPPORTED, "24"},
        {"4 8\n", "4 9\n", VM_ERR_FORMAT, "offsets"},
        {"7 -3", "7 .5", VM_ERR_FORMAT, "region"},
    };
    for (size_t i = 0; i < sizeof acases / sizeof acases[0]; i++) {
        text = generate_vtu(&asc, &len);
        if (strstr(text, acases[i].from)) {
            replace_once(text, acases[i].from, acases[i].to);
            CHECK(vm_test_write_file(p, text, len) == 0);
            expect_error(p, acases[i].want, acases[i].needle);
        }
        free(text);
    }
}

/* --- atomic output ------------------------------------------------------------------------ */

static int count_temp_files(const char *dir, const char *prefix) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0 && strstr(e->d_name, ".tmp-")) n++;
    closedir(d);
    return n;
}

static void failedWritesLeaveNoFileBehind(void) {
    vm_mesh m;
    vm_error eb, *err = &eb;
    const double o[3] = {0, 0, 0};
    build_cubes(&m, slab_cubes, 6, 1, o);
    const char *missing = vm_test_tmp("no_such_dir/out.vtu");
    vm_status st = vm_mesh_write_vtu(missing, &m, 1, err);
    CHECK(st == VM_ERR_IO);
    CHECK(strncmp(err->message, missing, strlen(missing)) == 0);
    CHECK(!vm_test_exists(missing));
    /* The final name is a directory: the rename fails and the temp file must go. */
    const char *dir = vm_test_tmp("target_is_dir.vtu");
    mkdir(dir, 0755);
    st = vm_mesh_write_vtu(dir, &m, 0, err);
    CHECK(st == VM_ERR_IO);
    const char *tmpdir = getenv("VM_TEST_TMP") ? getenv("VM_TEST_TMP") : ".";
    CHECK(count_temp_files(tmpdir, "target_is_dir.vtu") == 0);
    vm_mesh_free(&m);
}

TEST_MAIN(T(tetsAndHexesRoundTripExactlyCompressedOrNot),
          T(multiBlockArraysAndAwkwardDoublesRoundTripBitExact),
          T(multiBlockFilesAreTheSameBytesOnOneAndTwoThreads),
          T(compressLevelsAreNamedAndOthersRefused),
          T(surfacesAndEmptyMeshesRoundTrip), T(judgeFilesForVtkAreWritten),
          T(filesInEveryVtkEncodingAreRead),
          T(emptyGarbageMissingAndDirectoryPathsAreErrors),
          T(truncatedFilesAreErrorsAtEveryLength),
          T(lyingOffsetsSizesAndCellsAreErrors), T(failedWritesLeaveNoFileBehind))
