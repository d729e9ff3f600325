/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/octree.c — the adaptive octree of interior cells: aligned cubes of 2^l grid cells
 * whose every grid point is in the material, taken as large as allowed and split until
 * neighbouring leaves (sharing a face, an edge or a corner) differ by at most two levels,
 * so element sizes grade (seed 001, LBIE §4.2). Boundary leaves are single cells or the
 * aligned 2x2x2 blocks dual_contour.c merged (their level comes in with the kinds). */
#include "mesher_internal.h"
#include <stdlib.h>
#include <string.h>

static int in_range(const vm__octree *o, const int64_t c[3]) {
    for (int a = 0; a < 3; a++)
        if (c[a] < 0 || c[a] >= o->nc[a]) return 0;
    return 1;
}

int vm__octree_leaf(const vm__octree *o, const int64_t c[3], int64_t origin[3]) {
    if (!in_range(o, c)) return VM_LEAF_NONE;
    int code = vm__octree_get(o, c);
    if (code < VM_OCT_LEVEL) {
        memcpy(origin, c, 3 * sizeof(int64_t));
        return code == VM_OCT_NONE ? VM_LEAF_NONE : VM_LEAF_BOUNDARY;
    }
    int l = code - VM_OCT_LEVEL;
    for (int a = 0; a < 3; a++)
        origin[a] = c[a] & ~(((int64_t)1 << l) - 1);
    return l;
}

static int boundary_level(const vm__octree *o, const int64_t c[3]) {
    return vm__octree_get(o, c) == VM_OCT_COARSE;
}

int64_t vm__octree_size(const vm__octree *o, const int64_t c[3]) {
    int64_t org[3];
    int l = vm__octree_leaf(o, c, org);
    if (l == VM_LEAF_BOUNDARY) return (int64_t)1 << boundary_level(o, c);
    return l >= 0 ? (int64_t)1 << l : 0;
}

int vm__octree_is_vertex(const vm__octree *o, const int64_t p[3]) {
    for (int k = 0; k < 8; k++) {
        int64_t c[3] = {p[0] - (k & 1), p[1] - ((k >> 1) & 1), p[2] - (k >> 2)}, org[3];
        int l = vm__octree_leaf(o, c, org);
        if (l == VM_LEAF_BOUNDARY) {
            l = boundary_level(o, c);
            if (l == 0) return 1;
            for (int a = 0; a < 3; a++)
                org[a] = c[a] & ~(((int64_t)1 << l) - 1);
        }
        if (l < 0) continue;
        int64_t s = (int64_t)1 << l;
        int corner = 1;
        for (int a = 0; a < 3; a++)
            if (p[a] != org[a] && p[a] != org[a] + s) corner = 0;
        if (corner) return 1;
    }
    return 0;
}

/* Level of the leaf holding cell q as seen by a balancing neighbour: boundary cells count
 * as level 0, exterior cells do not count. */
static int neighbour_level(const vm__octree *o, const int64_t q[3]) {
    if (!in_range(o, q)) return 99;
    int code = vm__octree_get(o, q);
    if (code == VM_OCT_NONE) return 99;
    if (code < VM_OCT_LEVEL) return code == VM_OCT_COARSE;
    return code - VM_OCT_LEVEL;
}

vm_status vm__octree_init(vm__octree *o, const int64_t nc[3], vm_error *err) {
    memset(o, 0, sizeof *o);
    memcpy(o->nc, nc, sizeof o->nc);
    o->row = (nc[0] + 1) / 2;
    size_t bytes = (size_t)(o->row * nc[1] * nc[2]);
    o->code = calloc(bytes ? bytes : 1, 1);
    if (!o->code) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    return VM_OK;
}

/* Moves the dense codes into blocks of 8^3 cells: one code per uniform block, a page for
 * the others (cells beyond the grid in a border block count as agreeing). */
