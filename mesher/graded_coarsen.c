/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_coarsen.c — coarsening of the stuffed mesh by edge collapse, shortest edges
 * first, where the collapse keeps:
 * - the topology: the link condition of Dey, Edelsbrunner, Guha and Nekhayev (1999) on the
 *   mesh coned to a point beyond its boundary (so it holds for the boundary surface as well);
 * - the quality: every changed tet stays positive with dihedral angles in [GR_CO_MIN,
 *   GR_CO_MAX], or no worse than the worst tet around the removed vertex;
 * - the edge bound and the size field;
 * - the volume: GR_CO_VOLUME D per unit of new boundary area, GR_CO_NET_VOLUME in all;
 * - the distance both ways: every new boundary triangle, sampled at half a voxel, lies
 *   within the bound of the isosurface (|phi| / |grad phi|, the first-order distance, or
 *   near the bound the length of Newton steps onto the surface) and
 *   faces the way the field's gradient does (or, within the bound of a border plane and
 *   facing out of it, lies in the material's section of the plane or near its rim:
 *   near_plane); every sample of the isosurface (the crossings of
 *   the voxel edges, as marching cubes places its vertices) stays within the bound of the
 *   boundary (or within its distance on the stuffed mesh, when that was already over).
 * A vertex is moved onto the other end of the edge (a collapse moves no vertex); an edge
 * whose collapse fails both ways may be merged at a point between (merge_sweep: an interior
 * edge's midpoint or its stars' mean; a boundary edge's midpoint taken onto the isosurface).
 * Between rounds of collapses, vertices move under the same checks (boundary ones along their
 * normal so that chords straddle the surface, interior ones to their neighbours' mean) and
 * poorly shaped tets are flipped (2-3 and 3-2) where that betters them; after the rounds,
 * tets beyond 15..150 degrees are repaired by moves, collapses and peels. Vertices on the
 * volume's border planes move only by collapses within their plane (plane_ok); their
 * boundary edges flip within it (bedge_remove). */
#include "../core/core.h"
#include "../quality/tet_internal.h"
#include "graded_internal.h"
#include "mesher_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef VM_HAVE_OPENMP
#include <omp.h>
#endif

/* Dihedral angles (degrees) every tet a collapse changes must keep. */
#define GR_CO_MIN 15.01
#define GR_CO_MAX 149.99
/* A new boundary triangle's normal within this angle's cosine of the field's gradient. */
#define GR_CO_NORMAL_COS 0.5
/* Passes over the edges; the work stops early when a pass removes under 0.5% of vertices. */
#define GR_CO_PASSES 12
/* Rounds of collapse passes, merges, vertex moves and flips. */
#define GR_CO_ROUNDS 6
/* Between rounds, tets graded below this (minimum dihedral angle under 45 degrees or maximum
 * over 90: grade()) are flipped where that betters them, in up to this many sweeps. */
#define GR_CO_FLIP_BAR 3.0
#define GR_CO_FLIP_SWEEPS 3
/* The mean sweeps after the rounds (mean_sweep): at most this many, and a move must raise its
 * star's summed smallest dihedral angles by this many degrees a tet. */
#define GR_CO_MEAN_SWEEPS 3
#define GR_CO_MEAN_GAIN 0.01
/* After the quality pass (vm__gr_mean_smooth): rounds of flip sweeps and mean sweeps. On the
 * CT head at 500 (--graded) each round moves about half as many vertices as the one before
 * (about 2000 in the first); eight rounds raise the mean of each tet's smallest angle 0.07
 * degree above four (36.17 -> 37.90 in four). */
#define GR_CO_POLISH_ROUNDS 4
/* ... and they change the volume by at most this fraction either way (net): with the
 * coarsening's GR_CO_NET_VOLUME they took the 64^3 phantoms' volumes 0.8 to 1.0% down
 * (their chords cut inside the convex parts), with a tenth of a percent the mean angle
 * gained 1 to 2 degrees instead of 2 to 3. */
#define GR_CO_POLISH_VOLUME 0.002
/* A boundary collapse changes the volume by at most this times D times the new area. */
#define GR_CO_VOLUME 0.2
/* ... and the whole mesh's volume by at most this fraction (net). */
#define GR_CO_NET_VOLUME 0.01
/* ... and gain at most this fraction: the stuffed mesh's chords lie inside a convex surface,
 * so moves that make them straddle it bring volume back, but on thin plates they would
 * thicken the material. */
#define GR_CO_NET_GAIN 0.02
/* Every changed tet keeps at least this ABAQUS volume measure (the quality pass's target). */
#define GR_CO_VOLUME_MEASURE 0.03
/* Degrees per radian. */
#define GR_CO_DEG 57.29577951308232
/* cos 10 and cos 160 degrees (ABAQUS's face angle limits). */
#define GR_CO_COS10 0.984807753012208
#define GR_CO_COS160 (-0.9396926207859083)

typedef struct ilist {
    int32_t *v;
    int32_t n, cap;
} ilist;

/* What a check writes besides its plan: one per thread. */
typedef struct scratch {
    int32_t *vmark, vstamp; /* per vertex, for the link test */
    int late;       /* the check got past the changed tets (read the neighbours) */
    int budget_hit; /* it refused a collapse on the net volume budget */
    int reached;    /* it reached the budget's test, with this change of volume: */
    double dtry;
} scratch;

typedef struct co {
    vm_mesh *m;
    const gr_field *f;
    double inv[3][3]; /* world -> index */
    double D, max_edge, sign, voxel;
    size_t nv, nt, live;
    ilist *vt;          /* vertex -> live tets */
    ilist *vs;          /* vertex -> samples whose triangle may hold it (lazily pruned) */
    unsigned char *bnd; /* vertex on the boundary */
    unsigned char *fix; /* the volume's border planes a vertex lies on (bit 2 r + side) */
    unsigned char *dead_v, *dead_t;
    unsigned char *free_faces; /* per tet: bit k when no other live tet has its face k */
    double (*sp)[3];   /* isosurface samples (world) */
    double *tol;       /* distance each sample must keep to the boundary */
    int32_t (*st)[3];  /* the boundary triangle near each sample */
    size_t ns;
    int32_t *mark, stamp; /* per sample, for pruning repeats */
    scratch w;              /* the serial checks' scratch */
    float *qlo, *qhi;       /* per tet: its dihedral range */
    float *qab;             /* per tet: its ABAQUS grade (tet_angles) */
    double dvol, vol_budget; /* volume added so far; the most it may lose */
    double vol_gain;         /* ... and the most it may gain */
    int strict;              /* repairing: a collapse must better the worst angle */
    int merging;             /* merging: changed tets meet the angle limits themselves */
    size_t removals;         /* edge removals made (edge_remove) */
    size_t bremovals;        /* boundary edge removals made (bedge_remove) */
    size_t flips23, flips32; /* flips made (flip) */
    size_t slot;             /* dead tets below this index are all reused (flips) */
    /* per vertex: `applied` when a collapse last changed its star (star), or what its checks
     * read (near: its star or a neighbour's) */
    uint32_t *star, *near;
    uint32_t applied; /* collapses made, plus one */
    /* per tet: 0, or `applied` plus one when flip_tet last found no flip for it (the flip
     * sweeps try it again only once the near mark of one of its corners has passed that) */
    uint32_t *flipless;
    int flip_budget; /* a boundary edge removal was refused for the volume budget alone */
    int search;      /* mean_sweep tries sum_search's place first (after the quality pass) */
    vm__meter *pm;           /* polled for cancellation (may be NULL) */
    unsigned polls;
    int stop;                /* cancelled */
    int nomem;
} co;

static int push(ilist *l, int32_t x) {
    if (l->n == l->cap) {
        int32_t cap = l->cap ? 2 * l->cap : 8;
        int32_t *nv = realloc(l->v, (size_t)cap * sizeof *nv);
        if (!nv) return 0;
        l->v = nv;
        l->cap = cap;
    }
    l->v[l->n++] = x;
    return 1;
}

static void drop(ilist *l, int32_t x) {
    for (int32_t i = 0; i < l->n; i++)
        if (l->v[i] == x) {
            l->v[i] = l->v[--l->n];
            return;
        }
}

static const vm_index *tet(const co *C, int32_t t) {
    return C->m->cells + 4 * (size_t)t;
}
static const double *pt(const co *C, int64_t v) {
    return C->m->points + 3 * (size_t)v;
}

static double dist2(const double *a, const double *b) {
    double s = 0;
    for (int d = 0; d < 3; d++)
        s += (a[d] - b[d]) * (a[d] - b[d]);
    return s;
}

static double vol6(const double *a, const double *b, const double *c, const double *d) {
    double u[3], v[3], w[3];
    for (int k = 0; k < 3; k++) {
        u[k] = b[k] - a[k];
        v[k] = c[k] - a[k];
        w[k] = d[k] - a[k];
    }
    return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) +
           u[2] * (v[0] * w[1] - v[1] * w[0]);
}

/* The index point of world point x. */
static void to_index(const co *C, const double x[3], double ijk[3]) {
    double w[3];
    for (int r = 0; r < 3; r++)
        w[r] = x[r] - C->f->v->origin[r];
    for (int r = 0; r < 3; r++)
        ijk[r] = C->inv[r][0] * w[0] + C->inv[r][1] * w[1] + C->inv[r][2] * w[2];
}

/* phi and its gradient (world) at world point x; 0 when x is beyond the volume. */
static int phi_grad(const co *C, const double x[3], double *phi, double g[3]) {
    const gr_field *f = C->f;
    double ijk[3];
    to_index(C, x, ijk);
    int64_t c[3];
    double t[3];
    for (int d = 0; d < 3; d++) {
        double hi = (double)(f->n[d] - 1), tol = 1e-9 * (double)f->n[d];
        if (ijk[d] < -tol || ijk[d] > hi + tol || f->n[d] < 2) return 0;
        double q = ijk[d] < 0 ? 0 : ijk[d] > hi ? hi : ijk[d];
        c[d] = (int64_t)q; /* q >= 0: its floor (floor() is a library call) */
        if (c[d] > f->n[d] - 2) c[d] = f->n[d] - 2;
        t[d] = q - (double)c[d];
    }
    /* the cell's corners, x fastest (vm__gr_phi_point of each) */
    const float *s0 = f->v->data + c[0] + f->n[0] * (c[1] + f->n[1] * c[2]);
    int64_t sy0 = f->n[0], sz0 = f->n[0] * f->n[1];
    const int64_t off[8] = {0, 1, sy0, sy0 + 1, sz0, sz0 + 1, sz0 + sy0, sz0 + sy0 + 1};
    double v[8];
    for (int k = 0; k < 8; k++)
        v[k] = vm__gr_phi_value(f, s0[off[k]]);
    /* trilinear value and its derivatives in index space */
    const double tw[3][2] = {{1 - t[0], t[0]}, {1 - t[1], t[1]}, {1 - t[2], t[2]}};
    double val = 0, gi[3] = {0, 0, 0};
    for (int k = 0; k < 8; k++) {
        double wx = tw[0][k & 1], wy = tw[1][k >> 1 & 1], wz = tw[2][k >> 2];
        double sx = (k & 1) ? 1 : -1, sy = (k >> 1 & 1) ? 1 : -1, sz = (k >> 2) ? 1 : -1;
        val += v[k] * wx * wy * wz;
        gi[0] += v[k] * sx * wy * wz;
        gi[1] += v[k] * wx * sy * wz;
        gi[2] += v[k] * wx * wy * sz;
    }
    /* d phi / d world = inv^T d phi / d ijk */
    for (int r = 0; r < 3; r++)
        g[r] = C->inv[0][r] * gi[0] + C->inv[1][r] * gi[1] + C->inv[2][r] * gi[2];
    *phi = val;
    return 1;
}

/* The cosines of a tet's smallest and largest dihedral angles, [out] *cmax and *cmin (the
 * faces' normals all point the same way, in or out: the dihedral angle between two faces
 * is pi minus the angle of their normals). Returns 0 for a degenerate tet. */
static int dihedral_cosines(const double p[4][3], double *cmax, double *cmin) {
    static const int fc[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    double n[4][3], nl[4];
    for (int f = 0; f < 4; f++) {
        const double *a = p[fc[f][0]], *b = p[fc[f][1]], *c = p[fc[f][2]];
        double u[3], v[3];
        for (int d = 0; d < 3; d++)
            u[d] = b[d] - a[d], v[d] = c[d] - a[d];
        n[f][0] = u[1] * v[2] - u[2] * v[1];
        n[f][1] = u[2] * v[0] - u[0] * v[2];
        n[f][2] = u[0] * v[1] - u[1] * v[0];
        nl[f] = sqrt(n[f][0] * n[f][0] + n[f][1] * n[f][1] + n[f][2] * n[f][2]);
        if (!(nl[f] > 0)) return 0;
    }
    double hi = -1, lo = 1;
    for (int f = 0; f < 4; f++)
        for (int g = f + 1; g < 4; g++) {
            double c = -(n[f][0] * n[g][0] + n[f][1] * n[g][1] + n[f][2] * n[g][2]) /
                       (nl[f] * nl[g]);
            hi = c > hi ? c : hi;
            lo = c < lo ? c : lo;
        }
    *cmax = hi > 1 ? 1 : hi;
    *cmin = lo < -1 ? -1 : lo;
    return 1;
}

/* How a tet stands against ABAQUS's element check (face angles 10..160 degrees, volume
 * measure GR_CO_VOLUME_MEASURE, the quality pass's target): 1 at a limit, higher is
 * better. Dihedral angles alone let needles through (three close corners and a far one). */
static double abaqus_measures(const double p[4][3], double *chi, double *clo);
static double abaqus_grade(const double p[4][3]) {
    double hi, lo, vm = abaqus_measures(p, &hi, &lo);
    double famin = acos(hi) * GR_CO_DEG, famax = acos(lo) * GR_CO_DEG;
    double g = famin / 10.0, g2 = (180.0 - famax) / 20.0, g3 = vm / GR_CO_VOLUME_MEASURE;
    return g < g2 ? (g < g3 ? g : g3) : (g2 < g3 ? g2 : g3);
}

/* Whether the tet passes the limits of abaqus_grade: the same test in cosines. */
static int abaqus_ok(const double p[4][3]) {
    double hi, lo, vm = abaqus_measures(p, &hi, &lo);
    return hi <= GR_CO_COS10 && lo >= GR_CO_COS160 && vm >= GR_CO_VOLUME_MEASURE;
}

/* The cosines of a tet's smallest and largest face angles ([out] *chi, *clo) and its volume
 * measure (returned). */
static double abaqus_measures(const double p[4][3], double *chi, double *clo) {
    /* the six edges' squared lengths and lengths; the angle at corner a of face abc has
     * the cosine (|ab|^2 + |ac|^2 - |bc|^2) / (2 |ab| |ac|) */
    static const int ed[4][4] = {{-1, 0, 1, 2}, {0, -1, 3, 4}, {1, 3, -1, 5}, {2, 4, 5, -1}};
    double q[6], l[6];
    for (int i = 0, k = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++, k++) {
            q[k] = dist2(p[i], p[j]);
            l[k] = sqrt(q[k]);
        }
    double hi = -1, lo = 1; /* cosines of the largest and smallest face angles */
    for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
            for (int c = b + 1; c < 4; c++) {
                if (b == a || c == a) continue;
                int ab = ed[a][b], ac = ed[a][c], bc = ed[b][c];
                double c0 = (q[ab] + q[ac] - q[bc]) / (2 * l[ab] * l[ac]);
                hi = c0 > hi ? c0 : hi;
                lo = c0 < lo ? c0 : lo;
            }
    *chi = hi <= 1 ? hi : 1;
    *clo = lo >= -1 ? lo : -1;
    /* volume measure: V over the regular tet's of the same circumradius R, 8 R^3 / (9 sqrt 3);
     * with e the edges from p[0], 12 V R is |e0|^2 (e1 x e2) + |e1|^2 (e2 x e0) +
     * |e2|^2 (e0 x e1) */
    double e[3][3], x[3][3], l2[3];
    for (int k = 0; k < 3; k++) {
        l2[k] = 0;
        for (int d = 0; d < 3; d++) {
            e[k][d] = p[k + 1][d] - p[0][d];
            l2[k] += e[k][d] * e[k][d];
        }
    }
    for (int k = 0; k < 3; k++) { /* x[k] = e[k+1] x e[k+2] */
        const double *u = e[(k + 1) % 3], *v = e[(k + 2) % 3];
        x[k][0] = u[1] * v[2] - u[2] * v[1];
        x[k][1] = u[2] * v[0] - u[0] * v[2];
        x[k][2] = u[0] * v[1] - u[1] * v[0];
    }
    double v6 = fabs(e[0][0] * x[0][0] + e[0][1] * x[0][1] + e[0][2] * x[0][2]), w2 = 0;
    for (int d = 0; d < 3; d++) {
        double w = l2[0] * x[0][d] + l2[1] * x[1][d] + l2[2] * x[2][d];
        w2 += w * w;
    }
    double vm = 0;
    if (v6 > 0 && w2 > 0) {
        double r = sqrt(w2) / (2 * v6);
        vm = (v6 / 6) / (8 * r * r * r / (9 * sqrt(3.0)));
    }
    return vm;
}

/* tet_angles from the tet's dihedral cosines cmax and cmin (dihedral_cosines). */
static double tet_angles_of(const double p[4][3], double cmax, double cmin, double *lo,
                            double *hi) {
    *lo = acos(cmax) * GR_CO_DEG;
    *hi = acos(cmin) * GR_CO_DEG;
    return abaqus_grade(p);
}
/* A tet's dihedral range [*lo, *hi] (degrees) and its abaqus_grade; -1 (and 0..180) for a
 * degenerate tet. */
static double tet_angles(const double p[4][3], double *lo, double *hi) {
    double cmax, cmin;
    *lo = 0;
    *hi = 180;
    if (!dihedral_cosines(p, &cmax, &cmin)) return -1;
    return tet_angles_of(p, cmax, cmin, lo, hi);
}

/* Whether a live tet around v already fails the ABAQUS check (then changes there need not
 * pass it either: they are judged by the dihedral angles alone). */
static int star_fails_abaqus(const co *C, int32_t v) {
    const ilist *l = &C->vt[v];
    for (int32_t i = 0; i < l->n; i++)
        if (C->qab[l->v[i]] < 1) return 1;
    return 0;
}

/* Newton steps y -= f h / |h|^2 from y (f: phi there, h: its gradient; both updated), at
 * most `steps`, until |f| is within 1e-3 D of |h|: [out] *len, the length of the path.
 * Returns 0 when they leave the volume, meet no gradient or do not converge. */
static int newton_walk(const co *C, double y[3], double f, double h[3], int steps, double *len) {
    *len = 0;
    for (int it = 0; it < steps; it++) {
        double h2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
        if (!(h2 > 0)) return 0;
        double s = f / h2;
        for (int d = 0; d < 3; d++)
            y[d] -= s * h[d];
        *len += fabs(s) * sqrt(h2);
        if (!phi_grad(C, y, &f, h)) return 0;
        double hn = sqrt(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]);
        if (hn > 0 && fabs(f) <= 1e-3 * C->D * hn) return 1;
    }
    return 0;
}

/* The distance from x (phi and its gradient g there) to the isosurface, bounded from above
 * by the path of Newton steps x -= phi g / |g|^2 onto it: [out] *e, signed as phi. Returns 0
 * when the steps leave the volume, meet no gradient or do not converge. */
static int newton_distance(const co *C, const double x[3], double phi, const double g[3],
                           double *e) {
    double y[3] = {x[0], x[1], x[2]}, h[3] = {g[0], g[1], g[2]}, len;
    if (!newton_walk(C, y, phi, h, 8, &len)) return 0;
    *e = phi >= 0 ? len : -len;
    return 1;
}

/* Steps per side of a triangle's samples, every half voxel (at least 2); 0 past 256. */
static int tri_steps(const co *C, const double *p0, const double *p1, const double *p2) {
    double l = sqrt(fmax(dist2(p0, p1), fmax(dist2(p1, p2), dist2(p0, p2))));
    int k = (int)ceil(l / (0.5 * C->voxel));
    if (k < 2) k = 2;
    return k > 256 ? 0 : k;
}

/* The triangle's point p0 + a (p1 - p0) + b (p2 - p0) into x. */
static void tri_at(const double *p0, const double *p1, const double *p2, double a, double b,
                   double x[3]) {
    for (int d = 0; d < 3; d++)
        x[d] = p0[d] + a * (p1[d] - p0[d]) + b * (p2[d] - p0[d]);
}

/* The signed first-order distance phi / |grad phi| (positive inside) over the triangle
 * (world points), sampled every half voxel, corners included: its range [*lo, *hi]. 0 when a
 * sample has no gradient, lies beyond the volume, or where the triangle's outward normal n
 * (any length) is off -grad phi by over 60 degrees; 0 as well, without the other samples,
 * once a sample is farther than bound (INFINITY: none) either way. */
static int tri_errors(const co *C, const double *p0, const double *p1, const double *p2,
                      const double n[3], double bound, double *lo, double *hi) {
    int k = tri_steps(C, p0, p1, p2);
    if (!k) return 0;
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(nn > 0)) return 0;
    *lo = INFINITY;
    *hi = -INFINITY;
    /* the sample nearest the centroid first (where a chord is farthest from the surface),
     * then the others: a failing triangle fails sooner, and the range is the same */
    int ci = k / 3;
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i <= k; i++)
            for (int j = 0; i + j <= k; j++) {
                if ((i == ci && j == ci) != (pass == 0)) continue;
                double x[3], phi, g[3];
                tri_at(p0, p1, p2, (double)i / k, (double)j / k, x);
                if (!phi_grad(C, x, &phi, g)) return 0;
                double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
                if (!(gn > 0)) return 0;
                double e = phi / gn;
                /* near the bound the first-order distance may be short of the true one (the
                 * gradient is steeper here than on the way to the surface): the length of
                 * Newton steps onto the surface bounds it from above */
                if (fabs(e) > 0.5 * C->D && !newton_distance(C, x, phi, g, &e)) return 0;
                if (e < -bound || e > bound) return 0;
                if (e < *lo) *lo = e;
                if (e > *hi) *hi = e;
                /* outward is along -grad phi */
                if (-(g[0] * n[0] + g[1] * n[1] + g[2] * n[2]) < GR_CO_NORMAL_COS * gn * nn)
                    return 0;
            }
    return 1;
}

