/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/surface/test_surface_cover.c — the disk-covering surface mesher (--method cover): closed,
 * consistently oriented manifolds with the phantom's (or the interpolant's) Euler characteristic
 * and components, no self-intersections, the analytic volume, distance to the interpolant and to
 * the analytic surface within the error parameter, triangle aspect ratio (shortest / longest
 * edge) >= 0.3, fewer triangles at a larger error, anisotropic steps, the shared volumes, and
 * bad input. */
/* ctest parts: 4 */
#include "test.h"
#include <stdint.h>
#include <string.h>
#include "surface/surface_cover_internal.h"

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
    size_t kept;           /* triangles kept from the fine surface (cell field cover_fine) */
} surf_figures;

static void figures(const vm_mesh *m, const vm_volume *phantom, surf_figures *fg) {
    memset(fg, 0, sizeof *fg);
    fg->tris = m->ncells;
    fg->min_edge_ratio = 1;
    fg->min_angle = 180;
    const vm_field *kept = vm_mesh_find_field(m, 1, "cover_fine");
    CHECK(kept != NULL);
    for (size_t c = 0; c < m->ncells; c++) {
        double p[3][3], lmin = INFINITY, lmax = 0;
        if (kept && kept->data[c] != 0) { /* the aspect bound is for the covered part */
            fg->kept++;
            continue;
        }
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
                fg->hausdorff = fmax(fg->hausdorff, dq);
            }
        }
    }
}

