/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_dicom.c — the DICOM reader against files written here
 * (tests/io/dicom_writer.h): an oblique CT series in shuffled, mixed-syntax files beside a
 * second series reads to the exact voxels and geometry and meshes like the same voxels given
 * directly; every decoded syntax; values (rescale, sign, BitsStored, padding, dose);
 * multi-frame; series choice; and every kind of bad input refused as "PATH: problem". */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "io/dicom_writer.h"
#include "test.h"

enum { NX = 6, NY = 5, NZ = 6, PLANE = NX * NY, NVOX = PLANE * NZ };

/* An oblique orientation with exact decimals: rows (0.6, 0.8, 0), columns (-0.48, 0.36, 0.8),
 * normal their cross product (0.64, -0.48, 0.6); slices 1.25 mm apart along it. */
static const double ROW[3] = {0.6, 0.8, 0.0}, COL[3] = {-0.48, 0.36, 0.8},
                    NORMAL[3] = {0.64, -0.48, 0.6}, ORIGIN[3] = {-100.5, 20.25, 30.0};
static const double GAP = 1.25, PIXEL_SPACING[2] = {0.7, 0.5}; /* (rows, columns) */
static const double SLOPE = 1.5, INTERCEPT = -1024.0;

/* Stored word of voxel (i, j, k): a blob of about +300 HU in -900 HU. */
static uint32_t blob_word(int i, int j, int k) {
    double r2 = (i - 2.5) * (i - 2.5) + (j - 2.0) * (j - 2.0) + (k - 2.5) * (k - 2.5);
    return r2 < 4.0 ? 900u + (uint32_t)(20 * i + 3 * j + k) : 80u + (uint32_t)(i + j + k);
}

static uint32_t words[NZ][PLANE];

/* Fills the stored words of the CT series. */
static void fill_words(void) {
    for (int k = 0; k < NZ; k++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) words[k][i + NX * j] = blob_word(i, j, k);
}

/* The spec of slice k of the CT series in syntax ts. */
static dw_spec ct_slice(int k, const char *ts) {
    dw_spec s;
    memset(&s, 0, sizeof s);
    s.syntax = ts;
    s.series_uid = "1.2.826.0.1.3680043.2.1125.1.1";
    s.modality = "CT";
    s.description = "oblique CT";
    s.rows = NY, s.cols = NX, s.frames = 1;
    s.bits_allocated = 16, s.bits_stored = 12, s.high_bit = 11;
    s.has_position = s.has_orientation = 1;
    for (int a = 0; a < 3; a++) {
        s.position[a] = ORIGIN[a] + k * GAP * NORMAL[a];
        s.orientation[a] = ROW[a];
        s.orientation[3 + a] = COL[a];
    }
    s.spacing[0] = PIXEL_SPACING[0], s.spacing[1] = PIXEL_SPACING[1];
    s.slice_thickness = 3.0; /* disagrees with the 1.25 mm between positions */
    s.has_rescale = 1, s.slope = SLOPE, s.intercept = INTERCEPT;
    s.words = words[k];
    return s;
}

/* The volume the CT series must read to, built directly. */
static void expected_ct(vm_volume *v) {
    vm_error err;
    const int64_t dims[3] = {NX, NY, NZ};
    CHECK_OK(vm_volume_alloc(v, dims, &err), &err);
    for (int k = 0; k < NZ; k++)
        for (int p = 0; p < PLANE; p++)
            v->data[k * PLANE + p] = (float)(words[k][p] * SLOPE + INTERCEPT);
    v->spacing[0] = PIXEL_SPACING[1], v->spacing[1] = PIXEL_SPACING[0], v->spacing[2] = GAP;
    for (int a = 0; a < 3; a++) {
        v->origin[a] = ORIGIN[a];
        v->direction[a][0] = ROW[a], v->direction[a][1] = COL[a],
        v->direction[a][2] = NORMAL[a];
    }
}

/* A fresh folder under the test temp folder. */
static const char *fresh_dir(const char *name) {
    const char *dir = vm_test_tmp(name);
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s/sub/deeper'", dir, dir);
    CHECK(system(cmd) == 0);
    return dir;
}

/* dir/name in a rotating static buffer. */
static const char *join(const char *dir, const char *name) {
    static char buf[4][4200];
    static int slot;
    char *p = buf[slot++ % 4];
    snprintf(p, 4200, "%s/%s", dir, name);
    return p;
}

