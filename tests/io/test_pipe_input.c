/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_pipe_input.c — a device or pipe as input is read only up to the memory limit
 * (issue 31, item 4): a volume file that links to /dev/zero is refused within half of
 * VOLMESH_MAX_MEMORY, quickly, instead of being read until the machine runs out of memory;
 * a pipe that ends is read as a file. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include "test.h"

/* A hang (an endless read) is a failure: the alarm ends the program. */
enum { DEADLINE_S = 60 };

static void aVolumeLinkedToDevZeroIsRefusedWithinTheMemoryLimit(void) {
    alarm(DEADLINE_S);
    setenv("VOLMESH_MAX_MEMORY", "67108864", 1); /* 64 MiB */
    static const char *const names[] = {"zero.nrrd", "zero.nii", "zero.mha", "zero.vtk",
                                        "zero.vti"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        const char *path = vm_test_tmp(names[i]);
        remove(path);
        CHECK(symlink("/dev/zero", path) == 0);
        vm_volume v;
        vm_error err;
        vm_error_clear(&err);
        vm_status st = vm_volume_read(path, &v, &err);
        CHECK_MSG(st == VM_ERR_NOMEM && strstr(err.message, "not a regular file") &&
                      strstr(err.message, "33554432"),
                  "%s: %d %s", names[i], (int)st, err.message);
        if (!st) vm_volume_free(&v);
        remove(path);
    }
    unsetenv("VOLMESH_MAX_MEMORY");
    alarm(0);
}

static void aPipeThatEndsIsReadAsAFile(void) {
    alarm(DEADLINE_S);
    const char *fifo = vm_test_tmp("pipe.vtk");
    remove(fifo);
    CHECK(mkfifo(fifo, 0600) == 0);
    static const char text[] = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
                               "DIMENSIONS 2 2 2\nSPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA 8\n"
                               "SCALARS s float 1\nLOOKUP_TABLE default\n0 1 2 3 4 5 6 7\n";
    pid_t pid = fork();
    if (pid == 0) {
        FILE *fp = fopen(fifo, "w");
        if (fp) {
            fputs(text, fp);
            fclose(fp);
        }
        _exit(0);
    }
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_volume_read(fifo, &v, &err);
    CHECK_OK(st, &err);
    if (!st) {
        CHECK(v.dims[0] == 2 && v.dims[2] == 2 && v.data[7] == 7.0f);
        vm_volume_free(&v);
    }
    waitpid(pid, NULL, 0);
    remove(fifo);
    alarm(0);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"aVolumeLinkedToDevZeroIsRefusedWithinTheMemoryLimit",
         aVolumeLinkedToDevZeroIsRefusedWithinTheMemoryLimit},
        {"aPipeThatEndsIsReadAsAFile", aPipeThatEndsIsReadAsAFile},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
