/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom_codecs.c — one compressed DICOM frame to stored words with the codec library found
 * at build time: JPEG (libjpeg-turbo), JPEG-LS (CharLS), JPEG 2000 (OpenJPEG). Follows DICOM
 * PS3.5 A.4.1, A.4.3 and A.4.4, ITU T.81 B.2.2 (frame header), T.87 and ISO 15444-1 A.4. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "dicom_internal.h"
#ifdef VM_HAVE_DICOM_JPEG
#include <jpeglib.h>
#endif
#ifdef VM_HAVE_DICOM_JPEGLS
#include <charls/charls.h>
#endif
#ifdef VM_HAVE_DICOM_J2K
#include <openjpeg.h>
#endif

enum { MSG_MAX = 200 }; /* a library's message, cut to keep the error on one line */

/* The Debian package whose library decodes syntax s (docs/FORMATS.md). */
static const char *package_of(dcm_syntax s) {
    return s == DCM_JPEG ? "libjpeg62-turbo-dev" : s == DCM_JPEGLS ? "libcharls-dev"
                                                                     : "libopenjp2-7-dev";
}

/* True when this build decodes syntax s. */
static bool built_in(dcm_syntax s) {
    switch (s) {
#ifdef VM_HAVE_DICOM_JPEG
    case DCM_JPEG: return true;
#endif
#ifdef VM_HAVE_DICOM_JPEGLS
    case DCM_JPEGLS: return true;
#endif
#ifdef VM_HAVE_DICOM_J2K
    case DCM_J2K: return true;
#endif
    default: return false;
    }
}

/* The lossless JPEG processes (PS3.5 A.4.1: .57 and .70). */
static bool jpeg_lossless_uid(const char *uid) {
    return strcmp(uid, "1.2.840.10008.1.2.4.57") == 0 ||
           strcmp(uid, "1.2.840.10008.1.2.4.70") == 0;
}

/* Checks that this build decodes f's compressed syntax; else the one line naming it and the
 * package to build with. */
vm_status vm__dcm_codec_check(const dcm_file *f, vm_error *err) {
    const char *name = vm__dcm_syntax_name(f->syntax_uid);
    if (!name) name = "unknown";
    if (f->syntax != DCM_JPEG && f->syntax != DCM_JPEGLS && f->syntax != DCM_J2K)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: transfer syntax %s (%s) is "
                            "compressed; volmesh has no decoder for it", f->path,
                            f->syntax_uid, name);
    if (!built_in(f->syntax))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: transfer syntax %s (%s) is "
                            "compressed; this build has no decoder for it (rebuild volmesh "
                            "with Debian's %s installed)", f->path, f->syntax_uid, name,
                            package_of(f->syntax));
#ifndef VM_HAVE_DICOM_JPEG16
    if (f->syntax == DCM_JPEG && jpeg_lossless_uid(f->syntax_uid))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: transfer syntax %s (%s) needs "
                            "libjpeg-turbo 3.0 or later (its lossless decoder); this build's "
                            "libjpeg decodes 8-bit lossy JPEG only", f->path, f->syntax_uid,
                            name);
#endif
    return VM_OK;
}

/* The decoded image against the header: one component of cols x rows, at most
 * BitsAllocated bits. */
static vm_status check_decoded(const dcm_file *f, int64_t frame, const char *what, long long w,
                               long long h, long long comps, long long bits, vm_error *err) {
    if (comps != 1 || w != f->cols || h != f->rows || bits < 1 || bits > f->bits_allocated)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: the %s codestream holds "
                            "%lldx%lld pixels of %lld component(s) at %lld bits, but the "
                            "header says %lldx%lld of 1 at %lld bits", f->path,
                            (long long)frame + 1, what, w, h, comps, bits, (long long)f->cols,
                            (long long)f->rows, (long long)f->bits_allocated);
    return VM_OK;
}

/* One line of a library message: newlines cut, at most MSG_MAX - 1 bytes. */
static void one_line(char *dst, const char *src) {
    size_t k = 0;
    while (src[k] && src[k] != '\n' && k + 1 < MSG_MAX) dst[k] = src[k], k++;
    dst[k] = 0;
}

#ifdef VM_HAVE_DICOM_JPEG
/* T.81 B.1.1.3: SOF markers are FFC0..FFCF except DHT (C4), JPG (C8) and DAC (CC). */
static bool is_sof(unsigned m) {
    return m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
}

