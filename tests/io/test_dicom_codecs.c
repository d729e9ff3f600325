/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_dicom_codecs.c — compressed DICOM pixel data: series and multi-frame files
 * whose frames the test encodes with libjpeg, CharLS and OpenJPEG (the library only decodes),
 * written as encapsulated fragments (tests/io/dicom_writer.h) with a basic, an extended or no
 * offset table. Lossless syntaxes read to exactly the voxels, lossy ones within a tolerance;
 * corrupt, truncated and mismatched codestreams are refused in one line naming the file; a
 * codec this build lacks is refused with the one line naming the syntax and the Debian
 * package. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <sys/stat.h>
#include "io/dicom_writer.h"
#include "test.h"
#ifdef VM_HAVE_DICOM_JPEG
#include <jpeglib.h>
#endif
#ifdef VM_HAVE_DICOM_JPEGLS
#include <charls/charls.h>
#endif
#ifdef VM_HAVE_DICOM_J2K
#include <openjpeg.h>
#endif

enum { NX = 16, NY = 12, NZ = 4, PLANE = NX * NY };

#define TS_JPEG_EXTENDED "1.2.840.10008.1.2.4.51"
#define TS_JPEG_LOSSLESS "1.2.840.10008.1.2.4.57"
#define TS_JPEG_LOSSLESS_SV1 "1.2.840.10008.1.2.4.70"
#define TS_JPEGLS "1.2.840.10008.1.2.4.80"
#define TS_JPEGLS_NEAR "1.2.840.10008.1.2.4.81"
#define TS_J2K_LOSSLESS "1.2.840.10008.1.2.4.90"
#define TS_J2K "1.2.840.10008.1.2.4.91"
#define TS_HTJ2K "1.2.840.10008.1.2.4.201"

static const double SLOPE = 1.0, INTERCEPT = -1024.0;

/* What the stored words of a series are: bits stored and whether they are signed. */
typedef struct sample_kind {
    int bits_allocated, bits_stored, pixel_rep;
} sample_kind;

#define U8 ((sample_kind){8, 8, 0})
#define U12 ((sample_kind){16, 12, 0})
#define S16 ((sample_kind){16, 16, 1})

/* A smooth field (compresses well and within tolerance when lossy) with a bright blob, as
 * signed values in the kind's range. */
static int32_t field_value(sample_kind k, int i, int j, int z) {
    double r2 = (i - 8.0) * (i - 8.0) + (j - 6.0) * (j - 6.0) + (z - 1.5) * (z - 1.5);
    double t = 0.25 + 0.02 * i + 0.015 * j + 0.03 * z + (r2 < 12.0 ? 0.35 : 0.0);
    double top = (double)((1 << k.bits_stored) - 1);
    if (k.pixel_rep) return (int32_t)((t - 0.5) * top * 0.9);
    return (int32_t)(t * top * 0.9);
}

static int32_t values[NZ][PLANE];  /* the signed sample values */
static uint32_t words[NZ][PLANE];  /* the same as stored words (two's complement bits) */

/* Fills values and words for kind k. */
static void fill(sample_kind k) {
    uint32_t mask = k.bits_stored >= 32 ? 0xFFFFFFFFu : (1u << k.bits_stored) - 1u;
    for (int z = 0; z < NZ; z++)
        for (int j = 0; j < NY; j++)
            for (int i = 0; i < NX; i++) {
                values[z][i + NX * j] = field_value(k, i, j, z);
                words[z][i + NX * j] = (uint32_t)values[z][i + NX * j] & mask;
            }
}

