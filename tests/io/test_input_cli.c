/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_input_cli.c — the input options every reading command shares: --series
 * (a DICOM folder of two series, tests/io/dicom_writer.h), `info FOLDER` listing them, the
 * note on the default choice, --spacing, and their C API (vm_volume_read_with, readers). */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include "io/dicom_writer.h"
#include "test.h"

enum { NX = 8, NY = 7, NZ = 6, PLANE = NX * NY };
#define CT_UID "1.2.826.0.1.3680043.2.1125.7.1"
#define SCOUT_UID "1.2.826.0.1.3680043.2.1125.7.2"

static uint32_t words[NZ][PLANE];

/* An axial slice k of the CT series (a ball of 1000 in 0), or of the one-slice scout. */
static dw_spec slice(int k, int scout) {
    dw_spec s;
    memset(&s, 0, sizeof s);
    s.syntax = k % 2 ? TS_EXPLICIT : TS_IMPLICIT;
    s.series_uid = scout ? SCOUT_UID : CT_UID;
    s.modality = "CT";
    s.description = scout ? "scout" : "axial CT";
    s.rows = NY, s.cols = NX, s.frames = 1;
    s.bits_allocated = 16, s.bits_stored = 16, s.high_bit = 15;
    s.has_position = s.has_orientation = 1;
    s.position[0] = 10.0, s.position[1] = -5.0, s.position[2] = 2.0 * k + (scout ? 300 : 0);
    s.orientation[0] = 1.0, s.orientation[4] = 1.0;
    s.spacing[0] = 0.5, s.spacing[1] = 0.5;
    for (int j = 0; j < NY; j++)
        for (int i = 0; i < NX; i++) {
            double r2 = (i - 3.5) * (i - 3.5) + (j - 3.0) * (j - 3.0) + (k - 2.5) * (k - 2.5);
            words[k][i + NX * j] = r2 < 6.0 ? 1000u : 0u;
        }
    s.words = words[k];
    return s;
}

/* The folder of the CT series (6 slices) and the scout (1 slice); its path. */
static const char *two_series(void) {
    static char dir[4096];
    snprintf(dir, sizeof dir, "%s", vm_test_tmp("input_cli_dicom"));
    char cmd[8400], path[8400];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    CHECK(system(cmd) == 0);
    for (int k = 0; k < NZ; k++) {
        dw_spec s = slice(k, 0);
        snprintf(path, sizeof path, "%s/ct%d", dir, (k * 5) % NZ);
        CHECK(dw_write(path, &s) == 0);
    }
    dw_spec s = slice(0, 1);
    snprintf(path, sizeof path, "%s/scout", dir);
    CHECK(dw_write(path, &s) == 0);
    return dir;
}

/* Runs volmesh with args; [out] *out (free), the exit code. */
static int run(char **out, const char *fmt, const char *dir, const char *more) {
    char args[8400];
    snprintf(args, sizeof args, fmt, dir, more ? more : "");
    return vm_test_cli(args, out);
}

/* Exit 2 with exactly one line that contains phrase. */
static void expect_one_line_refusal(const char *args, const char *phrase) {
    char *out = NULL;
    int rc = vm_test_cli(args, &out);
    CHECK_MSG(rc == 2, "volmesh %s exited %d", args, rc);
    CHECK_MSG(out && strstr(out, phrase), "volmesh %s printed '%s', without '%s'", args,
              out ? out : "", phrase);
    CHECK_MSG(out && strchr(out, '\n') == out + strlen(out) - 1, "volmesh %s: not one line: %s",
              args, out ? out : "");
    free(out);
}

