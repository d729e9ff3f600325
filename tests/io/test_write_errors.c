/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_write_errors.c — errors say why (issue 31, item 8): a failed write names the
 * system's reason and leaves no file; a truncated file with a large header is "truncated",
 * not "out of memory", under an address-space limit (ulimit -v); messages stay on one line. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include "test.h"

/* A tet mesh of n^3 cubes split in 6 (about 150 KB as VTU without compression for n = 12). */
static void cube_mesh(vm_mesh *m, int n) {
    vm_mesh_init(m, VM_TET4);
    for (int k = 0; k <= n; k++)
        for (int j = 0; j <= n; j++)
            for (int i = 0; i <= n; i++) {
                double p[3] = {i, j, k};
                vm_mesh_add_point(m, p, NULL);
            }
    static const int kuhn[6][4] = {{0, 1, 3, 7}, {0, 1, 5, 7}, {0, 2, 3, 7},
                                   {0, 2, 6, 7}, {0, 4, 5, 7}, {0, 4, 6, 7}};
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                for (int t = 0; t < 6; t++) {
                    vm_index c[4];
                    for (int v = 0; v < 4; v++) {
                        int b = kuhn[t][v];
                        c[v] = (vm_index)((i + (b & 1)) + (n + 1) * ((j + (b >> 1 & 1)) +
                                                                    (n + 1) * (k + (b >> 2))));
                    }
                    vm_mesh_add_cell(m, c, 1, NULL);
                }
}

static void aFailedWriteNamesTheReasonAndLeavesNoFile(void) {
    vm_mesh m;
    cube_mesh(&m, 12);
    const char *path = vm_test_tmp("too_large.vtu");
    remove(path);
    /* a file size limit (RLIMIT_FSIZE) makes write() fail with EFBIG once SIGXFSZ is ignored */
    struct rlimit old, small;
    CHECK(getrlimit(RLIMIT_FSIZE, &old) == 0);
    small = old;
    small.rlim_cur = 16384;
    signal(SIGXFSZ, SIG_IGN);
    CHECK(setrlimit(RLIMIT_FSIZE, &small) == 0);
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.compress = 0;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_mesh_write_as(path, &m, &o, &err);
    setrlimit(RLIMIT_FSIZE, &old);
    signal(SIGXFSZ, SIG_DFL);
    CHECK_MSG(st == VM_ERR_IO && strstr(err.message, "File too large"), "%d %s", (int)st,
              err.message);
    CHECK(!vm_test_exists(path));
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    CHECK(!vm_test_exists(tmp));
    vm_mesh_free(&m);
}

/* Reads path in a child limited to 1 GiB of address space: 0 when refused as truncated. */
static int truncated_under_a_memory_limit(const char *path) {
    pid_t pid = fork();
    if (pid == 0) {
        struct rlimit lim = {(rlim_t)1 << 30, (rlim_t)1 << 30};
        setrlimit(RLIMIT_AS, &lim);
        vm_volume v;
        vm_error err;
        vm_error_clear(&err);
        vm_status st = vm_volume_read(path, &v, &err);
        if (st == VM_ERR_FORMAT && strstr(err.message, "truncated")) _exit(0);
        fprintf(stderr, "  %s: status %d: %s\n", path, (int)st, err.message);
        _exit(1);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

static void aTruncatedFileIsTruncatedNotOutOfMemory(void) {
    if (getenv("VM_SANITIZED")) { /* ASan reserves terabytes of address space */
        vm_test_skip("an address-space limit does not go with the sanitizers");
        return;
    }
    static const struct {
        const char *name, *text;
    } files[] = {
        {"trunc_ascii.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n"
                            "DIMENSIONS 1000 1000 1000\nSPACING 1 1 1\nORIGIN 0 0 0\n"
                            "POINT_DATA 1000000000\nSCALARS s unsigned_char 1\n"
                            "LOOKUP_TABLE default\n1 2 3\n"},
        {"trunc_ascii.vti",
         "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\">\n<ImageData "
         "WholeExtent=\"0 999 0 999 0 999\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n<Piece "
         "Extent=\"0 999 0 999 0 999\"><PointData Scalars=\"s\"><DataArray type=\"UInt8\" "
         "Name=\"s\" format=\"ascii\">1 2 3</DataArray></PointData></Piece></ImageData>"
         "</VTKFile>\n"},
        {"trunc_b64.vti",
         "<?xml version=\"1.0\"?>\n<VTKFile type=\"ImageData\" version=\"1.0\">\n<ImageData "
         "WholeExtent=\"0 999 0 999 0 999\" Origin=\"0 0 0\" Spacing=\"1 1 1\">\n<Piece "
         "Extent=\"0 999 0 999 0 999\"><PointData Scalars=\"s\"><DataArray type=\"UInt8\" "
         "Name=\"s\" format=\"binary\">AAAAAAAAAAAA</DataArray></PointData></Piece>"
         "</ImageData></VTKFile>\n"},
    };
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        const char *path = vm_test_tmp(files[f].name);
        CHECK(vm_test_write_file(path, files[f].text, strlen(files[f].text)) == 0);
        CHECK_MSG(truncated_under_a_memory_limit(path) == 0, "%s", files[f].name);
    }
}

static void messagesStayOnOneLine(void) {
    const char *path = vm_test_tmp("newline.vtu");
    const char *text = "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\">\n"
                       "<UnstructuredGrid><Piece NumberOfPoints=\"1\" NumberOfCells=\"0\">\n"
                       "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" "
                       "format=\"asc\nii\">0 0 0</DataArray></Points>\n"
                       "</Piece></UnstructuredGrid></VTKFile>\n";
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
    vm_mesh m;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_mesh_read(path, &m, &err);
    CHECK(st != VM_OK);
    CHECK_MSG(!strchr(err.message, '\n') && strstr(err.message, "asc?ii"), "%s", err.message);
    if (!st) vm_mesh_free(&m);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"aFailedWriteNamesTheReasonAndLeavesNoFile", aFailedWriteNamesTheReasonAndLeavesNoFile},
        {"aTruncatedFileIsTruncatedNotOutOfMemory", aTruncatedFileIsTruncatedNotOutOfMemory},
        {"messagesStayOnOneLine", messagesStayOnOneLine},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
