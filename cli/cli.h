/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/cli.h — shared pieces of the volmesh program's subcommands. */
#ifndef VM_CLI_H
#define VM_CLI_H

#include <stdio.h>
#include "volmesh/volmesh.h"

/* Exit codes (DESIGN.md): 0 ok, 1 a requested check failed, 2 bad input or usage. */
enum { VM_EXIT_OK = 0, VM_EXIT_CHECK = 1, VM_EXIT_INPUT = 2 };

/* Helpers return 0 or, after printing why, the exit code to return (VM_EXIT_INPUT); the
 * predicates vm_cli_is and vm_cli_ends_with return 1 or 0. */

/* ---- cli/output.c: messages, status line, progress bar, stage times ---- */

/* Prints "volmesh: MESSAGE" on stderr and returns VM_EXIT_INPUT. */
int vm_cli_fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* Prints err's message as "volmesh: ..." and returns VM_EXIT_INPUT. */
int vm_cli_fail_err(const vm_error *err);

/* For a stage whose length is not known in advance (writing a file, the final checks): on a
 * terminal and unless quiet, shows "WHAT NAME ..." on stderr until vm_cli_status_clear. */
void vm_cli_status(const char *what, const char *name, int quiet);
void vm_cli_status_clear(int quiet);

/* Progress callback drawing a bar on stderr when it is a terminal (user: quiet flag). */
int vm_cli_progress(const char *stage, double done, double total, void *user);

/* Seconds on a monotonic clock (differences only). */
double vm_cli_clock(void);

/* --verbose: prints "volmesh: STAGE  SECONDS s" on stderr when verbose. */
void vm_cli_stage_line(int verbose, const char *stage, double seconds);

/* --verbose: prints stage's line with the time since *t, then sets *t to now. */
void vm_cli_stage_done(int verbose, const char *stage, double *t);

/* An output file (option opt, e.g. "--report"), checked before the input is read: its name
 * ends with one of tails (case-insensitive; NULL: any), and vm_output_check. Returns 0, or
 * prints and returns VM_EXIT_INPUT. */
int vm_cli_output_check(const char *opt, const char *path, const char *const *tails);

/* vm_cli_output_check, then holds path (vm_output_hold) so that all the outputs of the run
 * are renamed together by vm_cli_outputs_end. From then on, stdout (the summary) is kept
 * back until vm_cli_outputs_end. */
int vm_cli_output(const char *opt, const char *path, const char *const *tails);

/* Ends a run whose exit code is rc: commits the held outputs when rc is 0 or 1 (and returns
 * VM_EXIT_INPUT if a rename fails), removes them otherwise. What the run printed on stdout
 * since its first vm_cli_output is printed only when every output was renamed. Returns the
 * exit code. */
int vm_cli_outputs_end(int rc);

/* Prints the opening of a mesh summary in JSON: {"output": "OUT", (the fields follow). */
void vm_cli_json_summary_open(const char *out);

/* --compress's value s (fast, best or none) into *out (a vm_compress): 0, or prints
 * "volmesh: --compress: 'S' is not fast, best or none" and returns VM_EXIT_INPUT. */
int vm_cli_compress(const char *s, int *out);

/* ---- cli/args.c: flags, numbers, option values, the input volume ---- */

/* 1 when argument a equals one of the given flag spellings (flag2 may be NULL). */
int vm_cli_is(const char *a, const char *flag1, const char *flag2);

/* 0 when option argv[i] of command cmd has a value after it. Otherwise prints
 * "volmesh: CMD: OPT needs a value" (naming the option that stands where the value should,
 * e.g. "--labels -o x.vtu") and returns VM_EXIT_INPUT. A value may start with '-' when a digit
 * or '.' follows (negative numbers) or when it is "-" alone. */
int vm_cli_need_value(const char *cmd, int i, int argc, char **argv);

/* Parses a number argument s of option opt into *out: 0, or prints and returns
 * VM_EXIT_INPUT (not a finite number; not a whole number from lo to hi). */
int vm_cli_double(const char *opt, const char *s, double *out);
int vm_cli_int(const char *opt, const char *s, long lo, long hi, long *out);

