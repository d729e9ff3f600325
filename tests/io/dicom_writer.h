/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/dicom_writer.h — a tiny DICOM writer for the tests of the DICOM reader: one image
 * (or multi-frame) file in any of the five always-decoded transfer syntaxes, or encapsulated
 * codestreams made by the test (fragments, basic offset table), after PS3.10 7.1 and
 * PS3.5 7, 8.2, A.4, A.5, G. Written for the tests only; writes what the tests need. */
#ifndef VM_TEST_DICOM_WRITER_H
#define VM_TEST_DICOM_WRITER_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define TS_IMPLICIT "1.2.840.10008.1.2"
#define TS_EXPLICIT "1.2.840.10008.1.2.1"
#define TS_DEFLATED "1.2.840.10008.1.2.1.99"
#define TS_BIG "1.2.840.10008.1.2.2"
#define TS_RLE "1.2.840.10008.1.2.5"
#define TS_JPEG_BASELINE "1.2.840.10008.1.2.4.50"
#define CT_IMAGE_CLASS "1.2.840.10008.5.1.4.1.1.2"

/* What one file holds. Zero means absent for the optional parts. */
typedef struct dw_spec {
    const char *syntax;       /* transfer syntax UID */
    const char *series_uid, *modality, *description;
    int rows, cols, frames;   /* frames > 1: NumberOfFrames written */
    int bits_allocated, bits_stored, high_bit, pixel_rep;
    int samples;              /* 0: 1 */
    int has_position, has_orientation;
    double position[3], orientation[6], spacing[2];
    double slice_thickness;   /* written when non-zero; the reader must ignore it */
    int has_rescale;
    double slope, intercept;
    int has_padding;
    int padding;              /* PixelPaddingValue, written as 16 bits */
    const double *grid_offsets; /* RT dose, frames of them */
    double dose_scaling;      /* written when non-zero */
    const double *frame_positions; /* enhanced: 3 per frame in functional groups */
    const double *frame_rescale;   /* enhanced: (slope, intercept) per frame, or NULL */
    int undefined_lengths;    /* sequences and items with undefined lengths */
    int no_pixels;
    int lie_rows, lie_cols, lie_frames; /* non-zero: announced instead of the real sizes */
    const uint32_t *words;    /* rows*cols*frames stored words */
    /* encapsulated codestreams (any 1.2.840.10008.1.2.4.x syntax), one per frame; NULL: a
     * 4-byte SOI-EOI stand-in per frame */
    unsigned char *const *codestreams;
    const size_t *codestream_sizes;
    int split;                /* each codestream cut into this many fragments (0: one) */
    int offset_table;         /* 1: a basic offset table is written (else it is empty); 2: an
                               * extended offset table (7FE0,0001) and its lengths instead */
} dw_spec;

/* A growing byte buffer with the encoding of the dataset being written. */
typedef struct dw_buf {
    unsigned char *p;
    size_t n, cap;
    int big, explicit_vr;
} dw_buf;

/* Appends len bytes. */
static void dw_put(dw_buf *b, const void *src, size_t len) {
    if (b->n + len > b->cap) {
        b->cap = (b->n + len) * 2 + 256;
        b->p = realloc(b->p, b->cap);
    }
    memcpy(b->p + b->n, src, len);
    b->n += len;
}

/* Appends a 16-bit value in the buffer's byte order. */
static void dw_u16(dw_buf *b, unsigned v) {
    unsigned char q[2] = {(unsigned char)(b->big ? v >> 8 : v),
                          (unsigned char)(b->big ? v : v >> 8)};
    dw_put(b, q, 2);
}

/* Appends a 32-bit value in the buffer's byte order. */
static void dw_u32(dw_buf *b, uint32_t v) {
    unsigned char q[4];
    for (int i = 0; i < 4; i++) q[b->big ? 3 - i : i] = (unsigned char)(v >> (8 * i));
    dw_put(b, q, 4);
}

