/* SPDX-License-Identifier: BSD-3-Clause */
/* io/nrrd.c — NRRD volumes: reads attached (.nrrd) and detached (.nhdr + data file) volumes,
 * writes attached float volumes. Follows the NRRD0001-0005 format definition
 * (teem.sourceforge.net/nrrd/format.html); world coordinates are the file's NRRD space. */
#define _POSIX_C_SOURCE 200809L
#include <assert.h>
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <zlib.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

#define NRRD_DIM_MAX 16 /* teem's NRRD_DIM_MAX */

/* Deflate cannot compress better than about 1032:1, so a compressed payload of n bytes
 * cannot hold more than this many bytes; larger sizes mean the header lies. */
#define GZIP_MAX_RATIO 1040u

enum nrrd_encoding { ENC_RAW, ENC_GZIP, ENC_ASCII };

/* Text of each header field the reader uses (pointers into the header buffer). */
typedef struct nrrd_fields {
    const char *dimension, *type, *encoding, *endian, *sizes, *spacings, *space,
        *space_dimension, *space_directions, *space_origin, *byte_skip, *line_skip,
        *data_file;
} nrrd_fields;

/* Field identifiers with spaces removed and lower-cased, so that "data file" and "datafile",
 * "byte skip" and "byteskip" (both spellings appear in the spec's history) match alike. */
#define FIELD(key, member) {key, offsetof(nrrd_fields, member)}
static const struct {
    const char *key;
    size_t offset;
} field_table[] = {
    FIELD("dimension", dimension),
    FIELD("type", type),
    FIELD("encoding", encoding),
    FIELD("endian", endian),
    FIELD("sizes", sizes),
    FIELD("spacings", spacings),
    FIELD("space", space),
    FIELD("spacedimension", space_dimension),
    FIELD("spacedirections", space_directions),
    FIELD("spaceorigin", space_origin),
    FIELD("byteskip", byte_skip),
    FIELD("lineskip", line_skip),
    FIELD("datafile", data_file),
};
#undef FIELD

/* The header, interpreted. */
typedef struct nrrd_info {
    int64_t dims[3];
    vm_scalar_type type;
    enum nrrd_encoding encoding;
    int big_endian; /* -1 when absent */
    double spacing[3], origin[3], direction[3][3];
    long long byte_skip, line_skip;
    char data_file[4096]; /* empty: attached */
} nrrd_info;

#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static vm_status fail(vm_error *err, vm_status st, const char *path, const char *fmt, ...) {
    char msg[448];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return vm_error_set(err, st, "%s: %s", path, msg);
}

/* Copy of file text fit for a one-line message: at most 40 characters, controls as '?'. */
static const char *show(const char *s, char out[48]) {
    size_t i = 0;
    for (; s[i] && i < 40; i++) out[i] = isprint((unsigned char)s[i]) ? s[i] : '?';
    if (s[i]) {
        memcpy(out + i, "...", 3);
        i += 3;
    }
    out[i] = 0;
    return out;
}

/* One whole decimal integer (white space around it allowed). */
static vm_status parse_ll(const char *s, long long *out) {
    char *end;
    errno = 0;
    long long x = strtoll(s, &end, 10);
    if (end == s || errno == ERANGE) return VM_ERR_FORMAT;
    while (isspace((unsigned char)*end)) end++;
    if (*end) return VM_ERR_FORMAT;
    *out = x;
    return VM_OK;
}

/* White-space separated numbers: integers into ints, or (ints NULL) doubles into reals, nan
 * allowed. Returns the count, or -1 when malformed or more than max. */
static int parse_list(const char *s, int64_t *ints, double *reals, int max) {
    int n = 0;
    for (;;) {
        while (isspace((unsigned char)*s)) s++;
        if (!*s) return n;
        if (n == max) return -1;
        char *end;
        errno = 0;
        if (ints)
            ints[n] = strtoll(s, &end, 10);
        else
            reals[n] = strtod(s, &end);
        if (end == s || (ints && errno == ERANGE) || (*end && !isspace((unsigned char)*end)))
            return -1;
        n++;
        s = end;
    }
}

