/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/surface/test_surface_asc.c — adaptive skeleton climbing surfaces: closed, manifold,
 * outward, free of self-intersections, with the phantom's Euler characteristic, components
 * and volume, near the analytic surface, and with far fewer triangles at max level 4 than
 * with unit cells (max level 0) on the same isovalue. */
#include "test.h"
#include "volmesh/surface.h"
#include <string.h>

typedef struct asc_result {
    size_t tris, points;
    long euler;
    size_t components;
    double volume;
    double min_angle;
    double hausdorff; /* largest |phantom field| at vertices, centroids and edge midpoints */
    double seconds;
} asc_result;

/* Trilinear value of v at index point x (clamped to the grid). */
static double trilinear(const vm_volume *v, const double x[3]) {
    int64_t i0[3];
    double t[3];
    for (int a = 0; a < 3; a++) {
        double c = x[a];
        if (c < 0) c = 0;
        if (c > (double)(v->dims[a] - 1)) c = (double)(v->dims[a] - 1);
        i0[a] = (int64_t)c;
        if (i0[a] >= v->dims[a] - 1) i0[a] = v->dims[a] > 1 ? v->dims[a] - 2 : 0;
        t[a] = c - (double)i0[a];
    }
    double s = 0;
    for (int k = 0; k < 8; k++) {
        int64_t p[3];
        double w = 1;
        for (int a = 0; a < 3; a++) {
            int bit = (k >> a) & 1;
            p[a] = i0[a] + bit;
            if (p[a] >= v->dims[a]) p[a] = v->dims[a] - 1;
            w *= bit ? t[a] : 1 - t[a];
        }
        s += w * v->data[p[0] + v->dims[0] * (p[1] + v->dims[1] * p[2])];
    }
    return s;
}

/* Checks the invariants of a closed surface; euler < -1000 skips Euler and components. */
static int check_surface(const vm_mesh *m, long euler, size_t components, asc_result *r) {
    vm_mesh_report rep;
    vm_error err;
    memset(&rep, 0, sizeof rep);
    vm_status s = vm_mesh_check(m, &rep, &err);
    CHECK_OK(s, &err);
    if (s) return 0;
    CHECK(m->kind == VM_TRI3);
    CHECK(rep.cells > 0);
    CHECK_MSG(rep.boundary_closed == 1, "open %zu, non-manifold edges %zu",
              rep.boundary_open_edges, rep.boundary_nonmanifold_edges);
    CHECK_MSG(rep.boundary_nonmanifold_vertices == 0, "%zu non-manifold vertices",
              rep.boundary_nonmanifold_vertices);
    CHECK_MSG(rep.degenerate == 0, "%zu degenerate triangles", rep.degenerate);
    CHECK_MSG(rep.boundary_self_intersections == 0, "%zu pairs of triangles intersect",
              rep.boundary_self_intersections);
    CHECK_MSG(rep.volume > 0, "volume %g (inward orientation?)", rep.volume);
    if (euler > -1000) {
        CHECK_MSG(rep.boundary_euler == euler, "Euler %ld, expected %ld", rep.boundary_euler,
                  euler);
        CHECK_MSG(rep.boundary_components == components, "%zu components, expected %zu",
                  rep.boundary_components, components);
    }
    r->tris = rep.cells;
    r->points = rep.points;
    r->euler = rep.boundary_euler;
    r->components = rep.boundary_components;
    r->volume = rep.volume;
    r->min_angle = 180;
    for (size_t c = 0; c < m->ncells; c++) {
        double p[3][3];
        for (int k = 0; k < 3; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[3 * c + k], sizeof p[k]);
        double a = vm_tri_min_angle((const double(*)[3])p);
        if (a < r->min_angle) r->min_angle = a;
    }
    return 1;
}

/* Largest |field| of the (noise-free, signed-distance) phantom f over the vertices, the
 * triangle centroids and the edge midpoints of m: the distance from those points to the
 * analytic surface (the field is a signed distance in voxels, trilinear between samples),
 * so a one-sided Hausdorff distance up to the sampling of the triangles. Inside the
 * material the distance to the grid border counts too (the closing faces). */
