/* SPDX-License-Identifier: BSD-3-Clause */
/* core/util.c — checked sizes, the memory limit, growable arrays, clock. */
#define _POSIX_C_SOURCE 200809L
#include "core.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#ifdef VM_HAVE_OPENMP
#include <omp.h>
#endif

/* A predicate, not a status: true (and *out untouched) when a*b overflows size_t. */
bool vm__mul_overflows(size_t a, size_t b, size_t *out) {
    if (a != 0 && b > SIZE_MAX / a) return true;
    *out = a * b;
    return false;
}

size_t vm__memory_limit(void) {
    const char *env = getenv("VOLMESH_MAX_MEMORY");
    if (env && *env) {
        char *end = NULL;
        unsigned long long v = strtoull(env, &end, 10);
        if (end != env && v > 0) return (size_t)v;
    }
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    if (pages <= 0 || page <= 0) return (size_t)1 << 34;
    size_t total;
    if (vm__mul_overflows((size_t)pages, (size_t)page, &total)) return SIZE_MAX;
    return total;
}

vm_status vm__check_dims(const int64_t dims[3], size_t elem_size, const char *what,
                         size_t *count, vm_error *err) {
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        if (dims[a] < 1)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: dimension %d is %lld (must be >= 1)",
                                what, a, (long long)dims[a]);
        if ((uint64_t)dims[a] > SIZE_MAX || vm__mul_overflows(n, (size_t)dims[a], &n))
            return vm_error_set(err, VM_ERR_NOMEM, "%s: dimensions %lldx%lldx%lld overflow",
                                what, (long long)dims[0], (long long)dims[1],
                                (long long)dims[2]);
    }
    size_t bytes;
    if (vm__mul_overflows(n, elem_size, &bytes) || bytes > vm__memory_limit()) {
        /* MiB below a GiB, so that a small limit does not read "0.0 GiB, more than 0.0" */
        double need = (double)n * (double)elem_size, lim = (double)vm__memory_limit();
        int gib = lim >= 1073741824.0;
        double unit = gib ? 1073741824.0 : 1048576.0;
        return vm_error_set(err, VM_ERR_NOMEM,
                            "%s: dimensions %lldx%lldx%lld need %.1f %s, more than the "
                            "memory limit of %.1f %s",
                            what, (long long)dims[0], (long long)dims[1], (long long)dims[2],
                            need / unit, gib ? "GiB" : "MiB", lim / unit, gib ? "GiB" : "MiB");
    }
    if (count) *count = n;
    return VM_OK;
}

vm_status vm__grow(void **buf, size_t *cap, size_t need, size_t elem, vm_error *err) {
    if (need <= *cap) return VM_OK;
    size_t ncap = *cap ? *cap : 16;
    while (ncap < need) {
        if (ncap > SIZE_MAX / 2) {
            ncap = need;
            break;
        }
        ncap *= 2;
    }
    size_t bytes;
    if (vm__mul_overflows(ncap, elem, &bytes))
        return vm_error_set(err, VM_ERR_NOMEM, "array of %zu elements overflows", ncap);
    void *p = realloc(*buf, bytes);
    if (!p) return vm_error_set(err, VM_ERR_NOMEM, "out of memory (%zu bytes)", bytes);
    *buf = p;
    *cap = ncap;
    return VM_OK;
}

double vm__now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* fn(stage, done, total) on mt, recording when and a request to stop. */
static int meter_call(vm__meter *mt) {
    mt->when = vm__now();
    if (mt->fn(mt->stage, mt->done, mt->total, mt->user))
        atomic_store_explicit(&mt->stop, 1, memory_order_relaxed);
    return vm__meter_stopped(mt);
}

void vm__meter_start(vm__meter *mt, vm_progress_fn fn, void *user, const char *stage,
                     double total) {
    mt->fn = fn;
    mt->user = user;
    mt->stage = stage;
    mt->total = total > 0.0 ? total : 1.0;
    mt->done = 0.0;
    mt->next = mt->total / 200.0;
    mt->ticks = 0;
    atomic_init(&mt->stop, 0);
    if (fn) meter_call(mt);
}