/* Whether the triangle lies within the distance bound of the isosurface and faces along
 * -grad phi. */
static int tri_near(const co *C, const double *p0, const double *p1, const double *p2,
                    const double n[3]) {
    double lo, hi;
    return tri_errors(C, p0, p1, p2, n, C->D, &lo, &hi) && -lo <= C->D && hi <= C->D;
}

/* Whether a boundary triangle in a border plane (it closes the material where the material
 * meets the border) lies in the material's section of the plane, or within the distance
 * bound of the section's rim: sampled every half voxel, by the first-order distance (the
 * length of Newton steps onto the surface near the bound). */
static int flat_near(const co *C, const double *p0, const double *p1, const double *p2) {
    int k = tri_steps(C, p0, p1, p2);
    if (!k) return 0;
    double m[3][3];
    vm__volume_frame(C->f->v, m);
    for (int i = 0; i <= k; i++)
        for (int j = 0; i + j <= k; j++) {
            double x[3], phi, g[3];
            tri_at(p0, p1, p2, (double)i / k, (double)j / k, x);
            /* a sample beyond the box is read on it, at its offset's cost: the stuffing
             * holds a cut across the border a hair beyond it where the vertex on the plane
             * has to stay inside (graded_stuff.c, GR_CUT_BORDER), and such points, read
             * beyond the volume, were never collapsed (a 0.6 degree tet on the CT head) */
            double ijk[3], x0[3] = {x[0], x[1], x[2]};
            to_index(C, x, ijk);
            for (int r = 0; r < 3; r++) {
                double top = (double)(C->f->n[r] - 1);
                double dr = ijk[r] < 0 ? -ijk[r] : ijk[r] > top ? top - ijk[r] : 0;
                for (int d = 0; d < 3; d++)
                    x[d] += m[d][r] * dr;
            }
            double off = sqrt(dist2(x, x0));
            if (off > C->D || !phi_grad(C, x, &phi, g)) return 0;
            if (phi >= 0) continue;
            double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
            if (!(gn > 0)) return 0;
            double e = phi / gn;
            if (-e > 0.5 * C->D && !newton_distance(C, x, phi, g, &e)) return 0;
            if (off - e > C->D) return 0;
        }
    return 1;
}

/* Whether a boundary triangle lies within the distance bound of a border plane where the
 * material meets it, facing out of the volume (within 60 degrees): the flat faces closing
 * the material there, and the faces a hair off the plane that the stuffing leaves beside
 * their rim, held by flat_near instead of tri_near. */
static int near_plane(const co *C, const double *p0, const double *p1, const double *p2,
                      const double n[3]) {
    const gr_field *f = C->f;
    double u[3][3];
    to_index(C, p0, u[0]);
    to_index(C, p1, u[1]);
    to_index(C, p2, u[2]);
    double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int r = 0; r < 3; r++) {
        /* |grad ijk[r]|: index units per world unit across the plane */
        double gr = sqrt(C->inv[r][0] * C->inv[r][0] + C->inv[r][1] * C->inv[r][1] +
                         C->inv[r][2] * C->inv[r][2]);
        for (int side = 0; side < 2; side++) {
            double plane = side ? (double)(f->n[r] - 1) : 0;
            int near = 1;
            for (int v = 0; v < 3 && near; v++)
                near = fabs(u[v][r] - plane) <= C->D * gr;
            if (!near) continue;
            double out = (C->inv[r][0] * n[0] + C->inv[r][1] * n[1] + C->inv[r][2] * n[2]) *
                         (side ? 1 : -1);
            if (out >= GR_CO_NORMAL_COS * gr * nn) return flat_near(C, p0, p1, p2);
        }
    }
    return 0;
}

/* A collapse's new boundary triangle near the isosurface (tri_near) or a border plane
 * (near_plane; moves and peels keep to tri_near: with it there too the CT head's
 * isosurface-to-boundary distance grew from 0.774 to 0.796 voxel for 0.5% fewer tets). */
static int tri_fits(const co *C, const double *p0, const double *p1, const double *p2,
                    const double n[3]) {
    return tri_near(C, p0, p1, p2, n) || near_plane(C, p0, p1, p2, n);
}

/* Every 1024th call polls the caller's meter; 1 once cancelled. */
static int stopped(co *C) {
    if (C->stop) return 1;
    if (C->pm && (++C->polls & 1023) == 0 && vm__meter_poll(C->pm)) C->stop = 1;
    return C->stop;
}

/* Edge pq within --max-edge and the size field. */
static int edge_ok(const co *C, const double *p, const double *q) {
    double l2 = dist2(p, q);
    if (l2 > C->max_edge * C->max_edge) return 0;
    if (!C->f->bsize) return 1;
    double lo3[3], hi3[3], up[3], uq[3];
    to_index(C, p, up);
    to_index(C, q, uq);
    for (int r = 0; r < 3; r++) {
        double u0 = up[r] * C->f->sp[r], u1 = uq[r] * C->f->sp[r];
        lo3[r] = fmin(u0, u1);
        hi3[r] = fmax(u0, u1);
    }
    double L = vm__gr_size_min(C->f, lo3, hi3);
    return l2 <= L * L;
}

/* Tet t has no other live tet on its face opposite corner k (kept in free_faces). */
static int face_free(const co *C, int32_t t, int k) {
    return C->free_faces[t] >> k & 1;
}

/* Tet t has no other live tet on its face opposite corner k, by the tet list of the face's
 * corner with the fewest. */
static int face_free_scan(const co *C, int32_t t, int k) {
    const vm_index *c = tet(C, t);
    int64_t x = c[(k + 1) & 3], y = c[(k + 2) & 3], z = c[(k + 3) & 3];
    if (C->vt[y].n < C->vt[x].n) {
        int64_t q = x;
        x = y;
        y = q;
    }
    if (C->vt[z].n < C->vt[x].n) {
        int64_t q = x;
        x = z;
        z = q;
    }
    const ilist *l = &C->vt[x];
    for (int32_t i = 0; i < l->n; i++) {
        int32_t o = l->v[i];
        if (o == t) continue;
        const vm_index *q = tet(C, o);
        int hy = 0, hz = 0;
        for (int j = 0; j < 4; j++) {
            hy |= q[j] == y;
            hz |= q[j] == z;
        }
        if (hy && hz) return 0;
    }
    return 1;
}

/* Finds the free faces of tet t again (after its neighbours changed). */
static void refresh_faces(co *C, int32_t t) {
    unsigned char bits = 0;
    for (int k = 0; k < 4; k++)
        bits |= (unsigned char)(face_free_scan(C, t, k) << k);
    C->free_faces[t] = bits;
}

/* Finds the free faces of the tets around v again: with `own`, only their faces that hold
 * v. */
static void refresh_star(co *C, int32_t v, int own) {
    const ilist *l = &C->vt[v];
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        const vm_index *c = tet(C, t);
        unsigned char bits = C->free_faces[t];
        for (int k = 0; k < 4; k++)
            if (!own || c[k] != (vm_index)v)
                bits = (unsigned char)((bits & ~(1u << k)) | (face_free_scan(C, t, k) << k));
        C->free_faces[t] = bits;
    }
}

/* Normal (any length) of the triangle (px, py, pz) pointing away from pk. */
static void out_normal(const double *px, const double *py, const double *pz, const double *pk,
                       double n[3]) {
    double u[3], v[3];
    for (int d = 0; d < 3; d++) {
        u[d] = py[d] - px[d];
        v[d] = pz[d] - px[d];
    }
    n[0] = u[1] * v[2] - u[2] * v[1];
    n[1] = u[2] * v[0] - u[0] * v[2];
    n[2] = u[0] * v[1] - u[1] * v[0];
    if (n[0] * (pk[0] - px[0]) + n[1] * (pk[1] - px[1]) + n[2] * (pk[2] - px[2]) > 0)
        for (int d = 0; d < 3; d++)
            n[d] = -n[d];
}

/* Outward normal (any length) of the face of tet c opposite corner k (positions now). */
static void face_out(const co *C, const vm_index *c, int k, double n[3]) {
    out_normal(pt(C, c[(k + 1) & 3]), pt(C, c[(k + 2) & 3]), pt(C, c[(k + 3) & 3]),
               pt(C, c[k]), n);
}

/* A hint to fetch what p points at into the cache (no effect on results). */
#if defined(__GNUC__) || defined(__clang__)
#define PREFETCH(p) __builtin_prefetch(p)
#else
#define PREFETCH(p) ((void)(p))
#endif

/* The edges come shortest first, all over the mesh, and a check waits on memory more than it
 * computes: what the check of edge e (the vertex lists) and of the edges before it (their
 * tets, their points) will read is asked for a few edges ahead. */
static void prefetch_edge(const co *C, int32_t a, int32_t b, int stage) {
    int32_t v[2] = {a, b};
    for (int i = 0; i < 2; i++) {
        const ilist *l = &C->vt[v[i]];
        if (stage == 0) {
            PREFETCH(l);
            PREFETCH(&C->bnd[v[i]]);
            PREFETCH(&C->dead_v[v[i]]);
        } else if (stage == 1) {
            PREFETCH(l->v);
        } else {
            int32_t n = l->n < 16 ? l->n : 16;
            for (int32_t k = 0; k < n; k++) {
                PREFETCH(tet(C, l->v[k]));
                if (stage == 3) {
                    const vm_index *c = tet(C, l->v[k]);
                    for (int r = 0; r < 4; r++)
                        PREFETCH(pt(C, c[r]));
                }
            }
        }
    }
}

/* Small bags of packed ids (edges, faces), sorted once, then searched. */
enum { SET_MAX = 2048 };
typedef struct set {
    int64_t v[SET_MAX];
    int n, full;
} set;

static void set_add(set *s, int64_t x) {
    if (s->n == SET_MAX)
        s->full = 1;
    else
        s->v[s->n++] = x;
}
static void set_sort(set *s) {
    vm__sort_i64(s->v, (size_t)s->n);
}
static int set_has(const set *s, int64_t x) {
    int lo = 0, hi = s->n;
    while (lo < hi) {
        int m = (lo + hi) / 2;
        if (s->v[m] < x)
            lo = m + 1;
        else
            hi = m;
    }
    return lo < s->n && s->v[lo] == x;
}
static int64_t pack2(int64_t x, int64_t y) {
    return x < y ? x << 32 | y : y << 32 | x;
}
/* Faces by a hash of their sorted ids: a collision only refuses a collapse. */
static int64_t pack3(int64_t x, int64_t y, int64_t z) {
    int64_t t;
    if (x > y) t = x, x = y, y = t;
    if (y > z) t = y, y = z, z = t;
    if (x > y) t = x, x = y, y = t;
    return (int64_t)(((uint64_t)x * 0x9E3779B97F4A7C15ull) ^ ((uint64_t)y * 0xC2B2AE3D27D4EB4Full) ^
                     ((uint64_t)z * 0x165667B19E3779F9ull));
}

typedef struct plan {
    double qmin; /* the worst min dihedral of the changed tets */
    double dvol; /* the volume it adds (boundary collapses) */
    int ntri;    /* b's boundary star after the collapse: triangles */
    int32_t tri[SET_MAX][3];
} plan;

/* Stamps of the vertex sets of one check: a's neighbours off the edge's tets (1), on them
 * (2). */
static void stamp_next(scratch *W, size_t nv) {
    if (W->vstamp >= INT32_MAX - 4) {
        memset(W->vmark, 0, nv * sizeof *W->vmark);
        W->vstamp = 0;
    }
    W->vstamp += 2;
}

/* Whether a boundary face with corners x, y, z lies in border plane bit `pl`. */
static int in_plane(const co *C, int64_t x, int64_t y, int64_t z, unsigned pl) {
    return (C->fix[x] & C->fix[y] & C->fix[z] & pl) != 0;
}

/* A vertex a on one border plane may collapse onto b on the same plane: inside the flat
 * face where the material meets the plane (all of a's boundary faces in the plane: the
 * face's outline stays), or along its rim (a's boundary faces in the plane and off it meet
 * in exactly two edges of a, and ab is one of them: the rim's new chord is an edge of a
 * face off the plane, which check() holds to the distance bound). A vertex on two planes
 * stays. */
static int plane_ok(const co *C, int32_t a, int32_t b) {
    unsigned pa = C->fix[a];
    if ((pa & (pa - 1)) || !(C->fix[b] & pa)) return 0;
    enum { RIM_MAX = 64 };
    int32_t other[RIM_MAX];
    unsigned char kind[RIM_MAX]; /* bit 0: in a face in the plane; bit 1: in one off it */
    int n = 0, off = 0;
    const ilist *ta = &C->vt[a];
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        for (int k = 0; k < 4; k++) {
            if (c[k] == a || !face_free(C, ta->v[i], k)) continue;
            int64_t q[2];
            int nq = 0;
            for (int j = 1; j < 4; j++)
                if (c[(k + j) & 3] != a) q[nq++] = c[(k + j) & 3];
            unsigned bit = in_plane(C, a, q[0], q[1], pa) ? 1u : 2u;
            if (bit == 2) off = 1;
            for (int j = 0; j < 2; j++) {
                int e = 0;
                while (e < n && other[e] != q[j])
                    e++;
                if (e == n) {
                    if (n == RIM_MAX) return 0;
                    other[n] = (int32_t)q[j];
                    kind[n++] = 0;
                }
                kind[e] |= (unsigned char)bit;
            }
        }
    }
    if (!off) return 1;
    int rim = 0, ab = 0;
    for (int e = 0; e < n; e++)
        if (kind[e] == 3) {
            rim++;
            if (other[e] == b) ab = 1;
        }
    return rim == 2 && ab;
}

/* Whether collapsing a onto b keeps every condition; fills the plan (b's boundary star after
 * the collapse). */
