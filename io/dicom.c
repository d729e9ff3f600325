/* SPDX-License-Identifier: BSD-3-Clause */
/* io/dicom.c — the DICOM reader's entry: lists the series under a path, reads one as a
 * volume (whole, header only, or by slabs), filling PixelPaddingValue voxels. Follows DICOM
 * PS3.3 C.7.5.1.1.2 (padding) and the series model of PS3.3 C.7.3; see docs/FORMATS.md. */
#define _POSIX_C_SOURCE 200809L
#include <assert.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "dicom_internal.h"
#include "volmesh/io.h"

/* Everything known about a path once its series is chosen. */
typedef struct dicom_job {
    dcm_set set;
    dcm_series *list;
    size_t count, which;
    dcm_slice *slices;
} dicom_job;

/* Frees what a job holds. */
static void job_free(dicom_job *j) {
    vm__dcm_series_free(j->list, j->count);
    vm__dcm_set_free(&j->set);
    free(j->slices);
    memset(j, 0, sizeof *j);
}

/* Scans path, groups its files and chooses a series, [out] v its header. */
static vm_status job_open(const char *path, const char *choice, dicom_job *j, vm_volume *v,
                          vm_error *err) {
    memset(j, 0, sizeof *j);
    vm_status st = vm__dcm_scan(path, &j->set, err);
    if (!st) st = vm__dcm_group(path, &j->set, &j->list, &j->count, err);
    if (!st) st = vm__dcm_choose(path, j->list, j->count, choice, &j->which, err);
    if (!st) st = vm__dcm_geometry(path, &j->set, &j->list[j->which], v, &j->slices, err);
    if (st) job_free(j);
    return st;
}

/* The file whose bytes are open for decoding (consecutive slices often share one). */
typedef struct open_file {
    size_t index; /* into the set; (size_t)-1 when none */
    dcm_file f;
    dcm_bytes b;
} open_file;

/* Releases the open file, if any. */
static void close_file(open_file *o) {
    if (o->index != (size_t)-1) {
        vm__dcm_file_free(&o->f);
        vm__dcm_bytes_free(&o->b);
    }
    o->index = (size_t)-1;
}

/* Decodes slice k of the job into dst (rows*cols floats). */
static vm_status decode_slice(const dicom_job *j, int64_t k, open_file *o, float *dst,
                              vm_error *err) {
    const dcm_slice *s = &j->slices[k];
    if (o->index != s->file) {
        close_file(o);
        vm_status st = vm__dcm_parse(j->set.files[s->file].path, &o->f, &o->b, err);
        if (!st) st = vm__dcm_check_pixels(&o->f, err);
        if (st) {
            vm__dcm_file_free(&o->f);
            vm__dcm_bytes_free(&o->b);
            return st;
        }
        o->index = s->file;
    }
    return vm__dcm_decode_frame(&o->f, &o->b, s->frame, dst, err);
}

/* 1 when some file of the chosen series declares a padding value. */
static int series_padded(const dicom_job *j) {
    const dcm_series *s = &j->list[j->which];
    for (size_t m = 0; m < s->n; m++)
        if (j->set.files[s->members[m]].has_padding) return 1;
    return 0;
}

/* Lowers *lo to the smallest non-NaN value of n floats. */
static void lower_min(const float *x, size_t n, float *lo) {
    for (size_t i = 0; i < n; i++)
        if (!isnan(x[i]) && x[i] < *lo) *lo = x[i];
}

/* Padding voxels (NaN) take the minimum of the other values of the whole series, so a slab
 * gets the same values as the whole read: the planes outside the slab are decoded one at a
 * time to find it. All padding: 0. */
static vm_status fill_padding(const dicom_job *j, int64_t z0, int64_t z1, size_t plane,
                              open_file *o, float *data, vm_error *err) {
    float lo = INFINITY;
    lower_min(data, plane * (size_t)(z1 - z0), &lo);
    if (z0 > 0 || z1 < j->list[j->which].slices) {
        float *tmp = malloc(plane * sizeof *tmp);
        if (!tmp) return vm_error_set(err, VM_ERR_NOMEM, "out of memory for a DICOM slice");
        for (int64_t k = 0; k < j->list[j->which].slices; k++) {
            if (k >= z0 && k < z1) continue;
            vm_status st = decode_slice(j, k, o, tmp, err);
            if (st) {
                free(tmp);
                return st;
            }
            lower_min(tmp, plane, &lo);
        }
        free(tmp);
    }
    if (isinf(lo)) lo = 0.0f;
    for (size_t i = 0; i < plane * (size_t)(z1 - z0); i++)
        if (isnan(data[i])) data[i] = lo;
    return VM_OK;
}

