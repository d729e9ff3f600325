/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom_parse.c — reads one DICOM file's data elements into a dcm_file: the file meta
 * group, the dataset in its transfer syntax, sequences and encapsulated pixel data. Follows
 * DICOM PS3.10 section 7 (preamble, meta group) and PS3.5 sections 7, 8.2, A.4, A.5. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <zlib.h>
#include "dicom_internal.h"

enum {
    PREAMBLE = 128,          /* PS3.10 7.1: 128 bytes, then "DICM" */
    MAX_DEPTH = 16,          /* sequences nested deeper are refused (real files use < 6) */
    DS_MAX_CHARS = 64,       /* a DS value is at most 16 bytes; allow generous padding */
    UNDEFINED = -1,          /* (int64) marker of an undefined length 0xFFFFFFFF */
    DEFLATE_MAX_RATIO = 1040 /* deflate cannot compress better than about 1032:1 */
};
#define UNDEFINED_LENGTH 0xFFFFFFFFu

/* The transfer syntaxes by UID (PS3.6 annex A). The first five are always decoded, the JPEG
 * families when their library was found at build time (io/dicom_codecs.c). */
static const struct {
    const char *uid, *name;
    dcm_syntax syntax;
} syntaxes[] = {
    {"1.2.840.10008.1.2", "Implicit VR Little Endian", DCM_IMPLICIT_LE},
    {"1.2.840.10008.1.2.1", "Explicit VR Little Endian", DCM_EXPLICIT_LE},
    {"1.2.840.10008.1.2.1.99", "Deflated Explicit VR Little Endian", DCM_DEFLATED_LE},
    {"1.2.840.10008.1.2.2", "Explicit VR Big Endian", DCM_EXPLICIT_BE},
    {"1.2.840.10008.1.2.5", "RLE Lossless", DCM_RLE},
    {"1.2.840.10008.1.2.4.50", "JPEG Baseline (Process 1)", DCM_JPEG},
    {"1.2.840.10008.1.2.4.51", "JPEG Extended (Process 2 & 4)", DCM_JPEG},
    {"1.2.840.10008.1.2.4.57", "JPEG Lossless, Non-Hierarchical (Process 14)",
     DCM_JPEG},
    {"1.2.840.10008.1.2.4.70", "JPEG Lossless, Non-Hierarchical, First-Order Prediction",
     DCM_JPEG},
    {"1.2.840.10008.1.2.4.80", "JPEG-LS Lossless", DCM_JPEGLS},
    {"1.2.840.10008.1.2.4.81", "JPEG-LS Lossy (Near-Lossless)", DCM_JPEGLS},
    {"1.2.840.10008.1.2.4.90", "JPEG 2000 Image Compression (Lossless Only)", DCM_J2K},
    {"1.2.840.10008.1.2.4.91", "JPEG 2000 Image Compression", DCM_J2K},
    {"1.2.840.10008.1.2.4.92", "JPEG 2000 Part 2 Multi-component (Lossless Only)",
     DCM_ENCAPSULATED},
    {"1.2.840.10008.1.2.4.93", "JPEG 2000 Part 2 Multi-component", DCM_ENCAPSULATED},
    {"1.2.840.10008.1.2.4.201", "High-Throughput JPEG 2000 (Lossless Only)", DCM_ENCAPSULATED},
    {"1.2.840.10008.1.2.4.202", "High-Throughput JPEG 2000 with RPCL (Lossless Only)",
     DCM_ENCAPSULATED},
    {"1.2.840.10008.1.2.4.203", "High-Throughput JPEG 2000", DCM_ENCAPSULATED},
};

/* The media storage SOP class of a DICOMDIR (PS3.4 annex F, PS3.6 annex A). */
static const char DICOMDIR_CLASS[] = "1.2.840.10008.1.3.10";

/* VRs whose explicit form has 2 reserved bytes and a 32-bit length (PS3.5 7.1.2). */
static const char *const LONG_VRS[] = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                       "SV", "UC", "UN", "UR", "UT", "UV"};
/* Every VR of PS3.5 table 6.2-1, to tell explicit from implicit VR at a dataset's start. */
static const char ALL_VRS[] = "AE AS AT CS DA DS DT FL FD IS LO LT OB OD OF OL OV OW PN SH SL "
                              "SQ SS ST SV TM UC UI UL UN UR US UT UV";

