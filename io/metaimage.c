/* SPDX-License-Identifier: BSD-3-Clause */
/* io/metaimage.c — MetaImage reader (.mha with LOCAL data, .mhd with a detached file).
 * Follows the MetaIO documentation (ITK wiki "MetaIO/Documentation", MetaImage tags) and, for
 * the meaning of TransformMatrix, ITK's MetaImageIO (axis i's direction = numbers 3i..3i+2). */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

/* The tags volmesh uses; values are kept as trimmed strings until validated. */
typedef struct meta_hdr {
    char object_type[64];
    int has_ndims, ndims;
    double dimsize[3];
    int n_dimsize;
    char element_type[64];
    int channels;
    double spacing[3], size[3];
    int n_spacing, n_size;
    double offset[3];
    int n_offset;
    double matrix[9];
    int n_matrix;
    int msb;                  /* BinaryDataByteOrderMSB / ElementByteOrderMSB */
    int binary;               /* BinaryData (default true) */
    int compressed;
    int has_csize;
    double csize;             /* CompressedDataSize */
    int has_header_size;
    double header_size;       /* HeaderSize: -1 = data at end of file */
    char data_file[1024];     /* ElementDataFile */
    int has_data_file;
    size_t data_start;        /* offset just after the ElementDataFile line */
} meta_hdr;

/* A MetaIO boolean: True/False or 1/0. */
static vm_status parse_bool(const char *s, int *out) {
    if (strcasecmp(s, "true") == 0 || strcmp(s, "1") == 0) {
        *out = 1;
        return VM_OK;
    }
    if (strcasecmp(s, "false") == 0 || strcmp(s, "0") == 0) {
        *out = 0;
        return VM_OK;
    }
    return VM_ERR_FORMAT;
}

static int key_is(const char *key, const char *name) {
    return strcasecmp(key, name) == 0;
}

/* Parses exactly n numbers of value into out (the tag named for the message). */
static vm_status parse_numbers(const char *path, const char *key, const char *value,
                               double *out, int n, int *count, vm_error *err) {
    int got = vm__parse_doubles(value, out, n);
    if (got != n)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: %s needs %d numbers, got '%.64s'", path, key,
                            n, value);
    for (int i = 0; i < n; i++)
        if (!isfinite(out[i]))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %s has a non-finite number", path, key);
    *count = got;
    return VM_OK;
}

/* Reads "Key = Value" lines from buf up to and including ElementDataFile (which ends the
 * header; for LOCAL data the samples start on the next byte). */