/* Splits a header into fields (in place: line ends become NULs). On success *data_at is the
 * offset just past the blank line ending the header, or len when the header runs to the end
 * of the file (*ended = 0). */
static vm_status parse_header(const char *path, unsigned char *buf, size_t len,
                              nrrd_fields *f, size_t *data_at, int *ended, vm_error *err) {
    char tmp[48];
    memset(f, 0, sizeof *f);
    *ended = 0;
    *data_at = len;
    if (len == 0) return fail(err, VM_ERR_FORMAT, path, "file is empty");
    if (len < 8 || memcmp(buf, "NRRD", 4) != 0)
        return fail(err, VM_ERR_FORMAT, path,
                    "not a NRRD file (the first line is not NRRD0001..NRRD0005)");
    if (memcmp(buf, "NRRD000", 7) != 0 || buf[7] < '1' || buf[7] > '5' ||
        (len > 8 && !isspace(buf[8])))
        return fail(err, VM_ERR_UNSUPPORTED, path,
                    "unsupported NRRD version (the first line must be NRRD0001..NRRD0005)");
    unsigned char *nl = memchr(buf, '\n', len);
    size_t pos = nl ? (size_t)(nl - buf) + 1 : len;
    int lineno = 1;
    while (pos < len) {
        lineno++;
        nl = memchr(buf + pos, '\n', len - pos);
        size_t end = nl ? (size_t)(nl - buf) : len;
        size_t next = nl ? end + 1 : len;
        size_t e = end;
        if (e > pos && buf[e - 1] == '\r') e--;
        if (e == pos) {
            *ended = 1;
            *data_at = next;
            return VM_OK;
        }
        buf[e] = 0; /* buf[len] is the NUL vm__read_file appends */
        char *line = (char *)buf + pos;
        pos = next;
        if (line[0] == '#') continue;
        char *field_sep = strstr(line, ": ");
        char *kv_sep = strstr(line, ":=");
        if (kv_sep && (!field_sep || kv_sep < field_sep)) continue; /* key:=value, unused */
        size_t ll = strlen(line);
        if (!field_sep && ll > 0 && line[ll - 1] == ':') field_sep = line + ll - 1;
        if (!field_sep)
            return fail(err, VM_ERR_FORMAT, path, "line %d ('%s') is not 'field: value'",
                        lineno, show(line, tmp));
        char key[40];
        size_t k = 0;
        for (const char *c = line; c < field_sep; c++) {
            if (*c == ' ' || *c == '\t') continue;
            if (k + 1 >= sizeof key) break;
            key[k++] = (char)tolower((unsigned char)*c);
        }
        key[k] = 0;
        char *value = vm__trim(field_sep + 1);
        for (size_t i = 0; i < sizeof field_table / sizeof field_table[0]; i++) {
            if (strcmp(key, field_table[i].key) != 0) continue;
            const char **slot = (const char **)((char *)f + field_table[i].offset);
            if (*slot)
                return fail(err, VM_ERR_FORMAT, path, "line %d: field '%s' appears twice",
                            lineno, field_table[i].key);
            *slot = value;
            break;
        }
    }
    return VM_OK;
}

