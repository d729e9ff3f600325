/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_writers.c — fuzz target for the mesh writers (issue 31): the first 8 bytes
 * pick the format (.vtu .vtk .inp .msh .msh2 .mesh .stl .off .ply .obj .bdf .k .mphtxt .feb),
 * the element kind, the counts, ASCII or binary, second order, an analysis deck and the
 * fields; the rest gives the points (small integers, with zero-length and huge coordinates
 * and NaN now and then) and the cells' nodes (one past the last point now and then). Every
 * write ends with VM_OK or a one-line refusal and leaves no temporary file; a VTU of a valid
 * mesh reads back with its counts and coordinates. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"

enum { OPTION_BYTES = 8 };

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < OPTION_BYTES) return 0;
    static const char *const exts[] = {".vtu", ".vtk", ".inp", ".msh", ".msh2", ".mesh", ".stl",
                                       ".off", ".ply", ".obj", ".bdf", ".k", ".mphtxt", ".feb"};
    static const vm_cell_kind kinds[4] = {VM_TET4, VM_HEX8, VM_TRI3, VM_QUAD4};
    const char *ext = exts[data[0] % (sizeof exts / sizeof exts[0])];
    vm_cell_kind kind = kinds[data[1] % 4];
    size_t np = 1 + data[2] % 48, nn = (size_t)vm_cell_nodes(kind);
    int flags = data[3];
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    wo.ascii = flags & 1;
    wo.order = flags & 2 ? 2 : 1;
    wo.deck = flags & 4 ? VM_DECK_STATIC : VM_DECK_NONE;
    wo.compress = !(flags & 8);
    int special = data[4]; /* which coordinates are out of the ordinary */
    const uint8_t *p = data + OPTION_BYTES, *end = data + size;

    vm_error err;
    vm_error_clear(&err);
    vm_mesh m;
    vm_mesh_init(&m, kind);
    int valid = 1; /* every node in range, every coordinate finite */
    for (size_t i = 0; i < np; i++) {
        double x[3];
        for (int a = 0; a < 3; a++) {
            x[a] = p < end ? (double)(int8_t)*p++ / 4.0 : 0.0;
            if ((special & 0x0f) == 1 + i % 15 && a == special >> 6) {
                static const double odd[4] = {1e29, 5e-324, -0.0, NAN};
                x[a] = odd[(special >> 4) & 3];
                if (isnan(x[a])) valid = 0;
            }
        }
        if (vm_mesh_add_point(&m, x, &err) < 0) abort();
    }
    while (end - p >= (ptrdiff_t)nn) {
        vm_index n[8];
        for (size_t k = 0; k < nn; k++) {
            n[k] = (vm_index)(*p++ % (np + 1));
            if ((size_t)n[k] == np) valid = 0;
        }
        if (vm_mesh_add_cell(&m, n, (int32_t)(data[5] % 4), &err) != VM_OK) abort();
    }
    if (flags & 16 && m.ncells) {
        double *f = calloc(m.ncells, sizeof *f);
        if (!f) abort();
        for (size_t c = 0; c < m.ncells; c++) f[c] = (double)c / 3.0;
        if (vm_mesh_set_field(&m, 1, "value", 1, f, &err) != VM_OK) abort();
        free(f);
    }

    static char out[4096];
    char name[64];
    snprintf(name, sizeof name, "fuzz_w_%ld%s", (long)getpid(), ext);
    snprintf(out, sizeof out, "%s", vm_test_tmp(name));
    vm_status st = vm_mesh_write_as(out, &m, &wo, &err);
    if (st != VM_OK && (!err.message[0] || strchr(err.message, '\n'))) abort();
    if (st != VM_OK && vm_test_exists(out)) abort(); /* a refusal leaves no file */
    if (st == VM_OK && valid && m.ncells && wo.order == 1 && strcmp(ext, ".vtu") == 0) {
        vm_mesh back;
        if (vm_mesh_read(out, &back, &err) != VM_OK) abort();
        if (back.ncells != m.ncells || back.npoints != m.npoints ||
            memcmp(back.points, m.points, 3 * m.npoints * sizeof *m.points) != 0)
            abort();
        vm_mesh_free(&back);
    }
    remove(out);
    vm_mesh_free(&m);
    return 0;
}
