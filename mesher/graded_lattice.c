/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_lattice.c — the body-centred cubic lattice over the octree's leaves (Labelle
 * and Shewchuk, "Isosurface Stuffing", 2007, §3): every face between two leaves of one size
 * gives four tets around the segment joining their centres (bisected where a finer leaf puts a
 * vertex on an edge), and a face next to four finer leaves gives four around each segment from
 * the coarse centre to a fine one (30..135 degrees). A face whose corners are all inside but
 * whose centre the two cell centres would read as outside is split at its centre instead, so
 * thin sheets keep their faces (the cubical reading of dual contouring). */
#include "../core/core.h"
#include "../core/hash.h"
#include "graded_config.h"
#include "graded_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static vm_status nomem(vm_error *err) {
    return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the lattice");
}

/* Where a key's probe starts: its block of 8^3 lattice points hashed, plus its place in the
 * block, so that the lookups of one leaf and its neighbours (most of them) stay within a few
 * pages of the table instead of one miss each. */
static inline uint64_t slot_hash(int64_t key) {
    const int64_t low = 7 | (int64_t)7 << 21 | (int64_t)7 << 42;
    int64_t in = key & low;
    return vm__hash_mix((uint64_t)(key & ~low)) +
           (uint64_t)((in & 7) | ((in >> 21) & 7) << 3 | ((in >> 42) & 7) << 6);
}

/* Empties the table and sizes it for at least `need` vertices at load 1/2 (a power of two,
 * at least 4096), then puts the vertices back. */
static vm_status rehash(gr_lattice *L, size_t need, vm_error *err) {
    size_t cap = L->tcap ? L->tcap : 4096;
    while (cap < 2 * need)
        cap *= 2;
    if (cap != L->tcap) {
        gr_slot *slot = malloc(cap * sizeof *slot);
        if (!slot) return nomem(err);
        free(L->slot);
        L->slot = slot;
        L->tcap = cap;
    }
    for (size_t i = 0; i < cap; i++)
        L->slot[i].id = -1;
    for (size_t v = 0; v < L->nv; v++) {
        size_t h = (size_t)slot_hash(L->key[v]) & (cap - 1);
        while (L->slot[h].id >= 0)
            h = (h + 1) & (cap - 1);
        L->slot[h].key = L->key[v];
        L->slot[h].id = (int64_t)v;
    }
    return VM_OK;
}

int64_t vm__gr_lattice_find(const gr_lattice *L, const int64_t p[3]) {
    int64_t key = vm__gr_key(p);
    size_t h = (size_t)slot_hash(key) & (L->tcap - 1);
    while (L->slot[h].id >= 0) {
        if (L->slot[h].key == key) return L->slot[h].id;
        h = (h + 1) & (L->tcap - 1);
    }
    return -1;
}

static double lattice_phi(const gr_tree *t, const gr_field *f, const int64_t p[3]);

/* The id of lattice point p, added when new with value phi, or (t not NULL) with the
 * field's value there. [out] id. */
static vm_status vertex_at(gr_lattice *L, const int64_t p[3], double phi, const gr_tree *t,
                           const gr_field *f, int64_t *id, vm_error *err) {
    if (2 * (L->nv + 1) > L->tcap) {
        vm_status s = rehash(L, L->nv + 1, err);
        if (s) return s;
    }
    int64_t key = vm__gr_key(p);
    size_t h = (size_t)slot_hash(key) & (L->tcap - 1);
    while (L->slot[h].id >= 0) {
        if (L->slot[h].key == key) {
            *id = L->slot[h].id;
            return VM_OK;
        }
        h = (h + 1) & (L->tcap - 1);
    }
    if (L->nv == L->vcap) {
        size_t cap = L->vcap ? 2 * L->vcap : 4096;
        if (cap > (size_t)INT32_MAX) return nomem(err);
        int64_t *k = realloc(L->key, cap * sizeof *k);
        if (!k) return nomem(err);
        L->key = k;
        double *ph = realloc(L->phi, cap * sizeof *ph);
        if (!ph) return nomem(err);
        L->phi = ph;
        L->vcap = cap;
    }
    L->key[L->nv] = key;
    L->phi[L->nv] = t ? lattice_phi(t, f, p) : phi;
    L->slot[h].key = key;
    L->slot[h].id = (int64_t)L->nv;
    *id = (int64_t)L->nv++;
    return VM_OK;
}

