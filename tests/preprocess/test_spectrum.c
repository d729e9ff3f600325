/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/preprocess/test_spectrum.c — the contour spectrum against analytic answers: sphere area,
 * volume and gradient integral for several radii and spacings, planes (exact), frames that
 * rotate the grid, component counts of the phantoms, CT head suggestions, bad input. */
#include "test.h"
#include <string.h>

#define PI 3.14159265358979323846

/* A volume of n^3 samples with the given spacing whose field is the world-space signed
 * distance to a sphere of radius r around centre c (world), positive inside. */
static int make_sphere(const int64_t dims[3], const double spacing[3], const double c[3],
                       double r, vm_volume *v) {
    vm_error err;
    if (vm_volume_alloc(v, dims, &err)) return -1;
    for (int a = 0; a < 3; a++) v->spacing[a] = spacing[a];
    size_t p = 0;
    for (int64_t k = 0; k < dims[2]; k++)
        for (int64_t j = 0; j < dims[1]; j++)
            for (int64_t i = 0; i < dims[0]; i++) {
                double x = i * spacing[0] - c[0], y = j * spacing[1] - c[1],
                       z = k * spacing[2] - c[2];
                v->data[p++] = (float)(r - sqrt(x * x + y * y + z * z));
            }
    return 0;
}

/* Spectrum over [-1, 1] with 201 isovalues, so that sample 100 is v = 0 exactly. */
static int spectrum_at_zero(const vm_volume *v, vm_spectrum *s, int *k0) {
    vm_error err;
    vm_status st = vm_spectrum_compute_range(v, 201, -1.0, 1.0, NULL, NULL, s, &err);
    CHECK_OK(st, &err);
    *k0 = 100;
    if (st) return -1;
    CHECK(fabs(s->isovalue[100]) < 1e-12);
    return 0;
}

static void sphereAreaAndVolumeAreWithinOnePercent(void) {
    static const struct {
        double r;
        double spacing[3];
    } cases[] = {
        {8.0, {1, 1, 1}},     {12.5, {1, 1, 1}},  {20.0, {1, 1, 1}},
        {10.0, {0.5, 0.5, 0.5}}, {15.0, {1, 1, 2}}, {9.0, {0.7, 1.3, 1.0}},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        double r = cases[c].r;
        const double *h = cases[c].spacing;
        int64_t dims[3];
        double centre[3];
        for (int a = 0; a < 3; a++) {
            dims[a] = (int64_t)ceil(2.0 * r / h[a]) + 6;
            centre[a] = 0.5 * (dims[a] - 1) * h[a] + 0.137 * h[a]; /* off the grid points */
        }
        vm_volume v;
        if (make_sphere(dims, h, centre, r, &v)) {
            CHECK(!"allocation");
            return;
        }
        vm_spectrum s;
        int k0;
        if (spectrum_at_zero(&v, &s, &k0) == 0) {
            double area = 4.0 * PI * r * r, volume = 4.0 / 3.0 * PI * r * r * r;
            double ea = (s.area[k0] - area) / area, ev = (s.volume[k0] - volume) / volume;
            double eg = (s.gradient_integral[k0] - area) / area; /* |grad| = 1 for a distance */
            printf("    r %-5g spacing %g,%g,%g: area %+.3f%%, volume %+.3f%%, gradient integral "
                   "%+.3f%%\n",
                   r, h[0], h[1], h[2], 100 * ea, 100 * ev, 100 * eg);
            CHECK_MSG(fabs(ea) < 0.01, "area %.6g, expected %.6g", s.area[k0], area);
            CHECK_MSG(fabs(ev) < 0.01, "volume %.6g, expected %.6g", s.volume[k0], volume);
            CHECK_MSG(fabs(eg) < 0.02, "gradient integral %.6g, expected %.6g",
                      s.gradient_integral[k0], area);
            CHECK(s.components[k0] == 1);
        }
        vm_spectrum_free(&s);
        vm_volume_free(&v);
    }
}

