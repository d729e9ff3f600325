/* SPDX-License-Identifier: BSD-3-Clause */
/* io/vtk_legacy.c — reads VTK legacy STRUCTURED_POINTS files (ASCII or big-endian BINARY).
 * Follows "VTK File Formats", section "Simple Legacy Formats" (dataset, attribute and field
 * data sections; keywords are case-insensitive, binary data follows the line of its keyword). */
#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

#define TOKEN_MAX 256

typedef struct reader {
    const char *path;
    const unsigned char *buf;
    size_t len, pos;
    int binary;
    vm_error *err;
    const vm__slab *rq;
    int mapped; /* buf is a vm__map's mapping (pages may be given back) */
} reader;

/* Next white-space separated word into tok; returns 0 at end of file. A word longer than
 * TOKEN_MAX - 1 is an error (sets *bad). */
static int next_token(reader *r, char tok[TOKEN_MAX], int *bad) {
    *bad = 0;
    while (r->pos < r->len && isspace(r->buf[r->pos])) r->pos++;
    if (r->pos >= r->len) return 0;
    size_t n = 0;
    while (r->pos < r->len && !isspace(r->buf[r->pos])) {
        if (n == TOKEN_MAX - 1) {
            *bad = 1;
            return 0;
        }
        unsigned char c = r->buf[r->pos++];
        tok[n++] = c < 0x20 || c == 0x7f ? '?' : (char)c; /* messages quote tokens */
    }
    tok[n] = 0;
    return 1;
}

/* Rest of the current line (without the newline) into line, truncated to cap - 1 chars;
 * the position moves past the newline. */
static void rest_of_line(reader *r, char *line, size_t cap) {
    size_t n = 0;
    while (r->pos < r->len && r->buf[r->pos] != '\n') {
        if (n + 1 < cap) line[n++] = (char)r->buf[r->pos];
        r->pos++;
    }
    if (r->pos < r->len) r->pos++;
    if (cap) line[n] = 0;
}

/* Skips blanks on the current line and reports whether the next word is kw (without
 * consuming anything when it is not). */
static int peek_keyword(reader *r, const char *kw) {
    size_t p = r->pos, k = strlen(kw);
    while (p < r->len && isspace(r->buf[p])) p++;
    if (r->len - p < k || strncasecmp((const char *)r->buf + p, kw, k) != 0) return 0;
    return p + k == r->len || isspace(r->buf[p + k]);
}

static vm_status expect_token(reader *r, char tok[TOKEN_MAX], const char *what) {
    int bad;
    if (next_token(r, tok, &bad)) return VM_OK;
    if (bad) return vm_error_set(r->err, VM_ERR_FORMAT, "%s: over-long word where %s was "
                                 "expected", r->path, what);
    return vm_error_set(r->err, VM_ERR_FORMAT, "%s: file ends where %s was expected", r->path,
                        what);
}

static vm_status read_int64(reader *r, const char *what, int64_t lo, int64_t *out) {
    char tok[TOKEN_MAX];
    vm_status st = expect_token(r, tok, what);
    if (st) return st;
    char *end;
    errno = 0;
    long long v = strtoll(tok, &end, 10);
    if (end == tok || *end || errno == ERANGE || v < lo)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: %s is '%s', not a whole number >= %lld",
                            r->path, what, tok, (long long)lo);
    *out = v;
    return VM_OK;
}

static vm_status read_double3(reader *r, const char *what, double out[3]) {
    for (int a = 0; a < 3; a++) {
        char tok[TOKEN_MAX];
        vm_status st = expect_token(r, tok, what);
        if (st) return st;
        char *end;
        errno = 0;
        out[a] = strtod(tok, &end);
        if (end == tok || *end || errno == ERANGE || !(out[a] - out[a] == 0.0))
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: %s value '%s' is not a finite "
                                "number", r->path, what, tok);
    }
    return VM_OK;
}

/* Legacy type names (vtkDataReader spellings plus the vtktype* fixed-width names). long is
 * read as 8 bytes, as written by VTK on LP64 machines. VM_ERR_FORMAT for an unknown name. */
