/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/core/test_compact.c — vm__sort_u32, vm__sort_size and vm__sort_u64 (core/util.c),
 * which put the buckets of counting sorts filled on the threads back in order, and
 * vm__compact (core/threads.c), the stable compaction the mesher's re-emission and the
 * quality pass's slot list run on the threads: on 1 to 4 threads, sizes from 0 past several
 * blocks (65,536 items each) and keep patterns from none to all, it keeps exactly the items
 * a serial filter keeps, in their order, and reads each item's keep flag from the item
 * itself (the items it moves carry their flags). */
#include "core/core.h"
#include "test.h"
#include <stdint.h>
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

TEST_MAIN(T(shortAndLongListsAreSortedAscending),
          T(keepsWhatASerialFilterKeepsInOrderOnAnyThreadCount))
