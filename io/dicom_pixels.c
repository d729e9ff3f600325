/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom_pixels.c — one frame of DICOM pixel data to modality values: native samples in
 * either byte order, RLE lossless, the fragments of a compressed frame (handed to
 * io/dicom_codecs.c), BitsStored masking, sign, padding, rescale and dose scaling. Follows
 * DICOM PS3.5 section 8 and annexes A.4 and G, PS3.3 C.7.6.3, C.11.1 and C.8.8.3. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include "dicom_internal.h"

enum {
    RLE_HEADER = 64,       /* PS3.5 G.3.1: segment count and 15 offsets, 32 bits each */
    RLE_MAX_SEGMENTS = 15,
    RLE_RUN_MAX = 128      /* PackBits: one run header byte covers at most 128 bytes */
};

/* The stored sample type from BitsAllocated and PixelRepresentation. */
vm_scalar_type vm__dcm_stored_type(const dcm_file *f) {
    int s = f->pixel_rep == 1;
    if (f->bits_allocated <= 8) return s ? VM_SCALAR_INT8 : VM_SCALAR_UINT8;
    if (f->bits_allocated == 32) return s ? VM_SCALAR_INT32 : VM_SCALAR_UINT32;
    return s ? VM_SCALAR_INT16 : VM_SCALAR_UINT16;
}

/* The sample layout (PS3.3 C.7.6.3): one sample, 8/16/32 bits, BitsStored and HighBit that
 * fit (absent ones default to BitsAllocated and BitsStored - 1). */
static vm_status check_layout(dcm_file *f, vm_error *err) {
    const char *p = f->path;
    if (f->samples != 1)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: SamplesPerPixel is %lld (colour); "
                            "volmesh reads grayscale images only (1 sample per pixel)", p,
                            (long long)f->samples);
    if (f->rows < 1 || f->cols < 1)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: Rows %lld and Columns %lld must be >= 1",
                            p, (long long)f->rows, (long long)f->cols);
    if (f->bits_allocated == 1 && (f->encapsulated || f->pixel_rep != 0))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: BitsAllocated 1 is supported in "
                            "native, unsigned pixel data only", p);
    if (f->bits_allocated != 1 && f->bits_allocated != 8 && f->bits_allocated != 16 &&
        f->bits_allocated != 32)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: BitsAllocated %lld is not "
                            "supported (1, 8, 16 or 32)", p, (long long)f->bits_allocated);
    if (f->bits_stored == 0) f->bits_stored = f->bits_allocated;
    if (f->high_bit < 0) f->high_bit = f->bits_stored - 1;
    if (f->bits_stored > f->bits_allocated || f->high_bit >= f->bits_allocated ||
        f->high_bit + 1 < f->bits_stored)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: BitsStored %lld and HighBit %lld do not "
                            "fit BitsAllocated %lld", p, (long long)f->bits_stored,
                            (long long)f->high_bit, (long long)f->bits_allocated);
    if (f->pixel_rep != 0 && f->pixel_rep != 1)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: PixelRepresentation %lld must be 0 or 1",
                            p, (long long)f->pixel_rep);
    return VM_OK;
}

/* True for the syntaxes whose frames a codec library decodes (or that none does). */
static bool compressed(const dcm_file *f) { return f->syntax >= DCM_JPEG; }

/* The item tag's place of fragment k, counted from the first fragment item, as the basic
 * offset table counts (PS3.5 A.4: each item has an 8-byte header). */
static size_t item_place(const dcm_file *f, size_t k) {
    return f->fragments[k].offset - 8 - f->first_item;
}

/* True when fragment k starts a codestream: SOI (JPEG, JPEG-LS; T.81 B.1.1.3), SOC and SIZ
 * (JPEG 2000 codestream; 15444-1 A.4.1) or a JP2 signature box. */
static bool starts_codestream(const dcm_file *f, const unsigned char *q, size_t n) {
    if (f->syntax == DCM_J2K)
        return (n >= 4 && q[0] == 0xFF && q[1] == 0x4F && q[2] == 0xFF && q[3] == 0x51) ||
               (n >= 8 && memcmp(q, "\0\0\0\x0cjP  ", 8) == 0);
    return n >= 2 && q[0] == 0xFF && q[1] == 0xD8;
}

/* The fragments of compressed frame `frame` (PS3.5 A.4): [out] *first and *count. From the
 * basic (or extended) offset table when present; else one frame in every fragment; one fragment per
 * frame; or, with more fragments than frames, a frame from each fragment that starts a
 * codestream (b: the bytes, needed in that last case only). */
