/* SPDX-License-Identifier: BSD-3-Clause */
/* io/vti.c — reads VTK XML ImageData (.vti): one piece, one scalar point-data array, in ascii,
 * inline base64 or appended (raw or base64) form, optionally zlib-compressed in blocks.
 * Follows "VTK File Formats", section "XML File Formats" (VTKFile attributes, DataArray
 * formats, the [nblocks][blocksize][lastsize][csizes...] compression header). */
#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

/* ---- a small tokenizer for the few elements and attributes of an ImageData file ---- */

typedef struct span {
    const char *p;
    size_t n;
} span;

#define MAX_ATTRS 24

typedef struct tag {
    span name;
    int closing, self_closing;
    int nattr;
    span attr_name[MAX_ATTRS], attr_value[MAX_ATTRS];
    size_t end; /* offset just past '>' */
} tag;

static int span_is(span s, const char *lit) {
    size_t k = strlen(lit);
    return s.n == k && memcmp(s.p, lit, k) == 0;
}

static int span_eq(span a, span b) { return a.n == b.n && memcmp(a.p, b.p, a.n) == 0; }

static const span *tag_attr(const tag *t, const char *name) {
    for (int i = 0; i < t->nattr; i++)
        if (span_is(t->attr_name[i], name)) return &t->attr_value[i];
    return NULL;
}

/* Copies s into a NUL-terminated buffer; returns 0 when it does not fit. */
static int span_copy(span s, char *out, size_t cap) {
    if (s.n >= cap) return 0;
    memcpy(out, s.p, s.n);
    out[s.n] = 0;
    return 1;
}

/* A file-supplied string made safe for a one-line message: at most 60 characters, control
 * characters shown as '?'. */
typedef struct shown {
    char s[64];
} shown;

static shown show(span v) {
    shown out;
    size_t n = v.n > 60 ? 60 : v.n;
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)v.p[i];
        out.s[i] = c < 0x20 || c == 0x7f ? '?' : (char)c;
    }
    out.s[n] = 0;
    return out;
}

/* In place: white space becomes ' ' (a separator in number lists), other control
 * characters '?', so that the text can be parsed and quoted in a one-line message. */
static char *sanitize(char *text) {
    for (char *c = text; *c; c++) {
        if (isspace((unsigned char)*c))
            *c = ' ';
        else if ((unsigned char)*c < 0x20 || *c == 0x7f)
            *c = '?';
    }
    return text;
}

static int name_char(int c) {
    return isalnum(c) || c == '_' || c == ':' || c == '-' || c == '.';
}

/* Skips a construct starting at pos that ends with term; returns 0 if unterminated. */
static int skip_past(const char *b, size_t len, size_t *pos, const char *term) {
    size_t k = strlen(term);
    for (size_t i = *pos; i + k <= len; i++)
        if (memcmp(b + i, term, k) == 0) {
            *pos = i + k;
            return 1;
        }
    return 0;
}

/* Reads the next element tag at or after *pos (comments, declarations and text skipped).
 * Returns 1 for a tag, 0 at the end of the input, -1 for a malformed tag (*pos at it). */
static int next_tag(const char *b, size_t len, size_t *pos, tag *t) {
    for (;;) {
        const char *lt = *pos < len ? memchr(b + *pos, '<', len - *pos) : NULL;
        if (!lt) return 0;
        size_t p = (size_t)(lt - b);
        *pos = p;
        if (len - p >= 4 && memcmp(lt, "<!--", 4) == 0) {
            if (!skip_past(b, len, pos, "-->")) return -1;
            continue;
        }
        if (len - p >= 2 && (lt[1] == '?' || lt[1] == '!')) {
            if (!skip_past(b, len, pos, lt[1] == '?' ? "?>" : ">")) return -1;
            continue;
        }
        memset(t, 0, sizeof *t);
        p++;
        if (p < len && b[p] == '/') {
            t->closing = 1;
            p++;
        }
        size_t start = p;
        while (p < len && name_char((unsigned char)b[p])) p++;
        if (p == start) return -1;
        t->name = (span){b + start, p - start};
        for (;;) {
            while (p < len && isspace((unsigned char)b[p])) p++;
            if (p >= len) return -1;
            if (b[p] == '>') {
                t->end = p + 1;
                return 1;
            }
            if (b[p] == '/' && p + 1 < len && b[p + 1] == '>') {
                t->self_closing = 1;
                t->end = p + 2;
                return 1;
            }
            size_t an = p;
            while (p < len && name_char((unsigned char)b[p])) p++;
            if (p == an) return -1;
            span aname = {b + an, p - an};
            while (p < len && isspace((unsigned char)b[p])) p++;
            if (p >= len || b[p] != '=') return -1;
            p++;
            while (p < len && isspace((unsigned char)b[p])) p++;
            if (p >= len || (b[p] != '"' && b[p] != '\'')) return -1;
            char q = b[p++];
            const char *close = memchr(b + p, q, len - p);
            if (!close) return -1;
            if (t->nattr < MAX_ATTRS) {
                t->attr_name[t->nattr] = aname;
                t->attr_value[t->nattr] = (span){b + p, (size_t)(close - (b + p))};
                t->nattr++;
            }
            p = (size_t)(close - b) + 1;
        }
    }
}

