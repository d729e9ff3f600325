/* cli/info.c — `volmesh info`: what a volume file holds, as text or JSON. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static const char *info_help =
    "usage: volmesh info FILE [--json] [raw options]\n"
    "\n"
    "Prints format, dims, scalar type, spacing, origin, direction, min, max, mean and a\n"
    "16-bin histogram of a volume (.nrrd .nhdr .nii .nii.gz .hdr .img .mha .mhd .vtk .vti).\n"
    "\n"
    "  --json                  one JSON object (keys: file, format, dims, type, spacing,\n"
    "                          origin, direction, min, max, mean, histogram)\n"
    "raw files (no header):\n"
    "  --raw-dims NXxNYxNZ     dimensions (required for raw)\n"
    "  --raw-type T            uint8 int8 uint16 int16 uint32 int32 float32 float64 ...\n"
    "  --raw-endian E          little (default) or big\n"
    "  --raw-spacing SX,SY,SZ  voxel spacing (default 1,1,1)\n"
    "  --raw-origin X,Y,Z      world position of the first voxel (default 0,0,0)\n"
    "  --raw-header N          bytes to skip before the data\n";

int vm_cli_raw_option(int argc, char **argv, int *i, vm_raw_options *raw, int *is_raw) {
    const char *a = argv[*i];
    if (strncmp(a, "--raw-", 6) != 0) return 0;
    if (vm_cli_need_value("raw input", *i, argc, argv)) return -1;
    const char *val = argv[++*i];
    *is_raw = 1;
    if (strcmp(a, "--raw-dims") == 0) {
        long long d[3];
        char tail;
        if (sscanf(val, "%lldx%lldx%lld%c", &d[0], &d[1], &d[2], &tail) != 3 || d[0] < 1 ||
            d[1] < 1 || d[2] < 1) {
            vm_cli_fail("--raw-dims: '%s' is not NXxNYxNZ with positive sizes", val);
            return -1;
        }
        for (int k = 0; k < 3; k++) raw->dims[k] = d[k];
    } else if (strcmp(a, "--raw-type") == 0) {
        if (vm_scalar_type_parse(val, &raw->type) != 0) {
            vm_cli_fail("--raw-type: unknown type '%s'", val);
            return -1;
        }
    } else if (strcmp(a, "--raw-endian") == 0) {
        if (strcmp(val, "big") == 0)
            raw->big_endian = 1;
        else if (strcmp(val, "little") == 0)
            raw->big_endian = 0;
        else {
            vm_cli_fail("--raw-endian: '%s' is not big or little", val);
            return -1;
        }
    } else if (strcmp(a, "--raw-spacing") == 0 || strcmp(a, "--raw-origin") == 0) {
        double *dst = strcmp(a, "--raw-spacing") == 0 ? raw->spacing : raw->origin;
        char tail;
        if (sscanf(val, "%lf,%lf,%lf%c", &dst[0], &dst[1], &dst[2], &tail) != 3) {
            vm_cli_fail("%s: '%s' is not X,Y,Z", a, val);
            return -1;
        }
        if (dst == raw->spacing && !(dst[0] > 0 && dst[1] > 0 && dst[2] > 0)) {
            vm_cli_fail("--raw-spacing: spacings must be positive");
            return -1;
        }
    } else if (strcmp(a, "--raw-header") == 0) {
        long n;
        if (vm_cli_int(a, val, 0, 1L << 40, &n)) return -1;
        raw->header_bytes = (uint64_t)n;
    } else {
        vm_cli_fail("unknown raw option %s", a);
        return -1;
    }
    return 1;
}

int vm_cli_read_volume(const char *path, const vm_raw_options *raw, vm_volume *v) {
    vm_error err;
    vm_error_clear(&err);
    vm_status st = raw ? vm_volume_read_raw(path, raw, v, &err) : vm_volume_read(path, v, &err);
    if (st) return vm_cli_fail_err(&err);
    return VM_EXIT_OK;
}

static void histogram(const vm_volume *v, double lo, double hi, size_t bins[16]) {
    memset(bins, 0, 16 * sizeof bins[0]);
    size_t n = vm_volume_count(v);
    double w = hi > lo ? (hi - lo) / 16.0 : 1.0;
    for (size_t i = 0; i < n; i++) {
        float f = v->data[i];
        if (!isfinite(f)) continue;
        int b = (int)((f - lo) / w);
        if (b < 0) b = 0;
        if (b > 15) b = 15;
        bins[b]++;
    }
}

void vm_cli_print_info(FILE *out, const char *path, const vm_volume *v, int json) {
    double lo, hi, mean;
    size_t bad = vm_volume_stats(v, &lo, &hi, &mean);
    size_t bins[16];
    histogram(v, lo, hi, bins);
    if (json) {
        fprintf(out, "{\"file\": \"");
        for (const char *c = path; *c; c++) {
            if (*c == '"' || *c == '\\') fputc('\\', out);
            if ((unsigned char)*c >= 0x20) fputc(*c, out);
        }
        fprintf(out, "\", \"format\": \"%s\", \"dims\": [%lld, %lld, %lld], \"type\": \"%s\",",
                v->format, (long long)v->dims[0], (long long)v->dims[1], (long long)v->dims[2],
                vm_scalar_type_name(v->type));
        fprintf(out, " \"spacing\": [%.17g, %.17g, %.17g],", v->spacing[0], v->spacing[1],
                v->spacing[2]);
        fprintf(out, " \"origin\": [%.17g, %.17g, %.17g],", v->origin[0], v->origin[1],
                v->origin[2]);
        fprintf(out, " \"direction\": [");
        for (int r = 0; r < 3; r++)
            fprintf(out, "%s[%.17g, %.17g, %.17g]", r ? ", " : "", v->direction[r][0],
                    v->direction[r][1], v->direction[r][2]);
        fprintf(out, "], \"voxels\": %zu, \"nonfinite\": %zu,", vm_volume_count(v), bad);
        if (isfinite(lo))
            fprintf(out, " \"min\": %.17g, \"max\": %.17g, \"mean\": %.17g,", lo, hi, mean);
        else
            fprintf(out, " \"min\": null, \"max\": null, \"mean\": null,");
        fprintf(out, " \"histogram\": [");
        for (int b = 0; b < 16; b++) fprintf(out, "%s%zu", b ? ", " : "", bins[b]);
        fprintf(out, "]}\n");
        return;
    }
    fprintf(out, "file       %s\n", path);
    fprintf(out, "format     %s\n", v->format);
    fprintf(out, "dims       %lld x %lld x %lld (%zu voxels)\n", (long long)v->dims[0],
            (long long)v->dims[1], (long long)v->dims[2], vm_volume_count(v));
    fprintf(out, "type       %s\n", vm_scalar_type_name(v->type));
    fprintf(out, "spacing    %g %g %g\n", v->spacing[0], v->spacing[1], v->spacing[2]);
    fprintf(out, "origin     %g %g %g\n", v->origin[0], v->origin[1], v->origin[2]);
    for (int r = 0; r < 3; r++)
        fprintf(out, "%s %9.6f %9.6f %9.6f\n", r ? "          " : "direction ",
                v->direction[r][0], v->direction[r][1], v->direction[r][2]);
    fprintf(out, "min        %.9g\nmax        %.9g\nmean       %.9g\n", lo, hi, mean);
    if (bad) fprintf(out, "nonfinite  %zu voxels (NaN or infinite)\n", bad);
    size_t most = 1;
    for (int b = 0; b < 16; b++)
        if (bins[b] > most) most = bins[b];
    fprintf(out, "histogram\n");
    double w = (hi - lo) / 16.0;
    for (int b = 0; b < 16; b++) {
        int len = (int)(40.0 * (double)bins[b] / (double)most + 0.5);
        fprintf(out, "  %12.6g %10zu %.*s\n", lo + w * b, bins[b], len,
                "########################################");
    }
}

int vm_cmd_info(int argc, char **argv) {
    const char *path = NULL;
    int json = 0, is_raw = 0;
    vm_raw_options raw;
    memset(&raw, 0, sizeof raw);
    raw.type = VM_SCALAR_UINT8;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(info_help, stdout);
            return VM_EXIT_OK;
        }
        if (strcmp(a, "--json") == 0) {
            json = 1;
            continue;
        }
        int r = vm_cli_raw_option(argc, argv, &i, &raw, &is_raw);
        if (r < 0) return VM_EXIT_INPUT;
        if (r > 0) continue;
        if (a[0] == '-' && a[1]) return vm_cli_fail("info: unknown option %s", a);
        if (path) return vm_cli_fail("info: more than one input file ('%s', '%s')", path, a);
        path = a;
    }
    if (!path) return vm_cli_fail("info: no input file (see volmesh info --help)");
    if (is_raw && raw.dims[0] == 0)
        return vm_cli_fail("%s: raw input needs --raw-dims NXxNYxNZ", path);
    vm_volume v;
    int rc = vm_cli_read_volume(path, is_raw ? &raw : NULL, &v);
    if (rc) return rc;
    vm_cli_print_info(stdout, path, &v, json);
    vm_volume_free(&v);
    return VM_EXIT_OK;
}
