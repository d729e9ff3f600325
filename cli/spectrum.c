/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/spectrum.c — `volmesh spectrum`: the contour spectrum of a volume as a table, CSV, SVG
 * plot or JSON, with suggested isovalues and material intervals (Bajaj et al. 1997). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

static const char *spectrum_help =
    "usage: volmesh spectrum IN [--n N] [--range A:B] [--csv FILE] [--svg FILE] [--json]\n"
    "\n"
    "Contour spectrum (Bajaj, Pascucci, Schikore 1997): for N isovalues v from the minimum to\n"
    "the maximum of the volume, the area of the isosurface f = v, the volume of f >= v, the\n"
    "integral of |grad f| over the isosurface and the number of connected components of\n"
    "f >= v (voxels joined through faces). Areas and volumes are in world units (spacing and\n"
    "direction applied). Prints a table, the suggested isovalues (boundaries between\n"
    "materials, where the mean gradient over the isosurface rises between two homogeneous\n"
    "ranges of values) and the intervals between them, ready for `volmesh mesh --range`.\n"
    "\n"
    "  --n N                   number of isovalues (2..1000000, default 256)\n"
    "  --range A:B             isovalues from A to B instead of min to max\n"
    "  --csv FILE              all N rows: isovalue,area,volume,gradient_integral,components\n"
    "  --svg FILE              plot of the curves (each scaled to its maximum) against the\n"
    "                          isovalue, with the suggested isovalues marked\n"
    "  --json                  print one JSON object (arrays, suggestions, intervals) instead\n"
    "                          of the table\n"
    "  --quiet                 no progress bar\n"
    "raw files (no header): --raw-dims NXxNYxNZ --raw-type T --raw-endian E\n"
    "                       --raw-spacing SX,SY,SZ --raw-origin X,Y,Z --raw-header N\n"
    "input: --series UID|N (DICOM series) --spacing SX,SY,SZ (replaces the file's)\n";

/* ---- CSV ---------------------------------------------------------------------------------- */

static void write_csv(FILE *fp, const vm_spectrum *s) {
    fprintf(fp, "isovalue,area,volume,gradient_integral,components\n");
    for (int k = 0; k < s->n; k++)
        fprintf(fp, "%.9g,%.9g,%.9g,%.9g,%lld\n", s->isovalue[k], s->area[k], s->volume[k],
                s->gradient_integral[k], (long long)s->components[k]);
}

/* ---- JSON --------------------------------------------------------------------------------- */

static void json_string(FILE *fp, const char *str) {
    fputc('"', fp);
    for (const unsigned char *c = (const unsigned char *)str; *c; c++) {
        if (*c == '"' || *c == '\\')
            fprintf(fp, "\\%c", *c);
        else if (*c < 0x20)
            fprintf(fp, "\\u%04x", *c);
        else
            fputc(*c, fp);
    }
    fputc('"', fp);
}

static void json_number(FILE *fp, double x) {
    if (isfinite(x))
        fprintf(fp, "%.10g", x);
    else
        fputs("null", fp);
}

static void json_array(FILE *fp, const char *name, const double *x, int n) {
    fprintf(fp, ", \"%s\": [", name);
    for (int k = 0; k < n; k++) {
        if (k) fputs(", ", fp);
        json_number(fp, x[k]);
    }
    fputc(']', fp);
}

/* One member of a JSON object: a number, or a count when is_count. */
typedef struct {
    const char *key;
    double x;
    long long count;
    int is_count;
} json_field;

/* Writes {"key": value, ...} (after ", " when not first in its array). */
static void json_object(FILE *fp, int after, const json_field *f, size_t n) {
    fputs(after ? ", {" : "{", fp);
    for (size_t i = 0; i < n; i++) {
        fprintf(fp, "%s\"%s\": ", i ? ", " : "", f[i].key);
        if (f[i].is_count)
            fprintf(fp, "%lld", f[i].count);
        else
            json_number(fp, f[i].x);
    }
    fputc('}', fp);
}

