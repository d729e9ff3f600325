/* SPDX-License-Identifier: BSD-3-Clause */
/* io/vtu.c — VTK XML UnstructuredGrid (.vtu) writer and reader.
 * Follows "VTK File Formats" (VTK User's Guide, XML formats: appended/inline data, header_type,
 * vtkZLibDataCompressor block header [nblocks][blocksize][lastblocksize][csize...]). */
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/io.h"
#include <errno.h>
#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

#define VTU_BLOCK 32768u

/* ======================================================================================= */
/* Writer                                                                                   */
/* ======================================================================================= */

typedef enum src_kind { SRC_COPY, SRC_INDEX, SRC_OFFSETS, SRC_TYPES } src_kind;

typedef struct out_array {
    const char *type; /* VTK type name */
    char name[400];   /* XML-escaped */
    int ncomp;
    size_t count; /* number of values */
    size_t esize; /* bytes per value */
    src_kind kind;
    const void *src;
    int64_t aux;         /* nodes per cell (offsets) or cell type (types) */
    unsigned char *blob; /* compressed: header + blocks */
    size_t blob_len;
    uint64_t offset;
} out_array;

/* Produces values [first, first+n) of a as raw bytes in host order. */
static void fill_values(const out_array *a, size_t first, size_t n, unsigned char *out) {
    switch (a->kind) {
    case SRC_COPY:
        memcpy(out, (const unsigned char *)a->src + first * a->esize, n * a->esize);
        break;
    case SRC_INDEX:
        for (size_t i = 0; i < n; i++) {
            int64_t v = ((const vm_index *)a->src)[first + i];
            if (a->esize == 4) {
                int32_t w = (int32_t)v;
                memcpy(out + 4 * i, &w, 4);
            } else {
                memcpy(out + 8 * i, &v, 8);
            }
        }
        break;
    case SRC_OFFSETS:
        for (size_t i = 0; i < n; i++) {
            int64_t v = (int64_t)(first + i + 1) * a->aux;
            if (a->esize == 4) {
                int32_t w = (int32_t)v;
                memcpy(out + 4 * i, &w, 4);
            } else {
                memcpy(out + 8 * i, &v, 8);
            }
        }
        break;
    case SRC_TYPES: memset(out, (int)a->aux, n); break;
    }
}

static void xml_escape(const char *s, char *out, size_t cap) {
    size_t j = 0;
    for (; *s; s++) {
        const char *rep = NULL;
        char one[2] = {*s, 0};
        switch (*s) {
        case '&': rep = "&amp;"; break;
        case '<': rep = "&lt;"; break;
        case '>': rep = "&gt;"; break;
        case '"': rep = "&quot;"; break;
        case '\'': rep = "&apos;"; break;
        default: rep = one; break;
        }
        size_t l = strlen(rep);
        if (j + l + 1 > cap) break;
        memcpy(out + j, rep, l);
        j += l;
    }
    out[j] = 0;
}

/* Compresses a in VTU_BLOCK-byte blocks into a->blob at zlib level `level`: UInt64 header
 * then zlib blocks. Blocks are independent, so a group of them is compressed in parallel,
 * then appended in order: the bytes are the same for any thread count. */
#define VTU_GROUP 64
static vm_status compress_array(const char *path, out_array *a, int level, vm_outfile *o,
                                vm_error *err) {
    size_t bytes = a->count * a->esize;
    size_t nblocks = (bytes + VTU_BLOCK - 1) / VTU_BLOCK;
    size_t hdr = (3 + nblocks) * 8;
    uint64_t *h = calloc(3 + nblocks, 8);
    unsigned char *raw = malloc((size_t)VTU_GROUP * VTU_BLOCK);
    uLong bound = compressBound(VTU_BLOCK);
    unsigned char *z = malloc((size_t)VTU_GROUP * bound);
    uLongf zlen[VTU_GROUP];
    int zok[VTU_GROUP];
    size_t cap = 0;
    vm_status st = VM_OK;
    a->blob = NULL;
    a->blob_len = 0;
    if (!h || !raw || !z) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory while compressing", path);
        goto done;
    }
    st = vm__grow((void **)&a->blob, &cap, hdr + bytes / 4 + 64, 1, err);
    if (st) goto done;
    h[0] = nblocks;
    h[1] = VTU_BLOCK;
    h[2] = bytes % VTU_BLOCK;
    a->blob_len = hdr;
    size_t per = VTU_BLOCK / a->esize; /* values per block; esize divides VTU_BLOCK */
    for (size_t b0 = 0; b0 < nblocks; b0 += VTU_GROUP) {
        int ng = nblocks - b0 < VTU_GROUP ? (int)(nblocks - b0) : VTU_GROUP;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int g = 0; g < ng; g++) {
            size_t b = b0 + (size_t)g, first = b * per;
            size_t n = a->count - first < per ? a->count - first : per;
            unsigned char *rb = raw + (size_t)g * VTU_BLOCK;
            fill_values(a, first, n, rb);
            zlen[g] = bound;
            zok[g] = compress2(z + (size_t)g * bound, &zlen[g], rb, (uLong)(n * a->esize),
                               level) == Z_OK;
        }
        for (int g = 0; g < ng; g++) {
            if (!zok[g]) {
                st = vm_error_set(err, VM_ERR_INTERNAL, "%s: zlib compression failed", path);
                goto done;
            }
            st = vm__grow((void **)&a->blob, &cap, a->blob_len + zlen[g], 1, err);
            if (st) goto done;
            memcpy(a->blob + a->blob_len, z + (size_t)g * bound, zlen[g]);
            a->blob_len += zlen[g];
            h[3 + b0 + (size_t)g] = zlen[g];
        }
        size_t done_bytes = (b0 + (size_t)ng) * VTU_BLOCK;
        vm__out_step(o, (double)(((size_t)ng * VTU_BLOCK) -
                                 (done_bytes > bytes ? done_bytes - bytes : 0)));
    }
    memcpy(a->blob, h, hdr);
done:
    if (st) {
        free(a->blob);
        a->blob = NULL;
    }
    free(h);
    free(raw);
    free(z);
    return st;
}

