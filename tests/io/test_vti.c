/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_vti.c — the VTK XML ImageData reader: the shared hydrogen volume against VTK's
 * statistics; files written here in every encoding (ascii, inline base64 with UInt32/UInt64
 * headers, appended raw and base64, zlib in several blocks via compress2, big endian); the
 * geometry (Direction, extent start); every kind of bad input. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <zlib.h>
#include "io/io_util.h"
#include "test.h"

/* ---- building files ---- */

typedef struct vti_spec {
    const char *type;   /* DataArray type, e.g. "Float32" */
    vm_scalar_type vt;  /* the same type */
    int big_endian;     /* byte_order */
    int header64;       /* header_type UInt64 */
    size_t block;       /* compression block size in bytes; 0: uncompressed */
    const char *format; /* "ascii", "binary", "raw" (appended), "base64" (appended) */
    const char *image;  /* ImageData attributes */
    const char *extent; /* Piece Extent */
    int n;              /* number of values (i*1.5 - 3 for i < n) */
} vti_spec;

static double value_at(int i) { return i * 1.5 - 3.0; }

/* Sample i as stored in type t: i*1.5-3 for floats; for integers its truncation, wrapped
 * modulo 2^bits for unsigned types. [out] out (file byte order); returns the value as text. */
static double put_sample(vm_scalar_type t, int i, int big, unsigned char *out, char text[32]) {
    unsigned char tmp[8];
    size_t n = vm_scalar_type_size(t);
    double d = value_at(i), r;
    int64_t k = (int64_t)d;
    switch (t) {
    case VM_SCALAR_UINT8: { uint8_t x = (uint8_t)k; memcpy(tmp, &x, 1); r = x; } break;
    case VM_SCALAR_INT8: { int8_t x = (int8_t)k; memcpy(tmp, &x, 1); r = x; } break;
    case VM_SCALAR_UINT16: { uint16_t x = (uint16_t)k; memcpy(tmp, &x, 2); r = x; } break;
    case VM_SCALAR_INT16: { int16_t x = (int16_t)k; memcpy(tmp, &x, 2); r = x; } break;
    case VM_SCALAR_UINT32: { uint32_t x = (uint32_t)k; memcpy(tmp, &x, 4); r = x; } break;
    case VM_SCALAR_INT32: { int32_t x = (int32_t)k; memcpy(tmp, &x, 4); r = x; } break;
    case VM_SCALAR_UINT64: {
        uint64_t x = (uint64_t)k;
        memcpy(tmp, &x, 8);
        r = (double)x;
        snprintf(text, 32, "%llu", (unsigned long long)x);
    } break;
    case VM_SCALAR_INT64: { int64_t x = k; memcpy(tmp, &x, 8); r = (double)x; } break;
    case VM_SCALAR_FLOAT32: { float x = (float)d; memcpy(tmp, &x, 4); r = x; } break;
    default: memcpy(tmp, &d, 8); r = d; break;
    }
    if (t != VM_SCALAR_UINT64) snprintf(text, 32, "%.17g", r);
    int little = vm__host_little_endian();
    for (size_t b = 0; b < n; b++) out[b] = (big == little) ? tmp[n - 1 - b] : tmp[b];
    return r;
}

static void put_uint(uint64_t v, int size, int big, unsigned char *out) {
    for (int i = 0; i < size; i++) out[big ? size - 1 - i : i] = (unsigned char)(v >> (8 * i));
}

static void b64_write(FILE *fp, const unsigned char *b, size_t n) {
    static const char *abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < n; i += 3) {
        uint32_t w = (uint32_t)b[i] << 16 | (i + 1 < n ? (uint32_t)b[i + 1] << 8 : 0) |
                     (i + 2 < n ? b[i + 2] : 0);
        fputc(abc[w >> 18 & 63], fp);
        fputc(abc[w >> 12 & 63], fp);
        fputc(i + 1 < n ? abc[w >> 6 & 63] : '=', fp);
        fputc(i + 2 < n ? abc[w & 63] : '=', fp);
    }
}

/* The encoded array: header bytes and data bytes (compressed blocks, or raw samples). */
typedef struct payload {
    unsigned char header[1024], data[65536];
    size_t header_len, data_len;
} payload;

