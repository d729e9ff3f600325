/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/mesh_check.c — whole-mesh invariants: inverted cells, face conformity, boundary
 * closedness and manifoldness, Euler characteristic, components, volume and element quality.
 * Faces are matched within buckets of their smallest node (a counting sort), and boundary
 * edges within buckets of their lower node; connectivity uses a union-find that the threads
 * share. Everything is O(n), and on the threads with the same report for any count. */
#include "../core/core.h"
#include "volmesh/quality.h"
#include "../core/self_intersect.h"
#include "tet_internal.h"
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* A cell is degenerate when its volume (area for surfaces) is at most this fraction of the
 * mean (relative, so in any unit): far below any real element, well above rounding (1e-16). */
#define DEGENERATE_FRACTION 1e-12

/* Faces of each volume kind, ordered so that normals point out of a positive cell. */
static const int tet_faces[4][4] = {{1, 2, 3, 0}, {0, 3, 2, 0}, {0, 1, 3, 0}, {0, 2, 1, 0}};
static const int hex_faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

typedef struct faceset {
    const vm_index *cells; /* cell nodes */
    int nn;                /* nodes per cell */
    int nf;                /* faces per cell */
    int k;                 /* nodes per face */
    const int (*faces)[4]; /* local face table */
    size_t npoints;        /* node indices are below this */
} faceset;

/* The k nodes of face instance inst (cell inst / nf, local face inst % nf). */
static void face_nodes(const faceset *fs, uint64_t inst, int64_t out[4]) {
    uint64_t c = inst / (uint64_t)fs->nf;
    int lf = (int)(inst % (uint64_t)fs->nf);
    const vm_index *cn = fs->cells + (size_t)c * (size_t)fs->nn;
    for (int i = 0; i < fs->k; i++)
        out[i] = cn[fs->faces[lf][i]];
}

/* Sorts a[0..n) ascending (insertion sort: n is at most 4). */
static void sort_small(int64_t *a, int n) {
    for (int i = 1; i < n; i++) {
        int64_t v = a[i];
        int j = i - 1;
        while (j >= 0 && a[j] > v) {
            a[j + 1] = a[j];
            j--;
        }
        a[j + 1] = v;
    }
}

/* --- checked allocation ------------------------------------------------------------------ */

/* n elements of elem bytes (zeroed or not), or NULL with *st set when too large or out of
 * memory; what names the array in the message. */
static void *alloc_array(size_t n, size_t elem, int zeroed, const char *what, vm_status *st,
                         vm_error *err) {
    size_t bytes;
    if (vm__mul_overflows(n, elem, &bytes) || bytes > vm__memory_limit()) {
        *st = vm_error_set(err, VM_ERR_NOMEM, "mesh check: %s of %zu entries is too large",
                           what, n);
        return NULL;
    }
    /* calloc: large zeroed blocks come straight from the kernel without a memset pass. */
    void *p = zeroed ? calloc(bytes ? bytes : 1, 1) : malloc(bytes ? bytes : 1);
    if (!p) *st = vm_error_set(err, VM_ERR_NOMEM, "mesh check: out of memory for %s", what);
    return p;
}

/* --- a union-find that threads share ---------------------------------------------------- */

/* Roots are linked larger index under smaller, by compare-and-swap, and finds halve their
 * paths with compare-and-swap too: any order of the same unions gives the same sets, so the
 * count of roots (the components) is the same for any thread count, though the parents may
 * differ. (The lock-free union-find of Anderson and Woll, STOC 1991, with index order for
 * rank.) */
static size_t shared_find(size_t *parent, size_t x) {
    for (;;) {
        size_t p = __atomic_load_n(&parent[x], __ATOMIC_RELAXED);
        if (p == x) return x;
        size_t g = __atomic_load_n(&parent[p], __ATOMIC_RELAXED);
        if (g != p)
            __atomic_compare_exchange_n(&parent[x], &p, g, 0, __ATOMIC_RELAXED,
                                        __ATOMIC_RELAXED);
        x = g;
    }
}

static void shared_union(size_t *parent, size_t a, size_t b) {
    for (;;) {
        a = shared_find(parent, a);
        b = shared_find(parent, b);
        if (a == b) return;
        size_t hi = a > b ? a : b, lo = a > b ? b : a;
        if (__atomic_compare_exchange_n(&parent[hi], &hi, lo, 0, __ATOMIC_RELAXED,
                                        __ATOMIC_RELAXED))
            return;
    }
}

/* The number of roots among parent[0..n). */
static size_t shared_roots(size_t *parent, size_t n) {
    size_t roots = 0;
    const ptrdiff_t nn = (ptrdiff_t)n;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : roots)
#endif
    for (ptrdiff_t i = 0; i < nn; i++)
        if (shared_find(parent, (size_t)i) == (size_t)i) roots++;
    return roots;
}

