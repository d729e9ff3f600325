/* SPDX-License-Identifier: BSD-3-Clause */
/* io/deck_sets.c — the node sets of the static decks (.inp, .feb): the fixed bottom slab and
 * the loaded top slab along z, with every connected piece held against rigid motion (three
 * nodes not on a line fix a body). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesh_util.h"

static int cmp_i64(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* Sorts v and drops repeats; returns the count left. */
static size_t sort_unique(int64_t *v, size_t n) {
    qsort(v, n, sizeof *v, cmp_i64);
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        if (k == 0 || v[k - 1] != v[i]) v[k++] = v[i];
    return k;
}

/* The static deck's slabs: nodes within this fraction of the z extent of the lowest (fixed)
 * and highest (loaded) z; a piece needs this many fixed nodes (three points not on a line
 * hold a body against rigid motion). */
static const double DECK_SLAB_FRACTION = 0.01;
enum { DECK_MIN_FIXED = 3 };

/* Fixed set: nodes within 1% of the z extent above the lowest z. A piece of the mesh that
 * does not reach that slab (or touches it at fewer than 3 nodes) gets its own lowest slab
 * fixed instead, widened up to its third-lowest node where it holds fewer than 3 (a coarse
 * graded mesh may have one node within 1% of its bottom), so the system is never singular;
 * a piece of fewer than 3 nodes is fixed whole. Loaded set: nodes within 1% of the extent
 * below the highest z. */
vm_status vm__deck_sets(const char *path, const vm_mesh *m, const double *zs,
                        const vm_index *mid, int nmid_per_cell, size_t nnodes,
                        vm__deck_nodes *d, vm_error *err) {
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    size_t *parent = malloc(nnodes * sizeof *parent);
    unsigned char *used = calloc(nnodes, 1);
    double *cmin = malloc(nnodes * sizeof *cmin);
    double(*low)[3] = malloc(nnodes * sizeof *low); /* per piece: its three lowest z */
    size_t *cfix = calloc(nnodes, sizeof *cfix);
    d->fixed = malloc(nnodes * sizeof *d->fixed);
    d->loaded = malloc(nnodes * sizeof *d->loaded);
    d->nfixed = d->nloaded = 0;
    vm_status st = VM_OK;
    if (!parent || !used || !cmin || !low || !cfix || !d->fixed || !d->loaded) {
        st = vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for the deck", path);
        goto done;
    }
    for (size_t i = 0; i < nnodes; i++)
        parent[i] = i;
    for (size_t c = 0; c < m->ncells; c++) {
        size_t r0 = vm__uf_find(parent, (size_t)m->cells[c * nn]);
        used[m->cells[c * nn]] = 1;
        for (size_t k = 1; k < nn + (size_t)nmid_per_cell; k++) {
            size_t v = k < nn ? (size_t)m->cells[c * nn + k]
                              : (size_t)mid[c * (size_t)nmid_per_cell + (k - nn)];
            used[v] = 1;
            size_t r = vm__uf_find(parent, v);
            if (r != r0) parent[r] = r0;
        }
    }
    double zmin = INFINITY, zmax = -INFINITY;
    for (size_t i = 0; i < nnodes; i++)
        if (used[i]) {
            zmin = zs[i] < zmin ? zs[i] : zmin;
            zmax = zs[i] > zmax ? zs[i] : zmax;
        }
    if (zmin > zmax) goto done; /* no cells */
    double slab = DECK_SLAB_FRACTION * (zmax - zmin);
    for (size_t i = 0; i < nnodes; i++)
        cmin[i] = low[i][0] = low[i][1] = low[i][2] = INFINITY;
    for (size_t i = 0; i < nnodes; i++)
        if (used[i]) {
            size_t r = vm__uf_find(parent, i);
            if (zs[i] < cmin[r]) cmin[r] = zs[i];
            if (zs[i] <= zmin + slab) cfix[r]++;
            double z = zs[i];
            for (int k = 0; k < 3; k++)
                if (z < low[r][k]) {
                    double q = low[r][k];
                    low[r][k] = z;
                    z = q;
                }
        }
    /* each piece's own slab: 1% of the extent, or up to its third-lowest node */
    for (size_t i = 0; i < nnodes; i++)
        if (used[i] && vm__uf_find(parent, i) == i && isfinite(low[i][2]))
            cmin[i] = fmax(cmin[i] + slab, low[i][2]) - slab;
    /* cfix of a root: nodes in the global slab; pieces with < 3 use their own slab. */
    for (size_t i = 0; i < nnodes; i++)
        if (used[i]) {
            size_t r = vm__uf_find(parent, i);
            if (cfix[r] >= DECK_MIN_FIXED ? zs[i] <= zmin + slab : zs[i] <= cmin[r] + slab)
                d->fixed[d->nfixed++] = (int64_t)i + 1;
            if (zs[i] >= zmax - slab) d->loaded[d->nloaded++] = (int64_t)i + 1;
        }
    /* Pieces whose own slab still has < 3 nodes are clamped whole. */
    for (size_t i = 0; i < nnodes; i++)
        cfix[i] = 0;
    for (size_t k = 0; k < d->nfixed; k++)
        cfix[vm__uf_find(parent, (size_t)(d->fixed[k] - 1))]++;
    for (size_t i = 0; i < nnodes; i++)
        if (used[i] && cfix[vm__uf_find(parent, i)] < DECK_MIN_FIXED &&
            !(zs[i] <= zmin + slab) && !(zs[i] <= cmin[vm__uf_find(parent, i)] + slab))
            d->fixed[d->nfixed++] = (int64_t)i + 1;
    d->nfixed = sort_unique(d->fixed, d->nfixed);
done:
    free(parent);
    free(used);
    free(cmin);
    free(low);
    free(cfix);
    return st;
}