/* An element header (length 0xFFFFFFFF: undefined). */
static void dw_head(dw_buf *b, unsigned g, unsigned e, const char *vr, uint32_t len) {
    dw_u16(b, g);
    dw_u16(b, e);
    if (g == 0xFFFE || !b->explicit_vr) {
        dw_u32(b, len);
        return;
    }
    dw_put(b, vr, 2);
    static const char *const longs[] = {"OB", "OW", "SQ", "UN", "UT", "OF", "OV"};
    for (size_t i = 0; i < sizeof longs / sizeof longs[0]; i++)
        if (strcmp(vr, longs[i]) == 0) {
            dw_u16(b, 0);
            dw_u32(b, len);
            return;
        }
    dw_u16(b, len);
}

/* A string element, padded to even length (UI with NUL, others with a space). */
static void dw_str(dw_buf *b, unsigned g, unsigned e, const char *vr, const char *s) {
    size_t len = strlen(s), even = len + (len & 1);
    dw_head(b, g, e, vr, (uint32_t)even);
    dw_put(b, s, len);
    if (even > len) dw_put(b, strcmp(vr, "UI") == 0 ? "" : " ", 1);
}

/* A US element. */
static void dw_us(dw_buf *b, unsigned g, unsigned e, unsigned v) {
    dw_head(b, g, e, "US", 2);
    dw_u16(b, v);
}

/* A DS element of n numbers. */
static void dw_ds(dw_buf *b, unsigned g, unsigned e, const double *x, int n) {
    char s[2048];
    size_t at = 0;
    for (int i = 0; i < n; i++)
        at += (size_t)snprintf(s + at, sizeof s - at, "%s%.10g", i ? "\\" : "", x[i]);
    dw_str(b, g, e, "DS", s);
}

/* A sequence of one item holding one DS element (a functional group macro). */
static void dw_macro(dw_buf *b, unsigned g, unsigned e, unsigned vg, unsigned ve,
                     const double *x, int n, int undefined) {
    dw_buf inner = {NULL, 0, 0, b->big, b->explicit_vr};
    dw_ds(&inner, vg, ve, x, n);
    uint32_t item = undefined ? 0xFFFFFFFFu : (uint32_t)inner.n;
    dw_head(b, g, e, "SQ", undefined ? 0xFFFFFFFFu : (uint32_t)inner.n + 8);
    dw_head(b, 0xFFFE, 0xE000, "", item);
    dw_put(b, inner.p, inner.n);
    if (undefined) {
        dw_head(b, 0xFFFE, 0xE00D, "", 0);
        dw_head(b, 0xFFFE, 0xE0DD, "", 0);
    }
    free(inner.p);
}

/* Wraps items (each a buffer) into a sequence element. */
static void dw_sequence(dw_buf *b, unsigned g, unsigned e, dw_buf *items, int n,
                        int undefined) {
    size_t total = 0;
    for (int i = 0; i < n; i++) total += items[i].n + 8;
    dw_head(b, g, e, "SQ", undefined ? 0xFFFFFFFFu : (uint32_t)total);
    for (int i = 0; i < n; i++) {
        dw_head(b, 0xFFFE, 0xE000, "", undefined ? 0xFFFFFFFFu : (uint32_t)items[i].n);
        dw_put(b, items[i].p, items[i].n);
        if (undefined) dw_head(b, 0xFFFE, 0xE00D, "", 0);
        free(items[i].p);
    }
    if (undefined) dw_head(b, 0xFFFE, 0xE0DD, "", 0);
}

