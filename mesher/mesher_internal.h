/* mesher/mesher_internal.h — data passed between the mesher's stages (private). */
#ifndef VM_MESHER_INTERNAL_H
#define VM_MESHER_INTERNAL_H

#include <stdint.h>
#include "volmesh/mesher.h"

/* A uniform grid of samples in the material test's hands: n points per axis, x fastest. */
typedef struct vm__grid {
    int64_t n[3];
    const float *f;
    double lo, hi;
    int has_lo, has_hi;
    vm_progress_fn progress;
    void *progress_user;
} vm__grid;

/* Tets over two kinds of vertices: ids below nlattice are grid points (i + nx*(j + ny*k)),
 * ids from nlattice on are surface/centre vertices with positions rep_pos (grid index
 * coordinates). Positive orientation in grid index space. */
typedef struct vm__tet_soup {
    int64_t *tets;
    size_t ntets;
    int64_t nlattice;
    size_t nreps;
    double *rep_pos;
} vm__tet_soup;

vm_status vm__dual_contour_tets(const vm__grid *g, vm__tet_soup *out, vm_mesh_stats *st,
                                vm_error *err);

#endif
