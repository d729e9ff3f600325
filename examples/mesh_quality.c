/* SPDX-License-Identifier: BSD-3-Clause */
/* examples/mesh_quality.c — the quality of an existing mesh, from any format volmesh reads
 * (VTU, legacy VTK, INP, MSH, MEDIT, ...), also meshes made by other programs: the checks,
 * the ABAQUS element test and the worst value of each metric.
 * Usage: mesh_quality MESH   (exit 1 when an element is inverted or the boundary is open) */
#include <stdio.h>
#include <volmesh/volmesh.h>

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s MESH\n", argv[0]);
        return 2;
    }
    vm_error err;
    vm_mesh m;
    vm_quality_summary q;
    if (vm_mesh_read(argv[1], &m, &err)) {
        fprintf(stderr, "%s\n", err.message);
        return 2;
    }
    vm_status s = vm_quality_report(&m, &q, &err);
    vm_mesh_free(&m);
    if (s) {
        fprintf(stderr, "%s\n", err.message);
        return 2;
    }
    printf("%s: %zu %s cells, %zu inverted, boundary %s, Euler %ld, %zu components\n", argv[1],
           q.check.cells, vm_cell_kind_name(q.kind), q.check.inverted,
           q.check.boundary_closed ? "closed" : "open", q.check.boundary_euler,
           q.check.components);
    if (q.has_abaqus) printf("ABAQUS check: %zu failing elements\n", q.abaqus_failures);
    for (size_t i = 0; i < q.nmetrics; i++) {
        const vm_metric_stats *st = &q.metrics[i];
        printf("  %-16s min %-10.4g mean %-10.4g max %-10.4g outside acceptable %zu\n",
               st->info->name, st->min, st->mean, st->max, st->unacceptable);
    }
    return q.check.inverted || !q.check.boundary_closed ? 1 : 0;
}
