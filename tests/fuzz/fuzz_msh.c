/* tests/fuzz/fuzz_msh.c — fuzz target for the .msh mesh reader (vm_mesh_read_msh): the input
 * becomes a .msh file, is read, checked (every node index in range) and freed. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>
#include "test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    static char path[4096];
    if (!path[0]) {
        /* Keep a lying count from asking for more than a fuzzing run should allocate. */
        setenv("VOLMESH_MAX_MEMORY", "268435456", 0);
        char unique[64];
        snprintf(unique, sizeof unique, "fuzz_msh_%ld.msh", (long)getpid());
        snprintf(path, sizeof path, "%s", vm_test_tmp(unique));
    }
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_mesh m;
    vm_error err;
    if (vm_mesh_read_msh(path, &m, &err) == VM_OK) {
        size_t nn = (size_t)vm_cell_nodes(m.kind);
        for (size_t i = 0; i < m.ncells * nn; i++)
            if (m.cells[i] < 0 || (size_t)m.cells[i] >= m.npoints) abort();
        volatile double sum = 0;
        for (size_t i = 0; i < 3 * m.npoints; i++)
            sum += m.points[i];
        (void)sum;
        vm_mesh_free(&m);
    }
    return 0;
}