/* ---- base64: concatenated streams (each may end with '=' padding) decode back to back,
 * which is how VTK writes a compressed array's header and its blocks ---- */

/* Decodes s up to its end or the first '<'. [out] *out (malloc'd), *out_len.
 * VM_ERR_FORMAT for an invalid character or padding (*bad_at = its offset), VM_ERR_NOMEM
 * when out of memory (the caller writes the message). */
static vm_status b64_decode(span s, unsigned char **out, size_t *out_len, size_t *bad_at) {
    unsigned char *o = malloc(s.n / 4 * 3 + 4);
    if (!o) return VM_ERR_NOMEM;
    size_t n = 0;
    int quad[4], q = 0, pad = 0;
    size_t i;
    for (i = 0; i < s.n; i++) {
        int c = (unsigned char)s.p[i];
        if (c == '<') break;
        if (isspace(c)) continue;
        if (c == '=') {
            if (q < 2) goto bad;
            pad++;
            if (q + pad == 4) {
                o[n++] = (unsigned char)(quad[0] << 2 | quad[1] >> 4);
                if (q == 3) o[n++] = (unsigned char)((quad[1] & 15) << 4 | quad[2] >> 2);
                q = pad = 0;
            }
            continue;
        }
        int val = vm__base64_value(c);
        if (val < 0 || pad) goto bad;
        quad[q++] = val;
        if (q == 4) {
            o[n++] = (unsigned char)(quad[0] << 2 | quad[1] >> 4);
            o[n++] = (unsigned char)((quad[1] & 15) << 4 | quad[2] >> 2);
            o[n++] = (unsigned char)((quad[2] & 3) << 6 | quad[3]);
            q = 0;
        }
    }
    if (pad || q == 1) goto bad;
    /* An unpadded tail: keep its whole bytes. */
    if (q >= 2) o[n++] = (unsigned char)(quad[0] << 2 | quad[1] >> 4);
    if (q == 3) o[n++] = (unsigned char)((quad[1] & 15) << 4 | quad[2] >> 2);
    *out = o;
    *out_len = n;
    return VM_OK;
bad:
    free(o);
    *bad_at = i;
    return VM_ERR_FORMAT;
}

/* ---- the file ---- */

typedef struct array_info {
    span name, type, format;
    int64_t ncomp;
    int has_offset;
    uint64_t offset;
    span content; /* text between <DataArray ...> and the next '<' */
} array_info;

typedef struct vti_file {
    const char *path;
    const char *buf;
    size_t len;
    vm_error *err;
    int big_endian, header_size, compressed;
    int64_t extent[6];
    int have_extent, have_whole;
    int64_t whole[6];
    double origin[3], spacing[3], direction[3][3];
    int pieces;
    span scalars; /* PointData Scalars="" (n == 0 when absent) */
    int have_scalars;
    array_info arrays[64];
    int narrays;
    int have_appended, appended_base64;
    size_t appended_start; /* first byte after '_' */
    const vm__slab *rq;
    int mapped; /* buf is a vm__map's mapping (pages may be given back) */
} vti_file;

static vm_status parse_extent(vti_file *f, span s, const char *what, int64_t e[6]) {
    char text[256];
    if (!span_copy(s, text, sizeof text))
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s is too long", f->path, what);
    sanitize(text);
    char *p = text;
    for (int i = 0; i < 6; i++) {
        char *end;
        errno = 0;
        long long v = strtoll(p, &end, 10);
        if (end == p || errno == ERANGE || v < -(1LL << 40) || v > (1LL << 40))
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s \"%s\" is not 6 whole numbers",
                                f->path, what, text);
        e[i] = v;
        p = end;
    }
    if (*vm__trim(p))
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s \"%s\" is not 6 whole numbers",
                            f->path, what, text);
    for (int a = 0; a < 3; a++)
        if (e[2 * a + 1] < e[2 * a])
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s \"%s\" is empty along axis %d",
                                f->path, what, text, a);
    return VM_OK;
}

