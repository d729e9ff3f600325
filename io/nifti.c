/* SPDX-License-Identifier: BSD-3-Clause */
/* io/nifti.c — NIfTI-1 and NIfTI-2 volume reader (.nii, .nii.gz, .hdr/.img pairs).
 * Follows the field documentation of nifti1.h (NIfTI-1, 348-byte header) and nifti2.h
 * (NIfTI-2, 540-byte header); the header layouts below are written from those offsets. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

/* NIfTI-1 byte offsets (nifti1.h, struct nifti_1_header). */
enum {
    N1_SIZE = 348,
    N1_DIM = 40,          /* short[8] */
    N1_DATATYPE = 70,     /* short */
    N1_PIXDIM = 76,       /* float[8] */
    N1_VOX_OFFSET = 108,  /* float */
    N1_SCL_SLOPE = 112,   /* float */
    N1_SCL_INTER = 116,   /* float */
    N1_QFORM_CODE = 252,  /* short */
    N1_SFORM_CODE = 254,  /* short */
    N1_QUATERN_B = 256,   /* float b, c, d, qoffset_x, y, z */
    N1_SROW_X = 280,      /* float[4] srow_x, then srow_y, srow_z */
    N1_MAGIC = 344        /* char[4] "n+1\0" or "ni1\0" */
};

/* NIfTI-2 byte offsets (nifti2.h, struct nifti_2_header). */
enum {
    N2_SIZE = 540,
    N2_MAGIC = 4,         /* char[8] "n+2\0\r\n\032\n" or "ni2\0..." */
    N2_DATATYPE = 12,     /* int16 */
    N2_DIM = 16,          /* int64[8] */
    N2_PIXDIM = 104,      /* double[8] */
    N2_VOX_OFFSET = 168,  /* int64 */
    N2_SCL_SLOPE = 176,   /* double */
    N2_SCL_INTER = 184,   /* double */
    N2_QFORM_CODE = 344,  /* int32 */
    N2_SFORM_CODE = 348,  /* int32 */
    N2_QUATERN_B = 352,   /* double b, c, d, qoffset_x, y, z */
    N2_SROW_X = 400       /* double[4] srow_x, then srow_y, srow_z */
};

/* The header fields volmesh uses, widened to one representation for both versions. */
typedef struct nifti_hdr {
    int version;          /* 1 or 2 */
    int single_file;      /* "n+1"/"n+2": data in the same file after vox_offset */
    int swap;             /* file byte order differs from the host's */
    int datatype;
    int64_t dim[8];
    double pixdim[8];
    double vox_offset;
    double scl_slope, scl_inter;
    int qform_code, sform_code;
    double quatern[6];    /* b, c, d, qoffset_x, qoffset_y, qoffset_z */
    double srow[3][4];
} nifti_hdr;

static void get_bytes(const unsigned char *p, size_t n, int swap, void *out) {
    unsigned char tmp[8];
    for (size_t i = 0; i < n; i++) tmp[i] = swap ? p[n - 1 - i] : p[i];
    memcpy(out, tmp, n);
}
static int16_t get_i16(const unsigned char *p, int swap) {
    int16_t v;
    get_bytes(p, 2, swap, &v);
    return v;
}
static int32_t get_i32(const unsigned char *p, int swap) {
    int32_t v;
    get_bytes(p, 4, swap, &v);
    return v;
}
static int64_t get_i64(const unsigned char *p, int swap) {
    int64_t v;
    get_bytes(p, 8, swap, &v);
    return v;
}
static double get_f32(const unsigned char *p, int swap) {
    float v;
    get_bytes(p, 4, swap, &v);
    return (double)v;
}
static double get_f64(const unsigned char *p, int swap) {
    double v;
    get_bytes(p, 8, swap, &v);
    return v;
}

/* Decodes the header at buf (len bytes). Version and byte order come from sizeof_hdr, which
 * is 348 (NIfTI-1) or 540 (NIfTI-2) in the writer's byte order. */