/* 1 when s ends with tail, ignoring case (".nrrd" matches "A.NRRD"). */
int vm_cli_ends_with(const char *s, const char *tail);

/* For a mesh that could not be read from path: when path is an image volume (a volume
 * extension, or legacy VTK image data), says so and how to mesh it; otherwise prints err.
 * Returns VM_EXIT_INPUT. */
int vm_cli_fail_mesh_read(const char *path, const vm_error *err);

/* The input of a command that reads one volume: the file, and how to read it when raw. */
typedef struct {
    const char *cmd;    /* the command, in messages */
    const char *path;   /* the input file; NULL until given */
    vm_raw_options raw; /* the --raw-* options (--raw-dims NXxNYxNZ --raw-type T
                         * --raw-endian big|little --raw-spacing SX,SY,SZ --raw-origin X,Y,Z
                         * --raw-header N) */
    int is_raw;         /* 1 once a --raw-* option is given: the file is raw data */
    const char *series; /* --series UID|N: the DICOM series to read (NULL: the most slices) */
    int has_spacing;    /* --spacing X,Y,Z given: replaces the file's spacing */
    double spacing[3];
} vm_cli_input;

/* [out] in: no file yet, raw defaults (uint8, little-endian); cmd names the command. */
void vm_cli_input_init(vm_cli_input *in, const char *cmd);

/* Takes argv[*i] when it is a --raw-* option, --series or --spacing (with its value: *i
 * advances) or the input file: *taken 1. Any other option is left to the command: *taken 0. Returns 0, or prints
 * and returns VM_EXIT_INPUT (a bad raw value, a second input file). */
int vm_cli_input_arg(vm_cli_input *in, int argc, char **argv, int *i, int *taken);

/* 0 when an input file was given, else prints "CMD: no input file ..." and returns
 * VM_EXIT_INPUT. */
int vm_cli_input_given(const vm_cli_input *in);

/* 0 unless the input is raw without --raw-dims: then prints and returns VM_EXIT_INPUT. */
int vm_cli_input_check_raw(const vm_cli_input *in);

/* The raw description of the input, or NULL when its file has a header. */
const vm_raw_options *vm_cli_input_raw(const vm_cli_input *in);

/* [out] o: how to read the input (raw description, series, spacing); points into in. */
void vm_cli_input_options(const vm_cli_input *in, vm_volume_read_options *o);

/* Reads the input volume ([out] v, free it with vm_volume_free): 0, or prints and returns
 * VM_EXIT_INPUT (raw without --raw-dims, a read error). A DICOM input read without --series
 * that holds other series gets a note on stderr listing them (vm_cli_input_note_series). */
int vm_cli_input_read(const vm_cli_input *in, vm_volume *v);

/* After the input was read as format (v->format): when it is DICOM, no --series was given
 * and the path holds more than one series, prints on stderr which series was read and the
 * others (UID, description, slices) with how to choose one. */
void vm_cli_input_note_series(const vm_cli_input *in, const char *format);
/* The isosurface a mesh is measured against by `quality` and `report`: --volume FILE with
 * --iso V (--invert: f <= V) or --range A:B, as `mesh` takes them. */
typedef struct {
    const char *volume; /* NULL: no distance asked */
    double lo, hi;
    int has_lo, has_hi;
    int have_iso, have_range, invert;
} vm_cli_surface;

/* [out] s: nothing asked. */
void vm_cli_surface_init(vm_cli_surface *s);

/* Takes argv[*i] when it is --volume, --iso, --range or --invert (with its value: *i
 * advances): *taken 1; else *taken 0. Returns 0, or prints and returns VM_EXIT_INPUT. */
int vm_cli_surface_arg(vm_cli_surface *s, const char *cmd, int argc, char **argv, int *i,
                       int *taken);

/* 0 when the options go together (--volume with exactly one of --iso and --range, and they
 * only with it); else prints and returns VM_EXIT_INPUT. --invert turns --iso V into f <= V. */
int vm_cli_surface_check(vm_cli_surface *s, const char *cmd);

/* Reads s->volume and measures the distance between m's boundary and its isosurface into
 * *d: 0, or prints and returns VM_EXIT_INPUT. */