static vm_status parse_type(const char *name, vm_scalar_type *t) {
    static const struct {
        const char *name;
        vm_scalar_type type;
    } names[] = {
        {"unsigned_char", VM_SCALAR_UINT8},   {"char", VM_SCALAR_INT8},
        {"signed_char", VM_SCALAR_INT8},      {"unsigned_short", VM_SCALAR_UINT16},
        {"short", VM_SCALAR_INT16},           {"unsigned_int", VM_SCALAR_UINT32},
        {"int", VM_SCALAR_INT32},             {"unsigned_long", VM_SCALAR_UINT64},
        {"long", VM_SCALAR_INT64},            {"unsigned_long_long", VM_SCALAR_UINT64},
        {"long_long", VM_SCALAR_INT64},       {"float", VM_SCALAR_FLOAT32},
        {"double", VM_SCALAR_FLOAT64},        {"vtktypeint8", VM_SCALAR_INT8},
        {"vtktypeuint8", VM_SCALAR_UINT8},    {"vtktypeint16", VM_SCALAR_INT16},
        {"vtktypeuint16", VM_SCALAR_UINT16},  {"vtktypeint32", VM_SCALAR_INT32},
        {"vtktypeuint32", VM_SCALAR_UINT32},  {"vtktypeint64", VM_SCALAR_INT64},
        {"vtktypeuint64", VM_SCALAR_UINT64},  {"vtktypefloat32", VM_SCALAR_FLOAT32},
        {"vtktypefloat64", VM_SCALAR_FLOAT64}, {"vtkidtype", VM_SCALAR_INT32},
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcasecmp(name, names[i].name) == 0) {
            *t = names[i].type;
            return VM_OK;
        }
    return VM_ERR_FORMAT;
}

/* Skips count values: ASCII words, or count*size bytes after the end of the current line. */
static vm_status skip_values(reader *r, uint64_t count, size_t size, const char *what) {
    if (r->binary) {
        char line[8];
        rest_of_line(r, line, sizeof line);
        size_t bytes;
        if (count > SIZE_MAX || vm__mul_overflows((size_t)count, size, &bytes) ||
            bytes > r->len - r->pos)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: %s data is truncated (needs %llu "
                                "values of %zu bytes, %zu bytes left)", r->path, what,
                                (unsigned long long)count, size, r->len - r->pos);
        r->pos += bytes;
        return VM_OK;
    }
    for (uint64_t i = 0; i < count; i++) {
        char tok[TOKEN_MAX];
        int bad;
        if (!next_token(r, tok, &bad))
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: %s data is truncated (got %llu of "
                                "%llu values)", r->path, what, (unsigned long long)i,
                                (unsigned long long)count);
    }
    return VM_OK;
}

static vm_status skip_typed(reader *r, uint64_t count, const char *type, const char *what) {
    vm_scalar_type t;
    if (strcasecmp(type, "bit") == 0) {
        if (!r->binary) return skip_values(r, count, 1, what);
        return skip_values(r, (count + 7) / 8, 1, what);
    }
    if (parse_type(type, &t) != VM_OK)
        return vm_error_set(r->err, VM_ERR_UNSUPPORTED, "%s: %s has unknown data type '%s'",
                            r->path, what, type);
    return skip_values(r, count, vm_scalar_type_size(t), what);
}

static vm_status mul_count(reader *r, int64_t a, int64_t b, uint64_t *out) {
    if (a < 0 || b < 0 || (a != 0 && (uint64_t)b > UINT64_MAX / (uint64_t)a))
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: array size %lld x %lld overflows",
                            r->path, (long long)a, (long long)b);
    *out = (uint64_t)a * (uint64_t)b;
    return VM_OK;
}

/* METADATA blocks (VTK >= 8) run to the next empty line. */
static void skip_metadata(reader *r) {
    char line[TOKEN_MAX];
    rest_of_line(r, line, sizeof line);
    while (r->pos < r->len) {
        rest_of_line(r, line, sizeof line);
        if (vm__trim(line)[0] == 0) break;
    }
}

/* FIELD name nArrays, then per array: name nComponents nTuples type, data. */
static vm_status skip_field(reader *r) {
    char tok[TOKEN_MAX];
    int64_t narrays;
    vm_status st = expect_token(r, tok, "FIELD name");
    if (!st) st = read_int64(r, "FIELD array count", 0, &narrays);
    for (int64_t i = 0; !st && i < narrays; i++) {
        int64_t ncomp, ntuples;
        uint64_t count = 0;
        char type[TOKEN_MAX];
        st = expect_token(r, tok, "FIELD array name");
        if (!st && strcasecmp(tok, "NULL_ARRAY") == 0) continue;
        if (!st) st = read_int64(r, "FIELD array components", 0, &ncomp);
        if (!st) st = read_int64(r, "FIELD array tuples", 0, &ntuples);
        if (!st) st = expect_token(r, type, "FIELD array type");
        if (!st) st = mul_count(r, ncomp, ntuples, &count);
        if (!st) st = skip_typed(r, count, type, "FIELD array");
        if (!st && peek_keyword(r, "METADATA")) {
            int bad;
            next_token(r, tok, &bad);
            skip_metadata(r);
        }
    }
    return st;
}

