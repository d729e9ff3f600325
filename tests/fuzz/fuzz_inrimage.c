/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_inrimage.c — fuzz target for the INRIMAGE-4 reader (plain or gzip: detected
 * by magic): the input bytes become a .inr file that must be read or refused with a one-line
 * message. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    return vm_test_fuzz_volume(data, size, ".inr", vm_volume_read_inrimage);
}