static int check(const co *C, scratch *W, int32_t a, int32_t b, plan *P, set *s1, set *s2,
                 set *s3) {
    W->late = 0;
    W->reached = 0;
    if ((C->bnd[a] && !C->bnd[b]) || (C->fix[a] && !plane_ok(C, a, b))) return 0;
    const ilist *ta = &C->vt[a], *tb = &C->vt[b];
    /* the changed tets first (cheap, and most collapses fail here): positive, within the
     * angle limits or no worse than the worst tet around a now, new edges within bounds */
    int shared = 0;
    double olo = 180, ohi = 0, dvol = 0;
    for (int32_t i = 0; i < ta->n; i++) {
        int32_t t = ta->v[i];
        const vm_index *c = tet(C, t);
        /* (the volume change matters to boundary collapses only) */
        if (C->bnd[a])
            dvol -= C->sign * vol6(pt(C, c[0]), pt(C, c[1]), pt(C, c[2]), pt(C, c[3]));
        if (c[0] == b || c[1] == b || c[2] == b || c[3] == b) {
            shared++;
            continue;
        }
        double p[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], pt(C, c[k] == a ? b : c[k]), sizeof p[k]);
        double v6 = C->sign * vol6(p[0], p[1], p[2], p[3]);
        if (v6 <= 0) return 0;
        dvol += v6;
    }
    if (!shared) return 0;
    /* (read only now: most checks stop above, and these are misses in the cache) */
    for (int32_t i = 0; i < ta->n; i++) {
        olo = fmin(olo, C->qlo[ta->v[i]]);
        ohi = fmax(ohi, C->qhi[ta->v[i]]);
    }
    double amin = C->merging ? GR_CO_MIN : fmin(GR_CO_MIN, olo),
           amax = C->merging ? GR_CO_MAX : fmax(GR_CO_MAX, ohi);
    /* in cosines: no arc cosine per tet on this, the hottest path */
    double camin = cos(amin / GR_CO_DEG), camax = cos(amax / GR_CO_DEG), worst = -1;
    int ab = -1; /* whether a's star fails the ABAQUS check already; -1: not known yet */
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        if (c[0] == b || c[1] == b || c[2] == b || c[3] == b) continue;
        double p[4][3], cmax, cmin;
        int ka = 0;
        for (int k = 0; k < 4; k++) {
            if (c[k] == a) ka = k;
            memcpy(p[k], pt(C, c[k] == a ? b : c[k]), sizeof p[k]);
        }
        for (int k = 0; k < 4; k++)
            if (k != ka && !edge_ok(C, p[k], p[ka])) return 0;
        if (!dihedral_cosines((const double(*)[3])p, &cmax, &cmin) || cmax > camin ||
            cmin < camax)
            return 0;
        if (!abaqus_ok((const double(*)[3])p)) {
            if (ab < 0) ab = !C->merging && star_fails_abaqus(C, a);
            if (!ab) return 0;
        }
        if (cmax > worst) worst = cmax;
    }
    P->qmin = acos(worst) * GR_CO_DEG;
    /* (up to here the check read a's tets only) */
    W->late = 1;
    /* link condition, vertices: a neighbour of both a and b is in a tet of the edge */
    stamp_next(W, C->nv);
    int32_t s_off = W->vstamp - 1, s_on = W->vstamp;
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        if (c[0] == b || c[1] == b || c[2] == b || c[3] == b)
            for (int k = 0; k < 4; k++)
                W->vmark[c[k]] = s_on;
    }
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        for (int k = 0; k < 4; k++)
            if (W->vmark[c[k]] != s_on) W->vmark[c[k]] = s_off;
    }
    for (int32_t i = 0; i < tb->n; i++) {
        const vm_index *c = tet(C, tb->v[i]);
        for (int k = 0; k < 4; k++)
            if (c[k] != a && W->vmark[c[k]] == s_off) return 0;
    }
    /* edges and faces: the link edges of a that b also has are the edge's link edges; no
     * link face is shared */
    s1->n = s2->n = s3->n = 0;
    s1->full = s2->full = s3->full = 0;
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        int ka = 0, hb = 0;
        for (int k = 0; k < 4; k++) {
            if (c[k] == a) ka = k;
            if (c[k] == b) hb = 1;
        }
        int64_t o[3] = {c[(ka + 1) & 3], c[(ka + 2) & 3], c[(ka + 3) & 3]};
        if (hb) { /* the edge's link edge: the two others */
            int64_t e[2], ne = 0;
            for (int k = 0; k < 3; k++)
                if (o[k] != b) e[ne++] = o[k];
            set_add(s2, pack2(e[0], e[1]));
            continue;
        }
        set_add(s1, pack2(o[0], o[1]));
        set_add(s1, pack2(o[1], o[2]));
        set_add(s1, pack2(o[0], o[2]));
        set_add(s3, pack3(o[0], o[1], o[2]));
    }
    if (s1->full || s2->full || s3->full) return 0;
    set_sort(s1);
    set_sort(s2);
    set_sort(s3);
    for (int32_t i = 0; i < tb->n; i++) {
        const vm_index *c = tet(C, tb->v[i]);
        int kb = 0, ha = 0;
        for (int k = 0; k < 4; k++) {
            if (c[k] == b) kb = k;
            if (c[k] == a) ha = 1;
        }
        if (ha) continue;
        int64_t o[3] = {c[(kb + 1) & 3], c[(kb + 2) & 3], c[(kb + 3) & 3]};
        if (set_has(s3, pack3(o[0], o[1], o[2]))) return 0;
        for (int k = 0; k < 3; k++) {
            int64_t e = pack2(o[k], o[(k + 1) % 3]);
            if (set_has(s1, e) && !set_has(s2, e)) return 0;
        }
    }
    P->ntri = 0;
    P->dvol = 0;
    if (!C->bnd[a]) return 1;
    /* the same over the cone beyond the boundary: a's boundary link (vertices s1, edges s2),
     * the edge's (s3); b's boundary link must meet a's only there */
    s1->n = s2->n = s3->n = 0;
    int edge_on_boundary = 0;
    for (int pass = 0; pass < 2; pass++) {
        int32_t x = pass ? b : a, y = pass ? a : b;
        const ilist *l = &C->vt[x];
        for (int32_t i = 0; i < l->n; i++) {
            int32_t t = l->v[i];
            const vm_index *c = tet(C, t);
            for (int k = 0; k < 4; k++) {
                if (c[k] == x || !face_free(C, t, k)) continue;
                int64_t o[2], no = 0, hy = 0;
                for (int j = 1; j < 4; j++) {
                    int64_t q = c[(k + j) & 3];
                    if (q == x) continue;
                    if (q == y) hy = 1;
                    o[no++] = q;
                }
                if (hy) { /* boundary face x y z: z is in the edge's boundary link */
                    edge_on_boundary = 1;
                    if (pass == 0) set_add(s3, o[0] == y ? o[1] : o[0]);
                    continue;
                }
                if (pass == 0) {
                    set_add(s1, o[0]);
                    set_add(s1, o[1]);
                    set_add(s2, pack2(o[0], o[1]));
                } else {
                    for (int j = 0; j < 2; j++)
                        if (set_has(s1, o[j]) && !set_has(s3, o[j])) return 0;
                    if (set_has(s2, pack2(o[0], o[1]))) return 0;
                }
            }
        }
        if (pass == 0) {
            if (!edge_on_boundary || s1->full || s2->full || s3->full) return 0;
            set_sort(s1);
            set_sort(s2);
            set_sort(s3);
        }
    }
    /* a's boundary faces become b's: near the surface, facing along -grad phi; the volume
     * changes by at most GR_CO_VOLUME D times their area (chords inside a convex surface
     * would otherwise shrink thin parts by up to 2/3 D over their whole area) */
    double area = 0;
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        if (c[0] == b || c[1] == b || c[2] == b || c[3] == b) continue;
        for (int k = 0; k < 4; k++) {
            if (c[k] == a || !face_free(C, ta->v[i], k)) continue;
            int x = (k + 1) & 3, y = (k + 2) & 3, z = (k + 3) & 3;
            const double *px = pt(C, c[x] == a ? b : c[x]), *py = pt(C, c[y] == a ? b : c[y]),
                         *pz = pt(C, c[z] == a ? b : c[z]), *pk = pt(C, c[k]);
            double n[3];
            out_normal(px, py, pz, pk, n);
            if (!tri_fits(C, px, py, pz, n)) return 0;
            area += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
            if (P->ntri == SET_MAX) return 0;
            int32_t *T = P->tri[P->ntri++];
            T[0] = (int32_t)(c[x] == a ? b : c[x]);
            T[1] = (int32_t)(c[y] == a ? b : c[y]);
            T[2] = (int32_t)(c[z] == a ? b : c[z]);
        }
    }
    if (fabs(dvol) / 6 > GR_CO_VOLUME * C->D * area) return 0;
    /* and the whole volume by at most GR_CO_NET_VOLUME of it */
    W->reached = 1;
    W->dtry = dvol / 6;
    if (C->dvol + dvol / 6 < -C->vol_budget || C->dvol + dvol / 6 > C->vol_gain) {
        W->budget_hit = 1;
        return 0;
    }
    P->dvol = dvol / 6;
    /* b's boundary faces that stay */
    for (int32_t i = 0; i < tb->n; i++) {
        int32_t t = tb->v[i];
        const vm_index *c = tet(C, t);
        if (c[0] == a || c[1] == a || c[2] == a || c[3] == a) continue;
        for (int k = 0; k < 4; k++) {
            if (c[k] == b || !face_free(C, t, k)) continue;
            if (P->ntri == SET_MAX) return 0;
            int32_t *T = P->tri[P->ntri++];
            for (int j = 0; j < 3; j++)
                T[j] = (int32_t)c[(k + 1 + j) & 3];
        }
    }
    /* the isosurface samples near a's triangles stay near the boundary */
    const ilist *ls = &C->vs[a];
    for (int32_t i = 0; i < ls->n; i++) {
        int32_t q = ls->v[i];
        const int32_t *T = C->st[q];
        if (T[0] != a && T[1] != a && T[2] != a) continue;
        double best = INFINITY, t2 = C->tol[q] * C->tol[q];
        for (int j = 0; j < P->ntri && best > t2; j++) {
            const int32_t *U = P->tri[j];
            double d2 =
                vm__point_triangle_dist2(C->sp[q], pt(C, U[0]), pt(C, U[1]), pt(C, U[2]));
            if (d2 < best) best = d2;
        }
        if (best > t2) return 0;
    }
    return 1;
}

/* The dihedral range of tet t into the caches. */
static void measure(co *C, int32_t t) {
    const vm_index *c = tet(C, t);
    double p[4][3];
    for (int k = 0; k < 4; k++)
        memcpy(p[k], pt(C, c[k]), sizeof p[k]);
    double lo, hi;
    C->qab[t] = (float)tet_angles((const double(*)[3])p, &lo, &hi);
    C->qlo[t] = (float)lo;
    C->qhi[t] = (float)hi;
    C->flipless[t] = 0;
}

/* Marks vertex x as in a changed tet (star) and its neighbours as next to one (near), for
 * the memo of vm__gr_coarsen's passes (C->applied bumped by the caller). */
static void mark_vertex(co *C, int32_t x) {
    C->star[x] = C->applied;
    const ilist *l = &C->vt[x];
    for (int32_t j = 0; j < l->n; j++) {
        const vm_index *q = tet(C, l->v[j]);
        for (int r = 0; r < 4; r++)
            C->near[q[r]] = C->applied;
    }
}

/* What a check of edge xy reads (the tets of x and y, their vertices' tet lists, the samples
 * near their triangles) changes, when the tets around v change (a collapse of v, a move of
 * v), only where x or y is in v's star or next to it, and the first part of it (x's tets)
 * only where x is in the star: such checks are to be made again (the memo of
 * vm__gr_coarsen's passes). */
static void mark_around(co *C, int32_t v) {
    const ilist *ta = &C->vt[v];
    C->applied++;
    stamp_next(&C->w, C->nv);
    for (int32_t i = 0; i < ta->n; i++) {
        const vm_index *c = tet(C, ta->v[i]);
        for (int k = 0; k < 4; k++) {
            if (C->w.vmark[c[k]] == C->w.vstamp) continue;
            C->w.vmark[c[k]] = C->w.vstamp;
            mark_vertex(C, (int32_t)c[k]);
        }
    }
}

/* Applies a checked collapse of a onto b. */
static void apply(co *C, int32_t a, int32_t b, const plan *P) {
    ilist *ta = &C->vt[a];
    mark_around(C, a);
    for (int32_t i = 0; i < ta->n; i++) {
        int32_t t = ta->v[i];
        vm_index *c = C->m->cells + 4 * (size_t)t;
        int hb = c[0] == b || c[1] == b || c[2] == b || c[3] == b;
        if (hb) {
            C->dead_t[t] = 1;
            C->live--;
            for (int k = 0; k < 4; k++)
                if (c[k] != a) drop(&C->vt[c[k]], t);
        } else {
            for (int k = 0; k < 4; k++)
                if (c[k] == a) c[k] = b;
            measure(C, t);
            if (!push(&C->vt[b], t)) C->nomem = 1;
        }
    }
    ta->n = 0;
    C->dead_v[a] = 1;
    C->dvol += P->dvol;
    /* the faces that changed neighbours: those holding b of the tets around it (a face
     * that held a holds b now; one of a tet that died held a or b; any other face keeps its
     * tets, as the link condition keeps a tet from turning into one that exists) */
    refresh_star(C, b, 1);
    if (!C->bnd[a]) return;
    /* samples: to the nearest triangle of b's new star */
    ilist *ls = &C->vs[a];
    for (int32_t i = 0; i < ls->n; i++) {
        int32_t s = ls->v[i];
        int32_t *T = C->st[s];
        if (T[0] != a && T[1] != a && T[2] != a) continue;
        double best = INFINITY;
        int bj = 0;
        for (int j = 0; j < P->ntri; j++) {
            const int32_t *U = P->tri[j];
            double d2 =
                vm__point_triangle_dist2(C->sp[s], pt(C, U[0]), pt(C, U[1]), pt(C, U[2]));
            if (d2 < best) best = d2, bj = j;
        }
        memcpy(T, P->tri[bj], 3 * sizeof *T);
        for (int j = 0; j < 3; j++)
            if (!push(&C->vs[T[j]], s)) C->nomem = 1;
    }
    ls->n = 0;
    /* prune the lists of the new star's vertices: entries that no longer name them, and
     * repeats */
    for (int j = 0; j < P->ntri; j++)
        for (int r = 0; r < 3; r++) {
            int32_t v = P->tri[j][r];
            ilist *lv = &C->vs[v];
            if (++C->stamp == INT32_MAX) {
                memset(C->mark, 0, C->ns * sizeof *C->mark);
                C->stamp = 1;
            }
            int32_t n = 0;
            for (int32_t i = 0; i < lv->n; i++) {
                int32_t q = lv->v[i];
                const int32_t *T = C->st[q];
                if ((T[0] != v && T[1] != v && T[2] != v) || C->mark[q] == C->stamp) continue;
                C->mark[q] = C->stamp;
                lv->v[n++] = q;
            }
            lv->n = n;
        }
}

/* Isosurface samples: the crossings of the voxel edges (linear along an edge), each near
 * the boundary triangle of its nearest boundary vertex's star; grid of boundary vertices
 * with cells of `cell` world units. */
static vm_status samples(co *C, vm_error *err) {
    const gr_field *f = C->f;
    size_t cap = 1024, n = 0;
    double(*sp)[3] = malloc(cap * sizeof *sp);
    if (!sp) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    for (int64_t k = 0; k < f->n[2]; k++)
        for (int64_t j = 0; j < f->n[1]; j++)
            for (int64_t i = 0; i < f->n[0]; i++) {
                double a = vm__gr_phi_point(f, i, j, k);
                for (int d = 0; d < 3; d++) {
                    int64_t q[3] = {i, j, k};
                    if (++q[d] >= f->n[d]) continue;
                    double b = vm__gr_phi_point(f, q[0], q[1], q[2]);
                    if ((a >= 0) == (b >= 0)) continue;
                    if (n == cap) {
                        double(*ns)[3] = realloc(sp, 2 * cap * sizeof *ns);
                        if (!ns) {
                            free(sp);
                            return vm_error_set(err, VM_ERR_NOMEM,
                                                "mesh: out of memory for coarsening");
                        }
                        sp = ns;
                        cap *= 2;
                    }
                    double ijk[3] = {(double)i, (double)j, (double)k};
                    ijk[d] += a / (a - b);
                    vm_volume_index_to_world(f->v, ijk, sp[n++]);
                }
            }
    C->sp = sp;
    C->ns = n;
    return VM_OK;
}

/* Sorts by key (ascending), ties by index: deterministic. */
typedef struct keyed {
    double key;
    int32_t a, b;
} keyed;
static int keyed_cmp(const void *x, const void *y) {
    const keyed *p = x, *q = y;
    if (p->key != q->key) return p->key < q->key ? -1 : 1;
    if (p->a != q->a) return p->a < q->a ? -1 : 1;
    return (p->b > q->b) - (p->b < q->b);
}

/* Sorts e[0..n) by keyed_cmp: a bottom-up merge sort through tmp (n entries), kept by the
 * caller across passes (qsort's own buffer would be a fresh block each time). */
static void keyed_sort(keyed *e, keyed *tmp, size_t n) {
    keyed *src = e, *dst = tmp;
    for (size_t w = 1; w < n; w *= 2) {
        for (size_t lo = 0; lo < n; lo += 2 * w) {
            size_t mid = lo + w < n ? lo + w : n, hi = lo + 2 * w < n ? lo + 2 * w : n;
            size_t i = lo, j = mid, k = lo;
            while (i < mid && j < hi)
                dst[k++] = keyed_cmp(&src[j], &src[i]) < 0 ? src[j++] : src[i++];
            while (i < mid)
                dst[k++] = src[i++];
            while (j < hi)
                dst[k++] = src[j++];
        }
        keyed *q = src;
        src = dst;
        dst = q;
    }
    if (src != e) memcpy(e, src, n * sizeof *e);
}

/* A failed edge of the last pass and `applied` when it failed. */
typedef struct memo {
    keyed e;
    uint32_t when;
    unsigned char late; /* 1: the check of x onto y failed late, 2: of y onto x */
} memo;

/* The nearest boundary vertex of each sample, by a grid of the boundary vertices; each
 * sample takes the nearest triangle of that vertex's star and keeps max(D, its distance). */
/* The boundary faces around vertex v: the nearest to x, if nearer than *bt (squared), into
 * T and *bt. */
static void nearest_face(const co *C, const double *x, int32_t v, int32_t T[3], double *bt) {
    const ilist *l = &C->vt[v];
    for (int32_t j = 0; j < l->n; j++) {
        const vm_index *c = tet(C, l->v[j]);
        for (int k = 0; k < 4; k++) {
            if (c[k] == v || !face_free(C, l->v[j], k)) continue;
            int64_t a = c[(k + 1) & 3], b = c[(k + 2) & 3], d = c[(k + 3) & 3];
            double d2 = vm__point_triangle_dist2(x, pt(C, a), pt(C, b), pt(C, d));
            if (d2 < *bt) *bt = d2, T[0] = (int32_t)a, T[1] = (int32_t)b, T[2] = (int32_t)d;
        }
    }
}

static vm_status assign_samples(co *C, vm_error *err) {
    size_t nb = 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t v = 0; v < C->nv; v++)
        if (C->bnd[v]) {
            nb++;
            for (int d = 0; d < 3; d++) {
                lo[d] = fmin(lo[d], pt(C, (int64_t)v)[d]);
                hi[d] = fmax(hi[d], pt(C, (int64_t)v)[d]);
            }
        }
    C->tol = malloc((C->ns + 1) * sizeof *C->tol);
    C->st = malloc((C->ns + 1) * sizeof *C->st);
    C->mark = calloc(C->ns + 1, sizeof *C->mark);
    if (!C->tol || !C->st || !C->mark)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    if (!nb) return VM_OK;
    double cell = 4 * C->voxel;
    int64_t g[3];
    size_t cells = 1;
    for (int d = 0; d < 3; d++) {
        g[d] = (int64_t)((hi[d] - lo[d]) / cell) + 1;
        cells *= (size_t)g[d];
    }
    size_t *start = calloc(cells + 1, sizeof *start);
    int32_t *item = malloc(nb * sizeof *item);
    if (!start || !item) {
        free(start);
        free(item);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    }