static void write_array_xml(FILE *fp, const out_array *a) {
    fprintf(fp, "        <DataArray type=\"%s\" Name=\"%s\"", a->type, a->name);
    if (a->ncomp != 1) fprintf(fp, " NumberOfComponents=\"%d\"", a->ncomp);
    fprintf(fp, " format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)a->offset);
}

/* Streams an uncompressed array: UInt64 byte count, then the values. */
static void write_raw_array(vm_outfile *o, const out_array *a, unsigned char *buf) {
    FILE *fp = o->fp;
    uint64_t n = (uint64_t)(a->count * a->esize);
    fwrite(&n, 8, 1, fp);
    size_t per = VTU_BLOCK / a->esize;
    for (size_t first = 0; first < a->count; first += per) {
        size_t k = a->count - first < per ? a->count - first : per;
        fill_values(a, first, k, buf);
        fwrite(buf, a->esize, k, fp);
        vm__out_step(o, (double)(k * a->esize));
    }
}

vm_status vm_mesh_write_vtu(const char *path, const vm_mesh *m, int compress, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    opt.compress = compress;
    if (compress != VM_COMPRESS_NONE && compress != VM_COMPRESS_FAST &&
        compress != VM_COMPRESS_BEST)
        return vm_error_set(err, VM_ERR_ARG, "%s: compress is %d: none (0), fast (1) or best (2)",
                            path, compress);
    return vm__write_vtu(path, m, &opt, err);
}

/* Describes the next array of arr (*na counts them); name is XML-escaped into it. */
static out_array *next_array(out_array *arr, size_t *na, const char *type, const char *name,
                             int ncomp, size_t count, size_t esize, src_kind kind,
                             const void *src) {
    out_array *a = &arr[(*na)++];
    a->type = type;
    xml_escape(name, a->name, sizeof a->name);
    a->ncomp = ncomp;
    a->count = count;
    a->esize = esize;
    a->kind = kind;
    a->src = src;
    return a;
}

/* The arrays in file order: point data, cell data (region first), points, cells. Returns
 * their number; [out] *first_cell_data, *first_points: where those groups start. */
static size_t describe_arrays(const vm_mesh *m, size_t nconn, int nn, int vtk_type,
                              out_array *arr, size_t *first_cell_data, size_t *first_points) {
    size_t na = 0;
    for (size_t f = 0; f < m->npoint_fields; f++) {
        const vm_field *fl = &m->point_fields[f];
        next_array(arr, &na, "Float64", fl->name, fl->ncomp, m->npoints * (size_t)fl->ncomp,
                   8, SRC_COPY, fl->data);
    }
    *first_cell_data = na;
    next_array(arr, &na, "Int32", "region", 1, m->ncells, 4, SRC_COPY, m->region);
    for (size_t f = 0; f < m->ncell_fields; f++) {
        const vm_field *fl = &m->cell_fields[f];
        if (strcmp(fl->name, "region") == 0) continue; /* the region ids take that name */
        next_array(arr, &na, "Float64", fl->name, fl->ncomp, m->ncells * (size_t)fl->ncomp, 8,
                   SRC_COPY, fl->data);
    }
    *first_points = na;
    next_array(arr, &na, "Float64", "Points", 3, 3 * m->npoints, 8, SRC_COPY, m->points);
    /* Int32 connectivity and offsets while every value fits (half the bytes to compress and
     * write), Int64 beyond */
    int narrow = m->npoints <= (size_t)INT32_MAX && nconn <= (size_t)INT32_MAX;
    const char *itype = narrow ? "Int32" : "Int64";
    size_t isize = narrow ? 4 : 8;
    next_array(arr, &na, itype, "connectivity", 1, nconn, isize,
               narrow && sizeof(vm_index) == 4 ? SRC_COPY : SRC_INDEX, m->cells);
    next_array(arr, &na, itype, "offsets", 1, m->ncells, isize, SRC_OFFSETS, NULL)->aux = nn;
    next_array(arr, &na, "UInt8", "types", 1, m->ncells, 1, SRC_TYPES, NULL)->aux = vtk_type;
    return na;
}

/* VTK cell types of the second-order elements (vtkCellType.h). */
enum { VTK_QUADRATIC_TETRA = 24, VTK_QUADRATIC_HEXAHEDRON = 25 };

/* The XML part: the piece's sizes and one DataArray per array, then the appended data's
 * opening (the bytes follow). */
static void write_vtu_xml(FILE *fp, const vm_mesh *m, const out_array *arr, size_t na,
                          size_t first_cell_data, size_t first_points, int compress) {
    fprintf(fp,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
            "byte_order=\"%s\" header_type=\"UInt64\"%s>\n",
            vm__host_little_endian() ? "LittleEndian" : "BigEndian",
            compress ? " compressor=\"vtkZLibDataCompressor\"" : "");
    fprintf(fp,
            "  <UnstructuredGrid>\n    <Piece NumberOfPoints=\"%zu\" NumberOfCells=\"%zu\">\n",
            m->npoints, m->ncells);
    fprintf(fp, "      <PointData>\n");
    for (size_t i = 0; i < first_cell_data; i++)
        write_array_xml(fp, &arr[i]);
    fprintf(fp, "      </PointData>\n      <CellData>\n");
    for (size_t i = first_cell_data; i < first_points; i++)
        write_array_xml(fp, &arr[i]);
    fprintf(fp, "      </CellData>\n      <Points>\n");
    write_array_xml(fp, &arr[first_points]);
    fprintf(fp, "      </Points>\n      <Cells>\n");
    for (size_t i = first_points + 1; i < na; i++)
        write_array_xml(fp, &arr[i]);
    fprintf(fp, "      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n"
                "  <AppendedData encoding=\"raw\">\n   _");
}

/* Sets each array's offset in the appended data, compressing the arrays first when asked
 * (uncompressed: a UInt64 byte count, then the bytes). */
static vm_status place_arrays(const char *path, out_array *arr, size_t na, int compress,
                              vm_outfile *o, vm_error *err) {
    uint64_t off = 0;
    /* best is zlib's default level 6: on the CT head mesh level 9 took 60x as long as level 1
     * for a larger file than level 6's (mesh arrays defeat its longer searches) */
    int level = compress == VM_COMPRESS_BEST ? Z_DEFAULT_COMPRESSION : Z_BEST_SPEED;
    for (size_t i = 0; i < na; i++) {
        arr[i].offset = off;
        if (compress) {
            vm_status st = compress_array(path, &arr[i], level, o, err);
            if (st) return st;
            off += arr[i].blob_len;
        } else {
            off += 8 + (uint64_t)(arr[i].count * arr[i].esize);
        }
    }
    return VM_OK;
}

static vm_status write_vtu(const char *path, const vm_mesh *m, int nn, int vtk_type,
                           const vm_mesh_write_options *opt, vm_error *err);

/* Order 1 writes m; order 2 its quadratic view (tetra10 / hexahedron20). */
vm_status vm__write_vtu(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    int nn = vm_cell_nodes(m->kind);
    if (nn == 0)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    if (opt->order != 2) return write_vtu(path, m, nn, (int)m->kind, opt, err);
    vm__quadratic q;
    vm_status st = vm__quadratic_make(path, m, NULL, opt, &q, err);
    if (st) return st;
    st = write_vtu(path, &q.view, m->kind == VM_TET4 ? 10 : 20,
                   m->kind == VM_TET4 ? VTK_QUADRATIC_TETRA : VTK_QUADRATIC_HEXAHEDRON, opt, err);
    vm__quadratic_free(&q);
    return st;
}

/* Describes the arrays, sizes the progress by their bytes, then writes XML and data. */
static vm_status write_vtu(const char *path, const vm_mesh *m, int nn, int vtk_type,
                           const vm_mesh_write_options *opt, vm_error *err) {
    int compress = opt->compress;
    size_t nconn;
    if (vm__mul_overflows(m->ncells, (size_t)nn, &nconn) || nconn > (size_t)INT64_MAX)
        return vm_error_set(err, VM_ERR_ARG, "%s: too many cells", path);
    /* region, Points, connectivity, offsets, types, and the fields */
    size_t narr = 5 + m->ncell_fields + m->npoint_fields;
    out_array *arr = calloc(narr, sizeof *arr);
    unsigned char *buf = malloc(VTU_BLOCK);
    vm_status st = VM_OK;
    vm_outfile o;
    int opened = 0;
    if (!arr || !buf) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
        goto fail;
    }
    size_t first_cell_data, first_points;
    size_t na = describe_arrays(m, nconn, nn, vtk_type, arr, &first_cell_data, &first_points);
    double total_bytes = 0.0;
    for (size_t i = 0; i < na; i++) {
        size_t bytes;
        if (vm__mul_overflows(arr[i].count, arr[i].esize, &bytes)) {
            st = vm_error_set(err, VM_ERR_ARG, "%s: array %s is too large", path, arr[i].name);
            goto fail;
        }
        total_bytes += (double)bytes;
    }
    st = vm__out_open(&o, path, err);
    if (st) goto fail;
    opened = 1;
    vm__out_meter(&o, opt->progress, opt->progress_user, total_bytes);
    st = place_arrays(path, arr, na, compress, &o, err);
    if (st) goto fail;
    FILE *fp = o.fp;
    write_vtu_xml(fp, m, arr, na, first_cell_data, first_points, compress);
    for (size_t i = 0; i < na; i++) {
        if (compress)
            fwrite(arr[i].blob, 1, arr[i].blob_len, fp);
        else
            write_raw_array(&o, &arr[i], buf);
    }
    fprintf(fp, "\n  </AppendedData>\n</VTKFile>\n");
    opened = 0;
    st = vm__out_commit(&o, err);
fail:
    if (opened) vm__out_abort(&o);
    if (arr)
        for (size_t i = 0; i < narr; i++)
            free(arr[i].blob);
    free(arr);
    free(buf);
    return st;
}

