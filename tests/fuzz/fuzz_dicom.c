/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_dicom.c — fuzz target for the DICOM reader: the input bytes become one file
 * (a single-file series) that must be read or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

/* The default series of the file, as vm_volume_read reads it. */
static vm_status read_dicom(const char *path, vm_volume *v, vm_error *err) {
    return vm_volume_read_dicom(path, NULL, v, err);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".dcm", read_dicom);
}
