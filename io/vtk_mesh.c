/* SPDX-License-Identifier: BSD-3-Clause */
/* io/vtk_mesh.c — legacy VTK UNSTRUCTURED_GRID (.vtk) meshes: writer (ASCII or big-endian
 * BINARY, region as int CELL_DATA, fields as FIELD arrays) and reader (version <= 4.2 CELLS
 * and 5.1 OFFSETS/CONNECTIVITY layouts). Follows "VTK File Formats", Simple Legacy Formats
 * (VTK User's Guide, 4th ed., and the VTK 9 file-formats page for version 5.1). */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"

/* ======================================================================================= */
/* Writer                                                                                   */
/* ======================================================================================= */

static void put_name(FILE *fp, const char *name) {
    /* Legacy names cannot hold white space; an empty name becomes "field". */
    if (!*name) fputs("field", fp);
    for (const char *s = name; *s; s++)
        fputc(*s == ' ' || *s == '\t' || *s == '\n' || *s == '\r' ? '_' : *s, fp);
}

static void put_doubles(FILE *fp, const double *v, size_t n, int per_line, int ascii) {
    if (ascii) {
        for (size_t i = 0; i < n; i++)
            fprintf(fp, "%.17g%c", v[i], (i + 1) % (size_t)per_line == 0 || i + 1 == n ? '\n' : ' ');
        return;
    }
    unsigned char b[8 * 512];
    for (size_t i = 0; i < n; i += 512) {
        size_t k = n - i < 512 ? n - i : 512;
        for (size_t j = 0; j < k; j++)
            vm__put_be64(b + 8 * j, vm__double_bits(v[i + j]));
        fwrite(b, 8, k, fp);
    }
    fputc('\n', fp);
}

static void put_int(FILE *fp, int64_t v, int ascii, int last) {
    if (ascii) {
        fprintf(fp, "%" PRId64 "%c", v, last ? '\n' : ' ');
        return;
    }
    unsigned char b[4];
    vm__put_be32(b, (uint32_t)(int32_t)v);
    fwrite(b, 4, 1, fp);
}

static void put_fields(FILE *fp, const vm_field *f, size_t nf, size_t count, int ascii) {
    size_t k = 0;
    for (size_t i = 0; i < nf; i++)
        if (strcmp(f[i].name, "region") != 0) k++;
    if (!k) return;
    fprintf(fp, "FIELD FieldData %zu\n", k);
    for (size_t i = 0; i < nf; i++) {
        if (strcmp(f[i].name, "region") == 0) continue; /* the region ids take that name */
        put_name(fp, f[i].name);
        fprintf(fp, " %d %zu double\n", f[i].ncomp, count);
        put_doubles(fp, f[i].data, count * (size_t)f[i].ncomp, f[i].ncomp, ascii);
    }
}

vm_status vm_mesh_write_vtk(const char *path, const vm_mesh *m, int ascii, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    opt.ascii = ascii;
    return vm__write_vtk(path, m, &opt, err);
}

