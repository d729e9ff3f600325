/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/core/test_compact.c — vm__sort_u32, vm__sort_size, vm__sort_u64 and vm__sort_i64
 * (core/util.c),
 * which put the buckets of counting sorts filled on the threads back in order, and
 * vm__compact (core/threads.c), the stable compaction the mesher's re-emission and the
 * quality pass's slot list run on the threads: on 1 to 4 threads, sizes from 0 past several
 * blocks (65,536 items each) and keep patterns from none to all, it keeps exactly the items
 * a serial filter keeps, in their order, and reads each item's keep flag from the item
 * itself (the items it moves carry their flags). */
#include "core/core.h"
#include "test.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* An item: its original index and whether it is to be kept, moved as a pair. */
typedef struct items {
    uint64_t *id;
    uint8_t *keep;
    size_t moves; /* calls of move with count > 1 (the blocks' moves) */
} items;

static int keep_item(size_t i, void *user) {
    return ((const items *)user)->keep[i];
}

static void move_items(size_t to, size_t from, size_t count, void *user) {
    items *a = user;
    CHECK(to < from);
    memmove(a->id + to, a->id + from, count * sizeof *a->id);
    memmove(a->keep + to, a->keep + from, count * sizeof *a->keep);
    if (count > 1) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
        a->moves++;
    }
}

static void keepsWhatASerialFilterKeepsInOrderOnAnyThreadCount(void) {
    static const size_t sizes[] = {0, 1, 2, 1000, 65536, 65537, 3 * 65536 + 17, 400000};
    /* keep patterns: none, all, every third, random halves, only the last, a long gap */
    const int npat = 6;
    int before = vm_threads();
    uint64_t st = 7;
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
        size_t n = sizes[si];
        uint8_t *pat = malloc(n + 1);
        uint64_t *want = malloc((n + 1) * sizeof *want);
        items a = {malloc((n + 1) * sizeof *a.id), malloc(n + 1), 0};
        CHECK(pat && want && a.id && a.keep);
        if (!pat || !want || !a.id || !a.keep) break;
        for (int p = 0; p < npat; p++) {
            for (size_t i = 0; i < n; i++)
                pat[i] = p == 0   ? 0
                         : p == 1 ? 1
                         : p == 2 ? i % 3 == 0
                         : p == 3 ? vm_test_uniform(&st) < 0.5
                         : p == 4 ? i + 1 == n
                                  : i < n / 5 || i > n - n / 5;
            size_t nw = 0;
            for (size_t i = 0; i < n; i++)
                if (pat[i]) want[nw++] = i;
            for (int t = 1; t <= 4; t++) {
                vm_set_threads(t);
                for (size_t i = 0; i < n; i++)
                    a.id[i] = i;
                memcpy(a.keep, pat, n);
                a.moves = 0;
                size_t kept = vm__compact(n, keep_item, move_items, &a);
                CHECK_MSG(kept == nw, "n %zu, pattern %d, %d threads: kept %zu of %zu", n, p, t,
                          kept, nw);
                CHECK_MSG(kept != nw || nw == 0 || memcmp(a.id, want, nw * sizeof *want) == 0,
                          "n %zu, pattern %d, %d threads: not the serial filter's items", n, p,
                          t);
                size_t flagged = 0;
                for (size_t i = 0; i < kept && i < n; i++)
                    flagged += a.keep[i];
                CHECK_MSG(flagged == kept, "n %zu, pattern %d, %d threads: flags not moved", n,
                          p, t);
                /* several blocks on several threads: the blocks were moved as ranges */
                if (t > 1 && n > 2 * 65536 && p == 1) CHECK(a.moves == 0);
                if (t > 1 && n > 2 * 65536 && p == 2) CHECK(a.moves > 0);
            }
        }
        free(pat);
        free(want);
        free(a.id);
        free(a.keep);
    }
    vm_set_threads(before);
}

static int u32_order(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Lists of 0 to 100 elements (insertion below 33, qsort beyond), with repeats, come out
 * as qsort sorts them. */
static void shortAndLongListsAreSortedAscending(void) {
    uint64_t st = 11;
    for (size_t n = 0; n <= 100; n++) {
        uint32_t a[100], want[100];
        size_t b[100];
        uint64_t c[100];
        for (size_t i = 0; i < n; i++) {
            want[i] = a[i] = (uint32_t)(vm_test_uniform(&st) * (n / 2 + 1));
            b[i] = (size_t)a[i] * 1000003u;
            c[i] = (uint64_t)a[i] << 33 | 5u;
        }
        qsort(want, n, sizeof *want, u32_order);
        vm__sort_u32(a, n);
        vm__sort_size(b, n);
        vm__sort_u64(c, n);
        int same = 1;
        for (size_t i = 0; i < n; i++)
            same &= a[i] == want[i] && b[i] == (size_t)want[i] * 1000003u &&
                    c[i] == ((uint64_t)want[i] << 33 | 5u);
        CHECK_MSG(same, "n %zu: not in qsort's order", n);
    }
}

static int i64_order(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return x < y ? -1 : x > y;
}

/* Longer lists (the quicksort's partitions, down to insertion) in the orders that trouble a
 * quicksort: random with and without repeats, sorted, reversed, all equal, organ pipe, saw
 * tooth; signed values (the coarsening's hashed faces are negative as often as not). Each
 * comes out as qsort sorts it. */
static void longListsInAwkwardOrdersAreSortedAscending(void) {
    static const size_t sizes[] = {33, 34, 65, 100, 257, 1000, 2048, 4099};
    uint64_t st = 5;
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
        size_t n = sizes[si];
        int64_t *a = malloc(n * sizeof *a), *want = malloc(n * sizeof *want);
        uint64_t *u = malloc(n * sizeof *u);
        CHECK(a && want && u);
        if (!a || !want || !u) {
            free(a);
            free(want);
            free(u);
            return;
        }
        for (int pat = 0; pat < 7; pat++) {
            for (size_t i = 0; i < n; i++) {
                double r = vm_test_uniform(&st);
                int64_t x = pat == 0   ? (int64_t)(r * 1e15) - (int64_t)5e14
                            : pat == 1 ? (int64_t)(r * 7) - 3
                            : pat == 2 ? (int64_t)i
                            : pat == 3 ? (int64_t)(n - i)
                            : pat == 4 ? 42
                            : pat == 5 ? (int64_t)(i < n / 2 ? i : n - i)
                                       : (int64_t)(i % 17) * (i % 2 ? -1 : 1);
                a[i] = want[i] = x;
                u[i] = (uint64_t)x ^ 0x8000000000000000ull; /* the same order, unsigned */
            }
            qsort(want, n, sizeof *want, i64_order);
            vm__sort_i64(a, n);
            vm__sort_u64(u, n);
            int same = 1;
            for (size_t i = 0; i < n; i++)
                same &= a[i] == want[i] && u[i] == ((uint64_t)want[i] ^ 0x8000000000000000ull);
            CHECK_MSG(same, "n %zu, pattern %d: not in qsort's order", n, pat);
        }
        free(a);
        free(want);
        free(u);
    }
}

TEST_MAIN(T(shortAndLongListsAreSortedAscending), T(longListsInAwkwardOrdersAreSortedAscending),
          T(keepsWhatASerialFilterKeepsInOrderOnAnyThreadCount))