/* Voxels equal exactly, geometry to tol. */
static void expect_same(const vm_volume *got, const vm_volume *want, double tol,
                        const char *what) {
    CHECK_MSG(memcmp(got->dims, want->dims, sizeof got->dims) == 0, "%s: dims %lld %lld %lld",
              what, (long long)got->dims[0], (long long)got->dims[1], (long long)got->dims[2]);
    if (memcmp(got->dims, want->dims, sizeof got->dims) != 0 || !got->data) return;
    size_t n = vm_volume_count(got), bad = 0;
    for (size_t i = 0; i < n; i++)
        if (got->data[i] != want->data[i] && bad++ == 0)
            CHECK_MSG(0, "%s: voxel %zu is %.9g, expected %.9g", what, i, got->data[i],
                      want->data[i]);
    for (int a = 0; a < 3; a++) {
        CHECK_NEAR(got->spacing[a], want->spacing[a], tol);
        CHECK_NEAR(got->origin[a], want->origin[a], tol);
        for (int c = 0; c < 3; c++)
            CHECK_NEAR(got->direction[a][c], want->direction[a][c], tol);
    }
}

/* Writes the CT series (slice k of it into names[k], syntaxes alternating implicit and
 * explicit), a one-slice second series, a text file and a DICOM file without pixels. */
static void write_ct_folder(const char *dir) {
    static const char *const names[NZ] = {"zz01", "sub/a7", "IMG_0003.txt", "m",
                                          "sub/deeper/b.dcm", "0001"};
    static const int order[NZ] = {3, 0, 5, 1, 4, 2}; /* file i holds slice order[i] */
    for (int i = 0; i < NZ; i++) {
        dw_spec s = ct_slice(order[i], i % 2 ? TS_EXPLICIT : TS_IMPLICIT);
        CHECK(dw_write(join(dir, names[i]), &s) == 0);
    }
    dw_spec scout = ct_slice(0, TS_EXPLICIT);
    scout.series_uid = "1.2.826.0.1.3680043.2.1125.1.2";
    scout.description = "scout";
    scout.position[2] += 500.0;
    CHECK(dw_write(join(dir, "sub/scout"), &scout) == 0);
    dw_spec report = ct_slice(0, TS_EXPLICIT);
    report.no_pixels = 1;
    report.series_uid = "1.2.826.0.1.3680043.2.1125.1.3";
    CHECK(dw_write(join(dir, "report"), &report) == 0);
    CHECK(vm_test_write_file(join(dir, "notes.txt"), "not DICOM\n", 10) == 0);
}

/* Sorted rows of a mesh's points and of its tets' corner coordinates. */
static int same_mesh(const vm_mesh *a, const vm_mesh *b, double tol) {
    if (a->npoints != b->npoints || a->ncells != b->ncells) return 0;
    if (memcmp(a->cells, b->cells, a->ncells * 4 * sizeof *a->cells) != 0) return 0;
    for (size_t i = 0; i < 3 * a->npoints; i++)
        if (!(fabs(a->points[i] - b->points[i]) <= tol)) return 0;
    return 1;
}

/* The default tet mesh of v. */
static void mesh_of(const vm_volume *v, vm_mesh *m) {
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_error err;
    vm_mesh_init(m, VM_TET4);
    CHECK_OK(vm_mesh_volume(v, &o, m, NULL, &err), &err);
}

static void dicomReadsShuffledMixedSyntaxObliqueSeriesExactly(void) {
    fill_words();
    const char *dir = fresh_dir("dicom_ct");
    write_ct_folder(dir);
    vm_volume want, got, direct;
    vm_error err;
    expected_ct(&want);
    CHECK_OK(vm_volume_read(dir, &got, &err), &err);
    if (!got.data) return;
    CHECK(strcmp(got.format, "dicom") == 0);
    CHECK(got.type == VM_SCALAR_UINT16);
    expect_same(&got, &want, 1e-12, "CT folder");
    CHECK_OK(vm_volume_read_dicom(dir, NULL, &direct, &err), &err);
    expect_same(&direct, &got, 0.0, "vm_volume_read_dicom");
    vm_volume_free(&direct);
    /* the same voxels given directly mesh to the same mesh: exactly with the geometry read,
     * and to rounding with the geometry written as exact decimals */
    vm_volume same = want;
    memcpy(same.spacing, got.spacing, sizeof same.spacing);
    memcpy(same.origin, got.origin, sizeof same.origin);
    memcpy(same.direction, got.direction, sizeof same.direction);
    vm_mesh a, b, c;
    mesh_of(&got, &a);
    mesh_of(&same, &b);
    mesh_of(&want, &c);
    CHECK(a.ncells > 0);
    CHECK_MSG(same_mesh(&a, &b, 0.0), "meshes differ (%zu/%zu points, %zu/%zu tets)",
              a.npoints, b.npoints, a.ncells, b.ncells);
    CHECK(same_mesh(&a, &c, 1e-9));
    vm_mesh_free(&a), vm_mesh_free(&b), vm_mesh_free(&c);
    vm_volume_free(&got);
    vm_volume_free(&want);
}

