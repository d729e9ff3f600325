/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/mesher/test_mesh_lift.c — the lift (mesher/dc_lift.c): the dual-contouring mesher
 * run with and without it on phantoms in isotropic, anisotropic and rotated frames. With it,
 * the tets and the patch vertices are the same; only inner grid points move, each by at most
 * 0.4 of the shortest voxel edge, and no other point; the tets below the quality targets
 * (measured here on their own: dihedral and face angles against 15 and 150 degrees) are
 * fewer, the worst tet is no worse, none is inverted, the mesh is valid (conforming, closed
 * boundary of the phantom's Euler characteristic and components, volume); the stats count
 * the moves; the bytes are the same on 1, 2 and 3 threads; and an adaptive mesh keeps the
 * same properties. */
#include "mesher/mesher_internal.h"
#include "test.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define DEG (180.0 / 3.14159265358979323846)

static double angle(const double u[3], const double w[3]) {
    double d = u[0] * w[0] + u[1] * w[1] + u[2] * w[2];
    double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    double lw = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    double c = d / (lu * lw);
    return acos(c > 1 ? 1 : c < -1 ? -1 : c) * DEG;
}

static void cross(const double a[3], const double b[3], double o[3]) {
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* min(dmin / 15, (180 - dmax) / 30, fmin / 15, (180 - fmax) / 30); -1 when not positive. */
static double tet_q(const double p[4][3]) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    double n[4][3], e1[3], e2[3], e3[3], c[3];
    for (int a = 0; a < 3; a++) {
        e1[a] = p[1][a] - p[0][a];
        e2[a] = p[2][a] - p[0][a];
        e3[a] = p[3][a] - p[0][a];
    }
    cross(e2, e3, c);
    if (!(e1[0] * c[0] + e1[1] * c[1] + e1[2] * c[2] > 0)) return -1;
    double fmin = 180, fmax = 0, dmin = 180, dmax = 0;
    for (int f = 0; f < 4; f++) {
        for (int k = 0; k < 3; k++) {
            double u[3], w[3];
            for (int a = 0; a < 3; a++) {
                u[a] = p[fo[f][(k + 1) % 3]][a] - p[fo[f][k]][a];
                w[a] = p[fo[f][(k + 2) % 3]][a] - p[fo[f][k]][a];
            }
            double t = angle(u, w);
            fmin = t < fmin ? t : fmin;
            fmax = t > fmax ? t : fmax;
        }
        double u[3], w[3];
        for (int a = 0; a < 3; a++) {
            u[a] = p[fo[f][1]][a] - p[fo[f][0]][a];
            w[a] = p[fo[f][2]][a] - p[fo[f][0]][a];
        }
        cross(u, w, n[f]); /* outward */
    }
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            double t = 180 - angle(n[i], n[j]);
            dmin = t < dmin ? t : dmin;
            dmax = t > dmax ? t : dmax;
        }
    double q = dmin / 15, t;
    if ((t = (180 - dmax) / 30) < q) q = t;
    if ((t = fmin / 15) < q) q = t;
    if ((t = (180 - fmax) / 30) < q) q = t;
    return q;
}

/* Tets below the targets and the worst q of a mesh in world coordinates. */
static size_t below(const vm_mesh *m, double *worst) {
    size_t nb = 0;
    *worst = 1e300;
    for (size_t t = 0; t < m->ncells; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[4 * t + (size_t)k], sizeof p[k]);
        double q = tet_q((const double(*)[3])p);
        nb += q < 1;
        if (q < *worst) *worst = q;
    }
    return nb;
}

/* The soup of v's mesh, lifted or not, and its mesh in v's world frame. */
static int run(const vm_volume *v, int L, int lift, vm_mesh *m, vm_mesh_stats *st) {
    vm_error err;
    vm__grid g;
    memset(&g, 0, sizeof g);
    for (int a = 0; a < 3; a++)
        g.n[a] = v->dims[a];
    g.f = v->data;
    g.lo = 0.0;
    g.has_lo = 1;
    g.max_level = L;
    g.error = 0.5;
    g.lift = lift;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            g.frame[3 * r + c] = v->direction[r][c] * v->spacing[c];
    vm__tet_soup soup;
    memset(&soup, 0, sizeof soup);
    memset(st, 0, sizeof *st);
    vm_mesh_init(m, VM_TET4);
    vm_status s = vm__dual_contour_tets(&g, &soup, st, &err);
    CHECK_OK(s, &err);
    if (s) return 0;
    CHECK(lift || (!soup.nlift && !soup.lift_id));
    const double step[3] = {1, 1, 1};
    s = vm__soup_to_mesh(&soup, v, g.n, 0, step, m, &err);
    CHECK_OK(s, &err);
    return s == VM_OK;
}

static void check_valid(const vm_mesh *m, const vm_phantom_info *info, double vol_scale,
                        const char *label) {
    vm_error err;
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(m, &r, &err), &err);
    CHECK_MSG(r.inverted == 0 && r.overshared_faces == 0 && r.boundary_closed &&
                  r.boundary_euler == info->euler && r.components == (size_t)info->components &&
                  fabs(r.volume - vol_scale * info->volume) <=
                      0.02 * vol_scale * info->volume &&
                  r.boundary_self_intersections == 0,
              "%s: %zu inverted, %zu overshared, closed %d, Euler %ld (want %d), %zu "
              "components (want %d), volume %.6g (want %.6g), %zu self-intersections",
              label, r.inverted, r.overshared_faces, r.boundary_closed, r.boundary_euler,
              info->euler, r.components, info->components, r.volume, vol_scale * info->volume,
              r.boundary_self_intersections);
}

