/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_raw.c — the raw reader: every sample type in both byte orders, header skip,
 * geometry from the options, and files too short for what the options describe. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include "test.h"

enum { NVOX = 24 };

static const vm_scalar_type all_types[] = {
    VM_SCALAR_UINT8,  VM_SCALAR_INT8,  VM_SCALAR_UINT16, VM_SCALAR_INT16,   VM_SCALAR_UINT32,
    VM_SCALAR_INT32,  VM_SCALAR_UINT64, VM_SCALAR_INT64, VM_SCALAR_FLOAT32, VM_SCALAR_FLOAT64,
};

/* Distinct values that every type (and float) holds exactly; negative ones for signed types. */
static double sample_value(vm_scalar_type t, int i) {
    int is_signed = t == VM_SCALAR_INT8 || t == VM_SCALAR_INT16 || t == VM_SCALAR_INT32 ||
                    t == VM_SCALAR_INT64 || t == VM_SCALAR_FLOAT32 || t == VM_SCALAR_FLOAT64;
    double x = i * 5 + 1;
    if (t == VM_SCALAR_FLOAT32 || t == VM_SCALAR_FLOAT64) x += 0.25;
    return is_signed && i % 2 ? -x : x;
}

/* header bytes of 0xEE, then the samples; returns the file size. */
static size_t write_raw(const char *path, vm_scalar_type t, int big, size_t header) {
    unsigned char buf[64 + NVOX * 8];
    memset(buf, 0xEE, header);
    size_t at = header;
    for (int i = 0; i < NVOX; i++)
        at += vm_test_put_sample(buf + at, t, big, sample_value(t, i));
    CHECK(vm_test_write_file(path, buf, at) == 0);
    return at;
}

static vm_raw_options options(vm_scalar_type t, int big, uint64_t header) {
    vm_raw_options o;
    memset(&o, 0, sizeof o);
    o.dims[0] = 2;
    o.dims[1] = 3;
    o.dims[2] = 4;
    o.type = t;
    o.big_endian = big;
    o.header_bytes = header;
    return o;
}

static void rawReadsEveryTypeInBothByteOrders(void) {
    const char *path = vm_test_tmp("raw_types.raw");
    for (size_t k = 0; k < sizeof all_types / sizeof all_types[0]; k++) {
        vm_scalar_type t = all_types[k];
        for (int big = 0; big < 2; big++) {
            write_raw(path, t, big, 0);
            vm_raw_options o = options(t, big, 0);
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_volume_read_raw(path, &o, &v, &err), &err);
            if (!v.data) continue;
            CHECK(v.type == t);
            CHECK(strcmp(v.format, "raw") == 0);
            CHECK(v.dims[0] == 2 && v.dims[1] == 3 && v.dims[2] == 4);
            int bad = 0;
            for (int i = 0; i < NVOX; i++) bad += v.data[i] != (float)sample_value(t, i);
            CHECK_MSG(bad == 0, "%s %s: %d wrong values", vm_scalar_type_name(t),
                      big ? "big" : "little", bad);
            vm_volume_free(&v);
        }
    }
}

static void rawSkipsHeaderBytesAndIgnoresTrailingBytes(void) {
    const char *path = vm_test_tmp("raw_header.raw");
    size_t size = write_raw(path, VM_SCALAR_INT16, 1, 37);
    vm_raw_options o = options(VM_SCALAR_INT16, 1, 37);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_raw(path, &o, &v, &err), &err);
    if (v.data) {
        for (int i = 0; i < NVOX; i++) CHECK(v.data[i] == (float)sample_value(VM_SCALAR_INT16, i));
        vm_volume_free(&v);
    }
    /* fewer voxels than the file holds: the first ones are read */
    o.dims[2] = 2;
    CHECK_OK(vm_volume_read_raw(path, &o, &v, &err), &err);
    if (v.data) {
        CHECK(v.data[11] == (float)sample_value(VM_SCALAR_INT16, 11));
        vm_volume_free(&v);
    }
    CHECK(size == 37 + NVOX * 2);
}

