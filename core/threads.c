/* SPDX-License-Identifier: BSD-3-Clause */
/* core/threads.c — how many threads the parallel stages use (OpenMP when built with it),
 * and a sort on them. */
#include "core.h"
#include "volmesh/volmesh.h"
#include <stdlib.h>
#include <string.h>
#ifdef VM_HAVE_OPENMP
#include <omp.h>
#endif

int vm_set_threads(int n) {
#ifdef VM_HAVE_OPENMP
    int before = omp_get_max_threads();
    if (n <= 0) n = omp_get_num_procs();
    omp_set_num_threads(n);
    return before;
#else
    (void)n;
    return 1;
#endif
}

int vm_threads(void) {
#ifdef VM_HAVE_OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

/* Merges the sorted runs a[0..na) and b[0..nb) into out, a's element first on ties. */
static void merge_runs(const char *a, size_t na, const char *b, size_t nb, char *out,
                       size_t size, int (*cmp)(const void *, const void *)) {
    size_t i = 0, j = 0;
    while (i < na && j < nb) {
        if (cmp(b + j * size, a + i * size) < 0) {
            memcpy(out, b + j * size, size);
            j++;
        } else {
            memcpy(out, a + i * size, size);
            i++;
        }
        out += size;
    }
    memcpy(out, a + i * size, (na - i) * size);
    out += (na - i) * size;
    memcpy(out, b + j * size, (nb - j) * size);
}

/* How many of the first k elements of the merge of a[0..na) and b[0..nb) (a's first on
 * ties) come from a: the merge path's split, by bisection. */
static size_t merge_split(const char *a, size_t na, const char *b, size_t nb, size_t k,
                          size_t size, int (*cmp)(const void *, const void *)) {
    size_t lo = k > nb ? k - nb : 0, hi = k < na ? k : na;
    while (lo < hi) {
        size_t i = lo + (hi - lo) / 2; /* (k - i >= 1: i < hi <= k) */
        if (cmp(a + i * size, b + (k - i - 1) * size) <= 0)
            lo = i + 1; /* a[i] comes before b[k - i - 1]: among the first k */
        else
            hi = i;
    }
    return lo;
}

int vm__psort(void *base, size_t n, size_t size, int (*cmp)(const void *, const void *)) {
    enum { RUNS = 16, SMALL = 1 << 15 };
    int nthreads = vm_threads();
    size_t runs = nthreads < RUNS ? (size_t)nthreads : RUNS;
    while (runs > 1 && n / runs < SMALL)
        runs /= 2;
    char *tmp = runs > 1 ? malloc(n * size) : NULL;
    if (!tmp) { /* one run, or no room for the merge: the library's sort */
        if (n > 1) qsort(base, n, size, cmp);
        return runs <= 1;
    }
    /* run k is [k n / runs, (k + 1) n / runs): sorted on the threads, then merged pairwise
     * (a level's merges on the threads too) */
    size_t at[RUNS + 1];
    for (size_t k = 0; k <= runs; k++)
        at[k] = k * n / runs;
    char *src = base, *dst = tmp;
    const ptrdiff_t pr = (ptrdiff_t)runs;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (ptrdiff_t k = 0; k < pr; k++)
        qsort(src + at[k] * size, at[k + 1] - at[k], size, cmp);
    for (size_t width = 1; width < runs; width *= 2) {
        /* each pair of runs merged in `pieces` parts of its output (split on the merge path),
         * so that the last levels, with fewer pairs than threads, keep the threads busy */
        size_t npair = (runs + 2 * width - 1) / (2 * width);
        size_t pieces = (size_t)nthreads / npair < 1 ? 1 : (size_t)nthreads / npair;
        if (pieces > RUNS) pieces = RUNS;
        const ptrdiff_t nw = (ptrdiff_t)(npair * pieces);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (ptrdiff_t w = 0; w < nw; w++) {
            size_t p = (size_t)w / pieces, q = (size_t)w % pieces;
            size_t lo = p * 2 * width, mid = lo + width, hi = mid + width;
            if (mid > runs) mid = runs;
            if (hi > runs) hi = runs;
            const char *a = src + at[lo] * size, *b = src + at[mid] * size;
            size_t na = at[mid] - at[lo], nb = at[hi] - at[mid];
            size_t k0 = q * (na + nb) / pieces, k1 = (q + 1) * (na + nb) / pieces;
            size_t i0 = merge_split(a, na, b, nb, k0, size, cmp);
            size_t i1 = merge_split(a, na, b, nb, k1, size, cmp);
            merge_runs(a + i0 * size, i1 - i0, b + (k0 - i0) * size, (k1 - i1) - (k0 - i0),
                       dst + (at[lo] + k0) * size, size, cmp);
        }
        char *q = src;
        src = dst;
        dst = q;
    }
    if (src != base) memcpy(base, src, n * size);
    free(tmp);
    return 1;
}

/* Items per block of vm__compact. */
#define COMPACT_BLOCK ((size_t)1 << 16)

/* Compacts items [a, b) within themselves; returns how many were kept. */
static size_t compact_block(size_t a, size_t b, int (*keep)(size_t, void *),
                            void (*move)(size_t, size_t, size_t, void *), void *user) {
    size_t c = a;
    for (size_t i = a; i < b; i++) {
        if (!keep(i, user)) continue;
        if (c != i) move(c, i, 1, user);
        c++;
    }
    return c - a;
}

size_t vm__compact(size_t n, int (*keep)(size_t i, void *user),
                   void (*move)(size_t to, size_t from, size_t count, void *user), void *user) {
    size_t nb = (n + COMPACT_BLOCK - 1) / COMPACT_BLOCK;
    size_t *cnt = nb > 1 && vm_threads() > 1 ? malloc(nb * sizeof *cnt) : NULL;
    if (!cnt) return compact_block(0, n, keep, move, user);
    const ptrdiff_t pnb = (ptrdiff_t)nb;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (ptrdiff_t b = 0; b < pnb; b++) {
        size_t a = (size_t)b * COMPACT_BLOCK, e = a + COMPACT_BLOCK < n ? a + COMPACT_BLOCK : n;
        cnt[b] = compact_block(a, e, keep, move, user);
    }
    size_t kept = 0;
    for (size_t b = 0; b < nb; b++) {
        size_t a = b * COMPACT_BLOCK;
        if (kept != a && cnt[b]) move(kept, a, cnt[b], user);
        kept += cnt[b];
    }
    free(cnt);
    return kept;
}
