/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface_cover.c — disk-covering surfaces (Gavriliu, Carranza, Breen, Barr, "Fast
 * extraction of adaptive multiresolution meshes with guaranteed properties from volumetric
 * data", seed 000): a simple independent disk covering of the candidate graph with radii
 * R_g / 2^i (sec. 3.3, Figs. 3-7), its graph Voronoi neighbourhoods and their dual triangles,
 * refined by the maximum-distance metric (sec. 3.4-3.5, Fig. 8). See docs/SURFACE_COVER.md. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "surface_cover_internal.h"
#include "../core/self_intersect.h"
#include "../core/vec3.h"

#define LEVELS 48      /* radii R_g / 2^l, l = 0 .. LEVELS-1 */
#define FORCED 255     /* level of a forced seed (a vertex of the fine surface kept as is) */
#define MAX_PASSES 120 /* covering passes before the fine surface itself is returned */
#define REPAIRS 6      /* failed duals of a component before its fine surface is kept */
#define EXTRA 0        /* levels below the 1-ring rule a topological repair may go (the aspect
                          bound holds only with 0) */
#define ASPECT 0.32    /* refine triangles whose shortest / longest edge is below this */
#define PAPER_RATIO 0.3 /* the paper's bound on shortest / longest edge (sec. 3.9) */
#define LEVEL_MARGIN 1e-9 /* relative rounding margin: a disk holds a 1-ring of its radius */

typedef struct {
    double d;
    int32_t v;
} hitem;

typedef struct {
    const vm__cover_fine *m;
    double rg, eps;
    /* Dijkstra scratch: dist is INFINITY except on the touched vertices */
    double *dist;
    int32_t *touched;
    size_t ntouched;
    int32_t *order; /* the touched vertices by increasing distance (the Dijkstra pops) */
    size_t norder;
    hitem *heap;
    size_t nheap, heapcap;
    /* per vertex */
    uint8_t *lmax;    /* finest level whose disk still holds the whole 1-ring (sec. 3.9) */
    uint8_t *cap;     /* coarsest level allowed here (raised by refinement and repairs) */
    uint8_t *lfloor;  /* lmax as the 1-ring rule sets it */
    uint8_t *hint;    /* one level coarser than the neighbourhood of the last pass: where a
                         new disk starts (it could not grow larger next to that seed) */
    uint8_t *forced;  /* kept as a seed of its own */
    uint8_t *forb;    /* inside a disk of the covering (forbidden as a centre) */
    int16_t *binl;    /* bin of the vertex, -1 unclassified */
    int16_t *seedlev; /* level of the disk centred here, -1 none */
    int32_t *bcnt;    /* scratch of the simple-disk test */
    uint8_t *fmark;   /* per face, scratch of the simple-disk test */
    int32_t *fqueue;
    int32_t *label;   /* Voronoi label: index of the nearest seed */
    /* the covering, in placement order */
    int32_t *seeds;
    size_t nseeds;
    int32_t *prev;
    uint8_t *prevlev;
    size_t nprev;
    int32_t *bins[LEVELS];
    size_t bn[LEVELS], bcap[LEVELS], bhead[LEVELS];
    int changed;
    /* the dual */
    int32_t *tri;     /* 3 ntri, seed indices */
    size_t ntri, tricap;
    uint64_t *half;   /* (a << 32 | b) per half-edge, sorted */
    int32_t *halft;
    size_t *toff;     /* nseeds + 1: triangles at each seed */
    int32_t *tlist;
    uint8_t *bad;
    size_t passes, repairs, forced_cells, pops, places, untangles;
    uint8_t *comp_fails; /* per fine component: failed duals so far */
    int32_t *nfps;       /* per fine component: seeds of its farthest-point covering, 0 none */
    uint8_t *grow;       /* per fine component: scratch, its farthest-point covering grows */
    double *fd;          /* per vertex: scratch of the farthest-point sampling */
    size_t *csize;       /* per fine component: vertices */
    int32_t *fps_ok;     /* per fine component: the last seed count whose dual was valid */
    uint8_t *frozen;     /* per fine component: back at fps_ok for good */
    int32_t *fps_hi;     /* per fine component: the smallest count whose dual failed, 0 none */
    uint8_t *thin;       /* per fine component: a farthest-point triangle below ASPECT */
} cover;

/* The error of a failed allocation. */
static vm_status cover_nomem(vm_error *err) {
    return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory");
}

static double radius(const cover *c, int l) { return ldexp(c->rg, -l); }

/* -- a binary heap of (distance, vertex) ------------------------------------------------ */

static vm_status heap_push(cover *c, double d, int32_t v, vm_error *err) {
    vm_status s = vm__grow((void **)&c->heap, &c->heapcap, c->nheap + 1, sizeof(hitem), err);
    if (s) return s;
    size_t i = c->nheap++;
    while (i > 0) {
        size_t p = (i - 1) / 2;
        if (c->heap[p].d <= d) break;
        c->heap[i] = c->heap[p];
        i = p;
    }
    c->heap[i].d = d;
    c->heap[i].v = v;
    return VM_OK;
}

static hitem heap_pop(cover *c) {
    hitem top = c->heap[0], last = c->heap[--c->nheap];
    size_t i = 0, n = c->nheap;
    for (;;) {
        size_t l = 2 * i + 1;
        if (l >= n) break;
        if (l + 1 < n && c->heap[l + 1].d < c->heap[l].d) l++;
        if (c->heap[l].d >= last.d) break;
        c->heap[i] = c->heap[l];
        i = l;
    }
    if (n > 0) c->heap[i] = last;
    return top;
}

static double euclid(const vm__cover_fine *m, int32_t a, int32_t b) {
    const double *p = m->x + 3 * (size_t)a, *q = m->x + 3 * (size_t)b;
    return sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                (p[2] - q[2]) * (p[2] - q[2]));
}

/* The disk neighbourhood of src: the vertices reached from src along the candidate graph
 * without leaving the ball of radius limit, each with its distance to src. The paper
 * measures the graph geodesic; we measure the straight distance within the connected piece
 * of the surface in the ball, which never exceeds the geodesic, agrees with it to second
 * order on small disks, and does not zigzag with the grid (see docs/SURFACE_COVER.md). */
static vm_status dijkstra(cover *c, int32_t src, double limit, vm_error *err) {
    const vm__cover_fine *m = c->m;
    for (size_t t = 0; t < c->ntouched; t++) c->dist[c->touched[t]] = INFINITY;
    c->ntouched = 0;
    c->norder = 0;
    c->nheap = 0;
    c->dist[src] = 0;
    c->touched[c->ntouched++] = src;
    vm_status s = heap_push(c, 0, src, err);
    while (!s && c->nheap > 0) {
        hitem it = heap_pop(c);
        if (it.d > c->dist[it.v]) continue;
        c->order[c->norder++] = it.v;
        for (size_t h = m->off[it.v]; h < m->off[it.v + 1]; h++) {
            int32_t y = m->nbr[h];
            double nd = euclid(m, y, src);
            if (nd < limit && nd < c->dist[y]) {
                if (c->dist[y] == INFINITY) c->touched[c->ntouched++] = y;
                c->dist[y] = nd;
                s = heap_push(c, nd, y, err);
                if (s) break;
            }
        }
    }
    return s;
}

/* -- FINDTOPOLOGICALEVENT (Fig. 4) ------------------------------------------------------ */

static int face_in(const cover *c, int32_t f, double r) {
    const int32_t *v = c->m->f + 3 * (size_t)f;
    return c->dist[v[0]] < r && c->dist[v[1]] < r && c->dist[v[2]] < r;
}

/* 1 when the disk of radius r around the last Dijkstra source is simple: the faces with all
 * corners inside form one connected surface without pinched vertices, holding every vertex
 * of the disk, with Euler characteristic 1 (so a topological disk: one boundary, genus 0).
 * A boundary that splits or vanishes (the paper's topological events) breaks this. */
static int disk_simple(cover *c, double r) {
    const vm__cover_fine *m = c->m;
    size_t nreg = 0, nf = 0, nb = 0, nvf = 0;
    int ok = 1;
    int32_t first = -1;
    size_t n = 0; /* the disk: the first n vertices by distance */
    while (n < c->norder && c->dist[c->order[n]] < r) c->bcnt[c->order[n++]] = 0;
    nreg = n;
    for (size_t t = 0; t < n; t++) {
        int32_t v = c->order[t];
        int has = 0;
        for (size_t h = m->off[v]; h < m->off[v + 1]; h++) {
            int32_t f = m->hface[h];
            if (!face_in(c, f, r)) continue;
            has = 1;
            if (m->f[3 * (size_t)f] != v) continue; /* count each face once */
            nf++;
            c->fmark[f] = 1;
            if (first < 0) first = f;
            for (int e = 0; e < 3; e++)
                if (!face_in(c, m->fadj[3 * (size_t)f + e], r)) {
                    nb++;
                    c->bcnt[m->f[3 * (size_t)f + e]]++;
                    c->bcnt[m->f[3 * (size_t)f + (e + 1) % 3]]++;
                }
        }
        nvf += has;
    }
    if (nvf != nreg || nb < 3 || first < 0) ok = 0;
    for (size_t t = 0; ok && t < n; t++) {
        int32_t v = c->order[t];
        if (c->bcnt[v] != 0 && c->bcnt[v] != 2) ok = 0;
    }
    if (ok) {
        long euler = (long)nvf - (long)(3 * nf + nb) / 2 + (long)nf;
        if (euler != 1) ok = 0;
    }
    if (ok) { /* one face-connected piece */
        size_t head = 0, tail = 0;
        c->fqueue[tail++] = first;
        c->fmark[first] = 2;
        while (head < tail) {
            int32_t f = c->fqueue[head++];
            for (int e = 0; e < 3; e++) {
                int32_t g = m->fadj[3 * (size_t)f + e];
                if (c->fmark[g] == 1) c->fmark[g] = 2, c->fqueue[tail++] = g;
            }
        }
        if (tail != nf) ok = 0;
    }
    for (size_t t = 0; t < n; t++) {
        int32_t v = c->order[t];
        for (size_t h = m->off[v]; h < m->off[v + 1]; h++) c->fmark[m->hface[h]] = 0;
    }
    return ok;
}

/* -- CLASSIFY (Fig. 5) and the bins ----------------------------------------------------- */

static vm_status bin_push(cover *c, int32_t x, int l, vm_error *err) {
    if (c->binl[x] >= l) return VM_OK;
    c->binl[x] = (int16_t)l;
    vm_status s = vm__grow((void **)&c->bins[l], &c->bcap[l], c->bn[l] + 1, sizeof(int32_t), err);
    if (!s) c->bins[l][c->bn[l]++] = x;
    return s;
}

/* Adds the disk of level l at w: the last Dijkstra ran from w. Inside the disk is forbidden;
 * the ring R..2R may take disks of the same radius (bin l), the ring 2R..3R disks of twice
 * the radius (bin l-1). */
static vm_status classify(cover *c, int32_t w, int l, vm_error *err) {
    double r = radius(c, l);
    vm_status s = VM_OK;
    for (size_t t = 0; !s && t < c->ntouched; t++) {
        int32_t x = c->touched[t];
        double d = c->dist[x];
        if (d < r) c->forb[x] = 1;
        else if (d < 2 * r) s = bin_push(c, x, l, err);
        else if (d < 3 * r) s = bin_push(c, x, l > 0 ? l - 1 : 0, err);
    }
    if (s) return s;
    c->seedlev[w] = (int16_t)l;
    c->forb[w] = 1;
    c->seeds[c->nseeds++] = w;
    return VM_OK;
}