static double hausdorff_estimate(const vm_mesh *m, const vm_volume *f) {
    double h = 0;
    for (size_t c = 0; c < m->ncells; c++) {
        const double *p[3];
        for (int k = 0; k < 3; k++)
            p[k] = m->points + 3 * (size_t)m->cells[3 * c + k];
        double q[7][3];
        for (int a = 0; a < 3; a++) {
            q[0][a] = p[0][a];
            q[1][a] = p[1][a];
            q[2][a] = p[2][a];
            q[3][a] = (p[0][a] + p[1][a]) / 2;
            q[4][a] = (p[1][a] + p[2][a]) / 2;
            q[5][a] = (p[2][a] + p[0][a]) / 2;
            q[6][a] = (p[0][a] + p[1][a] + p[2][a]) / 3;
        }
        for (int k = 0; k < 7; k++) {
            double fv = trilinear(f, q[k]), d = fabs(fv);
            /* material cut by the grid border is closed there: the flat faces are at the
             * distance to the border, not at the field's value */
            for (int a = 0; a < 3 && fv > 0; a++) {
                double b = fmin(fabs(q[k][a]), fabs(q[k][a] - (double)(f->dims[a] - 1)));
                if (b < d) d = b;
            }
            if (d > h) h = d;
        }
    }
    return h;
}

static vm_status extract(const vm_volume *v, int level, double iso, vm_mesh *s,
                         vm_surface_stats *st, vm_error *err) {
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_ASC;
    o.max_level = level;
    o.lo = iso;
    return vm_surface_extract(v, &o, s, st, err);
}

static int sanitized(void) {
    return getenv("VM_SANITIZED") != NULL;
}

/* One phantom at max levels 0 and 4: invariants at both, the volume within vol_tol of the
 * analytic one, distance bound, and the triangle ratio. */
static void phantom_case(vm_phantom_kind kind, int n, double noise, double vol_tol, double hd0,
                         double hd4, double min_ratio) {
    vm_volume v, clean;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(kind, n, noise, 7, &v, &info, &err), &err);
    CHECK_OK(vm_phantom_make(kind, n, 0, 7, &clean, NULL, &err), &err);
    asc_result r[2];
    int levels[2] = {0, 4};
    for (int li = 0; li < 2; li++) {
        vm_mesh m;
        vm_surface_stats st;
        memset(&r[li], 0, sizeof r[li]);
        vm_status s = extract(&v, levels[li], 0.0, &m, &st, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        /* the noisy fields have their own topology: only closed, manifold, outward */
        int ok =
            check_surface(&m, noise > 0 ? -10000 : info.euler, (size_t)info.components, &r[li]);
        r[li].seconds = st.seconds;
        if (ok && noise == 0) {
            double rel = (r[li].volume - info.volume) / info.volume;
            CHECK_MSG(fabs(rel) <= vol_tol,
                      "volume %.6g, analytic %.6g (%+.3f%%, bound %.1f%%)", r[li].volume,
                      info.volume, 100 * rel, 100 * vol_tol);
            r[li].hausdorff = hausdorff_estimate(&m, &clean);
            double hd_bound = li ? hd4 : hd0;
            CHECK_MSG(r[li].hausdorff <= hd_bound, "distance to the surface %.3f > %.3f",
                      r[li].hausdorff, hd_bound);
        }
        printf(
            "    %s n=%d noise=%g level %d: triangles %zu points %zu Euler %ld components %zu "
            "volume %+.3f%% min angle %.2f distance %.3f (%.3f s)\n",
            info.name, n, noise, levels[li], r[li].tris, r[li].points, r[li].euler,
            r[li].components, 100 * (r[li].volume - info.volume) / info.volume, r[li].min_angle,
            r[li].hausdorff, r[li].seconds);
        vm_mesh_free(&m);
    }
    if (r[1].tris > 0) {
        double ratio = (double)r[0].tris / (double)r[1].tris;
        printf("    %s: level 0 / level 4 triangles = %.2f\n", info.name, ratio);
        CHECK_MSG(ratio >= min_ratio, "reduction %.2f below %.2f", ratio, min_ratio);
    }
    fflush(stdout);
    vm_volume_free(&v);
    vm_volume_free(&clean);
}

static int size_n(void) {
    return 64;
}

/* Bounds: the distance at level 0 is that of the unit-edge interpolation of a signed
 * distance field (< 0.1 voxel); at level 4 the iso points of a box lie in a slab of
 * thickness o.error = 0.5, and its triangles in the same slab, so the distance stays below
 * 0.5. Material closed at the border lies on the box planes (the Hausdorff estimate counts
 * the distance to the border there). Volume: 2% (the thin genus-3 tubes lose 1.7% at
 * level 0 already, and 3.2% at level 4). Reduction ratios: measured at 64^3 minus ~10%. */