/* f = 2 x on a box with anisotropic spacing: every level set is a plane, which the
 * piecewise-linear interpolant reproduces exactly. */
static void rampGivesExactPlaneAreasAndVolumes(void) {
    int64_t dims[3] = {11, 7, 5};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    v.spacing[0] = 0.5;
    v.spacing[1] = 2.0;
    v.spacing[2] = 3.0;
    for (int64_t k = 0; k < 5; k++)
        for (int64_t j = 0; j < 7; j++)
            for (int64_t i = 0; i < 11; i++) v.data[i + 11 * (j + 7 * k)] = (float)(2.0 * 0.5 * i);
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 41, &s, &err), &err);
    double len = 10 * 0.5, wy = 6 * 2.0, wz = 4 * 3.0;
    CHECK_NEAR(s.lo, 0.0, 0);
    CHECK_NEAR(s.hi, 10.0, 0);
    CHECK_NEAR(s.total_volume, len * wy * wz, 1e-9);
    for (int k = 1; k < s.n - 1; k++) {
        double x = s.isovalue[k] / 2.0;
        CHECK_NEAR(s.area[k], wy * wz, 1e-9 * wy * wz);
        CHECK_NEAR(s.volume[k], (len - x) * wy * wz, 1e-9 * len * wy * wz);
        CHECK_NEAR(s.gradient_integral[k], 2.0 * wy * wz, 1e-9 * wy * wz);
        CHECK(s.components[k] == 1);
    }
    CHECK_NEAR(s.volume[0], len * wy * wz, 1e-9);
    CHECK_NEAR(s.volume[s.n - 1], 0.0, 1e-9);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

/* A rotation in the direction matrix moves the geometry rigidly: nothing changes. */
static void rotatingTheFrameLeavesAreaAndVolumeUnchanged(void) {
    int64_t dims[3] = {30, 30, 30};
    double h[3] = {1, 1, 1.5}, c[3] = {14.6, 14.3, 22.0};
    vm_volume v;
    if (make_sphere(dims, h, c, 10.0, &v)) return;
    vm_spectrum a, b;
    vm_error err;
    CHECK_OK(vm_spectrum_compute(&v, 64, &a, &err), &err);
    double ang = 0.7, ca = cos(ang), sa = sin(ang);
    double rot[3][3] = {{ca, -sa, 0}, {sa * 0.6, ca * 0.6, -0.8}, {sa * 0.8, ca * 0.8, 0.6}};
    memcpy(v.direction, rot, sizeof rot);
    v.origin[0] = 100;
    CHECK_OK(vm_spectrum_compute(&v, 64, &b, &err), &err);
    for (int k = 0; k < 64; k++) {
        CHECK_NEAR(b.area[k], a.area[k], 1e-9 * (1 + a.area[k]));
        CHECK_NEAR(b.volume[k], a.volume[k], 1e-9 * (1 + a.volume[k]));
        CHECK_NEAR(b.gradient_integral[k], a.gradient_integral[k],
                   1e-9 * (1 + a.gradient_integral[k]));
    }
    vm_spectrum_free(&a);
    vm_spectrum_free(&b);
    vm_volume_free(&v);
}

static void volumeNeverGrowsWithTheIsovalue(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_GENUS3, 40, 0.8, 3, &v, NULL, &err), &err);
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 300, &s, &err), &err);
    for (int k = 1; k < s.n; k++) CHECK(s.volume[k] <= s.volume[k - 1] + 1e-9 * s.volume[0]);
    for (int k = 0; k < s.n; k++) CHECK(s.area[k] >= 0 && s.volume[k] >= 0);
    CHECK_NEAR(s.volume[0], s.total_volume, 1e-9 * s.total_volume);
    CHECK_NEAR(s.total_volume, 39.0 * 39.0 * 39.0, 1e-6);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