vm_status vm__write_vtk(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    int ascii = opt->ascii;
    int nn = vm_cell_nodes(m->kind);
    if (!nn)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    if (m->ncells > (size_t)INT32_MAX / (size_t)(nn + 1) || m->npoints > (size_t)INT32_MAX)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: too large for legacy VTK's 32-bit cell lists (use .vtu)", path);
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) return st;
    FILE *fp = o.fp;
    /* Progress: the points at once, then cell by cell (connectivity, then regions). */
    vm__out_meter(&o, opt->progress, opt->progress_user, (double)m->npoints + 2.0 * m->ncells);
    fprintf(fp, "# vtk DataFile Version 4.2\nvolmesh %s mesh\n%s\nDATASET UNSTRUCTURED_GRID\n",
            vm_cell_kind_name(m->kind), ascii ? "ASCII" : "BINARY");
    fprintf(fp, "POINTS %zu double\n", m->npoints);
    put_doubles(fp, m->points, 3 * m->npoints, 3, ascii);
    vm__out_step(&o, (double)m->npoints);
    fprintf(fp, "CELLS %zu %zu\n", m->ncells, m->ncells * (size_t)(nn + 1));
    for (size_t c = 0; c < m->ncells; c++) {
        put_int(fp, nn, ascii, 0);
        for (int k = 0; k < nn; k++)
            put_int(fp, m->cells[c * (size_t)nn + (size_t)k], ascii, k == nn - 1);
        vm__out_step(&o, 1.0);
    }
    if (!ascii) fputc('\n', fp);
    fprintf(fp, "CELL_TYPES %zu\n", m->ncells);
    for (size_t c = 0; c < m->ncells; c++)
        put_int(fp, (int64_t)m->kind, ascii, 1);
    if (!ascii) fputc('\n', fp);
    fprintf(fp, "CELL_DATA %zu\nSCALARS region int 1\nLOOKUP_TABLE default\n", m->ncells);
    for (size_t c = 0; c < m->ncells; c++) {
        put_int(fp, m->region[c], ascii, 1);
        vm__out_step(&o, 1.0);
    }
    if (!ascii) fputc('\n', fp);
    put_fields(fp, m->cell_fields, m->ncell_fields, m->ncells, ascii);
    if (m->npoint_fields) {
        fprintf(fp, "POINT_DATA %zu\n", m->npoints);
        put_fields(fp, m->point_fields, m->npoint_fields, m->npoints, ascii);
    }
    return vm__out_commit(&o, err);
}

/* ======================================================================================= */
/* Reader                                                                                   */
/* ======================================================================================= */

typedef struct vtk_reader {
    vm__cursor c;
    int binary;
} vtk_reader;

/* Bytes per value of a legacy type name (0: unknown; -1: bit), and whether it is real. */
static int type_size(const char *t, size_t n, int *real) {
    static const struct {
        const char *name;
        int size, real;
    } types[] = {{"unsigned_char", 1, 0},  {"char", 1, 0},         {"signed_char", 1, 0},
                 {"unsigned_short", 2, 0}, {"short", 2, 0},        {"unsigned_int", 4, 0},
                 {"int", 4, 0},            {"unsigned_long", 8, 0}, {"long", 8, 0},
                 {"vtktypeint64", 8, 0},   {"vtktypeuint64", 8, 0}, {"vtkIdType", 4, 0},
                 {"vtktypeint32", 4, 0},   {"vtktypeuint32", 4, 0}, {"unsigned_long_long", 8, 0},
                 {"long_long", 8, 0},      {"float", 4, 1},        {"double", 8, 1},
                 {"bit", -1, 0}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (vm__tok_is(t, n, types[i].name)) {
            *real = types[i].real;
            return types[i].size;
        }
    return 0;
}

/* Reads count values of the named type (ASCII tokens, or big-endian binary) as doubles. */
static vm_status read_values(vtk_reader *r, const char *t, size_t tn, size_t count,
                             double *out) {
    int real = 0, size = type_size(t, tn, &real);
    if (size <= 0)
        return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED, "data type \"%.*s\" is not supported",
                            (int)(tn > 30 ? 30 : tn), t);
    if (!r->binary) {
        for (size_t i = 0; i < count; i++) {
            vm_status st = vm__cur_double(&r->c, "value", &out[i]);
            if (st) return st;
        }
        return VM_OK;
    }
    /* Binary data start after the single line break that ends the keyword line. */
    while (r->c.p < r->c.end && (*r->c.p == ' ' || *r->c.p == '\t' || *r->c.p == '\r'))
        r->c.p++;
    if (r->c.p < r->c.end && *r->c.p == '\n') r->c.p++;
    if (vm__cur_left(&r->c) / (size_t)size < count)
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "binary data are truncated (%zu values of "
                            "%d bytes needed)", count, size);
    const unsigned char *b = (const unsigned char *)r->c.p;
    int is_signed = !(t[0] == 'u' || t[0] == 'U' || vm__tok_is(t, tn, "vtktypeuint64") ||
                      vm__tok_is(t, tn, "vtktypeuint32"));
    for (size_t i = 0; i < count; i++, b += size) {
        uint64_t u = size == 8 ? vm__get_be64(b) : size == 4 ? vm__get_be32(b)
                     : size == 2 ? (uint64_t)((b[0] << 8) | b[1]) : b[0];
        double v;
        if (real)
            v = size == 8 ? vm__bits_double(u) : (double)vm__bits_float((uint32_t)u);
        else if (!is_signed || size == 8)
            v = is_signed ? (double)(int64_t)u : (double)u;
        else
            v = size == 4 ? (double)(int32_t)(uint32_t)u
                : size == 2 ? (double)(int16_t)(uint16_t)u : (double)(int8_t)(uint8_t)u;
        if (!isfinite(v))
            return vm__cur_fail(&r->c, VM_ERR_FORMAT, "a value is not finite");
        out[i] = v;
    }
    r->c.p = (const char *)b;
    return VM_OK;
}

