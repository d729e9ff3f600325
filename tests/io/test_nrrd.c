/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_nrrd.c — the NRRD reader against the shared CT head and files written here
 * (every type spelling x endian x encoding, detached data, geometry, skips), the writer's
 * exact round trip, and every kind of bad input reported as "PATH: problem". */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>
#include "test.h"

static const int64_t DIMS[3] = {3, 4, 5};
enum { NVOX = 60 };

/* A value exactly representable in type t and in float, distinct per index; the last voxel
 * holds an extreme of the type. */
static double sample_value(vm_scalar_type t, int i) {
    int last = i == NVOX - 1;
    switch (t) {
    case VM_SCALAR_UINT8: return last ? 255 : (i * 37) % 256;
    case VM_SCALAR_INT8: return last ? -128 : (i * 37) % 256 - 128;
    case VM_SCALAR_UINT16: return last ? 65535 : i * 1100;
    case VM_SCALAR_INT16: return last ? -32768 : i * 1100 - 32000;
    case VM_SCALAR_UINT32: return last ? 4294967040.0 : i * 250000.0;
    case VM_SCALAR_INT32: return last ? -2147483648.0 : (i - 30) * 250000.0;
    case VM_SCALAR_UINT64: return last ? 9223372036854775808.0 : i * 250000.0;
    case VM_SCALAR_INT64: return last ? -9223372036854775808.0 : (i - 30) * 250000.0;
    case VM_SCALAR_FLOAT32: return last ? 3.0e38 : (i - 30) * 0.375;
    case VM_SCALAR_FLOAT64: return last ? 1.0e-30 : (i - 30) * 0.125;
    }
    return 0;
}

/* The NVOX samples of type t in the byte order given; returns the byte count. */
static size_t make_samples(unsigned char *dst, vm_scalar_type t, int big) {
    size_t at = 0;
    for (int i = 0; i < NVOX; i++)
        at += vm_test_put_sample(dst + at, t, big, sample_value(t, i));
    return at;
}

static size_t make_ascii(char *dst, size_t cap, vm_scalar_type t) {
    size_t at = 0;
    for (int i = 0; i < NVOX; i++)
        at += (size_t)snprintf(dst + at, cap - at, "%.17g%s", sample_value(t, i),
                               i % 7 == 6 ? "\n" : " ");
    return at;
}

/* Writes text followed by len bytes of data (gzip-compressed with gzopen when gzip). */
static int write_parts(const char *path, const char *text, const void *data, size_t len,
                       int gzip) {
    FILE *fp = fopen(path, "wb");
    if (!fp) return -1;
    fputs(text, fp);
    if (!gzip) fwrite(data, 1, len, fp);
    if (fclose(fp) != 0) return -1;
    if (!gzip) return 0;
    gzFile gz = gzopen(path, "ab");
    if (!gz) return -1;
    int w = gzwrite(gz, data, (unsigned)len);
    return gzclose(gz) == Z_OK && w == (int)len ? 0 : -1;
}

static int expect_values(const vm_volume *v, vm_scalar_type t) {
    int bad = 0;
    for (int i = 0; i < NVOX && !bad; i++)
        if (v->data[i] != (float)sample_value(t, i)) {
            fprintf(stderr, "  voxel %d of %s: %.9g, expected %.9g\n", i,
                    vm_scalar_type_name(t), v->data[i], (float)sample_value(t, i));
            bad = 1;
        }
    return !bad;
}

static void nrrdReadsSharedCtHeadWithReferenceStatistics(void) {
    const char *path = vm_test_shared("ct_head_quarter.nrrd");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.dims[0] == 64 && v.dims[1] == 64 && v.dims[2] == 93);
    CHECK(v.type == VM_SCALAR_UINT16);
    CHECK(strcmp(v.format, "nrrd") == 0);
    CHECK_NEAR(v.spacing[0], 3.2, 1e-12);
    CHECK_NEAR(v.spacing[1], 3.2, 1e-12);
    CHECK_NEAR(v.spacing[2], 1.5, 1e-12);
    for (int r = 0; r < 3; r++) {
        CHECK_NEAR(v.origin[r], 0.0, 1e-12);
        for (int c = 0; c < 3; c++) CHECK_NEAR(v.direction[r][c], r == c ? 1.0 : 0.0, 1e-12);
    }
    double lo, hi, mean;
    CHECK(vm_volume_stats(&v, &lo, &hi, &mean) == 0);
    CHECK_NEAR(lo, 0.0, 1e-4);
    CHECK_NEAR(hi, 3926.0, 3926.0 * 1e-4);
    CHECK_NEAR(mean, 507.687324, 507.687324 * 1e-4);
    vm_volume_free(&v);
}

