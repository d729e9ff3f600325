/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/testlib.c — the harness behind tests/test.h. */
#define _POSIX_C_SOURCE 200809L
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include "test.h"

int vm_test_failures;
static int skipped_flag;

void vm_test_skip(const char *reason) {
    printf("  skipped: %s\n", reason);
    skipped_flag = 1;
}

static double wall_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int vm_test_run(const vm_test_case *cases, size_t n) {
    int passed = 0, failed = 0, skipped = 0;
    /* VM_TEST_PART=K/N (set by tests/CMakeLists.txt for a file that asks for N ctest parts):
     * only the cases i with i % N == K run here. */
    unsigned part = 0, parts = 1;
    const char *pe = getenv("VM_TEST_PART");
    if (pe && (sscanf(pe, "%u/%u", &part, &parts) != 2 || parts == 0 || part >= parts)) {
        fprintf(stderr, "VM_TEST_PART=%s: expected K/N with K < N\n", pe);
        return 2;
    }
    for (size_t i = 0; i < n; i++) {
        if (i % parts != part) continue;
        vm_test_failures = 0;
        skipped_flag = 0;
        printf("%s\n", cases[i].name);
        fflush(stdout);
        double t0 = wall_seconds();
        cases[i].fn();
        double dt = wall_seconds() - t0;
        if (dt >= 1.0) printf("  (%.1f s)\n", dt);
        if (vm_test_failures) {
            printf("  FAILED (%d checks)\n", vm_test_failures);
            failed++;
        } else if (skipped_flag) {
            skipped++;
        } else {
            passed++;
        }
        fflush(stdout);
    }
    printf("%d passed, %d failed, %d skipped\n", passed, failed, skipped);
    if (failed) return 1;
    if (skipped && !passed) return 77;
    return 0;
}

const char *vm_test_shared(const char *name) {
    static char buf[8][4096];
    static int slot;
    const char *dir = getenv("VM_SHARED_DATA");
    if (!dir) dir = "../shared/data";
    char *p = buf[slot++ % 8];
    snprintf(p, 4096, "%s/%s", dir, name);
    struct stat sb;
    if (stat(p, &sb) != 0) {
        char msg[4200];
        snprintf(msg, sizeof msg, "%s not found (../shared/data is absent in a fresh clone)", p);
        vm_test_skip(msg);
        return NULL;
    }
    return p;
}

const char *vm_test_tmp(const char *name) {
    static char buf[8][4096];
    static int slot;
    const char *dir = getenv("VM_TEST_TMP");
    char *p = buf[slot++ % 8];
    snprintf(p, 4096, "%s/%s", dir ? dir : ".", name);
    return p;
}

int vm_test_write_file(const char *path, const void *data, size_t len) {
    FILE *fp = fopen(path, "wb");
    if (!fp) return -1;
    size_t w = fwrite(data, 1, len, fp);
    int bad = fclose(fp) != 0 || w != len;
    return bad ? -1 : 0;
}

int vm_test_exists(const char *path) {
    struct stat sb;
    return stat(path, &sb) == 0;
}