/* Components of {f >= 0} for a phantom, from a spectrum whose middle sample is 0. */
static int64_t components_at_zero(vm_phantom_kind kind, int n) {
    vm_volume v;
    vm_error err;
    vm_status st = vm_phantom_make(kind, n, 0.0, 1, &v, NULL, &err);
    CHECK_OK(st, &err);
    if (st) return -1;
    vm_spectrum s;
    int k0;
    int64_t c = -1;
    if (spectrum_at_zero(&v, &s, &k0) == 0) c = s.components[k0];
    vm_spectrum_free(&s);
    vm_volume_free(&v);
    return c;
}

static void torusHasOneComponentAndTwoSpheresTwo(void) {
    CHECK(components_at_zero(VM_PHANTOM_TORUS, 48) == 1);
    CHECK(components_at_zero(VM_PHANTOM_TWO_SPHERES, 48) == 2);
    CHECK(components_at_zero(VM_PHANTOM_GENUS3, 48) == 1);
    CHECK(components_at_zero(VM_PHANTOM_SPHERE, 32) == 1);
}

/* Isolated peaks on a zero background: each is its own component until the threshold drops
 * to the background, checked against a direct count at every isovalue. */
static void componentCountsMatchADirectCount(void) {
    int64_t dims[3] = {9, 8, 7};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    unsigned long long st = 12345;
    size_t nv = vm_volume_count(&v);
    for (size_t p = 0; p < nv; p++) {
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        v.data[p] = (float)((st >> 40) % 10);
    }
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 19, &s, &err), &err);
    /* direct count by flood fill at each isovalue */
    int *label = malloc(nv * sizeof *label);
    size_t *stack = malloc(nv * sizeof *stack);
    for (int k = 0; k < s.n; k++) {
        for (size_t p = 0; p < nv; p++) label[p] = 0;
        int64_t count = 0;
        for (size_t p0 = 0; p0 < nv; p0++) {
            if (label[p0] || !(v.data[p0] >= s.isovalue[k])) continue;
            count++;
            size_t top = 0;
            stack[top++] = p0;
            label[p0] = 1;
            while (top) {
                size_t p = stack[--top];
                int64_t i = p % 9, j = (p / 9) % 8, kk = p / 72;
                int64_t nb[6][3] = {{i - 1, j, kk}, {i + 1, j, kk}, {i, j - 1, kk},
                                    {i, j + 1, kk}, {i, j, kk - 1}, {i, j, kk + 1}};
                for (int e = 0; e < 6; e++) {
                    if (nb[e][0] < 0 || nb[e][0] >= 9 || nb[e][1] < 0 || nb[e][1] >= 8 ||
                        nb[e][2] < 0 || nb[e][2] >= 7)
                        continue;
                    size_t q = (size_t)(nb[e][0] + 9 * (nb[e][1] + 8 * nb[e][2]));
                    if (!label[q] && v.data[q] >= s.isovalue[k]) {
                        label[q] = 1;
                        stack[top++] = q;
                    }
                }
            }
        }
        CHECK_MSG(s.components[k] == count, "isovalue %g: %lld components, direct count %lld",
                  s.isovalue[k], (long long)s.components[k], (long long)count);
    }
    free(label);
    free(stack);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

static void ctHeadSuggestionsIncludeSkinAndBone(void) {
    const char *path = vm_test_shared("ct_head_quarter.nrrd");
    if (!path) return;
    vm_volume v;
    vm_error err;
    vm_status st = vm_volume_read(path, &v, &err);
    CHECK_OK(st, &err);
    if (st) return;
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 256, &s, &err), &err);
    int skin = 0, bone = 0;
    printf("    %.3f s; suggestions:", s.seconds);
    for (int q = 0; q < s.n_suggestions; q++) {
        double iso = s.suggestions[q].isovalue;
        printf(" %.1f", iso);
        if (fabs(iso - 500) <= 150) skin = 1;
        if (fabs(iso - 1150) <= 250) bone = 1;
    }
    printf("\n");
    CHECK_MSG(skin, "no suggestion within 150 of the skin isovalue 500");
    CHECK_MSG(bone, "no suggestion within 250 of the bone isovalue 1150");
    CHECK(s.n_intervals == s.n_suggestions + 1);
    CHECK(s.intervals[0].lo == s.lo && s.intervals[s.n_intervals - 1].hi == s.hi);
    double sum = 0;
    for (int q = 0; q < s.n_intervals; q++) sum += s.intervals[q].volume;
    CHECK_NEAR(sum, s.total_volume, 1e-6 * s.total_volume);
    CHECK(s.seconds < 5.0);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