/* NRRD type spellings (format definition, "type"); vm_scalar_type_parse catches the rest. */
static vm_status parse_type(const char *s, vm_scalar_type *t) {
    static const struct {
        const char *name;
        vm_scalar_type t;
    } names[] = {
        {"signed char", VM_SCALAR_INT8},
        {"int8", VM_SCALAR_INT8},
        {"int8_t", VM_SCALAR_INT8},
        {"uchar", VM_SCALAR_UINT8},
        {"unsigned char", VM_SCALAR_UINT8},
        {"uint8", VM_SCALAR_UINT8},
        {"uint8_t", VM_SCALAR_UINT8},
        {"short", VM_SCALAR_INT16},
        {"short int", VM_SCALAR_INT16},
        {"signed short", VM_SCALAR_INT16},
        {"signed short int", VM_SCALAR_INT16},
        {"int16", VM_SCALAR_INT16},
        {"int16_t", VM_SCALAR_INT16},
        {"ushort", VM_SCALAR_UINT16},
        {"unsigned short", VM_SCALAR_UINT16},
        {"unsigned short int", VM_SCALAR_UINT16},
        {"uint16", VM_SCALAR_UINT16},
        {"uint16_t", VM_SCALAR_UINT16},
        {"int", VM_SCALAR_INT32},
        {"signed int", VM_SCALAR_INT32},
        {"int32", VM_SCALAR_INT32},
        {"int32_t", VM_SCALAR_INT32},
        {"uint", VM_SCALAR_UINT32},
        {"unsigned int", VM_SCALAR_UINT32},
        {"uint32", VM_SCALAR_UINT32},
        {"uint32_t", VM_SCALAR_UINT32},
        {"longlong", VM_SCALAR_INT64},
        {"long long", VM_SCALAR_INT64},
        {"long long int", VM_SCALAR_INT64},
        {"signed long long", VM_SCALAR_INT64},
        {"signed long long int", VM_SCALAR_INT64},
        {"int64", VM_SCALAR_INT64},
        {"int64_t", VM_SCALAR_INT64},
        {"ulonglong", VM_SCALAR_UINT64},
        {"unsigned long long", VM_SCALAR_UINT64},
        {"unsigned long long int", VM_SCALAR_UINT64},
        {"uint64", VM_SCALAR_UINT64},
        {"uint64_t", VM_SCALAR_UINT64},
        {"float", VM_SCALAR_FLOAT32},
        {"double", VM_SCALAR_FLOAT64},
    };
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(s, names[i].name) == 0) {
            *t = names[i].t;
            return VM_OK;
        }
    return vm_scalar_type_parse(s, t) == 0 ? VM_OK : VM_ERR_FORMAT;
}

/* Dimension of a named space (format definition, "space"); 0 when unknown. */
static int space_dimension_of(const char *s) {
    static const char *const three[] = {
        "right-anterior-superior", "RAS",         "left-anterior-superior", "LAS",
        "left-posterior-superior", "LPS",         "scanner-xyz",            "3D-right-handed",
        "3D-left-handed",
    };
    static const char *const four[] = {
        "right-anterior-superior-time", "RAST", "left-anterior-superior-time", "LAST",
        "left-posterior-superior-time", "LPST", "scanner-xyz-time", "3D-right-handed-time",
        "3D-left-handed-time",
    };
    for (size_t i = 0; i < sizeof three / sizeof three[0]; i++)
        if (strcasecmp(s, three[i]) == 0) return 3;
    for (size_t i = 0; i < sizeof four / sizeof four[0]; i++)
        if (strcasecmp(s, four[i]) == 0) return 4;
    return 0;
}

/* One "(x,y,z)" vector of exactly n components starting at *s (after white space), or
 * "none"; advances *s. Returns 1 for a vector, 0 for none, -1 when malformed. */
static int parse_vector(const char **s, double *out, int n) {
    const char *p = *s;
    while (isspace((unsigned char)*p)) p++;
    if (strncmp(p, "none", 4) == 0 && (p[4] == 0 || isspace((unsigned char)p[4]))) {
        *s = p + 4;
        return 0;
    }
    if (*p != '(') return -1;
    const char *close = strchr(p, ')');
    if (!close || close - p > 1000) return -1;
    char inner[1024];
    memcpy(inner, p + 1, (size_t)(close - p - 1));
    inner[close - p - 1] = 0;
    if (strchr(inner, '(')) return -1;
    if (vm__parse_doubles(inner, out, n) != n) return -1;
    for (int i = 0; i < n; i++)
        if (!isfinite(out[i])) return -1;
    *s = close + 1;
    return 1;
}

/* Required fields, dimension and sizes: h->dims and [out] *dim (the array's dimension) and
 * *first (the axis holding x: 1 when a leading axis of one sample is tolerated). */
