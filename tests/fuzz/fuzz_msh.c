/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_msh.c — fuzz target for the Gmsh .msh reader: the input bytes become a
 * .msh file that must be read (every node index in range) or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_mesh(data, size, ".msh", vm_mesh_read_msh);
}
