/* SPDX-License-Identifier: BSD-3-Clause */
/* io/surface_formats.c — triangle/quad surface files: STL (binary and ASCII), OFF, PLY
 * (binary little endian and ASCII), Wavefront OBJ; writers and readers. A volume mesh is
 * written as its boundary. Follows the 3D Systems "StereoLithography Interface
 * Specification" (1989), Geomview's OFF description, Greg Turk's "The PLY Polygon File
 * Format" (1994) and Wavefront's "Object Files (.obj)" appendix B1. */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* Faces of s as triangles (quads split along 0-2) for STL: [out] tri[3], count. */
static int face_tris(const vm_mesh *s, size_t c, vm_index tri[2][3]) {
    size_t nn = (size_t)vm_cell_nodes(s->kind);
    const vm_index *v = s->cells + c * nn;
    tri[0][0] = v[0];
    tri[0][1] = v[1];
    tri[0][2] = v[2];
    if (nn == 3) return 1;
    tri[1][0] = v[0];
    tri[1][1] = v[2];
    tri[1][2] = v[3];
    return 2;
}

static void tri_normal(const vm_mesh *s, const vm_index t[3], double n[3]) {
    const double *a = s->points + 3 * (size_t)t[0], *b = s->points + 3 * (size_t)t[1],
                 *c = s->points + 3 * (size_t)t[2];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    n[0] = u[1] * w[2] - u[2] * w[1];
    n[1] = u[2] * w[0] - u[0] * w[2];
    n[2] = u[0] * w[1] - u[1] * w[0];
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int d = 0; d < 3; d++)
        n[d] = l > 0 ? n[d] / l : 0;
}

/* Opens the output for a surface writer: resolves the surface and checks it. */
static vm_status begin_surface(const char *path, const vm_mesh *m, vm_mesh *tmp,
                               const vm_mesh **s, vm_error *err) {
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    return vm__surface_of(path, m, tmp, s, err);
}

/* A text or PLY surface writer's output: the surface (m itself, or its boundary held in tmp)
 * with its nodes per face, and the file. */
typedef struct surface_out {
    vm_mesh tmp;
    const vm_mesh *s;
    size_t nn;
    vm_outfile o;
} surface_out;

/* begin_surface, then the output file opened (the surface freed again if that fails) with
 * its progress over the surface's points and faces. */
static vm_status begin_surface_file(const char *path, const vm_mesh *m,
                                    const vm_mesh_write_options *opt, surface_out *so,
                                    vm_error *err) {
    vm_status st = begin_surface(path, m, &so->tmp, &so->s, err);
    if (st) return st;
    st = vm__out_open(&so->o, path, err);
    if (st) {
        vm_mesh_free(&so->tmp);
        return st;
    }
    so->nn = (size_t)vm_cell_nodes(so->s->kind);
    vm__out_meter(&so->o, opt->progress, opt->progress_user,
                  (double)so->s->npoints + so->s->ncells);
    return VM_OK;
}

/* Frees the surface, then checks and renames the file. */
static vm_status end_surface_file(surface_out *so, vm_error *err) {
    vm_mesh_free(&so->tmp);
    return vm__out_commit(&so->o, err);
}

/* One text line per point: prefix, then the coordinates, exactly (%.17g). */
static void put_points_text(vm_outfile *o, const vm_mesh *s, const char *prefix) {
    for (size_t i = 0; i < s->npoints; i++) {
        const double *p = s->points + 3 * i;
        fprintf(o->fp, "%s%.17g %.17g %.17g\n", prefix, p[0], p[1], p[2]);
        vm__out_step(o, 1.0);
    }
}

/* ======================================================================================= */
/* STL                                                                                      */
/* ======================================================================================= */

vm_status vm_mesh_write_stl(const char *path, const vm_mesh *m, int ascii, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    opt.ascii = ascii;
    return vm__write_stl(path, m, &opt, err);
}

