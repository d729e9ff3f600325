/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_local.c — the local quality pass (issue #32): only the tets below the
 * targets are worked on, each with RINGS rings of tets around it, in jobs by blocks of space.
 * The blocks of one colour (the parity of their three indices) run at the same time on
 * OpenMP threads, the eight colours one after the other; each job is a run of improve_run.c
 * over its submesh (vm__imp_job_run of improve_parts.c), every tet within the margin around
 * it locked. Rounds repeat this over the tets still below the targets while their number
 * goes down.
 *
 * Cost: one sweep of the tets tells which are below the targets (on cosines: no inverse
 * trigonometry but near a limit) and builds the vertex stars and a grid of the tets' boxes;
 * from then on only the tets below the targets and their neighbourhoods are read or set up,
 * and the stars and the grid follow the jobs' changes. A mesh with no tet below the targets
 * costs that one sweep.
 *
 * Why it is sound: as for the parts (improve_parts.c), a job's free vertices have their whole
 * stars in its submesh, and every tet within the margin of its free tets is in it, locked: a
 * vertex of a locked tet never moves and a locked tet is never replaced. A job reads and
 * writes only inside its box (its free tets' box grown by the margin, and the locked tets'
 * boxes): jobs run at the same time have disjoint boxes, so they share no tet and no point,
 * and no boundary triangle one of them makes can reach a triangle of another. A job is
 * scanned (its tets found) just before its batch runs, on the stars and the grid as the
 * batches before left them.
 *
 * Determinism: blocks, jobs, their order, their seeds and the batches depend on the mesh
 * only, never on the thread count, and a job reads nothing another job of its batch writes;
 * the tets jobs add beyond their slots are appended in job order. */
#include "../core/core.h"
#include "improve_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>
#ifdef VM_HAVE_OPENMP
#include <omp.h>
#endif

#define RINGS 2          /* rings of free tets (sharing a vertex) around each bad tet */
#define ROUNDS 4         /* most rounds over the tets below the targets */
#define BLOCK_EDGES 12.0 /* a block is this many mean longest edges of the bad tets a side */
#define CELL_EDGES 3.0   /* a cell of the tet grid: at least this many of them a side */
#define CELL_TETS 4.0    /* and about this many tets per cell at most on average */
#define CELL_AXIS 2048   /* most cells of the tet grid along an axis */
#define GRID 24          /* cells a side of the grid that finds the tets near a job */
#define COLOURS 8
#define DEAD VM__IMP_DEAD_SLOT

typedef vm__imp_pstate pstate;
typedef vm__imp_job job;

/* --- stars: the live slots around each point ------------------------------------------ */

/* Built once (CSR); a point whose star a job changed gets its own list in ov (ov[v][0]
 * tets, then their slots). */
typedef struct lstars {
    size_t *start;
    uint32_t *list;
    uint32_t **ov;
    size_t np;
} lstars;

static const uint32_t *star_of(const lstars *T, size_t v, size_t *n) {
    if (T->ov[v]) {
        *n = T->ov[v][0];
        return T->ov[v] + 1;
    }
    *n = T->start[v + 1] - T->start[v];
    return T->list + T->start[v];
}

static void stars_free(lstars *T) {
    if (T->ov)
        for (size_t v = 0; v < T->np; v++)
            free(T->ov[v]);
    free(T->ov);
    free(T->start);
    free(T->list);
    memset(T, 0, sizeof *T);
}

/* 0 on out-of-memory. */
static int stars_build(const pstate *S, lstars *T) {
    size_t np = S->m->npoints, nt = S->nt;
    const vm_index *c = S->m->cells;
    memset(T, 0, sizeof *T);
    T->np = np;
    T->start = calloc(np + 2, sizeof *T->start);
    T->list = malloc((4 * nt + 1) * sizeof *T->list);
    T->ov = calloc(np + 1, sizeof *T->ov);
    if (!T->start || !T->list || !T->ov) {
        stars_free(T);
        return 0;
    }
    /* a counting sort on the threads, each star then sorted: the same lists for any
     * thread count */
    const ptrdiff_t pnt = (ptrdiff_t)nt, pnp = (ptrdiff_t)np;
    size_t *start = T->start;
    uint32_t *list = T->list;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t t = 0; t < pnt; t++)
        if (c[4 * t] != DEAD)
            for (int k = 0; k < 4; k++) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
                start[(size_t)c[4 * t + k] + 2]++;
            }
    for (size_t v = 0; v < np; v++)
        start[v + 2] += start[v + 1];
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t t = 0; t < pnt; t++)
        if (c[4 * t] != DEAD)
            for (int k = 0; k < 4; k++) {
                size_t at;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic capture
#endif
                at = start[(size_t)c[4 * t + k] + 1]++;
                list[at] = (uint32_t)t;
            }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t v = 0; v < pnp; v++)
        vm__sort_u32(list + start[v], start[v + 1] - start[v]);
    return 1;
}

/* --- the grid of the tets' boxes ---------------------------------------------------------- */

typedef struct cvec {
    uint32_t *a;
    uint32_t n, cap;
} cvec;

/* Each live tet with a boundary face is listed in every cell its box meets (built once; the
 * tets jobs write, and those whose flag a job's changes reset from BF_NO, are added to more[],
 * where the cells' earlier entries for them stay: a query checks the boxes). The scans look
 * for boundary tets only: a tet known to have none was never wanted from the grid, and
 * listing only the others keeps each scan to the boundary near its job. */