static vm_status parse_numbers(vti_file *f, span s, const char *what, double *out, int count) {
    char text[1024];
    if (!span_copy(s, text, sizeof text))
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s is too long", f->path, what);
    sanitize(text);
    if (vm__parse_doubles(text, out, count) != count)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s \"%.80s\" is not %d numbers",
                            f->path, what, text, count);
    for (int i = 0; i < count; i++)
        if (!(out[i] - out[i] == 0.0))
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: %s \"%.80s\" is not finite",
                                f->path, what, text);
    return VM_OK;
}

static vm_status file_attrs(vti_file *f, const tag *t) {
    const span *s;
    if (!(s = tag_attr(t, "type")) || !span_is(*s, "ImageData")) {
        return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: VTKFile type is '%s' (only "
                            "ImageData is read)", f->path, s ? show(*s).s : "");
    }
    f->big_endian = 0;
    if ((s = tag_attr(t, "byte_order"))) {
        if (span_is(*s, "BigEndian"))
            f->big_endian = 1;
        else if (!span_is(*s, "LittleEndian"))
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: byte_order '%s' is not "
                                "LittleEndian or BigEndian", f->path, show(*s).s);
    }
    f->header_size = 4;
    if ((s = tag_attr(t, "header_type"))) {
        if (span_is(*s, "UInt64"))
            f->header_size = 8;
        else if (!span_is(*s, "UInt32"))
            return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: header_type '%s' is not "
                                "UInt32 or UInt64", f->path, show(*s).s);
    }
    if ((s = tag_attr(t, "compressor"))) {
        if (span_is(*s, "vtkZLibDataCompressor"))
            f->compressed = 1;
        else if (s->n)
            return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: compressor '%s' is not "
                                "supported (only vtkZLibDataCompressor)", f->path,
                                show(*s).s);
    }
    return VM_OK;
}

static vm_status image_attrs(vti_file *f, const tag *t) {
    const span *s;
    vm_status st;
    if ((s = tag_attr(t, "WholeExtent"))) {
        if ((st = parse_extent(f, *s, "WholeExtent", f->whole))) return st;
        f->have_whole = 1;
    }
    if ((s = tag_attr(t, "Origin")) && (st = parse_numbers(f, *s, "Origin", f->origin, 3)))
        return st;
    if ((s = tag_attr(t, "Spacing")) && (st = parse_numbers(f, *s, "Spacing", f->spacing, 3)))
        return st;
    if ((s = tag_attr(t, "Direction"))) {
        double d[9];
        if ((st = parse_numbers(f, *s, "Direction", d, 9))) return st;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) f->direction[r][c] = d[3 * r + c];
    }
    return VM_OK;
}

static vm_status array_attrs(vti_file *f, const tag *t, array_info *a) {
    const span *s;
    memset(a, 0, sizeof *a);
    a->ncomp = 1;
    if ((s = tag_attr(t, "Name"))) a->name = *s;
    if ((s = tag_attr(t, "type"))) a->type = *s;
    if ((s = tag_attr(t, "format"))) a->format = *s;
    if ((s = tag_attr(t, "NumberOfComponents"))) {
        char text[32], *end;
        if (!span_copy(*s, text, sizeof text) || (a->ncomp = strtoll(text, &end, 10)) < 1 ||
            *vm__trim(end))
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: DataArray NumberOfComponents "
                                "\"%s\" is not a positive whole number", f->path,
                                show(*s).s);
    }
    if ((s = tag_attr(t, "offset"))) {
        char text[32], *end;
        errno = 0;
        if (!span_copy(*s, text, sizeof text) || text[0] == '-' ||
            (a->offset = strtoull(text, &end, 10), end == text) || errno == ERANGE ||
            *vm__trim(end))
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: DataArray offset \"%s\" is not a "
                                "whole number", f->path, show(*s).s);
        a->has_offset = 1;
    }
    if (!t->self_closing) {
        const char *lt = memchr(f->buf + t->end, '<', f->len - t->end);
        size_t stop = lt ? (size_t)(lt - f->buf) : f->len;
        a->content = (span){f->buf + t->end, stop - t->end};
    }
    return VM_OK;
}

