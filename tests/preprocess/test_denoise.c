/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/preprocess/test_denoise.c — the bilateral filter and anisotropic diffusion on phantoms with
 * seeded Gaussian noise: PSNR gains, the isosurface stays put, constants stay constant,
 * anisotropic spacing, the stability limit of the time step, the noise estimate. */
#include "test.h"
#include <string.h>
#include <time.h>

#define PI 3.14159265358979323846
#define N 49 /* odd: the sphere centre (n-1)/2 is a grid point */
#define NOISE 1.0 /* voxels: the phantom field is a signed distance in voxels */

/* PSNR of a against the clean reference, peak = the reference's max - min. */
static double psnr(const vm_volume *a, const vm_volume *ref) {
    double lo, hi, mse = 0;
    vm_volume_stats(ref, &lo, &hi, NULL);
    size_t n = vm_volume_count(ref);
    for (size_t p = 0; p < n; p++) {
        double d = (double)a->data[p] - ref->data[p];
        mse += d * d;
    }
    mse /= (double)n;
    return 10.0 * log10((hi - lo) * (hi - lo) / mse);
}

/* Along every x row (j, k) that passes well inside the sphere phantom: [out] mean_abs, the
 * mean |error| of the zero crossing (linear interpolation between the last sample inside and
 * the first outside, walking out from the centre) against the exact sqrt(R^2 - dy^2 - dz^2);
 * it includes the residual noise. [out] surface_value, the mean of the field interpolated at
 * the exact crossings: with |grad f| = 1 it is how far (voxels, > 0 outward) the zero level
 * moved, free of the noise, which averages out. */
static void row_crossing_error(const vm_volume *v, double *mean_abs, double *surface_value) {
    const int n = (int)v->dims[0], c = (n - 1) / 2;
    const double R = 0.35 * (n - 1);
    double sa = 0, sv = 0;
    int count = 0, nv = 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++) {
            double dy = j - c, dz = k - c, q = R * R - dy * dy - dz * dz;
            if (q < 4.0) continue;
            double exact = sqrt(q);
            const float *row = v->data + (size_t)n * (j + (size_t)n * k);
            for (int dir = -1; dir <= 1; dir += 2) {
                /* the field interpolated at the exact crossing: the level set's shift */
                double x = c + dir * exact, fl = floor(x), u = x - fl;
                sv += (1 - u) * row[(int)fl] + u * row[(int)fl + 1];
                nv++;
                double prev = row[c];
                for (int t = 1; c + dir * t >= 0 && c + dir * t < n; t++) {
                    double f = row[c + dir * t];
                    if (prev >= 0 && f < 0) {
                        sa += fabs((t - 1) + prev / (prev - f) - exact);
                        count++;
                        break;
                    }
                    prev = f;
                }
            }
        }
    *mean_abs = count ? sa / count : NAN;
    *surface_value = nv ? sv / nv : NAN;
}

/* Radius of the sphere with the volume of {f >= 0} (from the contour spectrum). */
static double volume_radius(const vm_volume *v) {
    vm_spectrum s;
    vm_error err;
    double r = NAN;
    if (vm_spectrum_compute_range(v, 3, -1, 1, NULL, NULL, &s, &err) == VM_OK)
        r = cbrt(3.0 * s.volume[1] / (4.0 * PI));
    vm_spectrum_free(&s);
    return r;
}

typedef struct {
    const char *label;
    int diffusion;
    double min_gain_db; /* asserted; the measured figure is printed */
} denoise_case;

static void run_case(const denoise_case *dc) {
    vm_volume clean, noisy, out;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, N, 0.0, 1, &clean, NULL, &err), &err);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, N, NOISE, 2024, &noisy, NULL, &err), &err);
    vm_status st = dc->diffusion
                       ? vm_denoise_diffusion(&noisy, 0, 0, 0, &out, NULL, NULL, &err)
                       : vm_denoise_bilateral(&noisy, 0, 0, &out, NULL, NULL, &err);
    CHECK_OK(st, &err);
    if (st == VM_OK) {
        double before = psnr(&noisy, &clean), after = psnr(&out, &clean);
        double err_out, shift_out, err_noisy, shift_noisy, err_clean, shift_clean;
        row_crossing_error(&out, &err_out, &shift_out);
        row_crossing_error(&noisy, &err_noisy, &shift_noisy);
        row_crossing_error(&clean, &err_clean, &shift_clean);
        double R = 0.35 * (N - 1), rv = volume_radius(&out), rv_clean = volume_radius(&clean);
        double shift = shift_out - shift_clean;
        printf("    %s: PSNR %.2f -> %.2f dB (%+.2f dB)\n"
               "      zero level moved %+.3f voxel; crossings along x off by %.3f voxel on "
               "average (noisy %.3f, clean %.3f)\n"
               "      radius from the volume of {f >= 0}: %.3f (clean %.3f, exact %.3f)\n",
               dc->label, before, after, after - before, shift, err_out, err_noisy, err_clean,
               rv, rv_clean, R);
        CHECK_MSG(after - before >= dc->min_gain_db, "gain %.2f dB, want >= %.1f",
                  after - before, dc->min_gain_db);
        CHECK_MSG(fabs(rv - rv_clean) < 0.3, "volume radius %.3f vs %.3f", rv, rv_clean);
        CHECK_MSG(fabs(shift) < 0.1, "zero level moved by %+.3f voxel", shift);
        CHECK_MSG(err_out < 0.5 * err_noisy, "crossings off by %.3f voxel (noisy %.3f)", err_out,
                  err_noisy);
        for (int a = 0; a < 3; a++) CHECK(out.dims[a] == noisy.dims[a]);
        vm_volume_free(&out);
    }
    vm_volume_free(&clean);
    vm_volume_free(&noisy);
}

