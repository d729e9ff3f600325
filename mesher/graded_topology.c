/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_topology.c — the graded mesher's safety net: the topology of the voxels (the
 * cubical reading dual contouring makes: the Euler characteristic of the boundary and the
 * 6-connected components of the inside points) and the same two numbers for a tet mesh, so
 * that a mesh whose topology differs is refined until it agrees. */
#include "../core/core.h"
#include "graded_internal.h"
#include <stdlib.h>
#include <string.h>

static uint32_t root32(uint32_t *parent, uint32_t x) {
    while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
    return x;
}

vm_status vm__gr_digital_topology(const gr_field *f, long *euler, size_t *comps,
                                  vm_error *err) {
    /* Points padded by one outside layer on every side; a cube is owned by its lowest
     * corner, so every cube touching the volume is counted once. */
    const int64_t P0 = f->n[0] + 2, P1 = f->n[1] + 2, P2 = f->n[2] + 2;
    size_t np = 0;
    if (vm__mul_overflows((size_t)(P0 * P1), (size_t)P2, &np) || np >= UINT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many voxels for the topology count");
    uint8_t *in = calloc(np, 1);
    uint32_t *parent = malloc(np * sizeof *parent);
    if (!in || !parent) {
        free(in);
        free(parent);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
    }
    for (int64_t k = 0; k < f->n[2]; k++)
        for (int64_t j = 0; j < f->n[1]; j++)
            for (int64_t i = 0; i < f->n[0]; i++)
                in[(i + 1) + P0 * ((j + 1) + P1 * (k + 1))] = vm__gr_phi_point(f, i, j, k) >= 0;
    for (size_t p = 0; p < np; p++)
        parent[p] = (uint32_t)p;
    const size_t step[3] = {1, (size_t)P0, (size_t)(P0 * P1)};
    long V = 0, E = 0, F = 0, C = 0, S = 0;
    for (int64_t k = 0; k + 1 < P2; k++)
        for (int64_t j = 0; j + 1 < P1; j++)
            for (int64_t i = 0; i + 1 < P0; i++) {
                size_t p = (size_t)(i + P0 * (j + P1 * k));
                uint8_t c[8];
                int count = 0;
                for (int q = 0; q < 8; q++) {
                    c[q] = in[p + (size_t)(q & 1) * step[0] + (size_t)((q >> 1) & 1) * step[1] +
                              (size_t)(q >> 2) * step[2]];
                    count += c[q];
                }
                if (count == 8) C++;
                /* Six corners in and a diagonal pair out: the cubical reading joins the six
                 * around the diagonal into a ring (the configuration table's hole). */
                if (count == 6)
                    for (int q = 0; q < 4; q++)
                        if (!c[q] && !c[7 - q]) S++;
                if (!c[0]) continue;
                V++;
                for (int a = 0; a < 3; a++) {
                    if (c[1 << a]) {
                        E++;
                        uint32_t ra = root32(parent, (uint32_t)p);
                        uint32_t rb = root32(parent, (uint32_t)(p + step[a]));
                        if (ra != rb) parent[ra] = rb;
                    }
                    int b = (a + 1) % 3;
                    if (c[1 << a] && c[1 << b] && c[(1 << a) | (1 << b)]) F++;
                }
            }
    size_t n = 0;
    for (size_t p = 0; p < np; p++)
        if (in[p] && parent[p] == p) n++;
    free(in);
    free(parent);
    *euler = 2 * (V - E + F - C + S);
    *comps = n;
    return VM_OK;
}

/* A face or an edge as sorted vertex ids (c = UINT32_MAX for an edge). */
typedef struct face_key {
    uint32_t a, b, c;
} face_key;

static uint64_t key_hash(face_key k) {
    uint64_t h = (uint64_t)k.a * 0x9E3779B97F4A7C15ull;
    h ^= (uint64_t)k.b * 0xC2B2AE3D27D4EB4Full + (h >> 29);
    h ^= (uint64_t)k.c * 0x165667B19E3779F9ull + (h >> 31);
    return h ^ (h >> 33);
}

static face_key sorted3(uint32_t a, uint32_t b, uint32_t c) {
    uint32_t t;
    if (a > b) t = a, a = b, b = t;
    if (b > c) t = b, b = c, c = t;
    if (a > b) t = a, a = b, b = t;
    return (face_key){a, b, c};
}

/* Open-addressing set of keys with a count per key. */
typedef struct key_set {
    face_key *key;
    uint32_t *count;
    size_t cap;
} key_set;

static int set_init(key_set *s, size_t n) {
    s->cap = 16;
    while (s->cap < 2 * n)
        s->cap *= 2;
    s->key = malloc(s->cap * sizeof *s->key);
    s->count = calloc(s->cap, sizeof *s->count);
    return s->key && s->count;
}

static void set_add(key_set *s, face_key k) {
    for (size_t at = key_hash(k) & (s->cap - 1);; at = (at + 1) & (s->cap - 1)) {
        if (!s->count[at]) {
            s->key[at] = k;
            s->count[at] = 1;
            return;
        }
        if (s->key[at].a == k.a && s->key[at].b == k.b && s->key[at].c == k.c) {
            s->count[at]++;
            return;
        }
    }
}

static void set_free(key_set *s) {
    free(s->key);
    free(s->count);
}

vm_status vm__gr_mesh_topology(const vm_mesh *m, long *euler, size_t *comps, vm_error *err) {
    if (m->npoints >= UINT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many points for the topology count");
    key_set faces, edges;
    memset(&edges, 0, sizeof edges);
    uint32_t *parent = malloc((m->npoints + 1) * sizeof *parent);
    uint8_t *onb = calloc(m->npoints + 1, 1);
    if (!parent || !onb || !set_init(&faces, 4 * m->ncells)) {
        free(parent);
        free(onb);
        set_free(&faces);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
    }
    for (size_t p = 0; p < m->npoints; p++)
        parent[p] = (uint32_t)p;
    static const int fv[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        for (int q = 1; q < 4; q++) {
            uint32_t ra = root32(parent, (uint32_t)c[0]), rb = root32(parent, (uint32_t)c[q]);
            if (ra != rb) parent[ra] = rb;
        }
        for (int q = 0; q < 4; q++)
            set_add(&faces, sorted3((uint32_t)c[fv[q][0]], (uint32_t)c[fv[q][1]],
                                    (uint32_t)c[fv[q][2]]));
    }
    /* Boundary faces are those of one tet. */
    size_t nf = 0;
    for (size_t at = 0; at < faces.cap; at++)
        if (faces.count[at] == 1) nf++;
    vm_status s = VM_OK;
    if (!set_init(&edges, 3 * nf)) {
        s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
    } else {
        for (size_t at = 0; at < faces.cap; at++) {
            if (faces.count[at] != 1) continue;
            face_key k = faces.key[at];
            onb[k.a] = onb[k.b] = onb[k.c] = 1;
            set_add(&edges, (face_key){k.a, k.b, UINT32_MAX});
            set_add(&edges, (face_key){k.a, k.c, UINT32_MAX});
            set_add(&edges, (face_key){k.b, k.c, UINT32_MAX});
        }
        long nv = 0, ne = 0;
        for (size_t p = 0; p < m->npoints; p++)
            nv += onb[p];
        for (size_t at = 0; at < edges.cap; at++)
            ne += edges.count[at] != 0;
        *euler = nv - ne + (long)nf;
        /* Components of the points the tets use. */
        uint8_t *used = onb; /* reused: 1 where a tet uses the point */
        memset(used, 0, m->npoints);
        for (size_t t = 0; t < 4 * m->ncells; t++)
            used[m->cells[t]] = 1;
        size_t n = 0;
        for (size_t p = 0; p < m->npoints; p++)
            if (used[p] && parent[p] == p) n++;
        *comps = n;
    }
    set_free(&faces);
    set_free(&edges);
    free(parent);
    free(onb);
    return s;
}