static vm_status parse_header(const char *path, const unsigned char *buf, size_t len,
                              nifti_hdr *h, vm_error *err) {
    memset(h, 0, sizeof *h);
    if (len == 0) return vm_error_set(err, VM_ERR_FORMAT, "%s: file is empty", path);
    if (len < 4)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: file of %zu bytes is too short for a "
                            "NIfTI header", path, len);
    int32_t native = get_i32(buf, 0), swapped = get_i32(buf, 1);
    if (native == N1_SIZE || native == N2_SIZE) {
        h->version = native == N1_SIZE ? 1 : 2;
        h->swap = 0;
    } else if (swapped == N1_SIZE || swapped == N2_SIZE) {
        h->version = swapped == N1_SIZE ? 1 : 2;
        h->swap = 1;
    } else {
        return vm_error_set(err, VM_ERR_FORMAT, "%s: not a NIfTI file (sizeof_hdr is neither "
                            "348 nor 540 in either byte order)", path);
    }
    size_t need = h->version == 1 ? N1_SIZE : N2_SIZE;
    if (len < need)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: NIfTI-%d header is truncated (got %zu of "
                            "%zu bytes)", path, h->version, len, need);
    int s = h->swap;
    if (h->version == 1) {
        const unsigned char *m = buf + N1_MAGIC;
        if (m[3] != 0 || m[0] != 'n' || m[2] != '1' || (m[1] != '+' && m[1] != 'i'))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: bad NIfTI-1 magic (expected \"n+1\" or "
                                "\"ni1\"; ANALYZE 7.5 files are not supported)", path);
        h->single_file = m[1] == '+';
        for (int i = 0; i < 8; i++) {
            h->dim[i] = get_i16(buf + N1_DIM + 2 * i, s);
            h->pixdim[i] = get_f32(buf + N1_PIXDIM + 4 * i, s);
        }
        h->datatype = get_i16(buf + N1_DATATYPE, s);
        h->vox_offset = get_f32(buf + N1_VOX_OFFSET, s);
        h->scl_slope = get_f32(buf + N1_SCL_SLOPE, s);
        h->scl_inter = get_f32(buf + N1_SCL_INTER, s);
        h->qform_code = get_i16(buf + N1_QFORM_CODE, s);
        h->sform_code = get_i16(buf + N1_SFORM_CODE, s);
        for (int i = 0; i < 6; i++) h->quatern[i] = get_f32(buf + N1_QUATERN_B + 4 * i, s);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) h->srow[r][c] = get_f32(buf + N1_SROW_X + 16 * r + 4 * c, s);
    } else {
        /* Only the first four magic bytes are checked: the trailing "\r\n\032\n" exists to
         * detect text-mode transfers, and the size/offset checks below catch those anyway. */
        const unsigned char *m = buf + N2_MAGIC;
        if (m[3] != 0 || m[0] != 'n' || m[2] != '2' || (m[1] != '+' && m[1] != 'i'))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: bad NIfTI-2 magic (expected \"n+2\" or "
                                "\"ni2\")", path);
        h->single_file = m[1] == '+';
        for (int i = 0; i < 8; i++) {
            h->dim[i] = get_i64(buf + N2_DIM + 8 * i, s);
            h->pixdim[i] = get_f64(buf + N2_PIXDIM + 8 * i, s);
        }
        h->datatype = get_i16(buf + N2_DATATYPE, s);
        h->vox_offset = (double)get_i64(buf + N2_VOX_OFFSET, s);
        h->scl_slope = get_f64(buf + N2_SCL_SLOPE, s);
        h->scl_inter = get_f64(buf + N2_SCL_INTER, s);
        h->qform_code = get_i32(buf + N2_QFORM_CODE, s);
        h->sform_code = get_i32(buf + N2_SFORM_CODE, s);
        for (int i = 0; i < 6; i++) h->quatern[i] = get_f64(buf + N2_QUATERN_B + 8 * i, s);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++) h->srow[r][c] = get_f64(buf + N2_SROW_X + 32 * r + 8 * c, s);
    }
    return VM_OK;
}

/* NIfTI datatype codes volmesh reads (nifti1.h, DT_*). */
enum {
    DT_UINT8 = 2,
    DT_INT16 = 4,
    DT_INT32 = 8,
    DT_FLOAT32 = 16,
    DT_FLOAT64 = 64,
    DT_INT8 = 256,
    DT_UINT16 = 512,
    DT_UINT32 = 768,
    DT_INT64 = 1024,
    DT_UINT64 = 1280
};

