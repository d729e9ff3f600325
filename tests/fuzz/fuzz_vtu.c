/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_vtu.c — fuzz target for the VTU mesh reader: the input bytes become a .vtu
 * file that must be read (every node index in range) or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_mesh(data, size, ".vtu", vm_mesh_read_vtu);
}
