/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/improve/test_improve_local.c — the local pass (issue #32; the default, parts = 0): on
 * phantoms it keeps every invariant of the one pass and reaches about its quality, with the
 * same bytes and report on 1, 2 and 3 threads; a few bad tets in a good mesh change only
 * their neighbourhood (every point and tet farther away stays as it was); and a mesh with no
 * tet below the targets comes back as it was, nothing tried. */
/* ctest parts: 2 */
#include "improve/improve_internal.h"
#include "test.h"
#include "volmesh/improve.h"
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static int checked(const vm_mesh *m, vm_mesh_report *r) {
    vm_error err;
    memset(r, 0, sizeof *r);
    vm_status s = vm_mesh_check(m, r, &err);
    CHECK_OK(s, &err);
    return s == VM_OK;
}

static void copy_mesh(const vm_mesh *a, vm_mesh *b) {
    vm_error err;
    vm_mesh_init(b, a->kind);
    CHECK_OK(vm_mesh_reserve(b, a->npoints, a->ncells, &err), &err);
    memcpy(b->points, a->points, 3 * a->npoints * sizeof *b->points);
    memcpy(b->cells, a->cells, 4 * a->ncells * sizeof *b->cells);
    memcpy(b->region, a->region, a->ncells * sizeof *b->region);
    b->npoints = a->npoints;
    b->ncells = a->ncells;
}

static int same_mesh(const vm_mesh *a, const vm_mesh *b) {
    return a->npoints == b->npoints && a->ncells == b->ncells &&
           memcmp(a->points, b->points, 3 * a->npoints * sizeof *a->points) == 0 &&
           memcmp(a->cells, b->cells, 4 * a->ncells * sizeof *a->cells) == 0 &&
           memcmp(a->region, b->region, a->ncells * sizeof *a->region) == 0;
}

/* Tets of m below the targets of the default options (the pass's own quality). */
static size_t count_below(const vm_mesh *m, uint8_t *below) {
    vm__imp w;
    memset(&w, 0, sizeof w);
    vm_improve_options o;
    vm_improve_options_default(&o);
    vm__imp_scales(&w, &o);
    size_t n = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + k], sizeof p[k]);
        int b = vm__imp_quality(&w, (const double(*)[3])p) < 1.0;
        if (below) below[t] = (uint8_t)b;
        n += (size_t)b;
    }
    return n;
}

/* Improves a copy of m0 on the given threads (parts as given); checks the invariants
 * against the input. */
static int improve_copy(const char *label, const vm_mesh *m0, const vm_mesh_report *before,
                        const vm_volume *v, int parts, int threads, vm_mesh *m,
                        vm_improve_report *r) {
    vm_error err;
    copy_mesh(m0, m);
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.parts = parts;
    int old = vm_set_threads(threads);
    vm_status s = vm_mesh_improve(m, v, &o, r, &err);
    vm_set_threads(old);
    CHECK_OK(s, &err);
    r->seconds = 0.0;
    vm_mesh_report a;
    if (s != VM_OK || !checked(m, &a)) return 0;
    CHECK_MSG(a.inverted == 0 && a.degenerate == 0, "%s: %zu inverted, %zu degenerate", label,
              a.inverted, a.degenerate);
    CHECK_MSG(a.overshared_faces == 0, "%s: %zu over-shared faces", label, a.overshared_faces);
    CHECK_MSG(a.boundary_closed == 1 && a.boundary_open_edges == 0, "%s: boundary open", label);
    CHECK_MSG(a.boundary_nonmanifold_edges == 0 && a.boundary_nonmanifold_vertices == 0,
              "%s: non-manifold boundary", label);
    CHECK_MSG(a.boundary_euler == before->boundary_euler, "%s: boundary Euler %ld, was %ld",
              label, a.boundary_euler, before->boundary_euler);
    CHECK_MSG(a.components == before->components &&
                  a.boundary_components == before->boundary_components,
              "%s: components changed", label);
    CHECK_MSG(a.boundary_self_intersections <= before->boundary_self_intersections,
              "%s: %zu self-intersecting boundary triangle pairs, %zu before", label,
              a.boundary_self_intersections, before->boundary_self_intersections);
    CHECK_NEAR(a.min_dihedral, r->min_dihedral_after, 1e-9);
    CHECK(r->tets_after == m->ncells && r->points_after == m->npoints);
    double dv = fabs(r->volume_after - r->volume_before) / r->volume_before;
    CHECK_MSG(dv < 0.01, "%s: volume changed by %.3f%%", label, 100 * dv);
    if (v)
        CHECK_MSG(r->max_surface_move <= 0.8 + 1e-9, "%s: surface vertex moved %.3f voxels",
                  label, r->max_surface_move);
    return 1;
}

