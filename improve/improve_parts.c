/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_parts.c — the quality pass by parts (issue #12): slabs of the mesh along z
 * improved a few at a time on OpenMP threads, each with every tet near it locked, then bands
 * over the slab borders and a last round around the tets still failing ABAQUS's check.
 *
 * Why it is sound: a part P is improved as a submesh of P and the locked tets whose boxes
 * come within a margin of P's box, which include every tet sharing a vertex with P. A vertex
 * of a locked tet never moves nor goes and a locked tet is never replaced, so every vertex
 * the core may move or remove has its whole star in P, and every vertex an operation may
 * join to it (contraction, flips) is a vertex of P, whose star is whole in the submesh too:
 * the link condition and the "new edge must be new" tests see what they would see in the
 * whole mesh. The boundary guard sees every boundary face within the margin (the most a
 * boundary vertex may move from where the pass found it, twice), which is all a new boundary
 * triangle of P can reach. Parts run at the same time reach disjoint ranges of z, so they
 * share no tet and no vertex; each writes its tets into its own slots and its points, and
 * what it adds beyond its slots is appended in part order: the output does not depend on the
 * thread count. */
#include "../core/core.h"
#include "improve_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define HIST 4096           /* bins of the centroid histogram that places the slab borders */
#define MIN_THICK 6.0       /* a slab is at least this many mean longest tet edges thick */
#define MIN_THICK_ASKED 2.0 /* ... when the caller asked for a number of parts */
#define DEAD_SLOT VM__IMP_DEAD_SLOT
#define BAND_ROUNDS 4 /* most rounds over the tets left below the targets */
#define RINGS 2       /* rings of free tets around each of them */
#define GRID 128      /* cells a side of the grid that finds the tets near a part */

/* A part's box grows by this share of its longest edge beyond its vertices' bounds. */
#define BOX_SLACK 0.05
/* A part's window of planes: its vertices' planes, plus twice the surface bound, plus
 * WINDOW_MARGIN planes each side (the trilinear cells and the gradient's neighbours), plus
 * WINDOW_TOP planes above (k1 is exclusive, and the cell above the top vertex). */
#define WINDOW_MARGIN 3.0
#define WINDOW_TOP 2.0
/* Round-off slack on the world length of one index step along each axis. */
#define ROW_SLACK 1.01
/* The rounds' share of the bar: the even slabs up to BAR_EVENS, the odd ones up to
 * BAR_SLABS, then the band rounds each halving what is left of the next BAR_BANDS. */
#define BAR_EVENS 0.35
#define BAR_SLABS 0.7
#define BAR_BANDS 0.2

size_t vm__imp_parts_count(const vm_mesh *m, const vm_improve_options *o) {
    /* slots are 32-bit; the tets flips add stay far below the slack */
    if (o->frozen || o->parts == 1 || !m->region || m->ncells > UINT32_MAX / 2 ||
        m->npoints > UINT32_MAX)
        return 1;
    if (o->parts > 1) return (size_t)o->parts;
    return 0; /* the local pass */
}

typedef vm__imp_pstate pstate;
typedef vm__imp_job job;

static const double *pt(const pstate *S, vm_index a) {
    return S->m->points + 3 * (size_t)a;
}

static int slot_dead(const pstate *S, size_t t) {
    return S->m->cells[4 * t] == DEAD_SLOT;
}

static double centroid_z(const pstate *S, size_t t) {
    const vm_index *n = S->m->cells + 4 * t;
    return 0.25 * (pt(S, n[0])[2] + pt(S, n[1])[2] + pt(S, n[2])[2] + pt(S, n[3])[2]);
}

static int in_part(const pstate *S, const job *J, size_t t) {
    if (slot_dead(S, t)) return 0;
    double z;
    if (J->key) {
        if (t >= J->nkey || !(J->key[t] < INFINITY)) return 0;
        z = J->key[t];
    } else {
        z = centroid_z(S, t);
    }
    return z >= J->z0 && z < J->z1;
}

void vm__imp_slot_box(const pstate *S, size_t t, double lo[3], double hi[3]) {
    const vm_index *n = S->m->cells + 4 * t;
    for (int a = 0; a < 3; a++)
        lo[a] = hi[a] = pt(S, n[0])[a];
    for (int k = 1; k < 4; k++)
        for (int a = 0; a < 3; a++) {
            double x = pt(S, n[k])[a];
            if (x < lo[a]) lo[a] = x;
            if (x > hi[a]) hi[a] = x;
        }
}

double vm__imp_slot_edge2(const pstate *S, size_t t) {
    const vm_index *n = S->m->cells + 4 * t;
    double L = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            const double *p = pt(S, n[i]), *q = pt(S, n[j]);
            double d = (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                       (p[2] - q[2]) * (p[2] - q[2]);
            if (d > L) L = d;
        }
    return L;
}

int vm__imp_push_slot(uint32_t **l, size_t *n, size_t *cap, size_t t) {
    if (*n == *cap) {
        size_t c = *cap ? 2 * *cap : 1024;
        uint32_t *nl = realloc(*l, c * sizeof *nl);
        if (!nl) return 0;
        *l = nl;
        *cap = c;
    }
    (*l)[(*n)++] = (uint32_t)t;
    return 1;
}

/* The cells c0..c1 of a grid (origin lo, cell cs, gd cells a side) that box [a, b] meets
 * (clamped to the grid). */
void vm__imp_cell_range(const double lo[3], double cs, const size_t gd[3], const double a[3],
                       const double b[3], size_t c0[3], size_t c1[3]) {
    for (int k = 0; k < 3; k++) {
        double u = floor((a[k] - lo[k]) / cs), v = floor((b[k] - lo[k]) / cs);
        double top = (double)(gd[k] - 1);
        c0[k] = u < 0.0 ? 0 : u > top ? gd[k] - 1 : (size_t)u;
        c1[k] = v < 0.0 ? 0 : v > top ? gd[k] - 1 : (size_t)v;
    }
}

/* Grows the marked cells of grid (gd cells a side) by r cells along axis k. 0 on
 * out-of-memory. */
int vm__imp_dilate(uint8_t *grid, const size_t gd[3], int k, size_t r) {
    size_t n = gd[k], st = k == 0 ? 1 : k == 1 ? gd[0] : gd[0] * gd[1];
    uint8_t *line = malloc(n);
    if (!line) return 0;
    for (size_t z = 0; z < (k == 2 ? 1 : gd[2]); z++)
        for (size_t y = 0; y < (k == 1 ? 1 : gd[1]); y++)
            for (size_t x = 0; x < (k == 0 ? 1 : gd[0]); x++) {
                uint8_t *g = grid + (z * gd[1] + y) * gd[0] + x;
                for (size_t i = 0; i < n; i++)
                    line[i] = g[i * st];
                /* distance to the last marked cell before, then after */
                size_t last = SIZE_MAX;
                for (size_t i = 0; i < n; i++) {
                    if (line[i]) last = i;
                    if (last != SIZE_MAX && i - last <= r) g[i * st] = 1;
                }
                last = SIZE_MAX;
                for (size_t i = n; i-- > 0;) {
                    if (line[i]) last = i;
                    if (last != SIZE_MAX && last - i <= r) g[i * st] = 1;
                }
            }
    free(line);
    return 1;
}

/* Sorts a[0..n) ascending (radix, three 11-bit digits); tmp holds n. */
static void sort_u32(uint32_t *a, uint32_t *tmp, size_t n) {
    if (n < 2) return;
    size_t cnt[2048];
    uint32_t *src = a, *dst = tmp;
    for (int sh = 0; sh < 33; sh += 11) {
        memset(cnt, 0, sizeof cnt);
        for (size_t i = 0; i < n; i++)
            cnt[(src[i] >> sh) & 2047u]++;
        size_t acc = 0;
        for (size_t d = 0; d < 2048; d++) {
            size_t c = cnt[d];
            cnt[d] = acc;
            acc += c;
        }
        for (size_t i = 0; i < n; i++)
            dst[cnt[(src[i] >> sh) & 2047u]++] = src[i];
        uint32_t *x = src;
        src = dst;
        dst = x;
    }
    if (src != a) memcpy(a, src, n * sizeof *a);
}

/* Sorts a list of slots (or point ids) in place; 0 on out-of-memory. */
int vm__imp_sort_slots(uint32_t *l, size_t n) {
    uint32_t *tmp = malloc((n + 1) * sizeof *tmp);
    if (!tmp) return 0;
    sort_u32(l, tmp, n);
    free(tmp);
    return 1;
}

/* The live slots bucketed by a z value (the centroid's, or a part key): the candidates for a
 * range of z without a scan of the whole mesh. Built once per batch of parts. By centroid,
 * the tets are also split into classes by how far their box reaches from the centroid in z
 * (class c: at most reach / 2^c), so that the few big tets of an adaptive mesh do not widen
 * the search for all. */
#define ZCLASSES 12
typedef struct zindex {
    uint32_t *slot; /* class by class, bucket by bucket, each in slot order */
    size_t *start;  /* ncls * nb + 1 */
    size_t nb, ncls;
    double z0, dz;
    double reach; /* by centroid: the farthest a tet's box gets from its centroid in z */
} zindex;

/* The z value slot t is bucketed by (key: the part keys, slots below nkey only), or
 * INFINITY when it is not in the index. */
static double zvalue(const pstate *S, const float *key, size_t nkey, size_t t) {
    if (slot_dead(S, t)) return INFINITY;
    if (!key) return centroid_z(S, t);
    return t < nkey && key[t] < INFINITY ? (double)key[t] : INFINITY;
}

/* How far the box of slot t reaches from its centroid z. */
static double zreach(const pstate *S, size_t t, double z) {
    double a[3], b[3];
    vm__imp_slot_box(S, t, a, b);
    return z - a[2] > b[2] - z ? z - a[2] : b[2] - z;
}

static size_t zclass(const zindex *X, double r) {
    size_t c = 0;
    for (double h = 0.5 * X->reach; c + 1 < X->ncls && r <= h; h *= 0.5)
        c++;
    return c;
}

/* The bucket of value z in class c. */
static size_t zbucket(const zindex *X, size_t c, double z) {
    double b = floor((z - X->z0) / X->dz);
    return c * X->nb + (b < 0.0 ? 0 : b >= (double)X->nb ? X->nb - 1 : (size_t)b);
}

static void zindex_free(zindex *X) {
    free(X->slot);
    free(X->start);
    memset(X, 0, sizeof *X);
}

/* The bucket of slot t, or UINT32_MAX when it is not indexed. */
static uint32_t zslot_bucket(const pstate *S, const float *key, size_t nkey, const zindex *X,
                             size_t t) {
    double z = zvalue(S, key, nkey, t);
    if (!(z < INFINITY)) return UINT32_MAX;
    return (uint32_t)zbucket(X, key ? 0 : zclass(X, zreach(S, t, z)), z);
}

/* 0 on out-of-memory. */
static int zindex_build(const pstate *S, const float *key, size_t nkey, zindex *X) {
    memset(X, 0, sizeof *X);
    double zmin = INFINITY, zmax = -INFINITY, reach = 0.0;
    size_t n = 0;
    /* minima, maxima and counts: the same for any thread count */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096) reduction(min : zmin)                     \
    reduction(max : zmax, reach) reduction(+ : n)
#endif
    for (size_t t = 0; t < S->nt; t++) {
        double z = zvalue(S, key, nkey, t);
        if (!(z < INFINITY)) continue;
        n++;
        if (z < zmin) zmin = z;
        if (z > zmax) zmax = z;
        if (!key) {
            double r = zreach(S, t, z);
            if (r > reach) reach = r;
        }
    }
    X->reach = reach;
    X->ncls = key ? 1 : ZCLASSES;
    X->nb = n / 256 < 1 ? 1 : n / 256 > ((size_t)1 << 20) ? (size_t)1 << 20 : n / 256;
    X->z0 = n ? zmin : 0.0;
    X->dz = n && zmax > zmin ? (zmax - zmin) / (double)X->nb : 1.0;
    size_t nbk = X->ncls * X->nb;
    /* each slot's bucket once, then the slots bucket by bucket */
    uint32_t *bk = malloc((S->nt + 1) * sizeof *bk);
    X->slot = malloc((n + 1) * sizeof *X->slot);
    X->start = calloc(nbk + 1, sizeof *X->start);
    if (!bk || !X->slot || !X->start) {
        free(bk);
        zindex_free(X);
        return 0;
    }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (size_t t = 0; t < S->nt; t++)
        bk[t] = zslot_bucket(S, key, nkey, X, t);
    for (size_t t = 0; t < S->nt; t++)
        if (bk[t] != UINT32_MAX) X->start[bk[t] + 1]++;
    for (size_t i = 0; i < nbk; i++)
        X->start[i + 1] += X->start[i];
    /* fill with the starts, then shift them back */
    for (size_t t = 0; t < S->nt; t++)
        if (bk[t] != UINT32_MAX) X->slot[X->start[bk[t]]++] = (uint32_t)t;
    for (size_t i = nbk; i > 0; i--)
        X->start[i] = X->start[i - 1];
    X->start[0] = 0;
    free(bk);
    return 1;
}