typedef struct lgrid {
    double lo[3], cs;
    size_t gd[3];
    size_t *start;
    uint32_t *list;
    cvec *more;
} lgrid;

static void grid_free(lgrid *G) {
    size_t nc = G->gd[0] * G->gd[1] * G->gd[2];
    if (G->more)
        for (size_t i = 0; i < nc; i++)
            free(G->more[i].a);
    free(G->more);
    free(G->start);
    free(G->list);
    memset(G, 0, sizeof *G);
}

static void cells_of(const lgrid *G, const double a[3], const double b[3], size_t c0[3],
                     size_t c1[3]) {
    vm__imp_cell_range(G->lo, G->cs, G->gd, a, b, c0, c1);
}

/* 0 on out-of-memory. bflag: every live slot's flag (on_boundary); the slots with none
 * (BF_NO) are left out. */
static int grid_build(const pstate *S, double h, const uint8_t *bflag, lgrid *G) {
    memset(G, 0, sizeof *G);
    double ext[3], vol = 1.0;
    for (int k = 0; k < 3; k++) {
        ext[k] = S->box[3 + k] - S->box[k];
        vol *= ext[k] > h ? ext[k] : h;
    }
    double cs = CELL_EDGES * h, byn = cbrt(vol * CELL_TETS / (double)(S->nt ? S->nt : 1));
    if (byn > cs) cs = byn;
    for (int k = 0; k < 3; k++)
        if (ext[k] / cs > CELL_AXIS - 1) cs = ext[k] / (CELL_AXIS - 1);
    if (!(cs > 0.0) || !isfinite(cs)) cs = 1.0;
    for (int k = 0; k < 3; k++) {
        G->lo[k] = S->box[k];
        double n = floor(ext[k] / cs) + 1.0;
        G->gd[k] = !(n >= 1.0) ? 1 : n > CELL_AXIS ? CELL_AXIS : (size_t)n;
    }
    G->cs = cs;
    size_t nc = G->gd[0] * G->gd[1] * G->gd[2];
    G->start = calloc(nc + 2, sizeof *G->start);
    G->more = calloc(nc + 1, sizeof *G->more);
    if (!G->start || !G->more) {
        grid_free(G);
        return 0;
    }
    /* twice over the tets on the threads: count, then fill; then each cell's list sorted
     * (the same lists for any thread count) */
    const ptrdiff_t pnt = (ptrdiff_t)S->nt;
    for (int pass = 0; pass < 2; pass++) {
        size_t *start = G->start;
        uint32_t *list = G->list;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
        for (ptrdiff_t pt = 0; pt < pnt; pt++) {
            size_t t = (size_t)pt;
            if (S->m->cells[4 * t] == DEAD || bflag[t] == VM__IMP_BF_INSIDE) continue;
            double a[3], b[3];
            size_t c0[3], c1[3];
            vm__imp_slot_box(S, t, a, b);
            cells_of(G, a, b, c0, c1);
            for (size_t z = c0[2]; z <= c1[2]; z++)
                for (size_t y = c0[1]; y <= c1[1]; y++)
                    for (size_t x = c0[0]; x <= c1[0]; x++) {
                        size_t i = (z * G->gd[1] + y) * G->gd[0] + x;
                        if (pass == 0) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
                            start[i + 2]++;
                        } else {
                            size_t at;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic capture
#endif
                            at = start[i + 1]++;
                            list[at] = (uint32_t)t;
                        }
                    }
        }
        if (pass == 0) {
            for (size_t i = 0; i < nc; i++)
                G->start[i + 2] += G->start[i + 1];
            G->list = malloc((G->start[nc + 1] + 1) * sizeof *G->list);
            if (!G->list) {
                grid_free(G);
                return 0;
            }
        }
    }
    const ptrdiff_t pnc = (ptrdiff_t)nc;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t i = 0; i < pnc; i++)
        vm__sort_u32(G->list + G->start[i], G->start[i + 1] - G->start[i]);
    return 1;
}

/* Lists slot t in the cells its box meets now; 0 on out-of-memory. */
static int grid_add(const pstate *S, lgrid *G, size_t t) {
    double a[3], b[3];
    size_t c0[3], c1[3];
    vm__imp_slot_box(S, t, a, b);
    cells_of(G, a, b, c0, c1);
    for (size_t z = c0[2]; z <= c1[2]; z++)
        for (size_t y = c0[1]; y <= c1[1]; y++)
            for (size_t x = c0[0]; x <= c1[0]; x++) {
                cvec *v = &G->more[(z * G->gd[1] + y) * G->gd[0] + x];
                if (v->n == v->cap) {
                    uint32_t cap = v->cap ? 2 * v->cap : 8;
                    uint32_t *na = realloc(v->a, cap * sizeof *na);
                    if (!na) return 0;
                    v->a = na;
                    v->cap = cap;
                }
                v->a[v->n++] = (uint32_t)t;
            }
    return 1;
}

/* --- lists of slots --------------------------------------------------------------------------
 */

typedef struct slist {
    uint32_t *a;
    size_t n, cap;
} slist;

static int sl_push(slist *l, size_t t) {
    return vm__imp_push_slot(&l->a, &l->n, &l->cap, t);
}

/* Sorts l and drops the repeats; 0 on out-of-memory. */
static int sl_unique(slist *l) {
    if (l->n < 2) return 1;
    if (!vm__imp_sort_slots(l->a, l->n)) return 0;
    size_t u = 1;
    for (size_t i = 1; i < l->n; i++)
        if (l->a[i] != l->a[u - 1]) l->a[u++] = l->a[i];
    l->n = u;
    return 1;
}