static void print_result(const char *label, const char *how, const vm_improve_report *r) {
    printf("  %s, %s: tets %zu -> %zu, min dihedral %.2f -> %.2f, max %.2f, ABAQUS %zu -> %zu, "
           "unfixed %zu, volume %+.4f%%, surface move %.3f\n",
           label, how, r->tets_before, r->tets_after, r->min_dihedral_before,
           r->min_dihedral_after, r->max_dihedral_after, r->abaqus_before, r->abaqus_after,
           r->unfixed, 100.0 * (r->volume_after - r->volume_before) / r->volume_before,
           r->max_surface_move);
    fflush(stdout);
}

/* The one pass, then the local pass on 1, 2 and 3 threads. */
static void local_case(vm_phantom_kind kind, int n, int adaptive, int use_volume) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    char label[96];
    snprintf(label, sizeof label, "%s %d%s%s", info.name, n, adaptive ? " adaptive" : "",
             use_volume ? "" : " (no volume)");
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.adaptive = adaptive;
    vm_mesh m0;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m0, NULL, &err), &err);
    vm_mesh_report before;
    const vm_volume *vp = use_volume ? &v : NULL;
    if (checked(&m0, &before)) {
        vm_mesh one, ref;
        vm_improve_report r1, rref;
        if (improve_copy(label, &m0, &before, vp, 1, 2, &one, &r1))
            print_result(label, "one pass", &r1);
        int ok = improve_copy(label, &m0, &before, vp, 0, 1, &ref, &rref);
        if (ok) {
            print_result(label, "local", &rref);
            CHECK_MSG(rref.min_dihedral_after >= r1.min_dihedral_after - 3.0,
                      "%s: min dihedral %.2f, one pass %.2f", label, rref.min_dihedral_after,
                      r1.min_dihedral_after);
            CHECK_MSG(rref.max_dihedral_after <= r1.max_dihedral_after + 5.0,
                      "%s: max dihedral %.2f, one pass %.2f", label, rref.max_dihedral_after,
                      r1.max_dihedral_after);
            CHECK_MSG(rref.abaqus_after <= r1.abaqus_after + 2,
                      "%s: %zu ABAQUS failures, one pass %zu", label, rref.abaqus_after,
                      r1.abaqus_after);
            CHECK_MSG(rref.unfixed <= r1.unfixed + 3, "%s: %zu unfixed, one pass %zu", label,
                      rref.unfixed, r1.unfixed);
        }
        for (int threads = 2; ok && threads <= 3; threads++) {
            vm_mesh m;
            vm_improve_report r;
            if (improve_copy(label, &m0, &before, vp, 0, threads, &m, &r)) {
                CHECK_MSG(same_mesh(&m, &ref), "%s: %d threads give another mesh than 1", label,
                          threads);
                CHECK_MSG(memcmp(&r, &rref, sizeof r) == 0,
                          "%s: %d threads give another report than 1", label, threads);
            }
            vm_mesh_free(&m);
        }
        vm_mesh_free(&one);
        vm_mesh_free(&ref);
    }
    vm_mesh_free(&m0);
    vm_volume_free(&v);
}

static void sphereAndGenus3LocallyKeepInvariantsOnAnyThreads(void) {
    local_case(VM_PHANTOM_SPHERE, 48, 0, 1);
    local_case(VM_PHANTOM_GENUS3, 64, 0, 1);
}