static void dicomListsSeriesAndReadsTheOneChosen(void) {
    fill_words();
    const char *dir = fresh_dir("dicom_list");
    write_ct_folder(dir);
    vm_dicom_series_info *list = NULL;
    size_t n = 0;
    vm_error err;
    CHECK_OK(vm_dicom_list_series(dir, &list, &n, &err), &err);
    CHECK(n == 2);
    if (n == 2) {
        CHECK(strcmp(list[0].uid, "1.2.826.0.1.3680043.2.1125.1.1") == 0);
        CHECK(list[0].slices == NZ && list[0].files == NZ && list[0].dims[0] == NX &&
              list[0].dims[1] == NY && list[0].dims[2] == NZ);
        CHECK(strcmp(list[0].modality, "CT") == 0 &&
              strcmp(list[0].description, "oblique CT") == 0);
        CHECK(strcmp(list[1].description, "scout") == 0 && list[1].slices == 1);
    }
    vm_dicom_series_free(list);
    vm_volume v;
    CHECK_OK(vm_volume_read_dicom(dir, "2", &v, &err), &err);
    CHECK(v.dims[2] == 1);
    CHECK_NEAR(v.origin[2], ORIGIN[2] + 500.0, 1e-9);
    vm_volume_free(&v);
    CHECK_OK(vm_volume_read_dicom(dir, "1.2.826.0.1.3680043.2.1125.1.2", &v, &err), &err);
    CHECK(v.dims[2] == 1);
    vm_volume_free(&v);
    vm_status st = vm_volume_read_dicom(dir, "3", &v, &err);
    CHECK(st == VM_ERR_ARG && strstr(err.message, "series 3 does not exist"));
    st = vm_volume_read_dicom(dir, "1.2.3", &v, &err);
    CHECK(st == VM_ERR_ARG && strstr(err.message, "no series with SeriesInstanceUID 1.2.3"));
    /* one file alone is its own one-slice volume, recognised by content whatever its name */
    CHECK_OK(vm_volume_read(join(dir, "m"), &v, &err), &err);
    CHECK(v.dims[2] == 1);
    vm_volume_free(&v);
    CHECK(rename(join(dir, "m"), join(dir, "m.nrrd")) == 0);
    CHECK_OK(vm_volume_read(join(dir, "m.nrrd"), &v, &err), &err);
    CHECK(strcmp(v.format, "dicom") == 0 && v.dims[2] == 1);
    vm_volume_free(&v);
}

static void dicomReadsSlabsAndHeaderOnlyLikeTheWholeRead(void) {
    fill_words();
    const char *dir = fresh_dir("dicom_slab");
    write_ct_folder(dir);
    vm_volume whole, info, slab;
    vm_error err;
    CHECK_OK(vm_volume_read(dir, &whole, &err), &err);
    CHECK_OK(vm_volume_read_info(dir, &info, &err), &err);
    CHECK(info.data == NULL && memcmp(info.dims, whole.dims, sizeof info.dims) == 0);
    vm_volume_free(&info);
    CHECK_OK(vm_volume_read_slab(dir, 2, 5, &slab, &err), &err);
    if (whole.data && slab.data) {
        CHECK(slab.dims[2] == 3);
        CHECK(memcmp(slab.data, whole.data + 2 * PLANE, 3 * PLANE * sizeof(float)) == 0);
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(slab.origin[a], ORIGIN[a] + 2 * GAP * NORMAL[a], 1e-9);
    }
    vm_volume_free(&slab);
    /* forward, two planes at a time, through a reader */
    vm_volume_reader *r = NULL;
    float planes[2 * PLANE];
    CHECK_OK(vm_volume_reader_open(dir, NULL, NULL, &r, &err), &err);
    for (int k = 0; r && whole.data && k < NZ; k += 2) {
        CHECK_OK(vm_volume_reader_read(r, k, k + 2, planes, &err), &err);
        CHECK(memcmp(planes, whole.data + k * PLANE, sizeof planes) == 0);
    }
    vm_volume_reader_close(r);
    CHECK_OK(vm_volume_read_dicom_info(dir, "2", &info, &err), &err);
    CHECK(info.data == NULL && info.dims[2] == 1);
    vm_volume_free(&whole);
}

