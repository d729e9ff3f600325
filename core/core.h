/* SPDX-License-Identifier: BSD-3-Clause */
/* core/core.h — private helpers shared by io/, mesher/ and quality/: checked sizes, the
 * memory limit, growable arrays. Not part of the public API. */
#ifndef VM_CORE_H
#define VM_CORE_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "volmesh/error.h"
#include "volmesh/mesh.h"
#include "volmesh/volume.h"

/* a*b into *out; returns true, leaving *out alone, when the product overflows size_t
 * (a predicate: `if (vm__mul_overflows(n, size, &bytes)) return ...nomem...`). */
bool vm__mul_overflows(size_t a, size_t b, size_t *out);

/* Largest number of bytes one allocation may take: VOLMESH_MAX_MEMORY (bytes, env) when
 * set, else the machine's physical memory. */
size_t vm__memory_limit(void);

/* Checks dims (each >= 1, product * elem_size fits in size_t and within the memory limit).
 * what names the file or argument in the message. On success *count = nx*ny*nz. */
vm_status vm__check_dims(const int64_t dims[3], size_t elem_size, const char *what,
                         size_t *count, vm_error *err);

/* Grows *buf (elements of elem bytes) so that it holds at least need elements. */
vm_status vm__grow(void **buf, size_t *cap, size_t need, size_t elem, vm_error *err);
/* qsort's order (elements that compare equal in some order) on vm_threads() threads: runs
 * sorted on the threads, then merged; the library's qsort alone below 2^15 elements a run,
 * or when the merge's buffer (n * size bytes) cannot be had. Returns 0 in that last case
 * only (the array is sorted all the same). */
int vm__psort(void *base, size_t n, size_t size, int (*cmp)(const void *, const void *));

/* Sort lists of integers in ascending order: insertion up to 32 elements, a quicksort beyond
 * (the buckets of the counting sorts filled on the threads, put back in item order; the
 * coarsening's sets of packed ids). */
void vm__sort_u32(uint32_t *a, size_t n);
void vm__sort_size(size_t *a, size_t n);
void vm__sort_u64(uint64_t *a, size_t n);
void vm__sort_i64(int64_t *a, size_t n);

/* Squared distance from p to triangle (a, b, c) (core/util.c; Ericson 5.1.5, the closest
 * point by Voronoi regions), a degenerate triangle's nearest corner where the regions fail. */
double vm__point_triangle_dist2(const double p[3], const double a[3], const double b[3],
                                const double c[3]);

/* Edge removal's ring polygon (core/ring.c): the best triangulation of a polygon of np
 * vertices (3 <= np <= VM__RING_MAX, in order around the edge) by the worst grade of its
 * triangles, Klincsek's dynamic programme over the sub-chains. grade(user, i, k, j, bar) is
 * the grade of triangle (i, k, j), i < k < j (its two tets, one to each end of the edge); it
 * may return any value <= bar once it knows the grade is no more than bar. chord(user, i, j)
 * (NULL: every chord) says whether chord ij (i < j, not a polygon side) may be made; it is
 * asked at most once per chord, and only for chords a triangle above the floor could use.
 * Triangles above the floor only: returns the best worst grade, with the np - 2 triangles in
 * tri (the whole polygon's first, each chain's after, last in first out), or -INFINITY when no
 * triangulation beats the floor. */
#define VM__RING_MAX 9
typedef double (*vm__ring_grade_fn)(void *user, int i, int k, int j, double bar);
typedef int (*vm__ring_chord_fn)(void *user, int i, int j);
double vm__ring_triangulate(int np, double floor, vm__ring_grade_fn grade, void *user,
                            vm__ring_chord_fn chord, int (*tri)[3]);

/* Stable compaction on vm_threads() threads: keeps the items i of [0, n) for which
 * keep(i, user) is non-zero, in their order, moved down by move(to, from, count, user) (count
 * items from `from` to `to` < from; the ranges may overlap, as with memmove). keep(i) may
 * read item i only. Each block of items is compacted on its own, then the blocks are moved
 * down in order. Returns the number kept. */
size_t vm__compact(size_t n, int (*keep)(size_t i, void *user),
                   void (*move)(size_t to, size_t from, size_t count, void *user), void *user);

/* Checks that every coordinate of m is finite and within +-VM_COORD_MAX ("WHAT: point P,
 * coordinate y, is inf (coordinates must be finite, within +-1e+30)"), and that every node
 * of every cell of m is a point of m (0 .. npoints-1). On failure returns code, with the
 * message "WHAT: cell C uses node N, outside 0..NPOINTS-1". */
vm_status vm__check_nodes(const vm_mesh *m, vm_status code, const char *what, vm_error *err);