#define CELL_OF(p, c3)                                                                      \
    for (int d_ = 0; d_ < 3; d_++) {                                                        \
        int64_t q_ = (int64_t)floor(((p)[d_] - lo[d_]) / cell);                             \
        (c3)[d_] = q_ < 0 ? 0 : q_ >= g[d_] ? g[d_] - 1 : q_;                               \
    }
    for (size_t v = 0; v < C->nv; v++)
        if (C->bnd[v]) {
            int64_t c3[3];
            CELL_OF(pt(C, (int64_t)v), c3);
            start[(size_t)(c3[0] + g[0] * (c3[1] + g[1] * c3[2])) + 1]++;
        }
    for (size_t i = 0; i < cells; i++)
        start[i + 1] += start[i];
    for (size_t v = 0; v < C->nv; v++)
        if (C->bnd[v]) {
            int64_t c3[3];
            CELL_OF(pt(C, (int64_t)v), c3);
            item[start[(size_t)(c3[0] + g[0] * (c3[1] + g[1] * c3[2]))]++] = (int32_t)v;
        }
    for (size_t i = cells; i > 0; i--)
        start[i] = start[i - 1];
    start[0] = 0;
    vm_status s = VM_OK;
    for (size_t i = 0; i < C->ns && !s; i++) {
        int64_t c3[3];
        CELL_OF(C->sp[i], c3);
        double best = INFINITY;
        int32_t bv = -1;
        for (int r = 1; bv < 0 || r < 2; r++) { /* rings until found, and one more */
            for (int64_t z = c3[2] - r; z <= c3[2] + r; z++)
                for (int64_t y = c3[1] - r; y <= c3[1] + r; y++)
                    for (int64_t x = c3[0] - r; x <= c3[0] + r; x++) {
                        if (x < 0 || y < 0 || z < 0 || x >= g[0] || y >= g[1] || z >= g[2])
                            continue;
                        size_t at = (size_t)(x + g[0] * (y + g[1] * z));
                        for (size_t k = start[at]; k < start[at + 1]; k++) {
                            double d2 = dist2(C->sp[i], pt(C, item[k]));
                            if (d2 < best) best = d2, bv = item[k];
                        }
                    }
            if (r > g[0] + g[1] + g[2]) break;
        }
        /* the nearest triangle of its star */
        double bt = INFINITY;
        int32_t T[3] = {bv, bv, bv};
        nearest_face(C, C->sp[i], bv, T, &bt);
        /* Over the bound: the nearest vertex's star may miss the nearest triangle (across a
         * thin wall the nearest vertex can be on the other side), and the sample's own bound
         * would then be that farther triangle's distance: so the stars of every boundary
         * vertex within that distance and a cell count too. */
        if (sqrt(bt) > C->D) {
            int rr = (int)ceil(sqrt(bt) / cell) + 1;
            for (int64_t z = c3[2] - rr; z <= c3[2] + rr; z++)
                for (int64_t y = c3[1] - rr; y <= c3[1] + rr; y++)
                    for (int64_t x = c3[0] - rr; x <= c3[0] + rr; x++) {
                        if (x < 0 || y < 0 || z < 0 || x >= g[0] || y >= g[1] || z >= g[2])
                            continue;
                        size_t at = (size_t)(x + g[0] * (y + g[1] * z));
                        for (size_t k = start[at]; k < start[at + 1]; k++)
                            nearest_face(C, C->sp[i], item[k], T, &bt);
                    }
        }
        C->tol[i] = fmax(C->D, sqrt(bt)) * (1 + 1e-9);
        memcpy(C->st[i], T, sizeof T);
        for (int j = 0; j < 3 && !s; j++)
            if (!push(&C->vs[T[j]], (int32_t)i))
                s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    }
#undef CELL_OF
    free(start);
    free(item);
    return s;
}

static void co_free(co *C) {
    for (size_t v = 0; C->vt && v < C->nv; v++)
        free(C->vt[v].v);
    for (size_t v = 0; C->vs && v < C->nv; v++)
        free(C->vs[v].v);
    free(C->vt);
    free(C->vs);
    free(C->bnd);
    free(C->fix);
    free(C->dead_v);
    free(C->dead_t);
    free(C->free_faces);
    free(C->sp);
    free(C->tol);
    free(C->st);
    free(C->mark);
    free(C->w.vmark);
    free(C->qlo);
    free(C->qhi);
    free(C->qab);
    free(C->flipless);
    free(C->star);
    free(C->near);
}

/* Removes dead tets and unused points. */
static vm_status compact(co *C, vm_error *err) {
    vm_mesh *m = C->m;
    int64_t *map = malloc((C->nv + 1) * sizeof *map);
    if (!map) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    for (size_t v = 0; v < C->nv; v++)
        map[v] = -1;
    size_t nt = 0, np = 0;
    for (size_t t = 0; t < C->nt; t++) {
        if (C->dead_t[t]) continue;
        memmove(m->cells + 4 * nt, m->cells + 4 * t, 4 * sizeof *m->cells);
        m->region[nt] = m->region[t];
        nt++;
    }
    for (size_t i = 0; i < 4 * nt; i++)
        if (map[m->cells[i]] < 0) map[m->cells[i]] = 0;
    for (size_t v = 0; v < C->nv; v++)
        if (map[v] == 0) {
            map[v] = (int64_t)np;
            memmove(m->points + 3 * np, m->points + 3 * v, 3 * sizeof *m->points);
            np++;
        }
    for (size_t i = 0; i < 4 * nt; i++)
        m->cells[i] = (vm_index)map[m->cells[i]];
    m->ncells = nt;
    m->npoints = np;
    free(map);
    return VM_OK;
}

/* The place of vertex u, where vertex v is at x. */
static const double *pt_at(const co *C, int64_t u, int32_t v, const double *x) {
    return u == v ? x : pt(C, u);
}

/* Whether a change of volume dv keeps the net volume budget. */
static int budget_ok(const co *C, double dv) {
    return !(C->dvol + dv < -C->vol_budget || C->dvol + dv > C->vol_gain);
}

/* Whether vertex v may move to x: every condition of a collapse holds for its tets
 * (positive, the angle rule, the distance both ways for its boundary faces and their
 * samples, and with `budget` the net volume budget); with `better`, only when the worst min
 * dihedral around v grows. [out] *dv, the change of volume; P, v's boundary triangles. It
 * reads the mesh only (the move sweeps check vertices of one colour on threads). */
static int move_holds(const co *C, int32_t v, const double x[3], int better, int budget,
                      plan *P, double *dv) {
    const ilist *l = &C->vt[v];
    double olo = 180, ohi = 0, vol0 = 0, vol1 = 0;
    double osum = 0, nsum = 0; /* the star's smallest dihedral angles, summed */
    double oedge = 0, nedge = 0; /* the star's longest edge at v, squared, before and after */
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        const vm_index *c = tet(C, t);
        olo = fmin(olo, C->qlo[t]);
        ohi = fmax(ohi, C->qhi[t]);
        osum += C->qlo[t];
        for (int k = 0; k < 4; k++)
            if (c[k] != v) oedge = fmax(oedge, dist2(pt(C, c[k]), pt(C, v)));
        vol0 += C->sign * vol6(pt(C, c[0]), pt(C, c[1]), pt(C, c[2]), pt(C, c[3]));
    }
    int ok = 1;
    /* the worst angles each moved tet must keep, tested per tet (one past them rules the
     * move out without measuring the rest): within the targets or no worse than the star's
     * worst; better 1: above that worst, 2 and 3: no lower than it. And whether a tet may
     * fail ABAQUS's check (-1: not known yet) */
    double lo_min = fmin(GR_CO_MIN, olo), hi_max = fmax(GR_CO_MAX, ohi);
    if (better >= 2) lo_min = fmax(lo_min, olo);
    int may_fail = -1;
    for (int32_t i = 0; i < l->n && ok; i++) {
        const vm_index *c = tet(C, l->v[i]);
        double p[4][3], lo, hi;
        for (int k = 0; k < 4; k++)
            memcpy(p[k], pt_at(C, c[k], v, x), sizeof p[k]);
        double v6 = C->sign * vol6(p[0], p[1], p[2], p[3]);
        if (v6 <= 0) {
            ok = 0;
            break;
        }
        vol1 += v6;
        for (int k = 0; k < 4 && ok; k++)
            if (c[k] != v) {
                if (!edge_ok(C, p[k], x)) ok = 0;
                nedge = fmax(nedge, dist2(p[k], x));
            }
        if (!ok) break;
        double cmax, cmin;
        if (!dihedral_cosines((const double(*)[3])p, &cmax, &cmin)) {
            ok = 0;
            break;
        }
        lo = acos(cmax) * GR_CO_DEG;
        hi = acos(cmin) * GR_CO_DEG;
        if (lo < lo_min || hi > hi_max || (better == 1 && !(lo > olo + 0.01))) {
            ok = 0;
            break;
        }
        if (!abaqus_ok((const double(*)[3])p)) {
            /* (the star's cached grades are those of v's place) */
            if (may_fail < 0) may_fail = star_fails_abaqus(C, v);
            if (!may_fail) {
                ok = 0;
                break;
            }
        }
        nsum += lo;
    }
    /* (2: the mean sweep, the sum of the smallest angles up, the worst no lower (above)) */
    if (ok && better == 2 && !(nsum > osum + GR_CO_MEAN_GAIN * l->n)) ok = 0;
    /* (3: the same after the quality pass, where the size bounds are not known here: the
     * star's longest edge does not grow either) */
    if (ok && better == 3 && !(nsum > osum + GR_CO_MEAN_GAIN * l->n && nedge <= oedge)) ok = 0;
    *dv = (vol1 - vol0) / 6;
    if (ok && budget && !budget_ok(C, *dv)) ok = 0;
    P->ntri = 0;
    if (ok && C->bnd[v]) {
        for (int32_t i = 0; i < l->n && ok; i++) {
            int32_t t = l->v[i];
            const vm_index *c = tet(C, t);
            for (int k = 0; k < 4 && ok; k++) {
                if (c[k] == v || !face_free(C, t, k)) continue;
                double n[3];
                const double *q[3];
                for (int j = 0; j < 3; j++)
                    q[j] = pt_at(C, c[(k + 1 + j) & 3], v, x);
                out_normal(q[0], q[1], q[2], pt_at(C, c[k], v, x), n);
                if (!tri_near(C, q[0], q[1], q[2], n) || P->ntri == SET_MAX) {
                    ok = 0;
                    break;
                }
                int32_t *T = P->tri[P->ntri++];
                for (int j = 0; j < 3; j++)
                    T[j] = (int32_t)c[(k + 1 + j) & 3];
            }
        }
        const ilist *ls = &C->vs[v];
        for (int32_t i = 0; i < ls->n && ok; i++) {
            int32_t q = ls->v[i];
            const int32_t *T = C->st[q];
            if (T[0] != v && T[1] != v && T[2] != v) continue;
            double best = INFINITY, t2 = C->tol[q] * C->tol[q];
            for (int j = 0; j < P->ntri && best > t2; j++) {
                const int32_t *U = P->tri[j];
                double d2 = vm__point_triangle_dist2(
                    C->sp[q], pt_at(C, U[0], v, x), pt_at(C, U[1], v, x), pt_at(C, U[2], v, x));
                if (d2 < best) best = d2;
            }
            if (best > t2) ok = 0;
        }
    }
    return ok;
}

/* Moves vertex v to x, a change of volume dv (move_holds said it may). */
static void move_to(co *C, int32_t v, const double x[3], double dv) {
    const ilist *l = &C->vt[v];
    memcpy(C->m->points + 3 * (size_t)v, x, 3 * sizeof *x);
    for (int32_t i = 0; i < l->n; i++)
        measure(C, l->v[i]);
    C->dvol += dv;
    mark_around(C, v);
}

/* Moves vertex v to x when move_holds, with the budget, says it may. */
static int try_move(co *C, int32_t v, const double x[3], int better, plan *P) {
    double dv;
    if (!move_holds(C, v, x, better, 1, P, &dv)) return 0;
    move_to(C, v, x, dv);
    return 1;
}

/* The mean of vertex v's neighbours, each once per tet that holds both (a boundary vertex:
 * the other corners of its boundary faces) into m; how many were summed. */
static int neighbour_mean(const co *C, int32_t v, double m[3]) {
    const ilist *l = &C->vt[v];
    double s[3] = {0, 0, 0};
    int n = 0;
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        const vm_index *c = tet(C, t);
        for (int k = 0; k < 4; k++) {
            if (c[k] == (vm_index)v) continue;
            if (C->bnd[v]) {
                int on = 0;
                for (int f = 0; f < 4 && !on; f++)
                    on = f != k && c[f] != (vm_index)v && face_free(C, t, f);
                if (!on) continue;
            }
            for (int d = 0; d < 3; d++)
                s[d] += pt(C, c[k])[d];
            n++;
        }
    }
    for (int d = 0; d < 3 && n; d++)
        m[d] = s[d] / n;
    return n;
}

/* The places a move sweep tries for vertex v, in order, into x (how many: 0 to 2), and
 * `better` for try_move: a boundary vertex goes along its outward normal by the middle of
 * the signed distance range of its faces (so that chords of a convex surface straddle it
 * instead of lying inside: the same bound then holds with longer edges, and the volume comes
 * back), then half as far; an interior vertex goes to the mean of its neighbours when that
 * raises its worst angle. */
static int move_tries(const co *C, int32_t v, double x[][3], int *better) {
    const ilist *l = &C->vt[v];
    if (!C->bnd[v]) {
        neighbour_mean(C, v, x[0]);
        *better = 1;
        return 1;
    }
    *better = 0;
    double lo = INFINITY, hi = -INFINITY, phi, g[3];
    int ok = phi_grad(C, pt(C, v), &phi, g);
    for (int32_t i = 0; i < l->n && ok; i++) {
        int32_t t = l->v[i];
        const vm_index *c = tet(C, t);
        for (int k = 0; k < 4 && ok; k++) {
            if (c[k] == v || !face_free(C, t, k)) continue;
            double n[3], a, b;
            face_out(C, c, k, n);
            ok = tri_errors(C, pt(C, c[(k + 1) & 3]), pt(C, c[(k + 2) & 3]),
                            pt(C, c[(k + 3) & 3]), n, INFINITY, &a, &b);
            lo = fmin(lo, a);
            hi = fmax(hi, b);
        }
    }
    double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (!ok || !(gn > 0) || !(hi > lo)) return 0;
    /* e > 0 inside: moving outward (along -grad) by s lowers e by about s */
    double step = 0.5 * (lo + hi);
    if (step > 0.5 * C->D) step = 0.5 * C->D;
    if (step < -0.5 * C->D) step = -0.5 * C->D;
    if (fabs(step) < 0.02 * C->D) return 0;
    for (int k = 0; k < 2; k++, step *= 0.5)
        for (int d = 0; d < 3; d++)
            x[k][d] = pt(C, v)[d] - step * g[d] / gn;
    return 2;
}

/* The most places a sweep tries for one vertex (mean_tries). */
enum { GR_CO_TRIES = 9 };

/* A sweep's vertex, checked on a thread: its tries, the first that held without the volume
 * budget (-1: none) and its change of volume. */
typedef struct move_plan {
    double x[GR_CO_TRIES][3], dv;
    int n, held, better;
} move_plan;

/* What a sweep tries at each vertex: move_tries, or (mean) mean_tries with better; which
 * vertices: with interior_only, none on the boundary (colour). */
typedef struct sweep_kind {
    int mean, interior_only, better;
} sweep_kind;

static int mean_tries(const co *C, int32_t v, int better, double x[][3], int *better_out);

static int sweep_tries(const co *C, int32_t v, const sweep_kind *K, double x[][3],
                       int *better) {
    if (K->mean) return mean_tries(C, v, K->better, x, better);
    return move_tries(C, v, x, better);
}

/* GR_CO_CHUNK: the vertices of a colour checked at a time (the plans' memory) */
enum { GR_CO_COLOURS = 64, GR_CO_UNCOLOURED = 255, GR_CO_CHUNK = 16384 };

/* Colours the vertices that a sweep moves (live, off the border planes, in tets; with
 * interior_only, not on the boundary), no two neighbours alike: each gets the lowest colour
 * below GR_CO_COLOURS that its neighbours before it leave free (GR_CO_COLOURS itself where
 * they take all); the others get GR_CO_UNCOLOURED. */
static void colour(const co *C, int interior_only, unsigned char *col) {
    memset(col, GR_CO_UNCOLOURED, C->nv);
    for (size_t vv = 0; vv < C->nv; vv++) {
        int32_t v = (int32_t)vv;
        if (C->dead_v[v] || C->fix[v] || C->vt[v].n == 0 || (interior_only && C->bnd[v]))
            continue;
        const ilist *l = &C->vt[v];
        uint64_t used = 0;
        for (int32_t i = 0; i < l->n; i++) {
            const vm_index *c = tet(C, l->v[i]);
            for (int k = 0; k < 4; k++)
                if (col[c[k]] < GR_CO_COLOURS) used |= (uint64_t)1 << col[c[k]];
        }
        int k = 0;
        while (k < GR_CO_COLOURS && (used >> k & 1))
            k++;
        col[v] = (unsigned char)k;
    }
}