vm_status vm__write_stl(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    int ascii = opt->ascii;
    vm_mesh tmp;
    const vm_mesh *s = NULL;
    vm_status st = begin_surface(path, m, &tmp, &s, err);
    if (st) return st;
    size_t ntri = s->kind == VM_QUAD4 ? 2 * s->ncells : s->ncells;
    if (!ascii && ntri > UINT32_MAX) {
        vm_mesh_free(&tmp);
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: more triangles than binary STL holds",
                            path);
    }
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) {
        vm_mesh_free(&tmp);
        return st;
    }
    FILE *fp = o.fp;
    vm__out_meter(&o, opt->progress, opt->progress_user, (double)s->ncells);
    if (ascii) {
        /* One solid per region, faces in mesh order within each. */
        int32_t *regions = NULL;
        size_t nreg = 0;
        st = vm__distinct_regions(path, s, &regions, &nreg, err);
        if (st) {
            vm__out_abort(&o);
            vm_mesh_free(&tmp);
            return st;
        }
        for (size_t r = 0; r < nreg; r++) {
            char name[32];
            vm__region_name(regions[r], name, sizeof name);
            fprintf(fp, "solid %s\n", name);
            for (size_t c = 0; c < s->ncells; c++) {
                if (s->region[c] != regions[r]) continue;
                vm_index t[2][3];
                int k = face_tris(s, c, t);
                for (int j = 0; j < k; j++) {
                    double n[3];
                    tri_normal(s, t[j], n);
                    fprintf(fp, "  facet normal %.17g %.17g %.17g\n    outer loop\n", n[0], n[1],
                            n[2]);
                    for (int v = 0; v < 3; v++) {
                        const double *p = s->points + 3 * (size_t)t[j][v];
                        fprintf(fp, "      vertex %.17g %.17g %.17g\n", p[0], p[1], p[2]);
                    }
                    fprintf(fp, "    endloop\n  endfacet\n");
                }
                vm__out_step(&o, 1.0);
            }
            fprintf(fp, "endsolid %s\n", name);
        }
        if (nreg == 0) fprintf(fp, "solid REGION_0\nendsolid REGION_0\n");
        free(regions);
    } else {
        unsigned char hdr[84];
        memset(hdr, ' ', 80);
        const char *h = "volmesh binary STL; attribute = region id";
        memcpy(hdr, h, strlen(h));
        vm__put_le32(hdr + 80, (uint32_t)ntri);
        fwrite(hdr, 1, 84, fp);
        for (size_t c = 0; c < s->ncells; c++) {
            vm_index t[2][3];
            int k = face_tris(s, c, t);
            for (int j = 0; j < k; j++) {
                unsigned char rec[50];
                double n[3];
                tri_normal(s, t[j], n);
                for (int d = 0; d < 3; d++)
                    vm__put_le32(rec + 4 * d, vm__float_bits((float)n[d]));
                for (int v = 0; v < 3; v++)
                    for (int d = 0; d < 3; d++)
                        vm__put_le32(rec + 12 + 12 * v + 4 * d,
                                     vm__float_bits((float)s->points[3 * (size_t)t[j][v] + (size_t)d]));
                int32_t r = s->region[c];
                vm__put_le16(rec + 48, (uint16_t)(r >= 0 && r <= 65535 ? r : 0));
                fwrite(rec, 1, 50, fp);
            }
            vm__out_step(&o, 1.0);
        }
    }
    vm_mesh_free(&tmp);
    return vm__out_commit(&o, err);
}

static vm_status stl_read_binary(const char *path, const unsigned char *b, size_t len,
                                 vm_mesh *m, vm_error *err) {
    uint32_t n = vm__get_le32(b + 80);
    if ((uint64_t)len != 84 + 50 * (uint64_t)n)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: binary STL of %" PRIu32 " triangles needs "
                            "%" PRIu64 " bytes, file has %zu", path, n, 84 + 50 * (uint64_t)n,
                            len);
    vm_point_index pm = {0, NULL};
    vm_status st = vm_mesh_reserve(m, 0, n, err);
    for (uint32_t i = 0; i < n && !st; i++) {
        const unsigned char *rec = b + 84 + 50 * (size_t)i;
        vm_index v[3];
        for (int k = 0; k < 3 && !st; k++) {
            double p[3];
            for (int d = 0; d < 3; d++) {
                p[d] = (double)vm__bits_float(vm__get_le32(rec + 12 + 12 * k + 4 * d));
                if (!isfinite(p[d]))
                    st = vm_error_set(err, VM_ERR_FORMAT, "%s: triangle %" PRIu32 " has a "
                                      "non-finite coordinate", path, i);
            }
            if (!st && (v[k] = vm__point_index_add(&pm, m, p, err)) < 0) st = VM_ERR_NOMEM;
        }
        if (!st) st = vm_mesh_add_cell(m, v, (int32_t)vm__get_le16(rec + 48), err);
    }
    vm_point_index_free(&pm);
    return st;
}