static void sphereIsClosedWithEuler2AndFewerTriangles(void) {
    phantom_case(VM_PHANTOM_SPHERE, size_n(), 0, 0.02, 0.1, 0.5, 8.0);
}
static void torusIsClosedWithEuler0(void) {
    phantom_case(VM_PHANTOM_TORUS, size_n(), 0, 0.02, 0.1, 0.5, 3.5);
}
static void genus3IsClosedWithEulerMinus4(void) {
    phantom_case(VM_PHANTOM_GENUS3, size_n(), 0, 0.04, 0.1, 0.5, 1.7);
}
static void twoSpheresAreTwoClosedComponents(void) {
    phantom_case(VM_PHANTOM_TWO_SPHERES, size_n(), 0, 0.02, 0.1, 0.5, 4.5);
}
static void cutSphereIsClosedAtTheBorder(void) {
    phantom_case(VM_PHANTOM_CUT_SPHERE, size_n(), 0, 0.04, 0.1, 0.5, 6.0);
}
static void noisyPhantomsStayClosedManifoldOutward(void) {
    phantom_case(VM_PHANTOM_SPHERE, size_n(), 0.5, 0, 0, 0, 1.0);
    if (sanitized()) return;
    phantom_case(VM_PHANTOM_TORUS, size_n(), 1.0, 0, 0, 0, 1.0);
    phantom_case(VM_PHANTOM_GENUS3, size_n(), 1.0, 0, 0, 0, 1.0);
}

/* A shared volume at iso: closed, manifold, outward, no self-intersections at levels 0 and
 * 4, the same Euler characteristic and components at both (climbing never changes the
 * topology of the unit-cell surface), fewer triangles at level 4. */
