/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_topology.c — the graded mesher's safety net: the topology of the voxels (the
 * cubical reading dual contouring makes: the Euler characteristic of the boundary and the
 * 6-connected components of the inside points) and the same two numbers for a tet mesh, so
 * that a mesh whose topology differs is refined until it agrees. */
#include "../core/core.h"
#include "graded_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint32_t root32(uint32_t *parent, uint32_t x) {
    while (parent[x] != x)
        x = parent[x] = parent[parent[x]];
    return x;
}

/* The index of root r in the sorted roots[0..n). */
static size_t root_index(const uint32_t *roots, size_t n, uint32_t r) {
    size_t lo = 0, hi = n;
    while (hi - lo > 1) {
        size_t mid = (lo + hi) / 2;
        if (roots[mid] <= r) lo = mid;
        else hi = mid;
    }
    return lo;
}

/* The digital count over padded points `in` (parent: union-find over them, joined here
 * when join is set). With part (the root of each point's component, resolved), the count is
 * added up per component instead: sum[k] for the component whose root is roots[k] (sorted). */
static void digital_count(const gr_field *f, const uint8_t *in, uint32_t *parent, int join,
                          const uint32_t *roots, size_t nroots, long *sum, long *total) {
    const int64_t P0 = f->n[0] + 2, P1 = f->n[1] + 2, P2 = f->n[2] + 2;
    const size_t step[3] = {1, (size_t)P0, (size_t)(P0 * P1)};
    long all = 0;
    for (int64_t k = 0; k + 1 < P2; k++)
        for (int64_t j = 0; j + 1 < P1; j++)
            for (int64_t i = 0; i + 1 < P0; i++) {
                size_t p = (size_t)(i + P0 * (j + P1 * k));
                uint8_t c[8];
                int count = 0, first = -1;
                for (int q = 0; q < 8; q++) {
                    c[q] = in[p + (size_t)(q & 1) * step[0] + (size_t)((q >> 1) & 1) * step[1] +
                              (size_t)(q >> 2) * step[2]];
                    count += c[q];
                    if (c[q] && first < 0) first = q;
                }
                if (!count) continue;
                long x = 0;
                if (count == 8) x--;
                /* Six corners in and a diagonal pair out: the cubical reading joins the six
                 * around the diagonal into a ring (the configuration table's hole). */
                if (count == 6)
                    for (int q = 0; q < 4; q++)
                        if (!c[q] && !c[7 - q]) x++;
                if (c[0]) {
                    x++;
                    for (int a = 0; a < 3; a++) {
                        if (c[1 << a]) {
                            x--;
                            if (join) {
                                uint32_t ra = root32(parent, (uint32_t)p);
                                uint32_t rb = root32(parent, (uint32_t)(p + step[a]));
                                if (ra != rb) parent[ra] = rb;
                            }
                        }
                        int b = (a + 1) % 3;
                        if (c[1 << a] && c[1 << b] && c[(1 << a) | (1 << b)]) x++;
                    }
                }
                all += x;
                if (sum && x) {
                    /* every inside corner of the cube is in one component (the six of the
                     * ring as well), so its first one stands for them */
                    size_t q = (size_t)first;
                    uint32_t r = parent[p + (q & 1) * step[0] + ((q >> 1) & 1) * step[1] +
                                        (q >> 2) * step[2]];
                    sum[root_index(roots, nroots, r)] += x;
                }
            }
    *total = all;
}

/* The padded inside flags and their 6-connected union-find. 0 when out of memory. */
static int digital_parts(const gr_field *f, uint8_t **in_out, uint32_t **parent_out, size_t *np,
                         long *euler) {
    const int64_t P0 = f->n[0] + 2, P1 = f->n[1] + 2, P2 = f->n[2] + 2;
    *in_out = NULL;
    *parent_out = NULL;
    if (vm__mul_overflows((size_t)(P0 * P1), (size_t)P2, np) || *np >= UINT32_MAX) return 0;
    uint8_t *in = calloc(*np, 1);
    uint32_t *parent = malloc(*np * sizeof *parent);
    if (!in || !parent) {
        free(in);
        free(parent);
        return 0;
    }
    for (int64_t k = 0; k < f->n[2]; k++)
        for (int64_t j = 0; j < f->n[1]; j++)
            for (int64_t i = 0; i < f->n[0]; i++)
                in[(i + 1) + P0 * ((j + 1) + P1 * (k + 1))] = vm__gr_phi_point(f, i, j, k) >= 0;
    for (size_t p = 0; p < *np; p++)
        parent[p] = (uint32_t)p;
    digital_count(f, in, parent, 1, NULL, 0, NULL, euler);
    *in_out = in;
    *parent_out = parent;
    return 1;
}

