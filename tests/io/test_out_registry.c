/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_out_registry.c — every temporary file a run makes is in the outputs' registry
 * (issue 31, items 6 and 7): a signal while vm_output_write fills a file, or while a
 * temporary file of the library's own (vm__temp_track: the report's inline SVG) exists,
 * removes it, exit 128 + the signal; held files written by vm_output_write are renamed
 * together by vm_output_commit, or all removed by vm_output_discard; a failing callback
 * leaves nothing. Each signal case runs in a child process (fork), which raises the signal. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>
#include "io/io_util.h"
#include "test.h"

static int count_text(FILE *fp, void *user, vm_error *err) {
    (void)err;
    fprintf(fp, "%s\n", (const char *)user);
    return 0;
}

static int failing(FILE *fp, void *user, vm_error *err) {
    (void)user;
    fputs("partial", fp);
    vm_error_set(err, VM_ERR_NOMEM, "out of memory for the test");
    return -1;
}

/* Raises the signal given (an int *) while the file is half written. */
static int raising(FILE *fp, void *user, vm_error *err) {
    (void)err;
    fputs("half", fp);
    fflush(fp);
    raise(*(int *)user);
    return 0;
}

/* The names in the test folder that start with prefix (their count). */
static int files_starting(const char *prefix) {
    char cmd[4400];
    snprintf(cmd, sizeof cmd, "ls -A '%s' | grep -c '^%s'", vm_test_tmp(""), prefix);
    FILE *p = popen(cmd, "r");
    int n = -1;
    if (p) {
        if (fscanf(p, "%d", &n) != 1) n = -1;
        pclose(p);
    }
    return n;
}

/* Runs body(arg) in a child that installed the signal handlers; its exit status. */
static int in_child(void (*body)(int), int arg) {
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        vm_output_remove_on_signals();
        body(arg);
        _exit(0);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static void child_write(int sig) {
    vm_error err;
    vm_error_clear(&err);
    vm_output_write(vm_test_tmp("regA.txt"), raising, &sig, &err);
}

static void child_held(int sig) {
    vm_error err;
    vm_error_clear(&err);
    vm_output_hold(vm_test_tmp("regB1.txt"), &err);
    vm_output_hold(vm_test_tmp("regB2.txt"), &err);
    vm_output_write(vm_test_tmp("regB1.txt"), count_text, "one", &err);
    vm_output_write(vm_test_tmp("regB2.txt"), raising, &sig, &err);
}

static void child_tracked(int sig) {
    const char *tmp = vm_test_tmp("regC.svg-1");
    FILE *fp = fopen(tmp, "w");
    if (fp) fclose(fp);
    vm__temp_track(tmp);
    raise(sig);
}

static void signal_while_writing_removes_the_temporary(void) {
    const int sigs[2] = {SIGTERM, SIGINT};
    for (int k = 0; k < 2; k++) {
        vm_test_write_file(vm_test_tmp("regA.txt"), "old\n", 4);
        int rc = in_child(child_write, sigs[k]);
        CHECK_MSG(rc == 128 + sigs[k], "exit %d after signal %d", rc, sigs[k]);
        CHECK(files_starting("regA.txt.tmp-") == 0);
        FILE *fp = fopen(vm_test_tmp("regA.txt"), "r");
        char line[8] = "";
        CHECK(fp && fgets(line, sizeof line, fp) && strcmp(line, "old\n") == 0);
        if (fp) fclose(fp);
    }
}

static void signal_removes_held_outputs(void) {
    int rc = in_child(child_held, SIGTERM);
    CHECK_MSG(rc == 143, "exit %d", rc);
    CHECK(files_starting("regB") == 0);
}

static void signal_removes_a_tracked_temporary(void) {
    int rc = in_child(child_tracked, SIGTERM);
    CHECK_MSG(rc == 143, "exit %d", rc);
    CHECK(!vm_test_exists(vm_test_tmp("regC.svg-1")));
}

static void held_writes_are_committed_together(void) {
    vm_error err;
    vm_error_clear(&err);
    const char *a = vm_test_tmp("regD1.txt"), *b = vm_test_tmp("regD2.txt");
    remove(a);
    remove(b);
    CHECK_OK(vm_output_hold(a, &err), &err);
    CHECK_OK(vm_output_hold(b, &err), &err);
    CHECK_OK(vm_output_write(a, count_text, "one", &err), &err);
    CHECK(!vm_test_exists(a)); /* held: under its temporary name */
    CHECK_OK(vm_output_write(b, count_text, "two", &err), &err);
    CHECK_OK(vm_output_commit(&err), &err);
    CHECK(vm_test_exists(a) && vm_test_exists(b));
    CHECK(files_starting("regD") == 2);
    remove(a);
    remove(b);
    /* a failure in the second: discard removes the first too */
    CHECK_OK(vm_output_hold(a, &err), &err);
    CHECK_OK(vm_output_hold(b, &err), &err);
    CHECK_OK(vm_output_write(a, count_text, "one", &err), &err);
    vm_status st = vm_output_write(b, failing, NULL, &err);
    CHECK(st == VM_ERR_NOMEM && strstr(err.message, "out of memory for the test"));
    vm_output_discard();
    CHECK(files_starting("regD") == 0);
}

static void failing_callback_leaves_nothing(void) {
    vm_error err;
    vm_error_clear(&err);
    const char *a = vm_test_tmp("regE.txt");
    vm_test_write_file(a, "old\n", 4);
    CHECK(vm_output_write(a, failing, NULL, &err) == VM_ERR_NOMEM);
    CHECK(files_starting("regE.txt.tmp-") == 0);
    CHECK(vm_test_exists(a));
    remove(a);
}

TEST_MAIN(T(signal_while_writing_removes_the_temporary), T(signal_removes_held_outputs),
          T(signal_removes_a_tracked_temporary), T(held_writes_are_committed_together),
          T(failing_callback_leaves_nothing))
