/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/core/test_cancel.c — a progress callback that returns nonzero cancels (issue 28):
 * for every k, a callback that asks to stop from its k-th call on makes the mesher (tets,
 * adaptive tets, hexes), the quality pass, the labels mesher, the writers, the check, the
 * quality report, denoising, the spectrum and marching cubes return VM_ERR_CANCELLED with
 * "...: cancelled", hand back no mesh (or, improving in place, a valid one), write no file,
 * and free every block they allocated (counted here through the linker's --wrap, as
 * tests/mesher/test_alloc_failures.c does; LeakSanitizer checks the same under
 * -DVOLMESH_SANITIZE=ON). The k past the last call runs to VM_OK. */
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

static atomic_long live; /* blocks allocated minus blocks freed */

void *__wrap_malloc(size_t n) {
    void *p = __real_malloc(n);
    if (p) atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_calloc(size_t n, size_t size) {
    void *p = __real_calloc(n, size);
    if (p) atomic_fetch_add(&live, 1);
    return p;
}

void *__wrap_realloc(void *p, size_t n) {
    void *q = __real_realloc(p, n);
    if (!p && q) atomic_fetch_add(&live, 1);
    if (p && !n) atomic_fetch_sub(&live, 1); /* glibc frees p */
    return q;
}

void __wrap_free(void *p) {
    if (p) atomic_fetch_sub(&live, 1);
    __real_free(p);
}

static long live_blocks(void) { return atomic_load(&live); }
#else
static long live_blocks(void) { return 0; } /* counted only with the wrap */
#endif

/* The callback: counts its calls and asks to stop from call stop_at on (0: never). */
typedef struct stopper {
    long calls, stop_at;
    int asked;             /* it returned nonzero at least once */
    double last;           /* done of the last call (of the current stage) */
    const char *stage;     /* of the last call */
    int backwards;         /* a call whose done went below the one before in its stage */
} stopper;

static int stop_fn(const char *stage, double done, double total, void *user) {
    stopper *s = user;
    (void)total;
    if (s->stage && strcmp(stage, s->stage) == 0 && done < s->last) s->backwards++;
    s->stage = stage;
    s->last = done;
    s->calls++;
    if (s->stop_at > 0 && s->calls >= s->stop_at) {
        s->asked = 1;
        return 1;
    }
    return 0;
}

/* 1 when msg ends with "cancelled". */
static int says_cancelled(const char *msg) {
    size_t n = strlen(msg), t = strlen("cancelled");
    return n >= t && strcmp(msg + n - t, "cancelled") == 0;
}

/* One run of the sweep: what the run returned and what the callback saw. */
typedef vm_status (*run_fn)(const void *ctx, stopper *sp, vm_error *err);

/* Runs run with k = 1, 2, ... until it completes (at most max_k, every step-th k past 64):
 * each cancelled run must say so, and no run may keep a block. Returns the runs cancelled. */
static long sweep(const char *what, run_fn run, const void *ctx, long max_k) {
    long cancelled = 0, k;
    int completed = 0;
    for (k = 1; k <= max_k && !completed; k += k < 64 ? 1 : k / 16) {
        stopper sp;
        memset(&sp, 0, sizeof sp);
        sp.stop_at = k;
        vm_error err;
        vm_error_clear(&err);
        long before = live_blocks();
        vm_status s = run(ctx, &sp, &err);
        long kept = live_blocks() - before;
        CHECK_MSG(kept == 0, "%s, stop at call %ld: %ld blocks kept", what, k, kept);
        CHECK_MSG(sp.backwards == 0, "%s, stop at call %ld: done went back", what, k);
        if (sp.asked) {
            cancelled++;
            CHECK_MSG(s == VM_ERR_CANCELLED && err.status == VM_ERR_CANCELLED &&
                          says_cancelled(err.message),
                      "%s, stop at call %ld of %ld: status %d '%s'", what, k, sp.calls, (int)s,
                      err.message);
        } else {
            CHECK_MSG(s == VM_OK, "%s, %ld calls, never asked to stop: status %d '%s'", what,
                      sp.calls, (int)s, err.message);
            completed = 1;
        }
    }
    CHECK_MSG(completed, "%s: still cancelled at call %ld", what, k);
    return cancelled;
}

/* ---- the mesher ---- */

typedef struct mesh_case {
    const vm_volume *v;
    vm_cell_kind kind;
    int adaptive;
    int graded;
} mesh_case;

static vm_status run_mesh(const void *ctx, stopper *sp, vm_error *err) {
    const mesh_case *c = ctx;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = c->kind;
    o.adaptive = c->adaptive;
    o.graded = c->graded;
    o.progress = stop_fn;
    o.progress_user = sp;
    vm_mesh m;
    vm_status s = vm_mesh_volume(c->v, &o, &m, NULL, err);
    if (s) CHECK(m.ncells == 0 && m.npoints == 0 && !m.cells && !m.points && !m.region);
    if (!s) CHECK(m.ncells > 0);
    vm_mesh_free(&m);
    return s;
}

static void meshingStopsWithCancelledAtEveryCallAndKeepsNothing(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 28, 0.0, 1, &v, NULL, &err), &err);
    const mesh_case cases[] = {{&v, VM_TET4, 0, 0}, {&v, VM_TET4, 1, 0}, {&v, VM_HEX8, 0, 0},
                               {&v, VM_HEX8, 1, 0}, {&v, VM_TET4, 0, 1}};
    const char *names[] = {"tets", "adaptive tets", "hexes", "adaptive hexes", "graded tets"};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        long n = sweep(names[i], run_mesh, &cases[i], 4000);
        /* the graded mesher calls at its rounds and around coarsening (and polls between) */
        long least = cases[i].graded ? 3 : 4;
        CHECK_MSG(n >= least, "%s: cancelled at %ld calls only", names[i], n);
    }
    vm_volume_free(&v);
}

