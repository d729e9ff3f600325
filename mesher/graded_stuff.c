/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_stuff.c — isosurface stuffing over the graded lattice (Labelle and Shewchuk,
 * SIGGRAPH 2007, §4): cut points where lattice edges cross the surface (on the trilinear
 * field), lattice vertices warped onto a cut point that comes within alpha of them, and each
 * tet replaced by its inside part (one tet, a pyramid or a prism split by the smallest-vertex
 * rule, Dompierre et al. 1999, so that neighbours agree). volmesh warps a vertex only when
 * that is a simple-point move (the same-sign part of its link is a disk), so warping never
 * changes the topology, and undoes the warps of any tet a warp would turn over. */
#include "../core/core.h"
#include "../core/hash.h"
#include "graded_internal.h"
#include "mesher_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Warp thresholds of isosurface stuffing (fractions of the edge from the vertex). */
#define GR_ALPHA_LONG 0.24969
#define GR_ALPHA_SHORT 0.40173
#define GR_CUT_MIN 0.15
#define GR_ROUNDS 8
#define GR_CUT_BORDER 0.01

static const int tet_edge[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};

typedef struct stuff {
    const gr_lattice *L;
    const gr_tree *t;
    const gr_field *f;
    size_t nv, nt, ne;
    int32_t (*ev)[2]; /* edge ends */
    int32_t (*te)[6]; /* edges of each tet, in tet_edge order */
    double *cut;      /* cut parameter from ev[0] (NAN: not computed) */
    double *lpos;     /* lattice positions (3 per vertex) */
    double *pos;      /* positions after warping */
    double *val;      /* values after warping (0: on the surface) */
    double *delta;    /* assigned value - field value at the vertex (forced signs) */
    size_t *vt_start; /* vertex -> tets */
    int32_t *vt;
    size_t *ve_start; /* vertex -> edges */
    int32_t *ve;
    unsigned char *nowarp;
    unsigned char *keep; /* vertices of the exact cells: their warps keep their cuts */
    unsigned char *linear; /* per edge: place the cut by linear interpolation */
    int64_t (*piece)[4];
    int32_t *src; /* lattice tet of each piece */
    size_t np, pcap;
    int32_t cur;         /* the lattice tet being cut */
    size_t border_zeros; /* vertices put on the surface on the volume's border */
    int64_t root;
    gr_stuff_work *w; /* where the arrays above live between calls */
} stuff;

static vm_status nomem(vm_error *err) {
    return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory while stuffing the lattice");
}

/* The buffers a stuffing keeps in its gr_stuff_work, by use. */
enum {
    W_EV,
    W_TE,
    W_CUT,
    W_LPOS,
    W_POS,
    W_VAL,
    W_DELTA,
    W_NOWARP,
    W_LINEAR,
    W_VT_START,
    W_VT,
    W_VE_START,
    W_VE,
    W_PIECE,
    W_SRC,
    W_TMP1,
    W_TMP2,
    W_COUNT
};
_Static_assert((int)W_COUNT == (int)GR_STUFF_BUFFERS, "gr_stuff_work holds every buffer");

/* Buffer i of w with room for n bytes: the one kept from an earlier call when it is large
 * enough, else a fresh one with a quarter to spare (the next round's lattice is a little
 * larger), its contents undefined. NULL when out of memory. */
static void *take(gr_stuff_work *w, int i, size_t n) {
    if (n <= w->cap[i]) return w->buf[i];
    free(w->buf[i]);
    w->cap[i] = 0;
    size_t want = n + n / 4;
    w->buf[i] = malloc(want);
    if (!w->buf[i]) w->buf[i] = malloc(want = n);
    if (w->buf[i]) w->cap[i] = want;
    return w->buf[i];
}

/* Gives buffer i back: temporaries are not kept, or their pages would stay resident through
 * the stages that follow (the peak memory). */
static void give(gr_stuff_work *w, int i) {
    free(w->buf[i]);
    w->buf[i] = NULL;
    w->cap[i] = 0;
}

/* take, zeroed. */
static void *take_zero(gr_stuff_work *w, int i, size_t n) {
    void *p = take(w, i, n);
    if (p) memset(p, 0, n);
    return p;
}

void vm__gr_stuff_work_free(gr_stuff_work *w) {
    for (int i = 0; i < GR_STUFF_BUFFERS; i++)
        free(w->buf[i]);
    memset(w, 0, sizeof *w);
}

/* Unique edges of the tets: the tets' edge slots grouped by their lower vertex (a counting
 * sort, which walks memory in order where a hash table would miss the cache on every
 * lookup), then told apart by their upper vertex within each group. */