/* Shared and per-frame functional groups of an enhanced image (PS3.3 C.7.6.16). */
static void dw_functional_groups(dw_buf *b, const dw_spec *s) {
    int u = s->undefined_lengths;
    dw_buf shared = {NULL, 0, 0, b->big, b->explicit_vr};
    dw_macro(&shared, 0x0020, 0x9116, 0x0020, 0x0037, s->orientation, 6, u);
    dw_macro(&shared, 0x0028, 0x9110, 0x0028, 0x0030, s->spacing, 2, u);
    dw_sequence(b, 0x5200, 0x9229, &shared, 1, u);
    dw_buf *frames = calloc((size_t)s->frames, sizeof *frames);
    for (int k = 0; k < s->frames; k++) {
        frames[k].big = b->big, frames[k].explicit_vr = b->explicit_vr;
        dw_macro(&frames[k], 0x0020, 0x9113, 0x0020, 0x0032, s->frame_positions + 3 * k, 3, u);
        if (s->frame_rescale) { /* PixelValueTransformationSequence: intercept, slope */
            dw_buf item = {NULL, 0, 0, b->big, b->explicit_vr};
            dw_ds(&item, 0x0028, 0x1052, s->frame_rescale + 2 * k + 1, 1);
            dw_ds(&item, 0x0028, 0x1053, s->frame_rescale + 2 * k, 1);
            dw_sequence(&frames[k], 0x0028, 0x9145, &item, 1, u);
        }
    }
    dw_sequence(b, 0x5200, 0x9230, frames, s->frames, u);
    free(frames);
}

/* PackBits of n bytes (PS3.5 G.3.1): runs of 3 or more as replicate runs. */
static void dw_packbits(dw_buf *b, const unsigned char *x, size_t n) {
    size_t i = 0;
    while (i < n) {
        size_t run = 1;
        while (i + run < n && run < 128 && x[i + run] == x[i]) run++;
        if (run >= 3) {
            unsigned char h[2] = {(unsigned char)(257 - run), x[i]};
            dw_put(b, h, 2);
            i += run;
            continue;
        }
        size_t lit = 0;
        while (
            i + lit < n && lit < 128 &&
            !(i + lit + 2 < n && x[i + lit] == x[i + lit + 1] && x[i + lit] == x[i + lit + 2]))
            lit++;
        unsigned char h = (unsigned char)(lit - 1);
        dw_put(b, &h, 1);
        dw_put(b, x + i, lit);
        i += lit;
    }
}

/* One RLE frame: header and one segment per byte of a sample, most significant first. */
static void dw_rle_frame(dw_buf *b, const uint32_t *w, size_t n, int bytes) {
    dw_buf segs[4];
    unsigned char *plane = malloc(n);
    for (int s = 0; s < bytes; s++) {
        memset(&segs[s], 0, sizeof segs[s]);
        for (size_t i = 0; i < n; i++)
            plane[i] = (unsigned char)(w[i] >> (8 * (bytes - 1 - s)));
        dw_packbits(&segs[s], plane, n);
        if (segs[s].n & 1) dw_put(&segs[s], "", 1);
    }
    free(plane);
    dw_buf le = {NULL, 0, 0, 0, 1};
    dw_u32(&le, (uint32_t)bytes);
    uint32_t off = 64;
    for (int s = 0; s < 15; s++) {
        dw_u32(&le, s < bytes ? off : 0);
        if (s < bytes) off += (uint32_t)segs[s].n;
    }
    for (int s = 0; s < bytes; s++) {
        dw_put(&le, segs[s].p, segs[s].n);
        free(segs[s].p);
    }
    dw_head(b, 0xFFFE, 0xE000, "", (uint32_t)le.n);
    dw_put(b, le.p, le.n);
    free(le.p);
}

/* The fragments of frame f's codestream (padded to even length, PS3.5 A.4), cut into
 * s->split pieces of even length. */
static void dw_codestream(dw_buf *b, const dw_spec *s, size_t f) {
    size_t n = s->codestream_sizes[f], pieces = s->split > 1 ? (size_t)s->split : 1;
    size_t even = n + (n & 1), step = (even / pieces + 1) & ~(size_t)1, at = 0;
    if (step < 2) step = 2;
    unsigned char *padded = calloc(even + 1, 1);
    memcpy(padded, s->codestreams[f], n);
    while (at < even) {
        size_t len = even - at < step ? even - at : step;
        dw_head(b, 0xFFFE, 0xE000, "", (uint32_t)len);
        dw_put(b, padded + at, len);
        at += len;
    }
    free(padded);
}