/* The threads the sweeps may use. */
static int co_threads(void) {
#ifdef VM_HAVE_OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

/* One sweep of moves (sweep_tries), colour by colour: the vertices of one colour share no
 * tet, so each is checked against the mesh as its colour began, on threads (GR_CO_CHUNK at a
 * time: the moves of one colour change nothing another's check reads), and moved in
 * order when its check held and the volume budget still does (else the tries after it are
 * made in order); the last colour's vertices one by one. The same moves on any number of
 * threads. [out] moved. */
static size_t colour_sweep(co *C, const sweep_kind *K, int nthreads) {
    size_t moved = 0, nv = C->nv;
    unsigned char *col = malloc(nv + 1);
    int32_t *ord = malloc(nv * sizeof *ord + 1);
    plan *TP = malloc((size_t)nthreads * sizeof *TP);
    size_t start[GR_CO_COLOURS + 2] = {0};
    move_plan *M = NULL;
    if (col && ord && TP) {
        colour(C, K->interior_only, col);
        for (size_t v = 0; v < nv; v++)
            if (col[v] != GR_CO_UNCOLOURED) start[col[v] + 1]++;
        size_t most = 0;
        for (int k = 0; k <= GR_CO_COLOURS; k++) {
            if (start[k + 1] > most) most = start[k + 1];
            start[k + 1] += start[k];
        }
        size_t fill[GR_CO_COLOURS + 1];
        memcpy(fill, start, sizeof fill);
        for (size_t v = 0; v < nv; v++)
            if (col[v] != GR_CO_UNCOLOURED) ord[fill[col[v]]++] = (int32_t)v;
        M = malloc((most < GR_CO_CHUNK ? most : GR_CO_CHUNK) * sizeof *M + 1);
    }
    if (!M) {
        C->nomem = 1;
        free(col);
        free(ord);
        free(TP);
        return 0;
    }
    for (int k = 0; k <= GR_CO_COLOURS && !C->stop; k++)
        for (size_t i0 = start[k]; i0 < start[k + 1] && !C->stop; i0 += GR_CO_CHUNK) {
            size_t n = start[k + 1] - i0 < GR_CO_CHUNK ? start[k + 1] - i0 : GR_CO_CHUNK;
            if (k < GR_CO_COLOURS) {
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for num_threads(nthreads) schedule(dynamic, 16)
#endif
                for (long long i = 0; i < (long long)n; i++) {
                    int t = 0;
#ifdef VM_HAVE_OPENMP
                    t = omp_get_thread_num();
#endif
                    move_plan *q = &M[i];
                    int32_t v = ord[i0 + (size_t)i];
                    q->n = sweep_tries(C, v, K, q->x, &q->better);
                    q->held = -1;
                    for (int j = 0; j < q->n && q->held < 0; j++)
                        if (move_holds(C, v, q->x[j], q->better, 0, &TP[t], &q->dv))
                            q->held = j;
                }
            }
            for (size_t i = 0; i < n && !stopped(C); i++) {
                int32_t v = ord[i0 + i];
                move_plan *q = &M[i];
                int from = 0;
                if (k < GR_CO_COLOURS) {
                    if (q->held < 0) continue;
                    if (budget_ok(C, q->dv)) {
                        move_to(C, v, q->x[q->held], q->dv);
                        moved++;
                        continue;
                    }
                    from = q->held + 1;
                } else
                    q->n = sweep_tries(C, v, K, q->x, &q->better);
                for (int j = from; j < q->n; j++)
                    if (try_move(C, v, q->x[j], q->better, &TP[0])) {
                        moved++;
                        break;
                    }
            }
        }
    (void)nthreads;
    free(col);
    free(ord);
    free(TP);
    free(M);
    return moved;
}

/* Whether triangle T is one of the two faces f (the same ids in any order). */
static int on_faces(const int32_t T[3], int32_t (*f)[3]) {
    for (int g = 0; g < 2; g++) {
        int m = 0;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                m += T[a] == f[g][b];
        if (m == 3) return 1;
    }
    return 0;
}

/* Whether the samples in list ls whose triangle is one of the two faces of lie within their
 * bound of one of the two triangles nf (a peel's or a boundary flip's new faces). */
static int samples_near(const co *C, const ilist *ls, int32_t (*of)[3], int32_t (*nf)[3]) {
    for (int32_t i = 0; i < ls->n; i++) {
        int32_t q = ls->v[i];
        if (!on_faces(C->st[q], of)) continue;
        double best = INFINITY;
        for (int g = 0; g < 2; g++)
            best = fmin(best, vm__point_triangle_dist2(C->sp[q], pt(C, nf[g][0]),
                                                       pt(C, nf[g][1]), pt(C, nf[g][2])));
        if (best > C->tol[q] * C->tol[q]) return 0;
    }
    return 1;
}

/* The samples in list ls whose triangle is one of the two faces of go to the nearer of the
 * two triangles nf (and onto their corners' lists). */
static void samples_move(co *C, const ilist *ls, int32_t (*of)[3], int32_t (*nf)[3]) {
    for (int32_t i = 0; i < ls->n; i++) {
        int32_t q = ls->v[i];
        int32_t *T = C->st[q];
        if (!on_faces(T, of)) continue;
        double d0 = vm__point_triangle_dist2(C->sp[q], pt(C, nf[0][0]), pt(C, nf[0][1]),
                                             pt(C, nf[0][2]));
        double d1 = vm__point_triangle_dist2(C->sp[q], pt(C, nf[1][0]), pt(C, nf[1][1]),
                                             pt(C, nf[1][2]));
        memcpy(T, nf[d1 < d0], 3 * sizeof *T);
        for (int j = 0; j < 3; j++)
            if (!push(&C->vs[T[j]], q)) C->nomem = 1;
    }
}

/* Takes out tet t when two of its faces are on the boundary (a flat cap), the edge between
 * its two other corners is not on the boundary yet (so the boundary stays a manifold), its
 * two other faces lie within the distance bound facing out, the samples of the two faces it
 * drops stay near the new ones, and the volume budget allows. */
static int peel(co *C, int32_t t) {
    const vm_index *c = tet(C, t);
    int nb = 0, kb[4];
    for (int k = 0; k < 4; k++)
        if (face_free(C, t, k)) kb[nb++] = k;
    if (nb != 2) return 0;
    for (int k = 0; k < 4; k++)
        if (!C->bnd[c[k]] || C->fix[c[k]]) return 0;
    /* the corners opposite the boundary faces: their edge becomes a boundary edge */
    int32_t x = (int32_t)c[kb[0]], y = (int32_t)c[kb[1]];
    const ilist *lx = &C->vt[x];
    for (int32_t i = 0; i < lx->n; i++) {
        int32_t u = lx->v[i];
        if (u == t) continue;
        const vm_index *q = tet(C, u);
        int hy = q[0] == y || q[1] == y || q[2] == y || q[3] == y;
        if (!hy) continue;
        for (int k = 0; k < 4; k++)
            if (q[k] != x && q[k] != y && face_free(C, u, k)) return 0;
    }
    double v6 = C->sign * vol6(pt(C, c[0]), pt(C, c[1]), pt(C, c[2]), pt(C, c[3]));
    if (C->dvol - v6 / 6 < -C->vol_budget) return 0;
    int32_t nf[2][3], of[2][3];
    int n = 0, o = 0;
    for (int k = 0; k < 4; k++) {
        int32_t *F = (k == kb[0] || k == kb[1]) ? of[o++] : nf[n++];
        for (int j = 0; j < 3; j++)
            F[j] = (int32_t)c[(k + 1 + j) & 3];
        if (k == kb[0] || k == kb[1]) continue;
        double nn[3];
        face_out(C, c, k, nn);
        for (int d = 0; d < 3; d++)
            nn[d] = -nn[d]; /* the new boundary faces out where t was */
        if (!tri_near(C, pt(C, F[0]), pt(C, F[1]), pt(C, F[2]), nn)) return 0;
    }
    /* samples on the dropped faces */
    for (int f = 0; f < 2; f++)
        for (int r = 0; r < 3; r++)
            if (!samples_near(C, &C->vs[of[f][r]], of, nf)) return 0;
    /* apply */
    for (int f = 0; f < 2; f++)
        for (int r = 0; r < 3; r++)
            samples_move(C, &C->vs[of[f][r]], of, nf);
    for (int k = 0; k < 4; k++)
        drop(&C->vt[c[k]], t);
    C->dead_t[t] = 1;
    C->live--;
    C->dvol -= v6 / 6;
    C->applied++;
    for (int k = 0; k < 4; k++) { /* t's neighbours across its faces hold 3 of its corners */
        refresh_star(C, (int32_t)c[k], 0);
        mark_vertex(C, (int32_t)c[k]);
    }
    return 1;
}

/* A tet's standing against the targets 15..150 degrees: 1 at a limit, higher is better. */
static double grade(double lo, double hi) {
    return fmin(lo / 15.0, (180.0 - hi) / 30.0);
}

/* The cosines ([out] *ca, *cb) that a tet's smallest and largest dihedral angles are past
 * (its largest cosine above ca, or its smallest below cb) only when its grade is surely at or
 * below bar: the angles 15 bar and 180 - 30 bar, with a margin for round-off (2 and -2: never).
 */
static void bar_cosines(double bar, double *ca, double *cb) {
    double a = 15 * bar, b = 180 - 30 * bar;
    *ca = a > 0 && a < 180 ? cos(a / GR_CO_DEG) + 1e-9 : 2;
    *cb = b > 0 && b < 180 ? cos(b / GR_CO_DEG) - 1e-9 : -2;
}

/* The grade of the tet (a, b, c, d) as positioned, or -1 when it is not positive; bar when
 * its dihedral cosines are past ca or cb (bar_cosines: the grade is then at or below bar, and
 * the arc cosines and ABAQUS's measures are not needed). */
static double grade_cut(const co *C, const double *a, const double *b, const double *c,
                        const double *d, double bar, double ca, double cb) {
    if (!(C->sign * vol6(a, b, c, d) > 0)) return -1;
    double p[4][3], cmax, cmin;
    memcpy(p[0], a, sizeof p[0]);
    memcpy(p[1], b, sizeof p[1]);
    memcpy(p[2], c, sizeof p[2]);
    memcpy(p[3], d, sizeof p[3]);
    if (!dihedral_cosines((const double(*)[3])p, &cmax, &cmin))
        return -1; /* (as tet_angles: a degenerate tet) */
    if (cmax > ca || cmin < cb) return bar;
    double lo, hi, ab = tet_angles_of((const double(*)[3])p, cmax, cmin, &lo, &hi);
    return fmin(grade(lo, hi), ab);
}

/* The grade of the tet (a, b, c, d) as positioned, or -1 when it is not positive. */
static double grade_of(const co *C, const double *a, const double *b, const double *c,
                       const double *d) {
    return grade_cut(C, a, b, c, d, 0, 2, -2);
}

/* The grade of live tet t, from the caches. */
static double tet_grade(const co *C, int32_t t) {
    return fmin(grade(C->qlo[t], C->qhi[t]), C->qab[t]);
}

/* Whether a live tet other than those in `skip` holds all of the n vertices w. */
static int held(const co *C, const int32_t *w, int n, const int32_t *skip, int nskip) {
    const ilist *l = &C->vt[w[0]];
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i];
        int other = 1;
        for (int j = 0; j < nskip; j++)
            if (skip[j] == t) other = 0;
        if (!other) continue;
        const vm_index *c = tet(C, t);
        int all = 1;
        for (int j = 1; j < n && all; j++)
            all = c[0] == w[j] || c[1] == w[j] || c[2] == w[j] || c[3] == w[j];
        if (all) return 1;
    }
    return 0;
}

/* k dead tet slots for a flip's new tets, the first dead ones from C->slot on (dead tets
 * below it are all reused), the tet arrays grown when there are too few: slot[0..k) are
 * then live, of region `region`. 0 on out-of-memory. */
static int take_slots(co *C, int k, int32_t region, int32_t *slot) {
    size_t at = C->slot;
    int got = 0;
    while (got < k) {
        while (at < C->nt && !C->dead_t[at])
            at++;
        if (at < C->nt) {
            slot[got++] = (int32_t)at++;
            continue;
        }
        size_t nt = C->nt + (size_t)k + C->nt / 8 + 16;
        vm_error e;
        if (nt >= (size_t)INT32_MAX || vm_mesh_reserve(C->m, C->m->npoints, nt, &e)) {
            C->nomem = 1;
            return 0;
        }
        unsigned char *dt = realloc(C->dead_t, nt),
                      *ff = dt ? realloc(C->free_faces, nt) : NULL;
        if (dt) C->dead_t = dt;
        if (ff) C->free_faces = ff;
        float *q[3] = {C->qlo, C->qhi, C->qab};
        uint32_t *fl = realloc(C->flipless, nt * sizeof *fl);
        if (fl) C->flipless = fl;
        int ok = dt && ff && fl;
        for (int i = 0; i < 3 && ok; i++) {
            float *n = realloc(q[i], nt * sizeof *n);
            if (!n)
                ok = 0;
            else
                q[i] = n;
        }
        C->qlo = q[0];
        C->qhi = q[1];
        C->qab = q[2];
        if (!ok) {
            C->nomem = 1;
            return 0;
        }
        memset(C->dead_t + C->nt, 1, nt - C->nt);
        memset(C->free_faces + C->nt, 0, nt - C->nt);
        memset(C->m->cells + 4 * C->nt, 0, 4 * (nt - C->nt) * sizeof *C->m->cells);
        for (size_t t = C->nt; t < nt; t++) {
            C->qlo[t] = C->qhi[t] = C->qab[t] = 0;
            C->flipless[t] = 0;
            C->m->region[t] = 0;
        }
        C->m->ncells = nt;
        C->nt = nt;
    }
    for (int i = 0; i < k; i++) {
        C->dead_t[slot[i]] = 0;
        C->m->region[slot[i]] = region;
        C->live++;
        C->slot = (size_t)slot[i];
    }
    return 1;
}

/* A flip's change: the nold tets `old` give way to the nnew tets nt (nnew >= 2), put in the
 * slots `slot` (old's first, then those take_slots gave), old's slots past nnew dying. The
 * new tets' outer faces are the old ones' (their neighbours are unchanged). */
static void put_tets(co *C, const int32_t *old, int nold, const int32_t *slot,
                     const int32_t (*nt)[4], int nnew) {
    for (int i = 0; i < nold; i++) {
        const vm_index *c = tet(C, old[i]);
        for (int k = 0; k < 4; k++)
            drop(&C->vt[c[k]], old[i]);
    }
    for (int i = 0; i < nnew; i++) {
        vm_index *c = C->m->cells + 4 * (size_t)slot[i];
        for (int k = 0; k < 4; k++) {
            c[k] = (vm_index)nt[i][k];
            if (!push(&C->vt[nt[i][k]], slot[i])) C->nomem = 1;
        }
        measure(C, slot[i]);
    }
    for (int i = nnew; i < nold; i++) {
        C->dead_t[old[i]] = 1;
        C->live--;
    }
    for (int i = 0; i < nnew; i++)
        refresh_faces(C, slot[i]);
    C->applied++;
}

/* The flip between the triangle abc and the edge de (Joe 1989): the tets `old` (the two on
 * abc, or the three around de) become those on the other side (three around de, or two on
 * abc), when de crosses abc (the tets (a,b,d,e), (b,c,d,e), (c,a,d,e) turn the same way),
 * no tet has the new edge or face yet, the new edge keeps the size bounds, and the new
 * tets' worst grade beats the old ones'. Interior only: the boundary faces stay as they
 * are, and so do the distance and the volume. */
static int flip(co *C, const int32_t *old, int nold, const int32_t abc[3], int32_t d,
                int32_t e) {
    const double *pa = pt(C, abc[0]), *pb = pt(C, abc[1]), *pc = pt(C, abc[2]);
    const double *pd = pt(C, d), *pe = pt(C, e);
    double s1 = vol6(pa, pb, pd, pe), s2 = vol6(pb, pc, pd, pe), s3 = vol6(pc, pa, pd, pe);
    if (!((s1 > 0 && s2 > 0 && s3 > 0) || (s1 < 0 && s2 < 0 && s3 < 0))) return 0;
    for (int i = 1; i < nold; i++)
        if (C->m->region[old[i]] != C->m->region[old[0]]) return 0;
    double before = INFINITY;
    for (int i = 0; i < nold; i++)
        before = fmin(before, tet_grade(C, old[i]));
    int32_t nt[3][4];
    int nnew = nold == 2 ? 3 : 2;
    if (nnew == 3) {
        int32_t de[2] = {d, e};
        if (held(C, de, 2, NULL, 0) || !edge_ok(C, pd, pe)) return 0;
        for (int i = 0; i < 3; i++) {
            int32_t q[4] = {abc[i], abc[(i + 1) % 3], d, e};
            memcpy(nt[i], q, sizeof q);
        }
    } else {
        if (held(C, abc, 3, old, nold)) return 0;
        int32_t q0[4] = {abc[0], abc[1], abc[2], d}, q1[4] = {abc[0], abc[1], abc[2], e};
        memcpy(nt[0], q0, sizeof q0);
        memcpy(nt[1], q1, sizeof q1);
    }
    double after = INFINITY;
    for (int i = 0; i < nnew; i++) {
        if (C->sign * vol6(pt(C, nt[i][0]), pt(C, nt[i][1]), pt(C, nt[i][2]),
                           pt(C, nt[i][3])) < 0) {
            int32_t q = nt[i][0];
            nt[i][0] = nt[i][1];
            nt[i][1] = q;
        }
        after = fmin(after, grade_of(C, pt(C, nt[i][0]), pt(C, nt[i][1]), pt(C, nt[i][2]),
                                     pt(C, nt[i][3])));
        if (!(after > before + 1e-3)) return 0; /* (the rest cannot raise the minimum) */
    }
    int32_t slot[3];
    for (int i = 0; i < nold; i++)
        slot[i] = old[i];
    if (nnew > nold && !take_slots(C, 1, C->m->region[old[0]], slot + nold)) return 0;
    put_tets(C, old, nold, slot, (const int32_t(*)[4])nt, nnew);
    if (nold == 2)
        C->flips23++;
    else
        C->flips32++;
    for (int i = 0; i < 3; i++)
        mark_vertex(C, abc[i]);
    mark_vertex(C, d);
    mark_vertex(C, e);
    return 1;
}

/* Edge removal (Shewchuk, "Two discrete optimization algorithms for the topological
 * improvement of tetrahedral meshes", 2002) takes rings of this many tets at most. */
#define GR_CO_RING 7

/* The tets around edge de as a closed ring (open 0) or an open chain (open 1): ring vertices
 * w[0..nw) and tets ts[i] = (w[i], w[i+1], d, e) (indices mod nw when closed, where nw = n;
 * open, nw = n + 1, the chain running from its lower end w[0] to w[n]: the end faces (d, e,
 * w[0]) and (d, e, w[n]) are then boundary faces, since any tet on them holds de and would be
 * in the chain), every one positive as ordered, d and e swapped where that orders them so.
 * n, or 0 when de's tets are not one such ring of 3..GR_CO_RING tets (closed) or chain of
 * 2..GR_CO_RING - 1 (open). */
static int edge_around(const co *C, int32_t *d, int32_t *e, int32_t *w, int32_t *ts, int open) {
    int32_t old[GR_CO_RING], a[GR_CO_RING], b[GR_CO_RING];
    int n = 0;
    const ilist *l = &C->vt[*d];
    for (int32_t r = 0; r < l->n; r++) {
        const vm_index *q = tet(C, l->v[r]);
        if (q[0] != (vm_index)*e && q[1] != (vm_index)*e && q[2] != (vm_index)*e &&
            q[3] != (vm_index)*e)
            continue;
        if (n == GR_CO_RING - open) return 0;
        int32_t o[2];
        int no = 0;
        for (int k = 0; k < 4; k++)
            if (q[k] != (vm_index)*d && q[k] != (vm_index)*e) o[no++ & 1] = (int32_t)q[k];
        if (no != 2) return 0;
        old[n] = l->v[r];
        a[n] = o[0];
        b[n] = o[1];
        n++;
    }
    if (n < 3 - open) return 0;
    int used[GR_CO_RING] = {0}, i0 = 0;
    if (open) { /* from the lower end: the ends are the ring vertices in one tet each */
        int nend = 0;
        for (int j = 0; j < 2 * n; j++) {
            int32_t x = j & 1 ? b[j / 2] : a[j / 2];
            int cnt = 0;
            for (int k = 0; k < n; k++)
                cnt += (a[k] == x) + (b[k] == x);
            if (cnt > 2) return 0;
            if (cnt == 1 && (nend++ == 0 || x < w[0])) w[0] = x;
        }
        if (nend != 2) return 0;
    } else {
        w[0] = a[0];
        w[1] = b[0];
        ts[0] = old[0];
        used[0] = 1;
        i0 = 1;
    }
    /* each next tet is the one other tet holding the last ring vertex */
    for (int i = i0; i < n; i++) {
        int found = -1;
        for (int j = 0; j < n; j++)
            if (!used[j] && (a[j] == w[i] || b[j] == w[i])) {
                if (found >= 0) return 0;
                found = j;
            }
        if (found < 0) return 0;
        used[found] = 1;
        ts[i] = old[found];
        int32_t next = a[found] == w[i] ? b[found] : a[found];
        if (open || i + 1 < n)
            w[i + 1] = next;
        else if (next != w[0])
            return 0;
    }
    int nw = n + open;
    for (int i = 0; i < nw; i++)
        for (int j = i + 1; j < nw; j++)
            if (w[i] == w[j]) return 0;
    if (C->sign * vol6(pt(C, w[0]), pt(C, w[1]), pt(C, *d), pt(C, *e)) < 0) {
        int32_t q = *d;
        *d = *e;
        *e = q;
    }
    for (int i = 0; i < n; i++)
        if (!(C->sign * vol6(pt(C, w[i]), pt(C, w[(i + 1) % nw]), pt(C, *d), pt(C, *e)) > 0))
            return 0;
    return n;
}

