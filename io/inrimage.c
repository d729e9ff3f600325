/* SPDX-License-Identifier: BSD-3-Clause */
/* io/inrimage.c — INRIMAGE-4 volume reader (.inr, and .inr.gz: the whole file gzipped), the
 * format of CGAL and MedInria. Follows the INRIMAGE-4 header as Inria's Inrimage library
 * writes it: "#INRIMAGE-4#{" then KEY=VALUE lines (XDIM YDIM ZDIM VDIM TYPE PIXSIZE SCALE CPU
 * VX VY VZ), '#' comment lines, newlines padding the header to a multiple of 256 bytes, the
 * line "##}", then the samples, x fastest. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

enum {
    INR_BLOCK = 256,            /* the header is padded to a multiple of this */
    INR_HEADER_MAX = 64 * 1024  /* a longer header is refused (every writer uses 256) */
};
#define INR_MAGIC "#INRIMAGE-4#{"
/* Deflate cannot compress better than about 1032:1 (as in io/nrrd.c). */
#define GZIP_MAX_RATIO 1040u

/* The header fields, as read. */
typedef struct inr_hdr {
    long long dim[4];     /* XDIM YDIM ZDIM VDIM; 0: absent */
    char type[32];        /* "unsigned fixed", "signed fixed", "float" */
    long long pixsize;    /* bits per sample; 0: absent */
    char cpu[16];         /* decm alpha pc (little endian), sun sgi (big endian) */
    double spacing[3];    /* VX VY VZ; default 1 */
    size_t header_len;    /* bytes before the samples */
} inr_hdr;

/* A whole number from s to the end (spaces allowed after), or -1. */
static long long whole(const char *s) {
    char *end;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    while (*end == ' ' || *end == '\t') end++;
    if (end == s || *end || errno == ERANGE || v < 0) return -1;
    return v;
}

/* One KEY=VALUE line (NUL-terminated, value trimmed) into h. */
static vm_status header_line(const char *path, char *line, inr_hdr *h, vm_error *err) {
    char *eq = strchr(line, '=');
    if (!eq) return VM_OK; /* a blank or free-text line */
    *eq = 0;
    char *key = vm__trim(line), *val = vm__trim(eq + 1);
    static const char *const dims[4] = {"XDIM", "YDIM", "ZDIM", "VDIM"};
    for (int a = 0; a < 4; a++) {
        if (strcmp(key, dims[a]) != 0) continue;
        h->dim[a] = whole(val);
        if (h->dim[a] < 1)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %s=%s is not a positive whole number",
                                path, key, val);
        return VM_OK;
    }
    static const char *const vs[3] = {"VX", "VY", "VZ"};
    for (int a = 0; a < 3; a++) {
        if (strcmp(key, vs[a]) != 0) continue;
        char *end;
        double s = strtod(val, &end);
        if (end == val || *vm__trim(end) || !vm__spacing_in_range(s))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: %s=%s is not a spacing (a number from "
                                "%g to %g)", path, key, val, VM_SPACING_MIN, VM_SPACING_MAX);
        h->spacing[a] = s;
        return VM_OK;
    }
    if (strcmp(key, "TYPE") == 0) {
        snprintf(h->type, sizeof h->type, "%s", val);
    } else if (strcmp(key, "PIXSIZE") == 0) {
        /* "16 bits" */
        char *end;
        long long bits = strtoll(val, &end, 10);
        if (end == val || strcmp(vm__trim(end), "bits") != 0)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: PIXSIZE=%s is not 'N bits'", path,
                                val);
        h->pixsize = bits;
    } else if (strcmp(key, "CPU") == 0) {
        snprintf(h->cpu, sizeof h->cpu, "%s", val);
    } else if (strcmp(key, "SCALE") == 0) {
        /* "2**0": the fixed-point scale, which CGAL and ITK do not apply either */
    }
    return VM_OK;
}

/* Parses the header at the start of p (n bytes available): [out] h. */
static vm_status parse_header(const char *path, const unsigned char *p, size_t n, inr_hdr *h,
                              vm_error *err) {
    memset(h, 0, sizeof *h);
    h->spacing[0] = h->spacing[1] = h->spacing[2] = 1.0;
    size_t ml = strlen(INR_MAGIC);
    if (n < ml || memcmp(p, INR_MAGIC, ml) != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: not an INRIMAGE-4 file (no '%s' at its "
                            "start)", path, INR_MAGIC);
    size_t pos = ml, end = 0;
    char line[256];
    while (pos < n && pos < INR_HEADER_MAX) {
        size_t len = 0;
        while (pos + len < n && p[pos + len] != '\n') len++;
        if (pos + len >= n) break; /* no newline: the header is cut */
        if (len >= 3 && memcmp(p + pos, "##}", 3) == 0) {
            end = pos + len + 1;
            break;
        }
        if (len > 0 && p[pos] != '#') {
            if (len >= sizeof line)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: header line of %zu bytes is too "
                                    "long", path, len);
            memcpy(line, p + pos, len);
            line[len] = 0;
            vm_status st = header_line(path, line, h, err);
            if (st) return st;
        }
        pos += len + 1;
    }
    if (!end)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: header has no '##}' line %s", path,
                            pos >= INR_HEADER_MAX ? "in its first 64 KiB" : "(file cut short)");
    if (end % INR_BLOCK != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: header of %zu bytes is not a multiple of "
                            "%d bytes", path, end, INR_BLOCK);
    h->header_len = end;
    return VM_OK;
}