static vm_status frame_fragments(const dcm_file *f, const dcm_bytes *b, int64_t frame,
                                 size_t *first, size_t *count, vm_error *err) {
    const char *p = f->path;
    size_t nf = (size_t)f->frames, k = (size_t)frame;
    if (f->n_fragments == 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: encapsulated pixel data has no "
                            "fragments", p);
    if (f->n_frame_offsets > 0) {
        const char *table = f->extended_offsets ? "extended" : "basic";
        if (f->n_frame_offsets != nf)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: the %s offset table has %zu "
                                "entries for %zu frame(s)", p, table, f->n_frame_offsets, nf);
        size_t at = 0;
        while (at < f->n_fragments && item_place(f, at) < f->frame_offsets[k]) at++;
        size_t end = at;
        while (end < f->n_fragments &&
               (k + 1 == nf || item_place(f, end) < f->frame_offsets[k + 1]))
            end++;
        if (at == f->n_fragments || item_place(f, at) != f->frame_offsets[k] || end == at)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: the %s offset table entry of "
                                "frame %zu (%llu) points at no fragment of its own", p, table,
                                k + 1, (unsigned long long)f->frame_offsets[k]);
        *first = at, *count = end - at;
        return VM_OK;
    }
    if (nf == 1 || f->n_fragments == nf) {
        *first = nf == 1 ? 0 : k, *count = nf == 1 ? f->n_fragments : 1;
        return VM_OK;
    }
    size_t seen = 0;
    for (size_t i = 0; i < f->n_fragments; i++) {
        const dcm_fragment *fr = &f->fragments[i];
        if (!starts_codestream(f, b->p + fr->offset, fr->length)) continue;
        if (seen++ < k) continue;
        size_t end = i + 1;
        while (end < f->n_fragments &&
               !starts_codestream(f, b->p + f->fragments[end].offset, f->fragments[end].length))
            end++;
        *first = i, *count = end - i;
        return VM_OK;
    }
    return vm_error_set(err, VM_ERR_FORMAT, "%s: encapsulated pixel data has %zu fragments "
                        "and no offset table, and frame %zu of %zu starts in none of them", p,
                        f->n_fragments, k + 1, nf);
}

/* The pixel data against the syntax and the frames it must hold. */
static vm_status check_storage(const dcm_file *f, vm_error *err) {
    const char *p = f->path;
    if ((f->syntax == DCM_RLE || compressed(f)) != (f->encapsulated != 0))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: pixel data is %s but the transfer syntax "
                            "%s says otherwise", p, f->encapsulated ? "encapsulated" : "native",
                            f->syntax_uid[0] ? f->syntax_uid : "(none)");
    size_t plane, frame, all;
    if (f->encapsulated && compressed(f)) { /* the offset table is read without the bytes */
        size_t first, count;
        if (f->n_fragments < (size_t)f->frames)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: compressed pixel data has %zu "
                                "fragments for %lld frames", p, f->n_fragments,
                                (long long)f->frames);
        for (int64_t k = 0; k < f->frames && f->n_frame_offsets > 0; k++) {
            vm_status st = frame_fragments(f, NULL, k, &first, &count, err);
            if (st) return st;
        }
        return VM_OK;
    }
    if (f->encapsulated) {
        if (f->n_fragments < (size_t)f->frames)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: RLE pixel data has %zu fragments for "
                                "%lld frames", p, f->n_fragments, (long long)f->frames);
        /* PackBits turns 2 bytes into at most 128: a shorter fragment cannot hold a frame */
        size_t nseg = (size_t)f->bits_allocated / 8;
        plane = (size_t)f->rows * (size_t)f->cols;
        for (int64_t k = 0; k < f->frames; k++)
            if ((f->fragments[k].length -
                 (f->fragments[k].length > RLE_HEADER ? RLE_HEADER : 0)) /
                    2 <
                nseg * ((plane + RLE_RUN_MAX - 1) / RLE_RUN_MAX))
                return vm_error_set(err, VM_ERR_FORMAT, "%s: RLE fragment of frame %lld (%zu "
                                    "bytes) is too short for %lldx%lld pixels", p,
                                    (long long)k + 1, f->fragments[k].length,
                                    (long long)f->cols, (long long)f->rows);
        return VM_OK;
    }
    /* 1-bit frames follow each other bit after bit (PS3.5 8.1.1): bits, then bytes */
    size_t per = f->bits_allocated == 1 ? 1 : (size_t)f->bits_allocated / 8;
    if (vm__mul_overflows((size_t)f->rows, (size_t)f->cols, &plane) ||
        vm__mul_overflows(plane, per, &frame) || vm__mul_overflows(frame, (size_t)f->frames, &all) ||
        (f->bits_allocated == 1 ? (all + 7) / 8 : all) > f->pixel_length)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: pixel data holds %zu bytes, fewer than "
                            "%lld frame(s) of %lldx%lld at %lld bits need", p, f->pixel_length,
                            (long long)f->frames, (long long)f->cols, (long long)f->rows,
                            (long long)f->bits_allocated);
    return VM_OK;
}