int vm_test_cli(const char *args, char **out) {
    const char *cli = getenv("VM_CLI");
    if (!cli) cli = "volmesh";
    size_t len = strlen(cli) + strlen(args) + 32;
    char *cmd = malloc(len);
    snprintf(cmd, len, "%s %s 2>&1", cli, args);
    FILE *p = popen(cmd, "r");
    free(cmd);
    if (!p) return -1;
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    size_t r;
    while ((r = fread(buf + n, 1, cap - n - 1, p)) > 0) {
        n += r;
        if (cap - n < 2) buf = realloc(buf, cap *= 2);
    }
    buf[n] = 0;
    int status = pclose(p);
    if (out)
        *out = buf;
    else
        free(buf);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* Writes the fuzz input to this process's scratch file ending in ext; returns its path. */
static const char *fuzz_path(const unsigned char *data, size_t size, const char *ext) {
    static char path[4096];
    if (!path[0]) {
        /* keep a lying header from asking for more than a fuzzing run should allocate */
        setenv("VOLMESH_MAX_MEMORY", "268435456", 0);
        char unique[64];
        snprintf(unique, sizeof unique, "fuzz_%ld%s", (long)getpid(), ext);
        snprintf(path, sizeof path, "%s", vm_test_tmp(unique));
    }
    return vm_test_write_file(path, data, size) == 0 ? path : NULL;
}

static void fuzz_refusal(const char *ext, vm_status st, const vm_error *err) {
    if (err->message[0] == 0 || strchr(err->message, '\n')) {
        fprintf(stderr, "fuzz %s: error %d without a one-line message\n", ext, (int)st);
        abort();
    }
}

int vm_test_fuzz_volume(const unsigned char *data, size_t size, const char *ext,
                        vm_status (*read)(const char *path, vm_volume *v, vm_error *err)) {
    const char *path = fuzz_path(data, size, ext);
    if (!path) return 0;
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = read(path, &v, &err);
    if (st == VM_OK) {
        double lo, hi, mean; /* touch every voxel so a short allocation shows under ASan */
        vm_volume_stats(&v, &lo, &hi, &mean);
        /* A file read whole also reads by slabs: header, then the upper half, then forward
         * with a reader, same values. */
        vm_volume info, s;
        vm_status si = vm_volume_read_info(path, &info, &err);
        if (si == VM_OK) {
            if (memcmp(info.dims, v.dims, sizeof v.dims) != 0 || info.data) abort();
            int64_t z0 = v.dims[2] / 2;
            if (vm_volume_read_slab(path, z0, v.dims[2], &s, &err) != VM_OK) {
                fprintf(stderr, "slab read failed: %s\n", err.message);
                abort();
            }
            size_t plane = (size_t)v.dims[0] * (size_t)v.dims[1];
            if (s.dims[2] != v.dims[2] - z0 ||
                memcmp(s.data, v.data + plane * (size_t)z0,
                       plane * (size_t)s.dims[2] * sizeof(float)) != 0)
                abort();
            vm_volume_free(&s);
            /* and forward in up to 7 slabs, with a reader going on where it stopped */
            vm_volume_reader *r = NULL;
            int64_t step = (v.dims[2] + 6) / 7;
            float *buf = malloc(plane * (size_t)step * sizeof(float));
            if (!buf || vm_volume_reader_open(path, NULL, NULL, &r, &err) != VM_OK) abort();
            for (int64_t k = 0; k < v.dims[2]; k += step) {
                int64_t k1 = k + step < v.dims[2] ? k + step : v.dims[2];
                if (vm_volume_reader_read(r, k, k1, buf, &err) != VM_OK ||
                    memcmp(buf, v.data + plane * (size_t)k,
                           plane * (size_t)(k1 - k) * sizeof(float)) != 0) {
                    fprintf(stderr, "forward read of planes %lld..%lld failed: %s\n",
                            (long long)k, (long long)k1 - 1, err.message);
                    abort();
                }
            }
            vm_volume_reader_close(r);
            free(buf);
        } else if (si != VM_ERR_UNSUPPORTED) {
            fprintf(stderr, "header read failed: %s\n", err.message);
            abort();
        }
        vm_volume_free(&v);
    } else {
        fuzz_refusal(ext, st, &err);
    }
    remove(path);
    return 0;
}

int vm_test_fuzz_mesh(const unsigned char *data, size_t size, const char *ext,
                      vm_status (*read)(const char *path, vm_mesh *m, vm_error *err)) {
    const char *path = fuzz_path(data, size, ext);
    if (!path) return 0;
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = read(path, &m, &err);
    if (st == VM_OK) {
        size_t nn = (size_t)vm_cell_nodes(m.kind);
        for (size_t i = 0; i < m.ncells * nn; i++)
            if (m.cells[i] < 0 || (size_t)m.cells[i] >= m.npoints) abort();
        volatile double sum = 0; /* touch every point */
        for (size_t i = 0; i < 3 * m.npoints; i++) sum += m.points[i];
        (void)sum;
        vm_mesh_free(&m);
    } else {
        fuzz_refusal(ext, st, &err);
    }
    remove(path);
    return 0;
}

int vm_test_fuzz_mesh_check(const unsigned char *data, size_t size, const char *ext) {
    const char *path = fuzz_path(data, size, ext);
    if (!path) return 0;
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_mesh_read(path, &m, &err);
    if (st == VM_OK) {
        vm_mesh_report r;
        st = vm_mesh_check(&m, &r, &err);
        if (st == VM_OK && (r.inverted > m.ncells || r.components > m.ncells + m.npoints))
            abort();
        if (st != VM_OK) fuzz_refusal("check", st, &err);
        vm_quality_summary q;
        vm_error_clear(&err);
        st = vm_quality_report(&m, &q, &err);
        if (st != VM_OK) fuzz_refusal("quality", st, &err);
        vm_mesh_free(&m);
    } else {
        fuzz_refusal(ext, st, &err);
    }
    remove(path);
    return 0;
}

/* ---- shared checks for the volume-reader tests (see tests/test.h) ---- */
#include <stdint.h>
#include "io/io_util.h"

size_t vm_test_put_sample(unsigned char *dst, vm_scalar_type t, int big_endian, double x) {
    unsigned char b[8];
    size_t n = vm_scalar_type_size(t);
    switch (t) {
    case VM_SCALAR_UINT8: { uint8_t y = (uint8_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_INT8: { int8_t y = (int8_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_UINT16: { uint16_t y = (uint16_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_INT16: { int16_t y = (int16_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_UINT32: { uint32_t y = (uint32_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_INT32: { int32_t y = (int32_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_UINT64: { uint64_t y = (uint64_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_INT64: { int64_t y = (int64_t)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_FLOAT32: { float y = (float)x; memcpy(b, &y, n); } break;
    case VM_SCALAR_FLOAT64: memcpy(b, &x, n); break;
    }
    int swap = n > 1 && (big_endian != 0) == (vm__host_little_endian() != 0);
    for (size_t k = 0; k < n; k++) dst[k] = swap ? b[n - 1 - k] : b[k];
    return n;
}

void vm_test_expect_refusal_at(const char *file, int line, const char *path, vm_status got,
                               vm_status expected, const vm_error *err, const char *phrase,
                               const vm_volume *v) {
    const char *msg = err->message;
    size_t n = strlen(path);
    CHECK_MSG(got < 0, "[%s:%d] %s: read succeeded", file, line, path);
    CHECK_MSG(got == expected, "[%s:%d] %s: status %d, expected %d (%s)", file, line, path,
              (int)got, (int)expected, msg);
    CHECK_MSG(err->status == got, "[%s:%d] %s: err.status %d, returned %d", file, line, path,
              (int)err->status, (int)got);
    CHECK_MSG(strncmp(msg, path, n) == 0 && msg[n] == ':' && msg[n + 1] == ' ',
              "[%s:%d] message '%s' does not start with '%s: '", file, line, msg, path);
    CHECK_MSG(strchr(msg, '\n') == NULL, "[%s:%d] message has a newline: %s", file, line, msg);
    CHECK_MSG(!phrase || strstr(msg, phrase) != NULL, "[%s:%d] message '%s' lacks '%s'", file,
              line, msg, phrase ? phrase : "");
    CHECK_MSG(v->data == NULL, "[%s:%d] %s: a refused read returned data", file, line, path);
}

void vm_test_expect_cli_error_at(const char *file, int line, const char *args, const char *path,
                                 const char *message) {
    char info[4300], prefix[4300];
    if (!args) {
        snprintf(info, sizeof info, "info '%s'", path);
        args = info;
    }
    snprintf(prefix, sizeof prefix, "volmesh: %s: ", path);
    char *out = NULL;
    int rc = vm_test_cli(args, &out);
    const char *o = out ? out : "";
    size_t len = strlen(o);
    CHECK_MSG(rc == 2, "[%s:%d] volmesh %s exited %d: %s", file, line, args, rc, o);
    CHECK_MSG(strncmp(o, prefix, strlen(prefix)) == 0,
              "[%s:%d] volmesh %s printed '%s', not starting with '%s'", file, line, args, o,
              prefix);
    CHECK_MSG(len > 0 && strchr(o, '\n') == o + len - 1,
              "[%s:%d] volmesh %s printed '%s', not exactly one line", file, line, args, o);
    if (message) {
        char want[4900];
        snprintf(want, sizeof want, "%s%s\n", prefix, message);
        CHECK_MSG(strcmp(o, want) == 0, "[%s:%d] volmesh %s printed '%s', expected '%s'", file,
                  line, args, o, want);
    }
    free(out);
}

/* ---- digital topology of a thresholded volume (see test.h) ---- */

static int in_material(float f, int has_lo, double lo, int has_hi, double hi) {
    return (!has_lo || f >= lo) && (!has_hi || f <= hi);
}

static size_t digital_uf_find(size_t *parent, size_t x) {
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

/* Euler characteristic of the mesh boundary and number of components predicted from the grid:
 * X = grid points in the material, padded by a layer of outside points. The solid is the
 * cubical complex of X (6-adjacent edges, full squares, full cubes) plus, for every cube with
 * exactly its two antipodal corners outside, the filling that makes it a ball; the boundary
 * of a 3-manifold has twice its Euler characteristic. Components: 6-connected parts of X. */
void vm_test_digital_topology(const vm_volume *v, int has_lo, double lo, int has_hi, double hi,
                              long *euler, size_t *components) {
    const int64_t P0 = v->dims[0] + 2, P1 = v->dims[1] + 2, P2 = v->dims[2] + 2;
    const size_t np = (size_t)(P0 * P1 * P2);
    uint8_t *in = calloc(np, 1);
    size_t *parent = malloc(np * sizeof *parent);
    CHECK(in != NULL && parent != NULL);
    if (!in || !parent) {
        free(in);
        free(parent);
        *euler = -999999;
        *components = 0;
        return;
    }
    for (int64_t k = 0; k < v->dims[2]; k++)
        for (int64_t j = 0; j < v->dims[1]; j++)
            for (int64_t i = 0; i < v->dims[0]; i++) {
                float f = v->data[i + v->dims[0] * (j + v->dims[1] * k)];
                in[(i + 1) + P0 * ((j + 1) + P1 * (k + 1))] =
                    (uint8_t)in_material(f, has_lo, lo, has_hi, hi);
            }
    const size_t step[3] = {1, (size_t)P0, (size_t)(P0 * P1)};
    long V = 0, E = 0, F = 0, C = 0, S = 0;
    for (size_t p = 0; p < np; p++)
        parent[p] = p;
    /* Every cube has its lowest corner in [0, P-2]^3; the last layer is padding (outside). */
    for (int64_t k = 0; k + 1 < P2; k++)
        for (int64_t j = 0; j + 1 < P1; j++)
            for (int64_t i = 0; i + 1 < P0; i++) {
                size_t p = (size_t)(i + P0 * (j + P1 * k));
                uint8_t c[8];
                int count = 0;
                for (int q = 0; q < 8; q++) {
                    c[q] = in[p + (q & 1) * step[0] + ((q >> 1) & 1) * step[1] +
                              (q >> 2) * step[2]];
                    count += c[q];
                }
                if (count == 8) C++;
                if (count == 6)
                    for (int q = 0; q < 4; q++)
                        if (!c[q] && !c[7 - q]) S++;
                if (!c[0]) continue;
                V++;
                for (int a = 0; a < 3; a++) {
                    if (c[1 << a]) {
                        E++;
                        size_t ra = digital_uf_find(parent, p);
                        size_t rb = digital_uf_find(parent, p + step[a]);
                        if (ra != rb) parent[ra] = rb;
                    }
                    int b = (a + 1) % 3;
                    if (c[1 << a] && c[1 << b] && c[(1 << a) | (1 << b)]) F++;
                }
            }
    size_t comps = 0;
    for (size_t p = 0; p < np; p++)
        if (in[p] && digital_uf_find(parent, p) == p) comps++;
    free(in);
    free(parent);
    *euler = 2 * (V - E + F - C + S);
    *components = comps;
}

double vm_test_uniform(uint64_t *state) {
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return (double)(z >> 11) / 9007199254740992.0;
}

static int sort_width;

static int row_cmp(const void *pa, const void *pb) {
    const double *a = pa, *b = pb;
    for (int k = 0; k < sort_width; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

void vm_test_sort_rows(double *rows, size_t count, int width) {
    sort_width = width;
    qsort(rows, count, (size_t)width * sizeof(double), row_cmp);
}

int vm_test_progress(const char *stage, double done, double total, void *user) {
    vm_test_progress_log *l = user;
    if (l->stage && strcmp(stage, l->stage) != 0) {
        l->other_stage++;
        return 0;
    }
    if (l->calls > 0 && total != l->total) l->total_changed++;
    if (done < l->last || done > total) l->backwards++;
    l->calls++;
    l->last = done;
    l->total = total;
    l->ended = done == total;
    return 0;
}

size_t vm_test_push_interior(vm_mesh *m, double dist, unsigned seed, double max_edge) {
    vm_error err;
    vm_mesh b;
    if (vm_mesh_boundary(m, &b, &err) != VM_OK) {
        CHECK_MSG(0, "push: %s", err.message);
        return 0;
    }
    unsigned char *bnd = calloc(m->npoints + 1, 1);
    for (size_t i = 0; bnd && i < b.npoints; i++)
        for (size_t j = 0; j < m->npoints; j++)
            if (!memcmp(b.points + 3 * i, m->points + 3 * j, 3 * sizeof(double))) bnd[j] = 1;
    vm_mesh_free(&b);
    CHECK(bnd != NULL);
    size_t pushed = 0;
    unsigned rng = seed;
    for (size_t i = 0; bnd && i < m->npoints; i++) {
        if (bnd[i]) continue;
        double old[3], dir[3], n2 = 0;
        memcpy(old, m->points + 3 * i, sizeof old);
        for (int k = 0; k < 3; k++) {
            rng = rng * 1103515245u + 12345u;
            dir[k] = (double)(rng >> 8) / (double)(1u << 24) - 0.5;
            n2 += dir[k] * dir[k];
        }
        for (int k = 0; k < 3; k++)
            m->points[3 * i + (size_t)k] += dist * dir[k] / sqrt(n2);
        vm_mesh_report r;
        vm_quality_summary q;
        int ok = vm_mesh_check(m, &r, &err) == VM_OK && !r.inverted && r.min_dihedral >= 15 &&
                 r.max_dihedral <= 150;
        /* ABAQUS's check, and the quality pass's volume measure target (0.03) */
        if (ok)
            ok = vm_quality_report(m, &q, &err) == VM_OK && q.abaqus_failures == 0 &&
                 (max_edge <= 0 || q.edges.max <= max_edge);
        for (size_t t = 0; ok && t < m->ncells; t++) {
            double p[4][3];
            for (int k = 0; k < 4; k++)
                memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + (size_t)k], sizeof p[k]);
            ok = vm_tet_volume_measure((const double(*)[3])p) >= 0.03;
        }
        if (ok)
            pushed++;
        else
            memcpy(m->points + 3 * i, old, sizeof old);
    }
    free(bnd);
    return pushed;
}