static vm_status stl_read_ascii(const char *path, const unsigned char *b, size_t len,
                                vm_mesh *m, vm_error *err) {
    vm__cursor c;
    vm__cur_init(&c, path, b, len, 0, err);
    vm_point_index pm = {0, NULL};
    const char *t;
    size_t n;
    vm_status st = VM_OK;
    int32_t region = 0, nsolids = 0;
    int in_solid = 0;
    while (!st && vm__cur_token(&c, &t, &n)) {
        if (vm__tok_is(t, n, "solid")) {
            if (in_solid) {
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "solid inside a solid");
                break;
            }
            in_solid = 1;
            const char *s = "";
            size_t sl = 0;
            if (!vm__cur_line(&c, &s, &sl)) sl = 0; /* "solid" at the very end */
            while (sl && (*s == ' ' || *s == '\t')) {
                s++;
                sl--;
            }
            size_t w = 0;
            while (w < sl && s[w] != ' ' && s[w] != '\t')
                w++;
            if (vm__region_parse(s, w, &region) != VM_OK) region = nsolids;
            nsolids++;
        } else if (vm__tok_is(t, n, "endsolid")) {
            const char *s;
            size_t sl;
            vm__cur_line(&c, &s, &sl);
            in_solid = 0;
        } else if (vm__tok_is(t, n, "facet") && in_solid) {
            double x;
            if (!vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "normal")) {
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "expected facet normal");
                break;
            }
            for (int d = 0; d < 3 && !st; d++)
                st = vm__cur_double(&c, "normal component", &x);
            if (!st && (!vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "outer") ||
                        !vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "loop")))
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "expected outer loop");
            vm_index v[3];
            for (int k = 0; k < 3 && !st; k++) {
                double p[3];
                if (!vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "vertex")) {
                    st = vm__cur_fail(&c, VM_ERR_FORMAT, "expected vertex (3 per facet)");
                    break;
                }
                for (int d = 0; d < 3 && !st; d++)
                    st = vm__cur_double(&c, "vertex coordinate", &p[d]);
                if (!st && (v[k] = vm__point_index_add(&pm, m, p, err)) < 0) st = VM_ERR_NOMEM;
            }
            if (!st && (!vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "endloop") ||
                        !vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "endfacet")))
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "expected endloop endfacet");
            if (!st) st = vm_mesh_add_cell(m, v, region, err);
        } else {
            st = vm__cur_fail(&c, VM_ERR_FORMAT, "unexpected \"%.*s\" in ASCII STL",
                              (int)(n > 30 ? 30 : n), t);
        }
    }
    if (!st && !nsolids) st = vm_error_set(err, VM_ERR_FORMAT, "%s: not an STL file", path);
    vm_point_index_free(&pm);
    return st;
}

vm_status vm_mesh_read_stl(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TRI3);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    /* Binary files may also begin with "solid": the size decides, as most readers do. */
    int binary = len >= 84 && (uint64_t)len == 84 + 50 * (uint64_t)vm__get_le32(buf + 80);
    size_t k = 0;
    while (k < len && (buf[k] == ' ' || buf[k] == '\t' || buf[k] == '\r' || buf[k] == '\n'))
        k++;
    int ascii = !binary && len - k >= 5 && memcmp(buf + k, "solid", 5) == 0;
    if (binary || (!ascii && len >= 84))
        st = stl_read_binary(path, buf, len, m, err);
    else if (ascii)
        st = stl_read_ascii(path, buf, len, m, err);
    else
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: not an STL file (too short)", path);
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}

/* ======================================================================================= */
/* OFF                                                                                      */
/* ======================================================================================= */

vm_status vm_mesh_write_off(const char *path, const vm_mesh *m, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    return vm__write_off(path, m, &opt, err);
}

vm_status vm__write_off(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    surface_out so;
    vm_status st = begin_surface_file(path, m, opt, &so, err);
    if (st) return st;
    const vm_mesh *s = so.s;
    FILE *fp = so.o.fp;
    size_t nn = so.nn;
    fprintf(fp, "OFF\n# volmesh %s surface\n%zu %zu 0\n", vm_cell_kind_name(s->kind),
            s->npoints, s->ncells);
    put_points_text(&so.o, s, "");
    for (size_t c = 0; c < s->ncells; c++) {
        fprintf(fp, "%zu", nn);
        for (size_t k = 0; k < nn; k++)
            fprintf(fp, " %lld", (long long)s->cells[c * nn + k]);
        fputc('\n', fp);
        vm__out_step(&so.o, 1.0);
    }
    return end_surface_file(&so, err);
}

/* Adds a polygon of k >= 3 vertices: triangles and quads as they are, larger ones as a fan. */
static vm_status add_polygon(vm__polys *p, const vm_index *v, size_t k, int32_t region,
                             vm_error *err) {
    if (k <= 4) return vm__polys_add(p, v, (int)k, region, err);
    for (size_t i = 1; i + 1 < k; i++) {
        vm_index t[3] = {v[0], v[i], v[i + 1]};
        vm_status st = vm__polys_add(p, t, 3, region, err);
        if (st) return st;
    }
    return VM_OK;
}

