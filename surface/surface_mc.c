/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_mc.c — marching cubes (Lorensen & Cline 1987) with the topology of the
 * trilinear interpolant: face ambiguities by the asymptotic decider (Nielson & Hamann 1991),
 * the interior ambiguity by sweeping each cube with planes (derived in docs/ALGORITHMS.md).
 *
 * No case table: each cube's polygons are found by walking its face-resolved edge graph,
 * grouped into the pieces of the trilinear isosurface inside the cube (disks, tunnels), and
 * triangulated on the spot; where a cube has a tunnel or several pieces, candidate
 * triangulations are searched until no two triangles of the cube cross (the exact test of
 * core/self_intersect.c). One vertex per crossed grid edge, so the surface is watertight;
 * material on the volume border is closed by flat faces on the box (marching squares on the
 * border faces, with the same decider). */
#include "../core/core.h"
#include "../core/self_intersect.h"
#include "../core/vec3.h"
#include "surface_internal.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Crossings are kept this far (in cells) from the grid points, so no triangle is flat. */
#define MC_EDGE_MARGIN 1e-4
/* A value of exactly 0 is inside; it contours as this small positive value. */
#define MC_ZERO 1e-200

/* ---- the unit cube ---------------------------------------------------------------------
 * Corner c sits at (c & 1, (c >> 1) & 1, c >> 2). Edge e runs from its lower corner along
 * one axis; face f = 2 * axis + side. */
typedef struct cube_geom {
    int edge_c[12][2]; /* lower corner, upper corner */
    int edge_axis[12];
    int edge_faces[12]; /* bit f set for the two faces holding the edge */
    int face_c[6][4];   /* corners counter-clockwise seen from outside the cube */
    int face_e[6][4];   /* edge from face_c[f][i] to face_c[f][(i + 1) % 4] */
} cube_geom;

static void cube_geom_init(cube_geom *g) {
    int id[8][8];
    int e = 0;
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 8; c++) {
            if (c & (1 << a)) continue;
            g->edge_c[e][0] = c;
            g->edge_c[e][1] = c | (1 << a);
            g->edge_axis[e] = a;
            g->edge_faces[e] = 0;
            id[c][c | (1 << a)] = id[c | (1 << a)][c] = e;
            e++;
        }
    for (int a = 0; a < 3; a++) {
        int u = (a + 1) % 3, v = (a + 2) % 3;
        for (int s = 0; s < 2; s++) {
            int f = 2 * a + s;
            /* (u, v) = (0,0), (1,0), (1,1), (0,1) turns counter-clockwise about +a */
            static const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
            for (int i = 0; i < 4; i++) {
                int q = s ? i : 3 - i;
                g->face_c[f][i] = (s << a) | (uv[q][0] << u) | (uv[q][1] << v);
            }
            for (int i = 0; i < 4; i++) {
                int c0 = g->face_c[f][i], c1 = g->face_c[f][(i + 1) % 4];
                g->face_e[f][i] = id[c0][c1];
                g->edge_faces[id[c0][c1]] |= 1 << f;
            }
        }
    }
}

/* The asymptotic decider on a face with values a, b, c, d in cyclic order and alternating
 * signs: 1 when the two positive corners are joined across the face (the bilinear saddle
 * value, (ac - bd) / (a + c - b - d), is >= 0: zero counts as inside). Written with the
 * two diagonal products only, so that both cubes sharing the face, and the border square,
 * decide it identically. */
static int face_joins_inside(double a, double b, double c, double d) {
    return a > 0 ? a * c >= b * d : b * d >= a * c;
}

/* ---- per-extraction state --------------------------------------------------------------- */

typedef struct mc {
    const vm__surface_grid *g;
    vm_mesh *surf;
    vm_error *err;
    cube_geom cg;
    int64_t nx, ny, nz;
    int64_t k0;              /* z of layer slot 0 */
    vm_index *ex[2], *ey[2]; /* vertex ids of x and y edges of layers k0, k0 + 1 */
    vm_index *pv[2];         /* vertex ids of border grid points of those layers */
    vm_index *ez;            /* vertex ids of z edges between them */
    size_t centres;          /* vertices added inside cubes */
    double cube0[3];         /* lower corner of the cube being triangulated */
} mc;

static double value(const mc *m, int64_t i, int64_t j, int64_t k) {
    double s = vm__surface_at(m->g, i, j, k);
    return s == 0 ? MC_ZERO : s;
}

static vm_index *edge_slot(mc *m, int axis, int64_t i, int64_t j, int64_t k) {
    if (axis == 2) return &m->ez[i + m->nx * j];
    int l = (int)(k - m->k0);
    if (axis == 0) return &m->ex[l][i + (m->nx - 1) * j];
    return &m->ey[l][i + m->nx * j];
}

/* Vertex of the crossing on the grid edge from (i,j,k) along axis (created on first use). */
static vm_index edge_vertex(mc *m, int axis, int64_t i, int64_t j, int64_t k) {
    vm_index *slot = edge_slot(m, axis, i, j, k);
    if (*slot >= 0) return *slot;
    int64_t q[3] = {i, j, k};
    double a = value(m, i, j, k);
    q[axis]++;
    double b = value(m, q[0], q[1], q[2]);
    double t = a / (a - b);
    if (!(t >= MC_EDGE_MARGIN)) t = MC_EDGE_MARGIN;
    if (t > 1 - MC_EDGE_MARGIN) t = 1 - MC_EDGE_MARGIN;
    double p[3] = {(double)i, (double)j, (double)k};
    p[axis] += t;
    *slot = vm_mesh_add_point(m->surf, p, m->err);
    return *slot;
}

