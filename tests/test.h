/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/test.h — a small test harness: CHECK macros, a runner that prints
 * "N passed, N failed", helpers for shared data, temp files and the CLI. */
#ifndef VM_TEST_H
#define VM_TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include "volmesh/volmesh.h"

extern int vm_test_failures; /* failures in the current test function */

#define CHECK(cond)                                                                        \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            fprintf(stderr, "  %s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);     \
            vm_test_failures++;                                                            \
        }                                                                                  \
    } while (0)

#define CHECK_MSG(cond, ...)                                                               \
    do {                                                                                   \
        if (!(cond)) {                                                                     \
            fprintf(stderr, "  %s:%d: CHECK(%s) failed: ", __FILE__, __LINE__, #cond);     \
            fprintf(stderr, __VA_ARGS__);                                                  \
            fputc('\n', stderr);                                                           \
            vm_test_failures++;                                                            \
        }                                                                                  \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                              \
    do {                                                                                   \
        double vm_a_ = (double)(a), vm_b_ = (double)(b), vm_t_ = (double)(tol);            \
        if (!(fabs(vm_a_ - vm_b_) <= vm_t_)) {                                             \
            fprintf(stderr, "  %s:%d: %s = %.10g, expected %s = %.10g (tol %g)\n", __FILE__, \
                    __LINE__, #a, vm_a_, #b, vm_b_, vm_t_);                                \
            vm_test_failures++;                                                            \
        }                                                                                  \
    } while (0)

/* CHECK_OK(status expression): prints the error message on failure. */
#define CHECK_OK(expr, errp)                                                               \
    do {                                                                                   \
        vm_status vm_s_ = (expr);                                                          \
        const vm_error *vm_e_ = (errp);                                                    \
        if (vm_s_ != VM_OK) {                                                              \
            fprintf(stderr, "  %s:%d: %s returned %d: %s\n", __FILE__, __LINE__, #expr,    \
                    (int)vm_s_, vm_e_ != NULL ? vm_e_->message : "");                      \
            vm_test_failures++;                                                            \
        }                                                                                  \
    } while (0)

typedef void (*vm_test_fn)(void);
typedef struct {
    const char *name;
    vm_test_fn fn;
} vm_test_case;

/* Runs the cases, prints one line per case and "N passed, N failed[, N skipped]".
 * Returns the process exit code (0, or 1 when any failed; 77 when all were skipped). */
int vm_test_run(const vm_test_case *cases, size_t n);

/* Marks the current test as skipped with a reason (call, then return from the test). */
void vm_test_skip(const char *reason);

/* Path of a file in ../shared/data, or NULL (after calling vm_test_skip) when absent. */
const char *vm_test_shared(const char *name);

/* Path of a scratch file in the test temp folder (static buffer, rotating 8 slots). */
const char *vm_test_tmp(const char *name);

/* Writes len bytes to path; returns 0 on success. */
int vm_test_write_file(const char *path, const void *data, size_t len);

/* Runs the volmesh CLI with the given argument string (shell-quoted by the caller),
 * capturing stdout+stderr into *out (malloc'd, may be NULL). Returns the exit status. */
int vm_test_cli(const char *args, char **out);

/* What a progress callback was told, for the tests of the bars: give vm_test_progress as the
 * callback and a zeroed log (stage set to count only that stage, or NULL for all) as its
 * user data. */
typedef struct vm_test_progress_log {
    const char *stage; /* the stage counted (NULL: every call) */
    int calls;         /* calls counted */
    int backwards;     /* counted calls whose done went down, or past their total */
    int other_stage;   /* calls of another stage than stage */
    int total_changed; /* counted calls whose total differs from the one before */
    int ended;         /* the last counted call had done == total */
    double last, total; /* done and total of the last counted call */
} vm_test_progress_log;
int vm_test_progress(const char *stage, double done, double total, void *user);

/* 1 when a file exists at path. */
int vm_test_exists(const char *path);

/* Body of a reader fuzz target: writes the bytes to a temp file ending in ext, reads it with
 * read, touches every voxel of a result, and aborts when a refusal comes without a one-line
 * message. Caps VOLMESH_MAX_MEMORY at 256 MiB unless set. Always returns 0. */
int vm_test_fuzz_volume(const unsigned char *data, size_t size, const char *ext,
                        vm_status (*read)(const char *path, vm_volume *v, vm_error *err));

/* The same for a mesh reader: a result must have every node index in range (else abort). */
int vm_test_fuzz_mesh(const unsigned char *data, size_t size, const char *ext,
                      vm_status (*read)(const char *path, vm_mesh *m, vm_error *err));

/* Reads the bytes as a mesh of format ext (vm_mesh_read), then runs vm_mesh_check and
 * vm_quality_report on what was read: each ends with VM_OK or a one-line refusal, never a
 * crash or a hang; the check's counts stay within the mesh's. Always returns 0. */
int vm_test_fuzz_mesh_check(const unsigned char *data, size_t size, const char *ext);

/* Euler characteristic of the boundary and 6-connected components that a mesh of the
 * thresholded voxels {lo <= f <= hi} (either bound open) must have: the cubical complex of
 * the inside grid points, padded by outside points, where a cube with exactly its two
 * antipodal corners outside is filled to a ball (as dual contouring does); the boundary
 * of a 3-manifold has twice its Euler characteristic. CHECK-fails on out of memory. */
void vm_test_digital_topology(const vm_volume *v, int has_lo, double lo, int has_hi, double hi,
                              long *euler, size_t *components);

/* The next number in [0, 1) of the splitmix64 sequence *state (advanced): reproducible
 * noise for the tests. */
double vm_test_uniform(uint64_t *state);

/* Pushes each interior vertex of tet mesh m (on no boundary face) dist along a pseudo-random
 * direction (the sequence from seed), kept where the mesh stays uninverted within 15..150
 * degrees, passes ABAQUS's check with every volume measure at 0.03 or more (the quality
 * pass's targets) and, max_edge > 0, with no edge longer: work for the sweeps that raise the
 * mean angle. Returns the vertices pushed. */
size_t vm_test_push_interior(vm_mesh *m, double dist, unsigned seed, double max_edge);

/* Sorts count rows of width doubles (width <= 16) in lexicographic order, comparing the
 * values exactly: meshes compared as lists of points or of tets' corners. */
void vm_test_sort_rows(double *rows, size_t count, int width);

#define TEST_MAIN(...)                                                                     \
    int main(void) {                                                                       \
        static const vm_test_case cases_[] = {__VA_ARGS__};                                \
        return vm_test_run(cases_, sizeof cases_ / sizeof cases_[0]);                      \
    }
#define T(fn) {#fn, fn}

#endif

/* ---- shared checks for the volume-reader tests (tests/io) ---- */
#ifndef VM_TEST_READER_HELPERS_H
#define VM_TEST_READER_HELPERS_H

/* Stores x converted to scalar type t (a plain C cast) at dst in big-endian byte order when
 * big_endian is non-zero, else little-endian. Returns the sample size in bytes (1..8). */
size_t vm_test_put_sample(unsigned char *dst, vm_scalar_type t, int big_endian, double x);

/* Checks that a reader refused path: it returned got == expected (an error, so < 0),
 * err->status == got, err->message is one line that starts with "PATH: " and contains phrase
 * (phrase NULL: any message), and v->data is NULL. Each failure is recorded with CHECK_MSG and
 * names the calling file and line. */
#define vm_test_expect_refusal(path, got, expected, err, phrase, v)                          \
    vm_test_expect_refusal_at(__FILE__, __LINE__, path, got, expected, err, phrase, v)
void vm_test_expect_refusal_at(const char *file, int line, const char *path, vm_status got,
                               vm_status expected, const vm_error *err, const char *phrase,
                               const vm_volume *v);

/* Runs `volmesh ARGS` (args NULL: "info 'PATH'") and checks that it exits 2 and prints exactly
 * one line, ending in a newline, that starts with "volmesh: PATH: "; when message is not NULL
 * the line must be exactly "volmesh: PATH: MESSAGE\n". Failures are recorded with CHECK_MSG
 * and name the calling file and line. */
#define vm_test_expect_cli_error(args, path, message)                                      \
    vm_test_expect_cli_error_at(__FILE__, __LINE__, args, path, message)
void vm_test_expect_cli_error_at(const char *file, int line, const char *args, const char *path,
                                 const char *message);

#endif
