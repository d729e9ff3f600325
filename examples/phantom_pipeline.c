/* SPDX-License-Identifier: BSD-3-Clause */
/* examples/phantom_pipeline.c — the whole pipeline through the public API: make a torus
 * phantom, mesh it without the quality pass, improve it against the volume, report the
 * quality before and after, and write a CalculiX/ABAQUS deck with a static step.
 * Usage: phantom_pipeline OUT.inp [N]   (N: phantom size in voxels, default 40) */
#include <stdio.h>
#include <stdlib.h>
#include <volmesh/volmesh.h>

static int fail(const vm_error *err) {
    fprintf(stderr, "%s\n", err->message);
    return 2;
}

int main(int argc, char **argv) {
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: %s OUT.inp [N]\n", argv[0]);
        return 2;
    }
    int n = argc == 3 ? atoi(argv[2]) : 40;
    vm_error err;
    vm_volume v;
    vm_phantom_info info;
    if (vm_phantom_make(VM_PHANTOM_TORUS, n, 0.0, 1, &v, &info, &err)) return fail(&err);

    /* Phantoms are signed fields, positive inside: the material is f >= 0. */
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.lo = 0.0;
    vm_mesh m;
    if (vm_mesh_volume(&v, &mo, &m, NULL, &err)) {
        vm_volume_free(&v);
        return fail(&err);
    }

    /* Given the volume, the pass keeps boundary vertices on {f = 0}. */
    vm_improve_options io;
    vm_improve_options_default(&io);
    io.lo = mo.lo;
    io.has_lo = 1;
    vm_improve_report ir;
    vm_status s = vm_mesh_improve(&m, &v, &io, &ir, &err);
    vm_volume_free(&v);

    vm_quality_summary q;
    if (!s) s = vm_quality_report(&m, &q, &err);
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    wo.deck = VM_DECK_STATIC;
    if (!s) s = vm_mesh_write_as(argv[1], &m, &wo, &err);
    vm_mesh_free(&m);
    if (s) return fail(&err);

    printf("%s: %zu tets, boundary Euler %ld (expected %d), volume %.1f (analytic %.1f)\n",
           info.name, q.check.cells, q.check.boundary_euler, info.euler, q.check.volume,
           info.volume);
    printf("dihedral %.1f..%.1f deg before, %.1f..%.1f after; ABAQUS failures %zu -> %zu\n",
           ir.min_dihedral_before, ir.max_dihedral_before, ir.min_dihedral_after,
           ir.max_dihedral_after, ir.abaqus_before, q.abaqus_failures);
    return q.check.inverted || q.check.boundary_euler != info.euler ? 1 : 0;
}
