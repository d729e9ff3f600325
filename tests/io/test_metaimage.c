/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_metaimage.c — the MetaImage reader: the shared head and frog volumes against
 * VTK's statistics, .mha/.mhd files written here (every element type, MSB order, zlib,
 * TransformMatrix) and every kind of bad input. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>
#include "test.h"

/* Writes header text followed by raw bytes into path. */
static void write_two(const char *path, const char *header, const void *data, size_t n) {
    size_t hl = strlen(header);
    unsigned char *b = malloc(hl + n + 1);
    memcpy(b, header, hl);
    if (n) memcpy(b + hl, data, n);
    CHECK(vm_test_write_file(path, b, hl + n) == 0);
    free(b);
}

/* Checks a shared volume's geometry and statistics. vtk_count, when non-zero, is the number
 * of leading voxels VTK's reader filled (see the frog test): the VTK mean is then the sum over
 * those voxels divided by the full voxel count. */
static void check_reference(const char *name, int64_t nx, int64_t ny, int64_t nz,
                            const double sp[3], double mn, double mx, double mean,
                            size_t vtk_count, double full_mean) {
    const char *p = vm_test_shared(name);
    if (!p) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(p, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.dims[0] == nx && v.dims[1] == ny && v.dims[2] == nz);
    CHECK(v.type == VM_SCALAR_UINT8);
    CHECK(strcmp(v.format, "metaimage") == 0);
    for (int a = 0; a < 3; a++) {
        CHECK_NEAR(v.spacing[a], sp[a], 1e-9);
        CHECK_NEAR(v.origin[a], 0.0, 1e-9);
        for (int c = 0; c < 3; c++) CHECK(v.direction[a][c] == (a == c ? 1.0 : 0.0));
    }
    double lo, hi, avg;
    CHECK(vm_volume_stats(&v, &lo, &hi, &avg) == 0);
    CHECK_NEAR(lo, mn, 1e-9);
    CHECK_NEAR(hi, mx, mx * 1e-4);
    if (vtk_count) {
        double sum = 0.0;
        for (size_t i = 0; i < vtk_count; i++) sum += v.data[i];
        CHECK_NEAR(sum / (double)vm_volume_count(&v), mean, mean * 1e-4);
        CHECK_NEAR(avg, full_mean, full_mean * 1e-6);
    } else {
        CHECK_NEAR(avg, mean, mean * 1e-4);
    }
    vm_volume_free(&v);
}

static void metaimageReadsSharedHeadWithReferenceStatistics(void) {
    const double sp[3] = {4, 4, 4};
    check_reference("HeadMRVolume.mhd", 48, 62, 42, sp, 0, 255, 24.468222, 0, 0.0);
}

static void metaimageReadsSharedCompressedFrogWithReferenceStatistics(void) {
    const double sp[3] = {1, 1, 1.5};
    /* frogtissue.mhd says CompressedDataSize = 260020, but frogtissue.zraw holds a complete
     * 262087-byte zlib stream. VTK's MetaIO stops at the stated size, decodes only the first
     * 30963285 of 31960000 voxels and leaves the rest 0: its mean 0.383128 is the sum of those
     * voxels over all 31960000. volmesh decodes the whole stream (the stream marks its own
     * end); the full mean 0.3842138 was computed independently with Python's zlib. */
    check_reference("frogtissue.mhd", 500, 470, 136, sp, 0, 29, 0.383128, 30963285,
                    0.38421376720901124);
}