static void shared_case(const char *name, double iso, double min_ratio) {
    const char *path = vm_test_shared(name);
    if (!path) return;
    vm_volume v;
    vm_error err;
    vm_status s = vm_volume_read(path, &v, &err);
    CHECK_OK(s, &err);
    if (s) return;
    asc_result r[2];
    int levels[2] = {0, 4};
    for (int li = 0; li < 2; li++) {
        vm_mesh m;
        vm_surface_stats st;
        memset(&r[li], 0, sizeof r[li]);
        s = extract(&v, levels[li], iso, &m, &st, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        long euler = li ? r[0].euler : -10000;
        check_surface(&m, euler, r[0].components, &r[li]);
        printf("    %s iso %g level %d: triangles %zu points %zu Euler %ld components %zu "
               "volume %.6g min angle %.2f (%.3f s)\n",
               name, iso, levels[li], r[li].tris, r[li].points, r[li].euler, r[li].components,
               r[li].volume, r[li].min_angle, st.seconds);
        vm_mesh_free(&m);
    }
    if (r[1].tris > 0) {
        double ratio = (double)r[0].tris / (double)r[1].tris;
        double dv = (r[1].volume - r[0].volume) / r[0].volume;
        printf("    %s: level 0 / level 4 triangles = %.2f, volume change %+.3f%%\n", name,
               ratio, 100 * dv);
        CHECK_MSG(ratio >= min_ratio, "reduction %.2f below %.2f", ratio, min_ratio);
    }
    fflush(stdout);
    vm_volume_free(&v);
}

static void ironProteinKeepsEveryComponent(void) {
    shared_case("ironProt.vtk", 128, 1.75);
}
static void hydrogenIsClosedAndCoarser(void) {
    shared_case("hydrogen.vti", 0.1, 3.3);
}
static void ctHeadSkinIsClosedAndCoarser(void) {
    shared_case("ct_head_quarter.nrrd", 500, 2.5);
}

/* Random smoothed fields, several isovalues and errors: at every max level the surface is
 * closed, manifold, outward and free of self-intersections, with the Euler characteristic
 * and components of level 0 (climbing to larger boxes never changes the topology of the
 * unit-cell surface). Error 2 caught boxes with a diagonal unit square inside, which the
 * boxes now refuse. */
static void randomFieldsKeepTheUnitCellTopologyAtEveryLevel(void) {
    /* seed 99, cases 0..39 (case 14 has a diagonal square inside a box at error 2); seed
     * 2024, case 68 only (two sheets in one box crossed at error 2) */
    int cases = sanitized() ? 16 : 40;
    for (int batch = 0; batch < 2; batch++) {
        unsigned seed = batch ? 2024 : 99;
        int last = batch ? 68 : cases - 1;
        for (int c = 0; c <= last; c++) {
            int64_t dims[3] = {24 + c % 7, 20 + c % 5, 22 + c % 3};
            vm_volume v;
            vm_error err;
            CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
            size_t n = vm_volume_count(&v);
            float *tmp = malloc(n * sizeof *tmp);
            for (size_t i = 0; i < n; i++) {
                seed = seed * 1103515245u + 12345u;
                v.data[i] = (float)((seed >> 8) & 0xffff) / 65535.0f - 0.5f;
            }
            /* box smoothing, 1 + c % 6 passes: from rough noise to blobs */
            for (int pass = 0; pass < 1 + c % 6; pass++) {
                for (int64_t k = 0; k < dims[2]; k++)
                    for (int64_t j = 0; j < dims[1]; j++)
                        for (int64_t i = 0; i < dims[0]; i++) {
                            double sum = 0;
                            int cnt = 0;
                            for (int dk = -1; dk <= 1; dk++)
                                for (int dj = -1; dj <= 1; dj++)
                                    for (int di = -1; di <= 1; di++) {
                                        int64_t a = i + di, b = j + dj, d = k + dk;
                                        if (a < 0 || b < 0 || d < 0 || a >= dims[0] ||
                                            b >= dims[1] || d >= dims[2])
                                            continue;
                                        sum += v.data[a + dims[0] * (b + dims[1] * d)];
                                        cnt++;
                                    }
                            tmp[i + dims[0] * (j + dims[1] * k)] = (float)(sum / cnt);
                        }
                memcpy(v.data, tmp, n * sizeof *tmp);
            }
            free(tmp);
            if (batch && c != last) {
                vm_volume_free(&v);
                continue;
            }
            asc_result r0;
            memset(&r0, 0, sizeof r0);
            for (int level = 0; level <= 5; level++) {
                vm_mesh m;
                asc_result r;
                memset(&r, 0, sizeof r);
                vm_surface_options o;
                vm_surface_options_default(&o);
                o.method = VM_SURFACE_ASC;
                o.max_level = level;
                o.lo = ((c * 37) % 11 - 5) * 0.01;
                o.error = c % 3 == 0 ? 0.25 : c % 3 == 1 ? 0.5 : 2.0; /* 2: many large boxes */
                vm_status s = vm_surface_extract(&v, &o, &m, NULL, &err);
                if (s == VM_ERR_EMPTY) break;
                CHECK_OK(s, &err);
                if (s) break;
                int fails = vm_test_failures;
                check_surface(&m, level ? r0.euler : -10000, r0.components, &r);
                if (vm_test_failures != fails)
                    printf("    seed %u case %d (smoothing %d) level %d: %zu triangles\n",
                           batch ? 2024u : 99u, c, 1 + c % 6, level, r.tris);
                if (level == 0) r0 = r;
                vm_mesh_free(&m);
            }
            vm_volume_free(&v);
        }
    }
}

/* Bad options are refused with a one-line message naming the option. */
static void badOptionsAreRefusedWithAMessage(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0, 1, &v, NULL, &err), &err);
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_ASC;
    vm_mesh m;
    o.error = 0;
    CHECK(vm_surface_extract(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "error") != NULL && strchr(err.message, '\n') == NULL);
    o.error = 0.5;
    o.max_level = 11;
    CHECK(vm_surface_extract(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "max level") != NULL && strchr(err.message, '\n') == NULL);
    o.max_level = 4;
    o.lo = 1e9; /* nothing is in the material */
    CHECK(vm_surface_extract(&v, &o, &m, NULL, &err) == VM_ERR_EMPTY);
    vm_volume_free(&v);
}

/* Larger boxes give fewer triangles on a smooth shape: counts fall with max level. */
static void trianglesFallAsTheBoxesGrow(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 64, 0, 1, &v, NULL, &err), &err);
    size_t prev = 0;
    printf("    sphere 64:");
    for (int level = 0; level <= 10; level++) {
        vm_mesh m;
        vm_status s = extract(&v, level, 0.0, &m, NULL, &err);
        CHECK_OK(s, &err);
        if (s) break;
        printf(" L%d %zu", level, m.ncells);
        /* strictly fewer up to 8-cell boxes; 16-cell boxes are too curved at error 0.5 */
        if (level > 0 && level <= 3)
            CHECK_MSG(m.ncells < prev, "level %d: %zu >= %zu", level, m.ncells, prev);
        if (level > 3)
            CHECK_MSG(m.ncells <= prev, "level %d: %zu > %zu", level, m.ncells, prev);
        prev = m.ncells;
        vm_mesh_free(&m);
    }
    printf("\n");
    vm_volume_free(&v);
}

/* Small grids: one inside sample is closed by the padding into an octahedron (8 triangles,
 * Euler 2); one inside slice into a flat closed slab; at every level. */
