/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/args.c — the command line pieces every command shares: flags, numbers, option values,
 * the input volume (a file, or raw data described by the --raw-* options). */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

/* 1 when argument a equals one of the given flag spellings. */
int vm_cli_is(const char *a, const char *flag1, const char *flag2) {
    return (flag1 && strcmp(a, flag1) == 0) || (flag2 && strcmp(a, flag2) == 0);
}

/* A finite number for option opt. */
int vm_cli_double(const char *opt, const char *s, double *out) {
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end || errno == ERANGE || !isfinite(v))
        return vm_cli_fail("%s: '%s' is not a number", opt, s);
    *out = v;
    return VM_EXIT_OK;
}

/* A whole number from lo to hi for option opt. */
int vm_cli_int(const char *opt, const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (end == s || *end || errno == ERANGE || v < lo || v > hi)
        return vm_cli_fail("%s: '%s' is not a whole number from %ld to %ld", opt, s, lo, hi);
    *out = v;
    return VM_EXIT_OK;
}

/* 1 when s ends with tail, ignoring case. */
int vm_cli_ends_with(const char *s, const char *tail) {
    size_t n = strlen(s), t = strlen(tail);
    if (n < t) return 0;
    for (size_t i = 0; i < t; i++)
        if (tolower((unsigned char)s[n - t + i]) != tolower((unsigned char)tail[i])) return 0;
    return 1;
}

/* Option argv[i] of cmd has a value after it (not another option). */
int vm_cli_need_value(const char *cmd, int i, int argc, char **argv) {
    const char *opt = argv[i];
    if (i + 1 >= argc) return vm_cli_fail("%s: %s needs a value", cmd, opt);
    const char *v = argv[i + 1];
    int looks_like_option =
        v[0] == '-' && v[1] != 0 && !isdigit((unsigned char)v[1]) && v[1] != '.';
    if (looks_like_option)
        return vm_cli_fail("%s: %s needs a value (found the option '%s' in its place)",
                           cmd, opt, v);
    return VM_EXIT_OK;
}

/* A mesh that could not be read: an image volume is named as one, with how to mesh it. */
int vm_cli_fail_mesh_read(const char *path, const vm_error *err) {
    static const char *const volume_tails[] = {".nrrd", ".nhdr", ".nii", ".nii.gz", ".hdr",
                                               ".img",  ".mha",  ".mhd", ".vti",    ".raw",
                                               ".tif",  ".tiff", ".inr", ".inr.gz"};
    int volume = strstr(err->message, "STRUCTURED_POINTS") != NULL;
    for (size_t i = 0; i < sizeof volume_tails / sizeof volume_tails[0]; i++)
        volume |= vm_cli_ends_with(path, volume_tails[i]);
    if (!volume) return vm_cli_fail_err(err);
    return vm_cli_fail("%s: this is an image volume, not a mesh: mesh it first "
                       "(volmesh mesh %s --iso V -o OUT.vtu)",
                       path, path);
}

/* --raw-dims NXxNYxNZ: three positive sizes. */
static int raw_dims(const char *val, vm_raw_options *raw) {
    long long d[3];
    char tail;
    if (sscanf(val, "%lldx%lldx%lld%c", &d[0], &d[1], &d[2], &tail) != 3 || d[0] < 1 ||
        d[1] < 1 || d[2] < 1)
        return vm_cli_fail("--raw-dims: '%s' is not NXxNYxNZ with positive sizes", val);
    for (int k = 0; k < 3; k++) raw->dims[k] = d[k];
    return VM_EXIT_OK;
}

/* --raw-spacing or --raw-origin X,Y,Z (spacings positive). */
static int raw_triple(const char *a, const char *val, vm_raw_options *raw) {
    double *dst = strcmp(a, "--raw-spacing") == 0 ? raw->spacing : raw->origin;
    char tail;
    if (sscanf(val, "%lf,%lf,%lf%c", &dst[0], &dst[1], &dst[2], &tail) != 3)
        return vm_cli_fail("%s: '%s' is not X,Y,Z", a, val);
    if (dst == raw->spacing && !(dst[0] > 0 && dst[1] > 0 && dst[2] > 0))
        return vm_cli_fail("--raw-spacing: spacings must be positive");
    return VM_EXIT_OK;
}

