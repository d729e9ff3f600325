/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom_series.c — DICOM files to series and series to a volume's geometry: the folder
 * search, grouping by SeriesInstanceUID, slices sorted along the normal of the image plane.
 * Follows DICOM PS3.3 C.7.6.2 (image plane), C.7.6.16 (functional groups), C.8.8.3 (dose). */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "dicom_internal.h"

enum { MAX_FOLDER_DEPTH = 32 }; /* deeper folders (or symbolic link loops) are not searched */

/* Relative tolerances: a gap may differ from the mean by 1 % (the brief of issue 29); files of
 * one series must agree on orientation and pixel spacing to 1e-4 (DS values carry 16 chars). */
#define GAP_TOLERANCE 0.01
#define TILT_TOLERANCE 0.01
#define AGREE_TOLERANCE 1e-4
#define DEG_PER_RAD 57.29577951308232

/* Appends a parsed file to set. */
static vm_status set_add(dcm_set *set, size_t *cap, dcm_file *f, vm_error *err) {
    vm_status st = vm__grow((void **)&set->files, cap, set->n + 1, sizeof *f, err);
    if (st) {
        vm__dcm_file_free(f);
        return st;
    }
    set->files[set->n++] = *f;
    return VM_OK;
}

/* Orders names by strcmp. */
static int cmp_names(const void *a, const void *b) {
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* The entry names of a folder, sorted (so that files are met in the same order everywhere).
 * [out] *names (each and the array malloc'd), *n. */
static vm_status folder_names(const char *dir, char ***names, size_t *n, vm_error *err) {
    *names = NULL, *n = 0;
    DIR *d = opendir(dir);
    if (!d) return vm_error_set(err, VM_ERR_IO, "%s: cannot open folder (%s)", dir,
                                strerror(errno));
    size_t cap = 0;
    vm_status st = VM_OK;
    struct dirent *e;
    while (!st && (e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0) continue;
        st = vm__grow((void **)names, &cap, *n + 1, sizeof **names, err);
        char *copy = st ? NULL : malloc(strlen(e->d_name) + 1);
        if (!st && !copy) st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", dir);
        if (!st) (*names)[(*n)++] = strcpy(copy, e->d_name);
    }
    closedir(d);
    if (*n) qsort(*names, *n, sizeof **names, cmp_names);
    return st;
}

/* Adds the DICOM images under dir (recursively) to set. */
static vm_status walk_folder(const char *dir, int depth, dcm_set *set, size_t *cap,
                             vm_error *err) {
    if (depth > MAX_FOLDER_DEPTH) return VM_OK;
    char **names;
    size_t n;
    vm_status st = folder_names(dir, &names, &n, err);
    for (size_t i = 0; i < n; i++) {
        size_t len = strlen(dir) + strlen(names[i]) + 2;
        char *path = st ? NULL : malloc(len);
        struct stat sb;
        if (!st && !path) st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", dir);
        if (path) snprintf(path, len, "%s/%s", dir, names[i]);
        if (path && stat(path, &sb) == 0) {
            if (S_ISDIR(sb.st_mode)) {
                st = walk_folder(path, depth + 1, set, cap, err);
            } else if (S_ISREG(sb.st_mode) && vm__dcm_sniff_path(path)) {
                dcm_file f;
                st = vm__dcm_parse(path, &f, NULL, err);
                if (st || !f.has_pixels || f.is_dicomdir) /* reports, plans, directories */
                    vm__dcm_file_free(&f);
                else
                    st = set_add(set, cap, &f, err);
            }
        }
        free(path);
        free(names[i]);
    }
    free(names);
    return st;
}

/* Finds and parses the headers of the DICOM images under path. */
vm_status vm__dcm_scan(const char *path, dcm_set *set, vm_error *err) {
    memset(set, 0, sizeof *set);
    size_t cap = 0;
    struct stat sb;
    if (stat(path, &sb) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    vm_status st;
    if (S_ISDIR(sb.st_mode)) {
        st = walk_folder(path, 0, set, &cap, err);
    } else {
        dcm_file f;
        st = vm__dcm_parse(path, &f, NULL, err);
        if (!st && f.is_dicomdir) {
            /* a DICOMDIR: the images are in its folder (and below) */
            size_t len = strlen(path);
            char *dir = malloc(len + 3);
            if (!dir) st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
            if (dir) {
                strcpy(dir, path);
                char *slash = strrchr(dir, '/');
                if (slash) *slash = 0; else strcpy(dir, ".");
                st = walk_folder(dir, 0, set, &cap, err);
                free(dir);
            }
            vm__dcm_file_free(&f);
        } else if (!st) {
            st = set_add(set, &cap, &f, err);
        } else {
            vm__dcm_file_free(&f);
        }
    }
    if (!st && set->n == 0)
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: no DICOM images found%s", path,
                          S_ISDIR(sb.st_mode) ? " (a folder is read as a DICOM series)" : "");
    if (st) vm__dcm_set_free(set);
    return st;
}

/* Frees a set of files. */
void vm__dcm_set_free(dcm_set *set) {
    for (size_t i = 0; i < set->n; i++) vm__dcm_file_free(&set->files[i]);
    free(set->files);
    memset(set, 0, sizeof *set);
}

/* Orders series by slices (most first), then UID. */
static int cmp_series(const void *a, const void *b) {
    const dcm_series *x = a, *y = b;
    if (x->slices != y->slices) return x->slices > y->slices ? -1 : 1;
    return strcmp(x->uid, y->uid);
}

/* Groups the files of set by SeriesInstanceUID. */
vm_status vm__dcm_group(const char *path, const dcm_set *set, dcm_series **list,
                        size_t *count, vm_error *err) {
    *list = calloc(set->n ? set->n : 1, sizeof **list);
    *count = 0;
    if (!*list) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    for (size_t i = 0; i < set->n; i++) {
        const dcm_file *f = &set->files[i];
        size_t s = 0;
        while (s < *count && strcmp((*list)[s].uid, f->series_uid) != 0) s++;
        dcm_series *se = &(*list)[s];
        if (s == *count) {
            se->uid = f->series_uid;
            se->members = malloc(set->n * sizeof *se->members);
            (*count)++;
            if (!se->members) {
                vm__dcm_series_free(*list, *count);
                *list = NULL, *count = 0;
                return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
            }
        }
        se->members[se->n++] = i;
        se->slices += f->frames;
    }
    qsort(*list, *count, sizeof **list, cmp_series);
    return VM_OK;
}

/* Frees a list of series. */
void vm__dcm_series_free(dcm_series *list, size_t count) {
    if (!list) return;
    for (size_t i = 0; i < count; i++) free(list[i].members);
    free(list);
}

/* Finds the series a choice names. */
vm_status vm__dcm_choose(const char *path, const dcm_series *list, size_t count,
                         const char *choice, size_t *which, vm_error *err) {
    *which = 0;
    if (!choice) return VM_OK;
    size_t k = 0;
    while (isdigit((unsigned char)choice[k])) k++;
    if (k > 0 && !choice[k]) {
        long long idx = k > 18 ? 0 : atoll(choice);
        if (idx < 1 || (unsigned long long)idx > count)
            return vm_error_set(err, VM_ERR_ARG, "%s: series %s does not exist (%zu series "
                                "found, numbered from 1)", path, choice, count);
        *which = (size_t)idx - 1;
        return VM_OK;
    }
    for (size_t i = 0; i < count; i++)
        if (strcmp(list[i].uid, choice) == 0) {
            *which = i;
            return VM_OK;
        }
    return vm_error_set(err, VM_ERR_ARG, "%s: no series with SeriesInstanceUID %.80s (%zu "
                        "series found)", path, choice, count);
}

/* 1 when a and b agree to AGREE_TOLERANCE (relative to their size, at least 1). */
static int agree(const double *a, const double *b, int n) {
    for (int i = 0; i < n; i++) {
        double scale = fabs(a[i]) > 1.0 ? fabs(a[i]) : 1.0;
        if (fabs(a[i] - b[i]) > AGREE_TOLERANCE * scale) return 0;
    }
    return 1;
}

/* Every file of s decodable and like the first: size, sample layout, orientation, spacing. */
static vm_status check_members(dcm_set *set, const dcm_series *s, vm_error *err) {
    dcm_file *a = &set->files[s->members[0]];
    for (size_t m = 0; m < s->n; m++) {
        dcm_file *f = &set->files[s->members[m]];
        vm_status st = vm__dcm_check_pixels(f, err);
        if (st) return st;
        if (f->frame_orientation_differs)
            return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: frames have different "
                                "orientations", f->path);
        if (f->rows != a->rows || f->cols != a->cols)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %lldx%lld pixels, but %s of the same "
                                "series has %lldx%lld", f->path, (long long)f->cols,
                                (long long)f->rows, a->path, (long long)a->cols,
                                (long long)a->rows);
        if (f->bits_allocated != a->bits_allocated || f->pixel_rep != a->pixel_rep)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: sample type differs from %s of the "
                                "same series", f->path, a->path);
        if (f->has_orientation != a->has_orientation ||
            !agree(f->orientation, a->orientation, 6))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: ImageOrientationPatient differs from "
                                "%s of the same series (a localizer or radial series is not "
                                "a stack)", f->path, a->path);
        if (f->has_spacing != a->has_spacing || !agree(f->spacing, a->spacing, 2))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: PixelSpacing differs from %s of the "
                                "same series", f->path, a->path);
    }
    return VM_OK;
}

