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
        const ptrdiff_t np = (ptrdiff_t)((runs + 2 * width - 1) / (2 * width));
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (ptrdiff_t p = 0; p < np; p++) {
            size_t lo = (size_t)p * 2 * width, mid = lo + width, hi = mid + width;
            if (mid > runs) mid = runs;
            if (hi > runs) hi = runs;
            merge_runs(src + at[lo] * size, at[mid] - at[lo], src + at[mid] * size,
                       at[hi] - at[mid], dst + at[lo] * size, size, cmp);
        }
        char *q = src;
        src = dst;
        dst = q;
    }
    if (src != base) memcpy(base, src, n * size);
    free(tmp);
    return 1;
}