/* The CT series in one syntax, in its own folder, read against the expected volume. */
static void read_in_syntax(const char *ts, const char *name) {
    const char *dir = fresh_dir(name);
    for (int k = 0; k < NZ; k++) {
        dw_spec s = ct_slice(k, ts);
        char fname[32];
        snprintf(fname, sizeof fname, "f%d", (k * 5) % NZ);
        s = ct_slice((k * 5) % NZ, ts);
        CHECK(dw_write(join(dir, fname), &s) == 0);
    }
    vm_volume want, got;
    vm_error err;
    expected_ct(&want);
    vm_status st = vm_volume_read(dir, &got, &err);
    CHECK_MSG(st == VM_OK, "%s: %s", ts, err.message);
    if (!st) expect_same(&got, &want, 1e-12, ts);
    vm_volume_free(&got);
    vm_volume_free(&want);
}

static void dicomReadsBigEndianDeflatedAndRleLikeImplicit(void) {
    fill_words();
    read_in_syntax(TS_IMPLICIT, "dicom_implicit");
    read_in_syntax(TS_EXPLICIT, "dicom_explicit");
    read_in_syntax(TS_BIG, "dicom_big");
    read_in_syntax(TS_DEFLATED, "dicom_deflated");
    read_in_syntax(TS_RLE, "dicom_rle");
}

/* A one-slice file of the given words and layout; returns its path. */
static const char *one_file(const char *name, const char *ts, int bits, int stored, int high,
                            int signed_, const uint32_t *w, int n) {
    static dw_spec s;
    memset(&s, 0, sizeof s);
    s.syntax = ts;
    s.series_uid = "1.2.3.4.5";
    s.rows = 1, s.cols = n, s.frames = 1;
    s.bits_allocated = bits, s.bits_stored = stored, s.high_bit = high, s.pixel_rep = signed_;
    s.spacing[0] = s.spacing[1] = 1.0;
    s.words = w;
    const char *path = vm_test_tmp(name);
    CHECK(dw_write(path, &s) == 0);
    return path;
}

static void dicomMasksBitsStoredAndSignExtends(void) {
    /* 12 bits in 16, garbage above bit 11: signed -2048..2047 */
    const uint32_t w[6] = {0xF000u | 0x7FF, 0xA000u | 0x800, 0x0FFF, 0x5001, 0, 0xFFFF};
    const float want[6] = {2047, -2048, -1, 1, 0, -1};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(one_file("dicom_mask.dcm", TS_EXPLICIT, 16, 12, 11, 1, w, 6), &v,
                            &err), &err);
    for (int i = 0; v.data && i < 6; i++)
        CHECK_MSG(v.data[i] == want[i], "signed %d: %g", i, v.data[i]);
    CHECK(v.type == VM_SCALAR_INT16);
    vm_volume_free(&v);
    /* unsigned 12 bits; and stored bits below a HighBit of 13 (shifted by 2) */
    const float want_u[6] = {2047, 2048, 4095, 1, 0, 4095};
    CHECK_OK(
        vm_volume_read(one_file("dicom_mask_u.dcm", TS_BIG, 16, 12, 11, 0, w, 6), &v, &err),
        &err);
    for (int i = 0; v.data && i < 6; i++)
        CHECK_MSG(v.data[i] == want_u[i], "unsigned %d: %g", i, v.data[i]);
    vm_volume_free(&v);
    const uint32_t hw[2] = {0x3FFC, 0x0004};
    CHECK_OK(vm_volume_read(one_file("dicom_mask_h.dcm", TS_IMPLICIT, 16, 12, 13, 0, hw, 2), &v,
                            &err),
             &err);
    if (v.data) CHECK(v.data[0] == 4095 && v.data[1] == 1);
    vm_volume_free(&v);
    /* 8 and 32 bits, signed */
    const uint32_t b8[3] = {0x80, 0x7F, 0xFF}, b32[3] = {0x80000000u, 0x7FFFFFFFu, 0xFFFFFFFEu};
    CHECK_OK(vm_volume_read(one_file("dicom_8.dcm", TS_RLE, 8, 8, 7, 1, b8, 3), &v, &err),
             &err);
    if (v.data) CHECK(v.data[0] == -128 && v.data[1] == 127 && v.data[2] == -1);
    vm_volume_free(&v);
    CHECK_OK(vm_volume_read(one_file("dicom_32.dcm", TS_RLE, 32, 32, 31, 1, b32, 3), &v, &err),
             &err);
    if (v.data)
        CHECK(v.data[0] == -2147483648.0f && v.data[1] == 2147483648.0f && v.data[2] == -2);
    CHECK(v.type == VM_SCALAR_INT32);
    vm_volume_free(&v);
}