/* The name of a transfer syntax UID, NULL when unknown. */
const char *vm__dcm_syntax_name(const char *uid) {
    for (size_t i = 0; i < sizeof syntaxes / sizeof syntaxes[0]; i++)
        if (strcmp(uid, syntaxes[i].uid) == 0) return syntaxes[i].name;
    return NULL;
}

/* 1 when the two bytes are a VR of PS3.5 table 6.2-1. */
static int is_vr(const unsigned char *p) {
    if (!isupper(p[0]) || !isupper(p[1])) return 0;
    for (size_t i = 0; i + 2 < sizeof ALL_VRS; i += 3) /* "XX " entries, the last "XX\0" */
        if (ALL_VRS[i] == p[0] && ALL_VRS[i + 1] == p[1]) return 1;
    return 0;
}

/* 1 when an explicit VR has the 32-bit length form. */
static int is_long_vr(const char *vr) {
    for (size_t i = 0; i < sizeof LONG_VRS / sizeof LONG_VRS[0]; i++)
        if (strcmp(vr, LONG_VRS[i]) == 0) return 1;
    return 0;
}

/* A 16-bit value in the given byte order. */
static uint32_t get16(const unsigned char *p, int big) {
    return big ? (uint32_t)p[0] << 8 | p[1] : (uint32_t)p[1] << 8 | p[0];
}

/* A 32-bit value in the given byte order. */
static uint32_t get32(const unsigned char *p, int big) {
    return big ? (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3]
               : (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
}

/* The start of a dataset without meta group: its byte order and VR encoding, or -1 when the
 * bytes do not look like a group 0002 or 0008 element (PS3.5 7.1: elements ascend by tag, and
 * real datasets open with group 0008). */
static int bare_start(const unsigned char *p, size_t len, int *big, int *explicit_vr) {
    if (len < 8) return -1;
    uint32_t le = get16(p, 0), be = get16(p, 1);
    if ((le == 0x0008 || le == 0x0002) && is_vr(p + 4)) {
        *big = 0, *explicit_vr = 1;
        return 0;
    }
    if (be == 0x0008 && is_vr(p + 4)) {
        *big = 1, *explicit_vr = 1;
        return 0;
    }
    /* implicit VR little endian: a short first value of a low element number */
    if (le == 0x0008 && get16(p + 2, 0) < 0x1000 && get32(p + 4, 0) <= 1024) {
        *big = 0, *explicit_vr = 0;
        return 0;
    }
    return -1;
}

/* 1 when the first bytes of a file look like DICOM. */
int vm__dcm_sniff(const unsigned char *p, size_t len) {
    if (len >= PREAMBLE + 4 && memcmp(p + PREAMBLE, "DICM", 4) == 0) return 1;
    int big, ex;
    return bare_start(p, len, &big, &ex) == 0;
}

/* 1 when the file at path looks like DICOM from its first 132 bytes. */
int vm__dcm_sniff_path(const char *path) {
    /* regular files only: reading the start of a pipe would take it from the real reader */
    struct stat sb;
    if (stat(path, &sb) != 0 || !S_ISREG(sb.st_mode)) return 0;
    FILE *fp = fopen(path, "rb");
    if (!fp) return 0;
    unsigned char head[PREAMBLE + 4];
    size_t n = fread(head, 1, sizeof head, fp);
    fclose(fp);
    return vm__dcm_sniff(head, n);
}

/* A data element's header as read. */
typedef struct elem {
    uint32_t tag;
    char vr[3];
    size_t value;   /* offset of the value */
    int64_t length; /* bytes, or UNDEFINED */
} elem;

/* The state of a walk over a dataset. */
typedef struct walk {
    const char *path;
    const unsigned char *p;
    size_t len;
    int big, explicit_vr;
    dcm_file *f;
    int depth;
    uint32_t seq[MAX_DEPTH]; /* the sequences enclosing the current item */
    int64_t item[MAX_DEPTH]; /* and the item's index in each */
} walk;

/* VR of a tag in implicit VR files: SQ for the sequences the reader enters, else "UN". */
static const char *implicit_vr(uint32_t tag) {
    switch (tag) {
    case DCM_SHARED_GROUPS_SEQ: case DCM_PER_FRAME_GROUPS_SEQ: case DCM_PIXEL_MEASURES_SEQ:
    case DCM_PLANE_POSITION_SEQ: case DCM_PLANE_ORIENTATION_SEQ:
    case DCM_PIXEL_VALUE_TRANSFORM_SEQ: case DCM_DIRECTORY_RECORDS:
        return "SQ";
    default: return "UN";
    }
}

/* Reads the element header at *pos (PS3.5 7.1.1-7.1.3, items 7.5). */
static vm_status read_elem(walk *w, size_t *pos, size_t end, elem *e, vm_error *err) {
    const unsigned char *q = w->p + *pos;
    if (end - *pos < 8)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: file is truncated inside a data element "
                            "header at byte %zu", w->path, *pos);
    e->tag = get16(q, w->big) << 16 | get16(q + 2, w->big);
    uint32_t len32;
    size_t head = 8;
    if ((e->tag >> 16) == 0xFFFE) {
        strcpy(e->vr, "na");
        len32 = get32(q + 4, w->big);
    } else if (w->explicit_vr) {
        if (!isupper(q[4]) || !isupper(q[5]))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: element (%04X,%04X) at byte %zu has "
                                "no valid VR", w->path, e->tag >> 16, e->tag & 0xFFFF, *pos);
        e->vr[0] = (char)q[4], e->vr[1] = (char)q[5], e->vr[2] = 0;
        if (is_long_vr(e->vr)) {
            if (end - *pos < 12)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: file is truncated inside a data "
                                    "element header at byte %zu", w->path, *pos);
            len32 = get32(q + 8, w->big);
            head = 12;
        } else {
            len32 = get16(q + 6, w->big);
        }
    } else {
        strcpy(e->vr, implicit_vr(e->tag));
        len32 = get32(q + 4, w->big);
    }
    e->value = *pos + head;
    e->length = len32 == UNDEFINED_LENGTH ? UNDEFINED : (int64_t)len32;
    if (e->length != UNDEFINED && (uint64_t)e->length > end - e->value)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: element (%04X,%04X) at byte %zu says %lld "
                            "bytes but only %zu remain (truncated or lying length)", w->path,
                            e->tag >> 16, e->tag & 0xFFFF, *pos, (long long)e->length,
                            end - e->value);
    *pos = e->value;
    return VM_OK;
}