/* Vertex at the border grid point (i,j,k) (inside the material). */
static vm_index point_vertex(mc *m, int64_t i, int64_t j, int64_t k) {
    vm_index *slot = &m->pv[k - m->k0][i + m->nx * j];
    if (*slot >= 0) return *slot;
    double p[3] = {(double)i, (double)j, (double)k};
    *slot = vm_mesh_add_point(m->surf, p, m->err);
    return *slot;
}

static const double *pos(const mc *m, vm_index v) {
    return m->surf->points + 3 * (size_t)v;
}

/* Smallest angle of triangle (a, b, c) in degrees; 0 when degenerate or flat. */
static double tri_min_angle(const double *a, const double *b, const double *c) {
    double p[3][3];
    for (int x = 0; x < 3; x++) {
        p[0][x] = a[x];
        p[1][x] = b[x];
        p[2][x] = c[x];
    }
    return vm_tri_min_angle((const double(*)[3])p);
}

static vm_status emit(mc *m, vm_index a, vm_index b, vm_index c) {
    vm_index t[3] = {a, b, c};
    return vm_mesh_add_cell(m->surf, t, 1, m->err);
}

static vm_status fail(const mc *m) {
    return m->err ? m->err->status : VM_ERR_NOMEM;
}

/* ---- triangulating the pieces ---------------------------------------------------------- */

#define MC_MAXPOLY 16

/* Triangulates the polygon v[0..n-1] (oriented; fm[i]: faces of the cube holding v[i], 0
 * for none) by the triangulation that maximises the smallest angle, among those whose
 * diagonals never join two vertices of one cube face (such a chord would lie in the face,
 * where the neighbouring cube may use it too). Returns the smallest angle (> 0) and emits
 * the triangles when doit, 0 when there is no such triangulation, -1 on error. */
static double triangulate_polygon(mc *m, const vm_index *v, const int *fm, int n, int doit) {
    double best[MC_MAXPOLY][MC_MAXPOLY];
    int arg[MC_MAXPOLY][MC_MAXPOLY];
    for (int len = 1; len < n; len++)
        for (int i = 0; i + len < n; i++) {
            int j = i + len;
            if (len == 1) {
                best[i][j] = INFINITY;
                continue;
            }
            best[i][j] = -1;
            arg[i][j] = -1;
            int chord_ok = (i == 0 && j == n - 1) || !(fm[i] & fm[j]);
            if (!chord_ok) continue;
            for (int k = i + 1; k < j; k++) {
                double q = fmin(best[i][k], best[k][j]);
                if (q <= 0) continue;
                q = fmin(q, tri_min_angle(pos(m, v[i]), pos(m, v[k]), pos(m, v[j])));
                if (q > best[i][j]) {
                    best[i][j] = q;
                    arg[i][j] = k;
                }
            }
        }
    if (!(best[0][n - 1] > 0)) return 0;
    if (!doit) return best[0][n - 1];
    int stack[MC_MAXPOLY][2], top = 0;
    stack[top][0] = 0;
    stack[top++][1] = n - 1;
    while (top) {
        top--;
        int i = stack[top][0], j = stack[top][1];
        if (j - i < 2) continue;
        int k = arg[i][j];
        if (emit(m, v[i], v[k], v[j])) return -1;
        stack[top][0] = i;
        stack[top++][1] = k;
        stack[top][0] = k;
        stack[top++][1] = j;
    }
    return best[0][n - 1];
}

/* Fan of the polygon v[0..n-1] around a new vertex at its mean (inside the cube, on none of
 * its faces, so none of the new edges can be used by a neighbour). */
static vm_status fan_around_centre(mc *m, const vm_index *v, int n) {
    double c[3] = {0, 0, 0};
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            c[a] += pos(m, v[i])[a] / n;
    vm_index ci = vm_mesh_add_point(m->surf, c, m->err);
    if (ci < 0) return fail(m);
    m->centres++;
    for (int i = 0; i < n; i++)
        if (emit(m, ci, v[i], v[(i + 1) % n])) return fail(m);
    return VM_OK;
}

static double tri_area(const double *a, const double *b, const double *c) {
    double e1[3], e2[3], n[3];
    vm__sub3(b, a, e1);
    vm__sub3(c, a, e2);
    vm__cross3(e1, e2, n);
    return 0.5 * vm__norm3(n);
}

/* Smallest area of a band from the rung u[i0] - w[j0], and its steps (path[s], s from the
 * last step back: 1 along u, 2 along w), INFINITY when no band starts there. The state
 * (a, b) is the rung u[i0 + a], w[j0 - b]; from (0,0) to (nu, nw), the first step along u,
 * the last along w, never through (nu, 0): no rung is used twice. */
static double band_from(const mc *m, const vm_index *u, const int *fu, int nu,
                        const vm_index *w, const int *fw, int nw, int i0, int j0,
                        unsigned char *path) {
    double q[MC_MAXPOLY + 1][MC_MAXPOLY + 1];
    unsigned char from[MC_MAXPOLY + 1][MC_MAXPOLY + 1];
    if (nu < 1 || nw < 1 || nu > MC_MAXPOLY || nw > MC_MAXPOLY) return INFINITY;
    for (int a = 0; a <= MC_MAXPOLY; a++)
        for (int b = 0; b <= MC_MAXPOLY; b++)
            q[a][b] = INFINITY; /* all of it: the compiler cannot see nu, nw <= MC_MAXPOLY */
    for (int a = 0; a <= nu; a++)
        for (int b = 0; b <= nw; b++) {
            int iu = (i0 + a) % nu, iw = ((j0 - b) % nw + nw) % nw;
            q[a][b] = INFINITY;
            from[a][b] = 0;
            if (fu[iu] & fw[iw]) continue;
            if (a == 0 && b == 0) {
                q[a][b] = 0;
                continue;
            }
            if (a == 0 || (a == nu && b == 0)) continue;
            if (q[a - 1][b] < INFINITY && !(a == nu && b == nw)) {
                const double *p0 = pos(m, u[(i0 + a - 1) % nu]), *p1 = pos(m, u[iu]),
                             *p2 = pos(m, w[iw]);
                if (tri_min_angle(p0, p1, p2) > 0) {
                    double c = q[a - 1][b] + tri_area(p0, p1, p2);
                    if (c < q[a][b]) {
                        q[a][b] = c;
                        from[a][b] = 1;
                    }
                }
            }
            if (b > 0 && q[a][b - 1] < INFINITY) {
                const double *p0 = pos(m, w[iw]),
                             *p1 = pos(m, w[((j0 - b + 1) % nw + nw) % nw]),
                             *p2 = pos(m, u[iu]);
                if (tri_min_angle(p0, p1, p2) > 0) {
                    double c = q[a][b - 1] + tri_area(p0, p1, p2);
                    if (c < q[a][b]) {
                        q[a][b] = c;
                        from[a][b] = 2;
                    }
                }
            }
        }
    double total = q[nu][nw];
    if (path && total < INFINITY) {
        int a = nu, b = nw, s = 0;
        while (a || b) {
            path[s++] = from[a][b];
            if (from[a][b] == 1)
                a--;
            else
                b--;
        }
    }
    return total;
}