/* --- cell faces: which are shared, which are on the boundary ----------------------------- */

/* One face instance of a bucket: the nodes other than the smallest, sorted, and the
 * instance number (cell * faces per cell + local face). */
typedef struct bucket_face {
    int64_t key[3];
    uint64_t inst;
} bucket_face;

/* 1 when a comes before b: by the n keys, then by instance. */
static int bucket_less(const bucket_face *a, const bucket_face *b, int n) {
    for (int i = 0; i < n; i++)
        if (a->key[i] != b->key[i]) return a->key[i] < b->key[i];
    return a->inst < b->inst;
}

/* Stable order by key then instance: insertion sort (buckets hold a dozen faces or so). */
static void sort_bucket(bucket_face *f, size_t n, int nk) {
    for (size_t i = 1; i < n; i++) {
        bucket_face v = f[i];
        size_t j = i;
        while (j > 0 && bucket_less(&v, &f[j - 1], nk)) {
            f[j] = f[j - 1];
            j--;
        }
        f[j] = v;
    }
}

/* The smallest node of face instance inst: the bucket it is matched in. */
static int64_t face_low(const faceset *fs, uint64_t inst) {
    int64_t key[4] = {0, 0, 0, 0}; /* fs->k of them are set */
    face_nodes(fs, inst, key);
    int64_t lo = key[0];
    for (int j = 1; j < fs->k; j++)
        if (key[j] < lo) lo = key[j];
    return lo;
}

/* The face instances in bucket order: 32 bits each while they fit (half the memory of the
 * check's largest array), else 64. One of the two pointers is set. */
typedef struct inst_list {
    uint32_t *n32;
    uint64_t *n64;
} inst_list;

static uint64_t inst_get(const inst_list *o, size_t i) {
    return o->n32 ? o->n32[i] : o->n64[i];
}

static void inst_set(const inst_list *o, size_t i, uint64_t v) {
    if (o->n32)
        o->n32[i] = (uint32_t)v;
    else
        o->n64[i] = v;
}

/* Sorts bucket ord[first..first+b) by the faces' other nodes (tbf: b entries of scratch),
 * writes it back in that order and marks each instance: bit 0 a boundary face (counted in
 * *n), bit 1 the same face as the one before it; *over counts faces of more than two
 * instances. */
static void match_bucket(const faceset *fs, const inst_list *ord, size_t first, size_t b,
                         bucket_face *tbf, unsigned char *mark, size_t *n, size_t *over) {
    int k = fs->k;
    for (size_t q = 0; q < b; q++) {
        int64_t key[4];
        uint64_t inst = inst_get(ord, first + q);
        face_nodes(fs, inst, key);
        sort_small(key, k);
        memcpy(tbf[q].key, key + 1, (size_t)(k - 1) * sizeof key[0]);
        tbf[q].inst = inst;
    }
    sort_bucket(tbf, b, k - 1);
    for (size_t q = 0; q < b;) {
        size_t e = q + 1;
        while (e < b && memcmp(tbf[e].key, tbf[q].key, (size_t)(k - 1) * sizeof(int64_t)) == 0)
            e++;
        if (e - q == 1) {
            mark[tbf[q].inst] = 1;
            (*n)++;
        } else if (e - q > 2) {
            (*over)++;
        }
        for (size_t r = q + 1; r < e; r++)
            mark[tbf[r].inst] = 2;
        q = e;
    }
    for (size_t q = 0; q < b; q++)
        inst_set(ord, first + q, tbf[q].inst);
}

/* Matches the buckets of every node (start: np + 1 offsets into order), in slabs of nodes
 * whose buckets run on threads (each bucket on its own, so the result does not depend on
 * the threads). *n counts boundary faces, *over faces of more than two cells. Returns
 * VM_ERR_NOMEM when a thread's scratch could not be allocated, else VM_OK. */
static vm_status match_buckets(const faceset *fs, const size_t *start, const inst_list *order,
                               unsigned char *mark, size_t *nb, size_t *nover, vm__meter *mt,
                               double share) {
    size_t np = fs->npoints, n = 0, over = 0;
    int failed = 0;
    const size_t nslab = 16;
    for (size_t sl = 0; sl < nslab && !failed; sl++) {
        const ptrdiff_t v0 = (ptrdiff_t)(np * sl / nslab), v1 = (ptrdiff_t)(np * (sl + 1) / nslab);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel reduction(+ : n, over)
#endif
        {
            size_t tcap = 64;
            bucket_face *tbf = malloc(tcap * sizeof *tbf);
            int lost = tbf == NULL; /* this thread's scratch could not be allocated */
#ifdef VM_HAVE_OPENMP
#pragma omp for schedule(dynamic, 1024)
#endif
            for (ptrdiff_t vv = v0; vv < v1; vv++) {
                size_t v = (size_t)vv, b = start[v + 1] - start[v];
                if (b == 0 || lost) continue;
                if (b > tcap) {
                    free(tbf);
                    tcap = b;
                    tbf = malloc(tcap * sizeof *tbf);
                    if (!tbf) {
                        lost = 1;
                        continue;
                    }
                }
                match_bucket(fs, order, start[v], b, tbf, mark, &n, &over);
            }
            free(tbf);
            if (lost) {
#ifdef VM_HAVE_OPENMP
#pragma omp atomic write
#endif
                failed = 1;
            }
        }
        if (mt) vm__meter_add(mt, share / 3.0 / (double)nslab);
    }
    *nb = n;
    *nover = over;
    return failed ? VM_ERR_NOMEM : VM_OK;
}

