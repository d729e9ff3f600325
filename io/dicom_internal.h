/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom_internal.h — private types of the DICOM reader (io/dicom*.c): one parsed file,
 * its bytes, the transfer syntaxes and the tags used. Follows DICOM PS3.5 (encoding), PS3.6
 * (the tags and their VRs) and PS3.3 (image plane, image pixel, multi-frame, RT dose). */
#ifndef VM_DICOM_INTERNAL_H
#define VM_DICOM_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include "io_util.h"
#include "volmesh/dicom.h"

#define DCM_TAG(g, e) (((uint32_t)(g) << 16) | (uint32_t)(e))

/* The tags the reader uses (PS3.6 chapter 6 and 7), as (group << 16 | element). */
#define DCM_MEDIA_SOP_CLASS            DCM_TAG(0x0002, 0x0002)
#define DCM_TRANSFER_SYNTAX            DCM_TAG(0x0002, 0x0010)
#define DCM_DIRECTORY_RECORDS          DCM_TAG(0x0004, 0x1220)
#define DCM_MODALITY                   DCM_TAG(0x0008, 0x0060)
#define DCM_SERIES_DESCRIPTION         DCM_TAG(0x0008, 0x103E)
#define DCM_SERIES_UID                 DCM_TAG(0x0020, 0x000E)
#define DCM_IMAGE_POSITION             DCM_TAG(0x0020, 0x0032)
#define DCM_IMAGE_ORIENTATION          DCM_TAG(0x0020, 0x0037)
#define DCM_PLANE_POSITION_SEQ         DCM_TAG(0x0020, 0x9113)
#define DCM_PLANE_ORIENTATION_SEQ      DCM_TAG(0x0020, 0x9116)
#define DCM_SAMPLES_PER_PIXEL          DCM_TAG(0x0028, 0x0002)
#define DCM_NUMBER_OF_FRAMES           DCM_TAG(0x0028, 0x0008)
#define DCM_ROWS                       DCM_TAG(0x0028, 0x0010)
#define DCM_COLUMNS                    DCM_TAG(0x0028, 0x0011)
#define DCM_PIXEL_SPACING              DCM_TAG(0x0028, 0x0030)
#define DCM_BITS_ALLOCATED             DCM_TAG(0x0028, 0x0100)
#define DCM_BITS_STORED                DCM_TAG(0x0028, 0x0101)
#define DCM_HIGH_BIT                   DCM_TAG(0x0028, 0x0102)
#define DCM_PIXEL_REPRESENTATION       DCM_TAG(0x0028, 0x0103)
#define DCM_PIXEL_PADDING_VALUE        DCM_TAG(0x0028, 0x0120)
#define DCM_RESCALE_INTERCEPT          DCM_TAG(0x0028, 0x1052)
#define DCM_RESCALE_SLOPE              DCM_TAG(0x0028, 0x1053)
#define DCM_PIXEL_MEASURES_SEQ         DCM_TAG(0x0028, 0x9110)
#define DCM_PIXEL_VALUE_TRANSFORM_SEQ  DCM_TAG(0x0028, 0x9145)
#define DCM_GRID_FRAME_OFFSETS         DCM_TAG(0x3004, 0x000C)
#define DCM_DOSE_GRID_SCALING          DCM_TAG(0x3004, 0x000E)
#define DCM_SHARED_GROUPS_SEQ          DCM_TAG(0x5200, 0x9229)
#define DCM_PER_FRAME_GROUPS_SEQ       DCM_TAG(0x5200, 0x9230)
#define DCM_EXTENDED_OFFSET_TABLE      DCM_TAG(0x7FE0, 0x0001)
#define DCM_PIXEL_DATA                 DCM_TAG(0x7FE0, 0x0010)
#define DCM_ITEM                       DCM_TAG(0xFFFE, 0xE000)
#define DCM_ITEM_END                   DCM_TAG(0xFFFE, 0xE00D)
#define DCM_SEQUENCE_END               DCM_TAG(0xFFFE, 0xE0DD)