static vm_status interpret_layout(const char *path, const nrrd_fields *f, nrrd_info *h,
                                  long long *dim, int *first, vm_error *err) {
    char tmp[48];
    const char *missing = !f->dimension ? "dimension"
                          : !f->type    ? "type"
                          : !f->sizes   ? "sizes"
                          : !f->encoding ? "encoding"
                                         : NULL;
    if (missing) return fail(err, VM_ERR_FORMAT, path, "missing '%s' field", missing);
    if (parse_ll(f->dimension, dim) != VM_OK || *dim < 1 || *dim > NRRD_DIM_MAX)
        return fail(err, VM_ERR_FORMAT, path, "bad dimension '%s' (must be 1..%d)",
                    show(f->dimension, tmp), NRRD_DIM_MAX);
    int64_t sizes[NRRD_DIM_MAX];
    int ns = parse_list(f->sizes, sizes, NULL, NRRD_DIM_MAX);
    if (ns != *dim)
        return fail(err, VM_ERR_FORMAT, path, "sizes '%s' must be %lld integers",
                    show(f->sizes, tmp), *dim);
    for (int a = 0; a < ns; a++)
        if (sizes[a] < 1)
            return fail(err, VM_ERR_FORMAT, path, "size %lld of axis %d must be >= 1",
                        (long long)sizes[a], a);
    /* Axes holding x, y, z: all three of a 3-D array; a leading axis of one sample is
     * tolerated (a scalar stored as a 1-vector). */
    *first = 0;
    if (*dim == 4 && sizes[0] == 1) {
        *first = 1;
    } else if (*dim == 4) {
        return fail(err, VM_ERR_UNSUPPORTED, path,
                    "dimension 4 with %lld samples on the first axis (vectors or time "
                    "series) is not supported; volmesh reads scalar 3-D volumes",
                    (long long)sizes[0]);
    } else if (*dim != 3) {
        return fail(err, VM_ERR_UNSUPPORTED, path,
                    "dimension %lld is not supported; volmesh reads 3-D volumes", *dim);
    }
    for (int a = 0; a < 3; a++) h->dims[a] = sizes[*first + a];
    return VM_OK;
}

/* Sample storage: type, encoding, endianness, byte and line skips. */
static vm_status interpret_storage(const char *path, const nrrd_fields *f, nrrd_info *h,
                                   vm_error *err) {
    char tmp[48];
    if (strcmp(f->type, "block") == 0)
        return fail(err, VM_ERR_UNSUPPORTED, path, "type 'block' is not supported");
    if (parse_type(f->type, &h->type) != VM_OK)
        return fail(err, VM_ERR_FORMAT, path, "unknown type '%s'", show(f->type, tmp));
    const char *enc = f->encoding;
    if (strcasecmp(enc, "raw") == 0)
        h->encoding = ENC_RAW;
    else if (strcasecmp(enc, "gzip") == 0 || strcasecmp(enc, "gz") == 0)
        h->encoding = ENC_GZIP;
    else if (strcasecmp(enc, "ascii") == 0 || strcasecmp(enc, "text") == 0 ||
             strcasecmp(enc, "txt") == 0)
        h->encoding = ENC_ASCII;
    else if (strcasecmp(enc, "bzip2") == 0 || strcasecmp(enc, "bz2") == 0 ||
             strcasecmp(enc, "hex") == 0)
        return fail(err, VM_ERR_UNSUPPORTED, path,
                    "encoding '%s' is not supported (use raw, gzip or ascii)", enc);
    else
        return fail(err, VM_ERR_FORMAT, path, "unknown encoding '%s'", show(enc, tmp));
    if (f->endian) {
        if (strcasecmp(f->endian, "little") == 0)
            h->big_endian = 0;
        else if (strcasecmp(f->endian, "big") == 0)
            h->big_endian = 1;
        else
            return fail(err, VM_ERR_FORMAT, path, "endian '%s' must be little or big",
                        show(f->endian, tmp));
    } else if (vm_scalar_type_size(h->type) > 1 && h->encoding != ENC_ASCII) {
        return fail(err, VM_ERR_FORMAT, path, "missing 'endian' field (needed for %s data)",
                    vm_scalar_type_name(h->type));
    }
    if (f->byte_skip && (parse_ll(f->byte_skip, &h->byte_skip) != VM_OK || h->byte_skip < -1))
        return fail(err, VM_ERR_FORMAT, path, "bad byte skip '%s' (must be -1 or >= 0)",
                    show(f->byte_skip, tmp));
    if (h->byte_skip == -1 && h->encoding != ENC_RAW)
        return fail(err, VM_ERR_FORMAT, path, "byte skip -1 is only allowed with raw encoding");
    if (f->line_skip && (parse_ll(f->line_skip, &h->line_skip) != VM_OK || h->line_skip < 0))
        return fail(err, VM_ERR_FORMAT, path, "bad line skip '%s' (must be >= 0)",
                    show(f->line_skip, tmp));
    return VM_OK;
}