/* The slots of class c whose value may lie in [a - r, b + r], r the reach of the class when
 * grow (else 0): slot[*i0 .. *i1). */
static void zindex_span(const zindex *X, size_t c, double a, double b, int grow, size_t *i0,
                        size_t *i1) {
    double r = grow ? ldexp(X->reach, -(int)c) : 0.0;
    *i0 = X->start[zbucket(X, c, a - r)];
    *i1 = X->start[zbucket(X, c, b + r) + 1];
}

void vm__imp_part_margin(const pstate *S, double L, double M[3]) {
    for (int k = 0; k < 3; k++) {
        double bound =
            S->v ? S->o.max_surface_move * S->row[k] : S->o.max_surface_move_free * L;
        M[k] = 2.0 * bound + BOX_SLACK * L;
    }
}

/* Stage 1 (reads the mesh only): the part's slots, the locked slots and the z range, from
 * the candidates of the batch's indices (C by centroid; K by key, for keyed parts). The
 * margin is twice the farthest a boundary vertex may be from where the pass found it, plus a
 * quarter of the longest edge for the surface flips. 0 on out-of-memory. */
static int job_scan(const pstate *S, const zindex *C, const zindex *K, job *J) {
    size_t cp = 0, cl = 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double L2 = 0.0;
    J->nps = J->nls = 0;
    const zindex *X = J->key ? K : C;
    size_t i0, i1;
    for (size_t c = 0; c < X->ncls; c++) {
        zindex_span(X, c, J->z0, J->z1, 0, &i0, &i1);
        for (size_t i = i0; i < i1; i++)
            if (in_part(S, J, X->slot[i]) && !vm__imp_push_slot(&J->ps, &J->nps, &cp, X->slot[i]))
                return 0;
    }
    if (J->nps == 0) return 1;
    if (!vm__imp_sort_slots(J->ps, J->nps)) return 0;
    for (size_t i = 0; i < J->nps; i++) {
        double a[3], b[3], l2 = vm__imp_slot_edge2(S, J->ps[i]);
        vm__imp_slot_box(S, J->ps[i], a, b);
        for (int k = 0; k < 3; k++) {
            if (a[k] < lo[k]) lo[k] = a[k];
            if (b[k] > hi[k]) hi[k] = b[k];
        }
        if (l2 > L2) L2 = l2;
    }
    /* M[k]: how far along axis k a boundary vertex may get from where it is now (twice its
     * bound from where the pass found it), and a little slack */
    double L = sqrt(L2), M[3];
    vm__imp_part_margin(S, L, M);
    for (int k = 0; k < 3; k++) {
        lo[k] -= M[k];
        hi[k] += M[k];
    }
    J->zlo = lo[2];
    J->zhi = hi[2];
    /* Which tets come within M of a part tet: the cells of a grid over the grown box that the
     * part's tets meet, grown by M. A tet meeting a marked cell is locked: a superset of the
     * tets within M (the ring among them), much smaller than all tets in the box when the
     * part is thin or sparse. */
    double ext = 0.0;
    for (int k = 0; k < 3; k++)
        if (hi[k] - lo[k] > ext) ext = hi[k] - lo[k];
    double cs = ext / GRID;
    if (!(cs > 0.0)) cs = 1.0;
    size_t gd[3];
    for (int k = 0; k < 3; k++) {
        double c = floor((hi[k] - lo[k]) / cs) + 1.0;
        gd[k] = c > GRID + 1 ? GRID + 1 : (size_t)c;
    }
    uint8_t *grid = calloc(gd[0] * gd[1] * gd[2], 1);
    if (!grid) return 0;
    for (size_t i = 0; i < J->nps; i++) {
        double a[3], b[3];
        vm__imp_slot_box(S, J->ps[i], a, b);
        size_t c0[3], c1[3];
        vm__imp_cell_range(lo, cs, gd, a, b, c0, c1);
        for (size_t z = c0[2]; z <= c1[2]; z++)
            for (size_t y = c0[1]; y <= c1[1]; y++)
                memset(grid + (z * gd[1] + y) * gd[0] + c0[0], 1, c1[0] - c0[0] + 1);
    }
    for (int k = 0; k < 3; k++)
        if (!vm__imp_dilate(grid, gd, k, (size_t)ceil(M[k] / cs) + 1)) {
            free(grid);
            return 0;
        }
    int fail = 0;
    for (size_t c = 0; c < C->ncls && !fail; c++) {
        zindex_span(C, c, lo[2], hi[2], 1, &i0, &i1);
        for (size_t i = i0; i < i1 && !fail; i++) {
            size_t t = C->slot[i];
            if (in_part(S, J, t)) continue;
            double a[3], b[3];
            vm__imp_slot_box(S, t, a, b);
            if (a[0] > hi[0] || a[1] > hi[1] || a[2] > hi[2] || b[0] < lo[0] || b[1] < lo[1] ||
                b[2] < lo[2])
                continue;
            size_t c0[3], c1[3];
            vm__imp_cell_range(lo, cs, gd, a, b, c0, c1);
            int hit = 0;
            for (size_t z = c0[2]; z <= c1[2] && !hit; z++)
                for (size_t y = c0[1]; y <= c1[1] && !hit; y++)
                    for (size_t x = c0[0]; x <= c1[0] && !hit; x++)
                        hit = grid[(z * gd[1] + y) * gd[0] + x];
            if (!hit) continue;
            if (!vm__imp_push_slot(&J->ls, &J->nls, &cl, t)) fail = 1;
            if (a[2] < J->zlo) J->zlo = a[2];
            if (b[2] > J->zhi) J->zhi = b[2];
        }
    }
    free(grid);
    return !fail && vm__imp_sort_slots(J->ls, J->nls);
}

