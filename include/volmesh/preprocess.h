/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/preprocess.h — stages before meshing: denoising and the contour spectrum.
 *
 * Denoising (preprocess/denoise.c) follows seed 001 (LBIE, Zhang, Bajaj and Sohn, §3): a bilateral
 * filter (Tomasi and Manduchi 1998) and Perona–Malik anisotropic diffusion (Perona and Malik
 * 1990; Bajaj, Wu and Xu 2003). The contour spectrum (preprocess/spectrum.c) follows Bajaj,
 * Pascucci and Schikore, "The contour spectrum", IEEE Visualization 1997.
 *
 * Units. Distances, areas and volumes are in world units (spacing and direction applied).
 * Values (sigma_range, isovalues) are in the units of the volume's samples. Non-finite samples
 * (NaN, inf) are left as they are by the filters, never used as neighbours, and skipped by the
 * spectrum. Every function here leaves its input unchanged. */
#ifndef VOLMESH_PREPROCESS_H
#define VOLMESH_PREPROCESS_H

#include <stdint.h>
#include "error.h"
#include "mesher.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Denoising ---------------------------------------------------------------------------- */

/* Robust estimate of the standard deviation of additive white noise in v: the median absolute
 * deviation of the 7-point index-space Laplacian, 1.4826 * MAD / sqrt(42) (the Laplacian of
 * unit white noise has variance 36 + 6 = 42). Voxels on the border and voxels whose whole
 * neighbourhood is constant (flat background, masks) are left out, so a clean image with a
 * large flat background does not report zero. [in] v; [out] *sigma >= 0 (0 when v has no
 * varying interior voxel, e.g. a constant volume or one thinner than 3 voxels). */
vm_status vm_denoise_noise_sigma(const vm_volume *v, double *sigma, vm_error *err);

/* The parameters the filters pick when given <= 0 (see each filter for the rules). */
typedef struct vm_denoise_params {
    double noise_sigma;  /* vm_denoise_noise_sigma, or 1% of max - min when that is 0 */
    double sigma_space;  /* bilateral: geometric mean of the spacings (world units) */
    double sigma_range;  /* bilateral: 2 * noise_sigma (value units) */
    double kappa;        /* diffusion: 2 * noise_sigma * sqrt(sum_axes 1/(2 h^2)) */
    double max_dt;       /* diffusion: vm_denoise_diffusion_max_dt */
    double dt;           /* diffusion: max_dt / 2 */
    int iterations;      /* diffusion: 10 */
} vm_denoise_params;

/* Fills p with the defaults for v. [in] v; [out] p. Errors: VM_ERR_NOMEM. */
vm_status vm_denoise_defaults(const vm_volume *v, vm_denoise_params *p, vm_error *err);

/* Bilateral filter (Tomasi and Manduchi 1998): each voxel becomes the average of its
 * neighbours q weighted by exp(-|x_p - x_q|^2 / (2 sigma_space^2)) *
 * exp(-(f_p - f_q)^2 / (2 sigma_range^2)), with |x_p - x_q| the world distance (spacing and
 * direction applied), over the neighbours within 3 sigma_space.
 *
 * [in]  in           volume to filter; not modified.
 * [in]  sigma_space  spatial standard deviation in world units, > 0; <= 0 picks the default,
 *                    the geometric mean of the spacings (one voxel of a cubic grid).
 *                    The kernel may reach at most 64 voxels each way along an axis
 *                    (VM_ERR_ARG beyond).
 * [in]  sigma_range  range standard deviation in value units, > 0; <= 0 picks the default,
 *                    2 * vm_denoise_noise_sigma(in) (or 1% of max - min when that is 0).
 * [out] out          a new volume with in's dims, spacing, origin and direction (type float32);
 *                    the caller frees it with vm_volume_free. Untouched on error.
 * [in]  progress     called once per z slice (stage "bilateral"); may be NULL.
 * [in]  user         passed to progress.
 * A constant volume comes back unchanged. Errors: VM_ERR_NOMEM, VM_ERR_ARG. */