static vm_status alloc_doubles(vtk_reader *r, uint64_t count, int min_bytes, double **out) {
    *out = NULL;
    vm_status st = vm__check_count(&r->c, count, (size_t)min_bytes, "values");
    if (st) return st;
    *out = malloc((size_t)(count ? count : 1) * sizeof(double));
    if (!*out) return vm__cur_fail(&r->c, VM_ERR_NOMEM, "out of memory for %" PRIu64 " values",
                                   count);
    return VM_OK;
}

static int is_whole(double v, double lo, double hi) {
    return v == floor(v) && v >= lo && v <= hi;
}

typedef struct attr {
    char name[64];
    int ncomp;
    double *data; /* count * ncomp */
} attr;

typedef struct attrs {
    attr *a;
    size_t n, cap;
} attrs;

static void attrs_free(attrs *l) {
    for (size_t i = 0; i < l->n; i++)
        free(l->a[i].data);
    free(l->a);
    memset(l, 0, sizeof *l);
}

static vm_status attrs_add(vtk_reader *r, attrs *l, const char *name, size_t nlen, int ncomp,
                           double *data) {
    vm_status st = vm__grow((void **)&l->a, &l->cap, l->n + 1, sizeof *l->a, r->c.err);
    if (st) {
        free(data);
        return vm__cur_fail(&r->c, st, "out of memory");
    }
    attr *a = &l->a[l->n++];
    snprintf(a->name, sizeof a->name, "%.*s", (int)nlen, name);
    a->ncomp = ncomp;
    a->data = data;
    return VM_OK;
}

/* Skips a METADATA block: INFORMATION / COMPONENT_NAMES lines up to an empty line. */
static void skip_metadata(vtk_reader *r) {
    const char *s;
    size_t len;
    vm__cur_line(&r->c, &s, &len);
    while (vm__cur_line(&r->c, &s, &len)) {
        size_t k = 0;
        while (k < len && (s[k] == ' ' || s[k] == '\t'))
            k++;
        if (k == len) break;
    }
}