/* A string value, trailing and leading spaces and NULs removed, controls as '?'. */
static void take_string(const walk *w, const elem *e, char *out, size_t cap) {
    size_t a = e->value, b = e->value + (size_t)e->length;
    while (a < b && (w->p[a] == ' ' || w->p[a] == 0)) a++;
    while (b > a && (w->p[b - 1] == ' ' || w->p[b - 1] == 0)) b--;
    size_t n = b - a < cap - 1 ? b - a : cap - 1;
    for (size_t i = 0; i < n; i++) out[i] = isprint(w->p[a + i]) ? (char)w->p[a + i] : '?';
    out[n] = 0;
}

/* Decimal strings separated by '\' (DS, IS; PS3.5 6.2): up to max into out. Returns the
 * count, or -1 when one is not a finite number. */
static int64_t take_numbers(const walk *w, const elem *e, double *out, int64_t max) {
    const unsigned char *s = w->p + e->value, *end = s + e->length;
    int64_t n = 0;
    while (s < end && n < max) {
        const unsigned char *sep = memchr(s, '\\', (size_t)(end - s));
        const unsigned char *stop = sep ? sep : end;
        char buf[DS_MAX_CHARS + 1];
        size_t k = 0;
        for (const unsigned char *c = s; c < stop; c++) {
            if (*c == ' ' || *c == 0) continue;
            if (k == DS_MAX_CHARS) return -1;
            buf[k++] = (char)*c;
        }
        buf[k] = 0;
        if (k == 0 && !sep && n == 0) return 0; /* an empty value */
        char *tail;
        errno = 0;
        double x = strtod(buf, &tail);
        if (k == 0 || *tail || !isfinite(x)) return -1;
        out[n++] = x;
        s = sep ? sep + 1 : end;
    }
    return n;
}

/* An unsigned 16-bit value (US; PixelPaddingValue's US or SS bits); -1 when too short. */
static int64_t take_us(const walk *w, const elem *e) {
    return e->length < 2 ? -1 : (int64_t)get16(w->p + e->value, w->big);
}

/* Takes count numbers of a DS element into out, refusing other counts. */
static vm_status take_vector(const walk *w, const elem *e, const char *what, double *out,
                             int64_t count, vm_error *err) {
    if (take_numbers(w, e, out, count) != count)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: %s is not %lld numbers", w->path, what,
                            (long long)count);
    return VM_OK;
}

