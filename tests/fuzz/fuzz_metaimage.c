/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_metaimage.c — fuzz target for the MetaImage reader (LOCAL data, or a header naming a missing file): the input
 * bytes become a .mha file that must be read or refused with a one-line message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".mha", vm_volume_read_metaimage);
}
