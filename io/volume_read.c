/* SPDX-License-Identifier: BSD-3-Clause */
/* io/volume_read.c — picks the volume reader from the file name (a folder, or a file whose
 * content is DICOM, from the content); whole, header-only and slab reads all go through the
 * same reader of each format. */
#include <sys/stat.h>
#include "dicom_internal.h"
#include "io_util.h"
#include "volmesh/io.h"
#include <assert.h>
#include <stdlib.h>
#include <string.h>

typedef vm_status (*reader_fn)(const char *path, const vm__slab *rq, vm_volume *v,
                               vm_error *err);

/* The reader a file name's extension asks for, or NULL. */
static reader_fn reader_of_name(const char *path) {
    if (vm__ends_with(path, ".nrrd") || vm__ends_with(path, ".nhdr")) return vm__read_nrrd;
    if (vm__ends_with(path, ".nii") || vm__ends_with(path, ".nii.gz") ||
        vm__ends_with(path, ".hdr") || vm__ends_with(path, ".img") ||
        vm__ends_with(path, ".img.gz"))
        return vm__read_nifti;
    if (vm__ends_with(path, ".mha") || vm__ends_with(path, ".mhd")) return vm__read_metaimage;
    if (vm__ends_with(path, ".vtk")) return vm__read_vtk;
    if (vm__ends_with(path, ".vti")) return vm__read_vti;
    if (vm__ends_with(path, ".tif") || vm__ends_with(path, ".tiff")) return vm__read_tiff;
    if (vm__ends_with(path, ".inr") || vm__ends_with(path, ".inr.gz")) return vm__read_inrimage;
    return NULL;
}

/* A folder is a TIFF stack when it holds .tif files, else a DICOM series, unless its name is
 * a volume file's (then that reader says it is a folder); a file whose content is DICOM is
 * read as DICOM whatever its name. */
static vm_status read_any(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    reader_fn by_name = reader_of_name(path);
    struct stat sb;
    int is_dir = stat(path, &sb) == 0 && S_ISDIR(sb.st_mode);
    vm_status st;
    if (is_dir && !by_name && vm__tiff_folder(path))
        st = vm__read_tiff(path, rq, v, err);
    else if ((is_dir && !by_name) || (!is_dir && vm__dcm_sniff_path(path)))
        st = vm__read_dicom(path, rq, v, err);
    else if (by_name)
        st = by_name(path, rq, v, err);
    else
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: unknown volume format (expected .nrrd .nhdr .nii .nii.gz .hdr "
                            ".img .mha .mhd .vtk .vti .tif .tiff .inr .inr.gz, DICOM, or a raw "
                            "file with --raw-dims)",
                            path);
    /* a header-only read may stop before vm__slab_finish */
    if (!st && rq->spacing) memcpy(v->spacing, rq->spacing, sizeof v->spacing);
    return st;
}

/* Reads path as rq asks: raw when raw is not NULL, else by its name or content. */
static vm_status read_rq(const char *path, const vm_raw_options *raw, const vm__slab *rq,
                         vm_volume *v, vm_error *err) {
    if (!raw) return read_any(path, rq, v, err);
    memset(v, 0, sizeof *v);
    vm_status st = vm__read_raw(path, raw, rq, v, err);
    if (!st && rq->spacing) memcpy(v->spacing, rq->spacing, sizeof v->spacing);
    return st;
}

/* opt's spacing is one every reader accepts, or VM_ERR_ARG naming path. */
static vm_status check_options(const char *path, const vm_volume_read_options *opt,
                               vm_error *err) {
    if (!opt || !opt->has_spacing) return VM_OK;
    for (int a = 0; a < 3; a++)
        if (!vm__spacing_in_range(opt->spacing[a]))
            return vm_error_set(err, VM_ERR_ARG,
                                "%s: spacing %g of axis %c is not a number from %g to %g", path,
                                opt->spacing[a], "xyz"[a], VM_SPACING_MIN, VM_SPACING_MAX);
    return VM_OK;
}

void vm_volume_read_options_init(vm_volume_read_options *o) {
    assert(o);
    memset(o, 0, sizeof *o);
}

vm_status vm_volume_read(const char *path, vm_volume *v, vm_error *err) {
    return read_any(path, &vm__slab_whole, v, err);
}

vm_status vm_volume_read_with(const char *path, const vm_volume_read_options *opt,
                              vm_volume *v, vm_error *err) {
    assert(path && v);
    memset(v, 0, sizeof *v);
    vm_status st = check_options(path, opt, err);
    if (st) return st;
    vm__slab rq = vm__slab_whole;
    if (opt) {
        rq.spacing = opt->has_spacing ? opt->spacing : NULL;
        rq.series = opt->series;
    }
    return read_rq(path, opt ? opt->raw : NULL, &rq, v, err);
}