/* Makes room for frame k in the per-frame arrays (positions NaN until given). */
static vm_status frame_slot(walk *w, int64_t k, vm_error *err) {
    dcm_file *f = w->f;
    if (k < f->n_frame_positions) return VM_OK;
    size_t n = (size_t)k + 1;
    double *pos = realloc(f->frame_positions, n * 3 * sizeof *pos);
    if (pos) f->frame_positions = pos;
    double *rs = pos ? realloc(f->frame_rescale, n * 2 * sizeof *rs) : NULL;
    if (rs) f->frame_rescale = rs;
    if (!pos || !rs) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    for (size_t i = (size_t)f->n_frame_positions; i < n; i++) {
        pos[3 * i] = pos[3 * i + 1] = pos[3 * i + 2] = NAN;
        rs[2 * i] = rs[2 * i + 1] = NAN;
    }
    f->n_frame_positions = (int64_t)n;
    return VM_OK;
}

/* Values inside the functional groups: [shared or per-frame item k, macro, element]. */
static vm_status take_functional(walk *w, const elem *e, vm_error *err) {
    dcm_file *f = w->f;
    int per_frame = w->seq[0] == DCM_PER_FRAME_GROUPS_SEQ;
    int64_t k = w->item[0];
    uint32_t macro = w->seq[1];
    double x[6];
    vm_status st = VM_OK;
    if (macro == DCM_PIXEL_MEASURES_SEQ && e->tag == DCM_PIXEL_SPACING && !f->has_spacing) {
        st = take_vector(w, e, "PixelSpacing", f->spacing, 2, err);
        f->has_spacing = 1;
    } else if (macro == DCM_PLANE_ORIENTATION_SEQ && e->tag == DCM_IMAGE_ORIENTATION) {
        st = take_vector(w, e, "ImageOrientationPatient", x, 6, err);
        if (!st && !f->has_orientation) memcpy(f->orientation, x, sizeof f->orientation);
        else if (!st && memcmp(x, f->orientation, sizeof x) != 0)
            f->frame_orientation_differs = 1;
        f->has_orientation = 1;
    } else if (macro == DCM_PLANE_POSITION_SEQ && e->tag == DCM_IMAGE_POSITION) {
        if (!per_frame) return VM_OK;
        st = frame_slot(w, k, err);
        if (!st) st = take_vector(w, e, "ImagePositionPatient", f->frame_positions + 3 * k,
                                  3, err);
    } else if (macro == DCM_PIXEL_VALUE_TRANSFORM_SEQ &&
               (e->tag == DCM_RESCALE_SLOPE || e->tag == DCM_RESCALE_INTERCEPT)) {
        int slope = e->tag == DCM_RESCALE_SLOPE;
        st = take_vector(w, e, slope ? "RescaleSlope" : "RescaleIntercept", x, 1, err);
        if (st) return st;
        if (!per_frame) {
            *(slope ? &f->slope : &f->intercept) = x[0];
        } else {
            st = frame_slot(w, k, err);
            if (!st) f->frame_rescale[2 * k + (slope ? 0 : 1)] = x[0];
        }
    }
    return st;
}

