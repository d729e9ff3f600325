/* SPDX-License-Identifier: BSD-3-Clause */
/* core/point_index.c — the one index of points by exact coordinates (open addressing with
 * linear probing, core/hash.h's point hash): the slabs and MPI merges, and the STL readers. */
#include <stdlib.h>
#include "core.h"
#include "hash.h"
#include "volmesh/slabs.h"

/* Smallest room of a growing index (vm__point_index_add): spares the first rebuilds. */
#define MIN_GROWING_ROOM 512

/* Looks p up; on a miss *at is the free slot where p goes. */
vm_index vm_point_index_find(const vm_point_index *pi, const double *points, const double p[3],
                             size_t *at) {
    size_t i = (size_t)vm__hash_point(p) & (pi->cap - 1);
    while (pi->slot[i] >= 0) {
        const double *q = points + 3 * (size_t)pi->slot[i];
        if (q[0] == p[0] && q[1] == p[1] && q[2] == p[2]) return pi->slot[i];
        i = (i + 1) & (pi->cap - 1);
    }
    *at = i;
    return -1;
}

/* Sizes the slots for room points (load at most 1/2) and enters points 0..n-1. */
vm_status vm_point_index_build(vm_point_index *pi, const double *points, size_t n, size_t room,
                               vm_error *err) {
    size_t cap = 1;
    if (room < n) room = n;
    while (cap < 2 * room + 16)
        cap <<= 1;
    pi->slot = malloc(cap * sizeof *pi->slot);
    pi->cap = pi->slot ? cap : 0;
    if (!pi->slot)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for a point index");
    for (size_t i = 0; i < cap; i++)
        pi->slot[i] = -1;
    for (size_t i = 0; i < n; i++) {
        size_t at;
        if (vm_point_index_find(pi, points, points + 3 * i, &at) < 0)
            pi->slot[at] = (vm_index)i;
    }
    return VM_OK;
}

/* Frees the slots and leaves pi empty. */
void vm_point_index_free(vm_point_index *pi) {
    if (!pi) return;
    free(pi->slot);
    pi->slot = NULL;
    pi->cap = 0;
}

/* Finds xyz among m's points or appends it, rebuilding the index larger when half full. */
vm_index vm__point_index_add(struct vm_point_index *pi, vm_mesh *m, const double xyz[3],
                             vm_error *err) {
    if (2 * (m->npoints + 1) > pi->cap) {
        size_t room = 2 * (m->npoints + 1);
        if (room < MIN_GROWING_ROOM) room = MIN_GROWING_ROOM;
        vm_point_index_free(pi);
        if (vm_point_index_build(pi, m->points, m->npoints, room, err)) return -1;
    }
    size_t at;
    vm_index i = vm_point_index_find(pi, m->points, xyz, &at);
    if (i >= 0) return i;
    i = vm_mesh_add_point(m, xyz, err);
    if (i >= 0) pi->slot[at] = i;
    return i;
}
