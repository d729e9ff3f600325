/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_nifti.c — the NIfTI-1/NIfTI-2 reader: the shared MNI brain against VTK's
 * statistics, files written here for every datatype, byte order, container and geometry
 * method, and every kind of bad input. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>
#include "io/io_util.h"
#include "test.h"

/* ---- a tiny NIfTI writer (offsets from nifti1.h / nifti2.h) ---- */

typedef struct spec {
    int version;          /* 1 or 2 */
    int big_endian;
    int pair;             /* .hdr/.img (magic ni1/ni2) instead of one file */
    int datatype;
    int64_t dim[8];
    double pixdim[8];
    double scl_slope, scl_inter;
    int qform_code, sform_code;
    double quatern[6];
    double srow[3][4];
    int64_t vox_offset;   /* 0: default (352 / 544 for one file, 0 for a pair) */
} spec;

/* Stores n bytes of value at p in the spec's byte order. */
static void put(unsigned char *p, const void *value, size_t n, int big_endian) {
    unsigned char tmp[8];
    memcpy(tmp, value, n);
    int swap = big_endian == vm__host_little_endian();
    for (size_t i = 0; i < n; i++) p[i] = swap ? tmp[n - 1 - i] : tmp[i];
}
static void put16(unsigned char *p, int v, int be) {
    int16_t x = (int16_t)v;
    put(p, &x, 2, be);
}
static void put32(unsigned char *p, int v, int be) {
    int32_t x = v;
    put(p, &x, 4, be);
}
static void put64(unsigned char *p, int64_t v, int be) {
    put(p, &v, 8, be);
}
static void putf(unsigned char *p, double v, int be) {
    float x = (float)v;
    put(p, &x, 4, be);
}
static void putd(unsigned char *p, double v, int be) {
    put(p, &v, 8, be);
}

static spec default_spec(int datatype, int nx, int ny, int nz) {
    spec s;
    memset(&s, 0, sizeof s);
    s.version = 1;
    s.datatype = datatype;
    s.dim[0] = 3;
    s.dim[1] = nx;
    s.dim[2] = ny;
    s.dim[3] = nz;
    for (int i = 4; i < 8; i++) s.dim[i] = 1;
    for (int i = 0; i < 8; i++) s.pixdim[i] = 1.0;
    return s;
}

/* The scalar type a NIfTI datatype code is written as here; unsupported codes as float32. */
static vm_scalar_type scalar_of(int datatype) {
    switch (datatype) {
    case 2: return VM_SCALAR_UINT8;
    case 256: return VM_SCALAR_INT8;
    case 4: return VM_SCALAR_INT16;
    case 512: return VM_SCALAR_UINT16;
    case 8: return VM_SCALAR_INT32;
    case 768: return VM_SCALAR_UINT32;
    case 1024: return VM_SCALAR_INT64;
    case 1280: return VM_SCALAR_UINT64;
    case 64: return VM_SCALAR_FLOAT64;
    default: return VM_SCALAR_FLOAT32; /* 16, and the unsupported codes */
    }
}

/* Builds header (+ data when single file) into *out; for a pair, the data goes to *img.
 * values has nvox entries (or NULL: no data at all). */