int vm_cli_surface_measure(const vm_cli_surface *s, const vm_mesh *m, vm_surface_distance *d,
                           int quiet);

/* ---- the commands (cli/CMD.c) and what they share ---- */

int vm_cmd_info(int argc, char **argv);
int vm_cmd_mesh(int argc, char **argv);
int vm_cmd_demo(int argc, char **argv);
int vm_cmd_report(int argc, char **argv);

/* Writes the HTML quality report of m to path (name shown in it); returns an exit code.
 * check: m's vm_mesh_check when the caller has it (not run again), else NULL. dist: the
 * distance to the isosurface when measured (shown in the report), else NULL. Bars for the
 * check and the metrics and a status line while drawing, on a terminal and unless quiet. */
int vm_cli_write_report(const char *path, const vm_mesh *m, const char *name,
                        const vm_mesh_report *check, const vm_surface_distance *dist,
                        int quiet);

/* What a mesher adds to the report (not owned): the regions asked for (those missing are
 * listed) and warnings, one line each (what was not kept). */
typedef struct vm_cli_report_notes {
    const int32_t *regions;
    size_t nregions;
    const char *const *warnings;
    size_t nwarnings;
} vm_cli_report_notes;

/* vm_cli_write_report with notes (NULL: none). */
int vm_cli_write_report_with(const char *path, const vm_mesh *m, const char *name,
                             const vm_mesh_report *check, const vm_surface_distance *dist,
                             const vm_cli_report_notes *notes, int quiet);
int vm_cmd_quality(int argc, char **argv);
int vm_cmd_convert(int argc, char **argv);
int vm_cmd_denoise(int argc, char **argv);
int vm_cmd_spectrum(int argc, char **argv);

/* Prints the one-line summary (or JSON) of a mesh already checked (checked: its
 * vm_mesh_check report); returns an exit code. dist: the distance to the isosurface, when
 * measured (a second line, or the JSON key surface_distance), else NULL. */
int vm_cli_report_checked(const vm_mesh *m, const vm_mesh_report *checked,
                          const vm_mesh_stats *st, const vm_surface_distance *dist, int json,
                          const char *out);

/* --labels: "all" gives *labels NULL and *n 0, else the listed labels ("1,3,7", "2-5");
 * [out] *labels malloc'd. Returns 0, or prints and returns VM_EXIT_INPUT. */
int vm_cli_parse_labels(const char *s, int32_t **labels, size_t *n);

/* --size-per-label "3:0.5,7:2": [out] *sizes malloc'd (free it), *n entries. Returns 0, or
 * prints and returns VM_EXIT_INPUT (malformed list, size not positive). */
int vm_cli_parse_label_sizes(const char *s, vm_label_size **sizes, size_t *n);

/* --label-edge "3=0.8,7=4" (world units): [out] *edges malloc'd (free it), *n entries.
 * Returns 0, or prints one line and returns VM_EXIT_INPUT (malformed list, an edge that is
 * not a length > 0). */
int vm_cli_parse_label_edges(const char *s, vm_label_edge **edges, size_t *n);

/* Meshes the labels of v, runs the per-material quality pass on tets when improve, writes
 * out (and surface, the HTML report html, when not NULL) and prints the summary with one line
 * per label; in names the input in messages; verbose: stage times on stderr. Exit code. */
int vm_cli_mesh_labels(const vm_volume *v, const char *in, const char *out, const char *surface,
                       const vm_label_options *lo, const vm_mesh_write_options *wo, int json,
                       int quality_fields, const char *html, int improve, int verbose);

/* --elements tri|quad: extracts the surface of v's material with so, writes it to out with
 * wo and prints the summary line (or JSON); in names the input in messages. Exit code. */
int vm_cli_mesh_surface(const vm_volume *v, const char *in, const char *out,
                        const vm_surface_options *so, const vm_mesh_write_options *wo, int json,
                        int quality_fields);

/* Prints the volume summary (text or JSON) for `info` and `demo`. */
void vm_cli_print_info(FILE *out, const char *path, const vm_volume *v, int json);

#endif