/* The spec of slice z (or, frames > 1, of a multi-frame file of all slices). */
static dw_spec slice_spec(sample_kind k, const char *ts, int z, int frames) {
    static double positions[3 * NZ];
    dw_spec s;
    memset(&s, 0, sizeof s);
    s.syntax = ts;
    s.series_uid = "1.2.826.0.1.3680043.2.1125.7.1";
    s.modality = "CT";
    s.rows = NY, s.cols = NX, s.frames = frames;
    s.bits_allocated = k.bits_allocated, s.bits_stored = k.bits_stored;
    s.high_bit = k.bits_stored - 1, s.pixel_rep = k.pixel_rep;
    s.has_position = s.has_orientation = 1;
    const double orientation[6] = {1, 0, 0, 0, 1, 0};
    memcpy(s.orientation, orientation, sizeof orientation);
    s.position[0] = -10.0, s.position[1] = 5.0, s.position[2] = 2.0 * z;
    s.spacing[0] = 0.8, s.spacing[1] = 0.6;
    s.has_rescale = 1, s.slope = SLOPE, s.intercept = INTERCEPT;
    s.words = words[z];
    if (frames > 1) {
        for (int f = 0; f < NZ; f++) {
            positions[3 * f] = -10.0, positions[3 * f + 1] = 5.0;
            positions[3 * f + 2] = 2.0 * f;
        }
        s.frame_positions = positions;
        s.has_position = 0;
    }
    return s;
}

/* The codestreams of the NZ slices, made by one of the encoders below. */
typedef struct frames {
    unsigned char *p[NZ];
    size_t n[NZ];
} frames;

/* Frees the codestreams of fr. */
static void frames_free(frames *fr) {
    for (int z = 0; z < NZ; z++) free(fr->p[z]);
}

/* ---- encoders (the tests' own: the library only decodes) ---- */

#ifdef VM_HAVE_DICOM_JPEG
/* Slice z as a JPEG: 8-bit lossy at quality q; with libjpeg-turbo 3.0 also 12-bit lossy and
 * lossless (predictor psv) at the kind's precision. */