static void metaimageReadsEveryElementTypeLocalInBothByteOrders(void) {
    static const struct {
        const char *name;
        vm_scalar_type type;
        double lo, hi;
    } table[] = {
        {"MET_UCHAR", VM_SCALAR_UINT8, 0, 255},
        {"MET_CHAR", VM_SCALAR_INT8, -128, 127},
        {"MET_USHORT", VM_SCALAR_UINT16, 0, 65535},
        {"MET_SHORT", VM_SCALAR_INT16, -32768, 32767},
        {"MET_UINT", VM_SCALAR_UINT32, 0, 4000000},
        {"MET_INT", VM_SCALAR_INT32, -2000000, 2000000},
        {"MET_ULONG_LONG", VM_SCALAR_UINT64, 0, 9000000},
        {"MET_LONG_LONG", VM_SCALAR_INT64, -5000000, 5000000},
        {"MET_FLOAT", VM_SCALAR_FLOAT32, -1.5, 2.25},
        {"MET_DOUBLE", VM_SCALAR_FLOAT64, -1e6, 0.125},
    };
    for (size_t t = 0; t < sizeof table / sizeof table[0]; t++) {
        for (int msb = 0; msb <= 1; msb++) {
            double values[24];
            unsigned char raw[24 * 8];
            size_t n = 0;
            for (int i = 0; i < 24; i++) {
                values[i] = i == 0 ? table[t].lo : i == 23 ? table[t].hi : (double)(i % 5);
                n += vm_test_put_sample(raw + n, table[t].type, msb, values[i]);
            }
            char header[512];
            snprintf(header, sizeof header,
                     "ObjectType = Image\nNDims = 3\nDimSize = 2 3 4\n"
                     "BinaryData = True\n%s = %s\nElementType = %s\nElementDataFile = LOCAL\n",
                     msb ? "BinaryDataByteOrderMSB" : "ElementByteOrderMSB",
                     msb ? "True" : "False", table[t].name);
            const char *p = vm_test_tmp("types.mha");
            write_two(p, header, raw, n);
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_volume_read(p, &v, &err), &err);
            if (!v.data) continue;
            CHECK_MSG(v.type == table[t].type, "%s", table[t].name);
            CHECK(v.dims[0] == 2 && v.dims[1] == 3 && v.dims[2] == 4);
            for (int i = 0; i < 24; i++)
                CHECK_MSG(v.data[i] == (float)values[i], "%s msb %d i %d: %g", table[t].name,
                          msb, i, (double)v.data[i]);
            vm_volume_free(&v);
        }
    }
}

static void metaimageReadsDetachedRawAndCompressedData(void) {
    unsigned char raw[60];
    for (int i = 0; i < 60; i++) raw[i] = (unsigned char)(i * 4);
    CHECK(vm_test_write_file(vm_test_tmp("detached.raw"), raw, 60) == 0);
    /* Key names in mixed case, no spaces around '=', ElementSize used without spacing. */
    const char *h1 = "objecttype=Image\nndims=3\ndimsize=3 4 5\nelementsize=0.5 0.25 2\n"
                     "ELEMENTTYPE = MET_UCHAR\nElementDataFile = detached.raw\n";
    const char *p1 = vm_test_tmp("detached.mhd");
    write_two(p1, h1, NULL, 0);

    unsigned char z[256];
    uLongf zlen = sizeof z;
    CHECK(compress(z, &zlen, raw, 60) == Z_OK);
    CHECK(vm_test_write_file(vm_test_tmp("packed.zraw"), z, zlen) == 0);
    char h2[512];
    snprintf(h2, sizeof h2,
             "NDims = 3\nDimSize = 3 4 5\nElementSpacing = 0.5 0.25 2\nElementSize = 9 9 9\n"
             "CompressedData = True\nCompressedDataSize = %lu\nElementType = MET_UCHAR\n"
             "ElementDataFile = packed.zraw\n", (unsigned long)zlen);
    const char *p2 = vm_test_tmp("packed.mhd");
    write_two(p2, h2, NULL, 0);

    char h3[512];
    snprintf(h3, sizeof h3,
             "NDims = 3\nDimSize = 3 4 5\nElementSpacing = 0.5 0.25 2\n"
             "CompressedData = True\nCompressedDataSize = %lu\nElementType = MET_UCHAR\n"
             "ElementDataFile = LOCAL\n", (unsigned long)zlen);
    const char *p3 = vm_test_tmp("packed.mha");
    write_two(p3, h3, z, zlen);

    /* HeaderSize = -1: the samples are the last bytes of the data file. */
    unsigned char padded[70];
    memset(padded, 0xee, 10);
    memcpy(padded + 10, raw, 60);
    CHECK(vm_test_write_file(vm_test_tmp("padded.raw"), padded, 70) == 0);
    const char *p4 = vm_test_tmp("padded.mhd");
    write_two(p4, "NDims = 3\nDimSize = 3 4 5\nElementSpacing = 0.5 0.25 2\nHeaderSize = -1\n"
                  "ElementType = MET_UCHAR\nElementDataFile = padded.raw\n", NULL, 0);
    const char *p5 = vm_test_tmp("skip.mhd");
    write_two(p5, "NDims = 3\nDimSize = 3 4 5\nElementSpacing = 0.5 0.25 2\nHeaderSize = 10\n"
                  "ElementType = MET_UCHAR\nElementDataFile = padded.raw\n", NULL, 0);

    const char *paths[] = {p1, p2, p3, p4, p5};
    for (int k = 0; k < 5; k++) {
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read(paths[k], &v, &err), &err);
        if (!v.data) continue;
        CHECK(v.dims[0] == 3 && v.dims[1] == 4 && v.dims[2] == 5);
        CHECK_NEAR(v.spacing[0], 0.5, 1e-12);
        CHECK_NEAR(v.spacing[1], 0.25, 1e-12);
        CHECK_NEAR(v.spacing[2], 2, 1e-12);
        for (int i = 0; i < 60; i++) CHECK_MSG(v.data[i] == (float)(i * 4), "%s i %d", paths[k], i);
        vm_volume_free(&v);
    }
}