/* Annulus between loops u (nu) and w (nw), both oriented as the boundary of the piece: a
 * band of nu + nw triangles whose rungs join u[i] to w[j]; u is walked forward and w
 * backward. For every start rung the band of smallest area (the least twisted tube) with no
 * flat triangle and no rung joining two vertices of one cube face; the bands are ranked by
 * area and the rank-th is emitted (rank 0: the least twisted). Returns 1, 0 (fewer than
 * rank + 1 bands) or -1. */
static int triangulate_band(mc *m, const vm_index *u, const int *fu, int nu, const vm_index *w,
                            const int *fw, int nw, int rank) {
    double cost[MC_MAXPOLY * MC_MAXPOLY];
    int nc = 0;
    for (int i0 = 0; i0 < nu; i0++)
        for (int j0 = 0; j0 < nw; j0++) {
            cost[i0 * nw + j0] = band_from(m, u, fu, nu, w, fw, nw, i0, j0, NULL);
            nc += cost[i0 * nw + j0] < INFINITY;
        }
    if (rank >= nc) return 0;
    /* the rank-th finite cost, ties broken by start index (deterministic) */
    int pick = -1;
    unsigned char used[MC_MAXPOLY * MC_MAXPOLY] = {0};
    for (int r = 0; r <= rank; r++) {
        pick = -1;
        for (int x = 0; x < nu * nw; x++)
            if (!used[x] && cost[x] < INFINITY && (pick < 0 || cost[x] < cost[pick])) pick = x;
        used[pick] = 1;
    }
    int i0 = pick / nw, j0 = pick % nw;
    unsigned char path[2 * MC_MAXPOLY];
    band_from(m, u, fu, nu, w, fw, nw, i0, j0, path);
    int a = 0, b = 0;
    for (int s = nu + nw - 1; s >= 0; s--) {
        int iu = (i0 + a) % nu, iw = ((j0 - b) % nw + nw) % nw;
        vm_status st;
        if (path[s] == 1) {
            st = emit(m, u[iu], u[(iu + 1) % nu], w[iw]);
            a++;
        } else {
            st = emit(m, w[(iw + nw - 1) % nw], w[iw], u[iu]);
            b++;
        }
        if (st) return -1;
    }
    return 1;
}

/* Annulus between loops u and w through a ring of new vertices inside the cube: w shrunk by
 * the factor shrink toward the point c, a collar of 2 nw triangles from w to the ring, and a
 * band from u to the ring (whose rungs are free). Used when no band joins the loops
 * directly (every rung would lie in a cube face) or when the direct bands cross the cube's
 * other triangles. Returns 1, 0 (no band to the ring) or -1. */
static int triangulate_tube_ring(mc *m, const vm_index *u, const int *fu, int nu,
                                 const vm_index *w, int nw, const double c[3], double shrink) {
    vm_index ring[MC_MAXPOLY];
    int free_fm[MC_MAXPOLY] = {0};
    for (int i = 0; i < nw; i++) {
        double p[3];
        for (int a = 0; a < 3; a++)
            p[a] = (1 - shrink) * pos(m, w[i])[a] + shrink * c[a];
        ring[i] = vm_mesh_add_point(m->surf, p, m->err);
        if (ring[i] < 0) return -1;
        m->centres++;
    }
    for (int i = 0; i < nw; i++) {
        int i1 = (i + 1) % nw;
        if (emit(m, w[i], w[i1], ring[i1]) || emit(m, w[i], ring[i1], ring[i])) return -1;
    }
    return triangulate_band(m, u, fu, nu, ring, free_fm, nw, 0);
}

/* A sphere with k >= 2 holes around one new centre vertex at cpos: the loops are opened at
 * one edge each and chained into a single cycle fanned to the centre (the links
 * last_i -> first_i+1 join no two vertices of one face); the 2k edges left (the opened edges
 * and the links, backwards) form one more polygon, triangulated as a disk, or fanned around
 * a second centre when no triangulation avoids the face chords. Returns 1, 0 (no fan
 * without flat triangles) or -1. */