/* --- the pass ------------------------------------------------------------------------------
 */

struct scratch;
typedef struct lpass {
    pstate S;
    lstars T;
    lgrid G;
    double E;      /* block edge */
    size_t nb[3];  /* blocks a side */
    slist bad;     /* slots below the targets when last written (may repeat, or be fixed or
                      dead since) */
    uint8_t *mark; /* per slot, for the updates (serial) */
    size_t mark_cap;
    uint32_t *pidx; /* per point, for the updates (serial): UINT32_MAX between them */
    uint8_t *bflag; /* per slot: 0 not known, else BF_YES / BF_NO (a boundary face or not);
                       the scans set them (atomically: two may measure the same tet) */
    size_t bflag_cap;
    struct scratch *W; /* per thread, for the scans */
    int nw;
} lpass;

/* What a job needs beyond vm__imp_job: its block and the points of its free tets. */
typedef struct ljob {
    size_t block;
    slist seeds;
    slist pts;
    int scan_ok;
    /* local_update's results for local_commit: the tets to list in the grid and in P->bad,
     * in order, and its status (1 ok, 0 out of memory, -1 a tet with a point not J's) */
    slist grid, bad;
    int update;
} ljob;

static int slot_live(const pstate *S, size_t t) {
    return t < S->nt && S->m->cells[4 * t] != DEAD;
}

static void centroid(const pstate *S, size_t t, double c[3]) {
    const vm_index *n = S->m->cells + 4 * t;
    for (int k = 0; k < 3; k++) {
        c[k] = 0.0;
        for (int j = 0; j < 4; j++)
            c[k] += 0.25 * S->m->points[3 * (size_t)n[j] + k];
    }
}

/* Block index of slot t (z-major), and its colour. */
static size_t block_of(const lpass *P, size_t t, int *colour) {
    double c[3];
    size_t b[3];
    centroid(&P->S, t, c);
    for (int k = 0; k < 3; k++) {
        double x = floor((c[k] - P->S.box[k]) / P->E);
        b[k] = x < 0.0 ? 0 : x >= (double)P->nb[k] ? P->nb[k] - 1 : (size_t)x;
    }
    *colour = (int)((b[0] & 1) | (b[1] & 1) << 1 | (b[2] & 1) << 2);
    return (b[2] * P->nb[1] + b[1]) * P->nb[0] + b[0];
}

/* The slots of P->bad still live and below the targets, sorted, each once. */
static int bad_now(lpass *P) {
    slist *l = &P->bad;
    size_t c = 0;
    for (size_t i = 0; i < l->n; i++)
        if (slot_live(&P->S, l->a[i]) && P->S.below[l->a[i]]) l->a[c++] = l->a[i];
    l->n = c;
    return sl_unique(l);
}

/* Whether the tet in slot t has a face no other tet shares (a boundary face), on the
 * stars as they are: cached in P->bflag until a job changes the tet or a neighbour. */
enum { BF_UNKNOWN = 0, BF_YES = 1, BF_NO = VM__IMP_BF_INSIDE };
static int on_boundary(const lpass *P, size_t t) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    uint8_t f;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic read
#endif
    f = P->bflag[t];
    if (f != BF_UNKNOWN) return f == BF_YES;
    const vm_index *n = P->S.m->cells + 4 * t;
    int bnd = 0;
    size_t sz[4];
    const uint32_t *sts[4];
    for (int k = 0; k < 4; k++) sts[k] = star_of(&P->T, (size_t)n[k], &sz[k]);
    for (int k = 0; k < 4 && !bnd; k++) {
        /* the face's shared tet, if any, is in the star of each of its nodes: the smallest */
        int s0 = fo[k][0];
        for (int j = 1; j < 3; j++)
            if (sz[fo[k][j]] < sz[s0]) s0 = fo[k][j];
        vm_index b = s0 == fo[k][0] ? n[fo[k][1]] : n[fo[k][0]];
        vm_index c = s0 == fo[k][2] ? n[fo[k][1]] : n[fo[k][2]];
        size_t ns = sz[s0];
        const uint32_t *st = sts[s0];
        int shared = 0;
        for (size_t i = 0; i < ns && !shared; i++) {
            if (st[i] == t) continue;
            const vm_index *m = P->S.m->cells + 4 * (size_t)st[i];
            int hb = m[0] == b || m[1] == b || m[2] == b || m[3] == b;
            shared = hb && (m[0] == c || m[1] == c || m[2] == c || m[3] == c);
        }
        bnd = !shared;
    }
    f = bnd ? BF_YES : BF_NO;
    uint8_t *dst = &P->bflag[t];
#ifdef VM_HAVE_OPENMP
#pragma omp atomic write
#endif
    *dst = f;
    return bnd;
}

/* Per-thread scratch of the scans: a mark per slot and per point (0 between scans). */
enum { M_NONE = 0, M_FREE = 1, M_LOCK = 2, M_NO = 3 };
typedef struct scratch {
    uint8_t *sm, *pm;
    size_t scap, pcap;
    slist no; /* slots a scan looked at and left out */
} scratch;

/* Stage 1 (reads only): J's tets (seeds and RINGS rings), its points, the locked tets
 * (sharing a point with them, or within the margin of them) and its box. 0 on nomem. */