static void infoListsEverySeriesAndMarksTheOneRead(void) {
    const char *dir = two_series();
    char *out = NULL;
    CHECK(run(&out, "info '%s'%s", dir, NULL) == 0);
    CHECK_MSG(out && strstr(out, "dims       8 x 7 x 6") && strstr(out, "2 DICOM series") &&
                  strstr(out, "*  1  CT       6 slices  " CT_UID "  \"axial CT\"") &&
                  strstr(out, "   2  CT       1 slice   " SCOUT_UID "  \"scout\""),
              "%s", out ? out : "");
    CHECK_MSG(out && !strstr(out, "choose another"), "info lists on stdout, no note: %s", out);
    free(out);
    CHECK(run(&out, "info '%s' --json%s", dir, NULL) == 0);
    CHECK_MSG(out && strstr(out, "\"dims\": [8, 7, 6]") &&
                  strstr(out, "\"series\": [{\"number\": 1, \"uid\": \"" CT_UID
                              "\", \"description\": \"axial CT\", \"modality\": \"CT\", "
                              "\"slices\": 6, \"read\": true}, {\"number\": 2"),
              "%s", out ? out : "");
    free(out);
}

static void seriesChoosesByNumberOrUidAndRefusesOthersInOneLine(void) {
    const char *dir = two_series();
    char *out = NULL;
    CHECK(run(&out, "info '%s' --json --series 2%s", dir, NULL) == 0);
    CHECK_MSG(out && strstr(out, "\"dims\": [8, 7, 1]") && strstr(out, "\"slices\": 1, \"read\": true"),
              "%s", out ? out : "");
    free(out);
    CHECK(run(&out, "info '%s' --json --series " SCOUT_UID "%s", dir, NULL) == 0);
    CHECK_MSG(out && strstr(out, "\"dims\": [8, 7, 1]") && strstr(out, "\"origin\": [10, -5, 300]"),
              "%s", out ? out : "");
    free(out);
    char args[4400];
    snprintf(args, sizeof args, "info '%s' --series 3", dir);
    expect_one_line_refusal(args, "series 3 does not exist (2 series found");
    snprintf(args, sizeof args, "mesh '%s' --series 1.2.3 --iso 500 -o x.vtu", dir);
    expect_one_line_refusal(args, "no series with SeriesInstanceUID 1.2.3");
    snprintf(args, sizeof args, "info '%s' --series", dir);
    expect_one_line_refusal(args, "--series needs a value");
    /* a volume file has no series: the choice is ignored */
    CHECK(!vm_test_exists("x.vtu"));
}

static void theDefaultSeriesComesWithANoteListingTheOthers(void) {
    const char *dir = two_series();
    char *out = NULL;
    const char *vtu = vm_test_tmp("input_cli_default.vtu");
    char more[4200];
    snprintf(more, sizeof more, " --iso 500 --quiet -o '%s'", vtu);
    CHECK(run(&out, "mesh '%s'%s", dir, more) == 0);
    CHECK_MSG(out && strstr(out, "holds 2 DICOM series; read series 1 (6 slices, UID " CT_UID) &&
                  strstr(out, "volmesh:   2  " SCOUT_UID "  \"scout\"  1 slice"),
              "%s", out ? out : "");
    free(out);
    /* chosen explicitly, or by slabs: the same note only for the default */
    snprintf(more, sizeof more, " --series 1 --iso 500 --quiet -o '%s'", vtu);
    CHECK(run(&out, "mesh '%s'%s", dir, more) == 0);
    CHECK_MSG(out && !strstr(out, "DICOM series"), "%s", out ? out : "");
    free(out);
    snprintf(more, sizeof more, " --slabs 2 --iso 500 --quiet -o '%s'", vtu);
    CHECK(run(&out, "mesh '%s'%s", dir, more) == 0);
    CHECK_MSG(out && strstr(out, "read series 1 (6 slices"), "%s", out ? out : "");
    free(out);
}

/* A 12 x 10 x 9 NRRD ball with origin (1, 2, 3), written to path. */
static void write_ball(const char *path) {
    vm_volume v;
    vm_error err;
    const int64_t dims[3] = {12, 10, 9};
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    for (int64_t k = 0; k < 9; k++)
        for (int64_t j = 0; j < 10; j++)
            for (int64_t i = 0; i < 12; i++) {
                double r2 = (i - 5.5) * (i - 5.5) + (j - 4.5) * (j - 4.5) + (k - 4.0) * (k - 4.0);
                v.data[i + 12 * (j + 10 * k)] = (float)(16.0 - r2);
            }
    v.origin[0] = 1, v.origin[1] = 2, v.origin[2] = 3;
    CHECK_OK(vm_volume_write_nrrd(path, &v, 0, &err), &err);
    vm_volume_free(&v);
}