static void jpeg_encode(sample_kind k, int z, int q, int lossless_psv, frames *fr) {
    struct jpeg_compress_struct c;
    struct jpeg_error_mgr e;
    unsigned char *buf = NULL;
    unsigned long size = 0;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    jpeg_mem_dest(&c, &buf, &size);
    c.image_width = NX, c.image_height = NY;
    c.input_components = 1, c.in_color_space = JCS_GRAYSCALE;
#ifdef VM_HAVE_DICOM_JPEG16
    c.data_precision = k.bits_stored;
#endif
    jpeg_set_defaults(&c);
#ifdef VM_HAVE_DICOM_JPEG16
    if (lossless_psv) jpeg_enable_lossless(&c, lossless_psv, 0);
    else
#endif
        jpeg_set_quality(&c, q, TRUE);
    (void)lossless_psv;
    jpeg_start_compress(&c, TRUE);
    for (int j = 0; j < NY; j++) {
        const uint32_t *w = words[z] + NX * j;
        if (k.bits_stored <= 8) {
            JSAMPLE row[NX];
            JSAMPROW r = row;
            for (int i = 0; i < NX; i++) row[i] = (JSAMPLE)w[i];
            jpeg_write_scanlines(&c, &r, 1);
#ifdef VM_HAVE_DICOM_JPEG16
        } else if (k.bits_stored <= 12) {
            J12SAMPLE row[NX];
            J12SAMPROW r = row;
            for (int i = 0; i < NX; i++) row[i] = (J12SAMPLE)w[i];
            jpeg12_write_scanlines(&c, &r, 1);
        } else {
            J16SAMPLE row[NX];
            J16SAMPROW r = row;
            for (int i = 0; i < NX; i++) row[i] = (J16SAMPLE)w[i];
            jpeg16_write_scanlines(&c, &r, 1);
#endif
        }
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    fr->p[z] = buf, fr->n[z] = size;
}
#endif

#ifdef VM_HAVE_DICOM_JPEGLS
/* Slice z as JPEG-LS with CharLS (near 0: lossless). */
static void jpegls_encode(sample_kind k, int z, int near, frames *fr) {
    size_t bytes = k.bits_stored <= 8 ? 1 : 2, cap = 0, written = 0;
    unsigned char src[PLANE * 2];
    for (int i = 0; i < PLANE; i++) {
        if (bytes == 1) src[i] = (unsigned char)words[z][i];
        else {
            uint16_t v = (uint16_t)words[z][i];
            memcpy(src + 2 * i, &v, 2);
        }
    }
    charls_jpegls_encoder *e = charls_jpegls_encoder_create();
    charls_frame_info fi = {NX, NY, k.bits_stored, 1};
    CHECK(charls_jpegls_encoder_set_frame_info(e, &fi) == CHARLS_JPEGLS_ERRC_SUCCESS);
    CHECK(charls_jpegls_encoder_set_near_lossless(e, near) == CHARLS_JPEGLS_ERRC_SUCCESS);
    CHECK(charls_jpegls_encoder_get_estimated_destination_size(e, &cap) ==
          CHARLS_JPEGLS_ERRC_SUCCESS);
    unsigned char *buf = malloc(cap);
    CHECK(charls_jpegls_encoder_set_destination_buffer(e, buf, cap) ==
          CHARLS_JPEGLS_ERRC_SUCCESS);
    CHECK(charls_jpegls_encoder_encode_from_buffer(e, src, PLANE * bytes, 0) ==
          CHARLS_JPEGLS_ERRC_SUCCESS);
    CHECK(charls_jpegls_encoder_get_bytes_written(e, &written) == CHARLS_JPEGLS_ERRC_SUCCESS);
    charls_jpegls_encoder_destroy(e);
    fr->p[z] = buf, fr->n[z] = written;
}
#endif

#ifdef VM_HAVE_DICOM_J2K
/* A growing buffer OpenJPEG writes the codestream into. */
typedef struct j2k_sink {
    unsigned char *p;
    size_t n, at, cap;
} j2k_sink;

/* OpenJPEG's write callback: appends at the current place. */
static OPJ_SIZE_T sink_write(void *src, OPJ_SIZE_T n, void *user) {
    j2k_sink *s = user;
    if (s->at + n > s->cap) {
        s->cap = (s->at + n) * 2;
        s->p = realloc(s->p, s->cap);
    }
    memcpy(s->p + s->at, src, n);
    s->at += n;
    if (s->at > s->n) s->n = s->at;
    return n;
}

/* OpenJPEG's skip callback. */
static OPJ_OFF_T sink_skip(OPJ_OFF_T by, void *user) {
    j2k_sink *s = user;
    s->at += (size_t)by;
    return by;
}

/* OpenJPEG's seek callback. */
static OPJ_BOOL sink_seek(OPJ_OFF_T to, void *user) {
    j2k_sink *s = user;
    s->at = (size_t)to;
    return OPJ_TRUE;
}

/* Slice z as a JPEG 2000 codestream with OpenJPEG: the reversible 5/3 wavelet, or the
 * irreversible 9/7 (lossy: real-valued, quantised). */
static void j2k_encode(sample_kind k, int z, int irreversible, frames *fr) {
    opj_cparameters_t par;
    opj_set_default_encoder_parameters(&par);
    par.numresolution = 2; /* the image is smaller than the default 6 levels allow */
    par.irreversible = irreversible;
    opj_image_cmptparm_t cp;
    memset(&cp, 0, sizeof cp);
    cp.dx = cp.dy = 1, cp.w = NX, cp.h = NY;
    cp.prec = (OPJ_UINT32)k.bits_stored, cp.sgnd = (OPJ_UINT32)k.pixel_rep;
    opj_image_t *img = opj_image_create(1, &cp, OPJ_CLRSPC_GRAY);
    img->x0 = img->y0 = 0, img->x1 = NX, img->y1 = NY;
    for (int i = 0; i < PLANE; i++) img->comps[0].data[i] = values[z][i];
    opj_codec_t *c = opj_create_compress(OPJ_CODEC_J2K);
    CHECK(opj_setup_encoder(c, &par, img));
    j2k_sink sink = {NULL, 0, 0, 0};
    opj_stream_t *s = opj_stream_create(1u << 16, OPJ_FALSE);
    opj_stream_set_user_data(s, &sink, NULL);
    opj_stream_set_write_function(s, sink_write);
    opj_stream_set_skip_function(s, sink_skip);
    opj_stream_set_seek_function(s, sink_seek);
    CHECK(opj_start_compress(c, img, s) && opj_encode(c, s) && opj_end_compress(c, s));
    opj_stream_destroy(s);
    opj_destroy_codec(c);
    opj_image_destroy(img);
    fr->p[z] = sink.p, fr->n[z] = sink.n;
}
#endif

/* ---- reading back ---- */

/* A fresh folder under the test temp folder. */
static const char *fresh_dir(const char *name) {
    const char *dir = vm_test_tmp(name);
    char cmd[4200];
    snprintf(cmd, sizeof cmd, "rm -rf '%s' && mkdir -p '%s'", dir, dir);
    CHECK(system(cmd) == 0);
    return dir;
}

/* Writes the series in syntax ts as NZ files under a fresh folder name (split: fragments per
 * frame), or as one multi-frame file when multi (offset table as asked). Returns the path. */
static const char *write_series(const char *name, sample_kind k, const char *ts,
                                const frames *fr, int split, int multi, int offsets) {
    static char path[4200];
    const char *dir = fresh_dir(name);
    for (int z = 0; z < (multi ? 1 : NZ); z++) {
        dw_spec s = slice_spec(k, ts, z, multi ? NZ : 1);
        s.codestreams = multi ? fr->p : fr->p + z;
        s.codestream_sizes = multi ? fr->n : fr->n + z;
        s.split = split, s.offset_table = offsets;
        snprintf(path, sizeof path, "%s/slice%d.dcm", dir, z);
        CHECK(dw_write(path, &s) == 0);
    }
    return multi ? path : dir;
}

/* Reads path and checks every voxel is value * SLOPE + INTERCEPT within tol (0: exactly);
 * returns the largest difference. */
static double expect_voxels(const char *path, double tol, const char *what) {
    vm_volume v;
    vm_error err;
    double worst = 0;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    if (!v.data) return INFINITY;
    CHECK_MSG(v.dims[0] == NX && v.dims[1] == NY && v.dims[2] == NZ, "%s: dims %lld %lld %lld",
              what, (long long)v.dims[0], (long long)v.dims[1], (long long)v.dims[2]);
    CHECK_NEAR(v.spacing[2], 2.0, 1e-9);
    size_t bad = 0;
    for (int z = 0; z < NZ && v.dims[2] == NZ; z++)
        for (int p = 0; p < PLANE; p++) {
            double want = values[z][p] * SLOPE + INTERCEPT, got = v.data[z * PLANE + p];
            double d = fabs(got - want);
            if (d > worst) worst = d;
            if (d > tol && bad++ == 0)
                CHECK_MSG(0, "%s: voxel %d of slice %d is %.9g, expected %.9g (tolerance %g)",
                          what, p, z, got, want, tol);
        }
    vm_volume_free(&v);
    return worst;
}

/* Frames 1 and 2 of path read as a slab and forward through a reader are those planes of
 * the whole read (compressed frames are found one by one). */
static void expect_slabs_like_whole(const char *path, const char *what) {
    vm_volume whole, slab;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &whole, &err), &err);
    CHECK_OK(vm_volume_read_slab(path, 1, 3, &slab, &err), &err);
    if (whole.data && slab.data)
        CHECK_MSG(slab.dims[2] == 2 && memcmp(slab.data, whole.data + PLANE,
                                              2 * PLANE * sizeof(float)) == 0,
                  "%s: the slab of frames 1-2 differs from the whole read", what);
    vm_volume_free(&slab);
    vm_volume_reader *r = NULL;
    float planes[PLANE];
    CHECK_OK(vm_volume_reader_open(path, NULL, NULL, &r, &err), &err);
    for (int k = 0; r && whole.data && k < NZ; k++) {
        CHECK_OK(vm_volume_reader_read(r, k, k + 1, planes, &err), &err);
        CHECK_MSG(memcmp(planes, whole.data + k * PLANE, sizeof planes) == 0,
                  "%s: plane %d read forward differs from the whole read", what, k);
    }
    vm_volume_reader_close(r);
    vm_volume_free(&whole);
}