/* Measured (48^3 sphere, sigma 1 voxel, defaults): bilateral +7.4 dB, diffusion +13.3 dB. */
static void bilateralImprovesPsnrAndKeepsTheIsosurface(void) {
    denoise_case dc = {"bilateral (defaults)", 0, 6.5};
    run_case(&dc);
}

static void diffusionImprovesPsnrAndKeepsTheIsosurface(void) {
    denoise_case dc = {"diffusion (defaults)", 1, 12.0};
    run_case(&dc);
}

/* A sharp step between two materials (values 0 and 100, noise 10): both filters keep the edge
 * where it is while removing most of the noise. */
static void edgesBetweenMaterialsAreKept(void) {
    int64_t dims[3] = {40, 40, 40};
    vm_volume clean, noisy;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&clean, dims, &err), &err);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 40, 10.0, 99, &noisy, NULL, &err), &err);
    size_t n = vm_volume_count(&clean);
    for (size_t p = 0; p < n; p++) {
        int i = (int)(p % 40), j = (int)(p / 40 % 40), k = (int)(p / 1600);
        double d = 12.2 - sqrt((i - 19.5) * (i - 19.5) + (j - 19.5) * (j - 19.5) +
                               (k - 19.5) * (k - 19.5));
        clean.data[p] = d >= 0 ? 100.0f : 0.0f;
        /* the phantom's noise is its field minus the sphere distance; reuse it, scaled */
        double sd = 0.35 * 39 - sqrt((i - 19.5) * (i - 19.5) + (j - 19.5) * (j - 19.5) +
                                     (k - 19.5) * (k - 19.5));
        noisy.data[p] = clean.data[p] + (float)(noisy.data[p] - sd);
    }
    for (int method = 0; method < 2; method++) {
        vm_volume out;
        vm_status st = method ? vm_denoise_diffusion(&noisy, 0, 0, 0, &out, NULL, NULL, &err)
                              : vm_denoise_bilateral(&noisy, 0, 0, &out, NULL, NULL, &err);
        CHECK_OK(st, &err);
        if (st) continue;
        /* volume of {f >= 50}: the edge at 50 stays where it was */
        vm_spectrum a, b;
        CHECK_OK(vm_spectrum_compute_range(&clean, 3, 0, 100, NULL, NULL, &a, &err), &err);
        CHECK_OK(vm_spectrum_compute_range(&out, 3, 0, 100, NULL, NULL, &b, &err), &err);
        double ra = cbrt(3 * a.volume[1] / (4 * PI)), rb = cbrt(3 * b.volume[1] / (4 * PI));
        double gain = psnr(&out, &clean) - psnr(&noisy, &clean);
        printf("    %s: PSNR %+.2f dB, radius of {f >= 50} %.3f (clean %.3f)\n",
               method ? "diffusion" : "bilateral", gain, rb, ra);
        CHECK_MSG(gain >= 6.0, "gain %.2f dB", gain);
        CHECK_MSG(fabs(ra - rb) < 0.3, "edge moved by %.3f voxel", fabs(ra - rb));
        vm_spectrum_free(&a);
        vm_spectrum_free(&b);
        vm_volume_free(&out);
    }
    vm_volume_free(&clean);
    vm_volume_free(&noisy);
}