static vm_status parse_header(const char *path, const unsigned char *buf, size_t len,
                              meta_hdr *h, vm_error *err) {
    memset(h, 0, sizeof *h);
    h->binary = 1;
    h->channels = 1;
    size_t pos = 0;
    int line_no = 0;
    char line[2048];
    while (pos < len && !h->has_data_file) {
        size_t end = pos;
        while (end < len && buf[end] != '\n') end++;
        size_t n = end - pos;
        line_no++;
        if (n >= sizeof line)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: header line %d is too long (not a "
                                "MetaImage header?)", path, line_no);
        memcpy(line, buf + pos, n);
        line[n] = 0;
        pos = end < len ? end + 1 : end;
        if (memchr(line, 0, n))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: header line %d contains binary data "
                                "(not a MetaImage header, or ElementDataFile is missing)", path,
                                line_no);
        char *t = vm__trim(line);
        if (!*t) continue;
        char *eq = strchr(t, '=');
        if (!eq)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: header line %d is not 'Key = Value': "
                                "'%.40s'", path, line_no, t);
        *eq = 0;
        char *key = vm__trim(t), *value = vm__trim(eq + 1);
        int cnt = 0;
        vm_status st = VM_OK;
        if (key_is(key, "ObjectType")) {
            snprintf(h->object_type, sizeof h->object_type, "%s", value);
        } else if (key_is(key, "NDims")) {
            double d;
            st = parse_numbers(path, key, value, &d, 1, &cnt, err);
            if (st) return st;
            if (d != floor(d) || d < 0 || d > 1000)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: NDims '%s' is not a small "
                                    "integer", path, value);
            h->ndims = (int)d;
            h->has_ndims = 1;
        } else if (key_is(key, "DimSize")) {
            /* Counted now, checked against NDims once the whole header is known. */
            double tmp[4];
            int got = vm__parse_doubles(value, tmp, 4);
            if (got < 1 || got > 3)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: DimSize '%.64s' must hold 3 "
                                    "sizes (volmesh reads 3-D images)", path, value);
            memcpy(h->dimsize, tmp, sizeof h->dimsize);
            h->n_dimsize = got;
        } else if (key_is(key, "ElementType")) {
            snprintf(h->element_type, sizeof h->element_type, "%s", value);
        } else if (key_is(key, "ElementNumberOfChannels")) {
            double d;
            st = parse_numbers(path, key, value, &d, 1, &cnt, err);
            if (st) return st;
            h->channels = d == 1.0 ? 1 : (d > 1.0 && d < 1e6 ? (int)d : 0);
        } else if (key_is(key, "ElementSpacing")) {
            st = parse_numbers(path, key, value, h->spacing, 3, &h->n_spacing, err);
        } else if (key_is(key, "ElementSize")) {
            st = parse_numbers(path, key, value, h->size, 3, &h->n_size, err);
        } else if (key_is(key, "Offset") || key_is(key, "Origin") || key_is(key, "Position")) {
            st = parse_numbers(path, key, value, h->offset, 3, &h->n_offset, err);
        } else if (key_is(key, "TransformMatrix") || key_is(key, "Rotation") ||
                   key_is(key, "Orientation")) {
            st = parse_numbers(path, key, value, h->matrix, 9, &h->n_matrix, err);
        } else if (key_is(key, "BinaryDataByteOrderMSB") || key_is(key, "ElementByteOrderMSB")) {
            if (parse_bool(value, &h->msb) != VM_OK)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: %s must be True or False, not "
                                    "'%.40s'", path, key, value);
        } else if (key_is(key, "BinaryData")) {
            if (parse_bool(value, &h->binary) != VM_OK)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: BinaryData must be True or False, "
                                    "not '%.40s'", path, value);
        } else if (key_is(key, "CompressedData")) {
            if (parse_bool(value, &h->compressed) != VM_OK)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: CompressedData must be True or "
                                    "False, not '%.40s'", path, value);
        } else if (key_is(key, "CompressedDataSize")) {
            st = parse_numbers(path, key, value, &h->csize, 1, &cnt, err);
            if (st) return st;
            if (h->csize < 0 || h->csize != floor(h->csize))
                return vm_error_set(err, VM_ERR_FORMAT, "%s: CompressedDataSize '%s' is not a "
                                    "byte count", path, value);
            h->has_csize = 1;
        } else if (key_is(key, "HeaderSize")) {
            st = parse_numbers(path, key, value, &h->header_size, 1, &cnt, err);
            if (st) return st;
            if (h->header_size < -1 || h->header_size != floor(h->header_size))
                return vm_error_set(err, VM_ERR_FORMAT, "%s: HeaderSize '%s' must be -1 or a "
                                    "byte count", path, value);
            h->has_header_size = 1;
        } else if (key_is(key, "ElementDataFile")) {
            if (strlen(value) >= sizeof h->data_file)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: ElementDataFile name is too long",
                                    path);
            snprintf(h->data_file, sizeof h->data_file, "%s", value);
            h->has_data_file = 1;
            h->data_start = pos;
        }
        if (st) return st;
    }
    if (!h->has_data_file)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: header has no ElementDataFile", path);
    return VM_OK;
}

/* MetaIO element type name → volmesh scalar type; VM_ERR_FORMAT for an unknown name. */
static vm_status map_type(const char *name, vm_scalar_type *t) {
    static const struct {
        const char *name;
        vm_scalar_type type;
    } table[] = {{"MET_UCHAR", VM_SCALAR_UINT8},       {"MET_CHAR", VM_SCALAR_INT8},
                 {"MET_USHORT", VM_SCALAR_UINT16},     {"MET_SHORT", VM_SCALAR_INT16},
                 {"MET_UINT", VM_SCALAR_UINT32},       {"MET_INT", VM_SCALAR_INT32},
                 {"MET_ULONG_LONG", VM_SCALAR_UINT64}, {"MET_LONG_LONG", VM_SCALAR_INT64},
                 {"MET_FLOAT", VM_SCALAR_FLOAT32},     {"MET_DOUBLE", VM_SCALAR_FLOAT64}};
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++) {
        if (strcasecmp(name, table[i].name) == 0) {
            *t = table[i].type;
            return VM_OK;
        }
    }
    return VM_ERR_FORMAT;
}