/* Places a disk at w, at level l0 or finer: as large as the cap allows, halved while it is
 * not simple, while it holds another centre, or while it meets a disk less than half its
 * radius (ENFORCERADIUSCONSTRAINTS, Fig. 7). A neighbour more than twice as large gets its
 * cap lowered for the next pass instead of being halved in place. */
static vm_status place(cover *c, int32_t w, int l0, vm_error *err) {
    int lm = c->lmax[w];
    int l = l0 > c->cap[w] ? l0 : c->cap[w];
    if (l < c->hint[w]) l = c->hint[w];
    if (l > lm) l = lm;
    vm_status s = dijkstra(c, w, 3 * radius(c, l), err);
    if (s) return s;
    c->pops += c->norder;
    c->places++;
    for (;;) {
        while (l < lm && !disk_simple(c, radius(c, l))) l++;
        int bump = 0;
        double rw = radius(c, l);
        for (size_t t = 0; t < c->ntouched && !bump; t++) {
            int32_t v = c->touched[t];
            int sl = c->seedlev[v];
            if (sl < 0 || sl == FORCED) continue;
            double d = c->dist[v], rv = radius(c, sl);
            if (d < rw || (d < rw + rv && rw > 2 * rv)) bump = 1;
        }
        if (!bump || l >= lm) break;
        l++;
    }
    double rw = radius(c, l);
    for (size_t t = 0; t < c->ntouched; t++) {
        int32_t v = c->touched[t];
        int sl = c->seedlev[v];
        if (sl < 0 || sl == FORCED) continue;
        double d = c->dist[v], rv = radius(c, sl);
        if (d < rw + rv && rv > 2 * rw && c->cap[v] < l - 1 && c->cap[v] < c->lmax[v]) {
            c->cap[v] = (uint8_t)(l - 1);
            c->changed = 1;
        }
    }
    return classify(c, w, l, err);
}

/* EXTRACTCOARSEMESH (Fig. 3): forced seeds, then the seeds of the previous pass in their
 * order (so the vertex sets of successive meshes nest: multiresolution), then new disks
 * from the lowest-numbered non-empty bin. */
static vm_status covering(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    size_t nv = m->nv;
    memset(c->forb, 0, nv);
    for (size_t v = 0; v < nv; v++) c->binl[v] = -1, c->seedlev[v] = -1;
    for (int l = 0; l < LEVELS; l++) c->bn[l] = c->bhead[l] = 0;
    c->nseeds = 0;
    for (size_t v = 0; v < nv; v++)
        if (c->forced[v]) {
            c->seedlev[v] = FORCED;
            c->forb[v] = 1;
            c->seeds[c->nseeds++] = (int32_t)v;
        }
    /* the rest of a component covered by farthest points takes no disk */
    for (size_t v = 0; v < nv; v++)
        if (c->nfps[m->comp[v]] > 0 && !c->forced[v]) c->forb[v] = 1;
    vm_status s = VM_OK;
    for (size_t p = 0; !s && p < c->nprev; p++) {
        int32_t w = c->prev[p];
        if (c->seedlev[w] >= 0 || c->forb[w]) continue;
        s = place(c, w, c->prevlev[p], err);
    }
    size_t scan = 0;
    while (!s) {
        int32_t x = -1;
        int l = 0;
        for (l = 0; l < LEVELS; l++)
            if (c->bhead[l] < c->bn[l]) break;
        if (l < LEVELS) {
            x = c->bins[l][c->bhead[l]++];
            if (c->binl[x] != l) continue; /* also queued in a finer bin */
        } else if (scan < nv) {
            x = (int32_t)scan++;
            l = 0;
            if (c->binl[x] >= 0) continue;
        } else {
            break;
        }
        if (c->forb[x] || c->seedlev[x] >= 0) continue;
        s = place(c, x, l, err);
    }
    return s;
}

/* Voronoi neighbourhoods of the seeds, grown along the candidate graph: a vertex takes the
 * label of a neighbour when that neighbour's seed is nearer than its own. Every
 * neighbourhood is connected and holds its seed. */
static vm_status voronoi(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    for (size_t v = 0; v < m->nv; v++) c->dist[v] = INFINITY;
    c->ntouched = 0;
    c->nheap = 0;
    vm_status s = VM_OK;
    for (size_t i = 0; !s && i < c->nseeds; i++) {
        c->dist[c->seeds[i]] = 0;
        c->label[c->seeds[i]] = (int32_t)i;
        s = heap_push(c, 0, c->seeds[i], err);
    }
    while (!s && c->nheap > 0) {
        hitem it = heap_pop(c);
        if (it.d > c->dist[it.v]) continue;
        int32_t src = c->seeds[c->label[it.v]];
        for (size_t h = m->off[it.v]; h < m->off[it.v + 1]; h++) {
            int32_t y = m->nbr[h];
            double nd = euclid(m, y, src);
            if (nd < c->dist[y]) {
                c->dist[y] = nd;
                c->label[y] = c->label[it.v];
                s = heap_push(c, nd, y, err);
                if (s) break;
            }
        }
    }
    for (size_t v = 0; v < m->nv; v++) c->dist[v] = INFINITY;
    return s;
}

/* qsort order of uint64_t. */
static int cmp_u64(const void *a, const void *b) {
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The key of half-edge (a, b): a in the high word, so keys sort by tail. */
static uint64_t hkey(int32_t a, int32_t b) { return (uint64_t)(uint32_t)a << 32 | (uint32_t)b; }

/* Index of half-edge (a, b) in the sorted list, or -1. */
static long find_half(const cover *c, int32_t a, int32_t b) {
    uint64_t k = hkey(a, b);
    size_t lo = 0, hi = 3 * c->ntri;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (c->half[mid] < k) lo = mid + 1;
        else hi = mid;
    }
    return lo < 3 * c->ntri && c->half[lo] == k ? (long)lo : -1;
}

/* The dual triangles of the Voronoi covering into c->tri: one per fine face whose three
 * corners lie in three neighbourhoods. */
static vm_status dual_triangles(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    c->ntri = 0;
    vm_status s = VM_OK;
    for (size_t f = 0; !s && f < m->nf; f++) {
        int32_t a = c->label[m->f[3 * f]], b = c->label[m->f[3 * f + 1]];
        int32_t d = c->label[m->f[3 * f + 2]];
        if (a == b || b == d || a == d) continue;
        s = vm__grow((void **)&c->tri, &c->tricap, 3 * (c->ntri + 1), sizeof(int32_t), err);
        if (s) break;
        c->tri[3 * c->ntri] = a;
        c->tri[3 * c->ntri + 1] = b;
        c->tri[3 * c->ntri + 2] = d;
        c->ntri++;
    }
    return s;
}

/* The dual's half-edges sorted (c->half) and its triangles per seed (c->toff, c->tlist). */
static vm_status dual_index(cover *c, vm_error *err) {
    size_t ns = c->nseeds, nh = 3 * c->ntri;
    free(c->half);
    free(c->toff);
    free(c->tlist);
    c->half = malloc((nh + 1) * sizeof *c->half);
    c->toff = calloc(ns + 2, sizeof *c->toff);
    c->tlist = malloc((nh + 1) * sizeof *c->tlist);
    if (!c->half || !c->toff || !c->tlist)
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (dual)");
    for (size_t t = 0; t < c->ntri; t++)
        for (int e = 0; e < 3; e++) {
            c->half[3 * t + e] = hkey(c->tri[3 * t + e], c->tri[3 * t + (e + 1) % 3]);
            c->toff[c->tri[3 * t + e] + 1]++;
        }
    for (size_t i = 0; i < ns; i++) c->toff[i + 1] += c->toff[i];
    size_t *fill = malloc((ns + 1) * sizeof *fill);
    if (!fill) return cover_nomem(err);
    memcpy(fill, c->toff, ns * sizeof *fill);
    for (size_t t = 0; t < c->ntri; t++)
        for (int e = 0; e < 3; e++) c->tlist[fill[c->tri[3 * t + e]]++] = (int32_t)t;
    free(fill);
    qsort(c->half, nh, sizeof *c->half, cmp_u64);
    return VM_OK;
}

/* 1 when the triangles at seed a form one fan around it (deg of them). */
static int one_fan(const cover *c, size_t a, size_t deg) {
    int32_t t = c->tlist[c->toff[a]];
    size_t steps = 0;
    int32_t t0 = t;
    do {
        int e = 0;
        while (c->tri[3 * (size_t)t + e] != (int32_t)a) e++;
        int32_t prevv = c->tri[3 * (size_t)t + (e + 2) % 3];
        /* the next triangle around a holds the half-edge (a, prevv) */
        long h = find_half(c, (int32_t)a, prevv);
        if (h < 0) break;
        int32_t nt = -1;
        for (size_t q = c->toff[a]; q < c->toff[a + 1]; q++) {
            int32_t u = c->tlist[q];
            for (int k = 0; k < 3; k++)
                if (c->tri[3 * (size_t)u + k] == (int32_t)a &&
                    c->tri[3 * (size_t)u + (k + 1) % 3] == prevv)
                    nt = u;
        }
        if (nt < 0) break;
        t = nt;
        steps++;
    } while (t != t0 && steps <= deg);
    return t == t0 && steps == deg;
}

/* Marks in c->bad the seeds of a directed edge that is not there once with its twin once,
 * and the seeds whose triangles are not one fan of at least 3. */
static void mark_edges_fans(cover *c) {
    size_t ns = c->nseeds, nh = 3 * c->ntri;
    memset(c->bad, 0, ns);
    /* every directed edge once, and its twin once */
    for (size_t h = 0; h < nh; h++) {
        int32_t a = (int32_t)(c->half[h] >> 32), b = (int32_t)(uint32_t)c->half[h];
        if ((h + 1 < nh && c->half[h + 1] == c->half[h]) || find_half(c, b, a) < 0)
            c->bad[a] = c->bad[b] = 1;
    }
    /* one fan of triangles around every seed */
    for (size_t a = 0; a < ns; a++) {
        size_t deg = c->toff[a + 1] - c->toff[a];
        if (deg < 3) {
            c->bad[a] = 1;
            continue;
        }
        if (c->bad[a]) continue;
        if (!one_fan(c, a, deg)) c->bad[a] = 1;
    }
}

/* The closed-ball property: every Voronoi neighbourhood is a disk, Euler characteristic 1
 * (V - E + F of the fine vertices, edges and faces inside it). A neighbourhood wrapped
 * around a small handle (0) or holding a small component (2) hides topology from the
 * dual; its seed is marked bad. */
static vm_status mark_balls(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    size_t ns = c->nseeds;
    long *cchi = calloc(ns + 1, sizeof *cchi);
    if (!cchi) return cover_nomem(err);
    for (size_t x = 0; x < m->nv; x++) {
        int32_t a = c->label[x];
        cchi[a] += 1;
        for (size_t h = m->off[x]; h < m->off[x + 1]; h++)
            if ((size_t)m->nbr[h] > x && c->label[m->nbr[h]] == a) cchi[a] -= 1;
    }
    for (size_t f = 0; f < m->nf; f++) {
        int32_t a = c->label[m->f[3 * f]];
        if (c->label[m->f[3 * f + 1]] == a && c->label[m->f[3 * f + 2]] == a) cchi[a] += 1;
    }
    for (size_t i = 0; i < ns; i++)
        if (cchi[i] != 1) c->bad[i] = 1;
    free(cchi);
    return VM_OK;
}