static vm_status to_blocks(vm__octree *o, vm_error *err) {
    const int64_t *nc = o->nc;
    for (int a = 0; a < 3; a++)
        o->nb[a] = (nc[a] + 7) / 8;
    int64_t nblocks = o->nb[0] * o->nb[1] * o->nb[2];
    o->block = malloc((size_t)(nblocks ? nblocks : 1) * sizeof *o->block);
    if (!o->block) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    /* first the uniform blocks (entry: the code) and the others (entry: VM_OCT_PAGE) */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t b = 0; b < nblocks; b++) {
        int64_t org[3] = {8 * (b % o->nb[0]), 8 * ((b / o->nb[0]) % o->nb[1]),
                          8 * (b / (o->nb[0] * o->nb[1]))};
        int first = vm__octree_get(o, org), uniform = 1;
        for (int64_t k = org[2]; k < org[2] + 8 && k < nc[2] && uniform; k++)
            for (int64_t j = org[1]; j < org[1] + 8 && j < nc[1] && uniform; j++)
                for (int64_t i = org[0]; i < org[0] + 8 && i < nc[0]; i++)
                    if (vm__octree_get(o, (int64_t[3]){i, j, k}) != first) {
                        uniform = 0;
                        break;
                    }
        o->block[b] = uniform ? (uint32_t)first : VM_OCT_PAGE;
    }
    size_t npages = 0;
    for (int64_t b = 0; b < nblocks; b++)
        if (o->block[b] >= VM_OCT_PAGE) {
            if (npages >= (size_t)UINT32_MAX - VM_OCT_PAGE)
                return vm_error_set(err, VM_ERR_NOMEM, "mesh: octree too large");
            o->block[b] = VM_OCT_PAGE + (uint32_t)npages++;
        }
    o->pages = calloc(npages ? npages : 1, 256);
    if (!o->pages) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t b = 0; b < nblocks; b++) {
        if (o->block[b] < VM_OCT_PAGE) continue;
        uint8_t *pg = o->pages + 256 * (size_t)(o->block[b] - VM_OCT_PAGE);
        int64_t org[3] = {8 * (b % o->nb[0]), 8 * ((b / o->nb[0]) % o->nb[1]),
                          8 * (b / (o->nb[0] * o->nb[1]))};
        for (int64_t k = 0; k < 8 && org[2] + k < nc[2]; k++)
            for (int64_t j = 0; j < 8 && org[1] + j < nc[1]; j++)
                for (int64_t i = 0; i < 8 && org[0] + i < nc[0]; i++) {
                    int code = vm__octree_get(o, (int64_t[3]){org[0] + i, org[1] + j, org[2] + k});
                    size_t in = (size_t)(i + 8 * (j + 8 * k));
                    pg[in / 2] |= (uint8_t)(code << (4 * (in & 1)));
                }
    }
    free(o->code);
    o->code = NULL;
    return VM_OK;
}

/* Neighbouring leaves differ by at most this many levels: 2 keeps nearly all the saving of
 * unbalanced leaves on the shared volumes while bounding size jumps to 4x. */
enum { OCT_GRADE = 2 };
/* Tets of a 2x2x2 leaf per face next to single cells, and next to a leaf of its size or
 * larger (2-4, taken as 3); its eight cells as single cells cost 40 tets. */
enum { LEAF_FACE_FINE = 8, LEAF_FACE_COARSE = 3, CELLS_2X2X2_TETS = 40 };

/* What the per-cell steps of vm__octree_build read and write. */
typedef struct oct_pass {
    vm__octree *o;
    vm__octree *full; /* per cell 1 + the largest l such that the aligned cube of 2^l cells
                       * at origin c is inside (0: not inside), in the layout of o */
    int max_level;
    const uint8_t *keep; /* per aligned 2x2x2 block: whether a 2x2x2 leaf there stays */
    int64_t kb[3];       /* blocks per axis of keep */
} oct_pass;

/* Calls fn on every cell, z layers in parallel (see mesher_internal.h). */
void vm__octree_each_cell(const int64_t nc[3], void (*fn)(void *ctx, const int64_t c[3]),
                          void *ctx) {
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t z = 0; z < nc[2]; z++)
        for (int64_t y = 0; y < nc[1]; y++)
            for (int64_t x = 0; x < nc[0]; x++) {
                int64_t c[3] = {x, y, z};
                fn(ctx, c);
            }
}

