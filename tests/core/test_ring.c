/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/core/test_ring.c — vm__ring_triangulate (core/ring.c), the dynamic programme behind
 * edge removal in the quality pass and in the graded mesher's coarsening: on polygons of 3 to
 * 9 vertices with pseudo-random triangle grades and chord masks, it finds the best worst grade
 * that trying every triangulation finds, returns triangles that triangulate the polygon with
 * allowed chords only and that worst grade, refuses when nothing beats the floor, and gives
 * the same answer when the grade function cuts its work short at the bar; it asks for each
 * chord at most once, never for a polygon side. */
#include "core/core.h"
#include "test.h"
#include <math.h>
#include <string.h>

typedef struct grades {
    double g[VM__RING_MAX][VM__RING_MAX][VM__RING_MAX];
    int lazy; /* return a value at or below bar once the grade is at most bar */
    size_t calls;
    const unsigned char (*chord)[VM__RING_MAX]; /* the chords allowed */
    int asked[VM__RING_MAX][VM__RING_MAX];      /* how often each chord was asked for */
} grades;

static int chord_allowed(void *user, int i, int j) {
    grades *G = user;
    G->asked[i][j]++;
    return G->chord[i][j];
}

static double grade(void *user, int i, int k, int j, double bar) {
    grades *G = user;
    G->calls++;
    double g = G->g[i][k][j];
    return G->lazy && g <= bar ? bar - 1000.0 : g;
}

/* The best worst grade over every triangulation of the chain i..j (closed by chord ij). */
static double brute(const grades *G, const unsigned char (*chord)[VM__RING_MAX], int np, int i,
                    int j) {
    if (j - i < 2) return INFINITY;
    if (chord && (i != 0 || j != np - 1) && !chord[i][j]) return -INFINITY;
    double best = -INFINITY;
    for (int k = i + 1; k < j; k++) {
        double m =
            fmin(G->g[i][k][j], fmin(brute(G, chord, np, i, k), brute(G, chord, np, k, j)));
        if (m > best) best = m;
    }
    return best;
}

static void findsTheBestWorstTriangulation(void) {
    unsigned rng = 2024u;
    size_t cases = 0, refused = 0;
    for (int np = 3; np <= VM__RING_MAX; np++)
        for (int rep = 0; rep < 40; rep++) {
            static grades G;
            memset(&G, 0, sizeof G);
            for (int i = 0; i < np; i++)
                for (int k = i + 1; k < np; k++)
                    for (int j = k + 1; j < np; j++) {
                        rng = rng * 1103515245u + 12345u;
                        G.g[i][k][j] = (double)(rng >> 8) / (double)(1u << 24);
                    }
            unsigned char chord[VM__RING_MAX][VM__RING_MAX];
            memset(chord, 1, sizeof chord);
            int masked = rep % 2;
            if (masked)
                for (int i = 0; i < np; i++)
                    for (int j = i + 2; j < np; j++) {
                        rng = rng * 1103515245u + 12345u;
                        chord[i][j] = (rng >> 16) % 4 != 0;
                    }
            const unsigned char(*cm)[VM__RING_MAX] =
                masked ? (const unsigned char(*)[VM__RING_MAX])chord : NULL;
            double floor = rep % 5 == 4 ? 0.5 : -1.0;
            double want = brute(&G, cm, np, 0, np - 1);
            for (int lazy = 0; lazy < 2; lazy++) {
                G.lazy = lazy;
                G.chord = cm;
                memset(G.asked, 0, sizeof G.asked);
                int tri[VM__RING_MAX][3];
                double got =
                    vm__ring_triangulate(np, floor, grade, &G, cm ? chord_allowed : NULL, tri);
                cases++;
                for (int i = 0; i < np; i++)
                    for (int j = i + 1; j < np; j++)
                        CHECK(G.asked[i][j] <= (j == i + 1 || (i == 0 && j == np - 1) ? 0 : 1));
                if (!(want > floor)) {
                    CHECK_MSG(got == -INFINITY, "np %d: %g beats no floor %g", np, got, floor);
                    refused++;
                    continue;
                }
                CHECK_MSG(got == want, "np %d rep %d lazy %d: %g, trying all: %g", np, rep,
                          lazy, got, want);
                /* np - 2 triangles, the first on the whole polygon, each chord allowed, every
                 * polygon side in one triangle and every chord in two */
                CHECK(tri[0][0] == 0 && tri[0][2] == np - 1);
                int use[VM__RING_MAX][VM__RING_MAX];
                memset(use, 0, sizeof use);
                double worst = INFINITY;
                for (int r = 0; r < np - 2; r++) {
                    int i = tri[r][0], k = tri[r][1], j = tri[r][2];
                    CHECK(0 <= i && i < k && k < j && j < np);
                    worst = fmin(worst, G.g[i][k][j]);
                    use[i][k]++;
                    use[k][j]++;
                    use[i][j]++;
                }
                CHECK(worst == got);
                for (int i = 0; i < np; i++)
                    for (int j = i + 1; j < np; j++) {
                        int side = j == i + 1 || (i == 0 && j == np - 1);
                        CHECK(use[i][j] == (side ? 1 : use[i][j] ? 2 : 0));
                        if (!side && use[i][j]) CHECK(!cm || cm[i][j]);
                    }
            }
        }
    printf("    %zu polygons of 3..%d vertices, %zu refused\n", cases, VM__RING_MAX, refused);
    CHECK(refused > 0 && refused < cases);
    int tri[VM__RING_MAX][3];
    grades G0;
    memset(&G0, 0, sizeof G0);
    CHECK(vm__ring_triangulate(2, -1.0, grade, &G0, NULL, tri) == -INFINITY);
    CHECK(vm__ring_triangulate(VM__RING_MAX + 1, -1.0, grade, &G0, NULL, tri) == -INFINITY);
}

TEST_MAIN(T(findsTheBestWorstTriangulation))