/* Every layout of the same frames reads alike: a series of files with one fragment per
 * frame, frames cut into 3 fragments, and multi-frame files with and without an offset
 * table (frames then found by their start markers). */
static void expect_layouts(const char *tag, sample_kind k, const char *ts, const frames *fr,
                           double tol) {
    char name[64], what[128];
    static const int layout[5][3] = {{1, 0, 0}, {3, 0, 0}, {1, 1, 1}, {3, 1, 0}, {3, 1, 2}};
    static const char *const tables[3] = {"no offset table", "basic offset table",
                                          "extended offset table"};
    for (int l = 0; l < 5; l++) {
        snprintf(name, sizeof name, "dicom_%s_%d", tag, l);
        snprintf(what, sizeof what, "%s (%s, %d fragment(s) per frame, %s)", tag, ts,
                 layout[l][0], layout[l][1] ? tables[layout[l][2]] : "one file per slice");
        const char *path = write_series(name, k, ts, fr, layout[l][0], layout[l][1],
                                        layout[l][2]);
        double worst = expect_voxels(path, tol, what);
        expect_slabs_like_whole(path, what);
        if (tol > 0) printf("  %s: largest difference %g\n", what, worst);
    }
}

/* Expects path refused with code and phrase in a one-line "PATH: ..." message. */
static void expect_refused(const char *path, vm_status code, const char *phrase) {
    vm_volume v;
    vm_error err;
    vm_status st = vm_volume_read(path, &v, &err);
    vm_test_expect_refusal(path, st, code, &err, phrase, &v);
}

