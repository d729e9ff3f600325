/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/volume.h — the scalar volume every stage reads.
 *
 * Data is stored as float, x fastest: value(i,j,k) = data[i + nx*(j + ny*k)].
 * Index to world: x = origin + D * (i*sx, j*sy, k*sz), where D = direction (columns are the
 * world directions of the i, j, k axes) and s = spacing. */
#ifndef VOLMESH_VOLUME_H
#define VOLMESH_VOLUME_H

#include <stddef.h>
#include <stdint.h>
#include "error.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Scalar type of the samples as stored in the file (data is always converted to float). */
typedef enum vm_scalar_type {
    VM_SCALAR_UINT8,
    VM_SCALAR_INT8,
    VM_SCALAR_UINT16,
    VM_SCALAR_INT16,
    VM_SCALAR_UINT32,
    VM_SCALAR_INT32,
    VM_SCALAR_UINT64,
    VM_SCALAR_INT64,
    VM_SCALAR_FLOAT32,
    VM_SCALAR_FLOAT64
} vm_scalar_type;

/* The geometry every volume reader accepts (any unit, usually mm): spacing finite, within
 * VM_SPACING_MIN .. VM_SPACING_MAX; origin and direction finite; the origin and the far
 * corner within +-VM_EXTENT_MAX. Beyond them the world coordinates of the voxels lose their
 * precision or overflow; a reader refuses them, naming the field. */
#define VM_SPACING_MIN 1e-9
#define VM_SPACING_MAX 1e9
#define VM_EXTENT_MAX 1e15

typedef struct vm_volume {
    int64_t dims[3];          /* nx, ny, nz, each >= 1 */
    vm_scalar_type type;      /* type in the source file */
    float *data;              /* owned; nx*ny*nz values, x fastest */
    double spacing[3];        /* > 0 */
    double origin[3];         /* world position of voxel (0,0,0) */
    double direction[3][3];   /* direction[r][c]: row r (world axis) of column c (index axis) */
    char format[16];          /* "nrrd", "nifti", "metaimage", "vtk", "vti", "raw", "phantom" */
} vm_volume;

/* Description of a headerless raw file (for vm_volume_read_raw). */
typedef struct vm_raw_options {
    int64_t dims[3];
    vm_scalar_type type;
    int big_endian;           /* 0: little endian (default), 1: big endian */
    double spacing[3];        /* 0 means 1 */
    double origin[3];
    uint64_t header_bytes;    /* bytes to skip at the start of the file */
} vm_raw_options;

/* Allocates v->data for dims (checked against overflow and the memory limit), sets unit
 * spacing, zero origin, identity direction and type float32. [out] v; free with vm_volume_free. */
vm_status vm_volume_alloc(vm_volume *v, const int64_t dims[3], vm_error *err);

/* Frees v->data and zeroes v. v may be NULL. */
void vm_volume_free(vm_volume *v);

/* Number of voxels nx*ny*nz (dims assumed already checked). */
size_t vm_volume_count(const vm_volume *v);

/* World coordinates of the continuous index position (i, j, k). */
void vm_volume_index_to_world(const vm_volume *v, const double ijk[3], double xyz[3]);

/* Determinant of D*diag(spacing); negative when the index frame is left-handed in the world. */
double vm_volume_frame_determinant(const vm_volume *v);

/* min, max and mean over all voxels (mean accumulated in double). Any output may be NULL.
 * Returns the number of non-finite values seen (which are skipped). */
size_t vm_volume_stats(const vm_volume *v, double *min, double *max, double *mean);

/* Name of a scalar type ("uint8", "float32", ...). */
const char *vm_scalar_type_name(vm_scalar_type t);

/* Parses names such as "uint8", "uchar", "short", "float", "double"; returns 0 on success. */
int vm_scalar_type_parse(const char *name, vm_scalar_type *t);

/* Size in bytes of one sample of type t. */
size_t vm_scalar_type_size(vm_scalar_type t);

#ifdef __cplusplus
}
#endif
#endif