/* The instances marked boundary (bit 0 of mark[0..ninst)) into list, in instance order:
 * counted by fixed chunks on the threads, then each chunk written from its offset. */
static void boundary_list(const unsigned char *mark, size_t ninst, uint64_t *list) {
    enum { CHUNKS = 256 };
    size_t at[CHUNKS + 1];
    at[0] = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int k = 0; k < CHUNKS; k++) {
        size_t c = 0;
        for (size_t i = ninst * (size_t)k / CHUNKS; i < ninst * (size_t)(k + 1) / CHUNKS; i++)
            c += mark[i] & 1;
        at[k + 1] = c;
    }
    for (int k = 0; k < CHUNKS; k++) at[k + 1] += at[k];
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int k = 0; k < CHUNKS; k++) {
        size_t j = at[k];
        for (size_t i = ninst * (size_t)k / CHUNKS; i < ninst * (size_t)(k + 1) / CHUNKS; i++)
            if (mark[i] & 1) list[j++] = i;
    }
}

/* Matches all cell faces. Faces are grouped by their smallest node (a counting sort over
 * the points, so memory is read nearly in order) and matched within each group by their
 * other nodes. [out] *binst (malloc'd) lists the boundary face instances in cell order;
 * *overshared counts faces used by more than two cells; when parent != NULL, cells sharing
 * a face are united in it. */
static vm_status match_faces(const faceset *fs, size_t ncells, size_t *parent,
                             size_t *overshared, uint64_t **binst, size_t *nb, vm__meter *mt,
                             double share, vm_error *err) {
    vm_status st = VM_OK;
    *binst = NULL;
    *nb = 0;
    *overshared = 0;
    size_t ninst;
    if (vm__mul_overflows(ncells, (size_t)fs->nf, &ninst))
        return vm_error_set(err, VM_ERR_NOMEM, "mesh check: %zu cells overflow", ncells);
    size_t np = fs->npoints;
    size_t *start = alloc_array(np + 1, sizeof *start, 1, "face buckets", &st, err);
    if (!start) return st;
    /* The buckets are counted and filled on the threads with atomic counters: a bucket's
     * instances arrive in any order, but match_bucket sorts them by nodes then instance, so
     * what follows does not depend on it. */
    const ptrdiff_t ni = (ptrdiff_t)ninst;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t i = 0; i < ni; i++) {
        size_t *slot = &start[face_low(fs, (uint64_t)i) + 1];
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
        (*slot)++;
    }
    for (size_t v = 0; v < np; v++) start[v + 1] += start[v];
    if (mt) vm__meter_add(mt, share / 3.0);
    inst_list order = {NULL, NULL};
    if (ninst <= UINT32_MAX)
        order.n32 = alloc_array(ninst, sizeof *order.n32, 0, "face order", &st, err);
    else
        order.n64 = alloc_array(ninst, sizeof *order.n64, 0, "face order", &st, err);
    size_t *fill = alloc_array(np, sizeof *fill, 0, "face buckets", &st, err);
    unsigned char *mark = alloc_array(ninst, 1, 1, "face marks", &st, err);
    if ((!order.n32 && !order.n64) || !fill || !mark) goto done;
    memcpy(fill, start, np * sizeof *fill);
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t i = 0; i < ni; i++) {
        size_t *slot = &fill[face_low(fs, (uint64_t)i)], at;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic capture
#endif
        at = (*slot)++;
        inst_set(&order, at, (uint64_t)i);
    }
    free(fill);
    fill = NULL;
    if (mt) vm__meter_add(mt, share / 3.0);
    /* a bucket's instances go back into order sorted, marked (match_bucket); the cells are
     * united afterwards in one pass in order */
    size_t n = 0;
    if (match_buckets(fs, start, &order, mark, &n, overshared, mt, share)) {
        st = vm_error_set(err, VM_ERR_NOMEM, "mesh check: out of memory for a face bucket");
        goto done;
    }
    if (parent) {
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
        for (ptrdiff_t i = 1; i < ni; i++)
            if (mark[inst_get(&order, (size_t)i)] & 2)
                shared_union(parent, (size_t)(inst_get(&order, (size_t)i) / (uint64_t)fs->nf),
                             (size_t)(inst_get(&order, (size_t)i - 1) / (uint64_t)fs->nf));
    }
    uint64_t *list = alloc_array(n, sizeof *list, 0, "boundary faces", &st, err);
    if (!list) goto done;
    boundary_list(mark, ninst, list);
    *binst = list;
    *nb = n;
