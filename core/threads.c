/* SPDX-License-Identifier: BSD-3-Clause */
/* core/threads.c — how many threads the parallel stages use (OpenMP when built with it). */
#include "volmesh/volmesh.h"
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