/* Reads the attributes after POINT_DATA / CELL_DATA count, up to the next section. */
static vm_status read_attributes(vtk_reader *r, size_t count, attrs *out) {
    for (;;) {
        const char *save = r->c.p, *t, *name, *ty;
        size_t n, nlen, tylen;
        if (!vm__cur_token(&r->c, &t, &n)) return VM_OK;
        if (vm__tok_is(t, n, "POINT_DATA") || vm__tok_is(t, n, "CELL_DATA")) {
            r->c.p = save;
            return VM_OK;
        }
        vm_status st = VM_OK;
        if (vm__tok_is(t, n, "SCALARS")) {
            int64_t nc = 1;
            if (!vm__cur_token(&r->c, &name, &nlen) || !vm__cur_token(&r->c, &ty, &tylen))
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "SCALARS needs a name and a type");
            /* optional component count, then an optional LOOKUP_TABLE line */
            const char *s2 = r->c.p, *t2;
            size_t n2;
            if (vm__cur_token(&r->c, &t2, &n2) && vm__parse_int_tok(t2, n2, &nc) == VM_OK) {
                if (nc < 1 || nc > 4)
                    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "SCALARS with %" PRId64
                                        " components", nc);
                s2 = r->c.p;
                if (!vm__cur_token(&r->c, &t2, &n2)) n2 = 0;
            }
            if (n2 && vm__tok_is(t2, n2, "LOOKUP_TABLE")) {
                if (!vm__cur_token(&r->c, &t2, &n2))
                    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "LOOKUP_TABLE needs a name");
            } else {
                r->c.p = s2;
            }
            double *d;
            size_t total;
            if (vm__mul_overflows(count, (size_t)nc, &total))
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "too many values");
            st = alloc_doubles(r, total, r->binary ? 1 : 2, &d);
            if (!st) st = read_values(r, ty, tylen, total, d);
            if (!st) st = attrs_add(r, out, name, nlen, (int)nc, d);
            else free(d);
        } else if (vm__tok_is(t, n, "VECTORS") || vm__tok_is(t, n, "NORMALS") ||
                   vm__tok_is(t, n, "TENSORS")) {
            int nc = vm__tok_is(t, n, "TENSORS") ? 9 : 3;
            if (!vm__cur_token(&r->c, &name, &nlen) || !vm__cur_token(&r->c, &ty, &tylen))
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "%.*s needs a name and a type",
                                    (int)n, t);
            double *d;
            st = alloc_doubles(r, (uint64_t)count * (uint64_t)nc, r->binary ? 1 : 2, &d);
            if (!st) st = read_values(r, ty, tylen, count * (size_t)nc, d);
            if (!st) st = attrs_add(r, out, name, nlen, nc, d);
            else free(d);
        } else if (vm__tok_is(t, n, "FIELD")) {
            int64_t narr;
            if (!vm__cur_token(&r->c, &name, &nlen))
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD needs a name");
            st = vm__cur_int(&r->c, 0, 100000, "number of FIELD arrays", &narr);
            for (int64_t i = 0; i < narr && !st; i++) {
                int64_t nc, nt;
                if (!vm__cur_token(&r->c, &name, &nlen))
                    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD array needs a name");
                st = vm__cur_int(&r->c, 1, 1024, "number of components", &nc);
                if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "number of tuples", &nt);
                if (!st && !vm__cur_token(&r->c, &ty, &tylen))
                    st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD array needs a type");
                if (st) break;
                double *d;
                st = alloc_doubles(r, (uint64_t)nt * (uint64_t)nc, r->binary ? 1 : 2, &d);
                if (!st) st = read_values(r, ty, tylen, (size_t)nt * (size_t)nc, d);
                if (st) {
                    free(d);
                    break;
                }
                if ((size_t)nt == count)
                    st = attrs_add(r, out, name, nlen, (int)nc, d);
                else
                    free(d); /* not one tuple per entry: not a field of this mesh */
            }
        } else if (vm__tok_is(t, n, "METADATA")) {
            skip_metadata(r);
        } else if (vm__tok_is(t, n, "LOOKUP_TABLE") || vm__tok_is(t, n, "COLOR_SCALARS") ||
                   vm__tok_is(t, n, "TEXTURE_COORDINATES")) {
            int64_t k, dim = 1;
            if (!vm__cur_token(&r->c, &name, &nlen))
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "%.*s needs a name", (int)n, t);
            st = vm__cur_int(&r->c, 1, 1 << 20, "size", &k);
            int lut = vm__tok_is(t, n, "LOOKUP_TABLE"), color = vm__tok_is(t, n, "COLOR_SCALARS");
            if (!st && !lut && !color) {
                dim = k;
                if (!vm__cur_token(&r->c, &ty, &tylen))
                    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "needs a type");
            } else {
                ty = r->binary ? "unsigned_char" : "float";
                tylen = strlen(ty);
            }
            uint64_t total = lut ? (uint64_t)k * 4 : color ? count * (uint64_t)k : count * (uint64_t)dim;
            double *d;
            st = alloc_doubles(r, total, 1, &d);
            if (!st) st = read_values(r, ty, tylen, (size_t)total, d);
            free(d);
        } else {
            return vm__cur_fail(&r->c, VM_ERR_FORMAT, "unknown attribute \"%.*s\"",
                                (int)(n > 30 ? 30 : n), t);
        }
        if (st) return st;
    }
}