static int local_scan(const lpass *P, job *J, ljob *X, scratch *W) {
    const pstate *S = &P->S;
    const lstars *T = &P->T;
    uint8_t *sm = W->sm, *pm = W->pm;
    slist F = {NULL, 0, 0}, L = {NULL, 0, 0};
    slist *V = &X->pts;
    int ok = 1;
    V->n = 0;
    W->no.n = 0;
    /* the seeds still there and below the targets (a batch before may have changed them) */
    for (size_t i = 0; i < X->seeds.n && ok; i++) {
        uint32_t t = X->seeds.a[i];
        if (!slot_live(S, t) || !S->below[t] || sm[t]) continue;
        sm[t] = M_FREE;
        ok = sl_push(&F, t);
    }
    if (ok && F.n == 0) {
        /* nothing left to mend (a job before mended its seeds): no tets and an empty box.
         * (The box of no tets came out infinite, and its grid's size from it an allocation
         * that failed: the pass ended "out of memory" on the CT head at --distance 1.242893.)
         */
        for (int k = 0; k < 3; k++) {
            J->lo[k] = INFINITY;
            J->hi[k] = -INFINITY;
        }
        J->ps = J->ls = NULL;
        J->nps = J->nls = 0;
        return 1;
    }
    /* rings: the tets around the points of the tets taken so far; then the points of the
     * last ring */
    size_t done = 0;
    for (int r = 0; r <= RINGS && ok; r++) {
        size_t end = F.n;
        for (size_t i = done; i < end && ok; i++)
            for (int k = 0; k < 4 && ok; k++) {
                uint32_t v = (uint32_t)S->m->cells[4 * (size_t)F.a[i] + k];
                if (pm[v]) continue;
                pm[v] = 1;
                ok = sl_push(V, v);
                if (r == RINGS) continue;
                size_t ns;
                const uint32_t *st = star_of(T, v, &ns);
                for (size_t j = 0; j < ns && ok; j++)
                    if (!sm[st[j]]) {
                        sm[st[j]] = M_FREE;
                        ok = sl_push(&F, st[j]);
                    }
            }
        done = end;
    }
    /* locked: the tets sharing a point with F */
    for (size_t i = 0; i < V->n && ok; i++) {
        size_t ns;
        const uint32_t *st = star_of(T, V->a[i], &ns);
        for (size_t j = 0; j < ns && ok; j++)
            if (!sm[st[j]]) {
                sm[st[j]] = M_LOCK;
                ok = sl_push(&L, st[j]);
            }
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double L2 = 0.0;
    for (size_t i = 0; i < F.n && ok; i++) {
        double a[3], b[3], l2 = vm__imp_slot_edge2(S, F.a[i]);
        vm__imp_slot_box(S, F.a[i], a, b);
        for (int k = 0; k < 3; k++) {
            if (a[k] < lo[k]) lo[k] = a[k];
            if (b[k] > hi[k]) hi[k] = b[k];
        }
        if (l2 > L2) L2 = l2;
    }
    double M[3];
    vm__imp_part_margin(S, sqrt(L2), M);
    for (int k = 0; k < 3; k++) {
        lo[k] -= M[k];
        hi[k] += M[k];
    }
    /* The tets within the margin of F: those meeting the cells of a small grid over the grown
     * box that F's tets meet, grown by the margin (as the parts find theirs). */
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
    uint8_t *grid = ok ? calloc(gd[0] * gd[1] * gd[2], 1) : NULL;
    if (!grid) ok = 0;
    for (size_t i = 0; i < F.n && ok; i++) {
        double a[3], b[3];
        size_t c0[3], c1[3];
        vm__imp_slot_box(S, F.a[i], a, b);
        vm__imp_cell_range(lo, cs, gd, a, b, c0, c1);
        for (size_t z = c0[2]; z <= c1[2]; z++)
            for (size_t y = c0[1]; y <= c1[1]; y++)
                memset(grid + (z * gd[1] + y) * gd[0] + c0[0], 1, c1[0] - c0[0] + 1);
    }
    for (int k = 0; k < 3 && ok; k++)
        ok = vm__imp_dilate(grid, gd, k, (size_t)ceil(M[k] / cs) + 1);
    double xlo[3], xhi[3];
    memcpy(xlo, lo, sizeof xlo);
    memcpy(xhi, hi, sizeof xhi);
    const lgrid *G = &P->G;
    size_t g0[3], g1[3];
    cells_of(G, lo, hi, g0, g1);
    for (size_t z = g0[2]; z <= g1[2] && ok; z++)
        for (size_t y = g0[1]; y <= g1[1] && ok; y++)
            for (size_t x = g0[0]; x <= g1[0] && ok; x++) {
                size_t ci = (z * G->gd[1] + y) * G->gd[0] + x;
                size_t n0 = G->start[ci + 1] - G->start[ci];
                const uint32_t *base = G->list + G->start[ci];
                for (size_t j = 0; j < n0 + G->more[ci].n && ok; j++) {
                    uint32_t t = j < n0 ? base[j] : G->more[ci].a[j - n0];
                    if (t >= S->nt || sm[t] || !slot_live(S, t)) continue;
                    /* known to have no boundary face: left out whatever its box (below) */
                    uint8_t bf;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic read
#endif
                    bf = P->bflag[t];
                    if (bf == BF_NO) {
                        sm[t] = M_NO;
                        ok = sl_push(&W->no, t);
                        continue;
                    }
                    double a[3], b[3];
                    vm__imp_slot_box(S, t, a, b);
                    int hit = !(a[0] > hi[0] || a[1] > hi[1] || a[2] > hi[2] || b[0] < lo[0] ||
                                b[1] < lo[1] || b[2] < lo[2]);
                    if (hit) {
                        size_t c0[3], c1[3];
                        vm__imp_cell_range(lo, cs, gd, a, b, c0, c1);
                        hit = 0;
                        for (size_t zz = c0[2]; zz <= c1[2] && !hit; zz++)
                            for (size_t yy = c0[1]; yy <= c1[1] && !hit; yy++)
                                for (size_t xx = c0[0]; xx <= c1[0] && !hit; xx++)
                                    hit = grid[(zz * gd[1] + yy) * gd[0] + xx];
                    }
                    /* only a boundary face can be crossed: the tets inside, not sharing a point
                     * with F, are left out (the faces that leaves uncovered are interior ones
                     * no move of F's points can reach without inverting F's tets first) */
                    if (hit && !on_boundary(P, t)) hit = 0;
                    if (hit) {
                        sm[t] = M_LOCK;
                        ok = sl_push(&L, t);
                        for (int k = 0; k < 3; k++) {
                            if (a[k] < xlo[k]) xlo[k] = a[k];
                            if (b[k] > xhi[k]) xhi[k] = b[k];
                        }
                    } else {
                        sm[t] = M_NO;
                        ok = sl_push(&W->no, t);
                    }
                }
            }
    free(grid);
    /* the star ring's boxes (the margin's are in already) */
    for (size_t i = 0; i < L.n && ok; i++) {
        double a[3], b[3];
        vm__imp_slot_box(S, L.a[i], a, b);
        for (int k = 0; k < 3; k++) {
            if (a[k] < xlo[k]) xlo[k] = a[k];
            if (b[k] > xhi[k]) xhi[k] = b[k];
        }
    }
    /* the marks back to 0 */
    for (size_t i = 0; i < F.n; i++)
        sm[F.a[i]] = 0;
    for (size_t i = 0; i < L.n; i++)
        sm[L.a[i]] = 0;
    for (size_t i = 0; i < W->no.n; i++)
        sm[W->no.a[i]] = 0;
    for (size_t i = 0; i < V->n; i++)
        pm[V->a[i]] = 0;
    ok = ok && vm__imp_sort_slots(F.a, F.n) && vm__imp_sort_slots(L.a, L.n) &&
         vm__imp_sort_slots(V->a, V->n);
    memcpy(J->lo, xlo, sizeof xlo);
    memcpy(J->hi, xhi, sizeof xhi);
    J->ps = F.a;
    J->nps = F.n;
    J->ls = L.a;
    J->nls = L.n;
    if (!ok || F.n == 0) {
        free(F.a);
        free(L.a);
        J->ps = J->ls = NULL;
        J->nps = J->nls = 0;
    }
    return ok;
}

static int boxes_meet(const job *A, const job *B) {
    for (int k = 0; k < 3; k++)
        if (A->hi[k] < B->lo[k] || B->hi[k] < A->lo[k]) return 0;
    return 1;
}

/* After J ran and its extra tets were appended: the stars of its points, the grid and the
 * list of bad tets follow what it wrote. 0 on nomem, -1 when a tet it wrote has a point
 * outside its free tets (it cannot). */
static int local_update(lpass *P, const job *J, ljob *X) {
    pstate *S = &P->S;
    X->grid.n = X->bad.n = 0;
    const uint32_t *pts = X->pts.a;
    size_t np = X->pts.n, nout = 0;
    /* the slots J wrote: its own, live, then its extra ones */
    slist out = {NULL, 0, 0};
    int ok = 1;
    for (size_t i = 0; i < J->nps && ok; i++)
        if (slot_live(S, J->ps[i])) ok = sl_push(&out, J->ps[i]);
    for (size_t k = 0; k < J->nx && ok; k++)
        ok = sl_push(&out, J->x0 + k);
    nout = out.n;
    /* per point of J: how many written tets hold it, then which */
    size_t *cnt = ok ? calloc(np + 1, sizeof *cnt) : NULL;
    uint32_t *who = ok ? malloc((4 * nout + 1) * sizeof *who) : NULL;
    if (!cnt || !who) ok = 0;
    int bad_point = 0;
    uint32_t *pidx = P->pidx;
    for (size_t j = 0; j < np; j++)
        pidx[pts[j]] = (uint32_t)j;
    for (size_t i = 0; i < nout && ok && !bad_point; i++)
        for (int k = 0; k < 4; k++) {
            uint32_t j = pidx[S->m->cells[4 * (size_t)out.a[i] + k]];
            if (j == UINT32_MAX)
                bad_point = 1;
            else
                cnt[j + 1]++;
        }
    if (ok && !bad_point) {
        for (size_t j = 0; j < np; j++)
            cnt[j + 1] += cnt[j];
        for (size_t i = 0; i < nout; i++)
            for (int k = 0; k < 4; k++) {
                uint32_t j = pidx[S->m->cells[4 * (size_t)out.a[i] + k]];
                who[cnt[j]++] = out.a[i];
            }
        /* cnt[j] is now the end of point j's written tets; they start at cnt[j - 1] */
        for (size_t i = 0; i < J->nps; i++)
            P->mark[J->ps[i]] = 1;
        for (size_t j = 0; j < np && ok; j++) {
            size_t ns, w0 = j ? cnt[j - 1] : 0, w1 = cnt[j], c = 0;
            const uint32_t *st = star_of(&P->T, pts[j], &ns);
            for (size_t i = 0; i < ns; i++)
                c += !P->mark[st[i]];
            uint32_t *nl = malloc((c + (w1 - w0) + 1) * sizeof *nl);
            if (!nl) {
                ok = 0;
                break;
            }
            size_t m = 1;
            for (size_t i = 0; i < ns; i++)
                if (!P->mark[st[i]]) nl[m++] = st[i];
            for (size_t i = w0; i < w1; i++)
                nl[m++] = who[i];
            nl[0] = (uint32_t)(m - 1);
            free(P->T.ov[pts[j]]);
            P->T.ov[pts[j]] = nl;
        }
        for (size_t i = 0; i < J->nps; i++)
            P->mark[J->ps[i]] = 0;
    }
    /* The boundary flags of the tets J changed, and of the locked tets around them (a
     * neighbour may have changed), measured again on the stars as they are now: no other job
     * of the batch holds a point of theirs. The grid lists every tet with a boundary face
     * (with its box as it is now): the written ones that have one, and the locked ones that
     * had none before (the others are listed already, and a locked tet does not move); X
     * takes them for local_commit. */
    for (size_t i = 0; i < nout; i++)
        P->bflag[out.a[i]] = BF_UNKNOWN;
    for (size_t i = 0; i < J->nls; i++) {
        const vm_index *c = S->m->cells + 4 * (size_t)J->ls[i];
        if (pidx[c[0]] != UINT32_MAX || pidx[c[1]] != UINT32_MAX || pidx[c[2]] != UINT32_MAX ||
            pidx[c[3]] != UINT32_MAX) {
            int was_inside = P->bflag[J->ls[i]] == BF_NO;
            P->bflag[J->ls[i]] = BF_UNKNOWN;
            if (ok && !bad_point && on_boundary(P, J->ls[i]) && was_inside)
                ok = sl_push(&X->grid, J->ls[i]);
        }
    }
    for (size_t i = 0; i < nout && ok && !bad_point; i++) {
        if (on_boundary(P, out.a[i])) ok = sl_push(&X->grid, out.a[i]);
        if (ok && S->below[out.a[i]]) ok = sl_push(&X->bad, out.a[i]);
    }
    for (size_t j = 0; j < np; j++)
        pidx[pts[j]] = UINT32_MAX;
    free(cnt);
    free(who);
    free(out.a);
    return bad_point ? -1 : ok;
}

/* What local_update left in X: its tets into the grid and P->bad, in order (serial: every
 * job's the same as the loop of one thread). Returns local_update's status. */
static int local_commit(lpass *P, const ljob *X) {
    int ok = X->update;
    for (size_t i = 0; i < X->grid.n && ok > 0; i++)
        ok = grid_add(&P->S, &P->G, X->grid.a[i]);
    for (size_t i = 0; i < X->bad.n && ok > 0; i++)
        ok = sl_push(&P->bad, X->bad.a[i]);
    return ok;
}

static void ljob_free(ljob *X) {
    free(X->seeds.a);
    free(X->pts.a);
    free(X->grid.a);
    free(X->bad.a);
    memset(X, 0, sizeof *X);
}

/* Progress: done of the rounds' share, in the bar between vm_mesh_improve's first checks
 * and its last figures. */
static void progress(const lpass *P, double done) {
    const vm_improve_options *o = P->S.uo;
    if (o->progress) o->progress("improve", 0.05 + 0.85 * done, 1.0, o->progress_user);
}

/* Sorts the job indices r[0..n) by their tets (free, then locked), most first, then by
 * index: an insertion sort (a batch holds tens of jobs). */
static void qsort_r_jobs(size_t *r, size_t n, const job *jobs) {
    for (size_t i = 1; i < n; i++) {
        size_t x = r[i], j = i;
        size_t wx = jobs[x].nps + jobs[x].nls;
        while (j > 0) {
            size_t y = r[j - 1], wy = jobs[y].nps + jobs[y].nls;
            if (wy > wx || (wy == wx && y < x)) break;
            r[j] = y;
            j--;
        }
        r[j] = x;
    }
}

static int thread_id(void) {
#ifdef VM_HAVE_OPENMP
    return omp_get_thread_num();
#else
    return 0;
#endif
}

/* Each thread's scratch as big as the slots and points now; 0 on out-of-memory. */
static int scratch_ready(lpass *P) {
    for (int i = 0; i < P->nw; i++) {
        scratch *W = &P->W[i];
        if (W->scap < P->S.nt) {
            size_t cap = P->S.nt + P->S.nt / 4 + 1;
            uint8_t *sm = realloc(W->sm, cap);
            if (!sm) return 0;
            memset(sm + W->scap, 0, cap - W->scap);
            W->sm = sm;
            W->scap = cap;
        }
        if (W->pcap < P->S.m->npoints) {
            size_t cap = P->S.m->npoints + 1;
            uint8_t *pm = realloc(W->pm, cap);
            if (!pm) return 0;
            memset(pm + W->pcap, 0, cap - W->pcap);
            W->pm = pm;
            W->pcap = cap;
        }
    }
    return 1;
}

/* Runs jobs[0..n) (scanned as the mesh is now, then in batches of jobs whose boxes do not
 * meet, taken in order; those left wait for the next batch and are scanned again). */
static vm_status run_batch(lpass *P, job *jobs, ljob *X, size_t n, vm_error *err) {
    size_t *todo = malloc((n + 1) * sizeof *todo), *take = malloc((n + 1) * sizeof *take);
    size_t *run = malloc((n + 1) * sizeof *run);
    if (!todo || !take || !run) {
        free(todo);
        free(take);
        free(run);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t i = 0; i < n; i++)
        todo[i] = i;
    size_t ntodo = n;
    vm_status s = VM_OK;
    while (ntodo && s == VM_OK) {
        if ((s = vm__imp_check(P->S.uo, err))) break;
        /* (a reduction's private copies start at 0: the scratch's failure is tested apart) */
        int fail = 0, ready = scratch_ready(P);
        if (ready) {
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1) reduction(|| : fail)
#endif
            for (size_t i = 0; i < ntodo; i++)
                if (!fail && !local_scan(P, &jobs[todo[i]], &X[todo[i]], &P->W[thread_id()]))
                    fail = 1;
        }
        fail = fail || !ready;
        if (fail) {
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            break;
        }
        size_t ntake = 0, nleft = 0;
        for (size_t i = 0; i < ntodo; i++) {
            job *J = &jobs[todo[i]];
            int clash = 0;
            for (size_t j = 0; j < ntake && !clash; j++)
                clash = boxes_meet(J, &jobs[take[j]]);
            if (J->nps == 0) continue;
            if (clash) {
                free(J->ps);
                free(J->ls);
                J->ps = J->ls = NULL;
                J->nps = J->nls = 0;
                todo[nleft++] = todo[i];
            } else {
                take[ntake++] = todo[i];
            }
        }
        /* the biggest first (the order they run in changes nothing else) */
        for (size_t i = 0; i < ntake; i++)
            run[i] = take[i];
        qsort_r_jobs(run, ntake, jobs);
        /* the boundary flags as the scans left them (nothing writes them while the jobs run;
         * local_update, after them, clears those of the tets they changed) */
        for (size_t i = 0; i < ntake; i++)
            jobs[run[i]].bflag = P->bflag;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
        for (size_t i = 0; i < ntake; i++)
            vm__imp_job_run(&P->S, &jobs[run[i]]);
        s = vm__imp_jobs_append(&P->S, jobs, take, ntake, err);
        if (s == VM_OK && P->S.nt > P->bflag_cap) {
            size_t cap = P->S.nt + P->S.nt / 4 + 1;
            uint8_t *nb = realloc(P->bflag, cap);
            if (!nb)
                s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            else {
                memset(nb + P->bflag_cap, 0, cap - P->bflag_cap);
                P->bflag = nb;
                P->bflag_cap = cap;
            }
        }
        if (s == VM_OK && P->S.nt > P->mark_cap) {
            uint8_t *nm = realloc(P->mark, P->S.nt + P->S.nt / 4 + 1);
            if (!nm)
                s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            else {
                memset(nm + P->mark_cap, 0, P->S.nt + P->S.nt / 4 + 1 - P->mark_cap);
                P->mark = nm;
                P->mark_cap = P->S.nt + P->S.nt / 4 + 1;
            }
        }
        /* each job's stars and boundary flags on the threads (the jobs of a batch share no
         * point, and each writes only its own points' stars and its tets' flags), then the
         * grid and the list of bad tets in order */
        if (s == VM_OK) {
            const ptrdiff_t pnt = (ptrdiff_t)ntake;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
            for (ptrdiff_t i = 0; i < pnt; i++)
                X[take[i]].update = local_update(P, &jobs[take[i]], &X[take[i]]);
        }
        for (size_t i = 0; i < ntake && s == VM_OK; i++) {
            int u = local_commit(P, &X[take[i]]);
            if (u < 0)
                s = vm_error_set(err, VM_ERR_INTERNAL,
                                 "improve: a part wrote a tet "
                                 "with a point it did not hold");
            else if (!u)
                s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        }
        for (size_t i = 0; i < ntake; i++)
            vm__imp_job_reset(&jobs[take[i]]);
        ntodo = nleft;
    }
    for (size_t i = 0; i < n; i++)
        vm__imp_job_reset(&jobs[i]);
    free(todo);
    free(take);
    free(run);
    return s;
}

