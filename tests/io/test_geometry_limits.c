/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_geometry_limits.c — geometry that is not finite, or whose extent overflows, is
 * refused when it is read, naming the field (issue 31, item 2): volume spacing, origin and
 * extent within the limits of volmesh/volume.h, mesh coordinates within VM_COORD_MAX. */
#include <string.h>
#include "test.h"

/* A 2x2x2 uint8 NRRD with the given header lines for its geometry. */
static const char *nrrd_with(const char *geometry) {
    static const unsigned char vox[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    char text[512];
    int n = snprintf(text, sizeof text,
                     "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\n%s"
                     "encoding: raw\n\n", geometry);
    char buf[600];
    memcpy(buf, text, (size_t)n);
    memcpy(buf + n, vox, sizeof vox);
    const char *path = vm_test_tmp("geometry.nrrd");
    CHECK(vm_test_write_file(path, buf, (size_t)n + sizeof vox) == 0);
    return path;
}

static void volumeSpacingOriginAndExtentOutsideTheLimitsAreRefused(void) {
    static const struct {
        const char *lines, *says;
    } cases[] = {
        {"spacings: 1 1 1e308\n", "spacing z is 1e+308"},
        {"spacings: 1e-320 1 1\n", "spacing x is"},
        {"spacings: 1 9e18 1\n", "spacing y is 9e+18"},
        {"spacings: 1 1 1e-12\n", "spacing z is 1e-12"},
        {"space dimension: 3\nspace directions: (1,0,0) (0,1e12,0) (0,0,1)\n", "spacing y"},
        {"space dimension: 3\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n"
         "space origin: (0,0,1e300)\n", "origin z is 1e+300"},
        {"space dimension: 3\nspace directions: (1e9,0,0) (0,1e9,0) (0,0,1e9)\n"
         "space origin: (0,0,9.9999999e14)\n", "far corner has z"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const char *path = nrrd_with(cases[c].lines);
        for (int info = 0; info < 2; info++) {
            vm_volume v;
            vm_error err;
            vm_error_clear(&err);
            vm_status st = info ? vm_volume_read_info(path, &v, &err)
                                : vm_volume_read(path, &v, &err);
            CHECK_MSG(st == VM_ERR_FORMAT, "case %zu: status %d", c, (int)st);
            CHECK_MSG(strstr(err.message, path) && strstr(err.message, cases[c].says),
                      "case %zu: %s", c, err.message);
            if (!st) vm_volume_free(&v);
        }
    }
    /* within the limits: read */
    const char *path = nrrd_with("spacings: 1e-9 0.5 1e9\n");
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    vm_volume_free(&v);
}

static void rawSpacingOutsideTheLimitsIsRefused(void) {
    static const unsigned char vox[8] = {0};
    const char *path = vm_test_tmp("geometry.raw");
    CHECK(vm_test_write_file(path, vox, sizeof vox) == 0);
    static const double bad[] = {1e308, 1e-320, 9e18};
    for (size_t c = 0; c < sizeof bad / sizeof bad[0]; c++) {
        vm_raw_options o;
        memset(&o, 0, sizeof o);
        o.dims[0] = o.dims[1] = o.dims[2] = 2;
        o.type = VM_SCALAR_UINT8;
        o.spacing[1] = bad[c];
        vm_volume v;
        vm_error err;
        vm_error_clear(&err);
        vm_status st = vm_volume_read_raw(path, &o, &v, &err);
        CHECK_MSG(st == VM_ERR_FORMAT && strstr(err.message, "spacing y"), "%g: %d %s", bad[c],
                  (int)st, err.message);
        if (!st) vm_volume_free(&v);
    }
}

/* One tetrahedron's surface in each text mesh format, a coordinate replaced by `bad`. */
static void meshCoordinatesNotFiniteOrHugeAreRefusedWithThePoint(void) {
    static const char *const bad[] = {"nan", "inf", "-inf", "1e308", "-1e31"};
    for (size_t b = 0; b < sizeof bad / sizeof bad[0]; b++) {
        char text[1024];
        /* OBJ */
        snprintf(text, sizeof text, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 %s\n"
                                    "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", bad[b]);
        const char *obj = vm_test_tmp("coords.obj");
        CHECK(vm_test_write_file(obj, text, strlen(text)) == 0);
        /* VTU, ascii arrays */
        snprintf(text, sizeof text,
                 "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\">\n"
                 "<UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">\n"
                 "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" "
                 "format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 %s</DataArray></Points>\n"
                 "<Cells><DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">"
                 "0 1 2 3</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" "
                 "format=\"ascii\">4</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" "
                 "format=\"ascii\">10</DataArray></Cells>\n"
                 "</Piece></UnstructuredGrid></VTKFile>\n", bad[b]);
        const char *vtu = vm_test_tmp("coords.vtu");
        CHECK(vm_test_write_file(vtu, text, strlen(text)) == 0);
        const char *paths[2] = {obj, vtu};
        for (int k = 0; k < 2; k++) {
            vm_mesh m;
            vm_error err;
            vm_error_clear(&err);
            vm_status st = vm_mesh_read(paths[k], &m, &err);
            CHECK_MSG(st == VM_ERR_FORMAT, "%s in %s: status %d", bad[b], paths[k], (int)st);
            CHECK_MSG(strstr(err.message, paths[k]) != NULL &&
                          (strstr(err.message, "point 3, coordinate z") != NULL ||
                           strstr(err.message, "coordinate z \"") != NULL),
                      "%s in %s: %s", bad[b], paths[k], err.message);
            if (!st) vm_mesh_free(&m);
        }
    }
}

int main(void) {
    static const vm_test_case cases[] = {
        {"volumeSpacingOriginAndExtentOutsideTheLimitsAreRefused",
         volumeSpacingOriginAndExtentOutsideTheLimitsAreRefused},
        {"rawSpacingOutsideTheLimitsIsRefused", rawSpacingOutsideTheLimitsIsRefused},
        {"meshCoordinatesNotFiniteOrHugeAreRefusedWithThePoint",
         meshCoordinatesNotFiniteOrHugeAreRefusedWithThePoint},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