static unsigned char *build(const spec *s, const double *values, size_t nvox, size_t *out_len,
                            unsigned char **img, size_t *img_len) {
    int be = s->big_endian;
    size_t hsize = s->version == 1 ? 348 : 540;
    size_t esize = vm_scalar_type_size(scalar_of(s->datatype));
    int64_t vo = s->vox_offset ? s->vox_offset : (s->pair ? 0 : (int64_t)hsize + 4);
    size_t data_bytes = values ? nvox * esize : 0;
    size_t len = s->pair ? hsize : (size_t)vo + data_bytes;
    if (len < hsize) len = hsize; /* a vox_offset inside the header (a bad-input case) */
    unsigned char *h = calloc(len + 1, 1);
    if (s->version == 1) {
        put32(h, 348, be);
        for (int i = 0; i < 8; i++) {
            put16(h + 40 + 2 * i, (int)s->dim[i], be);
            putf(h + 76 + 4 * i, s->pixdim[i], be);
        }
        put16(h + 70, s->datatype, be);
        put16(h + 72, (int)(8 * esize), be);
        putf(h + 108, (double)vo, be);
        putf(h + 112, s->scl_slope, be);
        putf(h + 116, s->scl_inter, be);
        put16(h + 252, s->qform_code, be);
        put16(h + 254, s->sform_code, be);
        for (int i = 0; i < 6; i++) putf(h + 256 + 4 * i, s->quatern[i], be);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) putf(h + 280 + 16 * r + 4 * c, s->srow[r][c], be);
        memcpy(h + 344, s->pair ? "ni1" : "n+1", 4);
    } else {
        put32(h, 540, be);
        memcpy(h + 4, s->pair ? "ni2\0\r\n\032\n" : "n+2\0\r\n\032\n", 8);
        put16(h + 12, s->datatype, be);
        put16(h + 14, (int)(8 * esize), be);
        for (int i = 0; i < 8; i++) {
            put64(h + 16 + 8 * i, s->dim[i], be);
            putd(h + 104 + 8 * i, s->pixdim[i], be);
        }
        put64(h + 168, vo, be);
        putd(h + 176, s->scl_slope, be);
        putd(h + 184, s->scl_inter, be);
        put32(h + 344, s->qform_code, be);
        put32(h + 348, s->sform_code, be);
        for (int i = 0; i < 6; i++) putd(h + 352 + 8 * i, s->quatern[i], be);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) putd(h + 400 + 32 * r + 8 * c, s->srow[r][c], be);
    }
    unsigned char *d = s->pair ? calloc((size_t)vo + data_bytes + 1, 1) : h + vo;
    if (!s->pair && (size_t)vo + data_bytes > len) values = NULL;
    for (size_t i = 0; values && i < nvox; i++)
        vm_test_put_sample(d + i * esize, scalar_of(s->datatype), be, values[i]);
    *out_len = len;
    if (s->pair) {
        *img = d;
        *img_len = (size_t)vo + data_bytes;
    }
    return h;
}

static int write_gz(const char *path, const void *data, size_t len) {
    gzFile gz = gzopen(path, "wb");
    if (!gz) return -1;
    int w = gzwrite(gz, data, (unsigned)len);
    return gzclose(gz) == Z_OK && (size_t)w == len ? 0 : -1;
}

/* Writes s (with values) to path; a pair writes path (.hdr) and the .img beside it. */
static void write_nifti(const char *path, const spec *s, const double *values, size_t nvox) {
    size_t len, img_len = 0;
    unsigned char *img = NULL;
    unsigned char *h = build(s, values, nvox, &len, &img, &img_len);
    int gz = strlen(path) > 3 && strcmp(path + strlen(path) - 3, ".gz") == 0;
    CHECK((gz ? write_gz(path, h, len) : vm_test_write_file(path, h, len)) == 0);
    if (img) {
        char ipath[4096];
        snprintf(ipath, sizeof ipath, "%s", path);
        memcpy(ipath + strlen(ipath) - 4, ".img", 4);
        CHECK(vm_test_write_file(ipath, img, img_len) == 0);
        free(img);
    }
    free(h);
}

/* ---- shared data ---- */

static void niftiReadsSharedBrainWithReferenceStatistics(void) {
    const char *p = vm_test_shared("avg152T1_RL_nifti.nii.gz");
    if (!p) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(p, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.dims[0] == 91 && v.dims[1] == 109 && v.dims[2] == 91);
    CHECK(v.type == VM_SCALAR_UINT8);
    CHECK(strcmp(v.format, "nifti") == 0);
    for (int a = 0; a < 3; a++) CHECK_NEAR(v.spacing[a], 2.0, 1e-9);
    CHECK_NEAR(v.origin[0], -90.0, 1e-6);
    CHECK_NEAR(v.origin[1], -126.0, 1e-6);
    CHECK_NEAR(v.origin[2], -72.0, 1e-6);
    double mn, mx, mean;
    CHECK(vm_volume_stats(&v, &mn, &mx, &mean) == 0);
    CHECK_NEAR(mn, 0.0, 1e-9);
    CHECK_NEAR(mx, 255.0, 255.0 * 1e-4);
    CHECK_NEAR(mean, 82.897162, 82.897162 * 1e-4);
    vm_volume_free(&v);
}