/* One colour of one round: a job for each block of that colour holding bad tets, its seeds
 * the bad tets whose centroid is in it. */
static vm_status run_colour(lpass *P, int round, int colour, vm_error *err) {
    if (!bad_now(P)) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    size_t n = P->bad.n, nj = 0;
    /* (block, slot) of the seeds of this colour, sorted */
    uint64_t *key = malloc((n + 1) * sizeof *key);
    if (!key) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    size_t nk = 0;
    for (size_t i = 0; i < n; i++) {
        int c;
        size_t b = block_of(P, P->bad.a[i], &c);
        if (c == colour) key[nk++] = (uint64_t)b << 32 | P->bad.a[i];
    }
    vm__sort_u64(key, nk);
    for (size_t i = 0; i < nk; i++)
        nj += i == 0 || key[i] >> 32 != key[i - 1] >> 32;
    job *jobs = calloc(nj + 1, sizeof *jobs);
    ljob *X = calloc(nj + 1, sizeof *X);
    vm_status s = VM_OK;
    if (!jobs || !X) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t i = 0, j = 0; s == VM_OK && i < nk; i++) {
        if (i > 0 && key[i] >> 32 != key[i - 1] >> 32) j++;
        X[j].block = (size_t)(key[i] >> 32);
        jobs[j].seed = vm__imp_part_seed(P->S.o.seed, 16 + round, X[j].block);
        jobs[j].below_known = 1; /* P->S.below holds for every live slot */
        if (!sl_push(&X[j].seeds, (size_t)(key[i] & 0xffffffffu)))
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    free(key);
    if (s == VM_OK && nj) s = run_batch(P, jobs, X, nj, err);
    for (size_t j = 0; X && j < nj; j++)
        ljob_free(&X[j]);
    free(X);
    free(jobs);
    return s;
}