static void make_payload(const vti_spec *s, payload *p) {
    size_t es = vm_scalar_type_size(s->vt), raw_len = (size_t)s->n * es;
    int hs = s->header64 ? 8 : 4;
    unsigned char raw[16384];
    char text[32];
    for (int i = 0; i < s->n; i++) put_sample(s->vt, i, s->big_endian, raw + i * es, text);
    if (!s->block) {
        put_uint(raw_len, hs, s->big_endian, p->header);
        p->header_len = (size_t)hs;
        memcpy(p->data, raw, raw_len);
        p->data_len = raw_len;
        return;
    }
    size_t nb = (raw_len + s->block - 1) / s->block, last = raw_len % s->block;
    put_uint(nb, hs, s->big_endian, p->header);
    put_uint(s->block, hs, s->big_endian, p->header + hs);
    put_uint(last, hs, s->big_endian, p->header + 2 * hs);
    p->data_len = 0;
    for (size_t k = 0; k < nb; k++) {
        size_t us = k + 1 == nb && last ? last : s->block;
        uLongf cs = (uLongf)(sizeof p->data - p->data_len);
        compress2(p->data + p->data_len, &cs, raw + k * s->block, (uLong)us, 9);
        put_uint(cs, hs, s->big_endian, p->header + (3 + k) * (size_t)hs);
        p->data_len += cs;
    }
    p->header_len = (3 + nb) * (size_t)hs;
}

static const char *write_vti(const char *name, const vti_spec *s) {
    const char *path = vm_test_tmp(name);
    FILE *fp = fopen(path, "wb");
    if (!fp) return path;
    fprintf(fp, "<?xml version=\"1.0\"?>\n<!-- written by test_vti.c -->\n"
                "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"%s\" "
                "header_type=\"%s\"%s>\n",
            s->big_endian ? "BigEndian" : "LittleEndian", s->header64 ? "UInt64" : "UInt32",
            s->block ? " compressor=\"vtkZLibDataCompressor\"" : "");
    fprintf(fp, "  <ImageData %s>\n  <Piece Extent='%s'>\n    <PointData>\n", s->image,
            s->extent);
    int appended = strcmp(s->format, "raw") == 0 || strcmp(s->format, "base64") == 0;
    fprintf(fp, "      <DataArray type=\"%s\" Name=\"v\" format=\"%s\"%s>\n", s->type,
            appended ? "appended" : s->format, appended ? " offset=\"0\"/" : "");
    payload *p = malloc(sizeof *p);
    make_payload(s, p);
    if (strcmp(s->format, "ascii") == 0) {
        for (int i = 0; i < s->n; i++) {
            unsigned char b[8];
            char text[32];
            put_sample(s->vt, i, 0, b, text);
            fprintf(fp, "%s%c", text, i % 8 == 7 ? '\n' : ' ');
        }
        fprintf(fp, "\n      </DataArray>\n");
    } else if (!appended) {
        if (s->block) {
            b64_write(fp, p->header, p->header_len);
            b64_write(fp, p->data, p->data_len);
        } else {
            unsigned char all[70000];
            memcpy(all, p->header, p->header_len);
            memcpy(all + p->header_len, p->data, p->data_len);
            b64_write(fp, all, p->header_len + p->data_len);
        }
        fprintf(fp, "\n      </DataArray>\n");
    }
    fprintf(fp, "    </PointData>\n  </Piece>\n  </ImageData>\n");
    if (appended) {
        fprintf(fp, "  <AppendedData encoding=\"%s\">\n   _", s->format);
        if (strcmp(s->format, "raw") == 0) {
            fwrite(p->header, 1, p->header_len, fp);
            fwrite(p->data, 1, p->data_len, fp);
        } else if (s->block) {
            b64_write(fp, p->header, p->header_len);
            b64_write(fp, p->data, p->data_len);
        } else {
            unsigned char all[70000];
            memcpy(all, p->header, p->header_len);
            memcpy(all + p->header_len, p->data, p->data_len);
            b64_write(fp, all, p->header_len + p->data_len);
        }
        fprintf(fp, "\n  </AppendedData>\n");
    }
    fprintf(fp, "</VTKFile>\n");
    fclose(fp);
    free(p);
    return path;
}

static vti_spec base_spec(void) {
    vti_spec s = {"Float32", VM_SCALAR_FLOAT32, 0, 0, 0, "binary",
                  "WholeExtent=\"0 4 0 3 0 2\" Origin=\"0 0 0\" Spacing=\"1 1 1\"",
                  "0 4 0 3 0 2", 60};
    return s;
}

