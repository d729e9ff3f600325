/* tests/mesher/test_surface_cover.c — the disk-covering surface mesher (--method cover): closed,
 * consistently oriented manifolds with the phantom's Euler characteristic and components, no
 * self-intersections, the analytic volume, distance to the analytic surface below the error
 * parameter, triangle aspect ratio (shortest / longest edge) >= 0.3, fewer triangles at a larger
 * error, nested vertex sets, and the shared volumes. */
#include "test.h"
#include <stdint.h>
#include <string.h>

static int sanitized(void) { return getenv("VM_SANITIZED") != NULL; }

/* Trilinear interpolation of v (index space, clamped to the grid). */
static double trilinear(const vm_volume *v, const double p[3]) {
    const int64_t *n = v->dims;
    double t[3];
    int64_t i0[3];
    for (int a = 0; a < 3; a++) {
        double x = p[a];
        if (x < 0) x = 0;
        if (x > (double)(n[a] - 1)) x = (double)(n[a] - 1);
        i0[a] = (int64_t)floor(x);
        if (i0[a] >= n[a] - 1) i0[a] = n[a] > 1 ? n[a] - 2 : 0;
        t[a] = x - (double)i0[a];
    }
    double s = 0;
    for (int c = 0; c < 8; c++) {
        int64_t q[3];
        double w = 1;
        for (int a = 0; a < 3; a++) {
            int b = (c >> a) & 1;
            q[a] = i0[a] + b;
            if (q[a] > n[a] - 1) q[a] = n[a] - 1;
            w *= b ? t[a] : 1 - t[a];
        }
        s += w * v->data[q[0] + n[0] * (q[1] + n[1] * q[2])];
    }
    return s;
}

/* Distance estimate of point p to the boundary of the phantom's material inside the box:
 * |min(field, distance to the box)| (the phantom fields are signed distances). */
static double surface_distance(const vm_volume *v, const double p[3]) {
    double f = trilinear(v, p);
    for (int a = 0; a < 3; a++) {
        double b = fmin(p[a], (double)(v->dims[a] - 1) - p[a]);
        if (b < f) f = b;
    }
    return fabs(f);
}

typedef struct {
    size_t tris;
    double min_edge_ratio; /* the paper's aspect ratio: shortest / longest edge */
    double max_aspect;     /* vm_tri_aspect_ratio */
    double min_angle;      /* vm_tri_min_angle, degrees */
    double hausdorff;      /* max distance of vertices and face samples to the analytic surface */
} surf_figures;

static void figures(const vm_mesh *m, const vm_volume *phantom, surf_figures *fg) {
    memset(fg, 0, sizeof *fg);
    fg->tris = m->ncells;
    fg->min_edge_ratio = 1;
    fg->min_angle = 180;
    for (size_t c = 0; c < m->ncells; c++) {
        double p[3][3], lmin = INFINITY, lmax = 0;
        for (int k = 0; k < 3; k++)
            memcpy(p[k], m->points + 3 * (size_t)m->cells[3 * c + k], sizeof p[k]);
        for (int k = 0; k < 3; k++) {
            double l = 0;
            for (int a = 0; a < 3; a++) l += (p[k][a] - p[(k + 1) % 3][a]) * (p[k][a] - p[(k + 1) % 3][a]);
            l = sqrt(l);
            lmin = fmin(lmin, l);
            lmax = fmax(lmax, l);
        }
        fg->min_edge_ratio = fmin(fg->min_edge_ratio, lmax > 0 ? lmin / lmax : 0);
        fg->max_aspect = fmax(fg->max_aspect, vm_tri_aspect_ratio((const double(*)[3])p));
        fg->min_angle = fmin(fg->min_angle, vm_tri_min_angle((const double(*)[3])p));
        if (phantom) {
            /* vertices, edge midpoints, centroid and the points between them */
            static const double bary[][3] = {{1, 0, 0},       {0, 1, 0},       {0, 0, 1},
                                             {.5, .5, 0},     {0, .5, .5},     {.5, 0, .5},
                                             {1. / 3, 1. / 3, 1. / 3},         {.25, .25, .5},
                                             {.5, .25, .25},  {.25, .5, .25}};
            for (size_t b = 0; b < sizeof bary / sizeof bary[0]; b++) {
                double q[3];
                for (int a = 0; a < 3; a++)
                    q[a] = bary[b][0] * p[0][a] + bary[b][1] * p[1][a] + bary[b][2] * p[2][a];
                double dq = surface_distance(phantom, q);
                if (dq > fg->hausdorff && getenv("VM_COVER_DEBUG"))
                    fprintf(stderr, "worst %.3f at %.2f %.2f %.2f (b %zu) tri %zu\n", dq, q[0],
                            q[1], q[2], b, c);
                fg->hausdorff = fmax(fg->hausdorff, dq);
            }
        }
    }
}

