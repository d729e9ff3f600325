/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/dicom.h — DICOM series (CT, MR, RT dose, enhanced multi-frame) read as volumes.
 *
 * Files are recognised by content (128-byte preamble + "DICM", or a bare dataset starting
 * with a group 0008 element), never by name. A path is a single file, a folder (searched
 * recursively; files that are not DICOM images are skipped), or a DICOMDIR (its folder is
 * read). Files are grouped by SeriesInstanceUID. Geometry comes from ImagePositionPatient and
 * ImageOrientationPatient only, in the DICOM patient frame (LPS, mm): slices are sorted along
 * the normal of the orientation, the slice spacing is the distance between positions (uneven
 * gaps beyond 1 % and gantry tilt are refused). Values are the modality values: stored values
 * masked to BitsStored (sign-extended when PixelRepresentation is 1), times RescaleSlope plus
 * RescaleIntercept (and times DoseGridScaling for RT dose); PixelPaddingValue voxels take the
 * minimum of the other values. Transfer syntaxes: implicit VR little endian, explicit VR
 * little and big endian, deflated explicit VR little endian, RLE lossless; JPEG, JPEG-LS and
 * JPEG 2000 are refused by name. Details in docs/FORMATS.md. */
#ifndef VOLMESH_DICOM_H
#define VOLMESH_DICOM_H

#include <stddef.h>
#include <stdint.h>
#include "error.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One series found under a path. Strings are NUL-terminated, trailing padding removed, empty
 * when the files do not say. */
typedef struct vm_dicom_series_info {
    char uid[65];          /* SeriesInstanceUID (0020,000E); at most 64 characters */
    char description[65];  /* SeriesDescription (0008,103E), cut to 64 characters */
    char modality[17];     /* Modality (0008,0060): "CT", "MR", "RTDOSE", ... */
    int64_t files;         /* files of the series */
    int64_t slices;        /* one per single-frame file, NumberOfFrames per multi-frame */
    int64_t dims[3];       /* Columns, Rows, slices (of the first file; a series whose files
                              disagree is listed but refused when read) */
} vm_dicom_series_info;

/* Lists the series of the DICOM images under path (a file, a folder or a DICOMDIR), most
 * slices first (ties by UID), so that index 1 is the series vm_volume_read chooses.
 * [out] *list (free with vm_dicom_series_free), *count >= 1 on success. A folder with no
 * DICOM image is VM_ERR_FORMAT "PATH: no DICOM images found". Only headers are read. */
vm_status vm_dicom_list_series(const char *path, vm_dicom_series_info **list, size_t *count,
                               vm_error *err);

/* Frees a list from vm_dicom_list_series (NULL allowed). */
void vm_dicom_series_free(vm_dicom_series_info *list);

/* Reads one series under path as a volume. series: NULL for the default (the series with the
 * most slices, index 1 of vm_dicom_list_series), a SeriesInstanceUID, or a 1-based index
 * written in decimal ("2"). [out] v (format "dicom", type the stored sample type), free with
 * vm_volume_free. An unknown series is VM_ERR_ARG naming the choice. */
vm_status vm_volume_read_dicom(const char *path, const char *series, vm_volume *v,
                               vm_error *err);

/* The same for a header-only read (series chosen as above): [out] v has dims, type and
 * geometry, data NULL; no pixel is decoded. */
vm_status vm_volume_read_dicom_info(const char *path, const char *series, vm_volume *v,
                                    vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