done:
    free(start);
    free(order.n32);
    free(order.n64);
    free(fill);
    free(mark);
    return st;
}

/* --- surface analysis -------------------------------------------------------------------- */

/* Node a of edge instance i of faces (k nodes each) and node b, the next one around the
 * face. */
static void edge_ends(const vm_index *faces, int k, size_t i, int64_t *a, int64_t *b) {
    size_t f = i / (size_t)k, j = i % (size_t)k;
    *a = faces[i];
    *b = faces[f * (size_t)k + (j + 1) % (size_t)k];
}

/* The higher node of edge instance i (its bucket is the lower one). */
static int64_t edge_other(const vm_index *faces, int k, size_t i) {
    int64_t a, b;
    edge_ends(faces, k, i, &a, &b);
    return a > b ? a : b;
}

/* An edge instance and its higher node, for sorting a large bucket. */
typedef struct edge_key {
    int64_t other;
    size_t inst;
} edge_key;

static int edge_key_cmp(const void *pa, const void *pb) {
    const edge_key *a = pa, *b = pb;
    if (a->other != b->other) return a->other < b->other ? -1 : 1;
    return a->inst < b->inst ? -1 : a->inst > b->inst;
}

/* A bucket with more instances than this is sorted by qsort. */
#define EDGE_INSERTION_MAX 32

/* Sorts the n edge instances e[] of one bucket by their higher node, then by instance:
 * the instances of one edge then stand together, in instance order. */
static void sort_edge_bucket(const vm_index *faces, int k, size_t *e, size_t n) {
    edge_key *t = n > EDGE_INSERTION_MAX ? malloc(n * sizeof *t) : NULL;
    if (t) {
        for (size_t q = 0; q < n; q++)
            t[q] = (edge_key){edge_other(faces, k, e[q]), e[q]};
        qsort(t, n, sizeof *t, edge_key_cmp);
        for (size_t q = 0; q < n; q++)
            e[q] = t[q].inst;
        free(t);
        return;
    }
    for (size_t q = 1; q < n; q++) { /* few (a vertex's edges), or no memory for the keys */
        size_t x = e[q], j = q;
        int64_t ox = edge_other(faces, k, x);
        for (; j > 0; j--) {
            int64_t oy = edge_other(faces, k, e[j - 1]);
            if (oy < ox || (oy == ox && e[j - 1] < x)) break;
            e[j] = e[j - 1];
        }
        e[j] = x;
    }
}

/* The edges of one bucket (its instances e[0..n), sorted): each counted, an open or
 * non-manifold one flagged at both ends (vflag bit 2) and counted in r's two figures (the
 * caller's *open and *nonmanifold), the faces of its instances united in fparent and, at a
 * manifold edge, the corners of its two faces at each end united in cparent, into one fan.
 * Returns the number of edges. */
static size_t bucket_edges(const vm_index *faces, int k, const size_t *e, size_t n,
                           size_t *fparent, size_t *cparent, unsigned char *vflag, size_t *open,
                           size_t *nonmanifold) {
    size_t nedges = 0;
    for (size_t q0 = 0, q1; q0 < n; q0 = q1) {
        int64_t other = edge_other(faces, k, e[q0]);
        q1 = q0 + 1;
        while (q1 < n && edge_other(faces, k, e[q1]) == other)
            q1++;
        nedges++;
        size_t i1 = e[q0], f1 = i1 / (size_t)k, j1 = i1 % (size_t)k;
        for (size_t q = q0 + 1; q < q1; q++)
            shared_union(fparent, f1, e[q] / (size_t)k);
        size_t i1n = f1 * (size_t)k + (j1 + 1) % (size_t)k;
        int64_t a = faces[i1], b = faces[i1n];
        if (q1 - q0 != 2) {
            if (q1 - q0 == 1)
                (*open)++;
            else
                (*nonmanifold)++;
            __atomic_fetch_or(&vflag[a], 2, __ATOMIC_RELAXED);
            __atomic_fetch_or(&vflag[b], 2, __ATOMIC_RELAXED);
            continue;
        }
        /* Two faces meet here: join their corners at each end of the edge into one fan. */
        size_t i2 = e[q0 + 1], f2 = i2 / (size_t)k, j2 = i2 % (size_t)k;
        size_t i2n = f2 * (size_t)k + (j2 + 1) % (size_t)k;
        if (faces[i2] == a) {
            shared_union(cparent, i1, i2);
            shared_union(cparent, i1n, i2n);
        } else {
            shared_union(cparent, i1, i2n);
            shared_union(cparent, i1n, i2);
        }
    }
    return nedges;
}