/* Euler characteristic and connectedness per component of the fine surface: cbad[k] = 1
 * where the dual's part of component k differs (chi, uf, croot: scratch of nc + 1, ns + 1,
 * nc + 1 entries). */
static void check_components(const cover *c, long *chi, int32_t *uf, int32_t *croot,
                             uint8_t *cbad) {
    const vm__cover_fine *m = c->m;
    size_t ns = c->nseeds, nc = m->ncomp;
    for (size_t i = 0; i < ns; i++) uf[i] = (int32_t)i;
    for (size_t i = 0; i < ns; i++) chi[m->comp[c->seeds[i]]] += 2;
    for (size_t t = 0; t < c->ntri; t++) {
        chi[m->comp[c->seeds[c->tri[3 * t]]]] -= 1; /* V - E + F with E = 3F/2 */
        for (int e = 0; e < 3; e++) {
            int32_t a = c->tri[3 * t + e], b = c->tri[3 * t + (e + 1) % 3];
            while (uf[a] != a) a = uf[a] = uf[uf[a]];
            while (uf[b] != b) b = uf[b] = uf[uf[b]];
            if (a != b) uf[a < b ? b : a] = a < b ? a : b;
        }
    }
    for (size_t k = 0; k < nc; k++) {
        croot[k] = -1;
        if (chi[k] != 2 * m->comp_euler[k]) cbad[k] = 1;
    }
    for (size_t i = 0; i < ns; i++) {
        int32_t a = (int32_t)i;
        while (uf[a] != a) a = uf[a];
        int32_t k = m->comp[c->seeds[i]];
        if (croot[k] < 0) croot[k] = a;
        else if (croot[k] != a) cbad[k] = 1;
    }
}

/* Where a component of the fine surface fails its Euler characteristic or connectedness
 * (check_components) with no local defect found, every seed of the component is marked. */
static vm_status mark_components(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    size_t ns = c->nseeds, nc = m->ncomp;
    long *chi = calloc(nc + 1, sizeof *chi);
    int32_t *uf = malloc((ns + 1) * sizeof *uf);
    int32_t *croot = malloc((nc + 1) * sizeof *croot);
    uint8_t *cbad = calloc(nc + 1, 1);
    uint8_t *clocal = NULL;
    vm_status s = VM_OK;
    if (!chi || !uf || !croot || !cbad) {
        s = cover_nomem(err);
        goto done;
    }
    check_components(c, chi, uf, croot, cbad);
    clocal = calloc(nc + 1, 1);
    if (!clocal) {
        s = cover_nomem(err);
        goto done;
    }
    for (size_t i = 0; i < ns; i++)
        if (c->bad[i]) clocal[m->comp[c->seeds[i]]] = 1;
    for (size_t i = 0; i < ns; i++)
        if (cbad[m->comp[c->seeds[i]]] && !clocal[m->comp[c->seeds[i]]]) c->bad[i] = 1;
done:
    free(clocal);
    free(chi), free(uf), free(croot), free(cbad);
    return s;
}

/* The dual triangles of the Voronoi covering (one per fine face whose three corners lie in
 * three neighbourhoods), and the seeds where they fail to make a closed oriented manifold
 * with the Euler characteristic and the components of the fine surface. Returns the number
 * of bad seeds (marked in c->bad). */
static vm_status dual(cover *c, size_t *nbad, vm_error *err) {
    vm_status s = dual_triangles(c, err);
    if (!s) s = dual_index(c, err);
    if (s) return s;
    mark_edges_fans(c);
    s = mark_balls(c, err);
    if (!s) s = mark_components(c, err);
    if (s) return s;
    size_t n = 0;
    for (size_t i = 0; i < c->nseeds; i++) n += c->bad[i];
    *nbad = n;
    return VM_OK;
}

/* Distance from p to triangle (a, b, c) (closest point by Voronoi regions of the triangle). */
static double point_tri(const double *p, const double *a, const double *b, const double *c) {
    return sqrt(vm__point_triangle_dist2(p, a, b, c));
}

/* Fine faces of every Voronoi neighbourhood (by the label of their first corner):
 * faces of seed i are (*flist)[(*foff)[i] .. (*foff)[i+1]-1]. VM_ERR_NOMEM (no message set:
 * the callers without an error holder skip their work) when out of memory. */
static vm_status cell_faces(const vm__cover_fine *m, const int32_t *label, size_t ns,
                            size_t **foff_out, int32_t **flist_out) {
    size_t *foff = calloc(ns + 2, sizeof *foff);
    int32_t *flist = malloc((m->nf + 1) * sizeof *flist);
    if (!foff || !flist) {
        free(foff);
        free(flist);
        return VM_ERR_NOMEM;
    }
    for (size_t f = 0; f < m->nf; f++) foff[label[m->f[3 * f]] + 1]++;
    for (size_t i = 0; i < ns; i++) foff[i + 1] += foff[i];
    for (size_t f = 0; f < m->nf; f++) flist[foff[label[m->f[3 * f]]]++] = (int32_t)f;
    for (size_t i = ns; i > 0; i--) foff[i] = foff[i - 1];
    foff[0] = 0;
    *foff_out = foff;
    *flist_out = flist;
    return VM_OK;
}

/* 1 when a point of triangle p (centroid, edge midpoints, halfway from the centroid to the
 * corners) is farther than eps from the fine faces of the neighbourhoods cells[0..ncells-1]. */
static int tri_far(const vm__cover_fine *m, const size_t *foff, const int32_t *flist,
                   const double *const p[3], const int32_t *cells, int ncells, double eps) {
    static const double bary[7][3] = {{1. / 3, 1. / 3, 1. / 3}, {.5, .5, 0}, {0, .5, .5},
                                      {.5, 0, .5}, {2. / 3, 1. / 6, 1. / 6},
                                      {1. / 6, 2. / 3, 1. / 6}, {1. / 6, 1. / 6, 2. / 3}};
    for (int b = 0; b < 7; b++) {
        double q[3], best = INFINITY;
        for (int k = 0; k < 3; k++)
            q[k] = bary[b][0] * p[0][k] + bary[b][1] * p[1][k] + bary[b][2] * p[2][k];
        for (int e = 0; e < ncells && best > eps; e++)
            for (size_t r = foff[cells[e]]; r < foff[cells[e] + 1] && best > eps; r++) {
                const int32_t *g = m->f + 3 * (size_t)flist[r];
                double d = point_tri(q, m->x + 3 * (size_t)g[0], m->x + 3 * (size_t)g[1],
                                     m->x + 3 * (size_t)g[2]);
                if (d < best) best = d;
            }
        if (best > eps) return 1;
    }
    return 0;
}

/* Shortest / longest edge of dual triangle t (seed indices). */
static double edge_ratio(const vm__cover_fine *m, const int32_t *seeds, const int32_t *t) {
    double lmin = INFINITY, lmax = 0;
    for (int e = 0; e < 3; e++) {
        double l = euclid(m, seeds[t[e]], seeds[t[(e + 1) % 3]]);
        lmin = fmin(lmin, l);
        lmax = fmax(lmax, l);
    }
    return lmax > 0 ? lmin / lmax : 0;
}

/* The maximum-distance metric (sec. 3.5): a seed needs refining when a fine vertex of its
 * Voronoi neighbourhood lies farther than eps from the triangles at the seed. */
static void refine(cover *c) {
    const vm__cover_fine *m = c->m;
    memset(c->bad, 0, c->nseeds);
    for (size_t x = 0; x < m->nv; x++) {
        int32_t s = c->label[x];
        double best = INFINITY;
        for (size_t q = c->toff[s]; q < c->toff[s + 1] && best > c->eps; q++) {
            const int32_t *t = c->tri + 3 * (size_t)c->tlist[q];
            double d = point_tri(m->x + 3 * x, m->x + 3 * (size_t)c->seeds[t[0]],
                                 m->x + 3 * (size_t)c->seeds[t[1]],
                                 m->x + 3 * (size_t)c->seeds[t[2]]);
            if (d < best) best = d;
        }
        if (best > c->eps) {
            /* a chord's sagitta grows as the square of its length: halve the radius
             * log4(error / eps) times at once */
            int jump = (int)ceil(0.5 * log2(best / c->eps));
            jump = jump < 1 ? 1 : jump > 4 ? 4 : jump;
            if (c->bad[s] < jump) c->bad[s] = (uint8_t)jump;
        }
    }
    /* The other side of the Hausdorff distance: points of each triangle (centroid, edge
     * midpoints, and halfway from the centroid to the corners) farther than eps from the
     * fine faces of the three neighbourhoods refine the triangle's seeds. */
    size_t ns = c->nseeds, *foff = NULL;
    int32_t *flist = NULL;
    if (!cell_faces(m, c->label, ns, &foff, &flist)) {
        for (size_t t = 0; t < c->ntri; t++) {
            const int32_t *v = c->tri + 3 * t;
            if (c->bad[v[0]] && c->bad[v[1]] && c->bad[v[2]]) continue;
            const double *p[3];
            for (int e = 0; e < 3; e++) p[e] = m->x + 3 * (size_t)c->seeds[v[e]];
            int far = tri_far(m, foff, flist, p, v, 3, c->eps);
            if (far)
                for (int e = 0; e < 3; e++) c->bad[v[e]] = c->bad[v[e]] ? c->bad[v[e]] : 1;
        }
    } else {
        for (size_t i = 0; i < ns; i++) c->bad[i] = 1; /* out of memory: refine everything */
    }
    free(foff);
    free(flist);
    /* Sec. 3.7: the radius constraints bound the geodesic edge ratio of a triangle by 1/3;
     * the Euclidean ratio converges to it under refinement, so a triangle whose shortest /
     * longest edge is below ASPECT refines the seeds at its longest edge. */
    for (size_t t = 0; t < c->ntri; t++) {
        const int32_t *v = c->tri + 3 * t;
        double l[3];
        for (int e = 0; e < 3; e++) {
            const double *a = m->x + 3 * (size_t)c->seeds[v[e]];
            const double *b = m->x + 3 * (size_t)c->seeds[v[(e + 1) % 3]];
            l[e] = sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                        (a[2] - b[2]) * (a[2] - b[2]));
        }
        int emax = l[0] >= l[1] && l[0] >= l[2] ? 0 : l[1] >= l[2] ? 1 : 2;
        double lmin = fmin(l[0], fmin(l[1], l[2]));
        if (lmin < ASPECT * l[emax]) {
            /* the seeds of the longest edge, or the third when those are at their finest */
            int any = 0;
            for (int e = 0; e < 2; e++) {
                int32_t q = v[(emax + e) % 3];
                int lq = c->seedlev[c->seeds[q]];
                if (lq != FORCED && lq < c->lmax[c->seeds[q]]) any = 1;
                c->bad[q] = c->bad[q] ? c->bad[q] : 1;
            }
            if (!any) {
                int32_t q = v[(emax + 2) % 3];
                c->bad[q] = c->bad[q] ? c->bad[q] : 1;
            }
        }
    }
    /* Fig. 7 for interacting neighbours: Voronoi neighbours differ by at most one level */
    for (size_t h = 0; h < 3 * c->ntri; h++) {
        int32_t a = (int32_t)(c->half[h] >> 32), b = (int32_t)(uint32_t)c->half[h];
        int la = c->seedlev[c->seeds[a]], lb = c->seedlev[c->seeds[b]];
        if (la != FORCED && lb != FORCED && la + 1 < lb) c->bad[a] = c->bad[a] ? c->bad[a] : 1;
    }
    for (size_t i = 0; i < c->nseeds; i++) {
        int32_t w = c->seeds[i];
        int l = c->seedlev[w];
        int want = l + c->bad[i];
        if (want > c->lmax[w]) want = c->lmax[w];
        if (c->bad[i] && l != FORCED && c->cap[w] < want) {
            c->cap[w] = (uint8_t)want;
            c->changed = 1;
        }
    }
}