/* A US attribute into *out, refusing a value shorter than 2 bytes. */
static vm_status take_count(const walk *w, const elem *e, const char *what, int64_t *out,
                            vm_error *err) {
    int64_t x = take_us(w, e);
    if (x < 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: %s has no value", w->path, what);
    *out = x;
    return VM_OK;
}

/* Grid frame offsets of RT dose (PS3.3 C.8.8.3.2): one per frame, at most one per 2 bytes. */
static vm_status take_offsets(walk *w, const elem *e, vm_error *err) {
    dcm_file *f = w->f;
    size_t most = (size_t)e->length / 2 + 1;
    free(f->grid_offsets);
    f->grid_offsets = malloc(most * sizeof(double));
    if (!f->grid_offsets) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    f->n_offsets = take_numbers(w, e, f->grid_offsets, (int64_t)most);
    if (f->n_offsets < 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: GridFrameOffsetVector is not a list of "
                            "numbers", w->path);
    return VM_OK;
}

/* Keeps an offset table of n entries of `bytes` (4 or 8) little-endian bytes from p. */
static vm_status keep_offsets(walk *w, const unsigned char *p, size_t n, size_t bytes,
                              vm_error *err) {
    dcm_file *f = w->f;
    free(f->frame_offsets);
    f->frame_offsets = malloc((n ? n : 1) * sizeof *f->frame_offsets);
    f->n_frame_offsets = 0;
    if (!f->frame_offsets) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    for (size_t k = 0; k < n; k++, p += bytes)
        f->frame_offsets[k] = bytes == 4 ? get32(p, 0)
                                         : (uint64_t)get32(p + 4, 0) << 32 | get32(p, 0);
    f->n_frame_offsets = n;
    return VM_OK;
}

/* The Extended Offset Table (7FE0,0001; PS3.5 A.4, PS3.3 C.7.6.3.1.8): 64-bit offsets of
 * each frame's first fragment item, for when the basic offset table is empty. */
static vm_status take_extended_offsets(walk *w, const elem *e, vm_error *err) {
    if (e->length % 8 != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: the extended offset table has a length "
                            "that is not a multiple of 8", w->path);
    w->f->extended_offsets = 1;
    return keep_offsets(w, w->p + e->value, (size_t)e->length / 8, 8, err);
}

/* Values of the top-level dataset. */
static vm_status take_top(walk *w, const elem *e, vm_error *err) {
    dcm_file *f = w->f;
    double x[1];
    switch (e->tag) {
    case DCM_TRANSFER_SYNTAX: take_string(w, e, f->syntax_uid, sizeof f->syntax_uid); break;
    case DCM_MEDIA_SOP_CLASS: {
        char cls[65];
        take_string(w, e, cls, sizeof cls);
        if (strcmp(cls, DICOMDIR_CLASS) == 0) f->is_dicomdir = 1;
        break;
    }
    case DCM_MODALITY: take_string(w, e, f->modality, sizeof f->modality); break;
    case DCM_SERIES_DESCRIPTION:
        take_string(w, e, f->description, sizeof f->description);
        break;
    case DCM_SERIES_UID: take_string(w, e, f->series_uid, sizeof f->series_uid); break;
    case DCM_IMAGE_POSITION:
        f->has_position = 1;
        return take_vector(w, e, "ImagePositionPatient", f->position, 3, err);
    case DCM_IMAGE_ORIENTATION:
        f->has_orientation = 1;
        return take_vector(w, e, "ImageOrientationPatient", f->orientation, 6, err);
    case DCM_PIXEL_SPACING:
        f->has_spacing = 1;
        return take_vector(w, e, "PixelSpacing", f->spacing, 2, err);
    case DCM_SAMPLES_PER_PIXEL: return take_count(w, e, "SamplesPerPixel", &f->samples, err);
    case DCM_ROWS: return take_count(w, e, "Rows", &f->rows, err);
    case DCM_COLUMNS: return take_count(w, e, "Columns", &f->cols, err);
    case DCM_BITS_ALLOCATED: return take_count(w, e, "BitsAllocated", &f->bits_allocated, err);
    case DCM_BITS_STORED: return take_count(w, e, "BitsStored", &f->bits_stored, err);
    case DCM_HIGH_BIT: return take_count(w, e, "HighBit", &f->high_bit, err);
    case DCM_PIXEL_REPRESENTATION:
        return take_count(w, e, "PixelRepresentation", &f->pixel_rep, err);
    case DCM_PIXEL_PADDING_VALUE: {
        int64_t pad = take_us(w, e);
        f->has_padding = pad >= 0;
        f->padding_raw = (uint32_t)(pad >= 0 ? pad : 0);
        break;
    }
    case DCM_NUMBER_OF_FRAMES:
        if (take_numbers(w, e, x, 1) != 1 || x[0] < 1 || x[0] > 2147483647.0 ||
            x[0] != floor(x[0]))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: NumberOfFrames is not a positive "
                                "integer", w->path);
        f->frames = (int64_t)x[0];
        break;
    case DCM_RESCALE_SLOPE: return take_vector(w, e, "RescaleSlope", &f->slope, 1, err);
    case DCM_RESCALE_INTERCEPT:
        return take_vector(w, e, "RescaleIntercept", &f->intercept, 1, err);
    case DCM_DOSE_GRID_SCALING:
        return take_vector(w, e, "DoseGridScaling", &f->dose_scaling, 1, err);
    case DCM_GRID_FRAME_OFFSETS: return take_offsets(w, e, err);
    case DCM_EXTENDED_OFFSET_TABLE: return take_extended_offsets(w, e, err);
    default: break;
    }
    return VM_OK;
}