static void check_read(const char *path, const vti_spec *s) {
    vm_volume v;
    vm_error err;
    vm_status st = vm_volume_read_vti(path, &v, &err);
    CHECK_MSG(st == VM_OK, "%s", err.message);
    if (st) return;
    CHECK(strcmp(v.format, "vti") == 0);
    CHECK(v.type == s->vt);
    CHECK_MSG((int)vm_volume_count(&v) == s->n, "count %zu", vm_volume_count(&v));
    size_t bad = 0;
    for (int i = 0; i < s->n && i < (int)vm_volume_count(&v); i++) {
        unsigned char b[8];
        char text[32];
        float expect = (float)put_sample(s->vt, i, 0, b, text);
        if (v.data[i] != expect && bad++ < 3)
            fprintf(stderr, "  %s: value %d is %g, expected %g\n", path, i, v.data[i], expect);
    }
    CHECK(bad == 0);
    vm_volume_free(&v);
}

static void check_fails(const char *path, vm_status expected, const char *fragment) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_vti(path, &v, &err);
    vm_test_expect_refusal(path, st, expected, &err, fragment, &v);
}

/* ---- tests ---- */

static void vtiReadsSharedHydrogenWithReferenceStatistics(void) {
    const char *path = vm_test_shared("hydrogen.vti");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vti(path, &v, &err), &err);
    CHECK(v.dims[0] == 64 && v.dims[1] == 64 && v.dims[2] == 64);
    CHECK(v.type == VM_SCALAR_FLOAT32);
    for (int a = 0; a < 3; a++) {
        CHECK_NEAR(v.spacing[a], 1, 0);
        CHECK_NEAR(v.origin[a], 0, 0);
        CHECK_NEAR(v.direction[a][a], 1, 0);
    }
    double lo, hi, mean;
    if (v.data) {
        CHECK(vm_volume_stats(&v, &lo, &hi, &mean) == 0);
        CHECK_NEAR(lo, 0, 1e-4);
        CHECK_NEAR(hi, 1, 1e-4);
        CHECK_NEAR(mean, 0.018524, 0.018524 * 1e-4);
    }
    vm_volume_free(&v);
}

static void vtiReadsEveryTypeInEveryEncoding(void) {
    static const struct {
        const char *name;
        vm_scalar_type t;
    } types[] = {{"Int8", VM_SCALAR_INT8},       {"UInt8", VM_SCALAR_UINT8},
                 {"Int16", VM_SCALAR_INT16},     {"UInt16", VM_SCALAR_UINT16},
                 {"Int32", VM_SCALAR_INT32},     {"UInt32", VM_SCALAR_UINT32},
                 {"Int64", VM_SCALAR_INT64},     {"UInt64", VM_SCALAR_UINT64},
                 {"Float32", VM_SCALAR_FLOAT32}, {"Float64", VM_SCALAR_FLOAT64}};
    static const char *formats[] = {"ascii", "binary", "raw", "base64"};
    int count = 0;
    for (size_t t = 0; t < sizeof types / sizeof types[0]; t++)
        for (size_t f = 0; f < 4; f++)
            for (int variant = 0; variant < 4; variant++) {
                /* variant bits: header64, big endian */
                if (f == 0 && variant) continue;
                vti_spec s = base_spec();
                s.type = types[t].name;
                s.vt = types[t].t;
                s.format = formats[f];
                s.header64 = variant & 1;
                s.big_endian = (variant >> 1) & 1;
                char name[64];
                snprintf(name, sizeof name, "vti_%s_%s_%d.vti", types[t].name, formats[f],
                         variant);
                check_read(write_vti(name, &s), &s);
                count++;
            }
    CHECK(count == 10 * (1 + 3 * 4));
}

static void vtiReadsZlibCompressedDataInSeveralBlocks(void) {
    static const char *formats[] = {"binary", "raw", "base64"};
    for (size_t f = 0; f < 3; f++)
        for (int variant = 0; variant < 4; variant++)
            for (size_t block = 7; block <= 512; block *= 4) {
                /* 60 Float64 = 480 bytes: blocks of 7 (partial last), 28, 112, 448 bytes. */
                vti_spec s = base_spec();
                s.type = "Float64";
                s.vt = VM_SCALAR_FLOAT64;
                s.format = formats[f];
                s.header64 = variant & 1;
                s.big_endian = (variant >> 1) & 1;
                s.block = block;
                char name[64];
                snprintf(name, sizeof name, "vti_zlib_%s_%d_%zu.vti", formats[f], variant, block);
                check_read(write_vti(name, &s), &s);
            }
    /* A block size that divides the data exactly (last block size 0 means full). */
    vti_spec s = base_spec();
    s.block = 48;
    check_read(write_vti("vti_zlib_exact.vti", &s), &s);
}