/* ---- every datatype, both byte orders, NIfTI-1 and NIfTI-2 ---- */

static void niftiReadsEveryDatatypeInBothByteOrdersAndVersions(void) {
    static const struct {
        int code;
        vm_scalar_type type;
        double lo, hi;
    } table[] = {
        {2, VM_SCALAR_UINT8, 0, 255},        {256, VM_SCALAR_INT8, -128, 127},
        {4, VM_SCALAR_INT16, -32768, 32767}, {512, VM_SCALAR_UINT16, 0, 65535},
        {8, VM_SCALAR_INT32, -2000000, 2000000}, {768, VM_SCALAR_UINT32, 0, 4000000},
        {1024, VM_SCALAR_INT64, -5000000, 5000000}, {1280, VM_SCALAR_UINT64, 0, 9000000},
        {16, VM_SCALAR_FLOAT32, -1.5, 2.25}, {64, VM_SCALAR_FLOAT64, -1e6, 0.125},
    };
    double values[2 * 3 * 4];
    for (size_t t = 0; t < sizeof table / sizeof table[0]; t++) {
        for (int i = 0; i < 24; i++) values[i] = (double)(i % 7);
        values[0] = table[t].lo;
        values[23] = table[t].hi;
        for (int version = 1; version <= 2; version++) {
            for (int be = 0; be <= 1; be++) {
                spec s = default_spec(table[t].code, 2, 3, 4);
                s.version = version;
                s.big_endian = be;
                const char *p = vm_test_tmp("types.nii");
                write_nifti(p, &s, values, 24);
                vm_volume v;
                vm_error err;
                CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
                if (!v.data) continue;
                CHECK_MSG(v.type == table[t].type, "datatype %d", table[t].code);
                CHECK(v.dims[0] == 2 && v.dims[1] == 3 && v.dims[2] == 4);
                for (int i = 0; i < 24; i++)
                    CHECK_MSG(v.data[i] == (float)values[i], "datatype %d v%d be%d i%d: %g",
                              table[t].code, version, be, i, (double)v.data[i]);
                vm_volume_free(&v);
            }
        }
    }
}

static void niftiReadsGzipAndHeaderImagePairs(void) {
    double values[27];
    for (int i = 0; i < 27; i++) values[i] = i * 3;
    for (int version = 1; version <= 2; version++) {
        spec s = default_spec(4, 3, 3, 3);
        s.version = version;
        const char *gz = vm_test_tmp("gz.nii.gz");
        write_nifti(gz, &s, values, 27);
        s.pair = 1;
        s.big_endian = 1;
        const char *hdr = vm_test_tmp("pair.hdr");
        write_nifti(hdr, &s, values, 27);
        const char *img = vm_test_tmp("pair.img");
        const char *paths[3] = {gz, hdr, img};
        for (int k = 0; k < 3; k++) {
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_volume_read(paths[k], &v, &err), &err);
            if (!v.data) continue;
            CHECK(v.dims[0] == 3 && v.dims[2] == 3);
            CHECK(v.data[26] == 78.0f && v.data[5] == 15.0f);
            CHECK(strcmp(v.format, "nifti") == 0);
            vm_volume_free(&v);
        }
    }
}