/* Every NRRD spelling of every type. */
static const struct {
    const char *spelling;
    vm_scalar_type t;
} spellings[] = {
    {"uchar", VM_SCALAR_UINT8},         {"unsigned char", VM_SCALAR_UINT8},
    {"uint8", VM_SCALAR_UINT8},         {"uint8_t", VM_SCALAR_UINT8},
    {"signed char", VM_SCALAR_INT8},    {"int8", VM_SCALAR_INT8},
    {"int8_t", VM_SCALAR_INT8},         {"short", VM_SCALAR_INT16},
    {"short int", VM_SCALAR_INT16},     {"signed short", VM_SCALAR_INT16},
    {"signed short int", VM_SCALAR_INT16}, {"int16", VM_SCALAR_INT16},
    {"int16_t", VM_SCALAR_INT16},       {"ushort", VM_SCALAR_UINT16},
    {"unsigned short", VM_SCALAR_UINT16}, {"unsigned short int", VM_SCALAR_UINT16},
    {"uint16", VM_SCALAR_UINT16},       {"uint16_t", VM_SCALAR_UINT16},
    {"int", VM_SCALAR_INT32},           {"signed int", VM_SCALAR_INT32},
    {"int32", VM_SCALAR_INT32},         {"int32_t", VM_SCALAR_INT32},
    {"uint", VM_SCALAR_UINT32},         {"unsigned int", VM_SCALAR_UINT32},
    {"uint32", VM_SCALAR_UINT32},       {"uint32_t", VM_SCALAR_UINT32},
    {"longlong", VM_SCALAR_INT64},      {"long long", VM_SCALAR_INT64},
    {"long long int", VM_SCALAR_INT64}, {"signed long long", VM_SCALAR_INT64},
    {"signed long long int", VM_SCALAR_INT64}, {"int64", VM_SCALAR_INT64},
    {"int64_t", VM_SCALAR_INT64},       {"ulonglong", VM_SCALAR_UINT64},
    {"unsigned long long", VM_SCALAR_UINT64}, {"unsigned long long int", VM_SCALAR_UINT64},
    {"uint64", VM_SCALAR_UINT64},       {"uint64_t", VM_SCALAR_UINT64},
    {"float", VM_SCALAR_FLOAT32},       {"double", VM_SCALAR_FLOAT64},
};

static void nrrdReadsEveryTypeSpellingEndianAndEncoding(void) {
    static const char *const encodings[] = {"raw", "gzip", "ascii", "gz", "text", "txt"};
    const char *path = vm_test_tmp("nrrd_types.nrrd");
    int files = 0;
    for (size_t s = 0; s < sizeof spellings / sizeof spellings[0]; s++) {
        vm_scalar_type t = spellings[s].t;
        for (int big = 0; big < 2; big++) {
            for (int e = 0; e < 6; e++) {
                /* all spellings with raw/gzip/ascii; the encoding aliases with one of them */
                if (e >= 3 && s % 6 != 0) continue;
                const char *enc = encodings[e];
                int gz = e == 1 || e == 3, ascii = e == 2 || e == 4 || e == 5;
                unsigned char data[NVOX * 8];
                char text[NVOX * 32];
                size_t n = ascii ? make_ascii(text, sizeof text, t) : make_samples(data, t, big);
                char header[512];
                snprintf(header, sizeof header,
                         "NRRD0005\ntype: %s\ndimension: 3\nsizes: 3 4 5\nendian: %s\n"
                         "encoding: %s\n\n",
                         spellings[s].spelling, big ? "big" : "little", enc);
                CHECK(write_parts(path, header, ascii ? (void *)text : (void *)data, n, gz) == 0);
                vm_volume v;
                vm_error err;
                vm_status st = vm_volume_read_nrrd(path, &v, &err);
                CHECK_MSG(st == VM_OK, "type '%s' %s %s: %s", spellings[s].spelling,
                          big ? "big" : "little", enc, err.message);
                if (st) continue;
                files++;
                CHECK(v.dims[0] == 3 && v.dims[1] == 4 && v.dims[2] == 5);
                CHECK_MSG(v.type == t, "type '%s' read as %s", spellings[s].spelling,
                          vm_scalar_type_name(v.type));
                CHECK_MSG(expect_values(&v, t), "type '%s' %s %s", spellings[s].spelling,
                          big ? "big" : "little", enc);
                CHECK(strcmp(v.format, "nrrd") == 0);
                vm_volume_free(&v);
            }
        }
    }
    CHECK(files > 240);
}