/* -- the final edge flips ---------------------------------------------------------------- */

#define FLIP_RATIO 0.33 /* edge ratio a flip aims for: the paper's 0.3 with a margin */
#define FLIP_ANGLE 20.0 /* degrees: the smallest angle a flip aims for */
#define FLIP_GAIN 1e-9  /* a flip must raise the worse quality by more than rounding */
#define FLIP_ROUNDS 20  /* flip rounds at most */

/* Quality of a triangle for the flips: min(shortest / longest edge / FLIP_RATIO, smallest
 * angle / FLIP_ANGLE); 1 and above is good on both counts. */
static double tri_quality(const double *a, const double *b, const double *c) {
    double l[3], l2[3];
    const double *p[3] = {a, b, c};
    for (int e = 0; e < 3; e++) {
        const double *u = p[e], *w = p[(e + 1) % 3];
        l2[e] = (u[0] - w[0]) * (u[0] - w[0]) + (u[1] - w[1]) * (u[1] - w[1]) +
                (u[2] - w[2]) * (u[2] - w[2]);
        l[e] = sqrt(l2[e]);
    }
    double lmax = fmax(l[0], fmax(l[1], l[2])), lmin = fmin(l[0], fmin(l[1], l[2]));
    if (!(lmin > 0)) return 0;
    double amin = INFINITY;
    for (int e = 0; e < 3; e++) { /* the angle opposite edge e */
        double x = l[(e + 1) % 3], y = l[(e + 2) % 3];
        double cs = (x * x + y * y - l2[e]) / (2 * x * y);
        if (cs > 1) cs = 1;
        if (cs < -1) cs = -1;
        amin = fmin(amin, acos(cs) * 180.0 / 3.14159265358979323846);
    }
    return fmin(lmin / lmax / FLIP_RATIO, amin / FLIP_ANGLE);
}

/* Unit normal of triangle (a, b, c); 0, 0, 0 when degenerate. */
static void unit_normal(const double *a, const double *b, const double *c, double n[3]) {
    double u[3], w[3];
    vm__sub3(b, a, u);
    vm__sub3(c, a, w);
    vm__cross3(u, w, n);
    double l = vm__norm3(n);
    for (int k = 0; k < 3; k++) n[k] = l > 0 ? n[k] / l : 0;
}

typedef struct {
    uint64_t key;
    int32_t he; /* 3 t + e */
} hedge;

static int cmp_hedge(const void *a, const void *b) {
    uint64_t x = ((const hedge *)a)->key, y = ((const hedge *)b)->key;
    return x < y ? -1 : x > y;
}

static long find_hedge(const hedge *h, size_t n, uint64_t k) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (h[mid].key < k) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && h[lo].key == k ? (long)lo : -1;
}

/* Flips edges of the dual whose two triangles have a poor quality, when the flipped pair is
 * better, bends no more than the old pair (or less than 30 degrees), creates no edge that
 * exists, stays within eps of the fine faces of the four neighbourhoods, and leaves both
 * new triangles at an edge ratio of min_ratio or more (0: any). Flips keep the surface a
 * closed oriented manifold with the same vertices. Returns the number of flips. */
static size_t flip_edges(const vm__cover_fine *m, const int32_t *seeds, const uint8_t *forced,
                         size_t ns, int32_t *tri, size_t nt, const int32_t *label, double eps,
                         double min_ratio) {
    size_t *foff = NULL;
    int32_t *flist = NULL;
    hedge *h = malloc((3 * nt + 1) * sizeof *h);
    uint8_t *touched = malloc(ns + 1);
    size_t flips = 0;
    if (!h || !touched || cell_faces(m, label, ns, &foff, &flist)) {
        free(h);
        free(touched);
        return 0;
    }
    const double cos30 = 0.86602540378443865;
    for (int round = 0; round < FLIP_ROUNDS; round++) {
        for (size_t t = 0; t < nt; t++)
            for (int e = 0; e < 3; e++) {
                h[3 * t + e].key = hkey(tri[3 * t + e], tri[3 * t + (e + 1) % 3]);
                h[3 * t + e].he = (int32_t)(3 * t + (size_t)e);
            }
        qsort(h, 3 * nt, sizeof *h, cmp_hedge);
        memset(touched, 0, ns);
        size_t nflip = 0;
        for (size_t t = 0; t < nt; t++)
            for (int e = 0; e < 3; e++) {
                int32_t a = tri[3 * t + e], b = tri[3 * t + (e + 1) % 3];
                int32_t c = tri[3 * t + (e + 2) % 3];
                if (a > b || touched[a] || touched[b] || touched[c]) continue;
                long tw = find_hedge(h, 3 * nt, hkey(b, a));
                if (tw < 0) continue;
                size_t t2 = (size_t)h[tw].he / 3;
                int e2 = h[tw].he % 3;
                int32_t d = tri[3 * t2 + (e2 + 2) % 3];
                if (t2 == t || d == c || touched[d]) continue;
                /* the fine surface kept as is stays as is */
                if (forced[seeds[a]] == 1 || forced[seeds[b]] == 1 || forced[seeds[c]] == 1 ||
                    forced[seeds[d]] == 1)
                    continue;
                if (find_hedge(h, 3 * nt, hkey(c, d)) >= 0 || find_hedge(h, 3 * nt, hkey(d, c)) >= 0)
                    continue;
                const double *pa = m->x + 3 * (size_t)seeds[a], *pb = m->x + 3 * (size_t)seeds[b];
                const double *pc = m->x + 3 * (size_t)seeds[c], *pd = m->x + 3 * (size_t)seeds[d];
                double qold = fmin(tri_quality(pa, pb, pc), tri_quality(pb, pa, pd));
                if (qold >= 1.0) continue;
                double qnew = fmin(tri_quality(pa, pd, pc), tri_quality(pd, pb, pc));
                if (qnew <= qold + FLIP_GAIN) continue;
                if (min_ratio > 0) {
                    int32_t t1[3] = {a, d, c}, t2n[3] = {d, b, c};
                    if (edge_ratio(m, seeds, t1) < min_ratio) continue;
                    if (edge_ratio(m, seeds, t2n) < min_ratio) continue;
                }
                double n1[3], n2[3], n3[3], n4[3];
                unit_normal(pa, pb, pc, n1);
                unit_normal(pb, pa, pd, n2);
                unit_normal(pa, pd, pc, n3);
                unit_normal(pd, pb, pc, n4);
                double bend_old = vm__dot3(n1, n2), bend_new = vm__dot3(n3, n4);
                if (bend_new < fmin(bend_old, cos30)) continue;
                if (vm__dot3(n3, n1) <= 0 || vm__dot3(n3, n2) <= 0 || vm__dot3(n4, n1) <= 0 ||
                    vm__dot3(n4, n2) <= 0)
                    continue;
                int32_t cells[4] = {a, b, c, d};
                const double *p1[3] = {pa, pd, pc}, *p2[3] = {pd, pb, pc};
                if (tri_far(m, foff, flist, p1, cells, 4, eps) ||
                    tri_far(m, foff, flist, p2, cells, 4, eps))
                    continue;
                tri[3 * t] = a, tri[3 * t + 1] = d, tri[3 * t + 2] = c;
                tri[3 * t2] = d, tri[3 * t2 + 1] = b, tri[3 * t2 + 2] = c;
                touched[a] = touched[b] = touched[c] = touched[d] = 1;
                nflip++;
            }
        flips += nflip;
        if (nflip == 0) break;
    }
    free(h);
    free(touched);
    free(foff);
    free(flist);
    return flips;
}

/* Repairs the bad seeds of a failed dual: halve their disks, or, at the finest radius,
 * keep every fine vertex of their component as a seed. */
enum { GROW_DUAL, GROW_REFINE, GROW_TANGLE }; /* why a farthest-point covering grows */
static vm_status fps_apply(cover *c, int why, vm_error *err);

static vm_status repair(cover *c, vm_error *err) {
    const vm__cover_fine *m = c->m;
    int any_force = 0;
    /* count the failures of each component once per pass */
    uint8_t *seen = calloc(m->ncomp + 1, 1);
    for (size_t i = 0; seen && i < c->nseeds; i++)
        if (c->bad[i]) seen[m->comp[c->seeds[i]]] = 1;
    for (size_t k = 0; seen && k < m->ncomp; k++)
        if (c->nfps[k] > 0 && !seen[k]) c->fps_ok[k] = c->nfps[k];
    if (seen) memset(seen, 0, m->ncomp + 1);
    for (size_t i = 0; seen && i < c->nseeds; i++) {
        int32_t k = m->comp[c->seeds[i]];
        if (c->bad[i] && !seen[k]) {
            seen[k] = 1;
            if (c->comp_fails[k] < 255) c->comp_fails[k]++;
        }
    }
    free(seen);
    for (size_t i = 0; i < c->nseeds; i++) {
        if (!c->bad[i]) continue;
        int32_t w = c->seeds[i];
        int l = c->seedlev[w];
        if (c->forced[w] == 2) {
            c->grow[m->comp[w]] = 1; /* a farthest-point covering with too few seeds */
        } else if (c->forced[w] == 1) {
            continue;
        } else if (l != FORCED && l < c->lmax[w]) {
            if (c->cap[w] < l + 1) c->cap[w] = (uint8_t)(l + 1);
        } else if (l != FORCED && c->lmax[w] < c->lfloor[w] + EXTRA && l + 1 < LEVELS) {
            /* below the 1-ring rule, at most EXTRA levels: resolves a small feature at the
             * price of the aspect bound there (sec. 3.9's trade-off) */
            c->lmax[w]++;
            c->cap[w] = (uint8_t)(l + 1);
        } else if (c->comp_fails[m->comp[w]] >= REPAIRS) {
            c->bad[i] = 2;
            any_force = 1;
            c->forced_cells++;
        }
    }
    /* A neighbourhood that cannot shrink further (the paper's case for supersampling, sec.
     * 3.9, when the sampling is already at its finest): its whole component is covered by
     * farthest points instead (mixing disks and other seeds in one component made seams that
     * crossed themselves). */
    if (any_force)
        for (size_t i = 0; i < c->nseeds; i++)
            if (c->bad[i] == 2) c->grow[m->comp[c->seeds[i]]] = 1;
    return fps_apply(c, GROW_DUAL, err);
}

/* Farthest-point covering of component k with c->nfps[k] seeds (forced value 2): the first
 * seed is the vertex farthest from the component's first vertex, each next one the vertex
 * farthest (along the candidate graph) from the seeds so far. Seeds spread evenly, each
 * Voronoi neighbour within about twice the spacing, so their dual keeps a good edge ratio
 * where disks holding their 1-rings cannot be simple (a blob of a few voxels). */