/* The world space's dimension from 'space' and 'space dimension' (which must agree and be
 * 3 when given; 0 when neither is). */
static vm_status interpret_space(const char *path, const nrrd_fields *f, int *sdim,
                                 vm_error *err) {
    char tmp[48];
    *sdim = 0;
    if (f->space) {
        *sdim = space_dimension_of(f->space);
        if (!*sdim)
            return fail(err, VM_ERR_FORMAT, path, "unknown space '%s'", show(f->space, tmp));
    }
    if (f->space_dimension) {
        long long sd;
        if (parse_ll(f->space_dimension, &sd) != VM_OK || sd < 1 || sd > NRRD_DIM_MAX)
            return fail(err, VM_ERR_FORMAT, path, "bad space dimension '%s'",
                        show(f->space_dimension, tmp));
        if (*sdim && sd != *sdim)
            return fail(err, VM_ERR_FORMAT, path,
                        "space dimension %lld contradicts space '%s'", sd,
                        show(f->space, tmp));
        *sdim = (int)sd;
    }
    if (*sdim && *sdim != 3)
        return fail(err, VM_ERR_UNSUPPORTED, path,
                    "space dimension %d is not supported (volmesh needs 3)", *sdim);
    if ((f->space_directions || f->space_origin) && !*sdim)
        return fail(err, VM_ERR_FORMAT, path,
                    "'space directions' and 'space origin' need a 'space' or 'space "
                    "dimension' field");
    return VM_OK;
}

/* 'space directions': one "(x,y,z)" or "none" per axis; each spatial axis's length is its
 * spacing, its unit vector a column of h->direction. */
static vm_status interpret_directions(const char *path, const nrrd_fields *f, long long dim,
                                      int first, nrrd_info *h, vm_error *err) {
    char tmp[48];
    const char *s = f->space_directions;
    for (int a = 0; a < dim; a++) {
        double col[3];
        int r = parse_vector(&s, col, 3);
        if (r < 0)
            return fail(err, VM_ERR_FORMAT, path,
                        "space directions '%s': axis %d is not '(x,y,z)' or 'none'",
                        show(f->space_directions, tmp), a);
        if (a < first) continue;
        if (r == 0)
            return fail(err, VM_ERR_FORMAT, path,
                        "space directions: spatial axis %d has no direction", a);
        double norm = sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2]);
        if (!(norm > 0.0) || !isfinite(norm))
            return fail(err, VM_ERR_FORMAT, path,
                        "space directions: axis %d has a zero-length direction", a);
        h->spacing[a - first] = norm;
        for (int i = 0; i < 3; i++) h->direction[i][a - first] = col[i] / norm;
    }
    while (isspace((unsigned char)*s)) s++;
    if (*s)
        return fail(err, VM_ERR_FORMAT, path, "space directions '%s' must have %lld entries",
                    show(f->space_directions, tmp), dim);
    return VM_OK;
}

/* 'spacings' (used without 'space directions'): one number per axis, NaN for unknown. */
static vm_status interpret_spacings(const char *path, const nrrd_fields *f, long long dim,
                                    int first, nrrd_info *h, vm_error *err) {
    char tmp[48];
    double sp[NRRD_DIM_MAX];
    if (parse_list(f->spacings, NULL, sp, NRRD_DIM_MAX) != dim)
        return fail(err, VM_ERR_FORMAT, path, "spacings '%s' must be %lld numbers",
                    show(f->spacings, tmp), dim);
    for (int a = 0; a < 3; a++) {
        double s = sp[first + a];
        if (isnan(s)) continue; /* NaN: spacing unknown (format definition); keep 1 */
        if (!isfinite(s) || s == 0.0)
            return fail(err, VM_ERR_FORMAT, path,
                        "spacing of axis %d must be a non-zero number", first + a);
        /* A negative spacing flips the axis: keep spacing > 0 as vm_volume requires. */
        h->spacing[a] = fabs(s);
        h->direction[a][a] = s < 0 ? -1.0 : 1.0;
    }
    return VM_OK;
}

