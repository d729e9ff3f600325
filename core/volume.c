/* SPDX-License-Identifier: BSD-3-Clause */
/* core/volume.c — vm_volume allocation, geometry and statistics. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include "core.h"
#include "volmesh/volume.h"

vm_status vm_volume_alloc(vm_volume *v, const int64_t dims[3], vm_error *err) {
    size_t n;
    memset(v, 0, sizeof *v);
    vm_status st = vm__check_dims(dims, sizeof(float), "volume", &n, err);
    if (st) return st;
    v->data = malloc(n * sizeof(float));
    if (!v->data)
        return vm_error_set(err, VM_ERR_NOMEM, "volume: out of memory for %zu voxels", n);
    for (int a = 0; a < 3; a++) {
        v->dims[a] = dims[a];
        v->spacing[a] = 1.0;
        v->direction[a][a] = 1.0;
    }
    v->type = VM_SCALAR_FLOAT32;
    return VM_OK;
}

vm_status vm__check_geometry(const vm_volume *v, const char *what, vm_error *err) {
    static const char axis[] = "xyz";
    for (int a = 0; a < 3; a++) {
        double s = v->spacing[a];
        if (!(s >= VM_SPACING_MIN && s <= VM_SPACING_MAX))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: spacing %c is %g (must be finite, "
                                "within %g .. %g)", what, axis[a], s, VM_SPACING_MIN,
                                VM_SPACING_MAX);
        if (!(fabs(v->origin[a]) <= VM_EXTENT_MAX))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: origin %c is %g (must be finite, "
                                "within +-%g)", what, axis[a], v->origin[a], VM_EXTENT_MAX);
        for (int c = 0; c < 3; c++)
            if (!isfinite(v->direction[a][c]))
                return vm_error_set(err, VM_ERR_FORMAT, "%s: direction (%d, %d) is %g (must "
                                    "be finite)", what, a, c, v->direction[a][c]);
    }
    for (int r = 0; r < 3; r++) { /* the far corner, voxel (nx-1, ny-1, nz-1) */
        double x = v->origin[r];
        for (int c = 0; c < 3; c++)
            x += v->direction[r][c] * (double)(v->dims[c] > 1 ? v->dims[c] - 1 : 0) *
                 v->spacing[c];
        if (!(fabs(x) <= VM_EXTENT_MAX))
            return vm_error_set(err, VM_ERR_FORMAT, "%s: the volume's far corner has %c = %g "
                                "(its extent must be within +-%g)", what, axis[r], x,
                                VM_EXTENT_MAX);
    }
    return VM_OK;
}

void vm_volume_free(vm_volume *v) {
    if (!v) return;
    free(v->data);
    memset(v, 0, sizeof *v);
}

size_t vm_volume_count(const vm_volume *v) {
    return (size_t)v->dims[0] * (size_t)v->dims[1] * (size_t)v->dims[2];
}

void vm_volume_index_to_world(const vm_volume *v, const double ijk[3], double xyz[3]) {
    for (int r = 0; r < 3; r++) {
        double s = v->origin[r];
        for (int c = 0; c < 3; c++) s += v->direction[r][c] * ijk[c] * v->spacing[c];
        xyz[r] = s;
    }
}

void vm__volume_frame(const vm_volume *v, double m[3][3]) {
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) m[r][c] = v->direction[r][c] * v->spacing[c];
}

double vm__mat3_det(const double m[3][3]) {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
           m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

void vm__mat3_inverse(const double m[3][3], double det, double inv[3][3]) {
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            inv[r][c] = (m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]) / det;
        }
}

double vm_volume_frame_determinant(const vm_volume *v) {
    double m[3][3];
    vm__volume_frame(v, m);
    return vm__mat3_det((const double(*)[3])m);
}

size_t vm_volume_stats(const vm_volume *v, double *min, double *max, double *mean) {
    size_t n = vm_volume_count(v), bad = 0, good = 0;
    double lo = INFINITY, hi = -INFINITY, sum = 0.0;
    for (size_t i = 0; i < n; i++) {
        float f = v->data[i];
        if (!isfinite(f)) {
            bad++;
            continue;
        }
        if (f < lo) lo = f;
        if (f > hi) hi = f;
        sum += f;
        good++;
    }
    if (min) *min = good ? lo : NAN;
    if (max) *max = good ? hi : NAN;
    if (mean) *mean = good ? sum / (double)good : NAN;
    return bad;
}