/* Walks the tags up to <AppendedData> (whose raw bytes may hold anything) or the end. */
static vm_status scan(vti_file *f) {
    size_t pos = 0;
    tag t;
    int r, seen_file = 0, in_points = 0, depth_cell = 0;
    while ((r = next_tag(f->buf, f->len, &pos, &t)) > 0) {
        pos = t.end;
        if (!seen_file) {
            if (t.closing || !span_is(t.name, "VTKFile"))
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: not a VTK XML file (first "
                                    "element is not <VTKFile>)", f->path);
            seen_file = 1;
            vm_status st = file_attrs(f, &t);
            if (st) return st;
            continue;
        }
        if (span_is(t.name, "ImageData") && !t.closing) {
            vm_status st = image_attrs(f, &t);
            if (st) return st;
        } else if (span_is(t.name, "Piece") && !t.closing) {
            if (++f->pieces > 1) continue;
            const span *s = tag_attr(&t, "Extent");
            if (s) {
                vm_status st = parse_extent(f, *s, "Piece Extent", f->extent);
                if (st) return st;
                f->have_extent = 1;
            }
        } else if (span_is(t.name, "PointData")) {
            in_points = !t.closing && !t.self_closing && f->pieces == 1;
            const span *s = tag_attr(&t, "Scalars");
            if (in_points && s) {
                f->scalars = *s;
                f->have_scalars = 1;
            }
        } else if (span_is(t.name, "CellData") || span_is(t.name, "FieldData")) {
            depth_cell = !t.closing && !t.self_closing;
        } else if (span_is(t.name, "DataArray") && !t.closing && in_points && !depth_cell) {
            if (f->narrays == (int)(sizeof f->arrays / sizeof f->arrays[0])) continue;
            vm_status st = array_attrs(f, &t, &f->arrays[f->narrays]);
            if (st) return st;
            f->narrays++;
        } else if (span_is(t.name, "AppendedData") && !t.closing) {
            const span *s = tag_attr(&t, "encoding");
            if (!s || span_is(*s, "raw"))
                f->appended_base64 = 0;
            else if (span_is(*s, "base64"))
                f->appended_base64 = 1;
            else
                return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: AppendedData encoding "
                                    "'%s' is not raw or base64", f->path,
                                    show(*s).s);
            size_t p = t.end;
            while (p < f->len && isspace((unsigned char)f->buf[p])) p++;
            if (p >= f->len || f->buf[p] != '_')
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: AppendedData does not start "
                                    "with '_'", f->path);
            f->have_appended = 1;
            f->appended_start = p + 1;
            return VM_OK;
        }
    }
    if (r < 0)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: malformed XML tag at byte %zu", f->path,
                            pos);
    if (!seen_file)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: not a VTK XML file (no <VTKFile> "
                            "element)", f->path);
    return VM_OK;
}

