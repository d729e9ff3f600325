/* SPDX-License-Identifier: BSD-3-Clause */
/* core/ring.c — the best triangulation of the ring polygon of an edge removal (Shewchuk
 * 2002, "Two discrete optimization algorithms for the topological improvement of
 * tetrahedral meshes"), by Klincsek's dynamic programme over the polygon's sub-chains: what
 * the quality pass (improve/improve_flip.c) and the graded mesher's coarsening
 * (mesher/graded_coarsen.c) share. */
#include "core.h"
#include <math.h>

double vm__ring_triangulate(int np, double floor, vm__ring_grade_fn grade, void *user,
                            vm__ring_chord_fn chord, int (*tri)[3]) {
    if (np < 3 || np > VM__RING_MAX) return -INFINITY;
    /* best[i][j]: the best worst grade over the chain i..j closed by the chord ij; cut[i][j]
     * its apex (-1: none above the floor) */
    double best[VM__RING_MAX][VM__RING_MAX];
    signed char cut[VM__RING_MAX][VM__RING_MAX];
    for (int len = 2; len < np; len++)
        for (int i = 0; i + len < np; i++) {
            int j = i + len;
            best[i][j] = -INFINITY;
            cut[i][j] = -1;
            /* the chord is asked for once a triangle on it could count */
            int asked = !chord || (i == 0 && j == np - 1);
            for (int k = i + 1; k < j; k++) {
                double m = INFINITY;
                if (k - i >= 2 && best[i][k] < m) m = best[i][k];
                if (j - k >= 2 && best[k][j] < m) m = best[k][j];
                if (m <= best[i][j] || m <= floor) continue;
                if (!asked) {
                    if (!chord(user, i, j)) break;
                    asked = 1;
                }
                /* (a grade at or below the floor is of no use: known as soon as that) */
                double g = grade(user, i, k, j, best[i][j] > floor ? best[i][j] : floor);
                if (g < m) m = g;
                if (m > best[i][j]) {
                    best[i][j] = m;
                    cut[i][j] = (signed char)k;
                }
            }
        }
    double q = best[0][np - 1];
    if (!(q > floor)) return -INFINITY;
    /* the triangles, chains taken last in first out from the whole polygon */
    int n = 0, stack[VM__RING_MAX][2], sp = 0;
    stack[sp][0] = 0;
    stack[sp][1] = np - 1;
    sp++;
    while (sp > 0) {
        sp--;
        int i = stack[sp][0], j = stack[sp][1], k = cut[i][j];
        if (k < 0) return -INFINITY;
        tri[n][0] = i;
        tri[n][1] = k;
        tri[n][2] = j;
        n++;
        if (k - i >= 2) {
            stack[sp][0] = i;
            stack[sp][1] = k;
            sp++;
        }
        if (j - k >= 2) {
            stack[sp][0] = k;
            stack[sp][1] = j;
            sp++;
        }
    }
    return q;
}
