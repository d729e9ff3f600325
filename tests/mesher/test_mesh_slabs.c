/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_slabs.c — vm_mesh_volume_slabs: meshing slab after slab from a
 * source of planes gives the whole volume's mesh tet for tet (the same point coordinates,
 * the same tets with the same node order and regions) on the sphere, torus, two spheres and
 * genus-3 phantoms, uniform, at --size 2 and adaptive, in 1, 2, 3 and 7 slabs and in slabs
 * of one block (thinner than the ghost band), in a left-handed physical frame; material
 * through the first and last planes, slabs without material or without cells; the merged
 * mesh has every invariant (0 inverted, conforming, closed boundary, Euler characteristic,
 * components, volume against the analytic one); the source is asked for each plane once in
 * increasing z; a failing source and bad requests are refused with one line and no mesh. */
/* ctest parts: 3 */
#include "test.h"
#include <stdint.h>
#include <string.h>

#define PI 3.14159265358979323846

/* A source of planes over a volume in memory that checks the driver's contract: each call
 * starts where the previous ended, out has the requested shape. fail_at > 0: that call
 * fails as a truncated file would. */
typedef struct planes {
    const vm_volume *v;
    int64_t next;
    int calls, fail_at, broken_contract;
} planes;

static vm_status from_volume(int64_t z0, int64_t z1, vm_volume *out, void *user,
                             vm_error *err) {
    planes *p = user;
    p->calls++;
    if (z0 != p->next || z1 <= z0 || z1 > p->v->dims[2] || out->dims[0] != p->v->dims[0] ||
        out->dims[1] != p->v->dims[1] || out->dims[2] != z1 - z0 || !out->data)
        p->broken_contract++;
    p->next = z1;
    if (p->calls == p->fail_at)
        return vm_error_set(err, VM_ERR_FORMAT, "planes.nrrd: data is truncated at plane %lld",
                            (long long)z0);
    size_t plane = (size_t)p->v->dims[0] * (size_t)p->v->dims[1];
    memcpy(out->data, p->v->data + plane * (size_t)z0,
           plane * (size_t)(z1 - z0) * sizeof(float));
    return VM_OK;
}

/* m's tets as 13 doubles each (four corners in node order, then the region), sorted. */
static double *tet_list(const vm_mesh *m) {
    double *out = malloc((m->ncells + 1) * 13 * sizeof *out);
    if (!out) return NULL;
    for (size_t t = 0; t < m->ncells; t++) {
        for (int k = 0; k < 4; k++)
            memcpy(out + 13 * t + 3 * k, m->points + 3 * (size_t)m->cells[4 * t + (size_t)k],
                   3 * sizeof(double));
        out[13 * t + 12] = m->region[t];
    }
    vm_test_sort_rows(out, m->ncells, 13);
    return out;
}

/* 1 when a and b have the same points (as a set of coordinates, each once) and the same
 * tets; else says how they differ. */
static int same_mesh(const char *label, const vm_mesh *a, const vm_mesh *b) {
    if (a->npoints != b->npoints || a->ncells != b->ncells) {
        CHECK_MSG(0, "%s: %zu tets and %zu points by slabs, %zu and %zu whole", label,
                  b->ncells, b->npoints, a->ncells, a->npoints);
        return 0;
    }
    double *pa = malloc((a->npoints + 1) * 3 * sizeof(double));
    double *pb = malloc((b->npoints + 1) * 3 * sizeof(double));
    double *ta = tet_list(a), *tb = tet_list(b);
    int same = pa && pb && ta && tb;
    if (same) {
        memcpy(pa, a->points, a->npoints * 3 * sizeof(double));
        memcpy(pb, b->points, b->npoints * 3 * sizeof(double));
        vm_test_sort_rows(pa, a->npoints, 3);
        vm_test_sort_rows(pb, b->npoints, 3);
        same = memcmp(pa, pb, a->npoints * 3 * sizeof(double)) == 0;
        CHECK_MSG(same, "%s: the points differ", label);
        for (size_t i = 1; same && i < b->npoints; i++)
            CHECK_MSG(memcmp(pb + 3 * (i - 1), pb + 3 * i, 3 * sizeof(double)) != 0, "%s: a point appears twice",
                      label);
        int tets = memcmp(ta, tb, a->ncells * 13 * sizeof(double)) == 0;
        CHECK_MSG(tets, "%s: the tets differ", label);
        same = same && tets;
    }
    free(pa);
    free(pb);
    free(ta);
    free(tb);
    return same;
}

/* The invariants of the merged mesh: 0 inverted, conforming, closed boundary of the given
 * Euler characteristic, components, volume within tol (relative) of volume. */