/* ======================================================================================= */
/* Reader                                                                                   */
/* ======================================================================================= */

typedef enum dtype {
    DT_INT8,
    DT_UINT8,
    DT_INT16,
    DT_UINT16,
    DT_INT32,
    DT_UINT32,
    DT_INT64,
    DT_UINT64,
    DT_FLOAT32,
    DT_FLOAT64,
    DT_COUNT
} dtype;

static const char *const dtype_names[DT_COUNT] = {"Int8",    "UInt8",  "Int16", "UInt16",
                                                  "Int32",   "UInt32", "Int64", "UInt64",
                                                  "Float32", "Float64"};
static const size_t dtype_size[DT_COUNT] = {1, 1, 2, 2, 4, 4, 8, 8, 4, 8};

enum { SEC_NONE, SEC_POINTDATA, SEC_CELLDATA, SEC_POINTS, SEC_CELLS, SEC_OTHER };
enum { FMT_ASCII, FMT_BINARY, FMT_APPENDED };

typedef struct in_array {
    int section;
    char name[64];
    dtype type;
    int ncomp;
    int format;
    uint64_t offset;
    const char *text; /* inline content (ascii or base64) */
    size_t text_len;
} in_array;

typedef struct vtu_file {
    const char *path;
    const unsigned char *buf;
    size_t len;
    int swap;
    int header64;
    int compressed;
    int appended_b64;
    const unsigned char *appended; /* first byte after '_' or NULL */
    uint64_t npoints, ncells;
    int pieces;
    in_array *arrays;
    size_t narrays, cap;
} vtu_file;

/* --- XML scanning ------------------------------------------------------------------------ */

typedef struct xml_attr {
    char name[32];
    char value[256];
} xml_attr;

typedef struct xml_tag {
    char name[32];
    int end, empty; /* </name> ; <name/> */
    xml_attr attr[16];
    int nattr;
} xml_tag;

static int is_name_char(int c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
           c == '_' || c == ':' || c == '-' || c == '.';
}