static const struct {
    vm_scalar_type t;
    const char *name;
    size_t size;
} type_table[] = {
    {VM_SCALAR_UINT8, "uint8", 1},    {VM_SCALAR_INT8, "int8", 1},
    {VM_SCALAR_UINT16, "uint16", 2},  {VM_SCALAR_INT16, "int16", 2},
    {VM_SCALAR_UINT32, "uint32", 4},  {VM_SCALAR_INT32, "int32", 4},
    {VM_SCALAR_UINT64, "uint64", 8},  {VM_SCALAR_INT64, "int64", 8},
    {VM_SCALAR_FLOAT32, "float32", 4}, {VM_SCALAR_FLOAT64, "float64", 8},
};

const char *vm_scalar_type_name(vm_scalar_type t) {
    for (size_t i = 0; i < sizeof type_table / sizeof type_table[0]; i++)
        if (type_table[i].t == t) return type_table[i].name;
    return "unknown";
}

size_t vm_scalar_type_size(vm_scalar_type t) {
    for (size_t i = 0; i < sizeof type_table / sizeof type_table[0]; i++)
        if (type_table[i].t == t) return type_table[i].size;
    return 0;
}

int vm_scalar_type_parse(const char *name, vm_scalar_type *t) {
    static const struct {
        const char *alias;
        vm_scalar_type t;
    } aliases[] = {
        {"uint8", VM_SCALAR_UINT8},     {"uchar", VM_SCALAR_UINT8},
        {"unsigned char", VM_SCALAR_UINT8}, {"uint8_t", VM_SCALAR_UINT8},
        {"int8", VM_SCALAR_INT8},       {"char", VM_SCALAR_INT8},
        {"signed char", VM_SCALAR_INT8}, {"int8_t", VM_SCALAR_INT8},
        {"uint16", VM_SCALAR_UINT16},   {"ushort", VM_SCALAR_UINT16},
        {"unsigned short", VM_SCALAR_UINT16}, {"uint16_t", VM_SCALAR_UINT16},
        {"int16", VM_SCALAR_INT16},     {"short", VM_SCALAR_INT16},
        {"int16_t", VM_SCALAR_INT16},
        {"uint32", VM_SCALAR_UINT32},   {"uint", VM_SCALAR_UINT32},
        {"unsigned int", VM_SCALAR_UINT32}, {"uint32_t", VM_SCALAR_UINT32},
        {"int32", VM_SCALAR_INT32},     {"int", VM_SCALAR_INT32},
        {"int32_t", VM_SCALAR_INT32},
        {"uint64", VM_SCALAR_UINT64},   {"ulonglong", VM_SCALAR_UINT64},
        {"uint64_t", VM_SCALAR_UINT64},
        {"int64", VM_SCALAR_INT64},     {"longlong", VM_SCALAR_INT64},
        {"int64_t", VM_SCALAR_INT64},
        {"float32", VM_SCALAR_FLOAT32}, {"float", VM_SCALAR_FLOAT32},
        {"float64", VM_SCALAR_FLOAT64}, {"double", VM_SCALAR_FLOAT64},
    };
    for (size_t i = 0; i < sizeof aliases / sizeof aliases[0]; i++)
        if (strcasecmp(name, aliases[i].alias) == 0) {
            *t = aliases[i].t;
            return 0;
        }
    return -1;
}

/* The inverse of the index-to-world matrix (see core.h). */
vm_status vm__frame_inverse(const vm_volume *v, const char *who, double inv[3][3], double *det,
                            vm_error *err) {
    double m[3][3];
    vm__volume_frame(v, m);
    *det = vm__mat3_det((const double(*)[3])m);
    if (!(fabs(*det) > 0) || !isfinite(*det))
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: the volume's index-to-world frame is degenerate", who);
    vm__mat3_inverse((const double(*)[3])m, *det, inv);
    return VM_OK;
}