/* VTK cell type numbers ("VTK File Formats", Figure 2 and vtkCellType.h). */
enum {
    VTK_VERTEX = 1,
    VTK_POLY_VERTEX = 2,
    VTK_LINE = 3,
    VTK_POLY_LINE = 4,
    VTK_TRIANGLE = 5,
    VTK_PIXEL = 8,
    VTK_QUAD = 9,
    VTK_TETRA = 10,
    VTK_VOXEL = 11,
    VTK_HEXAHEDRON = 12,
    VTK_TYPE_MAX = 100 /* larger numbers are refused as bad types */
};

/* Largest number of FIELD arrays / components of one, a sanity bound on the header. */
#define FIELD_MAX_ARRAYS 100000
#define FIELD_MAX_COMPONENTS 1024
/* Longest counted point list of one cell (CELLS, <= 4.2 layout), a sanity bound: the cells
 * volmesh reads have at most 8. */
#define LIST_MAX_POINTS 64

/* The sections of a legacy file as read, before they become a mesh. */
typedef struct vtk_data {
    double *pts, *conn, *offs, *types;
    size_t npts, ncells, nconn;
    int v5; /* 5.1 layout: OFFSETS and CONNECTIVITY instead of counted lists */
    int seen_points, seen_cells, seen_types;
    attrs pattr, cattr;
} vtk_data;

/* Frees what the sections hold. */
static void vtk_data_free(vtk_data *d) {
    free(d->pts);
    free(d->conn);
    free(d->offs);
    free(d->types);
    attrs_free(&d->pattr);
    attrs_free(&d->cattr);
}

/* The first lines: version, title, ASCII/BINARY, DATASET UNSTRUCTURED_GRID. */
static vm_status read_header(vtk_reader *r) {
    const char *s, *t;
    size_t n;
    if (!vm__cur_line(&r->c, &s, &n) || n < 22 || memcmp(s, "# vtk DataFile Version", 22) != 0)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: not a legacy VTK file", r->c.path);
    vm__cur_line(&r->c, &s, &n); /* title */
    if (!vm__cur_token(&r->c, &t, &n) ||
        !(vm__tok_is(t, n, "ASCII") || vm__tok_is(t, n, "BINARY")))
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "third line must be ASCII or BINARY");
    r->binary = vm__tok_is(t, n, "BINARY");
    if (!vm__cur_token(&r->c, &t, &n) || !vm__tok_is(t, n, "DATASET") ||
        !vm__cur_token(&r->c, &t, &n))
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "expected DATASET");
    if (!vm__tok_is(t, n, "UNSTRUCTURED_GRID"))
        return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED, "dataset %.*s is not a mesh volmesh "
                            "reads (UNSTRUCTURED_GRID is)", (int)(n > 30 ? 30 : n), t);
    return VM_OK;
}

/* POINTS n type, then the coordinates. */
static vm_status read_points(vtk_reader *r, vtk_data *d) {
    int64_t np;
    const char *ty;
    size_t tyl;
    vm_status st = vm__cur_int(&r->c, 0, INT64_MAX, "number of points", &np);
    if (!st && !vm__cur_token(&r->c, &ty, &tyl))
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "POINTS needs a type");
    if (!st && (uint64_t)np > UINT64_MAX / 3)
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "too many points");
    if (!st) st = alloc_doubles(r, 3 * (uint64_t)np, r->binary ? 4 : 2, &d->pts);
    if (!st) st = read_values(r, ty, tyl, 3 * (size_t)np, d->pts);
    d->npts = (size_t)np;
    return st;
}