/* Validates the header and fills everything of v except data. */
static vm_status check_header(const char *path, const meta_hdr *h, vm_scalar_type *type,
                              int64_t dims[3], vm_volume *geo, vm_error *err) {
    if (h->object_type[0] && strcasecmp(h->object_type, "Image") != 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: ObjectType '%s' is not supported "
                            "(only Image)", path, h->object_type);
    if (!h->has_ndims) return vm_error_set(err, VM_ERR_FORMAT, "%s: header has no NDims", path);
    if (h->ndims != 3)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: NDims is %d; only 3-D images are "
                            "supported", path, h->ndims);
    if (h->n_dimsize != 3)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: DimSize must hold 3 sizes", path);
    for (int a = 0; a < 3; a++) {
        double d = h->dimsize[a];
        if (!(d >= 1.0) || d != floor(d) || d > 9.0e18)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: DimSize %g is not a positive integer",
                                path, d);
        dims[a] = (int64_t)d;
    }
    if (!h->element_type[0])
        return vm_error_set(err, VM_ERR_FORMAT, "%s: header has no ElementType", path);
    if (map_type(h->element_type, type) != VM_OK)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: ElementType %s is not supported "
                            "(MET_UCHAR, MET_CHAR, MET_USHORT, MET_SHORT, MET_UINT, MET_INT, "
                            "MET_ULONG_LONG, MET_LONG_LONG, MET_FLOAT, MET_DOUBLE)", path,
                            h->element_type);
    if (h->channels != 1)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: ElementNumberOfChannels must be 1 "
                            "(vector images are not supported)", path);
    if (!h->binary)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: BinaryData = False (ASCII samples) "
                            "is not supported", path);

    const double *sp = h->n_spacing ? h->spacing : h->n_size ? h->size : NULL;
    for (int a = 0; a < 3; a++) {
        double s = sp ? sp[a] : 1.0;
        if (!(s > 0.0))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %s %g must be positive", path,
                                h->n_spacing ? "ElementSpacing" : "ElementSize", s);
        geo->spacing[a] = s;
        geo->origin[a] = h->n_offset ? h->offset[a] : 0.0;
    }
    /* ITK's MetaImageIO reads numbers 3i..3i+2 of TransformMatrix as the world direction of
     * index axis i, i.e. as column i of D (and writes them the same way): the 9 numbers are
     * D's columns one after another, which is D transposed when read row by row. */
    for (int c = 0; c < 3; c++) {
        double col[3], n = 0.0;
        for (int r = 0; r < 3; r++) {
            col[r] = h->n_matrix ? h->matrix[3 * c + r] : (r == c ? 1.0 : 0.0);
            n += col[r] * col[r];
        }
        n = sqrt(n);
        if (!(n > 0.0) || !isfinite(n))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: TransformMatrix has a zero axis %d",
                                path, c);
        for (int r = 0; r < 3; r++) geo->direction[r][c] = col[r] / n;
    }
    return VM_OK;
}

/* True when the ElementDataFile value names a list or a numbered series of slice files. */
static int is_file_series(const char *name) {
    if (strcasecmp(name, "LIST") == 0 || strncasecmp(name, "LIST ", 5) == 0) return 1;
    return strchr(name, '%') != NULL;
}

