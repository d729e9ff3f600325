/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/improve/test_improve.c — the quality-improvement pass: on phantoms and the shared
 * volumes it meets the issue-6 bar (min dihedral >= 10, max <= 165, no ABAQUS failure, none
 * inverted) while keeping every mesh invariant and the boundary topology, keeps the surface
 * within half a voxel of the isosurface, never makes a good mesh worse, and rejects bad input. */
/* ctest parts: 2 */
#include "test.h"
#include <stdint.h>
#include <string.h>
#include "volmesh/improve.h"

/* --- helpers -------------------------------------------------------------------------------- */

static int checked(const vm_mesh *m, vm_mesh_report *r) {
    vm_error err;
    memset(r, 0, sizeof *r);
    vm_status s = vm_mesh_check(m, r, &err);
    CHECK_OK(s, &err);
    return s == VM_OK;
}

/* The invariants that must hold after improvement, against the report before. */
static void check_invariants(const char *label, const vm_mesh_report *b, const vm_mesh_report *a) {
    CHECK_MSG(a->inverted == 0, "%s: %zu inverted", label, a->inverted);
    CHECK_MSG(a->degenerate == 0, "%s: %zu degenerate", label, a->degenerate);
    CHECK_MSG(a->overshared_faces == 0, "%s: %zu over-shared faces", label, a->overshared_faces);
    CHECK_MSG(a->boundary_closed == 1 && a->boundary_open_edges == 0, "%s: boundary open", label);
    CHECK_MSG(a->boundary_nonmanifold_edges == 0 && a->boundary_nonmanifold_vertices == 0,
              "%s: non-manifold boundary (%zu edges, %zu vertices)", label,
              a->boundary_nonmanifold_edges, a->boundary_nonmanifold_vertices);
    CHECK_MSG(a->boundary_euler == b->boundary_euler, "%s: boundary Euler %ld, was %ld", label,
              a->boundary_euler, b->boundary_euler);
    CHECK_MSG(a->components == b->components, "%s: %zu components, was %zu", label,
              a->components, b->components);
    CHECK_MSG(a->boundary_components == b->boundary_components,
              "%s: %zu boundary components, was %zu", label, a->boundary_components,
              b->boundary_components);
}

static void print_report(const char *label, const vm_improve_report *r) {
    printf("  %s: tets %zu -> %zu, dihedral %.2f..%.2f -> %.2f..%.2f, slivers<5 %zu -> %zu, "
           "<10 %zu -> %zu, ABAQUS %zu -> %zu, unfixed %zu, volume %+.3f%%, surface move %.3f, "
           "collapses %zu, flips 2-3 %zu 3-2 %zu, edge removals %zu, moves %zu, perturbations "
           "%zu, peels %zu, boundary flips %zu, %d passes, %.2f s\n",
           label, r->tets_before, r->tets_after, r->min_dihedral_before, r->max_dihedral_before,
           r->min_dihedral_after, r->max_dihedral_after, r->slivers_5_before, r->slivers_5_after,
           r->slivers_10_before, r->slivers_10_after, r->abaqus_before, r->abaqus_after,
           r->unfixed, 100.0 * (r->volume_after - r->volume_before) / r->volume_before,
           r->max_surface_move, r->collapses, r->flips23, r->flips32, r->edge_removals, r->moves,
           r->perturbations, r->peels, r->boundary_flips, r->passes, r->seconds);
    fflush(stdout);
}

/* --- boundary self-intersection (brute force on a grid; test-only) -------------------------- */

typedef struct bface {
    vm_index v[3]; /* sorted, to find pairs */
    vm_index o[3]; /* as in the tet */
} bface;

static int bface_cmp(const void *pa, const void *pb) {
    const bface *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a->v[k] != b->v[k]) return a->v[k] < b->v[k] ? -1 : 1;
    return 0;
}

static double orient3(const double *a, const double *b, const double *c, const double *d) {
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
        w[k] = d[k] - a[k];
    }
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
           u[2] * (v[0] * w[1] - v[1] * w[0]);
}

