/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_vtk_legacy.c — the VTK legacy STRUCTURED_POINTS reader: the shared ironProt
 * volume against VTK's statistics, files written here (ASCII and big-endian binary, every
 * type), unsupported datasets, and every kind of bad input. */
#define _POSIX_C_SOURCE 200809L
#include <string.h>
#include <sys/stat.h>
#include "test.h"

static const double values12[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 100};

/* Writes a 3x2x2 STRUCTURED_POINTS file: header text then (binary) samples of values12. */
static const char *write_vtk(const char *name, const char *header, int binary,
                             vm_scalar_type t, const char *tail) {
    const char *path = vm_test_tmp(name);
    FILE *fp = fopen(path, "wb");
    if (!fp) return path;
    fputs(header, fp);
    unsigned char b[8];
    for (int i = 0; i < 12; i++) {
        if (binary)
            fwrite(b, 1, vm_test_put_sample(b, t, 1, values12[i]), fp);
        else
            fprintf(fp, "%g%c", values12[i], i % 5 == 4 ? '\n' : ' ');
    }
    fputs(tail ? tail : "\n", fp);
    fclose(fp);
    return path;
}

static const char *write_text_file(const char *name, const char *text) {
    const char *path = vm_test_tmp(name);
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
    return path;
}

static void check_values12(const vm_volume *v, double scale) {
    if (!v->data) return;
    for (int i = 0; i < 12; i++) CHECK_NEAR(v->data[i], values12[i] * scale, 1e-6);
}

static void check_fails(const char *path, vm_status expected, const char *fragment) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read_vtk(path, &v, &err);
    vm_test_expect_refusal(path, st, expected, &err, fragment, &v);
}

static void vtkReadsSharedIronProtWithReferenceStatistics(void) {
    const char *path = vm_test_shared("ironProt.vtk");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    CHECK(v.dims[0] == 68 && v.dims[1] == 68 && v.dims[2] == 68);
    CHECK(v.type == VM_SCALAR_UINT8);
    CHECK(strcmp(v.format, "vtk") == 0);
    for (int a = 0; a < 3; a++) {
        CHECK_NEAR(v.spacing[a], 1.0, 0);
        CHECK_NEAR(v.origin[a], 0.0, 0);
        CHECK_NEAR(v.direction[a][a], 1.0, 0);
    }
    double lo, hi, mean;
    CHECK(vm_volume_stats(&v, &lo, &hi, &mean) == 0);
    CHECK_NEAR(lo, 0, 0);
    CHECK_NEAR(hi, 255, 0);
    CHECK_NEAR(mean, 13.138259, 13.138259 * 1e-4);
    vm_volume_free(&v);
}

static const struct {
    const char *name;
    vm_scalar_type type;
} legacy_types[] = {
    {"unsigned_char", VM_SCALAR_UINT8},  {"char", VM_SCALAR_INT8},
    {"unsigned_short", VM_SCALAR_UINT16}, {"short", VM_SCALAR_INT16},
    {"unsigned_int", VM_SCALAR_UINT32},  {"int", VM_SCALAR_INT32},
    {"unsigned_long", VM_SCALAR_UINT64}, {"long", VM_SCALAR_INT64},
    {"float", VM_SCALAR_FLOAT32},        {"double", VM_SCALAR_FLOAT64},
    {"vtktypeint16", VM_SCALAR_INT16},   {"vtktypeuint64", VM_SCALAR_UINT64},
    {"vtktypefloat64", VM_SCALAR_FLOAT64},
};

static void readsEveryType(int binary) {
    for (size_t k = 0; k < sizeof legacy_types / sizeof legacy_types[0]; k++) {
        char header[512], name[64];
        snprintf(header, sizeof header,
                 "# vtk DataFile Version 3.0\ntypes\n%s\nDATASET STRUCTURED_POINTS\n"
                 "DIMENSIONS 3 2 2\nSPACING 0.5 1 2\nORIGIN -1 2 3.5\nPOINT_DATA 12\n"
                 "SCALARS s %s 1\nLOOKUP_TABLE default\n",
                 binary ? "BINARY" : "ASCII", legacy_types[k].name);
        snprintf(name, sizeof name, "legacy_%s_%s.vtk", binary ? "bin" : "ascii",
                 legacy_types[k].name);
        const char *path = write_vtk(name, header, binary, legacy_types[k].type, NULL);
        vm_volume v;
        vm_error err;
        vm_status st = vm_volume_read_vtk(path, &v, &err);
        CHECK_MSG(st == VM_OK, "%s: %s", legacy_types[k].name, err.message);
        if (st) continue;
        CHECK(v.dims[0] == 3 && v.dims[1] == 2 && v.dims[2] == 2);
        CHECK_MSG(v.type == legacy_types[k].type, "%s read as %s", legacy_types[k].name,
                  vm_scalar_type_name(v.type));
        CHECK_NEAR(v.spacing[0], 0.5, 0);
        CHECK_NEAR(v.spacing[2], 2, 0);
        CHECK_NEAR(v.origin[0], -1, 0);
        CHECK_NEAR(v.origin[2], 3.5, 0);
        check_values12(&v, 1.0);
        vm_volume_free(&v);
    }
}