/* Area of triangle c of m. */
static double tri_area(const vm_mesh *m, size_t c) {
    const double *p = m->points + 3 * (size_t)m->cells[3 * c];
    const double *q = m->points + 3 * (size_t)m->cells[3 * c + 1];
    const double *r = m->points + 3 * (size_t)m->cells[3 * c + 2];
    double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    double w[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
    double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2];
    double z = u[0] * w[1] - u[1] * w[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

static double area_of(const vm_mesh *m) {
    double a = 0;
    for (size_t c = 0; c < m->ncells; c++) a += tri_area(m, c);
    return a;
}

/* The share of the area of m on its triangles kept fine (cell field cover_fine). */
static double kept_area_fraction(const vm_mesh *m) {
    const vm_field *kept = vm_mesh_find_field(m, 1, "cover_fine");
    double a = 0, total = 0;
    for (size_t c = 0; c < m->ncells; c++) {
        double t = tri_area(m, c);
        total += t;
        if (kept && kept->data[c] != 0) a += t;
    }
    return total > 0 ? a / total : 0;
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

/* The supersampling of the last extraction (vm_surface_stats.supersample). */
static int last_ss[3] = {1, 1, 1};
static int improve_pass = 1; /* vm_surface_options.improve of the next extractions */

/* Extracts the cover surface of v (material >= iso) with error eps. Returns 1 on success. */
static int extract(const vm_volume *v, double iso, double eps, vm_mesh *m, double *seconds) {
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_COVER;
    o.lo = iso;
    o.error = eps;
    o.improve = improve_pass;
    vm_surface_stats st;
    vm_error err;
    vm_status s = vm_surface_extract(v, &o, m, &st, &err);
    CHECK_OK(s, &err);
    if (seconds) *seconds = st.seconds;
    for (int a = 0; s == VM_OK && a < 3; a++) last_ss[a] = st.supersample[a];
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

/* --- the implicit surface the method meshes: the fine candidate surface ------------------ */

/* The grid of v with material >= iso, as the dispatcher builds it for cell size 1. */
static vm__surface_grid grid_of(const vm_volume *v, double iso) {
    vm__surface_grid g;
    memset(&g, 0, sizeof g);
    for (int a = 0; a < 3; a++) g.n[a] = v->dims[a];
    g.f = v->data;
    g.lo = iso;
    g.has_lo = 1;
    return g;
}

/* v sampled as the last extraction did (the trilinear interpolant, last_ss times finer per
 * axis): a view sharing v's header, its data in *buf (free it). */
static vm_volume sampled_as_extracted(const vm_volume *v, float **buf) {
    vm__surface_grid g = grid_of(v, 0.0), g2;
    vm_error err;
    vm_volume w = *v;
    *buf = NULL;
    CHECK_OK(vm__cover_supersample(&g, last_ss, &g2, buf, &err), &err);
    for (int a = 0; a < 3; a++) w.dims[a] = g2.n[a];
    w.data = (float *)g2.f;
    return w;
}

/* Euler characteristic and components of the fine surface (the zero set of the interpolant)
 * at the sampling of the last extraction. */
static void fine_topology(const vm_volume *v0, double iso, long *euler, size_t *components) {
    float *buf;
    vm_volume vs = sampled_as_extracted(v0, &buf);
    const vm_volume *v = &vs;
    vm__surface_grid g = grid_of(v, iso);
    vm__cover_fine f;
    vm_error err;
    *euler = 0;
    *components = 0;
    vm_status s = vm__cover_fine_build(&g, NULL, &f, &err);
    free(buf);
    CHECK_OK(s, &err);
    if (s) return;
    for (size_t c = 0; c < f.ncomp; c++) *euler += f.comp_euler[c];
    *components = f.ncomp;
    vm__cover_fine_free(&f);
}

/* Distance from p to triangle (a, b, c): the plane when the foot is inside, else the edges. */
static double seg_dist(const double *p, const double *a, const double *b) {
    double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, t = 0, l2 = 0, d = 0;
    for (int k = 0; k < 3; k++) t += (p[k] - a[k]) * ab[k], l2 += ab[k] * ab[k];
    t = l2 > 0 ? fmax(0, fmin(1, t / l2)) : 0;
    for (int k = 0; k < 3; k++) d += (p[k] - a[k] - t * ab[k]) * (p[k] - a[k] - t * ab[k]);
    return sqrt(d);
}

static double tri_dist(const double *p, const double *a, const double *b, const double *c) {
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    double nn = n[0] * n[0] + n[1] * n[1] + n[2] * n[2];
    if (nn > 0) {
        double h = ((p[0] - a[0]) * n[0] + (p[1] - a[1]) * n[1] + (p[2] - a[2]) * n[2]) / nn;
        double f[3] = {p[0] - h * n[0], p[1] - h * n[1], p[2] - h * n[2]};
        /* barycentric signs of the foot */
        const double *q[3] = {a, b, c};
        int inside = 1;
        for (int e = 0; e < 3 && inside; e++) {
            const double *s0 = q[e], *s1 = q[(e + 1) % 3];
            double x[3] = {s1[0] - s0[0], s1[1] - s0[1], s1[2] - s0[2]};
            double y[3] = {f[0] - s0[0], f[1] - s0[1], f[2] - s0[2]};
            double z[3] = {x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
            if (z[0] * n[0] + z[1] * n[1] + z[2] * n[2] < 0) inside = 0;
        }
        if (inside) return fabs(h) * sqrt(nn);
    }
    return fmin(seg_dist(p, a, b), fmin(seg_dist(p, b, c), seg_dist(p, c, a)));
}

/* Triangles bucketed on a uniform grid of cell size h. */
typedef struct {
    const double *x;
    const int32_t *f32;
    const vm_index *fidx;
    size_t nf;
    double lo[3], h;
    int64_t n[3];
    size_t *off;
    uint32_t *list;
} buckets;

static void tri_corners(const buckets *b, size_t t, const double *p[3]) {
    for (int k = 0; k < 3; k++)
        p[k] = b->x + 3 * (size_t)(b->f32 ? (size_t)b->f32[3 * t + k] : (size_t)b->fidx[3 * t + k]);
}

static int64_t cell_of(const buckets *b, int a, double x) {
    int64_t i = (int64_t)floor((x - b->lo[a]) / b->h);
    return i < 0 ? 0 : i >= b->n[a] ? b->n[a] - 1 : i;
}

static void buckets_build(buckets *b, double h) {
    b->h = h;
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int a = 0; a < 3; a++) b->lo[a] = INFINITY;
    for (size_t t = 0; t < b->nf; t++) {
        const double *p[3];
        tri_corners(b, t, p);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) b->lo[a] = fmin(b->lo[a], p[k][a]), hi[a] = fmax(hi[a], p[k][a]);
    }
    for (int a = 0; a < 3; a++) b->n[a] = (int64_t)((hi[a] - b->lo[a]) / h) + 1;
    size_t nc = (size_t)(b->n[0] * b->n[1] * b->n[2]);
    b->off = calloc(nc + 1, sizeof *b->off);
    for (int pass = 0; pass < 2; pass++) {
        for (size_t t = 0; t < b->nf; t++) {
            const double *p[3];
            tri_corners(b, t, p);
            int64_t i0[3], i1[3];
            for (int a = 0; a < 3; a++) {
                i0[a] = cell_of(b, a, fmin(p[0][a], fmin(p[1][a], p[2][a])));
                i1[a] = cell_of(b, a, fmax(p[0][a], fmax(p[1][a], p[2][a])));
            }
            for (int64_t k = i0[2]; k <= i1[2]; k++)
                for (int64_t j = i0[1]; j <= i1[1]; j++)
                    for (int64_t i = i0[0]; i <= i1[0]; i++) {
                        size_t c = (size_t)(i + b->n[0] * (j + b->n[1] * k));
                        if (pass == 0) b->off[c + 1]++;
                        else b->list[b->off[c]++] = (uint32_t)t;
                    }
        }
        if (pass == 0) {
            for (size_t c = 0; c < nc; c++) b->off[c + 1] += b->off[c];
            b->list = malloc((b->off[nc] + 1) * sizeof *b->list);
        } else {
            for (size_t c = nc; c > 0; c--) b->off[c] = b->off[c - 1];
            b->off[0] = 0;
        }
    }
}

/* Distance from p to the bucketed triangles, searched within r (INFINITY when none is). */
static double buckets_dist(const buckets *b, const double *p, double r) {
    int64_t i0[3], i1[3];
    for (int a = 0; a < 3; a++) i0[a] = cell_of(b, a, p[a] - r), i1[a] = cell_of(b, a, p[a] + r);
    double best = INFINITY;
    for (int64_t k = i0[2]; k <= i1[2]; k++)
        for (int64_t j = i0[1]; j <= i1[1]; j++)
            for (int64_t i = i0[0]; i <= i1[0]; i++) {
                size_t c = (size_t)(i + b->n[0] * (j + b->n[1] * k));
                for (size_t q = b->off[c]; q < b->off[c + 1]; q++) {
                    const double *t[3];
                    tri_corners(b, b->list[q], t);
                    best = fmin(best, tri_dist(p, t[0], t[1], t[2]));
                }
            }
    return best <= r ? best : INFINITY;
}

/* Two-sided distance between the cover surface m (index space) and the fine surface of v:
 * [out] to_fine, the largest distance of a vertex or face sample of m to the fine surface;
 * [out] from_fine, the largest distance of a fine vertex to m. Searched within 3 * bound
 * (INFINITY beyond). */
static void fine_hausdorff(const vm_volume *v, double iso, const vm_mesh *m, double bound,
                           double *to_fine, double *from_fine) {
    vm__surface_grid g = grid_of(v, iso);
    vm__cover_fine f;
    vm_error err;
    *to_fine = *from_fine = INFINITY;
    vm_status s = vm__cover_fine_build(&g, NULL, &f, &err);
    CHECK_OK(s, &err);
    if (s) return;
    double r = 3 * bound;
    buckets bf = {f.x, f.f, NULL, f.nf, {0, 0, 0}, 0, {0, 0, 0}, NULL, NULL};
    buckets bc = {m->points, NULL, m->cells, m->ncells, {0, 0, 0}, 0, {0, 0, 0}, NULL, NULL};
    buckets_build(&bf, fmax(1.0, bound));
    buckets_build(&bc, fmax(1.0, bound));
    static const double bary[][3] = {{1, 0, 0},     {0, 1, 0},     {0, 0, 1},
                                     {.5, .5, 0},   {0, .5, .5},   {.5, 0, .5},
                                     {1. / 3, 1. / 3, 1. / 3},     {.25, .25, .5},
                                     {.5, .25, .25}, {.25, .5, .25}};
    double d1 = 0, d2 = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        const double *p[3];
        tri_corners(&bc, t, p);
        for (size_t b = 0; b < sizeof bary / sizeof bary[0]; b++) {
            double q[3];
            for (int a = 0; a < 3; a++)
                q[a] = bary[b][0] * p[0][a] + bary[b][1] * p[1][a] + bary[b][2] * p[2][a];
            d1 = fmax(d1, buckets_dist(&bf, q, r));
        }
    }
    for (size_t x = 0; x < f.nv; x++) d2 = fmax(d2, buckets_dist(&bc, f.x + 3 * x, r));
    *to_fine = d1;
    *from_fine = d2;
    free(bf.off), free(bf.list), free(bc.off), free(bc.list);
    vm__cover_fine_free(&f);
}

static void phantom_run(vm_phantom_kind kind, double eps, surf_figures *out) {
    int n = 64; /* smaller grids sit at the resolution floor of the thin tubes and rims */
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
        CHECK_MSG(fg.kept == 0, "%s: %zu triangles kept from the fine surface", info.name, fg.kept);
        /* the guarantee: within the error of the implicit surface (the interpolant) both ways */
        double to_fine, from_fine;
        fine_hausdorff(&v, 0.0, &m, eps, &to_fine, &from_fine);
        printf("      to the interpolant: surface -> fine %.3f, fine -> surface %.3f\n", to_fine,
               from_fine);
        /* At the creases of genus3's fused tori and the cut sphere's rim the disks reach the
         * finest radius the 1-ring rule allows (sec. 3.9) before the error: there the bound
         * is the resolution floor, half a cell more. */
        double floor_ = kind == VM_PHANTOM_GENUS3 || kind == VM_PHANTOM_CUT_SPHERE ? 0.5 : 0.0;
        CHECK_MSG(to_fine <= eps + floor_ && from_fine <= eps + floor_,
                  "%s: %.3f / %.3f from the interpolant, error %.2f", info.name, to_fine,
                  from_fine, eps);
        /* to the analytic surface: the interpolant itself is off by about 0.05 voxel here */
        CHECK_MSG(fg.hausdorff <= eps + floor_ + 0.1, "%s: Hausdorff %.3f above the error %.2f",
                  info.name, fg.hausdorff, eps);
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
    /* under the sanitizers the coarser pair (1, 2) keeps the run short */
    double e1 = sanitized() ? 1.0 : 0.5, e2 = 2.0;
    phantom_run(kind, e1, &fine);
    phantom_run(kind, e2, &coarse);
    CHECK_MSG(coarse.tris < fine.tris, "error %.1f gives %zu triangles, error %.1f %zu", e2,
              coarse.tris, e1, fine.tris);
}

static void sphereIsAClosedGenus0SurfaceAtBothErrors(void) {
    phantom_pair(VM_PHANTOM_SPHERE);
}
static void torusKeepsEuler0(void) { phantom_pair(VM_PHANTOM_TORUS); }
static void genus3KeepsEulerMinus4(void) { phantom_pair(VM_PHANTOM_GENUS3); }
static void twoSpheresStayTwoComponents(void) { phantom_pair(VM_PHANTOM_TWO_SPHERES); }
static void cutSphereIsClosedAtTheBorder(void) { phantom_pair(VM_PHANTOM_CUT_SPHERE); }

/* Noisy phantoms have many small pieces and rough walls: the surface stays closed, manifold,
 * oriented and free of self-intersections, with the Euler characteristic and the components
 * of the interpolant's zero set (the guaranteed genus). */
static void noisyPhantomsKeepTheTopologyOfTheInterpolant(void) {
    static const vm_phantom_kind kinds[] = {VM_PHANTOM_SPHERE, VM_PHANTOM_TORUS, VM_PHANTOM_GENUS3,
                                            VM_PHANTOM_SPHERE};
    int n = 40;
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        /* sigma 0.2: rough walls; sigma 0.6 (the last case): so rough that the covering keeps
         * fine surface where its cells fail (sec. 3.9), still closed and the same topology, the
         * edge ratio holding on the covered triangles */
        double sigma = k + 1 < sizeof kinds / sizeof kinds[0] ? 0.2 : 0.6;
        /* the rough one is also supersampled (it keeps fine triangles): smaller under the
         * sanitizers */
        int size = sigma > 0.5 && sanitized() ? 28 : n;
        CHECK_OK(vm_phantom_make(kinds[k], size, sigma, 7, &v, &info, &err), &err);
        vm_mesh m;
        double sec = 0;
        if (extract(&v, 0.0, 0.5, &m, &sec)) {
            vm_mesh_report r;
            check_surface(&m, &r);
            long euler;
            size_t comps;
            fine_topology(&v, 0.0, &euler, &comps);
            CHECK_MSG(r.boundary_euler == euler, "noisy %s: Euler %ld, interpolant %ld", info.name,
                      r.boundary_euler, euler);
            CHECK_MSG(r.boundary_components == comps, "noisy %s: %zu components, interpolant %zu",
                      info.name, r.boundary_components, comps);
            surf_figures fg;
            figures(&m, NULL, &fg);
            printf("    noisy %s n=%d sigma %.1f: %zu triangles (%zu kept fine), Euler %ld (phantom "
                   "%d), %zu components, edge ratio min %.3f, min angle %.2f, %.3f s\n",
                   info.name, size, sigma, fg.tris, fg.kept, r.boundary_euler, info.euler,
                   r.boundary_components, fg.min_edge_ratio, fg.min_angle, sec);
            CHECK_MSG(fg.min_edge_ratio >= 0.3, "noisy %s: min edge ratio %.3f", info.name,
                      fg.min_edge_ratio);
            vm_mesh_free(&m);
        }
        vm_volume_free(&v);
    }
}

/* Components of the samples >= iso (inside = 1) or < iso (inside = 0, with a padding layer of
 * outside samples around the grid), joined along 6 axis neighbours (kuhn = 0) or along the 14
 * edges of the Kuhn subdivision the interpolant lives on (kuhn = 1). */
static size_t sample_components(const vm_volume *v, double iso, int inside, int kuhn) {
    int64_t n[3] = {v->dims[0] + 2, v->dims[1] + 2, v->dims[2] + 2};
    size_t total = (size_t)(n[0] * n[1] * n[2]), count = 0;
    uint8_t *in = malloc(total), *seen = calloc(total, 1);
    size_t *stack = malloc(total * sizeof *stack);
    for (int64_t k = 0; k < n[2]; k++)
        for (int64_t j = 0; j < n[1]; j++)
            for (int64_t i = 0; i < n[0]; i++) {
                int64_t a = i - 1, b = j - 1, c = k - 1;
                int mat = a >= 0 && b >= 0 && c >= 0 && a < v->dims[0] && b < v->dims[1] &&
                          c < v->dims[2] && v->data[a + v->dims[0] * (b + v->dims[1] * c)] >= iso;
                in[i + n[0] * (j + n[1] * k)] = (uint8_t)(mat == inside);
            }
    static const int d[14][3] = {{1, 0, 0},  {-1, 0, 0},  {0, 1, 0},   {0, -1, 0},  {0, 0, 1},
                                 {0, 0, -1}, {1, 1, 0},   {-1, -1, 0}, {1, 0, 1},   {-1, 0, -1},
                                 {0, 1, 1},  {0, -1, -1}, {1, 1, 1},   {-1, -1, -1}};
    int nd = kuhn ? 14 : 6;
    for (size_t s0 = 0; s0 < total; s0++) {
        if (seen[s0] || !in[s0]) continue;
        size_t top = 0;
        stack[top++] = s0;
        seen[s0] = 1;
        count++;
        while (top) {
            size_t q = stack[--top];
            int64_t i = (int64_t)(q % (size_t)n[0]), j = (int64_t)(q / (size_t)n[0] % (size_t)n[1]);
            int64_t k = (int64_t)(q / (size_t)(n[0] * n[1]));
            for (int e = 0; e < nd; e++) {
                int64_t a = i + d[e][0], b = j + d[e][1], c = k + d[e][2];
                if (a < 0 || b < 0 || c < 0 || a >= n[0] || b >= n[1] || c >= n[2]) continue;
                size_t r = (size_t)(a + n[0] * (b + n[1] * c));
                if (!seen[r] && in[r]) seen[r] = 1, stack[top++] = r;
            }
        }
    }
    free(in);
    free(seen);
    free(stack);
    return count;
}

/* The invariants of the cover surface of v (material >= iso, error eps) against the
 * interpolant it meshes; aspect_floor: the paper's 0.3 (see docs/SURFACE_COVER.md).
 * Returns the fraction of triangles kept fine; *kept_area (NULL: not wanted) the fraction of
 * the area they hold. */
static double volume_case(const char *name, const vm_volume *vp, double iso, double eps,
                          double aspect_floor, double *kept_area) {
    vm_volume v = *vp;
    double kept_fraction = 1;
    vm_mesh m;
    double sec = 0;
    if (extract(&v, iso, eps, &m, &sec)) {
        vm_mesh_report r;
        check_surface(&m, &r);
        long euler;
        size_t comps;
        fine_topology(&v, iso, &euler, &comps);
        float *buf;
        vm_volume vs = sampled_as_extracted(&v, &buf);
        size_t vox = sample_components(&vs, iso, 1, 0), mat = sample_components(&vs, iso, 1, 1);
        size_t bg = sample_components(&vs, iso, 0, 1);
        free(buf);
        CHECK_MSG(r.boundary_euler == euler, "%s: Euler %ld, interpolant %ld", name, r.boundary_euler,
                  euler);
        CHECK_MSG(r.boundary_components == comps, "%s: %zu components, interpolant %zu", name,
                  r.boundary_components, comps);
        /* Every surface separates one piece of material from one piece of background, and
         * those pieces form a tree: surfaces = material + background - 1, the pieces joined
         * along the edges of the Kuhn subdivision the interpolant lives on. That subdivision
         * joins voxels across face and cell diagonals, so it may merge 6-connected pieces of
         * material, but it never loses one. */
        CHECK_MSG(r.boundary_components == mat + bg - 1,
                  "%s: %zu surfaces, %zu material and %zu background pieces", name,
                  r.boundary_components, mat, bg);
        CHECK_MSG(mat <= vox, "%s: %zu material pieces, %zu 6-connected ones", name, mat, vox);
        /* aspect in index space, where the method measures (anisotropic spacing aside) */
        vm_mesh idx = m;
        double *pts = malloc(3 * m.npoints * sizeof *pts);
        for (size_t p = 0; p < m.npoints; p++)
            for (int a = 0; a < 3; a++)
                pts[3 * p + a] = (m.points[3 * p + a] - v.origin[a]) / v.spacing[a];
        idx.points = pts;
        surf_figures fg, fw;
        figures(&idx, NULL, &fg);
        figures(&m, NULL, &fw);
        free(pts);
        printf("    %s iso %g error %.2f: %zu triangles (%zu kept fine), Euler %ld, %zu surfaces (material %zu, "
               "6-connected %zu, background %zu), "
               "edge ratio min %.3f (world %.3f), aspect max %.3f, min angle %.2f, %.3f s\n",
               name, iso, eps, fg.tris, fg.kept, r.boundary_euler, r.boundary_components, mat, vox, bg,
               fg.min_edge_ratio, fw.min_edge_ratio, fg.max_aspect, fg.min_angle, sec);
        /* the method measures lengths in the world (anisotropic spacing) */
        CHECK_MSG(fw.min_edge_ratio >= aspect_floor, "%s: min edge ratio %.3f", name,
                  fw.min_edge_ratio);
        kept_fraction = fg.tris ? (double)fg.kept / (double)fg.tris : 1;
        if (kept_area) *kept_area = kept_area_fraction(&m);
        vm_mesh_free(&m);
    }
    return kept_fraction;
}

static void shared_case(const char *name, double iso, double eps, double aspect_floor) {
    const char *path = vm_test_shared(name);
    if (!path) return;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    volume_case(name, &v, iso, eps, aspect_floor, NULL);
    vm_volume_free(&v);
}

/* The box lo .. hi-1 (voxel indices) of v as a volume of its own, at the same place in
 * the world. */
static vm_volume crop(const vm_volume *v, const int64_t lo[3], const int64_t hi[3]) {
    vm_volume c;
    vm_error err;
    int64_t d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    CHECK_OK(vm_volume_alloc(&c, d, &err), &err);
    for (int64_t k = 0; k < d[2]; k++)
        for (int64_t j = 0; j < d[1]; j++)
            for (int64_t i = 0; i < d[0]; i++)
                c.data[i + d[0] * (j + d[1] * k)] =
                    v->data[(i + lo[0]) + v->dims[0] * ((j + lo[1]) + v->dims[1] * (k + lo[2]))];
    for (int a = 0; a < 3; a++) {
        c.spacing[a] = v->spacing[a];
        c.origin[a] = v->origin[a] + (double)lo[a] * v->spacing[a];
    }
    return c;
}

/* A piece of the noisy MR head skin (genus 6 in the box; its disks and its farthest-point
 * cells fail at a few places, see docs/SURFACE_COVER.md): closed, the interpolant's Euler
 * characteristic and components, no crossings, edge ratio >= 0.3 on the covered triangles,
 * and only those places kept fine (the local fallback), not the whole skin. Quick enough
 * for the sanitizer build. */
/* The box [10,30) x [0,20) x [0,20) of the shared MR head: 1 with it in *box, 0 when the
 * data is absent (skipped) or too small (a failure). */
static int mr_head_box(vm_volume *box) {
    const char *path = vm_test_shared("HeadMRVolume.mhd");
    if (!path) return 0;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_volume_read(path, &v, &err), &err);
    int64_t lo[3] = {10, 0, 0}, hi[3] = {30, 20, 20};
    int ok = v.dims[0] >= hi[0] && v.dims[1] >= hi[1] && v.dims[2] >= hi[2];
    CHECK_MSG(ok, "HeadMRVolume: %lld x %lld x %lld samples, the box needs %lld x %lld x %lld",
              (long long)v.dims[0], (long long)v.dims[1], (long long)v.dims[2],
              (long long)hi[0], (long long)hi[1], (long long)hi[2]);
    if (ok) *box = crop(&v, lo, hi);
    vm_volume_free(&v);
    return ok;
}

