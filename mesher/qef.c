/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/qef.c — the QEF minimiser of dual contouring (Ju et al., "Dual contouring of
 * Hermite data", SIGGRAPH 2002, §2.3), solved by a symmetric eigen-decomposition with
 * truncated small eigenvalues around the mass point, as LBIE (seed 001, §4) uses it. */
#include "qef.h"
#include <math.h>
#include <string.h>

void vm__qef_init(vm_qef *q) { memset(q, 0, sizeof *q); }

void vm__qef_add(vm_qef *q, const double p[3], const double n[3]) {
    double d = n[0] * p[0] + n[1] * p[1] + n[2] * p[2];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) q->ata[r][c] += n[r] * n[c];
        q->atb[r] += n[r] * d;
        q->mass[r] += p[r];
    }
    q->count++;
}

/* Jacobi sweeps at most (a 3x3 converges in a handful); the rotations stop when the
 * off-diagonal sum is below jacobi_done, and skip an entry below jacobi_tiny, whose angle
 * would overflow (both far below any QEF entry: squared normals of unit order). */
enum { JACOBI_SWEEPS = 32 };
static const double jacobi_done = 1e-30, jacobi_tiny = 1e-300;

/* Cyclic Jacobi rotations: a = V diag(w) V^T for a symmetric 3x3 a. */
static void jacobi3(double a[3][3], double w[3], double v[3][3]) {
    memset(v, 0, 9 * sizeof(double));
    for (int i = 0; i < 3; i++) v[i][i] = 1.0;
    for (int sweep = 0; sweep < JACOBI_SWEEPS; sweep++) {
        double off = fabs(a[0][1]) + fabs(a[0][2]) + fabs(a[1][2]);
        if (off < jacobi_done) break;
        for (int p = 0; p < 2; p++)
            for (int r = p + 1; r < 3; r++) {
                if (fabs(a[p][r]) < jacobi_tiny) continue;
                double theta = (a[r][r] - a[p][p]) / (2.0 * a[p][r]);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; k++) { /* columns p, r */
                    double akp = a[k][p], akr = a[k][r];
                    a[k][p] = c * akp - s * akr;
                    a[k][r] = s * akp + c * akr;
                }
                for (int k = 0; k < 3; k++) { /* rows p, r */
                    double apk = a[p][k], ark = a[r][k];
                    a[p][k] = c * apk - s * ark;
                    a[r][k] = s * apk + c * ark;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = v[k][p], vkr = v[k][r];
                    v[k][p] = c * vkp - s * vkr;
                    v[k][r] = s * vkp + c * vkr;
                }
            }
    }
    for (int i = 0; i < 3; i++) w[i] = a[i][i];
}

void vm__qef_solve(const vm_qef *q, double rel_cutoff, const int fixed[3],
                   const double fixval[3], double x[3], double mass[3]) {
    double m[3];
    for (int r = 0; r < 3; r++) m[r] = fixed[r] ? fixval[r] : q->mass[r] / q->count;
    /* Pinned coordinates are removed from the system: rows/columns of A become zero and
     * the right-hand side loses their contribution. */
    double a[3][3], b[3];
    for (int r = 0; r < 3; r++) {
        b[r] = q->atb[r];
        for (int c = 0; c < 3; c++) {
            a[r][c] = q->ata[r][c];
            b[r] -= q->ata[r][c] * m[c];
        }
    }
    for (int k = 0; k < 3; k++)
        if (fixed[k])
            for (int j = 0; j < 3; j++) a[k][j] = a[j][k] = b[k] = 0.0;
    double w[3], v[3][3];
    jacobi3(a, w, v);
    double wmax = fmax(fabs(w[0]), fmax(fabs(w[1]), fabs(w[2])));
    double d[3] = {0, 0, 0};
    if (wmax > 0) {
        for (int e = 0; e < 3; e++) {
            if (fabs(w[e]) < rel_cutoff * wmax) continue;
            double proj = v[0][e] * b[0] + v[1][e] * b[1] + v[2][e] * b[2];
            for (int r = 0; r < 3; r++) d[r] += v[r][e] * proj / w[e];
        }
    }
    for (int r = 0; r < 3; r++) {
        x[r] = fixed[r] ? fixval[r] : m[r] + d[r];
        mass[r] = m[r];
    }
}