static void check_invariants(const char *label, const vm_mesh *m, long euler, size_t comps,
                             double volume, double tol) {
    vm_mesh_report r;
    vm_error err;
    vm_status s = vm_mesh_check(m, &r, &err);
    CHECK_MSG(s == VM_OK, "%s: %s", label, err.message);
    if (s) return;
    CHECK_MSG(r.inverted == 0 && r.degenerate == 0 && r.overshared_faces == 0 &&
                  r.boundary_closed && r.boundary_nonmanifold_vertices == 0 &&
                  r.boundary_euler == euler && r.components == comps,
              "%s: %zu inverted, %zu degenerate, %zu overshared faces, closed %d, %zu "
              "non-manifold vertices, Euler %ld (expected %ld), %zu components (expected %zu)",
              label, r.inverted, r.degenerate, r.overshared_faces, r.boundary_closed,
              r.boundary_nonmanifold_vertices, r.boundary_euler, euler, r.components, comps);
    CHECK_MSG(fabs(r.volume - volume) <= tol * volume,
              "%s: volume %.6g, expected %.6g (%.2f%%)", label, r.volume, volume, 100 * tol);
}

/* Gives v a physical frame: spacing, origin and a left-handed direction (z flipped). */
static double set_frame(vm_volume *v) {
    double sp[3] = {0.5, 0.75, 1.25}, org[3] = {10, -3, 7.5};
    memset(v->direction, 0, sizeof v->direction);
    for (int a = 0; a < 3; a++) {
        v->spacing[a] = sp[a];
        v->origin[a] = org[a];
        v->direction[a][a] = a == 2 ? -1 : 1;
    }
    return sp[0] * sp[1] * sp[2];
}

static vm_status mesh_by_slabs(const vm_volume *v, const vm_mesh_options *o, int n,
                               int64_t ghost, planes *p, vm_mesh *m, vm_error *err) {
    vm_volume info = *v;
    info.data = NULL; /* the driver must not need it */
    memset(p, 0, sizeof *p);
    p->v = v;
    vm_slab_options so = {n, ghost, from_volume, p};
    return vm_mesh_volume_slabs(&info, o, &so, m, NULL, err);
}

/* One volume and options: the whole mesh, then each slab count of counts[] (0 ends it; -1:
 * one slab per block), compared tet for tet and checked. */
static void slab_cases(const char *name, const vm_volume *v, const vm_mesh_options *o,
                       const int *counts, long euler, size_t comps, double volume, double tol) {
    vm_error err;
    vm_mesh whole;
    vm_status s = vm_mesh_volume(v, o, &whole, NULL, &err);
    CHECK_MSG(s == VM_OK, "%s: %s", name, err.message);
    if (s) return;
    check_invariants(name, &whole, euler, comps, volume, tol);
    vm_slab_grid g;
    vm_slab_grid_init(v->dims[2], o, 0, &g);
    for (const int *c = counts; *c; c++) {
        int n = *c < 0 ? (int)g.blocks : *c;
        char label[160];
        snprintf(label, sizeof label, "%s, %d slabs%s", name, n, *c < 0 ? " of one block" : "");
        planes p;
        vm_mesh m;
        s = mesh_by_slabs(v, o, n, 0, &p, &m, &err);
        CHECK_MSG(s == VM_OK, "%s: %s", label, err.message);
        if (s) continue;
        CHECK_MSG(!p.broken_contract && p.next == v->dims[2],
                  "%s: the source was asked out of order (%d times) or not to the end (%lld)",
                  label, p.broken_contract, (long long)p.next);
        if (same_mesh(label, &whole, &m))
            check_invariants(label, &m, euler, comps, volume, tol);
        printf("  %s: %zu tets, %d source calls\n", label, m.ncells, p.calls);
        vm_mesh_free(&m);
    }
    vm_mesh_free(&whole);
}

static int small(void) {
    return getenv("VM_SANITIZED") != NULL;
}

/* The four phantoms in a physical frame, one mode: 0 uniform, 2 --size 2, 'a' adaptive. */
static void phantoms_in(int mode) {
    static const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS,
                                            VM_PHANTOM_TWO_SPHERES, VM_PHANTOM_GENUS3};
    static const int counts[] = {1, 2, 3, 7, -1, 0};
    int n = mode == 2 ? 56 : small() ? 32 : 40; /* --size 2: genus-3 tubes need 28 cells */
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        CHECK_OK(vm_phantom_make(kinds[k], n, 0.0, 1, &v, &info, &err), &err);
        if (!v.data) continue;
        double cell = set_frame(&v);
        vm_mesh_options o;
        vm_mesh_options_default(&o);
        double tol = 0.015;
        if (mode == 2) o.cell_size = 2, tol = 0.04;
        if (mode == 'a') o.adaptive = 1, o.max_level = 2, tol = 0.04;
        char name[96];
        snprintf(name, sizeof name, "%s %d%s", info.name, n,
                 mode == 2     ? " --size 2"
                 : mode == 'a' ? " adaptive L2"
                               : "");
        slab_cases(name, &v, &o, counts, info.euler, (size_t)info.components,
                   info.volume * cell, tol);
        vm_volume_free(&v);
    }
}