/* The row, column and normal directions from the first file (PS3.3 C.7.6.2.1.1). */
static vm_status plane_axes(const dcm_file *a, int64_t slices, double axes[3][3],
                            vm_error *err) {
    memset(axes, 0, 9 * sizeof(double));
    if (!a->has_orientation) {
        if (slices > 1)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: no ImageOrientationPatient, so the "
                                "slices cannot be ordered", a->path);
        axes[0][0] = axes[1][1] = axes[2][2] = 1.0;
        return VM_OK;
    }
    double r[3], c[3];
    memcpy(r, a->orientation, sizeof r);
    memcpy(c, a->orientation + 3, sizeof c);
    double nr = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    double nc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    if (!(nr > 0.5 && nc > 0.5 &&
          fabs(r[0] * c[0] + r[1] * c[1] + r[2] * c[2]) < 0.01 * nr * nc))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: ImageOrientationPatient does not hold two "
                            "perpendicular directions", a->path);
    for (int i = 0; i < 3; i++) axes[0][i] = r[i] / nr, axes[1][i] = c[i] / nc;
    double *n = axes[2], *x = axes[0], *y = axes[1];
    n[0] = x[1] * y[2] - x[2] * y[1];
    n[1] = x[2] * y[0] - x[0] * y[2];
    n[2] = x[0] * y[1] - x[1] * y[0];
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int i = 0; i < 3; i++) n[i] /= nn;
    return VM_OK;
}

