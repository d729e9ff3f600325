/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_tiff.c — fuzz target for the TIFF reader (libtiff; a build without it
 * refuses every input in one line): the input bytes become a .tif file that must be read or
 * refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".tif", vm_volume_read_tiff);
}