/* --json: the whole spectrum as one object on one line. */
static void write_json(FILE *fp, const char *path, const vm_spectrum *s) {
    fputs("{\"file\": ", fp);
    json_string(fp, path);
    fprintf(fp, ", \"n\": %d, \"lo\": ", s->n);
    json_number(fp, s->lo);
    fputs(", \"hi\": ", fp);
    json_number(fp, s->hi);
    fputs(", \"value_min\": ", fp);
    json_number(fp, s->value_min);
    fputs(", \"value_max\": ", fp);
    json_number(fp, s->value_max);
    fputs(", \"total_volume\": ", fp);
    json_number(fp, s->total_volume);
    fprintf(fp, ", \"seconds\": %.4f", s->seconds);
    json_array(fp, "isovalue", s->isovalue, s->n);
    json_array(fp, "area", s->area, s->n);
    json_array(fp, "volume", s->volume, s->n);
    json_array(fp, "gradient_integral", s->gradient_integral, s->n);
    fputs(", \"components\": [", fp);
    for (int k = 0; k < s->n; k++) fprintf(fp, "%s%lld", k ? ", " : "", (long long)s->components[k]);
    fputs("], \"suggestions\": [", fp);
    for (int q = 0; q < s->n_suggestions; q++) {
        const vm_spectrum_suggestion *g = &s->suggestions[q];
        const json_field f[] = {{"isovalue", g->isovalue, 0, 0},
                                {"mean_gradient", g->mean_gradient, 0, 0},
                                {"area", g->area, 0, 0},
                                {"components", 0, (long long)g->components, 1},
                                {"strength", g->strength, 0, 0}};
        json_object(fp, q > 0, f, sizeof f / sizeof f[0]);
    }
    fputs("], \"intervals\": [", fp);
    for (int q = 0; q < s->n_intervals; q++) {
        const vm_spectrum_interval *iv = &s->intervals[q];
        const json_field f[] = {{"lo", iv->lo, 0, 0},
                                {"hi", iv->hi, 0, 0},
                                {"volume", iv->volume, 0, 0},
                                {"center", iv->center, 0, 0}};
        json_object(fp, q > 0, f, sizeof f / sizeof f[0]);
    }
    fputs("]}\n", fp);
}

/* ---- SVG plot ----------------------------------------------------------------------------- */

/* Tick spacing of about `want` intervals over span: 1, 2 or 5 times a power of ten. */
static double nice_step(double span, int want) {
    double raw = span / want, p = pow(10.0, floor(log10(raw))), f = raw / p;
    return (f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0) * p;
}

static void xml_text(FILE *fp, const char *str) {
    for (const unsigned char *c = (const unsigned char *)str; *c; c++) {
        if (*c == '<')
            fputs("&lt;", fp);
        else if (*c == '>')
            fputs("&gt;", fp);
        else if (*c == '&')
            fputs("&amp;", fp);
        else if (*c == '"')
            fputs("&quot;", fp);
        else if (*c >= 0x20)
            fputc(*c, fp);
    }
}