/* Checks v's geometry against the limits of volmesh/volume.h: spacing finite and within
 * VM_SPACING_MIN .. VM_SPACING_MAX, origin and direction finite, origin and far corner within
 * +-VM_EXTENT_MAX. On failure returns VM_ERR_FORMAT, "WHAT: spacing z is 1e+308 (...)". */
vm_status vm__check_geometry(const vm_volume *v, const char *what, vm_error *err);

/* Seconds from a monotonic clock. */
double vm__now(void);

struct vm_volume;
/* v's index-to-world matrix M = D diag(spacing): m[r][c] = direction[r][c] * spacing[c]. */
void vm__volume_frame(const struct vm_volume *v, double m[3][3]);
/* The determinant of m, and its inverse by cofactors over det (its determinant, non-zero). */
double vm__mat3_det(const double m[3][3]);
void vm__mat3_inverse(const double m[3][3], double det, double inv[3][3]);
/* The inverse (inv) of v's index-to-world matrix M = D diag(spacing), and its determinant
 * (*det); VM_ERR_ARG, its message starting with who (the caller's name), when M is
 * singular. Defined in volume.c. */
vm_status vm__frame_inverse(const struct vm_volume *v, const char *who, double inv[3][3],
                            double *det, vm_error *err);

/* Union-find over 0..n-1 (parent[i] = i to start): the root of x (path halving), and the
 * union of the sets of a and b, whose root is the smaller of their roots (so the result
 * does not depend on the order of the unions). */
size_t vm__uf_find(size_t *parent, size_t x);
void vm__uf_union(size_t *parent, size_t a, size_t b);

/* A progress meter over a known amount of work: calls fn(stage, done, total, user) when done
 * has grown by about 1/200 of total since the last call, and once at the end with done ==
 * total. fn may be NULL (the meter then does nothing). Add and poll from the calling thread
 * only; any thread may read the cancellation (vm__meter_stopped).
 *
 * Cancellation (volmesh/mesh.h): a nonzero return of fn is kept in the meter (stop, sticky);
 * vm__meter_add and vm__meter_poll return it. A stage without a known total forwards its
 * own calls through a meter (vm__meter_wrap, then fn vm__meter_forward with the meter as
 * user), so that the code below it can poll and read the request from (fn, user) alone
 * (vm__progress_poll, vm__progress_stopped). */
typedef struct vm__meter {
    vm_progress_fn fn;
    void *user;
    const char *stage;
    double total, done, next;
    double when;     /* vm__now() at the last call of fn */
    unsigned ticks;  /* adds since start: the clock is read every 256th */
    atomic_int stop; /* fn returned nonzero */
} vm__meter;
void vm__meter_start(vm__meter *mt, vm_progress_fn fn, void *user, const char *stage,
                     double total);
int vm__meter_add(vm__meter *mt, double units);
void vm__meter_end(vm__meter *mt);
/* Repeats the last call of fn when VM_PROGRESS_POLL seconds have passed since it; returns
 * the request to stop. Calling thread only. */
int vm__meter_poll(vm__meter *mt);
/* The request to stop; any thread. */
int vm__meter_stopped(const vm__meter *mt);
/* A meter that only forwards: fn may be NULL; its polls before the first forwarded call
 * repeat (stage, 0, total), the values that call will start from. */
void vm__meter_wrap(vm__meter *mt, vm_progress_fn fn, void *user, const char *stage,
                    double total);
/* vm_progress_fn over a meter (user: the vm__meter): records the call, calls its fn. */
int vm__meter_forward(const char *stage, double done, double total, void *user);
/* For a (fn, user) pair that a stage forwards through a meter (vm__meter_forward), the
 * meter's poll and request; any other pair (a caller's own callback, NULL) reads 0. Poll
 * from the calling thread; in a parallel loop vm__progress_poll_team polls on the team's
 * thread 0 (the calling thread) and reads the request on the others. */
int vm__progress_poll(vm_progress_fn fn, void *user);
int vm__progress_poll_team(vm_progress_fn fn, void *user);
int vm__progress_stopped(vm_progress_fn fn, void *user);
/* VM_ERR_CANCELLED "WHAT: cancelled" in err. */
vm_status vm__cancelled(vm_error *err, const char *what);
/* VM_ERR_CANCELLED (err filled) when (fn, user) asks to stop after a poll, else VM_OK. */
vm_status vm__progress_check(vm_progress_fn fn, void *user, const char *what, vm_error *err);

/* The index of xyz among m's points, appending it to m when new (an exact-coordinate
 * merge, the first of equal points winning). pi starts as {0, NULL} and grows with m; free
 * it with vm_point_index_free (volmesh/slabs.h). Returns -1 on out of memory (err filled). */
struct vm_point_index;
vm_index vm__point_index_add(struct vm_point_index *pi, vm_mesh *m, const double xyz[3],
                             vm_error *err);

#endif