static double area_of(const vm_mesh *m) {
    double a = 0;
    for (size_t c = 0; c < m->ncells; c++) {
        const double *p = m->points + 3 * (size_t)m->cells[3 * c];
        const double *q = m->points + 3 * (size_t)m->cells[3 * c + 1];
        const double *r = m->points + 3 * (size_t)m->cells[3 * c + 2];
        double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
        double w[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
        double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2];
        double z = u[0] * w[1] - u[1] * w[0];
        a += 0.5 * sqrt(x * x + y * y + z * z);
    }
    return a;
}

static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* 1 when every directed edge appears once and its reverse once: consistently oriented. */
static int consistently_oriented(const vm_mesh *m) {
    size_t nh = 3 * m->ncells;
    uint64_t *h = malloc((nh + 1) * sizeof *h);
    if (!h) return 0;
    for (size_t c = 0; c < m->ncells; c++)
        for (int k = 0; k < 3; k++)
            h[3 * c + k] = (uint64_t)m->cells[3 * c + k] << 32 | (uint64_t)m->cells[3 * c + (k + 1) % 3];
    qsort(h, nh, sizeof *h, cmp_u64);
    int ok = 1;
    for (size_t i = 0; ok && i < nh; i++) {
        if (i + 1 < nh && h[i + 1] == h[i]) ok = 0;
        uint64_t r = (h[i] & 0xffffffffu) << 32 | h[i] >> 32;
        if (!bsearch(&r, h, nh, sizeof *h, cmp_u64)) ok = 0;
    }
    free(h);
    return ok;
}

/* Extracts the cover surface of v (material >= iso) with error eps. Returns 1 on success. */
static int extract(const vm_volume *v, double iso, double eps, vm_mesh *m, double *seconds) {
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_COVER;
    o.lo = iso;
    o.error = eps;
    vm_surface_stats st;
    vm_error err;
    vm_status s = vm_surface_extract(v, &o, m, &st, &err);
    CHECK_OK(s, &err);
    if (seconds) *seconds = st.seconds;
    return s == VM_OK;
}

/* The invariants of every cover surface: closed, manifold, oriented outward, no
 * self-intersections, paper aspect ratio >= 0.3. Fills r. */
static void check_surface(const vm_mesh *m, vm_mesh_report *r) {
    vm_error err;
    CHECK_OK(vm_mesh_check(m, r, &err), &err);
    CHECK(m->kind == VM_TRI3);
    CHECK(r->cells > 0);
    CHECK_MSG(r->boundary_closed == 1, "%zu open, %zu non-manifold edges", r->boundary_open_edges,
              r->boundary_nonmanifold_edges);
    CHECK_MSG(r->boundary_nonmanifold_vertices == 0, "%zu non-manifold vertices",
              r->boundary_nonmanifold_vertices);
    CHECK_MSG(r->boundary_self_intersections == 0, "%zu self-intersecting pairs",
              r->boundary_self_intersections);
    CHECK_MSG(r->degenerate == 0, "%zu degenerate triangles", r->degenerate);
    CHECK(consistently_oriented(m));
    CHECK_MSG(r->volume > 0, "volume %g (inside out)", r->volume);
}