/* Finds the frame header (T.81 B.2.2) by walking the marker segments after SOI: [out] its
 * marker and sample precision. False when there is none before the scan or the data ends. */
static bool jpeg_frame_header(const unsigned char *p, size_t n, unsigned *marker,
                              unsigned *precision) {
    if (n < 4 || p[0] != 0xFF || p[1] != 0xD8) return false;
    size_t at = 2;
    while (at + 4 <= n) {
        if (p[at] != 0xFF) return false;
        unsigned m = p[at + 1];
        if (m == 0xFF) { at++; continue; } /* fill bytes before a marker */
        size_t len = (size_t)p[at + 2] << 8 | p[at + 3];
        if (is_sof(m)) {
            if (at + 5 > n) return false;
            *marker = m, *precision = p[at + 4];
            return true;
        }
        if (m == 0xDA || m == 0xD9 || len < 2) return false;
        at += 2 + len;
    }
    return false;
}

/* libjpeg's error manager: errors and warnings (corrupt or truncated data) jump back. */
typedef struct jpeg_fail {
    struct jpeg_error_mgr mgr;
    jmp_buf back;
    char msg[JMSG_LENGTH_MAX];
} jpeg_fail;

/* Keeps libjpeg's message and jumps back to jpeg_words. */
static void jpeg_on_error(j_common_ptr c) {
    jpeg_fail *e = (jpeg_fail *)c->err;
    e->mgr.format_message(c, e->msg);
    longjmp(e->back, 1);
}

/* Turns libjpeg's warnings into errors; trace messages are dropped. */
static void jpeg_on_message(j_common_ptr c, int level) {
    if (level < 0) jpeg_on_error(c); /* a warning: premature end, corrupt data */
}

/* The decoder state, outside the frame that calls setjmp so that it survives the jump. */
typedef struct jpeg_job {
    struct jpeg_decompress_struct d;
    jpeg_fail fail;
    void *row; /* one row of samples (8 or 16 bits) */
} jpeg_job;

/* Decodes with libjpeg; 0 on success, else 1 with j->fail.msg set. */
static int jpeg_run(jpeg_job *j, const unsigned char *p, size_t n, const dcm_file *f,
                    int64_t frame, uint32_t *raw, vm_error *err, vm_status *st) {
    if (setjmp(j->fail.back)) return 1;
    jpeg_mem_src(&j->d, p, (unsigned long)n);
    jpeg_read_header(&j->d, TRUE);
    *st = check_decoded(f, frame, "JPEG", j->d.image_width, j->d.image_height,
                        j->d.num_components, j->d.data_precision, err);
    if (*st) return 0;
    j->d.out_color_space = JCS_GRAYSCALE;
    jpeg_start_decompress(&j->d);
    size_t cols = (size_t)f->cols;
    while (j->d.output_scanline < j->d.output_height) {
        uint32_t *out = raw + (size_t)j->d.output_scanline * cols;
        if (j->d.data_precision <= 8) {
            JSAMPROW r = j->row;
            jpeg_read_scanlines(&j->d, &r, 1);
            for (size_t i = 0; i < cols; i++) out[i] = r[i];
#ifdef VM_HAVE_DICOM_JPEG16
        } else if (j->d.data_precision <= 12) {
            J12SAMPROW r = j->row;
            jpeg12_read_scanlines(&j->d, &r, 1);
            for (size_t i = 0; i < cols; i++) out[i] = (uint32_t)(uint16_t)r[i];
        } else {
            J16SAMPROW r = j->row;
            jpeg16_read_scanlines(&j->d, &r, 1);
            for (size_t i = 0; i < cols; i++) out[i] = r[i];
#endif
        }
    }
    jpeg_finish_decompress(&j->d);
    return 0;
}

/* A JPEG frame (T.81: baseline, extended, lossless) to stored words. */
static vm_status jpeg_words(const dcm_file *f, int64_t frame, const unsigned char *p, size_t n,
                            uint32_t *raw, vm_error *err) {
    unsigned marker, precision;
    if (!jpeg_frame_header(p, n, &marker, &precision))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: the JPEG codestream is "
                            "corrupt or truncated (no frame header)", f->path,
                            (long long)frame + 1);
#ifndef VM_HAVE_DICOM_JPEG16
    if (precision != 8 || marker == 0xC3 || marker == 0xC7 || marker == 0xCB || marker == 0xCF)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: frame %lld: %u-bit %s JPEG needs "
                            "libjpeg-turbo 3.0 or later; this build's libjpeg decodes 8-bit "
                            "lossy JPEG only", f->path, (long long)frame + 1, precision,
                            (marker & 3) == 3 ? "lossless" : "lossy");