static int is_space(int c) {
    return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

/* Decodes XML entities of value [s, e) into out (truncating at cap-1). */
static void xml_unescape(const char *s, const char *e, char *out, size_t cap) {
    size_t j = 0;
    while (s < e && j + 1 < cap) {
        if (*s == '&') {
            static const struct {
                const char *ent;
                char c;
            } ents[] = {{"&amp;", '&'},
                        {"&lt;", '<'},
                        {"&gt;", '>'},
                        {"&quot;", '"'},
                        {"&apos;", '\''}};
            int done = 0;
            for (size_t k = 0; k < sizeof ents / sizeof ents[0]; k++) {
                size_t l = strlen(ents[k].ent);
                if ((size_t)(e - s) >= l && memcmp(s, ents[k].ent, l) == 0) {
                    out[j++] = ents[k].c;
                    s += l;
                    done = 1;
                    break;
                }
            }
            if (done) continue;
            if (e - s > 2 && s[1] == '#') {
                const char *q = s + 2;
                long v = 0;
                int hex = (*q == 'x');
                if (hex) q++;
                while (q < e && *q != ';' && v < 0x110000) {
                    int d = (*q >= '0' && *q <= '9')                      ? *q - '0'
                            : hex && (*q | 32) >= 'a' && (*q | 32) <= 'f' ? (*q | 32) - 'a' + 10
                                                                          : -1;
                    if (d < 0) break;
                    v = v * (hex ? 16 : 10) + d;
                    q++;
                }
                if (q < e && *q == ';' && v > 0 && v < 128) {
                    out[j++] = (char)v;
                    s = q + 1;
                    continue;
                }
            }
        }
        out[j++] = *s++;
    }
    out[j] = 0;
}

/* Parses the tag starting at *pp (pointing at '<'); skips declarations and comments
 * (tag->name empty). Returns 0 on malformed markup. */
static int xml_next_tag(const char **pp, const char *end, xml_tag *tag) {
    const char *p = *pp;
    memset(tag, 0, sizeof *tag);
    if (end - p >= 4 && memcmp(p, "<!--", 4) == 0) {
        for (p += 4; end - p >= 3; p++)
            if (memcmp(p, "-->", 3) == 0) {
                *pp = p + 3;
                return 1;
            }
        return 0;
    }
    if (end - p >= 2 && (p[1] == '?' || p[1] == '!')) {
        const char *q = memchr(p, '>', (size_t)(end - p));
        if (!q) return 0;
        *pp = q + 1;
        return 1;
    }
    p++;
    if (p < end && *p == '/') {
        tag->end = 1;
        p++;
    }
    size_t n = 0;
    while (p < end && is_name_char((unsigned char)*p)) {
        if (n + 1 < sizeof tag->name) tag->name[n++] = *p;
        p++;
    }
    if (n == 0) return 0;
    for (;;) {
        while (p < end && is_space((unsigned char)*p))
            p++;
        if (p >= end) return 0;
        if (*p == '>') {
            *pp = p + 1;
            return 1;
        }
        if (*p == '/' && p + 1 < end && p[1] == '>') {
            tag->empty = 1;
            *pp = p + 2;
            return 1;
        }
        const char *an = p;
        while (p < end && is_name_char((unsigned char)*p))
            p++;
        if (p == an) return 0;
        size_t anl = (size_t)(p - an);
        while (p < end && is_space((unsigned char)*p))
            p++;
        if (p >= end || *p != '=') return 0;
        p++;
        while (p < end && is_space((unsigned char)*p))
            p++;
        if (p >= end || (*p != '"' && *p != '\'')) return 0;
        char q = *p++;
        const char *vs = p;
        while (p < end && *p != q)
            p++;
        if (p >= end) return 0;
        if (tag->nattr < (int)(sizeof tag->attr / sizeof tag->attr[0])) {
            xml_attr *a = &tag->attr[tag->nattr++];
            if (anl >= sizeof a->name) anl = sizeof a->name - 1;
            memcpy(a->name, an, anl);
            a->name[anl] = 0;
            xml_unescape(vs, p, a->value, sizeof a->value);
        }
        p++;
    }
}

static const char *attr_get(const xml_tag *t, const char *name) {
    for (int i = 0; i < t->nattr; i++)
        if (strcmp(t->attr[i].name, name) == 0) return t->attr[i].value;
    return NULL;
}

static int parse_u64(const char *s, uint64_t *out) {
    if (!s) return 0;
    while (is_space((unsigned char)*s))
        s++;
    if (*s < '0' || *s > '9') return 0;
    errno = 0;
    char *e;
    unsigned long long v = strtoull(s, &e, 10);
    if (errno) return 0;
    while (is_space((unsigned char)*e))
        e++;
    if (*e) return 0;
    *out = v;
    return 1;
}

static vm_status add_array(vtu_file *f, const xml_tag *t, int section, vm_error *err) {
    if (f->narrays == f->cap) {
        vm_status st =
            vm__grow((void **)&f->arrays, &f->cap, f->narrays + 1, sizeof(in_array), err);
        if (st) return vm_error_set(err, st, "%s: out of memory", f->path);
    }
    in_array *a = &f->arrays[f->narrays];
    memset(a, 0, sizeof *a);
    a->section = section;
    const char *v = attr_get(t, "Name");
    if (v) snprintf(a->name, sizeof a->name, "%s", v);
    v = attr_get(t, "type");
    a->type = DT_COUNT;
    for (int i = 0; v && i < DT_COUNT; i++)
        if (strcmp(v, dtype_names[i]) == 0) a->type = (dtype)i;
    /* VTK also accepts the legacy names of the 32/64-bit types. */
    if (v && a->type == DT_COUNT) {
        if (strcmp(v, "Float") == 0 || strcmp(v, "float") == 0) a->type = DT_FLOAT32;
        if (strcmp(v, "Double") == 0 || strcmp(v, "double") == 0) a->type = DT_FLOAT64;
    }
    if (a->type == DT_COUNT)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: DataArray %s has unsupported type %s",
                            f->path, a->name, v ? v : "(none)");
    uint64_t nc = 1;
    v = attr_get(t, "NumberOfComponents");
    if (v && (!parse_u64(v, &nc) || nc < 1 || nc > 1024))
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: DataArray %s has a bad NumberOfComponents \"%s\"", f->path,
                            a->name, v);
    a->ncomp = (int)nc;
    v = attr_get(t, "format");
    if (!v || strcmp(v, "ascii") == 0) {
        a->format = FMT_ASCII;
    } else if (strcmp(v, "binary") == 0) {
        a->format = FMT_BINARY;
    } else if (strcmp(v, "appended") == 0) {
        a->format = FMT_APPENDED;
        if (!parse_u64(attr_get(t, "offset"), &a->offset))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: DataArray %s has no valid offset",
                                f->path, a->name);
    } else {
        return vm_error_set(err, VM_ERR_FORMAT, "%s: DataArray %s has unknown format \"%s\"",
                            f->path, a->name, v);
    }
    f->narrays++;
    return VM_OK;
}

static vm_status read_vtkfile_attrs(vtu_file *f, const xml_tag *t, vm_error *err) {
    const char *v = attr_get(t, "type");
    if (!v || strcmp(v, "UnstructuredGrid") != 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: VTK file of type %s, not UnstructuredGrid", f->path,
                            v ? v : "(none)");
    v = attr_get(t, "byte_order");
    int little = 1;
    if (v && strcmp(v, "BigEndian") == 0)
        little = 0;
    else if (v && strcmp(v, "LittleEndian") != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: unknown byte_order \"%s\"", f->path, v);
    f->swap = little != vm__host_little_endian();
    v = attr_get(t, "header_type");
    if (!v || strcmp(v, "UInt32") == 0)
        f->header64 = 0;
    else if (strcmp(v, "UInt64") == 0)
        f->header64 = 1;
    else
        return vm_error_set(err, VM_ERR_FORMAT, "%s: unknown header_type \"%s\"", f->path, v);
    v = attr_get(t, "compressor");
    if (v && *v) {
        if (strcmp(v, "vtkZLibDataCompressor") != 0)
            return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: compressor %s is not supported",
                                f->path, v);
        f->compressed = 1;
    }
    return VM_OK;
}

/* Walks the XML part of the file, collecting the Piece sizes, the DataArray descriptions
 * and where the appended data begins. */