static void mrHeadPieceKeepsTheInterpolantTopology(void) {
    vm_volume c;
    if (!mr_head_box(&c)) return;
    double area = 1;
    double kept = volume_case("HeadMRVolume box", &c, 50, 1.0, 0.3, &area);
    printf("    kept fine: %.1f %% of the triangles, %.1f %% of the area\n", 100 * kept,
           100 * area);
    /* the failing farthest-point cells and their neighbours are kept fine, not the whole
     * skin (which held 94 % of the area before the local fallback) */
    CHECK_MSG(area <= 0.3, "HeadMRVolume box: %.1f %% of the area kept fine", 100 * area);
    vm_volume_free(&c);
}

/* Triangles of m below the paper's edge ratio 0.3, and of those how many carry cover_fine. */
static size_t thin_triangles(const vm_mesh *m, size_t *flagged) {
    const vm_field *kept = vm_mesh_find_field(m, 1, "cover_fine");
    size_t n = 0;
    *flagged = 0;
    for (size_t c = 0; c < m->ncells; c++) {
        double lmin = INFINITY, lmax = 0;
        for (int k = 0; k < 3; k++) {
            const double *p = m->points + 3 * (size_t)m->cells[3 * c + k];
            const double *q = m->points + 3 * (size_t)m->cells[3 * c + (k + 1) % 3];
            double l = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                            (p[2] - q[2]) * (p[2] - q[2]));
            lmin = fmin(lmin, l), lmax = fmax(lmax, l);
        }
        if (lmin < 0.3 * lmax) n++, *flagged += kept && kept->data[c] != 0;
    }
    return n;
}