vm_status vm__imp_local_run(vm_mesh *m, const vm_volume *v, vm_plane_source src, void *src_user,
                            const vm_improve_options *o, const uint8_t *below,
                            vm_improve_report *r, vm_error *err) {
    lpass P;
    memset(&P, 0, sizeof P);
    vm_status s = vm__imp_pstate_init(&P.S, m, v, src, src_user, o, r, err);
    if (s != VM_OK) return s;
    pstate *S = &P.S;
    /* Which tets are below the targets (the caller's sweep may have told): each on its own,
     * the same for any thread count. */
    vm__imp qw;
    memset(&qw, 0, sizeof qw);
    vm__imp_scales(&qw, o);
    vm__imp_bar one;
    vm__imp_bar_set(&qw, nextafter(1.0, 0.0), &one); /* above: q >= 1 */
    size_t nbad = 0;
    const vm_index *cells = m->cells;
    if (below) memcpy(S->below, below, S->nt);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096) reduction(+ : nbad)
#endif
    for (size_t t = 0; t < S->nt; t++) {
        if (!below) {
            double p[4][3];
            for (int k = 0; k < 4; k++)
                memcpy(p[k], m->points + 3 * (size_t)cells[4 * t + k], sizeof p[k]);
            S->below[t] = !vm__imp_quality_above(&qw, (const double(*)[3])p, &one);
        }
        nbad += S->below[t];
    }
    if (nbad == 0) {
        vm__imp_pstate_free(S);
        return VM_OK;
    }
    /* the blocks: BLOCK_EDGES mean longest edges of the bad tets a side */
    double hsum = 0.0;
    for (size_t t = 0; t < S->nt; t++)
        if (S->below[t]) {
            hsum += sqrt(vm__imp_slot_edge2(S, t));
            if (!sl_push(&P.bad, t))
                s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        }
    double h = hsum / (double)nbad;
    if (!(h > 0.0) || !isfinite(h)) h = 1.0;
    P.E = BLOCK_EDGES * h;
    for (int k = 0; k < 3; k++) {
        double nb = floor((S->box[3 + k] - S->box[k]) / P.E) + 1.0;
        P.nb[k] = nb < 1.0 ? 1 : nb > 1024.0 ? 1024 : (size_t)nb;
    }
    if (P.nb[0] * P.nb[1] * P.nb[2] >= ((size_t)1 << 31))
        s = vm_error_set(err, VM_ERR_ARG, "improve: too many blocks");
    if (s == VM_OK) {
        P.mark_cap = S->nt + S->nt / 4 + 1;
        P.mark = calloc(P.mark_cap, 1);
#ifdef VM_HAVE_OPENMP
        P.nw = omp_get_max_threads();
#else
        P.nw = 1;
#endif
        P.W = calloc((size_t)P.nw, sizeof *P.W);
        if (!P.W) P.nw = 0;
        P.bflag_cap = P.mark_cap;
        P.bflag = calloc(P.bflag_cap, 1);
        P.pidx = malloc((m->npoints + 1) * sizeof *P.pidx);
        for (size_t i = 0; P.pidx && i < m->npoints; i++)
            P.pidx[i] = UINT32_MAX;
        if (!P.mark || !P.W || !P.pidx || !P.bflag || !stars_build(S, &P.T))
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    /* Every tet's boundary flag once, on the threads (each on its own: any thread count gives
     * the same flags): the grid the scans search then lists only the tets with a boundary
     * face. */
    if (s == VM_OK) {
        const lpass *cp = &P;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
        for (size_t t = 0; t < S->nt; t++)
            if (cells[4 * t] != DEAD) (void)on_boundary(cp, t);
        if (!grid_build(S, h, P.bflag, &P.G))
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    size_t last = SIZE_MAX;
    for (int round = 0; round < ROUNDS && s == VM_OK; round++) {
        if (!bad_now(&P)) {
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
            break;
        }
        if (P.bad.n == 0 || P.bad.n >= last) break;
        last = P.bad.n;
        for (int c = 0; c < COLOURS && s == VM_OK; c++) {
            s = run_colour(&P, round, c, err);
            progress(&P, (1.0 - pow(0.5, round)) +
                             pow(0.5, round) * 0.5 * (double)(c + 1) / COLOURS);
        }
    }
    /* also after an error: the mesh stays valid (the jobs done so far improved it) */
    vm_error e2;
    vm_status s2 = vm__imp_parts_finish(S, &e2);
    if (s == VM_OK && s2 != VM_OK) {
        s = s2;
        if (err) *err = e2;
    }
    for (int i = 0; i < P.nw; i++) {
        free(P.W[i].sm);
        free(P.W[i].pm);
        free(P.W[i].no.a);
    }
    free(P.W);
    free(P.pidx);
    free(P.bflag);
    stars_free(&P.T);
    grid_free(&P.G);
    free(P.bad.a);
    free(P.mark);
    vm__imp_pstate_free(S);
    return s;
}