/* The sample type and byte order the header states. */
static vm_status sample_type(const char *path, const inr_hdr *h, vm_scalar_type *t, int *big,
                             vm_error *err) {
    static const char *const keys[3] = {"XDIM", "YDIM", "ZDIM"};
    for (int a = 0; a < 3; a++)
        if (h->dim[a] < 1)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: header has no %s", path, keys[a]);
    if (h->dim[3] > 1)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: VDIM=%lld (vector samples); only "
                            "scalar volumes (VDIM=1) are read", path, h->dim[3]);
    int fl = strcmp(h->type, "float") == 0, un = strcmp(h->type, "unsigned fixed") == 0;
    int sg = strcmp(h->type, "signed fixed") == 0;
    if (!fl && !un && !sg)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: TYPE=%s is not 'unsigned fixed', 'signed "
                            "fixed' or 'float'", path, h->type[0] ? h->type : "(absent)");
    long long b = h->pixsize;
    if (fl && (b == 32 || b == 64))
        *t = b == 32 ? VM_SCALAR_FLOAT32 : VM_SCALAR_FLOAT64;
    else if (!fl && b == 8)
        *t = un ? VM_SCALAR_UINT8 : VM_SCALAR_INT8;
    else if (!fl && b == 16)
        *t = un ? VM_SCALAR_UINT16 : VM_SCALAR_INT16;
    else if (!fl && b == 32)
        *t = un ? VM_SCALAR_UINT32 : VM_SCALAR_INT32;
    else if (!fl && b == 64)
        *t = un ? VM_SCALAR_UINT64 : VM_SCALAR_INT64;
    else
        return vm_error_set(err, VM_ERR_FORMAT, "%s: PIXSIZE=%lld bits does not fit TYPE=%s "
                            "(fixed: 8, 16, 32, 64; float: 32, 64)", path, b, h->type);
    if (!h->cpu[0] || strcmp(h->cpu, "decm") == 0 || strcmp(h->cpu, "alpha") == 0 ||
        strcmp(h->cpu, "pc") == 0)
        *big = 0;
    else if (strcmp(h->cpu, "sun") == 0 || strcmp(h->cpu, "sgi") == 0)
        *big = 1;
    else
        return vm_error_set(err, VM_ERR_FORMAT, "%s: CPU=%s is not decm, alpha, pc, sun or sgi",
                            path, h->cpu);
    return VM_OK;
}

static int is_gzip(const vm__map *m) { return m->len >= 2 && m->p[0] == 0x1f && m->p[1] == 0x8b; }

vm_status vm__read_inrimage(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    vm__map m;
    vm_status st = vm__map_file(path, (size_t)-1, &m, err);
    if (st) return st;
    unsigned char *pre = NULL;
    const unsigned char *hp = m.p;
    size_t hn = m.len;
    int gz = is_gzip(&m);
    if (gz) {
        pre = malloc(INR_HEADER_MAX);
        st = pre ? vm__gz_prefix(path, m.p, m.len, pre, INR_HEADER_MAX, &hn, err)
                 : vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
        hp = pre;
    }
    inr_hdr h;
    vm_scalar_type type = VM_SCALAR_UINT8;
    int big = 0;
    if (!st) st = parse_header(path, hp, hn, &h, err);
    if (!st) st = sample_type(path, &h, &type, &big, err);
    free(pre);
    size_t count = 0, first = 0, n = 0, tsize = vm_scalar_type_size(type);
    int64_t dims[3] = {h.dim[0], h.dim[1], h.dim[2]};
    if (!st) st = vm__slab_check(path, rq, dims, tsize, &count, &first, &n, err);
    if (st) {
        vm__map_free(&m);
        return st;
    }
    size_t bytes = count * tsize; /* checked by vm__slab_check */
    int swap = tsize > 1 && big == (vm__host_little_endian() != 0);
    vm__samples src = {path, m.p + h.header_len, 0, VM__ENC_RAW, 0, type, swap, m.maplen != 0, 0};
    if (gz) {
        src.p = m.p, src.avail = m.len, src.enc = VM__ENC_ZLIB, src.skip = h.header_len;
        /* the stream's trailer is checked when the read reaches its last sample */
        src.count = count;
        if ((h.header_len + bytes) / GZIP_MAX_RATIO > m.len + 64)
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (%zu compressed bytes "
                              "cannot hold %zu bytes of samples)", path, m.len, bytes);
    } else if (m.len - h.header_len < bytes) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of the %zu bytes "
                          "that %lldx%lldx%lld samples of %zu bytes need)", path,
                          m.len - h.header_len, bytes, h.dim[0], h.dim[1], h.dim[2], tsize);
    } else {
        src.avail = m.len - h.header_len;
    }
    if (!st) {
        const double origin[3] = {0, 0, 0}, dir[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        vm__volume_set_header(v, dims, type, h.spacing, origin, dir, "inrimage");
        st = vm__slab_read(path, rq, &src, first, n, v, err);
    }
    if (!st) vm__slab_finish(v, rq);
    vm__map_free(&m);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_inrimage(const char *path, vm_volume *v, vm_error *err) {
    return vm__read_inrimage(path, &vm__slab_whole, v, err);
}