/* 'space origin' "(x,y,z)" and 'data file' (a detached single file beside the header). */
static vm_status interpret_origin_and_data(const char *path, const nrrd_fields *f,
                                           nrrd_info *h, vm_error *err) {
    char tmp[48];
    if (f->space_origin) {
        const char *s = f->space_origin;
        int r = parse_vector(&s, h->origin, 3);
        while (r == 1 && isspace((unsigned char)*s)) s++;
        if (r != 1 || *s)
            return fail(err, VM_ERR_FORMAT, path, "space origin '%s' is not '(x,y,z)'",
                        show(f->space_origin, tmp));
    }
    if (f->data_file) {
        const char *df = f->data_file;
        if (strcmp(df, "LIST") == 0 || strncmp(df, "LIST ", 5) == 0 ||
            (strchr(df, '%') && strpbrk(df, " \t")))
            return fail(err, VM_ERR_UNSUPPORTED, path,
                        "multiple data files ('data file: %s') are not supported",
                        show(df, tmp));
        if (!*df) return fail(err, VM_ERR_FORMAT, path, "empty 'data file' field");
        if (!vm__path_sibling(path, df, h->data_file, sizeof h->data_file))
            return fail(err, VM_ERR_FORMAT, path, "data file path is too long");
    }
    return VM_OK;
}

/* The header fields as a volume: layout, storage, then geometry (space directions, or
 * else spacings; identity directions and unit spacing by default). */
static vm_status interpret(const char *path, const nrrd_fields *f, nrrd_info *h,
                           vm_error *err) {
    memset(h, 0, sizeof *h);
    h->big_endian = -1;
    for (int a = 0; a < 3; a++) {
        h->spacing[a] = 1.0;
        h->direction[a][a] = 1.0;
    }
    long long dim = 0;
    int first = 0, sdim = 0;
    vm_status st = interpret_layout(path, f, h, &dim, &first, err);
    if (!st) st = interpret_storage(path, f, h, err);
    if (!st) st = interpret_space(path, f, &sdim, err);
    if (!st && f->space_directions)
        st = interpret_directions(path, f, dim, first, h, err);
    else if (!st && f->spacings)
        st = interpret_spacings(path, f, dim, first, h, err);
    if (!st) st = interpret_origin_and_data(path, f, h, err);
    return st;
}

/* Skips n lines of data text; VM_ERR_FORMAT when the data ends first. */
static vm_status skip_lines(const unsigned char **p, const unsigned char *end, long long n) {
    for (long long i = 0; i < n; i++) {
        const unsigned char *nl = memchr(*p, '\n', (size_t)(end - *p));
        if (!nl) return VM_ERR_FORMAT;
        *p = nl + 1;
    }
    return VM_OK;
}

