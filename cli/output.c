/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/output.c — what every command prints besides its results: error lines, the status
 * line and progress bar on a terminal, --verbose stage times, the JSON summary's opening. */
#define _POSIX_C_SOURCE 200809L
#include <stdarg.h>
#include <time.h>
#include <unistd.h>
#include "cli.h"

/* Prints "volmesh: MESSAGE" on stderr; the exit code of bad input. */
int vm_cli_fail(const char *fmt, ...) {
    va_list ap;
    fputs("volmesh: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return VM_EXIT_INPUT;
}

/* A library error as "volmesh: MESSAGE" (the status's name when it carries no message). */
int vm_cli_fail_err(const vm_error *err) {
    return vm_cli_fail("%s", err->message[0] ? err->message : vm_status_string(err->status));
}

/* Shows "WHAT NAME ..." on a terminal until vm_cli_status_clear. */
void vm_cli_status(const char *what, const char *name, int quiet) {
    if (quiet || !isatty(2)) return;
    fprintf(stderr, "\r\033[K%s %s ...", what, name);
    fflush(stderr);
}

/* Erases the status line of vm_cli_status. */
void vm_cli_status_clear(int quiet) {
    if (quiet || !isatty(2)) return;
    fputs("\r\033[K", stderr);
    fflush(stderr);
}

/* Progress callback of the library's stages: a 30-column bar and a percentage on stderr. */
void vm_cli_progress(const char *stage, double done, double total, void *user) {
    int quiet = user ? *(const int *)user : 0;
    if (quiet || !isatty(2) || total <= 0) return;
    int width = 30, fill = (int)(width * (done / total) + 0.5);
    if (fill > width) fill = width;
    fprintf(stderr, "\r%-12s [%.*s%*s] %3d%%", stage, fill, "##############################",
            width - fill, "", (int)(100.0 * done / total + 0.5));
    if (done >= total) fputs("\r\033[K", stderr);
    fflush(stderr);
}

/* Seconds on a monotonic clock, for the times a command reports. */
double vm_cli_clock(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* --verbose: "volmesh: STAGE  SECONDS s" on stderr. */
void vm_cli_stage_line(int verbose, const char *stage, double seconds) {
    if (verbose) fprintf(stderr, "volmesh: %-8s %8.3f s\n", stage, seconds);
}

/* --verbose: the time since *t as the line of stage; *t becomes now. */
void vm_cli_stage_done(int verbose, const char *stage, double *t) {
    double now = vm_cli_clock();
    vm_cli_stage_line(verbose, stage, now - *t);
    *t = now;
}

/* The opening of a mesh summary in JSON, naming the file written. */
void vm_cli_json_summary_open(const char *out) {
    printf("{\"output\": \"%s\", ", out);
}