static void spacingReplacesTheFileSpacingInWholeHeaderAndSlabReads(void) {
    const char *path = vm_test_tmp("input_cli_ball.nrrd");
    write_ball(path);
    vm_volume_read_options o;
    vm_volume_read_options_init(&o);
    o.has_spacing = 1, o.spacing[0] = 0.25, o.spacing[1] = 2.0, o.spacing[2] = 3.5;
    vm_volume whole, plain;
    vm_error err;
    CHECK_OK(vm_volume_read_with(path, &o, &whole, &err), &err);
    CHECK_OK(vm_volume_read_with(path, NULL, &plain, &err), &err);
    CHECK(whole.spacing[0] == 0.25 && whole.spacing[1] == 2.0 && whole.spacing[2] == 3.5);
    CHECK(plain.spacing[0] == 1.0 && plain.spacing[2] == 1.0);
    CHECK(memcmp(whole.data, plain.data, vm_volume_count(&plain) * sizeof(float)) == 0);
    CHECK(whole.origin[0] == 1 && whole.origin[1] == 2 && whole.origin[2] == 3);
    /* a reader keeps the spacing: header and slabs, the slab's origin moved by the new sz */
    vm_volume info;
    vm_volume_reader *r = NULL;
    CHECK_OK(vm_volume_reader_open_with(path, &o, &info, &r, &err), &err);
    CHECK(info.spacing[0] == 0.25 && info.spacing[2] == 3.5 && !info.data);
    float planes[12 * 10 * 3];
    CHECK_OK(vm_volume_reader_read(r, 4, 7, planes, &err), &err);
    CHECK(memcmp(planes, whole.data + 4 * 120, sizeof planes) == 0);
    vm_volume_reader_close(r);
    vm_volume_free(&info);
    /* the DICOM series with a series choice and a spacing: both apply */
    const char *dir = two_series();
    vm_volume d;
    o.series = "2";
    CHECK_OK(vm_volume_read_with(dir, &o, &d, &err), &err);
    CHECK(d.dims[2] == 1 && d.spacing[0] == 0.25 && d.origin[2] == 300.0);
    vm_volume_free(&d);
    o.series = CT_UID;
    CHECK_OK(vm_volume_reader_open_with(dir, &o, &info, &r, &err), &err);
    CHECK(info.dims[2] == NZ && info.spacing[1] == 2.0);
    vm_volume_reader_close(r);
    vm_volume_free(&info);
    /* out of range, refused by the API as by the CLI */
    const double bad[] = {0.0, -1.0, 1e-10, 2e9, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o.spacing[1] = bad[i];
        vm_status st = vm_volume_read_with(path, &o, &d, &err);
        CHECK_MSG(st == VM_ERR_ARG && strstr(err.message, "spacing") &&
                      strstr(err.message, "input_cli_ball.nrrd"),
                  "spacing %g: %d %s", bad[i], (int)st, err.message);
        CHECK(vm_volume_reader_open_with(path, &o, NULL, &r, &err) == VM_ERR_ARG && !r);
    }
    vm_volume_free(&whole);
    vm_volume_free(&plain);
}

