/* tests/fuzz/fuzz_vti.c — fuzz target for the VTK XML ImageData reader: the input bytes become a
 * .vti file that vm_volume_read_vti must either read or refuse with a message. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char name[64];
    snprintf(name, sizeof name, "fuzz_vti_%ld.vti", (long)getpid());
    const char *path = vm_test_tmp(name);
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_vti(path, &v, &err);
    if (st == VM_OK) {
        size_t n = vm_volume_count(&v);
        volatile float sink = n ? v.data[n - 1] : 0.0f; /* touch the last voxel */
        (void)sink;
        vm_volume_free(&v);
    } else if (err.message[0] == 0 || strchr(err.message, '\n')) {
        fprintf(stderr, "fuzz_vti: error %d without a one-line message\n", (int)st);
        abort();
    }
    remove(path);
    return 0;
}