/* Pixel data: native words in the dataset's byte order, or RLE / JPEG-labelled fragments. */
static void dw_pixels(dw_buf *b, const dw_spec *s) {
    int bytes = s->bits_allocated / 8;
    size_t n = (size_t)s->rows * (size_t)s->cols, frames = (size_t)(s->frames ? s->frames : 1);
    int rle = strcmp(s->syntax, TS_RLE) == 0,
        jpeg = strncmp(s->syntax, "1.2.840.10008.1.2.4.", 20) == 0;
    if (rle || jpeg) {
        dw_buf items = {NULL, 0, 0, 0, 1};
        uint32_t *offsets = calloc(frames + 1, sizeof *offsets);
        for (size_t f = 0; f < frames; f++) {
            offsets[f] = (uint32_t)items.n;
            if (rle) dw_rle_frame(&items, s->words + f * n, n, bytes);
            else if (s->codestreams) dw_codestream(&items, s, f);
            else { /* a stand-in: SOI, EOI */
                dw_head(&items, 0xFFFE, 0xE000, "", 4);
                dw_put(&items, "\xFF\xD8\xFF\xD9", 4);
            }
        }
        offsets[frames] = (uint32_t)items.n;
        if (s->offset_table == 2) { /* 64-bit offsets and each frame's bytes (items and all) */
            dw_head(b, 0x7FE0, 0x0001, "OV", (uint32_t)(8 * frames));
            for (size_t f = 0; f < frames; f++) dw_u32(b, offsets[f]), dw_u32(b, 0);
            dw_head(b, 0x7FE0, 0x0002, "OV", (uint32_t)(8 * frames));
            for (size_t f = 0; f < frames; f++)
                dw_u32(b, offsets[f + 1] - offsets[f]), dw_u32(b, 0);
        }
        dw_head(b, 0x7FE0, 0x0010, "OB", 0xFFFFFFFFu);
        /* the basic offset table: each frame's first item from the first fragment item */
        int bot = s->offset_table == 1;
        dw_head(b, 0xFFFE, 0xE000, "", bot ? (uint32_t)(4 * frames) : 0);
        for (size_t f = 0; f < frames && bot; f++) dw_u32(b, offsets[f]);
        dw_put(b, items.p, items.n);
        free(items.p);
        free(offsets);
        dw_head(b, 0xFFFE, 0xE0DD, "", 0);
        return;
    }
    if (s->bits_allocated == 1) { /* bits of all frames in a row, least significant first */
        size_t nbytes = (n * frames + 7) / 8;
        unsigned char *packed = calloc(nbytes + 1, 1);
        for (size_t i = 0; i < n * frames; i++)
            packed[i >> 3] |= (unsigned char)((s->words[i] & 1u) << (i & 7));
        dw_head(b, 0x7FE0, 0x0010, "OB", (uint32_t)(nbytes + (nbytes & 1)));
        dw_put(b, packed, nbytes + (nbytes & 1));
        free(packed);
        return;
    }
    size_t len = n * frames * (size_t)bytes;
    dw_head(b, 0x7FE0, 0x0010, bytes == 1 ? "OB" : "OW", (uint32_t)(len + (len & 1)));
    for (size_t i = 0; i < n * frames; i++) {
        if (bytes == 1) { unsigned char c = (unsigned char)s->words[i]; dw_put(b, &c, 1); }
        else if (bytes == 2) dw_u16(b, s->words[i] & 0xFFFF);
        else dw_u32(b, s->words[i]);
    }
    if (len & 1) dw_put(b, "", 1);
}

