/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_surface_distance.c — vm_mesh_surface_distance both ways: exact answers
 * on a plane, meshed phantoms within half a voxel, moved and scaled meshes, a missing
 * component, world frames, thread-count independence and the points over a limit. */
#include "test.h"
#include "quality/quality_internal.h"
#include <string.h>

static int verbose_numbers(void) { return getenv("VM_TEST_VERBOSE") != NULL; }

static void print_distance(const char *what, const vm_surface_distance *d) {
    printf("    %s: mesh->surface max %.4f mean %.4f, surface->mesh max %.4f mean %.4f, "
           "hausdorff %.4f (%zu + %zu samples)\n",
           what, d->mesh_to_surface_max, d->mesh_to_surface_mean, d->surface_to_mesh_max,
           d->surface_to_mesh_mean, d->hausdorff, d->mesh_samples, d->surface_samples);
}

/* An n^3 volume whose field is f = x (index units): the isosurface of f >= iso is the
 * plane x = iso. */
static void ramp_volume(vm_volume *v, int n) {
    int64_t dims[3] = {n, n, n};
    CHECK_OK(vm_volume_alloc(v, dims, NULL), NULL);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) v->data[i + n * (j + n * k)] = (float)i;
}

/* Two triangles: the square x = x0 over y, z in [a, b]. */
static void square_mesh(vm_mesh *m, double x0, double a, double b) {
    vm_mesh_init(m, VM_TRI3);
    const double p[4][3] = {{x0, a, a}, {x0, b, a}, {x0, b, b}, {x0, a, b}};
    for (int i = 0; i < 4; i++) vm_mesh_add_point(m, p[i], NULL);
    const vm_index t[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int i = 0; i < 2; i++) CHECK_OK(vm_mesh_add_cell(m, t[i], 0, NULL), NULL);
}

static void planeAtKnownOffsetGivesThatDistanceBothWays(void) {
    vm_volume v;
    ramp_volume(&v, 9);
    vm_mesh m;
    square_mesh(&m, 4.0, 0.0, 8.0);
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 0.7, 1e-6);
    /* the square's sides lie on the box planes y, z = 0 and 8, in the material's sections
     * there (the flat faces that close it): their samples are at 0 */
    CHECK(d.mesh_to_surface_mean > 0.5 && d.mesh_to_surface_mean < 0.7);
    CHECK_NEAR(d.surface_to_mesh_max, 0.7, 1e-6);
    CHECK_NEAR(d.surface_to_mesh_mean, 0.7, 1e-6);
    CHECK_NEAR(d.hausdorff, 0.7, 1e-6);
    CHECK(d.mesh_samples >= 4 + 5 + 2);
    /* 9 x 9 voxel edges cross the plane, plus the finer lattice's */
    CHECK(d.surface_samples > 81);
    /* The upper bound: the plane x = 5.5 of f <= 5.5; spacing 2 doubles every distance. */
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 0, 5.5, 1, &d, &err), &err);
    CHECK_NEAR(d.hausdorff, 1.5, 1e-6);
    for (int a = 0; a < 3; a++) v.spacing[a] = 2.0;
    vm_mesh_free(&m);
    square_mesh(&m, 8.0, 0.0, 16.0);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 1.4, 1e-6);
    CHECK_NEAR(d.surface_to_mesh_max, 1.4, 1e-6);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void farMeshGivesTheExactOffsetAndBadInputIsRefused(void) {
    /* 50 voxels off: beyond the grid's rings, the hierarchy answers (on the side where no
     * material touches the box, so the isosurface is the nearest reference) */
    vm_volume v;
    ramp_volume(&v, 9);
    vm_mesh m;
    square_mesh(&m, -50.0, 0.0, 8.0);
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 53.3, 1e-6);
    CHECK_NEAR(d.mesh_to_surface_mean, 53.3, 1e-6);
    CHECK_NEAR(d.surface_to_mesh_max, 53.3, 1e-6);
    CHECK_NEAR(d.surface_to_mesh_mean, 53.3, 1e-6);
    /* the maxima's places: a point of the square, a point of the isosurface x = 3.3 */
    CHECK_NEAR(d.mesh_to_surface_ijk[0], -50.0, 1e-9);
    CHECK_NEAR(d.surface_to_mesh_ijk[0], 3.3, 1e-9);
    /* beyond the plane x = 8, where the material meets the box: the flat face closing it
     * there is the nearest reference, 46 away; the isosurface is 50.7 away */
    vm_mesh_free(&m);
    square_mesh(&m, 54.0, 0.0, 8.0);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 46.0, 1e-6);
    CHECK_NEAR(d.surface_to_mesh_max, 50.7, 1e-6);
    m.points[0] = -50.0;
    /* non-finite coordinates and values are refused, with a message */
    m.points[0] = NAN;
    CHECK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "must be finite") != NULL); /* vm__check_nodes names it */
    m.points[0] = 54.0;
    v.data[7] = NAN;
    CHECK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err) == VM_ERR_FORMAT);
    CHECK(vm_mesh_surface_distance(&m, &v, 0, 0, 0, 0, &d, &err) == VM_ERR_ARG);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void facesOnTheVolumeBorderCountWithinTheSection(void) {
    vm_volume v;
    ramp_volume(&v, 9);
    vm_mesh m;
    square_mesh(&m, 3.3, 0.0, 8.0);
    /* a square on the border plane y = 0 (it closes material on the border) */
    const double p[4][3] = {{3.3, 0, 0}, {8, 0, 0}, {8, 0, 8}, {3.3, 0, 8}};
    vm_index base = (vm_index)m.npoints;
    for (int i = 0; i < 4; i++) vm_mesh_add_point(&m, p[i], NULL);
    const vm_index t[2][3] = {{base, base + 1, base + 2}, {base, base + 2, base + 3}};
    for (int i = 0; i < 2; i++) CHECK_OK(vm_mesh_add_cell(&m, t[i], 0, NULL), NULL);
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK(d.hausdorff < 1e-6);
    /* the flat face overreaching the section (x from 0, where f < 3.3): measured against
     * the isosurface there, 3.3 at x = 0 */
    m.points[3 * (size_t)base] = 0;
    m.points[3 * (size_t)(base + 3)] = 0;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 3.3, 1e-6);
    CHECK(d.surface_to_mesh_max < 1e-6);
    /* a face a hair off the plane, within the section, is as near as that hair */
    for (int i = 0; i < 4; i++)
        m.points[3 * (size_t)(base + (vm_index)i) + 1] = 0.01;
    m.points[3 * (size_t)base] = 3.3;
    m.points[3 * (size_t)(base + 3)] = 3.3;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK_NEAR(d.mesh_to_surface_max, 0.01, 1e-6);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Meshes the phantom with the default options; fills v and m. */