/* Reads the planes rq asks for (vm__slab_whole: all of them). */
static vm_status read_nrrd(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    vm__map hm, dm;
    memset(&dm, 0, sizeof dm);
    unsigned char *buf;
    size_t len = 0, data_at = 0;
    int ended = 0;
    nrrd_fields f;
    nrrd_info h;
    memset(&h, 0, sizeof h);
    vm_status st = vm__map_file(path, (size_t)-1, &hm, err);
    if (st) return st;
    buf = hm.p;
    len = hm.len;
    st = parse_header(path, buf, len, &f, &data_at, &ended, err);
    if (!st) st = interpret(path, &f, &h, err);
    size_t count = 0, first = 0, n = 0, tsize = vm_scalar_type_size(h.type);
    if (!st) st = vm__slab_check(path, rq, h.dims, tsize, &count, &first, &n, err);
    if (st) goto done;
    size_t need = count * tsize;

    const unsigned char *p, *end;
    if (h.data_file[0]) {
        vm_error derr;
        vm_error_clear(&derr);
        st = vm__map_file(h.data_file, (size_t)-1, &dm, &derr);
        if (st) {
            st = fail(err, st, path, "cannot read data file (%s)", derr.message);
            goto done;
        }
        p = dm.p;
        end = dm.p + dm.len;
    } else {
        if (!ended) {
            st = fail(err, VM_ERR_FORMAT, path,
                      "no blank line ends the header, so no data is attached");
            goto done;
        }
        p = buf + data_at;
        end = buf + len;
    }
    if (skip_lines(&p, end, h.line_skip) != VM_OK) {
        st = fail(err, VM_ERR_FORMAT, path, "line skip %lld goes past the end of the data",
                  h.line_skip);
        goto done;
    }
    size_t avail = (size_t)(end - p);
    vm__samples src = {path, p, avail, VM__ENC_RAW, 0, h.type, 0,
                       (h.data_file[0] ? dm.maplen : hm.maplen) != 0, 0};
    src.swap = tsize > 1 && h.big_endian == vm__host_little_endian();
    if (h.encoding == ENC_RAW || h.encoding == ENC_ASCII) {
        if (h.byte_skip == -1) {
            if (avail < need) {
                st = fail(err, VM_ERR_FORMAT, path, "data is truncated (%zu of %zu bytes)",
                          avail, need);
                goto done;
            }
            p = end - need;
        } else if ((unsigned long long)h.byte_skip > avail) {
            st = fail(err, VM_ERR_FORMAT, path, "byte skip %lld goes past the end of the data",
                      h.byte_skip);
            goto done;
        } else {
            p += h.byte_skip;
        }
        avail = (size_t)(end - p);
        src.p = p;
        src.avail = avail;
        if (h.encoding == ENC_RAW) {
            if (avail < need) {
                st = fail(err, VM_ERR_FORMAT, path, "data is truncated (%zu of %zu bytes)",
                          avail, need);
                goto done;
            }
        } else if (count > avail / 2 + 1) { /* each value takes a character and a separator */
            st = fail(err, VM_ERR_FORMAT, path,
                      "data is truncated (%zu bytes of text cannot hold %zu values)", avail,
                      count);
            goto done;
        } else {
            src.enc = VM__ENC_ASCII;
        }
    } else {
        /* gzip: byte skip counts decompressed bytes. */
        if ((unsigned long long)h.byte_skip > SIZE_MAX - need ||
            (rq->all && need + (size_t)h.byte_skip > vm__memory_limit())) {
            st = fail(err, VM_ERR_NOMEM, path, "byte skip %lld is too large", h.byte_skip);
            goto done;
        }
        size_t total = need + (size_t)h.byte_skip;
        if (total / GZIP_MAX_RATIO > avail + 64) {
            st = fail(err, VM_ERR_FORMAT, path,
                      "compressed data is truncated (%zu bytes cannot hold %zu)", avail, total);
            goto done;
        }
        src.enc = VM__ENC_ZLIB;
        src.skip = (size_t)h.byte_skip;
        src.count = count;
    }

    vm__volume_set_header(v, h.dims, h.type, h.spacing, h.origin,
                          (const double(*)[3])h.direction, "nrrd");
    st = vm__slab_read(path, rq, &src, first, n, v, err);
    if (!st) vm__slab_finish(v, rq);
done:
    vm__map_free(&hm);
    vm__map_free(&dm);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_nrrd(const char *path, vm_volume *v, vm_error *err) {
    return read_nrrd(path, &vm__slab_whole, v, err);
}

vm_status vm__read_nrrd(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    return read_nrrd(path, rq, v, err);
}

/* Little-endian bytes of n floats. */
static void floats_le(const float *src, size_t n, unsigned char *dst) {
    int swap = !vm__host_little_endian();
    for (size_t i = 0; i < n; i++) {
        unsigned char b[4];
        memcpy(b, &src[i], 4);
        for (int k = 0; k < 4; k++) dst[4 * i + k] = swap ? b[3 - k] : b[k];
    }
}

/* Floats converted per write: 64 KiB of staging on the stack. */
enum { CHUNK_FLOATS = 16384 };

/* The floats as raw little-endian bytes. */
static vm_status write_raw(FILE *fp, const float *data, size_t n) {
    unsigned char stage[4 * CHUNK_FLOATS];
    for (size_t i = 0; i < n; i += CHUNK_FLOATS) {
        size_t m = n - i < CHUNK_FLOATS ? n - i : CHUNK_FLOATS;
        floats_le(data + i, m, stage);
        if (fwrite(stage, 4, m, fp) != m) return VM_ERR_IO;
    }
    return VM_OK;
}

/* deflateInit2 settings (zlib manual): zlib's default level and memory level; the largest
 * window (15 bits), + 16 for a gzip wrapper instead of zlib's. */
enum { GZIP_LEVEL = 6, GZIP_WINDOW_BITS = 15 + 16, GZIP_MEM_LEVEL = 8 };

/* gzip stream of the floats, little endian. */
static vm_status write_gzip(FILE *fp, const float *data, size_t n) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (deflateInit2(&zs, GZIP_LEVEL, Z_DEFLATED, GZIP_WINDOW_BITS, GZIP_MEM_LEVEL,
                     Z_DEFAULT_STRATEGY) != Z_OK)
        return VM_ERR_IO;
    unsigned char stage[4 * CHUNK_FLOATS], out[1 << 16];
    size_t i = 0;
    int r = Z_OK;
    do {
        size_t m = n - i < CHUNK_FLOATS ? n - i : CHUNK_FLOATS;
        floats_le(data + i, m, stage);
        i += m;
        int flush = i == n ? Z_FINISH : Z_NO_FLUSH;
        zs.next_in = stage;
        zs.avail_in = (uInt)(4 * m);
        do {
            zs.next_out = out;
            zs.avail_out = sizeof out;
            r = deflate(&zs, flush);
            if (r == Z_STREAM_ERROR) break;
            size_t have = sizeof out - zs.avail_out;
            if (have && fwrite(out, 1, have, fp) != have) r = Z_ERRNO;
        } while (r != Z_ERRNO && zs.avail_out == 0);
    } while (i < n && r != Z_ERRNO && r != Z_STREAM_ERROR);
    deflateEnd(&zs);
    return r == Z_STREAM_END ? VM_OK : VM_ERR_IO;
}