static void nrrdReadsZlibWrappedCompressedData(void) {
    unsigned char data[NVOX * 2], packed[1024];
    size_t n = make_samples(data, VM_SCALAR_INT16, 1);
    uLongf plen = sizeof packed;
    CHECK(compress2(packed, &plen, data, n, 9) == Z_OK);
    const char *path = vm_test_tmp("nrrd_zlib.nrrd");
    CHECK(write_parts(path,
                      "NRRD0004\ntype: short\ndimension: 3\nsizes: 3 4 5\nendian: big\n"
                      "encoding: gzip\n\n",
                      packed, plen, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_INT16));
    vm_volume_free(&v);
}

static void nrrdReadsDetachedDataRelativeToTheHeaderFolder(void) {
    const char *dir = vm_test_tmp("nrrd_detached_dir");
    mkdir(dir, 0755);
    char hdr[4200], raw[4200], gzpath[4200];
    snprintf(hdr, sizeof hdr, "%s/vol.nhdr", dir);
    snprintf(raw, sizeof raw, "%s/vol.raw", dir);
    snprintf(gzpath, sizeof gzpath, "%s/vol.raw.gz", dir);
    unsigned char data[NVOX * 4];
    size_t n = make_samples(data, VM_SCALAR_FLOAT32, 1);
    CHECK(vm_test_write_file(raw, data, n) == 0);
    CHECK(write_parts(hdr,
                      "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 4 5\nendian: big\n"
                      "encoding: raw\ndata file: vol.raw\n",
                      "", 0, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(hdr, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_FLOAT32));
    vm_volume_free(&v);
    /* the other spelling, gzip data, a blank line after the header, through vm_volume_read */
    gzFile gz = gzopen(gzpath, "wb");
    CHECK(gz != NULL);
    if (gz) {
        gzwrite(gz, data, (unsigned)n);
        gzclose(gz);
    }
    CHECK(write_parts(hdr,
                      "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 4 5\nendian: big\n"
                      "encoding: gzip\ndatafile: vol.raw.gz\n\n",
                      "", 0, 0) == 0);
    CHECK_OK(vm_volume_read(hdr, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_FLOAT32));
    vm_volume_free(&v);
}

static void nrrdHonoursByteSkipAndLineSkip(void) {
    unsigned char data[NVOX * 2], buf[NVOX * 2 + 64];
    size_t n = make_samples(data, VM_SCALAR_UINT16, 0);
    vm_volume v;
    vm_error err;
    /* attached: two lines, then 5 bytes, then the samples */
    const char *path = vm_test_tmp("nrrd_skip.nrrd");
    memcpy(buf, "line one\nline two\nabcde", 23);
    memcpy(buf + 23, data, n);
    CHECK(write_parts(path,
                      "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 3 4 5\nendian: little\n"
                      "encoding: raw\nline skip: 2\nbyte skip: 5\n\n",
                      buf, 23 + n, 0) == 0);
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_UINT16));
    vm_volume_free(&v);
    /* byte skip -1: the samples are the last bytes of the data file */
    const char *raw = vm_test_tmp("nrrd_skip_tail.raw");
    memset(buf, 0x5a, 37);
    memcpy(buf + 37, data, n);
    CHECK(vm_test_write_file(raw, buf, 37 + n) == 0);
    path = vm_test_tmp("nrrd_skip_tail.nhdr");
    CHECK(write_parts(path,
                      "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 3 4 5\nendian: little\n"
                      "encoding: raw\nbyte skip: -1\ndata file: nrrd_skip_tail.raw\n",
                      "", 0, 0) == 0);
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_UINT16));
    vm_volume_free(&v);
    /* gzip: byte skip counts decompressed bytes */
    memcpy(buf, "0123456", 7);
    memcpy(buf + 7, data, n);
    path = vm_test_tmp("nrrd_skip_gz.nrrd");
    CHECK(write_parts(path,
                      "NRRD0004\ntype: ushort\ndimension: 3\nsizes: 3 4 5\nendian: little\n"
                      "encoding: gzip\nbyte skip: 7\n\n",
                      buf, 7 + n, 1) == 0);
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_UINT16));
    vm_volume_free(&v);
}