/* CELLS a b: either counted lists (<= 4.2) or OFFSETS a + CONNECTIVITY b (5.1). */
static vm_status read_cells(vtk_reader *r, vtk_data *d) {
    int64_t a, b;
    const char *t, *ty;
    size_t n, tyl;
    vm_status st = vm__cur_int(&r->c, 0, INT64_MAX, "number of cells", &a);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "cell list size", &b);
    if (st) return st;
    const char *save = r->c.p;
    d->nconn = (size_t)b;
    if (!(vm__cur_token(&r->c, &t, &n) && vm__tok_is(t, n, "OFFSETS"))) {
        r->c.p = save;
        d->ncells = (size_t)a;
        st = alloc_doubles(r, (uint64_t)b, r->binary ? 4 : 2, &d->conn);
        if (!st) st = read_values(r, "int", 3, (size_t)b, d->conn);
        return st;
    }
    d->v5 = 1;
    d->ncells = (size_t)a - 1;
    if (!vm__cur_token(&r->c, &ty, &tyl))
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "OFFSETS needs a type");
    if (!st && a < 1) st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "OFFSETS needs >= 1");
    if (!st) st = alloc_doubles(r, (uint64_t)a, 1, &d->offs);
    if (!st) st = read_values(r, ty, tyl, (size_t)a, d->offs);
    if (!st && (!vm__cur_token(&r->c, &t, &n) || !vm__tok_is(t, n, "CONNECTIVITY") ||
                !vm__cur_token(&r->c, &ty, &tyl)))
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "expected CONNECTIVITY");
    if (!st) st = alloc_doubles(r, (uint64_t)b, 1, &d->conn);
    if (!st) st = read_values(r, ty, tyl, (size_t)b, d->conn);
    return st;
}

/* CELL_TYPES a, one type per cell. */
static vm_status read_cell_types(vtk_reader *r, vtk_data *d) {
    int64_t a;
    vm_status st = vm__cur_int(&r->c, 0, INT64_MAX, "number of cell types", &a);
    if (!st && (size_t)a != d->ncells)
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "CELL_TYPES %" PRId64 " for %zu cells", a,
                          d->ncells);
    if (!st) st = alloc_doubles(r, (uint64_t)a, r->binary ? 4 : 2, &d->types);
    if (!st) st = read_values(r, "int", 3, (size_t)a, d->types);
    return st;
}

/* POINT_DATA / CELL_DATA count (pd: which), then its attributes. */
static vm_status read_data_section(vtk_reader *r, vtk_data *d, int pd) {
    int64_t a;
    vm_status st = vm__cur_int(&r->c, 0, INT64_MAX, "count", &a);
    if (!st && (size_t)a != (pd ? d->npts : d->ncells))
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "%s %" PRId64 " does not match %zu",
                          pd ? "POINT_DATA" : "CELL_DATA", a, pd ? d->npts : d->ncells);
    if (!st) st = read_attributes(r, (size_t)a, pd ? &d->pattr : &d->cattr);
    return st;
}

/* Dataset-level FIELD data (TIME, CYCLE, ...): read and dropped. */
static vm_status skip_field(vtk_reader *r) {
    const char *name;
    size_t nl;
    int64_t narr = 0;
    vm_status st = VM_OK;
    if (!vm__cur_token(&r->c, &name, &nl))
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD needs a name");
    if (!st) st = vm__cur_int(&r->c, 0, FIELD_MAX_ARRAYS, "number of FIELD arrays", &narr);
    for (int64_t i = 0; i < narr && !st; i++) {
        int64_t nc, nt;
        const char *ty;
        size_t tyl;
        double *v = NULL;
        if (!vm__cur_token(&r->c, &name, &nl))
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD array needs a name");
        if (!st) st = vm__cur_int(&r->c, 1, FIELD_MAX_COMPONENTS, "number of components", &nc);
        if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "number of tuples", &nt);
        if (!st && !vm__cur_token(&r->c, &ty, &tyl))
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "FIELD array needs a type");
        if (!st && (uint64_t)nt > UINT64_MAX / FIELD_MAX_COMPONENTS)
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "too many tuples");
        if (!st) st = alloc_doubles(r, (uint64_t)nt * (uint64_t)nc, 1, &v);
        if (!st) st = read_values(r, ty, tyl, (size_t)(nt * nc), v);
        free(v);
    }
    return st;
}