static void dicomFillsPaddingWithTheMinimumOfTheOtherValues(void) {
    fill_words();
    const char *dir = fresh_dir("dicom_pad");
    for (int k = 0; k < NZ; k++) {
        dw_spec s = ct_slice(k, k % 2 ? TS_BIG : TS_IMPLICIT);
        s.pixel_rep = 1, s.bits_stored = 16, s.high_bit = 15;
        s.has_padding = 1, s.padding = -2000;
        static uint32_t padded[NZ][PLANE];
        memcpy(padded[k], words[k], sizeof padded[k]);
        if (k == 4) padded[k][0] = padded[k][7] = (uint32_t)(-2000) & 0xFFFF;
        s.words = padded[k];
        char name[16];
        snprintf(name, sizeof name, "p%d", k);
        CHECK(dw_write(join(dir, name), &s) == 0);
    }
    vm_volume v, slab;
    vm_error err;
    CHECK_OK(vm_volume_read(dir, &v, &err), &err);
    if (!v.data) return;
    float lo = (float)(80 * SLOPE + INTERCEPT); /* the smallest word, rescaled */
    CHECK(v.data[4 * PLANE] == lo && v.data[4 * PLANE + 7] == lo);
    double mn, mx;
    vm_volume_stats(&v, &mn, &mx, NULL);
    CHECK(mn == lo);
    CHECK_OK(vm_volume_read_slab(dir, 4, 5, &slab, &err), &err);
    if (slab.data) CHECK(memcmp(slab.data, v.data + 4 * PLANE, PLANE * sizeof(float)) == 0);
    vm_volume_free(&slab);
    vm_volume_free(&v);
}

/* Writes s as the temp file name and reads it back into v; 1 when it read. */
static int write_and_read(const char *name, const dw_spec *s, vm_volume *v) {
    const char *path = vm_test_tmp(name);
    vm_error err;
    CHECK(dw_write(path, s) == 0);
    CHECK_OK(vm_volume_read(path, v, &err), &err);
    return v->data != NULL;
}

static void dicomReadsRtDoseGridOffsetsWithDoseScaling(void) {
    enum { F = 4 };
    static uint32_t w[F * PLANE];
    for (int i = 0; i < F * PLANE; i++) w[i] = (uint32_t)(i * 100000u);
    const double offsets[F] = {0, -2.5, -5, -7.5}; /* decreasing: frames lie backwards */
    dw_spec s;
    memset(&s, 0, sizeof s);
    s.syntax = TS_IMPLICIT, s.series_uid = "1.2.3.9", s.modality = "RTDOSE";
    s.rows = NY, s.cols = NX, s.frames = F;
    s.bits_allocated = s.bits_stored = 32, s.high_bit = 31;
    s.has_position = s.has_orientation = 1;
    s.position[0] = 10, s.position[1] = 20, s.position[2] = 30;
    const double axial[6] = {1, 0, 0, 0, 1, 0};
    memcpy(s.orientation, axial, sizeof axial);
    s.spacing[0] = 2, s.spacing[1] = 3;
    s.grid_offsets = offsets;
    s.dose_scaling = 0.001;
    s.words = w;
    vm_volume v;
    if (!write_and_read("dicom_dose.dcm", &s, &v)) return;
    CHECK(v.dims[2] == F && v.type == VM_SCALAR_UINT32);
    CHECK_NEAR(v.spacing[0], 3, 1e-12);
    CHECK_NEAR(v.spacing[1], 2, 1e-12);
    CHECK_NEAR(v.spacing[2], 2.5, 1e-12);
    CHECK_NEAR(v.origin[2], 30 - 7.5, 1e-12);
    /* plane 0 is the last frame */
    for (int p = 0; p < PLANE; p++)
        CHECK(v.data[p] == (float)((double)w[3 * PLANE + p] * 0.001));
    vm_volume_free(&v);
}