/* full at an inside cell: 1 (a cube of one cell). */
static void seed_full(void *ctx, const int64_t c[3]) {
    const oct_pass *P = ctx;
    if (vm__octree_get(P->o, c) == VM_OCT_LEVEL) vm__octree_put(P->full, c, 1);
}

/* Fills P->full: the inside cells, then per level the aligned cubes whose eight halves are
 * inside (each level reads only the one below). */
static void full_levels(const oct_pass *P) {
    const int64_t *nc = P->o->nc;
    vm__octree_each_cell(nc, seed_full, (void *)P);
    for (int l = 1; l <= P->max_level; l++) {
        int64_t s2 = (int64_t)1 << l, h = s2 / 2;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
        for (int64_t z = 0; z < nc[2] - s2 + 1; z += s2)
            for (int64_t y = 0; y + s2 <= nc[1]; y += s2)
                for (int64_t x = 0; x + s2 <= nc[0]; x += s2) {
                    int ok = 1;
                    for (int k = 0; k < 8 && ok; k++) {
                        int64_t c[3] = {x + h * (k & 1), y + h * ((k >> 1) & 1),
                                        z + h * (k >> 2)};
                        ok = vm__octree_get(P->full, c) >= l;
                    }
                    if (ok) vm__octree_put(P->full, (int64_t[3]){x, y, z}, l + 1);
                }
    }
}

/* An inside cell's leaf: the largest inside cube holding it. */
static void pick_leaf(void *ctx, const int64_t c[3]) {
    const oct_pass *P = ctx;
    if (vm__octree_get(P->o, c) != VM_OCT_LEVEL) return;
    int l = P->max_level;
    for (; l > 0; l--) {
        int64_t m = ~(((int64_t)1 << l) - 1), org[3] = {c[0] & m, c[1] & m, c[2] & m};
        if (vm__octree_get(P->full, org) >= l + 1) break;
    }
    vm__octree_put(P->o, c, VM_OCT_LEVEL + l);
}

/* 1 when a cell in the shell round the leaf of 2^l cells at (x, y, z) is in a leaf more than
 * OCT_GRADE levels finer. */
static int needs_split(const vm__octree *o, int64_t x, int64_t y, int64_t z, int l) {
    int64_t sz = (int64_t)1 << l;
    for (int64_t k = -1; k <= sz; k++)
        for (int64_t j = -1; j <= sz; j++)
            for (int64_t i = -1; i <= sz; i++) {
                if (i >= 0 && i < sz && j >= 0 && j < sz && k >= 0 && k < sz) {
                    i = sz - 1; /* skip the inside of the cube */
                    continue;
                }
                int64_t q[3] = {x + i, y + j, z + k};
                if (neighbour_level(o, q) < l - OCT_GRADE) return 1;
            }
    return 0;
}

/* Balance across faces, edges and corners: splits any leaf that touches a leaf more than
 * OCT_GRADE levels finer, until nothing changes. Only leaves above OCT_GRADE can split, and
 * their origins are multiples of 2^(OCT_GRADE+1): the sweep visits just those positions, in
 * the order of a full raster scan, so the result is the same as scanning every cell. */
static void balance(vm__octree *o) {
    const int64_t *nc = o->nc;
    const int64_t step = (int64_t)1 << (OCT_GRADE + 1);
    for (int changed = 1; changed;) {
        changed = 0;
        for (int64_t z = 0; z < nc[2]; z += step)
            for (int64_t y = 0; y < nc[1]; y += step)
                for (int64_t x = 0; x < nc[0]; x += step) {
                    int64_t c[3] = {x, y, z}, org[3];
                    int l = vm__octree_leaf(o, c, org);
                    if (l <= OCT_GRADE || org[0] != x || org[1] != y || org[2] != z) continue;
                    if (!needs_split(o, x, y, z, l)) continue;
                    int64_t sz = (int64_t)1 << l;
                    for (int64_t k = 0; k < sz; k++)
                        for (int64_t j = 0; j < sz; j++)
                            for (int64_t i = 0; i < sz; i++)
                                vm__octree_put(o, (int64_t[3]){x + i, y + j, z + k},
                                               VM_OCT_LEVEL + l - 1);
                    changed = 1;
                }
    }
}