/* The sections after the header, each keyword once; POINTS, CELLS, CELL_TYPES required. */
static vm_status read_sections(vtk_reader *r, vtk_data *d) {
    const char *t;
    size_t n;
    vm_status st = VM_OK;
    while (!st && vm__cur_token(&r->c, &t, &n)) {
        if (vm__tok_is(t, n, "POINTS") && !d->seen_points++)
            st = read_points(r, d);
        else if (vm__tok_is(t, n, "CELLS") && !d->seen_cells++)
            st = read_cells(r, d);
        else if (vm__tok_is(t, n, "CELL_TYPES") && !d->seen_types++)
            st = read_cell_types(r, d);
        else if (vm__tok_is(t, n, "POINT_DATA") || vm__tok_is(t, n, "CELL_DATA"))
            st = read_data_section(r, d, vm__tok_is(t, n, "POINT_DATA"));
        else if (vm__tok_is(t, n, "METADATA"))
            skip_metadata(r);
        else if (vm__tok_is(t, n, "FIELD"))
            st = skip_field(r);
        else
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "unexpected \"%.*s\"",
                              (int)(n > 30 ? 30 : n), t);
    }
    if (st) return st;
    if (!d->seen_points || !d->seen_cells || !d->seen_types)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: needs POINTS, CELLS and CELL_TYPES",
                            r->c.path);
    return VM_OK;
}

/* Picks m->kind: volume cells win over surface cells; vertices and lines are skipped.
 * [out] *vol: whether the mesh is of volume cells. */
static vm_status pick_kind(const char *path, const vtk_data *d, vm_mesh *m, int *vol,
                           vm_error *err) {
    int have[16] = {0};
    for (size_t c = 0; c < d->ncells; c++) {
        double ty = d->types[c];
        if (!is_whole(ty, 0, VTK_TYPE_MAX))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: bad cell type %g", path, ty);
        int k = (int)ty;
        if (k == VTK_VERTEX || k == VTK_POLY_VERTEX || k == VTK_LINE || k == VTK_POLY_LINE)
            continue;
        if (k != VTK_TRIANGLE && k != VTK_PIXEL && k != VTK_QUAD && k != VTK_TETRA &&
            k != VTK_VOXEL && k != VTK_HEXAHEDRON)
            return vm_error_set(err, VM_ERR_UNSUPPORTED,
                                "%s: cell type %d is not supported (tetra, hexahedron, voxel, "
                                "triangle, quad, pixel are)", path, k);
        have[k] = 1;
    }
    *vol = have[VTK_TETRA] || have[VTK_VOXEL] || have[VTK_HEXAHEDRON];
    if (have[VTK_TETRA] && (have[VTK_VOXEL] || have[VTK_HEXAHEDRON]))
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes tetrahedra and hexahedra (one "
                            "element kind per mesh)", path);
    int quads = !*vol && (have[VTK_PIXEL] || have[VTK_QUAD]);
    if (quads && have[VTK_TRIANGLE])
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes triangles and quads", path);
    m->kind = have[VTK_TETRA] ? VM_TET4 : *vol ? VM_HEX8 : quads ? VM_QUAD4 : VM_TRI3;
    return VM_OK;
}

/* The point list of cell c: [out] *first (into d->conn) and *cnt; *at walks the counted
 * lists of the <= 4.2 layout. */
static vm_status cell_span(const char *path, const vtk_data *d, size_t c, size_t *at,
                           size_t *first, size_t *cnt, vm_error *err) {
    if (d->v5) {
        if (!is_whole(d->offs[c], 0, (double)d->nconn) ||
            !is_whole(d->offs[c + 1], d->offs[c], (double)d->nconn))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: bad OFFSETS at cell %zu", path, c);
        *first = (size_t)d->offs[c];
        *cnt = (size_t)d->offs[c + 1] - *first;
        return VM_OK;
    }
    if (*at >= d->nconn || !is_whole(d->conn[*at], 0, LIST_MAX_POINTS) ||
        d->conn[*at] > (double)(d->nconn - *at - 1))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: CELLS list is inconsistent at cell %zu",
                            path, c);
    *cnt = (size_t)d->conn[*at];
    *first = *at + 1;
    *at = *first + *cnt;
    return VM_OK;
}

/* Points per cell of VTK type k as volmesh reads it, or -1 for a skipped type. */
static int type_points(int k) {
    if (k == VTK_TETRA || k == VTK_PIXEL || k == VTK_QUAD) return 4;
    if (k == VTK_TRIANGLE) return 3;
    if (k == VTK_VOXEL || k == VTK_HEXAHEDRON) return 8;
    return -1;
}

/* Copies the points and adds the cells of m's kind; [out] keep[c]: the mesh cell of file
 * cell c, or -1 when skipped. */