static void singleSampleAndSingleSliceAreClosed(void) {
    int64_t dims[3] = {7, 5, 2};
    vm_volume v;
    vm_error err;
    for (int c = 0; c < 2; c++) {
        CHECK_OK(vm_volume_alloc(&v, dims, &err), &err);
        for (size_t i = 0; i < vm_volume_count(&v); i++)
            v.data[i] = c == 0 ? (i == 8 ? 1.0f : 0.0f) : (i < 35 ? 1.0f : 0.0f);
        for (int level = 0; level <= 4; level += 2) {
            vm_mesh m;
            asc_result r;
            memset(&r, 0, sizeof r);
            vm_status s = extract(&v, level, 0.5, &m, NULL, &err);
            CHECK_OK(s, &err);
            if (s) continue;
            check_surface(&m, 2, 1, &r);
            if (c == 0) CHECK_MSG(m.ncells == 8, "%zu triangles for one sample", m.ncells);
            vm_mesh_free(&m);
        }
        vm_volume_free(&v);
    }
}

/* DESIGN: material touching the volume border is closed there by flat faces on the box. The
 * cut sphere (centre 0.15 (n-1) from the plane x = 0, radius 0.35 (n-1)): every vertex lies
 * in the box [0, n-1]^3 up to 0.01 voxel (the padding pressed onto the box), and the
 * triangles on the plane x = 0 (within 0.01) face -x and cover the cut disc (their area
 * within 5% of pi (r^2 - c^2); the marching-squares polygon is inscribed). */
static void borderCapsLieOnTheBoxPlanes(void) {
    int n = sanitized() ? 32 : 48;
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_CUT_SPHERE, n, 0, 7, &v, &info, &err), &err);
    double n1 = n - 1, r = 0.35 * n1, c = 0.15 * n1;
    double disc = 3.14159265358979 * (r * r - c * c);
    for (int level = 0; level <= 4; level += 4) {
        vm_mesh m;
        asc_result res;
        memset(&res, 0, sizeof res);
        vm_status s = extract(&v, level, 0.0, &m, NULL, &err);
        CHECK_OK(s, &err);
        if (s) continue;
        check_surface(&m, 2, 1, &res);
        size_t outside = 0, wrong_way = 0;
        for (size_t p = 0; p < m.npoints; p++)
            for (int a = 0; a < 3; a++) {
                double x = (m.points[3 * p + a] - v.origin[a]) / v.spacing[a];
                if (x < -0.01 - 1e-9 || x > n1 + 0.01 + 1e-9) outside++;
            }
        double cap = 0;
        for (size_t t = 0; t < m.ncells; t++) {
            const double *q[3];
            int on = 1;
            for (int k = 0; k < 3; k++) {
                q[k] = m.points + 3 * (size_t)m.cells[3 * t + k];
                if (fabs(q[k][0] - v.origin[0]) > 0.01 * v.spacing[0] + 1e-9) on = 0;
            }
            if (!on) continue;
            double u[3], w[3];
            for (int a = 0; a < 3; a++) u[a] = q[1][a] - q[0][a], w[a] = q[2][a] - q[0][a];
            double nx = u[1] * w[2] - u[2] * w[1];
            if (nx > 0) wrong_way++;
            cap += 0.5 * fabs(nx) / (v.spacing[1] * v.spacing[2]);
        }
        printf("    cut sphere n=%d level %d: %zu triangles, cap area %.1f (disc %.1f), %zu "
               "coordinates outside the box\n", n, level, m.ncells, cap, disc, outside);
        CHECK_MSG(outside == 0, "level %d: %zu coordinates outside the box", level, outside);
        CHECK_MSG(wrong_way == 0, "level %d: %zu cap triangles face into the box", level,
                  wrong_way);
        CHECK_MSG(fabs(cap - disc) <= 0.05 * disc, "level %d: cap area %.1f, disc %.1f", level,
                  cap, disc);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

TEST_MAIN(T(sphereIsClosedWithEuler2AndFewerTriangles), T(torusIsClosedWithEuler0),
          T(genus3IsClosedWithEulerMinus4), T(twoSpheresAreTwoClosedComponents),
          T(cutSphereIsClosedAtTheBorder), T(noisyPhantomsStayClosedManifoldOutward),
          T(ironProteinKeepsEveryComponent), T(hydrogenIsClosedAndCoarser),
          T(ctHeadSkinIsClosedAndCoarser),
          T(randomFieldsKeepTheUnitCellTopologyAtEveryLevel),
          T(badOptionsAreRefusedWithAMessage), T(trianglesFallAsTheBoxesGrow),
          T(singleSampleAndSingleSliceAreClosed), T(borderCapsLieOnTheBoxPlanes))