static void lift_case(vm_phantom_kind kind, int n, int L, const double sp[3], int rotate) {
    vm_error err;
    vm_volume v;
    vm_phantom_info info;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    if (!v.data) return;
    memcpy(v.spacing, sp, 3 * sizeof(double));
    if (rotate) { /* a rotation by 30 degrees about z */
        double c = cos(30 / DEG), s = sin(30 / DEG);
        double D[3][3] = {{c, -s, 0}, {s, c, 0}, {0, 0, 1}};
        memcpy(v.direction, D, sizeof D);
    }
    double vol_scale = sp[0] * sp[1] * sp[2];
    char label[160];
    snprintf(label, sizeof label, "%s %d, level %d, spacing (%g %g %g)%s", info.name, n, L,
             sp[0], sp[1], sp[2], rotate ? ", rotated" : "");
    vm_mesh raw, lifted;
    vm_mesh_stats s0, s1;
    int ok = run(&v, L, 0, &raw, &s0) && run(&v, L, 1, &lifted, &s1);
    if (ok) {
        CHECK_MSG(raw.ncells == lifted.ncells && raw.npoints == lifted.npoints &&
                      memcmp(raw.cells, lifted.cells, 4 * raw.ncells * sizeof(vm_index)) == 0,
                  "%s: the lift changed the tets", label);
        double h = sp[0] < sp[1] ? sp[0] : sp[1];
        h = h < sp[2] ? h : sp[2];
        size_t moved = 0, far = 0;
        for (size_t i = 0; i < raw.npoints; i++) {
            const double *a = raw.points + 3 * i, *b = lifted.points + 3 * i;
            double d = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                            (a[2] - b[2]) * (a[2] - b[2]));
            if (d > 0) moved++;
            if (d > 0.4 * h * (1 + 1e-9)) far++;
        }
        /* a moved point is a grid point: it had integer index coordinates, which every
         * point at a patch vertex misses (checked through the count: the moved points are
         * exactly those the stats report) */
        CHECK_MSG(moved == s1.lifted_vertices && far == 0 && s0.lifted_vertices == 0,
                  "%s: %zu points moved (stats %zu), %zu farther than 0.4 voxel", label, moved,
                  s1.lifted_vertices, far);
        double w0, w1;
        size_t b0 = below(&raw, &w0), b1 = below(&lifted, &w1);
        printf("  %s: %zu tets, %zu grid points lifted; below the targets %zu -> %zu, worst "
               "%.3f -> %.3f\n",
               label, raw.ncells, s1.lifted_vertices, b0, b1, w0, w1);
        CHECK_MSG(b0 == 0 || (s1.lifted_vertices > 0 && b1 < b0),
                  "%s: tets below the targets %zu -> %zu", label, b0, b1);
        CHECK_MSG(w1 >= w0 - 1e-9 && w1 > 0, "%s: worst %.6f -> %.6f", label, w0, w1);
        check_valid(&lifted, &info, vol_scale, label);
        /* the same bytes on any number of threads */
        int before = vm_set_threads(1);
        for (int t = 1; t <= 3; t += 2) {
            vm_set_threads(t);
            vm_mesh again;
            vm_mesh_stats st;
            if (run(&v, L, 1, &again, &st))
                CHECK_MSG(again.npoints == lifted.npoints &&
                              memcmp(again.points, lifted.points,
                                     3 * again.npoints * sizeof(double)) == 0,
                          "%s: %d thread(s) give other points", label, t);
            vm_mesh_free(&again);
        }
        vm_set_threads(before);
    }
    vm_mesh_free(&raw);
    vm_mesh_free(&lifted);
    vm_volume_free(&v);
}

static void liftMendsTetsAndMovesOnlyGridPoints(void) {
    const double iso[3] = {1, 1, 1}, aniso[3] = {1, 1, 2.2}, flat[3] = {2.13, 2.13, 1},
                 tall[3] = {1, 1, 5};
    lift_case(VM_PHANTOM_SPHERE, 40, 0, iso, 0);
    lift_case(VM_PHANTOM_SPHERE, 40, 0, tall, 1);
    lift_case(VM_PHANTOM_TORUS, 40, 0, aniso, 0);
    lift_case(VM_PHANTOM_GENUS3, 40, 0, flat, 1);
    lift_case(VM_PHANTOM_TWO_SPHERES, 40, 0, flat, 0);
}

static void liftOnAdaptiveMeshes(void) {
    const double iso[3] = {1, 1, 1}, flat[3] = {2.13, 2.13, 1};
    lift_case(VM_PHANTOM_TORUS, 41, 3, iso, 0);
    lift_case(VM_PHANTOM_GENUS3, 41, 2, flat, 1);
}

TEST_MAIN(T(liftMendsTetsAndMovesOnlyGridPoints), T(liftOnAdaptiveMeshes))
