/* tests/fuzz/fuzz_nifti.c — fuzz target for the NIfTI reader: the input bytes become a .nii
 * file (plain or gzip: the reader detects gzip by its magic) and are read and freed. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char name[64];
    snprintf(name, sizeof name, "fuzz-nifti-%ld.nii", (long)getpid());
    const char *path = vm_test_tmp(name);
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_volume v;
    vm_error err;
    if (vm_volume_read_nifti(path, &v, &err) == VM_OK) vm_volume_free(&v);
    remove(path);
    return 0;
}