static int parse_array_type(span s, vm_scalar_type *t) {
    static const struct {
        const char *name;
        vm_scalar_type type;
    } names[] = {{"Int8", VM_SCALAR_INT8},       {"UInt8", VM_SCALAR_UINT8},
                 {"Int16", VM_SCALAR_INT16},     {"UInt16", VM_SCALAR_UINT16},
                 {"Int32", VM_SCALAR_INT32},     {"UInt32", VM_SCALAR_UINT32},
                 {"Int64", VM_SCALAR_INT64},     {"UInt64", VM_SCALAR_UINT64},
                 {"Float32", VM_SCALAR_FLOAT32}, {"Float64", VM_SCALAR_FLOAT64}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (span_is(s, names[i].name)) {
            *t = names[i].type;
            return 1;
        }
    return 0;
}

static uint64_t read_uint(const unsigned char *p, int size, int big_endian) {
    uint64_t v = 0;
    for (int i = 0; i < size; i++) v = v << 8 | p[big_endian ? i : size - 1 - i];
    return v;
}

/* Decodes a header-prefixed payload (uncompressed: [nbytes] data; compressed: [nblocks]
 * [blocksize][lastsize][csize...] blocks) into need bytes at dst. */
static vm_status decode_payload(vti_file *f, const unsigned char *b, size_t blen,
                                unsigned char *dst, size_t need) {
    const char *path = f->path;
    int hs = f->header_size;
    if (!f->compressed) {
        if (blen < (size_t)hs)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (no size "
                                "header)", path);
        uint64_t nbytes = read_uint(b, hs, f->big_endian);
        if (nbytes != need)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data header says %llu bytes, the "
                                "extent and type need %zu", path, (unsigned long long)nbytes,
                                need);
        if (blen - hs < need)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu "
                                "bytes)", path, blen - hs, need);
        memcpy(dst, b + hs, need);
        return VM_OK;
    }
    if (blen < 3 * (size_t)hs)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: compression header is truncated", path);
    uint64_t nb = read_uint(b, hs, f->big_endian), bs = read_uint(b + hs, hs, f->big_endian),
             last = read_uint(b + 2 * hs, hs, f->big_endian);
    if (nb == 0 || bs == 0 || last > bs)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: compression header is inconsistent "
                            "(%llu blocks of %llu bytes, last %llu)", path,
                            (unsigned long long)nb, (unsigned long long)bs,
                            (unsigned long long)last);
    if (nb > blen / (size_t)hs - 3)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: compression header lists %llu blocks "
                            "but the data holds only %zu bytes", path, (unsigned long long)nb,
                            blen);
    uint64_t lastsize = last ? last : bs;
    if ((nb - 1) > (UINT64_MAX - lastsize) / bs || (nb - 1) * bs + lastsize != (uint64_t)need)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: compression header describes %llu "
                            "blocks of %llu bytes (last %llu), the extent and type need %zu "
                            "bytes", path, (unsigned long long)nb, (unsigned long long)bs,
                            (unsigned long long)lastsize, need);
    size_t at = (3 + (size_t)nb) * (size_t)hs, out = 0;
    for (uint64_t k = 0; k < nb; k++) {
        uint64_t cs = read_uint(b + (3 + k) * (size_t)hs, hs, f->big_endian);
        if (cs > blen - at)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: compressed block %llu of %llu "
                                "bytes is truncated (%zu bytes left)", path,
                                (unsigned long long)k, (unsigned long long)cs, blen - at);
        size_t us = (size_t)(k + 1 == nb ? lastsize : bs);
        vm_status st = vm__inflate_exact(path, b + at, (size_t)cs, dst + out, us, f->err);
        if (st) return st;
        at += (size_t)cs;
        out += us;
    }
    return VM_OK;
}

static vm_status read_ascii(vti_file *f, span s, size_t n, float *dst) {
    size_t p = 0;
    for (size_t i = 0; i < n; i++) {
        while (p < s.n && isspace((unsigned char)s.p[p])) p++;
        if (p >= s.n)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: ascii data is truncated (got %zu "
                                "of %zu values)", f->path, i, n);
        size_t start = p;
        while (p < s.n && !isspace((unsigned char)s.p[p])) p++;
        char text[64], *end;
        if (!span_copy((span){s.p + start, p - start}, text, sizeof text) ||
            (dst[i] = (float)strtod(text, &end), end == text) || *end)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: ascii value %zu ('%s') is not a "
                                "number", f->path, i, show((span){s.p + start, p - start}).s);
    }
    return VM_OK;
}

/* Deflate's largest ratio (RFC 1951: a 258-byte match in under 2 bits; 1032:1), rounded up. */
#define DEFLATE_MAX_RATIO 1040u

/* Refuses, before the samples are allocated, an array whose bytes in the file cannot hold
 * need bytes of samples (ascii: a digit and a separator each; base64: 3 bytes per 4
 * characters; compressed: deflate's largest ratio), so that a truncated file reads as one
 * and not as a lack of memory. */
static vm_status check_room(const vti_file *f, const array_info *a, size_t count, size_t need) {
    size_t have;
    if (span_is(a->format, "ascii")) {
        size_t words = vm__count_words((const unsigned char *)a->content.p, a->content.n, count);
        if (words == count) return VM_OK;
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu "
                            "values)", f->path, words, count);
    }
    int appended = span_is(a->format, "appended");
    if (appended && (!f->have_appended || !a->has_offset ||
                     a->offset > f->len - f->appended_start))
        return VM_OK; /* read_array names the problem */
    have = appended ? f->len - f->appended_start - (size_t)a->offset : a->content.n;
    if (appended && !f->appended_base64 && !f->compressed) {
        size_t hs = (size_t)f->header_size; /* raw samples after their size header */
        if (have < hs || have - hs >= need) return VM_OK; /* read_array names the problem */
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu "
                            "bytes)", f->path, have - hs, need);
    }
    if (!appended || f->appended_base64) have = have / 4 * 3 + 3;
    if (f->compressed && have <= SIZE_MAX / DEFLATE_MAX_RATIO) have *= DEFLATE_MAX_RATIO;
    else if (f->compressed) have = SIZE_MAX;
    if (need <= have) return VM_OK;
    return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (%zu bytes cannot hold "
                        "%zu)", f->path, have, need);
}