static int write_svg(FILE *fp, const char *path, const vm_spectrum *s) {
    const double W = 880, H = 520, L = 70, R = 250, T = 50, B = 60;
    const double pw = W - L - R, ph = H - T - B;
    double *mg = malloc((size_t)s->n * sizeof *mg), *comp = malloc((size_t)s->n * sizeof *comp);
    if (!mg || !comp) {
        free(mg);
        free(comp);
        return -1; /* out of memory */
    }
    for (int k = 0; k < s->n; k++) {
        mg[k] = s->area[k] > 0 ? s->gradient_integral[k] / s->area[k] : 0.0;
        comp[k] = (double)s->components[k];
    }
    struct {
        const char *name, *color, *dash;
        const double *y;
    } curves[] = {{"area", "#1f77b4", "", s->area},
                  {"volume", "#2ca02c", "", s->volume},
                  {"gradient integral", "#ff7f0e", "", s->gradient_integral},
                  {"mean gradient", "#d62728", "6,3", mg},
                  {"components", "#9467bd", "2,2", comp}};
    const int ncurves = (int)(sizeof curves / sizeof curves[0]);
    fprintf(fp, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
                "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" "
                "viewBox=\"0 0 %g %g\" font-family=\"sans-serif\" font-size=\"12\">\n",
            W, H, W, H);
    fprintf(fp, "<rect width=\"%g\" height=\"%g\" fill=\"white\"/>\n", W, H);
    fputs("<text x=\"70\" y=\"28\" font-size=\"15\">Contour spectrum of ", fp);
    xml_text(fp, path);
    fputs("</text>\n", fp);
#define XP(v) (L + ((v) - s->lo) / (s->hi - s->lo) * pw)
#define YP(f) (T + ph - (f) * ph)
    /* Intervals between suggestions, shaded alternately. */
    for (int q = 0; q < s->n_intervals; q++)
        if (q % 2)
            fprintf(fp, "<rect x=\"%.2f\" y=\"%g\" width=\"%.2f\" height=\"%g\" "
                        "fill=\"#f2f2f2\"/>\n",
                    XP(s->intervals[q].lo), T, XP(s->intervals[q].hi) - XP(s->intervals[q].lo),
                    ph);
    /* Axes, ticks and grid. */
    double step = nice_step(s->hi - s->lo, 8);
    for (double v = ceil(s->lo / step) * step; v <= s->hi + 1e-9 * step; v += step) {
        double x = XP(v);
        fprintf(fp, "<line x1=\"%.2f\" y1=\"%g\" x2=\"%.2f\" y2=\"%g\" stroke=\"#ddd\"/>\n", x, T,
                x, T + ph);
        fprintf(fp, "<text x=\"%.2f\" y=\"%g\" text-anchor=\"middle\">%g</text>\n", x,
                T + ph + 18, fabs(v) < 1e-12 * step ? 0.0 : v);
    }
    for (int q = 0; q <= 4; q++) {
        double y = YP(q / 4.0);
        fprintf(fp, "<line x1=\"%g\" y1=\"%.2f\" x2=\"%g\" y2=\"%.2f\" stroke=\"#ddd\"/>\n", L, y,
                L + pw, y);
        fprintf(fp, "<text x=\"%g\" y=\"%.2f\" text-anchor=\"end\">%.2f</text>\n", L - 6, y + 4,
                q / 4.0);
    }
    fprintf(fp, "<rect x=\"%g\" y=\"%g\" width=\"%g\" height=\"%g\" fill=\"none\" "
                "stroke=\"black\"/>\n",
            L, T, pw, ph);
    fprintf(fp, "<text x=\"%g\" y=\"%g\" text-anchor=\"middle\">isovalue</text>\n", L + pw / 2,
            H - 15);
    fprintf(fp, "<text x=\"18\" y=\"%g\" text-anchor=\"middle\" "
                "transform=\"rotate(-90 18 %g)\">fraction of the curve's maximum</text>\n",
            T + ph / 2, T + ph / 2);
    /* Curves, each scaled to its own maximum. */
    for (int c = 0; c < ncurves; c++) {
        double top = 0;
        for (int k = 0; k < s->n; k++) top = fmax(top, curves[c].y[k]);
        fprintf(fp, "<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.6\"%s%s%s points=\"",
                curves[c].color, curves[c].dash[0] ? " stroke-dasharray=\"" : "",
                curves[c].dash, curves[c].dash[0] ? "\"" : "");
        for (int k = 0; k < s->n; k++)
            fprintf(fp, "%s%.2f,%.2f", k ? " " : "", XP(s->isovalue[k]),
                    YP(top > 0 ? curves[c].y[k] / top : 0.0));
        fputs("\"/>\n", fp);
        double ly = T + 10 + 22 * c;
        fprintf(fp, "<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"%s\" "
                    "stroke-width=\"2\"%s%s%s/>\n",
                W - R + 15, ly, W - R + 45, ly, curves[c].color,
                curves[c].dash[0] ? " stroke-dasharray=\"" : "", curves[c].dash,
                curves[c].dash[0] ? "\"" : "");
        fprintf(fp, "<text x=\"%g\" y=\"%g\">%s (max %.4g)</text>\n", W - R + 52, ly + 4,
                curves[c].name, top);
    }
    /* Suggested isovalues. */
    double ly = T + 10 + 22 * ncurves + 10;
    fprintf(fp, "<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"black\" "
                "stroke-dasharray=\"4,4\"/>\n",
            W - R + 15, ly, W - R + 45, ly);
    fprintf(fp, "<text x=\"%g\" y=\"%g\">suggested isovalue</text>\n", W - R + 52, ly + 4);
    for (int q = 0; q < s->n_suggestions; q++) {
        double x = XP(s->suggestions[q].isovalue);
        fprintf(fp, "<line x1=\"%.2f\" y1=\"%g\" x2=\"%.2f\" y2=\"%g\" stroke=\"black\" "
                    "stroke-dasharray=\"4,4\"/>\n",
                x, T, x, T + ph);
        fprintf(fp, "<text x=\"%.2f\" y=\"%g\" text-anchor=\"middle\">%.4g</text>\n", x, T - 6,
                s->suggestions[q].isovalue);
    }
#undef XP
#undef YP
    fputs("</svg>\n", fp);
    free(mg);
    free(comp);
    return 0;
}

