/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_nrrd.c — fuzz target for the NRRD reader (detached data files named by a mutated header resolve beside it): the input
 * bytes become a .nrrd file that must be read or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".nrrd", vm_volume_read_nrrd);
}
