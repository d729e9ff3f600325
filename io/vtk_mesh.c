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
    vm_status st = vm__check_cells(path, m, err);
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
            if (vm__cur_token(&r->c, &t2, &n2) && vm__parse_int_tok(t2, n2, &nc)) {
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
            if (!vm__mul_size(count, (size_t)nc, &total))
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

vm_status vm_mesh_read_vtk(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    vtk_reader r;
    memset(&r, 0, sizeof r);
    vm__cur_init(&r.c, path, buf, len, 0, err);
    const char *s, *t;
    size_t n;
    double *pts = NULL, *conn = NULL, *offs = NULL, *types = NULL;
    size_t npts = 0, ncells = 0, nconn = 0;
    int v5 = 0;
    attrs pattr = {NULL, 0, 0}, cattr = {NULL, 0, 0};
    int64_t *keep = NULL;
    if (!vm__cur_line(&r.c, &s, &n) || n < 22 || memcmp(s, "# vtk DataFile Version", 22) != 0) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: not a legacy VTK file", path);
        goto done;
    }
    vm__cur_line(&r.c, &s, &n); /* title */
    if (!vm__cur_token(&r.c, &t, &n) ||
        !(vm__tok_is(t, n, "ASCII") || vm__tok_is(t, n, "BINARY"))) {
        st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "third line must be ASCII or BINARY");
        goto done;
    }
    r.binary = vm__tok_is(t, n, "BINARY");
    if (!vm__cur_token(&r.c, &t, &n) || !vm__tok_is(t, n, "DATASET") ||
        !vm__cur_token(&r.c, &t, &n)) {
        st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "expected DATASET");
        goto done;
    }
    if (!vm__tok_is(t, n, "UNSTRUCTURED_GRID")) {
        st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED, "dataset %.*s is not a mesh volmesh reads "
                          "(UNSTRUCTURED_GRID is)", (int)(n > 30 ? 30 : n), t);
        goto done;
    }
    int seen_points = 0, seen_cells = 0, seen_types = 0;
    while (!st && vm__cur_token(&r.c, &t, &n)) {
        if (vm__tok_is(t, n, "POINTS") && !seen_points++) {
            int64_t np;
            const char *ty;
            size_t tyl;
            st = vm__cur_int(&r.c, 0, INT64_MAX, "number of points", &np);
            if (!st && !vm__cur_token(&r.c, &ty, &tyl))
                st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "POINTS needs a type");
            if (!st && (uint64_t)np > UINT64_MAX / 3)
                st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "too many points");
            if (!st) st = alloc_doubles(&r, 3 * (uint64_t)np, r.binary ? 4 : 2, &pts);
            if (!st) st = read_values(&r, ty, tyl, 3 * (size_t)np, pts);
            npts = (size_t)np;
        } else if (vm__tok_is(t, n, "CELLS") && !seen_cells++) {
            int64_t a, b;
            st = vm__cur_int(&r.c, 0, INT64_MAX, "number of cells", &a);
            if (!st) st = vm__cur_int(&r.c, 0, INT64_MAX, "cell list size", &b);
            if (st) break;
            const char *save = r.c.p;
            if (vm__cur_token(&r.c, &t, &n) && vm__tok_is(t, n, "OFFSETS")) {
                const char *ty;
                size_t tyl;
                v5 = 1;
                if (!vm__cur_token(&r.c, &ty, &tyl))
                    st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "OFFSETS needs a type");
                if (!st && a < 1) st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "OFFSETS needs >= 1");
                if (!st) st = alloc_doubles(&r, (uint64_t)a, 1, &offs);
                if (!st) st = read_values(&r, ty, tyl, (size_t)a, offs);
                if (!st && (!vm__cur_token(&r.c, &t, &n) || !vm__tok_is(t, n, "CONNECTIVITY") ||
                            !vm__cur_token(&r.c, &ty, &tyl)))
                    st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "expected CONNECTIVITY");
                if (!st) st = alloc_doubles(&r, (uint64_t)b, 1, &conn);
                if (!st) st = read_values(&r, ty, tyl, (size_t)b, conn);
                ncells = (size_t)a - 1;
                nconn = (size_t)b;
            } else {
                r.c.p = save;
                st = alloc_doubles(&r, (uint64_t)b, r.binary ? 4 : 2, &conn);
                if (!st) st = read_values(&r, "int", 3, (size_t)b, conn);
                ncells = (size_t)a;
                nconn = (size_t)b;
            }
        } else if (vm__tok_is(t, n, "CELL_TYPES") && !seen_types++) {
            int64_t a;
            st = vm__cur_int(&r.c, 0, INT64_MAX, "number of cell types", &a);
            if (!st && (size_t)a != ncells)
                st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "CELL_TYPES %" PRId64 " for %zu cells",
                                  a, ncells);
            if (!st) st = alloc_doubles(&r, (uint64_t)a, r.binary ? 4 : 2, &types);
            if (!st) st = read_values(&r, "int", 3, (size_t)a, types);
        } else if (vm__tok_is(t, n, "POINT_DATA") || vm__tok_is(t, n, "CELL_DATA")) {
            int pd = vm__tok_is(t, n, "POINT_DATA");
            int64_t a;
            st = vm__cur_int(&r.c, 0, INT64_MAX, "count", &a);
            if (!st && (size_t)a != (pd ? npts : ncells))
                st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "%s %" PRId64 " does not match %zu",
                                  pd ? "POINT_DATA" : "CELL_DATA", a, pd ? npts : ncells);
            if (!st) st = read_attributes(&r, (size_t)a, pd ? &pattr : &cattr);
        } else if (vm__tok_is(t, n, "METADATA")) {
            skip_metadata(&r);
        } else if (vm__tok_is(t, n, "FIELD")) {
            /* dataset-level field data (TIME, CYCLE, ...): read and dropped */
            const char *name;
            size_t nl;
            int64_t narr = 0;
            if (!vm__cur_token(&r.c, &name, &nl))
                st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "FIELD needs a name");
            if (!st) st = vm__cur_int(&r.c, 0, 100000, "number of FIELD arrays", &narr);
            for (int64_t i = 0; i < narr && !st; i++) {
                int64_t nc, nt;
                const char *ty;
                size_t tyl;
                double *d = NULL;
                if (!vm__cur_token(&r.c, &name, &nl))
                    st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "FIELD array needs a name");
                if (!st) st = vm__cur_int(&r.c, 1, 1024, "number of components", &nc);
                if (!st) st = vm__cur_int(&r.c, 0, INT64_MAX, "number of tuples", &nt);
                if (!st && !vm__cur_token(&r.c, &ty, &tyl))
                    st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "FIELD array needs a type");
                if (!st && (uint64_t)nt > UINT64_MAX / 1024)
                    st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "too many tuples");
                if (!st) st = alloc_doubles(&r, (uint64_t)nt * (uint64_t)nc, 1, &d);
                if (!st) st = read_values(&r, ty, tyl, (size_t)(nt * nc), d);
                free(d);
            }
        } else {
            st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "unexpected \"%.*s\"", (int)(n > 30 ? 30 : n),
                              t);
        }
    }
    if (st) goto done;
    if (!seen_points || !seen_cells || !seen_types) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: needs POINTS, CELLS and CELL_TYPES", path);
        goto done;
    }
    /* Pick the kind: volume cells win over surface cells; vertices and lines are skipped. */
    int have[16] = {0};
    for (size_t c = 0; c < ncells; c++) {
        double ty = types[c];
        if (!is_whole(ty, 0, 100)) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: bad cell type %g", path, ty);
            goto done;
        }
        int k = (int)ty;
        if (k == 1 || k == 2 || k == 3 || k == 4) continue;
        if (k != 5 && k != 8 && k != 9 && k != 10 && k != 11 && k != 12) {
            st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: cell type %d is not supported "
                              "(tetra, hexahedron, voxel, triangle, quad, pixel are)", path, k);
            goto done;
        }
        have[k] = 1;
    }
    int vol = have[10] || have[11] || have[12];
    if (have[10] && (have[11] || have[12])) {
        st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes tetrahedra and hexahedra (one "
                          "element kind per mesh)", path);
        goto done;
    }
    int quads = !vol && (have[8] || have[9]);
    if (quads && have[5]) {
        st = vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: mixes triangles and quads", path);
        goto done;
    }
    m->kind = have[10] ? VM_TET4 : vol ? VM_HEX8 : quads ? VM_QUAD4 : VM_TRI3;
    int nn = vm_cell_nodes(m->kind);
    keep = malloc((ncells ? ncells : 1) * sizeof *keep);
    if (!keep || vm_mesh_reserve(m, npts, ncells, err)) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
        goto done;
    }
    memcpy(m->points, pts, 3 * npts * sizeof(double));
    m->npoints = npts;
    size_t at = 0, kept = 0;
    for (size_t c = 0; c < ncells; c++) {
        size_t first, cnt;
        if (v5) {
            if (!is_whole(offs[c], 0, (double)nconn) || !is_whole(offs[c + 1], offs[c], (double)nconn)) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: bad OFFSETS at cell %zu", path, c);
                goto done;
            }
            first = (size_t)offs[c];
            cnt = (size_t)offs[c + 1] - first;
        } else {
            if (at >= nconn || !is_whole(conn[at], 0, 64) || conn[at] > (double)(nconn - at - 1)) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: CELLS list is inconsistent at cell "
                                  "%zu", path, c);
                goto done;
            }
            cnt = (size_t)conn[at];
            first = at + 1;
            at = first + cnt;
        }
        int k = (int)types[c];
        int want = k == 10 ? 4 : k == 5 ? 3 : (k == 8 || k == 9) ? 4 : (k == 11 || k == 12) ? 8 : -1;
        keep[c] = -1;
        if (want < 0 || (vol ? (k < 10) : 0)) continue;
        if ((int)cnt != want) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: cell %zu of type %d has %zu points", path,
                              c, k, cnt);
            goto done;
        }
        vm_index v[8];
        for (int j = 0; j < want; j++) {
            double x = conn[first + (size_t)j];
            if (!is_whole(x, 0, (double)npts - 1)) {
                st = vm_error_set(err, VM_ERR_FORMAT, "%s: cell %zu uses point %g of %zu", path,
                                  c, x, npts);
                goto done;
            }
            v[j] = (vm_index)x;
        }
        if (k == 8 || k == 11) { /* pixel / voxel: swap to quad / hexahedron order */
            vm_index tmp = v[2];
            v[2] = v[3];
            v[3] = tmp;
            if (k == 11) {
                tmp = v[6];
                v[6] = v[7];
                v[7] = tmp;
            }
        }
        vm_mesh_add_cell(m, v, 0, NULL);
        keep[c] = (int64_t)kept++;
    }
    if (!v5 && at != nconn) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: CELLS size %zu, lists use %zu", path, nconn,
                          at);
        goto done;
    }
    (void)nn;
    for (size_t i = 0; i < cattr.n && !st; i++) {
        attr *a = &cattr.a[i];
        if (strcmp(a->name, "region") == 0 && a->ncomp == 1) {
            for (size_t c = 0; c < ncells; c++) {
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
        for (size_t c = 0; c < ncells; c++)
            if (keep[c] >= 0)
                memmove(a->data + (size_t)keep[c] * nc, a->data + c * nc, nc * sizeof(double));
        st = vm_mesh_set_field(m, 1, a->name, a->ncomp, a->data, err);
    }
    for (size_t i = 0; i < pattr.n && !st; i++)
        st = vm_mesh_set_field(m, 0, pattr.a[i].name, pattr.a[i].ncomp, pattr.a[i].data, err);
done:
    free(pts);
    free(conn);
    free(offs);
    free(types);
    free(keep);
    attrs_free(&pattr);
    attrs_free(&cattr);
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}