static void spacingOptionReachesEveryReadingCommand(void) {
    const char *path = vm_test_tmp("input_cli_ball.nrrd");
    write_ball(path);
    char *out = NULL;
    CHECK(run(&out, "info '%s' --json --spacing 0.5,2,1e-3%s", path, NULL) == 0);
    CHECK_MSG(out && strstr(out, "\"spacing\": [0.5, 2, 0.001]"), "%s", out ? out : "");
    free(out);
    /* the mesh of --spacing equals the mesh of the volume with that spacing, whole or by
     * slabs */
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    v.spacing[0] = 0.5, v.spacing[1] = 2.0, v.spacing[2] = 1.5;
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.lo = 0.0, mo.has_lo = 1;
    vm_mesh want;
    vm_mesh_init(&want, VM_TET4);
    CHECK_OK(vm_mesh_volume(&v, &mo, &want, NULL, &err), &err);
    const char *vtu = vm_test_tmp("input_cli_spacing.vtu");
    static const char *const modes[] = {"", " --slabs 3"};
    for (int m = 0; m < 2; m++) {
        char more[4400];
        snprintf(more, sizeof more, " --spacing 0.5,2,1.5 --iso 0 --no-improve --quiet%s -o '%s'",
                 modes[m], vtu);
        CHECK(run(&out, "mesh '%s'%s", path, more) == 0);
        free(out);
        vm_mesh got;
        vm_mesh_init(&got, VM_TET4);
        CHECK_OK(vm_mesh_read(vtu, &got, &err), &err);
        double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
        double wlo[3] = {1e300, 1e300, 1e300}, whi[3] = {-1e300, -1e300, -1e300};
        for (size_t p = 0; p < got.npoints; p++)
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], got.points[3 * p + a]);
                hi[a] = fmax(hi[a], got.points[3 * p + a]);
            }
        for (size_t p = 0; p < want.npoints; p++)
            for (int a = 0; a < 3; a++) {
                wlo[a] = fmin(wlo[a], want.points[3 * p + a]);
                whi[a] = fmax(whi[a], want.points[3 * p + a]);
            }
        CHECK_MSG(got.ncells == want.ncells && got.npoints == want.npoints,
                  "%s: %zu cells, %zu points; expected %zu, %zu", modes[m], (size_t)got.ncells,
                  (size_t)got.npoints, (size_t)want.ncells, (size_t)want.npoints);
        for (int a = 0; a < 3; a++) {
            CHECK_NEAR(lo[a], wlo[a], 1e-9);
            CHECK_NEAR(hi[a], whi[a], 1e-9);
        }
        vm_mesh_free(&got);
    }
    vm_mesh_free(&want);
    vm_volume_free(&v);
    CHECK(run(&out, "spectrum '%s' --n 4 --quiet --spacing 2,2,2%s", path, NULL) == 0);
    free(out);
    const char *den = vm_test_tmp("input_cli_den.nrrd");
    char more[4400];
    snprintf(more, sizeof more, " --spacing 2,2,2 --quiet -o '%s'", den);
    CHECK(run(&out, "denoise '%s'%s", path, more) == 0);
    free(out);
    CHECK_OK(vm_volume_read(den, &v, &err), &err);
    CHECK(v.spacing[0] == 2.0 && v.spacing[2] == 2.0);
    vm_volume_free(&v);
}

static void spacingRefusesWhatNoReaderAcceptsInOneLine(void) {
    const char *path = vm_test_tmp("input_cli_ball.nrrd");
    write_ball(path);
    static const char *const bad[] = {"0,1,1", "1,-2,1", "1,1,nan", "1,inf,1", "1e10,1,1",
                                      "1e-12,1,1", "1,1", "1,1,1,1", "a,b,c", "1;1;1"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char args[4400];
        snprintf(args, sizeof args, "info '%s' --spacing '%s'", path, bad[i]);
        expect_one_line_refusal(args, "--spacing: '");
        snprintf(args, sizeof args, "mesh '%s' --iso 0 --spacing '%s' -o x.vtu", path, bad[i]);
        expect_one_line_refusal(args, "--spacing: '");
    }
    CHECK(!vm_test_exists("x.vtu"));
}

TEST_MAIN(T(infoListsEverySeriesAndMarksTheOneRead),
          T(seriesChoosesByNumberOrUidAndRefusesOthersInOneLine),
          T(theDefaultSeriesComesWithANoteListingTheOthers),
          T(spacingReplacesTheFileSpacingInWholeHeaderAndSlabReads),
          T(spacingOptionReachesEveryReadingCommand),
          T(spacingRefusesWhatNoReaderAcceptsInOneLine))