static vm_status read_array(vti_file *f, const array_info *a, vm_volume *v) {
    const char *path = f->path;
    vm_scalar_type t;
    char tname[64], aname[64];
    strcpy(tname, show(a->type).s);
    strcpy(aname, show(a->name).s);
    if (!parse_array_type(a->type, &t))
        return vm_error_set(f->err, a->type.n ? VM_ERR_UNSUPPORTED : VM_ERR_FORMAT,
                            "%s: DataArray '%s' has unsupported type '%s'", path, aname, tname);
    int64_t dims[3];
    const int64_t *e = f->have_extent ? f->extent : f->whole;
    for (int k = 0; k < 3; k++) dims[k] = e[2 * k + 1] - e[2 * k] + 1;
    size_t n, first, ns, esize = vm_scalar_type_size(t);
    vm_status st = vm__slab_check(path, f->rq, dims, esize, &n, &first, &ns, f->err);
    if (st) return st;
    memcpy(v->dims, dims, sizeof v->dims);
    v->type = t;
    if (f->rq->header_only) return VM_OK;
    if ((st = check_room(f, a, n, n * esize))) return st;
    if ((st = vm__slab_alloc(path, f->rq, ns, v, f->err))) return st;
    int swap = f->big_endian == vm__host_little_endian();
    if (span_is(a->format, "ascii")) {
        if (f->rq->all) return read_ascii(f, a->content, n, v->data);
        vm__samples src = {path, (const unsigned char *)a->content.p, a->content.n,
                           VM__ENC_ASCII, 0, t, 0, f->mapped, 0};
        return vm__samples_decode(&src, f->rq, first, ns, v->data, f->err);
    }

    const unsigned char *bytes;
    size_t blen;
    unsigned char *decoded = NULL;
    int inline_b64 = span_is(a->format, "binary");
    if (inline_b64 || (span_is(a->format, "appended") && f->appended_base64)) {
        span s = a->content;
        if (!inline_b64) {
            if (!f->have_appended || !a->has_offset)
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: appended DataArray '%s' without "
                                    "%s", path, aname, a->has_offset ? "<AppendedData>" : "offset");
            if (a->offset > f->len - f->appended_start)
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: DataArray '%s' offset %llu is "
                                    "past the end of the appended data", path, aname,
                                    (unsigned long long)a->offset);
            s = (span){f->buf + f->appended_start + a->offset,
                       f->len - f->appended_start - (size_t)a->offset};
        }
        size_t bad_at = 0;
        vm_status r = b64_decode(s, &decoded, &blen, &bad_at);
        if (r == VM_ERR_NOMEM)
            return vm_error_set(f->err, VM_ERR_NOMEM, "%s: out of memory", path);
        if (r < 0)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: DataArray '%s' has invalid base64 "
                                "data at byte %zu", path, aname, (size_t)(s.p - f->buf) + bad_at);
        bytes = decoded;
    } else if (span_is(a->format, "appended")) {
        if (!f->have_appended || !a->has_offset)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: appended DataArray '%s' without %s",
                                path, aname, a->has_offset ? "<AppendedData>" : "offset");
        if (a->offset > f->len - f->appended_start)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: DataArray '%s' offset %llu is past "
                                "the end of the appended data", path, aname,
                                (unsigned long long)a->offset);
        bytes = (const unsigned char *)f->buf + f->appended_start + a->offset;
        blen = f->len - f->appended_start - (size_t)a->offset;
        if (!f->compressed) {
            /* Raw appended samples are read in place: only the slab's bytes are touched. */
            int hs = f->header_size;
            if (blen < (size_t)hs)
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (no size "
                                    "header)", path);
            uint64_t nbytes = read_uint(bytes, hs, f->big_endian);
            if (nbytes != n * esize)
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data header says %llu bytes, "
                                    "the extent and type need %zu", path,
                                    (unsigned long long)nbytes, n * esize);
            if (blen - hs < n * esize)
                return vm_error_set(f->err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of "
                                    "%zu bytes)", path, blen - hs, n * esize);
            vm__samples src = {path, bytes + hs, blen - hs, VM__ENC_RAW, 0, t, swap, f->mapped,
                               0};
            return vm__samples_decode(&src, f->rq, first, ns, v->data, f->err);
        }
    } else {
        return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: DataArray '%s' has format '%s' "
                            "(expected ascii, binary or appended)", path, aname,
                            show(a->format).s);
    }
    unsigned char *raw = malloc(n * esize);
    if (!raw) {
        free(decoded);
        return vm_error_set(f->err, VM_ERR_NOMEM, "%s: out of memory for %zu bytes", path,
                            n * esize);
    }
    st = decode_payload(f, bytes, blen, raw, n * esize);
    /* base64 and zlib blocks are decoded whole; a slab keeps its planes */
    if (!st) vm__samples_to_float(raw + first * esize, t, swap, ns, v->data);
    free(raw);
    free(decoded);
    return st;
}