static void vtiAppliesDirectionSpacingAndExtentStartToTheGeometry(void) {
    vti_spec s = base_spec();
    s.image = "WholeExtent=\"2 6 -1 2 10 12\" Origin=\"1 2 3\" Spacing=\"0.5 2 -4\" "
              "Direction=\"0 -1 0 1 0 0 0 0 1\"";
    s.extent = "2 6 -1 2 10 12";
    const char *path = write_vti("vti_geometry.vti", &s);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vti(path, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.dims[0] == 5 && v.dims[1] == 4 && v.dims[2] == 3);
    /* world = O + D * (e0*s): D*(1, -2, -40) = (2, 1, -40) */
    CHECK_NEAR(v.origin[0], 1 + 2, 1e-12);
    CHECK_NEAR(v.origin[1], 2 + 1, 1e-12);
    CHECK_NEAR(v.origin[2], 3 - 40, 1e-12);
    CHECK_NEAR(v.spacing[2], 4, 0);
    CHECK_NEAR(v.direction[0][1], -1, 0);
    CHECK_NEAR(v.direction[1][0], 1, 0);
    CHECK_NEAR(v.direction[2][2], -1, 0);
    /* Voxel (1, 1, 1) sits at VTK's O + D * ((e0+1) * s). */
    double ijk[3] = {1, 1, 1}, xyz[3];
    vm_volume_index_to_world(&v, ijk, xyz);
    CHECK_NEAR(xyz[0], 1 + -(0 * 2.0), 1e-12);
    CHECK_NEAR(xyz[1], 2 + 3 * 0.5, 1e-12);
    CHECK_NEAR(xyz[2], 3 + 11 * -4.0, 1e-12);
    vm_volume_free(&v);
}

static const char *write_text(const char *name, const char *text) {
    const char *path = vm_test_tmp(name);
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
    return path;
}

#define VTI_HEAD                                                                           \
    "<VTKFile type=\"ImageData\" version=\"0.1\" byte_order=\"LittleEndian\">"             \
    "<ImageData WholeExtent=\"0 1 0 0 0 0\" Origin=\"0 0 0\" Spacing=\"1 1 1\">"           \
    "<Piece Extent=\"0 1 0 0 0 0\">"

static void vtiSelectsTheActiveScalarsElseTheFirstOneComponentArray(void) {
    const char *path = write_text(
        "vti_select.vti",
        VTI_HEAD "<PointData Scalars=\"b\">"
                 "<DataArray type=\"Float32\" Name=\"a\" format=\"ascii\">1 2</DataArray>"
                 "<DataArray type=\"Int16\" Name=\"b\" format=\"ascii\">3 4</DataArray>"
                 "</PointData><CellData><DataArray type=\"Float32\" Name=\"c\" "
                 "format=\"ascii\">9</DataArray></CellData></Piece></ImageData></VTKFile>");
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vti(path, &v, &err), &err);
    if (v.data) CHECK(v.type == VM_SCALAR_INT16 && v.data[0] == 3 && v.data[1] == 4);
    vm_volume_free(&v);
    path = write_text(
        "vti_first.vti",
        VTI_HEAD "<PointData>"
                 "<DataArray type=\"Float32\" Name=\"vec\" NumberOfComponents=\"3\" "
                 "format=\"ascii\">1 2 3 4 5 6</DataArray>"
                 "<DataArray type=\"UInt8\" Name=\"b\" format=\"ascii\">7 8</DataArray>"
                 "</PointData></Piece></ImageData></VTKFile>");
    CHECK_OK(vm_volume_read_vti(path, &v, &err), &err);
    if (v.data) CHECK(v.type == VM_SCALAR_UINT8 && v.data[0] == 7 && v.data[1] == 8);
    vm_volume_free(&v);
}