typedef struct {
    vm_phantom_kind kind;
} phantom_case;

static void phantom_run(vm_phantom_kind kind, double eps, surf_figures *out) {
    int n = sanitized() ? 40 : 64;
    vm_volume v;
    vm_phantom_info info;
    vm_error err;
    CHECK_OK(vm_phantom_make(kind, n, 0.0, 1, &v, &info, &err), &err);
    vm_mesh m;
    double sec = 0;
    if (extract(&v, 0.0, eps, &m, &sec)) {
        vm_mesh_report r;
        check_surface(&m, &r);
        CHECK_MSG(r.boundary_euler == info.euler, "%s: Euler %ld, expected %d", info.name,
                  r.boundary_euler, info.euler);
        CHECK_MSG(r.boundary_components == (size_t)info.components, "%s: %zu components, expected %d",
                  info.name, r.boundary_components, info.components);
        surf_figures fg;
        figures(&m, &v, &fg);
        double rel = (r.volume - info.volume) / info.volume;
        printf("    %s n=%d error %.2f: %zu triangles, %zu points, edge ratio min %.3f, "
               "aspect max %.3f, min angle %.2f, Hausdorff %.3f, volume %+.2f%%, %.3f s\n",
               info.name, n, eps, fg.tris, m.npoints, fg.min_edge_ratio, fg.max_aspect,
               fg.min_angle, fg.hausdorff, 100 * rel, sec);
        fflush(stdout);
        CHECK_MSG(fg.min_edge_ratio >= 0.3, "%s: min edge ratio %.3f", info.name, fg.min_edge_ratio);
        CHECK_MSG(fg.hausdorff <= eps, "%s: Hausdorff %.3f above the error %.2f", info.name,
                  fg.hausdorff, eps);
        /* The surface lies within the error of the analytic one, so the volume is within
         * error x area of the analytic volume (chords cut inside: a few % at 64^3 and 0.5). */
        double vol_tol = (eps * area_of(&m) + 0.01 * info.volume) / info.volume;
        CHECK_MSG(fabs(rel) <= vol_tol, "%s: volume error %+.2f%%, bound %.1f%%", info.name,
                  100 * rel, 100 * vol_tol);
        if (out) *out = fg;
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

/* Every phantom at a fine and a coarse error: closed, its Euler characteristic and
 * components, no self-intersections, aspect >= 0.3, Hausdorff below the error; and the coarse
 * error gives fewer triangles (adaptivity). */
static void phantom_pair(vm_phantom_kind kind) {
    surf_figures fine, coarse;
    memset(&fine, 0, sizeof fine);
    memset(&coarse, 0, sizeof coarse);
    phantom_run(kind, 0.5, &fine);
    phantom_run(kind, 2.0, &coarse);
    CHECK_MSG(coarse.tris < fine.tris, "error 2 gives %zu triangles, error 0.5 %zu", coarse.tris,
              fine.tris);
}

static void sphere_is_a_closed_genus0_surface_at_both_errors(void) {
    phantom_pair(VM_PHANTOM_SPHERE);
}
static void torus_keeps_euler_0(void) { phantom_pair(VM_PHANTOM_TORUS); }
static void genus3_keeps_euler_minus4(void) { phantom_pair(VM_PHANTOM_GENUS3); }
static void two_spheres_stay_two_components(void) { phantom_pair(VM_PHANTOM_TWO_SPHERES); }
static void cut_sphere_is_closed_at_the_border(void) { phantom_pair(VM_PHANTOM_CUT_SPHERE); }

TEST_MAIN(T(sphere_is_a_closed_genus0_surface_at_both_errors), T(torus_keeps_euler_0),
          T(genus3_keeps_euler_minus4), T(two_spheres_stay_two_components),
          T(cut_sphere_is_closed_at_the_border))
