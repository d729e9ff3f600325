/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/denoise.c — `volmesh denoise`: bilateral filter or anisotropic diffusion, written as
 * NRRD with the input's geometry. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static const char *denoise_help =
    "usage: volmesh denoise IN -o OUT.nrrd [--method bilateral|diffusion] [options]\n"
    "\n"
    "Removes noise from a volume before meshing while keeping its edges (seed 001, LBIE §3),\n"
    "and writes the result as NRRD (float32, gzip) with the input's spacing, origin and\n"
    "direction. Parameters left out are chosen from the data; the ones used are printed.\n"
    "\n"
    "  -o, --output FILE       output volume (.nrrd)\n"
    "  --method M              bilateral (default) or diffusion\n"
    "  --quiet                 no progress bar and no summary line\n"
    "bilateral filter (each voxel averages its neighbours, weighted by distance and by\n"
    "value difference, so that edges are not blurred):\n"
    "  --sigma-space S         spatial standard deviation in world units (e.g. mm);\n"
    "                          default: the geometric mean of the spacings\n"
    "  --sigma-range R         value standard deviation; default: 2 x the noise level,\n"
    "                          estimated robustly from the data\n"
    "anisotropic diffusion (Perona-Malik: smooths where the gradient is below kappa and\n"
    "keeps edges where it is above):\n"
    "  --kappa K               gradient magnitude (value per world unit) separating noise\n"
    "                          from edges; default: 2 x the gradient of the noise\n"
    "  --dt T                  time step in world units squared; must not exceed\n"
    "                          1/(2 (1/sx^2 + 1/sy^2 + 1/sz^2)) (stability of the explicit\n"
    "                          scheme); default: half of that\n"
    "  --iterations N          number of steps (1..100000, default 10); smoothing grows like\n"
    "                          a Gaussian of standard deviation sqrt(2 N T)\n"
    "raw files (no header): --raw-dims NXxNYxNZ --raw-type T --raw-endian E\n"
    "                       --raw-spacing SX,SY,SZ --raw-origin X,Y,Z --raw-header N\n"
    "input: --series UID|N (DICOM series) --spacing SX,SY,SZ (replaces the file's)\n";

/* What `volmesh denoise` takes from its command line (0: chosen from the data). */
typedef struct {
    vm_cli_input in;
    const char *out_path, *method;
    double sigma_space, sigma_range, kappa, dt;
    long iterations;
    const char *bilateral_opt, *diffusion_opt; /* the last option given of each method */
    int quiet;
} denoise_args;

/* One option a that takes value val (the filter's parameters, -o, --method). */
static int denoise_value(denoise_args *d, const char *a, const char *val) {
    if (vm_cli_is(a, "-o", "--output")) {
        d->out_path = val;
    } else if (strcmp(a, "--method") == 0) {
        if (strcmp(val, "bilateral") != 0 && strcmp(val, "diffusion") != 0)
            return vm_cli_fail("--method: '%s' is not bilateral or diffusion", val);
        d->method = val;
    } else if (strcmp(a, "--iterations") == 0) {
        if (vm_cli_int(a, val, 1, 100000, &d->iterations)) return VM_EXIT_INPUT;
        d->diffusion_opt = a;
    } else {
        double x;
        if (vm_cli_double(a, val, &x)) return VM_EXIT_INPUT;
        if (!(x > 0)) return vm_cli_fail("%s: '%s' must be positive", a, val);
        if (strcmp(a, "--sigma-space") == 0) {
            d->sigma_space = x;
            d->bilateral_opt = a;
        } else if (strcmp(a, "--sigma-range") == 0) {
            d->sigma_range = x;
            d->bilateral_opt = a;
        } else if (strcmp(a, "--kappa") == 0) {
            d->kappa = x;
            d->diffusion_opt = a;
        } else {
            d->dt = x;
            d->diffusion_opt = a;
        }
    }
    return VM_EXIT_OK;
}

/* Reads the command line into d; *help 1 when --help was printed. */
static int denoise_parse(denoise_args *d, int argc, char **argv, int *help) {
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(denoise_help, stdout);
            *help = 1;
            return VM_EXIT_OK;
        }
        if (strcmp(a, "--quiet") == 0) {
            d->quiet = 1;
            continue;
        }
        int takes_value = vm_cli_is(a, "-o", "--output") || strcmp(a, "--method") == 0 ||
                          strcmp(a, "--sigma-space") == 0 || strcmp(a, "--sigma-range") == 0 ||
                          strcmp(a, "--kappa") == 0 || strcmp(a, "--dt") == 0 ||
                          strcmp(a, "--iterations") == 0;
        if (takes_value) {
            if (vm_cli_need_value("denoise", i, argc, argv)) return VM_EXIT_INPUT;
            int rc = denoise_value(d, a, argv[++i]);
            if (rc) return rc;
            continue;
        }
        int taken, rc = vm_cli_input_arg(&d->in, argc, argv, &i, &taken);
        if (rc) return rc;
        if (!taken)
            return vm_cli_fail("denoise: unknown option %s (see volmesh denoise --help)", a);
    }
    return VM_EXIT_OK;
}