static void nrrdReadsSpaceDirectionsWithRotationAndOrigin(void) {
    /* 30 degrees about z; spacings 0.5, 0.75, 2 */
    const double c = 0.86602540378443865, s = 0.5;
    const double sp[3] = {0.5, 0.75, 2.0};
    const double dir[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}};
    char header[1024];
    snprintf(header, sizeof header,
             "NRRD0004\ntype: uchar\ndimension: 3\nspace: left-posterior-superior\n"
             "sizes: 3 4 5\nspace directions: (%.17g,%.17g,%.17g) (%.17g,%.17g,%.17g) "
             "(%.17g,%.17g,%.17g)\nkinds: domain domain domain\nencoding: raw\n"
             "space origin: (10,-5.5,3.25)\n\n",
             dir[0][0] * sp[0], dir[1][0] * sp[0], dir[2][0] * sp[0], dir[0][1] * sp[1],
             dir[1][1] * sp[1], dir[2][1] * sp[1], dir[0][2] * sp[2], dir[1][2] * sp[2],
             dir[2][2] * sp[2]);
    unsigned char data[NVOX];
    make_samples(data, VM_SCALAR_UINT8, 0);
    const char *path = vm_test_tmp("nrrd_rotated.nrrd");
    CHECK(write_parts(path, header, data, NVOX, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (!v.data) return;
    for (int a = 0; a < 3; a++) CHECK_NEAR(v.spacing[a], sp[a], 1e-12);
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) CHECK_NEAR(v.direction[r][k], dir[r][k], 1e-12);
    CHECK_NEAR(v.origin[0], 10.0, 0);
    CHECK_NEAR(v.origin[1], -5.5, 0);
    CHECK_NEAR(v.origin[2], 3.25, 0);
    double ijk[3] = {1, 0, 0}, xyz[3];
    vm_volume_index_to_world(&v, ijk, xyz);
    CHECK_NEAR(xyz[0], 10.0 + 0.5 * c, 1e-12);
    CHECK_NEAR(xyz[1], -5.5 + 0.5 * s, 1e-12);
    CHECK(expect_values(&v, VM_SCALAR_UINT8));
    vm_volume_free(&v);
}