/* Analyses a surface of nf faces with k nodes each (faces[f*k + j]): closedness, manifold
 * edges and vertices, Euler characteristic and edge-connected components. On the threads:
 * the edge instances are binned by their lower node (a counting sort, each bin then sorted,
 * so the bins are the same for any thread count), the bins' edges counted and their faces
 * and corners united in shared union-finds, whose sets, and so every figure, do not depend
 * on the order of the unions. */
static vm_status analyse_surface(const vm_index *faces, size_t nf, int k, size_t npoints,
                                 vm_mesh_report *r, vm_error *err) {
    vm_status st = VM_OK;
    size_t ninst;
    if (vm__mul_overflows(nf, (size_t)k, &ninst) || npoints == SIZE_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh check: %zu faces overflow", nf);
    size_t *start = NULL, *ent = NULL, *fparent = NULL, *cparent = NULL, *first_root = NULL;
    unsigned char *vflag = NULL; /* bit 1: used, bit 2: bad */
    if (!(start = alloc_array(npoints + 1, sizeof *start, 1, "edge buckets", &st, err)))
        goto done;
    if (!(ent = alloc_array(ninst, sizeof *ent, 0, "edge order", &st, err))) goto done;
    if (!(fparent = alloc_array(nf, sizeof *fparent, 0, "face components", &st, err)))
        goto done;
    if (!(cparent = alloc_array(ninst, sizeof *cparent, 0, "face corners", &st, err)))
        goto done;
    if (!(first_root = alloc_array(npoints, sizeof *first_root, 0, "vertex fans", &st, err)))
        goto done;
    if (!(vflag = alloc_array(npoints, 1, 1, "vertex flags", &st, err))) goto done;
    const ptrdiff_t pf = (ptrdiff_t)nf, pi = (ptrdiff_t)ninst, pv = (ptrdiff_t)npoints;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel
#endif
    {
#ifdef VM_HAVE_OPENMP
#pragma omp for schedule(static) nowait
#endif
        for (ptrdiff_t f = 0; f < pf; f++)
            fparent[f] = (size_t)f;
#ifdef VM_HAVE_OPENMP
#pragma omp for schedule(static) nowait
#endif
        for (ptrdiff_t v = 0; v < pv; v++)
            first_root[v] = SIZE_MAX;
#ifdef VM_HAVE_OPENMP
#pragma omp for schedule(static)
#endif
        for (ptrdiff_t c = 0; c < pi; c++) {
            cparent[c] = (size_t)c;
            int64_t a, b;
            edge_ends(faces, k, (size_t)c, &a, &b);
            __atomic_fetch_or(&vflag[a], 1, __ATOMIC_RELAXED);
#ifdef VM_HAVE_OPENMP
#pragma omp atomic
#endif
            start[(a < b ? a : b) + 1]++;
        }
    }
    for (size_t v = 0; v < npoints; v++)
        start[v + 1] += start[v];
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t c = 0; c < pi; c++) { /* start[v] runs ahead while filling */
        int64_t a, b;
        edge_ends(faces, k, (size_t)c, &a, &b);
        size_t at;
#ifdef VM_HAVE_OPENMP
#pragma omp atomic capture
#endif
        at = start[a < b ? a : b]++;
        ent[at] = (size_t)c;
    }
    for (size_t v = npoints; v > 0; v--) /* shift back: start[v] is the bucket's first */
        start[v] = start[v - 1];
    start[0] = 0;
    size_t nedges = 0, open = 0, nonmanifold = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1024) reduction(+ : nedges, open, nonmanifold)
#endif
    for (ptrdiff_t v = 0; v < pv; v++) {
        size_t *e = ent + start[v], n = start[v + 1] - start[v];
        if (!n) continue;
        sort_edge_bucket(faces, k, e, n);
        nedges += bucket_edges(faces, k, e, n, fparent, cparent, vflag, &open, &nonmanifold);
    }
    r->boundary_open_edges += open;
    r->boundary_nonmanifold_edges += nonmanifold;
    /* A vertex is manifold when all its corners form one fan and none of its edges is open
     * or non-manifold (a fan that closes into a single cycle). A set's root is its smallest
     * corner, whichever thread finds it. */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t c = 0; c < pi; c++) {
        size_t v = (size_t)faces[c], root = shared_find(cparent, (size_t)c), none = SIZE_MAX;
        if (!__atomic_compare_exchange_n(&first_root[v], &none, root, 0, __ATOMIC_RELAXED,
                                         __ATOMIC_RELAXED) &&
            none != root)
            __atomic_fetch_or(&vflag[v], 2, __ATOMIC_RELAXED);
    }
    size_t nverts = 0, badv = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : nverts, badv)