/* Transfer syntaxes (PS3.5 section 10 and annex A). */
typedef enum dcm_syntax {
    DCM_IMPLICIT_LE,
    DCM_EXPLICIT_LE,
    DCM_EXPLICIT_BE,
    DCM_DEFLATED_LE,
    DCM_RLE,
    DCM_JPEG,         /* JPEG baseline, extended and lossless (PS3.5 A.4.1), libjpeg-turbo */
    DCM_JPEGLS,       /* JPEG-LS lossless and near-lossless (A.4.3), CharLS */
    DCM_J2K,          /* JPEG 2000 part 1, lossless and lossy (A.4.4), OpenJPEG */
    DCM_ENCAPSULATED  /* any other encapsulated syntax: refused when pixels are read */
} dcm_syntax;

/* Where one encapsulated fragment lies in the dataset bytes. */
typedef struct dcm_fragment {
    size_t offset, length;
} dcm_fragment;

/* The attributes of one file that the reader uses. */
typedef struct dcm_file {
    char *path;                 /* owned */
    dcm_syntax syntax;
    char syntax_uid[65];
    int is_dicomdir;            /* a media directory (DirectoryRecordSequence or its class) */
    char series_uid[65], description[65], modality[17];
    int64_t rows, cols, frames, samples, bits_allocated, bits_stored, high_bit, pixel_rep;
    int has_padding;
    uint32_t padding_raw;       /* PixelPaddingValue's 16 bits, read per pixel_rep */
    double slope, intercept, dose_scaling;
    int has_position, has_orientation, has_spacing;
    double position[3], orientation[6], spacing[2]; /* spacing: (row, column) as in the file */
    int64_t n_frame_positions;  /* enhanced: per-frame PlanePositionSequence */
    double *frame_positions;    /* 3 per frame (owned); NaN when a frame has none */
    double *frame_rescale;      /* 2 per frame (slope, intercept; owned) or NULL */
    int frame_orientation_differs; /* a per-frame orientation that is not the shared one */
    int64_t n_offsets;          /* RT dose GridFrameOffsetVector */
    double *grid_offsets;       /* owned */
    int has_pixels, encapsulated;
    size_t pixel_offset, pixel_length; /* native pixel data in the dataset bytes */
    dcm_fragment *fragments;    /* encapsulated: every fragment after the offset table */
    size_t n_fragments;
    uint64_t *frame_offsets;    /* encapsulated: the basic offset table, or the extended one
                                 * when the basic is empty (owned); maybe none */
    size_t n_frame_offsets;
    int extended_offsets;       /* frame_offsets came from the ExtendedOffsetTable */
    size_t first_item;          /* where the first fragment item's tag lies in the bytes */
} dcm_file;

/* The bytes a parse read from: the file's mapping, or the inflated dataset of a deflated
 * file. Offsets in dcm_file are into p. */
typedef struct dcm_bytes {
    vm__map map;
    unsigned char *inflated; /* owned, deflated syntax only */
    const unsigned char *p;
    size_t len;
    int big; /* the dataset's byte order */
} dcm_bytes;

/* 1 when the first bytes of a file (len of them, at least 132 for a preamble) look like
 * DICOM: "DICM" at 128, or a bare dataset starting with a plausible group 0002 or 0008
 * element in either byte order. */
int vm__dcm_sniff(const unsigned char *p, size_t len);

/* 1 when the file at path is a regular file and DICOM by vm__dcm_sniff (reads its first
 * bytes only; pipes and devices are left alone for the other readers). */
int vm__dcm_sniff_path(const char *path);

/* Parses the file at path into f (zeroed first; f->path is a copy of path). keep NULL: the
 * bytes are released (a header read); else [out] *keep holds them for the pixel decoder,
 * release with vm__dcm_bytes_free. Refuses malformed, truncated or lying files with
 * "PATH: problem". */
vm_status vm__dcm_parse(const char *path, dcm_file *f, dcm_bytes *keep, vm_error *err);
void vm__dcm_bytes_free(dcm_bytes *b);
void vm__dcm_file_free(dcm_file *f);