/* The grade of triangle (w[i], w[k], w[j]) (i < k < j in ring order) of an edge removal's
 * ring: the worse of its tets (w[i], w[k], w[j], e) and (w[k], w[i], w[j], d) (the second not
 * measured once the first is at or below bar). */
typedef struct ring_ctx {
    const co *C;
    const int32_t *w;
    int32_t d, e;
    double bar, ca, cb; /* the last bar asked and its bar_cosines */
} ring_ctx;
/* Whether the ring's chord w[i] w[j] may be made: it keeps the size bounds and is no edge
 * yet. */
static int ring_chord(void *user, int i, int j) {
    const ring_ctx *r = user;
    int32_t ij[2] = {r->w[i], r->w[j]};
    return edge_ok(r->C, pt(r->C, ij[0]), pt(r->C, ij[1])) && !held(r->C, ij, 2, NULL, 0);
}
static double ring_grade(void *user, int i, int k, int j, double bar) {
    ring_ctx *r = user;
    const co *C = r->C;
    const double *pi = pt(C, r->w[i]), *pk = pt(C, r->w[k]), *pj = pt(C, r->w[j]);
    if (bar != r->bar) { /* (the programme takes any grade at or below bar as bar) */
        r->bar = bar;
        bar_cosines(bar, &r->ca, &r->cb);
    }
    double g = grade_cut(C, pi, pk, pj, pt(C, r->e), bar, r->ca, r->cb);
    if (!(g > bar)) return g;
    return fmin(g, grade_cut(C, pk, pi, pj, pt(C, r->d), bar, r->ca, r->cb));
}

/* Edge removal: the n = 4..GR_CO_RING tets around interior edge de become the 2n - 4 tets of
 * the ring polygon's triangulation joined to d and to e, the triangulation whose worst tet is
 * best (Klincsek's dynamic programme over the polygon's sub-chains), when that worst beats
 * the ring's worst, every tet is of one region, no new edge exists yet or breaks the size
 * bounds. The ring's outer faces stay: the boundary, the distance and the volume do too (the
 * new tets, positive in the ring's turn, tile what the old ones did). 1 when removed. */
static int edge_remove(co *C, int32_t d, int32_t e) {
    int32_t w[GR_CO_RING], ts[GR_CO_RING];
    int n = edge_around(C, &d, &e, w, ts, 0);
    if (n < 4) return 0;
    double before = INFINITY;
    for (int i = 0; i < n; i++) {
        if (C->m->region[ts[i]] != C->m->region[ts[0]]) return 0;
        before = fmin(before, tet_grade(C, ts[i]));
    }
    ring_ctx rc = {C, w, d, e, NAN, 2, -2};
    int tri[VM__RING_MAX][3];
    if (!(vm__ring_triangulate(n, before + 1e-3, ring_grade, &rc, ring_chord, tri) >
          before + 1e-3))
        return 0;
    int nt = 0;
    int32_t nt4[2 * GR_CO_RING][4];
    for (int r = 0; r < n - 2; r++) {
        int i = tri[r][0], k = tri[r][1], j = tri[r][2];
        int32_t te[4] = {w[i], w[k], w[j], e}, td[4] = {w[k], w[i], w[j], d};
        memcpy(nt4[nt++], te, sizeof te);
        memcpy(nt4[nt++], td, sizeof td);
    }
    /* slots: the ring's, then dead ones past C->slot */
    int32_t slot[2 * GR_CO_RING];
    for (int i = 0; i < n; i++)
        slot[i] = ts[i];
    if (nt > n && !take_slots(C, nt - n, C->m->region[ts[0]], slot + n)) return 0;
    put_tets(C, ts, n, slot, (const int32_t(*)[4])nt4, nt);
    for (int i = 0; i < n; i++)
        mark_vertex(C, w[i]);
    mark_vertex(C, d);
    mark_vertex(C, e);
    C->removals++;
    return 1;
}

/* Boundary edge removal: the m = 2..GR_CO_RING - 1 tets around boundary edge de (an open
 * chain from w[0] to w[m]) become the 2m - 2 tets of the best triangulation of the polygon
 * w[0..m] joined to d and to e, as edge_remove does; the boundary triangles (d, e, w[0]) and
 * (d, e, w[m]) become (w[0], w[m], d) and (w[0], w[m], e), an edge flip of the boundary. It
 * holds every check of a collapse's boundary: the new triangles within the distance bound and
 * facing out (tri_near), the samples of the old ones near the new ones, the volume budget;
 * none of the four corners on a border plane, or all four in one (the flip then keeps the
 * boundary's place, and only the samples are checked), the new edge w[0] w[m] new and within
 * the size bounds, one region, and the ring's worst grade bettered. 1 when removed. */
static int bedge_remove(co *C, int32_t d, int32_t e) {
    if (!C->bnd[d] || !C->bnd[e]) return 0;
    int32_t w[GR_CO_RING], ts[GR_CO_RING];
    int m = edge_around(C, &d, &e, w, ts, 1);
    if (m < 2) return 0;
    int32_t w0 = w[0], wm = w[m];
    /* all four in one border plane: the flip keeps the boundary where it is (the two
     * triangles of a convex quad in the plane trade their diagonal) */
    int flat = (C->fix[d] & C->fix[e] & C->fix[w0] & C->fix[wm]) != 0;
    if (!flat && (C->fix[d] | C->fix[e] | C->fix[w0] | C->fix[wm])) return 0;
    double before = INFINITY, vold = 0;
    for (int i = 0; i < m; i++) {
        if (C->m->region[ts[i]] != C->m->region[ts[0]]) return 0;
        before = fmin(before, tet_grade(C, ts[i]));
        const vm_index *c = tet(C, ts[i]);
        vold += C->sign * vol6(pt(C, c[0]), pt(C, c[1]), pt(C, c[2]), pt(C, c[3]));
    }
    int32_t cd[2] = {w0, wm};
    if (!edge_ok(C, pt(C, w0), pt(C, wm)) || held(C, cd, 2, NULL, 0)) return 0;
    ring_ctx rc = {C, w, d, e, NAN, 2, -2};
    int tri[VM__RING_MAX][3];
    if (!(vm__ring_triangulate(m + 1, before + 1e-3, ring_grade, &rc, ring_chord, tri) >
          before + 1e-3))
        return 0;
    int nt = 0;
    int32_t nt4[2 * GR_CO_RING][4];
    double vnew = 0;
    for (int r = 0; r < m - 1; r++) {
        int i = tri[r][0], k = tri[r][1], j = tri[r][2];
        int32_t te[4] = {w[i], w[k], w[j], e}, td[4] = {w[k], w[i], w[j], d};
        memcpy(nt4[nt++], te, sizeof te);
        memcpy(nt4[nt++], td, sizeof td);
        vnew += C->sign * vol6(pt(C, w[i]), pt(C, w[k]), pt(C, w[j]), pt(C, e));
        vnew += C->sign * vol6(pt(C, w[k]), pt(C, w[i]), pt(C, w[j]), pt(C, d));
    }
    double dv = (vnew - vold) / 6;
    if (C->dvol + dv < -C->vol_budget || C->dvol + dv > C->vol_gain) {
        C->flip_budget = 1; /* (the budget moves with every change anywhere) */
        return 0;
    }
    /* the new boundary triangles, over the whole polygon's triangle (0, k, m) */
    int32_t nf[2][3] = {{w0, wm, d}, {w0, wm, e}}, of[2][3] = {{d, e, w0}, {d, e, wm}};
    const double *pk = pt(C, w[tri[0][1]]);
    for (int f = 0; f < 2 && !flat; f++) {
        double n[3];
        out_normal(pt(C, nf[f][0]), pt(C, nf[f][1]), pt(C, nf[f][2]), pk, n);
        if (!tri_near(C, pt(C, nf[f][0]), pt(C, nf[f][1]), pt(C, nf[f][2]), n)) return 0;
    }
    /* the samples on the old triangles (both hold d) near the new ones */
    if (!samples_near(C, &C->vs[d], of, nf)) return 0;
    int32_t slot[2 * GR_CO_RING];
    for (int i = 0; i < m; i++)
        slot[i] = ts[i];
    if (nt > m && !take_slots(C, nt - m, C->m->region[ts[0]], slot + m)) return 0;
    put_tets(C, ts, m, slot, (const int32_t(*)[4])nt4, nt);
    C->dvol += dv;
    samples_move(C, &C->vs[d], of, nf);
    for (int i = 0; i <= m; i++)
        mark_vertex(C, w[i]);
    mark_vertex(C, d);
    mark_vertex(C, e);
    C->bremovals++;
    return 1;
}

/* Flips that better tet t: across each of its inner faces (two tets to three), and around
 * each of its edges held by exactly three tets in a closed ring (three to two). */
static int flip_tet(co *C, int32_t t) {
    vm_index c[4];
    memcpy(c, tet(C, t), sizeof c);
    for (int k = 0; k < 4; k++) {
        int32_t abc[3] = {(int32_t)c[(k + 1) & 3], (int32_t)c[(k + 2) & 3],
                          (int32_t)c[(k + 3) & 3]};
        const ilist *l = &C->vt[abc[0]];
        for (int32_t i = 0; i < l->n; i++) {
            int32_t u = l->v[i];
            if (u == t) continue;
            const vm_index *q = tet(C, u);
            int has = 0, e = -1;
            for (int j = 0; j < 4; j++) {
                if (q[j] == (vm_index)abc[1] || q[j] == (vm_index)abc[2]) has++;
                else if (q[j] != (vm_index)abc[0]) e = (int32_t)q[j];
            }
            if (has < 2) continue;
            int32_t old[2] = {t, u};
            if (flip(C, old, 2, abc, (int32_t)c[k], e)) return 1;
            break;
        }
    }
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            int32_t d = (int32_t)c[i], e = (int32_t)c[j], old[4], w[8];
            int n = 0, nw = 0;
            const ilist *l = &C->vt[d];
            for (int32_t r = 0; r < l->n && n < 4; r++) {
                const vm_index *q = tet(C, l->v[r]);
                if (q[0] != (vm_index)e && q[1] != (vm_index)e && q[2] != (vm_index)e &&
                    q[3] != (vm_index)e)
                    continue;
                old[n++] = l->v[r];
                for (int k = 0; k < 4; k++)
                    if (q[k] != (vm_index)d && q[k] != (vm_index)e && nw < 8)
                        w[nw++] = (int32_t)q[k];
            }
            if (n != 3) continue;
            /* a closed ring: three vertices, each in two of the tets */
            int32_t abc[3], na = 0, ok = 1;
            for (int r = 0; r < 6 && ok; r++) {
                int seen = 0, cnt = 0;
                for (int s2 = 0; s2 < na; s2++)
                    seen |= abc[s2] == w[r];
                for (int s2 = 0; s2 < 6; s2++)
                    cnt += w[s2] == w[r];
                if (cnt != 2) ok = 0;
                if (!seen && ok) {
                    if (na == 3) ok = 0;
                    else abc[na++] = w[r];
                }
            }
            if (!ok || na != 3) continue;
            if (flip(C, old, 3, abc, d, e)) return 1;
        }
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++)
            if (edge_remove(C, (int32_t)c[i], (int32_t)c[j]) ||
                bedge_remove(C, (int32_t)c[i], (int32_t)c[j]))
                return 1;
    return 0;
}

/* Whether b's tets off the edge ab stay good with b at x: positive, dihedral angles within
 * GR_CO_MIN..GR_CO_MAX, edges within bounds, ABAQUS's check passed (a merge makes no tet
 * worse than the targets, even where the stars hold one already). */
static int star_holds_at(const co *C, int32_t a, int32_t b, const double x[3]) {
    const ilist *tb = &C->vt[b];
    double camin = cos(GR_CO_MIN / GR_CO_DEG), camax = cos(GR_CO_MAX / GR_CO_DEG);
    for (int32_t i = 0; i < tb->n; i++) {
        const vm_index *c = tet(C, tb->v[i]);
        if (c[0] == a || c[1] == a || c[2] == a || c[3] == a) continue;
        double p[4][3], cmax, cmin;
        int kb = 0;
        for (int k = 0; k < 4; k++) {
            if (c[k] == b) kb = k;
            memcpy(p[k], c[k] == b ? x : pt(C, c[k]), sizeof p[k]);
        }
        if (C->sign * vol6(p[0], p[1], p[2], p[3]) <= 0) return 0;
        for (int k = 0; k < 4; k++)
            if (k != kb && !edge_ok(C, p[k], x)) return 0;
        if (!dihedral_cosines((const double(*)[3])p, &cmax, &cmin) || cmax > camin ||
            cmin < camax)
            return 0;
        if (!abaqus_ok((const double(*)[3])p)) return 0;
    }
    return 1;
}

/* Interior edge ab merged at x: b moves there and a collapses onto it, when every condition
 * of a collapse holds for both stars, every changed tet within the targets themselves. A
 * collapse onto an end often inverts a tet of the other's star that a point between them
 * keeps positive. Returns 1 when merged. */
static int merge_at(co *C, int32_t a, int32_t b, const double x[3], plan *P, set *sets) {
    if (!star_holds_at(C, a, b, x)) return 0;
    double *pb = C->m->points + 3 * (size_t)b, old[3];
    memcpy(old, pb, sizeof old);
    memcpy(pb, x, sizeof old);
    C->merging = 1;
    int ok = check(C, &C->w, a, b, P, &sets[0], &sets[1], &sets[2]);
    C->merging = 0;
    if (!ok) {
        memcpy(pb, old, sizeof old);
        return 0;
    }
    apply(C, a, b, P);
    const ilist *l = &C->vt[b];
    for (int32_t i = 0; i < l->n; i++)
        measure(C, l->v[i]);
    mark_around(C, b); /* b moved: its tets off the edge changed too */
    return 1;
}

/* x moved onto the isosurface: where it is already, or after at most 7 Newton steps
 * (newton_walk); 0 when they fail. */
static int onto_surface(const co *C, double x[3]) {
    double f, g[3], len;
    if (!phi_grad(C, x, &f, g)) return 0;
    double gn = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    if (!(gn > 0)) return 0;
    if (fabs(f) <= 1e-3 * C->D * gn) return 1;
    return newton_walk(C, x, f, g, 7, &len);
}

/* Boundary edge ab whose collapse failed both ways, merged: one end (not on a border plane)
 * moves to the edge's midpoint taken onto the isosurface, under every check of a move
 * (try_move), and the other collapses onto it with every changed tet within the targets;
 * the move is undone when the collapse fails. The collapse is tried again first unless
 * `failed` (the memo says it fails). Returns 1 when merged. */
static int bmerge(co *C, int32_t a, int32_t b, plan *P, set *sets, int failed) {
    if (!failed && check(C, &C->w, a, b, P, &sets[0], &sets[1], &sets[2])) {
        apply(C, a, b, P);
        return 1;
    }
    if (!failed && check(C, &C->w, b, a, P, &sets[0], &sets[1], &sets[2])) {
        apply(C, b, a, P);
        return 1;
    }
    double x[3];
    for (int d = 0; d < 3; d++)
        x[d] = 0.5 * (pt(C, a)[d] + pt(C, b)[d]);
    if (!onto_surface(C, x)) return 0;
    for (int e = 0; e < 2; e++) {
        int32_t u = e ? a : b, w = e ? b : a; /* u moves, w collapses onto it */
        if (C->fix[u] || C->fix[w]) continue;
        double *pu = C->m->points + 3 * (size_t)u, old[3], dvol = C->dvol;
        memcpy(old, pu, sizeof old);
        if (!try_move(C, u, x, 0, P)) continue;
        C->merging = 1;
        int ok = check(C, &C->w, w, u, P, &sets[0], &sets[1], &sets[2]);
        C->merging = 0;
        if (ok) {
            apply(C, w, u, P);
            return 1;
        }
        memcpy(pu, old, sizeof old);
        C->dvol = dvol;
        const ilist *l = &C->vt[u];
        for (int32_t i = 0; i < l->n; i++)
            measure(C, l->v[i]);
    }
    return 0;
}

static int memo_holds(const co *C, const memo *F, int32_t x, int32_t y);

/* A sweep over the interior edges, shortest first (E, ne: the pass's sorted edges): those
 * whose collapse fails both ways are merged at their midpoint, or at the mean of the two
 * stars' other vertices; it stops at `target` tets when nonzero. The collapse is not tried
 * again where the pass's memo (F, nf, in E's order) says it fails. [out] *removed counts the
 * merges. */
static void merge_sweep(co *C, const keyed *E, size_t ne, const memo *F, size_t nf,
                        size_t target, plan *P, set *sets, size_t *removed) {
    size_t j = 0;
    for (size_t i = 0; i < ne && !C->nomem && !stopped(C) && !(target && C->live <= target);
         i++) {
        int32_t a = E[i].a, b = E[i].b;
        if (C->dead_v[a] || C->dead_v[b]) continue;
        /* the last pass's memo (in E's order): the collapse fails again both ways when it
         * holds (a and b in the pass's order: both on the boundary or neither) */
        while (j < nf && keyed_cmp(&F[j].e, &E[i]) < 0)
            j++;
        int failed = C->bnd[a] == C->bnd[b] && j < nf && keyed_cmp(&F[j].e, &E[i]) == 0 &&
                     memo_holds(C, &F[j], a, b);
        if (C->bnd[a] || C->bnd[b]) {
            if (C->bnd[a] && C->bnd[b] && bmerge(C, a, b, P, sets, failed)) ++*removed;
            continue;
        }
        /* (the edge may be gone: a and b no longer share a tet) */
        const ilist *ta = &C->vt[a];
        int shared = 0;
        for (int32_t k = 0; k < ta->n && !shared; k++) {
            const vm_index *c = tet(C, ta->v[k]);
            shared = c[0] == b || c[1] == b || c[2] == b || c[3] == b;
        }
        if (!shared) continue;
        if (!failed && check(C, &C->w, a, b, P, &sets[0], &sets[1], &sets[2])) {
            apply(C, a, b, P);
            ++*removed;
            continue;
        }
        double x[2][3], s[3] = {0, 0, 0};
        int n = 0;
        for (int e = 0; e < 2; e++) {
            const ilist *l = &C->vt[e ? b : a];
            for (int32_t k = 0; k < l->n; k++) {
                const vm_index *c = tet(C, l->v[k]);
                for (int r = 0; r < 4; r++)
                    if (c[r] != (vm_index)a && c[r] != (vm_index)b) {
                        for (int d = 0; d < 3; d++)
                            s[d] += pt(C, c[r])[d];
                        n++;
                    }
            }
        }
        for (int d = 0; d < 3; d++) {
            x[0][d] = 0.5 * (pt(C, a)[d] + pt(C, b)[d]);
            x[1][d] = n ? s[d] / n : x[0][d];
        }
        for (int k = 0; k < 2; k++)
            if (merge_at(C, a, b, x[k], P, sets)) {
                ++*removed;
                break;
            }
    }
}