static void torusTwoSpheresAndCutSphereLocallyKeepInvariantsOnAnyThreads(void) {
    local_case(VM_PHANTOM_TORUS, 64, 1, 1);
    local_case(VM_PHANTOM_TWO_SPHERES, 56, 1, 1);
    local_case(VM_PHANTOM_CUT_SPHERE, 48, 1, 0);
}

/* Point -> tets, CSR. */
typedef struct adj {
    size_t *start;
    size_t *list;
} adj;

static void adj_build(const vm_mesh *m, adj *A) {
    A->start = calloc(m->npoints + 2, sizeof *A->start);
    A->list = malloc((4 * m->ncells + 1) * sizeof *A->list);
    for (size_t i = 0; i < 4 * m->ncells; i++)
        A->start[(size_t)m->cells[i] + 2]++;
    for (size_t v = 0; v < m->npoints; v++)
        A->start[v + 2] += A->start[v + 1];
    for (size_t t = 0; t < m->ncells; t++)
        for (int k = 0; k < 4; k++)
            A->list[A->start[(size_t)m->cells[4 * t + k] + 1]++] = t;
}

/* Moves one interior point of tet t most of the way to the plane of its opposite face (a
 * flat, bad tet) as far as its star stays positive; 1 when t ends below the targets. */
static int flatten(vm_mesh *m, const adj *A, size_t t, int k, vm__imp *w) {
    size_t a = (size_t)m->cells[4 * t + k];
    double *pa = m->points + 3 * a, keep[3], c[3] = {0, 0, 0};
    memcpy(keep, pa, sizeof keep);
    for (int j = 0; j < 4; j++)
        if (j != k)
            for (int d = 0; d < 3; d++)
                c[d] += m->points[3 * (size_t)m->cells[4 * t + j] + d] / 3.0;
    for (double f = 0.9; f > 0.3; f -= 0.1) {
        for (int d = 0; d < 3; d++)
            pa[d] = keep[d] + f * (c[d] - keep[d]);
        int ok = 1;
        double qt = 2.0;
        for (size_t i = A->start[a]; i < A->start[a + 1] && ok; i++) {
            double p[4][3];
            size_t u = A->list[i];
            for (int j = 0; j < 4; j++)
                memcpy(p[j], m->points + 3 * (size_t)m->cells[4 * u + j], sizeof p[j]);
            double q = vm__imp_quality(w, (const double(*)[3])p);
            ok = q > 0.05;
            if (u == t) qt = q;
        }
        if (ok && qt < 1.0) return 1;
    }
    memcpy(pa, keep, sizeof keep);
    return 0;
}

/* Points within rings rings of tets (sharing a point) of the tets flagged in seed. */
static void near_points(const vm_mesh *m, const adj *A, const uint8_t *seed, int rings,
                        uint8_t *near) {
    uint8_t *tin = calloc(m->ncells + 1, 1);
    memset(near, 0, m->npoints);
    memcpy(tin, seed, m->ncells);
    for (int r = 0; r <= rings; r++) {
        for (size_t t = 0; t < m->ncells; t++)
            if (tin[t])
                for (int k = 0; k < 4; k++)
                    near[m->cells[4 * t + k]] = 1;
        if (r == rings) break;
        for (size_t v = 0; v < m->npoints; v++)
            if (near[v])
                for (size_t i = A->start[v]; i < A->start[v + 1]; i++)
                    tin[A->list[i]] = 1;
    }
    free(tin);
}