/* The dataset (group 0008 and up) of s in b's encoding. */
static void dw_dataset(dw_buf *b, const dw_spec *s) {
    dw_str(b, 0x0008, 0x0016, "UI", CT_IMAGE_CLASS);
    if (s->modality) dw_str(b, 0x0008, 0x0060, "CS", s->modality);
    if (s->description) dw_str(b, 0x0008, 0x103E, "LO", s->description);
    if (s->slice_thickness != 0) dw_ds(b, 0x0018, 0x0050, &s->slice_thickness, 1);
    if (s->series_uid) dw_str(b, 0x0020, 0x000E, "UI", s->series_uid);
    if (s->has_position) dw_ds(b, 0x0020, 0x0032, s->position, 3);
    if (s->has_orientation) dw_ds(b, 0x0020, 0x0037, s->orientation, 6);
    dw_us(b, 0x0028, 0x0002, (unsigned)(s->samples ? s->samples : 1));
    dw_str(b, 0x0028, 0x0004, "CS", "MONOCHROME2");
    if (s->frames > 1 || s->lie_frames) {
        char nf[16];
        snprintf(nf, sizeof nf, "%d", s->lie_frames ? s->lie_frames : s->frames);
        dw_str(b, 0x0028, 0x0008, "IS", nf);
    }
    dw_us(b, 0x0028, 0x0010, (unsigned)(s->lie_rows ? s->lie_rows : s->rows));
    dw_us(b, 0x0028, 0x0011, (unsigned)(s->lie_cols ? s->lie_cols : s->cols));
    if (!s->frame_positions) dw_ds(b, 0x0028, 0x0030, s->spacing, 2);
    dw_us(b, 0x0028, 0x0100, (unsigned)s->bits_allocated);
    dw_us(b, 0x0028, 0x0101, (unsigned)s->bits_stored);
    dw_us(b, 0x0028, 0x0102, (unsigned)s->high_bit);
    dw_us(b, 0x0028, 0x0103, (unsigned)s->pixel_rep);
    if (s->has_padding) dw_us(b, 0x0028, 0x0120, (unsigned)s->padding & 0xFFFF);
    if (s->has_rescale) {
        dw_ds(b, 0x0028, 0x1052, &s->intercept, 1);
        dw_ds(b, 0x0028, 0x1053, &s->slope, 1);
    }
    if (s->grid_offsets) dw_ds(b, 0x3004, 0x000C, s->grid_offsets, s->frames);
    if (s->dose_scaling != 0) dw_ds(b, 0x3004, 0x000E, &s->dose_scaling, 1);
    if (s->frame_positions) dw_functional_groups(b, s);
    if (!s->no_pixels) dw_pixels(b, s);
}

/* Raw deflate of the dataset (PS3.5 A.5). */
static void dw_deflate(dw_buf *out, const dw_buf *in) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    deflateInit2(&zs, 6, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY);
    size_t cap = deflateBound(&zs, (uLong)in->n);
    unsigned char *tmp = malloc(cap);
    zs.next_in = in->p, zs.avail_in = (uInt)in->n;
    zs.next_out = tmp, zs.avail_out = (uInt)cap;
    deflate(&zs, Z_FINISH);
    dw_put(out, tmp, cap - zs.avail_out);
    deflateEnd(&zs);
    free(tmp);
}

/* Writes s to path: preamble, "DICM", file meta group, dataset. Returns 0 on success. */
static int dw_write(const char *path, const dw_spec *s) {
    dw_buf meta = {NULL, 0, 0, 0, 1}, file = {NULL, 0, 0, 0, 1};
    dw_head(&meta, 0x0002, 0x0001, "OB", 2);
    dw_put(&meta, "\0\1", 2);
    dw_str(&meta, 0x0002, 0x0002, "UI", CT_IMAGE_CLASS);
    dw_str(&meta, 0x0002, 0x0010, "UI", s->syntax);
    unsigned char pre[128] = {0};
    dw_put(&file, pre, sizeof pre);
    dw_put(&file, "DICM", 4);
    dw_head(&file, 0x0002, 0x0000, "UL", 4);
    dw_u32(&file, (uint32_t)meta.n);
    dw_put(&file, meta.p, meta.n);
    int implicit = strcmp(s->syntax, TS_IMPLICIT) == 0, big = strcmp(s->syntax, TS_BIG) == 0;
    dw_buf ds = {NULL, 0, 0, big, !implicit};
    dw_dataset(&ds, s);
    if (strcmp(s->syntax, TS_DEFLATED) == 0)
        dw_deflate(&file, &ds);
    else
        dw_put(&file, ds.p, ds.n);
    FILE *fp = fopen(path, "wb");
    int bad = !fp || fwrite(file.p, 1, file.n, fp) != file.n;
    if (fp && fclose(fp) != 0) bad = 1;
    free(meta.p), free(file.p), free(ds.p);
    return bad ? -1 : 0;
}

#endif