static float color_value(double d) {
    d = d * 255.0 + 0.5;
    d = d > 0 ? (d < 255 ? d : 255) : 0; /* also maps NaN to 0 */
    return (float)(int)d;
}

/* color: COLOR_SCALARS with one value per point, stored as unsigned char; VTK writes them
 * as raw bytes in BINARY files and as fractions 0..1 (times 255) in ASCII files. Reads
 * samples first .. first+n-1 of the total into v->data. */
static vm_status read_samples(reader *r, vm_scalar_type t, int color, size_t total,
                              size_t first, size_t n, vm_volume *v) {
    if (r->binary) {
        size_t size = vm_scalar_type_size(t);
        vm__samples src = {r->path, r->buf + r->pos, r->len - r->pos, VM__ENC_RAW, 0, t,
                           vm__host_little_endian(), r->mapped, 0};
        vm_status st = vm__samples_decode(&src, r->rq, first, n, v->data, r->err);
        r->pos += total * size;
        return st;
    }
    if (!r->rq->all) {
        vm__samples src = {r->path, r->buf + r->pos, r->len - r->pos, VM__ENC_ASCII, 0, t, 0,
                           r->mapped, 0};
        vm_status st = vm__samples_decode(&src, r->rq, first, n, v->data, r->err);
        if (!st && color)
            for (size_t i = 0; i < n; i++) v->data[i] = color_value(v->data[i]);
        return st;
    }
    for (size_t i = 0; i < n; i++) {
        char tok[TOKEN_MAX], *end;
        int bad;
        if (!next_token(r, tok, &bad)) {
            if (bad) return vm_error_set(r->err, VM_ERR_FORMAT, "%s: sample %zu is not a "
                                         "number (over-long word)", r->path, i);
            return vm_error_set(r->err, VM_ERR_FORMAT,
                                "%s: data is truncated (got %zu of %zu values)", r->path, i, n);
        }
        double d = strtod(tok, &end);
        if (end == tok || *end)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: sample %zu ('%.40s') is not a "
                                "number", r->path, i, tok);
        v->data[i] = color ? color_value(d) : (float)d;
    }
    return VM_OK;
}

/* Reads the selected point scalars (the planes r->rq asks for, of n values of type t) and
 * sets the geometry. */
static vm_status take_scalars(reader *r, vm_volume *v, const int64_t dims[3],
                              int64_t point_count, const double spacing[3],
                              const double origin[3], vm_scalar_type t, int color) {
    vm_status st;
    size_t n, first, ns, esize = vm_scalar_type_size(t);
    if ((st = vm__slab_check(r->path, r->rq, dims, esize, &n, &first, &ns, r->err))) return st;
    if ((uint64_t)point_count != (uint64_t)n)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: POINT_DATA %lld does not match "
                            "DIMENSIONS %lldx%lldx%lld", r->path, (long long)point_count,
                            (long long)dims[0], (long long)dims[1], (long long)dims[2]);
    for (int a = 0; a < 3; a++) {
        /* A negative spacing flips the axis: keep spacing > 0, negate the column. */
        if (spacing[a] == 0.0)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: SPACING %d is zero", r->path, a);
        v->dims[a] = dims[a];
        v->spacing[a] = spacing[a] < 0 ? -spacing[a] : spacing[a];
        v->direction[a][a] = spacing[a] < 0 ? -1.0 : 1.0;
        v->origin[a] = origin[a];
    }
    v->type = t;
    strcpy(v->format, "vtk");
    if (r->binary) {
        char line[8];
        rest_of_line(r, line, sizeof line);
        size_t bytes = n * esize; /* checked by vm__slab_check */
        if (bytes > r->len - r->pos)
            return vm_error_set(r->err, VM_ERR_FORMAT,
                                "%s: data is truncated (got %zu of %zu bytes)", r->path,
                                r->len - r->pos, bytes);
    }
    size_t words;
    if (!r->binary && !r->rq->header_only &&
        (words = vm__count_words(r->buf + r->pos, r->len - r->pos, n)) < n)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: data is truncated (got %zu of %zu "
                            "values)", r->path, words, n);
    if ((st = vm__check_geometry(v, r->path, r->err)) || r->rq->header_only) return st;
    if ((st = vm__slab_alloc(r->path, r->rq, ns, v, r->err))) return st;
    st = read_samples(r, t, color, n, first, ns, v);
    if (st) {
        vm__slab_release(v, r->rq);
        return st;
    }
    vm__slab_finish(v, r->rq);
    return VM_OK;
}

