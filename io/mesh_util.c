/* SPDX-License-Identifier: BSD-3-Clause */
/* io/mesh_util.c — shared pieces of the mesh format readers and writers: text cursor,
 * id maps, boundary faces with element/face ids (ABAQUS face numbering,
 * "Abaqus Analysis User's Guide", 28.1.4 three-dimensional solid element library). */
#include "mesh_util.h"
#include "io_util.h"
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "volmesh/quality.h"

/* --- text cursor ------------------------------------------------------------------------- */

void vm__cur_init(vm__cursor *c, const char *path, const void *buf, size_t len, char comment,
                  vm_error *err) {
    c->path = path;
    c->start = c->p = (const char *)buf;
    c->end = c->start + len;
    c->comment = comment;
    c->err = err;
}

/* Empties m, reads the file whole and puts the cursor at its start. */
vm_status vm__mesh_read_begin(const char *path, vm_mesh *m, vm_cell_kind kind, char comment,
                              unsigned char **buf, vm__cursor *c, vm_error *err) {
    vm_mesh_init(m, kind);
    size_t len = 0;
    *buf = NULL;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, buf, &len, err);
    if (st) return st;
    vm__cur_init(c, path, *buf, len, comment, err);
    return VM_OK;
}

/* Frees the file's bytes, and the mesh when the read failed. */
vm_status vm__mesh_read_end(vm_mesh *m, unsigned char *buf, vm_status st) {
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}

vm_status vm__cur_fail(const vm__cursor *c, vm_status status, const char *fmt, ...) {
    size_t line = 1;
    for (const char *q = c->start; q < c->p && q < c->end; q++)
        if (*q == '\n') line++;
    char msg[400];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return vm_error_set(c->err, status, "%s: line %zu: %s", c->path, line, msg);
}

static int is_ws(int ch) {
    return ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r' || ch == '\f' || ch == '\v';
}

static void skip_ws(vm__cursor *c) {
    while (c->p < c->end) {
        if (is_ws((unsigned char)*c->p)) {
            c->p++;
        } else if (c->comment && *c->p == c->comment) {
            while (c->p < c->end && *c->p != '\n')
                c->p++;
        } else {
            break;
        }
    }
}

int vm__cur_more(vm__cursor *c) {
    skip_ws(c);
    return c->p < c->end;
}

size_t vm__cur_left(const vm__cursor *c) {
    return (size_t)(c->end - c->p);
}

int vm__cur_token(vm__cursor *c, const char **tok, size_t *len) {
    skip_ws(c);
    if (c->p >= c->end) return 0;
    const char *s = c->p;
    while (c->p < c->end && !is_ws((unsigned char)*c->p) &&
           !(c->comment && *c->p == c->comment))
        c->p++;
    *tok = s;
    *len = (size_t)(c->p - s);
    return 1;
}

int vm__cur_line(vm__cursor *c, const char **s, size_t *len) {
    if (c->p >= c->end) return 0;
    const char *b = c->p;
    const char *nl = memchr(b, '\n', (size_t)(c->end - b));
    const char *e = nl ? nl : c->end;
    c->p = nl ? nl + 1 : c->end;
    if (e > b && e[-1] == '\r') e--;
    *s = b;
    *len = (size_t)(e - b);
    return 1;
}

int vm__tok_is(const char *tok, size_t len, const char *word) {
    size_t n = strlen(word);
    if (n != len) return 0;
    for (size_t i = 0; i < n; i++)
        if (tolower((unsigned char)tok[i]) != tolower((unsigned char)word[i])) return 0;
    return 1;
}

/* A whole token as a decimal integer (sign allowed) that fits in int64. */
vm_status vm__parse_int_tok(const char *tok, size_t len, int64_t *v) {
    char b[32];
    if (len == 0 || len >= sizeof b) return VM_ERR_FORMAT;
    memcpy(b, tok, len);
    b[len] = 0;
    const char *q = b;
    if (*q == '+' || *q == '-') q++;
    if (!isdigit((unsigned char)*q)) return VM_ERR_FORMAT;
    char *e;
    errno = 0;
    long long x = strtoll(b, &e, 10);
    if (errno || *e) return VM_ERR_FORMAT;
    *v = (int64_t)x;
    return VM_OK;
}

