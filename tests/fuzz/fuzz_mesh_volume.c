/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/fuzz_mesh_volume.c — fuzz target for the whole pipeline on a small mutated
 * volume (issue 31): the first 8 bytes are the choices (dims 2..10 each, uint8 or float32
 * samples, the isovalue, anisotropic spacing up to 1:1:10, tets or hexes, adaptive, a
 * closed range, the quality pass, the output format), the rest the samples of a raw file.
 * It is read (vm_volume_read_raw), meshed (dual contouring), improved (tets) and written
 * (.vtu, .vtk, .inp, .msh or .mesh) then read back: each step ends with VM_OK or a one-line
 * refusal, never a crash or a hang; a tet mesh has no inverted tet, and the file read back
 * has the mesh's elements. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "test.h"

/* ctest executions: 300 */

enum { OPTION_BYTES = 8 };

static void one_line(vm_status st, const vm_error *err) {
    if (st != VM_OK && (!err->message[0] || strchr(err->message, '\n'))) abort();
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < OPTION_BYTES) return 0;
    static int once;
    if (!once) once = 1, vm_set_threads(1); /* thread start-ups would cost more than the work */
    vm_raw_options opt;
    memset(&opt, 0, sizeof opt);
    for (int a = 0; a < 3; a++) opt.dims[a] = 2 + data[a] % 9;
    int is_float = data[3] & 1;
    opt.type = is_float ? VM_SCALAR_FLOAT32 : VM_SCALAR_UINT8;
    static const double sz[4] = {1, 0.5, 3, 10}, sx[2] = {1, 2};
    opt.spacing[0] = sx[data[5] & 1];
    opt.spacing[1] = 1;
    opt.spacing[2] = sz[(data[5] >> 1) % 4];
    int flags = data[6];
    static const char *const exts[5] = {".vtu", ".vtk", ".inp", ".msh", ".mesh"};
    const char *ext = exts[data[7] % 5];

    static char in[4096], out[4096];
    char name[64];
    snprintf(name, sizeof name, "fuzz_mv_%ld.raw", (long)getpid());
    snprintf(in, sizeof in, "%s", vm_test_tmp(name));
    snprintf(name, sizeof name, "fuzz_mv_%ld%s", (long)getpid(), ext);
    snprintf(out, sizeof out, "%s", vm_test_tmp(name));
    if (vm_test_write_file(in, data + OPTION_BYTES, size - OPTION_BYTES) != 0) return 0;

    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    vm_status st = vm_volume_read_raw(in, &opt, &v, &err);
    remove(in);
    one_line(st, &err);
    if (st != VM_OK) return 0; /* too few samples for the dims, mostly */

    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = is_float ? (double)(int8_t)data[4] : (double)data[4];
    if (flags & 8) {
        o.has_hi = 1;
        o.hi = o.lo + 1 + (flags >> 5) * 16;
    }
    o.elements = flags & 1 ? VM_HEX8 : VM_TET4;
    o.adaptive = (flags >> 1) & 1;
    vm_mesh m;
    vm_mesh_init(&m, o.elements);
    st = vm_mesh_volume(&v, &o, &m, NULL, &err);
    one_line(st, &err);
    if (st == VM_OK && m.kind == VM_TET4) {
        vm_mesh_report r;
        if (vm_mesh_check(&m, &r, &err) == VM_OK && r.inverted) abort();
        if (flags & 4) {
            vm_improve_options io;
            vm_improve_options_default(&io);
            io.lo = o.lo, io.has_lo = 1, io.hi = o.hi, io.has_hi = o.has_hi;
            st = vm_mesh_improve(&m, &v, &io, NULL, &err);
            one_line(st, &err);
            if (st == VM_OK && vm_mesh_check(&m, &r, &err) == VM_OK && r.inverted) abort();
        }
    }
    if (st == VM_OK) {
        st = vm_mesh_write(out, &m, &err);
        one_line(st, &err);
        if (st == VM_OK) {
            vm_mesh back;
            st = vm_mesh_read(out, &back, &err);
            one_line(st, &err);
            if (st == VM_OK && back.ncells < m.ncells) abort(); /* .msh may add faces */
            vm_mesh_free(&back);
            remove(out);
        }
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
    return 0;
}