static vm_status scan_xml(vtu_file *f, vm_error *err) {
    const char *p = (const char *)f->buf, *end = p + f->len;
    if (f->len >= 3 && memcmp(p, "\xEF\xBB\xBF", 3) == 0) p += 3; /* UTF-8 byte order mark */
    int depth = 0, section = SEC_NONE, section_depth = -1, array_depth = -1, seen_root = 0;
    in_array *open_array = NULL;
    size_t open_index = 0;
    while (p < end) {
        const char *lt = memchr(p, '<', (size_t)(end - p));
        const char *text_end = lt ? lt : end;
        if (open_array && depth == array_depth && !open_array->text) {
            const char *s = p;
            while (s < text_end && is_space((unsigned char)*s))
                s++;
            if (s < text_end) {
                f->arrays[open_index].text = s;
                f->arrays[open_index].text_len = (size_t)(text_end - s);
            }
        } else if (!seen_root) {
            for (const char *s = p; s < text_end; s++)
                if (!is_space((unsigned char)*s))
                    return vm_error_set(err, VM_ERR_FORMAT, "%s: not an XML file", f->path);
        }
        if (!lt) break;
        p = lt;
        xml_tag t;
        if (!xml_next_tag(&p, end, &t))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: malformed XML near byte %zu", f->path,
                                (size_t)(lt - (const char *)f->buf));
        if (!t.name[0]) continue;
        if (t.end) {
            depth--;
            if (depth < 0)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: unbalanced </%s>", f->path,
                                    t.name);
            if (depth < array_depth) {
                open_array = NULL;
                array_depth = -1;
            }
            if (depth < section_depth) {
                section = SEC_NONE;
                section_depth = -1;
            }
            continue;
        }
        if (!seen_root) {
            if (strcmp(t.name, "VTKFile") != 0)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: not a VTK XML file (root <%s>)",
                                    f->path, t.name);
            seen_root = 1;
            vm_status st = read_vtkfile_attrs(f, &t, err);
            if (st) return st;
        } else if (strcmp(t.name, "Piece") == 0) {
            if (++f->pieces > 1)
                return vm_error_set(err, VM_ERR_UNSUPPORTED,
                                    "%s: more than one Piece is not supported", f->path);
            if (!parse_u64(attr_get(&t, "NumberOfPoints"), &f->npoints) ||
                !parse_u64(attr_get(&t, "NumberOfCells"), &f->ncells))
                return vm_error_set(err, VM_ERR_FORMAT,
                                    "%s: Piece lacks valid NumberOfPoints/NumberOfCells",
                                    f->path);
        } else if (strcmp(t.name, "DataArray") == 0 && section != SEC_NONE &&
                   section != SEC_OTHER && !open_array) {
            vm_status st = add_array(f, &t, section, err);
            if (st) return st;
            if (!t.empty) {
                open_index = f->narrays - 1;
                open_array = &f->arrays[open_index];
                array_depth = depth + 1;
            }
        } else if (section == SEC_NONE && !open_array) {
            int s = strcmp(t.name, "PointData") == 0   ? SEC_POINTDATA
                    : strcmp(t.name, "CellData") == 0  ? SEC_CELLDATA
                    : strcmp(t.name, "Points") == 0    ? SEC_POINTS
                    : strcmp(t.name, "Cells") == 0     ? SEC_CELLS
                    : strcmp(t.name, "FieldData") == 0 ? SEC_OTHER
                                                       : SEC_NONE;
            if (s != SEC_NONE && !t.empty) {
                section = s;
                section_depth = depth + 1;
            }
        }
        if (strcmp(t.name, "AppendedData") == 0) {
            const char *enc = attr_get(&t, "encoding");
            if (enc && strcmp(enc, "base64") == 0)
                f->appended_b64 = 1;
            else if (enc && strcmp(enc, "raw") != 0)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: unknown AppendedData encoding %s",
                                    f->path, enc);
            while (p < end && is_space((unsigned char)*p))
                p++;
            if (p >= end || *p != '_')
                return vm_error_set(err, VM_ERR_FORMAT,
                                    "%s: AppendedData does not start with '_'", f->path);
            f->appended = (const unsigned char *)p + 1;
            break; /* the rest is binary data */
        }
        if (!t.empty) depth++;
        /* open_array may move when the array list grows; refresh it. */
        if (open_array) open_array = &f->arrays[open_index];
    }
    if (!seen_root) return vm_error_set(err, VM_ERR_FORMAT, "%s: no VTKFile element", f->path);
    if (!f->appended && depth != 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: XML is truncated (unclosed elements)",
                            f->path);
    if (f->pieces == 0)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: no Piece element", f->path);
    return VM_OK;
}

/* --- byte sources: raw bytes or base64 text ---------------------------------------------- */

typedef struct bsrc {
    const unsigned char *p, *end;
    int b64;
    unsigned char pend[3];
    int npend, ipend;
} bsrc;

/* Decodes the next 4-character group into s->pend. Returns 1, 0 at end of data, -1 on bad
 * characters. Groups ending in '=' padding decode to fewer bytes; decoding continues after
 * them, because VTK encodes the header and the data as separate base64 runs. */
static int b64_group(bsrc *s) {
    int v[4], n = 0, pad = 0;
    while (n < 4) {
        while (s->p < s->end && is_space(*s->p))
            s->p++;
        if (s->p >= s->end || *s->p == '<') return n == 0 ? 0 : -1;
        int c = *s->p++;
        if (c == '=') {
            if (n < 2) return -1;
            pad++;
            v[n++] = 0;
            continue;
        }
        if (pad) return -1;
        int d = vm__base64_value(c);
        if (d < 0) return -1;
        v[n++] = d;
    }
    uint32_t w = ((uint32_t)v[0] << 18) | ((uint32_t)v[1] << 12) | ((uint32_t)v[2] << 6) |
                 (uint32_t)v[3];
    s->pend[0] = (unsigned char)(w >> 16);
    s->pend[1] = (unsigned char)(w >> 8);
    s->pend[2] = (unsigned char)w;
    s->npend = 3 - pad;
    s->ipend = 0;
    return 1;
}

/* Upper bound of the bytes left in s. */
static size_t bsrc_left(const bsrc *s) {
    size_t n = (size_t)(s->end - s->p);
    return s->b64 ? n / 4 * 3 + 3 + (size_t)(s->npend - s->ipend) : n;
}