static void vtkReadsAsciiScalarsOfEveryType(void) { readsEveryType(0); }
static void vtkReadsBigEndianBinaryScalarsOfEveryType(void) { readsEveryType(1); }

static void vtkAcceptsKeywordsInAnyOrderAspectRatioAndNoLookupTable(void) {
    const char *path = write_vtk("legacy_order.vtk",
                                 "# vtk DataFile Version 2.0\nany order\nbinary\n\n"
                                 "dataset structured_points\norigin 1 2 3\n"
                                 "ASPECT_RATIO 2 2 2\ndimensions 3 2 2\n\npoint_data 12\n"
                                 "SCALARS s short\n",
                                 1, VM_SCALAR_INT16, NULL);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    CHECK_NEAR(v.spacing[1], 2, 0);
    CHECK_NEAR(v.origin[1], 2, 0);
    check_values12(&v, 1.0);
    vm_volume_free(&v);
}

static void vtkSkipsFieldDataCellDataAndOtherAttributesBeforeTheScalars(void) {
    /* ASCII: FIELD in the header, CELL_DATA scalars and vectors, point VECTORS first. */
    const char *path = write_vtk(
        "legacy_skip_ascii.vtk",
        "# vtk DataFile Version 5.1\nskip\nASCII\nDATASET STRUCTURED_POINTS\n"
        "FIELD FieldData 2\ntime 1 1 double\n2.5\nnames 2 1 float\n1 2\n"
        "DIMENSIONS 3 2 2\nSPACING 1 1 1\nORIGIN 0 0 0\n"
        "CELL_DATA 2\nSCALARS c int 1\nLOOKUP_TABLE default\n7 8\nVECTORS v float\n"
        "1 2 3 4 5 6\nPOINT_DATA 12\nNORMALS n float\n"
        "0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1 0 0 1\n"
        "FIELD fd 1\nids 1 12 int\n1 2 3 4 5 6 7 8 9 10 11 12\n"
        "SCALARS s float\nLOOKUP_TABLE default\n",
        0, VM_SCALAR_FLOAT32, NULL);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    check_values12(&v, 1.0);
    vm_volume_free(&v);

    /* BINARY: cell scalars (big endian doubles) and a METADATA block before the points. */
    const char *bpath = vm_test_tmp("legacy_skip_binary.vtk");
    FILE *fp = fopen(bpath, "wb");
    CHECK(fp != NULL);
    if (!fp) return;
    fputs("# vtk DataFile Version 5.1\nskip\nBINARY\nDATASET STRUCTURED_POINTS\n"
          "DIMENSIONS 3 2 2\nSPACING 1 1 1\nORIGIN 0 0 0\nCELL_DATA 2\n"
          "SCALARS c double 1\nLOOKUP_TABLE default\n",
          fp);
    unsigned char b[8];
    fwrite(b, 1, vm_test_put_sample(b, VM_SCALAR_FLOAT64, 1, 10.0), fp);
    fwrite(b, 1, vm_test_put_sample(b, VM_SCALAR_FLOAT64, 1, 20.0), fp);
    fputs("\nMETADATA\nINFORMATION 0\n\nPOINT_DATA 12\nSCALARS s unsigned_short 1\n"
          "LOOKUP_TABLE default\n",
          fp);
    for (int i = 0; i < 12; i++)
        fwrite(b, 1, vm_test_put_sample(b, VM_SCALAR_UINT16, 1, values12[i]), fp);
    fputs("\n", fp);
    fclose(fp);
    CHECK_OK(vm_volume_read_vtk(bpath, &v, &err), &err);
    CHECK(v.type == VM_SCALAR_UINT16);
    check_values12(&v, 1.0);
    vm_volume_free(&v);
}