/* The position of frame k of f: per-frame plane position (enhanced), grid frame offset (RT
 * dose), or the image position. */
static vm_status frame_position(const dcm_file *f, int64_t k, int64_t total,
                                const double n[3], double pos[3], vm_error *err) {
    if (f->n_frame_positions > 0) {
        if (k >= f->n_frame_positions || isnan(f->frame_positions[3 * k]))
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: frame %lld has no PlanePositionSequence", f->path,
                                (long long)k + 1);
        memcpy(pos, f->frame_positions + 3 * k, 3 * sizeof(double));
        return VM_OK;
    }
    if (f->n_offsets > 0 || f->frames > 1) {
        if (f->n_offsets < f->frames || !f->has_position)
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: %lld frames but %lld grid frame offsets "
                                "and %s image position; their positions are unknown",
                                f->path, (long long)f->frames, (long long)f->n_offsets,
                                f->has_position ? "an" : "no");
        /* PS3.3 C.8.8.3.2 (files cut to fewer frames keep the whole vector: the first
         * entries are used): a first offset of 0 makes them relative to the image position
         * along the normal; otherwise they are z coordinates (axial dose grids only). */
        double off = f->grid_offsets[k];
        if (f->grid_offsets[0] != 0.0) {
            if (fabs(fabs(n[2]) - 1.0) > AGREE_TOLERANCE)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: absolute GridFrameOffsetVector "
                                    "needs an axial orientation", f->path);
            off = (off - f->position[2]) * n[2];
        }
        for (int i = 0; i < 3; i++) pos[i] = f->position[i] + off * n[i];
        return VM_OK;
    }
    if (!f->has_position && total > 1)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: no ImagePositionPatient, so the slices "
                            "cannot be ordered", f->path);
    memcpy(pos, f->position, 3 * sizeof(double));
    return VM_OK;
}

/* Orders slices by their position along the normal. */
static int cmp_slices(const void *a, const void *b) {
    const dcm_slice *x = a, *y = b;
    return x->d < y->d ? -1 : x->d > y->d ? 1 : 0;
}