/* Reads exactly n bytes; VM_ERR_FORMAT when the data end early or are not valid base64. */
static vm_status bsrc_read(bsrc *s, void *out, size_t n) {
    unsigned char *o = out;
    if (!s->b64) {
        if ((size_t)(s->end - s->p) < n) return VM_ERR_FORMAT;
        memcpy(o, s->p, n);
        s->p += n;
        return VM_OK;
    }
    while (n > 0) {
        if (s->ipend == s->npend && b64_group(s) != 1) return VM_ERR_FORMAT;
        while (n > 0 && s->ipend < s->npend) {
            *o++ = s->pend[s->ipend++];
            n--;
        }
    }
    return VM_OK;
}

static uint64_t load_uint(const unsigned char *b, int bytes, int swap) {
    unsigned char t[8];
    for (int i = 0; i < bytes; i++)
        t[i] = swap ? b[bytes - 1 - i] : b[i];
    if (bytes == 4) {
        uint32_t v;
        memcpy(&v, t, 4);
        return v;
    }
    uint64_t v;
    memcpy(&v, t, 8);
    return v;
}

/* --- decoding arrays --------------------------------------------------------------------- */

/* Decoded values, as doubles or as integers. */
typedef struct values {
    size_t n;
    double *d;
    int64_t *i;
} values;

static vm_status check_alloc(const vtu_file *f, const in_array *a, size_t n, size_t elem,
                             vm_error *err) {
    size_t bytes;
    if (vm__mul_overflows(n, elem, &bytes) || bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "%s: array %s of %zu values is too large",
                            f->path, a->name, n);
    return VM_OK;
}

/* Reads the binary payload (header + data, maybe compressed) from s. */
static vm_status read_payload(const vtu_file *f, const in_array *a, bsrc *s,
                              unsigned char **out, size_t *out_len, vm_error *err) {
    int hb = f->header64 ? 8 : 4;
    unsigned char hbuf[8];
    *out = NULL;
    *out_len = 0;
    if (!f->compressed) {
        if (bsrc_read(s, hbuf, (size_t)hb) != VM_OK)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: header is truncated",
                                f->path, a->name);
        uint64_t nb = load_uint(hbuf, hb, f->swap);
        if (nb > bsrc_left(s))
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: array %s claims %llu bytes, more than the file holds",
                                f->path, a->name, (unsigned long long)nb);
        unsigned char *b = malloc(nb ? (size_t)nb : 1);
        if (!b) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
        if (bsrc_read(s, b, (size_t)nb) != VM_OK) {
            free(b);
            return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: data is truncated or bad",
                                f->path, a->name);
        }
        *out = b;
        *out_len = (size_t)nb;
        return VM_OK;
    }
    unsigned char h3[24];
    if (bsrc_read(s, h3, 3 * (size_t)hb) != VM_OK)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: compression header is truncated",
                            f->path, a->name);
    uint64_t nblocks = load_uint(h3, hb, f->swap), bs = load_uint(h3 + hb, hb, f->swap),
             last = load_uint(h3 + 2 * hb, hb, f->swap);
    if (nblocks > bsrc_left(s) / (size_t)hb)
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: array %s claims %llu blocks, more than the "
                            "file holds",
                            f->path, a->name, (unsigned long long)nblocks);
    if (nblocks > 0 && (bs == 0 || last > bs || bs > ((uint64_t)1 << 40)))
        return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: bad compression block sizes",
                            f->path, a->name);
    uint64_t total = 0;
    if (nblocks > 0) {
        uint64_t full = last ? nblocks - 1 : nblocks;
        if (full > UINT64_MAX / bs)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: size overflows", f->path,
                                a->name);
        total = full * bs + last;
    }
    if (total > vm__memory_limit() || total > SIZE_MAX - 1)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: array %s of %llu bytes is too large",
                            f->path, a->name, (unsigned long long)total);
    size_t nbk = (size_t)nblocks;
    uint64_t *cs = malloc(nbk ? nbk * sizeof *cs : 1);
    unsigned char *cb = NULL, *data = NULL;
    vm_status st = VM_OK;
    if (!cs) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    uint64_t cmax = 0, csum = 0;
    for (size_t b = 0; b < nbk; b++) {
        if (bsrc_read(s, hbuf, (size_t)hb) != VM_OK) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: block sizes are truncated",
                              f->path, a->name);
            goto done;
        }
        cs[b] = load_uint(hbuf, hb, f->swap);
        uint64_t ub = (b + 1 == nbk && last) ? last : bs;
        /* zlib cannot expand data by more than about 1032:1; a larger claim is a lie. */
        if (cs[b] > bsrc_left(s) || ub / 1032 > cs[b] + 16) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: block %zu size is impossible",
                              f->path, a->name, b);
            goto done;
        }
        csum += cs[b];
        if (cs[b] > cmax) cmax = cs[b];
    }
    if (csum > bsrc_left(s)) {
        st = vm_error_set(err, VM_ERR_FORMAT,
                          "%s: array %s: compressed blocks run past the end of the file",
                          f->path, a->name);
        goto done;
    }
    cb = malloc(cmax ? (size_t)cmax : 1);
    data = malloc(total ? (size_t)total : 1);
    if (!cb || !data) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
        goto done;
    }
    size_t pos = 0;
    for (size_t b = 0; b < nbk; b++) {
        size_t ub = (size_t)((b + 1 == nbk && last) ? last : bs);
        if (bsrc_read(s, cb, (size_t)cs[b]) != VM_OK) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: compressed data is truncated",
                              f->path, a->name);
            goto done;
        }
        st = vm__inflate_exact(f->path, cb, (size_t)cs[b], data + pos, ub, err);
        if (st) goto done;
        pos += ub;
    }
    *out = data;
    *out_len = (size_t)total;
    data = NULL;
done:
    free(cs);
    free(cb);
    free(data);
    return st;
}

/* Converts n binary values of type t to doubles or integers. Returns 0 when an integer
 * target gets a float type or a value out of int64 range. */