/* Checks that f's frames can be decoded: syntax first, then layout and sizes. */
vm_status vm__dcm_check_pixels(dcm_file *f, vm_error *err) {
    if (!f->has_pixels)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: no pixel data (7FE0,0010): not an image",
                            f->path);
    if (compressed(f)) { /* first: whatever else the file holds */
        vm_status st = vm__dcm_codec_check(f, err);
        if (st) return st;
    }
    vm_status st = check_layout(f, err);
    if (!st) st = check_storage(f, err);
    if (!st && !(isfinite(f->slope) && isfinite(f->intercept) && isfinite(f->dose_scaling)))
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: rescale values are not finite", f->path);
    return st;
}

/* Native samples of one frame as unsigned words (PS3.5 8.1.1: OW words in the syntax's byte
 * order; OB bytes as they are; 1-bit pixels packed from the least significant bit, frames
 * not byte-aligned, as segmentations store them, PS3.5 8.1.1 and PS3.3 C.8.20.2). */
static void native_words(const dcm_file *f, const dcm_bytes *b, int64_t frame, size_t n,
                         uint32_t *raw) {
    if (f->bits_allocated == 1) {
        const unsigned char *bits = b->p + f->pixel_offset;
        size_t first = (size_t)frame * n;
        for (size_t i = 0, at = first; i < n; i++, at++)
            raw[i] = bits[at >> 3] >> (at & 7) & 1u;
        return;
    }
    size_t bytes = (size_t)f->bits_allocated / 8;
    const unsigned char *s = b->p + f->pixel_offset + (size_t)frame * n * bytes;
    for (size_t i = 0; i < n; i++, s += bytes) {
        if (bytes == 1) raw[i] = s[0];
        else if (bytes == 2)
            raw[i] = b->big ? (uint32_t)s[0] << 8 | s[1] : (uint32_t)s[1] << 8 | s[0];
        else
            raw[i] = b->big ? (uint32_t)s[0] << 24 | (uint32_t)s[1] << 16 |
                                  (uint32_t)s[2] << 8 | s[3]
                            : (uint32_t)s[3] << 24 | (uint32_t)s[2] << 16 |
                                  (uint32_t)s[1] << 8 | s[0];
    }
}

/* One PackBits segment (PS3.5 G.3.1) into n bytes at out; returns the bytes produced. */
static size_t unpack_segment(const unsigned char *s, size_t len, unsigned char *out, size_t n) {
    size_t i = 0, o = 0;
    while (i < len && o < n) {
        int c = (signed char)s[i++];
        if (c >= 0) { /* c + 1 literal bytes */
            size_t k = (size_t)c + 1;
            if (k > len - i) k = len - i;
            if (k > n - o) k = n - o;
            memcpy(out + o, s + i, k);
            i += k, o += k;
        } else if (c != -128 && i < len) { /* the next byte 1 - c times */
            size_t k = (size_t)(1 - c);
            if (k > n - o) k = n - o;
            memset(out + o, s[i++], k);
            o += k;
        }
    }
    return o;
}

/* An RLE frame (one fragment, PS3.5 G.2-G.5) as unsigned words: segment s holds byte s of
 * each sample counted from the most significant. */