/* With a volume given by its planes: reads the planes part J may sample into a new buffer
 * (returned; NULL with J->s set on error) and points x at them. A vertex of the submesh
 * samples the field where it is or, moving, within twice its surface bound (in voxels) of
 * it; the trilinear cell adds a plane above, and a Newton step may stray a little: three
 * planes more each side. */
static float *part_planes(pstate *S, job *J, const vm_mesh *sub, vm__imp_sub *x) {
    const vm_volume *v = S->v;
    double kmin = INFINITY, kmax = -INFINITY;
    for (size_t i = 0; i < sub->npoints; i++) {
        const double *p = sub->points + 3 * i;
        double k = S->kz[0] * (p[0] - v->origin[0]) + S->kz[1] * (p[1] - v->origin[1]) +
                   S->kz[2] * (p[2] - v->origin[2]);
        if (k < kmin) kmin = k;
        if (k > kmax) kmax = k;
    }
    double grow = 2.0 * S->o.max_surface_move + WINDOW_MARGIN;
    double lo = floor(kmin - grow), hi = ceil(kmax + grow) + WINDOW_TOP;
    double nz = (double)v->dims[2];
    int64_t k0 = lo < 0.0 ? 0 : lo > nz - 1.0 ? v->dims[2] - 1 : (int64_t)lo;
    int64_t k1 = hi > nz ? v->dims[2] : hi < (double)(k0 + 1) ? k0 + 1 : (int64_t)hi;
    float *planes;
    vm_status s;
    /* a source (a file reader) serves one call at a time */
#ifdef VM_HAVE_OPENMP
#pragma omp critical(vm_improve_planes)
#endif
    s = vm__imp_read_planes(v, S->src, S->src_user, k0, k1, &planes, &J->err);
    if (s != VM_OK) {
        J->s = s;
        return NULL;
    }
    x->planes = planes;
    x->k0 = k0;
    x->k1 = k1;
    return planes;
}