static int convert_binary(const unsigned char *b, dtype t, int swap, size_t n, values *v) {
    size_t es = dtype_size[t];
    for (size_t k = 0; k < n; k++) {
        unsigned char tmp[8];
        for (size_t j = 0; j < es; j++)
            tmp[j] = swap ? b[k * es + es - 1 - j] : b[k * es + j];
        double d = 0;
        int64_t i = 0;
        int is_float = 0;
        switch (t) {
        case DT_INT8: {
            int8_t x;
            memcpy(&x, tmp, 1);
            i = x;
        } break;
        case DT_UINT8: {
            uint8_t x;
            memcpy(&x, tmp, 1);
            i = x;
        } break;
        case DT_INT16: {
            int16_t x;
            memcpy(&x, tmp, 2);
            i = x;
        } break;
        case DT_UINT16: {
            uint16_t x;
            memcpy(&x, tmp, 2);
            i = x;
        } break;
        case DT_INT32: {
            int32_t x;
            memcpy(&x, tmp, 4);
            i = x;
        } break;
        case DT_UINT32: {
            uint32_t x;
            memcpy(&x, tmp, 4);
            i = x;
        } break;
        case DT_INT64: {
            int64_t x;
            memcpy(&x, tmp, 8);
            i = x;
        } break;
        case DT_UINT64: {
            uint64_t x;
            memcpy(&x, tmp, 8);
            if (x > (uint64_t)INT64_MAX) {
                if (v->i) return 0;
                d = (double)x;
                is_float = 1;
            } else {
                i = (int64_t)x;
            }
        } break;
        case DT_FLOAT32: {
            float x;
            memcpy(&x, tmp, 4);
            d = x;
            is_float = 1;
        } break;
        case DT_FLOAT64: {
            memcpy(&d, tmp, 8);
            is_float = 1;
        } break;
        default: return 0;
        }
        if (v->i) {
            if (is_float) return 0;
            v->i[k] = i;
        } else {
            v->d[k] = is_float ? d : (double)i;
        }
    }
    return 1;
}

/* Decodes array a into values (integers when want_int). */
static vm_status decode_array(const vtu_file *f, const in_array *a, int want_int, values *v,
                              vm_error *err) {
    memset(v, 0, sizeof *v);
    int is_float = a->type == DT_FLOAT32 || a->type == DT_FLOAT64;
    if (want_int && is_float)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s must be integers, not %s",
                            f->path, a->name, dtype_names[a->type]);
    size_t esz = want_int ? sizeof(int64_t) : sizeof(double);
    if (a->format == FMT_ASCII) {
        const char *p = a->text, *end = a->text ? a->text + a->text_len : NULL;
        size_t n = 0;
        for (const char *q = p; q && q < end;) {
            while (q < end && is_space((unsigned char)*q))
                q++;
            if (q >= end) break;
            n++;
            while (q < end && !is_space((unsigned char)*q))
                q++;
        }
        vm_status st = check_alloc(f, a, n, esz, err);
        if (st) return st;
        void *buf = malloc(n ? n * esz : 1);
        if (!buf) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
        if (want_int)
            v->i = buf;
        else
            v->d = buf;
        char tok[128];
        for (size_t k = 0; k < n; k++) {
            while (is_space((unsigned char)*p))
                p++;
            size_t l = 0;
            while (p < end && !is_space((unsigned char)*p)) {
                if (l + 1 < sizeof tok) tok[l] = *p;
                l++;
                p++;
            }
            if (l >= sizeof tok) l = sizeof tok - 1;
            tok[l] = 0;
            char *e;
            errno = 0;
            if (want_int)
                v->i[k] = strtoll(tok, &e, 10);
            else
                v->d[k] = strtod(tok, &e);
            if (e == tok || *e || (want_int && errno == ERANGE)) {
                free(buf);
                memset(v, 0, sizeof *v);
                return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s: bad number \"%s\"",
                                    f->path, a->name, tok);
            }
        }
        v->n = n;
        return VM_OK;
    }
    bsrc s;
    memset(&s, 0, sizeof s);
    if (a->format == FMT_BINARY) {
        s.b64 = 1;
        s.p = (const unsigned char *)a->text;
        s.end = s.p + (a->text ? a->text_len : 0);
    } else {
        if (!f->appended)
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: array %s is appended but there is no "
                                "AppendedData",
                                f->path, a->name);
        size_t avail = (size_t)(f->buf + f->len - f->appended);
        if (a->offset >= avail)
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: array %s: offset %llu is past the end of the file",
                                f->path, a->name, (unsigned long long)a->offset);
        s.b64 = f->appended_b64;
        s.p = f->appended + a->offset;
        s.end = f->buf + f->len;
    }
    unsigned char *bytes;
    size_t nbytes;
    vm_status st = read_payload(f, a, &s, &bytes, &nbytes, err);
    if (st) return st;
    size_t es = dtype_size[a->type];
    if (nbytes % es) {
        free(bytes);
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: array %s: %zu bytes is not a whole number "
                            "of %s values",
                            f->path, a->name, nbytes, dtype_names[a->type]);
    }
    size_t n = nbytes / es;
    st = check_alloc(f, a, n, esz, err);
    void *buf = st ? NULL : malloc(n ? n * esz : 1);
    if (!buf) {
        free(bytes);
        return st ? st : vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", f->path);
    }
    if (want_int)
        v->i = buf;
    else
        v->d = buf;
    int ok = convert_binary(bytes, a->type, f->swap, n, v);
    free(bytes);
    if (!ok) {
        free(buf);
        memset(v, 0, sizeof *v);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: array %s holds values out of range",
                            f->path, a->name);
    }
    v->n = n;
    return VM_OK;
}

static const in_array *find_array(const vtu_file *f, int section, const char *name) {
    for (size_t i = 0; i < f->narrays; i++)
        if (f->arrays[i].section == section && (!name || strcmp(f->arrays[i].name, name) == 0))
            return &f->arrays[i];
    return NULL;
}

static void free_values(values *v) {
    free(v->d);
    free(v->i);
    memset(v, 0, sizeof *v);
}

/* Cell kind for a VTK type id and the node permutation to VTK order of that kind
 * (voxels and pixels are hexes and quads with a different node order). */
static int cell_kind_of(int64_t type, vm_cell_kind *kind, const int **perm) {
    static const int voxel[8] = {0, 1, 3, 2, 4, 5, 7, 6};
    static const int pixel[4] = {0, 1, 3, 2};
    *perm = NULL;
    switch (type) {
    case 5: *kind = VM_TRI3; return 1;
    case 9: *kind = VM_QUAD4; return 1;
    case 10: *kind = VM_TET4; return 1;
    case 12: *kind = VM_HEX8; return 1;
    case 11:
        *kind = VM_HEX8;
        *perm = voxel;
        return 1;
    case 8:
        *kind = VM_QUAD4;
        *perm = pixel;
        return 1;
    }
    return 0;
}