#endif
    jpeg_job *j = calloc(1, sizeof *j);
    if (j) j->row = malloc((size_t)f->cols * 2 + 16);
    if (!j || !j->row) {
        if (j) free(j);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    }
    j->d.err = jpeg_std_error(&j->fail.mgr);
    j->fail.mgr.error_exit = jpeg_on_error;
    j->fail.mgr.emit_message = jpeg_on_message;
    jpeg_create_decompress(&j->d);
    vm_status st = VM_OK;
    if (jpeg_run(j, p, n, f, frame, raw, err, &st)) {
        char msg[MSG_MAX];
        one_line(msg, j->fail.msg);
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: the JPEG codestream is corrupt "
                          "or truncated (libjpeg: %s)", f->path, (long long)frame + 1, msg);
    }
    jpeg_destroy_decompress(&j->d);
    free(j->row);
    free(j);
    return st;
}
#endif

#ifdef VM_HAVE_DICOM_JPEGLS
/* A JPEG-LS frame (T.87, lossless or near-lossless) to stored words with CharLS. */
static vm_status jpegls_words(const dcm_file *f, int64_t frame, const unsigned char *p,
                              size_t n, uint32_t *raw, vm_error *err) {
    charls_jpegls_decoder *d = charls_jpegls_decoder_create();
    if (!d) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    charls_frame_info fi;
    size_t size = 0;
    unsigned char *buf = NULL;
    vm_status st = VM_OK;
    charls_jpegls_errc e = charls_jpegls_decoder_set_source_buffer(d, p, n);
    if (!e) e = charls_jpegls_decoder_read_header(d);
    if (!e) e = charls_jpegls_decoder_get_frame_info(d, &fi);
    if (!e) {
        st = check_decoded(f, frame, "JPEG-LS", fi.width, fi.height, fi.component_count,
                           fi.bits_per_sample, err);
        if (!st) e = charls_jpegls_decoder_get_destination_size(d, 0, &size);
    }
    if (!st && !e) {
        buf = malloc(size ? size : 1);
        if (!buf) st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
        else e = charls_jpegls_decoder_decode_to_buffer(d, buf, size, 0);
    }
    if (!st && e) {
        char msg[MSG_MAX];
        one_line(msg, charls_get_error_message(e));
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: the JPEG-LS codestream is "
                          "corrupt or truncated (CharLS: %s)", f->path, (long long)frame + 1,
                          msg);
    }
    if (!st) {
        size_t count = (size_t)f->rows * (size_t)f->cols;
        if (fi.bits_per_sample <= 8)
            for (size_t i = 0; i < count; i++) raw[i] = buf[i];
        else
            for (size_t i = 0; i < count; i++) { /* samples in the machine's byte order */
                uint16_t v;
                memcpy(&v, buf + 2 * i, 2);
                raw[i] = v;
            }
    }
    free(buf);
    charls_jpegls_decoder_destroy(d);
    return st;
}
#endif

#ifdef VM_HAVE_DICOM_J2K
/* The codestream bytes OpenJPEG reads through its stream callbacks. */
typedef struct j2k_source {
    const unsigned char *p;
    size_t n, at;
    char msg[MSG_MAX]; /* the first error OpenJPEG reported */
} j2k_source;

/* OpenJPEG's read callback: up to want bytes, (OPJ_SIZE_T)-1 at the end. */
static OPJ_SIZE_T j2k_read(void *dst, OPJ_SIZE_T want, void *user) {
    j2k_source *s = user;
    if (s->at >= s->n) return (OPJ_SIZE_T)-1;
    size_t k = s->n - s->at < want ? s->n - s->at : want;
    memcpy(dst, s->p + s->at, k);
    s->at += k;
    return k;
}

/* OpenJPEG's skip callback: forward only, clamped to the end. */
static OPJ_OFF_T j2k_skip(OPJ_OFF_T by, void *user) {
    j2k_source *s = user;
    if (by < 0) return -1;
    size_t k = s->n - s->at < (uint64_t)by ? s->n - s->at : (size_t)by;
    s->at += k;
    return (OPJ_OFF_T)k;
}

/* OpenJPEG's seek callback: any place inside the codestream. */
static OPJ_BOOL j2k_seek(OPJ_OFF_T to, void *user) {
    j2k_source *s = user;
    if (to < 0 || (uint64_t)to > s->n) return OPJ_FALSE;
    s->at = (size_t)to;
    return OPJ_TRUE;
}

