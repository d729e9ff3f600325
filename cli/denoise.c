/* cli/denoise.c — `volmesh denoise`: bilateral filter or anisotropic diffusion, written as
 * NRRD with the input's geometry. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
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
    "                       --raw-spacing SX,SY,SZ --raw-origin X,Y,Z --raw-header N\n";

static double now_seconds(void) {
    struct timespec ts;
    if (timespec_get(&ts, TIME_UTC) != TIME_UTC) return 0.0;
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int vm_cmd_denoise(int argc, char **argv) {
    const char *in_path = NULL, *out_path = NULL, *method = "bilateral";
    double sigma_space = 0, sigma_range = 0, kappa = 0, dt = 0;
    long iterations = 0;
    const char *bilateral_opt = NULL, *diffusion_opt = NULL;
    int quiet = 0, is_raw = 0;
    vm_raw_options raw;
    memset(&raw, 0, sizeof raw);
    raw.type = VM_SCALAR_UINT8;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(denoise_help, stdout);
            return VM_EXIT_OK;
        }
        if (strcmp(a, "--quiet") == 0) {
            quiet = 1;
            continue;
        }
        int r = vm_cli_raw_option(argc, argv, &i, &raw, &is_raw);
        if (r < 0) return VM_EXIT_INPUT;
        if (r > 0) continue;
        int takes_value = vm_cli_is(a, "-o", "--output") || strcmp(a, "--method") == 0 ||
                          strcmp(a, "--sigma-space") == 0 || strcmp(a, "--sigma-range") == 0 ||
                          strcmp(a, "--kappa") == 0 || strcmp(a, "--dt") == 0 ||
                          strcmp(a, "--iterations") == 0;
        if (takes_value) {
            if (vm_cli_need_value("denoise", i, argc, argv)) return VM_EXIT_INPUT;
            const char *val = argv[++i];
            if (vm_cli_is(a, "-o", "--output")) {
                out_path = val;
            } else if (strcmp(a, "--method") == 0) {
                if (strcmp(val, "bilateral") != 0 && strcmp(val, "diffusion") != 0)
                    return vm_cli_fail("--method: '%s' is not bilateral or diffusion", val);
                method = val;
            } else if (strcmp(a, "--iterations") == 0) {
                if (vm_cli_int(a, val, 1, 100000, &iterations)) return VM_EXIT_INPUT;
                diffusion_opt = a;
            } else {
                double x;
                if (vm_cli_double(a, val, &x)) return VM_EXIT_INPUT;
                if (!(x > 0)) return vm_cli_fail("%s: '%s' must be positive", a, val);
                if (strcmp(a, "--sigma-space") == 0) {
                    sigma_space = x;
                    bilateral_opt = a;
                } else if (strcmp(a, "--sigma-range") == 0) {
                    sigma_range = x;
                    bilateral_opt = a;
                } else if (strcmp(a, "--kappa") == 0) {
                    kappa = x;
                    diffusion_opt = a;
                } else {
                    dt = x;
                    diffusion_opt = a;
                }
            }
            continue;
        }
        if (a[0] == '-' && a[1])
            return vm_cli_fail("denoise: unknown option %s (see volmesh denoise --help)", a);
        if (in_path)
            return vm_cli_fail("denoise: more than one input file ('%s', '%s')", in_path, a);
        in_path = a;
    }
    if (!in_path) return vm_cli_fail("denoise: no input file (see volmesh denoise --help)");
    if (!out_path) return vm_cli_fail("denoise: no output file (-o OUT.nrrd)");
    if (!vm_cli_ends_with(out_path, ".nrrd"))
        return vm_cli_fail("%s: denoise writes NRRD; name the output *.nrrd", out_path);
    int diffusion = strcmp(method, "diffusion") == 0;
    if (diffusion && bilateral_opt)
        return vm_cli_fail("%s applies to --method bilateral, not diffusion", bilateral_opt);
    if (!diffusion && diffusion_opt)
        return vm_cli_fail("%s applies to --method diffusion (add --method diffusion)",
                           diffusion_opt);
    if (is_raw && raw.dims[0] == 0)
        return vm_cli_fail("%s: raw input needs --raw-dims NXxNYxNZ", in_path);

    vm_volume v, out;
    int rc = vm_cli_read_volume(in_path, is_raw ? &raw : NULL, &v);
    if (rc) return rc;
    vm_error err;
    vm_error_clear(&err);
    vm_denoise_params def;
    if (vm_denoise_defaults(&v, &def, &err)) {
        vm_volume_free(&v);
        return vm_cli_fail_err(&err);
    }
    double t0 = now_seconds();
    vm_status st;
    char used[256];
    if (diffusion) {
        if (kappa <= 0) kappa = def.kappa;
        if (dt <= 0) dt = def.dt;
        if (iterations <= 0) iterations = def.iterations;
        snprintf(used, sizeof used, "diffusion kappa %.4g dt %.4g (limit %.4g) iterations %ld",
                 kappa, dt, def.max_dt, iterations);
        st = vm_denoise_diffusion(&v, kappa, dt, (int)iterations, &out, vm_cli_progress, &quiet,
                                  &err);
    } else {
        if (sigma_space <= 0) sigma_space = def.sigma_space;
        if (sigma_range <= 0) sigma_range = def.sigma_range;
        snprintf(used, sizeof used, "bilateral sigma-space %.4g sigma-range %.4g", sigma_space,
                 sigma_range);
        st = vm_denoise_bilateral(&v, sigma_space, sigma_range, &out, vm_cli_progress, &quiet,
                                  &err);
    }
    double seconds = now_seconds() - t0;
    if (st) {
        vm_volume_free(&v);
        return vm_cli_fail_err(&err);
    }
    out.type = VM_SCALAR_FLOAT32;
    st = vm_volume_write_nrrd(out_path, &out, 1, &err);
    if (!st && !quiet)
        printf("%s: %lld x %lld x %lld, %s (noise estimate %.4g), %.2f s -> %s\n", in_path,
               (long long)v.dims[0], (long long)v.dims[1], (long long)v.dims[2], used,
               def.noise_sigma, seconds, out_path);
    vm_volume_free(&v);
    vm_volume_free(&out);
    if (st) return vm_cli_fail_err(&err);
    return VM_EXIT_OK;
}