/* After "SCALARS name type": optional numComp on the same line, optional LOOKUP_TABLE line.
 * Leaves the position where the values start (ASCII) or on the line before them (BINARY). */
static vm_status scalars_header(reader *r, int64_t *ncomp) {
    char line[TOKEN_MAX];
    size_t save = r->pos;
    rest_of_line(r, line, sizeof line);
    char *s = vm__trim(line);
    for (char *c = s; *c; c++)
        if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
    *ncomp = 1;
    if (*s) {
        char *end;
        errno = 0;
        long long c = strtoll(s, &end, 10);
        if (end == s || errno == ERANGE || *vm__trim(end) || c < 1)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: SCALARS component count '%s' is "
                                "not a positive whole number", r->path, s);
        *ncomp = c;
    }
    if (peek_keyword(r, "LOOKUP_TABLE")) {
        char tok[TOKEN_MAX];
        int bad;
        next_token(r, tok, &bad);
        /* Leave the position on the LOOKUP_TABLE line: binary data follows its newline. */
        while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
    } else if (r->binary) {
        /* Position on the SCALARS line end so that read_samples skips just its newline. */
        r->pos = save;
        while (r->pos < r->len && r->buf[r->pos] != '\n') r->pos++;
    }
    return VM_OK;
}

/* Components per tuple of the attribute arrays that are skipped (VTK File Formats,
 * "Dataset attribute format"). */
enum { TENSOR_COMPONENTS = 9, TENSOR6_COMPONENTS = 6, VECTOR_COMPONENTS = 3 };
/* A LOOKUP_TABLE entry is rgba. */
enum { LOOKUP_ENTRY_VALUES = 4 };

/* What the header and attribute loop has met so far. */
typedef struct sp_header {
    int64_t dims[3];
    double spacing[3], origin[3];
    int have_dims;
    int64_t point_count, mode_count; /* POINT_DATA count (-1: none yet); the section's count */
    int in_points, in_attributes;    /* which attribute section the loop is in */
} sp_header;

/* The first lines: version, title, ASCII/BINARY, DATASET STRUCTURED_POINTS. */
static vm_status read_preamble(reader *r) {
    const char *path = r->path;
    vm_error *err = r->err;
    char line[TOKEN_MAX], tok[TOKEN_MAX];
    if (r->len == 0) return vm_error_set(err, VM_ERR_FORMAT, "%s: file is empty", path);
    rest_of_line(r, line, sizeof line);
    if (strncasecmp(vm__trim(line), "# vtk DataFile Version", 22) != 0)
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: not a VTK legacy file (first line is not '# vtk DataFile "
                            "Version x.y')", path);
    if (r->pos >= r->len)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: file ends after the first line", path);
    rest_of_line(r, line, sizeof line); /* title */
    vm_status st = expect_token(r, tok, "ASCII or BINARY");
    if (st) return st;
    if (strcasecmp(tok, "ASCII") == 0)
        r->binary = 0;
    else if (strcasecmp(tok, "BINARY") == 0)
        r->binary = 1;
    else
        return vm_error_set(err, VM_ERR_FORMAT, "%s: file type is '%.40s', not ASCII or BINARY",
                            path, tok);
    st = expect_token(r, tok, "DATASET");
    if (st) return st;
    if (strcasecmp(tok, "DATASET") != 0) {
        if (strcasecmp(tok, "POINT_DATA") == 0 || strcasecmp(tok, "CELL_DATA") == 0)
            return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: file has attributes but no "
                                "DATASET; only STRUCTURED_POINTS volumes are read", path);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: expected DATASET, found '%.40s'", path,
                            tok);
    }
    st = expect_token(r, tok, "dataset type");
    if (st) return st;
    if (strcasecmp(tok, "STRUCTURED_POINTS") != 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: dataset %.40s is not supported (only "
                            "STRUCTURED_POINTS volumes are read)", path, tok);
    return VM_OK;
}