static vm_status vertex(gr_lattice *L, const int64_t p[3], double phi, int64_t *id,
                        vm_error *err) {
    return vertex_at(L, p, phi, NULL, NULL, id, err);
}

/* phi at a lattice point, with 0 read as inside (the bound belongs to the material). */
static double lattice_phi(const gr_tree *t, const gr_field *f, const int64_t p[3]) {
    double u[3];
    vm__gr_lattice_pos(t, p, u);
    double v = vm__gr_phi(f, u);
    return v == 0 ? -1e-9 * f->out : v;
}

static vm_status add_tet(gr_lattice *L, const int64_t *id, vm_error *err) {
    if (L->nt == L->tcap4) {
        size_t cap = L->tcap4 ? 2 * L->tcap4 : 8192;
        int32_t(*nt)[4] = realloc(L->tet, cap * sizeof *nt);
        if (!nt) return nomem(err);
        L->tet = nt;
        L->tcap4 = cap;
    }
    /* Positive in lattice coordinates (exact: small integers). */
    int64_t p[4][3];
    for (int k = 0; k < 4; k++)
        vm__gr_unkey(L->key[id[k]], p[k]);
    double a[3], b[3], c[3];
    for (int d = 0; d < 3; d++) {
        a[d] = (double)(p[1][d] - p[0][d]);
        b[d] = (double)(p[2][d] - p[0][d]);
        c[d] = (double)(p[3][d] - p[0][d]);
    }
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    if (det == 0) return VM_OK; /* cannot happen for the shapes made here */
    int32_t *t4 = L->tet[L->nt++];
    for (int k = 0; k < 4; k++)
        t4[k] = (int32_t)id[k];
    if (det < 0) {
        int32_t x = t4[2];
        t4[2] = t4[3];
        t4[3] = x;
    }
    return VM_OK;
}

/* The boundary of the square with lowest corner a, edge e (lattice units), normal axis d:
 * its corners in cyclic order with the edge midpoints that are lattice vertices. */
static int face_loop(const gr_lattice *L, const int64_t a[3], int64_t e, int d, int64_t id[8]) {
    int u = (d + 1) % 3, w = (d + 2) % 3, n = 0;
    static const int cu[4] = {0, 1, 1, 0}, cw[4] = {0, 0, 1, 1};
    for (int k = 0; k < 4; k++) {
        int64_t p[3] = {a[0], a[1], a[2]}, m[3];
        p[u] += cu[k] * e;
        p[w] += cw[k] * e;
        id[n++] = vm__gr_lattice_find(L, p);
        int k1 = (k + 1) & 3;
        for (int x = 0; x < 3; x++)
            m[x] = p[x];
        m[u] = a[u] + (cu[k] + cu[k1]) * e / 2;
        m[w] = a[w] + (cw[k] + cw[k1]) * e / 2;
        if (e >= 2) {
            int64_t mid = vm__gr_lattice_find(L, m);
            if (mid >= 0) id[n++] = mid;
        }
    }
    return n;
}

/* Tets between two centres c and c2 (ids) over the square (a, e, d); x is the fraction of the
 * way from c to c2 where their segment crosses the square. */
