/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_heads.c — the hex quality pass on the two biggest shared
 * volumes (the CT head at the skin isovalue, 145 000 hexes, and avg152T1, 356 000), apart
 * from test_mesh_hexes.c so that the two run side by side: 0 inverted after the pass, the
 * topology and volume kept, the worst scaled Jacobian not lower and at least the floor. One
 * ctest part per head, so that they too run side by side. */
/* ctest parts: 2 */
#include <stdlib.h>
#include <string.h>
#include "hex_checks.h"

/* Issue #5's bar is 0.2. The CT head at 500 reaches it since the polish (boundary points of
 * the selective layer's hexes sliding along the isosurface, docs/IMPROVE.md), avg152T1 since
 * the repair (coupled moves of the last patches below 0.3, boundary points also anywhere
 * within 0.4 voxel of the isosurface); issue 34's raise of the repair's bar to 0.52 takes
 * them to 0.466 and 0.39 (every hex measured at its corners, centre and Gauss points); the
 * group moves after the raise (at most 64 hexes below the target) take the CT head to 0.5,
 * issue 34's bar. */
/* One head: skipped under the sanitizers (minutes there: left to the Release run). */
static void check_head(const char *file, double iso, double floor) {
    const char *sanitized = getenv("VM_SANITIZED");
    if (sanitized && strcmp(sanitized, "1") == 0) {
        vm_test_skip("minutes under the sanitizers: left to the Release run");
        return;
    }
    check_shared_volume(file, iso, floor, -1, 0, 1);
}

static void hexPassOnTheCtHeadSkinReachesTheBar(void) {
    /* measured 0.5008 (0.466 before the last group moves, 0.300 before the raise) */
    check_head("ct_head_quarter.nrrd", 500, 0.5);
}

static void hexPassOnAvg152ReachesTheBar(void) {
    check_head("avg152T1_RL_nifti.nii.gz", 100, 0.35); /* measured 0.3895 (0.300 before) */
}

TEST_MAIN(T(hexPassOnTheCtHeadSkinReachesTheBar), T(hexPassOnAvg152ReachesTheBar))