static void vtkReadsColorScalarsAsUnsignedCharLikeVtkDoes(void) {
    /* VTK writes unsigned char point scalars as COLOR_SCALARS: fractions in ASCII, bytes in
     * BINARY. */
    const char *path = write_text_file("legacy_color_ascii.vtk",
                                       "# vtk DataFile Version 5.1\nc\nASCII\n"
                                       "DATASET STRUCTURED_POINTS\nDIMENSIONS 3 1 1\n"
                                       "POINT_DATA 3\nCOLOR_SCALARS c 1\n0 0.501961 1\n");
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    if (v.data) CHECK(v.type == VM_SCALAR_UINT8 && v.data[0] == 0 && v.data[1] == 128 &&
                      v.data[2] == 255);
    vm_volume_free(&v);
    path = write_text_file("legacy_color_binary.vtk",
                           "# vtk DataFile Version 5.1\nc\nBINARY\nDATASET STRUCTURED_POINTS\n"
                           "DIMENSIONS 3 1 1\nPOINT_DATA 3\nCOLOR_SCALARS c 1\n\x07\x80\xff\n");
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    if (v.data) CHECK(v.data[0] == 7 && v.data[1] == 128 && v.data[2] == 255);
    vm_volume_free(&v);
}

static void vtkTurnsNegativeSpacingIntoAFlippedDirection(void) {
    const char *path = write_vtk("legacy_negative.vtk",
                                 "# vtk DataFile Version 3.0\nflip\nASCII\n"
                                 "DATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\n"
                                 "SPACING 1 -2 1\nORIGIN 0 10 0\nPOINT_DATA 12\n"
                                 "SCALARS s float\nLOOKUP_TABLE default\n",
                                 0, VM_SCALAR_FLOAT32, NULL);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read_vtk(path, &v, &err), &err);
    CHECK_NEAR(v.spacing[1], 2, 0);
    CHECK_NEAR(v.direction[1][1], -1, 0);
    double ijk[3] = {0, 1, 0}, xyz[3];
    if (v.data) {
        vm_volume_index_to_world(&v, ijk, xyz);
        CHECK_NEAR(xyz[1], 8, 1e-12);
    }
    vm_volume_free(&v);
}