static void niftiAcceptsTrailingUnitDimensionsAndRefusesTimeSeries(void) {
    double values[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    spec s = default_spec(2, 2, 2, 2);
    s.dim[0] = 5;
    const char *p = vm_test_tmp("unit4d.nii");
    write_nifti(p, &s, values, 8);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
    vm_volume_free(&v);

    s.dim[4] = 2;
    p = vm_test_tmp("series.nii");
    write_nifti(p, &s, values, 8);
    vm_status st = vm_volume_read_nifti(p, &v, &err);
    vm_test_expect_refusal(p, st, VM_ERR_UNSUPPORTED, &err, "dim[4]", &v);

    s = default_spec(2, 2, 2, 1);
    s.dim[0] = 2;
    p = vm_test_tmp("slice2d.nii");
    write_nifti(p, &s, values, 4);
    st = vm_volume_read_nifti(p, &v, &err);
    vm_test_expect_refusal(p, st, VM_ERR_UNSUPPORTED, &err, "dim[0]", &v);
}

/* ---- geometry ---- */

static void niftiPrefersSformOverQform(void) {
    /* sform: index axes i -> -y (spacing 2), j -> +x (spacing 3), k -> +z (spacing 4). */
    spec s = default_spec(2, 2, 2, 2);
    s.sform_code = 1;
    s.qform_code = 1;
    double srow[3][4] = {{0, 3, 0, 10}, {-2, 0, 0, 20}, {0, 0, 4, 30}};
    memcpy(s.srow, srow, sizeof srow);
    s.quatern[3] = 99; /* a qform that must be ignored */
    double values[8] = {0};
    const char *p = vm_test_tmp("sform.nii");
    write_nifti(p, &s, values, 8);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
    if (!v.data) return;
    CHECK_NEAR(v.spacing[0], 2, 1e-6);
    CHECK_NEAR(v.spacing[1], 3, 1e-6);
    CHECK_NEAR(v.spacing[2], 4, 1e-6);
    CHECK_NEAR(v.origin[0], 10, 1e-6);
    CHECK_NEAR(v.origin[1], 20, 1e-6);
    CHECK_NEAR(v.origin[2], 30, 1e-6);
    double expect[3][3] = {{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}};
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) CHECK_NEAR(v.direction[r][c], expect[r][c], 1e-6);
    double ijk[3] = {1, 1, 1}, xyz[3];
    vm_volume_index_to_world(&v, ijk, xyz);
    CHECK_NEAR(xyz[0], 13, 1e-6);
    CHECK_NEAR(xyz[1], 18, 1e-6);
    CHECK_NEAR(xyz[2], 34, 1e-6);
    vm_volume_free(&v);
}

static void niftiReadsQformRotationAndQfac(void) {
    /* 90 degrees about z: quaternion (a, b, c, d) = (cos 45, 0, 0, sin 45); the rotation maps
     * i -> +y, j -> -x, k -> +z; qfac = -1 flips k to -z. */
    for (int version = 1; version <= 2; version++) {
        spec s = default_spec(2, 2, 2, 2);
        s.version = version;
        s.qform_code = 1;
        s.quatern[2] = sqrt(0.5);
        s.quatern[3] = -5;
        s.quatern[4] = 6;
        s.quatern[5] = 7;
        s.pixdim[0] = -1;
        s.pixdim[1] = 1.5;
        s.pixdim[2] = 2.5;
        s.pixdim[3] = 3.5;
        double values[8] = {0};
        const char *p = vm_test_tmp("qform.nii");
        write_nifti(p, &s, values, 8);
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
        if (!v.data) continue;
        CHECK_NEAR(v.spacing[0], 1.5, 1e-6);
        CHECK_NEAR(v.spacing[1], 2.5, 1e-6);
        CHECK_NEAR(v.spacing[2], 3.5, 1e-6);
        CHECK_NEAR(v.origin[0], -5, 1e-6);
        CHECK_NEAR(v.origin[1], 6, 1e-6);
        CHECK_NEAR(v.origin[2], 7, 1e-6);
        double expect[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, -1}};
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) CHECK_NEAR(v.direction[r][c], expect[r][c], 1e-6);
        CHECK(vm_volume_frame_determinant(&v) < 0);
        vm_volume_free(&v);
    }
}

static void niftiFallsBackToPixdimWithoutTransforms(void) {
    spec s = default_spec(2, 2, 2, 2);
    s.pixdim[1] = 0.5;
    s.pixdim[2] = 0.0; /* missing: becomes 1 */
    s.pixdim[3] = 2.0;
    s.quatern[3] = 42; /* qform_code 0: ignored */
    double values[8] = {0};
    const char *p = vm_test_tmp("pixdim.nii");
    write_nifti(p, &s, values, 8);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
    if (!v.data) return;
    CHECK_NEAR(v.spacing[0], 0.5, 1e-9);
    CHECK_NEAR(v.spacing[1], 1.0, 1e-9);
    CHECK_NEAR(v.spacing[2], 2.0, 1e-9);
    for (int r = 0; r < 3; r++) {
        CHECK(v.origin[r] == 0.0);
        for (int c = 0; c < 3; c++) CHECK(v.direction[r][c] == (r == c ? 1.0 : 0.0));
    }
    vm_volume_free(&v);
}

