/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/soup_mesh.c — a mesher's cell soup (cells over grid-point ids) made into a vm_mesh
 * in world coordinates, shared by vm_mesh_volume and the adaptive hexes' coarse grids
 * (hex_base.c). */
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesher_internal.h"
#include "volmesh/mesher.h"

void vm__mirror_cell(vm_index *c, int nodes) {
    static const int tet_swap[][2] = {{1, 2}}, hex_swap[][2] = {{1, 3}, {5, 7}};
    const int(*sw)[2] = nodes == 8 ? hex_swap : tet_swap;
    for (int q = 0; q < (nodes == 8 ? 2 : 1); q++) {
        vm_index tmp = c[sw[q][0]];
        c[sw[q][0]] = c[sw[q][1]];
        c[sw[q][1]] = tmp;
    }
}

/* The numbers of a soup's used vertices. The used grid points are a bit set with a rank per
 * word (a grid point costs 0.25 bytes, not a 4-byte map entry); map holds the numbers of
 * the used grid points, then of every representative vertex. */
typedef struct vnumber {
    size_t nl, nw;        /* grid points; words of the bit set */
    uint64_t *used_bits;  /* per grid point: used */
    size_t *used_rank;    /* per word: the used grid points before it */
    size_t nused_lattice; /* used grid points */
    int32_t *map;         /* per slot (map_slot): the vertex number, -1 while unused */
} vnumber;

/* Id q of the soup's cells, whichever width the soup keeps them in. */
static int64_t soup_id(const vm__tet_soup *soup, size_t q) {
    return soup->tets32 ? (int64_t)soup->tets32[q] : soup->tets[q];
}

/* The slot in N->map of vertex id. */
static size_t map_slot(const vnumber *N, int64_t id) {
    return (size_t)id < N->nl
               ? N->used_rank[id >> 6] +
                     (size_t)__builtin_popcountll(N->used_bits[id >> 6] &
                                                  (((uint64_t)1 << (id & 63)) - 1))
               : N->nused_lattice + ((size_t)id - N->nl);
}

/* Frees N's arrays. */
static void vnumber_free(vnumber *N) {
    free(N->map);
    free(N->used_bits);
    free(N->used_rank);
    memset(N, 0, sizeof *N);
}

/* Numbers the soup's used vertices in order of first use; *used: how many. */
static vm_status number_vertices(const vm__tet_soup *soup, vnumber *N, size_t *used,
                                 vm_error *err) {
    size_t nid = (size_t)soup->nodes * soup->ntets;
    N->nl = (size_t)soup->nlattice;
    N->nw = N->nl / 64 + 1;
    N->used_bits = calloc(N->nw, sizeof *N->used_bits);
    N->used_rank = malloc(N->nw * sizeof *N->used_rank);
    if (!N->used_bits || !N->used_rank)
        return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    /* (most ids repeat: a bit already set is only read) */
    const ptrdiff_t pid = (ptrdiff_t)nid;
    uint64_t *bits = N->used_bits;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 65536)
#endif
    for (ptrdiff_t q = 0; q < pid; q++) {
        int64_t id = soup_id(soup, (size_t)q);
        if ((size_t)id >= N->nl) continue;
        uint64_t bit = (uint64_t)1 << (id & 63);
        if (!(__atomic_load_n(&bits[id >> 6], __ATOMIC_RELAXED) & bit))
            __atomic_fetch_or(&bits[id >> 6], bit, __ATOMIC_RELAXED);
    }
    N->nused_lattice = 0;
    for (size_t w = 0; w < N->nw; w++) {
        N->used_rank[w] = N->nused_lattice;
        N->nused_lattice += (size_t)__builtin_popcountll(N->used_bits[w]);
    }
    N->map = malloc((N->nused_lattice + soup->nreps + 1) * sizeof *N->map);
    if (!N->map) return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory");
    for (size_t i = 0; i < N->nused_lattice + soup->nreps; i++)
        N->map[i] = -1;
    *used = 0;
    for (size_t q = 0; q < nid; q++) {
        size_t slot = map_slot(N, soup_id(soup, q));
        if (N->map[slot] < 0) N->map[slot] = (int32_t)(*used)++;
    }
    return VM_OK;
}

/* Writes the used vertices' world positions (index position id * step, see
 * vm__soup_to_mesh) into mesh->points, on the threads (each vertex has its own slot). */
static void write_vertices(const vm__tet_soup *soup, const vnumber *N, const vm_volume *v,
                           const int64_t n[3], int64_t z_off, const double step[3],
                           vm_mesh *mesh) {
    const ptrdiff_t pw = (ptrdiff_t)N->nw, pr = (ptrdiff_t)soup->nreps,
                    pl = (ptrdiff_t)soup->nlift;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 1024)