static int triangulate_around_centre(mc *m, int k, const vm_index loops[][12],
                                     const int fms[][12], const int *len,
                                     const double cpos[3]) {
    int rot[4] = {0, 0, 0, 0}, best_rot[4] = {0, 0, 0, 0};
    double best_q = 0;
    int best_poly = 0, combos = 1;
    for (int i = 0; i < k; i++)
        combos *= len[i];
    vm_index c = vm_mesh_add_point(m->surf, cpos, m->err);
    if (c < 0) return -1;
    m->centres++;
    vm_index poly[8];
    int pfm[8];
    for (int combo = 0; combo < combos; combo++) {
        int x = combo;
        for (int i = 0; i < k; i++) {
            rot[i] = x % len[i];
            x /= len[i];
        }
        /* first_i = loops[i][rot], last_i = loops[i][rot - 1] */
        double qmin = INFINITY;
        int ok = 1;
        for (int i = 0; i < k && ok; i++) {
            int n = len[i], r = rot[i], nx = (i + 1) % k, r1 = rot[nx];
            int last = (r + n - 1) % n;
            if (fms[i][last] & fms[nx][r1]) ok = 0;
            for (int j = 0; j + 1 < n && ok; j++)
                qmin = fmin(qmin, tri_min_angle(pos(m, c), pos(m, loops[i][(r + j) % n]),
                                                pos(m, loops[i][(r + j + 1) % n])));
            qmin = fmin(
                qmin, tri_min_angle(pos(m, c), pos(m, loops[i][last]), pos(m, loops[nx][r1])));
        }
        if (!ok || !(qmin > 0)) continue;
        /* the remaining polygon: last_1, first_1, last_k, first_k, ..., last_2, first_2 */
        int np = 0;
        for (int s = 0; s < k; s++) {
            int i = s == 0 ? 0 : k - s, n = len[i], r = rot[i], last = (r + n - 1) % n;
            poly[np] = loops[i][last];
            pfm[np++] = fms[i][last];
            poly[np] = loops[i][r];
            pfm[np++] = fms[i][r];
        }
        double pq = triangulate_polygon(m, poly, pfm, np, 0);
        int has_poly = pq > 0;
        if (has_poly) qmin = fmin(qmin, pq);
        if (has_poly > best_poly || (has_poly == best_poly && qmin > best_q)) {
            best_poly = has_poly;
            best_q = qmin;
            memcpy(best_rot, rot, sizeof rot);
        }
    }
    if (!(best_q > 0)) return 0;
    int np = 0;
    for (int s = 0; s < k; s++) {
        int i = s == 0 ? 0 : k - s, n = len[i], r = best_rot[i], last = (r + n - 1) % n;
        poly[np] = loops[i][last];
        pfm[np++] = fms[i][last];
        poly[np] = loops[i][r];
        pfm[np++] = fms[i][r];
    }
    if (best_poly) {
        if (triangulate_polygon(m, poly, pfm, np, 1) < 0) return -1;
    } else if (fan_around_centre(m, poly, np)) {
        return -1;
    }
    for (int i = 0; i < k; i++) {
        int n = len[i], r = best_rot[i], nx = (i + 1) % k;
        for (int j = 0; j + 1 < n; j++)
            if (emit(m, c, loops[i][(r + j) % n], loops[i][(r + j + 1) % n])) return -1;
        if (emit(m, c, loops[i][(r + n - 1) % n], loops[nx][best_rot[nx]])) return -1;
    }
    return 1;
}

/* Mean of the vertices of loop v[0..n-1]. */
static void loop_mean(const mc *m, const vm_index *v, int n, double c[3]) {
    c[0] = c[1] = c[2] = 0;
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            c[a] += pos(m, v[i])[a] / n;
}

/* The candidate triangulations of a tunnel piece (k >= 2 loops), in order of preference:
 * the bands between two loops ranked by area; then rings, one loop shrunk toward a point
 * (the mean of the loops, points between the loops' means, then the points of a grid over
 * the cube's interior) by 0.5, 0.3 or 0.7, and banded to the other loop; then fans around
 * one centre vertex at such points. Variant `variant` is emitted; returns 1, 0 when that
 * variant does not exist for this piece, or -1. */
#define MC_GRID 5 /* grid points per axis */
#define MC_GRID3 (MC_GRID * MC_GRID * MC_GRID)
#define MC_POINTS (5 + MC_GRID3)
#define MC_BAND_VARIANTS (MC_MAXPOLY * MC_MAXPOLY)
#define MC_RING_VARIANTS (2 * 3 * MC_POINTS)
#define MC_TUNNEL_VARIANTS (MC_BAND_VARIANTS + MC_RING_VARIANTS + MC_POINTS)

/* Candidate point q of a tunnel between k loops with means lm and overall mean: 0 the mean,
 * 1..4 toward each loop (k > 2) or along the segment between the two loops' means (k = 2),
 * then the grid over the cube. Returns 0 when q does not exist. */
static int tunnel_point(const mc *m, int k, double lm[][3], const double mean[3], int q,
                        double c[3]) {
    if (q == 0) {
        memcpy(c, mean, 3 * sizeof *c);
        return 1;
    }
    if (q < 5) {
        static const double along[4] = {0.5, 0.3, 0.7, 0.15};
        if (k > 2 && q > k) return 0;
        for (int a = 0; a < 3; a++)
            c[a] = k > 2 ? 0.6 * mean[a] + 0.4 * lm[q - 1][a]
                         : lm[0][a] + along[q - 1] * (lm[1][a] - lm[0][a]);
        return 1;
    }
    int g = q - 5;
    c[0] = m->cube0[0] + (0.5 + g % MC_GRID) / MC_GRID;
    c[1] = m->cube0[1] + (0.5 + (g / MC_GRID) % MC_GRID) / MC_GRID;
    c[2] = m->cube0[2] + (0.5 + g / (MC_GRID * MC_GRID)) / MC_GRID;
    return 1;
}