static void niftiAppliesSclSlopeAndIntercept(void) {
    static const struct {
        double slope, inter, in, out;
    } table[] = {
        {2.0, 10.0, 5, 20}, {0.0, 10.0, 5, 5}, {1.0, 0.0, 5, 5}, {1.0, -3.0, 5, 2},
        {0.5, 0.0, 5, 2.5},
    };
    for (size_t t = 0; t < sizeof table / sizeof table[0]; t++) {
        for (int version = 1; version <= 2; version++) {
            spec s = default_spec(4, 1, 1, 1);
            s.version = version;
            s.scl_slope = table[t].slope;
            s.scl_inter = table[t].inter;
            double values[1] = {table[t].in};
            const char *p = vm_test_tmp("scl.nii");
            write_nifti(p, &s, values, 1);
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_volume_read_nifti(p, &v, &err), &err);
            if (!v.data) continue;
            CHECK_NEAR(v.data[0], table[t].out, 1e-6);
            CHECK(v.type == VM_SCALAR_INT16);
            vm_volume_free(&v);
        }
    }
}

/* ---- bad input ---- */

static void expect_error(const char *p, vm_status want, const char *fragment) {
    vm_volume v;
    vm_error err;
    memset(&v, 0x5a, sizeof v);
    vm_error_clear(&err);
    vm_status st = vm_volume_read(p, &v, &err);
    vm_test_expect_refusal(p, st, want, &err, fragment, &v);
}