/* Stage 2: builds the submesh (the part's tets first, then the locked ones), improves it and
 * writes it back into the part's slots and points; tets beyond its slots wait in J->xt.
 * Touches only what this part reaches. */
void vm__imp_job_run(pstate *S, job *J) {
    /* cancelled: the job changes nothing (vm__imp_jobs_append appends the others) */
    if (vm__progress_poll_team(S->uo->progress, S->uo->progress_user)) {
        J->s = vm__cancelled(&J->err, "improve");
        return;
    }
    vm_mesh *m = S->m;
    size_t nc = J->nps + J->nls, ng = 0;
    /* the part's points: sorted, each once; S->loc maps them to submesh ids */
    uint32_t *gid = malloc((4 * nc + 1) * sizeof *gid);
    vm_mesh sub;
    vm_mesh_init(&sub, VM_TET4);
    uint8_t *lock = calloc(nc + 1, 1);
    float *planes = NULL;
    double *sp0 = NULL;
    size_t *tpar = NULL;
    uint8_t *tbelow = NULL, *tinside = NULL;
    vm__imp w;
    memset(&w, 0, sizeof w);
    if (!gid || !lock) goto nomem;
    for (size_t i = 0; i < nc; i++) {
        size_t t = i < J->nps ? J->ps[i] : J->ls[i - J->nps];
        for (int k = 0; k < 4; k++)
            gid[4 * i + k] = (uint32_t)m->cells[4 * t + k];
    }
    if (!vm__imp_sort_slots(gid, 4 * nc)) goto nomem;
    for (size_t i = 0; i < 4 * nc; i++)
        if (ng == 0 || gid[i] != gid[ng - 1]) gid[ng++] = gid[i];
    uint32_t *g2 = realloc(gid, (ng + 1) * sizeof *gid); /* held while the part runs */
    if (g2) gid = g2;
    for (size_t i = 0; i < ng; i++)
        S->loc[gid[i]] = (uint32_t)i;
    sub.points = malloc((3 * ng + 1) * sizeof *sub.points);
    sp0 = malloc((3 * ng + 1) * sizeof *sp0);
    sub.cells = malloc((4 * nc + 1) * sizeof *sub.cells);
    sub.region = malloc((nc + 1) * sizeof *sub.region);
    if (!sub.points || !sp0 || !sub.cells || !sub.region) goto nomem;
    for (size_t i = 0; i < ng; i++) {
        memcpy(sub.points + 3 * i, pt(S, gid[i]), 3 * sizeof(double));
        memcpy(sp0 + 3 * i, S->p0 + 3 * (size_t)gid[i], 3 * sizeof(double));
    }
    for (size_t i = 0; i < nc; i++) {
        size_t t = i < J->nps ? J->ps[i] : J->ls[i - J->nps];
        for (int k = 0; k < 4; k++)
            sub.cells[4 * i + k] = (vm_index)S->loc[m->cells[4 * t + k]];
        sub.region[i] = m->region[t];
        lock[i] = i >= J->nps;
    }
    sub.npoints = sub.point_cap = ng;
    sub.ncells = sub.cell_cap = nc;
    /* the local pass knows which tets are below the targets: the others' qualities wait */
    if (J->below_known) {
        tbelow = malloc(nc + 1);
        if (!tbelow) goto nomem;
        for (size_t i = 0; i < nc; i++)
            tbelow[i] = S->below[i < J->nps ? J->ps[i] : J->ls[i - J->nps]];
    }
    /* and which free tets have no boundary face: their faces need no search */
    if (J->bflag) {
        tinside = calloc(nc + 1, 1);
        if (!tinside) goto nomem;
        for (size_t i = 0; i < J->nps; i++)
            tinside[i] = J->bflag[J->ps[i]] == VM__IMP_BF_INSIDE;
    }
    vm__imp_sub x = {lock, sp0, S->box, J->seed, NULL, 0, 0, tbelow, tinside};
    if (S->src && !(planes = part_planes(S, J, &sub, &x))) goto done;
    sp0 = NULL; /* the run frees it and the submesh once it has copied them */
    J->s = vm__imp_run(&w, &sub, S->v, &S->o, &x, &J->passes, &J->maxmove, &J->maxiface,
                       &J->err);
    if (J->s != VM_OK) goto done;
    for (size_t t = J->nps; t < nc; t++)
        if (w.dead[t]) {
            J->s = vm_error_set(&J->err, VM_ERR_INTERNAL, "improve: a locked tet was removed");
            goto done;
        }
    /* the parents of the part's tets, before their slots are overwritten */
    if (S->par) {
        tpar = malloc((J->nps + 1) * sizeof *tpar);
        if (!tpar) goto nomem;
        for (size_t i = 0; i < J->nps; i++)
            tpar[i] = (size_t)S->par[J->ps[i]];
    }
    /* room for the tets beyond the part's slots first: nothing fails half-way */
    size_t nout = 0;
    for (size_t t = 0; t < w.ntet; t++)
        nout += !w.dead[t] && !(t >= J->nps && t < nc);
    if (nout > J->nps) {
        size_t nx = nout - J->nps;
        J->xt = malloc(nx * sizeof *J->xt);
        J->xreg = malloc(nx * sizeof *J->xreg);
        J->xpar = malloc(nx * sizeof *J->xpar);
        J->xbelow = malloc(nx);
        if (!J->xt || !J->xreg || !J->xpar || !J->xbelow) goto nomem;
    }
    for (size_t i = 0; i < ng; i++)
        if (!w.vlock[i] && !w.pdead[i])
            memcpy(m->points + 3 * (size_t)gid[i], w.p + 3 * i, 3 * sizeof(double));
    size_t k = 0;
    for (size_t t = 0; t < w.ntet; t++) {
        if (w.dead[t] || (t >= J->nps && t < nc)) continue;
        vm_index n[4];
        for (int c = 0; c < 4; c++)
            n[c] = gid[w.tet[4 * t + c]];
        vm_index pg = tpar ? (vm_index)tpar[w.parent[t]] : 0;
        if (k < J->nps) {
            size_t s = J->ps[k];
            memcpy(m->cells + 4 * s, n, sizeof n);
            m->region[s] = w.region[t];
            if (S->par) S->par[s] = pg;
            S->below[s] = w.below[t];
        } else {
            memcpy(J->xt[J->nx], n, sizeof n);
            J->xreg[J->nx] = w.region[t];
            J->xpar[J->nx] = pg;
            J->xbelow[J->nx] = w.below[t];
            J->nx++;
        }
        k++;
    }
    for (; k < J->nps; k++)
        m->cells[4 * J->ps[k]] = DEAD_SLOT;
    size_t c8[8] = {w.collapses, w.flips23,       w.flips32, w.edge_removals,
                    w.moves,     w.perturbations, w.peels,   w.boundary_flips};
    memcpy(J->cnt, c8, sizeof c8);
    goto done;
nomem:
    J->s = vm_error_set(&J->err, VM_ERR_NOMEM, "improve: out of memory for a part");
done:
    free(planes);
    vm__imp_free(&w);
    vm_mesh_free(&sub);
    free(sp0);
    free(tpar);
    free(tbelow);
    free(tinside);
    free(lock);
    free(gid);
}