static void vtkRefusesOtherDatasetsCellDataOnlyAndVectorsAsUnsupported(void) {
    static const struct {
        const char *name, *text, *fragment;
    } cases[] = {
        {"legacy_grid.vtk",
         "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_GRID\nDIMENSIONS 1 1 1\n",
         "STRUCTURED_GRID"},
        {"legacy_poly.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\n",
         "POLYDATA"},
        {"legacy_cells.vtk",
         "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
         "DIMENSIONS 2 2 2\nCELL_DATA 1\nSCALARS c float\nLOOKUP_TABLE default\n1\n",
         "no POINT_DATA"},
        {"legacy_vectors.vtk",
         "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
         "DIMENSIONS 1 1 2\nPOINT_DATA 2\nVECTORS v float\n1 2 3 4 5 6\n",
         "no SCALARS"},
        {"legacy_ncomp.vtk",
         "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
         "DIMENSIONS 1 1 2\nPOINT_DATA 2\nSCALARS s float 3\nLOOKUP_TABLE default\n"
         "1 2 3 4 5 6\n",
         "3 components"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *path = vm_test_tmp(cases[i].name);
        CHECK(vm_test_write_file(path, cases[i].text, strlen(cases[i].text)) == 0);
        check_fails(path, VM_ERR_UNSUPPORTED, cases[i].fragment);
    }
}

static void vtkRejectsBadInputWithThePathInTheMessage(void) {
    static const char *head = "# vtk DataFile Version 3.0\nbad\n";
    static const struct {
        const char *name, *text;
        vm_status status;
        const char *fragment;
    } cases[] = {
        {"legacy_empty.vtk", "", VM_ERR_FORMAT, "empty"},
        {"legacy_magic.vtk", "# not vtk\nx\nASCII\n", VM_ERR_FORMAT, "not a VTK legacy file"},
        {"legacy_oneline.vtk", "# vtk DataFile Version 3.0", VM_ERR_FORMAT, "first line"},
        {"legacy_mode.vtk", "#\nx\nTEXT\n", VM_ERR_FORMAT, "not a VTK"},
        {"legacy_filetype.vtk", "# vtk DataFile Version 3.0\nx\nTEXT\n", VM_ERR_FORMAT,
         "not ASCII or BINARY"},
        {"legacy_truncated_ascii.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nPOINT_DATA 12\n"
         "SCALARS s float\nLOOKUP_TABLE default\n1 2 3\n",
         VM_ERR_FORMAT, "truncated (got 3 of 12 values)"},
        {"legacy_truncated_binary.vtk",
         "BINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nPOINT_DATA 12\n"
         "SCALARS s float\nLOOKUP_TABLE default\n\x01\x02\x03\x04\x05",
         VM_ERR_FORMAT, "truncated (got 5 of 48 bytes)"},
        {"legacy_lying_count.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 2 2\nPOINT_DATA 10\n"
         "SCALARS s float\nLOOKUP_TABLE default\n1 2 3 4 5 6 7 8 9 10\n",
         VM_ERR_FORMAT, "does not match DIMENSIONS"},
        {"legacy_overflow.vtk",
         "BINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4294967296 4294967296 4294967296\n"
         "POINT_DATA 1\nSCALARS s float\nLOOKUP_TABLE default\n",
         VM_ERR_NOMEM, "overflow"},
        {"legacy_huge.vtk",
         "BINARY\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1000000 1000000 1000\n"
         "POINT_DATA 1000000000000000\nSCALARS s float\nLOOKUP_TABLE default\n",
         VM_ERR_NOMEM, "memory limit"},
        {"legacy_zero_dim.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 3 0 2\n", VM_ERR_FORMAT, ">= 1"},
        {"legacy_type.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 1\nPOINT_DATA 1\n"
         "SCALARS s quaternion\nLOOKUP_TABLE default\n1\n",
         VM_ERR_FORMAT, "unsupported type 'quaternion'"},
        {"legacy_number.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 2\nPOINT_DATA 2\n"
         "SCALARS s float\nLOOKUP_TABLE default\n1 x2\n",
         VM_ERR_FORMAT, "sample 1 ('x2') is not a number"},
        {"legacy_spacing.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 2\nSPACING 1 nan 1\n",
         VM_ERR_FORMAT, "SPACING"},
        {"legacy_zero_spacing.vtk",
         "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 1\nSPACING 1 0 1\nPOINT_DATA 1\n"
         "SCALARS s float\nLOOKUP_TABLE default\n1\n",
         VM_ERR_FORMAT, "zero"},
        {"legacy_no_dims.vtk", "ASCII\nDATASET STRUCTURED_POINTS\nSPACING 1 1 1\n",
         VM_ERR_FORMAT, "no DIMENSIONS"},
        {"legacy_keyword.vtk", "ASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 1 1 1\nCOLOR 1\n",
         VM_ERR_FORMAT, "unexpected keyword 'COLOR'"},
        {"legacy_field_lies.vtk",
         "BINARY\nDATASET STRUCTURED_POINTS\nFIELD f 1\na 1 99999999999 double\n\x01\x02",
         VM_ERR_FORMAT, "FIELD array data is truncated"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *path = vm_test_tmp(cases[i].name);
        char text[1024];
        int plain = i < 5;
        snprintf(text, sizeof text, "%s%s", plain ? "" : head, cases[i].text);
        CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
        check_fails(path, cases[i].status, cases[i].fragment);
    }
    check_fails(vm_test_tmp("."), VM_ERR_IO, "directory");
    check_fails(vm_test_tmp("legacy_does_not_exist.vtk"), VM_ERR_IO, "cannot open");
}

static void vtkCliInfoReportsABadFileOnOneLineAndExitsWith2(void) {
    const char *path = vm_test_tmp("legacy_cli_bad.vtk");
    const char *text = "# vtk DataFile Version 3.0\nx\nBINARY\nDATASET STRUCTURED_POINTS\n"
                       "DIMENSIONS 4 4 4\nPOINT_DATA 64\nSCALARS s int\nLOOKUP_TABLE default\n"
                       "abc";
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
    vm_test_expect_cli_error(NULL, path, NULL);
    /* And a good file through the CLI reports its dims. */
    const char *good = write_vtk("legacy_cli_good.vtk",
                                 "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
                                 "DIMENSIONS 3 2 2\nPOINT_DATA 12\nSCALARS s float\n"
                                 "LOOKUP_TABLE default\n",
                                 0, VM_SCALAR_FLOAT32, NULL);
    char args[4200], *out = NULL;
    snprintf(args, sizeof args, "info '%s' --json", good);
    int rc = vm_test_cli(args, &out);
    CHECK_MSG(rc == 0, "exit %d: %s", rc, out ? out : "");
    if (out) {
        CHECK_MSG(strstr(out, "\"dims\": [3, 2, 2]") && strstr(out, "\"format\": \"vtk\""),
                  "output: %s", out);
        free(out);
    }
}

TEST_MAIN(T(vtkReadsSharedIronProtWithReferenceStatistics), T(vtkReadsAsciiScalarsOfEveryType),
          T(vtkReadsBigEndianBinaryScalarsOfEveryType),
          T(vtkAcceptsKeywordsInAnyOrderAspectRatioAndNoLookupTable),
          T(vtkSkipsFieldDataCellDataAndOtherAttributesBeforeTheScalars),
          T(vtkReadsColorScalarsAsUnsignedCharLikeVtkDoes),
          T(vtkTurnsNegativeSpacingIntoAFlippedDirection),
          T(vtkRefusesOtherDatasetsCellDataOnlyAndVectorsAsUnsupported),
          T(vtkRejectsBadInputWithThePathInTheMessage),
          T(vtkCliInfoReportsABadFileOnOneLineAndExitsWith2))