static void niftiRefusesBadInputWithPathInMessage(void) {
    double values[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    spec s = default_spec(2, 2, 2, 2);
    size_t len, il;
    unsigned char *img = NULL;
    unsigned char *good = build(&s, values, 8, &len, &img, &il);

    const char *p = vm_test_tmp("empty.nii");
    vm_test_write_file(p, "", 0);
    expect_error(p, VM_ERR_FORMAT, "empty");

    p = vm_test_tmp("short.nii");
    vm_test_write_file(p, good, 100);
    expect_error(p, VM_ERR_FORMAT, "truncated");

    p = vm_test_tmp("truncdata.nii");
    vm_test_write_file(p, good, len - 3);
    expect_error(p, VM_ERR_FORMAT, "truncated");

    unsigned char *bad = malloc(len);
    memcpy(bad, good, len);
    memcpy(bad + 344, "xyz", 4);
    p = vm_test_tmp("magic.nii");
    vm_test_write_file(p, bad, len);
    expect_error(p, VM_ERR_FORMAT, "magic");

    memcpy(bad, good, len);
    bad[0] = 0x11;
    p = vm_test_tmp("sizeof.nii");
    vm_test_write_file(p, bad, len);
    expect_error(p, VM_ERR_FORMAT, "not a NIfTI");

    /* A header that lies: dims far larger than the data present. */
    spec big = s;
    big.dim[1] = 100;
    unsigned char *lie = build(&big, NULL, 0, &len, &img, &il);
    p = vm_test_tmp("lies.nii");
    vm_test_write_file(p, lie, len);
    expect_error(p, VM_ERR_FORMAT, "truncated");
    free(lie);

    /* dims whose product overflows size_t (NIfTI-2 has 64-bit dims). */
    spec huge = s;
    huge.version = 2;
    huge.dim[1] = huge.dim[2] = huge.dim[3] = (int64_t)1 << 40;
    lie = build(&huge, NULL, 0, &len, &img, &il);
    p = vm_test_tmp("overflow.nii");
    vm_test_write_file(p, lie, len);
    expect_error(p, VM_ERR_NOMEM, "overflow");
    free(lie);

    /* dims that fit size_t but exceed any memory limit. */
    huge.dim[1] = 32767;
    huge.dim[2] = 32767;
    huge.dim[3] = 32767;
    huge.version = 1;
    lie = build(&huge, NULL, 0, &len, &img, &il);
    p = vm_test_tmp("toobig.nii");
    vm_test_write_file(p, lie, len);
    expect_error(p, VM_ERR_NOMEM, "memory");
    free(lie);

    spec zero = s;
    zero.dim[2] = 0;
    lie = build(&zero, NULL, 0, &len, &img, &il);
    p = vm_test_tmp("zerodim.nii");
    vm_test_write_file(p, lie, len);
    expect_error(p, VM_ERR_FORMAT, "dimension");
    free(lie);

    static const int unsupported[] = {32, 128, 1792, 2304, 1536, 0, 1, 77};
    for (size_t i = 0; i < sizeof unsupported / sizeof unsupported[0]; i++) {
        spec u = s;
        u.datatype = unsupported[i];
        lie = build(&u, values, 8, &len, &img, &il);
        p = vm_test_tmp("unsupported.nii");
        vm_test_write_file(p, lie, len);
        expect_error(p, VM_ERR_UNSUPPORTED, "datatype");
        free(lie);
    }

    spec off = s;
    off.vox_offset = 100;
    lie = build(&off, NULL, 0, &len, &img, &il);
    p = vm_test_tmp("voxoffset.nii");
    vm_test_write_file(p, lie, len);
    expect_error(p, VM_ERR_FORMAT, "vox_offset");
    free(lie);

    /* A .hdr whose .img is missing, an .img whose .hdr is missing. */
    spec pair = s;
    pair.pair = 1;
    p = vm_test_tmp("lonely.hdr");
    remove(vm_test_tmp("lonely.img"));
    lie = build(&pair, values, 8, &len, &img, &il);
    vm_test_write_file(p, lie, len);
    free(lie);
    free(img);
    img = NULL;
    expect_error(p, VM_ERR_IO, "lonely.img");
    p = vm_test_tmp("orphan.img");
    remove(vm_test_tmp("orphan.hdr"));
    vm_test_write_file(p, good, 8);
    expect_error(p, VM_ERR_IO, "orphan.hdr");

    p = vm_test_tmp("folder.nii");
    mkdir(p, 0755);
    expect_error(p, VM_ERR_IO, "directory");

    p = vm_test_tmp("missing.nii");
    remove(p);
    expect_error(p, VM_ERR_IO, NULL);

    /* A corrupt gzip stream. */
    p = vm_test_tmp("corrupt.nii.gz");
    write_nifti(p, &s, values, 8);
    FILE *fp = fopen(p, "r+b");
    if (fp) {
        fseek(fp, 0, SEEK_END);
        long n = ftell(fp);
        fclose(fp);
        unsigned char *z = malloc((size_t)n);
        fp = fopen(p, "rb");
        CHECK(fread(z, 1, (size_t)n, fp) == (size_t)n);
        fclose(fp);
        vm_test_write_file(p, z, (size_t)n / 2);
        free(z);
        expect_error(p, VM_ERR_FORMAT, NULL);
    }

    free(bad);
    free(good);
}

static void niftiCliInfoReportsBadFileOnOneLine(void) {
    const char *p = vm_test_tmp("cli-bad.nii");
    vm_test_write_file(p, "not a nifti file at all, just some text that is long enough", 60);
    vm_test_expect_cli_error(NULL, p, NULL);
}

TEST_MAIN(T(niftiReadsSharedBrainWithReferenceStatistics),
          T(niftiReadsEveryDatatypeInBothByteOrdersAndVersions),
          T(niftiReadsGzipAndHeaderImagePairs),
          T(niftiAcceptsTrailingUnitDimensionsAndRefusesTimeSeries),
          T(niftiPrefersSformOverQform), T(niftiReadsQformRotationAndQfac),
          T(niftiFallsBackToPixdimWithoutTransforms), T(niftiAppliesSclSlopeAndIntercept),
          T(niftiRefusesBadInputWithPathInMessage), T(niftiCliInfoReportsBadFileOnOneLine))