/* Keeps OpenJPEG's first error message for the one-line refusal. */
static void j2k_on_error(const char *msg, void *user) {
    j2k_source *s = user;
    if (!s->msg[0]) one_line(s->msg, msg);
}

/* Drops OpenJPEG's warnings and information. */
static void j2k_quiet(const char *msg, void *user) { (void)msg, (void)user; }

/* A JPEG 2000 frame (a J2K codestream, or a JP2 file as some writers store) to stored words
 * with OpenJPEG; signed samples keep their two's complement bits. */
static vm_status j2k_words(const dcm_file *f, int64_t frame, const unsigned char *p, size_t n,
                           uint32_t *raw, vm_error *err) {
    static const unsigned char JP2_SIGNATURE[8] = {0, 0, 0, 12, 'j', 'P', ' ', ' '};
    int jp2 = n >= 8 && memcmp(p, JP2_SIGNATURE, 8) == 0;
    j2k_source src = {p, n, 0, {0}};
    opj_codec_t *c = opj_create_decompress(jp2 ? OPJ_CODEC_JP2 : OPJ_CODEC_J2K);
    opj_stream_t *s = opj_stream_create(1u << 16, OPJ_TRUE);
    opj_image_t *img = NULL;
    vm_status st = VM_OK;
    if (!c || !s) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
        goto done;
    }
    opj_stream_set_user_data(s, &src, NULL);
    opj_stream_set_user_data_length(s, n);
    opj_stream_set_read_function(s, j2k_read);
    opj_stream_set_skip_function(s, j2k_skip);
    opj_stream_set_seek_function(s, j2k_seek);
    opj_set_error_handler(c, j2k_on_error, &src);
    opj_set_warning_handler(c, j2k_quiet, NULL);
    opj_set_info_handler(c, j2k_quiet, NULL);
    opj_dparameters_t par;
    opj_set_default_decoder_parameters(&par);
    bool ok = opj_setup_decoder(c, &par);
#ifdef VM_HAVE_OPJ_STRICT
    ok = ok && opj_decoder_set_strict_mode(c, OPJ_TRUE); /* truncation is an error */
#endif
    ok = ok && opj_read_header(s, c, &img);
    if (ok) {
        const opj_image_comp_t *k = &img->comps[0];
        st = check_decoded(f, frame, "JPEG 2000", k->w, k->h, img->numcomps, k->prec, err);
        if (st) goto done;
    }
    ok = ok && opj_decode(c, s, img) && opj_end_decompress(c, s) && img->comps[0].data;
    if (!ok) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: frame %lld: the JPEG 2000 codestream is "
                          "corrupt or truncated (OpenJPEG: %s)", f->path, (long long)frame + 1,
                          src.msg[0] ? src.msg : "decoding failed");
        goto done;
    }
    const opj_image_comp_t *k = &img->comps[0];
    if (k->w != (OPJ_UINT32)f->cols || k->h != (OPJ_UINT32)f->rows) { /* reduced or cropped */
        st = check_decoded(f, frame, "JPEG 2000", k->w, k->h, img->numcomps, k->prec, err);
        goto done;
    }
    size_t count = (size_t)f->rows * (size_t)f->cols;
    for (size_t i = 0; i < count; i++) raw[i] = (uint32_t)k->data[i];
done:
    if (img) opj_image_destroy(img);
    if (s) opj_stream_destroy(s);
    if (c) opj_destroy_codec(c);
    return st;
}
#endif

/* Decodes one compressed frame (its fragments joined: p, n) into rows*cols stored words. */
vm_status vm__dcm_codec_decode(const dcm_file *f, int64_t frame, const unsigned char *p,
                               size_t n, uint32_t *raw, vm_error *err) {
    switch (f->syntax) {
#ifdef VM_HAVE_DICOM_JPEG
    case DCM_JPEG: return jpeg_words(f, frame, p, n, raw, err);
#endif
#ifdef VM_HAVE_DICOM_JPEGLS
    case DCM_JPEGLS: return jpegls_words(f, frame, p, n, raw, err);
#endif
#ifdef VM_HAVE_DICOM_J2K
    case DCM_J2K: return j2k_words(f, frame, p, n, raw, err);
#endif
    default: (void)p, (void)n, (void)raw, (void)frame; return vm__dcm_codec_check(f, err);
    }
}