/* One --raw-* option a with its value val. */
static int raw_option(const char *a, const char *val, vm_raw_options *raw) {
    if (strcmp(a, "--raw-dims") == 0) return raw_dims(val, raw);
    if (strcmp(a, "--raw-type") == 0) {
        if (vm_scalar_type_parse(val, &raw->type) != 0)
            return vm_cli_fail("--raw-type: unknown type '%s'", val);
    } else if (strcmp(a, "--raw-endian") == 0) {
        if (strcmp(val, "big") == 0)
            raw->big_endian = 1;
        else if (strcmp(val, "little") == 0)
            raw->big_endian = 0;
        else
            return vm_cli_fail("--raw-endian: '%s' is not big or little", val);
    } else if (strcmp(a, "--raw-spacing") == 0 || strcmp(a, "--raw-origin") == 0) {
        return raw_triple(a, val, raw);
    } else if (strcmp(a, "--raw-header") == 0) {
        long n = 0;
        if (vm_cli_int(a, val, 0, 1L << 40, &n)) return VM_EXIT_INPUT;
        raw->header_bytes = (uint64_t)n;
    } else {
        return vm_cli_fail("unknown raw option %s", a);
    }
    return VM_EXIT_OK;
}

/* --spacing SX,SY,SZ: three finite spacings within the readers' limits. */
static int spacing_option(const char *val, vm_cli_input *in) {
    char tail;
    double *s = in->spacing;
    if (sscanf(val, "%lf,%lf,%lf%c", &s[0], &s[1], &s[2], &tail) != 3)
        return vm_cli_fail("--spacing: '%s' is not SX,SY,SZ", val);
    for (int a = 0; a < 3; a++)
        if (!(s[a] >= VM_SPACING_MIN && s[a] <= VM_SPACING_MAX))
            return vm_cli_fail("--spacing: '%s': each spacing must be a number from %g to %g",
                               val, VM_SPACING_MIN, VM_SPACING_MAX);
    in->has_spacing = 1;
    return VM_EXIT_OK;
}

/* No input yet, raw data of unsigned bytes unless --raw-type says otherwise. */
void vm_cli_input_init(vm_cli_input *in, const char *cmd) {
    memset(in, 0, sizeof *in);
    in->cmd = cmd;
    in->raw.type = VM_SCALAR_UINT8;
}

/* Takes argv[*i] when it is a --raw-* option (and its value) or the input file. */
int vm_cli_input_arg(vm_cli_input *in, int argc, char **argv, int *i, int *taken) {
    const char *a = argv[*i];
    *taken = 1;
    if (strncmp(a, "--raw-", 6) == 0) {
        if (vm_cli_need_value("raw input", *i, argc, argv)) return VM_EXIT_INPUT;
        in->is_raw = 1;
        return raw_option(a, argv[++*i], &in->raw);
    }
    if (strcmp(a, "--series") == 0 || strcmp(a, "--spacing") == 0) {
        if (vm_cli_need_value(in->cmd, *i, argc, argv)) return VM_EXIT_INPUT;
        const char *val = argv[++*i];
        if (a[3] == 'p') return spacing_option(val, in);
        if (!val[0]) return vm_cli_fail("--series: empty series");
        in->series = val;
        return VM_EXIT_OK;
    }
    if (a[0] == '-' && a[1]) {
        *taken = 0; /* an option: the command's, or unknown */
        return VM_EXIT_OK;
    }
    if (in->path)
        return vm_cli_fail("%s: more than one input file ('%s', '%s')", in->cmd, in->path, a);
    in->path = a;
    return VM_EXIT_OK;
}

/* After the options: an input file was given. */
int vm_cli_input_given(const vm_cli_input *in) {
    if (!in->path)
        return vm_cli_fail("%s: no input file (see volmesh %s --help)", in->cmd, in->cmd);
    return VM_EXIT_OK;
}

/* Raw input has its dimensions. */
int vm_cli_input_check_raw(const vm_cli_input *in) {
    if (in->is_raw && in->raw.dims[0] == 0)
        return vm_cli_fail("%s: raw input needs --raw-dims NXxNYxNZ", in->path);
    return VM_EXIT_OK;
}

/* The raw description to read in's file with, or NULL for a file with a header. */
const vm_raw_options *vm_cli_input_raw(const vm_cli_input *in) {
    return in->is_raw ? &in->raw : NULL;
}

/* How to read in's file: its raw description, series and spacing. */
void vm_cli_input_options(const vm_cli_input *in, vm_volume_read_options *o) {
    vm_volume_read_options_init(o);
    o->raw = vm_cli_input_raw(in);
    o->series = in->series;
    o->has_spacing = in->has_spacing;
    memcpy(o->spacing, in->spacing, sizeof o->spacing);
}