vm_status vm_denoise_bilateral(const vm_volume *in, double sigma_space, double sigma_range,
                               vm_volume *out, vm_progress_fn progress, void *user,
                               vm_error *err);

/* Largest time step of vm_denoise_diffusion for which the explicit scheme is stable for v's
 * spacing: 1 / (2 * (1/sx^2 + 1/sy^2 + 1/sz^2)) (world units squared; 1/6 for unit spacing).
 * Axes with a single sample do not count. */
double vm_denoise_diffusion_max_dt(const vm_volume *v);

/* Perona–Malik anisotropic diffusion, df/dt = div(g(|grad f|) grad f) with the conductance
 * g(s) = 1 / (1 + (s/kappa)^2), by explicit time steps on the voxel grid:
 *   f_p += dt * sum over the 6 faces (p,q) of g(|grad f|_pq) (f_q - f_p) / h_pq^2,
 * where h_pq is the spacing along the face's axis and |grad f|_pq the world-space gradient at
 * the face (normal part from f_q - f_p, tangential parts from the central differences of p
 * and q). Since 0 < g <= 1, the new value is a convex combination of the old ones when
 * dt * sum_axes 2/h^2 <= 1, i.e. dt <= vm_denoise_diffusion_max_dt(): no new extrema, no
 * oscillation. Regions with gradients well below kappa are smoothed like the heat equation
 * (after total time T = dt * iterations, as a Gaussian of standard deviation sqrt(2 T) world
 * units); edges with gradients well above kappa are kept. Borders are insulating (no flux).
 *
 * [in]  in          volume to filter; not modified.
 * [in]  kappa       conductance contrast: a gradient magnitude in value units per world unit,
 *                   > 0; <= 0 picks the default, 2 * the expected gradient magnitude of the
 *                   noise: 2 * sigma * sqrt(sum_axes 1/(2 h^2)), sigma from
 *                   vm_denoise_noise_sigma (or 1% of max - min when that is 0).
 * [in]  dt          time step in world units squared, 0 < dt <= vm_denoise_diffusion_max_dt(in);
 *                   a larger step is refused with VM_ERR_ARG (the message gives the limit);
 *                   <= 0 picks half the limit (which also damps the grid's checkerboard mode
 *                   in one step).
 * [in]  iterations  number of steps, 1..100000; <= 0 picks 10.
 * [out] out         a new volume with in's geometry (type float32); free with vm_volume_free.
 *                   Untouched on error.
 * [in]  progress    called once per iteration (stage "diffusion"); may be NULL.
 * [in]  user        passed to progress.
 * A constant volume comes back exactly unchanged. Errors: VM_ERR_NOMEM, VM_ERR_ARG. */
vm_status vm_denoise_diffusion(const vm_volume *in, double kappa, double dt, int iterations,
                               vm_volume *out, vm_progress_fn progress, void *user,
                               vm_error *err);

/* ---- Contour spectrum --------------------------------------------------------------------- */

/* Suggestions. The mean gradient over the isosurface, m(v) = gradient_integral / area (both
 * smoothed over the isovalues with a Gaussian of n/128 samples, at least 1; left undefined
 * where the smoothed area is below 1% of its maximum), is low for isovalues inside a
 * homogeneous material and high across boundaries. A *material class* is a minimum of m whose
 * depth (how far m rises on either side before it falls below the minimum again, as in the
 * topographic prominence of a valley) is at least 5% of the range of m. A class ends on each
 * side where m has risen by half of min(depth, the rise on that side). A suggested boundary
 * isovalue sits midway between the end of one class and the start of the next, or at the end
 * of a class with no class beyond it (e.g. the top of soft tissue in CT, where bone values
 * are spread over a wide range and form no homogeneous class). */