static vm_status rle_words(const dcm_file *f, const dcm_bytes *b, int64_t frame, size_t n,
                           uint32_t *raw, vm_error *err) {
    const dcm_fragment *fr = &f->fragments[frame];
    const unsigned char *s = b->p + fr->offset;
    size_t nseg = (size_t)f->bits_allocated / 8;
    if (fr->length < RLE_HEADER || (s[0] | s[1] << 8 | s[2] << 16 | (size_t)s[3] << 24) != nseg)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: RLE header does not give %zu "
                            "segment(s)", f->path, (long long)frame, nseg);
    size_t off[RLE_MAX_SEGMENTS + 1];
    for (size_t k = 0; k <= nseg; k++) {
        const unsigned char *q = s + 4 + 4 * k;
        off[k] = k == nseg ? fr->length
                           : (size_t)(q[0] | q[1] << 8 | q[2] << 16 | (uint32_t)q[3] << 24);
        if (off[k] < (k ? off[k - 1] : RLE_HEADER) || off[k] > fr->length)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: RLE segment offsets are "
                                "out of order or past the fragment", f->path, (long long)frame);
    }
    unsigned char *plane = malloc(n ? n : 1);
    if (!plane) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    memset(raw, 0, n * sizeof *raw);
    for (size_t k = 0; k < nseg; k++) {
        if (unpack_segment(s + off[k], off[k + 1] - off[k], plane, n) != n) {
            free(plane);
            return vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: RLE segment %zu decodes "
                                "to fewer than %zu bytes", f->path, (long long)frame, k, n);
        }
        unsigned shift = (unsigned)(8 * (nseg - 1 - k));
        for (size_t i = 0; i < n; i++) raw[i] |= (uint32_t)plane[i] << shift;
    }
    free(plane);
    return VM_OK;
}

/* A compressed frame as stored words: its fragments joined, then decoded by its codec. */
static vm_status compressed_words(const dcm_file *f, const dcm_bytes *b, int64_t frame,
                                  uint32_t *raw, vm_error *err) {
    size_t first, count, len = 0;
    vm_status st = frame_fragments(f, b, frame, &first, &count, err);
    if (st) return st;
    if (count == 1)
        return vm__dcm_codec_decode(f, frame, b->p + f->fragments[first].offset,
                                    f->fragments[first].length, raw, err);
    for (size_t k = first; k < first + count; k++) len += f->fragments[k].length;
    unsigned char *joined = malloc(len ? len : 1);
    if (!joined) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    for (size_t k = first, at = 0; k < first + count; k++) {
        memcpy(joined + at, b->p + f->fragments[k].offset, f->fragments[k].length);
        at += f->fragments[k].length;
    }
    st = vm__dcm_codec_decode(f, frame, joined, len, raw, err);
    free(joined);
    return st;
}

/* Stored words to modality values: mask to BitsStored below HighBit, sign-extend, padding to
 * NaN, then slope, intercept and dose scaling (PS3.3 C.7.6.3.1, C.11.1.1.2, C.8.8.3.4.1). */
static void to_values(const dcm_file *f, int64_t frame, const uint32_t *raw, size_t n,
                      float *dst) {
    unsigned bits = (unsigned)f->bits_stored;
    unsigned shift = (unsigned)(f->high_bit + 1 - f->bits_stored);
    uint32_t mask = bits >= 32 ? 0xFFFFFFFFu : (1u << bits) - 1u;
    int sign = f->pixel_rep == 1;
    double slope = f->slope, intercept = f->intercept;
    if (f->frame_rescale && frame < f->n_frame_positions) {
        if (!isnan(f->frame_rescale[2 * frame])) slope = f->frame_rescale[2 * frame];
        if (!isnan(f->frame_rescale[2 * frame + 1]))
            intercept = f->frame_rescale[2 * frame + 1];
    }
    int64_t pad = sign ? (int64_t)(int16_t)(uint16_t)f->padding_raw : (int64_t)f->padding_raw;
    for (size_t i = 0; i < n; i++) {
        uint32_t u = (raw[i] >> shift) & mask;
        int64_t v = sign && (u >> (bits - 1)) & 1u ? (int64_t)u - ((int64_t)1 << bits)
                                                    : (int64_t)u;
        if (f->has_padding && v == pad)
            dst[i] = NAN;
        else
            dst[i] = (float)(((double)v * slope + intercept) * f->dose_scaling);
    }
}

/* Decodes one frame of f into modality values. */
vm_status vm__dcm_decode_frame(const dcm_file *f, const dcm_bytes *b, int64_t frame,
                               float *dst, vm_error *err) {
    size_t n = (size_t)f->rows * (size_t)f->cols, bytes;
    if (vm__mul_overflows(n, sizeof(uint32_t), &bytes) || bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "%s: a frame of %lldx%lld is larger than "
                            "allowed", f->path, (long long)f->cols, (long long)f->rows);
    uint32_t *raw = malloc(bytes ? bytes : 1);
    if (!raw) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    vm_status st = VM_OK;
    if (f->encapsulated && compressed(f))
        st = compressed_words(f, b, frame, raw, err);
    else if (f->encapsulated)
        st = rle_words(f, b, frame, n, raw, err);
    else
        native_words(f, b, frame, n, raw);
    if (!st) to_values(f, frame, raw, n, dst);
    free(raw);
    return st;
}