static int tunnel_variant(mc *m, int k, const vm_index v[][12], const int fm[][12],
                          const int *len, int variant) {
    double mean[3] = {0, 0, 0}, lm[4][3], c[3];
    int nall = 0;
    for (int i = 0; i < k; i++) {
        loop_mean(m, v[i], len[i], lm[i]);
        nall += len[i];
        for (int a = 0; a < 3; a++)
            mean[a] += lm[i][a] * len[i];
    }
    for (int a = 0; a < 3; a++)
        mean[a] /= nall;
    if (variant < MC_BAND_VARIANTS) {
        if (k != 2) return 0;
        return triangulate_band(m, v[0], fm[0], len[0], v[1], fm[1], len[1], variant);
    }
    variant -= MC_BAND_VARIANTS;
    if (variant < MC_RING_VARIANTS) {
        static const double shrink[3] = {0.5, 0.3, 0.7};
        int side = variant / (3 * MC_POINTS), q = (variant / 3) % MC_POINTS;
        if (k != 2 || !tunnel_point(m, k, lm, mean, q, c)) return 0;
        int big = (len[0] >= len[1]) != side ? 0 : 1; /* side 0: ring on the smaller loop */
        return triangulate_tube_ring(m, v[big], fm[big], len[big], v[1 - big], len[1 - big], c,
                                     shrink[variant % 3]);
    }
    variant -= MC_RING_VARIANTS;
    if (variant >= MC_POINTS || !tunnel_point(m, k, lm, mean, variant, c)) return 0;
    return triangulate_around_centre(m, k, v, fm, len, c);
}

/* One disk: the best triangulation of its loop, else a fan around a centre vertex. */
static vm_status piece_disk(mc *m, const vm_index *v, const int *fm, int n) {
    double r = triangulate_polygon(m, v, fm, n, 1);
    if (r < 0) return fail(m);
    if (r > 0) return VM_OK;
    return fan_around_centre(m, v, n);
}

/* ---- one cube -----------------------------------------------------------------------------
 */

static int uf_find(int *p, int x) {
    while (p[x] != x)
        x = p[x] = p[p[x]];
    return x;
}

static void uf_union(int *p, int a, int b) {
    a = uf_find(p, a);
    b = uf_find(p, b);
    if (a != b) p[a < b ? b : a] = a < b ? a : b;
}

/* Interior connections, by sweeping the cube with the planes z = t. Every slice is a
 * bilinear square whose inside is joined to its corners, the points of the four vertical
 * edges at height t; two adjacent ones meet on a side face (already on the boundary), and
 * a diagonal pair of one sign whose other two corners have the other sign is joined
 * across the slice when its product beats theirs, Q(t) = f_d1 f_d2 - f_o1 f_o2 (> 0 for
 * the negative pair, >= 0 for the positive one: zero counts as inside). Q is quadratic in
 * t; where its maximum lies strictly inside the interval of t with that sign pattern, the
 * pair is joined through the cube's interior (a tunnel). Ends of the interval are faces or
 * sign changes along a side, which the boundary already accounts for. */
static void interior_joins(const double s[8], int *parent) {
    static const int diag[2][2] = {{0, 3}, {1, 2}}, other[2][2] = {{1, 2}, {0, 3}};
    for (int d = 0; d < 2; d++)
        for (int sg = 1; sg >= -1; sg -= 2) {
            double lo = 0, hi = 1;
            int strands[4] = {diag[d][0], diag[d][1], other[d][0], other[d][1]};
            for (int q = 0; q < 4 && lo < hi; q++) {
                double b = s[strands[q]], t = s[strands[q] + 4];
                double want = q < 2 ? sg : -sg; /* sign the strand must have */
                int pb = want * b > 0, pt = want * t > 0;
                if (pb && pt) continue;
                if (!pb && !pt) {
                    hi = lo;
                    break;
                }
                double z = b / (b - t);
                if (pb)
                    hi = fmin(hi, z);
                else
                    lo = fmax(lo, z);
            }
            if (!(lo < hi)) continue;
            double b1 = s[diag[d][0]], m1 = s[diag[d][0] + 4] - b1;
            double b2 = s[diag[d][1]], m2 = s[diag[d][1] + 4] - b2;
            double b3 = s[other[d][0]], m3 = s[other[d][0] + 4] - b3;
            double b4 = s[other[d][1]], m4 = s[other[d][1] + 4] - b4;
            double A = m1 * m2 - m3 * m4, B = b1 * m2 + b2 * m1 - b3 * m4 - b4 * m3;
            double C = b1 * b2 - b3 * b4;
            if (!(A < 0)) continue;
            double ts = -B / (2 * A);
            if (!(ts > lo && ts < hi)) continue;
            double qv = (A * ts + B) * ts + C;
            if (sg > 0 ? qv >= 0 : qv > 0) {
                int c1 = sg * b1 > 0 ? diag[d][0] : diag[d][0] + 4;
                int c2 = sg * b2 > 0 ? diag[d][1] : diag[d][1] + 4;
                uf_union(parent, c1, c2);
            }
        }
}

/* Pairs of crossing triangles (in the sense of vm_mesh_check) with one triangle from
 * piece_first on and the other from cube_first on. */
static size_t piece_crossings(const mc *m, size_t cube_first, size_t piece_first) {
    const vm_mesh *s = m->surf;
    size_t n = 0;
    for (size_t a = piece_first; a < s->ncells; a++)
        for (size_t b = cube_first; b < a; b++) {
            const vm_index *ia = s->cells + 3 * a, *ib = s->cells + 3 * b;
            const double *pa[3] = {pos(m, ia[0]), pos(m, ia[1]), pos(m, ia[2])};
            const double *pb[3] = {pos(m, ib[0]), pos(m, ib[1]), pos(m, ib[2])};
            n += (size_t)vm__tri_pair_intersects(pa, ia, pb, ib);
        }
    return n;
}

/* One candidate triangulation of a piece: a disk (k = 1) is its best polygon triangulation
 * (variant 0) or a fan around its mean (variant 1); a tunnel is tunnel_variant. Returns 1,
 * 0 (no such variant) or -1. */