static vm_status face_tets(gr_lattice *L, const gr_tree *t, const gr_field *f, int64_t c,
                           int64_t c2, const int64_t a[3], int64_t e, int d, double x,
                           vm_error *err) {
    int64_t loop[8];
    int n = face_loop(L, a, e, d, loop);
    for (int k = 0; k < n; k++)
        if (loop[k] < 0)
            return vm_error_set(err, VM_ERR_INTERNAL, "mesh: lattice face corner missing");
    /* The inside part of the square's boundary: all of it, one arc, none, or several arcs. */
    int inside = 0, arcs = 0;
    for (int k = 0; k < n; k++) {
        int here = L->phi[loop[k]] >= 0, next = L->phi[loop[(k + 1) % n]] >= 0;
        inside += here;
        arcs += here && !next;
    }
    int full = inside == n, one_arc = inside > 0 && arcs == 1;
    /* The segment between the centres crosses the square at a point read as `at`. The
     * cubical reading fills a square exactly when its corners all are inside: a full square
     * crossed outside, or an empty or split one crossed inside, is split at its centre (a
     * centre inside, resp. outside); a square whose inside part is one arc may be crossed
     * either way (the cones from the centres over it change no topology). */
    double at = (1 - x) * L->phi[c] + x * L->phi[c2];
    vm_status s = VM_OK;
    if ((full && at < 0) || (!full && !one_arc && at >= 0)) {
        int64_t m[3] = {a[0], a[1], a[2]}, mid;
        m[(d + 1) % 3] += e / 2;
        m[(d + 2) % 3] += e / 2;
        double v = lattice_phi(t, f, m), mag = 0;
        for (int k = 0; k < n; k++)
            mag += fabs(L->phi[loop[k]]) / (2 * n);
        if (full && v <= 0) v = mag > 0 ? mag : 1e-300;
        if (!full && v >= 0) v = mag > 0 ? -mag : -1e-300;
        if ((s = vertex(L, m, v, &mid, err))) return s;
        for (int k = 0; k < n && !s; k++) {
            int64_t t1[4] = {c, mid, loop[k], loop[(k + 1) % n]};
            int64_t t2[4] = {c2, mid, loop[k], loop[(k + 1) % n]};
            if (!(s = add_tet(L, t1, err))) s = add_tet(L, t2, err);
        }
        return s;
    }
    for (int k = 0; k < n && !s; k++) {
        int64_t t1[4] = {c, c2, loop[k], loop[(k + 1) % n]};
        s = add_tet(L, t1, err);
    }
    return s;
}

/* A face on the root's boundary: a fan from its centre (outside the volume). */
static vm_status root_face(gr_lattice *L, const gr_tree *t, const gr_field *f, int64_t c,
                           const int64_t a[3], int64_t e, int d, vm_error *err) {
    int64_t loop[8], m[3] = {a[0], a[1], a[2]}, mid;
    int n = face_loop(L, a, e, d, loop);
    m[(d + 1) % 3] += e / 2;
    m[(d + 2) % 3] += e / 2;
    vm_status s = vertex(L, m, lattice_phi(t, f, m), &mid, err);
    for (int k = 0; k < n && !s; k++) {
        int64_t t1[4] = {c, mid, loop[k], loop[(k + 1) % n]};
        s = add_tet(L, t1, err);
    }
    return s;
}

/* The centre's id of the leaf at lattice point p below node `at` (its children are leaves
 * next to a coarser one, by the 2:1 balance), without the hash table where it can. */
static int64_t child_centre(const gr_lattice *L, const gr_tree *t, int64_t at,
                            const int64_t p[3]) {
    const gr_node *q = &t->node[at];
    int64_t half = (int64_t)1 << q->level;
    int c = 0;
    for (int d = 0; d < 3; d++)
        if (p[d] >= q->a[d] + half) c |= 1 << d;
    int64_t k = q->child + c;
    return t->node[k].child < 0 ? L->centre[k] : vm__gr_lattice_find(L, p);
}

