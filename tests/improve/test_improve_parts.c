/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/improve/test_improve_parts.c — the quality pass by parts (issue #12): forced into 2, 3
 * and 4 slabs it keeps every invariant of the one pass (none inverted, conforming, closed
 * boundary with the same Euler characteristic and components, volume, surface bound, no
 * boundary crossing), reaches about the one pass's quality, gives the same bytes for 1 and 2
 * threads and carries fields; with the volume given by its planes, each part reads only a
 * window of them, for the same mesh (also the local pass, the default). */
/* ctest parts: 2 */
#include "test.h"
#include <stdint.h>
#include <string.h>
#include "volmesh/improve.h"
#include "volmesh/io.h"

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

/* Improves a copy of m0 with parts and threads; checks the invariants against the input. */
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

static void print_result(const char *label, int parts, const vm_improve_report *r) {
    printf("  %s, parts %d: tets %zu -> %zu, min dihedral %.2f -> %.2f, max %.2f, ABAQUS %zu -> "
           "%zu, unfixed %zu, volume %+.4f%%, surface move %.3f, %.2f s\n",
           label, parts, r->tets_before, r->tets_after, r->min_dihedral_before,
           r->min_dihedral_after, r->max_dihedral_after, r->abaqus_before, r->abaqus_after,
           r->unfixed, 100.0 * (r->volume_after - r->volume_before) / r->volume_before,
           r->max_surface_move, r->seconds);
    fflush(stdout);
}

/* The one pass, then 2, 3 and 4 parts on 1 and 2 threads. */
static void parts_case(vm_phantom_kind kind, int n, int adaptive, int use_volume) {
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
        vm_mesh one, a, b;
        vm_improve_report r1, ra, rb;
        if (improve_copy(label, &m0, &before, vp, 1, 2, &one, &r1)) print_result(label, 1, &r1);
        for (int parts = 2; parts <= 4; parts++) {
            int ok = improve_copy(label, &m0, &before, vp, parts, 1, &a, &ra);
            ok = improve_copy(label, &m0, &before, vp, parts, 2, &b, &rb) && ok;
            if (ok) {
                print_result(label, parts, &ra);
                CHECK_MSG(same_mesh(&a, &b), "%s, %d parts: 1 and 2 threads differ", label,
                          parts);
                CHECK_MSG(ra.min_dihedral_after >= r1.min_dihedral_after - 3.0,
                          "%s, %d parts: min dihedral %.2f, one pass %.2f", label, parts,
                          ra.min_dihedral_after, r1.min_dihedral_after);
                CHECK_MSG(ra.abaqus_after <= r1.abaqus_after + 2,
                          "%s, %d parts: %zu ABAQUS failures, one pass %zu", label, parts,
                          ra.abaqus_after, r1.abaqus_after);
                CHECK_MSG(ra.unfixed <= r1.unfixed + 3, "%s, %d parts: %zu unfixed, one pass %zu",
                          label, parts, ra.unfixed, r1.unfixed);
            }
            vm_mesh_free(&a);
            vm_mesh_free(&b);
        }
        vm_mesh_free(&one);
    }
    vm_mesh_free(&m0);
    vm_volume_free(&v);
}

static void sphereTorusGenus3ByPartsKeepInvariantsAndQuality(void) {
    parts_case(VM_PHANTOM_SPHERE, 48, 0, 1);
    parts_case(VM_PHANTOM_TORUS, 64, 1, 1);
    parts_case(VM_PHANTOM_GENUS3, 64, 0, 1);
}

static void twoSpheresAndPlateByPartsKeepInvariantsAndQuality(void) {
    parts_case(VM_PHANTOM_TWO_SPHERES, 56, 1, 1);
    parts_case(VM_PHANTOM_PLATE, 48, 0, 1);
    parts_case(VM_PHANTOM_CUT_SPHERE, 48, 1, 0);
}

/* Point fields follow their points and cell fields their cells (each new tet takes the
 * field of a tet it replaces). */
