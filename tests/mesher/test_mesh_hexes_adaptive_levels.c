/* tests/mesher/test_mesh_hexes_adaptive_levels.c — nested coarsening of adaptive hexahedra
 * (mesher/dc_hex_adaptive.c, --max-level 2): the second level on the 128^3 sphere. Apart from
 * test_mesh_hexes_adaptive.c so that each stays within a minute. */
#include "hex_checks.h"
#include <stdlib.h>
#include <string.h>

/* Meshes v at iso lo in hexes with up to `levels` coarse levels. */
static vm_status mesh_levels(const vm_volume *v, double lo, int levels, vm_mesh *m) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = 1;
    o.max_level = levels;
    o.lo = lo;
    vm_status s = vm_mesh_volume(v, &o, m, NULL, &err);
    CHECK_OK(s, &err);
    return s;
}

/* A second level (9x9x9-cell hexes made of level-1 ones, the same pillowed transition one
 * level up) on the sphere at 128^3, the smallest size where one fits: a valid, conforming,
 * closed mesh with the sphere's topology and volume, fewer hexes than level 1 alone (which
 * is 0.45 of uniform). Release only: two 128^3 meshes take minutes under the sanitizers,
 * where test_mesh_hexes_adaptive.c runs the same code at scales 1 and 3 (no block fits). */
static void secondLevelCoarsensTheSphereFurtherAt128(void) {
    const char *sanitized = getenv("VM_SANITIZED");
    if (sanitized && strcmp(sanitized, "1") == 0) {
        printf("  the 128^3 sphere left to the Release run (sanitizer build)\n");
        return;
    }
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 128, 0.0, 0, &v, &info, &err), &err);
    vm_mesh one, two;
    if (mesh_levels(&v, 0.0, 1, &one) == VM_OK) {
        if (mesh_levels(&v, 0.0, 2, &two) == VM_OK) {
            printf("  sphere 128^3: level 1 %zu hexes, level 2 %zu\n", one.ncells, two.ncells);
            CHECK_MSG(two.ncells < one.ncells, "level 2 %zu, level 1 %zu hexes", two.ncells,
                      one.ncells);
            check_hex_mesh("sphere 128^3 level 2", &two, info.euler, (size_t)info.components,
                           info.volume, 0.02);
            vm_mesh_free(&two);
        }
        check_hex_mesh("sphere 128^3 level 1", &one, info.euler, (size_t)info.components,
                       info.volume, 0.02);
        vm_mesh_free(&one);
    }
    vm_volume_free(&v);
}

TEST_MAIN(T(secondLevelCoarsensTheSphereFurtherAt128))