/* Slices sorted along the normal must step evenly along it and nowhere else. [out] *dz. */
static vm_status check_stack(const dcm_set *set, const dcm_slice *sl, int64_t n,
                             const double normal[3], double *dz, vm_error *err) {
    *dz = 1.0; /* one slice: no distance to measure */
    if (n < 2) return VM_OK;
    const char *first = set->files[sl[0].file].path;
    double mean = (sl[n - 1].d - sl[0].d) / (double)(n - 1);
    for (int64_t k = 1; k < n; k++) {
        const char *pk = set->files[sl[k].file].path, *pp = set->files[sl[k - 1].file].path;
        double along = sl[k].d - sl[0].d, off = 0;
        for (int i = 0; i < 3; i++) {
            double e = sl[k].pos[i] - sl[0].pos[i] - along * normal[i];
            off += e * e;
        }
        off = sqrt(off);
        if (off > TILT_TOLERANCE * mean + 1e-6)
            return vm_error_set(
                err, VM_ERR_UNSUPPORTED,
                "%s: slice positions are not along "
                "the slice normal (gantry tilt of about %.2f degrees: %s is %.4g "
                "mm off the line through %s); tilted stacks are not supported",
                pk, atan2(off, along) * DEG_PER_RAD, pk, off, first);
        int seg = strcmp(set->files[sl[k].file].modality, "SEG") == 0;
        if (sl[k].d - sl[k - 1].d <= 1e-6 * (mean > 1 ? mean : 1))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %s at the same position as %s (%s)",
                                pk, seg ? "frames" : "slice", pp,
                                seg ? "a segmentation of several segments is not supported"
                                    : "two acquisitions in one series?");
    }
    for (int64_t k = 1; k < n; k++) {
        const char *pk = set->files[sl[k].file].path, *pp = set->files[sl[k - 1].file].path;
        double gap = sl[k].d - sl[k - 1].d;
        if (fabs(gap - mean) > GAP_TOLERANCE * mean)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: uneven slice gaps: %.6g mm after %s "
                                "against %.6g mm on average (more than 1 %% off; missing "
                                "slices?)", pk, gap, pp, mean);
    }
    *dz = mean;
    return VM_OK;
}

/* Every frame of every file of s as a slice with its position along the normal. */
static vm_status collect_slices(const dcm_set *set, const dcm_series *s, const double n[3],
                                dcm_slice *sl, vm_error *err) {
    int64_t k = 0;
    for (size_t m = 0; m < s->n; m++) {
        const dcm_file *f = &set->files[s->members[m]];
        for (int64_t fr = 0; fr < f->frames; fr++, k++) {
            sl[k].file = s->members[m];
            sl[k].frame = fr;
            vm_status st = frame_position(f, fr, s->slices, n, sl[k].pos, err);
            if (st) return st;
            sl[k].d = sl[k].pos[0] * n[0] + sl[k].pos[1] * n[1] + sl[k].pos[2] * n[2];
        }
    }
    return VM_OK;
}

/* The volume header of series s and its sorted slices. */
vm_status vm__dcm_geometry(const char *path, dcm_set *set, const dcm_series *s, vm_volume *v,
                           dcm_slice **slices, vm_error *err) {
    memset(v, 0, sizeof *v);
    *slices = NULL;
    vm_status st = check_members(set, s, err);
    const dcm_file *a = &set->files[s->members[0]];
    double axes[3][3], dz;
    if (!st) st = plane_axes(a, s->slices, axes, err);
    if (st) return st;
    dcm_slice *sl = malloc((size_t)s->slices * sizeof *sl);
    if (!sl) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    st = collect_slices(set, s, axes[2], sl, err);
    if (!st) {
        qsort(sl, (size_t)s->slices, sizeof *sl, cmp_slices);
        st = check_stack(set, sl, s->slices, axes[2], &dz, err);
    }
    if (st) {
        free(sl);
        return st;
    }
    v->dims[0] = a->cols, v->dims[1] = a->rows, v->dims[2] = s->slices;
    v->type = vm__dcm_stored_type(a);
    /* PixelSpacing is (between rows, between columns) = (y, x) */
    v->spacing[0] = a->has_spacing ? a->spacing[1] : 1.0;
    v->spacing[1] = a->has_spacing ? a->spacing[0] : 1.0;
    v->spacing[2] = dz;
    if (!(v->spacing[0] > 0 && v->spacing[1] > 0)) {
        free(sl);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: PixelSpacing must be positive", a->path);
    }
    memcpy(v->origin, sl[0].pos, sizeof v->origin);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) v->direction[r][c] = axes[c][r];
    snprintf(v->format, sizeof v->format, "dicom");
    *slices = sl;
    return VM_OK;
}
