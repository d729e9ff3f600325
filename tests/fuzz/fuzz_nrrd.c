/* tests/fuzz/fuzz_nrrd.c — fuzz target for the NRRD reader: the input becomes a .nrrd file
 * (detached data files named by a mutated header resolve beside it) and is read and freed. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static char path[4096];
    if (!path[0]) {
        /* Keep a lying header from asking for more than a fuzzing run should allocate. */
        setenv("VOLMESH_MAX_MEMORY", "268435456", 0);
        char unique[64];
        snprintf(unique, sizeof unique, "fuzz_nrrd_%ld.nrrd", (long)getpid());
        snprintf(path, sizeof path, "%s", vm_test_tmp(unique));
    }
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_volume v;
    vm_error err;
    if (vm_volume_read_nrrd(path, &v, &err) == VM_OK) {
        /* touch every voxel so a short allocation shows up under ASan */
        double lo, hi, mean;
        vm_volume_stats(&v, &lo, &hi, &mean);
        vm_volume_free(&v);
    }
    return 0;
}
