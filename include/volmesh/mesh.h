/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/mesh.h — unstructured meshes: one element kind per mesh, VTK node order.
 *
 * Points are double; connectivity uses vm_index (32-bit, or 64-bit with VM_INDEX64).
 * Every cell carries a region id (label, interval index, or 0). */
#ifndef VOLMESH_MESH_H
#define VOLMESH_MESH_H

#include <stddef.h>
#include <stdint.h>
#include "error.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifdef VM_INDEX64
typedef int64_t vm_index;
#else
typedef int32_t vm_index;
#endif

/* The largest coordinate magnitude the readers and checks accept (any unit): beyond it the
 * span of a bounding box, squared lengths and volumes overflow. Every mesh reader refuses a
 * coordinate that is NaN, infinite or larger, naming the point and axis. */
#define VM_COORD_MAX 1e30

/* Progress callback: stage name, work done out of total (done never decreases and ends equal
 * to total), and the user pointer given beside it. Used by the mesher, the quality pass, the
 * labels, surfaces, denoising, the writers and the checks.
 *
 * Called only from the thread that called the library (never from its worker threads): a
 * few hundred times per stage as done grows, and in the long loops between those also
 * again with the last values (done unchanged), about every VM_PROGRESS_POLL seconds of work,
 * so that a callback can stop a run on time (e.g. on Ctrl-C).
 *
 * Returns 0 to go on, nonzero to cancel: the library then stops at its next check (a
 * fraction of a second on a 256^3 volume; docs/GUIDE.md section 9 lists where it checks),
 * frees what it allocated, writes no output file, and returns VM_ERR_CANCELLED ("STAGE:
 * cancelled"). A cancelled call returns the outputs as on any error (a mesh it was to make
 * is freed; a mesh it was to improve in place stays valid). The request is sticky for the
 * call: once nonzero, later return values do not matter. Not yet: the hex quality pass and
 * the graded mesher run to their end. (This callback returned void before cancellation
 * came: such a callback now returns 0.) */
typedef int (*vm_progress_fn)(const char *stage, double done, double total, void *user);

/* About how often (seconds) a long loop repeats its last progress call (see vm_progress_fn). */
#define VM_PROGRESS_POLL 0.1

/* Element kinds, valued as VTK cell type ids. */
typedef enum vm_cell_kind {
    VM_TRI3 = 5,
    VM_QUAD4 = 9,
    VM_TET4 = 10,
    VM_HEX8 = 12
} vm_cell_kind;

/* A named per-point or per-cell array of ncomp doubles per entry (owned by the mesh). */
typedef struct vm_field {
    char name[64];
    int ncomp;
    double *data;
} vm_field;

typedef struct vm_mesh {
    vm_cell_kind kind;
    size_t npoints, ncells;
    double *points;          /* 3*npoints */
    vm_index *cells;         /* vm_cell_nodes(kind)*ncells */
    int32_t *region;         /* ncells */
    size_t point_cap, cell_cap;
    vm_field *point_fields;  /* npoint_fields entries, each npoints*ncomp */
    size_t npoint_fields;
    vm_field *cell_fields;   /* ncell_fields entries, each ncells*ncomp */
    size_t ncell_fields;
} vm_mesh;

/* Nodes per element of kind (3, 4, 4, 8); 0 for an unknown kind. */
int vm_cell_nodes(vm_cell_kind kind);

/* Name of a kind ("tet4", "hex8", "tri3", "quad4"). */
const char *vm_cell_kind_name(vm_cell_kind kind);

/* Initialises an empty mesh of kind (no allocation). */
void vm_mesh_init(vm_mesh *m, vm_cell_kind kind);

/* Frees everything the mesh owns and re-initialises it empty. m may be NULL. */
void vm_mesh_free(vm_mesh *m);

/* Ensures room for npoints points and ncells cells in total. */
vm_status vm_mesh_reserve(vm_mesh *m, size_t npoints, size_t ncells, vm_error *err);

/* Appends a point; returns its index or -1 when out of memory (err filled). */
vm_index vm_mesh_add_point(vm_mesh *m, const double xyz[3], vm_error *err);

/* Appends a cell with vm_cell_nodes(kind) node indices and a region id. */
vm_status vm_mesh_add_cell(vm_mesh *m, const vm_index *nodes, int32_t region, vm_error *err);

/* Adds (or replaces) a per-point (on_cells == 0) or per-cell field, copying data
 * (count*ncomp doubles, where count is npoints or ncells). */
vm_status vm_mesh_set_field(vm_mesh *m, int on_cells, const char *name, int ncomp,
                            const double *data, vm_error *err);

/* Returns the field named name, or NULL. */
const vm_field *vm_mesh_find_field(const vm_mesh *m, int on_cells, const char *name);

#ifdef __cplusplus
}
#endif
#endif