/* Frame 0 of fr damaged three ways, each refused naming the file: cut in half (a truncated
 * fragment), its header overwritten (a corrupt codestream), and announced with more
 * columns than it holds; the CLI exits 2 with one line for the truncated one. */
static void expect_damage_refused(const char *tag, sample_kind k, const char *ts, frames *fr) {
    char name[64];
    const char *path;
    size_t n0 = fr->n[0];
    unsigned char *keep = malloc(n0);
    memcpy(keep, fr->p[0], n0);
    for (int how = 0; how < 3; how++) {
        snprintf(name, sizeof name, "dicom_%s_bad%d.dcm", tag, how);
        path = vm_test_tmp(name);
        dw_spec s = slice_spec(k, ts, 0, 1);
        s.codestreams = fr->p, s.codestream_sizes = fr->n;
        if (how == 0) fr->n[0] = n0 / 2;
        if (how == 1) memset(fr->p[0] + 2, 0, 8);
        if (how == 2) s.lie_cols = NX + 2;
        CHECK(dw_write(path, &s) == 0);
        expect_refused(path, VM_ERR_FORMAT,
                       how == 2 ? "codestream holds 16x12 pixels of 1 component(s)"
                                : "codestream is corrupt or truncated");
        if (how == 0) vm_test_expect_cli_error(NULL, path, NULL);
        fr->n[0] = n0;
        memcpy(fr->p[0], keep, n0);
    }
    free(keep);
}

/* A file of syntax ts with stand-in fragments, refused with the message phrase. */
static void expect_syntax_refused(const char *ts, const char *phrase) {
    fill(U12);
    dw_spec s = slice_spec(U12, ts, 0, 1);
    const char *path = vm_test_tmp("dicom_codec_missing.dcm");
    CHECK(dw_write(path, &s) == 0);
    expect_refused(path, VM_ERR_UNSUPPORTED, phrase);
    vm_test_expect_cli_error(NULL, path, NULL);
}

/* The one line for a syntax whose library this build lacks. */
static void expect_missing(const char *ts, const char *name, const char *package) {
    char phrase[512];
    snprintf(phrase, sizeof phrase, "transfer syntax %s (%s) is compressed; this build has no "
             "decoder for it (rebuild volmesh with Debian's %s installed)", ts, name, package);
    expect_syntax_refused(ts, phrase);
}

/* ---- the cases ---- */

static void dicomDecodesJpegBaselineAndExtendedWithinTolerance(void) {
#ifdef VM_HAVE_DICOM_JPEG
    frames fr;
    fill(U8);
    for (int z = 0; z < NZ; z++) jpeg_encode(U8, z, 95, 0, &fr);
    /* quality 95 on a smooth 8-bit field: a few grey levels at most */
    expect_layouts("jpeg50", U8, TS_JPEG_BASELINE, &fr, 6.0);
    expect_layouts("jpeg51", U8, TS_JPEG_EXTENDED, &fr, 6.0);
    expect_damage_refused("jpeg", U8, TS_JPEG_BASELINE, &fr);
    frames_free(&fr);
#else
    expect_missing(TS_JPEG_BASELINE, "JPEG Baseline (Process 1)", "libjpeg62-turbo-dev");
    expect_missing(TS_JPEG_LOSSLESS_SV1, "JPEG Lossless, Non-Hierarchical, First-Order "
                   "Prediction", "libjpeg62-turbo-dev");
#endif
}

