/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/qef.h — quadratic error function of dual contouring (private). */
#ifndef VM_QEF_H
#define VM_QEF_H

/* Accumulated planes n·(x - p) = 0 and their mass point. */
typedef struct vm_qef {
    double ata[3][3]; /* sum n n^T */
    double atb[3];    /* sum n (n·p) */
    double mass[3];   /* sum p */
    int count;
} vm_qef;

void vm__qef_init(vm_qef *q);

/* Adds the plane through p with normal n (n need not be unit; zero n only adds the mass). */
void vm__qef_add(vm_qef *q, const double p[3], const double n[3]);

/* Minimiser nearest the mass point: x = m + pinv(A)(b - A m), where eigenvalues below
 * rel_cutoff * the largest are dropped (flat or cylindrical patches keep x near m).
 * fixed[a] != 0 pins coordinate a to fixval[a]. [out] x, [out] mass (the mass point with
 * pinned coordinates). count must be > 0. */
void vm__qef_solve(const vm_qef *q, double rel_cutoff, const int fixed[3],
                   const double fixval[3], double x[3], double mass[3]);

#endif