typedef struct vm_spectrum_suggestion {
    double isovalue;
    double mean_gradient; /* gradient_integral / area at isovalue (value units per world unit) */
    double area;          /* isosurface area at isovalue (world units^2) */
    int64_t components;   /* components of {f >= v} at the nearest sample */
    double strength;      /* depth of the shallower class it bounds, relative to the range of
                           * the smoothed m: (0, 1]; larger is a clearer boundary */
} vm_spectrum_suggestion;

/* A material class candidate: the values between two consecutive suggested isovalues (the
 * first interval starts at lo, the last ends at hi). */
typedef struct vm_spectrum_interval {
    double lo, hi;
    double volume;        /* world volume of {lo <= f < hi} (the last interval includes hi) */
    double center;        /* isovalue of the class (minimum of m) inside, or NaN when the
                           * interval holds no homogeneous class */
} vm_spectrum_interval;

/* The contour spectrum at n isovalues isovalue[k] = lo + k (hi - lo) / (n - 1). Geometry is
 * that of the piecewise-linear interpolant on the Kuhn split of every cell into 6 tetrahedra
 * (all sharing the cell's (0,0,0)-(1,1,1) diagonal), in world units. All arrays hold n
 * entries, are owned by the struct and freed by vm_spectrum_free. */
typedef struct vm_spectrum {
    int n;                        /* number of isovalues, >= 2 */
    double lo, hi;                /* first and last isovalue, lo < hi */
    double value_min, value_max;  /* range of the finite samples of the volume */
    double total_volume;          /* world volume of all cells with 8 finite corners */
    double *isovalue;             /* [n] */
    double *area;                 /* [n] area of {f = v} (world units^2) */
    double *volume;               /* [n] volume of {f >= v} (world units^3) */
    double *gradient_integral;    /* [n] integral of |grad f| over {f = v} (value * world^1) */
    int64_t *components;          /* [n] connected components of the grid points with f >= v,
                                   * 6-connectivity (faces of the voxel grid) */
    int n_suggestions;            /* 0..VM_SPECTRUM_MAX_SUGGESTIONS, increasing isovalue */
    vm_spectrum_suggestion *suggestions;
    int n_intervals;              /* n_suggestions + 1 */
    vm_spectrum_interval *intervals;
    double seconds;               /* time taken */
} vm_spectrum;

#define VM_SPECTRUM_MAX_SUGGESTIONS 8

/* Computes the spectrum of v at n isovalues over [min, max] of its finite samples, in one pass
 * over the cells (plus one union-find sweep over the points, in decreasing value, for the
 * component counts). [in] v; [in] n in 2..1000000 (256 is a good default);
 * [out] out, initialised here, freed with vm_spectrum_free (also after an error).
 * Errors: VM_ERR_EMPTY when v is constant or has no finite sample ("no isosurfaces"),
 * VM_ERR_ARG for n out of range, VM_ERR_NOMEM. */
vm_status vm_spectrum_compute(const vm_volume *v, int n, vm_spectrum *out, vm_error *err);

/* As vm_spectrum_compute over the isovalue range [lo, hi] (lo < hi, both finite; VM_ERR_ARG
 * otherwise), with a progress callback (stage "spectrum", may be NULL) and its user pointer.
 * The range may extend past the data (areas are 0 there). Suggestions are searched within the
 * range; the first and last interval start and end at lo and hi. */
vm_status vm_spectrum_compute_range(const vm_volume *v, int n, double lo, double hi,
                                    vm_progress_fn progress, void *user, vm_spectrum *out,
                                    vm_error *err);

/* Linear interpolation of one of the spectrum's curves (s->area, s->volume,
 * s->gradient_integral) at isovalue v, clamped to [lo, hi]. */
double vm_spectrum_at(const vm_spectrum *s, const double *curve, double v);

/* Frees the arrays of s and zeroes it. s may be NULL. */
void vm_spectrum_free(vm_spectrum *s);

#ifdef __cplusplus
}
#endif
#endif