static void dicomDecodesJpegLosslessAnd12BitWhenLibjpegTurboHasThem(void) {
#if defined(VM_HAVE_DICOM_JPEG) && defined(VM_HAVE_DICOM_JPEG16)
    frames fr;
    fill(U12);
    for (int z = 0; z < NZ; z++) jpeg_encode(U12, z, 0, 1, &fr);
    expect_layouts("jpeg70", U12, TS_JPEG_LOSSLESS_SV1, &fr, 0);
    frames_free(&fr);
    fill(S16);
    for (int z = 0; z < NZ; z++) jpeg_encode(S16, z, 0, 4, &fr);
    expect_layouts("jpeg57", S16, TS_JPEG_LOSSLESS, &fr, 0);
    frames_free(&fr);
    fill(U12);
    for (int z = 0; z < NZ; z++) jpeg_encode(U12, z, 95, 0, &fr);
    expect_layouts("jpeg51_12", U12, TS_JPEG_EXTENDED, &fr, 24.0);
    frames_free(&fr);
#elif defined(VM_HAVE_DICOM_JPEG)
    /* libjpeg-turbo before 3.0: lossless refused by its syntax, 12-bit by its frame header */
    expect_syntax_refused(TS_JPEG_LOSSLESS, "transfer syntax 1.2.840.10008.1.2.4.57 (JPEG "
                          "Lossless, Non-Hierarchical (Process 14)) needs libjpeg-turbo 3.0 "
                          "or later (its lossless decoder)");
    expect_syntax_refused(TS_JPEG_LOSSLESS_SV1, "1.2.840.10008.1.2.4.70 (JPEG Lossless, "
                          "Non-Hierarchical, First-Order Prediction) needs libjpeg-turbo 3.0");
    /* SOI, SOF1 of 12-bit samples (T.81 B.2.2: 16x12, one component), EOI */
    static unsigned char sof12[] = {0xFF, 0xD8, 0xFF, 0xC1, 0x00, 0x0B, 0x0C, 0x00, 0x0C,
                                    0x00, 0x10, 0x01, 0x01, 0x11, 0x00, 0xFF, 0xD9};
    unsigned char *p[1] = {sof12};
    size_t n[1] = {sizeof sof12};
    fill(U12);
    dw_spec s = slice_spec(U12, TS_JPEG_EXTENDED, 0, 1);
    s.codestreams = p, s.codestream_sizes = n;
    const char *path = vm_test_tmp("dicom_jpeg12.dcm");
    CHECK(dw_write(path, &s) == 0);
    expect_refused(path, VM_ERR_UNSUPPORTED, "frame 1: 12-bit lossy JPEG needs libjpeg-turbo "
                   "3.0 or later");
#else
    vm_test_skip("no JPEG decoder in this build (the refusal is checked by the baseline case)");
#endif
}

static void dicomDecodesJpegLsLosslessExactlyAndNearLosslessWithinNear(void) {
#ifdef VM_HAVE_DICOM_JPEGLS
    frames fr;
    const sample_kind kinds[2] = {U12, U8};
    for (int i = 0; i < 2; i++) {
        fill(kinds[i]);
        for (int z = 0; z < NZ; z++) jpegls_encode(kinds[i], z, 0, &fr);
        expect_layouts(i ? "jls8" : "jls12", kinds[i], TS_JPEGLS, &fr, 0);
        frames_free(&fr);
    }
    fill(U12);
    for (int z = 0; z < NZ; z++) jpegls_encode(U12, z, 3, &fr);
    expect_layouts("jls_near", U12, TS_JPEGLS_NEAR, &fr, 3.0); /* |error| <= NEAR */
    expect_damage_refused("jls", U12, TS_JPEGLS_NEAR, &fr);
    frames_free(&fr);
#else
    expect_missing(TS_JPEGLS, "JPEG-LS Lossless", "libcharls-dev");
#endif
}

