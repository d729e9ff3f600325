/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded.c — the graded mesher: an octree sized in world units (distance bound, edge
 * bounds), balanced 2:1, its body-centred lattice, and isosurface stuffing (Labelle and
 * Shewchuk 2007) on the trilinear field; see docs/SIZING.md. */
#include <math.h>
#include <string.h>
#include "../core/core.h"
#include "graded_internal.h"
#include "mesher_internal.h"

vm_status vm__mesh_graded(const vm_volume *v, const vm_mesh_options *o, vm_mesh *mesh,
                          vm_mesh_stats *st, vm_error *err) {
    double voxel = fmin(v->spacing[0], fmin(v->spacing[1], v->spacing[2]));
    double vmax = fmax(v->spacing[0], fmax(v->spacing[1], v->spacing[2]));
    gr_sizing sz;
    sz.max_edge = o->max_edge > 0 ? o->max_edge : INFINITY;
    /* Half a voxel; for anisotropic voxels, half the edge of the cube of a voxel's volume. */
    double mean = cbrt(v->spacing[0] * v->spacing[1] * v->spacing[2]);
    sz.distance = o->distance > 0 ? o->distance : 0.5 * mean;
    /* Base cells: voxels, unless --min-edge asks otherwise or the voxels are over 3 times
     * longer one way than another; then each voxel edge is cut into (or, above a voxel,
     * joined from) a whole number of pieces near the asked length, so that base cells are
     * near cubes and voxel points stay lattice points. */
    double want = o->min_edge > 0 ? o->min_edge : vmax > 3 * voxel ? voxel : 0;
    if (want > sz.max_edge) want = sz.max_edge;
    for (int d = 0; d < 3; d++) {
        double sp = v->spacing[d];
        if (want <= 0)
            sz.h0[d] = sp;
        else if (want < sp)
            sz.h0[d] = sp / fmax(1, floor(sp / want + 0.5));
        else
            sz.h0[d] = sp * fmax(1, floor(want / sp + 0.5));
    }
    gr_field f;
    gr_tree t;
    gr_lattice L;
    memset(&t, 0, sizeof t);
    memset(&L, 0, sizeof L);
    vm_status s = vm__gr_field_init(&f, v, o, err);
    if (s) return s;
    if (!(s = vm__gr_tree_build(&t, &f, &sz, err))) s = vm__gr_tree_balance(&t, err);
    if (!s) s = vm__gr_lattice_build(&L, &t, &f, err);
    gr_stuff_stats ss;
    memset(&ss, 0, sizeof ss);
    if (!s) s = vm__gr_stuff(&L, &t, &f, mesh, &ss, err);
    st->octree_leaves = t.leaves;
    st->warped_vertices = ss.warped;
    st->surface_vertices = ss.cut_vertices + ss.warped;
    vm__gr_lattice_free(&L);
    vm__gr_tree_free(&t);
    vm__gr_field_free(&f);
    if (!s && mesh->ncells == 0)
        s = vm_error_set(err, VM_ERR_EMPTY, "mesh: the material holds no element");
    return s;
}
