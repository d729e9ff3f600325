/* mesher/octree.c — the adaptive octree of interior cells: aligned cubes of 2^l grid cells
 * whose every grid point is in the material, taken as large as allowed and split until
 * neighbouring leaves (sharing a face, an edge or a corner) differ by at most two levels,
 * so element sizes grade (seed 001, LBIE §4.2). Boundary leaves are single cells or the
 * aligned 2x2x2 blocks dual_contour.c merged (their level comes in with the kinds). */
#include "mesher_internal.h"
#include <stdlib.h>
#include <string.h>

static int64_t cell_index(const vm__octree *o, const int64_t c[3]) {
    return c[0] + o->nc[0] * (c[1] + o->nc[1] * c[2]);
}

static int in_range(const vm__octree *o, const int64_t c[3]) {
    for (int a = 0; a < 3; a++)
        if (c[a] < 0 || c[a] >= o->nc[a]) return 0;
    return 1;
}

int vm__octree_leaf(const vm__octree *o, const int64_t c[3], int64_t origin[3]) {
    if (!in_range(o, c)) return VM_LEAF_NONE;
    int l = o->lvl[cell_index(o, c)];
    if (l < 0) {
        memcpy(origin, c, 3 * sizeof(int64_t));
        return l;
    }
    for (int a = 0; a < 3; a++)
        origin[a] = c[a] & ~(((int64_t)1 << l) - 1);
    return l;
}

static int boundary_level(const vm__octree *o, const int64_t c[3]) {
    return o->blvl ? o->blvl[cell_index(o, c)] : 0;
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
    int l = o->lvl[cell_index(o, q)];
    if (l == VM_LEAF_BOUNDARY) return boundary_level(o, q);
    if (l < 0) return 99;
    return l;
}

