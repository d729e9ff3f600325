/* SPDX-License-Identifier: BSD-3-Clause */
/* examples/mesh_file.c — read a volume, fill {f >= iso} with tetrahedra, check the mesh and
 * write it as VTU, using only the public API.  Usage: mesh_file IN ISO OUT.vtu */
#include <stdio.h>
#include <stdlib.h>
#include <volmesh/volmesh.h>

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: %s IN ISO OUT.vtu\n", argv[0]);
        return 2;
    }
    vm_error err;
    vm_volume v;
    if (vm_volume_read(argv[1], &v, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 2;
    }
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = atof(argv[2]);
    vm_mesh m;
    vm_mesh_report r;
    vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    vm_volume_free(&v);
    if (!s) s = vm_mesh_check(&m, &r, &err);
    if (!s) s = vm_mesh_write(argv[3], &m, &err);
    if (s) {
        fprintf(stderr, "%s\n", err.message);
        vm_mesh_free(&m);
        return 2;
    }
    printf("%zu tets, %zu inverted, boundary Euler %ld, volume %g\n", m.ncells, r.inverted,
           r.boundary_euler, r.volume);
    vm_mesh_free(&m);
    return r.inverted ? 1 : 0;
}