#endif
    for (ptrdiff_t v = 0; v < pv; v++) {
        if (!(vflag[v] & 1)) continue;
        nverts++;
        if (vflag[v] & 2) badv++;
    }
    r->boundary_nonmanifold_vertices += badv;
    r->boundary_components = shared_roots(fparent, nf);
    r->boundary_closed = r->boundary_open_edges == 0 && r->boundary_nonmanifold_edges == 0;
    r->boundary_euler = (long)nverts - (long)nedges + (long)nf;
done:
    free(start);
    free(ent);
    free(fparent);
    free(cparent);
    free(first_root);
    free(vflag);
    return st;
}

/* --- the checks -------------------------------------------------------------------------- */

/* The nn corner points of cell c. */
static void cell_points(const vm_mesh *m, size_t c, int nn, double p[8][3]) {
    const vm_index *cn = m->cells + c * (size_t)nn;
    for (int i = 0; i < nn; i++)
        memcpy(p[i], m->points + 3 * (size_t)cn[i], sizeof p[i]);
}

/* The face table of volume mesh m (tets or hexes). */
static faceset faceset_of(const vm_mesh *m) {
    faceset fs;
    fs.cells = m->cells;
    fs.nn = vm_cell_nodes(m->kind);
    fs.npoints = m->npoints;
    if (m->kind == VM_TET4) {
        fs.nf = 4;
        fs.k = 3;
        fs.faces = tet_faces;
    } else {
        fs.nf = 6;
        fs.k = 4;
        fs.faces = hex_faces;
    }
    return fs;
}

/* Per-cell metrics of a volume mesh. */
static vm_status cell_metrics(const vm_mesh *m, vm_mesh_report *r, vm__meter *mt, double share,
                              vm_error *err) {
    vm_status st = VM_OK;
    double *vol = alloc_array(m->ncells, sizeof *vol, 0, "cell volumes", &st, err);
    if (!vol) return st;
    int nn = vm_cell_nodes(m->kind), tets = m->kind == VM_TET4;
    double sum_abs = 0.0, sj_min = 1.0, dmin = 180.0, dmax = 0.0;
    size_t s5 = 0, s10 = 0, inv = 0, below = 0;
    /* Cells in parallel; min, max and counts do not depend on the order, and the volumes are
     * summed afterwards in cell order, so the report is the same for any thread count. */
    const ptrdiff_t nc = (ptrdiff_t)m->ncells, block = (ptrdiff_t)1 << 18;
    for (ptrdiff_t c0 = 0; c0 < nc; c0 += block) {
        const ptrdiff_t c1 = nc - c0 < block ? nc : c0 + block;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(min : sj_min, dmin) \
        reduction(max : dmax) reduction(+ : s5, s10, inv, below)
#endif
        for (ptrdiff_t c = c0; c < c1; c++) {
            double p[8][3];
            cell_points(m, (size_t)c, nn, p);
            double v, sj;
            if (tets) {
                v = vm_tet_signed_volume((const double(*)[3])p);
                sj = vm_tet_scaled_jacobian((const double(*)[3])p);
                double lo, hi;
                vm__tet_dihedral_range((const double(*)[3])p, &lo, &hi);
                if (lo < dmin) dmin = lo;
                if (hi > dmax) dmax = hi;
                if (lo < 5.0) s5++;
                if (lo < 10.0) s10++;
                if (v <= 0.0) inv++;
            } else {
                v = vm_hex_volume((const double(*)[3])p);
                /* corners, centre and Gauss points: the measure every hex figure uses */
                sj = vm_hex_scaled_jacobian((const double(*)[3])p);
                if (sj <= 0.0) inv++;
                if (sj < VM_HEX_TARGET_SJ) below++;
            }
            if (sj < sj_min) sj_min = sj;
            vol[c] = v;
        }
        vm__meter_add(mt, share * (double)(c1 - c0) / (double)nc);
    }
    r->slivers_5 += s5;
    r->slivers_10 += s10;
    r->inverted += inv;
    r->below_target += below;
    for (size_t c = 0; c < m->ncells; c++) {
        r->volume += vol[c];
        sum_abs += fabs(vol[c]);
    }
    double floor = m->ncells ? DEGENERATE_FRACTION * sum_abs / (double)m->ncells : 0.0;
    size_t degenerate = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : degenerate)
#endif
    for (ptrdiff_t c = 0; c < nc; c++)
        if (fabs(vol[c]) <= floor) degenerate++;
    r->degenerate += degenerate;
    free(vol);
    if (m->ncells) {
        r->min_scaled_jacobian = sj_min;
        if (m->kind == VM_TET4) {
            r->min_dihedral = dmin;
            r->max_dihedral = dmax;
        }
    }
    return VM_OK;
}

/* Shares of the check's progress bar, measured on a 7 M-tet mesh. */
#define SHARE_METRICS 0.35
#define SHARE_FACES 0.45