/* The options that must be there or go together: an input, a .nrrd output, one method's. */
static int denoise_check(const denoise_args *d) {
    int rc = vm_cli_input_given(&d->in);
    if (rc) return rc;
    if (!d->out_path) return vm_cli_fail("denoise: no output file (-o OUT.nrrd)");
    static const char *const nrrd[] = {".nrrd", NULL};
    if (vm_cli_output_check("denoise", d->out_path, nrrd)) return VM_EXIT_INPUT;
    int diffusion = strcmp(d->method, "diffusion") == 0;
    if (diffusion && d->bilateral_opt)
        return vm_cli_fail("%s applies to --method bilateral, not diffusion", d->bilateral_opt);
    if (!diffusion && d->diffusion_opt)
        return vm_cli_fail("%s applies to --method diffusion (add --method diffusion)",
                           d->diffusion_opt);
    return VM_EXIT_OK;
}

/* Runs the chosen filter on v with d's parameters, the missing ones from def ([out] out;
 * used: the parameters, for the summary line). */
static vm_status denoise_filter(denoise_args *d, const vm_volume *v,
                                const vm_denoise_params *def, vm_volume *out, char *used,
                                size_t n, vm_error *err) {
    if (strcmp(d->method, "diffusion") == 0) {
        if (d->kappa <= 0) d->kappa = def->kappa;
        if (d->dt <= 0) d->dt = def->dt;
        if (d->iterations <= 0) d->iterations = def->iterations;
        snprintf(used, n, "diffusion kappa %.4g dt %.4g (limit %.4g) iterations %ld", d->kappa,
                 d->dt, def->max_dt, d->iterations);
        return vm_denoise_diffusion(v, d->kappa, d->dt, (int)d->iterations, out,
                                    vm_cli_progress, &d->quiet, err);
    }
    if (d->sigma_space <= 0) d->sigma_space = def->sigma_space;
    if (d->sigma_range <= 0) d->sigma_range = def->sigma_range;
    snprintf(used, n, "bilateral sigma-space %.4g sigma-range %.4g", d->sigma_space,
             d->sigma_range);
    return vm_denoise_bilateral(v, d->sigma_space, d->sigma_range, out, vm_cli_progress,
                                &d->quiet, err);
}

/* Reads the input, filters it and writes the NRRD, with a summary line unless quiet. */
static int denoise_run(denoise_args *d) {
    vm_volume v, out;
    int rc = vm_cli_input_read(&d->in, &v);
    if (rc) return rc;
    vm_error err;
    vm_error_clear(&err);
    vm_denoise_params def;
    if (vm_denoise_defaults(&v, &def, &err)) {
        vm_volume_free(&v);
        return vm_cli_fail_err(&err);
    }
    double t0 = vm_cli_clock();
    char used[256];
    vm_status st = denoise_filter(d, &v, &def, &out, used, sizeof used, &err);
    double seconds = vm_cli_clock() - t0;
    if (st) {
        vm_volume_free(&v);
        return vm_cli_fail_err(&err);
    }
    out.type = VM_SCALAR_FLOAT32;
    st = vm_volume_write_nrrd(d->out_path, &out, 1, &err);
    if (!st && !d->quiet)
        printf("%s: %lld x %lld x %lld, %s (noise estimate %.4g), %.2f s -> %s\n", d->in.path,
               (long long)v.dims[0], (long long)v.dims[1], (long long)v.dims[2], used,
               def.noise_sigma, seconds, d->out_path);
    vm_volume_free(&v);
    vm_volume_free(&out);
    if (st) return vm_cli_fail_err(&err);
    return VM_EXIT_OK;
}

/* volmesh denoise: an edge-keeping filter of a volume, written as NRRD. */
int vm_cmd_denoise(int argc, char **argv) {
    denoise_args d;
    memset(&d, 0, sizeof d);
    vm_cli_input_init(&d.in, "denoise");
    d.method = "bilateral";
    int help = 0;
    int rc = denoise_parse(&d, argc, argv, &help);
    if (rc || help) return rc;
    rc = denoise_check(&d);
    if (rc) return rc;
    return denoise_run(&d);
}