static vm_status parse(vti_file *f, vm_volume *v) {
    const char *path = f->path;
    if (f->len == 0) return vm_error_set(f->err, VM_ERR_FORMAT, "%s: file is empty", path);
    for (int a = 0; a < 3; a++) {
        f->spacing[a] = 1.0;
        f->direction[a][a] = 1.0;
    }
    vm_status st = scan(f);
    if (st) return st;
    if (f->pieces == 0)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: no <Piece> in the ImageData", path);
    if (f->pieces > 1)
        return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: %d pieces (only single-piece "
                            "ImageData is read)", path, f->pieces);
    if (!f->have_extent && !f->have_whole)
        return vm_error_set(f->err, VM_ERR_FORMAT, "%s: neither Piece Extent nor WholeExtent",
                            path);
    const array_info *a = NULL;
    if (f->have_scalars) {
        for (int i = 0; i < f->narrays && !a; i++)
            if (span_eq(f->arrays[i].name, f->scalars)) a = &f->arrays[i];
        if (!a)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: PointData Scalars=\"%s\" names no "
                                "DataArray", path, show(f->scalars).s);
        if (a->ncomp != 1)
            return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: scalars \"%s\" have %lld "
                                "components (only 1 is supported)", path,
                                show(a->name).s,
                                (long long)a->ncomp);
    } else {
        for (int i = 0; i < f->narrays && !a; i++)
            if (f->arrays[i].ncomp == 1) a = &f->arrays[i];
        if (!a)
            return vm_error_set(f->err, VM_ERR_UNSUPPORTED, "%s: no one-component point data "
                                "array", path);
    }
    if ((st = read_array(f, a, v))) return st;

    const int64_t *e = f->have_extent ? f->extent : f->whole;
    for (int r = 0; r < 3; r++) {
        double o = f->origin[r];
        for (int c = 0; c < 3; c++) o += f->direction[r][c] * (double)e[2 * c] * f->spacing[c];
        v->origin[r] = o;
    }
    for (int c = 0; c < 3; c++) {
        if (f->spacing[c] == 0.0)
            return vm_error_set(f->err, VM_ERR_FORMAT, "%s: Spacing %d is zero", path, c);
        /* A negative spacing flips the axis: keep spacing > 0 and negate the column. */
        double sign = f->spacing[c] < 0 ? -1.0 : 1.0;
        v->spacing[c] = sign * f->spacing[c];
        for (int r = 0; r < 3; r++) v->direction[r][c] = sign * f->direction[r][c];
    }
    strcpy(v->format, "vti");
    if ((st = vm__check_geometry(v, path, f->err))) return st;
    vm__slab_finish(v, f->rq);
    return VM_OK;
}

vm_status vm__read_vti(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    vm__map m;
    vm_status st = vm__map_file(path, (size_t)-1, &m, err);
    if (st) return st;
    vti_file *f = calloc(1, sizeof *f);
    if (!f) {
        vm__map_free(&m);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    }
    f->path = path;
    f->buf = (const char *)m.p;
    f->len = m.len;
    f->err = err;
    f->rq = rq;
    f->mapped = m.maplen != 0;
    st = parse(f, v);
    free(f);
    vm__map_free(&m);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_vti(const char *path, vm_volume *v, vm_error *err) {
    return vm__read_vti(path, &vm__slab_whole, v, err);
}