static vm_status build_cells(const char *path, const vtk_data *d, int vol, vm_mesh *m,
                             int64_t *keep, vm_error *err) {
    memcpy(m->points, d->pts, 3 * d->npts * sizeof(double));
    m->npoints = d->npts;
    size_t at = 0, kept = 0;
    for (size_t c = 0; c < d->ncells; c++) {
        size_t first = 0, cnt = 0;
        vm_status st = cell_span(path, d, c, &at, &first, &cnt, err);
        if (st) return st;
        int k = (int)d->types[c];
        int want = type_points(k);
        keep[c] = -1;
        if (want < 0 || (vol ? (k < VTK_TETRA) : 0)) continue;
        if ((int)cnt != want)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: cell %zu of type %d has %zu points",
                                path, c, k, cnt);
        vm_index v[8];
        for (int j = 0; j < want; j++) {
            double x = d->conn[first + (size_t)j];
            if (!is_whole(x, 0, (double)d->npts - 1))
                return vm_error_set(err, VM_ERR_FORMAT, "%s: cell %zu uses point %g of %zu",
                                    path, c, x, d->npts);
            v[j] = (vm_index)x;
        }
        if (k == VTK_PIXEL || k == VTK_VOXEL) { /* swap to quad / hexahedron order */
            vm_index tmp = v[2];
            v[2] = v[3];
            v[3] = tmp;
            if (k == VTK_VOXEL) {
                tmp = v[6];
                v[6] = v[7];
                v[7] = tmp;
            }
        }
        vm_mesh_add_cell(m, v, 0, NULL);
        keep[c] = (int64_t)kept++;
    }
    if (!d->v5 && at != d->nconn)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: CELLS size %zu, lists use %zu", path,
                            d->nconn, at);
    return VM_OK;
}

/* Cell attributes ("region" becomes the regions, others fields, of the kept cells only)
 * and point attributes (fields) into m. */
static vm_status set_attributes(const char *path, vtk_data *d, const int64_t *keep,
                                vm_mesh *m, vm_error *err) {
    vm_status st = VM_OK;
    for (size_t i = 0; i < d->cattr.n && !st; i++) {
        attr *a = &d->cattr.a[i];
        if (strcmp(a->name, "region") == 0 && a->ncomp == 1) {
            for (size_t c = 0; c < d->ncells; c++) {
                if (keep[c] < 0) continue;
                if (!is_whole(a->data[c], INT32_MIN, INT32_MAX)) {
                    st = vm_error_set(err, VM_ERR_FORMAT, "%s: region of cell %zu is %g", path,
                                      c, a->data[c]);
                    break;
                }
                m->region[keep[c]] = (int32_t)a->data[c];
            }
            continue;
        }
        size_t nc = (size_t)a->ncomp;
        for (size_t c = 0; c < d->ncells; c++)
            if (keep[c] >= 0)
                memmove(a->data + (size_t)keep[c] * nc, a->data + c * nc, nc * sizeof(double));
        st = vm_mesh_set_field(m, 1, a->name, a->ncomp, a->data, err);
    }
    for (size_t i = 0; i < d->pattr.n && !st; i++)
        st = vm_mesh_set_field(m, 0, d->pattr.a[i].name, d->pattr.a[i].ncomp,
                               d->pattr.a[i].data, err);
    return st;
}

/* Reads the whole file, then turns its sections into m. */
vm_status vm_mesh_read_vtk(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    vtk_reader r;
    memset(&r, 0, sizeof r);
    vm__cur_init(&r.c, path, buf, len, 0, err);
    vtk_data d;
    memset(&d, 0, sizeof d);
    int64_t *keep = NULL;
    int vol = 0;
    st = read_header(&r);
    if (!st) st = read_sections(&r, &d);
    if (!st) st = pick_kind(path, &d, m, &vol, err);
    if (!st) {
        keep = malloc((d.ncells ? d.ncells : 1) * sizeof *keep);
        if (!keep || vm_mesh_reserve(m, d.npts, d.ncells, err))
            st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    }
    if (!st) st = build_cells(path, &d, vol, m, keep, err);
    if (!st) st = set_attributes(path, &d, keep, m, err);
    vtk_data_free(&d);
    free(keep);
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}