/* The error for a file that ends (or holds an over-long word, bad) before point scalars. */
static vm_status end_of_header(const reader *r, const sp_header *h, int bad) {
    if (bad)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: over-long word in the header", r->path);
    if (!h->have_dims)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: no DIMENSIONS line", r->path);
    if (h->point_count < 0)
        return vm_error_set(r->err, VM_ERR_UNSUPPORTED, "%s: no POINT_DATA section (cell "
                            "data alone is not a volume)", r->path);
    return vm_error_set(r->err, VM_ERR_UNSUPPORTED, "%s: POINT_DATA has no SCALARS array",
                        r->path);
}

/* POINT_DATA / CELL_DATA count: starts an attribute section. */
static vm_status data_section(reader *r, sp_header *h, const char *tok) {
    int pts = strcasecmp(tok, "POINT_DATA") == 0;
    vm_status st;
    if (!h->have_dims)
        return vm_error_set(r->err, VM_ERR_FORMAT, "%s: %s before DIMENSIONS", r->path, tok);
    if ((st = read_int64(r, tok, 0, &h->mode_count))) return st;
    if (pts) {
        if (h->point_count >= 0)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: two POINT_DATA sections", r->path);
        h->point_count = h->mode_count;
    }
    h->in_points = pts;
    h->in_attributes = 1;
    return VM_OK;
}

/* SCALARS name type [ncomp]: point scalars are the volume (*taken = 1), cell scalars are
 * skipped. */
static vm_status scalars_section(reader *r, sp_header *h, vm_volume *v, int *taken) {
    char name[TOKEN_MAX], type[TOKEN_MAX];
    int64_t ncomp;
    vm_scalar_type t;
    vm_status st;
    if ((st = expect_token(r, name, "SCALARS name"))) return st;
    if ((st = expect_token(r, type, "SCALARS type"))) return st;
    if ((st = scalars_header(r, &ncomp))) return st;
    if (!h->in_points) {
        uint64_t count = 0;
        if ((st = mul_count(r, h->mode_count, ncomp, &count))) return st;
        return skip_typed(r, count, type, "CELL_DATA SCALARS");
    }
    *taken = 1;
    if (parse_type(type, &t) != VM_OK)
        return vm_error_set(r->err, strcasecmp(type, "bit") == 0 ? VM_ERR_UNSUPPORTED
                                                                 : VM_ERR_FORMAT,
                            "%s: SCALARS %.60s has unsupported type '%.40s'", r->path, name,
                            type);
    if (ncomp != 1)
        return vm_error_set(r->err, VM_ERR_UNSUPPORTED, "%s: SCALARS %.60s has %lld "
                            "components (only 1 is supported)", r->path, name,
                            (long long)ncomp);
    return take_scalars(r, v, h->dims, h->point_count, h->spacing, h->origin, t, 0);
}

/* COLOR_SCALARS name n: one value per point is taken as the volume (*taken = 1), as VTK
 * writes unsigned char scalars so and its reader takes them; others are skipped. */
static vm_status color_scalars_section(reader *r, sp_header *h, vm_volume *v, int *taken) {
    char tok[TOKEN_MAX];
    int64_t nvalues;
    uint64_t count = 0;
    vm_status st;
    if ((st = expect_token(r, tok, "array name"))) return st;
    if ((st = read_int64(r, "COLOR_SCALARS size", 1, &nvalues))) return st;
    if (h->in_points && nvalues == 1) {
        *taken = 1; /* the values start after this line */
        return take_scalars(r, v, h->dims, h->point_count, h->spacing, h->origin,
                            VM_SCALAR_UINT8, 1);
    }
    if ((st = mul_count(r, h->mode_count, nvalues, &count))) return st;
    return skip_values(r, count, 1, "COLOR_SCALARS");
}

/* Skips an attribute array volmesh does not use (LOOKUP_TABLE, VECTORS, NORMALS, TENSORS,
 * TENSORS6, GLOBAL_IDS, PEDIGREE_IDS, TEXTURE_COORDINATES); *known = 0 when tok is none. */
