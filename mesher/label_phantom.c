/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/label_phantom.c — small label volumes with known materials and topology, for the
 * multi-material tests: nested, face-sharing, a three-material junction, diagonal contacts. */
#include <math.h>
#include <string.h>
#include "volmesh/labels.h"

/* Outer radii of the nested phantom's three shells, as fractions of n: each at least 0.12 n
 * (4 voxels at n = 32) thick, all inside the box. */
static const double shell_r[3] = {0.2, 0.32, 0.44};

/* Label of voxel (i, j, k) of an n^3 phantom of the given kind. */
static int phantom_label(int kind, int n, int i, int j, int k) {
    int q = n / 4, h = n / 2, e = 3 * n / 4;
    switch (kind) {
    case 0: {
        double c = 0.5 * (n - 1), dx = i - c, dy = j - c, dz = k - c;
        double r = sqrt(dx * dx + dy * dy + dz * dz) / n;
        return r < shell_r[0] ? 1 : r < shell_r[1] ? 2 : r < shell_r[2] ? 3 : 0;
    }
    case 1:
        if (j < q || j >= e || k < q || k >= e || i < q || i >= e) return 0;
        return i < h ? 1 : 2;
    case 2:
        if (j < q || j >= e || k < q || k >= e || i < q || i >= e) return 0;
        return i >= h ? 3 : j < h ? 1 : 2;
    default: {
        /* cubes A, B (label 1) share only an edge along z; C (label 2) touches B at a corner */
        int s = n / 5, o = n / 10;
        int in_a = i >= o && i < o + s && j >= o && j < o + s && k >= o && k < o + s;
        int in_b = i >= o + s && i < o + 2 * s && j >= o + s && j < o + 2 * s && k >= o && k < o + s;
        int in_c = i >= o + 2 * s && i < o + 3 * s && j >= o + 2 * s && j < o + 3 * s &&
                   k >= o + s && k < o + 2 * s;
        return in_a || in_b ? 1 : in_c ? 2 : 0;
    }
    }
}

vm_status vm_label_phantom_make(int kind, int n, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    if (kind < 0 || kind > 3)
        return vm_error_set(err, VM_ERR_ARG, "label phantom: kind %d is not 0..3", kind);
    if (n < 16 || n > 1024)
        return vm_error_set(err, VM_ERR_ARG, "label phantom: size %d is outside 16..1024", n);
    int64_t dims[3] = {n, n, n};
    vm_status s = vm_volume_alloc(v, dims, err);
    if (s) return s;
    v->type = VM_SCALAR_UINT8;
    strcpy(v->format, "phantom");
    size_t p = 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) v->data[p++] = (float)phantom_label(kind, n, i, j, k);
    return VM_OK;
}