static vm_status fps_place(cover *c, size_t k, vm_error *err) {
    const vm__cover_fine *m = c->m;
    int32_t first = -1;
    for (size_t v = 0; v < m->nv; v++)
        if ((size_t)m->comp[v] == k) {
            if (c->forced[v] == 2) c->forced[v] = 0;
            c->fd[v] = INFINITY;
            if (first < 0) first = (int32_t)v;
        }
    if (first < 0) return VM_OK;
    vm_status s = VM_OK;
    int32_t src = first;
    for (int32_t n = -1; !s && n < c->nfps[k]; n++) {
        /* distances from src, lowering fd (n = -1: a throwaway pass to find the start) */
        c->nheap = 0;
        c->fd[src] = 0;
        s = heap_push(c, 0, src, err);
        while (!s && c->nheap > 0) {
            hitem it = heap_pop(c);
            if (it.d > c->fd[it.v]) continue;
            for (size_t h = m->off[it.v]; h < m->off[it.v + 1]; h++) {
                int32_t y = m->nbr[h];
                double nd = it.d + m->len[h];
                if (nd < c->fd[y]) {
                    c->fd[y] = nd;
                    s = heap_push(c, nd, y, err);
                    if (s) break;
                }
            }
        }
        int32_t far = -1;
        double dfar = -1;
        for (size_t v = 0; v < m->nv; v++)
            if ((size_t)m->comp[v] == k && c->fd[v] > dfar && c->forced[v] != 2)
                dfar = c->fd[v], far = (int32_t)v;
        if (n == -1)
            for (size_t v = 0; v < m->nv; v++)
                if ((size_t)m->comp[v] == k) c->fd[v] = INFINITY;
        if (far < 0 || (n >= 0 && dfar <= 0)) break;
        c->forced[far] = 2;
        src = far;
    }
    return s;
}

/* Starts or grows (by one seed up to 8, then x1.5) the farthest-point covering of every component marked in c->grow;
 * one that would need more than half of its vertices keeps its fine surface. */
static vm_status fps_apply(cover *c, int why, vm_error *err) {
    const vm__cover_fine *m = c->m;
    vm_status s = VM_OK;
    for (size_t k = 0; !s && k < m->ncomp; k++) {
        if (!c->grow[k]) continue;
        c->grow[k] = 0;
        int thin = c->thin[k];
        c->thin[k] = 0;
        /* frozen: the error is given up, not the edge ratio */
        if (c->frozen[k] && why == GROW_REFINE && !thin) continue;
        c->changed = 1;
        int32_t ok = c->fps_ok[k], n = c->nfps[k];
        if (!c->frozen[k] && why == GROW_DUAL && ok > 0) {
            /* more seeds than the candidate graph can carry: bisect between the last valid
             * count and this one, and stay at the valid one when they are close */
            c->fps_hi[k] = n;
            int32_t mid = ok + (n - ok) / 2;
            if (mid > ok && n - ok > 1 + ok / 10) {
                c->nfps[k] = mid;
            } else {
                c->frozen[k] = 1;
                c->nfps[k] = ok;
            }
            s = fps_place(c, k, err);
            continue;
        }
        long genus = (2 - m->comp_euler[k]) / 2;
        if (n == 0) { /* start from the disks' count there */
            n = (int32_t)(4 + 8 * (genus > 0 ? genus : 0));
            int32_t have = 0;
            for (size_t i = 0; i < c->nseeds; i++) have += (size_t)m->comp[c->seeds[i]] == k;
            if (have > n && (size_t)have <= c->csize[k] / 2) n = have;
        } else {
            n = n < 8 ? n + 1 : n + n / 2;
        }
        if (c->fps_hi[k] > 0 && n >= c->fps_hi[k]) n = c->nfps[k] + (c->fps_hi[k] - c->nfps[k]) / 2;
        if (n <= c->nfps[k] && c->nfps[k] > 0) c->frozen[k] = 1; /* no room left */
        if ((size_t)n > c->csize[k] / 2 || c->frozen[k]) {
            for (size_t x = 0; x < m->nv; x++)
                if ((size_t)m->comp[x] == k) c->forced[x] = 1;
            c->forced_cells++;
            continue;
        }
        c->nfps[k] = n;
        s = fps_place(c, k, err);
    }
    return s;
}

/* Self-intersections of the dual (the paper leaves them to refinement, sec. 3.8; we look):
 * every component of the fine surface holding an intersecting triangle is covered by
 * farthest points, or more of them (and at worst keeps its fine surface). Returns the number of intersecting pairs. */
static vm_status untangle(cover *c, const int32_t *tri, size_t nt, size_t *pairs, vm_error *err) {
    const vm__cover_fine *m = c->m;
    vm_index *t = malloc((3 * nt + 1) * sizeof *t);
    uint8_t *flags = malloc(nt + 1);
    double *pts = malloc((3 * c->nseeds + 1) * sizeof *pts);
    uint8_t *cf = calloc(m->ncomp + 1, 1);
    vm_status s = VM_OK;
    if (!t || !flags || !pts || !cf) s = cover_nomem(err);
    if (!s) {
        for (size_t i = 0; i < 3 * nt; i++) t[i] = (vm_index)tri[i];
        for (size_t i = 0; i < c->nseeds; i++)
            memcpy(pts + 3 * i, m->x + 3 * (size_t)c->seeds[i], 3 * sizeof *pts);
        s = vm__self_intersections(pts, t, nt, pairs, flags, err);
    }
    if (!s && *pairs > 0) {
        for (size_t i = 0; i < nt; i++)
            if (flags[i]) cf[m->comp[c->seeds[tri[3 * i]]]] = 1;
        for (size_t k = 0; k < m->ncomp; k++)
            if (cf[k]) c->grow[k] = 1;
        s = fps_apply(c, GROW_TANGLE, err);
    }
    free(t), free(flags), free(pts), free(cf);
    return s;
}

/* -- the local fallback: one-vertex cells where the farthest-point cells fail ------------ */

#define LOCAL_SPACING 6   /* fine vertices per farthest-point cell of a local fallback */
#define LOCAL_MIN 8       /* components this small keep their fine surface as they are */
#define NOMEM_LOCAL "surface cover: out of memory (local fallback)"
#define LOCAL_RATIO 0.301 /* the paper's edge ratio 0.3, a margin for rounding in the world */

/* Farthest-point cells of component k with n seeds, grown along the candidate graph as
 * voronoi() does: rep[v] is the seed vertex of v's cell. */
static vm_status local_cells(cover *c, size_t k, int32_t n, int32_t *rep, vm_error *err) {
    const vm__cover_fine *m = c->m;
    c->nfps[k] = n;
    vm_status s = fps_place(c, k, err);
    if (s) return s;
    c->nheap = 0;
    for (size_t v = 0; !s && v < m->nv; v++) {
        if ((size_t)m->comp[v] != k) continue;
        c->dist[v] = INFINITY;
        rep[v] = -1;
        if (c->forced[v] == 2) {
            c->dist[v] = 0;
            rep[v] = (int32_t)v;
            s = heap_push(c, 0, (int32_t)v, err);
        }
    }
    while (!s && c->nheap > 0) {
        hitem it = heap_pop(c);
        if (it.d > c->dist[it.v]) continue;
        int32_t src = rep[it.v];
        for (size_t h = m->off[it.v]; h < m->off[it.v + 1]; h++) {
            int32_t y = m->nbr[h];
            double nd = euclid(m, y, src);
            if (nd < c->dist[y]) {
                c->dist[y] = nd;
                rep[y] = src;
                s = heap_push(c, nd, y, err);
                if (s) break;
            }
        }
    }
    for (size_t v = 0; v < m->nv; v++)
        if ((size_t)m->comp[v] == k) {
            c->dist[v] = INFINITY;
            if (rep[v] < 0) rep[v] = (int32_t)v; /* unreachable: a cell of its own */
        }
    return s;
}

#define FLAT_AREA 1e-9 /* relative to the longest edge squared: rounding, not geometry */

/* 1 when dual triangle t (seed indices) has next to no area: twice its area at most
 * FLAT_AREA of its longest edge squared (a seam triangle whose corners lie on one grid
 * line). */
static int flat(const vm__cover_fine *m, const int32_t *seeds, const int32_t *t) {
    const double *a = m->x + 3 * (size_t)seeds[t[0]], *b = m->x + 3 * (size_t)seeds[t[1]];
    const double *d = m->x + 3 * (size_t)seeds[t[2]];
    double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double w[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
    double n[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2],
                   u[0] * w[1] - u[1] * w[0]};
    double l = fmax(euclid(m, seeds[t[0]], seeds[t[1]]), euclid(m, seeds[t[1]], seeds[t[2]]));
    l = fmax(l, euclid(m, seeds[t[2]], seeds[t[0]]));
    return sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) <= FLAT_AREA * l * l;
}

/* The scratch of one local fallback and the dual it builds. */
typedef struct lfb {
    cover *c;
    const vm__cover_fine *m;
    size_t nv, nc;
    uint8_t *local;   /* per fine component: cut into local cells */
    size_t *nforced;  /* per fine component: forced vertices, then: components to replace */
    int32_t *rep;     /* per fine vertex: the seed vertex of its cell */
    int32_t *idx;     /* per fine vertex: its seed index when it is a seed, else -1 */
    int32_t *cnt;     /* per seed: vertices in its cell */
    uint8_t *split;   /* per seed: its cell is split into one-vertex cells */
    int32_t *out;     /* 3 nt: the triangles (seed indices) */
    vm_index *vt;     /* 3 nt: out as vm_index, for the crossing test */
    uint8_t *flags;   /* nt: the triangle crosses another */
    double *pts;      /* 3 nseeds: the seeds' points */
    size_t nt, tcap;
} lfb;

/* Frees the scratch of a local fallback. */
static void lfb_free(lfb *L) {
    free(L->local), free(L->nforced), free(L->rep), free(L->idx), free(L->cnt), free(L->split);
    free(L->out), free(L->vt), free(L->pts), free(L->flags);
}

/* Allocates L's per-vertex scratch and marks the local components: those of at least
 * LOCAL_MIN vertices all forced (kept fine) on entry; *nlocal counts them. */
static vm_status lfb_init(lfb *L, cover *c, const uint8_t *pforced, size_t *nlocal,
                          vm_error *err) {
    memset(L, 0, sizeof *L);
    const vm__cover_fine *m = c->m;
    L->c = c;
    L->m = m;
    L->nv = m->nv;
    L->nc = m->ncomp;
    size_t nv = L->nv, nc = L->nc;
    L->local = calloc(nc + 1, 1);
    L->nforced = calloc(nc + 1, sizeof *L->nforced);
    L->rep = malloc((nv + 1) * sizeof *L->rep);
    L->idx = malloc((nv + 1) * sizeof *L->idx);
    L->cnt = malloc((nv + 1) * sizeof *L->cnt);
    L->split = malloc(nv + 1);
    *nlocal = 0;
    if (!L->local || !L->nforced || !L->rep || !L->idx || !L->cnt || !L->split)
        return vm_error_set(err, VM_ERR_NOMEM, NOMEM_LOCAL);
    for (size_t v = 0; v < nv; v++) L->nforced[m->comp[v]] += pforced[v] == 1;
    for (size_t k = 0; k < nc; k++)
        if (L->nforced[k] == c->csize[k] && c->csize[k] >= LOCAL_MIN)
            L->local[k] = 1, (*nlocal)++;
    return VM_OK;
}