static int piece_variant(mc *m, int k, const vm_index v[][12], const int fm[][12],
                         const int *len, int variant) {
    if (k >= 2) return tunnel_variant(m, k, v, fm, len, variant);
    if (variant == 0) {
        double r = triangulate_polygon(m, v[0], fm[0], len[0], 1);
        if (r < 0) return -1;
        if (r > 0) return 1;
        return fan_around_centre(m, v[0], len[0]) ? -1 : 1;
    }
    if (variant == 1) return fan_around_centre(m, v[0], len[0]) ? -1 : 1;
    return 0;
}

/* The pieces of one cube, in the order they are triangulated. */
typedef struct cube_pieces {
    int n;
    int k[6];             /* loops of each piece */
    vm_index v[6][4][12]; /* vertex ids of each loop */
    int fm[6][4][12];     /* cube faces holding each vertex */
    int len[6][4];
} cube_pieces;

static int piece_variants(const cube_pieces *cp, int p) {
    return cp->k[p] >= 2 ? MC_TUNNEL_VARIANTS : 2;
}

static int emit_piece(mc *m, const cube_pieces *cp, int p, int variant) {
    return piece_variant(m, cp->k[p], (const vm_index(*)[12])cp->v[p],
                         (const int(*)[12])cp->fm[p], cp->len[p], variant);
}

static void undo_to(mc *m, size_t cells, size_t points, size_t centres) {
    m->surf->ncells = cells;
    m->surf->npoints = points;
    m->centres = centres;
}

/* Depth-first search for candidate triangulations of pieces p.. that cross neither
 * themselves nor each other nor the pieces before p (triangles from cube_first on), at most
 * *budget candidates in all. Returns 1 with the triangles emitted, 0 with nothing emitted
 * (none found within the budget), -1 on error. */
static int search_pieces(mc *m, const cube_pieces *cp, int p, size_t cube_first, int *budget) {
    if (p == cp->n) return 1;
    size_t cells = m->surf->ncells, points = m->surf->npoints, centres = m->centres;
    for (int var = 0; var < piece_variants(cp, p) && *budget > 0; var++) {
        int r = emit_piece(m, cp, p, var);
        if (r < 0) return -1;
        if (r > 0) {
            --*budget;
            if (piece_crossings(m, cube_first, cells) == 0) {
                r = search_pieces(m, cp, p + 1, cube_first, budget);
                if (r != 0) return r;
            }
        }
        undo_to(m, cells, points, centres);
    }
    return 0;
}

/* Piece p alone, when the search found nothing: its candidate with the fewest crossings
 * with the triangles from cube_first on (check = 0: its first candidate). */
static vm_status fewest_crossings(mc *m, const cube_pieces *cp, int p, size_t cube_first,
                                  int check) {
    size_t cells = m->surf->ncells, points = m->surf->npoints, centres = m->centres;
    size_t best_x = SIZE_MAX;
    int best = -1;
    for (int var = 0; var < piece_variants(cp, p); var++) {
        int r = emit_piece(m, cp, p, var);
        if (r < 0) return fail(m);
        if (r == 0) {
            undo_to(m, cells, points, centres);
            continue;
        }
        size_t x = check ? piece_crossings(m, cube_first, cells) : 0;
        if (x == 0) return VM_OK;
        if (x < best_x) {
            best_x = x;
            best = var;
        }
        undo_to(m, cells, points, centres);
    }
    if (best < 0)
        return vm_error_set(m->err, VM_ERR_INTERNAL,
                            "surface mc: a piece with %d loops found no triangulation",
                            cp->k[p]);
    return emit_piece(m, cp, p, best) < 0 ? fail(m) : VM_OK;
}

/* Searched candidates per cube before giving up on a crossing-free triangulation. */
#define MC_SEARCH_BUDGET 20000

/* The face segments of a cube with corner values s (in: corner inside), entry -> exit, as
 * next[entry edge] = exit edge (-1: no crossing): walking a face counter-clockwise from
 * outside, an edge from an outside to an inside corner is an entry; the segment keeps the
 * inside on its right, as the boundary of a piece of surface whose normal points outside.
 * The corners a face joins through its inside are united in parent. */
static void face_segments(const cube_geom *cg, const double s[8], const int in[8],
                          int parent[8], int next[12]) {
    for (int e = 0; e < 12; e++)
        next[e] = -1;
    for (int f = 0; f < 6; f++) {
        const int *fc = cg->face_c[f], *fe = cg->face_e[f];
        int entry[4], ncross = 0;
        for (int q = 0; q < 4; q++) {
            int a = in[fc[q]], b = in[fc[(q + 1) % 4]];
            entry[q] = !a && b;
            ncross += a != b;
        }
        if (ncross == 0) continue;
        int joined = 0;
        if (ncross == 4) {
            joined = face_joins_inside(s[fc[0]], s[fc[1]], s[fc[2]], s[fc[3]]);
            int first = in[fc[0]] == joined ? 0 : 1; /* the diagonal that is joined */
            uf_union(parent, fc[first], fc[first + 2]);
        }
        for (int q = 0; q < 4; q++) {
            if (!entry[q]) continue;
            int x = -1;
            if (ncross == 2) {
                for (int r = 1; r < 4; r++)
                    if (in[fc[(q + r) % 4]] && !in[fc[(q + r + 1) % 4]]) x = (q + r) % 4;
            } else {
                x = joined ? (q + 3) % 4 : (q + 1) % 4;
            }
            next[fe[q]] = fe[x];
        }
    }
}

/* The iso-line loops of a cube: the edges of each (e, n), and the inside and outside
 * regions it separates (key = inside root * 8 + outside root). */
typedef struct cube_loops {
    int e[6][12], n[6], key[6], count;
} cube_loops;