/* ---- text --------------------------------------------------------------------------------- */

static void write_table(FILE *fp, const char *path, const vm_spectrum *s) {
    fprintf(fp, "%s: contour spectrum, %d isovalues from %.6g to %.6g (%.2f s)\n", path, s->n,
            s->lo, s->hi, s->seconds);
    fprintf(fp, "%12s %12s %12s %14s %10s %10s\n", "isovalue", "area", "volume",
            "grad integral", "mean grad", "components");
    int rows = s->n < 17 ? s->n : 17;
    for (int r = 0; r < rows; r++) {
        int k = (int)((double)r * (s->n - 1) / (rows - 1) + 0.5);
        double mg = s->area[k] > 0 ? s->gradient_integral[k] / s->area[k] : 0.0;
        fprintf(fp, "%12.6g %12.6g %12.6g %14.6g %10.4g %10lld\n", s->isovalue[k], s->area[k],
                s->volume[k], s->gradient_integral[k], mg, (long long)s->components[k]);
    }
    if (s->n_suggestions == 0) {
        fprintf(fp, "no suggested isovalues: the mean gradient over the isosurfaces shows no "
                    "homogeneous materials\n");
    } else {
        fprintf(fp, "suggested isovalues (boundaries between materials):\n");
        for (int q = 0; q < s->n_suggestions; q++) {
            const vm_spectrum_suggestion *g = &s->suggestions[q];
            fprintf(fp, "  %-12.6g area %-11.5g mean gradient %-10.4g components %-6lld "
                        "strength %.2f\n",
                    g->isovalue, g->area, g->mean_gradient, (long long)g->components,
                    g->strength);
        }
    }
    fprintf(fp, "intervals (material classes; mesh one with volmesh mesh IN -o OUT.vtu "
                "--range A:B):\n");
    for (int q = 0; q < s->n_intervals; q++) {
        const vm_spectrum_interval *iv = &s->intervals[q];
        char range[80], cls[64];
        snprintf(range, sizeof range, "%.6g:%.6g", iv->lo, iv->hi);
        if (isnan(iv->center))
            snprintf(cls, sizeof cls, "no homogeneous class");
        else
            snprintf(cls, sizeof cls, "class at %.5g", iv->center);
        fprintf(fp, "  %-24s volume %-12.5g %s\n", range, iv->volume, cls);
    }
}

/* ---- the command -------------------------------------------------------------------------- */

/* --range A:B: both bounds, A < B. */
static int parse_range(const char *s, double *lo, double *hi) {
    const char *colon = strchr(s, ':');
    char a[128];
    size_t la = colon ? (size_t)(colon - s) : 0;
    if (!colon || la == 0 || la >= sizeof a || !colon[1])
        return vm_cli_fail("--range: '%s' is not A:B", s);
    memcpy(a, s, la);
    a[la] = '\0';
    if (vm_cli_double("--range", a, lo) || vm_cli_double("--range", colon + 1, hi))
        return VM_EXIT_INPUT;
    if (!(*lo < *hi)) return vm_cli_fail("--range: '%s' is empty (need A < B)", s);
    return 0;
}

/* What `volmesh spectrum` takes from its command line. */
typedef struct {
    vm_cli_input in;
    const char *csv, *svg;
    long n;
    int json, quiet, has_range;
    double lo, hi;
} spectrum_args;

/* One option a of those with a value (--n, --range, --csv, --svg), with its value val. */
static int spectrum_value(spectrum_args *p, const char *a, const char *val) {
    if (strcmp(a, "--n") == 0) {
        if (vm_cli_int(a, val, 2, 1000000, &p->n)) return VM_EXIT_INPUT;
    } else if (strcmp(a, "--range") == 0) {
        if (parse_range(val, &p->lo, &p->hi)) return VM_EXIT_INPUT;
        p->has_range = 1;
    } else if (strcmp(a, "--csv") == 0) {
        p->csv = val;
    } else {
        p->svg = val;
    }
    return VM_EXIT_OK;
}

