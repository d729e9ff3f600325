/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_mesh_check.c — fuzz target for the mesh check and the quality metrics on
 * whatever a reader accepts: the first byte picks the format (OBJ, OFF, STL, legacy VTK, VTU,
 * INP, MSH, MEDIT), the rest is the file; a mesh read is checked (vm_mesh_check) and measured
 * (vm_quality_report), degenerate, inverted or huge elements included, without a crash. */
#include <stdint.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static const char *const exts[] = {".obj", ".off", ".stl", ".vtk",
                                       ".vtu", ".inp", ".msh", ".mesh"};
    if (size < 1) return 0;
    return vm_test_fuzz_mesh_check(data + 1, size - 1, exts[data[0] % 8]);
}
