/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_vti.c — fuzz target for the VTK XML ImageData reader: the input
 * bytes become a .vti file that must be read or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".vti", vm_volume_read_vti);
}