/* 1 when segment pq crosses the interior of triangle abc (strictly). */
static int segment_crosses(const double *p, const double *q, const double *a, const double *b,
                           const double *c) {
    double sp = orient3(a, b, c, p), sq = orient3(a, b, c, q);
    if (!((sp > 0 && sq < 0) || (sp < 0 && sq > 0))) return 0;
    double s1 = orient3(p, q, a, b), s2 = orient3(p, q, b, c), s3 = orient3(p, q, c, a);
    return (s1 > 0 && s2 > 0 && s3 > 0) || (s1 < 0 && s2 < 0 && s3 < 0);
}

/* Pairs of boundary triangles without a common vertex that cross each other. */
static size_t boundary_self_intersections(const vm_mesh *m) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    size_t nf = 4 * m->ncells, nb = 0, hits = 0;
    bface *f = malloc((nf + 1) * sizeof *f);
    if (!f) return 0;
    for (size_t t = 0; t < m->ncells; t++)
        for (int i = 0; i < 4; i++) {
            bface *x = f + 4 * t + (size_t)i;
            for (int k = 0; k < 3; k++) x->v[k] = x->o[k] = m->cells[4 * t + (size_t)fo[i][k]];
            for (int a = 0; a < 3; a++)
                for (int b = a + 1; b < 3; b++)
                    if (x->v[b] < x->v[a]) {
                        vm_index y = x->v[a];
                        x->v[a] = x->v[b];
                        x->v[b] = y;
                    }
        }
    qsort(f, nf, sizeof *f, bface_cmp);
    for (size_t i = 0; i < nf;) {
        size_t j = i + 1;
        while (j < nf && bface_cmp(f + j, f + i) == 0) j++;
        if (j - i == 1) f[nb++] = f[i];
        i = j;
    }
    /* Uniform grid of cells twice the mean edge; a pair is tested in the cell holding the
     * low corner of the overlap of their boxes, so once. */
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double mean = 0.0;
    for (size_t i = 0; i < nb; i++)
        for (int k = 0; k < 3; k++) {
            const double *p = m->points + 3 * (size_t)f[i].o[k], *q = m->points + 3 * (size_t)f[i].o[(k + 1) % 3];
            mean += sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                         (p[2] - q[2]) * (p[2] - q[2]));
            for (int a = 0; a < 3; a++) {
                if (p[a] < lo[a]) lo[a] = p[a];
                if (p[a] > hi[a]) hi[a] = p[a];
            }
        }
    double h = nb ? 2.0 * mean / (3.0 * (double)nb) : 1.0;
    long g[3];
    for (int a = 0; a < 3; a++) g[a] = (long)((hi[a] - lo[a]) / h) + 1;
    size_t ncell = (size_t)(g[0] * g[1] * g[2]);
    size_t *cnt = calloc(ncell + 1, sizeof *cnt), total = 0;
    double (*box)[6] = malloc((nb + 1) * sizeof *box);
    if (!cnt || !box) {
        free(f);
        free(cnt);
        free(box);
        return 0;
    }
    for (int pass = 0; pass < 2; pass++) {
        size_t *idx = pass ? malloc((total + 1) * sizeof *idx) : NULL, *fill = NULL;
        if (pass) {
            fill = calloc(ncell + 1, sizeof *fill);
            for (size_t c = 1; c <= ncell; c++) cnt[c] += cnt[c - 1]; /* prefix: cnt[c] = end */
        }
        for (size_t i = 0; i < nb; i++) {
            double *b = box[i];
            for (int a = 0; a < 3; a++) {
                b[a] = INFINITY;
                b[3 + a] = -INFINITY;
                for (int k = 0; k < 3; k++) {
                    double x = m->points[3 * (size_t)f[i].o[k] + (size_t)a];
                    if (x < b[a]) b[a] = x;
                    if (x > b[3 + a]) b[3 + a] = x;
                }
            }
            long c0[3], c1[3];
            for (int a = 0; a < 3; a++) {
                c0[a] = (long)((b[a] - lo[a]) / h);
                c1[a] = (long)((b[3 + a] - lo[a]) / h);
                if (c1[a] >= g[a]) c1[a] = g[a] - 1;
            }
            for (long z = c0[2]; z <= c1[2]; z++)
                for (long y = c0[1]; y <= c1[1]; y++)
                    for (long x = c0[0]; x <= c1[0]; x++) {
                        size_t c = (size_t)(x + g[0] * (y + g[1] * z));
                        if (!pass) {
                            cnt[c + 1]++;
                            total++;
                        } else if (idx && fill) {
                            idx[cnt[c] + fill[c]++] = i;
                        }
                    }
        }
        if (!pass) continue;
        for (size_t c = 0; idx && c < ncell; c++)
            for (size_t u = cnt[c]; u < cnt[c + 1]; u++)
                for (size_t v = u + 1; v < cnt[c + 1]; v++) {
                    size_t i = idx[u], j = idx[v];
                    const bface *A = f + i, *B = f + j;
                    int share = 0;
                    for (int k = 0; k < 3; k++)
                        for (int l = 0; l < 3; l++) share |= A->o[k] == B->o[l];
                    if (share) continue;
                    long owner[3];
                    int overlap = 1;
                    for (int a = 0; a < 3; a++) {
                        double l0 = box[i][a] > box[j][a] ? box[i][a] : box[j][a];
                        double l1 = box[i][3 + a] < box[j][3 + a] ? box[i][3 + a] : box[j][3 + a];
                        if (l0 > l1) overlap = 0;
                        owner[a] = (long)((l0 - lo[a]) / h);
                        if (owner[a] >= g[a]) owner[a] = g[a] - 1;
                    }
                    if (!overlap ||
                        (size_t)(owner[0] + g[0] * (owner[1] + g[1] * owner[2])) != c)
                        continue;
                    const double *P[3], *Q[3];
                    for (int k = 0; k < 3; k++) {
                        P[k] = m->points + 3 * (size_t)A->o[k];
                        Q[k] = m->points + 3 * (size_t)B->o[k];
                    }
                    int x = 0;
                    for (int k = 0; k < 3 && !x; k++)
                        x = segment_crosses(P[k], P[(k + 1) % 3], Q[0], Q[1], Q[2]) ||
                            segment_crosses(Q[k], Q[(k + 1) % 3], P[0], P[1], P[2]);
                    hits += (size_t)x;
                }
        free(idx);
        free(fill);
    }
    free(cnt);
    free(box);
    free(f);
    return hits;
}