static void nrrdReadsSpacingsWithoutSpaceFlippingNegativeAndUnitForNan(void) {
    unsigned char data[NVOX];
    make_samples(data, VM_SCALAR_INT8, 0);
    const char *path = vm_test_tmp("nrrd_spacings.nrrd");
    CHECK(write_parts(path,
                      "NRRD0001\ntype: signed char\ndimension: 3\nsizes: 3 4 5\n"
                      "spacings: 0.25 -2 1.5\nencoding: raw\n\n",
                      data, NVOX, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (!v.data) return;
    CHECK_NEAR(v.spacing[0], 0.25, 0);
    CHECK_NEAR(v.spacing[1], 2.0, 0);
    CHECK_NEAR(v.spacing[2], 1.5, 0);
    CHECK_NEAR(v.direction[0][0], 1.0, 0);
    CHECK_NEAR(v.direction[1][1], -1.0, 0);
    CHECK_NEAR(v.direction[2][2], 1.0, 0);
    CHECK(expect_values(&v, VM_SCALAR_INT8));
    vm_volume_free(&v);
    /* NaN means "spacing unknown": unit spacing */
    CHECK(write_parts(path,
                      "NRRD0001\ntype: int8\ndimension: 3\nsizes: 3 4 5\n"
                      "spacings: nan 3 NaN\nencoding: raw\n\n",
                      data, NVOX, 0) == 0);
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.spacing[0] == 1.0 && v.spacing[1] == 3.0 && v.spacing[2] == 1.0);
    vm_volume_free(&v);
}

static void nrrdAcceptsFourDimensionsWithALeadingAxisOfOne(void) {
    unsigned char data[NVOX * 8];
    size_t n = make_samples(data, VM_SCALAR_FLOAT64, 0);
    const char *path = vm_test_tmp("nrrd_4d.nrrd");
    CHECK(write_parts(path,
                      "NRRD0004\ntype: double\ndimension: 4\nspace dimension: 3\n"
                      "sizes: 1 3 4 5\nspace directions: none (2,0,0) (0,3,0) (0,0,4)\n"
                      "kinds: scalar domain domain domain\nendian: little\nencoding: raw\n\n",
                      data, n, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.dims[0] == 3 && v.dims[1] == 4 && v.dims[2] == 5);
    CHECK_NEAR(v.spacing[0], 2.0, 0);
    CHECK_NEAR(v.spacing[1], 3.0, 0);
    CHECK_NEAR(v.spacing[2], 4.0, 0);
    CHECK(expect_values(&v, VM_SCALAR_FLOAT64));
    vm_volume_free(&v);
}

static void nrrdIgnoresCommentsKeyValuesAndCrLfLineEnds(void) {
    unsigned char data[NVOX];
    make_samples(data, VM_SCALAR_UINT8, 0);
    const char *path = vm_test_tmp("nrrd_crlf.nrrd");
    CHECK(write_parts(path,
                      "NRRD0005\r\n# a comment: with a colon\r\nmodality:=CT\r\n"
                      "type: uint8\r\ncontent: anything: at all\r\ndimension: 3\r\n"
                      "sizes: 3 4 5\r\nencoding: raw\r\nsome future field: 1 2 3\r\n\r\n",
                      data, NVOX, 0) == 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nrrd(path, &v, &err), &err);
    if (v.data) CHECK(expect_values(&v, VM_SCALAR_UINT8));
    vm_volume_free(&v);
}

static void nrrdWriteReadRoundTripIsExact(void) {
    vm_volume v, w;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, DIMS, &err), &err);
    if (!v.data) return;
    for (int i = 0; i < NVOX; i++) v.data[i] = (float)((i - 20) * 0.1);
    v.data[0] = -0.0f;
    v.data[1] = 1e-40f; /* subnormal */
    v.data[2] = 3.4e38f;
    v.data[3] = NAN;
    const double c = 0.6, s = 0.8;
    const double dir[3][3] = {{c, 0, -s}, {0, 1, 0}, {s, 0, c}};
    memcpy(v.direction, dir, sizeof dir);
    v.spacing[0] = 0.1;
    v.spacing[1] = 1.0 / 3.0;
    v.spacing[2] = 7.25;
    v.origin[0] = -1e-3;
    v.origin[1] = 123.456;
    v.origin[2] = 1e10;
    for (int gzip = 0; gzip < 2; gzip++) {
        const char *path = vm_test_tmp(gzip ? "nrrd_roundtrip_gz.nrrd" : "nrrd_roundtrip.nrrd");
        CHECK_OK(vm_volume_write_nrrd(path, &v, gzip, &err), &err);
        CHECK_OK(vm_volume_read(path, &w, &err), &err);
        if (!w.data) continue;
        CHECK(w.type == VM_SCALAR_FLOAT32);
        CHECK(memcmp(w.dims, v.dims, sizeof v.dims) == 0);
        CHECK(memcmp(w.data, v.data, NVOX * sizeof(float)) == 0);
        for (int a = 0; a < 3; a++) {
            CHECK_NEAR(w.spacing[a], v.spacing[a], 1e-14 * v.spacing[a]);
            CHECK(w.origin[a] == v.origin[a]);
            for (int r = 0; r < 3; r++) CHECK_NEAR(w.direction[r][a], v.direction[r][a], 1e-15);
        }
        vm_volume_free(&w);
    }
    vm_volume_free(&v);
}

