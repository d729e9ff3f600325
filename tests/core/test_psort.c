/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/core/test_psort.c — vm__psort (core/threads.c), the sort the mesher's boundary
 * search runs on the threads: on 1 to 5 threads and sizes from 0 past a few runs, it
 * gives what qsort gives (the same keys in the same order; with a comparator that tells
 * every element apart, the same array byte for byte) and keeps every element. */
#include "core/core.h"
#include "test.h"
#include <stdint.h>
#include <string.h>

typedef struct item {
    int64_t key[3];
    uint32_t payload;
} item;

static int key_cmp(const void *x, const void *y) {
    const int64_t *a = ((const item *)x)->key, *b = ((const item *)y)->key;
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* keys, then the payload: a total order */
static int full_cmp(const void *x, const void *y) {
    int c = key_cmp(x, y);
    if (c) return c;
    uint32_t a = ((const item *)x)->payload, b = ((const item *)y)->payload;
    return a < b ? -1 : a > b;
}

static int i64_cmp(const void *x, const void *y) {
    int64_t a = *(const int64_t *)x, b = *(const int64_t *)y;
    return a < b ? -1 : a > b;
}

static void fill(item *a, size_t n, uint64_t *st, int range) {
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++)
            a[i].key[k] = (int64_t)(vm_test_uniform(st) * range);
        a[i].payload = (uint32_t)i;
    }
}

static void sortsAsQsortOnAnyThreadCount(void) {
    static const size_t sizes[] = {0, 1, 7, 32767, 32768, 65537, 200003, 600001};
    uint64_t st = 12345;
    int before = vm_set_threads(1);
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; si++) {
        size_t n = sizes[si];
        item *orig = malloc((n + 1) * sizeof *orig), *ref = malloc((n + 1) * sizeof *ref);
        item *a = malloc((n + 1) * sizeof *a);
        int64_t *ia = malloc((n + 1) * sizeof *ia), *ir = malloc((n + 1) * sizeof *ir);
        CHECK(orig && ref && a && ia && ir);
        if (!orig || !ref || !a || !ia || !ir) break;
        /* few distinct keys (many equal ones, as the mesher's duplicate faces) */
        fill(orig, n, &st, 40);
        memcpy(ref, orig, n * sizeof *ref);
        qsort(ref, n, sizeof *ref, full_cmp);
        for (size_t i = 0; i < n; i++)
            ir[i] = orig[i].key[0] * 1000003 + orig[i].key[1];
        memcpy(ia, ir, n * sizeof *ia);
        qsort(ir, n, sizeof *ir, i64_cmp);
        for (int t = 1; t <= 5; t++) {
            vm_set_threads(t);
            /* a total order: the very same array */
            memcpy(a, orig, n * sizeof *a);
            CHECK(vm__psort(a, n, sizeof *a, full_cmp) == 1);
            CHECK_MSG(n == 0 || memcmp(a, ref, n * sizeof *a) == 0, "n %zu, %d threads", n, t);
            /* keys only: the same keys in order, every payload once */
            memcpy(a, orig, n * sizeof *a);
            CHECK(vm__psort(a, n, sizeof *a, key_cmp) == 1);
            int same = 1;
            for (size_t i = 0; i < n && same; i++)
                same = key_cmp(&a[i], &ref[i]) == 0;
            CHECK_MSG(same, "keys out of order: n %zu, %d threads", n, t);
            uint8_t *seen = calloc(n + 1, 1);
            CHECK(seen != NULL);
            size_t once = 0;
            for (size_t i = 0; seen && i < n; i++)
                if (a[i].payload < n && !seen[a[i].payload]) seen[a[i].payload] = 1, once++;
            CHECK_MSG(once == n, "n %zu, %d threads: %zu of the elements kept", n, t, once);
            free(seen);
            /* plain integers */
            int64_t *b = malloc((n + 1) * sizeof *b);
            CHECK(b != NULL);
            if (b) {
                memcpy(b, ia, n * sizeof *b);
                CHECK(vm__psort(b, n, sizeof *b, i64_cmp) == 1);
                CHECK_MSG(n == 0 || memcmp(b, ir, n * sizeof *b) == 0,
                          "int64: n %zu, %d threads", n, t);
                free(b);
            }
        }
        free(orig);
        free(ref);
        free(a);
        free(ia);
        free(ir);
    }
    vm_set_threads(before);
}

TEST_MAIN(T(sortsAsQsortOnAnyThreadCount))