/* NIfTI datatype code → volmesh scalar type; VM_ERR_UNSUPPORTED for other codes. */
static vm_status map_datatype(int code, vm_scalar_type *t) {
    switch (code) {
    case DT_UINT8: *t = VM_SCALAR_UINT8; return VM_OK;
    case DT_INT8: *t = VM_SCALAR_INT8; return VM_OK;
    case DT_INT16: *t = VM_SCALAR_INT16; return VM_OK;
    case DT_UINT16: *t = VM_SCALAR_UINT16; return VM_OK;
    case DT_INT32: *t = VM_SCALAR_INT32; return VM_OK;
    case DT_UINT32: *t = VM_SCALAR_UINT32; return VM_OK;
    case DT_INT64: *t = VM_SCALAR_INT64; return VM_OK;
    case DT_UINT64: *t = VM_SCALAR_UINT64; return VM_OK;
    case DT_FLOAT32: *t = VM_SCALAR_FLOAT32; return VM_OK;
    case DT_FLOAT64: *t = VM_SCALAR_FLOAT64; return VM_OK;
    default: return VM_ERR_UNSUPPORTED;
    }
}

static const char *datatype_name(int code) {
    switch (code) {
    case 0: return "unknown";
    case 1: return "binary";
    case 32: return "complex64";
    case 128: return "rgb24";
    case 1536: return "float128";
    case 1792: return "complex128";
    case 2048: return "complex256";
    case 2304: return "rgba32";
    default: return "unrecognised";
    }
}

static int finite3(const double *a) {
    return isfinite(a[0]) && isfinite(a[1]) && isfinite(a[2]);
}

/* Splits M = D * diag(spacing) (columns of m are the index axes in world space): spacing =
 * column norms, direction = normalised columns. VM_ERR_FORMAT when a column is zero or not
 * finite. */
static vm_status split_matrix(double m[3][3], vm_volume *v) {
    for (int c = 0; c < 3; c++) {
        double n = sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
        if (!isfinite(n) || n <= 0.0) return VM_ERR_FORMAT;
        v->spacing[c] = n;
        for (int r = 0; r < 3; r++) v->direction[r][c] = m[r][c] / n;
    }
    return VM_OK;
}

/* Positive pixdim, or 1 where the header leaves it zero, negative or not finite (as the
 * NIfTI reference library does for the quaternion method). */
static double pixdim_or_one(double d) {
    return isfinite(d) && d > 0.0 ? d : 1.0;
}

/* Geometry per nifti1.h "3D IMAGE (VOLUME) ORIENTATION AND LOCATION IN SPACE": method 3
 * (sform) when sform_code > 0, else method 2 (qform) when qform_code > 0, else method 1
 * (pixdim only, origin 0). World coordinates stay in NIfTI's RAS+ space (+x = Right,
 * +y = Anterior, +z = Superior); nothing is flipped to ITK/DICOM's LPS, so a NIfTI and a
 * MetaImage of the same scan differ by diag(-1, -1, 1) in world space. A degenerate sform (zero or non-finite column)
 * falls back to the qform, and a degenerate qform to pixdim. */
static void set_geometry(const nifti_hdr *h, vm_volume *v) {
    double dx = pixdim_or_one(h->pixdim[1]), dy = pixdim_or_one(h->pixdim[2]),
           dz = pixdim_or_one(h->pixdim[3]);
    if (h->sform_code > 0) {
        double m[3][3];
        int ok = 1;
        for (int r = 0; r < 3; r++) {
            for (int c = 0; c < 3; c++) m[r][c] = h->srow[r][c];
            if (!isfinite(h->srow[r][3])) ok = 0;
        }
        if (ok && split_matrix(m, v) == VM_OK) {
            for (int r = 0; r < 3; r++) v->origin[r] = h->srow[r][3];
            return;
        }
    }
    if (h->qform_code > 0 && finite3(h->quatern) && finite3(h->quatern + 3)) {
        double b = h->quatern[0], c = h->quatern[1], d = h->quatern[2];
        double a = 1.0 - (b * b + c * c + d * d);
        if (a < 1e-7) {
            /* A 180-degree rotation: a is 0 and (b, c, d) is renormalised. */
            double n = sqrt(b * b + c * c + d * d);
            if (n > 0.0) {
                b /= n;
                c /= n;
                d /= n;
            }
            a = 0.0;
        } else {
            a = sqrt(a);
        }
        double R[3][3] = {
            {a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)},
            {2 * (b * c + a * d), a * a + c * c - b * b - d * d, 2 * (c * d - a * b)},
            {2 * (b * d - a * c), 2 * (c * d + a * b), a * a + d * d - c * c - b * b}};
        /* qfac = pixdim[0] is -1 for a left-handed index frame; anything else counts as 1. */
        double qfac = h->pixdim[0] < 0.0 ? -1.0 : 1.0;
        double m[3][3];
        for (int r = 0; r < 3; r++) {
            m[r][0] = R[r][0] * dx;
            m[r][1] = R[r][1] * dy;
            m[r][2] = R[r][2] * dz * qfac;
        }
        if (split_matrix(m, v) == VM_OK) {
            for (int r = 0; r < 3; r++) v->origin[r] = h->quatern[3 + r];
            return;
        }
    }
    double s[3] = {dx, dy, dz};
    for (int r = 0; r < 3; r++) {
        v->spacing[r] = s[r];
        v->origin[r] = 0.0;
        for (int c = 0; c < 3; c++) v->direction[r][c] = r == c ? 1.0 : 0.0;
    }
}