/* Whether flip_tet surely finds no flip for tet t: it found none last time (and no boundary
 * edge removal was refused for the volume budget then, which every change anywhere moves),
 * and nothing it reads has changed since: the tets around t's corners, their places, the
 * edges of the corners' neighbours (a ring's chords) and the isosurface samples near their
 * boundary triangles, all of which the near marks of t's corners follow. (Every change of
 * tets marks their corners: apply, try_move, flip, edge_remove, bedge_remove, peel.) */
static int flip_settled(const co *C, int32_t t) {
    uint32_t w = C->flipless[t];
    if (!w) return 0;
    const vm_index *c = tet(C, t);
    for (int k = 0; k < 4; k++)
        if (C->near[c[k]] >= w) return 0;
    return 1;
}

/* Sweeps (up to GR_CO_FLIP_SWEEPS, while any flips) over the live tets graded below
 * GR_CO_FLIP_BAR, each flipped (2-3, 3-2, edge removal) where that betters the worst of the
 * tets it replaces: between rounds, so that the collapses and merges of the next find
 * better-shaped stars. A tet that found no flip is tried again only once something near it
 * has changed (flip_settled). Returns the flips made. */
static size_t flip_sweep(co *C) {
    size_t all = 0;
    for (int sweep = 0; sweep < GR_CO_FLIP_SWEEPS && !C->nomem && !stopped(C); sweep++) {
        size_t flips = 0;
        for (size_t t = 0; t < C->nt && !C->nomem; t++) {
            if (C->dead_t[t] || !(tet_grade(C, (int32_t)t) < GR_CO_FLIP_BAR) ||
                flip_settled(C, (int32_t)t))
                continue;
            C->flip_budget = 0;
            if (flip_tet(C, (int32_t)t))
                flips++;
            else if (!C->flip_budget)
                C->flipless[t] = C->applied + 1;
        }
        all += flips;
        if (!flips) break;
    }
    return all;
}

/* The pattern searches' 14 directions (optimize_vertex, sum_search): the axes, then the
 * diagonals (the callers scale these by 1 / sqrt 3). */
static const double search_dir[14][3] = {
    {1, 0, 0},  {-1, 0, 0}, {0, 1, 0},   {0, -1, 0}, {0, 0, 1},   {0, 0, -1},  {1, 1, 1},
    {1, 1, -1}, {1, -1, 1}, {1, -1, -1}, {-1, 1, 1}, {-1, 1, -1}, {-1, -1, 1}, {-1, -1, -1}};

/* Moves vertex v to where the worst grade of its tets is highest, by a pattern search
 * (14 directions, steps from a third of its mean edge down), then through try_move (every
 * bound of a collapse), halving the move when that refuses. */
static int optimize_vertex(co *C, int32_t v, plan *P) {
    const ilist *l = &C->vt[v];
    if (C->fix[v] || l->n == 0) return 0;
    double L = 0, base = INFINITY;
    int ne = 0;
    for (int32_t i = 0; i < l->n; i++) {
        const vm_index *c = tet(C, l->v[i]);
        base = fmin(base, tet_grade(C, l->v[i]));
        for (int k = 0; k < 4; k++)
            if (c[k] != (vm_index)v) L += sqrt(dist2(pt(C, v), pt(C, c[k]))), ne++;
    }
    L /= ne;
    /* the star's tets worst first (the minimum does not depend on the order; a step is ruled
     * out sooner when the tet that limits it comes first) */
    enum { ORD_MAX = 512 };
    int32_t ord_here[ORD_MAX], *ord = ord_here;
    if (l->n > ORD_MAX && !(ord = malloc((size_t)l->n * sizeof *ord))) return 0;
    for (int32_t i = 0; i < l->n; i++) {
        int32_t t = l->v[i], k = i;
        double gt = tet_grade(C, t);
        for (; k > 0 && tet_grade(C, ord[k - 1]) > gt; k--)
            ord[k] = ord[k - 1];
        ord[k] = t;
    }
    double x[3], best = base;
    memcpy(x, pt(C, v), sizeof x);
    for (double step = 0.3 * L; step > 0.03 * L; step *= 0.4)
        for (int it = 0; it < 3; it++) {
            int bd = -1;
            double bg = best;
            for (int d = 0; d < 14; d++) {
                double y[3], g = INFINITY, s = d < 6 ? step : step / sqrt(3.0);
                for (int r = 0; r < 3; r++)
                    y[r] = x[r] + s * search_dir[d][r];
                /* a tet whose dihedral cosines put its grade clearly at or below bg rules
                 * the step out without its arc cosines and ABAQUS measures */
                double ca, cb;
                bar_cosines(bg, &ca, &cb);
                for (int32_t i = 0; i < l->n && g > bg; i++) {
                    const vm_index *c = tet(C, ord[i]);
                    const double *q[4];
                    for (int k = 0; k < 4; k++)
                        q[k] = c[k] == (vm_index)v ? y : pt(C, c[k]);
                    g = fmin(g, grade_cut(C, q[0], q[1], q[2], q[3], bg, ca, cb));
                }
                if (g > bg) bg = g, bd = d;
            }
            if (bd < 0) break;
            double s = bd < 6 ? step : step / sqrt(3.0);
            for (int r = 0; r < 3; r++)
                x[r] += s * search_dir[bd][r];
            best = bg;
        }
    if (ord != ord_here) free(ord);
    if (!(best > base + 1e-3)) return 0;
    double o[3], y[3];
    memcpy(o, pt(C, v), sizeof o);
    for (double w = 1; w > 0.1; w *= 0.5) {
        for (int r = 0; r < 3; r++)
            y[r] = o[r] + w * (x[r] - o[r]);
        if (try_move(C, v, y, 0, P)) return 1;
    }
    return 0;
}

/* The sum of the smallest dihedral angles (degrees) of v's tets with v at y, or -1 when a
 * tet is not positive, has its smallest angle below lo or its largest above hi. */
static double star_sum(const co *C, int32_t v, const double y[3], double lo, double hi) {
    const ilist *l = &C->vt[v];
    double sum = 0;
    for (int32_t i = 0; i < l->n; i++) {
        const vm_index *c = tet(C, l->v[i]);
        double p[4][3], cmax, cmin;
        for (int k = 0; k < 4; k++)
            memcpy(p[k], c[k] == (vm_index)v ? y : pt(C, c[k]), sizeof p[k]);
        if (!(C->sign * vol6(p[0], p[1], p[2], p[3]) > 0) ||
            !dihedral_cosines((const double(*)[3])p, &cmax, &cmin))
            return -1;
        double a = acos(cmax) * GR_CO_DEG, b = acos(cmin) * GR_CO_DEG;
        if (a < lo || b > hi) return -1;
        sum += a;
    }
    return sum;
}

/* Where the sum of v's tets' smallest dihedral angles is highest, by a pattern search (14
 * directions, steps from a fifth of its mean edge down; a boundary vertex along its tangent
 * plane, then onto the isosurface), no tet's smallest angle below the star's worst nor its
 * largest above the targets or the star's largest. [out] x. 1 when it found a better place. */
static int sum_search(const co *C, int32_t v, double x[3]) {
    const ilist *l = &C->vt[v];
    double L = 0, lo = 180, hi = 0, nrm[3] = {0, 0, 0};
    int ne = 0;
    for (int32_t i = 0; i < l->n; i++) {
        const vm_index *c = tet(C, l->v[i]);
        lo = fmin(lo, C->qlo[l->v[i]]);
        hi = fmax(hi, C->qhi[l->v[i]]);
        for (int k = 0; k < 4; k++)
            if (c[k] != (vm_index)v) L += sqrt(dist2(pt(C, v), pt(C, c[k]))), ne++;
    }
    if (!ne) return 0;
    L /= ne;
    hi = fmax(hi, GR_CO_MAX);
    if (C->bnd[v]) {
        double f;
        if (!phi_grad(C, pt(C, v), &f, nrm)) return 0;
        double gn = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        if (!(gn > 0)) return 0;
        for (int d = 0; d < 3; d++)
            nrm[d] /= gn;
    }
    memcpy(x, pt(C, v), 3 * sizeof *x);
    double base = star_sum(C, v, x, lo, hi), best = base;
    if (base < 0) return 0;
    for (double step = 0.2 * L; step > 0.02 * L; step *= 0.4)
        for (int it = 0; it < 3; it++) {
            double by[3], bg = best;
            for (int d = 0; d < 14; d++) {
                double y[3], e[3], s = d < 6 ? step : step / sqrt(3.0);
                for (int r = 0; r < 3; r++)
                    e[r] = s * search_dir[d][r];
                if (C->bnd[v]) {
                    double en = e[0] * nrm[0] + e[1] * nrm[1] + e[2] * nrm[2];
                    for (int r = 0; r < 3; r++)
                        e[r] -= en * nrm[r];
                }
                for (int r = 0; r < 3; r++)
                    y[r] = x[r] + e[r];
                if (C->bnd[v] && !onto_surface(C, y)) continue;
                double g = star_sum(C, v, y, lo, hi);
                if (g > bg) {
                    bg = g;
                    memcpy(by, y, sizeof by);
                }
            }
            if (!(bg > best)) break;
            best = bg;
            memcpy(x, by, sizeof by);
        }
    return best > base + GR_CO_MEAN_GAIN * l->n;
}

/* One sweep for the mean angle, after the rounds: each vertex not on a border plane goes
 * towards the mean of its neighbours (a boundary vertex: of its boundary neighbours, that
 * point taken onto the isosurface), the whole way, half or a quarter, where that raises the
 * sum of its tets' smallest dihedral angles and lowers none below the star's worst, under
 * every check of a move (try_move with `better` 2 or 3: 15..150 degrees and ABAQUS's check,
 * the volume, the distance both ways). With C->search, sum_search's place is tried first.
 * The collapses leave any tet of 15 degrees or more; this raises the mean of each tet's
 * smallest angle (issue 32) without touching the worst. The places it tries for vertex v,
 * in order, into x (how many: 0 to GR_CO_TRIES), and `better` for try_move. */
static int mean_tries(const co *C, int32_t v, int better, double x[][3], int *better_out) {
    *better_out = better;
    const ilist *l = &C->vt[v];
    double m[3];
    if (!neighbour_mean(C, v, m)) return 0;
    int lap = !C->bnd[v] || onto_surface(C, m);
    /* an interior vertex tries the centre of its tets' circumcentres weighted by their
     * volumes too (the optimal Delaunay triangulation's move, Chen and Xu 2004) */
    double cand[3][3], wsum = 0, cs[3] = {0, 0, 0};
    int nc = 0;
    if (C->search && sum_search(C, v, cand[0])) nc++;
    if (lap) memcpy(cand[nc++], m, sizeof m);
    for (int32_t i = 0; i < l->n && !C->bnd[v]; i++) {
        const vm_index *c = tet(C, l->v[i]);
        double p[4][3], a[3], bc[3], w[3];
        for (int k = 0; k < 4; k++)
            memcpy(p[k], pt(C, c[k]), sizeof p[k]);
        vm__tet_circum_vector((const double(*)[3])p, a, bc, w);
        double v6 = a[0] * bc[0] + a[1] * bc[1] + a[2] * bc[2];
        if (!(fabs(v6) > 0)) {
            wsum = 0;
            break;
        }
        /* circumcentre p0 + w / (2 v6); weight |v6| */
        for (int d = 0; d < 3; d++)
            cs[d] += fabs(v6) * p[0][d] + 0.5 * w[d] * (v6 > 0 ? 1 : -1);
        wsum += fabs(v6);
    }
    if (wsum > 0) {
        for (int d = 0; d < 3; d++)
            cand[nc][d] = cs[d] / wsum;
        nc++;
    }
    /* each candidate, then halfway and a quarter of the way there */
    const double *o = pt(C, v);
    int nt = 0;
    for (int j = 0; j < nc; j++)
        for (double w = 1; w > 0.2; w *= 0.5, nt++)
            for (int d = 0; d < 3; d++)
                x[nt][d] = o[d] + w * (cand[j][d] - o[d]);
    return nt;
}

/* The sweep for the mean angle (mean_tries), colour by colour (colour_sweep). [out] moved. */
static size_t mean_sweep(co *C, int interior_only, int better) {
    sweep_kind K = {1, interior_only, better};
    return colour_sweep(C, &K, co_threads());
}

/* Repair: each tet beyond 15..150 degrees has its vertices moved where that raises the worst
 * angle around them: an interior vertex towards the mean of its neighbours, a boundary one
 * towards the mean of its boundary neighbours and back onto the surface (two Newton steps
 * along the gradient); then its edges collapsed where that leaves the worst angle better.
 * [out] tets still beyond. */
static size_t repair(co *C, plan *P, set *sets, size_t *removed) {
    size_t left = 0;
    for (size_t tt = 0; tt < C->nt && !C->nomem && !stopped(C); tt++) {
        int32_t t = (int32_t)tt;
        if (C->dead_t[t] || tet_grade(C, t) >= 1) continue;
        vm_index c[4];
        memcpy(c, tet(C, t), sizeof c);
        for (int k = 0; k < 4 && !C->dead_t[t] && tet_grade(C, t) < 1; k++) {
            int32_t v = (int32_t)c[k];
            if (C->fix[v]) continue;
            const ilist *l = &C->vt[v];
            double s[3] = {0, 0, 0}, x[3];
            int n = 0;
            for (int32_t i = 0; i < l->n; i++) {
                const vm_index *q = tet(C, l->v[i]);
                for (int j = 0; j < 4; j++)
                    if (q[j] != v && (!C->bnd[v] || C->bnd[q[j]])) {
                        for (int d = 0; d < 3; d++)
                            s[d] += pt(C, q[j])[d];
                        n++;
                    }
            }
            if (!n) continue;
            for (double w = 1.0; w > 0.2; w *= 0.5) {
                for (int d = 0; d < 3; d++)
                    x[d] = pt(C, v)[d] + w * (s[d] / n - pt(C, v)[d]);
                if (C->bnd[v])
                    for (int it = 0; it < 2; it++) {
                        double phi, g[3];
                        if (!phi_grad(C, x, &phi, g)) break;
                        double g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
                        if (!(g2 > 0)) break;
                        for (int d = 0; d < 3; d++)
                            x[d] -= phi * g[d] / g2;
                    }
                if (try_move(C, v, x, 1, P)) break;
            }
            if (C->bnd[v] || C->dead_t[t] || tet_grade(C, t) >= 1) continue;
            /* an interior corner: away from the face opposite it */
            const vm_index *q = tet(C, t);
            int kv = 0;
            for (int j = 0; j < 4; j++)
                if (q[j] == (vm_index)v) kv = j;
            double nn[3], L = 0;
            face_out(C, q, kv, nn);
            double nl = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
            for (int j = 0; j < 4; j++)
                if (j != kv) L += sqrt(dist2(pt(C, v), pt(C, q[j]))) / 3;
            if (!(nl > 0)) continue;
            for (double w = 0.4; w > 0.04; w *= 0.5) {
                for (int d = 0; d < 3; d++)
                    x[d] = pt(C, v)[d] - w * L * nn[d] / nl;
                if (try_move(C, v, x, 1, P)) break;
            }
        }
#define GOOD(t) (C->dead_t[t] || tet_grade(C, t) >= 1)
        for (int k = 0; k < 3 && !GOOD(t) && flip_tet(C, t); k++)
            ;
        memcpy(c, tet(C, t), sizeof c);
        for (int k = 0; k < 4 && !GOOD(t); k++)
            optimize_vertex(C, (int32_t)c[k], P);
#undef GOOD
        if (C->dead_t[t] || tet_grade(C, t) >= 1) continue;
        C->strict = 1;
        memcpy(c, tet(C, t), sizeof c);
        int done = 0;
        for (int i = 0; i < 4 && !done; i++)
            for (int j = i + 1; j < 4 && !done; j++) {
                int32_t x = (int32_t)c[i], y = (int32_t)c[j];
                if (check(C, &C->w, x, y, &P[0], &sets[0], &sets[1], &sets[2])) {
                    apply(C, x, y, &P[0]);
                    done = 1;
                } else if (check(C, &C->w, y, x, &P[0], &sets[0], &sets[1], &sets[2])) {
                    apply(C, y, x, &P[0]);
                    done = 1;
                }
            }
        C->strict = 0;
        if (done)
            ++*removed;
        else if (!peel(C, t))
            left++;
    }
    return left;
}

/* Whether the memo's failed checks of edge xy (x first) would fail again: no collapse since
 * has marked what they read (x's star for a check that failed on the changed tets, else the
 * stars of x, y and their neighbours). */
static int memo_holds(const co *C, const memo *F, int32_t x, int32_t y) {
    uint32_t w = F->when;
    int near = C->near[x] <= w && C->near[y] <= w;
    return (F->late & 1 ? near : C->star[x] <= w) && (F->late & 2 ? near : C->star[y] <= w);
}

/* Checks made ahead on threads (the batch of edges after the current one), each against
 * the mesh as it was when the batch began (`when`), and taken in order afterwards when
 * nothing the check read has changed since (the memo's rule) and the net volume budget,
 * which the collapses in between move, still says what it said; any other check is made
 * again in order. So the collapses are those of the serial loop, on any number of threads. */
enum { GR_CO_BATCH = 1024, GR_CO_SPEC_TRI = 96 };
typedef struct spec {
    int32_t x, y; /* the edge as checked (x < 0: not checked ahead) */
    int two;      /* both ways checked (both ends on the boundary, or neither) */
    uint32_t when;
    int ok[2], late[2], reached[2], budget[2];
    double dtry[2];
    /* the plans, kept when they hold at most GR_CO_SPEC_TRI triangles (else ok is -1: the
     * check is made again in order) */
    double qmin[2], dvol[2];
    int ntri[2];
    int32_t tri[2][GR_CO_SPEC_TRI][3];
} spec;