vm_status vm_volume_read_info(const char *path, vm_volume *v, vm_error *err) {
    assert(path && v);
    vm__slab rq = {0, 0, 0, 1, NULL, NULL, NULL, NULL};
    return read_any(path, &rq, v, err);
}

vm_status vm_volume_read_slab(const char *path, int64_t z0, int64_t z1, vm_volume *v,
                              vm_error *err) {
    assert(path && v);
    vm__slab rq = {z0, z1, 0, 0, NULL, NULL, NULL, NULL};
    return read_any(path, &rq, v, err);
}

vm_status vm_volume_read_raw_info(const char *path, const vm_raw_options *opt, vm_volume *v,
                                  vm_error *err) {
    assert(path && opt && v);
    vm__slab rq = {0, 0, 0, 1, NULL, NULL, NULL, NULL};
    return vm__read_raw(path, opt, &rq, v, err);
}

vm_status vm_volume_read_raw_slab(const char *path, const vm_raw_options *opt, int64_t z0,
                                  int64_t z1, vm_volume *v, vm_error *err) {
    assert(path && opt && v);
    vm__slab rq = {z0, z1, 0, 0, NULL, NULL, NULL, NULL};
    return vm__read_raw(path, opt, &rq, v, err);
}

struct vm_volume_reader {
    char *path;
    int is_raw;
    vm_raw_options raw;
    char *series;       /* owned copy, or NULL */
    int has_spacing;
    double spacing[3];
    int64_t dims[3];
    vm__resume cursor;
};

/* Reads what rq asks with the reader's choices. */
static vm_status reader_read(vm_volume_reader *r, vm__slab *rq, vm_volume *v, vm_error *err) {
    rq->spacing = r->has_spacing ? r->spacing : NULL;
    rq->series = r->series;
    return read_rq(r->path, r->is_raw ? &r->raw : NULL, rq, v, err);
}

/* A malloc'd copy of s, or NULL when out of memory. */
static char *copy_string(const char *s) {
    size_t len = strlen(s);
    char *c = malloc(len + 1);
    if (c) memcpy(c, s, len + 1);
    return c;
}

vm_status vm_volume_reader_open_with(const char *path, const vm_volume_read_options *opt,
                                     vm_volume *info, vm_volume_reader **out, vm_error *err) {
    assert(path && out);
    *out = NULL;
    vm_status st = check_options(path, opt, err);
    if (st) return st;
    vm_volume_reader *r = calloc(1, sizeof *r);
    if (r) r->path = copy_string(path);
    if (r && r->path && opt && opt->series && !(r->series = copy_string(opt->series)))
        free(r->path), r->path = NULL;
    if (!r || !r->path) {
        free(r);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    }
    if (opt && opt->raw) {
        r->is_raw = 1;
        r->raw = *opt->raw;
    }
    if (opt && opt->has_spacing) {
        r->has_spacing = 1;
        memcpy(r->spacing, opt->spacing, sizeof r->spacing);
    }
    vm_volume v;
    vm__slab rq = {0, 0, 0, 1, NULL, NULL, NULL, NULL};
    st = reader_read(r, &rq, &v, err);
    if (st) {
        vm_volume_reader_close(r);
        return st;
    }
    memcpy(r->dims, v.dims, sizeof r->dims);
    if (info)
        *info = v;
    else
        vm_volume_free(&v);
    *out = r;
    return VM_OK;
}

vm_status vm_volume_reader_open(const char *path, const vm_raw_options *raw, vm_volume *info,
                                vm_volume_reader **out, vm_error *err) {
    vm_volume_read_options o;
    vm_volume_read_options_init(&o);
    o.raw = raw;
    return vm_volume_reader_open_with(path, &o, info, out, err);
}

vm_status vm_volume_reader_read(vm_volume_reader *r, int64_t z0, int64_t z1, float *dst,
                                vm_error *err) {
    assert(r && dst);
    vm__slab rq = {z0, z1, 0, 0, dst, &r->cursor, NULL, NULL};
    vm_volume v;
    vm_status st = reader_read(r, &rq, &v, err);
    v.data = NULL; /* the caller's */
    vm_volume_free(&v);
    return st;
}

void vm_volume_reader_close(vm_volume_reader *r) {
    if (!r) return;
    vm__resume_end(&r->cursor);
    free(r->series);
    free(r->path);
    free(r);
}
