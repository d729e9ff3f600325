/* SPDX-License-Identifier: BSD-3-Clause */
/* preprocess/denoise.c — bilateral filter and Perona–Malik anisotropic diffusion, spacing-aware.
 * Seed 001 (LBIE) §3; Tomasi and Manduchi 1998; Perona and Malik 1990; noise by MAD. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "volmesh/preprocess.h"
#include "preprocess_internal.h"

#define BILATERAL_REACH 3.0 /* kernel radius in units of sigma_space */
#define BILATERAL_MAX_RADIUS 64

/* MAD to standard deviation for Gaussian noise: 1 / Phi^-1(3/4). */
static const double mad_to_sigma = 1.4826;
/* Noise below this fraction of the value range counts as none (a clean image) ... */
static const double clean_noise_fraction = 1e-6;
/* ... and is then taken as this fraction of the range (1 %). */
static const double fallback_noise_fraction = 0.01;
/* The default range sigma and conductance scale, in noise sigmas: edges stronger than about
 * two noise sigmas are kept. */
static const double noise_sigmas = 2.0;
/* The default time step, as a fraction of the explicit scheme's stability limit. */
static const double dt_fraction = 0.5;
/* Default and largest number of diffusion iterations. */
enum { DEFAULT_ITERATIONS = 10, MAX_ITERATIONS = 100000 };