/* The distances both ways between m and the fine surface of v as last extracted, in voxels
 * of v (m in the world; isotropic spacing). */
static void error_both_ways(const vm_volume *v, double iso, const vm_mesh *m, double eps,
                            double *to_fine, double *from_fine) {
    float *buf;
    vm_volume vs = sampled_as_extracted(v, &buf);
    vm_mesh idx = *m;
    double *pts = malloc(3 * m->npoints * sizeof *pts);
    for (size_t p = 0; p < m->npoints; p++)
        for (int a = 0; a < 3; a++)
            pts[3 * p + a] = (m->points[3 * p + a] - v->origin[a]) / v->spacing[a] * last_ss[a];
    idx.points = pts;
    /* searched within 1.5 eps: farther is reported as INFINITY (and fails) */
    fine_hausdorff(&vs, iso, &idx, 0.5 * eps * last_ss[0], to_fine, from_fine);
    *to_fine /= last_ss[0], *from_fine /= last_ss[0];
    free(pts);
    free(buf);
}

/* The improvement pass over the kept-fine triangles (docs/SURFACE_COVER.md, "The
 * improvement pass") on the MR head box: the same closed, oriented, manifold surface
 * topology as without it (Euler characteristic, components), no crossings, far fewer
 * triangles and triangles below the edge ratio 0.3, cover_fine on every one of those, and the
 * error both ways no larger than without the pass (within the error parameter). */