/* Follows next into loops L, each keyed by the regions of parent it separates. */
static vm_status follow_loops(mc *m, const int in[8], const int next[12], int parent[8],
                              cube_loops *L) {
    const cube_geom *cg = &m->cg;
    int seen = 0;
    L->count = 0;
    for (int e = 0; e < 12; e++) {
        if (next[e] < 0 || (seen & (1 << e))) continue;
        if (L->count == 6) return vm_error_set(m->err, VM_ERR_INTERNAL, "surface mc: loops");
        int n = 0, x = e;
        do {
            seen |= 1 << x;
            L->e[L->count][n++] = x;
            x = next[x];
        } while (x != e && x >= 0 && n < 12);
        if (x != e) return vm_error_set(m->err, VM_ERR_INTERNAL, "surface mc: open loop");
        int c0 = cg->edge_c[e][0], c1 = cg->edge_c[e][1];
        int cin = in[c0] ? c0 : c1, cout = in[c0] ? c1 : c0;
        L->key[L->count] = uf_find(parent, cin) * 8 + uf_find(parent, cout);
        L->n[L->count++] = n;
    }
    return VM_OK;
}

/* Pieces: the loops of L between the same inside and outside region of the cube (vertex
 * ids vid per edge), the disks first, then the tunnels (*tunnels counts them). */
static vm_status group_pieces(mc *m, const cube_loops *L, const vm_index vid[12],
                              cube_pieces *cp, int *tunnels) {
    const cube_geom *cg = &m->cg;
    int done = 0;
    cp->n = 0;
    *tunnels = 0;
    for (int pass = 0; pass < 2; pass++) /* the disks first, then the tunnels */
        for (int l = 0; l < L->count; l++) {
            if (done & (1 << l)) continue;
            int np = 0;
            for (int l2 = 0; l2 < L->count; l2++)
                np += L->key[l2] == L->key[l];
            if ((np > 1) != pass) continue;
            if (np > 4) return vm_error_set(m->err, VM_ERR_INTERNAL, "surface mc: pieces");
            np = 0;
            for (int l2 = l; l2 < L->count; l2++) {
                if ((done & (1 << l2)) || L->key[l2] != L->key[l]) continue;
                done |= 1 << l2;
                for (int q = 0; q < L->n[l2]; q++) {
                    cp->v[cp->n][np][q] = vid[L->e[l2][q]];
                    cp->fm[cp->n][np][q] = cg->edge_faces[L->e[l2][q]];
                }
                cp->len[cp->n][np++] = L->n[l2];
            }
            *tunnels += np > 1;
            cp->k[cp->n++] = np;
        }
    return VM_OK;
}

/* The surface in cube (i, j, k): face segments, loops, their vertices, pieces, and each
 * piece's triangulation. */
