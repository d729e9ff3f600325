/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/edge_lengths.c — the distinct edges of a mesh and their length statistics: each
 * cell edge is filed under its lower node (a counting sort), then every node's short list is
 * sorted and its repeats dropped, in blocks of nodes so the lists stay within a fixed size. */
#include "../core/core.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Node pairs of the edges of each kind, in VTK node order. */
static const int tet_edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
static const int hex_edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                     {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
static const int tri_edges[3][2] = {{0, 1}, {1, 2}, {2, 0}};
static const int quad_edges[4][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}};

/* Largest number of edge entries held at once (4 bytes each, plus as many per block node). */
#define BLOCK_ENTRIES ((size_t)1 << 24)

static int edge_table(vm_cell_kind k, const int (**e)[2]) {
    switch (k) {
    case VM_TET4: *e = tet_edges; return 6;
    case VM_HEX8: *e = hex_edges; return 12;
    case VM_TRI3: *e = tri_edges; return 3;
    case VM_QUAD4: *e = quad_edges; return 4;
    }
    return 0;
}

/* Lengths statistics so far: min, max, sum, and the lengths kept for the histogram. */
typedef struct lengths {
    double *len;
    size_t n, cap;
    double min, max, sum;
} lengths;

static vm_status lengths_add(lengths *L, double d, vm_error *err) {
    if (L->n == L->cap) {
        vm_status s = vm__grow((void **)&L->len, &L->cap, L->n + 1, sizeof(double), err);
        if (s) return s;
    }
    L->len[L->n++] = d;
    if (d < L->min) L->min = d;
    if (d > L->max) L->max = d;
    L->sum += d;
    return VM_OK;
}

/* Sorts a short list of node ids (insertion sort: a node has a few dozen neighbours). */
static void sort_small(vm_index *a, size_t n) {
    for (size_t i = 1; i < n; i++) {
        vm_index v = a[i];
        size_t j = i;
        while (j > 0 && a[j - 1] > v) {
            a[j] = a[j - 1];
            j--;
        }
        a[j] = v;
    }
}

static int cmp_index(const void *x, const void *y) {
    vm_index a = *(const vm_index *)x, b = *(const vm_index *)y;
    return a < b ? -1 : a > b;
}

vm_status vm_mesh_edge_lengths(const vm_mesh *m, vm_edge_stats *e, vm_error *err) {
    memset(e, 0, sizeof *e);
    const int(*et)[2];
    int ne = edge_table(m->kind, &et), nn = vm_cell_nodes(m->kind);
    if (!ne) return vm_error_set(err, VM_ERR_ARG, "edge lengths: unknown cell kind %d", (int)m->kind);
    vm_status s = vm__check_nodes(m, VM_ERR_ARG, "edge lengths", err);
    if (s) return s;
    size_t np = m->npoints;
    uint32_t *cnt = calloc(np + 1, sizeof *cnt);
    if (!cnt) return vm_error_set(err, VM_ERR_NOMEM, "edge lengths: out of memory");
    for (size_t c = 0; c < m->ncells; c++) {
        const vm_index *cn = m->cells + (size_t)nn * c;
        for (int k = 0; k < ne; k++) {
            vm_index a = cn[et[k][0]], b = cn[et[k][1]];
            if (a == b) continue;
            cnt[a < b ? a : b]++;
        }
    }
    lengths L = {NULL, 0, 0, INFINITY, -INFINITY, 0};
    size_t *off = NULL;
    vm_index *nb = NULL;
    for (size_t v0 = 0; v0 < np && !s;) {
        /* the block v0..v1: as many nodes as fit in BLOCK_ENTRIES (at least one) */
        size_t v1 = v0, total = 0;
        while (v1 < np && (v1 == v0 || total + cnt[v1] <= BLOCK_ENTRIES)) total += cnt[v1++];
        free(off);
        free(nb);
        off = malloc((v1 - v0 + 1) * sizeof *off);
        nb = malloc((total ? total : 1) * sizeof *nb);
        if (!off || !nb) {
            s = vm_error_set(err, VM_ERR_NOMEM, "edge lengths: out of memory");
            break;
        }
        off[0] = 0;
        for (size_t v = v0; v < v1; v++) off[v - v0 + 1] = off[v - v0] + cnt[v];
        for (size_t c = 0; c < m->ncells; c++) {
            const vm_index *cn = m->cells + (size_t)nn * c;
            for (int k = 0; k < ne; k++) {
                vm_index a = cn[et[k][0]], b = cn[et[k][1]];
                if (a == b) continue;
                vm_index lo = a < b ? a : b, hi = a < b ? b : a;
                if ((size_t)lo < v0 || (size_t)lo >= v1) continue;
                nb[off[(size_t)lo - v0]++] = hi;
            }
        }
        /* the fill moved every offset to the next node's start */
        for (size_t v = v1; v > v0; v--) off[v - v0] = off[v - v0 - 1];
        off[0] = 0;
        for (size_t v = v0; v < v1 && !s; v++) {
            vm_index *list = nb + off[v - v0];
            size_t n = off[v - v0 + 1] - off[v - v0];
            if (n < 64)
                sort_small(list, n);
            else
                qsort(list, n, sizeof *list, cmp_index);
            const double *p = m->points + 3 * v;
            for (size_t i = 0; i < n && !s; i++) {
                if (i > 0 && list[i] == list[i - 1]) continue;
                const double *q = m->points + 3 * (size_t)list[i];
                double d = sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) +
                                (p[2] - q[2]) * (p[2] - q[2]));
                s = lengths_add(&L, d, err);
            }
        }
        v0 = v1;
    }
    free(off);
    free(nb);
    free(cnt);
    if (s) {
        free(L.len);
        return s;
    }
    e->edges = L.n;
    if (L.n) {
        e->min = L.min;
        e->max = L.max;
        e->mean = L.sum / (double)L.n;
        e->lo = L.min;
        e->hi = L.max > L.min ? L.max : L.min + 1.0;
        double w = (e->hi - e->lo) / VM_QUALITY_BINS;
        for (size_t i = 0; i < L.n; i++) {
            double d = L.len[i];
            int b = (int)floor((d - e->lo) / w);
            if (b < 0) b = 0;
            if (b >= VM_QUALITY_BINS) b = VM_QUALITY_BINS - 1;
            e->bins[b]++;
        }
    } else {
        e->hi = 1.0;
    }
    free(L.len);
    return VM_OK;
}