static void rawTakesGeometryFromTheOptionsWithZeroSpacingAsOne(void) {
    const char *path = vm_test_tmp("raw_geometry.raw");
    write_raw(path, VM_SCALAR_UINT8, 0, 0);
    vm_raw_options o = options(VM_SCALAR_UINT8, 0, 0);
    o.spacing[0] = 0.5;
    o.spacing[2] = 2.5;
    o.origin[0] = -10;
    o.origin[1] = 20;
    o.origin[2] = 0.125;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_raw(path, &o, &v, &err), &err);
    if (!v.data) return;
    CHECK(v.spacing[0] == 0.5 && v.spacing[1] == 1.0 && v.spacing[2] == 2.5);
    CHECK(v.origin[0] == -10 && v.origin[1] == 20 && v.origin[2] == 0.125);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) CHECK(v.direction[r][c] == (r == c ? 1.0 : 0.0));
    vm_volume_free(&v);
}

static void check_error(const char *path, const vm_raw_options *o, vm_status want,
                        const char *phrase) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_raw(path, o, &v, &err);
    vm_test_expect_refusal(path, st, want, &err, phrase, &v);
}

static void rawRejectsTruncatedFilesWithByteCounts(void) {
    const char *path = vm_test_tmp("raw_short.raw");
    write_raw(path, VM_SCALAR_FLOAT32, 0, 0);
    vm_raw_options o = options(VM_SCALAR_FLOAT32, 0, 0);
    o.dims[2] = 5; /* 30 voxels, file holds 24 */
    check_error(path, &o, VM_ERR_FORMAT, "data is truncated (96 of 120 bytes)");
    char want[4200];
    vm_volume v;
    vm_error err;
    vm_volume_read_raw(path, &o, &v, &err);
    snprintf(want, sizeof want, "%s: data is truncated (96 of 120 bytes)", path);
    CHECK_MSG(strcmp(err.message, want) == 0, "%s", err.message);
    /* header skip past the end */
    o = options(VM_SCALAR_FLOAT32, 0, 1000);
    check_error(path, &o, VM_ERR_FORMAT, "data is truncated (0 of 96 bytes)");
    /* header plus data one byte too long */
    o = options(VM_SCALAR_FLOAT32, 0, 1);
    check_error(path, &o, VM_ERR_FORMAT, "data is truncated (95 of 96 bytes)");
    const char *empty = vm_test_tmp("raw_empty.raw");
    CHECK(vm_test_write_file(empty, "", 0) == 0);
    check_error(empty, &o, VM_ERR_FORMAT, "data is truncated (0 of 96 bytes)");
}

static void rawRejectsMissingFilesDirectoriesAndOverflowingDims(void) {
    vm_raw_options o = options(VM_SCALAR_UINT8, 0, 0);
    check_error(vm_test_tmp("raw_missing.raw"), &o, VM_ERR_IO, "cannot open");
    const char *dir = vm_test_tmp("raw_dir.raw");
    mkdir(dir, 0755);
    check_error(dir, &o, VM_ERR_IO, "directory");
    const char *path = vm_test_tmp("raw_small.raw");
    write_raw(path, VM_SCALAR_UINT8, 0, 0);
    o.dims[0] = o.dims[1] = o.dims[2] = INT64_C(1) << 40;
    check_error(path, &o, VM_ERR_NOMEM, "overflow");
    o = options(VM_SCALAR_UINT8, 0, 0);
    o.dims[1] = 0;
    check_error(path, &o, VM_ERR_FORMAT, "must be >= 1");
    o = options(VM_SCALAR_UINT8, 0, 0);
    o.spacing[0] = -1;
    check_error(path, &o, VM_ERR_ARG, "spacing");
}

static void rawCliReadsWithOptionsAndReportsTruncation(void) {
    const char *path = vm_test_tmp("raw_cli.raw");
    write_raw(path, VM_SCALAR_UINT16, 1, 0);
    char args[4300], *out = NULL;
    snprintf(args, sizeof args, "info '%s' --raw-dims 2x3x4 --raw-type uint16 --raw-endian big",
             path);
    int rc = vm_test_cli(args, &out);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, out ? out : "");
    CHECK(out && strstr(out, "raw"));
    free(out);
    snprintf(args, sizeof args, "info '%s' --raw-dims 2x3x5 --raw-type uint16", path);
    vm_test_expect_cli_error(args, path, "data is truncated (48 of 60 bytes)");
}

TEST_MAIN(T(rawReadsEveryTypeInBothByteOrders), T(rawSkipsHeaderBytesAndIgnoresTrailingBytes),
          T(rawTakesGeometryFromTheOptionsWithZeroSpacingAsOne),
          T(rawRejectsTruncatedFilesWithByteCounts),
          T(rawRejectsMissingFilesDirectoriesAndOverflowingDims),
          T(rawCliReadsWithOptionsAndReportsTruncation))