/* The first partition: the entry's cells, and farthest-point cells on local components
 * (about one per LOCAL_SPACING vertices, enough for the genus, at most half the vertices). */
static vm_status lfb_first_cells(lfb *L, const int32_t *seeds, const int32_t *label,
                                 vm_error *err) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    vm_status s = VM_OK;
    for (size_t v = 0; v < L->nv; v++) L->rep[v] = seeds[label[v]];
    for (size_t k = 0; !s && k < L->nc; k++) {
        if (!L->local[k]) continue;
        long genus = (2 - m->comp_euler[k]) / 2;
        int32_t n = (int32_t)(c->csize[k] / LOCAL_SPACING);
        if (n < 4 + 8 * genus) n = (int32_t)(4 + 8 * (genus > 0 ? genus : 0));
        if ((size_t)n > c->csize[k] / 2) n = (int32_t)(c->csize[k] / 2);
        if (n < 1) n = 1;
        s = local_cells(c, k, n, L->rep, err);
    }
    return s;
}

/* The partition rep as seeds and labels (c->seeds, c->label), and its dual (c->tri). */
static vm_status lfb_dual(lfb *L, vm_error *err) {
    cover *c = L->c;
    size_t ns = 0;
    for (size_t v = 0; v < L->nv; v++) L->idx[v] = -1;
    for (size_t v = 0; v < L->nv; v++) {
        int32_t r = L->rep[v];
        if (L->idx[r] < 0) L->idx[r] = (int32_t)ns, c->seeds[ns++] = r;
        c->label[v] = L->idx[r];
    }
    c->nseeds = ns;
    size_t nbad = 0;
    return dual(c, &nbad, err);
}

/* The triangles L->out: the dual's on local components, the entry's (seeds, tri, nt0)
 * elsewhere, renumbered to the new seeds; L->pts, L->cnt for them, and L->flags marking the
 * crossing ones. */
static vm_status lfb_triangles(lfb *L, const int32_t *seeds, const int32_t *tri, size_t nt0,
                               vm_error *err) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    size_t ns = c->nseeds, nt = 0;
    for (size_t t = 0; t < c->ntri; t++)
        if (L->local[m->comp[c->seeds[c->tri[3 * t]]]]) nt++;
    for (size_t t = 0; t < nt0; t++)
        if (!L->local[m->comp[seeds[tri[3 * t]]]]) nt++;
    L->nt = nt;
    if (nt > L->tcap) {
        free(L->out), free(L->vt), free(L->flags);
        L->tcap = nt;
        L->out = malloc((3 * L->tcap + 1) * sizeof *L->out);
        L->vt = malloc((3 * L->tcap + 1) * sizeof *L->vt);
        L->flags = malloc(L->tcap + 1);
    }
    free(L->pts);
    L->pts = malloc((3 * ns + 1) * sizeof *L->pts);
    if (!L->out || !L->vt || !L->flags || !L->pts)
        return vm_error_set(err, VM_ERR_NOMEM, NOMEM_LOCAL);
    nt = 0;
    for (size_t t = 0; t < c->ntri; t++)
        if (L->local[m->comp[c->seeds[c->tri[3 * t]]]])
            memcpy(L->out + 3 * nt++, c->tri + 3 * t, 3 * sizeof *L->out);
    for (size_t t = 0; t < nt0; t++)
        if (!L->local[m->comp[seeds[tri[3 * t]]]]) {
            for (int e = 0; e < 3; e++) L->out[3 * nt + e] = L->idx[seeds[tri[3 * t + e]]];
            nt++;
        }
    for (size_t i = 0; i < ns; i++) {
        memcpy(L->pts + 3 * i, m->x + 3 * (size_t)c->seeds[i], 3 * sizeof *L->pts);
        L->cnt[i] = 0;
    }
    for (size_t v = 0; v < L->nv; v++) L->cnt[c->label[v]]++;
    for (size_t i = 0; i < 3 * nt; i++) L->vt[i] = (vm_index)L->out[i];
    size_t pairs = 0;
    return vm__self_intersections(L->pts, L->vt, nt, &pairs, L->flags, err);
}

/* Marks the cells to split: failing cells and their neighbours along fine edges, corners
 * (of more than one vertex) of crossing triangles and of thin covered triangles; a crossing
 * triangle of a covered component with no such corner marks its component in nforced. */
static void lfb_mark_failing(lfb *L) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    const uint8_t *local = L->local;
    const int32_t *cnt = L->cnt;
    memset(L->split, 0, c->nseeds);
    memset(L->nforced, 0, L->nc * sizeof *L->nforced); /* now: components to replace */
    for (size_t v = 0; v < L->nv; v++) {
        int32_t a = c->label[v];
        if (!local[m->comp[v]] || !c->bad[a]) continue;
        L->split[a] = 1;
        for (size_t h = m->off[v]; h < m->off[v + 1]; h++) L->split[c->label[m->nbr[h]]] = 1;
    }
    for (size_t t = 0; t < L->nt; t++) {
        const int32_t *q = L->out + 3 * t;
        int32_t w = c->seeds[q[0]];
        int thin = 0;
        if (!L->flags[t] && local[m->comp[w]]) {
            int one = cnt[q[0]] == 1 || cnt[q[1]] == 1 || cnt[q[2]] == 1;
            thin = !one && edge_ratio(m, c->seeds, q) < LOCAL_RATIO;
            thin = thin || flat(m, c->seeds, q);
        }
        if (!L->flags[t] && !thin) continue;
        int any = 0;
        for (int e = 0; e < 3; e++)
            if (local[m->comp[w]] && cnt[q[e]] > 1) L->split[q[e]] = 1, any = 1;
        if (!any && !local[m->comp[w]]) L->nforced[m->comp[w]] = 1;
    }
}

/* The maximum-distance metric both ways (sec. 3.5), as refine() measures it: splits the cell
 * of a fine vertex farther than eps from the triangles at its cell's seed, and the cells of a
 * triangle with a point farther than eps from the fine faces of its three cells. */
static vm_status lfb_mark_far(lfb *L, vm_error *err) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    const int32_t *cnt = L->cnt;
    uint8_t *split = L->split;
    for (size_t v = 0; v < L->nv; v++) {
        int32_t a = c->label[v];
        if (!L->local[m->comp[v]] || cnt[a] == 1 || split[a]) continue;
        double best = INFINITY;
        for (size_t q = c->toff[a]; q < c->toff[a + 1] && best > c->eps; q++) {
            const int32_t *t = c->tri + 3 * (size_t)c->tlist[q];
            best = fmin(best, point_tri(m->x + 3 * v, m->x + 3 * (size_t)c->seeds[t[0]],
                                        m->x + 3 * (size_t)c->seeds[t[1]],
                                        m->x + 3 * (size_t)c->seeds[t[2]]));
        }
        if (best > c->eps) split[a] = 1;
    }
    size_t *foff = NULL;
    int32_t *flist = NULL;
    if (cell_faces(m, c->label, c->nseeds, &foff, &flist))
        return vm_error_set(err, VM_ERR_NOMEM, NOMEM_LOCAL);
    for (size_t t = 0; t < c->ntri; t++) {
        const int32_t *q = c->tri + 3 * t;
        if (!L->local[m->comp[c->seeds[q[0]]]]) continue;
        int open = 0;
        for (int e = 0; e < 3; e++) open |= cnt[q[e]] > 1 && !split[q[e]];
        if (!open) continue;
        const double *p[3];
        for (int e = 0; e < 3; e++) p[e] = m->x + 3 * (size_t)c->seeds[q[e]];
        if (tri_far(m, foff, flist, p, q, 3, c->eps))
            for (int e = 0; e < 3; e++) split[q[e]] = 1;
    }
    free(foff);
    free(flist);
    return VM_OK;
}

/* Splits the marked cells into one-vertex cells; when none is marked, a covered component
 * marked in nforced becomes local, all of it one-vertex cells (its fine surface). Returns
 * the number of vertices or components changed (0: the fixpoint). */
static size_t lfb_split(lfb *L) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    size_t nsplit = 0;
    for (size_t v = 0; v < L->nv; v++)
        if (L->local[m->comp[v]] && L->split[c->label[v]] && L->cnt[c->label[v]] > 1)
            L->rep[v] = (int32_t)v, nsplit++;
    /* a covered component elsewhere at a crossing that no split removes becomes local,
     * all of it one-vertex cells (its fine surface) */
    for (size_t v = 0; nsplit == 0 && v < L->nv; v++)
        if (L->nforced[m->comp[v]]) L->rep[v] = (int32_t)v;
    for (size_t k = 0; nsplit == 0 && k < L->nc; k++)
        if (L->nforced[k]) L->local[k] = 1, nsplit++;
    return nsplit;
}

/* The final flips on the covered triangles, none below LOCAL_RATIO (a flip trades edge
 * ratio for angle), all undone if they made a crossing or a thin triangle. */
static vm_status lfb_flip(lfb *L, const uint8_t *pforced, vm_error *err) {
    cover *c = L->c;
    const vm__cover_fine *m = L->m;
    size_t nt = L->nt;
    int32_t *out = L->out;
    vm_status s = VM_OK;
    int32_t *save = malloc((3 * nt + 1) * sizeof *save);
    if (!save) return VM_OK;
    memcpy(save, out, 3 * nt * sizeof *save);
    size_t nflip =
        flip_edges(m, c->seeds, pforced, c->nseeds, out, nt, c->label, c->eps, LOCAL_RATIO);
    if (nflip > 0) {
        int ok = 1;
        for (size_t t = 0; ok && t < nt; t++) {
            const int32_t *q = out + 3 * t;
            int one = L->cnt[q[0]] == 1 || L->cnt[q[1]] == 1 || L->cnt[q[2]] == 1;
            one = one || !L->local[m->comp[c->seeds[q[0]]]];
            if (!one && edge_ratio(m, c->seeds, q) < LOCAL_RATIO) ok = 0;
            if (!one && flat(m, c->seeds, q)) ok = 0;
        }
        size_t pairs = 0;
        for (size_t i = 0; ok && i < 3 * nt; i++) L->vt[i] = (vm_index)out[i];
        if (ok) s = vm__self_intersections(L->pts, L->vt, nt, &pairs, NULL, err);
        if (!ok || pairs > 0) memcpy(out, save, 3 * nt * sizeof *out);
    }
    free(save);
    return s;
}

/* Where a component kept its fine surface whole (its farthest-point duals failed), keep
 * it fine only locally, as a fixpoint: the component is cut into farthest-point cells; every
 * cell failing the dual checks (twin edges, one fan, closed ball, Euler and connectedness of
 * the component) and every cell next to it along a fine edge is split into one-vertex cells;
 * then so is every cell owning a corner of a crossing triangle (core/self_intersect.c)
 * or of a triangle below the edge ratio 0.3 without a one-vertex corner (or flat), and every
 * cell farther than the error from its triangles or they from it (sec. 3.5); repeat until
 * nothing fails. It ends: with every cell split, the component is its fine surface, which
 * passes every check. One-vertex cells reproduce the fine faces between them; seam
 * triangles join them to larger cells. The arrays *pseeds, *pforced (per fine vertex: 1 on
 * one-vertex cells, whose triangles carry cover_fine = 1), *pns, *ptri, *pnt describe the
 * valid dual on entry and on return; label is its labelling (seed index per fine vertex);
 * *iterations counts the duals built. Components covered on entry keep their triangles as
 * they are (one of them is replaced by its fine surface only if it crosses a triangle no
 * split can remove). */