vm_status vm__octree_build(vm__octree *o, const int64_t nc[3], const uint8_t *kind,
                           int8_t *blevel, int max_level, size_t *leaves, vm_error *err) {
    memset(o, 0, sizeof *o);
    memcpy(o->nc, nc, sizeof o->nc);
    size_t n = (size_t)(nc[0] * nc[1] * nc[2]);
    o->lvl = malloc(n ? n : 1);
    int8_t *full = malloc(n ? n : 1);
    o->blvl = blevel;
    if (!o->lvl || !full) {
        free(full);
        vm__octree_free(o);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    }
    /* full[c] = largest l such that the aligned cube of 2^l cells at origin c is inside */
    /* Every loop over cells below reads and writes disjoint cells per z layer (or per
     * level, reading the level below): parallel and the same for any thread count. */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (size_t i = 0; i < n; i++)
        full[i] = kind[i] == VM_KIND_INTERIOR ? 0 : -1;
    for (int l = 1; l <= max_level; l++) {
        int64_t s = (int64_t)1 << l, h = s / 2;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
        for (int64_t z = 0; z < nc[2] - s + 1; z += s)
            for (int64_t y = 0; y + s <= nc[1]; y += s)
                for (int64_t x = 0; x + s <= nc[0]; x += s) {
                    int ok = 1;
                    for (int k = 0; k < 8 && ok; k++) {
                        int64_t c[3] = {x + h * (k & 1), y + h * ((k >> 1) & 1),
                                        z + h * (k >> 2)};
                        ok = full[cell_index(o, c)] >= l - 1;
                    }
                    if (ok) {
                        int64_t c[3] = {x, y, z};
                        full[cell_index(o, c)] = (int8_t)l;
                    }
                }
    }
    /* leaves: the largest inside cube holding each cell */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t z = 0; z < nc[2]; z++)
        for (int64_t y = 0; y < nc[1]; y++)
            for (int64_t x = 0; x < nc[0]; x++) {
                int64_t c[3] = {x, y, z};
                size_t ci = (size_t)cell_index(o, c);
                if (kind[ci] != VM_KIND_INTERIOR) {
                    o->lvl[ci] = kind[ci] == VM_KIND_BOUNDARY ? VM_LEAF_BOUNDARY : VM_LEAF_NONE;
                    continue;
                }
                int l = max_level;
                for (; l > 0; l--) {
                    int64_t m = ~(((int64_t)1 << l) - 1), org[3] = {x & m, y & m, z & m};
                    if (full[cell_index(o, org)] >= l) break;
                }
                o->lvl[ci] = (int8_t)l;
            }
    free(full);
    /* Balance across faces, edges and corners: split any leaf that touches a leaf more than
     * `grade` levels finer, until nothing changes. */
    /* Neighbouring leaves differ by at most `grade` levels: 2 keeps nearly all the saving of
     * unbalanced leaves on the shared volumes while bounding size jumps to 4x. */
    /* Only leaves above `grade` can split, and their origins are multiples of
     * 2^(grade+1): the sweep visits just those positions, in the order of a full raster
     * scan, so the result is the same as scanning every cell. */
    const int grade = 2;
    const int64_t step = (int64_t)1 << (grade + 1);
    for (int changed = 1; changed;) {
        changed = 0;
        for (int64_t z = 0; z < nc[2]; z += step)
            for (int64_t y = 0; y < nc[1]; y += step)
                for (int64_t x = 0; x < nc[0]; x += step) {
                    int64_t c[3] = {x, y, z}, org[3];
                    int l = vm__octree_leaf(o, c, org);
                    if (l <= grade || org[0] != x || org[1] != y || org[2] != z) continue;
                    int64_t s = (int64_t)1 << l;
                    int split = 0;
                    for (int64_t k = -1; k <= s && !split; k++)
                        for (int64_t j = -1; j <= s && !split; j++)
                            for (int64_t i = -1; i <= s && !split; i++) {
                                if (i >= 0 && i < s && j >= 0 && j < s && k >= 0 && k < s) {
                                    i = s - 1; /* skip the inside of the cube */
                                    continue;
                                }
                                int64_t q[3] = {x + i, y + j, z + k};
                                if (neighbour_level(o, q) < l - grade) split = 1;
                            }
                    if (!split) continue;
                    for (int64_t k = 0; k < s; k++)
                        for (int64_t j = 0; j < s; j++)
                            for (int64_t i = 0; i < s; i++) {
                                int64_t q[3] = {x + i, y + j, z + k};
                                o->lvl[cell_index(o, q)] = (int8_t)(l - 1);
                            }
                    changed = 1;
                }
    }
    /* A leaf of 2x2x2 cells costs 8 tets on a face next to single cells and 2-4 on a face
     * next to a leaf of its size or larger; its eight cells cost 40. Leaves that would cost
     * more (mostly those with finer neighbours) return to cells. The faces of coarse leaves
     * accept any finer neighbour, so this keeps the mesh conforming. */
    int8_t *keep = malloc(n ? n : 1);
    if (!keep) {
        vm__octree_free(o);
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for the octree");
    }
    /* keep is set, and later read, only at the origins of 2x2x2 leaves (even positions) */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t z = 0; z < nc[2]; z += 2)
        for (int64_t y = 0; y < nc[1]; y += 2)
            for (int64_t x = 0; x < nc[0]; x += 2) {
                size_t ci = (size_t)cell_index(o, (int64_t[3]){x, y, z});
                keep[ci] = 1;
                if (o->lvl[ci] != 1) continue;
                int cost = 0;
                for (int f = 0; f < 6; f++) {
                    int64_t q[3] = {x, y, z};
                    q[f >> 1] += (f & 1) ? 2 : -1;
                    int64_t sz = vm__octree_size(o, q);
                    cost += sz == 1 ? 8 : 3;
                }
                keep[ci] = cost < 40;
            }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static)
#endif
    for (int64_t z = 0; z < nc[2]; z++)
        for (int64_t y = 0; y < nc[1]; y++)
            for (int64_t x = 0; x < nc[0]; x++) {
                size_t ci = (size_t)cell_index(o, (int64_t[3]){x, y, z});
                if (o->lvl[ci] != 1) continue;
                if (!keep[cell_index(o, (int64_t[3]){x & ~1, y & ~1, z & ~1})]) o->lvl[ci] = 0;
            }
    free(keep);
    size_t count = 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static) reduction(+ : count)
#endif
    for (int64_t z = 0; z < nc[2]; z++)
        for (int64_t y = 0; y < nc[1]; y++)
            for (int64_t x = 0; x < nc[0]; x++) {
                int l = o->lvl[cell_index(o, (int64_t[3]){x, y, z})];
                int64_t m = ((int64_t)1 << (l > 0 ? l : 0)) - 1;
                if (l >= 0 && !(x & m) && !(y & m) && !(z & m)) count++;
            }
    if (leaves) *leaves = count;
    return VM_OK;
}

void vm__octree_free(vm__octree *o) {
    if (!o) return;
    free(o->lvl);
    free(o->blvl);
    o->lvl = NULL;
    o->blvl = NULL;
}
