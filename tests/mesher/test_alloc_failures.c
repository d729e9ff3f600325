/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_alloc_failures.c — every allocation of read -> mesh -> improve -> write
 * can fail (issue 31; zlib's test/infcover.c does the same for inflate): a first run counts
 * the library's allocations, then run k fails the k-th (k = 1 .. N, or an even spread of
 * them when N is large). Each run returns VM_OK or VM_ERR_NOMEM with a one-line message,
 * never crashes, leaves no output file (nor a temporary one), and frees every block it
 * allocated (counted here; LeakSanitizer checks the same under -DVOLMESH_SANITIZE=ON).
 *
 * The library's calls to malloc, calloc, realloc and free are redirected to the __wrap_
 * functions below by the linker (-Wl,--wrap=..., tests/CMakeLists.txt): the library itself
 * carries no hook. Without that link option (VM_WRAP_ALLOC undefined) the test skips. */
#define _POSIX_C_SOURCE 200809L
#include <stdatomic.h>
#include <string.h>
#include "test.h"

#ifdef VM_WRAP_ALLOC
void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

static atomic_int armed;       /* counting (and maybe failing) */
static atomic_long calls;      /* allocations counted since armed */
static atomic_long fail_at;    /* the allocation that fails (1-based); 0: none */
static atomic_long live;       /* blocks allocated minus blocks freed since armed */

/* 1 when this allocation is the one to fail. */
static int fails(void) {
    if (!atomic_load(&armed)) return 0;
    long k = atomic_fetch_add(&calls, 1) + 1;
    return k == atomic_load(&fail_at);
}

void *__wrap_malloc(size_t n) {
    if (fails()) return NULL;
    void *p = __real_malloc(n);
    if (p && atomic_load(&armed)) atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_calloc(size_t n, size_t size) {
    if (fails()) return NULL;
    void *p = __real_calloc(n, size);
    if (p && atomic_load(&armed)) atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_realloc(void *p, size_t n) {
    if (n && fails()) return NULL; /* the block p stays, as realloc leaves it */
    void *q = __real_realloc(p, n);
    if (atomic_load(&armed)) {
        if (!p && q) atomic_fetch_add(&live, 1);
        if (p && !n) atomic_fetch_sub(&live, 1); /* glibc frees p */
    }
    return q;
}

void __wrap_free(void *p) {
    if (p && atomic_load(&armed)) atomic_fetch_sub(&live, 1);
    __real_free(p);
}

static char in_path[4096], out_path[4096]; /* vm_test_tmp's buffers rotate */

/* read -> mesh -> improve -> write; returns the status, err the message. */
static vm_status pipeline(vm_error *err) {
    vm_volume v;
    memset(&v, 0, sizeof v);
    vm_mesh m;
    vm_mesh_init(&m, VM_TET4);
    vm_status s = vm_volume_read(in_path, &v, err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    if (!s) s = vm_mesh_volume(&v, &o, &m, NULL, err);
    vm_improve_options io;
    vm_improve_options_default(&io);
    if (!s) s = vm_mesh_improve(&m, &v, &io, NULL, err);
    if (!s) s = vm_mesh_write(out_path, &m, err);
    vm_mesh_free(&m);
    vm_volume_free(&v);
    return s;
}

/* Runs the pipeline with allocation k failing (0: none); *n the allocations counted. */
static vm_status run_failing(long k, long *n, long *leaked, vm_error *err) {
    vm_error_clear(err);
    atomic_store(&calls, 0);
    atomic_store(&live, 0);
    atomic_store(&fail_at, k);
    atomic_store(&armed, 1);
    vm_status s = pipeline(err);
    atomic_store(&armed, 0);
    *n = atomic_load(&calls);
    *leaked = atomic_load(&live);
    return s;
}

/* 1 when a temporary file of out_path's is left in the test folder. */
static int temporary_left(void) {
    char cmd[4400];
    snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -q '^alloc_out\\.vtu\\.'", vm_test_tmp(""));
    return system(cmd) == 0;
}

static void every_allocation_failure_is_clean(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    /* a sphere of radius ~5 voxels in 14^3: a few thousand tets, every stage at work */
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 14, 0.0, 1, &v, NULL, &err), &err);
    snprintf(in_path, sizeof in_path, "%s", vm_test_tmp("alloc_in.nrrd"));
    CHECK_OK(vm_volume_write_nrrd(in_path, &v, 1, &err), &err);
    vm_volume_free(&v);
    snprintf(out_path, sizeof out_path, "%s", vm_test_tmp("alloc_out.vtu"));
    remove(out_path);
    int threads = vm_set_threads(1); /* the same allocations in the same order each run */

    long n = 0, leaked = 0;
    vm_status s = run_failing(0, &n, &leaked, &err);
    CHECK_OK(s, &err);
    CHECK_MSG(leaked == 0, "the run without failures keeps %ld blocks", leaked);
    CHECK(vm_test_exists(out_path));
    remove(out_path);
    fprintf(stderr, "  %ld allocations in read -> mesh -> improve -> write\n", n);
    CHECK(n > 50);

    /* every k up to 200 (reading, the octree, the first tets), then about 400 more spread
     * evenly to N (infcover fails every one; here N is in the thousands, and the spread
     * keeps the test well under a minute, under the sanitizers too) */
    long step = n > 600 ? (n - 200) / 400 + 1 : 1, tried = 0, nomem = 0, ok = 0;
    for (long k = 1; k <= n; k += k < 200 ? 1 : step) {
        long nk = 0;
        s = run_failing(k, &nk, &leaked, &err);
        tried++;
        if (s == VM_OK) {
            ok++; /* the failure was absorbed (a fallback): the output must then be there */
            CHECK_MSG(vm_test_exists(out_path), "allocation %ld: VM_OK without the output", k);
        } else {
            nomem++;
            CHECK_MSG(s == VM_ERR_NOMEM, "allocation %ld of %ld: status %d (%s)", k, n, (int)s,
                      err.message);
            CHECK_MSG(err.message[0] && !strchr(err.message, '\n'),
                      "allocation %ld: message \"%s\"", k, err.message);
            CHECK_MSG(!vm_test_exists(out_path), "allocation %ld: an output was left", k);
        }
        CHECK_MSG(leaked == 0, "allocation %ld of %ld (%s): %ld blocks not freed", k, n,
                  err.message, leaked);
        CHECK_MSG(!temporary_left(), "allocation %ld: a temporary file was left", k);
        remove(out_path);
        if (vm_test_failures > 20) break; /* enough to go on */
    }
    fprintf(stderr, "  %ld failures injected: %ld VM_ERR_NOMEM, %ld absorbed (VM_OK)\n", tried,
            nomem, ok);
    vm_set_threads(threads);
    remove(in_path);
}
#else
static void every_allocation_failure_is_clean(void) {
    vm_test_skip("built without the linker's --wrap of malloc (tests/CMakeLists.txt)");
}
#endif

TEST_MAIN(T(every_allocation_failure_is_clean))