static void improvementPassKeepsTheTopologyAndRemovesThinTriangles(void) {
    if (sanitized()) { /* the box test above runs the pass under the sanitizers */
        vm_test_skip("the improvement pass comparison is left to the Release run");
        return;
    }
    vm_volume c;
    if (!mr_head_box(&c)) return;
    vm_mesh m[2];
    vm_mesh_report r[2];
    size_t thin[2], flagged[2];
    double to_fine[2], from_fine[2], eps = 1.0;
    int have[2] = {0, 0};
    for (int pass = 0; pass < 2; pass++) {
        improve_pass = pass;
        if (!(have[pass] = extract(&c, 50, eps, &m[pass], NULL))) break;
        check_surface(&m[pass], &r[pass]);
        thin[pass] = thin_triangles(&m[pass], &flagged[pass]);
        error_both_ways(&c, 50, &m[pass], eps, &to_fine[pass], &from_fine[pass]);
        printf("    improve %d: %zu triangles, %zu below 0.3 (%zu flagged), Euler %ld, %zu surfaces, "
               "error %.3f / %.3f\n", pass, m[pass].ncells, thin[pass], flagged[pass],
               r[pass].boundary_euler, r[pass].boundary_components, to_fine[pass], from_fine[pass]);
    }
    improve_pass = 1;
    if (have[0] && have[1]) {
        CHECK(r[1].boundary_euler == r[0].boundary_euler);
        CHECK(r[1].boundary_components == r[0].boundary_components);
        CHECK_MSG(10 * m[1].ncells < 9 * m[0].ncells, "%zu triangles, %zu before", m[1].ncells,
                  m[0].ncells);
        /* before the pass some thousand are below 0.3; after it a few dozen */
        CHECK_MSG(20 * thin[1] < thin[0], "%zu triangles below 0.3, %zu before", thin[1], thin[0]);
        CHECK_MSG(flagged[1] == thin[1], "%zu flagged, %zu below 0.3", flagged[1], thin[1]);
        CHECK_MSG(to_fine[1] <= fmax(eps, to_fine[0]) * 1.05, "mesh to fine %.3f", to_fine[1]);
        CHECK_MSG(from_fine[1] <= fmax(eps, from_fine[0]) * 1.05, "fine to mesh %.3f",
                  from_fine[1]);
    }
    for (int pass = 0; pass < 2; pass++)
        if (have[pass]) vm_mesh_free(&m[pass]);
    vm_volume_free(&c);
}