static void metaimageReadsTransformMatrixAsItkDoes(void) {
    /* ITK writes the direction of index axis i as numbers 3i..3i+2. Here axis i points to
     * world +y, axis j to world -x, axis k to world +z: D = [[0,-1,0],[1,0,0],[0,0,1]]. */
    static const char *keys[] = {"TransformMatrix", "Rotation", "Orientation"};
    static const char *offs[] = {"Offset", "Origin", "Position"};
    for (int k = 0; k < 3; k++) {
        char header[512];
        snprintf(header, sizeof header,
                 "ObjectType = Image\nNDims = 3\n%s = 0 1 0 -1 0 0 0 0 1\n%s = 1 -2 3.5\n"
                 "CenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\n"
                 "ElementSpacing = 1 2 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                 "ElementDataFile = LOCAL\n", keys[k], offs[k]);
        const char *p = vm_test_tmp("rotated.mha");
        write_two(p, header, "\1\2\3\4\5\6\7\10", 8);
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read(p, &v, &err), &err);
        if (!v.data) continue;
        double expect[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) CHECK_NEAR(v.direction[r][c], expect[r][c], 1e-12);
        double ijk[3] = {1, 1, 1}, xyz[3];
        vm_volume_index_to_world(&v, ijk, xyz);
        CHECK_NEAR(xyz[0], 1 - 2, 1e-12);
        CHECK_NEAR(xyz[1], -2 + 1, 1e-12);
        CHECK_NEAR(xyz[2], 3.5 + 3, 1e-12);
        CHECK(v.data[7] == 8.0f);
        vm_volume_free(&v);
    }
}

/* ---- bad input ---- */

static void expect_error(const char *p, vm_status want, const char *fragment) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read(p, &v, &err);
    vm_test_expect_refusal(p, st, want, &err, fragment, &v);
}

static void bad_header(const char *name, const char *header, size_t data_bytes,
                       vm_status want, const char *fragment) {
    unsigned char data[64];
    memset(data, 1, sizeof data);
    const char *p = vm_test_tmp(name);
    write_two(p, header, data, data_bytes);
    expect_error(p, want, fragment);
}