static int quad_cmp(const void *pa, const void *pb) {
    const int64_t *a = pa, *b = pb;
    for (int k = 0; k < 4; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

/* The four points of tet t (by their ids) in increasing order. */
static void quad_of(const vm_mesh *m, size_t t, const double *id, int64_t q[4]) {
    for (int k = 0; k < 4; k++) {
        size_t v = (size_t)m->cells[4 * t + k];
        q[k] = id ? (int64_t)id[v] : (int64_t)v;
    }
    for (int i = 1; i < 4; i++)
        for (int j = i; j > 0 && q[j] < q[j - 1]; j--) {
            int64_t x = q[j];
            q[j] = q[j - 1];
            q[j - 1] = x;
        }
}

/* Points farther than this many rings of tets from a bad tet never move: the local pass's
 * jobs free two rings around the bad tets (one ring of points moves), and each of its later
 * rounds starts from tets those made, two rings further at most. */
#define NEAR_RINGS 7

/* A good sphere mesh with a few tets flattened: the local pass fixes them and leaves every
 * point and tet farther than a few rings from them as they were. */
static void aFewBadTetsChangeOnlyTheirNeighbourhood(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 48, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m, NULL, &err), &err);
    vm_improve_report r;
    CHECK_OK(vm_mesh_improve(&m, &v, NULL, &r, &err), &err);
    vm__imp w;
    memset(&w, 0, sizeof w);
    vm_improve_options o;
    vm_improve_options_default(&o);
    vm__imp_scales(&w, &o);
    uint8_t *below = calloc(m.ncells + 1, 1), *near = calloc(m.npoints + 1, 1);
    size_t nb0 = count_below(&m, below);
    adj A;
    adj_build(&m, &A);
    /* flatten tets of interior points, far apart, spread over the mesh */
    vm_mesh_report mr;
    CHECK(checked(&m, &mr));
    size_t made = 0;
    for (size_t t = m.ncells / 7; t < m.ncells && made < 6; t += m.ncells / 7) {
        for (int k = 0; k < 4 && made < 6; k++) {
            size_t a = (size_t)m.cells[4 * t + k];
            const double *p = m.points + 3 * a;
            double ijk[3];
            int inner = 1;
            for (int d = 0; d < 3; d++) {
                ijk[d] = (p[d] - v.origin[d]) / v.spacing[d];
                inner = inner && ijk[d] > 2.0 && ijk[d] < (double)v.dims[d] - 3.0;
            }
            /* not on the boundary: the sphere's inside, by the field */
            if (!inner ||
                v.data[(size_t)(ijk[0] + 0.5) +
                       (size_t)v.dims[0] * ((size_t)(ijk[1] + 0.5) +
                                            (size_t)v.dims[1] * (size_t)(ijk[2] + 0.5))] < 0.5)
                continue;
            if (flatten(&m, &A, t, k, &w)) made++;
        }
    }
    size_t nb = count_below(&m, below);
    printf("  %zu tets below the targets after the first pass, %zu after flattening %zu\n", nb0,
           nb, made);
    CHECK(made >= 3 && nb > nb0);
    near_points(&m, &A, below, NEAR_RINGS, near);
    size_t nnear = 0;
    for (size_t i = 0; i < m.npoints; i++)
        nnear += near[i];
    CHECK_MSG(nnear * 2 < m.npoints, "%zu of %zu points are near the bad tets", nnear,
              m.npoints);
    /* each point's input id, as a point field (fields follow their points) */
    double *id = malloc((m.npoints + 1) * sizeof *id);
    for (size_t i = 0; i < m.npoints; i++)
        id[i] = (double)i;
    vm_mesh m0;
    copy_mesh(&m, &m0);
    CHECK_OK(vm_mesh_set_field(&m, 0, "id", 1, id, &err), &err);
    CHECK_OK(vm_mesh_improve(&m, &v, NULL, &r, &err), &err);
    printf("  local pass: %zu collapses, %zu moves, %zu flips, min dihedral %.2f -> %.2f\n",
           r.collapses, r.moves, r.flips23 + r.flips32 + r.edge_removals, r.min_dihedral_before,
           r.min_dihedral_after);
    CHECK(r.min_dihedral_after >= 15.0 && r.max_dihedral_after <= 150.0);
    CHECK(m.npoint_fields == 1);
    const double *oid = m.npoint_fields ? m.point_fields[0].data : NULL;
    /* the points far away: where they were */
    size_t moved = 0, far_in = 0, far_out = 0, missing = 0;
    for (size_t i = 0; oid && i < m.npoints; i++) {
        size_t j = (size_t)oid[i];
        if (!near[j] && memcmp(m.points + 3 * i, m0.points + 3 * j, 3 * sizeof(double)) != 0)
            moved++;
    }
    /* the tets far away: all there */
    int64_t(*out)[4] = malloc((m.ncells + 1) * sizeof *out);
    for (size_t t = 0; oid && t < m.ncells; t++)
        quad_of(&m, t, oid, out[t]);
    qsort(out, m.ncells, sizeof *out, quad_cmp);
    for (size_t t = 0; oid && t < m0.ncells; t++) {
        const vm_index *c = m0.cells + 4 * t;
        if (near[c[0]] || near[c[1]] || near[c[2]] || near[c[3]]) continue;
        far_in++;
        int64_t q[4];
        quad_of(&m0, t, NULL, q);
        if (bsearch(q, out, m.ncells, sizeof *out, quad_cmp))
            far_out++;
        else
            missing++;
    }
    printf("  %zu tets far from the bad ones, %zu of them kept; %zu far points moved\n", far_in,
           far_out, moved);
    CHECK_MSG(moved == 0, "%zu points far from the bad tets moved", moved);
    CHECK_MSG(missing == 0 && far_in > m0.ncells / 2, "%zu of %zu far tets changed", missing,
              far_in);
    free(out);
    free(id);
    free(below);
    free(near);
    free(A.start);
    free(A.list);
    vm_mesh_free(&m0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* A cube of n^3 cells, six Kuhn tets each (dihedral angles 45, 60 and 90 degrees): every tet
 * meets the targets, and the local pass tries nothing. */
static void aMeshMeetingTheTargetsComesBackAsItWas(void) {
    const int n = 8;
    vm_error err;
    vm_mesh m, m0;
    vm_mesh_init(&m, VM_TET4);
    size_t np = (size_t)(n + 1) * (n + 1) * (n + 1), nt = 6 * (size_t)n * n * n;
    CHECK_OK(vm_mesh_reserve(&m, np, nt, &err), &err);
    for (int z = 0; z <= n; z++)
        for (int y = 0; y <= n; y++)
            for (int x = 0; x <= n; x++) {
                double *p = m.points + 3 * (((size_t)z * (n + 1) + y) * (n + 1) + x);
                p[0] = x;
                p[1] = y;
                p[2] = z;
            }
    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                   {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    size_t c = 0;
    for (int z = 0; z < n; z++)
        for (int y = 0; y < n; y++)
            for (int x = 0; x < n; x++)
                for (int k = 0; k < 6; k++) {
                    int at[3] = {x, y, z};
                    vm_index *t = m.cells + 4 * c;
                    for (int j = 0; j < 4; j++) {
                        if (j > 0) at[perm[k][j - 1]]++;
                        t[j] = (vm_index)(((size_t)at[2] * (n + 1) + at[1]) * (n + 1) + at[0]);
                    }
                    double pp[4][3];
                    for (int j = 0; j < 4; j++)
                        memcpy(pp[j], m.points + 3 * (size_t)t[j], sizeof pp[j]);
                    if (vm_tet_signed_volume((const double(*)[3])pp) < 0.0) {
                        vm_index s = t[0];
                        t[0] = t[1];
                        t[1] = s;
                    }
                    m.region[c++] = 0;
                }
    m.npoints = np;
    m.ncells = nt;
    size_t nb = count_below(&m, NULL);
    printf("  Kuhn cube %d: %zu tets, %zu below the targets\n", n, m.ncells, nb);
    CHECK(nb == 0);
    copy_mesh(&m, &m0);
    vm_improve_report r;
    CHECK_OK(vm_mesh_improve(&m, NULL, NULL, &r, &err), &err);
    CHECK(same_mesh(&m, &m0));
    CHECK(r.collapses + r.moves + r.flips23 + r.flips32 + r.edge_removals + r.perturbations +
              r.peels + r.boundary_flips ==
          0);
    CHECK(r.passes == 0 && r.tets_after == r.tets_before && r.inverted_after == 0);
    vm_mesh_free(&m);
    vm_mesh_free(&m0);
}

TEST_MAIN(T(sphereAndGenus3LocallyKeepInvariantsOnAnyThreads),
          T(torusTwoSpheresAndCutSphereLocallyKeepInvariantsOnAnyThreads),
          T(aFewBadTetsChangeOnlyTheirNeighbourhood), T(aMeshMeetingTheTargetsComesBackAsItWas))