static void vtiFindsAppendedArraysByTheirOffsetAfterTheUnderscore(void) {
    /* Two UInt8 arrays [1 2] and [5 6], each "[02 00 00 00] v0 v1"; the second is active. */
    static const char head[] = VTI_HEAD
        "<PointData Scalars=\"b\">"
        "<DataArray type=\"UInt8\" Name=\"a\" format=\"appended\" offset=\"0\"/>"
        "<DataArray type=\"UInt8\" Name=\"b\" format=\"appended\" offset=\"%d\"/>"
        "</PointData></Piece></ImageData><AppendedData encoding=\"%s\">\n  _";
    static const unsigned char raw[12] = {2, 0, 0, 0, 1, 2, 2, 0, 0, 0, 5, 6};
    for (int b64 = 0; b64 < 2; b64++) {
        char text[2048];
        int n = snprintf(text, sizeof text, head, b64 ? 8 : 6, b64 ? "base64" : "raw");
        if (b64) {
            n += snprintf(text + n, sizeof text - n, "AgAAAAECAgAAAAUG");
        } else {
            memcpy(text + n, raw, sizeof raw);
            n += (int)sizeof raw;
        }
        n += snprintf(text + n, sizeof text - n, "\n</AppendedData></VTKFile>\n");
        const char *path = vm_test_tmp(b64 ? "vti_offsets_b64.vti" : "vti_offsets_raw.vti");
        CHECK(vm_test_write_file(path, text, (size_t)n) == 0);
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read_vti(path, &v, &err), &err);
        if (v.data) CHECK_MSG(v.data[0] == 5 && v.data[1] == 6, "got %g %g", v.data[0], v.data[1]);
        vm_volume_free(&v);
    }
}