/* k-th smallest of a[0..n-1] (a is reordered), Hoare's selection. */
static float select_kth(float *a, size_t n, size_t k) {
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        float pivot = a[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (a[i] < pivot) i++;
            while (a[j] > pivot) j--;
            if (i <= j) {
                float t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                if (j == 0) break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            break;
    }
    return a[k];
}

/* The noise sigma: the MAD of the voxels' Laplacians (see volmesh/preprocess.h). */
vm_status vm_denoise_noise_sigma(const vm_volume *v, double *sigma, vm_error *err) {
    const int64_t nx = v->dims[0], ny = v->dims[1], nz = v->dims[2];
    const int64_t n[3] = {nx, ny, nz};
    const int64_t stride[3] = {1, nx, nx * ny};
    int used[3], m = 0;
    for (int a = 0; a < 3; a++) {
        used[a] = n[a] >= 3;
        m += used[a];
    }
    *sigma = 0.0;
    if (m == 0) return VM_OK;
    size_t count = vm_volume_count(v);
    float *lap = malloc(count * sizeof *lap);
    if (!lap) return vm_error_set(err, VM_ERR_NOMEM, "noise estimate: out of memory");
    size_t kept = 0;
    const float *f = v->data;
    for (int64_t k = used[2]; k < nz - used[2]; k++)
        for (int64_t j = used[1]; j < ny - used[1]; j++)
            for (int64_t i = used[0]; i < nx - used[0]; i++) {
                int64_t p = i + nx * (j + ny * k);
                float c = f[p];
                if (!isfinite(c)) continue;
                double sum = 0;
                int flat = 1, ok = 1;
                for (int a = 0; a < 3 && ok; a++) {
                    if (!used[a]) continue;
                    float lo = f[p - stride[a]], hi = f[p + stride[a]];
                    if (!isfinite(lo) || !isfinite(hi)) ok = 0;
                    if (lo != c || hi != c) flat = 0;
                    sum += (double)lo + (double)hi - 2.0 * c;
                }
                if (ok && !flat) lap[kept++] = (float)sum;
            }
    if (kept > 0) {
        float med = select_kth(lap, kept, kept / 2);
        for (size_t q = 0; q < kept; q++) lap[q] = fabsf(lap[q] - med);
        double mad = select_kth(lap, kept, kept / 2);
        /* Var of the Laplacian of unit white noise: (2m)^2 for the centre + 2m neighbours. */
        *sigma = mad_to_sigma * mad / sqrt(4.0 * m * m + 2.0 * m);
    }
    free(lap);
    return VM_OK;
}

/* Allocates *out with in's geometry (data not filled). */
static vm_status alloc_like(const vm_volume *in, vm_volume *out, vm_error *err) {
    vm_status st = vm_volume_alloc(out, in->dims, err);
    if (st) return st;
    memcpy(out->spacing, in->spacing, sizeof out->spacing);
    memcpy(out->origin, in->origin, sizeof out->origin);
    memcpy(out->direction, in->direction, sizeof out->direction);
    memcpy(out->format, in->format, sizeof out->format);
    out->format[sizeof out->format - 1] = '\0';
    return VM_OK;
}

double vm_denoise_diffusion_max_dt(const vm_volume *v) {
    double s = 0;
    for (int a = 0; a < 3; a++)
        if (v->dims[a] > 1) s += 1.0 / (v->spacing[a] * v->spacing[a]);
    return s > 0 ? 1.0 / (2.0 * s) : INFINITY;
}

/* Parameters from the noise and the spacing (see volmesh/preprocess.h). */
vm_status vm_denoise_defaults(const vm_volume *v, vm_denoise_params *p, vm_error *err) {
    memset(p, 0, sizeof *p);
    vm_status st = vm_denoise_noise_sigma(v, &p->noise_sigma, err);
    if (st) return st;
    double lo, hi;
    vm_volume_stats(v, &lo, &hi, NULL);
    double range = isfinite(lo) ? hi - lo : 0.0;
    /* A clean image shows no noise: fall back to a small fraction of the contrast. */
    if (!(p->noise_sigma > clean_noise_fraction * range))
        p->noise_sigma = fallback_noise_fraction * range;
    const double *h = v->spacing;
    p->sigma_space = cbrt(h[0] * h[1] * h[2]);
    p->sigma_range = noise_sigmas * p->noise_sigma;
    double q = 0;
    for (int a = 0; a < 3; a++)
        if (v->dims[a] > 1) q += 1.0 / (2.0 * h[a] * h[a]);
    p->kappa = noise_sigmas * p->noise_sigma * sqrt(q);
    if (!(p->kappa > 0)) p->kappa = 1.0; /* constant volume: nothing flows anyway */
    if (!(p->sigma_range > 0)) p->sigma_range = 1.0;
    p->max_dt = vm_denoise_diffusion_max_dt(v);
    p->dt = isfinite(p->max_dt) ? dt_fraction * p->max_dt : 1.0;
    p->iterations = DEFAULT_ITERATIONS;
    return VM_OK;
}

typedef struct {
    int di, dj, dk;
    int64_t off;
    float w;
} tap;

/* One z slab of the bilateral filter: out = c + sum w (f_q - c) / sum w over the taps
 * (exact on constant regions); non-finite samples pass through and are skipped as taps. */
static void bilateral_slab(const vm_volume *in, const tap *taps, size_t ntap, const int rad[3],
                           float rscale, int64_t k, float *out) {
    const int64_t nx = in->dims[0], ny = in->dims[1], nz = in->dims[2];
    const float *f = in->data;
    for (int64_t j = 0; j < ny; j++) {
        int inner_jk = j >= rad[1] && j < ny - rad[1] && k >= rad[2] && k < nz - rad[2];
        for (int64_t i = 0; i < nx; i++) {
            int64_t p = i + nx * (j + ny * k);
            float c = f[p];
            if (!isfinite(c)) {
                out[p] = c;
                continue;
            }
            int inner = inner_jk && i >= rad[0] && i < nx - rad[0];
            double sw = 1.0, swd = 0.0;
            for (size_t t = 0; t < ntap; t++) {
                if (!inner) {
                    int64_t ii = i + taps[t].di, jj = j + taps[t].dj, kk = k + taps[t].dk;
                    if (ii < 0 || ii >= nx || jj < 0 || jj >= ny || kk < 0 || kk >= nz)
                        continue;
                }
                float q = f[p + taps[t].off];
                float d = q - c;
                if (!isfinite(d)) continue;
                float w = taps[t].w * expf(d * d * rscale);
                sw += w;
                swd += (double)w * d;
            }
            out[p] = (float)(c + swd / sw);
        }
    }
}

/* The bilateral filter (see volmesh/preprocess.h). */
vm_status vm_denoise_bilateral(const vm_volume *in, double sigma_space, double sigma_range,
                               vm_volume *out, vm_progress_fn progress, void *user,
                               vm_error *err) {
    const int64_t nx = in->dims[0], ny = in->dims[1], nz = in->dims[2];
    if (!(sigma_space > 0) || !isfinite(sigma_space) || !(sigma_range > 0) ||
        !isfinite(sigma_range)) {
        vm_denoise_params def;
        vm_status st = vm_denoise_defaults(in, &def, err);
        if (st) return st;
        if (!(sigma_space > 0) || !isfinite(sigma_space)) sigma_space = def.sigma_space;
        if (!(sigma_range > 0) || !isfinite(sigma_range)) sigma_range = def.sigma_range;
    }
    double inv[3][3], det;
    vm_status st = vm__frame_inverse(in, "bilateral", inv, &det, err);
    if (st) return st;
    /* |index offset along a| <= |row a of M^-1| * world distance, so this radius holds the
     * whole ball of world radius reach whatever the direction matrix. */
    double reach = BILATERAL_REACH * sigma_space;
    int rad[3];
    for (int a = 0; a < 3; a++) {
        double row = sqrt(inv[a][0] * inv[a][0] + inv[a][1] * inv[a][1] + inv[a][2] * inv[a][2]);
        double r = floor(reach * row);
        if (r > BILATERAL_MAX_RADIUS)
            return vm_error_set(err, VM_ERR_ARG,
                                "bilateral: sigma-space %g reaches %.0f voxels along axis %d "
                                "(at most %d); use a smaller sigma-space",
                                sigma_space, r, a, BILATERAL_MAX_RADIUS);
        rad[a] = (int)r;
        if (rad[a] > in->dims[a] - 1) rad[a] = (int)(in->dims[a] - 1);
    }
    size_t ntap_max = (size_t)(2 * rad[0] + 1) * (size_t)(2 * rad[1] + 1) * (size_t)(2 * rad[2] + 1);
    tap *taps = malloc(ntap_max * sizeof *taps);
    if (!taps) return vm_error_set(err, VM_ERR_NOMEM, "bilateral: out of memory");
    size_t ntap = 0;
    for (int dk = -rad[2]; dk <= rad[2]; dk++)
        for (int dj = -rad[1]; dj <= rad[1]; dj++)
            for (int di = -rad[0]; di <= rad[0]; di++) {
                if (!di && !dj && !dk) continue;
                const int d[3] = {di, dj, dk};
                double d2 = 0;
                for (int r = 0; r < 3; r++) {
                    double x = 0;
                    for (int c = 0; c < 3; c++) x += in->direction[r][c] * in->spacing[c] * d[c];
                    d2 += x * x;
                }
                if (d2 > reach * reach) continue;
                tap t = {di, dj, dk, di + nx * (dj + ny * (int64_t)dk),
                         (float)exp(-d2 / (2.0 * sigma_space * sigma_space))};
                taps[ntap++] = t;
            }
    vm_volume res;
    st = alloc_like(in, &res, err);
    if (st) {
        free(taps);
        return st;
    }
    const float rscale = (float)(-1.0 / (2.0 * sigma_range * sigma_range));
    /* Slabs in parallel, a block of them between progress reports (from this thread only);
     * every voxel is computed the same way whatever the thread count. */
    const int64_t block = 8;
    for (int64_t k0 = 0; k0 < nz; k0 += block) {
        int64_t k1 = k0 + block < nz ? k0 + block : nz;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (int64_t k = k0; k < k1; k++) bilateral_slab(in, taps, ntap, rad, rscale, k, res.data);
        if (progress && progress("bilateral", (double)k1, (double)nz, user)) {
            free(taps);
            vm_volume_free(&res);
            return vm__cancelled(err, "bilateral");
        }
    }
    free(taps);
    *out = res;
    return VM_OK;
}

/* Flux through the face between voxel p and its a-neighbour q = p + e_a: Perona-Malik
 * conductance 1 / (1 + |grad|^2 / kappa^2), with the normal derivative across the face and
 * the tangential ones averaged from both sides. 0 when either value is not finite. */
static double face_flux(const float *cur, float *const g[3], int64_t p, int64_t q, int a,
                        const double coef[3], double inv_k2, const double h[3]) {
    float fp = cur[p];
    if (!isfinite(fp)) return 0.0;
    float d = cur[q] - fp;
    if (d == 0.0f || !isfinite(d)) return 0.0;
    double gn = d / h[a], s2 = gn * gn;
    for (int b = 0; b < 3; b++) {
        if (b == a) continue;
        double gt = 0.5 * ((double)g[b][p] + g[b][q]);
        s2 += gt * gt;
    }
    return coef[a] * d / (1.0 + s2 * inv_k2);
}

/* One diffusion step: what its per-voxel work reads and writes. */
typedef struct diffusion {
    const float *cur;  /* the values before the step */
    float *next;       /* after it */
    float *g[3];       /* the gradient of cur per axis */
    int64_t n[3], stride[3];
    const double *h;   /* the spacing */
    double coef[3];    /* dt / h^2 per axis */
    double inv_k2;     /* 1 / kappa^2 */
} diffusion;

/* Calls fn on every voxel (idx its index, p its offset), z slabs in parallel: fn writes
 * only at p, so the result is the same for any thread count. */
static void each_voxel(const diffusion *D,
                       void (*fn)(const diffusion *, const int64_t[3], int64_t)) {
    const int64_t *n = D->n;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            for (int64_t i = 0; i < n[0]; i++) {
                const int64_t idx[3] = {i, j, k};
                fn(D, idx, i + n[0] * (j + n[1] * k));
            }
}

/* The gradient of cur at voxel p: central differences (one-sided on the border, 0 next to
 * non-finite samples) / spacing. */
static void gradient_at(const diffusion *D, const int64_t idx[3], int64_t p) {
    const float *f = D->cur;
    for (int a = 0; a < 3; a++) {
        int64_t lo = idx[a] > 0 ? p - D->stride[a] : p;
        int64_t hi = idx[a] < D->n[a] - 1 ? p + D->stride[a] : p;
        float d = f[hi] - f[lo];
        D->g[a][p] = (hi != lo && isfinite(d))
                         ? (float)(d / ((double)(hi - lo) / D->stride[a] * D->h[a]))
                         : 0.0f;
    }
}

/* Voxel p after the step. Each face (p, p + e_a) moves the same amount out of one voxel and
 * into the other; every voxel gathers its six faces in the order a sequential sweep would
 * add them (lower neighbours z, y, x, then its own faces x, y, z), so slabs run in parallel
 * with the same result. */
static void diffuse_at(const diffusion *D, const int64_t idx[3], int64_t p) {
    float v = D->cur[p];
    if (!isfinite(v)) {
        D->next[p] = v;
        return;
    }
    for (int a = 2; a >= 0; a--)
        if (idx[a] > 0)
            v -= (float)face_flux(D->cur, D->g, p - D->stride[a], p, a, D->coef, D->inv_k2,
                                  D->h);
    for (int a = 0; a < 3; a++)
        if (idx[a] < D->n[a] - 1)
            v += (float)face_flux(D->cur, D->g, p, p + D->stride[a], a, D->coef, D->inv_k2,
                                  D->h);
    D->next[p] = v;
}

/* Perona-Malik diffusion, explicit steps (see volmesh/preprocess.h). */
vm_status vm_denoise_diffusion(const vm_volume *in, double kappa, double dt, int iterations,
                               vm_volume *out, vm_progress_fn progress, void *user,
                               vm_error *err) {
    double max_dt = vm_denoise_diffusion_max_dt(in);
    if (dt > max_dt)
        return vm_error_set(err, VM_ERR_ARG,
                            "diffusion: time step %g is above the stability limit %.6g for "
                            "spacing %g %g %g (explicit scheme: dt <= 1/(2 sum 1/h^2))",
                            dt, max_dt, in->spacing[0], in->spacing[1], in->spacing[2]);
    if (!(dt > 0) || !isfinite(dt)) dt = isfinite(max_dt) ? dt_fraction * max_dt : 1.0;
    if (iterations > MAX_ITERATIONS)
        return vm_error_set(err, VM_ERR_ARG, "diffusion: %d iterations (at most 100000)",
                            iterations);
    if (iterations <= 0) iterations = DEFAULT_ITERATIONS;
    const double *h = in->spacing;
    if (!(kappa > 0) || !isfinite(kappa)) {
        vm_denoise_params def;
        vm_status st = vm_denoise_defaults(in, &def, err);
        if (st) return st;
        kappa = def.kappa;
    }
    size_t count = vm_volume_count(in);
    vm_volume res;
    vm_status st = alloc_like(in, &res, err);
    if (st) return st;
    float *next = malloc(count * sizeof *next);
    float *grad = malloc(3 * count * sizeof *grad);
    if (!next || !grad) {
        free(next);
        free(grad);
        vm_volume_free(&res);
        return vm_error_set(err, VM_ERR_NOMEM, "diffusion: out of memory for %zu voxels",
                            count);
    }
    const int64_t n[3] = {in->dims[0], in->dims[1], in->dims[2]};
    diffusion D = {.n = {n[0], n[1], n[2]},
                   .stride = {1, n[0], n[0] * n[1]},
                   .g = {grad, grad + count, grad + 2 * count},
                   .h = h,
                   .inv_k2 = 1.0 / (kappa * kappa)};
    for (int a = 0; a < 3; a++) D.coef[a] = dt / (h[a] * h[a]);
    float *cur = res.data;
    memcpy(cur, in->data, count * sizeof *cur);
    for (int it = 0; it < iterations; it++) {
        D.cur = cur;
        D.next = next;
        each_voxel(&D, gradient_at);
        each_voxel(&D, diffuse_at);
        float *t = cur;
        cur = next;
        next = t;
        if (progress && progress("diffusion", it + 1.0, (double)iterations, user)) {
            free(cur == res.data ? next : cur);
            free(grad);
            vm_volume_free(&res);
            return vm__cancelled(err, "diffusion");
        }
    }
    if (cur != res.data) {
        memcpy(res.data, cur, count * sizeof *cur);
        next = cur;
    }
    free(next);
    free(grad);
    *out = res;
    return VM_OK;
}
