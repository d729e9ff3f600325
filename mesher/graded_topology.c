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

/* A face as sorted vertex ids. */
typedef struct face_key {
    uint32_t a, b, c;
} face_key;

static face_key sorted3(uint32_t a, uint32_t b, uint32_t c) {
    uint32_t t;
    if (a > b) t = a, a = b, b = t;
    if (b > c) t = b, b = c, c = t;
    if (a > b) t = a, a = b, b = t;
    return (face_key){a, b, c};
}

/* Sorts x[0..n) ascending (the small groups of one lowest vertex). */
static void sort_u64(uint64_t *x, size_t n) {
    for (size_t i = 1; i < n; i++) {
        uint64_t v = x[i];
        size_t j = i;
        for (; j > 0 && x[j - 1] > v; j--)
            x[j] = x[j - 1];
        x[j] = v;
    }
}

/* Groups pairs (lo, rest) by lo with a counting sort: start[lo] .. start[lo + 1] index the
 * rests of lo in out, sorted. [out] *start (npoints + 1 entries) and *out (n), freed by the
 * caller; 0 when out of memory. The groups are small (the faces or edges at one vertex), so
 * this walks memory in order where a hash table of all faces missed the cache on each. */
static int group(size_t npoints, size_t n, const uint32_t *lo, const uint64_t *rest,
                 size_t **start, uint64_t **out) {
    *start = calloc(npoints + 2, sizeof **start);
    *out = malloc((n + 1) * sizeof **out);
    if (!*start || !*out) return 0;
    size_t *st = *start;
    for (size_t i = 0; i < n; i++)
        st[lo[i] + 2]++;
    for (size_t v = 0; v < npoints; v++)
        st[v + 2] += st[v + 1];
    for (size_t i = 0; i < n; i++)
        (*out)[st[lo[i] + 1]++] = rest[i];
    for (size_t v = 0; v < npoints; v++)
        sort_u64(*out + st[v], st[v + 1] - st[v]);
    return 1;
}

vm_status vm__gr_mesh_topology(const vm_mesh *m, long *euler, size_t *comps, vm_error *err) {
    if (m->npoints >= UINT32_MAX || m->ncells >= SIZE_MAX / 64)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many points for the topology count");
    size_t nf4 = 4 * m->ncells, nf = 0, ne = 0, *fs = NULL, *es = NULL;
    uint32_t *parent = malloc((m->npoints + 1) * sizeof *parent);
    uint8_t *onb = calloc(m->npoints + 1, 1);
    uint32_t *lo = malloc((nf4 + 1) * sizeof *lo);
    uint64_t *rest = malloc((nf4 + 1) * sizeof *rest), *faces = NULL, *edges = NULL;
    vm_status s = VM_OK;
    if (!parent || !onb || !lo || !rest) goto nomem;
    for (size_t p = 0; p < m->npoints; p++)
        parent[p] = (uint32_t)p;
    static const int fv[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        for (int q = 1; q < 4; q++) {
            uint32_t ra = root32(parent, (uint32_t)c[0]), rb = root32(parent, (uint32_t)c[q]);
            if (ra != rb) parent[ra] = rb;
        }
        for (int q = 0; q < 4; q++) {
            face_key k =
                sorted3((uint32_t)c[fv[q][0]], (uint32_t)c[fv[q][1]], (uint32_t)c[fv[q][2]]);
            lo[4 * t + (size_t)q] = k.a;
            rest[4 * t + (size_t)q] = (uint64_t)k.b << 32 | k.c;
        }
    }
    /* Boundary faces are those of one tet: single entries of their lowest vertex's group.
     * Their edges (each face's three) go back into lo and rest, then the same for them. */
    if (!group(m->npoints, nf4, lo, rest, &fs, &faces)) goto nomem;
    for (int pass = 0; pass < 2; pass++) { /* count, then (room made) fill */
        if (pass == 1 && 3 * nf > nf4) {
            free(lo);
            free(rest);
            lo = malloc(3 * nf * sizeof *lo);
            rest = malloc(3 * nf * sizeof *rest);
            if (!lo || !rest) goto nomem;
        }
        nf = 0;
        for (size_t v = 0; v < m->npoints; v++)
            for (size_t i = fs[v]; i < fs[v + 1];) {
                size_t j = i + 1;
                while (j < fs[v + 1] && faces[j] == faces[i])
                    j++;
                if (j == i + 1 && pass == 1) {
                    uint32_t b = (uint32_t)(faces[i] >> 32), c = (uint32_t)faces[i];
                    onb[v] = onb[b] = onb[c] = 1;
                    uint32_t pl[3] = {(uint32_t)v, (uint32_t)v, b};
                    uint32_t ph[3] = {b, c, c};
                    for (int q = 0; q < 3; q++) {
                        lo[3 * nf + (size_t)q] = pl[q];
                        rest[3 * nf + (size_t)q] = ph[q];
                    }
                }
                nf += j == i + 1;
                i = j;
            }
    }
    free(fs);
    free(faces);
    fs = NULL;
    faces = NULL;
    if (!group(m->npoints, 3 * nf, lo, rest, &es, &edges)) goto nomem;
    /* distinct edges: distinct entries within each group */
    for (size_t v = 0; v < m->npoints; v++)
        for (size_t i = es[v]; i < es[v + 1]; i++)
            ne += i == es[v] || edges[i] != edges[i - 1];
    long nv = 0;
    for (size_t p = 0; p < m->npoints; p++)
        nv += onb[p];
    *euler = nv - (long)ne + (long)nf;
    /* Components of the points the tets use. */
    uint8_t *used = onb; /* reused: 1 where a tet uses the point */
    memset(used, 0, m->npoints);
    for (size_t t = 0; t < 4 * m->ncells; t++)
        used[m->cells[t]] = 1;
    size_t n = 0;
    for (size_t p = 0; p < m->npoints; p++)
        if (used[p] && parent[p] == p) n++;
    *comps = n;
    goto done;
nomem:
    s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
done:
    free(parent);
    free(onb);
    free(lo);
    free(rest);
    free(fs);
    free(faces);
    free(es);
    free(edges);
    return s;
}