/* Takes the value of a leaf element where the reader wants it. */
static vm_status take(walk *w, const elem *e, vm_error *err) {
    if (e->length == UNDEFINED || e->length == 0) return VM_OK; /* empty: absent */
    if (w->depth == 0) return take_top(w, e, err);
    if (w->depth == 2 &&
        (w->seq[0] == DCM_SHARED_GROUPS_SEQ || w->seq[0] == DCM_PER_FRAME_GROUPS_SEQ))
        return take_functional(w, e, err);
    return VM_OK;
}

/* 1 when a defined-length sequence holds values the reader uses (others are skipped whole:
 * private sequences need not be well formed). */
static int wanted_sequence(const walk *w, uint32_t tag) {
    if (w->depth == 0) return tag == DCM_SHARED_GROUPS_SEQ || tag == DCM_PER_FRAME_GROUPS_SEQ;
    if (w->depth == 1)
        return tag == DCM_PIXEL_MEASURES_SEQ || tag == DCM_PLANE_POSITION_SEQ ||
               tag == DCM_PLANE_ORIENTATION_SEQ || tag == DCM_PIXEL_VALUE_TRANSFORM_SEQ;
    return 0;
}

static vm_status walk_items(walk *w, size_t *pos, size_t end, const elem *seq, vm_error *err);

/* Walks data elements from *pos up to end; in an undefined-length item (in_item) up to its
 * Item Delimitation. Stops after the top-level pixel data. */
static vm_status walk_elements(walk *w, size_t *pos, size_t end, int in_item, vm_error *err) {
    while (*pos < end) {
        size_t at = *pos;
        elem e;
        vm_status st = read_elem(w, pos, end, &e, err);
        if (st) return st;
        if (e.tag == DCM_ITEM_END && in_item) return VM_OK;
        if ((e.tag >> 16) == 0xFFFE)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: unexpected item tag (FFFE,%04X) at "
                                "byte %zu", w->path, e.tag & 0xFFFF, at);
        if (e.tag == DCM_DIRECTORY_RECORDS && w->depth == 0) w->f->is_dicomdir = 1;
        if (e.tag == DCM_PIXEL_DATA && w->depth == 0) {
            w->f->has_pixels = 1;
            if (e.length != UNDEFINED) {
                w->f->pixel_offset = e.value;
                w->f->pixel_length = (size_t)e.length;
                return VM_OK;
            }
            w->f->encapsulated = 1;
            return walk_items(w, pos, end, &e, err);
        }
        int seq = strcmp(e.vr, "SQ") == 0 || e.length == UNDEFINED;
        if (seq && (e.length == UNDEFINED || wanted_sequence(w, e.tag))) {
            size_t seq_end = e.length == UNDEFINED ? end : e.value + (size_t)e.length;
            walk inner = *w;
            if (strcmp(e.vr, "UN") == 0) inner.explicit_vr = 0, inner.big = 0; /* PS3.5 6.2.2 */
            st = walk_items(&inner, pos, seq_end, &e, err);
            if (st) return st;
            if (e.length != UNDEFINED) *pos = seq_end;
            continue;
        }
        st = take(w, &e, err);
        if (st) return st;
        *pos = e.value + (size_t)e.length;
    }
    if (in_item)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: an item has no end (truncated file)",
                            w->path);
    return VM_OK;
}

/* Records one fragment of encapsulated pixel data (PS3.5 A.4); the first item is the Basic
 * Offset Table (32-bit little-endian offsets of each frame's first fragment item, counted
 * from the first fragment item), kept for the frames' fragments when it is not empty. */
static vm_status add_fragment(walk *w, int64_t index, const elem *it, vm_error *err) {
    dcm_file *f = w->f;
    if (index == 0) {
        if (it->length == UNDEFINED || it->length % 4 != 0)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: the basic offset table of the pixel "
                                "data has a length that is not a multiple of 4", w->path);
        f->first_item = it->value + (size_t)it->length;
        if (it->length == 0) return VM_OK; /* empty: the extended table, if any, stands */
        f->extended_offsets = 0;
        return keep_offsets(w, w->p + it->value, (size_t)it->length / 4, 4, err);
    }
    if (it->length == UNDEFINED)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: a pixel data fragment has an undefined "
                            "length", w->path);
    dcm_fragment *fr = realloc(f->fragments, (f->n_fragments + 1) * sizeof *fr);
    if (!fr) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    f->fragments = fr;
    fr[f->n_fragments].offset = it->value;
    fr[f->n_fragments].length = (size_t)it->length;
    f->n_fragments++;
    return VM_OK;
}