int vm__meter_add(vm__meter *mt, double units) {
    if (!mt->fn) return 0;
    mt->done += units;
    if (mt->done > mt->total) mt->done = mt->total;
    if (mt->done < mt->next || mt->done >= mt->total)
        return (++mt->ticks & 255) == 0 ? vm__meter_poll(mt) : vm__meter_stopped(mt);
    mt->next = mt->done + mt->total / 200.0;
    return meter_call(mt);
}

void vm__meter_end(vm__meter *mt) {
    if (!mt->fn) return;
    mt->done = mt->total;
    meter_call(mt);
    mt->fn = NULL;
}

int vm__meter_poll(vm__meter *mt) {
    if (mt->fn && mt->stage && vm__now() - mt->when >= VM_PROGRESS_POLL) meter_call(mt);
    return vm__meter_stopped(mt);
}

int vm__meter_stopped(const vm__meter *mt) {
    return atomic_load_explicit(&((vm__meter *)mt)->stop, memory_order_relaxed);
}

void vm__meter_wrap(vm__meter *mt, vm_progress_fn fn, void *user, const char *stage,
                    double total) {
    mt->fn = fn;
    mt->user = user;
    mt->stage = stage; /* polls before the first call repeat (stage, 0, total) */
    mt->total = total;
    mt->done = mt->next = 0.0;
    mt->when = vm__now();
    mt->ticks = 0;
    atomic_init(&mt->stop, 0);
}

int vm__meter_forward(const char *stage, double done, double total, void *user) {
    vm__meter *mt = user;
    if (!mt->fn) return vm__meter_stopped(mt);
    mt->stage = stage;
    mt->done = done;
    mt->total = total;
    return meter_call(mt);
}

int vm__progress_poll(vm_progress_fn fn, void *user) {
    return fn == vm__meter_forward ? vm__meter_poll(user) : 0;
}

int vm__progress_poll_team(vm_progress_fn fn, void *user) {
    if (fn != vm__meter_forward) return 0;
#ifdef VM_HAVE_OPENMP
    if (omp_get_thread_num() != 0) return vm__meter_stopped(user);
#endif
    return vm__meter_poll(user);
}

int vm__progress_stopped(vm_progress_fn fn, void *user) {
    return fn == vm__meter_forward ? vm__meter_stopped(user) : 0;
}

vm_status vm__cancelled(vm_error *err, const char *what) {
    return vm_error_set(err, VM_ERR_CANCELLED, "%s: cancelled", what);
}

vm_status vm__progress_check(vm_progress_fn fn, void *user, const char *what, vm_error *err) {
    return vm__progress_poll(fn, user) ? vm__cancelled(err, what) : VM_OK;
}