vm_status vm_volume_write_nrrd(const char *path, const vm_volume *v, int gzip, vm_error *err) {
    assert(path && v && v->data);
    size_t count;
    vm_status st = vm__check_dims(v->dims, sizeof(float), path, &count, err);
    if (st) return st;
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) return st;
    fprintf(o.fp,
            "NRRD0004\n"
            "# Complete NRRD file format specification at:\n"
            "# http://teem.sourceforge.net/nrrd/format.html\n"
            "type: float\n"
            "dimension: 3\n"
            "space dimension: 3\n"
            "sizes: %lld %lld %lld\n"
            "space directions:",
            (long long)v->dims[0], (long long)v->dims[1], (long long)v->dims[2]);
    for (int c = 0; c < 3; c++)
        fprintf(o.fp, " (%.17g,%.17g,%.17g)", v->direction[0][c] * v->spacing[c],
                v->direction[1][c] * v->spacing[c], v->direction[2][c] * v->spacing[c]);
    fprintf(o.fp,
            "\nkinds: domain domain domain\n"
            "endian: little\n"
            "encoding: %s\n"
            "space origin: (%.17g,%.17g,%.17g)\n\n",
            gzip ? "gzip" : "raw", v->origin[0], v->origin[1], v->origin[2]);
    st = gzip ? write_gzip(o.fp, v->data, count) : write_raw(o.fp, v->data, count);
    if (st != VM_OK && !ferror(o.fp)) { /* zlib's failure; a write's is commit's to tell */
        vm__out_abort(&o);
        return fail(err, VM_ERR_IO, path, "compressing failed");
    }
    return vm__out_commit(&o, err); /* names a write error's reason */
}
