/* tests/fuzz/fuzz_metaimage.c — fuzz target for the MetaImage reader: the input bytes become
 * a .mha file (header plus LOCAL data, or a header naming a missing detached file) and are
 * read and freed. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <unistd.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char name[64];
    snprintf(name, sizeof name, "fuzz-metaimage-%ld.mha", (long)getpid());
    const char *path = vm_test_tmp(name);
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_volume v;
    vm_error err;
    if (vm_volume_read_metaimage(path, &v, &err) == VM_OK) vm_volume_free(&v);
    remove(path);
    return 0;
}