/* Decodes the planes of rq into v->data (allocated here, or rq->into). */
static vm_status read_planes(const char *path, const dicom_job *j, const vm__slab *rq,
                             size_t n, vm_volume *v, vm_error *err) {
    vm_status st = vm__slab_alloc(path, rq, n, v, err);
    if (st) return st;
    int64_t z0 = rq->all ? 0 : rq->z0, z1 = rq->all ? v->dims[2] : rq->z1;
    size_t plane = (size_t)v->dims[0] * (size_t)v->dims[1];
    open_file o;
    o.index = (size_t)-1;
    for (int64_t k = z0; k < z1 && !st; k++)
        st = decode_slice(j, k, &o, v->data + plane * (size_t)(k - z0), err);
    if (!st && series_padded(j)) st = fill_padding(j, z0, z1, plane, &o, v->data, err);
    close_file(&o);
    return st;
}

/* Reads series choice under path as rq asks. */
static vm_status read_series(const char *path, const char *choice, const vm__slab *rq,
                             vm_volume *v, vm_error *err) {
    dicom_job j;
    memset(v, 0, sizeof *v);
    vm_status st = job_open(path, choice, &j, v, err);
    if (st) return st;
    size_t count, first, n;
    size_t tsize = vm_scalar_type_size(v->type);
    st = vm__slab_check(path, rq, v->dims, tsize, &count, &first, &n, err);
    if (!st) st = vm__check_geometry(v, path, err);
    if (!st && !rq->header_only) st = read_planes(path, &j, rq, n, v, err);
    if (!st) vm__slab_finish(v, rq);
    job_free(&j);
    if (st) vm__slab_release(v, rq);
    return st;
}

/* Series rq->series of path (NULL: the default), as rq asks (vm_volume_read_with and its
 * slab calls). */
vm_status vm__read_dicom(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    return read_series(path, rq->series, rq, v, err);
}

/* Reads series choice under path whole. */
vm_status vm_volume_read_dicom(const char *path, const char *series, vm_volume *v,
                               vm_error *err) {
    assert(path && v);
    return read_series(path, series, &vm__slab_whole, v, err);
}

/* Reads the header of series choice under path, no pixel. */
vm_status vm_volume_read_dicom_info(const char *path, const char *series, vm_volume *v,
                                    vm_error *err) {
    assert(path && v);
    vm__slab rq = {0, 0, 0, 1, NULL, NULL, NULL, NULL};
    return read_series(path, series, &rq, v, err);
}

/* Lists the series under path from their files' headers. */
vm_status vm_dicom_list_series(const char *path, vm_dicom_series_info **list, size_t *count,
                               vm_error *err) {
    assert(path && list && count);
    *list = NULL, *count = 0;
    dicom_job j;
    memset(&j, 0, sizeof j);
    vm_status st = vm__dcm_scan(path, &j.set, err);
    if (!st) st = vm__dcm_group(path, &j.set, &j.list, &j.count, err);
    vm_dicom_series_info *out = st ? NULL : calloc(j.count, sizeof *out);
    if (!st && !out) st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    for (size_t i = 0; !st && i < j.count; i++) {
        const dcm_file *a = &j.set.files[j.list[i].members[0]];
        snprintf(out[i].uid, sizeof out[i].uid, "%s", a->series_uid);
        snprintf(out[i].description, sizeof out[i].description, "%s", a->description);
        snprintf(out[i].modality, sizeof out[i].modality, "%s", a->modality);
        out[i].files = (int64_t)j.list[i].n;
        out[i].slices = j.list[i].slices;
        out[i].dims[0] = a->cols, out[i].dims[1] = a->rows, out[i].dims[2] = j.list[i].slices;
    }
    if (!st) *list = out, *count = j.count;
    job_free(&j);
    return st;
}

/* Frees a list of series. */
void vm_dicom_series_free(vm_dicom_series_info *list) { free(list); }