/* A whole token as a finite double. */
vm_status vm__parse_double_tok(const char *tok, size_t len, double *v) {
    char b[80];
    if (len == 0 || len >= sizeof b) return VM_ERR_FORMAT;
    memcpy(b, tok, len);
    b[len] = 0;
    /* Fortran-style exponents (1.5D+02) appear in decks written by older codes. */
    for (size_t i = 0; i < len; i++)
        if (b[i] == 'd' || b[i] == 'D') b[i] = 'e';
    char *e;
    errno = 0;
    double x = strtod(b, &e);
    if (e == b || *e || errno == ERANGE || x != x || x > DBL_MAX || x < -DBL_MAX)
        return VM_ERR_FORMAT;
    *v = x;
    return VM_OK;
}

vm_status vm__cur_int(vm__cursor *c, int64_t lo, int64_t hi, const char *what, int64_t *v) {
    const char *t;
    size_t n;
    if (!vm__cur_token(c, &t, &n))
        return vm__cur_fail(c, VM_ERR_FORMAT, "file ends where %s was expected", what);
    if (vm__parse_int_tok(t, n, v) != VM_OK || *v < lo || *v > hi)
        return vm__cur_fail(c, VM_ERR_FORMAT, "bad %s \"%.*s\"", what, (int)(n > 40 ? 40 : n),
                            t);
    return VM_OK;
}

vm_status vm__cur_double(vm__cursor *c, const char *what, double *v) {
    const char *t;
    size_t n;
    if (!vm__cur_token(c, &t, &n))
        return vm__cur_fail(c, VM_ERR_FORMAT, "file ends where %s was expected", what);
    if (vm__parse_double_tok(t, n, v) != VM_OK)
        return vm__cur_fail(c, VM_ERR_FORMAT, "bad %s \"%.*s\"", what, (int)(n > 40 ? 40 : n),
                            t);
    return VM_OK;
}

vm_status vm__check_count(const vm__cursor *c, uint64_t count, size_t min_bytes,
                          const char *what) {
    uint64_t left = vm__cur_left(c);
    if (min_bytes && count > left / min_bytes + 1)
        return vm__cur_fail(c, VM_ERR_FORMAT, "%" PRIu64 " %s do not fit in the %" PRIu64
                            " bytes left", count, what, left);
    if (count > (uint64_t)INT32_MAX && sizeof(vm_index) == 4)
        return vm__cur_fail(c, VM_ERR_UNSUPPORTED, "%" PRIu64 " %s need 64-bit indices", count,
                            what);
    size_t bytes;
    if (count > SIZE_MAX / 64 || vm__mul_overflows((size_t)count, 64, &bytes) ||
        bytes > vm__memory_limit())
        return vm__cur_fail(c, VM_ERR_NOMEM, "%" PRIu64 " %s are more than memory allows",
                            count, what);
    return VM_OK;
}

/* --- ids ------------------------------------------------------------------------------- */

vm_status vm__idmap_add(vm__idmap *m, int64_t id, vm_index index, vm_error *err) {
    if (m->n == m->cap) {
        size_t c1 = m->cap, c2 = m->cap;
        vm_status st = vm__grow((void **)&m->ids, &c1, m->n + 1, sizeof(int64_t), err);
        if (!st) st = vm__grow((void **)&m->index, &c2, c1, sizeof(vm_index), err);
        if (st) return st;
        m->cap = c1 < c2 ? c1 : c2;
    }
    m->ids[m->n] = id;
    m->index[m->n] = index;
    m->n++;
    return VM_OK;
}

typedef struct id_pair {
    int64_t id;
    vm_index index;
} id_pair;