static void slabsAreTheWholeMeshUniform(void) {
    phantoms_in(0);
}
static void slabsAreTheWholeMeshAtSize2(void) {
    phantoms_in(2);
}
static void slabsAreTheWholeMeshAdaptive(void) {
    phantoms_in('a');
}

/* Adaptive at the default level 4: blocks of 16 cells, slabs cut on them; a ghost band of
 * 38 cells, wider than the volume's slabs. */
static void slabsAreTheWholeMeshAdaptiveLevel4(void) {
    int n = small() ? 40 : 72;
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, n, 0.0, 1, &v, &info, &err), &err);
    if (!v.data) return;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.adaptive = 1;
    static const int counts[] = {2, 3, -1, 0};
    slab_cases("sphere adaptive L4", &v, &o, counts, 2, 1, info.volume, 0.04);
    vm_volume_free(&v);
}

/* A volume whose values f(i, j, k) the caller fills; unit frame. */
static int make_volume(vm_volume *v, int nx, int ny, int nz) {
    int64_t d[3] = {nx, ny, nz};
    vm_error err;
    vm_status s = vm_volume_alloc(v, d, &err);
    CHECK_OK(s, &err);
    return s == VM_OK;
}

/* A cylinder along z through the whole volume: its material lies on the first and last
 * planes, where each end slab closes it. */
static void materialThroughTheFirstAndLastPlanes(void) {
    int n = small() ? 28 : 40, nz = small() ? 30 : 45;
    vm_volume v;
    if (!make_volume(&v, n, n, nz)) return;
    double c = 0.5 * (n - 1), r = 0.3 * (n - 1);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                v.data[i + n * (j + n * k)] =
                    (float)(r - sqrt((i - c) * (i - c) + (j - c) * (j - c)));
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    static const int counts[] = {2, 3, 7, -1, 0};
    slab_cases("cylinder", &v, &o, counts, 2, 1, PI * r * r * (nz - 1), 0.015);
    o.adaptive = 1;
    o.max_level = 2;
    slab_cases("cylinder adaptive L2", &v, &o, counts, 2, 1, PI * r * r * (nz - 1), 0.03);
    vm_volume_free(&v);
}

/* A sphere in the lower third: the upper slabs have no material (the mesher finds none in
 * their planes), and with more slabs than cells some slabs have no cells at all. */
static void slabsWithoutMaterialOrCells(void) {
    int n = small() ? 28 : 36, nz = 3 * n;
    vm_volume v;
    if (!make_volume(&v, n, n, nz)) return;
    double c = 0.5 * (n - 1), r = 0.35 * (n - 1);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                v.data[i + n * (j + n * k)] =
                    (float)(r -
                            sqrt((i - c) * (i - c) + (j - c) * (j - c) + (k - c) * (k - c)));
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    static const int counts[] = {3, 5, 0};
    slab_cases("low sphere", &v, &o, counts, 2, 1, 4.0 / 3.0 * PI * r * r * r, 0.015);
    /* more slabs than the volume has cells: the empty ones are skipped */
    const int many[] = {4 * nz, 0};
    o.cell_size = 3;
    slab_cases("low sphere --size 3", &v, &o, many, 2, 1, 4.0 / 3.0 * PI * r * r * r, 0.06);
    vm_volume_free(&v);
}

/* A source that fails: its error comes back as it is (naming its file), nothing is kept. */
static void failingSourceLeavesNoMesh(void) {
    vm_volume v;
    vm_error err;
    /* (64 planes: 3 slabs with their ghost bands ask the source 3 times) */
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 64, 0.0, 1, &v, NULL, &err), &err);
    if (!v.data) return;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    for (int at = 1; at <= 3; at++) {
        vm_volume info = v;
        info.data = NULL;
        planes p;
        memset(&p, 0, sizeof p);
        p.v = &v;
        p.fail_at = at;
        vm_slab_options so = {3, 0, from_volume, &p};
        vm_mesh m;
        vm_error_clear(&err);
        vm_status s = vm_mesh_volume_slabs(&info, &o, &so, &m, NULL, &err);
        CHECK_MSG(s == VM_ERR_FORMAT && strncmp(err.message, "planes.nrrd: ", 13) == 0 &&
                      !strchr(err.message, '\n') && m.ncells == 0 && m.npoints == 0 &&
                      !m.points && !m.cells,
                  "source failing at call %d: status %d, '%s', %zu tets", at, (int)s,
                  err.message, m.ncells);
        CHECK_MSG(p.calls == at, "the driver went on after the failure (%d calls)", p.calls);
    }
    vm_volume_free(&v);
}