/* ---- the quality pass ---- */

typedef struct improve_case {
    const vm_volume *v;
    int parts;
} improve_case;

static vm_status run_improve(const void *ctx, stopper *sp, vm_error *err) {
    const improve_case *c = ctx;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh m;
    vm_status s = vm_mesh_volume(c->v, &o, &m, NULL, err);
    CHECK_OK(s, err);
    if (s) return VM_ERR_INTERNAL;
    vm_improve_options io;
    vm_improve_options_default(&io);
    io.parts = c->parts;
    io.progress = stop_fn;
    io.progress_user = sp;
    vm_improve_report r;
    s = vm_mesh_improve(&m, c->v, &io, &r, err);
    /* cancelled or not, the mesh improved in place is whole and valid */
    vm_mesh_report q;
    vm_error e2;
    CHECK_OK(vm_mesh_check(&m, &q, &e2), &e2);
    CHECK_MSG(q.cells > 0 && q.inverted == 0 && q.overshared_faces == 0 && q.boundary_closed,
              "improve (parts %d) stopped at call %ld: %zu cells, %zu inverted, closed %d",
              c->parts, sp->stop_at, q.cells, q.inverted, q.boundary_closed);
    vm_mesh_free(&m);
    return s;
}

static void qualityPassStopsWithCancelledAndLeavesAValidMesh(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 28, 0.0, 1, &v, NULL, &err), &err);
    /* 0: the local pass (the default), 1: one pass over the whole mesh, 3: by parts */
    const int parts[] = {0, 1, 3};
    for (size_t i = 0; i < sizeof parts / sizeof parts[0]; i++) {
        improve_case c = {&v, parts[i]};
        char name[32];
        snprintf(name, sizeof name, "improve (parts %d)", parts[i]);
        long n = sweep(name, run_improve, &c, 4000);
        CHECK_MSG(n >= 2, "%s: cancelled at %ld calls only", name, n);
    }
    vm_volume_free(&v);
}

/* ---- the labels mesher ---- */

static vm_status run_labels(const void *ctx, stopper *sp, vm_error *err) {
    const vm_volume *v = ctx;
    vm_label_options o;
    vm_label_options_default(&o);
    o.progress = stop_fn;
    o.progress_user = sp;
    vm_mesh m;
    vm_label_stats st;
    vm_status s = vm_mesh_labels(v, &o, &m, &st, err);
    if (s) CHECK(m.ncells == 0 && !m.cells && !m.points && !m.region);
    if (!s) vm_label_stats_free(&st);
    vm_mesh_free(&m);
    return s;
}

