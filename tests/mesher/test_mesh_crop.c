/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_crop.c — cropped volumes (vm_mesh_options z_offset, full_nz): the
 * planes z0..z1 of a phantom meshed on their own give, away from the crop's first and last
 * planes, exactly the tets of the whole volume's mesh (the same doubles, tet for tet), also
 * with --size 2 and adaptive octrees whose blocks the crop cuts at odd offsets; the crop's
 * own mesh is a valid closed mesh (0 inverted, conforming, closed boundary of sphere
 * topology, one component); bad crops are refused with one line. */
#include <stdint.h>
#include <string.h>
#include "test.h"

/* The tets of m (index frame) whose centroid z lies in [zlo, zhi), each as its four corners
 * sorted (12 doubles), the list sorted: [out] *n tets, returned array (free it). */
static double *tets_between(const vm_mesh *m, double zlo, double zhi, size_t *n) {
    double *out = malloc((m->ncells + 1) * 12 * sizeof *out);
    size_t c = 0;
    if (!out) {
        *n = 0;
        return NULL;
    }
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *v = m->cells + 4 * t;
        double cz = 0;
        for (int k = 0; k < 4; k++)
            cz += m->points[3 * (size_t)v[k] + 2];
        cz *= 0.25;
        if (cz < zlo || cz >= zhi) continue;
        double *o = out + 12 * c++;
        for (int k = 0; k < 4; k++)
            memcpy(o + 3 * k, m->points + 3 * (size_t)v[k], 3 * sizeof(double));
        vm_test_sort_rows(o, 4, 3);
    }
    vm_test_sort_rows(out, c, 12);
    *n = c;
    return out;
}

/* Planes z0..z1 of v as a volume with v's frame (plane 0 at v's origin). */
static int crop(const vm_volume *v, int64_t z0, int64_t z1, vm_volume *c) {
    *c = *v;
    c->dims[2] = z1 - z0 + 1;
    size_t plane = (size_t)v->dims[0] * (size_t)v->dims[1];
    c->data = malloc(plane * (size_t)c->dims[2] * sizeof(float));
    if (!c->data) return 0;
    memcpy(c->data, v->data + plane * (size_t)z0, plane * (size_t)c->dims[2] * sizeof(float));
    return 1;
}

/* One case: the crop z0..z1 of phantom kind at n^3 with cell size S, adaptive max level L
 * (0: uniform); the whole mesh's and the crop's tets with centroid in [z0 + g, z1 - g) (in
 * voxels) must be the same, and the crop's mesh valid. */