static vm_status check_volume_mesh(const vm_mesh *m, vm_mesh_report *r, vm__meter *mt,
                                   vm_error *err) {
    vm_status st = cell_metrics(m, r, mt, SHARE_METRICS, err);
    if (!st && vm__meter_poll(mt)) st = vm__cancelled(err, "mesh check");
    if (st) return st;
    faceset fs = faceset_of(m);
    size_t *parent = alloc_array(m->ncells, sizeof *parent, 0, "cell components", &st, err);
    if (!parent) return st;
    const ptrdiff_t nc = (ptrdiff_t)m->ncells;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t c = 0; c < nc; c++)
        parent[c] = (size_t)c;
    uint64_t *binst = NULL;
    size_t nb = 0;
    st = match_faces(&fs, m->ncells, parent, &r->overshared_faces, &binst, &nb, mt,
                     SHARE_FACES, err);
    if (!st && vm__meter_poll(mt)) st = vm__cancelled(err, "mesh check");
    if (st) {
        free(binst);
        free(parent);
        return st;
    }
    r->components = shared_roots(parent, m->ncells);
    free(parent);
    r->boundary_faces = nb;
    size_t nidx;
    vm_index *bf = NULL;
    if (vm__mul_overflows(nb, (size_t)fs.k, &nidx) ||
        !(bf = alloc_array(nidx, sizeof *bf, 0, "boundary faces", &st, err))) {
        free(binst);
        return st ? st : vm_error_set(err, VM_ERR_NOMEM, "mesh check: boundary overflows");
    }
    const ptrdiff_t nbf = (ptrdiff_t)nb;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (ptrdiff_t i = 0; i < nbf; i++) {
        int64_t fn[4];
        face_nodes(&fs, binst[i], fn);
        for (int j = 0; j < fs.k; j++)
            bf[(size_t)i * (size_t)fs.k + (size_t)j] = (vm_index)fn[j];
    }
    free(binst);
    st = analyse_surface(bf, nb, fs.k, m->npoints, r, err);
    if (vm__meter_add(mt, 0.5 * (1.0 - SHARE_METRICS - SHARE_FACES)) && !st)
        st = vm__cancelled(err, "mesh check");
    if (!st && fs.k == 3)
        st = vm__self_intersections(m->points, bf, nb, &r->boundary_self_intersections, NULL,
                                    err);
    free(bf);
    return st;
}

static vm_status check_surface_mesh(const vm_mesh *m, vm_mesh_report *r, vm_error *err) {
    int k = vm_cell_nodes(m->kind);
    const double *o = m->npoints ? m->points : NULL;
    double sum_area = 0.0;
    vm_status st = VM_OK;
    double *area = alloc_array(m->ncells, sizeof *area, 0, "face areas", &st, err);
    if (!area) return st;
    for (size_t c = 0; c < m->ncells; c++) {
        double q[4][3], ctr[3] = {0, 0, 0};
        for (int i = 0; i < k; i++) {
            const double *p = m->points + 3 * (size_t)m->cells[c * (size_t)k + (size_t)i];
            for (int d = 0; d < 3; d++) {
                q[i][d] = p[d] - o[d];
                ctr[d] += q[i][d] / k;
            }
        }
        /* Fan around the vertex average: exact for triangles and bilinear quads. */
        double vsum = 0.0, an[3] = {0, 0, 0};
        for (int i = 0; i < k; i++) {
            const double *a = q[i], *b = q[(i + 1) % k];
            double ea[3] = {a[0] - ctr[0], a[1] - ctr[1], a[2] - ctr[2]};
            double eb[3] = {b[0] - ctr[0], b[1] - ctr[1], b[2] - ctr[2]};
            double x[3] = {ea[1] * eb[2] - ea[2] * eb[1], ea[2] * eb[0] - ea[0] * eb[2],
                           ea[0] * eb[1] - ea[1] * eb[0]};
            for (int d = 0; d < 3; d++)
                an[d] += 0.5 * x[d];
            vsum += ctr[0] * (a[1] * b[2] - a[2] * b[1]) +
                    ctr[1] * (a[2] * b[0] - a[0] * b[2]) + ctr[2] * (a[0] * b[1] - a[1] * b[0]);
        }
        r->volume += vsum / 6.0;
        area[c] = sqrt(an[0] * an[0] + an[1] * an[1] + an[2] * an[2]);
        sum_area += area[c];
    }
    double floor = m->ncells ? DEGENERATE_FRACTION * sum_area / (double)m->ncells : 0.0;
    for (size_t c = 0; c < m->ncells; c++)
        if (area[c] <= floor) r->degenerate++;
    free(area);
    if (!isfinite(r->volume)) r->volume = 0.0;
    r->boundary_faces = m->ncells;
    st = analyse_surface(m->cells, m->ncells, k, m->npoints, r, err);
    if (!st && k == 3)
        st = vm__self_intersections(m->points, m->cells, m->ncells,
                                    &r->boundary_self_intersections, NULL, err);
    r->components = r->boundary_components;
    return st;
}

