/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_off.c — fuzz target for the OFF reader: the input bytes become a
 * .off file that must be read (every node index in range) or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_mesh(data, size, ".off", vm_mesh_read_off);
}