static vm_status leaf_faces(gr_lattice *L, const gr_tree *t, const gr_field *f, size_t qi,
                            vm_error *err) {
    const gr_node *q = &t->node[qi];
    int64_t e = (int64_t)2 << q->level, h = e / 2, root = (int64_t)2 << t->root_level;
    int64_t cp[3] = {q->a[0] + h, q->a[1] + h, q->a[2] + h};
    int64_t c = L->centre[qi];
    vm_status s = VM_OK;
    for (int d = 0; d < 3 && !s; d++)
        for (int side = 0; side < 2 && !s; side++) {
            int64_t a[3] = {q->a[0], q->a[1], q->a[2]};
            a[d] += side * e;
            if (a[d] == 0 || a[d] == root) {
                s = root_face(L, t, f, c, a, e, d, err);
                continue;
            }
            int64_t qn[3] = {cp[0], cp[1], cp[2]};
            qn[d] += side ? e : -e;
            int64_t nb = vm__gr_tree_find(t, qn, q->level);
            const gr_node *m = &t->node[nb];
            if (m->child < 0) {
                if (m->level > q->level || !side) continue; /* the other side makes them */
                s = face_tets(L, t, f, c, L->centre[nb], a, e, d, 0.5, err);
                continue;
            }
            /* Four finer leaves across: around each segment from c to their centres. */
            for (int k = 0; k < 4 && !s; k++) {
                int64_t sa[3] = {a[0], a[1], a[2]}, dc[3];
                sa[(d + 1) % 3] += (k & 1) * h;
                sa[(d + 2) % 3] += (k >> 1) * h;
                for (int x = 0; x < 3; x++)
                    dc[x] = sa[x] + h / 2;
                dc[d] = a[d] + (side ? h / 2 : -h / 2);
                s = face_tets(L, t, f, c, child_centre(L, t, nb, dc), sa, h, d, 2.0 / 3.0, err);
            }
        }
    return s;
}

vm_status vm__gr_lattice_build(gr_lattice *L, const gr_tree *t, const gr_field *f,
                               vm_error *err) {
    /* the arrays of a lattice built before stay, emptied */
    L->nv = 0;
    L->nt = 0;
    vm__gr_config_init();
    vm_status s = rehash(L, 0, err);
    if (!s && L->ccap < t->n) {
        free(L->centre);
        L->ccap = t->n + t->n / 4;
        L->centre = malloc(L->ccap * sizeof *L->centre);
        if (!L->centre) {
            L->ccap = 0;
            s = nomem(err);
        }
    }
    /* Corners first (every leaf's), then centres: a base cell's centre takes the sign the
     * cubical reading of its corners asks for. */
    for (size_t i = 0; i < t->n && !s; i++) {
        const gr_node *q = &t->node[i];
        if (q->child >= 0) continue;
        int64_t e = (int64_t)2 << q->level, id;
        for (int k = 0; k < 8 && !s; k++) {
            int64_t p[3] = {q->a[0] + (k & 1) * e, q->a[1] + ((k >> 1) & 1) * e,
                            q->a[2] + (k >> 2) * e};
            s = vertex_at(L, p, 0, t, f, &id, err);
        }
    }
    for (size_t i = 0; i < t->n && !s; i++) {
        const gr_node *q = &t->node[i];
        if (q->child >= 0) continue;
        int64_t e = (int64_t)2 << q->level, h = e / 2, id;
        int64_t p[3] = {q->a[0] + h, q->a[1] + h, q->a[2] + h};
        double v = lattice_phi(t, f, p);
        if (q->level == 0) {
            int mask = 0;
            double mag = 0;
            for (int k = 0; k < 8; k++) {
                int64_t r[3] = {q->a[0] + (k & 1) * e, q->a[1] + ((k >> 1) & 1) * e,
                                q->a[2] + (k >> 2) * e};
                double cv = L->phi[vm__gr_lattice_find(L, r)];
                if (cv >= 0) mask |= 1 << k;
                mag += fabs(cv) / 16;
            }
            int rule = vm__gr_config[mask].centre;
            if (rule == GR_CENTRE_IN && v < 0) v = mag > 0 ? mag : 1e-300;
            if (rule == GR_CENTRE_OUT && v >= 0) v = mag > 0 ? -mag : -1e-300;
        }
        s = vertex(L, p, v, &id, err);
        L->centre[i] = id;
    }
    for (size_t i = 0; i < t->n && !s; i++)
        if (t->node[i].child < 0) s = leaf_faces(L, t, f, i, err);
    return s;
}

void vm__gr_lattice_free(gr_lattice *L) {
    free(L->key);
    free(L->phi);
    free(L->slot);
    free(L->tet);
    free(L->centre);
    memset(L, 0, sizeof *L);
}