size_t vm__uf_find(size_t *parent, size_t x) {
    while (parent[x] != x) {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    return x;
}

void vm__uf_union(size_t *parent, size_t a, size_t b) {
    a = vm__uf_find(parent, a);
    b = vm__uf_find(parent, b);
    if (a < b)
        parent[b] = a;
    else if (b < a)
        parent[a] = b;
}

/* Lists longer than this are sorted by qsort. */
#define SORT_INSERTION_MAX 32

static int u32_cmp(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static int size_cmp(const void *a, const void *b) {
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

static int i64_cmp(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

static int u64_cmp(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The short-list sort of one element type (core.h): a quicksort with the median of three
 * as pivot, the smaller part first by recursion and the larger by the loop, insertion sort
 * below SORT_INSERTION_MAX, and qsort for what is left once the depth passes twice the
 * list's log2 (a run of bad pivots: the sort stays n log n). The values are integers, so any
 * correct sort gives the same array. */
#define SHORT_SORT(name, type, cmp)                                                            \
    static void name##_at(type *a, size_t n, int depth) {                                      \
        while (n > SORT_INSERTION_MAX) {                                                       \
            if (depth-- == 0) {                                                                \
                qsort(a, n, sizeof *a, cmp);                                                   \
                return;                                                                        \
            }                                                                                  \
            type x = a[0], y = a[n / 2], z = a[n - 1], t;                                      \
            type pv = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y));   \
            size_t i = 0, j = n - 1;                                                           \
            for (;;) {                                                                         \
                while (a[i] < pv)                                                              \
                    i++;                                                                       \
                while (pv < a[j])                                                              \
                    j--;                                                                       \
                if (i >= j) break;                                                             \
                t = a[i];                                                                      \
                a[i++] = a[j];                                                                 \
                a[j--] = t;                                                                    \
            }                                                                                  \
            /* a[0..j] <= pv <= a[j+1..n) */                                                   \
            size_t nl = j + 1, nr = n - nl;                                                    \
            if (nl < nr) {                                                                     \
                name##_at(a, nl, depth);                                                       \
                a += nl;                                                                       \
                n = nr;                                                                        \
            } else {                                                                           \
                name##_at(a + nl, nr, depth);                                                  \
                n = nl;                                                                        \
            }                                                                                  \
        }                                                                                      \
        for (size_t i = 1; i < n; i++) {                                                       \
            type x = a[i];                                                                     \
            size_t j = i;                                                                      \
            for (; j > 0 && a[j - 1] > x; j--)                                                 \
                a[j] = a[j - 1];                                                               \
            a[j] = x;                                                                          \
        }                                                                                      \
    }                                                                                          \
    void name(type *a, size_t n) {                                                             \
        int depth = 0;                                                                         \
        for (size_t k = n; k > 1; k >>= 1)                                                     \
            depth += 2;                                                                        \
        name##_at(a, n, depth);                                                                \
    }

SHORT_SORT(vm__sort_u32, uint32_t, u32_cmp)
SHORT_SORT(vm__sort_size, size_t, size_cmp)
SHORT_SORT(vm__sort_u64, uint64_t, u64_cmp)
SHORT_SORT(vm__sort_i64, int64_t, i64_cmp)

/* Squared distance between points p and q. */
static double tri_pd2(const double a[3], const double b[3]) {
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
}

/* Squared distance from p to triangle (a, b, c) (Ericson 5.1.5, closest point on triangle,
 * by Voronoi regions), guarded against degenerate triangles. */
double vm__point_triangle_dist2(const double p[3], const double a[3], const double b[3],
                                const double c[3]) {
    double ab[3], ac[3], ap[3], bp[3], cp[3], q[3];
    for (int k = 0; k < 3; k++) {
        ab[k] = b[k] - a[k];
        ac[k] = c[k] - a[k];
        ap[k] = p[k] - a[k];
        bp[k] = p[k] - b[k];
        cp[k] = p[k] - c[k];
    }
#define DOT(u, w) ((u)[0] * (w)[0] + (u)[1] * (w)[1] + (u)[2] * (w)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
    if (d1 <= 0 && d2 <= 0) return tri_pd2(p, a);
    double d3 = DOT(ab, bp), d4 = DOT(ac, bp);
    if (d3 >= 0 && d4 <= d3) return tri_pd2(p, b);
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 - d3 > 0 ? d1 / (d1 - d3) : 0;
        for (int k = 0; k < 3; k++)
            q[k] = a[k] + v * ab[k];
        return tri_pd2(p, q);
    }
    double d5 = DOT(ab, cp), d6 = DOT(ac, cp);
    if (d6 >= 0 && d5 <= d6) return tri_pd2(p, c);
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double w = d2 - d6 > 0 ? d2 / (d2 - d6) : 0;
        for (int k = 0; k < 3; k++)
            q[k] = a[k] + w * ac[k];
        return tri_pd2(p, q);
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
        double den = (d4 - d3) + (d5 - d6);
        double w = den > 0 ? (d4 - d3) / den : 0;
        for (int k = 0; k < 3; k++)
            q[k] = b[k] + w * (c[k] - b[k]);
        return tri_pd2(p, q);
    }
#undef DOT
    double den = va + vb + vc;
    if (!(den > 0)) { /* degenerate: the nearest of the three corners */
        double e = fmin(tri_pd2(p, a), fmin(tri_pd2(p, b), tri_pd2(p, c)));
        return e;
    }
    double v = vb / den, w = vc / den;
    for (int k = 0; k < 3; k++)
        q[k] = a[k] + ab[k] * v + ac[k] * w;
    return tri_pd2(p, q);
}