static int cmp_pair(const void *a, const void *b) {
    int64_t x = ((const id_pair *)a)->id, y = ((const id_pair *)b)->id;
    return (x > y) - (x < y);
}

/* Sorts by id (qsort, or insertion sort without scratch memory), then looks for repeats. */
vm_status vm__idmap_finish(vm__idmap *m, int64_t *dup) {
    int sorted = 1;
    for (size_t i = 1; i < m->n && sorted; i++)
        if (m->ids[i - 1] >= m->ids[i]) sorted = 0;
    if (!sorted) {
        id_pair *tmp = malloc((m->n ? m->n : 1) * sizeof *tmp);
        if (tmp) {
            for (size_t i = 0; i < m->n; i++) {
                tmp[i].id = m->ids[i];
                tmp[i].index = m->index[i];
            }
            qsort(tmp, m->n, sizeof *tmp, cmp_pair);
            for (size_t i = 0; i < m->n; i++) {
                m->ids[i] = tmp[i].id;
                m->index[i] = tmp[i].index;
            }
            free(tmp);
        } else {
            /* Without scratch memory: insertion sort keeps this correct, if slow. */
            for (size_t i = 1; i < m->n; i++) {
                int64_t id = m->ids[i];
                vm_index ix = m->index[i];
                size_t j = i;
                for (; j > 0 && m->ids[j - 1] > id; j--) {
                    m->ids[j] = m->ids[j - 1];
                    m->index[j] = m->index[j - 1];
                }
                m->ids[j] = id;
                m->index[j] = ix;
            }
        }
    }
    for (size_t i = 1; i < m->n; i++)
        if (m->ids[i - 1] == m->ids[i]) {
            *dup = m->ids[i];
            return VM_ERR_FORMAT;
        }
    return VM_OK;
}