/* Reads OFF: counts, vertices, then faces (polygons of 3 or more vertices). */
vm_status vm_mesh_read_off(const char *path, vm_mesh *m, vm_error *err) {
    unsigned char *buf = NULL;
    vm__cursor c;
    vm_status st = vm__mesh_read_begin(path, m, VM_TRI3, '#', &buf, &c, err);
    if (st) return st;
    vm__polys polys;
    memset(&polys, 0, sizeof polys);
    vm_index *v = NULL;
    size_t capv = 0;
    const char *t;
    size_t n;
    int64_t nv = 0, nf = 0, ne = 0;
    if (!vm__cur_token(&c, &t, &n) || !vm__tok_is(t, n, "OFF")) {
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: not an OFF file (expected OFF first; COFF, "
                          "NOFF and 4OFF are not supported)", path);
        goto done;
    }
    st = vm__cur_int(&c, 0, INT64_MAX, "number of vertices", &nv);
    if (!st) st = vm__cur_int(&c, 0, INT64_MAX, "number of faces", &nf);
    if (!st) st = vm__cur_int(&c, 0, INT64_MAX, "number of edges", &ne);
    if (!st) st = vm__check_count(&c, (uint64_t)nv, 6, "vertices");
    if (!st) st = vm__check_count(&c, (uint64_t)nf, 6, "faces");
    if (!st) st = vm_mesh_reserve(m, (size_t)nv, 0, err);
    for (int64_t i = 0; i < nv && !st; i++) {
        double p[3];
        for (int d = 0; d < 3 && !st; d++)
            st = vm__cur_double(&c, "vertex coordinate", &p[d]);
        if (!st) vm_mesh_add_point(m, p, NULL);
    }
    for (int64_t i = 0; i < nf && !st; i++) {
        int64_t k, x;
        st = vm__cur_int(&c, 3, 1 << 20, "face vertex count (3 or more)", &k);
        if (!st) st = vm__grow((void **)&v, &capv, (size_t)k, sizeof *v, err);
        for (int64_t j = 0; j < k && !st; j++) {
            st = vm__cur_int(&c, 0, nv - 1, "vertex index", &x);
            if (!st) v[j] = (vm_index)x;
        }
        /* A face color may follow the indices on the same line: skipped. */
        const char *s;
        size_t sl;
        if (!st) vm__cur_line(&c, &s, &sl);
        if (!st) st = add_polygon(&polys, v, (size_t)k, 0, err);
    }
    if (!st) st = vm__polys_finish(path, &polys, m, err);
done:
    vm__polys_free(&polys);
    free(v);
    return vm__mesh_read_end(m, buf, st);
}

/* ======================================================================================= */
/* PLY                                                                                      */
/* ======================================================================================= */

vm_status vm_mesh_write_ply(const char *path, const vm_mesh *m, int ascii, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    opt.ascii = ascii;
    return vm__write_ply(path, m, &opt, err);
}

vm_status vm__write_ply(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    int ascii = opt->ascii;
    surface_out so;
    vm_status st = begin_surface_file(path, m, opt, &so, err);
    if (st) return st;
    const vm_mesh *s = so.s;
    FILE *fp = so.o.fp;
    size_t nn = so.nn;
    fprintf(fp, "ply\nformat %s 1.0\ncomment volmesh %s surface\nelement vertex %zu\n"
                "property double x\nproperty double y\nproperty double z\nelement face %zu\n"
                "property list uchar int vertex_indices\nproperty int region\nend_header\n",
            ascii ? "ascii" : "binary_little_endian", vm_cell_kind_name(s->kind), s->npoints,
            s->ncells);
    if (ascii) {
        put_points_text(&so.o, s, "");
        for (size_t c = 0; c < s->ncells; c++) {
            fprintf(fp, "%zu", nn);
            for (size_t k = 0; k < nn; k++)
                fprintf(fp, " %lld", (long long)s->cells[c * nn + k]);
            fprintf(fp, " %ld\n", (long)s->region[c]);
            vm__out_step(&so.o, 1.0);
        }
    } else {
        for (size_t i = 0; i < s->npoints; i++) {
            unsigned char b[24];
            for (int d = 0; d < 3; d++)
                vm__put_le64(b + 8 * d, vm__double_bits(s->points[3 * i + (size_t)d]));
            fwrite(b, 1, 24, fp);
            vm__out_step(&so.o, 1.0);
        }
        for (size_t c = 0; c < s->ncells; c++) {
            unsigned char b[1 + 4 * 8 + 4];
            b[0] = (unsigned char)nn;
            for (size_t k = 0; k < nn; k++)
                vm__put_le32(b + 1 + 4 * k, (uint32_t)(int32_t)s->cells[c * nn + k]);
            vm__put_le32(b + 1 + 4 * nn, (uint32_t)s->region[c]);
            fwrite(b, 1, 1 + 4 * nn + 4, fp);
            vm__out_step(&so.o, 1.0);
        }
    }
    return end_surface_file(&so, err);
}