/* Walks the items of a sequence (or the fragments of encapsulated pixel data) from *pos up to
 * end, or up to its Sequence Delimitation when its length is undefined (PS3.5 7.5). */
static vm_status walk_items(walk *w, size_t *pos, size_t end, const elem *seq, vm_error *err) {
    int pixels = seq->tag == DCM_PIXEL_DATA && w->depth == 0;
    if (w->depth + 1 >= MAX_DEPTH)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: sequences nested deeper than %d",
                            w->path, MAX_DEPTH);
    for (int64_t index = 0; *pos < end; index++) {
        size_t at = *pos;
        elem it;
        vm_status st = read_elem(w, pos, end, &it, err);
        if (st) return st;
        if (it.tag == DCM_SEQUENCE_END && seq->length == UNDEFINED) return VM_OK;
        if (it.tag != DCM_ITEM)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: expected an item in sequence "
                                "(%04X,%04X) at byte %zu", w->path, seq->tag >> 16,
                                seq->tag & 0xFFFF, at);
        if (pixels) {
            st = add_fragment(w, index, &it, err);
            if (st) return st;
            *pos = it.value + (size_t)it.length;
            continue;
        }
        w->seq[w->depth] = seq->tag;
        w->item[w->depth] = index;
        w->depth++;
        size_t item_end = it.length == UNDEFINED ? end : it.value + (size_t)it.length;
        st = walk_elements(w, pos, item_end, it.length == UNDEFINED, err);
        w->depth--;
        if (st) return st;
        if (it.length != UNDEFINED) *pos = item_end;
    }
    if (seq->length == UNDEFINED)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: sequence (%04X,%04X) has no end "
                            "(truncated file)", w->path, seq->tag >> 16, seq->tag & 0xFFFF);
    return VM_OK;
}

/* Inflates the deflated dataset (PS3.5 A.5: raw deflate, no zlib header) into b->inflated,
 * no larger than the memory limit nor than deflate's best ratio allows. */
static vm_status inflate_dataset(const char *path, const unsigned char *src, size_t n,
                                 dcm_bytes *b, vm_error *err) {
    size_t limit = vm__memory_limit(), got = 0, in_done = 0, cap = 1u << 20;
    if (n < (SIZE_MAX - 4096) / DEFLATE_MAX_RATIO && n * DEFLATE_MAX_RATIO + 4096 < limit)
        limit = n * DEFLATE_MAX_RATIO + 4096;
    if (cap > limit) cap = limit;
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    b->inflated = malloc(cap + 1);
    if (!b->inflated || inflateInit2(&zs, -15) != Z_OK)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    const char *bad = NULL;
    for (;;) {
        if (got == cap) {
            size_t ncap = cap > limit / 2 ? limit : cap * 2;
            unsigned char *nb = ncap > cap ? realloc(b->inflated, ncap + 1) : NULL;
            if (!nb) {
                bad = "deflated dataset is larger than allowed";
                break;
            }
            b->inflated = nb, cap = ncap;
        }
        if (zs.avail_in == 0) {
            size_t c = n - in_done > (1u << 30) ? (1u << 30) : n - in_done;
            zs.next_in = (unsigned char *)src + in_done, zs.avail_in = (uInt)c;
            in_done += c;
        }
        size_t room = cap - got > (1u << 30) ? (1u << 30) : cap - got;
        zs.next_out = b->inflated + got, zs.avail_out = (uInt)room;
        int r = inflate(&zs, Z_NO_FLUSH);
        got += room - zs.avail_out;
        if (r == Z_STREAM_END) break;
        if (r != Z_OK && r != Z_BUF_ERROR) bad = "deflated dataset is corrupt";
        else if (zs.avail_in == 0 && in_done == n && zs.avail_out != 0)
            bad = "deflated dataset is truncated";
        if (bad) break;
    }
    inflateEnd(&zs);
    if (bad) return vm_error_set(err, VM_ERR_FORMAT, "%s: %s", path, bad);
    b->inflated[got] = 0;
    b->p = b->inflated;
    b->len = got;
    return VM_OK;
}

/* Reads the file meta group (PS3.10 7.1; always explicit VR little endian) from *pos. */
static vm_status read_meta(walk *w, size_t *pos, vm_error *err) {
    walk m = *w;
    m.big = 0, m.explicit_vr = 1;
    while (m.len - *pos >= 8 && get16(m.p + *pos, 0) == 0x0002) {
        elem e;
        vm_status st = read_elem(&m, pos, m.len, &e, err);
        if (st) return st;
        if (e.length == UNDEFINED)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: file meta element (0002,%04X) has an "
                                "undefined length", w->path, e.tag & 0xFFFF);
        st = take_top(&m, &e, err);
        if (st) return st;
        *pos = e.value + (size_t)e.length;
    }
    return VM_OK;
}