/* Lists the tets the pass could not fix (cell field improve_unfixed): their angles. */
static void print_unfixed(const vm_mesh *m) {
    const vm_field *f = vm_mesh_find_field(m, 1, "improve_unfixed");
    if (!f) return;
    for (size_t t = 0; t < m->ncells; t++) {
        if (f->data[t] == 0.0) continue;
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + k], sizeof p[k]);
        printf("    unfixed tet %zu at (%.1f %.1f %.1f): dihedral %.2f..%.2f, face angle "
               "%.2f..%.2f\n",
               t, p[0][0], p[0][1], p[0][2], vm_tet_min_dihedral((const double(*)[3])p),
               vm_tet_max_dihedral((const double(*)[3])p),
               vm_tet_min_face_angle((const double(*)[3])p),
               vm_tet_max_face_angle((const double(*)[3])p));
    }
}

/* Meshes v at iso (f >= iso), improves with or without the volume, checks invariants and
 * returns the report. [out] m (caller frees). 0 on failure. */
static int mesh_and_improve(const char *label, const vm_volume *v, double iso, int use_volume,
                            int adaptive, vm_mesh *m, vm_improve_report *ir) {
    vm_error err;
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    mo.lo = iso;
    mo.adaptive = adaptive;
    vm_status s = vm_mesh_volume(v, &mo, m, NULL, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return 0;
    vm_mesh_report before, after;
    if (!checked(m, &before)) return 0;
    size_t crossings_before = boundary_self_intersections(m);
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.lo = iso;
    o.mark_unfixed = 1;
    s = vm_mesh_improve(m, use_volume ? v : NULL, &o, ir, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return 0;
    print_report(label, ir);
    print_unfixed(m);
    /* The pass must not fold the boundary through itself. */
    size_t crossings = boundary_self_intersections(m);
    CHECK_MSG(crossings <= crossings_before, "%s: %zu crossing boundary triangle pairs, %zu before",
              label, crossings, crossings_before);
    if (crossings_before) printf("    %zu crossing boundary triangle pairs before, %zu after\n", crossings_before, crossings);
    if (!checked(m, &after)) return 0;
    /* Exactly: a boundary free of self-intersections (vm_mesh_check's count, pairs with a
     * common vertex included) stays free of them. */
    CHECK_MSG(before.boundary_self_intersections != 0 || after.boundary_self_intersections == 0,
              "%s: %zu self-intersecting boundary triangle pairs after the pass, 0 before", label,
              after.boundary_self_intersections);
    CHECK_MSG(after.boundary_self_intersections <= before.boundary_self_intersections,
              "%s: %zu self-intersecting boundary triangle pairs, %zu before", label,
              after.boundary_self_intersections, before.boundary_self_intersections);
    check_invariants(label, &before, &after);
    CHECK_NEAR(after.min_dihedral, ir->min_dihedral_after, 1e-9);
    CHECK_NEAR(after.max_dihedral, ir->max_dihedral_after, 1e-9);
    CHECK(after.slivers_10 == ir->slivers_10_after);
    return 1;
}

static void check_bar(const char *label, const vm_improve_report *r) {
    CHECK_MSG(r->min_dihedral_after >= 10.0, "%s: min dihedral %.2f", label,
              r->min_dihedral_after);
    CHECK_MSG(r->max_dihedral_after <= 165.0, "%s: max dihedral %.2f", label,
              r->max_dihedral_after);
    CHECK_MSG(r->abaqus_after == 0, "%s: %zu ABAQUS failures", label, r->abaqus_after);
    CHECK_MSG(r->inverted_after == 0, "%s: %zu inverted", label, r->inverted_after);
    CHECK_MSG(r->unfixed == 0, "%s: %zu unfixed", label, r->unfixed);
}

/* --- phantoms ------------------------------------------------------------------------------ */

static void phantom_case(vm_phantom_kind kind, int n, int adaptive) {
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    char label[64];
    snprintf(label, sizeof label, "%s %d%s", info.name, n, adaptive ? " adaptive" : "");
    vm_mesh m;
    vm_improve_report r;
    if (mesh_and_improve(label, &v, 0.0, 1, adaptive, &m, &r)) {
        check_bar(label, &r);
        double dv = fabs(r.volume_after - r.volume_before) / r.volume_before;
        CHECK_MSG(dv < 0.01, "%s: volume changed by %.3f%%", label, 100 * dv);
        CHECK_MSG(r.max_surface_move <= 0.8 + 1e-9, "%s: surface vertex moved %.3f voxels",
                  label, r.max_surface_move);
        CHECK(r.inverted_after == 0);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void phantomsMeetTheQualityBarAndKeepTheirTopology(void) {
    for (int adaptive = 0; adaptive < 2; adaptive++) {
        phantom_case(VM_PHANTOM_SPHERE, 48, adaptive);
        phantom_case(VM_PHANTOM_TORUS, 64, adaptive);
        phantom_case(VM_PHANTOM_GENUS3, 64, adaptive);
        phantom_case(VM_PHANTOM_TWO_SPHERES, 56, adaptive);
        phantom_case(VM_PHANTOM_CUT_SPHERE, 64, adaptive);
        phantom_case(VM_PHANTOM_PLATE, 48, adaptive);
    }
}

/* Boundary vertices of a tet mesh (faces used once), as a 0/1 flag per point. */
static int face_cmp(const void *pa, const void *pb) {
    const vm_index *a = pa, *b = pb;
    for (int k = 0; k < 3; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

static unsigned char *boundary_points(const vm_mesh *m) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    vm_index *f = malloc(12 * m->ncells * sizeof *f);
    unsigned char *on = calloc(m->npoints, 1);
    if (!f || !on) {
        free(f);
        free(on);
        return NULL;
    }
    for (size_t t = 0; t < m->ncells; t++)
        for (int i = 0; i < 4; i++) {
            vm_index *k = f + 3 * (4 * t + (size_t)i);
            for (int j = 0; j < 3; j++) k[j] = m->cells[4 * t + (size_t)fo[i][j]];
            for (int a = 0; a < 3; a++)
                for (int b = a + 1; b < 3; b++)
                    if (k[b] < k[a]) {
                        vm_index x = k[a];
                        k[a] = k[b];
                        k[b] = x;
                    }
        }
    size_t nf = 4 * m->ncells;
    qsort(f, nf, 3 * sizeof *f, face_cmp);
    for (size_t i = 0; i < nf;) {
        size_t j = i + 1;
        while (j < nf && face_cmp(f + 3 * j, f + 3 * i) == 0) j++;
        if (j - i == 1)
            for (int k = 0; k < 3; k++) on[f[3 * i + k]] = 1;
        i = j;
    }
    free(f);
    return on;
}

static void sphereSurfaceStaysWithinHalfAVoxelOfTheSphere(void) {
    const int n = 64;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, n, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh m;
    vm_improve_report r;
    if (mesh_and_improve("sphere 64 (surface distance)", &v, 0.0, 1, 0, &m, &r)) {
        unsigned char *on = boundary_points(&m);
        CHECK(on != NULL);
        double c = 0.5 * (n - 1), rad = 0.35 * (n - 1), worst = 0.0;
        size_t nb = 0;
        for (size_t i = 0; on && i < m.npoints; i++) {
            if (!on[i]) continue;
            const double *p = m.points + 3 * i;
            double d = sqrt((p[0] - c) * (p[0] - c) + (p[1] - c) * (p[1] - c) +
                            (p[2] - c) * (p[2] - c));
            if (fabs(d - rad) > worst) worst = fabs(d - rad);
            nb++;
        }
        printf("    %zu boundary points, largest | |p - c| - r | = %.3f voxel\n", nb, worst);
        CHECK_MSG(worst <= 0.5, "boundary point %.3f voxel off the sphere", worst);
        free(on);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void alreadyGoodMeshIsNotMadeWorse(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 48, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh m;
    vm_improve_report r1, r2;
    if (mesh_and_improve("torus 48 (first run)", &v, 0.0, 1, 0, &m, &r1)) {
        /* A second run starts from a mesh already meeting the targets. */
        vm_mesh_report before, after;
        checked(&m, &before);
        vm_improve_options o;
        vm_improve_options_default(&o);
        CHECK_OK(vm_mesh_improve(&m, &v, &o, &r2, &err), &err);
        print_report("torus 48 (second run)", &r2);
        checked(&m, &after);
        check_invariants("torus 48 (second run)", &before, &after);
        CHECK(r2.min_dihedral_after >= r2.min_dihedral_before);
        CHECK(r2.max_dihedral_after <= r2.max_dihedral_before);
        CHECK(r2.abaqus_after <= r2.abaqus_before);
        CHECK(r2.slivers_10_after <= r2.slivers_10_before);
    }
    vm_mesh_free(&m);
    /* The plate mesh is good from the start (min dihedral above 30): nothing gets worse. */
    vm_volume_free(&v);
    CHECK_OK(vm_phantom_make(VM_PHANTOM_PLATE, 48, 0.0, 1, &v, NULL, &err), &err);
    if (mesh_and_improve("plate 48 (good input)", &v, 0.0, 1, 0, &m, &r1)) {
        CHECK(r1.min_dihedral_after >= r1.min_dihedral_before);
        CHECK(r1.max_dihedral_after <= r1.max_dihedral_before);
        CHECK_NEAR(r1.volume_after, r1.volume_before, 1e-9 * r1.volume_before);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void meshWithoutTheVolumeStillImproves(void) {
    const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS, VM_PHANTOM_CUT_SPHERE};
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        CHECK_OK(vm_phantom_make(kinds[i], 48, 0.0, 1, &v, &info, &err), &err);
        char label[64];
        snprintf(label, sizeof label, "%s 48 without the volume", info.name);
        vm_mesh m;
        vm_improve_report r;
        if (mesh_and_improve(label, &v, 0.0, 0, 0, &m, &r)) {
            /* Weaker bar: tangent-plane moves only, so surface slivers may stay. */
            CHECK_MSG(r.min_dihedral_after >= 5.0, "%s: min dihedral %.2f", label,
                      r.min_dihedral_after);
            CHECK_MSG(r.max_dihedral_after <= 170.0, "%s: max dihedral %.2f", label,
                      r.max_dihedral_after);
            CHECK_MSG(r.abaqus_after * 20 <= r.abaqus_before, "%s: ABAQUS %zu -> %zu", label,
                      r.abaqus_before, r.abaqus_after);
            double dv = fabs(r.volume_after - r.volume_before) / r.volume_before;
            CHECK_MSG(dv < 0.01, "%s: volume changed by %.3f%%", label, 100 * dv);
        }
        vm_mesh_free(&m);
        vm_volume_free(&v);
    }
}

/* --- shared volumes ------------------------------------------------------------------------- */

/* Every shared volume at the isovalues of ../shared/data/README.md (as in test_mesh_tets.c). */
static const struct {
    const char *file;
    double iso;
} shared_cases[] = {{"ct_head_quarter.nrrd", 500}, {"ct_head_quarter.nrrd", 1150},
                    {"HeadMRVolume.mhd", 50},      {"ironProt.vtk", 128},
                    {"hydrogen.vti", 0.1},         {"avg152T1_RL_nifti.nii.gz", 100}};

static void shared_case(const char *name, double iso, int adaptive) {
    const char *path = vm_test_shared(name);
    if (!path) return;
    vm_volume v;
    vm_error err;
    vm_status s = vm_volume_read(path, &v, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return;
    char label[128];
    snprintf(label, sizeof label, "%s iso %g%s", name, iso, adaptive ? " adaptive" : "");
    vm_mesh m;
    vm_improve_report r;
    if (mesh_and_improve(label, &v, iso, 1, adaptive, &m, &r)) {
        check_bar(label, &r);
        double dv = fabs(r.volume_after - r.volume_before) / r.volume_before;
        CHECK_MSG(dv < 0.02, "%s: volume changed by %.3f%%", label, 100 * dv);
        CHECK_MSG(r.max_surface_move <= 0.8 + 1e-9, "%s: surface vertex moved %.3f voxels",
                  label, r.max_surface_move);
    }
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

static void sharedVolumesMeetTheQualityBarUniformAndAdaptive(void) {
    for (int adaptive = 0; adaptive < 2; adaptive++)
        for (size_t c = 0; c < sizeof shared_cases / sizeof shared_cases[0]; c++)
            shared_case(shared_cases[c].file, shared_cases[c].iso, adaptive);
}

static void fieldsFollowTheirCellsAndPoints(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 32, 0.0, 1, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m, NULL, &err), &err);
    double *cf = malloc(m.ncells * sizeof *cf), *pf = malloc(m.npoints * sizeof *pf);
    CHECK(cf != NULL && pf != NULL);
    if (cf && pf) {
        for (size_t i = 0; i < m.ncells; i++) cf[i] = 3.0;
        for (size_t i = 0; i < m.npoints; i++) pf[i] = (double)i;
        CHECK_OK(vm_mesh_set_field(&m, 1, "c", 1, cf, &err), &err);
        CHECK_OK(vm_mesh_set_field(&m, 0, "p", 1, pf, &err), &err);
        vm_improve_report r;
        CHECK_OK(vm_mesh_improve(&m, &v, NULL, &r, &err), &err);
        CHECK(r.collapses > 0 && m.npoints < r.points_before);
        const vm_field *c = vm_mesh_find_field(&m, 1, "c"), *p = vm_mesh_find_field(&m, 0, "p");
        CHECK(c != NULL && p != NULL);
        int ok = 1;
        for (size_t i = 0; c && i < m.ncells; i++) ok &= c->data[i] == 3.0;
        /* Points keep their input order: the old ids increase. */
        for (size_t i = 1; p && i < m.npoints; i++) ok &= p->data[i] > p->data[i - 1];
        CHECK(ok);
    }
    free(cf);
    free(pf);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* --- bad input ------------------------------------------------------------------------------ */

static void badInputGivesACleanError(void) {
    vm_error err;
    vm_mesh m;
    vm_improve_report r;
    /* A hex mesh. */
    vm_mesh_init(&m, VM_HEX8);
    const double cube[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                               {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    for (int i = 0; i < 8; i++) vm_mesh_add_point(&m, cube[i], &err);
    const vm_index hex[8] = {0, 1, 2, 3, 4, 5, 6, 7};
    CHECK_OK(vm_mesh_add_cell(&m, hex, 0, &err), &err);
    CHECK(vm_mesh_improve(&m, NULL, NULL, &r, &err) == VM_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "tet4") != NULL);
    CHECK(m.ncells == 1 && m.npoints == 8);
    vm_mesh_free(&m);
    /* An empty tet mesh. */
    vm_mesh_init(&m, VM_TET4);
    CHECK(vm_mesh_improve(&m, NULL, NULL, &r, &err) == VM_ERR_EMPTY);
    /* A node index out of range, then an inverted tet: the mesh stays as it was. */
    for (int i = 0; i < 4; i++) vm_mesh_add_point(&m, cube[i == 3 ? 4 : i], &err);
    const vm_index bad[4] = {0, 1, 2, 9}, inv[4] = {0, 2, 1, 3};
    CHECK_OK(vm_mesh_add_cell(&m, bad, 0, &err), &err);
    CHECK(vm_mesh_improve(&m, NULL, NULL, &r, &err) == VM_ERR_ARG);
    memcpy(m.cells, inv, sizeof inv);
    CHECK(vm_mesh_improve(&m, NULL, NULL, &r, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "inverted") != NULL);
    CHECK(m.cells[1] == 2 && m.cells[2] == 1);
    vm_mesh_free(&m);
}

static void singleTetIsReturnedUnchanged(void) {
    vm_error err;
    vm_mesh m;
    vm_improve_report r;
    vm_mesh_init(&m, VM_TET4);
    const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 0.01}};
    for (int i = 0; i < 4; i++) vm_mesh_add_point(&m, p[i], &err);
    const vm_index t[4] = {0, 1, 2, 3};
    CHECK_OK(vm_mesh_add_cell(&m, t, 7, &err), &err);
    vm_improve_options o;
    vm_improve_options_default(&o);
    o.mark_unfixed = 1;
    CHECK_OK(vm_mesh_improve(&m, NULL, &o, &r, &err), &err);
    /* All four vertices are on the boundary and it cannot be fixed: it is reported. */
    CHECK(m.ncells == 1 && m.npoints == 4 && m.region[0] == 7);
    CHECK(r.unfixed == 1 && r.abaqus_after == 1);
    const vm_field *f = vm_mesh_find_field(&m, 1, "improve_unfixed");
    CHECK(f != NULL && f->ncomp == 1 && f->data[0] == 1.0);
    vm_mesh_free(&m);
}

/* The crossing check of these tests sees two tets pushed through each other, and not two
 * tets side by side. */
static void boundaryCrossingCheckSeesCrossingTets(void) {
    vm_error err;
    vm_mesh m;
    vm_mesh_init(&m, VM_TET4);
    const double p[8][3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2},
                            {0.5, 0.5, -1}, {2.5, 0.5, -1}, {0.5, 2.5, -1}, {0.5, 0.5, 1}};
    for (int i = 0; i < 8; i++) vm_mesh_add_point(&m, p[i], &err);
    const vm_index a[4] = {0, 1, 2, 3}, b[4] = {4, 5, 6, 7};
    CHECK_OK(vm_mesh_add_cell(&m, a, 0, &err), &err);
    CHECK_OK(vm_mesh_add_cell(&m, b, 0, &err), &err);
    CHECK(boundary_self_intersections(&m) > 0);
    for (int i = 4; i < 8; i++) m.points[3 * (size_t)i + 2] -= 3.0;
    CHECK(boundary_self_intersections(&m) == 0);
    vm_mesh_free(&m);
}

/* The pass reports its rounds in order and ends with done == total (the CLI's bar). */
static void progressIsReportedRoundByRound(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_TORUS, 24, 0.0, 0, &v, NULL, &err), &err);
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    vm_mesh m;
    CHECK_OK(vm_mesh_volume(&v, &mo, &m, NULL, &err), &err);
    vm_improve_options o;
    vm_improve_options_default(&o);
    vm_test_progress_log pl = {"improve", 0, 0, 0, 0, 0, 0.0, 0.0};
    o.progress = vm_test_progress;
    o.progress_user = &pl;
    vm_improve_report r;
    CHECK_OK(vm_mesh_improve(&m, &v, &o, &r, &err), &err);
    CHECK(pl.calls >= 2 && pl.backwards == 0 && pl.ended && pl.other_stage == 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(boundaryCrossingCheckSeesCrossingTets),
          T(phantomsMeetTheQualityBarAndKeepTheirTopology),
          T(sphereSurfaceStaysWithinHalfAVoxelOfTheSphere), T(alreadyGoodMeshIsNotMadeWorse),
          T(meshWithoutTheVolumeStillImproves),
          T(sharedVolumesMeetTheQualityBarUniformAndAdaptive), T(fieldsFollowTheirCellsAndPoints),
          T(badInputGivesACleanError),
          T(singleTetIsReturnedUnchanged), T(progressIsReportedRoundByRound))
