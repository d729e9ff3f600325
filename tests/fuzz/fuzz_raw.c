/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_raw.c — fuzz target for the raw reader: the first 8 bytes are its options
 * (dims 1..16 each, sample type, endianness, header bytes, spacing, origin), the rest is the
 * file, which must be read (every voxel touched, the upper half read again as a slab with the
 * same values) or refused with a one-line message. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"

enum { OPTION_BYTES = 8 };

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < OPTION_BYTES) return 0;
    vm_raw_options opt;
    memset(&opt, 0, sizeof opt);
    for (int a = 0; a < 3; a++) opt.dims[a] = 1 + data[a] % 16;
    opt.type = (vm_scalar_type)(data[3] % 10);
    opt.big_endian = data[4] & 1;
    opt.header_bytes = data[5] % 32;
    /* spacing: 0 (means 1), ordinary, or outside the limits (refused) */
    static const double spacings[8] = {0, 0.5, 1, 3, 1e-12, 1e12, 1e308, -1};
    opt.spacing[data[6] % 3] = spacings[data[6] / 3 % 8];
    opt.origin[data[7] % 3] = (double)(int8_t)data[7] * 10.0;

    static char path[4096];
    if (!path[0]) {
        char name[64];
        snprintf(name, sizeof name, "fuzz_%ld.raw", (long)getpid());
        snprintf(path, sizeof path, "%s", vm_test_tmp(name));
    }
    if (vm_test_write_file(path, data + OPTION_BYTES, size - OPTION_BYTES) != 0) return 0;
    vm_volume v, s;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_raw(path, &opt, &v, &err);
    if (st != VM_OK) {
        if (!err.message[0] || strchr(err.message, '\n')) abort();
        remove(path);
        return 0;
    }
    double lo, hi, mean; /* touch every voxel so a short allocation shows under ASan */
    vm_volume_stats(&v, &lo, &hi, &mean);
    int64_t z0 = v.dims[2] / 2;
    if (vm_volume_read_raw_slab(path, &opt, z0, v.dims[2], &s, &err) != VM_OK) abort();
    size_t plane = (size_t)v.dims[0] * (size_t)v.dims[1];
    if (s.dims[2] != v.dims[2] - z0 ||
        memcmp(s.data, v.data + plane * (size_t)z0, plane * (size_t)s.dims[2] * sizeof(float)))
        abort();
    vm_volume_free(&s);
    vm_volume_free(&v);
    remove(path);
    return 0;
}