static void fieldsFollowByParts(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 40, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m, NULL, &err), &err);
    double *pf = malloc(3 * m.npoints * sizeof *pf), *cf = malloc(m.ncells * sizeof *cf);
    memcpy(pf, m.points, 3 * m.npoints * sizeof *pf);
    double zmin = INFINITY, zmax = -INFINITY;
    for (size_t t = 0; t < m.ncells; t++) {
        double z = 0.0;
        for (int k = 0; k < 4; k++) z += 0.25 * m.points[3 * (size_t)m.cells[4 * t + k] + 2];
        cf[t] = z;
        if (z < zmin) zmin = z;
        if (z > zmax) zmax = z;
    }
    CHECK_OK(vm_mesh_set_field(&m, 0, "p0", 3, pf, &err), &err);
    CHECK_OK(vm_mesh_set_field(&m, 1, "zc", 1, cf, &err), &err);
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.parts = 3;
    vm_improve_report r;
    CHECK_OK(vm_mesh_improve(&m, &v, &o, &r, &err), &err);
    CHECK(m.npoint_fields == 1 && m.ncell_fields == 1);
    double far = 0.0, cfar = 0.0;
    for (size_t i = 0; i < m.npoints; i++)
        for (int k = 0; k < 3; k++) {
            double d = fabs(m.point_fields[0].data[3 * i + k] - m.points[3 * i + k]);
            if (d > far) far = d;
        }
    for (size_t t = 0; t < m.ncells; t++) {
        double z = 0.0;
        for (int k = 0; k < 4; k++) z += 0.25 * m.points[3 * (size_t)m.cells[4 * t + k] + 2];
        double d = fabs(m.cell_fields[0].data[t] - z);
        if (d > cfar) cfar = d;
    }
    /* points move less than a voxel or two; a tet's centroid stays near its parent's */
    CHECK_MSG(far < 2.0, "a point is %.3f from where its field says it was", far);
    CHECK_MSG(cfar < 3.0, "a tet's centroid is %.3f from its parent's", cfar);
    free(pf);
    free(cf);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* By parts too, the bar only goes forward and ends at its total. */
static void progressGoesForwardByParts(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 40, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m, NULL, &err), &err);
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.parts = 3;
    vm_test_progress_log pl = {NULL, 0, 0, 0, 0, 0, 0.0, 0.0};
    o.progress = vm_test_progress;
    o.progress_user = &pl;
    CHECK_OK(vm_mesh_improve(&m, &v, &o, NULL, &err), &err);
    CHECK(pl.calls >= 3 && pl.backwards == 0 && pl.ended);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* A plane source over a volume in memory, logging what it is asked for. */
typedef struct plane_log {
    const vm_volume *v;
    int64_t reads, planes, most;
    int64_t fail_at; /* the read that fails (-1: none) */
} plane_log;

static vm_status copy_planes(int64_t z0, int64_t z1, vm_volume *out, void *user,
                             vm_error *err) {
    plane_log *L = user;
    if (L->reads++ == L->fail_at)
        return vm_error_set(err, VM_ERR_IO, "planes.nrrd: cannot read planes %lld..%lld",
                            (long long)z0, (long long)z1 - 1);
    CHECK(0 <= z0 && z0 < z1 && z1 <= L->v->dims[2]);
    CHECK(out->dims[0] == L->v->dims[0] && out->dims[1] == L->v->dims[1] &&
          out->dims[2] == z1 - z0);
    size_t plane = (size_t)(L->v->dims[0] * L->v->dims[1]);
    memcpy(out->data, L->v->data + (size_t)z0 * plane,
           (size_t)(z1 - z0) * plane * sizeof(float));
    L->planes += z1 - z0;
    if (z1 - z0 > L->most) L->most = z1 - z0;
    return VM_OK;
}

/* vm_mesh_improve_planes: by parts (and by the local pass's jobs) each part reads a window of
 * the planes, never the whole volume, and the mesh is the whole volume's byte for byte, on 1
 * and 2 threads; the one pass reads the planes all at once; a source that fails fails the
 * pass with its message and leaves a valid mesh. */