static vm_status build_mesh(vtu_file *f, vm_mesh *m, vm_error *err) {
    values pts = {0, 0, 0}, conn = {0, 0, 0}, offs = {0, 0, 0}, types = {0, 0, 0},
           fv = {0, 0, 0};
    vm_status st = VM_OK;
    const in_array *ap = find_array(f, SEC_POINTS, NULL);
    const in_array *ac = find_array(f, SEC_CELLS, "connectivity");
    const in_array *ao = find_array(f, SEC_CELLS, "offsets");
    const in_array *at = find_array(f, SEC_CELLS, "types");
    if (f->npoints > 0 && !ap)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: no Points array", f->path);
    if (f->ncells > 0 && (!ac || !ao || !at))
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: Cells needs connectivity, offsets and types arrays", f->path);
    if (ap) {
        if ((st = decode_array(f, ap, 0, &pts, err))) goto done;
        if (ap->ncomp != 3 || f->npoints > SIZE_MAX / 3 || pts.n != 3 * f->npoints) {
            st = vm_error_set(err, VM_ERR_FORMAT,
                              "%s: Points holds %zu values with %d components, expected 3 x "
                              "%llu",
                              f->path, pts.n, ap->ncomp, (unsigned long long)f->npoints);
            goto done;
        }
    }
    vm_cell_kind kind = VM_TET4;
    const int *perm = NULL;
    int nn = 4;
    if (f->ncells > 0) {
        if ((st = decode_array(f, at, 1, &types, err))) goto done;
        if ((st = decode_array(f, ao, 1, &offs, err))) goto done;
        if ((st = decode_array(f, ac, 1, &conn, err))) goto done;
        if (types.n != f->ncells) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: types holds %zu values for %llu cells",
                              f->path, types.n, (unsigned long long)f->ncells);
            goto done;
        }
        if (!cell_kind_of(types.i[0], &kind, &perm)) {
            st = vm_error_set(err, VM_ERR_UNSUPPORTED,
                              "%s: cell type %lld is not supported "
                              "(tet, hex, triangle, quad only)",
                              f->path, (long long)types.i[0]);
            goto done;
        }
        for (size_t c = 1; c < types.n; c++)
            if (types.i[c] != types.i[0]) {
                st = vm_error_set(err, VM_ERR_UNSUPPORTED,
                                  "%s: mixed cell types %lld and %lld (one kind per mesh)",
                                  f->path, (long long)types.i[0], (long long)types.i[c]);
                goto done;
            }
        nn = vm_cell_nodes(kind);
        /* Offsets end each cell; some writers add a leading 0. */
        const int64_t *o = offs.i;
        size_t no = offs.n;
        if (no == f->ncells + 1 && o[0] == 0) {
            o++;
            no--;
        }
        if (no != f->ncells) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: offsets holds %zu values for %llu cells",
                              f->path, offs.n, (unsigned long long)f->ncells);
            goto done;
        }
        for (size_t c = 0; c < no; c++)
            if (o[c] != (int64_t)(c + 1) * nn) {
                st = vm_error_set(err, VM_ERR_FORMAT,
                                  "%s: offsets[%zu] = %lld, expected %lld for %s cells",
                                  f->path, c, (long long)o[c], (long long)(c + 1) * nn,
                                  vm_cell_kind_name(kind));
                goto done;
            }
        if (conn.n != f->ncells * (size_t)nn) {
            st = vm_error_set(err, VM_ERR_FORMAT,
                              "%s: connectivity holds %zu values, expected %llu", f->path,
                              conn.n, (unsigned long long)f->ncells * (unsigned long long)nn);
            goto done;
        }
        for (size_t k = 0; k < conn.n; k++)
            if (conn.i[k] < 0 || (uint64_t)conn.i[k] >= f->npoints) {
                st = vm_error_set(err, VM_ERR_FORMAT,
                                  "%s: connectivity[%zu] = %lld is not a point index", f->path,
                                  k, (long long)conn.i[k]);
                goto done;
            }
    }
    vm_mesh_init(m, kind);
    size_t np = (size_t)f->npoints, nc = (size_t)f->ncells;
    if ((st = vm_mesh_reserve(m, np, nc, err))) {
        vm_error_set(err, st, "%s: out of memory for %zu points and %zu cells", f->path, np,
                     nc);
        goto done;
    }
    if (np) memcpy(m->points, pts.d, np * 3 * sizeof(double));
    m->npoints = np;
    for (size_t c = 0; c < nc; c++) {
        for (int j = 0; j < nn; j++)
            m->cells[c * (size_t)nn + (size_t)j] =
                (vm_index)conn.i[c * (size_t)nn + (size_t)(perm ? perm[j] : j)];
        m->region[c] = 0;
    }
    m->ncells = nc;
    for (size_t i = 0; i < f->narrays; i++) {
        const in_array *a = &f->arrays[i];
        if (a->section != SEC_POINTDATA && a->section != SEC_CELLDATA) continue;
        int on_cells = a->section == SEC_CELLDATA;
        size_t count = on_cells ? nc : np;
        int is_region = on_cells && strcmp(a->name, "region") == 0 && a->ncomp == 1;
        if (!is_region && (a->type != DT_FLOAT32 && a->type != DT_FLOAT64)) continue;
        if (!a->name[0]) continue;
        if ((st = decode_array(f, a, 0, &fv, err))) goto done;
        if (count > SIZE_MAX / (size_t)a->ncomp || fv.n != count * (size_t)a->ncomp) {
            st = vm_error_set(err, VM_ERR_FORMAT, "%s: array %s holds %zu values, expected %zu",
                              f->path, a->name, fv.n, count * (size_t)a->ncomp);
            goto done;
        }
        if (is_region) {
            for (size_t c = 0; c < nc; c++) {
                double d = fv.d[c];
                if (!(d >= INT32_MIN && d <= INT32_MAX) || d != (double)(int32_t)d) {
                    st = vm_error_set(err, VM_ERR_FORMAT,
                                      "%s: region of cell %zu is not a 32-bit integer", f->path,
                                      c);
                    goto done;
                }
                m->region[c] = (int32_t)d;
            }
        } else if ((st = vm_mesh_set_field(m, on_cells, a->name, a->ncomp, fv.d, err))) {
            vm_error_set(err, st, "%s: out of memory for array %s", f->path, a->name);
            goto done;
        }
        free_values(&fv);
    }
done:
    free_values(&pts);
    free_values(&conn);
    free_values(&offs);
    free_values(&types);
    free_values(&fv);
    return st;
}

vm_status vm_mesh_read_vtu(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    vtu_file f;
    memset(&f, 0, sizeof f);
    f.path = path;
    unsigned char *buf;
    size_t len;
    vm_status st = vm__read_file(path, vm__memory_limit(), &buf, &len, err);
    if (st) return st;
    f.buf = buf;
    f.len = len;
    if (len == 0)
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: file is empty", path);
    else
        st = scan_xml(&f, err);
    if (!st) st = build_mesh(&f, m, err);
    if (!st) st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) vm_mesh_free(m);
    free(f.arrays);
    free(buf);
    return st;
}