/* Length of path without a trailing ".gz" and a trailing ext (4 chars, e.g. ".hdr"), so the
 * partner file of a pair can be built by appending another extension. */
static size_t pair_stem(const char *path, int *gz) {
    size_t n = strlen(path);
    *gz = vm__ends_with(path, ".gz");
    if (*gz) n -= 3;
    return n >= 4 ? n - 4 : n;
}

/* Reads the partner file stem+ext for the first ext of exts[] (NULL-terminated) that exists
 * (the first one when none does). Errors name the file the user gave (owner) first. */
static vm_status read_partner(const char *owner, const char *what, size_t stem_len,
                              const char *const *exts, unsigned char **buf, size_t *len,
                              vm_error *err) {
    char cand[4200];
    struct stat sb;
    int pick = 0;
    for (int i = 0; exts[i]; i++) {
        snprintf(cand, sizeof cand, "%.*s%s", (int)stem_len, owner, exts[i]);
        if (stat(cand, &sb) == 0) {
            pick = i;
            break;
        }
    }
    if ((size_t)snprintf(cand, sizeof cand, "%.*s%s", (int)stem_len, owner, exts[pick]) >=
        sizeof cand)
        return vm_error_set(err, VM_ERR_IO, "%s: path too long", owner);
    vm_error inner;
    vm_error_clear(&inner);
    vm_status st = vm__read_gz_file(cand, vm__memory_limit(), buf, len, &inner);
    if (st) return vm_error_set(err, st, "%s: %s %s", owner, what, inner.message);
    return VM_OK;
}

static int is_gzip(const vm__map *m) { return m->len >= 2 && m->p[0] == 0x1f && m->p[1] == 0x8b; }

/* Maps the partner file stem+ext for the first ext of exts[] that exists (the first one
 * when none does). [out] m, dpath. */
static vm_status map_partner(const char *owner, const char *what, size_t stem_len,
                             const char *const *exts, vm__map *m, char dpath[4200],
                             vm_error *err) {
    struct stat sb;
    int pick = 0;
    for (int i = 0; exts[i]; i++) {
        snprintf(dpath, 4200, "%.*s%s", (int)stem_len, owner, exts[i]);
        if (stat(dpath, &sb) == 0) {
            pick = i;
            break;
        }
    }
    if ((size_t)snprintf(dpath, 4200, "%.*s%s", (int)stem_len, owner, exts[pick]) >= 4200)
        return vm_error_set(err, VM_ERR_IO, "%s: path too long", owner);
    vm_error inner;
    vm_error_clear(&inner);
    vm_status st = vm__map_file(dpath, (size_t)-1, m, &inner);
    if (st) return vm_error_set(err, st, "%s: %s %s", owner, what, inner.message);
    return VM_OK;
}

/* Deflate cannot compress better than about 1032:1 (as in io/nrrd.c). */
#define GZIP_MAX_RATIO 1040u