static void dicomReadsEnhancedMultiFramePositions(void) {
    fill_words();
    static uint32_t w[NZ * PLANE];
    double pos[NZ * 3];
    for (int f = 0; f < NZ; f++) { /* frame f holds slice NZ-1-f */
        int k = NZ - 1 - f;
        memcpy(w + f * PLANE, words[k], sizeof words[k]);
        for (int a = 0; a < 3; a++) pos[3 * f + a] = ORIGIN[a] + k * GAP * NORMAL[a];
    }
    /* per-frame rescale: the CT's everywhere but frame 0 (slice NZ-1): 2, -1000 */
    double rescale[2 * NZ];
    for (int f = 0; f < NZ; f++) rescale[2 * f] = SLOPE, rescale[2 * f + 1] = INTERCEPT;
    rescale[0] = 2.0, rescale[1] = -1000.0;
    static const char *const names[3] = {"dicom_enh.dcm", "dicom_enh_u.dcm", "dicom_enh_r.dcm"};
    for (int u = 0; u < 3; u++) {
        dw_spec s = ct_slice(0, u ? TS_EXPLICIT : TS_IMPLICIT);
        s.has_position = s.has_orientation = 0;
        s.frames = NZ;
        s.frame_positions = pos;
        s.undefined_lengths = u == 1;
        s.words = w;
        if (u == 2) s.frame_rescale = rescale, s.has_rescale = 0;
        CHECK(dw_write(vm_test_tmp(names[u]), &s) == 0);
        vm_volume v, want;
        vm_error err;
        expected_ct(&want);
        if (u == 2)
            for (int p = 0; p < PLANE; p++)
                want.data[(NZ - 1) * PLANE + p] = (float)(words[NZ - 1][p] * 2.0 - 1000.0);
        CHECK_OK(vm_volume_read(vm_test_tmp(names[u]), &v, &err), &err);
        if (v.data) expect_same(&v, &want, 1e-12, names[u]);
        vm_volume_free(&v);
        vm_volume_free(&want);
    }
}

static void dicomReadsOneBitSegmentationFrames(void) {
    enum { F = 3 };
    static uint32_t bits[F * PLANE]; /* 30 bits a frame: frames are not byte-aligned */
    for (int i = 0; i < F * PLANE; i++) bits[i] = (uint32_t)((i * 7 + i / 5) % 3 == 0);
    double pos[3 * F];
    for (int f = 0; f < F; f++)
        for (int a = 0; a < 3; a++) pos[3 * f + a] = ORIGIN[a] + f * GAP * NORMAL[a];
    dw_spec s = ct_slice(0, TS_EXPLICIT);
    s.modality = "SEG";
    s.has_position = s.has_orientation = s.has_rescale = 0;
    s.bits_allocated = s.bits_stored = 1, s.high_bit = 0;
    s.frames = F, s.frame_positions = pos, s.words = bits;
    vm_volume v;
    if (!write_and_read("dicom_seg.dcm", &s, &v)) return;
    CHECK(v.dims[2] == F && v.type == VM_SCALAR_UINT8);
    int bad = 0;
    for (int i = 0; i < F * PLANE; i++) bad += v.data[i] != (float)bits[i];
    CHECK_MSG(bad == 0, "%d voxels differ", bad);
    vm_volume_free(&v);
}