static vm_status do_cube(mc *m, int64_t i, int64_t j, int64_t k) {
    const cube_geom *cg = &m->cg;
    double s[8];
    int in[8], mask = 0;
    for (int c = 0; c < 8; c++) {
        s[c] = value(m, i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
        in[c] = s[c] > 0;
        mask |= in[c] << c;
    }
    if (mask == 0 || mask == 255) return VM_OK;
    m->cube0[0] = (double)i;
    m->cube0[1] = (double)j;
    m->cube0[2] = (double)k;

    int parent[8];
    for (int c = 0; c < 8; c++)
        parent[c] = c;
    for (int e = 0; e < 12; e++)
        if (in[cg->edge_c[e][0]] == in[cg->edge_c[e][1]])
            uf_union(parent, cg->edge_c[e][0], cg->edge_c[e][1]);
    int next[12];
    face_segments(cg, s, in, parent, next);
    interior_joins(s, parent);
    cube_loops L;
    vm_status st = follow_loops(m, in, next, parent, &L);
    if (st) return st;

    /* Vertex ids of the crossings. */
    vm_index vid[12] = {0};
    for (int e = 0; e < 12; e++) {
        if (next[e] < 0) continue;
        int c0 = cg->edge_c[e][0];
        vid[e] =
            edge_vertex(m, cg->edge_axis[e], i + (c0 & 1), j + ((c0 >> 1) & 1), k + (c0 >> 2));
        if (vid[e] < 0) return fail(m);
    }

    /* When the cube has more than one piece or a tunnel, each piece takes the first of its
     * candidate triangulations that crosses neither itself nor the pieces made before it
     * (a thin, twisted tunnel may need a ring of vertices inside the cube, or a centre
     * vertex). */
    cube_pieces cp;
    int tunnels = 0;
    st = group_pieces(m, &L, vid, &cp, &tunnels);
    if (st) return st;
    size_t cube_first = m->surf->ncells;
    int check = tunnels > 0 || cp.n > 1;
    if (check) {
        int budget = MC_SEARCH_BUDGET;
        int r = search_pieces(m, &cp, 0, cube_first, &budget);
        if (r < 0) return fail(m);
        if (r > 0) return VM_OK;
    }
    for (int p = 0; p < cp.n; p++) {
        st = fewest_crossings(m, &cp, p, cube_first, check);
        if (st) return st;
    }
    return VM_OK;
}

/* ---- the border: marching squares on the box faces ------------------------------------- */

/* Square with corners p[4] (grid points, counter-clockwise seen from outside the box):
 * the inside part, as convex polygons keeping the inside on their left. */
static vm_status do_border_square(mc *m, const int64_t p[4][3]) {
    double s[4];
    int in[4], nin = 0;
    for (int q = 0; q < 4; q++) {
        s[q] = value(m, p[q][0], p[q][1], p[q][2]);
        in[q] = s[q] > 0;
        nin += in[q];
    }
    if (nin == 0) return VM_OK;
    vm_index corner[4], cross[4];
    for (int q = 0; q < 4; q++) {
        corner[q] = cross[q] = -1;
        if (in[q]) {
            corner[q] = point_vertex(m, p[q][0], p[q][1], p[q][2]);
            if (corner[q] < 0) return fail(m);
        }
        int r = (q + 1) % 4;
        if (in[q] != in[r]) {
            int axis = 0;
            int64_t lo[3];
            for (int a = 0; a < 3; a++) {
                if (p[q][a] != p[r][a]) axis = a;
                lo[a] = p[q][a] < p[r][a] ? p[q][a] : p[r][a];
            }
            cross[q] = edge_vertex(m, axis, lo[0], lo[1], lo[2]);
            if (cross[q] < 0) return fail(m);
        }
    }
    static const int none[MC_MAXPOLY] = {0};
    if (nin == 4) return piece_disk(m, corner, none, 4);
    int joined = 1; /* after an exit, the walk goes on to the next entry */
    if (nin == 2 && in[0] == in[2]) joined = face_joins_inside(s[0], s[1], s[2], s[3]);
    int used = 0;
    for (int q0 = 0; q0 < 4; q0++) {
        if (!(!in[q0] && in[(q0 + 1) % 4]) || (used & (1 << q0))) continue;
        vm_index poly[8];
        int n = 0, q = q0;
        do {
            used |= 1 << q; /* entry edge q */
            poly[n++] = cross[q];
            int c = (q + 1) % 4;
            while (in[c]) {
                poly[n++] = corner[c];
                c = (c + 1) % 4;
            }
            poly[n++] = cross[(c + 3) % 4]; /* the exit */
            if (!joined) break;
            q = c; /* corner c is outside: on to the next entry */
            while (!(!in[q] && in[(q + 1) % 4]))
                q = (q + 1) % 4;
        } while (q != q0);
        vm_status st = piece_disk(m, poly, none, n);
        if (st) return st;
    }
    return VM_OK;
}

/* Border squares of cube layer k (between z = k and k + 1): the four side faces, and the
 * bottom and top faces on the first and last layer. */
static vm_status do_border_layer(mc *m, int64_t k) {
    const int64_t n[3] = {m->nx, m->ny, m->nz};
    static const int uv[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int a = 0; a < 3; a++) {
        int u = (a + 1) % 3, v = (a + 2) % 3;
        for (int side = 0; side < 2; side++) {
            int64_t at = side ? n[a] - 1 : 0;
            int64_t ulo = 0, uhi = n[u] - 1, vlo = 0, vhi = n[v] - 1;
            if (a == 2) {
                if (side ? k + 1 != n[2] - 1 : k != 0) continue;
            } else if (u == 2) {
                ulo = k;
                uhi = k + 1;
            } else {
                vlo = k;
                vhi = k + 1;
            }
            for (int64_t jv = vlo; jv < vhi; jv++)
                for (int64_t ju = ulo; ju < uhi; ju++) {
                    int64_t p[4][3];
                    for (int q = 0; q < 4; q++) {
                        int r = side ? q : 3 - q;
                        p[q][a] = at;
                        p[q][u] = ju + uv[r][0];
                        p[q][v] = jv + uv[r][1];
                    }
                    vm_status st = do_border_square(m, (const int64_t(*)[3])p);
                    if (st) return st;
                }
        }
    }
    return VM_OK;
}

static vm_status alloc_ids(vm_index **p, size_t n, vm_error *err) {
    *p = malloc((n ? n : 1) * sizeof **p);
    if (!*p) return vm_error_set(err, VM_ERR_NOMEM, "surface mc: out of memory");
    for (size_t i = 0; i < n; i++)
        (*p)[i] = -1;
    return VM_OK;
}

static void reset_ids(vm_index *p, size_t n) {
    for (size_t i = 0; i < n; i++)
        p[i] = -1;
}

vm_status vm__surface_mc(const vm__surface_grid *g, const vm_surface_options *o, vm_mesh *surf,
                         vm_surface_stats *st, vm_error *err) {
    mc m;
    memset(&m, 0, sizeof m);
    m.g = g;
    m.surf = surf;
    m.err = err;
    m.nx = g->n[0];
    m.ny = g->n[1];
    m.nz = g->n[2];
    cube_geom_init(&m.cg);
    size_t nxy = (size_t)(m.nx * m.ny), nxe = (size_t)((m.nx - 1) * m.ny),
           nye = (size_t)(m.nx * (m.ny - 1));
    vm_status s = VM_OK;
    for (int l = 0; l < 2 && !s; l++) {
        s = alloc_ids(&m.ex[l], nxe, err);
        if (!s) s = alloc_ids(&m.ey[l], nye, err);
        if (!s) s = alloc_ids(&m.pv[l], nxy, err);
    }
    if (!s) s = alloc_ids(&m.ez, nxy, err);
    for (int64_t k = 0; k + 1 < m.nz && !s; k++) {
        m.k0 = k;
        for (int64_t j = 0; j + 1 < m.ny && !s; j++)
            for (int64_t i = 0; i + 1 < m.nx && !s; i++)
                s = do_cube(&m, i, j, k);
        if (!s) s = do_border_layer(&m, k);
        /* layer k + 1 becomes the lower one */
        vm_index *t;
        t = m.ex[0], m.ex[0] = m.ex[1], m.ex[1] = t;
        t = m.ey[0], m.ey[0] = m.ey[1], m.ey[1] = t;
        t = m.pv[0], m.pv[0] = m.pv[1], m.pv[1] = t;
        reset_ids(m.ex[1], nxe);
        reset_ids(m.ey[1], nye);
        reset_ids(m.pv[1], nxy);
        reset_ids(m.ez, nxy);
        if (!s && o->progress &&
            o->progress("marching cubes", (double)(k + 1), (double)(m.nz - 1),
                        o->progress_user))
            s = vm__cancelled(err, "surface");
    }
    if (st) {
        st->cells_visited = (size_t)((m.nx - 1) * (m.ny - 1) * (m.nz - 1));
        st->centre_vertices = m.centres;
    }
    for (int l = 0; l < 2; l++) {
        free(m.ex[l]);
        free(m.ey[l]);
        free(m.pv[l]);
    }
    free(m.ez);
    return s;
}