static void dicomDecodesJpeg2000LosslessExactlyAndLossyWithinTolerance(void) {
#ifdef VM_HAVE_DICOM_J2K
    frames fr;
    const sample_kind kinds[2] = {S16, U12};
    for (int i = 0; i < 2; i++) {
        fill(kinds[i]);
        for (int z = 0; z < NZ; z++) j2k_encode(kinds[i], z, 0, &fr);
        expect_layouts(i ? "j2k12" : "j2k16s", kinds[i], TS_J2K_LOSSLESS, &fr, 0);
        frames_free(&fr);
    }
    fill(U12);
    for (int z = 0; z < NZ; z++) j2k_encode(U12, z, 1, &fr);
    /* 9/7 on a smooth 12-bit field (values up to 3700): within 0.1 % of the range */
    expect_layouts("j2k_lossy", U12, TS_J2K, &fr, 4.0);
    expect_damage_refused("j2k", U12, TS_J2K, &fr);
    frames_free(&fr);
#else
    expect_missing(TS_J2K, "JPEG 2000 Image Compression", "libopenjp2-7-dev");
#endif
}

static void dicomRefusesCompressedSyntaxesWithNoDecoderByName(void) {
    expect_syntax_refused(TS_HTJ2K, "transfer syntax 1.2.840.10008.1.2.4.201 (High-Throughput "
                          "JPEG 2000 (Lossless Only)) is compressed; volmesh has no decoder "
                          "for it");
}

static void dicomRefusesALyingBasicOrExtendedOffsetTable(void) {
    /* more fragments than frames, and an offset table that points inside a fragment */
    static unsigned char stand_in[8] = {0xFF, 0xD8, 0xFF, 0xD9, 0, 0, 0, 0};
    /* where the tables' entries start: after (7FE0,0010) OB of undefined length and the
     * first item's header, or after (7FE0,0001) OV's header */
    static const unsigned char bot[20] = {0xE0, 0x7F, 0x10, 0x00, 'O', 'B', 0, 0, 0xFF, 0xFF,
                                          0xFF, 0xFF, 0xFE, 0xFF, 0x00, 0xE0, 4 * NZ, 0, 0, 0};
    static const unsigned char eot[12] = {0xE0, 0x7F, 0x01, 0x00, 'O', 'V', 0, 0, 8 * NZ,
                                          0, 0, 0};
    for (int table = 1; table <= 2; table++) {
        fill(U12);
        dw_spec s = slice_spec(U12, TS_JPEGLS, 0, NZ);
        unsigned char *p[NZ] = {stand_in, stand_in, stand_in, stand_in};
        size_t n[NZ] = {8, 8, 8, 8};
        s.codestreams = p, s.codestream_sizes = n, s.split = 2, s.offset_table = table;
        const char *path = vm_test_tmp("dicom_bad_offsets.dcm");
        CHECK(dw_write(path, &s) == 0);
        /* the table the writer made is right; shift frame 3's entry by 2 bytes in the file */
        FILE *fp = fopen(path, "r+b");
        CHECK(fp != NULL);
        if (!fp) return;
        unsigned char buf[8192];
        size_t len = fread(buf, 1, sizeof buf, fp), at = 0;
        const unsigned char *head = table == 1 ? bot : eot;
        size_t hn = table == 1 ? sizeof bot : sizeof eot, entry = table == 1 ? 4 : 8;
        while (at + hn <= len && memcmp(buf + at, head, hn) != 0) at++;
        at += hn + 2 * entry;
        CHECK(at < len);
        buf[at] = (unsigned char)(buf[at] + 2);
        CHECK(fseek(fp, (long)at, SEEK_SET) == 0);
        CHECK(fwrite(buf + at, 1, 1, fp) == 1);
        CHECK(fclose(fp) == 0);
#ifdef VM_HAVE_DICOM_JPEGLS
        expect_refused(path, VM_ERR_FORMAT,
                       table == 1 ? "the basic offset table entry of frame 3"
                                  : "the extended offset table entry of frame 3");
#else
        expect_refused(path, VM_ERR_UNSUPPORTED, "libcharls-dev");
#endif
    }
}

TEST_MAIN(T(dicomDecodesJpegBaselineAndExtendedWithinTolerance),
          T(dicomDecodesJpegLosslessAnd12BitWhenLibjpegTurboHasThem),
          T(dicomDecodesJpegLsLosslessExactlyAndNearLosslessWithinNear),
          T(dicomDecodesJpeg2000LosslessExactlyAndLossyWithinTolerance),
          T(dicomRefusesCompressedSyntaxesWithNoDecoderByName),
          T(dicomRefusesALyingBasicOrExtendedOffsetTable))