vm_status vm__gr_digital_topology(const gr_field *f, long *euler, size_t *comps,
                                  vm_error *err) {
    uint8_t *in;
    uint32_t *parent;
    size_t np;
    long e;
    if (!digital_parts(f, &in, &parent, &np, &e))
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
    size_t n = 0;
    for (size_t p = 0; p < np; p++)
        if (in[p] && parent[p] == p) n++;
    free(in);
    free(parent);
    *euler = 2 * e;
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
        vm__sort_u64(*out + st[v], st[v + 1] - st[v]);
    return 1;
}

vm_status vm__gr_mesh_topology(const vm_mesh *m, long *euler, size_t *comps, uint32_t *root,
                               long *part, vm_error *err) {
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
    if (part) memset(part, 0, m->npoints * sizeof *part);
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
                if (part && pass == 1 && j == i + 1) part[root32(parent, (uint32_t)v)]++;
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
            if (i == es[v] || edges[i] != edges[i - 1]) {
                ne++;
                if (part) part[root32(parent, (uint32_t)v)]--;
            }
    long nv = 0;
    for (size_t p = 0; p < m->npoints; p++) {
        nv += onb[p];
        if (part) part[root32(parent, (uint32_t)p)] += onb[p];
    }
    if (root)
        for (size_t p = 0; p < m->npoints; p++)
            root[p] = root32(parent, (uint32_t)p);
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

/* Grows box b (lo[3], hi[3]) to hold x, or to hold box c when x is NULL. */
static void box_grow(double *b, const double *x, const double *c) {
    for (int d = 0; d < 3; d++) {
        double l = x ? x[d] : c[d], h = x ? x[d] : c[3 + d];
        if (l < b[d]) b[d] = l;
        if (h > b[3 + d]) b[3 + d] = h;
    }
}

static void box_empty(double *b) {
    for (int d = 0; d < 3; d++) {
        b[d] = INFINITY;
        b[3 + d] = -INFINITY;
    }
}

vm_status vm__gr_topology_misfits(const gr_field *f, const vm_mesh *m, double **boxes,
                                  size_t *nboxes, vm_error *err) {
    *boxes = NULL;
    *nboxes = 0;
    double inv[3][3], det;
    vm_status s = vm__frame_inverse(f->v, "mesh", inv, &det, err);
    if (s) return s;
    if (m->npoints >= INT32_MAX)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: too many points for the topology count");
    const int64_t P0 = f->n[0] + 2, P1 = f->n[1] + 2;
    uint8_t *in = NULL, *used = NULL;
    uint32_t *parent = NULL, *roots = NULL, *root = NULL;
    long *dsum = NULL, *part = NULL, *dme = NULL;
    double *dbox = NULL, *mbox = NULL, *out = NULL;
    int32_t *cid = NULL, *mrep = NULL, *dcount = NULL;
    size_t np = 0, nr = 0, nm = 0, nout = 0;
    long e;
    if (!digital_parts(f, &in, &parent, &np, &e)) goto nomem;
    /* the voxels' components: roots in index order (so sorted), each one's Euler
     * characteristic and box */
    for (size_t p = 0; p < np; p++)
        if (in[p] && (parent[p] = root32(parent, (uint32_t)p)) == p) nr++;
    roots = malloc((nr + 1) * sizeof *roots);
    dsum = calloc(nr + 1, sizeof *dsum);
    dbox = malloc((6 * nr + 1) * sizeof *dbox);
    if (!roots || !dsum || !dbox) goto nomem;
    nr = 0;
    for (size_t p = 0; p < np; p++)
        if (in[p] && parent[p] == p) roots[nr++] = (uint32_t)p;
    for (size_t k = 0; k < nr; k++)
        box_empty(dbox + 6 * k);
    digital_count(f, in, parent, 0, roots, nr, dsum, &e);
    for (size_t p = 0; p < np; p++) {
        if (!in[p]) continue;
        int64_t i = (int64_t)(p % (size_t)P0) - 1, j = (int64_t)((p / (size_t)P0) % (size_t)P1) - 1,
                k = (int64_t)(p / (size_t)(P0 * P1)) - 1;
        double x[3] = {(double)i * f->sp[0], (double)j * f->sp[1], (double)k * f->sp[2]};
        box_grow(dbox + 6 * root_index(roots, nr, parent[p]), x, NULL);
    }
    /* the mesh's components: Euler characteristic, box, and the voxel component that one of
     * its points (in index order) falls on */
    root = malloc((m->npoints + 1) * sizeof *root);
    part = malloc((m->npoints + 1) * sizeof *part);
    used = calloc(m->npoints + 1, 1);
    cid = malloc((m->npoints + 1) * sizeof *cid);
    if (!root || !part || !used || !cid) goto nomem;
    long me;
    size_t mc;
    if ((s = vm__gr_mesh_topology(m, &me, &mc, root, part, err))) goto done;
    for (size_t t = 0; t < 4 * m->ncells; t++)
        used[m->cells[t]] = 1;
    for (size_t p = 0; p < m->npoints; p++)
        cid[p] = -1;
    for (size_t p = 0; p < m->npoints; p++)
        if (used[p] && cid[root[p]] < 0) cid[root[p]] = (int32_t)nm++;
    mbox = malloc((6 * nm + 1) * sizeof *mbox);
    mrep = malloc((nm + 1) * sizeof *mrep);
    dcount = calloc(nr + 1, sizeof *dcount);
    dme = calloc(nr + 1, sizeof *dme);
    if (!mbox || !mrep || !dcount || !dme) goto nomem;
    for (size_t c = 0; c < nm; c++) {
        box_empty(mbox + 6 * c);
        mrep[c] = -1;
    }
    for (size_t p = 0; p < m->npoints; p++) {
        if (!used[p]) continue;
        int32_t c = cid[root[p]];
        double w[3], u[3];
        for (int r = 0; r < 3; r++)
            w[r] = m->points[3 * p + (size_t)r] - f->v->origin[r];
        for (int r = 0; r < 3; r++)
            u[r] = inv[r][0] * w[0] + inv[r][1] * w[1] + inv[r][2] * w[2];
        double x[3] = {u[0] * f->sp[0], u[1] * f->sp[1], u[2] * f->sp[2]};
        box_grow(mbox + 6 * c, x, NULL);
        if (mrep[c] >= 0) continue;
        int64_t q[3];
        int inside = 1;
        for (int r = 0; r < 3; r++) {
            q[r] = (int64_t)floor(u[r] + 0.5);
            if (q[r] < 0 || q[r] >= f->n[r]) inside = 0;
        }
        size_t at = inside ? (size_t)((q[0] + 1) + P0 * ((q[1] + 1) + P1 * (q[2] + 1))) : 0;
        if (inside && in[at]) {
            mrep[c] = (int32_t)root_index(roots, nr, parent[at]);
            dcount[mrep[c]]++;
            dme[mrep[c]] += part[root[p]];
        }
    }
    /* the boxes of the misfits, each padded by a voxel */
    out = malloc((6 * (nr + nm) + 1) * sizeof *out);
    if (!out) goto nomem;
    for (size_t d = 0; d < nr; d++) {
        if (dcount[d] == 1 && dme[d] == 2 * dsum[d]) continue;
        double *B = out + 6 * nout++;
        memcpy(B, dbox + 6 * d, 6 * sizeof *B);
        for (size_t c = 0; c < nm; c++)
            if (mrep[c] == (int32_t)d) box_grow(B, NULL, mbox + 6 * c);
    }
    for (size_t c = 0; c < nm; c++)
        if (mrep[c] < 0) memcpy(out + 6 * nout++, mbox + 6 * c, 6 * sizeof *out);
    for (size_t b = 0; b < nout; b++)
        for (int d = 0; d < 3; d++) {
            out[6 * b + (size_t)d] -= f->sp[d];
            out[6 * b + 3 + (size_t)d] += f->sp[d];
        }
    *boxes = out;
    *nboxes = nout;
    out = NULL;
    goto done;
nomem:
    s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the topology count");
done:
    free(in);
    free(parent);
    free(roots);
    free(dsum);
    free(dbox);
    free(root);
    free(part);
    free(used);
    free(cid);
    free(mbox);
    free(mrep);
    free(dcount);
    free(dme);
    free(out);
    return s;
}