static vm_status read_nifti(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    unsigned char *hbuf = NULL, hpre[N2_SIZE + 8];
    vm__map fm, dm;
    memset(&fm, 0, sizeof fm);
    memset(&dm, 0, sizeof dm);
    size_t hlen = 0;
    int gz = 0;
    size_t stem_len = pair_stem(path, &gz);
    int given_img = vm__ends_with(path, ".img") || vm__ends_with(path, ".img.gz");
    const unsigned char *hdr;
    vm_status st;

    if (given_img) {
        static const char *const hdr_exts[] = {".hdr", ".hdr.gz", NULL};
        st = read_partner(path, "header", stem_len, hdr_exts, &hbuf, &hlen, err);
        hdr = hbuf;
    } else {
        st = vm__map_file(path, (size_t)-1, &fm, err);
        hdr = fm.p;
        hlen = fm.len;
        if (!st && is_gzip(&fm)) {
            st = vm__gz_prefix(path, fm.p, fm.len, hpre, sizeof hpre, &hlen, err);
            hdr = hpre;
        }
    }
    if (st) goto done;

    nifti_hdr h;
    st = parse_header(path, hdr, hlen, &h, err);
    if (st) goto done;

    vm_scalar_type type;
    if (map_datatype(h.datatype, &type) != VM_OK) {
        st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: NIfTI datatype %d (%s) is not supported "
                          "(only integer and real scalars)", path, h.datatype,
                          datatype_name(h.datatype));
        goto done;
    }
    if (h.dim[0] < 3 || h.dim[0] > 7) {
        st = vm_error_set(err, h.dim[0] < 1 || h.dim[0] > 7 ? VM_ERR_FORMAT : VM_ERR_UNSUPPORTED,
                          "%s: dim[0] is %lld (need a 3-D volume: dim[0] = 3, or 4..7 with the "
                          "extra dimensions equal to 1)", path, (long long)h.dim[0]);
        goto done;
    }
    for (int i = 4; i <= h.dim[0]; i++) {
        if (h.dim[i] != 1) {
            st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: dim[%d] is %lld; only 3-D volumes "
                              "are supported (time series and vector data are not)", path, i,
                              (long long)h.dim[i]);
            goto done;
        }
    }
    int64_t dims[3] = {h.dim[1], h.dim[2], h.dim[3]};
    size_t esize = vm_scalar_type_size(type), count, first, n, bytes;
    st = vm__slab_check(path, rq, dims, esize, &count, &first, &n, err);
    if (st) goto done;
    bytes = count * esize; /* checked by vm__slab_check */

    double vo = h.vox_offset;
    if (!isfinite(vo) || vo < 0.0 || vo != floor(vo) || vo > 9.0e15) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: vox_offset %g is not a valid byte offset",
                          path, vo);
        goto done;
    }
    size_t offset = (size_t)vo;
    const vm__map *data;
    if (h.single_file) {
        size_t hsize = h.version == 1 ? N1_SIZE : N2_SIZE;
        if (offset < hsize) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: vox_offset %zu lies inside the %zu-byte "
                              "header", path, offset, hsize);
            goto done;
        }
        data = &fm;
    } else {
        static const char *const img_exts[] = {".img", ".img.gz", NULL};
        char dpath[4200];
        if (given_img) {
            st = vm__map_file(path, (size_t)-1, &dm, err);
        } else {
            st = map_partner(path, "data file", stem_len, img_exts, &dm, dpath, err);
        }
        if (st) goto done;
        data = &dm;
    }
    vm__samples src = {path, data->p + offset, 0, VM__ENC_RAW, 0, type, h.swap,
                       data->maplen != 0, 0};
    if (is_gzip(data)) {
        src.p = data->p;
        src.avail = data->len;
        src.enc = VM__ENC_ZLIB;
        src.skip = offset;
        src.count = count;
        if ((offset + bytes) / GZIP_MAX_RATIO > data->len + 64) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (%zu compressed bytes "
                              "cannot hold %zu bytes after offset %zu)", path, data->len, bytes,
                              offset);
            goto done;
        }
    } else {
        size_t avail = data->len;
        if (offset > avail || avail - offset < bytes) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu bytes "
                              "after offset %zu)", path, offset > avail ? 0 : avail - offset,
                              bytes, offset);
            goto done;
        }
        src.avail = avail - offset;
    }

    v->dims[0] = dims[0];
    v->dims[1] = dims[1];
    v->dims[2] = dims[2];
    v->type = type;
    set_geometry(&h, v);
    snprintf(v->format, sizeof v->format, "nifti");
    st = vm__slab_read(path, rq, &src, first, n, v, err);
    if (st || rq->header_only) goto done;

    /* scl_slope = 0 means "no scaling" (nifti1.h); (1, 0) is the identity. */
    double a = h.scl_slope, b = h.scl_inter;
    if (a != 0.0 && isfinite(a) && isfinite(b) && !(a == 1.0 && b == 0.0)) {
        float *d = v->data;
        int64_t nn = (int64_t)n;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) if (nn > (1 << 18))
#endif
        for (int64_t i = 0; i < nn; i++) d[i] = (float)((double)d[i] * a + b);
    }
    vm__slab_finish(v, rq);

done:
    free(hbuf);
    vm__map_free(&fm);
    vm__map_free(&dm);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_nifti(const char *path, vm_volume *v, vm_error *err) {
    return read_nifti(path, &vm__slab_whole, v, err);
}

vm_status vm__read_nifti(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    return read_nifti(path, rq, v, err);
}
