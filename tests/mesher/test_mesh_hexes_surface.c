/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_hexes_surface.c — where the hexahedral mesher puts the boundary: the
 * distance of each boundary point (off the volume's box) from the trilinear isosurface, on
 * the MR head and on a noisy sphere, measured by brute force (the nearest point of a
 * 0.1-voxel grid where the field crosses the isovalue). */
#include "test.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Bounds, from the measured figures (before the mesher pulled only the points of the corners
 * that are not valid and the QEF outliers toward their mass points: MR head 797 points over
 * 0.5 voxel off, noisy sphere 80; after: 248 and 16, worst 1.31 and 0.82). A vertex in a
 * cell the surface crosses is within 1.73 voxels of it. Since the repair for hexes keeps
 * the air passages by taking inside points out too (mesher/dual_contour.c: MR head boundary
 * Euler 472 -> 246, tets 230; 208 -> 210 components, as the tets), 113 such points, whose
 * cells' vertices sit off the isosurface like those of the points it takes in: 447 over
 * 0.5 voxel, the worst still 1.31; with its two-flip detour (2026-12-07) 466, the worst
 * 1.31 (1.49 when the detour took the first pair it found, not the one nearest the bound). */
#define MR_WORST 1.4
#define MR_OVER 480
#define SPHERE_WORST 0.9
#define SPHERE_OVER 30

/* Trilinear value of v at index position x (clamped to the box). */
static double trilinear(const vm_volume *v, const double x[3]) {
    int64_t i0[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double c = fmin(fmax(x[a], 0.0), (double)(v->dims[a] - 1));
        int64_t i = (int64_t)floor(c);
        if (i > v->dims[a] - 2) i = v->dims[a] - 2;
        i0[a] = i;
        f[a] = c - (double)i;
    }
    double s = 0.0;
    for (int c = 0; c < 8; c++) {
        int o[3] = {c & 1, (c >> 1) & 1, c >> 2};
        double w =
            (o[0] ? f[0] : 1 - f[0]) * (o[1] ? f[1] : 1 - f[1]) * (o[2] ? f[2] : 1 - f[2]);
        s += w * v->data[(i0[0] + o[0]) +
                         v->dims[0] * ((i0[1] + o[1]) + v->dims[1] * (i0[2] + o[2]))];
    }
    return s;
}

/* Distance (voxels) from index position y to the nearest point, within radius R, of the
 * 0.1-voxel lattice (which holds the grid points: a material of single grid points on the
 * isovalue is met) where f - iso has the other sign or is 0; R + 1 when there is none. */
static double crossing_distance(const vm_volume *v, double iso, const double y[3], double R) {
    double f0 = trilinear(v, y) - iso, best = R + 1, base[3];
    if (f0 == 0.0) return 0.0;
    for (int a = 0; a < 3; a++)
        base[a] = 0.1 * floor(10.0 * y[a] + 0.5);
    int n = (int)(R * 10 + 1.5);
    for (int k = -n; k <= n; k++)
        for (int j = -n; j <= n; j++)
            for (int i = -n; i <= n; i++) {
                double z[3] = {base[0] + 0.1 * i, base[1] + 0.1 * j, base[2] + 0.1 * k};
                double d = sqrt((z[0] - y[0]) * (z[0] - y[0]) + (z[1] - y[1]) * (z[1] - y[1]) +
                                (z[2] - y[2]) * (z[2] - y[2]));
                if (d >= best || d > R) continue;
                int out = 0;
                for (int a = 0; a < 3; a++)
                    out |= z[a] < 0 || z[a] > (double)(v->dims[a] - 1);
                if (!out && (trilinear(v, z) - iso) * f0 <= 0.0) best = d;
            }
    return best;
}

static int cmp_quad(const void *a, const void *b) {
    const vm_index *x = a, *y = b;
    for (int k = 0; k < 4; k++)
        if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
    return 0;
}

/* Marks the points of m's boundary quads (the faces used by one hex). [out] on: npoints flags.
 */
