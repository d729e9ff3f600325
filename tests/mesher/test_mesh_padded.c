/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_padded.c — the mesher's compact per-cell state (bit sets with
 * ranks, coarse-leaf keys, octree codes in 8^3 blocks) indexes cells by their position in
 * the padded grid: a phantom on an odd grid, and the same field with exterior planes added
 * beyond its upper faces (odd counts, so every row, word and block boundary moves), must
 * give the same elements (the same doubles, element for element), uniform and adaptive,
 * tets and hexes; each mesh is valid (0 inverted, conforming, closed boundary of the
 * phantom's Euler characteristic, its component count). */
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "test.h"

static int coord_cmp(const void *pa, const void *pb) {
    const double *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

static size_t g_width; /* doubles per element in elem_cmp */

static int elem_cmp(const void *pa, const void *pb) {
    const double *a = pa, *b = pb;
    for (size_t k = 0; k < g_width; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* Every element of m as its corners sorted (3 doubles each), the list sorted. */
static double *elements(const vm_mesh *m, size_t *width) {
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    *width = 3 * nn;
    double *out = malloc((m->ncells + 1) * *width * sizeof *out);
    if (!out) return NULL;
    for (size_t t = 0; t < m->ncells; t++) {
        double *o = out + *width * t;
        for (size_t k = 0; k < nn; k++)
            memcpy(o + 3 * k, m->points + 3 * (size_t)m->cells[nn * t + k], 3 * sizeof(double));
        qsort(o, nn, 3 * sizeof(double), coord_cmp);
    }
    g_width = *width;
    qsort(out, m->ncells, *width * sizeof(double), elem_cmp);
    return out;
}

/* v with pad[a] planes of value `outside` added after its last plane along each axis. */
static int padded(const vm_volume *v, const int64_t pad[3], float outside, vm_volume *p) {
    *p = *v;
    for (int a = 0; a < 3; a++)
        p->dims[a] = v->dims[a] + pad[a];
    size_t n = (size_t)(p->dims[0] * p->dims[1] * p->dims[2]);
    p->data = malloc(n * sizeof(float));
    if (!p->data) return 0;
    for (size_t i = 0; i < n; i++)
        p->data[i] = outside;
    for (int64_t k = 0; k < v->dims[2]; k++)
        for (int64_t j = 0; j < v->dims[1]; j++)
            memcpy(p->data + (size_t)(p->dims[0] * (j + p->dims[1] * k)),
                   v->data + (size_t)(v->dims[0] * (j + v->dims[1] * k)),
                   (size_t)v->dims[0] * sizeof(float));
    return 1;
}

static void check_valid(const vm_mesh *m, const vm_phantom_info *info, const char *label) {
    vm_error err;
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(m, &r, &err), &err);
    CHECK_MSG(m->ncells > 100 && r.inverted == 0 && r.overshared_faces == 0 &&
                  r.boundary_closed && r.boundary_euler == info->euler &&
                  r.components == (size_t)info->components,
              "%s: %zu cells, %zu inverted, %zu overshared, closed %d, Euler %ld (want %d), "
              "%zu components (want %d)",
              label, m->ncells, r.inverted, r.overshared_faces, r.boundary_closed,
              r.boundary_euler, info->euler, r.components, info->components);
}

/* One phantom at n^3, meshed as given and padded by pad; L: adaptive max level (0:
 * uniform); hex: hexahedra. */
static void padded_case(vm_phantom_kind kind, int n, int L, int hex, const int64_t pad[3]) {
    vm_error err;
    vm_volume v, p;
    vm_phantom_info info;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    if (!v.data) return;
    char label[128];
    snprintf(label, sizeof label, "%s %d, %s, level %d, padded by %lld %lld %lld", info.name,
             n, hex ? "hexes" : "tets", L, (long long)pad[0], (long long)pad[1],
             (long long)pad[2]);
    /* the premise: no material within 3 voxels of the faces that get padded */
    size_t near = 0;
    for (int64_t k = 0; k < n; k++)
        for (int64_t j = 0; j < n; j++)
            for (int64_t i = 0; i < n; i++)
                if ((i >= n - 3 || j >= n - 3 || k >= n - 3) &&
                    v.data[i + n * (j + n * k)] >= 0)
                    near++;
    CHECK_MSG(near == 0, "%s: %zu material voxels near the padded faces", label, near);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.adaptive = L > 0;
    if (L > 0) o.max_level = L;
    o.elements = hex ? VM_HEX8 : VM_TET4;
    vm_mesh a, b;
    vm_mesh_init(&a, o.elements);
    vm_mesh_init(&b, o.elements);
    CHECK(padded(&v, pad, -100.0f, &p));
    vm_status s1 = vm_mesh_volume(&v, &o, &a, NULL, &err);
    CHECK_MSG(s1 == VM_OK, "%s: %s", label, err.message);
    vm_status s2 = vm_mesh_volume(&p, &o, &b, NULL, &err);
    CHECK_MSG(s2 == VM_OK, "%s (padded): %s", label, err.message);
    if (s1 == VM_OK && s2 == VM_OK) {
        check_valid(&a, &info, label);
        check_valid(&b, &info, label);
        size_t wa, wb;
        double *ea = elements(&a, &wa), *eb = elements(&b, &wb);
        CHECK_MSG(a.ncells == b.ncells && a.npoints == b.npoints && ea && eb &&
                      memcmp(ea, eb, a.ncells * wa * sizeof(double)) == 0,
                  "%s: %zu elements and %zu points, padded %zu and %zu, not the same", label,
                  a.ncells, a.npoints, b.ncells, b.npoints);
        free(ea);
        free(eb);
    }
    vm_mesh_free(&a);
    vm_mesh_free(&b);
    free(p.data);
    vm_volume_free(&v);
}

static void paddingBeyondTheMaterialKeepsEveryElement(void) {
    int small = getenv("VM_SANITIZED") != NULL;
    const int64_t odd[3] = {5, 3, 7}, wide[3] = {67, 1, 2};
    int n = small ? 29 : 37;
    padded_case(VM_PHANTOM_SPHERE, n, 0, 0, odd);
    padded_case(VM_PHANTOM_SPHERE, n, 4, 0, odd);
    padded_case(VM_PHANTOM_SPHERE, n, 4, 0, wide);
    padded_case(VM_PHANTOM_TORUS, small ? 31 : 41, 3, 0, odd);
    /* (two-spheres reaches within 3 voxels of the faces below 45^3) */
    padded_case(small ? VM_PHANTOM_SPHERE : VM_PHANTOM_TWO_SPHERES, small ? 33 : 45, 2, 0, wide);
    padded_case(VM_PHANTOM_SPHERE, small ? 21 : 27, 0, 1, odd);
    if (!small) padded_case(VM_PHANTOM_TORUS, 35, 1, 1, wide);
}

TEST_MAIN(T(paddingBeyondTheMaterialKeepsEveryElement))