static void hydrogenIsClosedWithTheInterpolantTopology(void) {
    shared_case("hydrogen.vti", 0.1, 0.5, 0.3);
}
/* Small blobs of a few voxels: supersampled twice and covered by farthest points. */
static void ironProteinKeepsItsComponents(void) {
    shared_case("ironProt.vtk", 128, 0.5, 0.3);
}
static void mrHeadKeepsTheEdgeRatio(void) {
    if (sanitized()) {
        vm_test_skip("HeadMRVolume is left to the Release run");
        return;
    }
    shared_case("HeadMRVolume.mhd", 50, 1.0, 0.3);
}
static void ctHeadSkinIsClosedAtTheBorder(void) {
    if (sanitized()) {
        vm_test_skip("ct_head_quarter is left to the Release run");
        return;
    }
    shared_case("ct_head_quarter.nrrd", 500, 1.0, 0.3);
}

/* Anisotropic steps: lengths are measured in the scaled space, where the edge ratio holds. */
static void scaledStepsBoundTheEdgeRatioInWorldLengths(void) {
    int n = sanitized() ? 32 : 48;
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, n, 0.0, 1, &v, NULL, &err), &err);
    vm__surface_grid g = grid_of(&v, 0.0);
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_COVER;
    const double scale[3] = {2.0, 2.0, 1.0};
    vm_mesh m;
    vm_mesh_init(&m, VM_TRI3);
    vm_surface_stats st;
    memset(&st, 0, sizeof st);
    CHECK_OK(vm__surface_cover_scaled(&g, &o, scale, &m, &st, &err), &err);
    for (size_t p = 0; p < m.npoints; p++)
        for (int a = 0; a < 3; a++) m.points[3 * p + a] *= scale[a];
    vm_mesh_report r;
    check_surface(&m, &r);
    CHECK(r.boundary_euler == 2);
    surf_figures fg;
    figures(&m, NULL, &fg);
    printf("    sphere n=%d, steps 2 2 1: %zu triangles, edge ratio min %.3f, min angle %.2f\n", n,
           fg.tris, fg.min_edge_ratio, fg.min_angle);
    CHECK_MSG(fg.min_edge_ratio >= 0.3, "min edge ratio %.3f", fg.min_edge_ratio);
    double bad[3] = {1, 0, 1};
    vm_mesh m2;
    vm_mesh_init(&m2, VM_TRI3);
    vm_status s = vm__surface_cover_scaled(&g, &o, bad, &m2, &st, &err);
    CHECK(s == VM_ERR_ARG);
    if (s == VM_ERR_ARG) printf("    zero step: %s\n", err.message);
    vm_mesh_free(&m2);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* A bad error parameter is refused with a one-line message naming it. */