static void constantVolumeStaysConstant(void) {
    int64_t dims[3] = {12, 10, 9};
    vm_volume v, out;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    v.spacing[2] = 2.5;
    size_t n = vm_volume_count(&v);
    for (size_t p = 0; p < n; p++) v.data[p] = 1234.5f;
    for (int method = 0; method < 2; method++) {
        vm_status st = method ? vm_denoise_diffusion(&v, 0, 0, 25, &out, NULL, NULL, &err)
                              : vm_denoise_bilateral(&v, 0, 0, &out, NULL, NULL, &err);
        CHECK_OK(st, &err);
        if (st) continue;
        size_t changed = 0;
        for (size_t p = 0; p < n; p++) changed += out.data[p] != 1234.5f;
        CHECK_MSG(changed == 0, "%s changed %zu voxels", method ? "diffusion" : "bilateral",
                  changed);
        CHECK(out.spacing[2] == 2.5);
        vm_volume_free(&out);
    }
    vm_volume_free(&v);
}

/* Second moment, in index units along axis a, of the response to a unit impulse. */
static double spread(const vm_volume *v, int a, const int64_t c[3]) {
    double m0 = 0, m2 = 0;
    size_t p = 0;
    for (int64_t k = 0; k < v->dims[2]; k++)
        for (int64_t j = 0; j < v->dims[1]; j++)
            for (int64_t i = 0; i < v->dims[0]; i++, p++) {
                const int64_t idx[3] = {i, j, k};
                double d = (double)(idx[a] - c[a]), w = v->data[p];
                m0 += w;
                m2 += w * d * d;
            }
    return sqrt(m2 / m0);
}

/* With spacing 1,1,3 a filter of a given world width spans a third as many voxels along z. */
static void anisotropicSpacingSmoothsLessAcrossZInIndexTerms(void) {
    int64_t dims[3] = {31, 31, 15}, c[3] = {15, 15, 7};
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    v.spacing[2] = 3.0;
    memset(v.data, 0, vm_volume_count(&v) * sizeof(float));
    v.data[c[0] + 31 * (c[1] + 31 * c[2])] = 1.0f;
    for (int method = 0; method < 2; method++) {
        vm_volume out;
        /* range sigma far above the impulse: a plain Gaussian; large kappa: heat equation */
        vm_status st = method ? vm_denoise_diffusion(&v, 1e6, 0, 20, &out, NULL, NULL, &err)
                              : vm_denoise_bilateral(&v, 3.0, 1e6, &out, NULL, NULL, &err);
        CHECK_OK(st, &err);
        if (st) continue;
        double sx = spread(&out, 0, c), sz = spread(&out, 2, c);
        printf("    %s: spread %.3f voxels along x, %.3f along z (world %.3f, %.3f)\n",
               method ? "diffusion" : "bilateral", sx, sz, sx, 3 * sz);
        CHECK_MSG(sz < 0.5 * sx, "z spread %.3f is not well below x spread %.3f", sz, sx);
        CHECK_MSG(fabs(3 * sz - sx) < 0.25 * sx, "world spreads %.3f (z) and %.3f (x) differ",
                  3 * sz, sx);
        if (method) {
            /* the heat equation after T = dt * 20 spreads as sqrt(2 T) world units */
            double T = 20 * 0.5 * vm_denoise_diffusion_max_dt(&v);
            CHECK_NEAR(sx, sqrt(2 * T), 0.1 * sqrt(2 * T));
        } else {
            CHECK_NEAR(sx, 3.0, 0.3);
        }
        vm_volume_free(&out);
    }
    vm_volume_free(&v);
}

static void unstableTimeStepIsRefused(void) {
    vm_volume v, out;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.5, 1, &v, NULL, &err), &err);
    v.spacing[0] = 0.5;
    double limit = vm_denoise_diffusion_max_dt(&v);
    CHECK_NEAR(limit, 1.0 / (2.0 * (4.0 + 1.0 + 1.0)), 1e-15);
    vm_error_clear(&err);
    CHECK(vm_denoise_diffusion(&v, 1, 1.01 * limit, 5, &out, NULL, NULL, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "stability") != NULL);
    CHECK(vm_denoise_diffusion(&v, 1, INFINITY, 5, &out, NULL, NULL, &err) == VM_ERR_ARG);
    /* at the limit the scheme is a convex combination: no new extrema */
    CHECK_OK(vm_denoise_diffusion(&v, 1e6, limit, 50, &out, NULL, NULL, &err), &err);
    double lo, hi, olo, ohi;
    vm_volume_stats(&v, &lo, &hi, NULL);
    vm_volume_stats(&out, &olo, &ohi, NULL);
    CHECK(olo >= lo - 1e-4 && ohi <= hi + 1e-4);
    vm_volume_free(&out);
    CHECK(vm_denoise_diffusion(&v, 1, 0, 100001, &out, NULL, NULL, &err) == VM_ERR_ARG);
    vm_volume_free(&v);
}