static void crop_case(vm_phantom_kind kind, int n, int S, int L, int64_t z0, int64_t z1, int g) {
    vm_error err;
    vm_volume v, c;
    vm_phantom_info info;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    if (!v.data) return;
    char label[96];
    snprintf(label, sizeof label, "%s %d, size %d, level %d, planes %lld..%lld", info.name, n,
             S, L, (long long)z0, (long long)z1);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.cell_size = S;
    o.adaptive = L > 0;
    if (L > 0) o.max_level = L;
    vm_mesh whole, part;
    vm_mesh_init(&whole, VM_TET4);
    vm_mesh_init(&part, VM_TET4);
    CHECK_OK(vm_mesh_volume(&v, &o, &whole, NULL, &err), &err);
    CHECK(crop(&v, z0, z1, &c));
    o.z_offset = z0;
    o.full_nz = v.dims[2];
    vm_status s = vm_mesh_volume(&c, &o, &part, NULL, &err);
    CHECK_MSG(s == VM_OK, "%s: %s", label, err.message);
    if (s == VM_OK) {
        size_t na, nb;
        /* margins only at a crop plane that is not the volume's own border */
        double lo = z0 > 0 ? (double)(z0 + g) : -INFINITY;
        double hi = z1 < v.dims[2] - 1 ? (double)(z1 - g) : INFINITY;
        double *a = tets_between(&whole, lo, hi, &na);
        double *b = tets_between(&part, lo, hi, &nb);
        CHECK_MSG(na > 100, "%s: only %zu tets in the compared range", label, na);
        CHECK_MSG(na == nb && a && b && memcmp(a, b, na * 12 * sizeof(double)) == 0,
                  "%s: %zu tets in the whole mesh, %zu in the crop's, not the same", label, na,
                  nb);
        free(a);
        free(b);
        vm_mesh_report r;
        CHECK_OK(vm_mesh_check(&part, &r, &err), &err);
        CHECK_MSG(r.inverted == 0 && r.overshared_faces == 0 && r.boundary_closed &&
                      r.boundary_euler == 2 && r.components == 1,
                  "%s: crop mesh: %zu inverted, %zu overshared, closed %d, Euler %ld, %zu "
                  "components",
                  label, r.inverted, r.overshared_faces, r.boundary_closed, r.boundary_euler,
                  r.components);
        /* every point of the crop's mesh lies within its planes */
        double zmin = INFINITY, zmax = -INFINITY;
        for (size_t i = 0; i < part.npoints; i++) {
            zmin = fmin(zmin, part.points[3 * i + 2]);
            zmax = fmax(zmax, part.points[3 * i + 2]);
        }
        CHECK_MSG(zmin >= (double)z0 && zmax <= (double)z1, "%s: points at z %g..%g", label,
                  zmin, zmax);
    }
    vm_mesh_free(&whole);
    vm_mesh_free(&part);
    free(c.data);
    vm_volume_free(&v);
}

static void cropIsTheWholeMeshAwayFromItsPlanes(void) {
    int small = getenv("VM_SANITIZED") != NULL;
    int n = small ? 32 : 48;
    /* uniform: the crop's planes reach 2 cells into the compared range's margin */
    crop_case(VM_PHANTOM_SPHERE, n, 1, 0, 9, n - 12, 3);
    crop_case(VM_PHANTOM_SPHERE, n, 1, 0, 0, n / 2 + 1, 3); /* from the first plane */
    crop_case(VM_PHANTOM_SPHERE, n, 2, 0, 7, n - 1, 4);     /* resampled, to the last */
    /* adaptive: blocks of 4 and 8 cells, crops starting at odd multiples of them and off
     * them (the mesher leaves out the planes below the first aligned one) */
    crop_case(VM_PHANTOM_SPHERE, n, 1, 2, 4, small ? n - 1 : n - 9, 14);
    crop_case(VM_PHANTOM_SPHERE, n, 1, 2, 5, n - 1, 16);
    if (!small) crop_case(VM_PHANTOM_SPHERE, n, 1, 3, 8, n - 1, 22);
}

static void badCropIsRefused(void) {
    vm_error err;
    vm_volume v;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 1, &v, NULL, &err), &err);
    if (!v.data) return;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_mesh m;
    struct {
        int64_t z0, full;
        vm_cell_kind kind;
        const char *phrase;
    } cases[] = {
        {4, 16, VM_TET4, "not inside"},      /* planes 4..19 of 16 */
        {-1, 20, VM_TET4, "not inside"},     /* negative offset */
        {3, 0, VM_TET4, "whole volume"},     /* an offset without the whole size */
        {0, 20, VM_HEX8, "tets only"},       /* hexes */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        o.z_offset = cases[i].z0;
        o.full_nz = cases[i].full;
        o.elements = cases[i].kind;
        vm_error_clear(&err);
        vm_status s = vm_mesh_volume(&v, &o, &m, NULL, &err);
        CHECK_MSG(s == VM_ERR_ARG && strstr(err.message, cases[i].phrase) &&
                      !strchr(err.message, '\n') && m.ncells == 0,
                  "case %zu: status %d, '%s'", i, (int)s, err.message);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

TEST_MAIN(T(cropIsTheWholeMeshAwayFromItsPlanes), T(badCropIsRefused))