static void badErrorParameterIsRefused(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 1, &v, NULL, &err), &err);
    const double bad[] = {0.0, -1.0, NAN};
    for (size_t b = 0; b < 3; b++) {
        vm_surface_options o;
        vm_surface_options_default(&o);
        o.method = VM_SURFACE_COVER;
        o.error = bad[b];
        vm_mesh m;
        vm_status s = vm_surface_extract(&v, &o, &m, NULL, &err);
        CHECK(s == VM_ERR_ARG);
        CHECK(strstr(err.message, "error") != NULL && strchr(err.message, '\n') == NULL);
        vm_mesh_free(&m);
    }
    vm_volume_free(&v);
}

/* Material that is nowhere: the empty selection error, not an empty mesh. */
static void emptyMaterialIsRefused(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 1, &v, NULL, &err), &err);
    vm_surface_options o;
    vm_surface_options_default(&o);
    o.method = VM_SURFACE_COVER;
    o.lo = 1e6;
    vm_mesh m;
    vm_status s = vm_surface_extract(&v, &o, &m, NULL, &err);
    CHECK(s == VM_ERR_EMPTY);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* Ordered so that the 4 ctest parts (case i runs in part i % 4) take about the same time:
 * the whole CT head alone in part 0 (Release), ironProt and the phantoms spread over parts 2
 * and 3 (sanitizers). */
TEST_MAIN(T(ctHeadSkinIsClosedAtTheBorder), T(mrHeadKeepsTheEdgeRatio),
          T(ironProteinKeepsItsComponents),
          T(noisyPhantomsKeepTheTopologyOfTheInterpolant), T(badErrorParameterIsRefused),
          T(scaledStepsBoundTheEdgeRatioInWorldLengths), T(genus3KeepsEulerMinus4),
          T(torusKeepsEuler0), T(emptyMaterialIsRefused), T(twoSpheresStayTwoComponents),
          T(cutSphereIsClosedAtTheBorder),
          T(sphereIsAClosedGenus0SurfaceAtBothErrors),
          T(hydrogenIsClosedWithTheInterpolantTopology),
          T(mrHeadPieceKeepsTheInterpolantTopology),
          T(improvementPassKeepsTheTopologyAndRemovesThinTriangles))