static void noiseEstimateIsCloseToTheTrueLevel(void) {
    static const double levels[] = {0.25, 1.0, 4.0};
    for (int q = 0; q < 3; q++) {
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 40, levels[q], 5, &v, NULL, &err), &err);
        double s = 0;
        CHECK_OK(vm_denoise_noise_sigma(&v, &s, &err), &err);
        printf("    noise %.2f: estimate %.4f\n", levels[q], s);
        CHECK_NEAR(s, levels[q], 0.1 * levels[q]);
        vm_volume_free(&v);
    }
    vm_volume v;
    vm_error err;
    int64_t dims[3] = {2, 2, 2};
    CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
    memset(v.data, 0, 8 * sizeof(float));
    double s = -1;
    CHECK_OK(vm_denoise_noise_sigma(&v, &s, &err), &err);
    CHECK(s == 0.0);
    vm_volume_free(&v);
}

static void nonfiniteVoxelsStayAndDoNotSpread(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.3, 1, &v, NULL, &err), &err);
    v.data[5 + 16 * (6 + 16 * 7)] = NAN;
    for (int method = 0; method < 2; method++) {
        vm_volume out;
        vm_status st = method ? vm_denoise_diffusion(&v, 0, 0, 0, &out, NULL, NULL, &err)
                              : vm_denoise_bilateral(&v, 0, 0, &out, NULL, NULL, &err);
        CHECK_OK(st, &err);
        if (st) continue;
        size_t bad = 0;
        for (size_t p = 0; p < vm_volume_count(&out); p++) bad += !isfinite(out.data[p]);
        CHECK(bad == 1);
        CHECK(isnan(out.data[5 + 16 * (6 + 16 * 7)]));
        vm_volume_free(&out);
    }
    vm_volume_free(&v);
}

static void progressIsReportedAndGeometryKept(void) {
    vm_volume v, out;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 20, 0.5, 1, &v, NULL, &err), &err);
    v.origin[1] = -7.5;
    v.direction[0][0] = -1;
    vm_test_progress_log pl = {NULL, 0, 0, 0, 0, 0, 0.0, 0.0};
    CHECK_OK(vm_denoise_bilateral(&v, 0, 0, &out, vm_test_progress, &pl, &err), &err);
    /* Reported per block of slabs, in order, ending at the whole volume. */
    CHECK(pl.calls >= 2 && pl.calls <= 20 && pl.backwards == 0);
    CHECK(pl.last == 20 && pl.total == 20 && pl.ended);
    CHECK(out.origin[1] == -7.5 && out.direction[0][0] == -1);
    vm_volume_free(&out);
    vm_test_progress_log pd = {NULL, 0, 0, 0, 0, 0, 0.0, 0.0};
    CHECK_OK(vm_denoise_diffusion(&v, 0, 0, 7, &out, vm_test_progress, &pd, &err), &err);
    CHECK(pd.calls == 7 && pd.backwards == 0 && pd.ended);
    vm_volume_free(&out);
    vm_volume_free(&v);
}

static void timingOnTheCtHeadIsWellUnderAFewSeconds(void) {
    const char *path = vm_test_shared("ct_head_quarter.nrrd");
    if (!path) return;
    vm_volume v, out;
    vm_error err;
    vm_status st = vm_volume_read(path, &v, &err);
    CHECK_OK(st, &err);
    if (st) return;
    double t0 = (double)clock() / CLOCKS_PER_SEC;
    CHECK_OK(vm_denoise_bilateral(&v, 0, 0, &out, NULL, NULL, &err), &err);
    double t1 = (double)clock() / CLOCKS_PER_SEC;
    vm_volume_free(&out);
    CHECK_OK(vm_denoise_diffusion(&v, 0, 0, 0, &out, NULL, NULL, &err), &err);
    double t2 = (double)clock() / CLOCKS_PER_SEC;
    vm_volume_free(&out);
    printf("    64x64x93: bilateral %.3f s, diffusion (10 steps) %.3f s (CPU)\n", t1 - t0,
           t2 - t1);
    CHECK(t1 - t0 < 3.0);
    CHECK(t2 - t1 < 3.0);
    vm_volume_free(&v);
}

TEST_MAIN(T(bilateralImprovesPsnrAndKeepsTheIsosurface),
          T(diffusionImprovesPsnrAndKeepsTheIsosurface),
          T(edgesBetweenMaterialsAreKept), T(constantVolumeStaysConstant),
          T(anisotropicSpacingSmoothsLessAcrossZInIndexTerms),
          T(unstableTimeStepIsRefused), T(noiseEstimateIsCloseToTheTrueLevel),
          T(nonfiniteVoxelsStayAndDoNotSpread), T(progressIsReportedAndGeometryKept),
          T(timingOnTheCtHeadIsWellUnderAFewSeconds))