static void spec_one(const co *C, scratch *W, set *sets, plan *P, spec *q) {
    for (int k = 0; k < 1 + q->two; k++) {
        int32_t a = k ? q->y : q->x, b = k ? q->x : q->y;
        W->budget_hit = 0;
        q->ok[k] = check(C, W, a, b, P, &sets[0], &sets[1], &sets[2]);
        q->late[k] = W->late;
        q->reached[k] = W->reached;
        q->budget[k] = W->budget_hit;
        q->dtry[k] = W->dtry;
        if (!q->ok[k]) continue;
        if (P->ntri > GR_CO_SPEC_TRI) {
            q->ok[k] = -1;
            continue;
        }
        q->qmin[k] = P->qmin;
        q->dvol[k] = P->dvol;
        q->ntri[k] = P->ntri;
        memcpy(q->tri[k], P->tri, (size_t)P->ntri * sizeof P->tri[0]);
    }
}

/* Plan k of q into P. */
static void spec_plan(const spec *q, int k, plan *P) {
    P->qmin = q->qmin[k];
    P->dvol = q->dvol[k];
    P->ntri = q->ntri[k];
    memcpy(P->tri, q->tri[k], (size_t)q->ntri[k] * sizeof P->tri[0]);
}

/* Whether the checks of q hold now; [out] *ok (one bit per way), *late, *budget_hit as the
 * checks would give them. */
static int spec_take(const co *C, const spec *q, int *ok, int *late, int *budget_hit) {
    uint32_t w = q->when;
    int near = C->near[q->x] <= w && C->near[q->y] <= w;
    *ok = *late = *budget_hit = 0;
    for (int k = 0; k < 1 + q->two; k++) {
        int32_t a = k ? q->y : q->x;
        if (!(q->late[k] ? near : C->star[a] <= w)) return 0;
        if (q->budget[k] || q->ok[k] < 0) return 0; /* (refused on the budget then: maybe
                                                         not now; a plan too big to keep) */
        int ok_k = q->ok[k];
        if (q->reached[k] && (C->dvol + q->dtry[k] < -C->vol_budget ||
                              C->dvol + q->dtry[k] > C->vol_gain)) {
            ok_k = 0;
            *budget_hit = 1;
        }
        *ok |= ok_k << k;
        *late |= q->late[k] << k;
    }
    return 1;
}

/* Checks ahead the edges of E[i0 .. i0 + GR_CO_BATCH) that the loop will check (alive, not
 * skipped by the memo F from its position j), on nthreads threads with their scratch. */
static void speculate(const co *C, const keyed *E, size_t ne, size_t i0, const memo *F, size_t nf,
                      size_t j, spec *S, scratch *TW, set *TS, plan *TP, int nthreads) {
    size_t i1 = i0 + GR_CO_BATCH < ne ? i0 + GR_CO_BATCH : ne;
    int todo[GR_CO_BATCH], n = 0;
    for (size_t i = i0; i < i1; i++) {
        spec *q = &S[i - i0];
        q->x = -1;
        int32_t x = E[i].a, y = E[i].b;
        if (C->dead_v[x] || C->dead_v[y]) continue;
        if (C->bnd[x] && !C->bnd[y]) {
            int32_t t = x;
            x = y;
            y = t;
        }
        while (j < nf && keyed_cmp(&F[j].e, &E[i]) < 0)
            j++;
        if (j < nf && keyed_cmp(&F[j].e, &E[i]) == 0 && memo_holds(C, &F[j], x, y)) continue;
        q->x = x;
        q->y = y;
        q->two = C->bnd[x] == C->bnd[y];
        q->when = C->applied;
        todo[n++] = (int)(i - i0);
    }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for num_threads(nthreads) schedule(dynamic, 8)
#endif
    for (int k = 0; k < n; k++) {
        int t = 0;
#ifdef VM_HAVE_OPENMP
        t = omp_get_thread_num();
#endif
        spec_one(C, &TW[t], &TS[3 * t], &TP[t], &S[todo[k]]);
    }
    (void)nthreads;
}

/* The coarsening's state over mesh m (its tets, stars, qualities, boundary and border
 * planes), without the isosurface's samples. */
static vm_status co_setup(co *Cp, vm_mesh *m, const gr_field *f, double distance,
                          double max_edge, vm__meter *pm, vm_error *err) {
    co C;
    memset(&C, 0, sizeof C);
    C.m = m;
    C.f = f;
    C.D = distance;
    C.max_edge = max_edge > 0 ? max_edge : INFINITY;
    C.nv = m->npoints;
    C.nt = m->ncells;
    C.pm = pm;
    C.live = m->ncells;
    C.voxel = fmin(f->sp[0], fmin(f->sp[1], f->sp[2]));
    double det;
    vm_status s = vm__frame_inverse(f->v, "mesh", C.inv, &det, err);
    if (s) return s;
    C.vt = calloc(C.nv, sizeof *C.vt);
    C.vs = calloc(C.nv, sizeof *C.vs);
    C.bnd = calloc(C.nv, 1);
    C.fix = calloc(C.nv, 1);
    C.dead_v = calloc(C.nv, 1);
    C.dead_t = calloc(C.nt, 1);
    C.free_faces = calloc(C.nt, 1);
    C.w.vmark = calloc(C.nv, sizeof *C.w.vmark);
    C.qlo = malloc(C.nt * sizeof *C.qlo);
    C.qhi = malloc(C.nt * sizeof *C.qhi);
    C.qab = malloc(C.nt * sizeof *C.qab);
    C.flipless = calloc(C.nt, sizeof *C.flipless);
    C.star = calloc(C.nv, sizeof *C.star);
    C.near = calloc(C.nv, sizeof *C.near);
    C.applied = 1;
    if (!C.vt || !C.vs || !C.bnd || !C.fix || !C.dead_v || !C.dead_t || !C.free_faces ||
        !C.w.vmark || !C.qlo || !C.qhi || !C.qab || !C.flipless || !C.star || !C.near) {
        co_free(&C);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    }
    double pos = 0, neg = 0;
    for (size_t t = 0; t < C.nt && !C.nomem; t++) {
        const vm_index *c = tet(&C, (int32_t)t);
        double v = vol6(pt(&C, c[0]), pt(&C, c[1]), pt(&C, c[2]), pt(&C, c[3]));
        if (v > 0) pos += v;
        if (v < 0) neg -= v;
        for (int k = 0; k < 4; k++)
            if (!push(&C.vt[c[k]], (int32_t)t)) C.nomem = 1;
        measure(&C, (int32_t)t);
    }
    C.sign = pos >= neg ? 1 : -1;
    C.vol_budget = GR_CO_NET_VOLUME * fabs(pos - neg) / 6;
    C.vol_gain = GR_CO_NET_GAIN * fabs(pos - neg) / 6;
    for (size_t t = 0; t < C.nt && !C.nomem; t++)
        refresh_faces(&C, (int32_t)t);
    for (size_t t = 0; t < C.nt && !C.nomem; t++)
        for (int k = 0; k < 4; k++)
            if (face_free(&C, (int32_t)t, k))
                for (int j = 1; j < 4; j++)
                    C.bnd[tet(&C, (int32_t)t)[(k + j) & 3]] = 1;
    /* the border planes each vertex lies on */
    for (size_t v = 0; v < C.nv; v++) {
        double ijk[3];
        to_index(&C, pt(&C, (int64_t)v), ijk);
        for (int r = 0; r < 3; r++) {
            double tol = 1e-6;
            if (ijk[r] < tol) C.fix[v] |= (unsigned char)(1u << (2 * r));
            if (ijk[r] > (double)(f->n[r] - 1) - tol) C.fix[v] |= (unsigned char)(2u << (2 * r));
        }
    }
    *Cp = C;
    if (C.nomem) {
        co_free(Cp);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    }
    return s;
}

vm_status vm__gr_coarsen(vm_mesh *m, const gr_field *f, double distance, double max_edge,
                         size_t target, int merge, vm__meter *pm, size_t *removed,
                         vm_error *err) {
    *removed = 0;
    if (m->ncells == 0 || m->npoints >= (size_t)INT32_MAX || m->ncells >= (size_t)INT32_MAX / 4)
        return VM_OK;
    co C;
    vm_status s = co_setup(&C, m, f, distance, max_edge, pm, err);
    if (s) return s;
    if (C.nomem) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    if (!s) s = samples(&C, err);
    if (!s) s = assign_samples(&C, err);
    keyed *E = NULL, *Etmp = NULL;
    /* The memo: the edges whose checks failed both ways in the last pass (in E's order),
     * with `applied` then and which ways failed late; a check fails again while nothing has
     * changed what it read since: collapses, merges, moves and flips mark the vertices
     * (mark_around, mark_vertex), and an edge whose end moved has another length, so another
     * key. It lasts across rounds: a round's first pass rechecks only the edges near what
     * the merges, moves and flips between rounds changed. */
    memo *F = NULL, *Fn = NULL;
    /* checks ahead on threads (none on one) */
    int nthreads = co_threads();
    spec *S = NULL;
    scratch *TW = NULL;
    set *TS = NULL;
    plan *TP = NULL;
    if (nthreads > 1) {
        S = malloc(GR_CO_BATCH * sizeof *S);
        TW = calloc((size_t)nthreads, sizeof *TW);
        TS = malloc(3 * (size_t)nthreads * sizeof *TS);
        TP = malloc((size_t)nthreads * sizeof *TP);
        int ok = S && TW && TS && TP;
        for (int t = 0; ok && t < nthreads; t++)
            ok = (TW[t].vmark = calloc(C.nv, sizeof *TW[t].vmark)) != NULL;
        if (!ok) { /* then serially */
            for (int t = 0; TW && t < nthreads; t++)
                free(TW[t].vmark);
            free(S);
            free(TW);
            free(TS);
            free(TP);
            S = NULL;
            TW = NULL;
            TS = NULL;
            TP = NULL;
        }
    }
    size_t nf = 0, fcap = 0, ne_last = 0;
    set *sets = malloc(3 * sizeof *sets);
    plan *P = malloc(2 * sizeof *P);
    if (!s && (!sets || !P))
        s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    /* rounds of collapses, then moves (which open room for more collapses) */
    for (int round = 0; round < GR_CO_ROUNDS && !s && !C.nomem && !C.stop; round++) {
        size_t r0 = *removed;
        for (int pass = 0; pass < GR_CO_PASSES && !s && !C.nomem && !C.stop; pass++) {
            /* the live edges, shortest first */
            size_t ne = 0;
            /* once: the live tets only get fewer (a fresh block per pass would have the
             * kernel clear its pages every time) */
            if (!E) {
                E = malloc(6 * C.live * sizeof *E + 1);
                Etmp = malloc(6 * C.live * sizeof *Etmp + 1);
            }
            if (!E || !Etmp) {
                s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
                break;
            }
            /* each edge once, from its lower end (the sort below fixes the order) */
            for (size_t x = 0; x < C.nv; x++) {
                const ilist *l = &C.vt[x];
                if (!l->n) continue;
                stamp_next(&C.w, C.nv);
                for (int32_t k = 0; k < l->n; k++) {
                    const vm_index *c = tet(&C, l->v[k]);
                    for (int r = 0; r < 4; r++) {
                        int32_t y = (int32_t)c[r];
                        if ((size_t)y <= x || C.w.vmark[y] == C.w.vstamp) continue;
                        C.w.vmark[y] = C.w.vstamp;
                        E[ne++] = (keyed){dist2(pt(&C, (int64_t)x), pt(&C, y)), (int32_t)x, y};
                    }
                }
            }
            keyed_sort(E, Etmp, ne);
            ne_last = ne;
            if (!F) {
                fcap = ne;
                F = malloc(fcap * sizeof *F + 1);
                Fn = malloc(fcap * sizeof *Fn + 1);
                if (!F || !Fn) {
                    s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
                    break;
                }
            }
            size_t before = *removed, j = 0, nfn = 0, i0 = 0;
            for (size_t i = 0; i < ne && !C.nomem; i++) {
                if (S && i == i0 + (i > 0 ? GR_CO_BATCH : 0)) {
                    i0 = i;
                    speculate(&C, E, ne, i0, F, nf, j, S, TW, TS, TP, nthreads);
                }
                static const size_t ahead[4] = {24, 16, 8, 4};
                for (int st = 0; st < 4; st++)
                    if (i + ahead[st] < ne)
                        prefetch_edge(&C, E[i + ahead[st]].a, E[i + ahead[st]].b, st);
                int32_t x = E[i].a, y = E[i].b;
                if (C.dead_v[x] || C.dead_v[y]) continue;
                if (target && C.live <= target) break;
                /* remove the interior end where there is one, else try x first */
                if (C.bnd[x] && !C.bnd[y]) {
                    int32_t q = x;
                    x = y;
                    y = q;
                }
                while (j < nf && keyed_cmp(&F[j].e, &E[i]) < 0)
                    j++;
                if (j < nf && keyed_cmp(&F[j].e, &E[i]) == 0 && memo_holds(&C, &F[j], x, y)) {
                    if (nfn < fcap) Fn[nfn++] = F[j];
                    continue;
                }
                spec *q = S ? &S[i - i0] : NULL;
                int okx, oky = 0, late, bh, both;
                plan *P0 = &P[0], *P1 = &P[1];
                if (q && q->x == x && q->y == y && spec_take(&C, q, &both, &late, &bh)) {
                    okx = both & 1;
                    oky = both >> 1;
                    if (okx) spec_plan(q, 0, P0);
                    if (oky) spec_plan(q, 1, P1);
                } else {
                    C.w.budget_hit = 0;
                    okx = check(&C, &C.w, x, y, P0, &sets[0], &sets[1], &sets[2]);
                    late = C.w.late;
                    if (C.bnd[x] == C.bnd[y]) {
                        oky = check(&C, &C.w, y, x, P1, &sets[0], &sets[1], &sets[2]);
                        late |= C.w.late << 1;
                    }
                    bh = C.w.budget_hit;
                }
                if (okx && (!oky || P0->qmin >= P1->qmin))
                    apply(&C, x, y, P0);
                else if (oky)
                    apply(&C, y, x, P1);
                else {
                    if (!bh && nfn < fcap)
                        Fn[nfn++] = (memo){E[i], C.applied, (unsigned char)late};
                    continue;
                }
                ++*removed;
            }
            memo *q = F;
            F = Fn;
            Fn = q;
            nf = nfn;
            if (target && C.live <= target) break;
            if ((double)(*removed - before) < 0.005 * (double)C.nv) break;
        }
        if ((target && C.live <= target) || (round > 0 && *removed == r0)) break;
        if (E && merge) merge_sweep(&C, E, ne_last, F, nf, target, P, sets, removed);
        static const sweep_kind moves = {0, 0, 0};
        for (int k = 0; k < 2 && !C.nomem; k++)
            colour_sweep(&C, &moves, nthreads);
        if (merge) flip_sweep(&C);
    }
    for (int k = 0; k < 3 && !s && !C.nomem && !C.stop; k++)
        if (!repair(&C, P, sets, removed)) break;
    for (int k = 0; k < GR_CO_MEAN_SWEEPS && !s && !C.nomem && !C.stop; k++)
        if (!mean_sweep(&C, 0, 2)) break;
    for (int t = 0; TW && t < nthreads; t++)
        free(TW[t].vmark);
    free(S);
    free(TW);
    free(TS);
    free(TP);
    free(E);
    free(Etmp);
    free(F);
    free(Fn);
    free(sets);
    free(P);
    if (!s && C.nomem) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for coarsening");
    if (!s && C.stop) s = vm__cancelled(err, "mesh");
    if (!s) s = compact(&C, err);
    co_free(&C);
    return s;
}

/* What vm__gr_mean_smooth and vm__gr_flips run on a finished mesh: the field of v's material
 * {lo <= f <= hi} and the coarsening's state over m, with the distance bound (world units)
 * and the isosurface samples when distance > 0 (else none: nothing moves the boundary off
 * its place). 1 when set up (free both after), 0 when there is nothing to do (*s VM_OK) or
 * on an error (*s set). */
static int co_open(vm_mesh *m, const vm_volume *v, double lo, int has_lo, double hi, int has_hi,
                   double max_edge, double distance, gr_field *f, co *C, vm_status *s,
                   vm_error *err) {
    *s = VM_OK;
    if (m->kind != VM_TET4 || m->ncells == 0 || m->npoints >= (size_t)INT32_MAX ||
        m->ncells >= (size_t)INT32_MAX / 4)
        return 0;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.graded = 1;
    o.lo = lo;
    o.hi = hi;
    o.has_lo = has_lo;
    o.has_hi = has_hi;
    if ((*s = vm__gr_field_init(f, v, &o, err))) return 0;
    if ((*s = co_setup(C, m, f, distance, max_edge, NULL, err))) {
        vm__gr_field_free(f);
        return 0;
    }
    if (distance > 0) {
        *s = samples(C, err);
        if (!*s) *s = assign_samples(C, err);
        if (*s) {
            co_free(C);
            vm__gr_field_free(f);
            return 0;
        }
    }
    return 1;
}

vm_status vm__gr_mean_smooth(vm_mesh *m, const vm_volume *v, double lo, int has_lo, double hi,
                             int has_hi, double max_edge, double distance, size_t *moved,
                             size_t flips[4], vm_error *err) {
    *moved = 0;
    flips[0] = flips[1] = flips[2] = flips[3] = 0;
    gr_field f;
    co C;
    vm_status s;
    if (!co_open(m, v, lo, has_lo, hi, has_hi, max_edge, distance, &f, &C, &s, err)) return s;
    int bnd = distance > 0;
    C.search = 1;
    C.vol_budget *= GR_CO_POLISH_VOLUME / GR_CO_NET_VOLUME;
    C.vol_gain *= GR_CO_POLISH_VOLUME / GR_CO_NET_VOLUME;
    for (int k = 0; !s && !C.nomem && k < GR_CO_POLISH_ROUNDS; k++) {
        size_t nf = bnd ? flip_sweep(&C) : 0;
        size_t n = mean_sweep(&C, !bnd, 3);
        *moved += n;
        if (!n && !nf) break;
    }
    flips[0] = C.flips23;
    flips[1] = C.flips32;
    flips[2] = C.removals;
    flips[3] = C.bremovals;
    if (!s && C.nomem) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for smoothing");
    if (!s && (flips[0] || flips[1] || flips[2] || flips[3])) s = compact(&C, err);
    co_free(&C);
    vm__gr_field_free(&f);
    return s;
}

vm_status vm__gr_flips(vm_mesh *m, const vm_volume *v, double lo, int has_lo, double hi,
                       int has_hi, double max_edge, double distance, size_t *flips,
                       size_t *removals, size_t *bremovals, vm_error *err) {
    *flips = *removals = *bremovals = 0;
    gr_field f;
    co C;
    vm_status s;
    if (!co_open(m, v, lo, has_lo, hi, has_hi, max_edge, distance, &f, &C, &s, err)) return s;
    *flips = flip_sweep(&C);
    *removals = C.removals;
    *bremovals = C.bremovals;
    if (C.nomem) s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for flips");
    if (!s) s = compact(&C, err);
    co_free(&C);
    vm__gr_field_free(&f);
    return s;
}