static vm_status read_metaimage(const char *path, const vm__slab *rq, vm_volume *v,
                                vm_error *err) {
    memset(v, 0, sizeof *v);
    vm__map hm, dm;
    memset(&dm, 0, sizeof dm);
    vm_status st = vm__map_file(path, (size_t)-1, &hm, err);
    if (st) return st;
    unsigned char *hbuf = hm.p;
    size_t hlen = hm.len, dlen = 0;
    if (hlen == 0) {
        vm__map_free(&hm);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: file is empty", path);
    }

    meta_hdr h;
    vm_volume geo;
    vm_scalar_type type = VM_SCALAR_UINT8;
    int64_t dims[3];
    memset(&geo, 0, sizeof geo);
    st = parse_header(path, hbuf, hlen, &h, err);
    if (!st) st = check_header(path, &h, &type, dims, &geo, err);
    if (st) goto done;
    size_t esize = vm_scalar_type_size(type), count, first, n;
    st = vm__slab_check(path, rq, dims, esize, &count, &first, &n, err);
    if (st) goto done;
    size_t bytes = count * esize; /* checked by vm__check_dims */

    const unsigned char *data;
    size_t avail, start;
    /* LOCAL samples start right after the ElementDataFile line; a positive HeaderSize only
     * skips bytes at the start of a detached data file, and -1 means "the last bytes". */
    int local = strcasecmp(h.data_file, "LOCAL") == 0;
    if (local) {
        data = hbuf;
        avail = hlen;
        start = h.data_start;
    } else {
        if (is_file_series(h.data_file)) {
            st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: ElementDataFile '%.200s' is a list "
                              "or numbered series of files, which is not supported", path,
                              h.data_file);
            goto done;
        }
        if (!h.data_file[0]) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: ElementDataFile is empty", path);
            goto done;
        }
        char dpath[4200];
        if (!vm__path_sibling(path, h.data_file, dpath, sizeof dpath)) {
            st = vm_error_set(err, VM_ERR_IO, "%s: data file path is too long", path);
            goto done;
        }
        vm_error inner;
        vm_error_clear(&inner);
        st = vm__map_file(dpath, (size_t)-1, &dm, &inner);
        dlen = dm.len;
        if (st) {
            st = vm_error_set(err, st, "%s: data file %s", path, inner.message);
            goto done;
        }
        data = dm.p;
        avail = dlen;
        start = 0;
        if (h.has_header_size && h.header_size > 0) {
            if (h.header_size > (double)avail) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: HeaderSize %.0f is larger than the "
                                  "%zu-byte data file", path, h.header_size, avail);
                goto done;
            }
            start = (size_t)h.header_size;
        }
    }

    vm__samples src = {path, NULL, 0, VM__ENC_RAW, 0, type, h.msb == vm__host_little_endian(),
                       (local ? hm.maplen : dm.maplen) != 0, 0};
    if (h.compressed) {
        size_t clen = avail - start;
        if (h.has_csize) {
            if (h.csize > (double)clen) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: CompressedDataSize %.0f is larger "
                                  "than the %zu bytes of data present", path, h.csize, clen);
                goto done;
            }
            /* A smaller CompressedDataSize does not cut the stream short: some writers store
             * a wrong value (VTK's frogtissue.mhd says 260020 for a 262087-byte stream) and
             * MetaIO readers still read them; the zlib stream marks its own end. */
            if (h.has_header_size && h.header_size == -1) {
                start = avail - (size_t)h.csize;
                clen = (size_t)h.csize;
            }
        } else if (h.has_header_size && h.header_size == -1) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: HeaderSize = -1 with compressed data "
                              "needs CompressedDataSize", path);
            goto done;
        }
        src.enc = VM__ENC_ZLIB;
        src.count = count;
        src.p = data + start;
        src.avail = clen;
    } else {
        if (h.has_header_size && h.header_size == -1) {
            if (avail < bytes) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu "
                                  "bytes)", path, avail, bytes);
                goto done;
            }
            start = avail - bytes;
        }
        if (avail - start < bytes) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu bytes)",
                              path, avail - start, bytes);
            goto done;
        }
        src.p = data + start;
        src.avail = avail - start;
    }
    vm__volume_set_header(v, dims, type, geo.spacing, geo.origin,
                          (const double(*)[3])geo.direction, "metaimage");
    st = vm__slab_read(path, rq, &src, first, n, v, err);
    if (!st) vm__slab_finish(v, rq);

done:
    vm__map_free(&hm);
    vm__map_free(&dm);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_metaimage(const char *path, vm_volume *v, vm_error *err) {
    return read_metaimage(path, &vm__slab_whole, v, err);
}

vm_status vm__read_metaimage(const char *path, const vm__slab *rq, vm_volume *v,
                             vm_error *err) {
    return read_metaimage(path, rq, v, err);
}