vm_status vm_mesh_check(const vm_mesh *m, vm_mesh_report *r, vm_error *err) {
    return vm_mesh_check_with(m, NULL, NULL, r, err);
}

vm_status vm_mesh_check_with(const vm_mesh *m, vm_progress_fn progress, void *user,
                             vm_mesh_report *r, vm_error *err) {
    memset(r, 0, sizeof *r);
    r->cells = m->ncells;
    r->points = m->npoints;
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "mesh check: unknown cell kind %d",
                            (int)m->kind);
    vm_status st = vm__check_nodes(m, VM_ERR_ARG, "mesh check", err);
    if (st) return st;
    vm__meter mt;
    vm__meter_start(&mt, progress, user, "check", 1.0);
    if (m->kind == VM_TET4 || m->kind == VM_HEX8)
        st = check_volume_mesh(m, r, &mt, err);
    else
        st = check_surface_mesh(m, r, err);
    if (!st) vm__meter_end(&mt);
    /* (a request at a call no check followed, the last one included) */
    if (!st && vm__meter_stopped(&mt)) st = vm__cancelled(err, "mesh check");
    return st;
}

vm_status vm_mesh_boundary(const vm_mesh *m, vm_mesh *surf, vm_error *err) {
    vm_mesh_init(surf, m->kind == VM_HEX8 ? VM_QUAD4 : VM_TRI3);
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "mesh boundary: needs a tet4 or hex8 mesh, not %s",
                            vm_cell_kind_name(m->kind));
    vm_status st = vm__check_nodes(m, VM_ERR_ARG, "mesh boundary", err);
    if (st) return st;
    faceset fs = faceset_of(m);
    uint64_t *binst = NULL;
    size_t nb = 0, dummy = 0;
    st = match_faces(&fs, m->ncells, NULL, &dummy, &binst, &nb, NULL, 0.0, err);
    if (st) return st;
    vm_index *map = alloc_array(m->npoints, sizeof *map, 0, "point map", &st, err);
    if (!map) {
        free(binst);
        return st;
    }
    for (size_t v = 0; v < m->npoints; v++)
        map[v] = -1;
    for (size_t i = 0; i < nb; i++) {
        int64_t fn[4];
        face_nodes(&fs, binst[i], fn);
        for (int j = 0; j < fs.k; j++)
            map[fn[j]] = 0;
    }
    /* Kept points are numbered in their original order. */
    size_t np = 0;
    for (size_t v = 0; v < m->npoints; v++)
        if (map[v] == 0) map[v] = (vm_index)np++;
    st = vm_mesh_reserve(surf, np, nb, err);
    if (st) goto fail;
    for (size_t v = 0; v < m->npoints; v++)
        if (map[v] >= 0)
            memcpy(surf->points + 3 * (size_t)map[v], m->points + 3 * v, 3 * sizeof(double));
    surf->npoints = np;
    for (size_t i = 0; i < nb; i++) {
        int64_t fn[4];
        face_nodes(&fs, binst[i], fn);
        for (int j = 0; j < fs.k; j++)
            surf->cells[i * (size_t)fs.k + (size_t)j] = map[fn[j]];
        surf->region[i] = m->region[binst[i] / (uint64_t)fs.nf];
    }
    surf->ncells = nb;
    for (size_t f = 0; f < m->npoint_fields; f++) {
        const vm_field *src = &m->point_fields[f];
        size_t nc = (size_t)src->ncomp;
        double *d = alloc_array(np ? np : 1, nc * sizeof(double), 0, "point field", &st, err);
        if (!d) goto fail;
        for (size_t v = 0; v < m->npoints; v++)
            if (map[v] >= 0)
                memcpy(d + (size_t)map[v] * nc, src->data + v * nc, nc * sizeof(double));
        st = vm_mesh_set_field(surf, 0, src->name, src->ncomp, d, err);
        free(d);
        if (st) goto fail;
    }
    for (size_t f = 0; f < m->ncell_fields; f++) {
        const vm_field *src = &m->cell_fields[f];
        size_t nc = (size_t)src->ncomp;
        double *d = alloc_array(nb ? nb : 1, nc * sizeof(double), 0, "cell field", &st, err);
        if (!d) goto fail;
        for (size_t i = 0; i < nb; i++)
            memcpy(d + i * nc, src->data + (size_t)(binst[i] / (uint64_t)fs.nf) * nc,
                   nc * sizeof(double));
        st = vm_mesh_set_field(surf, 1, src->name, src->ncomp, d, err);
        free(d);
        if (st) goto fail;
    }
    free(map);
    free(binst);
    return VM_OK;
fail:
    free(map);
    free(binst);
    vm_mesh_free(surf);
    return st;
}