vm_index vm__idmap_find(const vm__idmap *m, int64_t id) {
    size_t lo = 0, hi = m->n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (m->ids[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < m->n && m->ids[lo] == id ? m->index[lo] : -1;
}

void vm__idmap_free(vm__idmap *m) {
    free(m->ids);
    free(m->index);
    memset(m, 0, sizeof *m);
}

/* --- faces ------------------------------------------------------------------------------ */

const int vm__tet_faces[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
const int vm__hex_faces[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                                 {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
const int vm__tet_edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
const int vm__hex_edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                  {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

typedef struct face_key {
    vm_index v[4]; /* sorted, unused slots -1 */
    uint64_t id;   /* cell * nfaces + face */
} face_key;

static int cmp_face(const void *a, const void *b) {
    const face_key *x = a, *y = b;
    for (int i = 0; i < 4; i++)
        if (x->v[i] != y->v[i]) return x->v[i] < y->v[i] ? -1 : 1;
    return (x->id > y->id) - (x->id < y->id);
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Every face of every cell with its nodes sorted, sorted by nodes (equal faces adjacent).
 * [out] *keys (malloc'd), *total = ncells * nfaces. */
static vm_status face_keys(const char *path, const vm_mesh *m, face_key **keys, size_t *total,
                           vm_error *err) {
    *keys = NULL;
    int nf = m->kind == VM_TET4 ? 4 : m->kind == VM_HEX8 ? 6 : 0;
    int fk = m->kind == VM_TET4 ? 3 : 4;
    if (!nf)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: boundary faces need tet4 or hex8",
                            path);
    size_t bytes;
    if (vm__mul_overflows(m->ncells, (size_t)nf, total) ||
        vm__mul_overflows(*total ? *total : 1, sizeof(face_key), &bytes) ||
        bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "%s: too many faces", path);
    face_key *k = malloc(bytes);
    if (!k)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for %zu faces", path, *total);
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    for (size_t c = 0; c < m->ncells; c++) {
        const vm_index *cell = m->cells + c * nn;
        for (int f = 0; f < nf; f++) {
            face_key *e = &k[c * (size_t)nf + (size_t)f];
            e->v[3] = -1;
            for (int j = 0; j < fk; j++)
                e->v[j] = cell[nf == 4 ? vm__tet_faces[f][j] : vm__hex_faces[f][j]];
            for (int a = 1; a < fk; a++) /* insertion sort of 3 or 4 values */
                for (int b = a; b > 0 && e->v[b - 1] > e->v[b]; b--) {
                    vm_index t = e->v[b];
                    e->v[b] = e->v[b - 1];
                    e->v[b - 1] = t;
                }
            e->id = (uint64_t)c * (uint64_t)nf + (uint64_t)f;
        }
    }
    qsort(k, *total, sizeof *k, cmp_face);
    *keys = k;
    return VM_OK;
}

vm_status vm__boundary_faces(const char *path, const vm_mesh *m, uint64_t **faces, size_t *n,
                             vm_error *err) {
    *faces = NULL;
    *n = 0;
    face_key *k;
    size_t total;
    vm_status st = face_keys(path, m, &k, &total, err);
    if (st) return st;
    uint64_t *out = malloc((total ? total : 1) * sizeof *out);
    if (!out) {
        free(k);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for %zu faces", path, total);
    }
    size_t nb = 0;
    for (size_t i = 0; i < total;) {
        size_t j = i + 1;
        while (j < total && memcmp(k[j].v, k[i].v, sizeof k[i].v) == 0)
            j++;
        if (j - i == 1) out[nb++] = k[i].id;
        i = j;
    }
    free(k);
    qsort(out, nb, sizeof *out, cmp_u64);
    *faces = out;
    *n = nb;
    return VM_OK;
}

static int cmp_iface(const void *a, const void *b) {
    const vm__iface *x = a, *y = b;
    if (x->region != y->region) return x->region < y->region ? -1 : 1;
    if (x->other != y->other) return x->other < y->other ? -1 : 1;
    return (x->face > y->face) - (x->face < y->face);
}

vm_status vm__interface_faces(const char *path, const vm_mesh *m, vm__iface **faces, size_t *n,
                              vm_error *err) {
    *faces = NULL;
    *n = 0;
    face_key *k;
    size_t total;
    vm_status st = face_keys(path, m, &k, &total, err);
    if (st) return st;
    uint64_t nf = m->kind == VM_TET4 ? 4 : 6;
    vm__iface *out = NULL;
    size_t cap = 0, ni = 0;
    for (size_t i = 0; i + 1 < total && !st;) {
        size_t j = i + 1;
        while (j < total && memcmp(k[j].v, k[i].v, sizeof k[i].v) == 0)
            j++;
        if (j - i == 2) {
            int32_t ra = m->region[k[i].id / nf], rb = m->region[k[i + 1].id / nf];
            if (ra != rb) {
                st = vm__grow((void **)&out, &cap, ni + 1, sizeof *out, err);
                if (st) break;
                out[ni].face = ra < rb ? k[i].id : k[i + 1].id;
                out[ni].region = ra < rb ? ra : rb;
                out[ni].other = ra < rb ? rb : ra;
                ni++;
            }
        }
        i = j;
    }
    free(k);
    if (st) {
        free(out);
        return st;
    }
    if (ni) qsort(out, ni, sizeof *out, cmp_iface);
    *faces = out;
    *n = ni;
    return VM_OK;
}

static int cmp_i32(const void *a, const void *b) {
    int32_t x = *(const int32_t *)a, y = *(const int32_t *)b;
    return (x > y) - (x < y);
}

vm_status vm__distinct_regions(const char *path, const vm_mesh *m, int32_t **regions,
                               size_t *n, vm_error *err) {
    int32_t *r = malloc((m->ncells ? m->ncells : 1) * sizeof *r);
    if (!r) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    if (m->ncells) memcpy(r, m->region, m->ncells * sizeof *r);
    qsort(r, m->ncells, sizeof *r, cmp_i32);
    size_t k = 0;
    for (size_t i = 0; i < m->ncells; i++)
        if (k == 0 || r[k - 1] != r[i]) r[k++] = r[i];
    *regions = r;
    *n = k;
    return VM_OK;
}

long vm__region_slot(const int32_t *regions, size_t n, int32_t r) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (regions[mid] < r)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < n && regions[lo] == r ? (long)lo : -1;
}

void vm__region_name(int32_t r, char *out, size_t cap) {
    if (r < 0)
        snprintf(out, cap, "REGION_M%lld", -(long long)r);
    else
        snprintf(out, cap, "REGION_%ld", (long)r);
}

/* "REGION_<n>" or "REGION_M<n>" (negative), n of at most 10 digits within int32. */
vm_status vm__region_parse(const char *s, size_t len, int32_t *r) {
    if (len < 8) return VM_ERR_FORMAT;
    for (int i = 0; i < 7; i++)
        if (toupper((unsigned char)s[i]) != "REGION_"[i]) return VM_ERR_FORMAT;
    s += 7;
    len -= 7;
    int neg = 0;
    if (toupper((unsigned char)*s) == 'M') {
        neg = 1;
        s++;
        len--;
    }
    if (len == 0 || len > 10) return VM_ERR_FORMAT;
    int64_t v = 0;
    for (size_t i = 0; i < len; i++) {
        if (!isdigit((unsigned char)s[i])) return VM_ERR_FORMAT;
        v = v * 10 + (s[i] - '0');
    }
    if (neg) v = -v;
    if (v < INT32_MIN || v > INT32_MAX) return VM_ERR_FORMAT;
    *r = (int32_t)v;
    return VM_OK;
}

vm_status vm__surface_of(const char *path, const vm_mesh *m, vm_mesh *tmp,
                         const vm_mesh **surf, vm_error *err) {
    vm_mesh_init(tmp, VM_TRI3);
    if (m->kind == VM_TRI3 || m->kind == VM_QUAD4) {
        *surf = m;
        return VM_OK;
    }
    (void)path;
    vm_status st = vm_mesh_boundary(m, tmp, err);
    if (st) return st;
    *surf = tmp;
    return VM_OK;
}

vm_status vm__polys_add(vm__polys *p, const vm_index *idx, int count, int32_t region,
                        vm_error *err) {
    if (p->nfaces == p->cap_f) {
        size_t c1 = p->cap_f, c2 = p->cap_f;
        vm_status st = vm__grow((void **)&p->count, &c1, p->nfaces + 1, 1, err);
        if (!st) st = vm__grow((void **)&p->region, &c2, c1, sizeof(int32_t), err);
        if (st) return st;
        p->cap_f = c1 < c2 ? c1 : c2;
    }
    vm_status st = vm__grow((void **)&p->idx, &p->cap_i, p->nidx + 4, sizeof(vm_index), err);
    if (st) return st;
    memcpy(p->idx + p->nidx, idx, (size_t)count * sizeof(vm_index));
    p->nidx += (size_t)count;
    p->count[p->nfaces] = (uint8_t)count;
    p->region[p->nfaces] = region;
    p->nfaces++;
    return VM_OK;
}

vm_status vm__polys_finish(const char *path, vm__polys *p, vm_mesh *m, vm_error *err) {
    int all_quads = p->nfaces > 0;
    size_t nquads = 0;
    for (size_t i = 0; i < p->nfaces; i++) {
        if (p->count[i] != 4) all_quads = 0;
        else nquads++;
    }
    m->kind = all_quads ? VM_QUAD4 : VM_TRI3;
    size_t ncells = all_quads ? p->nfaces : p->nfaces + nquads;
    vm_status st = vm_mesh_reserve(m, m->npoints, ncells, err);
    if (st) {
        vm__polys_free(p);
        return vm_error_set(err, st, "%s: out of memory for %zu faces", path, ncells);
    }
    size_t at = 0;
    for (size_t i = 0; i < p->nfaces; i++) {
        const vm_index *v = p->idx + at;
        at += p->count[i];
        if (all_quads || p->count[i] == 3) {
            vm_mesh_add_cell(m, v, p->region[i], NULL);
        } else {
            vm_index a[3] = {v[0], v[1], v[2]}, b[3] = {v[0], v[2], v[3]};
            vm_mesh_add_cell(m, a, p->region[i], NULL);
            vm_mesh_add_cell(m, b, p->region[i], NULL);
        }
    }
    vm__polys_free(p);
    return vm__check_nodes(m, VM_ERR_FORMAT, path, err);
}

void vm__polys_free(vm__polys *p) {
    free(p->idx);
    free(p->count);
    free(p->region);
    memset(p, 0, sizeof *p);
}

/* --- byte order ---------------------------------------------------------------------------- */

/* The n-byte unsigned integer at b, most significant byte first (big) or last. */
static uint64_t get_bytes(const unsigned char *b, int n, int big) {
    uint64_t v = 0;
    for (int i = 0; i < n; i++)
        v = (v << 8) | b[big ? i : n - 1 - i];
    return v;
}

/* Stores the low n bytes of v at b, most significant byte first (big) or last. */
static void put_bytes(unsigned char *b, uint64_t v, int n, int big) {
    for (int i = 0; i < n; i++)
        b[big ? n - 1 - i : i] = (unsigned char)(v >> (8 * i));
}

/* Fixed-width big- and little-endian stores and loads, on get_bytes / put_bytes. */
void vm__put_be32(unsigned char *b, uint32_t v) { put_bytes(b, v, 4, 1); }
void vm__put_be64(unsigned char *b, uint64_t v) { put_bytes(b, v, 8, 1); }
uint32_t vm__get_be32(const unsigned char *b) { return (uint32_t)get_bytes(b, 4, 1); }
uint64_t vm__get_be64(const unsigned char *b) { return get_bytes(b, 8, 1); }
void vm__put_le16(unsigned char *b, uint16_t v) { put_bytes(b, v, 2, 0); }
void vm__put_le32(unsigned char *b, uint32_t v) { put_bytes(b, v, 4, 0); }
void vm__put_le64(unsigned char *b, uint64_t v) { put_bytes(b, v, 8, 0); }
uint16_t vm__get_le16(const unsigned char *b) { return (uint16_t)get_bytes(b, 2, 0); }
uint32_t vm__get_le32(const unsigned char *b) { return (uint32_t)get_bytes(b, 4, 0); }
uint64_t vm__get_le64(const unsigned char *b) { return get_bytes(b, 8, 0); }

/* Bit casts between floating-point values and their IEEE 754 words. */
double vm__bits_double(uint64_t u) {
    double d;
    memcpy(&d, &u, 8);
    return d;
}
uint64_t vm__double_bits(double d) {
    uint64_t u;
    memcpy(&u, &d, 8);
    return u;
}
float vm__bits_float(uint32_t u) {
    float f;
    memcpy(&f, &u, 4);
    return f;
}
uint32_t vm__float_bits(float f) {
    uint32_t u;
    memcpy(&u, &f, 4);
    return u;
}

vm_status vm__solid_deck_open(const char *path, const vm_mesh *m, const char *what,
                              long long max_id, const vm_mesh_write_options *opt,
                              int32_t **regions, size_t *nregions, struct vm_outfile *o,
                              vm_error *err) {
    *regions = NULL;
    *nregions = 0;
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: %s for tet4 and hex8 meshes, not %s", path, what,
                            vm_cell_kind_name(m->kind));
    if ((long long)m->npoints > max_id || (long long)m->ncells > max_id)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: more than %lld nodes or elements (8-column ids)", path, max_id);
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (!st) st = vm__distinct_regions(path, m, regions, nregions, err);
    if (!st) st = vm__out_open(o, path, err);
    if (st) {
        free(*regions);
        *regions = NULL;
        return st;
    }
    vm__out_meter(o, opt->progress, opt->progress_user, (double)m->npoints + m->ncells);
    return VM_OK;
}