/* The default DICOM series was read: names it and the others, when there are others. */
void vm_cli_input_note_series(const vm_cli_input *in, const char *format) {
    if (in->series || in->is_raw || strcmp(format, "dicom") != 0) return;
    vm_dicom_series_info *list = NULL;
    size_t n = 0;
    vm_error err;
    vm_error_clear(&err);
    if (vm_dicom_list_series(in->path, &list, &n, &err) != VM_OK || n < 2) {
        vm_dicom_series_free(list);
        return;
    }
    fprintf(stderr, "volmesh: %s holds %zu DICOM series; read series 1 (%lld slices, "
            "UID %s); choose another with --series UID|N:\n", in->path, n,
            (long long)list[0].slices, list[0].uid);
    for (size_t i = 1; i < n; i++)
        fprintf(stderr, "volmesh:   %zu  %s  \"%s\"  %lld slice%s\n", i + 1, list[i].uid,
                list[i].description, (long long)list[i].slices, list[i].slices == 1 ? "" : "s");
    vm_dicom_series_free(list);
}

/* Reads the input volume (checked by vm_cli_input_check_raw first). */
int vm_cli_input_read(const vm_cli_input *in, vm_volume *v) {
    int rc = vm_cli_input_check_raw(in);
    if (rc) return rc;
    vm_error err;
    vm_error_clear(&err);
    vm_volume_read_options o;
    vm_cli_input_options(in, &o);
    if (vm_volume_read_with(in->path, &o, v, &err)) return vm_cli_fail_err(&err);
    vm_cli_input_note_series(in, v->format);
    return VM_EXIT_OK;
}

/* ---- the isosurface a mesh is measured against (quality, report) ---- */

void vm_cli_surface_init(vm_cli_surface *s) {
    memset(s, 0, sizeof *s);
}

int vm_cli_surface_arg(vm_cli_surface *s, const char *cmd, int argc, char **argv, int *i,
                       int *taken) {
    const char *a = argv[*i];
    *taken = 1;
    int valued = vm_cli_is(a, "--volume", NULL) || vm_cli_is(a, "--iso", NULL) ||
                 vm_cli_is(a, "--range", NULL);
    if (valued && vm_cli_need_value(cmd, *i, argc, argv)) return VM_EXIT_INPUT;
    if (vm_cli_is(a, "--volume", NULL)) {
        s->volume = argv[++*i];
    } else if (vm_cli_is(a, "--iso", NULL)) {
        s->have_iso = 1;
        s->has_lo = 1;
        s->has_hi = 0;
        return vm_cli_double("--iso", argv[++*i], &s->lo);
    } else if (vm_cli_is(a, "--range", NULL)) {
        const char *v = argv[++*i], *colon = strchr(v, ':');
        if (!colon) return vm_cli_fail("--range: '%s' is not A:B (either side may be empty)", v);
        char lo[128], hi[128];
        size_t la = (size_t)(colon - v);
        if (la >= sizeof lo || strlen(colon + 1) >= sizeof hi)
            return vm_cli_fail("--range: '%s' is too long", v);
        memcpy(lo, v, la);
        lo[la] = 0;
        strcpy(hi, colon + 1);
        s->have_range = 1;
        s->has_lo = lo[0] != 0;
        s->has_hi = hi[0] != 0;
        if (!s->has_lo && !s->has_hi)
            return vm_cli_fail("--range: give at least one bound (A: or :B)");
        if (s->has_lo && vm_cli_double("--range", lo, &s->lo)) return VM_EXIT_INPUT;
        if (s->has_hi && vm_cli_double("--range", hi, &s->hi)) return VM_EXIT_INPUT;
    } else if (vm_cli_is(a, "--invert", NULL)) {
        s->invert = 1;
    } else {
        *taken = 0;
    }
    return VM_EXIT_OK;
}

int vm_cli_surface_check(vm_cli_surface *s, const char *cmd) {
    if (!s->volume) {
        if (s->have_iso || s->have_range || s->invert)
            return vm_cli_fail("%s: --iso, --range and --invert go with --volume FILE", cmd);
        return VM_EXIT_OK;
    }
    if (s->have_iso + s->have_range != 1)
        return vm_cli_fail("%s: --volume needs exactly one of --iso V or --range A:B", cmd);
    if (s->invert && !s->have_iso) return vm_cli_fail("%s: --invert goes with --iso", cmd);
    if (s->invert) {
        s->has_lo = 0;
        s->has_hi = 1;
        s->hi = s->lo;
    }
    return VM_EXIT_OK;
}

int vm_cli_surface_measure(const vm_cli_surface *s, const vm_mesh *m, vm_surface_distance *d,
                           int quiet) {
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_cli_status("reading", s->volume, quiet);
    vm_status st = vm_volume_read(s->volume, &v, &err);
    vm_cli_status_clear(quiet);
    if (st) return vm_cli_fail_err(&err);
    vm_cli_status("measuring the distance to", s->volume, quiet);
    st = vm_mesh_surface_distance(m, &v, s->lo, s->has_lo, s->hi, s->has_hi, d, &err);
    vm_cli_status_clear(quiet);
    vm_volume_free(&v);
    if (st) return vm_cli_fail("%s: %s", s->volume, err.message);
    return VM_EXIT_OK;
}