void vm__imp_job_reset(job *J) {
    free(J->ps);
    free(J->ls);
    free(J->xt);
    free(J->xreg);
    free(J->xpar);
    free(J->xbelow);
    J->ps = J->ls = NULL;
    J->xt = NULL;
    J->xreg = NULL;
    J->xpar = NULL;
    J->xbelow = NULL;
    J->nps = J->nls = J->nx = 0;
}

static int slot_keep(size_t t, void *user) {
    return !slot_dead(user, t);
}

/* Moves count slots (cells, regions, parents and below flags) from `from` down to `to`. */
static void slot_move(size_t to, size_t from, size_t count, void *user) {
    pstate *S = user;
    memmove(S->m->cells + 4 * to, S->m->cells + 4 * from, 4 * count * sizeof *S->m->cells);
    memmove(S->m->region + to, S->m->region + from, count * sizeof *S->m->region);
    if (S->par) memmove(S->par + to, S->par + from, count * sizeof *S->par);
    memmove(S->below + to, S->below + from, count * sizeof *S->below);
}

/* Drops the dead slots, keeping the order of the others (on the threads). */
static void compact_slots(pstate *S) {
    S->nt = S->m->ncells = vm__compact(S->nt, slot_keep, slot_move, S);
}

/* done (0..0.9) within what vm_mesh_improve has shown before (its first checks) and after */
static void progress(const pstate *S, double done) {
    if (S->uo->progress)
        S->uo->progress("improve", 0.05 + 0.85 * done / 0.9, 1.0, S->uo->progress_user);
}

/* After a batch: the first error of jobs take[0..n) (its message to err), else room for the
 * tets beyond their slots, appended in job order (J->x0: the first one's slot), and their
 * counters and figures added to the report; then a cancelled job's VM_ERR_CANCELLED. */
vm_status vm__imp_jobs_append(pstate *S, job *jobs, const size_t *take, size_t n,
                              vm_error *err) {
    vm_status s = VM_OK;
    size_t extra = 0;
    const job *cancelled = NULL; /* the first job that did nothing, cancelled */
    for (size_t i = 0; i < n; i++) {
        job *J = &jobs[take[i]];
        if (J->s == VM_ERR_CANCELLED) {
            if (!cancelled) cancelled = J;
        } else if (J->s != VM_OK && s == VM_OK) {
            s = J->s;
            if (err) *err = J->err;
        }
        extra += J->nx;
    }
    if (s == VM_OK && extra) s = vm_mesh_reserve(S->m, S->m->npoints, S->nt + extra, err);
    if (s == VM_OK && extra && S->par) {
        vm_index *np = realloc(S->par, (S->nt + extra) * sizeof *np);
        if (!np)
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        else
            S->par = np;
    }
    if (s == VM_OK && extra) {
        uint8_t *nb = realloc(S->below, S->nt + extra);
        if (!nb)
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        else
            S->below = nb;
    }
    for (size_t i = 0; i < n && s == VM_OK; i++) {
        job *J = &jobs[take[i]];
        J->x0 = S->nt;
        for (size_t k = 0; k < J->nx; k++) {
            memcpy(S->m->cells + 4 * S->nt, J->xt[k], sizeof J->xt[k]);
            S->m->region[S->nt] = J->xreg[k];
            if (S->par) S->par[S->nt] = J->xpar[k];
            S->below[S->nt] = J->xbelow[k];
            S->nt++;
        }
        S->m->ncells = S->nt;
        vm_improve_report *r = S->r;
        size_t *c[8] = {&r->collapses,     &r->flips23,       &r->flips32,
                        &r->edge_removals, &r->moves,         &r->perturbations,
                        &r->peels,         &r->boundary_flips};
        for (int q = 0; q < 8; q++)
            *c[q] += J->cnt[q];
        if (J->passes > r->passes) r->passes = J->passes;
        if (J->maxmove > r->max_surface_move) r->max_surface_move = J->maxmove;
        if (J->maxiface > r->max_interface_move) r->max_interface_move = J->maxiface;
    }
    if (s == VM_OK && cancelled) {
        s = VM_ERR_CANCELLED;
        if (err) *err = cancelled->err;
    }
    return s;
}