/* Bad requests and empty material: one line each, as the whole mesher words them. */
static void badRequestsAreRefused(void) {
    vm_volume v;
    vm_error err, werr;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 1, &v, NULL, &err), &err);
    if (!v.data) return;
    struct {
        int slabs, hexes, crop, lo;
        vm_status status;
        const char *phrase;
    } cases[] = {
        {0, 0, 0, 0, VM_ERR_ARG, "0 slabs"},
        {2, 1, 0, 0, VM_ERR_ARG, "tetrahedra only"},
        {2, 0, 1, 0, VM_ERR_ARG, "cropped"},
        {3, 0, 0, 100, VM_ERR_EMPTY, "no voxel >= 100 (the data range is"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        vm_mesh_options o;
        vm_mesh_options_default(&o);
        if (cases[i].hexes) o.elements = VM_HEX8;
        if (cases[i].crop) o.full_nz = 32;
        o.lo = cases[i].lo;
        planes p;
        vm_mesh m;
        vm_error_clear(&err);
        vm_status s = mesh_by_slabs(&v, &o, cases[i].slabs, 0, &p, &m, &err);
        CHECK_MSG(s == cases[i].status && strstr(err.message, cases[i].phrase) &&
                      !strchr(err.message, '\n') && m.ncells == 0 && !m.points,
                  "case %zu: status %d, '%s'", i, (int)s, err.message);
        if (cases[i].status == VM_ERR_EMPTY) { /* the whole mesher's message */
            vm_mesh w;
            vm_mesh_volume(&v, &o, &w, NULL, &werr);
            CHECK_MSG(strcmp(err.message, werr.message) == 0, "'%s' against '%s'", err.message,
                      werr.message);
            vm_mesh_free(&w);
        }
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

/* The geometry: slabs cover the cells once, cut on blocks, their planes hold the ghost band
 * and grow along z; the plane budget picks the fewest slabs that fit. */
static void slabGeometryCoversTheCellsOnce(void) {
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    for (int mode = 0; mode < 3; mode++) {
        o.cell_size = mode == 1 ? 3 : 1;
        o.adaptive = mode == 2;
        o.max_level = 3;
        vm_slab_grid g;
        vm_slab_grid_init(101, &o, 0, &g);
        CHECK(g.ghost == (mode == 2 ? 38 : 14));
        for (int n = 1; n <= 9; n++) {
            int64_t next = 0, p0 = 0, p1 = 0;
            for (int i = 0; i < n; i++) {
                vm_slab s;
                vm_slab_part(&g, i, n, &s);
                if (s.cell1 <= s.cell0) continue;
                CHECK(s.cell0 == next && s.cell0 % g.block == 0);
                CHECK(s.plane0 >= p0 && s.plane1 >= p1 && s.plane0 <= p1 + (p1 == 0));
                CHECK(s.whole == (n == 1));
                CHECK((double)s.plane0 <= fmax(0, (double)(s.cell0 - g.ghost) * g.step - 1));
                CHECK((double)s.plane1 - 1 >=
                      fmin((double)(s.cell1 + g.ghost) * g.step, (double)(g.nz - 1)));
                next = s.cell1;
                p0 = s.plane0;
                p1 = s.plane1;
            }
            CHECK(next == g.cells && p1 == g.nz);
        }
        int64_t held4 = vm_slab_planes_held(&g, 4);
        int k = vm_slab_count_within(&g, held4);
        CHECK(k >= 1 && k <= 4 && vm_slab_planes_held(&g, k) <= held4);
        CHECK(vm_slab_count_within(&g, g.nz) == 1);
        CHECK(vm_slab_count_within(&g, 2) == 0);
    }
}

TEST_MAIN(T(slabsAreTheWholeMeshUniform), T(slabsAreTheWholeMeshAtSize2),
          T(slabsAreTheWholeMeshAdaptive), T(slabsAreTheWholeMeshAdaptiveLevel4),
          T(materialThroughTheFirstAndLastPlanes), T(slabsWithoutMaterialOrCells),
          T(failingSourceLeavesNoMesh), T(badRequestsAreRefused),
          T(slabGeometryCoversTheCellsOnce))
