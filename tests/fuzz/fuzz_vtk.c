/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_vtk.c — fuzz target for the VTK legacy reader: the input
 * bytes become a .vtk file that must be read or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".vtk", vm_volume_read_vtk);
}