/* Runs jobs order[0..n) in batches: each batch takes, in order, the jobs whose z ranges do
 * not meet those of the jobs taken before it; the others wait for the next batch (scanned
 * again, since the mesh changed). Progress goes from f0 to f1. The slots the parts empty stay
 * dead until the caller compacts them (keys stay aligned across calls). */
static vm_status run_jobs(pstate *S, job *jobs, const size_t *order, size_t n, double f0,
                          double f1, vm_error *err) {
    size_t *todo = malloc((n + 1) * sizeof *todo), *take = malloc((n + 1) * sizeof *take);
    if (!todo || !take) {
        free(todo);
        free(take);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    memcpy(todo, order, n * sizeof *todo);
    size_t ntodo = n, ndone = 0;
    vm_status s = VM_OK;
    while (ntodo && s == VM_OK) {
        int fail = 0;
        /* the jobs of one call share their key (or have none) */
        const float *key = jobs[todo[0]].key;
        zindex C, K;
        memset(&K, 0, sizeof K);
        if (!zindex_build(S, NULL, 0, &C))
            fail = 1;
        else if (key && !zindex_build(S, key, jobs[todo[0]].nkey, &K))
            fail = 1;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : fail)
#endif
        for (size_t i = 0; i < ntodo; i++)
            if (!fail && !job_scan(S, &C, &K, &jobs[todo[i]])) fail = 1;
        zindex_free(&C);
        zindex_free(&K);
        if (fail) {
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            break;
        }
        size_t ntake = 0, nleft = 0;
        for (size_t i = 0; i < ntodo; i++) {
            job *J = &jobs[todo[i]];
            int clash = 0;
            for (size_t j = 0; j < ntake && !clash; j++)
                clash = !(J->zhi < jobs[take[j]].zlo || J->zlo > jobs[take[j]].zhi);
            if (J->nps == 0)
                ndone++;
            else if (clash)
                todo[nleft++] = todo[i];
            else
                take[ntake++] = todo[i];
        }
        /* the rest are scanned again next time */
        for (size_t i = 0; i < nleft; i++) {
            job *J = &jobs[todo[i]];
            free(J->ps);
            free(J->ls);
            J->ps = J->ls = NULL;
        }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (size_t i = 0; i < ntake; i++)
            vm__imp_job_run(S, &jobs[take[i]]);
        vm_status sa = vm__imp_jobs_append(S, jobs, take, ntake, err);
        if (s == VM_OK) s = sa;
        for (size_t i = 0; i < ntake; i++)
            vm__imp_job_reset(&jobs[take[i]]);
        ndone += ntake;
        ntodo = nleft;
        progress(S, f0 + (f1 - f0) * (double)ndone / (double)(n ? n : 1));
        if (s == VM_OK) s = vm__imp_check(S->uo, err);
    }
    for (size_t i = 0; i < n; i++)
        vm__imp_job_reset(&jobs[order[i]]);
    free(todo);
    free(take);
    return s;
}

/* Slab borders cut[1..ns) (cut[0] = -inf, cut[ns] = +inf) placing about as many tet
 * centroids in each slab; fewer slabs when one would be thinner than thick mean
 * longest tet edges (else the parts around a slab would reach into each other). Returns the
 * number of slabs (>= 1) or 0 on out-of-memory. */
static size_t slab_cuts(const pstate *S, size_t want, double thick, double **cut_out) {
    double zmin = INFINITY, zmax = -INFINITY, hsum = 0.0;
    for (size_t t = 0; t < S->nt; t++) {
        double z = centroid_z(S, t);
        if (z < zmin) zmin = z;
        if (z > zmax) zmax = z;
        hsum += sqrt(vm__imp_slot_edge2(S, t));
    }
    double h = S->nt ? hsum / (double)S->nt : 0.0;
    size_t *hist = calloc(HIST, sizeof *hist);
    double *cut = malloc((want + 2) * sizeof *cut);
    if (!hist || !cut) {
        free(hist);
        free(cut);
        return 0;
    }
    double dz = (zmax - zmin) / HIST;
    for (size_t t = 0; t < S->nt && dz > 0.0; t++) {
        double b = floor((centroid_z(S, t) - zmin) / dz);
        size_t i = b < 0 ? 0 : b >= HIST ? HIST - 1 : (size_t)b;
        hist[i]++;
    }
    size_t ns = dz > 0.0 ? want : 1;
    for (; ns > 1; ns--) {
        size_t acc = 0, k = 1, i = 0;
        for (; i < HIST && k < ns; i++) {
            acc += hist[i];
            while (k < ns && (double)acc >= (double)S->nt * (double)k / (double)ns)
                cut[k++] = zmin + dz * (double)(i + 1);
        }
        cut[0] = zmin;
        cut[ns] = zmax;
        int ok = k == ns;
        for (size_t j = 0; j < ns && ok; j++)
            ok = cut[j + 1] - cut[j] >= thick * h;
        if (ok) break;
    }
    cut[0] = -INFINITY;
    cut[ns] = INFINITY;
    free(hist);
    *cut_out = cut;
    return ns;
}