static void dicomReadsTheFolderOfADicomdir(void) {
    fill_words();
    const char *dir = fresh_dir("dicom_dir");
    write_ct_folder(dir);
    /* a minimal DICOMDIR: its media storage class and an empty record sequence */
    dw_buf f = {NULL, 0, 0, 0, 1}, meta = {NULL, 0, 0, 0, 1};
    unsigned char pre[128] = {0};
    dw_put(&f, pre, 128);
    dw_put(&f, "DICM", 4);
    dw_str(&meta, 0x0002, 0x0002, "UI", "1.2.840.10008.1.3.10");
    dw_str(&meta, 0x0002, 0x0010, "UI", TS_EXPLICIT);
    dw_head(&f, 0x0002, 0x0000, "UL", 4);
    dw_u32(&f, (uint32_t)meta.n);
    dw_put(&f, meta.p, meta.n);
    dw_head(&f, 0x0004, 0x1220, "SQ", 0xFFFFFFFFu);
    dw_head(&f, 0xFFFE, 0xE0DD, "", 0);
    CHECK(vm_test_write_file(join(dir, "DICOMDIR"), f.p, f.n) == 0);
    free(f.p), free(meta.p);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(join(dir, "DICOMDIR"), &v, &err), &err);
    CHECK(v.dims[2] == NZ);
    vm_volume_free(&v);
}

/* Writes n slices of the CT series into dir (files s0, s1, ...): slice k at along[k] on the
 * normal (NULL: k * GAP) plus shift[k] along the rows (NULL: 0); the last one narrower by a
 * column when narrow_last. */
static void write_stack(const char *dir, int n, const double *along, const double *shift,
                        int narrow_last) {
    fill_words();
    for (int k = 0; k < n; k++) {
        dw_spec s = ct_slice(0, TS_EXPLICIT);
        for (int a = 0; a < 3; a++)
            s.position[a] = ORIGIN[a] + (along ? along[k] : k * GAP) * NORMAL[a] +
                            (shift ? shift[k] : 0) * ROW[a];
        if (narrow_last && k == n - 1) s.cols = NX - 1;
        char fname[16];
        snprintf(fname, sizeof fname, "s%d", k);
        CHECK(dw_write(join(dir, fname), &s) == 0);
    }
}

/* Expects a read of dir refused with code and phrase, the message naming a file in dir. */
static void expect_dir_refused(const char *dir, vm_status code, const char *phrase) {
    vm_volume v;
    vm_error err;
    vm_status st = vm_volume_read(dir, &v, &err);
    CHECK_MSG(st == code && strstr(err.message, phrase) && strstr(err.message, dir),
              "%s: %d %s", dir, (int)st, err.message);
    CHECK(v.data == NULL);
}

/* Four slices at along[k] on the normal and shift[k] along the rows, refused. */
static void expect_stack_refused(const char *name, const double *along, const double *shift,
                                 vm_status code, const char *phrase) {
    const char *dir = fresh_dir(name);
    write_stack(dir, 4, along, shift, 0);
    expect_dir_refused(dir, code, phrase);
}

static void dicomRefusesUnevenGapsAndGantryTilt(void) {
    const double even[4] = {0, 1, 2, 3}, uneven[4] = {0, 1, 2, 3.5}, twin[4] = {0, 1, 1, 2};
    const double none[4] = {0, 0, 0, 0}, tilt[4] = {0, 0.2, 0.4, 0.6};
    expect_stack_refused("dicom_uneven", uneven, none, VM_ERR_FORMAT, "uneven slice gaps");
    expect_stack_refused("dicom_twin", twin, none, VM_ERR_FORMAT, "at the same position");
    expect_stack_refused("dicom_tilt", even, tilt, VM_ERR_UNSUPPORTED, "gantry tilt");
    /* within 1 %: read */
    const char *dir = fresh_dir("dicom_nearly");
    const double nearly[4] = {0, 1.004, 2, 3};
    write_stack(dir, 4, nearly, NULL, 0);
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(dir, &v, &err), &err);
    CHECK_NEAR(v.spacing[2], 1.0, 1e-9);
    vm_volume_free(&v);
}

/* Expects path refused with code and phrase in a one-line "PATH: ..." message. */
static void expect_refused(const char *path, vm_status code, const char *phrase) {
    vm_volume v;
    vm_error err;
    vm_status st = vm_volume_read(path, &v, &err);
    vm_test_expect_refusal(path, st, code, &err, phrase, &v);
}