static void metaimageRefusesBadInputWithPathInMessage(void) {
    const char *p = vm_test_tmp("empty.mha");
    vm_test_write_file(p, "", 0);
    expect_error(p, VM_ERR_FORMAT, "empty");

    bad_header("truncated.mha", "NDims = 3\nDimSize = 4 4 4\nElementType = MET_UCHAR\n"
               "ElementDataFile = LOCAL\n", 63, VM_ERR_FORMAT, "truncated");
    bad_header("lying.mha", "NDims = 3\nDimSize = 400 400 400\nElementType = MET_SHORT\n"
               "ElementDataFile = LOCAL\n", 64, VM_ERR_FORMAT, "truncated");
    bad_header("overflow.mha", "NDims = 3\nDimSize = 4e9 4e9 4e9\nElementType = MET_UCHAR\n"
               "ElementDataFile = LOCAL\n", 8, VM_ERR_NOMEM, "overflow");
    bad_header("toobig.mha", "NDims = 3\nDimSize = 100000 100000 100000\n"
               "ElementType = MET_DOUBLE\nElementDataFile = LOCAL\n", 8, VM_ERR_NOMEM, "memory");
    bad_header("type.mha", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_FLOAT_MATRIX\n"
               "ElementDataFile = LOCAL\n", 8, VM_ERR_UNSUPPORTED, "ElementType");
    bad_header("notype.mha", "NDims = 3\nDimSize = 2 2 2\nElementDataFile = LOCAL\n", 8,
               VM_ERR_FORMAT, "ElementType");
    bad_header("channels.mha", "NDims = 3\nDimSize = 2 2 2\nElementNumberOfChannels = 3\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 24, VM_ERR_UNSUPPORTED,
               "Channels");
    bad_header("ndims.mha", "NDims = 2\nDimSize = 2 2\nElementType = MET_UCHAR\n"
               "ElementDataFile = LOCAL\n", 4, VM_ERR_UNSUPPORTED, "NDims");
    bad_header("list.mhd", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
               "ElementDataFile = LIST\nslice0.raw\nslice1.raw\n", 0, VM_ERR_UNSUPPORTED,
               "LIST");
    bad_header("pattern.mhd", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
               "ElementDataFile = slice%03d.raw 1 2 1\n", 0, VM_ERR_UNSUPPORTED, "series");
    bad_header("ascii.mha", "NDims = 3\nDimSize = 2 2 2\nBinaryData = False\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n1 2 3 4 5 6 7 8\n", 0,
               VM_ERR_UNSUPPORTED, "BinaryData");
    bad_header("object.mha", "ObjectType = Tube\nNDims = 3\nDimSize = 2 2 2\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VM_ERR_UNSUPPORTED,
               "ObjectType");
    bad_header("nodatafile.mha", "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n", 0,
               VM_ERR_FORMAT, "ElementDataFile");
    bad_header("binary.mha", "", 16, VM_ERR_FORMAT, NULL);
    bad_header("spacing.mha", "NDims = 3\nDimSize = 2 2 2\nElementSpacing = 1 0 1\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VM_ERR_FORMAT,
               "ElementSpacing");
    bad_header("badnumber.mha", "NDims = 3\nDimSize = 2 x 2\nElementType = MET_UCHAR\n"
               "ElementDataFile = LOCAL\n", 8, VM_ERR_FORMAT, "DimSize");
    bad_header("matrix.mha", "NDims = 3\nDimSize = 2 2 2\nTransformMatrix = 1 0 0 0 1 0\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 8, VM_ERR_FORMAT,
               "TransformMatrix");
    bad_header("noequals.mha", "NDims 3\nElementDataFile = LOCAL\n", 8, VM_ERR_FORMAT,
               "Key = Value");
    bad_header("corrupt.mha", "NDims = 3\nDimSize = 2 2 2\nCompressedData = True\n"
               "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", 16, VM_ERR_FORMAT,
               "compressed");
    bad_header("csize.mha", "NDims = 3\nDimSize = 2 2 2\nCompressedData = True\n"
               "CompressedDataSize = 5000\nElementType = MET_UCHAR\nElementDataFile = LOCAL\n",
               16, VM_ERR_FORMAT, "CompressedDataSize");

    /* Compressed stream cut in half. */
    unsigned char raw[1000], z[1200];
    for (int i = 0; i < 1000; i++) raw[i] = (unsigned char)(i * 7 + i / 13);
    uLongf zlen = sizeof z;
    CHECK(compress(z, &zlen, raw, 1000) == Z_OK);
    p = vm_test_tmp("halfz.mha");
    write_two(p, "NDims = 3\nDimSize = 10 10 10\nCompressedData = True\n"
                 "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n", z, zlen / 2);
    expect_error(p, VM_ERR_FORMAT, "truncated");

    p = vm_test_tmp("missingraw.mhd");
    remove(vm_test_tmp("nowhere.raw"));
    write_two(p, "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                 "ElementDataFile = nowhere.raw\n", NULL, 0);
    expect_error(p, VM_ERR_IO, "nowhere.raw");

    mkdir(vm_test_tmp("rawdir.raw"), 0755);
    p = vm_test_tmp("dirraw.mhd");
    write_two(p, "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                 "ElementDataFile = rawdir.raw\n", NULL, 0);
    expect_error(p, VM_ERR_IO, "directory");

    p = vm_test_tmp("folder.mha");
    mkdir(p, 0755);
    expect_error(p, VM_ERR_IO, "directory");

    p = vm_test_tmp("absent.mhd");
    remove(p);
    expect_error(p, VM_ERR_IO, NULL);
}

static void metaimageCliInfoReportsBadFileOnOneLine(void) {
    const char *p = vm_test_tmp("cli-bad.mhd");
    write_two(p, "NDims = 3\nDimSize = 2 2 2\nElementType = MET_UCHAR\n"
                 "ElementDataFile = cli-missing.raw\n", NULL, 0);
    remove(vm_test_tmp("cli-missing.raw"));
    vm_test_expect_cli_error(NULL, p, NULL);
}

TEST_MAIN(T(metaimageReadsSharedHeadWithReferenceStatistics),
          T(metaimageReadsSharedCompressedFrogWithReferenceStatistics),
          T(metaimageReadsEveryElementTypeLocalInBothByteOrders),
          T(metaimageReadsDetachedRawAndCompressedData),
          T(metaimageReadsTransformMatrixAsItkDoes),
          T(metaimageRefusesBadInputWithPathInMessage),
          T(metaimageCliInfoReportsBadFileOnOneLine))