unsigned vm__imp_part_seed(unsigned seed, int phase, size_t k) {
    uint64_t h = (uint64_t)(seed ? seed : 1u) * 0x9E3779B97F4A7C15ull;
    h ^= ((uint64_t)phase << 32) + (uint64_t)k * 0xC2B2AE3D27D4EB4Full;
    h ^= h >> 29;
    unsigned r = (unsigned)(h ^ (h >> 32));
    return r ? r : 1u;
}

/* Grows the marked tets (finite key) by one ring of tets sharing a vertex; a new tet takes
 * the least key of the marked tets around its vertices. */
static void key_grow(const pstate *S, float *key, float *vkey) {
    const vm_index *c = S->m->cells;
    for (size_t i = 0; i < S->m->npoints; i++)
        vkey[i] = INFINITY;
    for (size_t t = 0; t < S->nt; t++)
        if (key[t] < INFINITY)
            for (int k = 0; k < 4; k++)
                if (key[t] < vkey[c[4 * t + k]]) vkey[c[4 * t + k]] = key[t];
    for (size_t t = 0; t < S->nt; t++) {
        if (slot_dead(S, t)) continue;
        for (int k = 0; k < 4; k++)
            if (vkey[c[4 * t + k]] < key[t]) key[t] = vkey[c[4 * t + k]];
    }
}

/* Marks the tets below the targets with their centroid's z, grows the marks by rings rings
 * of tets sharing a vertex, and gives each connected group of marked tets (sharing
 * vertices) the least key in it: a group goes to one part whole. Returns the number below
 * the targets, or SIZE_MAX on out-of-memory. */
static size_t key_bad(const pstate *S, float *key, int rings) {
    size_t n = 0;
    for (size_t t = 0; t < S->nt; t++) {
        key[t] = INFINITY;
        if (!slot_dead(S, t) && S->below[t]) {
            key[t] = (float)centroid_z(S, t);
            n++;
        }
    }
    if (n == 0) return 0;
    size_t np = S->m->npoints;
    float *vkey = malloc((np + 1) * sizeof *vkey);
    size_t *up = malloc((np + 1) * sizeof *up);
    if (!vkey || !up) {
        free(vkey);
        free(up);
        return SIZE_MAX;
    }
    for (int r = 0; r < rings; r++)
        key_grow(S, key, vkey);
    const vm_index *c = S->m->cells;
    for (size_t i = 0; i < np; i++) {
        up[i] = i;
        vkey[i] = INFINITY;
    }
    for (size_t t = 0; t < S->nt; t++)
        if (key[t] < INFINITY)
            for (int k = 1; k < 4; k++)
                vm__uf_union(up, (size_t)c[4 * t], (size_t)c[4 * t + k]);
    for (size_t t = 0; t < S->nt; t++) {
        if (!(key[t] < INFINITY)) continue;
        size_t r = vm__uf_find(up, (size_t)c[4 * t]);
        if (key[t] < vkey[r]) vkey[r] = key[t];
    }
    for (size_t t = 0; t < S->nt; t++)
        if (key[t] < INFINITY) key[t] = vkey[vm__uf_find(up, (size_t)c[4 * t])];
    free(vkey);
    free(up);
    return n;
}

/* Drops the points no tet uses (keeping the order of the others) and permutes the cell
 * fields to the tets' input cells. */
vm_status vm__imp_parts_finish(pstate *S, vm_error *err) {
    compact_slots(S);
    vm_mesh *m = S->m;
    vm_index *map = malloc((m->npoints + 1) * sizeof *map);
    if (!map) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t i = 0; i < m->npoints; i++)
        map[i] = -1;
    for (size_t i = 0; i < 4 * m->ncells; i++)
        map[m->cells[i]] = 0;
    size_t np = 0;
    for (size_t i = 0; i < m->npoints; i++)
        if (map[i] >= 0) map[i] = (vm_index)np++;
    double **cf = calloc(m->ncell_fields + 1, sizeof *cf);
    int fail = !cf;
    for (size_t f = 0; !fail && f < m->ncell_fields; f++) {
        cf[f] = malloc((m->ncells + 1) * (size_t)m->cell_fields[f].ncomp * sizeof(double));
        if (!cf[f]) fail = 1;
    }
    if (fail) {
        for (size_t f = 0; cf && f < m->ncell_fields; f++)
            free(cf[f]);
        free(cf);
        free(map);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t f = 0; f < m->ncell_fields; f++) {
        size_t nc = (size_t)m->cell_fields[f].ncomp;
        for (size_t i = 0; i < m->ncells; i++)
            memcpy(cf[f] + i * nc, m->cell_fields[f].data + (size_t)S->par[i] * nc,
                   nc * sizeof(double));
        free(m->cell_fields[f].data);
        m->cell_fields[f].data = cf[f];
    }
    free(cf);
    /* points and point fields move down in place: map[i] <= i */
    for (size_t i = 0; i < m->npoints; i++) {
        if (map[i] < 0) continue;
        size_t j = (size_t)map[i];
        memmove(m->points + 3 * j, m->points + 3 * i, 3 * sizeof(double));
        for (size_t f = 0; f < m->npoint_fields; f++) {
            size_t nc = (size_t)m->point_fields[f].ncomp;
            memmove(m->point_fields[f].data + j * nc, m->point_fields[f].data + i * nc,
                    nc * sizeof(double));
        }
    }
    for (size_t i = 0; i < 4 * m->ncells; i++)
        m->cells[i] = map[m->cells[i]];
    m->npoints = np;
    free(map);
    return VM_OK;
}