static void mesh_phantom(vm_phantom_kind kind, int n, vm_volume *v, vm_mesh *m) {
    vm_error err;
    CHECK_OK(vm_phantom_make(kind, n, 0, 1, v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    CHECK_OK(vm_mesh_volume(v, &o, m, NULL, &err), &err);
}

static void sphereMeshIsWithinHalfAVoxelBothWays(void) {
    vm_volume v;
    vm_mesh m;
    mesh_phantom(VM_PHANTOM_SPHERE, 64, &v, &m);
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    print_distance("sphere 64", &d);
    CHECK(d.mesh_to_surface_max <= 0.5);
    CHECK(d.surface_to_mesh_max <= 0.5);
    CHECK(d.mesh_to_surface_mean < 0.1);
    CHECK(d.surface_to_mesh_mean < 0.1);
    CHECK(d.hausdorff == fmax(d.mesh_to_surface_max, d.surface_to_mesh_max));
    CHECK(d.mesh_samples > 1000 && d.surface_samples > 1000);
    /* the report carries it, under the lookup keys */
    vm_quality_summary q;
    CHECK_OK(vm_quality_report(&m, &q, &err), &err);
    CHECK(!q.has_distance);
    CHECK_OK(vm_quality_add_distance(&q, &m, &v, 0, 1, 0, 0, &err), &err);
    CHECK(q.has_distance && memcmp(&q.distance, &d, sizeof d) == 0);
    double x;
    CHECK(vm_quality_lookup(&q, "hausdorff", &x) == VM_OK && x == d.hausdorff);
    CHECK(vm_quality_lookup(&q, "surface_to_mesh_mean", &x) == VM_OK &&
          x == d.surface_to_mesh_mean);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void hexMeshOfATorusIsWithinHalfAVoxel(void) {
    vm_error err;
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 48, 0, 1, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    vm_surface_distance d;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    print_distance("torus 48 hexes", &d);
    CHECK(d.hausdorff <= 0.75);
    CHECK(d.mesh_to_surface_mean < 0.25 && d.surface_to_mesh_mean < 0.25);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* x <- c + s (x - c) + t for every point. */
static void transform(vm_mesh *m, const double c[3], double s, const double t[3]) {
    for (size_t i = 0; i < m->npoints; i++)
        for (int a = 0; a < 3; a++) {
            double *x = &m->points[3 * i + (size_t)a];
            *x = c[a] + s * (*x - c[a]) + t[a];
        }
}

static void movedAndScaledMeshesGiveTheExpectedDistance(void) {
    vm_volume v;
    vm_mesh m;
    const int n = 48;
    mesh_phantom(VM_PHANTOM_SPHERE, n, &v, &m);
    vm_surface_distance d0, d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d0, &err), &err);
    double c[3] = {0.5 * (n - 1), 0.5 * (n - 1), 0.5 * (n - 1)}, r = 0.35 * (n - 1);
    /* moved by 3 along x: the poles on the x axis are 3 away, both ways */
    const double shift[3] = {3, 0, 0}, none[3] = {0, 0, 0};
    transform(&m, c, 1.0, shift);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    if (verbose_numbers()) print_distance("moved by 3", &d);
    CHECK(fabs(d.mesh_to_surface_max - 3) <= d0.hausdorff + 0.05);
    CHECK(fabs(d.surface_to_mesh_max - 3) <= d0.hausdorff + 0.05);
    transform(&m, c, 1.0, (const double[3]){-3, 0, 0});
    /* scaled by 1.2 about the centre: every point is 0.2 r away, both ways */
    transform(&m, c, 1.2, none);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    if (verbose_numbers()) print_distance("scaled by 1.2", &d);
    CHECK(fabs(d.mesh_to_surface_max - 0.2 * r) <= 1.2 * d0.hausdorff + 0.05);
    CHECK(fabs(d.mesh_to_surface_mean - 0.2 * r) <= 1.2 * d0.mesh_to_surface_mean + 0.05);
    CHECK(fabs(d.surface_to_mesh_mean - 0.2 * r) <= 1.2 * d0.surface_to_mesh_mean + 0.05);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void aMissingComponentShowsOnlyFromTheSurfaceSide(void) {
    vm_volume v;
    vm_mesh m;
    const int n = 48;
    mesh_phantom(VM_PHANTOM_TWO_SPHERES, n, &v, &m);
    vm_surface_distance d;
    vm_error err;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    CHECK(d.hausdorff <= 0.5);
    /* drop the tets of the sphere on the low side of the axis the two lie on */
    double c = 0.5 * (n - 1);
    int axis = -1;
    for (int a = 0; a < 3 && axis < 0; a++) {
        size_t low = 0;
        for (size_t i = 0; i < m.npoints; i++) low += m.points[3 * i + (size_t)a] < c - 2;
        if (low > m.npoints / 4 && low < 3 * m.npoints / 4) axis = a;
    }
    CHECK(axis >= 0);
    size_t kept = 0;
    for (size_t t = 0; t < m.ncells; t++) {
        double x = 0;
        for (int q = 0; q < 4; q++) x += m.points[3 * (size_t)m.cells[4 * t + (size_t)q] + (size_t)axis];
        if (x / 4 < c) continue;
        memmove(m.cells + 4 * kept, m.cells + 4 * t, 4 * sizeof(vm_index));
        m.region[kept++] = m.region[t];
    }
    CHECK(kept > 0 && kept < m.ncells);
    m.ncells = kept;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    print_distance("two spheres, one dropped", &d);
    CHECK(d.mesh_to_surface_max <= 0.5);
    /* the far side of the dropped sphere: 2 (off + r) from the kept one's near side */
    double gap = 2 * (0.25 + 0.2) * (n - 1) - 2 * 0.2 * (n - 1);
    CHECK(d.surface_to_mesh_max > gap - 1);
    CHECK(d.hausdorff == d.surface_to_mesh_max);
    /* the farthest isosurface point is on the far side of the dropped sphere, the farthest
     * boundary point on the kept one */
    CHECK_MSG(d.surface_to_mesh_ijk[axis] < c - gap / 2, "farthest isosurface point %g",
              d.surface_to_mesh_ijk[axis]);
    CHECK_MSG(d.mesh_to_surface_ijk[axis] > c - 2, "farthest boundary point %g",
              d.mesh_to_surface_ijk[axis]);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void worldFrameIsApplied(void) {
    vm_error err;
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 40, 0, 1, &v, NULL, &err), &err);
    /* anisotropic spacing, an origin, and a rotation by 90 degrees about z */
    v.spacing[0] = 0.5;
    v.spacing[1] = 0.8;
    v.spacing[2] = 1.5;
    v.origin[0] = 10;
    v.origin[1] = -3;
    v.origin[2] = 7;
    memset(v.direction, 0, sizeof v.direction);
    v.direction[0][1] = -1;
    v.direction[1][0] = 1;
    v.direction[2][2] = 1;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    vm_surface_distance d;
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &d, &err), &err);
    print_distance("sphere 40, spacing 0.5 0.8 1.5, rotated", &d);
    CHECK(d.hausdorff <= 0.5 * 1.5);
    CHECK(d.mesh_to_surface_mean < 0.1 && d.surface_to_mesh_mean < 0.1);
    /* where the maxima are: world = origin + direction (spacing ijk), within the volume */
    const double *at[2] = {d.mesh_to_surface_at, d.surface_to_mesh_at},
                 *ijk[2] = {d.mesh_to_surface_ijk, d.surface_to_mesh_ijk};
    for (int k = 0; k < 2; k++)
        for (int r = 0; r < 3; r++) {
            double x = v.origin[r];
            for (int a = 0; a < 3; a++)
                x += v.direction[r][a] * v.spacing[a] * ijk[k][a];
            CHECK_NEAR(at[k][r], x, 1e-9);
            CHECK(ijk[k][r] >= -0.5 && ijk[k][r] <= (double)v.dims[r] - 0.5);
        }
    /* the same mesh against the volume with identity frame is far off */
    vm_surface_distance d2;
    vm_volume w = v;
    memset(w.direction, 0, sizeof w.direction);
    for (int a = 0; a < 3; a++) w.direction[a][a] = 1;
    CHECK_OK(vm_mesh_surface_distance(&m, &w, 0, 1, 0, 0, &d2, &err), &err);
    CHECK(d2.hausdorff > 5);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void resultDoesNotDependOnThreads(void) {
    vm_volume v;
    vm_mesh m;
    mesh_phantom(VM_PHANTOM_GENUS3, 48, &v, &m);
    vm_surface_distance a, b;
    vm_error err;
    int before = vm_set_threads(1);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &a, &err), &err);
    vm_set_threads(4);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &b, &err), &err);
    vm_set_threads(before);
    print_distance("genus3 48", &a);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    /* moved 10 voxels: most queries go past the grid's rings to the hierarchy */
    const double c[3] = {0, 0, 0}, t[3] = {10, 0, 0};
    transform(&m, c, 1.0, t);
    vm_set_threads(1);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &a, &err), &err);
    vm_set_threads(4);
    CHECK_OK(vm_mesh_surface_distance(&m, &v, 0, 1, 0, 0, &b, &err), &err);
    vm_set_threads(before);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    CHECK(a.hausdorff > 9);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void pointsOverTheLimitAreReturned(void) {
    vm_volume v;
    ramp_volume(&v, 9);
    vm_mesh m;
    /* a square at x = 4 over y, z in [0, 4]: the plane x = 3.3 beyond z, y > 4 is far */
    square_mesh(&m, 4.0, 0.0, 4.0);
    vm_surface_distance d;
    vm_error err;
    double *pts = NULL;
    size_t np = 0;
    CHECK_OK(vm__surface_distance_points(&m, &v, 3.3, 1, 0, 0, 1.0, &d, &pts, &np, &err), &err);
    CHECK(np > 0);
    CHECK_NEAR(d.mesh_to_surface_max, 0.7, 1e-6);
    CHECK(d.surface_to_mesh_max > 4);
    /* every point returned is a surface point (x = 3.3) with y or z beyond 4 + 0.7 */
    for (size_t i = 0; i < np; i++) {
        CHECK_NEAR(pts[3 * i], 3.3, 1e-9);
        double y = pts[3 * i + 1], z = pts[3 * i + 2];
        CHECK(y > 4 || z > 4);
    }
    free(pts);
    /* a limit above everything: none */
    CHECK_OK(vm__surface_distance_points(&m, &v, 3.3, 1, 0, 0, 100.0, &d, &pts, &np, &err), &err);
    CHECK(np == 0 && pts == NULL);
    /* both sides empty of samples: zeros; a surface with no mesh: infinite */
    vm_mesh e;
    vm_mesh_init(&e, VM_TET4);
    CHECK_OK(vm_mesh_surface_distance(&e, &v, 3.3, 1, 0, 0, &d, &err), &err);
    CHECK(isinf(d.hausdorff) && isinf(d.surface_to_mesh_max));
    CHECK_OK(vm_mesh_surface_distance(&e, &v, 100, 1, 0, 0, &d, &err), &err);
    CHECK(d.hausdorff == 0);
    CHECK(vm_mesh_surface_distance(&m, &v, 5, 1, 4, 1, &d, &err) == VM_ERR_ARG);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* A measure within a region counts only the samples there: the far part of the plane
 * (y or z beyond the square) is left out by a mask of the blocks below 4 in y and z; a full
 * mask gives what no mask gives, an empty one counts nothing. */
static void aRegionCountsOnlyItsSamples(void) {
    vm_volume v;
    ramp_volume(&v, 9);
    vm_mesh m;
    square_mesh(&m, 4.0, 0.0, 4.0);
    vm_surface_distance all, d;
    vm_error err;
    double *pts = NULL;
    size_t np = 0;
    unsigned char mask[27];
    vm__sd_region r = {mask, {3, 3, 3}, 4};
    CHECK_OK(vm__surface_distance_points(&m, &v, 3.3, 1, 0, 0, 1.0, &all, NULL, NULL, &err),
             &err);
    memset(mask, 1, sizeof mask);
    CHECK_OK(vm__surface_distance_region(&m, &v, 3.3, 1, 0, 0, 1.0, 1, &r, NULL, &d, NULL, NULL,
                                         &err),
             &err);
    CHECK(memcmp(&all, &d, sizeof d) == 0);
    memset(mask, 0, sizeof mask);
    for (int x = 0; x < 3; x++)
        mask[x] = 1; /* y and z blocks 0: y, z in [0, 4) */
    CHECK_OK(vm__surface_distance_region(&m, &v, 3.3, 1, 0, 0, 1.0, 1, &r, NULL, &d, &pts, &np,
                                         &err),
             &err);
    CHECK(np == 0 && pts == NULL);
    CHECK(d.surface_samples > 0 && d.surface_samples < all.surface_samples);
    CHECK(d.mesh_samples > 0 && d.mesh_samples < all.mesh_samples);
    CHECK_NEAR(d.surface_to_mesh_max, 0.7, 1e-6);
    CHECK(all.surface_to_mesh_max > 4);
    memset(mask, 0, sizeof mask);
    CHECK_OK(vm__surface_distance_region(&m, &v, 3.3, 1, 0, 0, 1.0, 1, &r, NULL, &d, &pts, &np,
                                         &err),
             &err);
    CHECK(d.surface_samples == 0 && d.mesh_samples == 0 && np == 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"planeAtKnownOffsetGivesThatDistanceBothWays",
         planeAtKnownOffsetGivesThatDistanceBothWays},
        {"facesOnTheVolumeBorderCountWithinTheSection",
         facesOnTheVolumeBorderCountWithinTheSection},
        {"farMeshGivesTheExactOffsetAndBadInputIsRefused",
         farMeshGivesTheExactOffsetAndBadInputIsRefused},
        {"sphereMeshIsWithinHalfAVoxelBothWays", sphereMeshIsWithinHalfAVoxelBothWays},
        {"hexMeshOfATorusIsWithinHalfAVoxel", hexMeshOfATorusIsWithinHalfAVoxel},
        {"movedAndScaledMeshesGiveTheExpectedDistance",
         movedAndScaledMeshesGiveTheExpectedDistance},
        {"aMissingComponentShowsOnlyFromTheSurfaceSide",
         aMissingComponentShowsOnlyFromTheSurfaceSide},
        {"worldFrameIsApplied", worldFrameIsApplied},
        {"resultDoesNotDependOnThreads", resultDoesNotDependOnThreads},
        {"pointsOverTheLimitAreReturned", pointsOverTheLimitAreReturned},
        {"aRegionCountsOnlyItsSamples", aRegionCountsOnlyItsSamples},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