static vm_status local_fallback(cover *c, int32_t **pseeds, uint8_t *pforced, size_t *pns,
                                int32_t **ptri, size_t *pnt, const int32_t *label,
                                size_t *iterations, vm_error *err) {
    lfb L;
    size_t nlocal = 0;
    vm_status s = lfb_init(&L, c, pforced, &nlocal, err);
    if (!s && nlocal == 0) goto done;
    if (!s) s = lfb_first_cells(&L, *pseeds, label, err);
    for (size_t it = 0; !s; it++) {
        s = lfb_dual(&L, err);
        if (!s) s = lfb_triangles(&L, *pseeds, *ptri, *pnt, err);
        if (s) break;
        lfb_mark_failing(&L);
        s = lfb_mark_far(&L, err);
        if (s) break;
        if (lfb_split(&L) == 0) {
            *iterations = it + 1;
            break;
        }
    }
    if (!s) {
        for (size_t v = 0; v < L.nv; v++)
            if (L.local[L.m->comp[v]]) pforced[v] = L.cnt[c->label[v]] == 1 ? 1 : 2;
        s = lfb_flip(&L, pforced, err);
    }
    if (!s) { /* the result */
        int32_t *seeds = malloc((c->nseeds + 1) * sizeof *seeds);
        if (!seeds) {
            s = vm_error_set(err, VM_ERR_NOMEM, NOMEM_LOCAL);
        } else {
            memcpy(seeds, c->seeds, c->nseeds * sizeof *seeds);
            free(*pseeds);
            free(*ptri);
            *pseeds = seeds;
            *pns = c->nseeds;
            *ptri = L.out;
            *pnt = L.nt;
            L.out = NULL;
        }
    }
done:
    lfb_free(&L);
    return s;
}

static void cover_free(cover *c) {
    free(c->dist), free(c->touched), free(c->order), free(c->heap), free(c->lmax), free(c->cap), free(c->hint), free(c->lfloor);
    free(c->comp_fails), free(c->nfps), free(c->grow), free(c->fd), free(c->csize);
    free(c->fps_ok), free(c->frozen), free(c->fps_hi), free(c->thin);
    free(c->forced), free(c->forb), free(c->binl), free(c->seedlev), free(c->bcnt);
    free(c->fmark), free(c->fqueue), free(c->label), free(c->seeds), free(c->prev);
    free(c->prevlev), free(c->tri), free(c->half), free(c->toff), free(c->tlist), free(c->bad);
    for (int l = 0; l < LEVELS; l++) free(c->bins[l]);
}

/* Appends the points x (3 np, scaled space; output x / scale[a]) and triangles tri (3 ntri)
 * to surf, with the cell field cover_fine = kept[t]. */
static vm_status emit(const double *x, size_t np, const double *scale, const int32_t *tri,
                      size_t ntri, const uint8_t *kept, vm_mesh *surf, vm_error *err) {
    vm_status s = vm_mesh_reserve(surf, surf->npoints + np, surf->ncells + ntri, err);
    size_t base = surf->npoints;
    for (size_t i = 0; !s && i < np; i++) {
        double q[3] = {x[3 * i] / scale[0], x[3 * i + 1] / scale[1], x[3 * i + 2] / scale[2]};
        if (vm_mesh_add_point(surf, q, err) < 0) s = VM_ERR_NOMEM;
    }
    for (size_t t = 0; !s && t < ntri; t++) {
        vm_index nodes[3];
        for (int e = 0; e < 3; e++) nodes[e] = (vm_index)(base + (size_t)tri[3 * t + e]);
        s = vm_mesh_add_cell(surf, nodes, 1, err);
    }
    double *f = s ? NULL : malloc((surf->ncells + 1) * sizeof *f);
    if (!s && !f) s = cover_nomem(err);
    if (!s) {
        for (size_t t = 0; t < surf->ncells; t++) f[t] = 0;
        for (size_t t = 0; t < ntri; t++) f[surf->ncells - ntri + t] = kept[t];
        s = vm_mesh_set_field(surf, 1, "cover_fine", 1, f, err);
    }
    free(f);
    return s;
}

/* The final triangles: the dual (seed indices into seeds; NULL seeds: every fine vertex),
 * appended to surf. Cell field cover_fine: 1 on triangles kept from the fine surface or at
 * its seam (a corner is a forced seed); *nkept counts them. */
static vm_status finish(const vm__cover_fine *m, const double *scale, const int32_t *seeds,
                        const uint8_t *forced,
                        size_t ns, const int32_t *tri, size_t ntri, vm_mesh *surf,
                        size_t *nkept, vm_error *err) {
    double *x = malloc((3 * ns + 1) * sizeof *x);
    uint8_t *kept = malloc(ntri + 1);
    vm_status s = VM_OK;
    if (!x || !kept) s = cover_nomem(err);
    size_t any = 0;
    for (size_t i = 0; !s && i < ns; i++)
        memcpy(x + 3 * i, m->x + 3 * (size_t)(seeds ? seeds[i] : (int32_t)i), 3 * sizeof *x);
    for (size_t k = 0; !s && k < ntri; k++) {
        kept[k] = 0;
        for (int e = 0; e < 3; e++) {
            size_t q = (size_t)tri[3 * k + e];
            if (forced[seeds ? (size_t)seeds[q] : q] == 1) kept[k] = 1;
        }
        any += kept[k];
    }
    *nkept += any;
    if (!s) s = emit(x, ns, scale, tri, ntri, kept, surf, err);
    free(x);
    free(kept);
    return s;
}

/* The last valid dual of a covering: seeds (ns), triangles (3 nt, seed indices), and per
 * fine vertex its label and forced value. */
typedef struct cover_best {
    int32_t *seeds, *tri, *label;
    uint8_t *forced;
    size_t ns, nt;
} cover_best;

/* Sets up c over the fine surface m of g (lengths scaled by scale): R_g, the per-vertex and
 * per-component arrays, and the finest level lmax whose disk holds each 1-ring. */
static vm_status cover_init(cover *c, const vm__cover_fine *m, const vm__surface_grid *g,
                            const vm_surface_options *o, const double scale[3], vm_error *err) {
    memset(c, 0, sizeof *c);
    c->m = m;
    c->eps = o->error;
    double nmax = 0;
    for (int a = 0; a < 3; a++) nmax = fmax(nmax, (double)g->n[a] * scale[a]);
    c->rg = 0.5 * nmax + 1.0; /* R_g: half the volume, the first disk may cover it all */
    size_t nv = m->nv, nc = m->ncomp;
    c->dist = malloc(nv * sizeof *c->dist);
    c->touched = malloc(nv * sizeof *c->touched);
    c->order = malloc(nv * sizeof *c->order);
    c->lmax = malloc(nv);
    c->cap = calloc(nv, 1);
    c->hint = calloc(nv, 1);
    c->lfloor = malloc(nv + 1);
    c->comp_fails = calloc(nc + 1, 1);
    c->nfps = calloc(nc + 1, sizeof *c->nfps);
    c->grow = calloc(nc + 1, 1);
    c->fd = malloc((nv + 1) * sizeof *c->fd);
    c->csize = calloc(nc + 1, sizeof *c->csize);
    c->fps_ok = calloc(nc + 1, sizeof *c->fps_ok);
    c->frozen = calloc(nc + 1, 1);
    c->fps_hi = calloc(nc + 1, sizeof *c->fps_hi);
    c->thin = calloc(nc + 1, 1);
    if (c->csize)
        for (size_t v = 0; v < nv; v++) c->csize[m->comp[v]]++;
    c->forced = calloc(nv, 1);
    c->forb = malloc(nv);
    c->binl = malloc(nv * sizeof *c->binl);
    c->seedlev = malloc(nv * sizeof *c->seedlev);
    c->bcnt = malloc(nv * sizeof *c->bcnt);
    c->fmark = calloc(m->nf, 1);
    c->fqueue = malloc(m->nf * sizeof *c->fqueue);
    c->label = malloc(nv * sizeof *c->label);
    c->seeds = malloc(nv * sizeof *c->seeds);
    c->prev = malloc(nv * sizeof *c->prev);
    c->prevlev = malloc(nv);
    c->bad = malloc(nv);
    if (!c->dist || !c->touched || !c->order || !c->lmax || !c->cap || !c->hint ||
        !c->lfloor || !c->comp_fails || !c->nfps || !c->grow || !c->fd || !c->csize ||
        !c->fps_ok || !c->frozen || !c->fps_hi || !c->thin || !c->forced || !c->forb ||
        !c->binl || !c->seedlev || !c->bcnt || !c->fmark || !c->fqueue || !c->label ||
        !c->seeds || !c->prev || !c->prevlev || !c->bad)
        return vm_error_set(err, VM_ERR_NOMEM, "surface cover: out of memory (%zu vertices)",
                            nv);
    for (size_t v = 0; v < nv; v++) {
        c->dist[v] = INFINITY;
        double emax = 0;
        for (size_t h = m->off[v]; h < m->off[v + 1]; h++)
            if (m->len[h] > emax) emax = m->len[h];
        int l = 0;
        while (l + 1 < LEVELS && radius(c, l + 1) > emax * (1 + LEVEL_MARGIN)) l++;
        c->lmax[v] = c->lfloor[v] = (uint8_t)l;
    }
    return VM_OK;
}

/* Copies c's current (valid) dual into b. */
static vm_status keep_best(const cover *c, cover_best *b, vm_error *err) {
    size_t nv = c->m->nv;
    free(b->seeds);
    free(b->tri);
    b->seeds = malloc((c->nseeds + 1) * sizeof *b->seeds);
    b->tri = malloc((3 * c->ntri + 1) * sizeof *b->tri);
    if (!b->seeds || !b->tri) return cover_nomem(err);
    memcpy(b->seeds, c->seeds, c->nseeds * sizeof *b->seeds);
    memcpy(b->tri, c->tri, 3 * c->ntri * sizeof *b->tri);
    memcpy(b->label, c->label, nv * sizeof *b->label);
    memcpy(b->forced, c->forced, nv);
    b->ns = c->nseeds;
    b->nt = c->ntri;
    return VM_OK;
}

/* After a valid dual (kept in b): refinement, farthest-point coverings grown where too
 * coarse; when nothing changes, flips and the crossing test on b, and *done once no
 * triangle crosses and no covering grows. */