static vm_status skip_attribute(reader *r, const sp_header *h, const char *tok, int *known) {
    char name[TOKEN_MAX], type[TOKEN_MAX];
    uint64_t count = 0;
    vm_status st;
    *known = 1;
    if (strcasecmp(tok, "LOOKUP_TABLE") == 0) {
        int64_t size;
        if ((st = expect_token(r, name, "LOOKUP_TABLE name"))) return st;
        if ((st = read_int64(r, "LOOKUP_TABLE size", 0, &size))) return st;
        if ((st = mul_count(r, size, LOOKUP_ENTRY_VALUES, &count))) return st;
        return skip_values(r, count, 1, "LOOKUP_TABLE");
    }
    if (strcasecmp(tok, "TEXTURE_COORDINATES") == 0) {
        int64_t dim;
        if ((st = expect_token(r, name, "array name"))) return st;
        if ((st = read_int64(r, "TEXTURE_COORDINATES dimension", 1, &dim))) return st;
        if ((st = expect_token(r, type, "array type"))) return st;
        if ((st = mul_count(r, h->mode_count, dim, &count))) return st;
        return skip_typed(r, count, type, "TEXTURE_COORDINATES");
    }
    int64_t ncomp = strcasecmp(tok, "TENSORS") == 0       ? TENSOR_COMPONENTS
                    : strcasecmp(tok, "TENSORS6") == 0    ? TENSOR6_COMPONENTS
                    : strcasecmp(tok, "GLOBAL_IDS") == 0  ? 1
                    : strcasecmp(tok, "PEDIGREE_IDS") == 0 ? 1
                    : (strcasecmp(tok, "VECTORS") == 0 || strcasecmp(tok, "NORMALS") == 0)
                        ? VECTOR_COMPONENTS
                        : 0;
    if (!ncomp) {
        *known = 0;
        return VM_OK;
    }
    if ((st = expect_token(r, name, "array name"))) return st;
    if ((st = expect_token(r, type, "array type"))) return st;
    if ((st = mul_count(r, h->mode_count, ncomp, &count))) return st;
    return skip_typed(r, count, type, tok);
}

/* The whole file: preamble, then header keywords and attribute sections until the point
 * scalars, which become v. */
static vm_status parse(reader *r, vm_volume *v) {
    char tok[TOKEN_MAX];
    vm_status st = read_preamble(r);
    if (st) return st;
    sp_header h = {{0, 0, 0}, {1, 1, 1}, {0, 0, 0}, 0, -1, 0, 0, 0};
    int bad;
    for (;;) {
        if (!next_token(r, tok, &bad)) return end_of_header(r, &h, bad);
        int taken = 0, known = 1;
        if (!h.in_attributes && strcasecmp(tok, "DIMENSIONS") == 0) {
            for (int a = 0; a < 3 && !st; a++) st = read_int64(r, "DIMENSIONS", 1, &h.dims[a]);
            h.have_dims = 1;
        } else if (!h.in_attributes && (strcasecmp(tok, "SPACING") == 0 ||
                                        strcasecmp(tok, "ASPECT_RATIO") == 0)) {
            st = read_double3(r, "SPACING", h.spacing);
        } else if (!h.in_attributes && strcasecmp(tok, "ORIGIN") == 0) {
            st = read_double3(r, "ORIGIN", h.origin);
        } else if (strcasecmp(tok, "FIELD") == 0) {
            st = skip_field(r);
        } else if (strcasecmp(tok, "METADATA") == 0) {
            skip_metadata(r);
        } else if (strcasecmp(tok, "POINT_DATA") == 0 || strcasecmp(tok, "CELL_DATA") == 0) {
            st = data_section(r, &h, tok);
        } else if (h.in_attributes && strcasecmp(tok, "SCALARS") == 0) {
            st = scalars_section(r, &h, v, &taken);
        } else if (h.in_attributes && strcasecmp(tok, "COLOR_SCALARS") == 0) {
            st = color_scalars_section(r, &h, v, &taken);
        } else if (h.in_attributes) {
            st = skip_attribute(r, &h, tok, &known);
        } else {
            known = 0;
        }
        if (st || taken) return st;
        if (!known)
            return vm_error_set(r->err, VM_ERR_FORMAT, "%s: unexpected keyword '%.40s'%s",
                                r->path, tok, h.in_attributes
                                                  ? " in the attribute data"
                                                  : " in the STRUCTURED_POINTS header");
    }
}

vm_status vm__read_vtk(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    vm__map m;
    vm_status st = vm__map_file(path, (size_t)-1, &m, err);
    if (st) return st;
    reader r = {path, m.p, m.len, 0, 0, err, rq, m.maplen != 0};
    st = parse(&r, v);
    vm__map_free(&m);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_vtk(const char *path, vm_volume *v, vm_error *err) {
    return vm__read_vtk(path, &vm__slab_whole, v, err);
}