static void labelsStopWithCancelledAndKeepNothing(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    CHECK_OK(vm_label_phantom_make(0, 24, &v, &err), &err);
    long n = sweep("labels", run_labels, &v, 1000);
    CHECK_MSG(n >= 4, "labels: cancelled at %ld calls only", n);
    vm_volume_free(&v);
}

/* ---- a writer ---- */

typedef struct write_case {
    const vm_mesh *m;
    const char *path;
} write_case;

static vm_status run_write(const void *ctx, stopper *sp, vm_error *err) {
    const write_case *c = ctx;
    remove(c->path);
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    wo.progress = stop_fn;
    wo.progress_user = sp;
    vm_status s = vm_mesh_write_as(c->path, c->m, &wo, err);
    FILE *f = fopen(c->path, "rb");
    CHECK_MSG((f != NULL) == (s == VM_OK), "%s: status %d, file %s", c->path, (int)s,
              f ? "written" : "absent");
    if (f) fclose(f);
    char cmd[4400]; /* no temporary file left beside it either */
    snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -q '^cancel_out\\.[a-z]*\\.'", vm_test_tmp(""));
    CHECK_MSG(system(cmd) != 0, "%s: a temporary file is left", c->path);
    return s;
}

static void writersStopWithCancelledAndLeaveNoFile(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 20, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    const char *names[] = {"cancel_out.vtu", "cancel_out.inp", "cancel_out.msh"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s", vm_test_tmp(names[i]));
        write_case c = {&m, path};
        long n = sweep(names[i], run_write, &c, 1000);
        CHECK_MSG(n >= 1, "%s: cancelled at %ld calls only", names[i], n);
        remove(path);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* ---- checks, reports, denoising, the spectrum, marching cubes ---- */

typedef struct other_case {
    const vm_volume *v;
    const vm_mesh *m;
    int which;
} other_case;

static vm_status run_other(const void *ctx, stopper *sp, vm_error *err) {
    const other_case *c = ctx;
    vm_status s = VM_OK;
    if (c->which == 0) {
        vm_mesh_report r;
        s = vm_mesh_check_with(c->m, stop_fn, sp, &r, err);
    } else if (c->which == 1) {
        vm_quality_options o;
        vm_quality_options_init(&o);
        o.progress = stop_fn;
        o.progress_user = sp;
        vm_quality_summary q;
        s = vm_quality_report_with(c->m, &o, &q, err);
    } else if (c->which == 2 || c->which == 3) {
        vm_volume out;
        memset(&out, 0, sizeof out);
        s = c->which == 2 ? vm_denoise_bilateral(c->v, 0, 0, &out, stop_fn, sp, err)
                          : vm_denoise_diffusion(c->v, 0, 0, 0, &out, stop_fn, sp, err);
        if (s) CHECK(out.data == NULL); /* untouched */
        vm_volume_free(&out);
    } else if (c->which == 4) {
        vm_spectrum sp_out;
        s = vm_spectrum_compute_range(c->v, 64, -20.0, 20.0, stop_fn, sp, &sp_out, err);
        vm_spectrum_free(&sp_out);
    } else if (c->which == 5) {
        vm_surface_options o;
        vm_surface_options_default(&o);
        o.method = VM_SURFACE_MC;
        o.progress = stop_fn;
        o.progress_user = sp;
        vm_mesh m;
        s = vm_surface_extract(c->v, &o, &m, NULL, err);
        if (s) CHECK(m.ncells == 0 && !m.cells);
        vm_mesh_free(&m);
    }
    return s;
}

static void checksReportsDenoisingSpectrumAndMarchingCubesStopWithCancelled(void) {
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 24, 0.5, 1, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    const char *names[] = {"check", "quality report", "bilateral", "diffusion", "spectrum",
                           "marching cubes"};
    for (int i = 0; i < 6; i++) {
        other_case c = {&v, &m, i};
        long n = sweep(names[i], run_other, &c, 1000);
        CHECK_MSG(n >= 1, "%s: cancelled at %ld calls only", names[i], n);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(meshingStopsWithCancelledAtEveryCallAndKeepsNothing),
          T(qualityPassStopsWithCancelledAndLeavesAValidMesh),
          T(labelsStopWithCancelledAndKeepNothing), T(writersStopWithCancelledAndLeaveNoFile),
          T(checksReportsDenoisingSpectrumAndMarchingCubesStopWithCancelled))