/* A blurred step between two materials: the boundary is suggested at the middle value. */
static void stepBetweenTwoMaterialsIsSuggestedAtItsMiddle(void) {
    int64_t dims[3] = {40, 40, 40};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    size_t p = 0;
    for (int k = 0; k < 40; k++)
        for (int j = 0; j < 40; j++)
            for (int i = 0; i < 40; i++) {
                double d = 13.3 - sqrt((i - 19.6) * (i - 19.6) + (j - 19.3) * (j - 19.3) +
                                       (k - 19.5) * (k - 19.5));
                v.data[p++] = (float)(100.0 + 200.0 / (1.0 + exp(-2.0 * d)));
            }
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 256, &s, &err), &err);
    CHECK(s.n_suggestions >= 1);
    double best = INFINITY;
    for (int q = 0; q < s.n_suggestions; q++)
        best = fmin(best, fabs(s.suggestions[q].isovalue - 200.0));
    CHECK_MSG(best < 20.0, "nearest suggestion is %g from the middle value 200", best);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

static void constantVolumeIsRefusedWithAClearMessage(void) {
    int64_t dims[3] = {5, 5, 5};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    for (size_t p = 0; p < 125; p++) v.data[p] = 7.0f;
    vm_spectrum s;
    vm_error_clear(&err);
    CHECK(vm_spectrum_compute(&v, 256, &s, &err) == VM_ERR_EMPTY);
    CHECK(strstr(err.message, "constant") != NULL);
    vm_spectrum_free(&s);
    CHECK(vm_spectrum_compute_range(&v, 16, 0, 10, NULL, NULL, &s, &err) == VM_ERR_EMPTY);
    vm_spectrum_free(&s);
    v.data[3] = 8.0f;
    CHECK(vm_spectrum_compute(&v, 1, &s, &err) == VM_ERR_ARG);
    vm_spectrum_free(&s);
    CHECK(vm_spectrum_compute_range(&v, 16, 5, 5, NULL, NULL, &s, &err) == VM_ERR_ARG);
    vm_spectrum_free(&s);
    CHECK_OK(vm_spectrum_compute(&v, 16, &s, &err), &err);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

static void nonfiniteSamplesAreSkipped(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 24, 0.0, 1, &v, NULL, &err), &err);
    v.data[0] = NAN;
    v.data[100] = INFINITY;
    vm_spectrum s;
    CHECK_OK(vm_spectrum_compute(&v, 32, &s, &err), &err);
    for (int k = 0; k < s.n; k++) CHECK(isfinite(s.area[k]) && isfinite(s.volume[k]));
    CHECK(s.total_volume < 23.0 * 23.0 * 23.0);
    vm_spectrum_free(&s);
    vm_volume_free(&v);
}

TEST_MAIN(T(sphereAreaAndVolumeAreWithinOnePercent),
          T(rampGivesExactPlaneAreasAndVolumes),
          T(rotatingTheFrameLeavesAreaAndVolumeUnchanged),
          T(volumeNeverGrowsWithTheIsovalue),
          T(torusHasOneComponentAndTwoSpheresTwo),
          T(componentCountsMatchADirectCount),
          T(ctHeadSuggestionsIncludeSkinAndBone),
          T(stepBetweenTwoMaterialsIsSuggestedAtItsMiddle),
          T(constantVolumeIsRefusedWithAClearMessage),
          T(nonfiniteSamplesAreSkipped))