/* Reads the command line into p; *help 1 when --help was printed. */
static int spectrum_parse(spectrum_args *p, int argc, char **argv, int *help) {
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(spectrum_help, stdout);
            *help = 1;
            return VM_EXIT_OK;
        }
        if (strcmp(a, "--json") == 0) {
            p->json = 1;
        } else if (strcmp(a, "--quiet") == 0) {
            p->quiet = 1;
        } else if (strcmp(a, "--n") == 0 || strcmp(a, "--range") == 0 ||
                   strcmp(a, "--csv") == 0 || strcmp(a, "--svg") == 0) {
            if (vm_cli_need_value("spectrum", i, argc, argv)) return VM_EXIT_INPUT;
            int rc = spectrum_value(p, a, argv[++i]);
            if (rc) return rc;
        } else {
            int taken, rc = vm_cli_input_arg(&p->in, argc, argv, &i, &taken);
            if (rc) return rc;
            if (!taken)
                return vm_cli_fail("spectrum: unknown option %s (see volmesh spectrum --help)",
                                   a);
        }
    }
    return vm_cli_input_given(&p->in);
}

/* Without --range: the isovalues span v's finite values, which must not be constant. */
static int value_range(spectrum_args *p, const vm_volume *v) {
    if (p->has_range) return VM_EXIT_OK;
    vm_volume_stats(v, &p->lo, &p->hi, NULL);
    if (!isfinite(p->lo)) return vm_cli_fail("%s: the volume has no finite sample", p->in.path);
    if (!(p->hi > p->lo))
        return vm_cli_fail("%s: the volume is constant (every sample is %g): it has no "
                           "isosurfaces and no spectrum",
                           p->in.path, p->lo);
    return VM_EXIT_OK;
}

/* The --csv file's and the --svg file's contents (vm_output_write's callbacks). */
typedef struct {
    const char *path; /* the input, named in the plot */
    const char *out;  /* the file written */
    const vm_spectrum *s;
} spectrum_file;

static int csv_contents(FILE *fp, void *user, vm_error *err) {
    (void)err;
    write_csv(fp, ((const spectrum_file *)user)->s);
    return 0;
}

static int svg_contents(FILE *fp, void *user, vm_error *err) {
    const spectrum_file *f = user;
    if (write_svg(fp, f->path, f->s) == 0) return 0;
    vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for the plot", f->out);
    return -1;
}

/* Writes the --csv and --svg files asked for: both, or (on any failure or a signal) none. */
static int write_files(const spectrum_args *p, const vm_spectrum *s) {
    const char *files[2] = {p->csv, p->svg};
    vm_output_write_fn fns[2] = {csv_contents, svg_contents};
    vm_error err;
    vm_error_clear(&err);
    vm_status st = VM_OK;
    for (int f = 0; f < 2 && !st; f++)
        if (files[f]) st = vm_output_hold(files[f], &err);
    for (int f = 0; f < 2 && !st; f++) {
        if (!files[f]) continue;
        spectrum_file sf = {p->in.path, files[f], s};
        st = vm_output_write(files[f], fns[f], &sf, &err);
    }
    if (st) {
        vm_output_discard();
        return vm_cli_fail_err(&err);
    }
    if (vm_output_commit(&err)) return vm_cli_fail_err(&err);
    return VM_EXIT_OK;
}

/* volmesh spectrum: the contour spectrum of a volume, its files and its table or JSON. */
int vm_cmd_spectrum(int argc, char **argv) {
    spectrum_args p;
    memset(&p, 0, sizeof p);
    vm_cli_input_init(&p.in, "spectrum");
    p.n = 256;
    int help = 0;
    int rc = spectrum_parse(&p, argc, argv, &help);
    if (rc || help) return rc;
    static const char *const csv[] = {".csv", NULL}, *const svg[] = {".svg", NULL};
    if ((p.csv && vm_cli_output_check("--csv", p.csv, csv)) ||
        (p.svg && vm_cli_output_check("--svg", p.svg, svg)))
        return VM_EXIT_INPUT;
    vm_volume v;
    rc = vm_cli_input_read(&p.in, &v);
    if (rc) return rc;
    rc = value_range(&p, &v);
    if (rc) {
        vm_volume_free(&v);
        return rc;
    }
    vm_error err;
    vm_error_clear(&err);
    vm_spectrum s;
    vm_status st = vm_spectrum_compute_range(&v, (int)p.n, p.lo, p.hi, vm_cli_progress,
                                             &p.quiet, &s, &err);
    vm_volume_free(&v);
    if (st) {
        vm_spectrum_free(&s);
        return vm_cli_fail("%s: %s", p.in.path, err.message);
    }
    rc = write_files(&p, &s);
    if (rc == VM_EXIT_OK) {
        if (p.json)
            write_json(stdout, p.in.path, &s);
        else
            write_table(stdout, p.in.path, &s);
    }
    vm_spectrum_free(&s);
    return rc;
}
