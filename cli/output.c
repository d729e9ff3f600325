/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/output.c — what every command prints besides its results: error lines, the status
 * line and progress bar on a terminal, --verbose stage times, the JSON summary's opening. */
#define _POSIX_C_SOURCE 200809L
#include <stdarg.h>
#include <string.h>
#include <strings.h>
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
int vm_cli_progress(const char *stage, double done, double total, void *user) {
    int quiet = user ? *(const int *)user : 0;
    if (quiet || !isatty(2) || total <= 0) return 0;
    int width = 30, fill = (int)(width * (done / total) + 0.5);
    if (fill > width) fill = width;
    fprintf(stderr, "\r%-12s [%.*s%*s] %3d%%", stage, fill, "##############################",
            width - fill, "", (int)(100.0 * done / total + 0.5));
    if (done >= total) fputs("\r\033[K", stderr);
    fflush(stderr);
    return 0;
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

/* 1 when s ends with tail, ignoring case. */
static int has_tail(const char *s, const char *tail) {
    size_t n = strlen(s), t = strlen(tail);
    return n >= t && strcasecmp(s + n - t, tail) == 0;
}

/* An output checked before any work: its extension, a place it can be written. */
int vm_cli_output_check(const char *opt, const char *path, const char *const *tails) {
    if (tails) {
        int ok = 0;
        for (size_t i = 0; tails[i] && !ok; i++) ok = has_tail(path, tails[i]);
        if (!ok) {
            char list[128] = "";
            for (size_t i = 0; tails[i]; i++)
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s",
                         i ? " " : "", tails[i]);
            return vm_cli_fail("%s: %s writes %s: name the file so", path, opt, list);
        }
    }
    vm_error err;
    vm_error_clear(&err);
    if (vm_output_check(path, &err)) return vm_cli_fail_err(&err);
    return VM_EXIT_OK;
}

/* What a run that holds outputs prints on stdout (its summary) waits in an anonymous file
 * until the outputs are committed: a run whose outputs fail prints no summary of a mesh it
 * did not save. saved_stdout is the real stdout meanwhile; -1 when not capturing. */
static int saved_stdout = -1;
static FILE *captured;

static void stdout_capture(void) {
    if (saved_stdout >= 0) return;
    fflush(stdout);
    FILE *t = tmpfile(); /* unlinked at once: nothing to remove after a signal */
    if (!t) return;      /* the summary is printed as it comes */
    int fd = dup(STDOUT_FILENO);
    if (fd < 0 || dup2(fileno(t), STDOUT_FILENO) < 0) {
        if (fd >= 0) close(fd);
        fclose(t);
        return;
    }
    saved_stdout = fd;
    captured = t;
}

/* Ends the capture: what was printed goes to the real stdout when keep, is dropped otherwise. */
static void stdout_release(int keep) {
    if (saved_stdout < 0) return;
    fflush(stdout);
    dup2(saved_stdout, STDOUT_FILENO);
    close(saved_stdout);
    saved_stdout = -1;
    if (keep) {
        rewind(captured);
        char buf[8192];
        size_t n;
        while ((n = fread(buf, 1, sizeof buf, captured)) > 0) fwrite(buf, 1, n, stdout);
        fflush(stdout);
    }
    fclose(captured);
    captured = NULL;
}

/* An output of the run, checked before any work and held until vm_cli_outputs_end. */
int vm_cli_output(const char *opt, const char *path, const char *const *tails) {
    int rc = vm_cli_output_check(opt, path, tails);
    if (rc) return rc;
    vm_error err;
    vm_error_clear(&err);
    if (vm_output_hold(path, &err)) return vm_cli_fail_err(&err);
    stdout_capture();
    return VM_EXIT_OK;
}

/* The end of a run: its held outputs renamed when it succeeded (or wrote a mesh it warns
 * about, exit 1), removed otherwise; then the summary printed meanwhile, only when every
 * output was renamed. */
int vm_cli_outputs_end(int rc) {
    if (rc != VM_EXIT_OK && rc != VM_EXIT_CHECK) {
        vm_output_discard();
        stdout_release(0);
        return rc;
    }
    vm_error err;
    vm_error_clear(&err);
    if (vm_output_commit(&err)) {
        stdout_release(0);
        return vm_cli_fail_err(&err);
    }
    stdout_release(1);
    return rc;
}

int vm_cli_compress(const char *s, int *out) {
    vm_compress c;
    if (!vm_compress_parse(s, &c))
        return vm_cli_fail("--compress: '%s' is not fast, best or none", s);
    *out = (int)c;
    return VM_EXIT_OK;
}

/* The opening of a mesh summary in JSON, naming the file written. */
void vm_cli_json_summary_open(const char *out) {
    printf("{\"output\": \"%s\", ", out);
}