static void dicomRefusesTruncatedEmptyAndPixellessFiles(void) {
    fill_words();
    dw_spec s = ct_slice(0, TS_EXPLICIT);
    const char *path = vm_test_tmp("dicom_trunc.dcm");
    CHECK(dw_write(path, &s) == 0);
    struct stat sb;
    CHECK(stat(path, &sb) == 0);
    CHECK(truncate(path, sb.st_size - 7) == 0);
    expect_refused(path, VM_ERR_FORMAT, "truncated or lying length");
    CHECK(truncate(path, 200) == 0);
    expect_refused(path, VM_ERR_FORMAT, NULL);
    s.no_pixels = 1;
    path = vm_test_tmp("dicom_nopix.dcm");
    CHECK(dw_write(path, &s) == 0);
    expect_refused(path, VM_ERR_FORMAT, "no pixel data");
    /* a deflated dataset cut short (raw deflate has no check value: damage inside it
     * shows as a malformed dataset instead, which the fuzz target covers) */
    path = vm_test_tmp("dicom_bad_deflate.dcm");
    s = ct_slice(0, TS_DEFLATED);
    CHECK(dw_write(path, &s) == 0);
    CHECK(stat(path, &sb) == 0);
    CHECK(truncate(path, sb.st_size - 40) == 0);
    expect_refused(path, VM_ERR_FORMAT, "deflated dataset");
    const char *dir = fresh_dir("dicom_empty");
    CHECK(vm_test_write_file(join(dir, "a.txt"), "hello", 5) == 0);
    expect_refused(dir, VM_ERR_FORMAT, "no DICOM images found");
}

static void dicomRefusesUndecodedCompressionColourAndAbsurdSizes(void) {
    fill_words();
    /* a compressed syntax no decoder reads (tests/io/test_dicom_codecs.c: the others) */
    dw_spec s = ct_slice(0, "1.2.840.10008.1.2.4.203");
    const char *path = vm_test_tmp("dicom_jpeg.dcm");
    CHECK(dw_write(path, &s) == 0);
    expect_refused(path, VM_ERR_UNSUPPORTED,
                   "transfer syntax 1.2.840.10008.1.2.4.203 (High-Throughput JPEG 2000) is "
                   "compressed; volmesh has no decoder for it");
    s = ct_slice(0, TS_EXPLICIT);
    s.samples = 3;
    path = vm_test_tmp("dicom_rgb.dcm");
    CHECK(dw_write(path, &s) == 0);
    expect_refused(path, VM_ERR_UNSUPPORTED, "SamplesPerPixel is 3 (colour)");
    /* sizes announced beyond the pixels present: refused before any allocation */
    const int lies[3][3] = {{65535, 65535, 2147483647}, {65535, 65535, 1}, {NY, NX, 2}};
    for (int i = 0; i < 3; i++) {
        s = ct_slice(0, i == 1 ? TS_RLE : TS_EXPLICIT);
        s.lie_rows = lies[i][0], s.lie_cols = lies[i][1], s.lie_frames = lies[i][2];
        path = vm_test_tmp("dicom_huge.dcm");
        CHECK(dw_write(path, &s) == 0);
        expect_refused(path, VM_ERR_FORMAT, NULL);
    }
}

static void dicomRefusesMixedDimsWithinASeries(void) {
    const char *dir = fresh_dir("dicom_mixed");
    write_stack(dir, 3, NULL, NULL, 1);
    expect_dir_refused(dir, VM_ERR_FORMAT, "s2: 5x5 pixels, but");
}

TEST_MAIN(T(dicomReadsShuffledMixedSyntaxObliqueSeriesExactly),
          T(dicomListsSeriesAndReadsTheOneChosen),
          T(dicomReadsSlabsAndHeaderOnlyLikeTheWholeRead),
          T(dicomReadsBigEndianDeflatedAndRleLikeImplicit),
          T(dicomMasksBitsStoredAndSignExtends),
          T(dicomFillsPaddingWithTheMinimumOfTheOtherValues),
          T(dicomReadsRtDoseGridOffsetsWithDoseScaling),
          T(dicomReadsEnhancedMultiFramePositions),
          T(dicomReadsOneBitSegmentationFrames),
          T(dicomReadsTheFolderOfADicomdir),
          T(dicomRefusesUnevenGapsAndGantryTilt),
          T(dicomRefusesTruncatedEmptyAndPixellessFiles),
          T(dicomRefusesUndecodedCompressionColourAndAbsurdSizes),
          T(dicomRefusesMixedDimsWithinASeries))