vm_status vm__imp_pstate_init(pstate *S, vm_mesh *m, const vm_volume *v, vm_plane_source src,
                              void *src_user, const vm_improve_options *o, vm_improve_report *r,
                              vm_error *err) {
    memset(S, 0, sizeof *S);
    S->m = m;
    S->v = v;
    S->src = v ? src : NULL;
    S->src_user = src_user;
    if (S->src) {
        /* row 2 of the inverse of the index frame A (world = origin + A ijk), as imp_init */
        double A[3][3], Ainv[3][3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                A[i][j] = v->direction[i][j] * v->spacing[j];
        if (!vm__imp_invert3(A, Ainv))
            return vm_error_set(err, VM_ERR_ARG,
                                "improve: the volume's index frame is singular");
        memcpy(S->kz, Ainv[2], sizeof S->kz);
    }
    S->uo = o;
    S->o = *o;
    S->o.progress = NULL;
    S->o.mark_unfixed = 0;
    S->nt = m->ncells;
    S->r = r;
    /* with a volume: |x_k| <= |row k of A| |ijk| (world = org + A ijk), a little over */
    for (int k = 0; v && k < 3; k++) {
        double f = 0.0;
        for (int c = 0; c < 3; c++) {
            double a = v->direction[k][c] * v->spacing[c];
            f += a * a;
        }
        S->row[k] = ROW_SLACK * sqrt(f);
    }
    S->p0 = malloc((3 * m->npoints + 1) * sizeof *S->p0);
    if (m->ncell_fields) S->par = malloc((m->ncells + 1) * sizeof *S->par);
    S->below = malloc(m->ncells + 1);
    S->loc = malloc((m->npoints + 1) * sizeof *S->loc);
    if (!S->p0 || (m->ncell_fields && !S->par) || !S->below || !S->loc) {
        vm__imp_pstate_free(S);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    memcpy(S->p0, m->points, 3 * m->npoints * sizeof *S->p0);
    for (size_t t = 0; S->par && t < m->ncells; t++)
        S->par[t] = (vm_index)t;
    for (int a = 0; a < 3; a++) {
        S->box[a] = INFINITY;
        S->box[3 + a] = -INFINITY;
    }
    for (size_t i = 0; i < m->npoints; i++)
        for (int a = 0; a < 3; a++) {
            double x = m->points[3 * i + a];
            if (x < S->box[a]) S->box[a] = x;
            if (x > S->box[3 + a]) S->box[3 + a] = x;
        }
    return VM_OK;
}

void vm__imp_pstate_free(pstate *S) {
    free(S->p0);
    free(S->par);
    free(S->below);
    free(S->loc);
    S->p0 = NULL;
    S->par = NULL;
    S->below = NULL;
    S->loc = NULL;
}

vm_status vm__imp_parts_run(vm_mesh *m, const vm_volume *v, vm_plane_source src, void *src_user,
                            const vm_improve_options *o, size_t nparts, vm_improve_report *r,
                            vm_error *err) {
    pstate S;
    vm_status s0 = vm__imp_pstate_init(&S, m, v, src, src_user, o, r, err);
    if (s0 != VM_OK) return s0;
    /* every slot is in a slab of the first phase, which sets its below flag */
    double *cut = NULL;
    size_t ns = slab_cuts(&S, nparts, o->parts > 1 ? MIN_THICK_ASKED : MIN_THICK, &cut);
    job *jobs = ns ? calloc(ns, sizeof *jobs) : NULL;
    size_t *order = ns ? malloc(ns * sizeof *order) : NULL;
    float *key = NULL;
    vm_status s = VM_OK;
    if (!jobs || !order) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    /* Phase 1: the slabs, even ones first. */
    size_t no = 0;
    for (size_t k = 0; s == VM_OK && k < ns; k += 2)
        order[no++] = k;
    for (size_t k = 1; s == VM_OK && k < ns; k += 2)
        order[no++] = k;
    for (size_t k = 0; s == VM_OK && k < ns; k++) {
        jobs[k].z0 = cut[k];
        jobs[k].z1 = cut[k + 1];
        jobs[k].seed = vm__imp_part_seed(o->seed, 1, k);
    }
    /* evens, then odds: the parts of a call are all scanned before they run */
    size_t ne = (ns + 1) / 2;
    if (s == VM_OK) s = run_jobs(&S, jobs, order, ne, 0.0, BAR_EVENS, err);
    if (s == VM_OK && no > ne)
        s = run_jobs(&S, jobs, order + ne, no - ne, BAR_EVENS, BAR_SLABS, err);
    compact_slots(&S);
    /* Then rounds over the tets still below the targets, anywhere, with two rings of tets
     * around them: first by the slabs shifted by half a slab (their borders were locked in
     * the slabs), then by the slabs, and so on while the count goes down. */
    size_t nbad_last = SIZE_MAX;
    for (int round = 0; round < BAND_ROUNDS && s == VM_OK && ns > 1; round++) {
        /* the keys cover the slots appended since */
        float *nk = realloc(key, (S.nt + 1) * sizeof *nk);
        if (!nk) {
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            break;
        }
        key = nk;
        size_t nb = key_bad(&S, key, RINGS);
        if (nb == SIZE_MAX) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        if (nb == SIZE_MAX || nb == 0 || nb >= nbad_last) break;
        nbad_last = nb;
        int shifted = round % 2 == 0;
        size_t nj = shifted ? ns - 1 : ns;
        for (size_t k = 0; k < nj; k++) {
            memset(&jobs[k], 0, sizeof jobs[k]);
            if (shifted) {
                jobs[k].z0 = k == 0 ? -INFINITY : 0.5 * (cut[k] + cut[k + 1]);
                jobs[k].z1 = k + 1 == nj ? INFINITY : 0.5 * (cut[k + 1] + cut[k + 2]);
            } else {
                jobs[k].z0 = cut[k];
                jobs[k].z1 = cut[k + 1];
            }
            jobs[k].key = key;
            jobs[k].nkey = S.nt;
            jobs[k].seed = vm__imp_part_seed(o->seed, 2 + round, k);
        }
        no = 0;
        for (size_t k = 0; k < nj; k += 2)
            order[no++] = k;
        for (size_t k = 1; k < nj; k += 2)
            order[no++] = k;
        double f0 = BAR_SLABS + BAR_BANDS * (1.0 - pow(0.5, round)),
               f1 = BAR_SLABS + BAR_BANDS * (1.0 - pow(0.5, round + 1));
        size_t nje = (nj + 1) / 2;
        s = run_jobs(&S, jobs, order, nje, f0, 0.5 * (f0 + f1), err);
        if (s == VM_OK && no > nje)
            s = run_jobs(&S, jobs, order + nje, no - nje, 0.5 * (f0 + f1), f1, err);
        compact_slots(&S);
    }
    /* also after an error: the mesh stays valid (the parts done so far improved) */
    vm_error e2;
    vm_status s2 = vm__imp_parts_finish(&S, &e2);
    if (s == VM_OK && s2 != VM_OK) {
        s = s2;
        if (err) *err = e2;
    }
    free(key);
    free(order);
    free(jobs);
    free(cut);
    vm__imp_pstate_free(&S);
    return s;
}
