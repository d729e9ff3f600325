/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/surface/test_surface_asc_export.c — writes volumes and their adaptive skeleton
 * climbing surfaces (max levels 0 and 4) into the test temp folder, for
 * test_surface_asc_vtk.py to compare with VTK's marching cubes: asc_NAME.nrrd (the volume),
 * asc_NAME_L0.vtu and asc_NAME_L4.vtu (the surfaces), and asc_cases.txt (NAME ISO per line). */
#include "test.h"
#include "volmesh/surface.h"
#include <string.h>

static FILE *cases_file;

static void export_volume(const char *name, const vm_volume *v, double iso) {
    vm_error err;
    char file[128];
    snprintf(file, sizeof file, "asc_%s.nrrd", name);
    CHECK_OK(vm_volume_write_nrrd(vm_test_tmp(file), v, 0, &err), &err);
    for (int level = 0; level <= 4; level += 4) {
        vm_surface_options o;
        vm_surface_options_default(&o);
        o.method = VM_SURFACE_ASC;
        o.max_level = level;
        o.lo = iso;
        vm_mesh m;
        vm_status s = vm_surface_extract(v, &o, &m, NULL, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        snprintf(file, sizeof file, "asc_%s_L%d.vtu", name, level);
        CHECK_OK(vm_mesh_write(vm_test_tmp(file), &m, &err), &err);
        vm_mesh_free(&m);
    }
    if (cases_file) fprintf(cases_file, "%s %.17g\n", name, iso);
}

static void phantomsAndSharedVolumesAreWritten(void) {
    cases_file = fopen(vm_test_tmp("asc_cases.txt"), "w");
    CHECK(cases_file != NULL);
    static const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS,
                                            VM_PHANTOM_GENUS3, VM_PHANTOM_TWO_SPHERES};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        vm_status s = vm_phantom_make(kinds[i], 64, 0, 7, &v, &info, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        export_volume(info.name, &v, 0.0);
        vm_volume_free(&v);
    }
    static const struct {
        const char *file, *name;
        double iso;
    } shared[] = {{"ironProt.vtk", "ironProt", 128},
                  {"hydrogen.vti", "hydrogen", 0.1},
                  {"ct_head_quarter.nrrd", "ct_head", 500}};
    for (size_t i = 0; i < sizeof shared / sizeof shared[0]; i++) {
        /* absent shared data leaves the phantoms only (no skip: they were written) */
        const char *dir = getenv("VM_SHARED_DATA");
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir ? dir : "../shared/data", shared[i].file);
        if (!vm_test_exists(path)) continue;
        vm_volume v;
        vm_error err;
        vm_status s = vm_volume_read(path, &v, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        export_volume(shared[i].name, &v, shared[i].iso);
        vm_volume_free(&v);
    }
    if (cases_file) fclose(cases_file);
    cases_file = NULL;
}

TEST_MAIN(T(phantomsAndSharedVolumesAreWritten))