static void boundary_points(const vm_mesh *m, unsigned char *on) {
    static const int ft[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                 {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    size_t nf = 6 * m->ncells;
    vm_index *q = malloc((4 * nf + 1) * sizeof *q);
    CHECK(q != NULL);
    if (!q) return;
    for (size_t u = 0; u < nf; u++) {
        vm_index *k = q + 4 * u;
        for (int j = 0; j < 4; j++)
            k[j] = m->cells[8 * (u / 6) + (size_t)ft[u % 6][j]];
        for (int a = 1; a < 4; a++)
            for (int c = a; c > 0 && k[c - 1] > k[c]; c--) {
                vm_index t = k[c];
                k[c] = k[c - 1];
                k[c - 1] = t;
            }
    }
    qsort(q, nf, 4 * sizeof *q, cmp_quad);
    memset(on, 0, m->npoints);
    for (size_t u = 0; u < nf;) {
        size_t e = u + 1;
        while (e < nf && cmp_quad(q + 4 * u, q + 4 * e) == 0)
            e++;
        if (e - u == 1)
            for (int j = 0; j < 4; j++)
                on[q[4 * u + (size_t)j]] = 1;
        u = e;
    }
    free(q);
}

/* Meshes v in hexes at iso (no quality pass) and measures its boundary points off the box:
 * [out] *n of them, *over more than 0.5 voxel off, *worst distance. */
static void measure_offset(const vm_volume *v, double iso, size_t *n, size_t *over,
                           double *worst) {
    vm_error err;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.lo = iso;
    vm_mesh m;
    *n = *over = 0;
    *worst = 0.0;
    vm_status s = vm_mesh_volume(v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s) return;
    unsigned char *on = malloc(m.npoints + 1);
    CHECK(on != NULL);
    if (on) boundary_points(&m, on);
    for (size_t i = 0; on && i < m.npoints; i++) {
        if (!on[i]) continue;
        double y[3]; /* the test volumes have identity direction */
        int box = 0;
        for (int a = 0; a < 3; a++) {
            y[a] = (m.points[3 * i + (size_t)a] - v->origin[a]) / v->spacing[a];
            box |= fabs(y[a]) < 1e-6 || fabs(y[a] - (double)(v->dims[a] - 1)) < 1e-6;
        }
        if (box) continue;
        (*n)++;
        double d = crossing_distance(v, iso, y, 0.5); /* most are near: a small search */
        if (d > 0.5) d = crossing_distance(v, iso, y, 2.5);
        if (d > 0.5) (*over)++;
        if (d > *worst) *worst = d;
    }
    free(on);
    vm_mesh_free(&m);
}

/* The MR head at 50: what stays over 0.5 voxel off is relaxation toward cell centres (to
 * keep the hexes valid) and points round the grid points the repair took in. */
static void hexBoundaryOfTheMRHeadStaysNearTheIsosurface(void) {
    const char *path = vm_test_shared("HeadMRVolume.mhd");
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    size_t n, over;
    double worst;
    measure_offset(&v, 50, &n, &over, &worst);
    printf("  MR head iso 50: %zu boundary points, %zu over 0.5 voxel off, worst %.2f\n", n,
           over, worst);
    CHECK(n > 20000);
    CHECK_MSG(worst <= MR_WORST, "worst %.2f voxel off", worst);
    CHECK_MSG(over <= MR_OVER, "%zu points over 0.5 voxel off", over);
    vm_volume_free(&v);
}

/* A sphere of radius ~13 voxels with Gaussian noise (0.3 voxel) on its signed field. */
static void hexBoundaryOfANoisySphereStaysNearTheIsosurface(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 32, 0.3, 7, &v, NULL, &err), &err);
    size_t n, over;
    double worst;
    measure_offset(&v, 0.0, &n, &over, &worst);
    printf("  noisy sphere 32^3: %zu boundary points, %zu over 0.5 voxel off, worst %.2f\n", n,
           over, worst);
    CHECK(n > 1000);
    CHECK_MSG(worst <= SPHERE_WORST, "worst %.2f voxel off", worst);
    CHECK_MSG(over <= SPHERE_OVER, "%zu points over 0.5 voxel off", over);
    vm_volume_free(&v);
}

TEST_MAIN(T(hexBoundaryOfTheMRHeadStaysNearTheIsosurface),
          T(hexBoundaryOfANoisySphereStaysNearTheIsosurface))