/* Names in the temp folder starting with prefix. */
static int count_with_prefix(const char *prefix) {
    DIR *d = opendir(vm_test_tmp("."));
    if (!d) return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0) n++;
    closedir(d);
    return n;
}

static void nrrdWriterLeavesNoTempFileWhenItFails(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, DIMS, &err), &err);
    if (!v.data) return;
    memset(v.data, 0, NVOX * sizeof(float));
    /* a missing folder: fails at once */
    const char *missing = vm_test_tmp("nrrd_no_such_dir/out.nrrd");
    vm_status st = vm_volume_write_nrrd(missing, &v, 1, &err);
    CHECK(st == VM_ERR_IO);
    CHECK_MSG(strncmp(err.message, missing, strlen(missing)) == 0, "%s", err.message);
    CHECK(!vm_test_exists(missing));
    /* the target is a folder: the data is written, the final rename fails */
    const char *target = vm_test_tmp("nrrd_target_dir.nrrd");
    mkdir(target, 0755);
    char inside[4200];
    snprintf(inside, sizeof inside, "%s/keep", target);
    CHECK(vm_test_write_file(inside, "x", 1) == 0);
    st = vm_volume_write_nrrd(target, &v, 0, &err);
    CHECK(st == VM_ERR_IO);
    CHECK_MSG(strncmp(err.message, target, strlen(target)) == 0, "%s", err.message);
    CHECK(count_with_prefix("nrrd_target_dir.nrrd.tmp") == 0);
    vm_volume_free(&v);
}