static void vtiRefusesUnsupportedFeaturesClearly(void) {
    static const struct {
        const char *name, *text, *fragment;
    } cases[] = {
        {"vti_grid.vti", "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid/></VTKFile>",
         "UnstructuredGrid"},
        {"vti_pieces.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"ascii\">1 2"
                  "</DataArray></PointData></Piece><Piece Extent=\"0 1 0 0 0 0\"></Piece>"
                  "</ImageData></VTKFile>",
         "2 pieces"},
        {"vti_ncomp.vti",
         VTI_HEAD "<PointData Scalars=\"a\"><DataArray type=\"UInt8\" Name=\"a\" "
                  "NumberOfComponents=\"2\" format=\"ascii\">1 2 3 4</DataArray>"
                  "</PointData></Piece></ImageData></VTKFile>",
         "2 components"},
        {"vti_lz4.vti",
         "<VTKFile type=\"ImageData\" compressor=\"vtkLZ4DataCompressor\"></VTKFile>",
         "vtkLZ4DataCompressor"},
        {"vti_header16.vti", "<VTKFile type=\"ImageData\" header_type=\"UInt16\"></VTKFile>",
         "UInt16"},
        {"vti_nodata.vti", VTI_HEAD "<PointData></PointData></Piece></ImageData></VTKFile>",
         "no one-component"},
        {"vti_string.vti",
         VTI_HEAD "<PointData><DataArray type=\"String\" Name=\"a\" format=\"ascii\">1 2"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         "unsupported type 'String'"},
        {"vti_format.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"hex\">1 2"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         "format 'hex'"},
        {"vti_encoding.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"appended\" "
                  "offset=\"0\"/></PointData></Piece></ImageData>"
                  "<AppendedData encoding=\"base85\">_xx</AppendedData></VTKFile>",
         "base85"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        check_fails(write_text(cases[i].name, cases[i].text), VM_ERR_UNSUPPORTED,
                    cases[i].fragment);
}

/* Writes a valid compressed or uncompressed file, then patches bytes of its payload. */
static const char *write_patched(const char *name, const vti_spec *s, size_t at,
                                 const unsigned char *bytes, size_t n, long truncate) {
    const char *path = write_vti(name, s);
    FILE *fp = fopen(path, "rb");
    unsigned char buf[80000];
    size_t len = fread(buf, 1, sizeof buf, fp);
    fclose(fp);
    size_t start = 0; /* just past the "\n   _" that write_vti puts before the payload */
    for (size_t i = 0; i + 5 <= len && !start; i++)
        if (memcmp(buf + i, "\n   _", 5) == 0) start = i + 5;
    CHECK(start != 0);
    memcpy(buf + start + at, bytes, n);
    if (truncate >= 0) len = start + (size_t)truncate;
    vm_test_write_file(path, buf, len);
    return path;
}

static void vtiRejectsLyingHeadersAndTruncatedData(void) {
    vti_spec s = base_spec();
    s.format = "raw";
    unsigned char le[8];
    /* Uncompressed: header claims more bytes than the extent needs; then truncated data. */
    put_uint(1000, 4, 0, le);
    check_fails(write_patched("vti_bad_nbytes.vti", &s, 0, le, 4, -1), VM_ERR_FORMAT,
                "header says 1000 bytes");
    check_fails(write_patched("vti_truncated_raw.vti", &s, 0, le, 0, 100), VM_ERR_FORMAT,
                "truncated (got 96 of 240 bytes)");
    check_fails(write_patched("vti_no_header.vti", &s, 0, le, 0, 2), VM_ERR_FORMAT,
                "truncated");
    /* Compressed (blocks of 64 bytes: 4 blocks, last 48). */
    s.block = 64;
    put_uint(0xFFFFFFFFu, 4, 0, le);
    check_fails(write_patched("vti_many_blocks.vti", &s, 0, le, 4, -1), VM_ERR_FORMAT,
                "lists 4294967295 blocks");
    put_uint(0, 4, 0, le);
    check_fails(write_patched("vti_zero_blocks.vti", &s, 0, le, 4, -1), VM_ERR_FORMAT,
                "inconsistent");
    put_uint(100, 4, 0, le);
    check_fails(write_patched("vti_last_gt_block.vti", &s, 8, le, 4, -1), VM_ERR_FORMAT,
                "inconsistent");
    put_uint(65, 4, 0, le);
    check_fails(write_patched("vti_block_sizes.vti", &s, 4, le, 4, -1), VM_ERR_FORMAT,
                "the extent and type need 240");
    put_uint(0x7FFFFFFF, 4, 0, le);
    check_fails(write_patched("vti_csize_lies.vti", &s, 12, le, 4, -1), VM_ERR_FORMAT,
                "compressed block 0");
    check_fails(write_patched("vti_truncated_zlib.vti", &s, 0, le, 0, 40), VM_ERR_FORMAT,
                "truncated");
    unsigned char junk[4] = {0x78, 0x9c, 0xff, 0xff};
    check_fails(write_patched("vti_corrupt_zlib.vti", &s, 28, junk, 4, -1), VM_ERR_FORMAT,
                "compressed data");
    s.header64 = 1;
    unsigned char big[8];
    put_uint(UINT64_MAX, 8, 0, big);
    check_fails(write_patched("vti_huge_blocks64.vti", &s, 0, big, 8, -1), VM_ERR_FORMAT,
                "blocks");
    put_uint(UINT64_MAX / 2, 8, 0, big);
    check_fails(write_patched("vti_huge_blocksize64.vti", &s, 8, big, 8, -1), VM_ERR_FORMAT,
                "");
}

static void vtiRejectsBadInputWithThePathInTheMessage(void) {
    static const struct {
        const char *name, *text;
        vm_status status;
        const char *fragment;
    } cases[] = {
        {"vti_empty.vti", "", VM_ERR_FORMAT, "empty"},
        {"vti_notxml.vti", "# vtk DataFile Version 3.0\n", VM_ERR_FORMAT, "not a VTK XML"},
        {"vti_otherxml.vti", "<?xml version=\"1.0\"?><svg></svg>", VM_ERR_FORMAT,
         "not a VTK XML"},
        {"vti_badtag.vti", "<VTKFile type=\"ImageData\"><ImageData Origin=\"0 0", VM_ERR_FORMAT,
         "malformed XML"},
        {"vti_nopiece.vti", "<VTKFile type=\"ImageData\"><ImageData/></VTKFile>",
         VM_ERR_FORMAT, "no <Piece>"},
        {"vti_extent.vti",
         "<VTKFile type=\"ImageData\"><ImageData><Piece Extent=\"0 1 0\"/></ImageData>"
         "</VTKFile>",
         VM_ERR_FORMAT, "not 6 whole numbers"},
        {"vti_huge.vti",
         "<VTKFile type=\"ImageData\"><ImageData><Piece Extent=\"0 99999 0 99999 0 "
         "99999\"><PointData><DataArray type=\"Float32\" Name=\"a\" format=\"ascii\">1"
         "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_NOMEM, "memory limit"},
        {"vti_overflow.vti",
         "<VTKFile type=\"ImageData\"><ImageData><Piece Extent=\"0 999999999999 0 "
         "999999999999 0 999999999999\"><PointData><DataArray type=\"Float32\" Name=\"a\" "
         "format=\"ascii\">1</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_NOMEM, "overflow"},
        {"vti_spacing.vti",
         "<VTKFile type=\"ImageData\"><ImageData Spacing=\"1 inf 1\"></ImageData></VTKFile>",
         VM_ERR_FORMAT, "Spacing"},
        {"vti_ascii_short.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"ascii\">1"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "truncated (got 1 of 2 values)"},
        {"vti_ascii_word.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"ascii\">1 two"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "ascii value 1 ('two')"},
        {"vti_base64_garbage.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"binary\">AgAA!AAB"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "invalid base64"},
        {"vti_base64_pad.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"binary\">A===AAAB"
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "invalid base64"},
        {"vti_base64_short.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"binary\">AgAAAA=="
                  "</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "truncated (got 0 of 2 bytes)"},
        {"vti_scalars_missing.vti",
         VTI_HEAD "<PointData Scalars=\"zz\"><DataArray type=\"UInt8\" Name=\"a\" "
                  "format=\"ascii\">1 2</DataArray></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "names no DataArray"},
        {"vti_no_appended.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"appended\" "
                  "offset=\"0\"/></PointData></Piece></ImageData></VTKFile>",
         VM_ERR_FORMAT, "without <AppendedData>"},
        {"vti_offset.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"appended\" "
                  "offset=\"99\"/></PointData></Piece></ImageData>"
                  "<AppendedData encoding=\"raw\">_\x02\x00\x00\x00\x01\x02</AppendedData>",
         VM_ERR_FORMAT, "past the end"},
        {"vti_underscore.vti",
         VTI_HEAD "<PointData><DataArray type=\"UInt8\" Name=\"a\" format=\"appended\" "
                  "offset=\"0\"/></PointData></Piece></ImageData>"
                  "<AppendedData encoding=\"raw\">xyz</AppendedData>",
         VM_ERR_FORMAT, "'_'"},
        {"vti_byteorder.vti", "<VTKFile type=\"ImageData\" byte_order=\"Middle\"></VTKFile>",
         VM_ERR_FORMAT, "byte_order"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        check_fails(write_text(cases[i].name, cases[i].text), cases[i].status,
                    cases[i].fragment);
    check_fails(vm_test_tmp("."), VM_ERR_IO, "directory");
    check_fails(vm_test_tmp("vti_does_not_exist.vti"), VM_ERR_IO, "cannot open");
}

static void vtiCliInfoReportsABadFileOnOneLineAndExitsWith2(void) {
    const char *path = write_text("vti_cli_bad.vti", VTI_HEAD "<PointData><DataArray "
                                  "type=\"UInt8\" Name=\"a\" format=\"binary\">@@@@"
                                  "</DataArray></PointData></Piece></ImageData></VTKFile>");
    vm_test_expect_cli_error(NULL, path, NULL);
    vti_spec s = base_spec();
    s.block = 100;
    const char *good = write_vti("vti_cli_good.vti", &s);
    char args[4200], *out = NULL;
    snprintf(args, sizeof args, "info '%s' --json", good);
    int rc = vm_test_cli(args, &out);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, out ? out : "");
    if (out) {
        CHECK_MSG(strstr(out, "\"dims\": [5, 4, 3]") && strstr(out, "\"format\": \"vti\""),
                  "output: %s", out);
        free(out);
    }
}

TEST_MAIN(T(vtiReadsSharedHydrogenWithReferenceStatistics), T(vtiReadsEveryTypeInEveryEncoding),
          T(vtiReadsZlibCompressedDataInSeveralBlocks),
          T(vtiAppliesDirectionSpacingAndExtentStartToTheGeometry),
          T(vtiSelectsTheActiveScalarsElseTheFirstOneComponentArray),
          T(vtiFindsAppendedArraysByTheirOffsetAfterTheUnderscore),
          T(vtiRefusesUnsupportedFeaturesClearly), T(vtiRejectsLyingHeadersAndTruncatedData),
          T(vtiRejectsBadInputWithThePathInTheMessage),
          T(vtiCliInfoReportsABadFileOnOneLineAndExitsWith2))
