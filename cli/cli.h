/* cli/cli.h — shared pieces of the volmesh program's subcommands. */
#ifndef VM_CLI_H
#define VM_CLI_H

#include <stdio.h>
#include "volmesh/volmesh.h"

/* Exit codes (DESIGN.md): 0 ok, 1 a requested check failed, 2 bad input or usage. */
enum { VM_EXIT_OK = 0, VM_EXIT_CHECK = 1, VM_EXIT_INPUT = 2 };

/* Prints "volmesh: MESSAGE" on stderr and returns VM_EXIT_INPUT. */
int vm_cli_fail(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* Prints err's message as "volmesh: ..." and returns VM_EXIT_INPUT. */
int vm_cli_fail_err(const vm_error *err);

/* For a mesh that could not be read from path: when path is an image volume (a volume
 * extension, or legacy VTK image data), says so and how to mesh it; otherwise prints err.
 * Returns VM_EXIT_INPUT. */
int vm_cli_fail_mesh_read(const char *path, const vm_error *err);

/* 1 when argument a equals one of the given flag spellings. */
int vm_cli_is(const char *a, const char *flag1, const char *flag2);

/* 0 when option argv[i] of command cmd has a value after it. Otherwise prints
 * "volmesh: CMD: OPT needs a value" (naming the option that stands where the value should,
 * e.g. "--labels -o x.vtu") and returns VM_EXIT_INPUT. A value may start with '-' when a digit
 * or '.' follows (negative numbers) or when it is "-" alone. */
int vm_cli_need_value(const char *cmd, int i, int argc, char **argv);

/* Parses a number argument of option opt; on error prints and returns -1. */
int vm_cli_double(const char *opt, const char *s, double *out);
int vm_cli_int(const char *opt, const char *s, long lo, long hi, long *out);

/* 1 when s ends with tail, ignoring case (".nrrd" matches "A.NRRD"). */
int vm_cli_ends_with(const char *s, const char *tail);

/* For a stage whose length is not known in advance (writing a file, the final checks): on a
 * terminal and unless quiet, shows "WHAT NAME ..." on stderr until vm_cli_status_clear. */
void vm_cli_status(const char *what, const char *name, int quiet);
void vm_cli_status_clear(int quiet);

/* Progress callback drawing a bar on stderr when it is a terminal (user: quiet flag). */
void vm_cli_progress(const char *stage, double done, double total, void *user);

int vm_cmd_info(int argc, char **argv);
int vm_cmd_mesh(int argc, char **argv);
int vm_cmd_demo(int argc, char **argv);
int vm_cmd_report(int argc, char **argv);

/* Writes the HTML quality report of m to path (name shown in it); returns an exit code.
 * check: m's vm_mesh_check when the caller has it (not run again), else NULL. Bars for the
 * check and the metrics and a status line while drawing, on a terminal and unless quiet. */
int vm_cli_write_report(const char *path, const vm_mesh *m, const char *name,
                        const vm_mesh_report *check, int quiet);
int vm_cmd_quality(int argc, char **argv);
int vm_cmd_convert(int argc, char **argv);
int vm_cmd_denoise(int argc, char **argv);
int vm_cmd_spectrum(int argc, char **argv);

/* Reads a volume: a regular file by extension, or raw with the options already parsed. */
int vm_cli_read_volume(const char *path, const vm_raw_options *raw, vm_volume *v);

/* Parses the raw-file options (--raw-dims NXxNYxNZ --raw-type T --raw-endian big|little
 * --raw-spacing SX,SY,SZ --raw-header N) at argv[*i]; returns 1 when consumed, 0 when the
 * argument is not a raw option, -1 on error. */
int vm_cli_raw_option(int argc, char **argv, int *i, vm_raw_options *raw, int *is_raw);

/* Prints the one-line summary (or JSON) of a mesh already checked (checked: its
 * vm_mesh_check report); returns an exit code. */
int vm_cli_report_checked(const vm_mesh *m, const vm_mesh_report *checked,
                          const vm_mesh_stats *st, int json, const char *out);

/* --labels: "all" gives *labels NULL and *n 0, else the listed labels ("1,3,7", "2-5");
 * [out] *labels malloc'd. Returns 0, or prints and returns VM_EXIT_INPUT. */
int vm_cli_parse_labels(const char *s, int32_t **labels, size_t *n);

/* --size-per-label "3:0.5,7:2": [out] *sizes malloc'd (free it), *n entries. Returns 0, or
 * prints and returns VM_EXIT_INPUT (malformed list, size not positive). */
int vm_cli_parse_label_sizes(const char *s, vm_label_size **sizes, size_t *n);

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