static vm_status build_edges(stuff *S, vm_error *err) {
    size_t ns = 6 * S->nt;
    if (ns >= (size_t)INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: over 2^31 lattice edges; raise --min-edge");
    size_t *start = take_zero(S->w, W_TMP1, (S->nv + 2) * sizeof *start);
    int32_t(*slot)[2] = take(S->w, W_TMP2, (ns + 1) * sizeof *slot); /* upper vertex, tet*6+k */
    S->ev = take(S->w, W_EV, (ns + 1) * sizeof *S->ev);
    S->te = take(S->w, W_TE, (S->nt + 1) * sizeof *S->te);
    if (!start || !slot || !S->ev || !S->te) return nomem(err);
    for (size_t t = 0; t < S->nt; t++)
        for (int k = 0; k < 6; k++) {
            int32_t a = S->L->tet[t][tet_edge[k][0]], b = S->L->tet[t][tet_edge[k][1]];
            start[(size_t)(a < b ? a : b) + 2]++;
        }
    for (size_t v = 0; v < S->nv; v++)
        start[v + 2] += start[v + 1];
    for (size_t t = 0; t < S->nt; t++)
        for (int k = 0; k < 6; k++) {
            int32_t a = S->L->tet[t][tet_edge[k][0]], b = S->L->tet[t][tet_edge[k][1]];
            size_t at = start[(size_t)(a < b ? a : b) + 1]++;
            slot[at][0] = a < b ? b : a;
            slot[at][1] = (int32_t)(6 * t + (size_t)k);
        }
    /* now start[v] .. start[v + 1] are vertex v's slots */
    S->ne = 0;
    for (size_t v = 0; v < S->nv; v++) {
        size_t first = S->ne;
        for (size_t i = start[v]; i < start[v + 1]; i++) {
            size_t e = first;
            while (e < S->ne && S->ev[e][1] != slot[i][0])
                e++;
            if (e == S->ne) {
                S->ev[e][0] = (int32_t)v;
                S->ev[e][1] = slot[i][0];
                S->ne++;
            }
            S->te[slot[i][1] / 6][slot[i][1] % 6] = (int32_t)e;
        }
    }
    give(S->w, W_TMP2);
    S->cut = take(S->w, W_CUT, (S->ne + 1) * sizeof *S->cut);
    if (!S->cut) return nomem(err);
    for (size_t e = 0; e < S->ne; e++)
        S->cut[e] = NAN;
    return VM_OK;
}

/* Compressed adjacency: for each vertex, the items (tets or edges) that use it. */
static vm_status adjacency(gr_stuff_work *w, int wstart, int wlist, size_t nv, size_t nitems,
                           int per, const int32_t *ids, size_t **start, int32_t **list,
                           vm_error *err) {
    *start = take_zero(w, wstart, (nv + 1) * sizeof **start);
    *list = take(w, wlist, (nitems * (size_t)per + 1) * sizeof **list);
    if (!*start || !*list) return nomem(err);
    for (size_t i = 0; i < nitems * (size_t)per; i++)
        (*start)[ids[i] + 1]++;
    for (size_t v = 0; v < nv; v++)
        (*start)[v + 1] += (*start)[v];
    size_t *fill = take(w, W_TMP1, (nv + 1) * sizeof *fill);
    if (!fill) return nomem(err);
    memcpy(fill, *start, (nv + 1) * sizeof *fill);
    for (size_t i = 0; i < nitems * (size_t)per; i++)
        (*list)[fill[ids[i]]++] = (int32_t)(i / (size_t)per);
    return VM_OK;
}

static int sgn(double x) {
    return x > 0 ? 1 : x < 0 ? -1 : 0;
}

/* Where the surface crosses edge e, as a fraction from ev[0]: regula falsi (Illinois) on the
 * field along the edge, corrected linearly so that it takes the ends' assigned values. */
static double cut_param(stuff *S, size_t e) {
    if (!isnan(S->cut[e])) return S->cut[e];
    int32_t a = S->ev[e][0], b = S->ev[e][1];
    const double *pa = S->lpos + 3 * (size_t)a, *pb = S->lpos + 3 * (size_t)b;
    double fa = S->L->phi[a], fb = S->L->phi[b], lo = 0, hi = 1;
    double da = S->delta[a], db = S->delta[b];
    int side = 0;
    double t = 0.5, best = INFINITY, tbest = 0.5;
    for (int it = 0; it < 60 && hi - lo > 1e-12; it++) {
        t = (lo * fb - hi * fa) / (fb - fa);
        if (!(t > lo && t < hi)) t = 0.5 * (lo + hi);
        double u[3] = {pa[0] + t * (pb[0] - pa[0]), pa[1] + t * (pb[1] - pa[1]),
                       pa[2] + t * (pb[2] - pa[2])};
        double ft = vm__gr_phi(S->f, u) + (1 - t) * da + t * db;
        if (fabs(ft) < best) {
            best = fabs(ft);
            tbest = t;
        }
        if (ft == 0) break;
        if ((ft > 0) == (fa > 0)) {
            lo = t;
            fa = ft;
            if (side == -1) fb *= 0.5;
            side = -1;
        } else {
            hi = t;
            fb = ft;
            if (side == 1) fa *= 0.5;
            side = 1;
        }
    }
    /* The field may jump (the volume's border): then the bracket, not the value, closes. */
    t = best < 1e-9 * fabs(S->f->out) ? tbest : 0.5 * (lo + hi);
    /* A cut this close to a vertex that could not be warped would make a sliver: it is
     * held GR_CUT_MIN of the edge away, or half the distance bound when that is less (the
     * surface moves by at most that much there). */
    double len = 0;
    for (int d = 0; d < 3; d++)
        len += (pb[d] - pa[d]) * (pb[d] - pa[d]);
    double tmin = fmin(GR_CUT_MIN, 0.5 * S->t->distance / sqrt(len));
    /* Across the volume's border the cut belongs on the border plane: held closer. */
    if (S->L->phi[a] == S->f->out || S->L->phi[b] == S->f->out)
        tmin = fmin(tmin, GR_CUT_BORDER);
    if (t < tmin) t = tmin;
    if (t > 1 - tmin) t = 1 - tmin;
    S->cut[e] = t;
    return t;
}

/* Whether moving v onto the surface keeps the topology: the part of its link with v's sign
 * is a disk (connected, Euler characteristic 1). */
enum { LINK_MAX = 192 };
static int simple_point(const stuff *S, int32_t v) {
    int sv = sgn(S->val[v]);
    int32_t lv[LINK_MAX], edges[3 * LINK_MAX][2];
    int nl = 0, ne = 0, T = 0, parent[LINK_MAX];
    for (size_t k = S->vt_start[v]; k < S->vt_start[v + 1]; k++) {
        const int32_t *tt = S->L->tet[S->vt[k]];
        int loc[3], m = 0, same = 0;
        for (int c = 0; c < 4; c++) {
            if (tt[c] == v) continue;
            int x = 0;
            while (x < nl && lv[x] != tt[c])
                x++;
            if (x == nl) {
                if (nl == LINK_MAX) return 0;
                lv[nl++] = tt[c];
            }
            loc[m++] = x;
            same += sgn(S->val[tt[c]]) == sv;
        }
        if (same == 3) T++;
        for (int i = 0; i < 3; i++) {
            int a = loc[i], b = loc[(i + 1) % 3];
            if (sgn(S->val[lv[a]]) != sv || sgn(S->val[lv[b]]) != sv) continue;
            if (a > b) {
                int x = a;
                a = b;
                b = x;
            }
            int y = 0;
            while (y < ne && (edges[y][0] != a || edges[y][1] != b))
                y++;
            if (y == ne) {
                if (ne == 3 * LINK_MAX) return 0;
                edges[ne][0] = a;
                edges[ne][1] = b;
                ne++;
            }
        }
    }
    int V = 0, comps = 0;
    for (int i = 0; i < nl; i++)
        parent[i] = i;
    for (int i = 0; i < ne; i++)
        parent[vm__gr_root(parent, edges[i][0])] = vm__gr_root(parent, edges[i][1]);
    for (int i = 0; i < nl; i++)
        if (sgn(S->val[lv[i]]) == sv) {
            V++;
            if (vm__gr_root(parent, i) == i) comps++;
        }
    return V >= 1 && comps == 1 && V - ne + T == 1;
}

static int on_root_boundary(const stuff *S, int32_t v) {
    int64_t p[3];
    vm__gr_unkey(S->L->key[v], p);
    for (int d = 0; d < 3; d++)
        if (p[d] == 0 || p[d] == S->root) return 1;
    return 0;
}

/* Whether v lies on a plane of the volume's box with a neighbour beyond it (outside). */
static int on_box_border(const stuff *S, size_t v) {
    const double *p = S->lpos + 3 * v;
    int on = 0;
    for (int d = 0; d < 3; d++) {
        double top = (double)(S->f->n[d] - 1) * S->f->sp[d], tol = 1e-9 * S->t->h0[d];
        if (p[d] < -tol || p[d] > top + tol) return 0;
        if (fabs(p[d]) <= tol || fabs(p[d] - top) <= tol) on = 1;
    }
    if (!on) return 0;
    for (size_t k = S->ve_start[v]; k < S->ve_start[v + 1]; k++) {
        size_t e = (size_t)S->ve[k];
        int32_t w = S->ev[e][0] == (int32_t)v ? S->ev[e][1] : S->ev[e][0];
        if (S->L->phi[w] == S->f->out) return 1;
    }
    return 0;
}

/* Whether moving v to x keeps every cut point of v's other crossed edges within the distance
 * bound of x: the warp replaces those cuts by x. Across a one-voxel cavity or thin bone the
 * far side's cut is the surface's only point there (on the CT head, 15 isosurface points
 * were up to 0.85 voxel from the boundary after such warps). skip: the edge warped along. */
static int keeps_cuts(stuff *S, size_t v, const double x[3], size_t skip) {
    double D2 = S->t->distance * S->t->distance;
    for (size_t k = S->ve_start[v]; k < S->ve_start[v + 1]; k++) {
        size_t e = (size_t)S->ve[k];
        int32_t w = S->ev[e][0] == (int32_t)v ? S->ev[e][1] : S->ev[e][0];
        if (e == skip || S->val[w] == 0 || sgn(S->val[w]) == sgn(S->val[v])) continue;
        double t = cut_param(S, e), d2 = 0;
        const double *a = S->lpos + 3 * (size_t)S->ev[e][0],
                     *b = S->lpos + 3 * (size_t)S->ev[e][1];
        for (int d = 0; d < 3; d++) {
            double c = a[d] + t * (b[d] - a[d]) - x[d];
            d2 += c * c;
        }
        if (d2 > D2) return 0;
    }
    return 1;
}

/* Marks the lattice vertices of the base cells marked exact (graded.c refine_far): their
 * warps must keep their other cuts. */
static void mark_exact(stuff *S) {
    const gr_tree *t = S->t;
    for (size_t i = 0; i < t->n; i++) {
        const gr_node *q = &t->node[i];
        if (q->child >= 0 || !q->exact) continue;
        for (int k = 0; k < 27; k++) {
            int64_t p[3] = {q->a[0] + k % 3, q->a[1] + (k / 3) % 3, q->a[2] + k / 9};
            int64_t v = vm__gr_lattice_find(S->L, p);
            if (v >= 0) S->keep[v] = 1;
        }
    }
}

/* One pass of warps, in vertex order: each vertex goes to the nearest cut point within alpha
 * of it on its edges, when that is a simple-point move (and, in an exact cell, keeps its
 * other cuts within the distance bound: keeps_cuts). Material meeting the volume's border
 * is closed on the border plane: inside vertices on it are put on the surface where they
 * stand (these may neighbour each other: the plane separates their links' two sides). */
static size_t warp(stuff *S) {
    size_t warped = 0;
    for (size_t v = 0; v < S->nv; v++)
        if (!S->nowarp[v] && S->val[v] > 0 && on_box_border(S, v) &&
            simple_point(S, (int32_t)v)) {
            S->val[v] = 0;
            warped++;
            S->border_zeros++;
        }
    for (size_t v = 0; v < S->nv; v++) {
        if (S->nowarp[v] || S->val[v] == 0 || on_root_boundary(S, (int32_t)v)) continue;
        double best = INFINITY;
        size_t be = 0;
        double bt = 0;
        int next_to_zero = 0;
        for (size_t k = S->ve_start[v]; k < S->ve_start[v + 1]; k++) {
            size_t e = (size_t)S->ve[k];
            int32_t w = S->ev[e][0] == (int32_t)v ? S->ev[e][1] : S->ev[e][0];
            if (S->val[w] == 0) next_to_zero = 1;
            if (S->val[w] == 0 || sgn(S->val[w]) == sgn(S->val[v])) continue;
            double t = cut_param(S, e), from_v = S->ev[e][0] == (int32_t)v ? t : 1 - t;
            int64_t pa[3], pb[3];
            vm__gr_unkey(S->L->key[S->ev[e][0]], pa);
            vm__gr_unkey(S->L->key[S->ev[e][1]], pb);
            int axes = (pa[0] != pb[0]) + (pa[1] != pb[1]) + (pa[2] != pb[2]);
            double alpha = axes == 1 ? GR_ALPHA_LONG : GR_ALPHA_SHORT;
            const double *p0 = S->lpos + 3 * (size_t)S->ev[e][0],
                         *p1 = S->lpos + 3 * (size_t)S->ev[e][1];
            double len =
                sqrt((p1[0] - p0[0]) * (p1[0] - p0[0]) + (p1[1] - p0[1]) * (p1[1] - p0[1]) +
                     (p1[2] - p0[2]) * (p1[2] - p0[2]));
            if (from_v < alpha && from_v * len < best) {
                best = from_v * len;
                be = e;
                bt = t;
            }
        }
        /* Warped vertices are kept apart, so that each one's link holds no vertex on the
         * surface: then its two sides are disks (the simple-point test, and its complement
         * on the sphere) and the surface is a manifold there. */
        if (best == INFINITY || next_to_zero) continue;
        const double *p0 = S->lpos + 3 * (size_t)S->ev[be][0],
                     *p1 = S->lpos + 3 * (size_t)S->ev[be][1];
        double x[3];
        for (int d = 0; d < 3; d++)
            x[d] = p0[d] + bt * (p1[d] - p0[d]);
        if ((S->keep[v] && !keeps_cuts(S, v, x, be)) || !simple_point(S, (int32_t)v)) continue;
        memcpy(S->pos + 3 * v, x, sizeof x);
        S->val[v] = 0;
        warped++;
    }
    return warped;
}

/* Where the linear interpolation of the ends' values crosses zero on edge e. */
static double linear_param(const stuff *S, size_t e) {
    double a = S->L->phi[S->ev[e][0]], b = S->L->phi[S->ev[e][1]];
    return a / (a - b);
}

/* Position of a piece vertex (lattice id, or nv + edge for a cut point). The reference
 * geometry (reference = 1: lattice positions, cuts at edge midpoints) makes every piece a
 * part of a convex one (the midpoints of a tet's cut edges are coplanar), so it orients
 * them; the mesh has the warped positions and the cuts on the surface. */
static void piece_pos(const stuff *S, int64_t id, int reference, double p[3]) {
    if (id < (int64_t)S->nv) {
        const double *q = (reference ? S->lpos : S->pos) + 3 * (size_t)id;
        p[0] = q[0];
        p[1] = q[1];
        p[2] = q[2];
        return;
    }
    size_t e = (size_t)(id - (int64_t)S->nv);
    const double *a = S->lpos + 3 * (size_t)S->ev[e][0], *b = S->lpos + 3 * (size_t)S->ev[e][1];
    double t = reference ? 0.5 : S->linear[e] ? linear_param(S, e) : S->cut[e];
    for (int d = 0; d < 3; d++)
        p[d] = a[d] + t * (b[d] - a[d]);
    if (reference) return;
    /* A cut where the material meets the volume's border lies on the border plane. */
    for (int d = 0; d < 3; d++) {
        double top = (double)(S->f->n[d] - 1) * S->f->sp[d], tol = 1e-6 * S->t->h0[d];
        if (fabs(p[d]) < tol) p[d] = 0;
        if (fabs(p[d] - top) < tol) p[d] = top;
    }
}

static double orient(const stuff *S, const int64_t *id, int lattice) {
    double p[4][3];
    for (int k = 0; k < 4; k++)
        piece_pos(S, id[k], lattice, p[k]);
    double a[3], b[3], c[3];
    for (int d = 0; d < 3; d++) {
        a[d] = p[1][d] - p[0][d];
        b[d] = p[2][d] - p[0][d];
        c[d] = p[3][d] - p[0][d];
    }
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/* Adds a piece, oriented by the reference geometry; returns 0 when it is not clearly
 * positive in the mesh's. */
static int add_piece(stuff *S, int64_t a, int64_t b, int64_t c, int64_t d, int *nomem_flag) {
    int64_t id[4] = {a, b, c, d};
    double ref = orient(S, id, 1);
    if (ref == 0) return 1;
    if (ref < 0) {
        id[2] = d;
        id[3] = c;
    }
    const double *h0 = S->t->h0;
    double now = orient(S, id, 0);
    if (S->np == S->pcap) {
        size_t cap = S->pcap ? 2 * S->pcap : 8192;
        int64_t(*np)[4] = realloc(S->piece, cap * sizeof *np);
        if (np) S->w->buf[W_PIECE] = S->piece = np;
        int32_t *ns = realloc(S->src, cap * sizeof *ns);
        if (ns) S->w->buf[W_SRC] = S->src = ns;
        if (!np || !ns) {
            *nomem_flag = 1;
            return 1;
        }
        S->pcap = cap;
        S->w->cap[W_PIECE] = cap * sizeof *np;
        S->w->cap[W_SRC] = cap * sizeof *ns;
    }
    S->src[S->np] = S->cur;
    memcpy(S->piece[S->np++], id, sizeof id);
    return now > 1e-12 * h0[0] * h0[1] * h0[2];
}

static int64_t edge_between(const stuff *S, size_t t, int i, int j) {
    for (int k = 0; k < 6; k++)
        if ((tet_edge[k][0] == i && tet_edge[k][1] == j) ||
            (tet_edge[k][0] == j && tet_edge[k][1] == i))
            return (int64_t)S->nv + S->te[t][k];
    return -1;
}

/* The pyramid over quad q (cyclic) from apex z, split at the quad's smallest vertex. */
static int pyramid(stuff *S, int64_t z, const int64_t q[4], int *nm) {
    int m = 0;
    for (int k = 1; k < 4; k++)
        if (q[k] < q[m]) m = k;
    if (m == 0 || m == 2)
        return add_piece(S, z, q[0], q[1], q[2], nm) & add_piece(S, z, q[0], q[2], q[3], nm);
    return add_piece(S, z, q[1], q[2], q[3], nm) & add_piece(S, z, q[1], q[3], q[0], nm);
}

/* The prism of triangles a and b (a[i]-b[i] lateral edges), by the smallest-vertex rule. */
static int prism(stuff *S, const int64_t a_in[3], const int64_t b_in[3], int *nm) {
    int64_t a[3], b[3], mn = a_in[0];
    int at = 0, top = 0;
    for (int k = 0; k < 3; k++) {
        if (a_in[k] < mn) mn = a_in[k], at = k, top = 0;
        if (b_in[k] < mn) mn = b_in[k], at = k, top = 1;
    }
    for (int k = 0; k < 3; k++) {
        a[k] = (top ? b_in : a_in)[(at + k) % 3];
        b[k] = (top ? a_in : b_in)[(at + k) % 3];
    }
    int ok = add_piece(S, a[0], b[0], b[1], b[2], nm);
    int64_t m1 = a[1] < b[2] ? a[1] : b[2], m2 = a[2] < b[1] ? a[2] : b[1];
    if (m1 < m2)
        ok &=
            add_piece(S, a[0], a[1], a[2], b[2], nm) & add_piece(S, a[0], a[1], b[2], b[1], nm);
    else
        ok &=
            add_piece(S, a[0], a[1], a[2], b[1], nm) & add_piece(S, a[0], b[1], a[2], b[2], nm);
    return ok;
}

/* The inside part of lattice tet t; returns 0 when a piece came out turned over. */
static int stencil(stuff *S, size_t t, int *nm) {
    const int32_t *v = S->L->tet[t];
    int P[4], Z[4], N[4], np = 0, nz = 0, nn = 0;
    for (int k = 0; k < 4; k++) {
        int s = sgn(S->val[v[k]]);
        if (s > 0)
            P[np++] = k;
        else if (s < 0)
            N[nn++] = k;
        else
            Z[nz++] = k;
    }
    if (np == 0) return 1;
    if (nn == 0) return add_piece(S, v[0], v[1], v[2], v[3], nm);
    if (np == 1) {
        int64_t id[4];
        for (int k = 0; k < 4; k++)
            id[k] = k == P[0]                ? v[k]
                    : sgn(S->val[v[k]]) == 0 ? v[k]
                                             : edge_between(S, t, P[0], k);
        return add_piece(S, id[0], id[1], id[2], id[3], nm);
    }
    if (np == 2 && nn == 1) {
        int64_t q[4] = {v[P[0]], v[P[1]], edge_between(S, t, P[1], N[0]),
                        edge_between(S, t, P[0], N[0])};
        return pyramid(S, v[Z[0]], q, nm);
    }
    if (np == 2) {
        int64_t a[3] = {v[P[0]], edge_between(S, t, P[0], N[0]),
                        edge_between(S, t, P[0], N[1])};
        int64_t b[3] = {v[P[1]], edge_between(S, t, P[1], N[0]),
                        edge_between(S, t, P[1], N[1])};
        return prism(S, a, b, nm);
    }
    int64_t a[3] = {v[P[0]], v[P[1]], v[P[2]]};
    int64_t b[3] = {edge_between(S, t, P[0], N[0]), edge_between(S, t, P[1], N[0]),
                    edge_between(S, t, P[2], N[0])};
    return prism(S, a, b, nm);
}

/* Cut parameters of every edge the pieces may use. */
static void cut_all(stuff *S) {
    for (size_t e = 0; e < S->ne; e++) {
        double a = S->val[S->ev[e][0]], b = S->val[S->ev[e][1]];
        if (a != 0 && b != 0 && (a > 0) != (b > 0)) cut_param(S, e);
    }
}

static vm_status write_mesh(stuff *S, vm_mesh *mesh, gr_stuff_stats *st, vm_error *err) {
    const vm_volume *vol = S->f->v;
    size_t total = S->nv + S->ne;
    int64_t *map = take(S->w, W_TMP1, (total + 1) * sizeof *map);
    if (!map) return nomem(err);
    for (size_t i = 0; i < total; i++)
        map[i] = -1;
    size_t npts = 0;
    for (size_t p = 0; p < S->np; p++)
        for (int k = 0; k < 4; k++)
            if (map[S->piece[p][k]] < 0) map[S->piece[p][k]] = (int64_t)npts++;
    vm_status s = vm_mesh_reserve(mesh, npts, S->np, err);
    if (s) return s;
    /* vm_mesh_reserve sized the region array with the cells */
    for (size_t i = 0; i < total; i++) {
        if (map[i] < 0) continue;
        double u[3], ijk[3];
        piece_pos(S, (int64_t)i, 0, u);
        for (int d = 0; d < 3; d++)
            ijk[d] = u[d] / S->f->sp[d];
        vm_volume_index_to_world(vol, ijk, mesh->points + 3 * (size_t)map[i]);
        if (i >= S->nv) st->cut_vertices++;
    }
    int mirror = vm_volume_frame_determinant(vol) < 0;
    for (size_t p = 0; p < S->np; p++) {
        vm_index *c = mesh->cells + 4 * p;
        for (int k = 0; k < 4; k++)
            c[k] = (vm_index)map[S->piece[p][k]];
        if (mirror) vm__mirror_cell(c, 4);
        mesh->region[p] = 1;
    }
    mesh->npoints = npts;
    mesh->ncells = S->np;
    return VM_OK;
}

typedef struct face_rec {
    int64_t v[3];
    size_t piece;
} face_rec;

static int face_cmp(const void *x, const void *y) {
    const face_rec *a = x, *b = y;
    for (int i = 0; i < 3; i++)
        if (a->v[i] != b->v[i]) return a->v[i] < b->v[i] ? -1 : 1;
    return 0;
}

enum { FAN_MAX = 128 }; /* faces around one boundary vertex checked at most */

typedef struct inc_rec {
    int64_t v, other;
    size_t face;
} inc_rec;

static int inc_cmp(const void *x, const void *y) {
    const inc_rec *a = x, *b = y;
    if (a->v != b->v) return a->v < b->v ? -1 : 1;
    if (a->other != b->other) return a->other < b->other ? -1 : 1;
    return a->face < b->face ? -1 : a->face > b->face;
}

/* Undoes the warps around any place where the boundary is not a manifold: an edge of other
 * than two boundary faces, or a vertex whose faces make more than one fan. Warps are
 * simple-point moves, so these come only from warped vertices meeting (on the volume's
 * border); without warps the boundary is the zero set of a linear field on each tet. */
static vm_status undo_pinches(stuff *S, gr_stuff_stats *st, size_t *bad, vm_error *err) {
    size_t nf = 4 * S->np, nb = 0;
    face_rec *f = take(S->w, W_TMP1, (nf + 1) * sizeof *f);
    if (!f) return nomem(err);
    for (size_t p = 0; p < S->np; p++)
        for (int k = 0; k < 4; k++) {
            face_rec *r = &f[4 * p + (size_t)k];
            int m = 0;
            for (int j = 0; j < 4; j++)
                if (j != k) r->v[m++] = S->piece[p][j];
            for (int a = 0; a < 3; a++)
                for (int b = a + 1; b < 3; b++)
                    if (r->v[b] < r->v[a]) {
                        int64_t x = r->v[a];
                        r->v[a] = r->v[b];
                        r->v[b] = x;
                    }
            r->piece = p;
        }
    (void)vm__psort(f, nf, sizeof *f, face_cmp); /* (equal faces are dropped together) */
    for (size_t i = 0; i < nf;) {
        size_t j = i + 1;
        while (j < nf && face_cmp(&f[i], &f[j]) == 0)
            j++;
        if (j == i + 1) f[nb++] = f[i];
        i = j;
    }
    /* Incidences (vertex, other vertex of an edge, face): around each vertex, faces that
     * share an edge join one fan; an edge with other than two faces is a pinch too. */
    inc_rec *in = take(S->w, W_TMP2, (6 * nb + 1) * sizeof *in);
    if (!in) return nomem(err);
    size_t ni = 0;
    for (size_t b = 0; b < nb; b++) {
        for (int k = 0; k < 3; k++)
            for (int o = 0; o < 3; o++)
                if (o != k) in[ni++] = (inc_rec){f[b].v[k], f[b].v[o], b};
    }
    (void)vm__psort(in, ni, sizeof *in, inc_cmp); /* (a total order) */
    for (size_t i = 0; i < ni;) {
        size_t j = i;
        while (j < ni && in[j].v == in[i].v)
            j++;
        /* faces around in[i].v: join those sharing an edge (a local union-find over the
         * fan's faces); an edge with other than two faces, or two fans, is a pinch */
        int pinched = j - i > 2 * FAN_MAX;
        size_t face[2 * FAN_MAX], nl = 0;
        int lp[2 * FAN_MAX];
        for (size_t a = i; a < j && !pinched; a++) {
            size_t x = 0;
            while (x < nl && face[x] != in[a].face)
                x++;
            if (x == nl) {
                face[nl] = in[a].face;
                lp[nl] = (int)nl;
                nl++;
            }
        }
        for (size_t a = i; a < j && !pinched;) {
            size_t b = a;
            while (b < j && in[b].other == in[a].other)
                b++;
            if (b - a != 2) pinched = 1;
            int x = 0, y = 0;
            while (face[x] != in[a].face)
                x++;
            while (face[y] != in[a + 1 < b ? a + 1 : a].face)
                y++;
            lp[vm__gr_root(lp, x)] = vm__gr_root(lp, y);
            a = b;
        }
        for (int x = 1; x < (int)nl && !pinched; x++)
            if (vm__gr_root(lp, x) != vm__gr_root(lp, 0)) pinched = 1;
        if (pinched) {
            /* undo the warps of the tets whose pieces have a face here */
            for (size_t a = i; a < j; a++) {
                const int32_t *tt = S->L->tet[S->src[f[in[a].face].piece]];
                for (int k = 0; k < 4; k++)
                    if (S->val[tt[k]] == 0 && !S->nowarp[tt[k]]) {
                        S->nowarp[tt[k]] = 1;
                        st->unwarped++;
                        ++*bad;
                    }
            }
        }
        i = j;
    }
    return VM_OK;
}

vm_status vm__gr_stuff(const gr_lattice *L, const gr_tree *t, const gr_field *f, vm_mesh *mesh,
                       gr_stuff_stats *st, gr_stuff_work *work, vm_error *err) {
    memset(st, 0, sizeof *st);
    stuff S;
    memset(&S, 0, sizeof S);
    gr_stuff_work own;
    memset(&own, 0, sizeof own);
    S.w = work ? work : &own;
    S.piece = S.w->buf[W_PIECE];
    S.src = S.w->buf[W_SRC];
    S.pcap = S.w->cap[W_PIECE] / sizeof *S.piece;
    if (S.w->cap[W_SRC] / sizeof *S.src < S.pcap) S.pcap = S.w->cap[W_SRC] / sizeof *S.src;
    S.L = L;
    S.t = t;
    S.f = f;
    S.nv = L->nv;
    S.nt = L->nt;
    S.root = (int64_t)2 << t->root_level;
    vm_status s = build_edges(&S, err);
    if (!s) {
        S.lpos = take(S.w, W_LPOS, (3 * S.nv + 1) * sizeof *S.lpos);
        S.pos = take(S.w, W_POS, (3 * S.nv + 1) * sizeof *S.pos);
        S.val = take(S.w, W_VAL, (S.nv + 1) * sizeof *S.val);
        S.delta = take(S.w, W_DELTA, (S.nv + 1) * sizeof *S.delta);
        S.nowarp = take_zero(S.w, W_NOWARP, S.nv + 1);
        S.linear = take_zero(S.w, W_LINEAR, S.ne + 1);
        S.keep = calloc(S.nv + 1, 1);
        if (!S.lpos || !S.pos || !S.val || !S.delta || !S.nowarp || !S.linear || !S.keep)
            s = nomem(err);
    }
    if (!s)
        s = adjacency(S.w, W_VT_START, W_VT, S.nv, S.nt, 4, &L->tet[0][0], &S.vt_start, &S.vt,
                      err);
    if (!s)
        s = adjacency(S.w, W_VE_START, W_VE, S.nv, S.ne, 2, &S.ev[0][0], &S.ve_start, &S.ve,
                      err);
    if (!s) {
        long long nv = (long long)S.nv;
#pragma omp parallel for schedule(static)
        for (long long i = 0; i < nv; i++) {
            size_t v = (size_t)i;
            int64_t p[3];
            vm__gr_unkey(L->key[v], p);
            vm__gr_lattice_pos(t, p, S.lpos + 3 * v);
            double truth = vm__gr_phi(f, S.lpos + 3 * v);
            /* Forced signs (and 0 read as inside) shift the field near the vertex. */
            S.delta[v] = fabs(L->phi[v] - truth) < 1e-200 ? 0 : L->phi[v] - truth;
        }
        /* The cut of every edge the lattice's signs cross, ahead and in parallel: each is a
         * function of its edge alone (warps and pieces then find them made). */
        long long ne = (long long)S.ne;
#pragma omp parallel for schedule(dynamic, 4096)
        for (long long i = 0; i < ne; i++) {
            double a = L->phi[S.ev[i][0]], b = L->phi[S.ev[i][1]];
            if (a != 0 && b != 0 && (a > 0) != (b > 0)) cut_param(&S, (size_t)i);
        }
    }
    if (!s) mark_exact(&S);
    for (int round = 0; !s; round++) {
        memcpy(S.pos, S.lpos, 3 * S.nv * sizeof *S.pos);
        memcpy(S.val, L->phi, S.nv * sizeof *S.val);
        if (round == GR_ROUNDS - 1) { /* the last resort: no warps, linear cuts */
            memset(S.nowarp, 1, S.nv);
            memset(S.linear, 1, S.ne);
            st->no_warps = 1;
        }
        S.border_zeros = 0;
        st->warped = warp(&S);
        cut_all(&S);
        S.np = 0;
        int nm = 0;
        size_t bad = 0;
        for (size_t i = 0; i < S.nt; i++) {
            S.cur = (int32_t)i;
            if (stencil(&S, i, &nm)) continue;
            /* A piece came out flat or turned: undo the warps of its tet, or where there
             * are none, place its cuts by linear interpolation (the reference geometry). */
            bad++;
            int undone = 0;
            for (int k = 0; k < 4; k++)
                if (S.val[L->tet[i][k]] == 0 && !S.nowarp[L->tet[i][k]]) {
                    S.nowarp[L->tet[i][k]] = 1;
                    st->unwarped++;
                    undone = 1;
                }
            if (!undone)
                for (int k = 0; k < 6; k++)
                    S.linear[S.te[i][k]] = 1;
        }
        if (nm) s = nomem(err);
        /* Only vertices on the border plane may neighbour another on the surface. */
        if (!s && !bad && S.border_zeros && round < GR_ROUNDS - 1)
            s = undo_pinches(&S, st, &bad, err);
        st->rounds = (size_t)round + 1;
        if (!bad || round == GR_ROUNDS - 1) break;
    }
    if (!s) s = write_mesh(&S, mesh, st, err);
    give(S.w, W_TMP1);
    give(S.w, W_TMP2);
    free(S.keep);
    vm__gr_stuff_work_free(&own);
    return s;
}