/* Bad inputs: the file's bytes, the status and a phrase of the message. */
static const struct {
    const char *name;
    const char *text;
    vm_status status;
    const char *phrase;
} bad_inputs[] = {
    {"nrrd_bad_empty.nrrd", "", VM_ERR_FORMAT, "empty"},
    {"nrrd_bad_magic.nrrd", "P5\n3 4\n255\n", VM_ERR_FORMAT, "not a NRRD file"},
    {"nrrd_bad_version.nrrd", "NRRD0009\ntype: uchar\n", VM_ERR_UNSUPPORTED, "version"},
    {"nrrd_bad_type.nrrd",
     "NRRD0004\ntype: quaternion\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "unknown type 'quaternion'"},
    {"nrrd_bad_block.nrrd",
     "NRRD0004\ntype: block\nblock size: 4\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\nxxxx",
     VM_ERR_UNSUPPORTED, "block"},
    {"nrrd_bad_encoding.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: zip\n\nx", VM_ERR_FORMAT,
     "unknown encoding 'zip'"},
    {"nrrd_bad_bzip2.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: bzip2\n\nx",
     VM_ERR_UNSUPPORTED, "encoding 'bzip2' is not supported"},
    {"nrrd_bad_hex.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: hex\n\n00",
     VM_ERR_UNSUPPORTED, "encoding 'hex' is not supported"},
    {"nrrd_bad_dim2.nrrd", "NRRD0004\ntype: uchar\ndimension: 2\nsizes: 2 2\nencoding: raw\n\nxxxx",
     VM_ERR_UNSUPPORTED, "dimension 2 is not supported"},
    {"nrrd_bad_vector.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 4\nsizes: 3 1 1 1\nencoding: raw\n\nxxx",
     VM_ERR_UNSUPPORTED, "dimension 4"},
    {"nrrd_bad_truncated_raw.nrrd",
     "NRRD0004\ntype: short\ndimension: 3\nsizes: 4 4 4\nendian: little\nencoding: raw\n\n"
     "only twenty bytes...",
     VM_ERR_FORMAT, "data is truncated (20 of 128 bytes)"},
    {"nrrd_bad_no_data.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n",
     VM_ERR_FORMAT, "no blank line"},
    {"nrrd_bad_overflow.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4294967296 4294967296 4294967296\n"
     "encoding: raw\n\nx",
     VM_ERR_NOMEM, "overflow"},
    {"nrrd_bad_huge.nrrd",
     "NRRD0004\ntype: float\ndimension: 3\nsizes: 100000 100000 100000\nendian: little\n"
     "encoding: raw\n\nx",
     VM_ERR_NOMEM, "memory limit"},
    {"nrrd_bad_size_range.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 99999999999999999999 1 1\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "sizes"},
    {"nrrd_bad_zero_size.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 0 2\nencoding: raw\n\nxxxx", VM_ERR_FORMAT,
     "must be >= 1"},
    {"nrrd_bad_sizes_count.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2\nencoding: raw\n\nxxxx", VM_ERR_FORMAT,
     "must be 3 integers"},
    {"nrrd_bad_no_sizes.nrrd", "NRRD0004\ntype: uchar\ndimension: 3\nencoding: raw\n\nxxxx",
     VM_ERR_FORMAT, "missing 'sizes'"},
    {"nrrd_bad_no_endian.nrrd",
     "NRRD0004\ntype: int\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n\nxxxx", VM_ERR_FORMAT,
     "missing 'endian'"},
    {"nrrd_bad_endian.nrrd",
     "NRRD0004\ntype: int\ndimension: 3\nsizes: 1 1 1\nendian: middle\nencoding: raw\n\nxxxx",
     VM_ERR_FORMAT, "endian 'middle'"},
    {"nrrd_bad_twice.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nsizes: 2 2 2\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "appears twice"},
    {"nrrd_bad_line.nrrd", "NRRD0004\ntype: uchar\nthis is not a field\n\nx", VM_ERR_FORMAT,
     "line 3"},
    {"nrrd_bad_directions.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nspace: RAS\nsizes: 1 1 1\n"
     "space directions: (1,0,0) (0,1) (0,0,1)\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "space directions"},
    {"nrrd_bad_zero_direction.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nspace: RAS\nsizes: 1 1 1\n"
     "space directions: (1,0,0) (0,0,0) (0,0,1)\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "zero-length"},
    {"nrrd_bad_no_space.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\n"
     "space directions: (1,0,0) (0,1,0) (0,0,1)\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "need a 'space'"},
    {"nrrd_bad_space_time.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nspace: RAST\nsizes: 1 1 1\nencoding: raw\n\nx",
     VM_ERR_UNSUPPORTED, "space dimension 4"},
    {"nrrd_bad_origin.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nspace dimension: 3\nsizes: 1 1 1\n"
     "space origin: (1,2)\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "space origin"},
    {"nrrd_bad_spacing.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nspacings: 1 0 1\nencoding: raw\n\nx",
     VM_ERR_FORMAT, "spacing of axis 1"},
    {"nrrd_bad_ascii_word.nrrd",
     "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n1.5 banana\n",
     VM_ERR_FORMAT, "ascii value 1 ('banana')"},
    {"nrrd_bad_ascii_short.nrrd",
     "NRRD0004\ntype: float\ndimension: 3\nsizes: 3 1 1\nencoding: ascii\n\n1 2   \n",
     VM_ERR_FORMAT, "truncated (2 of 3 ascii values)"},
    {"nrrd_bad_gzip_skip.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: gzip\nbyte skip: -1\n\nx",
     VM_ERR_FORMAT, "byte skip -1"},
    {"nrrd_bad_line_skip.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\nline skip: 3\n\nx\n",
     VM_ERR_FORMAT, "line skip 3"},
    {"nrrd_bad_gzip_garbage.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: gzip\n\nnot compressed",
     VM_ERR_FORMAT, "compressed data"},
    {"nrrd_bad_gzip_lies.nrrd",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 200 200 200\nencoding: gzip\n\nxx",
     VM_ERR_FORMAT, "compressed data is truncated"},
    {"nrrd_bad_missing_detached.nhdr",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
     "data file: nrrd_no_such_file.raw\n",
     VM_ERR_IO, "cannot read data file"},
    {"nrrd_bad_data_list.nhdr",
     "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n"
     "data file: slice%03d.raw 1 2 1\n",
     VM_ERR_UNSUPPORTED, "multiple data files"},
};

/* The reader and `volmesh info` both refuse path with a one-line "PATH: ..." message. */
static void check_bad(const char *path, vm_status want, const char *phrase) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_nrrd(path, &v, &err);
    vm_test_expect_refusal(path, st, want, &err, phrase, &v);
    vm_volume_free(&v);
    vm_test_expect_cli_error(NULL, path, NULL);
}

static void nrrdRejectsBadInputsWithThePathInAOneLineMessage(void) {
    for (size_t i = 0; i < sizeof bad_inputs / sizeof bad_inputs[0]; i++) {
        const char *path = vm_test_tmp(bad_inputs[i].name);
        CHECK(vm_test_write_file(path, bad_inputs[i].text, strlen(bad_inputs[i].text)) == 0);
        check_bad(path, bad_inputs[i].status, bad_inputs[i].phrase);
    }
}

static void nrrdRejectsMissingFilesDirectoriesAndTruncatedGzip(void) {
    check_bad(vm_test_tmp("nrrd_does_not_exist.nrrd"), VM_ERR_IO, "cannot open");
    const char *dir = vm_test_tmp("nrrd_a_directory.nrrd");
    mkdir(dir, 0755);
    check_bad(dir, VM_ERR_IO, "directory");
    /* a detached data file that is a directory */
    const char *hdr = vm_test_tmp("nrrd_data_is_dir.nhdr");
    CHECK(write_parts(hdr,
                      "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 1 1 1\nencoding: raw\n"
                      "data file: nrrd_a_directory.nrrd\n",
                      "", 0, 0) == 0);
    check_bad(hdr, VM_ERR_IO, "directory");
    /* a gzip stream cut in half, and a header whose sizes exceed the compressed data */
    unsigned char data[NVOX * 8], packed[2048];
    size_t n = make_samples(data, VM_SCALAR_FLOAT64, 0);
    const char *full = vm_test_tmp("nrrd_full_gz.nrrd");
    const char *head = "NRRD0004\ntype: double\ndimension: 3\nsizes: 3 4 5\nendian: little\n"
                       "encoding: gzip\n\n";
    CHECK(write_parts(full, head, data, n, 1) == 0);
    FILE *fp = fopen(full, "rb");
    size_t got = fp ? fread(packed, 1, sizeof packed, fp) : 0;
    if (fp) fclose(fp);
    const char *cut = vm_test_tmp("nrrd_bad_cut_gz.nrrd");
    CHECK(vm_test_write_file(cut, packed, strlen(head) + (got - strlen(head)) / 2) == 0);
    check_bad(cut, VM_ERR_FORMAT, "compressed data is truncated");
    const char *lies = vm_test_tmp("nrrd_bad_lying_gz.nrrd");
    CHECK(write_parts(lies,
                      "NRRD0004\ntype: double\ndimension: 3\nsizes: 3 4 6\nendian: little\n"
                      "encoding: gzip\n\n",
                      data, n, 1) == 0);
    check_bad(lies, VM_ERR_FORMAT, "compressed data is truncated (got 480 of 576 bytes)");
    /* a detached raw file shorter than the header says */
    const char *raw = vm_test_tmp("nrrd_short.raw");
    CHECK(vm_test_write_file(raw, data, 100) == 0);
    hdr = vm_test_tmp("nrrd_short.nhdr");
    CHECK(write_parts(hdr,
                      "NRRD0004\ntype: double\ndimension: 3\nsizes: 3 4 5\nendian: little\n"
                      "encoding: raw\ndata file: nrrd_short.raw\n",
                      "", 0, 0) == 0);
    check_bad(hdr, VM_ERR_FORMAT, "data is truncated (100 of 480 bytes)");
}

TEST_MAIN(T(nrrdReadsSharedCtHeadWithReferenceStatistics),
          T(nrrdReadsEveryTypeSpellingEndianAndEncoding),
          T(nrrdReadsZlibWrappedCompressedData),
          T(nrrdReadsDetachedDataRelativeToTheHeaderFolder),
          T(nrrdHonoursByteSkipAndLineSkip),
          T(nrrdReadsSpaceDirectionsWithRotationAndOrigin),
          T(nrrdReadsSpacingsWithoutSpaceFlippingNegativeAndUnitForNan),
          T(nrrdAcceptsFourDimensionsWithALeadingAxisOfOne),
          T(nrrdIgnoresCommentsKeyValuesAndCrLfLineEnds),
          T(nrrdWriteReadRoundTripIsExact),
          T(nrrdWriterLeavesNoTempFileWhenItFails),
          T(nrrdRejectsBadInputsWithThePathInAOneLineMessage),
          T(nrrdRejectsMissingFilesDirectoriesAndTruncatedGzip))