static void planesGiveTheWholeVolumeMesh(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 64, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.adaptive = 1;
    vm_mesh m0, a, b;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m0, NULL, &err), &err);
    vm_volume info = v;
    info.data = NULL;
    vm_improve_options o;
    vm_improve_options_default(&o);
    static const int parts_tried[3] = {4, 1, 0};
    for (int pi = 0; pi < 3; pi++)
        for (int threads = 1; threads <= 2; threads++) {
            int parts = parts_tried[pi];
            copy_mesh(&m0, &a);
            copy_mesh(&m0, &b);
            o.parts = parts;
            int old = vm_set_threads(threads);
            CHECK_OK(vm_mesh_improve(&a, &v, &o, NULL, &err), &err);
            plane_log L = {&v, 0, 0, 0, -1};
            CHECK_OK(vm_mesh_improve_planes(&b, &info, copy_planes, &L, &o, NULL, &err), &err);
            vm_set_threads(old);
            CHECK_MSG(same_mesh(&a, &b), "%d parts, %d threads: not the whole volume's mesh",
                      parts, threads);
            if (parts != 1)
                CHECK_MSG(L.reads >= 2 && L.most < v.dims[2] * 3 / 4,
                          "%d parts: %lld reads, up to %lld of %lld planes", parts,
                          (long long)L.reads, (long long)L.most, (long long)v.dims[2]);
            else
                CHECK(L.reads == 1 && L.most == v.dims[2]);
            printf("  %d parts, %d threads: %lld reads, %lld planes in all, at most %lld of "
                   "%lld\n",
                   parts, threads, (long long)L.reads, (long long)L.planes, (long long)L.most,
                   (long long)v.dims[2]);
            vm_mesh_free(&a);
            vm_mesh_free(&b);
        }
    /* the source fails on its third read */
    copy_mesh(&m0, &b);
    o.parts = 4;
    plane_log L = {&v, 0, 0, 0, 2};
    vm_status s = vm_mesh_improve_planes(&b, &info, copy_planes, &L, &o, NULL, &err);
    CHECK(s == VM_ERR_IO && strstr(err.message, "planes.nrrd") != NULL);
    vm_mesh_report r;
    if (checked(&b, &r)) CHECK(r.inverted == 0 && r.overshared_faces == 0 && r.boundary_closed);
    vm_mesh_free(&b);
    CHECK(vm_mesh_improve_planes(&m0, &info, NULL, NULL, &o, NULL, &err) == VM_ERR_ARG);
    vm_mesh_free(&m0);
    vm_volume_free(&v);
}

/* volmesh mesh --improve-parts N runs and is the same for 1 and 2 threads. */
static void cliImprovePartsOption(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 40, 0.0, 1, &v, NULL, &err), &err);
    char in[512], o1[512], o2[512], args[2048];
    snprintf(in, sizeof in, "%s", vm_test_tmp("parts_torus.nrrd"));
    snprintf(o1, sizeof o1, "%s", vm_test_tmp("parts_t1.vtu"));
    snprintf(o2, sizeof o2, "%s", vm_test_tmp("parts_t2.vtu"));
    CHECK_OK(vm_volume_write_nrrd(in, &v, 1, &err), &err);
    vm_volume_free(&v);
    snprintf(args, sizeof args, "--threads 1 mesh '%s' --iso 0 -o '%s' --improve-parts 3 --quiet", in, o1);
    CHECK(vm_test_cli(args, NULL) == 0);
    snprintf(args, sizeof args, "--threads 2 mesh '%s' --iso 0 -o '%s' --improve-parts 3 --quiet", in, o2);
    CHECK(vm_test_cli(args, NULL) == 0);
    vm_mesh a, b;
    CHECK_OK(vm_mesh_read(o1, &a, &err), &err);
    CHECK_OK(vm_mesh_read(o2, &b, &err), &err);
    CHECK(a.ncells > 0 && same_mesh(&a, &b));
    vm_mesh_free(&a);
    vm_mesh_free(&b);
    snprintf(args, sizeof args, "mesh '%s' --iso 0 -o '%s' --improve-parts 0 --quiet", in, o1);
    CHECK(vm_test_cli(args, NULL) == 2);
}

TEST_MAIN(T(sphereTorusGenus3ByPartsKeepInvariantsAndQuality),
          T(twoSpheresAndPlateByPartsKeepInvariantsAndQuality), T(fieldsFollowByParts),
          T(progressGoesForwardByParts), T(planesGiveTheWholeVolumeMesh),
          T(cliImprovePartsOption))