/* Per aligned 2x2x2 block (keep, kb blocks per axis): 0 where a 2x2x2 leaf there costs more
 * tets than its eight cells. */
static void leaf_costs(const vm__octree *o, uint8_t *keep, const int64_t kb[3]) {
    const int64_t *nc = o->nc;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t z = 0; z < nc[2]; z += 2)
        for (int64_t y = 0; y < nc[1]; y += 2)
            for (int64_t x = 0; x < nc[0]; x += 2) {
                size_t bi = (size_t)(x / 2 + kb[0] * (y / 2 + kb[1] * (z / 2)));
                keep[bi] = 1;
                if (vm__octree_get(o, (int64_t[3]){x, y, z}) != VM_OCT_LEVEL + 1) continue;
                int cost = 0;
                for (int f = 0; f < 6; f++) {
                    int64_t q[3] = {x, y, z};
                    q[f >> 1] += (f & 1) ? 2 : -1;
                    int64_t sz = vm__octree_size(o, q);
                    cost += sz == 1 ? LEAF_FACE_FINE : LEAF_FACE_COARSE;
                }
                keep[bi] = cost < CELLS_2X2X2_TETS;
            }
}

/* A cell of a 2x2x2 leaf not kept returns to a single cell. */
static void drop_costly(void *ctx, const int64_t c[3]) {
    const oct_pass *P = ctx;
    if (vm__octree_get(P->o, c) != VM_OCT_LEVEL + 1) return;
    if (!P->keep[c[0] / 2 + P->kb[0] * (c[1] / 2 + P->kb[1] * (c[2] / 2))])
        vm__octree_put(P->o, c, VM_OCT_LEVEL);
}

/* The number of leaves of interior cubes (counted at their origins). */
static size_t count_leaves(const vm__octree *o) {
    const int64_t *nc = o->nc;
    size_t count = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : count)
#endif
    for (int64_t z = 0; z < nc[2]; z++)
        for (int64_t y = 0; y < nc[1]; y++)
            for (int64_t x = 0; x < nc[0]; x++) {
                int code = vm__octree_get(o, (int64_t[3]){x, y, z});
                if (code < VM_OCT_LEVEL) continue;
                int l = code - VM_OCT_LEVEL;
                int64_t m = ((int64_t)1 << l) - 1;
                if (!(x & m) && !(y & m) && !(z & m)) count++;
            }
    return count;
}

/* Builds the leaves of the interior cells (see mesher_internal.h): the largest inside cubes,
 * balanced, then 2x2x2 leaves that cost more tets than their cells returned to cells. */
vm_status vm__octree_build(vm__octree *o, int max_level, size_t *leaves, vm_error *err) {
    const int64_t *nc = o->nc;
    vm__octree full;
    vm_status s = vm__octree_init(&full, nc, err);
    if (s) return s;
    oct_pass P = {.o = o, .full = &full, .max_level = max_level};
    full_levels(&P);
    vm__octree_each_cell(nc, pick_leaf, &P);
    vm__octree_free(&full);
    P.full = NULL;
    balance(o);
    /* A leaf of 2x2x2 cells costs 8 tets on a face next to single cells and 2-4 on a face
     * next to a leaf of its size or larger; its eight cells cost 40. Leaves that would cost
     * more (mostly those with finer neighbours) return to cells. The faces of coarse leaves
     * accept any finer neighbour, so this keeps the mesh conforming. */
    /* keep: one byte per aligned 2x2x2 block (bytes: blocks of different z layers apart) */
    for (int a = 0; a < 3; a++)
        P.kb[a] = (nc[a] + 1) / 2;
    uint8_t *keep = malloc((size_t)(P.kb[0] * P.kb[1] * P.kb[2]) + 1);
    if (!keep) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    leaf_costs(o, keep, P.kb);
    P.keep = keep;
    vm__octree_each_cell(nc, drop_costly, &P);
    free(keep);
    size_t count = count_leaves(o);
    if (leaves) *leaves = count;
    return to_blocks(o, err);
}

void vm__octree_free(vm__octree *o) {
    if (!o) return;
    free(o->code);
    free(o->block);
    free(o->pages);
    o->code = o->pages = NULL;
    o->block = NULL;
}
