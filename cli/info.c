/* SPDX-License-Identifier: BSD-3-Clause */
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

/* A 16-bin histogram of v's finite values from lo to hi. */
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

/* volmesh info: prints what the volume file holds. */
int vm_cmd_info(int argc, char **argv) {
    vm_cli_input in;
    vm_cli_input_init(&in, "info");
    int json = 0;
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
        int taken, rc = vm_cli_input_arg(&in, argc, argv, &i, &taken);
        if (rc) return rc;
        if (!taken) return vm_cli_fail("info: unknown option %s", a);
    }
    int rc = vm_cli_input_given(&in);
    vm_volume v;
    if (!rc) rc = vm_cli_input_read(&in, &v);
    if (rc) return rc;
    vm_cli_print_info(stdout, in.path, &v, json);
    vm_volume_free(&v);
    return VM_EXIT_OK;
}