static vm_status after_valid(cover *c, cover_best *b, int *done, vm_error *err) {
    const vm__cover_fine *m = c->m;
    for (size_t k = 0; k < m->ncomp; k++)
        if (c->nfps[k] > 0) c->fps_ok[k] = c->nfps[k];
    refine(c);
    /* a farthest-point covering too coarse for the error or the edge ratio grows */
    for (size_t i = 0; i < c->nseeds; i++)
        if (c->bad[i] && c->forced[c->seeds[i]] == 2) c->grow[m->comp[c->seeds[i]]] = 1;
    for (size_t t = 0; t < c->ntri; t++) {
        int32_t w = c->seeds[c->tri[3 * t]];
        if (c->forced[w] == 2 && edge_ratio(m, c->seeds, c->tri + 3 * t) < ASPECT)
            c->thin[m->comp[w]] = 1, c->grow[m->comp[w]] = 1;
    }
    vm_status s = fps_apply(c, GROW_REFINE, err);
    if (s || c->changed) return s;
    size_t pairs = 0;
    flip_edges(m, b->seeds, b->forced, b->ns, b->tri, b->nt, b->label, c->eps, 0);
    s = untangle(c, b->tri, b->nt, &pairs, err);
    if (s) return s;
    if (pairs > 0) {
        c->untangles++;
        return VM_OK;
    }
    /* after the flips, a triangle still below the paper's 0.3 (its seeds at their floor):
     * its component is covered by farthest points instead */
    for (size_t t = 0; t < b->nt; t++) {
        int32_t w = b->seeds[b->tri[3 * t]];
        if (b->forced[w] != 1 && edge_ratio(m, b->seeds, b->tri + 3 * t) < PAPER_RATIO)
            c->grow[m->comp[w]] = 1, c->thin[m->comp[w]] = 1;
    }
    c->changed = 0;
    s = fps_apply(c, GROW_REFINE, err);
    if (!s && !c->changed) *done = 1;
    return s;
}

/* The next pass starts from these seeds: new disks one level coarser than the
 * neighbourhood they replace, and the unforced seeds as the previous covering. */
static void next_pass_hints(cover *c) {
    for (size_t v = 0; v < c->m->nv; v++) {
        int l = c->seedlev[c->seeds[c->label[v]]];
        c->hint[v] = (uint8_t)(l == FORCED || l < 1 ? 0 : l - 1);
    }
    c->nprev = 0;
    for (size_t i = 0; i < c->nseeds; i++) {
        int32_t w = c->seeds[i];
        if (c->seedlev[w] == FORCED) continue;
        c->prev[c->nprev] = w;
        c->prevlev[c->nprev++] = (uint8_t)c->seedlev[w];
    }
}

/* One pass: covering, Voronoi neighbourhoods, dual; a failed dual is repaired, a valid one
 * kept in b and refined (after_valid). */
static vm_status cover_pass(cover *c, cover_best *b, int *done, vm_error *err) {
    c->changed = 0;
    c->passes++;
    vm_status s = covering(c, err);
    if (!s) s = voronoi(c, err);
    size_t nbad = 0;
    if (!s) s = dual(c, &nbad, err);
    if (s) return s;
    if (nbad > 0) {
        c->repairs++;
        s = repair(c, err);
    } else {
        s = keep_best(c, b, err);
        if (!s) s = after_valid(c, b, done, err);
    }
    if (s) return s;
    next_pass_hints(c);
    return VM_OK;
}

/* No valid covering: the fine surface m itself, which is one, as b (every vertex a forced
 * seed). */
static vm_status fine_as_best(const vm__cover_fine *m, cover_best *b, vm_error *err) {
    size_t nv = m->nv;
    b->seeds = malloc((nv + 1) * sizeof *b->seeds);
    b->tri = malloc((3 * m->nf + 1) * sizeof *b->tri);
    if (!b->seeds || !b->tri) return cover_nomem(err);
    for (size_t v = 0; v < nv; v++) b->seeds[v] = b->label[v] = (int32_t)v;
    memcpy(b->tri, m->f, 3 * m->nf * sizeof *b->tri);
    memset(b->forced, 1, nv);
    b->ns = nv;
    b->nt = m->nf;
    return VM_OK;
}

/* One extraction on the samples of g, lengths measured with index steps scale[a] (in
 * voxels of the smallest original spacing); output points are x / out_scale[a] (the original
 * grid's index coordinates). *kept counts the triangles kept from the fine surface, *nfine
 * the triangles of the fine surface. */
static vm_status cover_once(const vm__surface_grid *g, const vm_surface_options *o,
                            const double scale[3], const double out_scale[3], vm_mesh *surf,
                            vm_surface_stats *st, size_t *kept, size_t *nfine, vm_error *err) {
    vm__cover_fine m;
    vm_status s = vm__cover_fine_build(g, scale, &m, err);
    if (s) return s;
    *nfine = m.nf;
    st->cells_visited += m.cells_visited;
    if (m.nf == 0) {
        vm__cover_fine_free(&m);
        return VM_OK; /* the dispatcher reports the empty material */
    }
    cover c;
    s = cover_init(&c, &m, g, o, scale, err);
    size_t nv = m.nv;
    cover_best b = {0};
    b.label = malloc((nv + 1) * sizeof(int32_t));
    b.forced = malloc(nv + 1);
    if (!s && (!b.label || !b.forced))
        s = cover_nomem(err);
    int done = 0;
    uint8_t *all_forced = NULL;
    for (size_t pass = 0; !s && pass < MAX_PASSES && !done; pass++)
        s = cover_pass(&c, &b, &done, err);
    if (!s && !b.tri) s = fine_as_best(&m, &b, err);
    if (!s) {
        size_t iters = 0;
        s = local_fallback(&c, &b.seeds, b.forced, &b.ns, &b.tri, &b.nt, b.label, &iters, err);
    }
    if (!s) {
        if (b.tri)
            s = finish(&m, out_scale, b.seeds, b.forced, b.ns, b.tri, b.nt, surf, kept, err);
        else if (!(all_forced = malloc(nv + 1)))
            s = cover_nomem(err);
        else { /* no valid covering: the fine surface itself, which is one */
            memset(all_forced, 1, nv);
            s = finish(&m, out_scale, NULL, all_forced, m.nv, m.f, m.nf, surf, kept, err);
        }
    }
    free(b.seeds);
    free(b.tri);
    free(b.label);
    free(b.forced);
    free(all_forced);
    cover_free(&c);
    vm__cover_fine_free(&m);
    return s;
}

/* The improvement pass (surface_cover_improve.c) on surf, the result at sampling k[a] of g
 * with lengths measured by scale[a]: it rebuilds that fine surface (cheap next to the
 * covering) and replaces surf by the improved mesh. Run once, on the returned sampling. */
static vm_status improve_result(const vm__surface_grid *g, const vm_surface_options *o,
                                const double scale[3], const int k[3], vm_mesh *surf,
                                vm_error *err) {
    const vm_field *fl = vm_mesh_find_field(surf, 1, "cover_fine");
    size_t nt = surf->ncells, nv = surf->npoints, any = 0;
    for (size_t t = 0; fl && t < nt; t++) any += fl->data[t] != 0;
    if (!any) return VM_OK;
    vm__surface_grid g2;
    float *buf = NULL;
    vm_status s = vm__cover_supersample(g, k, &g2, &buf, err);
    if (s) return s;
    double sc[3];
    for (int a = 0; a < 3; a++) sc[a] = scale[a] / k[a];
    vm__cover_fine m;
    s = vm__cover_fine_build(&g2, sc, &m, err);
    free(buf);
    if (s) return s;
    double *x = malloc((3 * nv + 1) * sizeof *x);
    int32_t *tri = malloc((3 * nt + 1) * sizeof *tri);
    uint8_t *kept = malloc(nt + 1);
    if (!x || !tri || !kept) s = cover_nomem(err);
    for (size_t v = 0; !s && v < nv; v++)
        for (int a = 0; a < 3; a++) x[3 * v + a] = surf->points[3 * v + a] * scale[a];
    for (size_t t = 0; !s && t < nt; t++) {
        for (int e = 0; e < 3; e++) tri[3 * t + e] = (int32_t)surf->cells[3 * t + e];
        kept[t] = fl->data[t] != 0;
    }
    if (!s) s = vm__cover_improve(&m, o->error, x, &nv, tri, &nt, kept, NULL, err);
    vm_mesh out;
    vm_mesh_init(&out, VM_TRI3);
    if (!s) s = emit(x, nv, scale, tri, nt, kept, &out, err);
    if (!s) {
        vm_mesh_free(surf);
        *surf = out;
    } else {
        vm_mesh_free(&out);
    }
    free(x), free(tri), free(kept);
    vm__cover_fine_free(&m);
    return s;
}

vm_status vm__surface_cover(const vm__surface_grid *g, const vm_surface_options *o,
                            vm_mesh *surf, vm_surface_stats *st, vm_error *err) {
    static const double unit[3] = {1, 1, 1};
    return vm__surface_cover_scaled(g, o, unit, surf, st, err);
}

/* Supersampling (sec. 3.2, 3.9): where the covering cannot make simple disks that hold the
 * 1-rings of their centres, the features are smaller than the candidate graph resolves, and
 * the paper samples the function finer (4-8x). When triangles had to be kept fine, we
 * resample the trilinear interpolant of the samples twice finer along every axis and keep
 * the surface with fewer kept triangles. Bounded work (the time goes as the fine surface):
 * at most MAX_SAMPLES samples, and not when the fine surface would grow past MAX_FINE
 * triangles (the whole heads: with the local fallback their kept part is a few places,
 * and resampling the whole volume for them costs ten times the 1x run, see
 * docs/SURFACE_COVER.md). */
#define MAX_SUPERSAMPLE 2
#define MAX_SAMPLES ((int64_t)4 * 1000 * 1000)
#define MAX_FINE ((size_t)400000)

vm_status vm__surface_cover_scaled(const vm__surface_grid *g, const vm_surface_options *o,
                                   const double scale_in[3], vm_mesh *surf, vm_surface_stats *st,
                                   vm_error *err) {
    double scale[3], smin = INFINITY;
    for (int a = 0; a < 3; a++) {
        if (!(fabs(scale_in[a]) > 0) || !isfinite(scale_in[a]))
            return vm_error_set(err, VM_ERR_ARG, "surface cover: axis %d step %g must be finite and "
                                "non-zero", a, scale_in[a]);
        smin = fmin(smin, fabs(scale_in[a]));
    }
    for (int a = 0; a < 3; a++) scale[a] = fabs(scale_in[a]) / smin;
    vm_mesh best;
    size_t best_kept = SIZE_MAX, fine1 = 0;
    int have = 0;
    vm_status s = VM_OK;
    for (int f = 1; f <= MAX_SUPERSAMPLE && best_kept > 0; f *= 2) {
        int k[3];
        int64_t total = 1;
        for (int a = 0; a < 3; a++) {
            k[a] = f;
            total *= (g->n[a] - 1) * k[a] + 1;
        }
        if (have && (total > MAX_SAMPLES || fine1 * (size_t)(f * f) > MAX_FINE)) break;
        vm__surface_grid g2;
        float *buf = NULL;
        s = vm__cover_supersample(g, k, &g2, &buf, err);
        if (s) break;
        double sc[3];
        for (int a = 0; a < 3; a++) sc[a] = scale[a] / k[a];
        vm_mesh m;
        vm_mesh_init(&m, VM_TRI3);
        size_t kept = 0, nfine = 0;
        s = cover_once(&g2, o, sc, scale, &m, st, &kept, &nfine, err);
        if (f == 1) fine1 = nfine;
        free(buf);
        if (s) {
            vm_mesh_free(&m);
            break;
        }
        if (!have || kept < best_kept) {
            if (have) vm_mesh_free(&best);
            best = m;
            best_kept = kept;
            have = 1;
            for (int a = 0; a < 3; a++) st->supersample[a] = k[a];
        } else {
            vm_mesh_free(&m);
        }
    }
    if (!s && have && o->improve) s = improve_result(g, o, scale, st->supersample, &best, err);
    if (s) {
        if (have) vm_mesh_free(&best);
        return s;
    }
    vm_mesh_free(surf);
    *surf = best;
    return VM_OK;
}