/* Name of a transfer syntax UID ("JPEG Baseline (Process 1)", ...), or NULL when unknown. */
const char *vm__dcm_syntax_name(const char *uid);

/* Checks that frames of f can be decoded (sample layout, sizes, syntax) with a message
 * naming f->path; fills in an absent BitsStored and HighBit. */
vm_status vm__dcm_check_pixels(dcm_file *f, vm_error *err);

/* Decodes frame `frame` of f (bytes b from vm__dcm_parse with keep) into rows*cols floats:
 * stored values masked to BitsStored, sign-extended, rescaled (per-frame rescale when
 * present) and dose-scaled; PixelPaddingValue voxels become NaN for the caller to fill. */
vm_status vm__dcm_decode_frame(const dcm_file *f, const dcm_bytes *b, int64_t frame,
                               float *dst, vm_error *err);

/* ---- Compressed frames (io/dicom_codecs.c) ---- */

/* VM_OK when this build decodes f's compressed syntax (JPEG, JPEG-LS, JPEG 2000); else
 * VM_ERR_UNSUPPORTED with one line naming the syntax (UID and name) and the Debian package
 * that enables its decoder. */
vm_status vm__dcm_codec_check(const dcm_file *f, vm_error *err);

/* Decodes one compressed frame (the codestream p, n: the frame's fragments joined) into
 * rows*cols stored words [out] raw; a corrupt or truncated codestream, or one whose size,
 * components or precision disagree with the header, is refused naming f->path. */
vm_status vm__dcm_codec_decode(const dcm_file *f, int64_t frame, const unsigned char *p,
                               size_t n, uint32_t *raw, vm_error *err);

/* The stored sample type of f (uint8 .. int32 from BitsAllocated and PixelRepresentation). */
vm_scalar_type vm__dcm_stored_type(const dcm_file *f);

/* ---- Series (io/dicom_series.c) ---- */

/* The files found under a path, headers parsed. */
typedef struct dcm_set {
    dcm_file *files;
    size_t n;
} dcm_set;

/* One series: its files (indices into a dcm_set) and slice count. */
typedef struct dcm_series {
    const char *uid; /* the first file's */
    size_t *members; /* owned */
    size_t n;
    int64_t slices;
} dcm_series;

/* One slice of a series: a frame of a file and its position. */
typedef struct dcm_slice {
    size_t file;
    int64_t frame;
    double pos[3];
    double d; /* position along the slice normal */
} dcm_slice;

/* Finds and parses (headers only) the DICOM images under path: a file, a folder searched
 * recursively (files that are not DICOM, and DICOM files without pixel data, are skipped), or
 * a DICOMDIR (its folder). [out] set, free with vm__dcm_set_free. */
vm_status vm__dcm_scan(const char *path, dcm_set *set, vm_error *err);
void vm__dcm_set_free(dcm_set *set);

/* Groups set by SeriesInstanceUID, most slices first (ties by UID). [out] *list, *count,
 * free with vm__dcm_series_free. */
vm_status vm__dcm_group(const char *path, const dcm_set *set, dcm_series **list,
                        size_t *count, vm_error *err);
void vm__dcm_series_free(dcm_series *list, size_t count);

/* The series that choice names (NULL: the first; a decimal 1-based index; a UID). */
vm_status vm__dcm_choose(const char *path, const dcm_series *list, size_t count,
                         const char *choice, size_t *which, vm_error *err);

/* The geometry of series s: checks its files agree and its slices form an even, untilted
 * stack; [out] v's header (dims, type, spacing, origin, direction, format; data NULL) and
 * *slices (nz of them, sorted along the normal; free). */
vm_status vm__dcm_geometry(const char *path, dcm_set *set, const dcm_series *s, vm_volume *v,
                           dcm_slice **slices, vm_error *err);

/* The reader behind vm_volume_read (path: file, folder or DICOMDIR; series rq->series). */
vm_status vm__read_dicom(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);

#endif
