/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/info.c — `volmesh info`: what a volume file holds, as text or JSON. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static const char *info_help =
    "usage: volmesh info FILE|FOLDER [--json] [--series UID|N] [--spacing SX,SY,SZ]\n"
    "                               [raw options]\n"
    "\n"
    "Prints format, dims, scalar type, spacing, origin, direction, min, max, mean and a\n"
    "16-bin histogram of a volume (.nrrd .nhdr .nii .nii.gz .hdr .img .mha .mhd .vtk .vti\n"
    ".tif .tiff .inr .inr.gz, a folder of TIFF slices, DICOM files or folders). For DICOM,\n"
    "also every series found (number, UID, description, slices; * marks the one read).\n"
    "\n"
    "  --json                  one JSON object (keys: file, format, dims, type, spacing,\n"
    "                          origin, direction, min, max, mean, histogram; for DICOM\n"
    "                          also series: [{uid, description, modality, slices}])\n"
    "  --series UID|N          DICOM: the series to read, by SeriesInstanceUID or by its\n"
    "                          number in the list (default 1: the most slices)\n"
    "  --spacing SX,SY,SZ      voxel spacing replacing the file's (finite, 1e-09..1e+09;\n"
    "                          every command that reads a volume takes it)\n"
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

/* Writes s as a JSON string (quotes and backslashes escaped, control characters dropped). */
static void json_string(FILE *out, const char *s) {
    fputc('"', out);
    for (const char *c = s; *c; c++) {
        if (*c == '"' || *c == '\\') fputc('\\', out);
        if ((unsigned char)*c >= 0x20) fputc(*c, out);
    }
    fputc('"', out);
}

/* The DICOM series found beside the one read (which: its index in list). */
typedef struct series_list {
    const vm_dicom_series_info *list;
    size_t n, which;
} series_list;

/* The summary, with the series list when sl is not NULL. */
static void print_info(FILE *out, const char *path, const vm_volume *v, int json,
                       const series_list *sl) {
    double lo, hi, mean;
    size_t bad = vm_volume_stats(v, &lo, &hi, &mean);
    size_t bins[16];
    histogram(v, lo, hi, bins);
    if (json) {
        fprintf(out, "{\"file\": ");
        json_string(out, path);
        fprintf(out, ", \"format\": \"%s\", \"dims\": [%lld, %lld, %lld], \"type\": \"%s\",",
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
        fprintf(out, "]");
        if (sl) {
            fprintf(out, ", \"series\": [");
            for (size_t i = 0; i < sl->n; i++) {
                const vm_dicom_series_info *e = &sl->list[i];
                fprintf(out, "%s{\"number\": %zu, \"uid\": ", i ? ", " : "", i + 1);
                json_string(out, e->uid);
                fprintf(out, ", \"description\": ");
                json_string(out, e->description);
                fprintf(out, ", \"modality\": ");
                json_string(out, e->modality);
                fprintf(out, ", \"slices\": %lld, \"read\": %s}", (long long)e->slices,
                        i == sl->which ? "true" : "false");
            }
            fprintf(out, "]");
        }
        fprintf(out, "}\n");
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
    if (!sl) return;
    fprintf(out, "series     %zu DICOM series (* read; choose with --series UID|N)\n", sl->n);
    for (size_t i = 0; i < sl->n; i++) {
        const vm_dicom_series_info *e = &sl->list[i];
        fprintf(out, "  %c%3zu  %-4s %5lld slice%s  %s  \"%s\"\n", i == sl->which ? '*' : ' ',
                i + 1, e->modality, (long long)e->slices, e->slices == 1 ? " " : "s", e->uid,
                e->description);
    }
}

void vm_cli_print_info(FILE *out, const char *path, const vm_volume *v, int json) {
    print_info(out, path, v, json, NULL);
}

/* The index in list of the series that choice names (NULL: the first). */
static size_t series_index(const vm_dicom_series_info *list, size_t n, const char *choice) {
    if (!choice) return 0;
    size_t k = strspn(choice, "0123456789");
    if (choice[k] == 0) {
        unsigned long long i = strtoull(choice, NULL, 10);
        if (i >= 1 && i <= n) return (size_t)(i - 1);
    }
    for (size_t i = 0; i < n; i++)
        if (strcmp(list[i].uid, choice) == 0) return i;
    return 0;
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
    if (!rc) rc = vm_cli_input_check_raw(&in);
    if (rc) return rc;
    vm_volume v;
    vm_volume_read_options o;
    vm_cli_input_options(&in, &o);
    vm_error err;
    vm_error_clear(&err);
    if (vm_volume_read_with(in.path, &o, &v, &err)) return vm_cli_fail_err(&err);
    /* DICOM: every series under the path, listed on stdout (no note on stderr) */
    series_list sl = {NULL, 0, 0};
    vm_dicom_series_info *list = NULL;
    if (strcmp(v.format, "dicom") == 0 && !in.is_raw &&
        vm_dicom_list_series(in.path, &list, &sl.n, &err) == VM_OK) {
        sl.list = list;
        sl.which = series_index(list, sl.n, in.series);
    }
    print_info(stdout, in.path, &v, json, sl.list ? &sl : NULL);
    vm_dicom_series_free(list);
    vm_volume_free(&v);
    return VM_EXIT_OK;
}