#endif
    for (ptrdiff_t pw_i = 0; pw_i < pw; pw_i++) {
        size_t w = (size_t)pw_i;
        for (uint64_t bits = N->used_bits[w]; bits; bits &= bits - 1) {
            size_t id = 64 * w + (size_t)__builtin_ctzll(bits);
            double ijk[3];
            ijk[0] = (double)(id % (size_t)n[0]) * step[0];
            ijk[1] = (double)((id / (size_t)n[0]) % (size_t)n[1]) * step[1];
            ijk[2] = (double)((int64_t)(id / (size_t)(n[0] * n[1])) + z_off) * step[2];
            vm_volume_index_to_world(
                v, ijk, mesh->points + 3 * (size_t)N->map[map_slot(N, (int64_t)id)]);
        }
    }
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t pr_i = 0; pr_i < pr; pr_i++) {
        size_t r = (size_t)pr_i;
        if (N->map[N->nused_lattice + r] < 0) continue;
        double ijk[3];
        for (int a = 0; a < 3; a++)
            ijk[a] = soup->rep_pos[3 * r + a] * step[a];
        vm_volume_index_to_world(v, ijk,
                                 mesh->points + 3 * (size_t)N->map[N->nused_lattice + r]);
    }
    /* grid points moved off the grid (each once) */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (ptrdiff_t pl_i = 0; pl_i < pl; pl_i++) {
        size_t k = (size_t)pl_i;
        int64_t id = soup->lift_id[k];
        if ((size_t)id >= N->nl || !((N->used_bits[id >> 6] >> (id & 63)) & 1)) continue;
        double ijk[3];
        for (int a = 0; a < 3; a++)
            ijk[a] = soup->lift_pos[3 * k + a] * step[a];
        vm_volume_index_to_world(v, ijk, mesh->points + 3 * (size_t)N->map[map_slot(N, id)]);
    }
}

/* The cells take over the soup's buffer, each id replaced by its number in place (the soup
 * and the cells are never both whole in memory): forward when a number is no wider than an
 * id (it lands at or below every id still to be read), backward when wider. */
static vm_status take_cells(vm__tet_soup *soup, const vnumber *N, vm_mesh *mesh,
                            vm_error *err) {
    size_t nn = (size_t)soup->nodes, nid = nn * soup->ntets;
    int narrow = soup->tets32 != NULL;
    size_t isz = narrow ? sizeof(uint32_t) : sizeof(int64_t), osz = sizeof(vm_index);
    unsigned char *buf = narrow ? (unsigned char *)soup->tets32 : (unsigned char *)soup->tets;
    soup->tets = NULL;
    soup->tets32 = NULL;
    if (nid && osz > isz) {
        unsigned char *wider = realloc(buf, nid * osz);
        if (!wider) {
            free(buf);
            return vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for %zu cells",
                                (size_t)(nid / nn));
        }
        buf = wider;
    }
    mesh->cells = (vm_index *)buf;
    mesh->cell_cap = soup->ntets;
    if (osz == isz) { /* each id in its own place: on the threads */
        const ptrdiff_t pid = (ptrdiff_t)nid;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 65536)
#endif
        for (ptrdiff_t k = 0; k < pid; k++) {
            int64_t id;
            if (isz == sizeof(uint32_t)) {
                uint32_t x;
                memcpy(&x, buf + isz * (size_t)k, sizeof x);
                id = (int64_t)x;
            } else {
                memcpy(&id, buf + isz * (size_t)k, sizeof id);
            }
            vm_index c = (vm_index)N->map[map_slot(N, id)];
            memcpy(buf + osz * (size_t)k, &c, sizeof c);
        }
        return VM_OK;
    }
    for (size_t k = 0; k < nid; k++) {
        size_t q = osz <= isz ? k : nid - 1 - k;
        int64_t id;
        if (isz == sizeof(uint32_t)) {
            uint32_t x;
            memcpy(&x, buf + isz * q, sizeof x);
            id = (int64_t)x;
        } else {
            memcpy(&id, buf + isz * q, sizeof id);
        }
        vm_index c = (vm_index)N->map[map_slot(N, id)];
        memcpy(buf + osz * q, &c, sizeof c);
    }
    if (nid && osz < isz) {
        vm_index *fit = realloc(buf, nid * osz);
        if (fit) mesh->cells = fit;
    }
    return VM_OK;
}

/* The mesh of soup's cells (see mesher_internal.h). */
vm_status vm__soup_to_mesh(vm__tet_soup *soup, const vm_volume *v, const int64_t n[3],
                           int64_t z_off, const double step[3], vm_mesh *mesh, vm_error *err) {
    vnumber N;
    memset(&N, 0, sizeof N);
    size_t nn = (size_t)soup->nodes, used = 0;
    vm_status s = number_vertices(soup, &N, &used, err);
    if (!s) s = vm_mesh_reserve(mesh, used, 0, err);
    if (!s) {
        mesh->npoints = used;
        write_vertices(soup, &N, v, n, z_off, step, mesh);
        s = take_cells(soup, &N, mesh, err);
    }
    vnumber_free(&N);
    free(soup->rep_pos);
    soup->rep_pos = NULL;
    free(soup->lift_id);
    free(soup->lift_pos);
    soup->lift_id = NULL;
    soup->lift_pos = NULL;
    if (!s) {
        mesh->region = malloc((soup->ntets ? soup->ntets : 1) * sizeof *mesh->region);
        if (!mesh->region)
            s = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for %zu cells",
                             soup->ntets);
    }
    if (!s) {
        /* A left-handed frame mirrors every element: swap nodes so volumes stay positive. */
        int flip = vm_volume_frame_determinant(v) < 0;
        const ptrdiff_t pt = (ptrdiff_t)soup->ntets;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 65536)
#endif
        for (ptrdiff_t t = 0; t < pt; t++) {
            if (flip) vm__mirror_cell(mesh->cells + nn * (size_t)t, (int)nn);
            mesh->region[t] = 1;
        }
        mesh->ncells = soup->ntets;
    }
    free(soup->tets);
    free(soup->tets32);
    memset(soup, 0, sizeof *soup);
    if (s) vm_mesh_free(mesh);
    return s;
}