enum { PLY_ASCII, PLY_LE, PLY_BE };

/* volmesh's bounds on a PLY header and its lists (the format sets none): elements, properties
 * of one element, entries of one list (a face of more vertices is refused). */
enum { PLY_MAX_ELEMENTS = 8, PLY_MAX_PROPS = 16, PLY_MAX_LIST = 64 };

typedef struct ply_prop {
    char name[32];
    int type;       /* bytes of a scalar type, negative for signed ints, 0 unused */
    int real;       /* float or double */
    int list;       /* 1: list with count type ctype */
    int ctype, creal;
} ply_prop;

typedef struct ply_elem {
    char name[32];
    uint64_t count;
    ply_prop prop[PLY_MAX_PROPS];
    int nprop;
} ply_elem;

static int ply_type(const char *t, size_t n, int *real) {
    static const struct {
        const char *name;
        int type, real;
    } types[] = {{"char", -1, 0},   {"int8", -1, 0},    {"uchar", 1, 0},   {"uint8", 1, 0},
                 {"short", -2, 0},  {"int16", -2, 0},   {"ushort", 2, 0},  {"uint16", 2, 0},
                 {"int", -4, 0},    {"int32", -4, 0},   {"uint", 4, 0},    {"uint32", 4, 0},
                 {"float", 4, 1},   {"float32", 4, 1},  {"double", 8, 1},  {"float64", 8, 1}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (vm__tok_is(t, n, types[i].name)) {
            *real = types[i].real;
            return types[i].type;
        }
    return 0;
}

/* Reads one value of type (bytes, sign by negative) / real. */
static vm_status ply_value(vm__cursor *c, int fmt, int type, int real, double *out) {
    if (fmt == PLY_ASCII) return vm__cur_double(c, "value", out);
    int size = type < 0 ? -type : type;
    if (vm__cur_left(c) < (size_t)size)
        return vm__cur_fail(c, VM_ERR_FORMAT, "binary data are truncated");
    const unsigned char *b = (const unsigned char *)c->p;
    uint64_t u = 0;
    for (int i = 0; i < size; i++)
        u |= (uint64_t)b[fmt == PLY_LE ? i : size - 1 - i] << (8 * i);
    c->p += size;
    if (real)
        *out = size == 8 ? vm__bits_double(u) : (double)vm__bits_float((uint32_t)u);
    else if (type > 0)
        *out = (double)u;
    else
        *out = size == 4 ? (double)(int32_t)(uint32_t)u
               : size == 2 ? (double)(int16_t)(uint16_t)u : (double)(int8_t)(uint8_t)u;
    if (!isfinite(*out)) return vm__cur_fail(c, VM_ERR_FORMAT, "a value is not finite");
    return VM_OK;
}

/* The header: the format and the elements with their properties. */
typedef struct ply_header {
    ply_elem el[PLY_MAX_ELEMENTS];
    int nel, fmt;
} ply_header;

/* "format ascii|binary_little_endian|binary_big_endian 1.0" (lc: the rest of the line). */
static vm_status ply_header_format(vm__cursor *c, vm__cursor *lc, ply_header *h) {
    const char *t, *ver;
    size_t n, vl;
    vm__cur_token(lc, &t, &n);
    if (!vm__cur_token(lc, &ver, &vl) || !vm__tok_is(ver, vl, "1.0"))
        return vm__cur_fail(c, VM_ERR_UNSUPPORTED, "PLY format version is not 1.0");
    h->fmt = vm__tok_is(t, n, "ascii")                  ? PLY_ASCII
             : vm__tok_is(t, n, "binary_little_endian") ? PLY_LE
             : vm__tok_is(t, n, "binary_big_endian")    ? PLY_BE
                                                        : -1;
    if (h->fmt < 0) return vm__cur_fail(c, VM_ERR_FORMAT, "unknown PLY format");
    return VM_OK;
}

/* "element NAME COUNT". */
static vm_status ply_header_element(vm__cursor *c, vm__cursor *lc, ply_header *h) {
    const char *t;
    size_t n;
    int64_t cnt;
    if (h->nel == PLY_MAX_ELEMENTS)
        return vm__cur_fail(c, VM_ERR_UNSUPPORTED, "more than 8 elements");
    ply_elem *e = &h->el[h->nel++];
    memset(e, 0, sizeof *e);
    if (!vm__cur_token(lc, &t, &n)) n = 0;
    snprintf(e->name, sizeof e->name, "%.*s", (int)n, t);
    if (vm__cur_int(lc, 0, INT64_MAX, "element count", &cnt))
        return vm__cur_fail(c, VM_ERR_FORMAT, "bad element count");
    e->count = (uint64_t)cnt;
    return VM_OK;
}

/* "property TYPE NAME" or "property list CTYPE TYPE NAME", of the last element. */
static vm_status ply_header_property(vm__cursor *c, vm__cursor *lc, ply_header *h) {
    const char *t;
    size_t n;
    if (h->nel == 0 || h->el[h->nel - 1].nprop == PLY_MAX_PROPS)
        return vm__cur_fail(c, VM_ERR_FORMAT, "property outside an element, or more than 16");
    ply_prop *p = &h->el[h->nel - 1].prop[h->el[h->nel - 1].nprop++];
    memset(p, 0, sizeof *p);
    vm__cur_token(lc, &t, &n);
    if (vm__tok_is(t, n, "list")) {
        p->list = 1;
        if (!vm__cur_token(lc, &t, &n) || !(p->ctype = ply_type(t, n, &p->creal)) || p->creal)
            return vm__cur_fail(c, VM_ERR_FORMAT, "bad list count type");
        vm__cur_token(lc, &t, &n);
    }
    if (!(p->type = ply_type(t, n, &p->real)))
        return vm__cur_fail(c, VM_ERR_FORMAT, "unknown property type \"%.*s\"",
                            (int)(n > 20 ? 20 : n), t);
    if (!vm__cur_token(lc, &t, &n)) n = 0;
    snprintf(p->name, sizeof p->name, "%.*s", (int)n, t);
    return VM_OK;
}

/* The header lines from "ply" to "end_header", one by one. */
static vm_status ply_read_header(vm__cursor *c, ply_header *h) {
    const char *s, *t;
    size_t n, sl;
    h->nel = 0;
    h->fmt = -1;
    if (!vm__cur_line(c, &s, &sl) || sl != 3 || memcmp(s, "ply", 3) != 0)
        return vm_error_set(c->err, VM_ERR_FORMAT, "%s: not a PLY file", c->path);
    for (;;) {
        vm_status st = VM_OK;
        if (!vm__cur_line(c, &s, &sl))
            return vm__cur_fail(c, VM_ERR_FORMAT, "header has no end_header");
        vm__cursor lc;
        vm__cur_init(&lc, c->path, s, sl, 0, c->err);
        if (!vm__cur_token(&lc, &t, &n)) continue;
        if (vm__tok_is(t, n, "end_header")) break;
        if (vm__tok_is(t, n, "comment") || vm__tok_is(t, n, "obj_info")) continue;
        if (vm__tok_is(t, n, "format"))
            st = ply_header_format(c, &lc, h);
        else if (vm__tok_is(t, n, "element"))
            st = ply_header_element(c, &lc, h);
        else if (vm__tok_is(t, n, "property"))
            st = ply_header_property(c, &lc, h);
        else
            st = vm__cur_fail(c, VM_ERR_FORMAT, "unknown header line \"%.*s\"",
                              (int)(sl > 30 ? 30 : sl), s);
        if (st) return st;
    }
    if (h->fmt < 0) return vm__cur_fail(c, VM_ERR_FORMAT, "header has no format line");
    return VM_OK;
}

/* Which properties of an element volmesh uses: x, y, z of "vertex"; the index list and the
 * region of "face" (-1: absent). */
typedef struct ply_roles {
    int is_vertex, is_face;
    int ix[3], ilist, iregion;
} ply_roles;

/* Finds the roles of e's properties; fails when a vertex lacks a coordinate or a face
 * its index list. */
static vm_status ply_find_roles(vm__cursor *c, const ply_elem *e, ply_roles *r) {
    r->is_vertex = strcmp(e->name, "vertex") == 0;
    r->is_face = strcmp(e->name, "face") == 0;
    r->ix[0] = r->ix[1] = r->ix[2] = r->ilist = r->iregion = -1;
    for (int k = 0; k < e->nprop; k++) {
        const char *pn = e->prop[k].name;
        if (r->is_vertex && !e->prop[k].list && pn[0] && !pn[1] && pn[0] >= 'x' &&
            pn[0] <= 'z')
            r->ix[pn[0] - 'x'] = k;
        if (r->is_face && e->prop[k].list &&
            (strcmp(pn, "vertex_indices") == 0 || strcmp(pn, "vertex_index") == 0))
            r->ilist = k;
        if (r->is_face && !e->prop[k].list && strcmp(pn, "region") == 0) r->iregion = k;
    }
    if (r->is_vertex && (r->ix[0] < 0 || r->ix[1] < 0 || r->ix[2] < 0))
        return vm__cur_fail(c, VM_ERR_FORMAT, "vertex element lacks x, y or z");
    if (r->is_face && r->ilist < 0)
        return vm__cur_fail(c, VM_ERR_FORMAT, "face element lacks vertex_indices");
    return VM_OK;
}

/* One list property (count, then entries); the face's index list goes to v[*nv]. */
static vm_status ply_read_list(vm__cursor *c, int fmt, const ply_prop *pp, int is_list,
                               const vm_mesh *m, vm_index v[PLY_MAX_LIST], size_t *nv) {
    double cnt, x;
    vm_status st = ply_value(c, fmt, pp->ctype, 0, &cnt);
    if (!st && (cnt < 0 || cnt > PLY_MAX_LIST || cnt != floor(cnt) || (is_list && cnt < 3)))
        st = vm__cur_fail(c, VM_ERR_FORMAT, "list of %g entries", cnt);
    for (int q = 0; q < (int)cnt && !st; q++) {
        st = ply_value(c, fmt, pp->type, pp->real, &x);
        if (!st && is_list) {
            if (x < 0 || x >= (double)m->npoints || x != floor(x))
                st = vm__cur_fail(c, VM_ERR_FORMAT, "face uses vertex %g of %zu", x,
                                  m->npoints);
            else
                v[(*nv)++] = (vm_index)x;
        }
    }
    return st;
}

/* One record of element e: a vertex becomes a point of m, a face a polygon. */
static vm_status ply_read_record(vm__cursor *c, int fmt, const ply_elem *e,
                                 const ply_roles *r, vm_mesh *m, vm__polys *polys) {
    double p[3] = {0, 0, 0}, region = 0;
    vm_index v[PLY_MAX_LIST];
    size_t nv = 0;
    vm_status st = VM_OK;
    for (int k = 0; k < e->nprop && !st; k++) {
        const ply_prop *pp = &e->prop[k];
        double x;
        if (pp->list) {
            st = ply_read_list(c, fmt, pp, k == r->ilist, m, v, &nv);
            continue;
        }
        st = ply_value(c, fmt, pp->type, pp->real, &x);
        if (st) break;
        if (r->is_vertex && (k == r->ix[0] || k == r->ix[1] || k == r->ix[2]))
            p[k == r->ix[0] ? 0 : k == r->ix[1] ? 1 : 2] = x;
        if (k == r->iregion) region = x;
    }
    if (st) return st;
    if (r->is_vertex) vm_mesh_add_point(m, p, NULL);
    if (r->is_face) {
        if (region != floor(region) || region < INT32_MIN || region > INT32_MAX) region = 0;
        st = add_polygon(polys, v, nv, (int32_t)region, c->err);
    }
    return st;
}

/* Reads the header, then every element's records in order. */
vm_status vm_mesh_read_ply(const char *path, vm_mesh *m, vm_error *err) {
    unsigned char *buf = NULL;
    vm__cursor c;
    vm_status st = vm__mesh_read_begin(path, m, VM_TRI3, 0, &buf, &c, err);
    if (st) return st;
    ply_header h;
    vm__polys polys;
    memset(&polys, 0, sizeof polys);
    st = ply_read_header(&c, &h);
    for (int i = 0; i < h.nel && !st; i++) {
        const ply_elem *e = &h.el[i];
        ply_roles r;
        st = ply_find_roles(&c, e, &r);
        if (!st) st = vm__check_count(&c, e->count, 1, "PLY elements");
        if (!st && r.is_vertex) st = vm_mesh_reserve(m, (size_t)e->count, 0, err);
        for (uint64_t j = 0; j < e->count && !st; j++)
            st = ply_read_record(&c, h.fmt, e, &r, m, &polys);
    }
    if (!st) st = vm__polys_finish(path, &polys, m, err);
    vm__polys_free(&polys);
    return vm__mesh_read_end(m, buf, st);
}

/* ======================================================================================= */
/* OBJ                                                                                      */
/* ======================================================================================= */

vm_status vm_mesh_write_obj(const char *path, const vm_mesh *m, vm_error *err) {
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    return vm__write_obj(path, m, &opt, err);
}

vm_status vm__write_obj(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    surface_out so;
    vm_status st = begin_surface_file(path, m, opt, &so, err);
    if (st) return st;
    const vm_mesh *s = so.s;
    FILE *fp = so.o.fp;
    size_t nn = so.nn;
    fprintf(fp, "# volmesh %s surface: %zu vertices, %zu faces; g REGION_r groups\n",
            vm_cell_kind_name(s->kind), s->npoints, s->ncells);
    put_points_text(&so.o, s, "v ");
    for (size_t c = 0; c < s->ncells; c++) {
        if (c == 0 || s->region[c] != s->region[c - 1]) {
            char name[32];
            vm__region_name(s->region[c], name, sizeof name);
            fprintf(fp, "g %s\n", name);
        }
        fputc('f', fp);
        for (size_t k = 0; k < nn; k++)
            fprintf(fp, " %lld", (long long)s->cells[c * nn + k] + 1);
        fputc('\n', fp);
        vm__out_step(&so.o, 1.0);
    }
    return end_surface_file(&so, err);
}

/* Reads OBJ line by line: v and f statements, g groups as regions. */
vm_status vm_mesh_read_obj(const char *path, vm_mesh *m, vm_error *err) {
    unsigned char *buf = NULL;
    vm__cursor c;
    vm_status st = vm__mesh_read_begin(path, m, VM_TRI3, 0, &buf, &c, err);
    if (st) return st;
    vm__polys polys;
    memset(&polys, 0, sizeof polys);
    vm_index *v = NULL;
    size_t capv = 0;
    int32_t region = 0, ngroups = 0;
    int any = 0;
    const char *s, *t;
    size_t sl, n;
    while (!st && vm__cur_line(&c, &s, &sl)) {
        vm__cursor lc;
        vm__cur_init(&lc, path, s, sl, '#', err);
        if (!vm__cur_token(&lc, &t, &n)) continue;
        if (vm__tok_is(t, n, "v")) {
            double p[3];
            int ok = 1, d = 0, has = 1;
            for (; d < 3 && ok; d++)
                ok = (has = vm__cur_token(&lc, &t, &n)) &&
                     vm__parse_double_tok(t, n, &p[d]) == VM_OK;
            if (!ok) {
                c.p = s;
                if (has)
                    st = vm__cur_fail(&c, VM_ERR_FORMAT, "bad vertex line: coordinate %c "
                                      "\"%.*s\" is not a finite number", "xyz"[d - 1],
                                      (int)(n > 40 ? 40 : n), t);
                else
                    st = vm__cur_fail(&c, VM_ERR_FORMAT, "bad vertex line: coordinate %c is "
                                      "missing", "xyz"[d - 1]);
                break;
            }
            if (vm_mesh_add_point(m, p, err) < 0) st = VM_ERR_NOMEM;
            any = 1;
        } else if (vm__tok_is(t, n, "f")) {
            size_t k = 0;
            while (!st && vm__cur_token(&lc, &t, &n)) {
                /* v, v/vt, v//vn, v/vt/vn: the vertex number comes first; negative counts
                 * back from the last vertex read. */
                size_t w = 0;
                while (w < n && t[w] != '/')
                    w++;
                int64_t x;
                if (vm__parse_int_tok(t, w, &x) != VM_OK || x == 0 ||
                    (x > 0 && (uint64_t)x > m->npoints) ||
                    (x < 0 && (uint64_t)(-(x + 1)) >= m->npoints)) {
                    c.p = s;
                    st = vm__cur_fail(&c, VM_ERR_FORMAT, "bad face vertex \"%.*s\" (%zu "
                                      "vertices so far)", (int)(n > 20 ? 20 : n), t, m->npoints);
                    break;
                }
                st = vm__grow((void **)&v, &capv, k + 1, sizeof *v, err);
                if (!st) v[k++] = (vm_index)(x > 0 ? x - 1 : (int64_t)m->npoints + x);
            }
            if (!st && k < 3) {
                c.p = s;
                st = vm__cur_fail(&c, VM_ERR_FORMAT, "face with fewer than 3 vertices");
            }
            if (!st) st = add_polygon(&polys, v, k, region, err);
            any = 1;
        } else if (vm__tok_is(t, n, "g") || vm__tok_is(t, n, "o")) {
            int is_g = vm__tok_is(t, n, "g");
            if (vm__cur_token(&lc, &t, &n) && is_g) {
                if (vm__region_parse(t, n, &region) != VM_OK) region = ++ngroups;
            }
        } else if (n > 16) {
            c.p = s;
            st = vm__cur_fail(&c, VM_ERR_FORMAT, "not an OBJ statement \"%.*s\"", 16, t);
        }
        /* vt, vn, s, usemtl, mtllib, l, p and other statements carry nothing we keep. */
    }
    if (!st && !any) st = vm_error_set(err, VM_ERR_FORMAT, "%s: no vertices or faces", path);
    if (!st) st = vm__polys_finish(path, &polys, m, err);
    vm__polys_free(&polys);
    free(v);
    return vm__mesh_read_end(m, buf, st);
}