/* The transfer syntax of f->syntax_uid; an empty UID keeps what the bytes showed. */
static void set_syntax(dcm_file *f, walk *w) {
    f->syntax = w->explicit_vr ? (w->big ? DCM_EXPLICIT_BE : DCM_EXPLICIT_LE) : DCM_IMPLICIT_LE;
    if (!f->syntax_uid[0]) return;
    f->syntax = DCM_ENCAPSULATED; /* unknown UIDs: explicit VR little endian, pixels refused */
    for (size_t i = 0; i < sizeof syntaxes / sizeof syntaxes[0]; i++)
        if (strcmp(f->syntax_uid, syntaxes[i].uid) == 0) f->syntax = syntaxes[i].syntax;
    w->explicit_vr = f->syntax != DCM_IMPLICIT_LE;
    w->big = f->syntax == DCM_EXPLICIT_BE;
}

/* Where the dataset starts and how it is encoded: after the preamble and meta group, or at
 * byte 0 of a bare dataset (whose bytes tell the encoding). */
static vm_status find_dataset(walk *w, dcm_file *f, size_t *pos, vm_error *err) {
    *pos = 0;
    if (w->len >= PREAMBLE + 4 && memcmp(w->p + PREAMBLE, "DICM", 4) == 0) *pos = PREAMBLE + 4;
    else if (bare_start(w->p, w->len, &w->big, &w->explicit_vr) != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: not a DICOM file (no \"DICM\" at byte 128 "
                            "and no data element at the start)", w->path);
    vm_status st = w->big ? VM_OK : read_meta(w, pos, err);
    if (st) return st;
    /* the dataset's own first bytes decide when the meta group names no syntax */
    if (!f->syntax_uid[0] && *pos > 0 &&
        bare_start(w->p + *pos, w->len - *pos, &w->big, &w->explicit_vr) != 0)
        w->big = 0, w->explicit_vr = 0;
    set_syntax(f, w);
    /* some writers announce explicit VR and write implicit VR: believe the bytes */
    if (f->syntax != DCM_DEFLATED_LE && w->explicit_vr && !w->big && w->len - *pos >= 8 &&
        !is_vr(w->p + *pos + 4) &&
        get16(w->p + *pos, 0) != 0xFFFE)
        w->explicit_vr = 0;
    return VM_OK;
}

/* Parses one file: meta group, dataset (inflated when deflated), up to the pixel data. */
vm_status vm__dcm_parse(const char *path, dcm_file *f, dcm_bytes *keep, vm_error *err) {
    memset(f, 0, sizeof *f);
    f->frames = f->samples = 1;
    f->slope = f->dose_scaling = 1.0;
    f->high_bit = -1; /* absent until read */
    f->path = malloc(strlen(path) + 1);
    if (!f->path) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    strcpy(f->path, path);
    dcm_bytes b;
    memset(&b, 0, sizeof b);
    vm_status st = vm__map_file(path, (size_t)-1, &b.map, err);
    if (st) return st;
    b.p = b.map.p, b.len = b.map.len;
    walk w = {path, b.p, b.len, 0, 1, f, 0, {0}, {0}};
    size_t pos;
    st = find_dataset(&w, f, &pos, err);
    if (!st && f->syntax == DCM_DEFLATED_LE) {
        st = inflate_dataset(path, b.p + pos, b.len - pos, &b, err);
        w.p = b.p, w.len = b.len, pos = 0;
    }
    b.big = w.big;
    if (!st) st = walk_elements(&w, &pos, w.len, 0, err);
    if (st || !keep)
        vm__dcm_bytes_free(&b);
    else
        *keep = b;
    return st;
}

/* Releases the bytes a parse kept. */
void vm__dcm_bytes_free(dcm_bytes *b) {
    vm__map_free(&b->map);
    free(b->inflated);
    memset(b, 0, sizeof *b);
}

/* Frees what a parsed file owns. */
void vm__dcm_file_free(dcm_file *f) {
    free(f->path);
    free(f->frame_positions);
    free(f->frame_rescale);
    free(f->grid_offsets);
    free(f->fragments);
    free(f->frame_offsets);
    memset(f, 0, sizeof *f);
}
