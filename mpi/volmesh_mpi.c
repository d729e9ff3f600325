/* SPDX-License-Identifier: BSD-3-Clause */
/* mpi/volmesh_mpi.c — `volmesh_mpi`: one tetrahedral mesh over several MPI ranks, written as
 * a partitioned VTK XML grid (.pvtu + one .vtu piece per rank). Design: docs/MPI.md.
 *
 * Every rank reads only the planes of its slab of cells along z plus a ghost band
 * (vm_volume_read_slab) and meshes them with the ordinary mesher as a cropped volume
 * (vm_mesh_options z_offset, full_nz) in the whole volume's index frame: its grid structures
 * span the crop only, its coordinates are the whole grid's. The mesher's decisions are local
 * (a cell's vertices, splits and octree leaf depend only on samples a few cells away), so
 * away from the ghost band's far edge the rank's tets are bit for bit those of the
 * single-process mesh. Each rank keeps the tets whose centroid lies in its slab; the
 * centroids are computed from the same doubles on both sides of a cut, so every tet is kept
 * by exactly one rank and the pieces meet on identical shared vertices. */
#include "volmesh/volmesh.h"
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { EXIT_OK = 0, EXIT_INPUT = 2 };

static const char *help =
    "usage: mpirun -np N volmesh_mpi (FILE | --phantom NAME[:SIZE]) -o OUT.pvtu\n"
    "                  (--iso V | --range A:B) [options]\n"
    "\n"
    "Meshes the material of a volume with tetrahedra on N MPI ranks: the cells are split into\n"
    "N slabs along z, each rank meshes its slab (plus a ghost band it throws away) and writes\n"
    "OUT_RANK.vtu; rank 0 writes OUT.pvtu naming the pieces. The union of the pieces is the\n"
    "mesh `volmesh mesh --no-improve` makes of the same volume, tet for tet (see "
    "docs/MPI.md).\n"
    "\n"
    "  FILE                    volume file, format from the extension (as volmesh mesh)\n"
    "  --phantom NAME[:SIZE]   a built-in phantom instead (sphere, torus, genus3,\n"
    "                          two-spheres, plate, cut-sphere; SIZE^3, default 48), iso 0\n"
    "  -o, --output OUT.pvtu   partitioned output (the pieces go beside it)\n"
    "  --iso V                 material is f >= V\n"
    "  --range A:B             material is A <= f <= B (either side may be left open)\n"
    "  --size S                cell size in voxels (default 1)\n"
    "  --adaptive              octree cells (slab cuts fall on the coarsest block size)\n"
    "  --error E               adaptive: boundary error in voxels (default 0.5)\n"
    "  --max-level L           adaptive: largest cell 2^L cells (default 4)\n"
    "  --ghost G               ghost band in cells on each side of a slab (default 14, or\n"
    "                          2*2^L + 22 when adaptive)\n"
    "  --improve               the quality pass: on each slab with the vertices it shares\n"
    "                          held fixed, then across each cut on the lower rank; the\n"
    "                          pieces still conform, but are not tet for tet what the\n"
    "                          single-process pass makes (needs a slab per rank and slabs\n"
    "                          a few cells thick)\n"
    "  --balance               slabs of about equal material (a z histogram of the inside\n"
    "                          voxels, each rank reading a share of the planes once more)\n"
    "                          instead of equal numbers of blocks\n"
    "  --no-compress           write the pieces without zlib\n"
    "  --quiet                 no summary line\n"
    "\n"
    "Without --improve no quality pass runs. Prints one line on rank 0: ranks, elements per\n"
    "rank, time of the slowest rank. Exit 0 ok, 2 bad input or a failure on any rank: one\n"
    "line volmesh_mpi: ... from the lowest failing rank (mpirun adds its own notice), and\n"
    "no file is left.\n";

typedef struct args {
    const char *in, *out;
    int phantom;
    vm_phantom_kind kind;
    long phantom_n;
    vm_mesh_options mo;
    int have_bound;
    long ghost;
    int compress, quiet, help, improve, balance;
} args;

/* Messages come from rank 0 only: every rank parses the same arguments and reads the same
 * file, so they fail alike. */
static int rank_, nranks_;
/* --balance: the first block of each rank (nranks_ + 1 entries); NULL: equal numbers. */
static int64_t *cuts_;

static int fail(const char *fmt, const char *a, const char *b) {
    if (rank_ == 0) {
        fputs("volmesh_mpi: ", stderr);
        fprintf(stderr, fmt, a, b ? b : "");
        fputc('\n', stderr);
    }
    return EXIT_INPUT;
}

static int parse_double(const char *opt, const char *s, double *out) {
    char *end;
    double x = strtod(s, &end);
    if (end == s || *end || !isfinite(x)) return fail("%s: '%s' is not a number", opt, s);
    *out = x;
    return 0;
}

static int parse_long(const char *opt, const char *s, long lo, long hi, long *out) {
    char *end;
    long x = strtol(s, &end, 10);
    if (end == s || *end || x < lo || x > hi) {
        char range[64];
        snprintf(range, sizeof range, "%ld..%ld", lo, hi);
        if (rank_ == 0)
            fprintf(stderr, "volmesh_mpi: %s: '%s' is not an integer in %s\n", opt, s, range);
        return EXIT_INPUT;
    }
    *out = x;
    return 0;
}

static int parse_range(const char *s, vm_mesh_options *o) {
    const char *colon = strchr(s, ':');
    if (!colon) return fail("--range: '%s' is not A:B%s", s, NULL);
    char a[128], b[128];
    size_t la = (size_t)(colon - s);
    if (la >= sizeof a || strlen(colon + 1) >= sizeof b)
        return fail("--range: '%s' is too long%s", s, NULL);
    memcpy(a, s, la);
    a[la] = 0;
    strcpy(b, colon + 1);
    o->has_lo = a[0] != 0;
    o->has_hi = b[0] != 0;
    if (!o->has_lo && !o->has_hi) return fail("--range: give at least one bound%s%s", "", NULL);
    if (o->has_lo && parse_double("--range", a, &o->lo)) return EXIT_INPUT;
    if (o->has_hi && parse_double("--range", b, &o->hi)) return EXIT_INPUT;
    return 0;
}

static int parse_args(int argc, char **argv, args *A) {
    memset(A, 0, sizeof *A);
    vm_mesh_options_default(&A->mo);
    A->ghost = -1;
    A->compress = 1;
    A->phantom_n = 48;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            A->help = 1;
            return 0;
        }
        int takes = !strcmp(a, "-o") || !strcmp(a, "--output") || !strcmp(a, "--iso") ||
                    !strcmp(a, "--range") || !strcmp(a, "--size") || !strcmp(a, "--error") ||
                    !strcmp(a, "--max-level") || !strcmp(a, "--ghost") ||
                    !strcmp(a, "--phantom");
        if (takes && i + 1 >= argc) return fail("%s needs a value%s", a, NULL);
        long l;
        if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            A->out = argv[++i];
        } else if (!strcmp(a, "--iso")) {
            if (parse_double(a, argv[++i], &A->mo.lo)) return EXIT_INPUT;
            A->mo.has_lo = 1;
            A->mo.has_hi = 0;
            A->have_bound = 1;
        } else if (!strcmp(a, "--range")) {
            if (parse_range(argv[++i], &A->mo)) return EXIT_INPUT;
            A->have_bound = 1;
        } else if (!strcmp(a, "--size")) {
            if (parse_long(a, argv[++i], 1, 64, &l)) return EXIT_INPUT;
            A->mo.cell_size = (int)l;
        } else if (!strcmp(a, "--adaptive")) {
            A->mo.adaptive = 1;
        } else if (!strcmp(a, "--error")) {
            if (parse_double(a, argv[++i], &A->mo.error)) return EXIT_INPUT;
        } else if (!strcmp(a, "--max-level")) {
            if (parse_long(a, argv[++i], 1, 10, &l)) return EXIT_INPUT;
            A->mo.max_level = (int)l;
        } else if (!strcmp(a, "--ghost")) {
            if (parse_long(a, argv[++i], 1, 1 << 20, &A->ghost)) return EXIT_INPUT;
        } else if (!strcmp(a, "--phantom")) {
            char name[64];
            const char *s = argv[++i], *colon = strchr(s, ':');
            size_t ln = colon ? (size_t)(colon - s) : strlen(s);
            if (ln >= sizeof name) return fail("--phantom: unknown phantom '%s'%s", s, NULL);
            memcpy(name, s, ln);
            name[ln] = 0;
            if (vm_phantom_parse(name, &A->kind))
                return fail("--phantom: unknown phantom '%s'%s", name, NULL);
            if (colon && parse_long("--phantom", colon + 1, 8, 1024, &A->phantom_n))
                return EXIT_INPUT;
            A->phantom = 1;
        } else if (!strcmp(a, "--improve")) {
            A->improve = 1;
        } else if (!strcmp(a, "--balance")) {
            A->balance = 1;
        } else if (!strcmp(a, "--no-compress")) {
            A->compress = 0;
        } else if (!strcmp(a, "--quiet")) {
            A->quiet = 1;
        } else if (a[0] == '-' && a[1]) {
            return fail("unknown option %s (see volmesh_mpi --help)%s", a, NULL);
        } else if (!A->in) {
            A->in = a;
        } else {
            return fail("one input only ('%s' and '%s')", A->in, a);
        }
    }
    if (!A->in && !A->phantom)
        return fail("no input volume (FILE or --phantom NAME)%s%s", "", NULL);
    if (A->in && A->phantom)
        return fail("give FILE or --phantom, not both ('%s')%s", A->in, NULL);
    if (!A->out) return fail("no output: give -o OUT.pvtu%s%s", "", NULL);
    size_t lo = strlen(A->out);
    if (lo < 6 || strcmp(A->out + lo - 5, ".pvtu") != 0)
        return fail("-o %s: the output must end in .pvtu%s", A->out, NULL);
    if (A->phantom && !A->have_bound) {
        A->mo.has_lo = 1;
        A->mo.lo = 0;
        A->have_bound = 1;
    }
    if (!A->have_bound)
        return fail("no material bound: give --iso V or --range A:B%s%s", "", NULL);
    if (A->ghost < 0) A->ghost = (long)vm_slab_default_ghost(&A->mo);
    return 0;
}

/* The whole volume's z axis of nz planes cut into blocks (vm_slab_grid_init). */
static void grid_of(const args *A, int64_t nz, vm_slab_grid *g) {
    vm_slab_grid_init(nz, &A->mo, A->ghost, g);
}

/* This rank's slab of g: its cells, owned z range and planes (the ghost band included):
 * equal numbers of blocks, or the --balance cuts. */
static void rank_slab(const vm_slab_grid *g, vm_slab *s) {
    if (cuts_)
        vm_slab_of_blocks(g, cuts_[rank_], cuts_[rank_ + 1], s);
    else
        vm_slab_part(g, rank_, nranks_, s);
}

static int in_material(const vm_mesh_options *o, float f) {
    return (!o->has_lo || f >= o->lo) && (!o->has_hi || f <= o->hi);
}

/* The weight of plane f (nx * ny voxels; below and above: its neighbour planes, NULL on the
 * volume's border) for --balance, a proxy of its tets: the inside voxels (uniform cells:
 * about 5 tets each; adaptive: about one leaf of 2^L cells each) plus twice the surface
 * (inside voxels with an outside neighbour: boundary cells, more tets each; with the grading
 * around them, almost all of an adaptive mesh). */
static double plane_weight(const vm_mesh_options *o, const float *f, const float *below,
                           const float *above, int64_t nx, int64_t ny) {
    double inside = 0, surface = 0;
    for (int64_t j = 0; j < ny; j++)
        for (int64_t i = 0; i < nx; i++) {
            int64_t at = i + nx * j;
            const float *p = f + at;
            if (!in_material(o, *p)) continue;
            inside++;
            if (i == 0 || j == 0 || i == nx - 1 || j == ny - 1 || !below || !above ||
                !in_material(o, p[-1]) || !in_material(o, p[1]) || !in_material(o, p[-nx]) ||
                !in_material(o, p[nx]) || !in_material(o, below[at]) ||
                !in_material(o, above[at]))
                surface++;
        }
    /* adaptive: a 2^L leaf is a few tets; the grading around the surface is in its share */
    double leaf = o->adaptive ? (double)((int64_t)1 << (3 * o->max_level)) : 1;
    return inside / leaf + 2 * surface;
}

/* --balance: cuts_ from the inside voxels per plane (count[k], the whole volume's nz planes):
 * rank r starts at the first block where the blocks before it hold r/N of the material. */
static vm_status balance_cuts(const args *A, const double *count, int64_t nz, vm_error *err) {
    vm_slab_grid g;
    grid_of(A, nz, &g);
    int64_t blocks = g.blocks, B = g.block;
    double step = g.step;
    cuts_ = malloc((size_t)(nranks_ + 1) * sizeof *cuts_);
    double *w = malloc((size_t)(blocks + 1) * sizeof *w);
    if (!cuts_ || !w) {
        free(w);
        return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    }
    double total = 0;
    for (int64_t b = 0; b < blocks; b++) { /* voxel planes of block b's cells */
        int64_t k0 = (int64_t)floor((double)(b * B) * step);
        int64_t k1 = (int64_t)floor((double)((b + 1) * B) * step);
        if (b == blocks - 1) k1 = nz;
        w[b] = 0;
        for (int64_t k = k0; k < k1 && k < nz; k++)
            w[b] += count[k];
        total += w[b];
    }
    /* the smallest largest slab weight L for which N slabs in order hold every block
     * (bisection; greedy packing: a slab takes blocks while it stays within L), then the cuts
     * of that packing, leaving each later rank a block where there are enough */
    double lo = 0, hi = total;
    for (int64_t b = 0; b < blocks; b++)
        lo = fmax(lo, w[b]);
    for (int it = 0; it < 100 && hi - lo > 1e-9 * total; it++) {
        double L = 0.5 * (lo + hi), load = 0;
        int used = 1;
        for (int64_t b = 0; b < blocks; b++) {
            if (load + w[b] > L) used++, load = 0;
            load += w[b];
        }
        if (used <= nranks_)
            hi = L;
        else
            lo = L;
    }
    int r = 1;
    double load = 0;
    cuts_[0] = 0;
    for (int64_t b = 0; b < blocks; b++) {
        int must = blocks - b <= nranks_ - r; /* as many blocks left as ranks after this */
        if (r < nranks_ && b > cuts_[r - 1] && (load + w[b] > hi || must)) {
            cuts_[r++] = b;
            load = 0;
        }
        load += w[b];
    }
    while (r <= nranks_)
        cuts_[r++] = blocks;
    free(w);
    return VM_OK;
}

/* --balance for a file: every rank reads a share of the planes, counts its inside voxels per
 * plane, and the counts are summed over the ranks. Collective, whatever fails. */
static vm_status balance_file(const args *A, vm_error *err) {
    vm_volume info, slab;
    memset(&slab, 0, sizeof slab);
    vm_status s = vm_volume_read_info(A->in, &info, err);
    int64_t nz = s ? 0 : info.dims[2];
    int64_t nzs[2] = {nz, -nz}, agree[2];
    MPI_Allreduce(nzs, agree, 2, MPI_INT64_T, MPI_MIN, MPI_COMM_WORLD);
    int bad = s != VM_OK || agree[0] != -agree[1] || nz < 2;
    double *count = bad ? NULL : calloc((size_t)nz, sizeof *count);
    double *sum = bad ? NULL : malloc((size_t)nz * sizeof *sum);
    if (!bad && (!count || !sum)) {
        s = vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
        bad = 1;
    }
    int64_t k0 = nz * rank_ / nranks_, k1 = nz * (rank_ + 1) / nranks_; /* and one beyond */
    int64_t r0 = k0 > 0 ? k0 - 1 : 0, r1 = k1 < nz ? k1 + 1 : nz;
    if (!bad && k1 > k0) {
        s = vm_volume_read_slab(A->in, r0, r1, &slab, err);
        if (s) bad = 1;
    }
    if (!bad && slab.data) {
        size_t plane = (size_t)slab.dims[0] * (size_t)slab.dims[1];
        for (int64_t k = k0; k < k1; k++) {
            const float *f = slab.data + (size_t)(k - r0) * plane;
            count[k] = plane_weight(&A->mo, f, k > 0 ? f - plane : NULL,
                                    k < nz - 1 ? f + plane : NULL, slab.dims[0], slab.dims[1]);
        }
    }
    vm_volume_free(&slab);
    int anybad;
    MPI_Allreduce(&bad, &anybad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (!anybad) {
        MPI_Allreduce(count, sum, (int)nz, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
        s = balance_cuts(A, sum, nz, err);
    } else if (!bad) {
        s = VM_ERR_INTERNAL; /* another rank failed: it reads the same file and says why */
    }
    free(count);
    free(sum);
    return s;
}

/* --balance for a whole volume (a phantom): the counts from its planes. */
static vm_status balance_whole(const args *A, const vm_volume *v, vm_error *err) {
    int64_t nz = v->dims[2];
    double *count = calloc((size_t)nz, sizeof *count);
    if (!count) return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    size_t plane = (size_t)v->dims[0] * (size_t)v->dims[1];
    for (int64_t k = 0; k < nz; k++) {
        const float *f = v->data + (size_t)k * plane;
        count[k] = plane_weight(&A->mo, f, k > 0 ? f - plane : NULL,
                                k < nz - 1 ? f + plane : NULL, v->dims[0], v->dims[1]);
    }
    vm_status s = balance_cuts(A, count, nz, err);
    free(count);
    return s;
}

/* This rank's planes lo..hi of the volume (vm_volume_read_slab): [out] v holds just them, with
 * the whole volume's geometry (origin of plane 0), [out] *nz: the whole volume's planes;
 * no data when the rank has no cells. */
static vm_status read_planes(const args *A, vm_volume *v, int64_t *nz, vm_error *err) {
    memset(v, 0, sizeof *v);
    vm_volume info, slab;
    memset(&slab, 0, sizeof slab);
    vm_status s = vm_volume_read_info(A->in, &info, err);
    if (s) return s;
    *nz = info.dims[2];
    vm_slab_grid g;
    vm_slab sl;
    grid_of(A, info.dims[2], &g);
    rank_slab(&g, &sl);
    *v = info;
    if (sl.plane1 <= sl.plane0) return VM_OK;
    s = vm_volume_read_slab(A->in, sl.plane0, sl.plane1, &slab, err);
    if (s) return s;
    v->data = slab.data; /* the frame stays the whole volume's */
    v->dims[2] = slab.dims[2];
    return VM_OK;
}

/* A whole volume cut down to this rank's planes lo..hi (as read_planes reads them). [in,out]
 * v, [out] *nz: the whole volume's planes. */
static vm_status crop_planes(const args *A, vm_volume *v, int64_t *nz, vm_error *err) {
    *nz = v->dims[2];
    vm_slab_grid g;
    vm_slab sl;
    grid_of(A, v->dims[2], &g);
    rank_slab(&g, &sl);
    int64_t lo = sl.plane0, hi = sl.plane1;
    if (lo == 0 && hi == v->dims[2]) return VM_OK;
    size_t plane = (size_t)v->dims[0] * (size_t)v->dims[1], keep = 0;
    if (hi > lo) {
        keep = plane * (size_t)(hi - lo);
        memmove(v->data, v->data + plane * (size_t)lo, keep * sizeof(float));
    }
    float *d = realloc(v->data, (keep ? keep : 1) * sizeof(float));
    if (!d) return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    v->data = d;
    v->dims[2] = hi > lo ? hi - lo : 0;
    return VM_OK;
}

/* The piece name of rank r beside OUT.pvtu: OUT_r.vtu. [out] path (size n). */
static void piece_path(const char *out, int r, char *path, size_t n) {
    size_t base = strlen(out) - 5;
    snprintf(path, n, "%.*s_%d.vtu", (int)base, out, r);
}

static const char *base_name(const char *p) {
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}

/* OUT.pvtu's contents: the non-empty pieces (vm_output_write's callback). */
typedef struct {
    const char *out;
    const unsigned long long *tets;
    int n;
} pvtu_list;

static int pvtu_contents(FILE *fp, void *user, vm_error *err) {
    const pvtu_list *L = user;
    char piece[4096];
    (void)err;
    unsigned one = 1;
    int little = *(unsigned char *)&one == 1;
    fprintf(fp,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" "
            "byte_order=\"%s\" header_type=\"UInt64\">\n"
            "  <PUnstructuredGrid GhostLevel=\"0\">\n"
            "    <PPointData>\n    </PPointData>\n"
            "    <PCellData>\n"
            "      <PDataArray type=\"Int32\" Name=\"region\"/>\n"
            "      <PDataArray type=\"Float64\" Name=\"rank\"/>\n"
            "    </PCellData>\n"
            "    <PPoints>\n"
            "      <PDataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"/>\n"
            "    </PPoints>\n",
            little ? "LittleEndian" : "BigEndian");
    for (int r = 0; r < L->n; r++) {
        if (!L->tets[r]) continue;
        piece_path(base_name(L->out), r, piece, sizeof piece);
        fprintf(fp, "    <Piece Source=\"%s\"/>\n", piece);
    }
    fprintf(fp, "  </PUnstructuredGrid>\n</VTKFile>\n");
    return 0;
}

/* Rank 0: OUT.pvtu listing the non-empty pieces, held (renamed with the pieces at the end). */
static int write_pvtu(const char *out, const unsigned long long *tets, int n) {
    pvtu_list L = {out, tets, n};
    vm_error err;
    vm_error_clear(&err);
    if (vm_output_write(out, pvtu_contents, &L, &err)) return fail("%s%s", err.message, NULL);
    return 0;
}

/* Keeps the tets of m (index space) of odd region (this rank's; even ones belong to other
 * ranks), with their points in world coordinates of frame, as region 1; [out] piece. */
static vm_status own_tets(const vm_mesh *m, const vm_volume *frame, vm_mesh *piece,
                          vm_error *err) {
    vm_mesh_init(piece, VM_TET4);
    vm_index *map = malloc((m->npoints ? m->npoints : 1) * sizeof *map);
    if (!map) return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    for (size_t i = 0; i < m->npoints; i++)
        map[i] = -1;
    vm_status s = VM_OK;
    for (size_t t = 0; t < m->ncells && !s; t++) {
        const vm_index *c = m->cells + 4 * t;
        if (m->region[t] % 2 != 1) continue;
        vm_index nodes[4];
        for (int k = 0; k < 4 && !s; k++) {
            if (map[c[k]] < 0) {
                map[c[k]] = vm_mesh_add_point(piece, m->points + 3 * (size_t)c[k], err);
                if (map[c[k]] < 0) s = VM_ERR_NOMEM;
            }
            nodes[k] = map[c[k]];
        }
        if (!s) s = vm_mesh_add_cell(piece, nodes, 1, err);
    }
    free(map);
    if (s)
        vm_mesh_free(piece);
    else /* world coordinates; a left-handed frame mirrors the tets, as vm_mesh_volume does */
        vm_mesh_index_to_world(piece, frame);
    return s;
}

/* Drops the tets of other slabs (region != 1) without a vertex of an owned tet, and gives
 * each remaining one a region of its own: the quality pass then sees the owned tets and one
 * ring of the neighbours' around them, each ring vertex has tets of two or more regions
 * around it, so it stays fixed, and no operation touches a ring tet (they all need one
 * region; even ids: not this rank's). Points stay (unused ones are left out at the end). */
static vm_status keep_ring(vm_mesh *m, vm_error *err) {
    uint8_t *mine = calloc(m->npoints ? m->npoints : 1, 1);
    if (!mine) return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    for (size_t t = 0; t < m->ncells; t++)
        if (m->region[t] == 1)
            for (int k = 0; k < 4; k++)
                mine[m->cells[4 * t + (size_t)k]] = 1;
    size_t kept = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        if (m->region[t] != 1 && !mine[c[0]] && !mine[c[1]] && !mine[c[2]] && !mine[c[3]])
            continue;
        memmove(m->cells + 4 * kept, c, 4 * sizeof *c);
        m->region[kept] = m->region[t] == 1 ? 1 : (int32_t)(2 + 2 * kept);
        kept++;
    }
    m->ncells = kept;
    free(mine);
    return VM_OK;
}

/* The quality pass on m (index space, v its volume's planes) with every vertex between two
 * regions fixed. Only region 1 is improved: the other tets (each a region of its own, with
 * fixed vertices) cannot change and are kept off the pass's work lists (frozen). With
 * cut != 0 (the first phase) so are the region-1 tets with a vertex on another region: the
 * cut's tets, whose fixed vertices keep most of them from reaching the targets; the second
 * phase improves them across the cut (they are in its bands), and until then they would
 * keep every round of the pass busy for nothing. */
static vm_status improve(const args *A, const vm_volume *v, vm_mesh *m, int cut,
                         vm_error *err) {
    if (!m->ncells) return VM_OK;
    unsigned char *fz = malloc(m->ncells);
    uint8_t *other = cut ? calloc(m->npoints ? m->npoints : 1, 1) : NULL;
    if (!fz || (cut && !other)) {
        free(fz);
        free(other);
        return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    }
    for (size_t t = 0; other && t < m->ncells; t++)
        if (m->region[t] != 1)
            for (int k = 0; k < 4; k++)
                other[m->cells[4 * t + (size_t)k]] = 1;
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        fz[t] = m->region[t] != 1 ||
                (other && (other[c[0]] || other[c[1]] || other[c[2]] || other[c[3]]));
    }
    free(other);
    vm_improve_options io;
    vm_improve_options_default(&io);
    io.lo = A->mo.lo;
    io.hi = A->mo.hi;
    io.has_lo = A->mo.has_lo;
    io.has_hi = A->mo.has_hi;
    io.max_interface_move = 0;
    io.frozen = fz;
    vm_status s = vm_mesh_improve(m, v, &io, NULL, err);
    free(fz);
    return s;
}

/* The quality pass on the tets of region 1 of m only: it runs on them and the one ring of
 * tets around them (their vertices between two regions stay fixed, the ring's tets cannot
 * change), not on the whole of m, whose set-up (figures, stars, qualities, guard) would cost
 * as much as a pass over it; then the improved region-1 tets replace the old ones in m, on
 * the ring's vertices (the same coordinates, matched exactly). */
static vm_status improve_region1(const args *A, const vm_volume *v, vm_mesh *m,
                                 vm_error *err) {
    size_t np = m->npoints, nc = m->ncells;
    vm_index *map = malloc((np ? np : 1) * sizeof *map);
    uint8_t *near = calloc(np ? np : 1, 1);
    vm_mesh sub, out;
    vm_mesh_init(&sub, VM_TET4);
    vm_mesh_init(&out, VM_TET4);
    vm_point_index pm = {0, NULL};
    vm_status s = VM_OK;
    if (!map || !near) {
        s = vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory for --improve");
        goto done;
    }
    for (size_t t = 0; t < nc; t++)
        if (m->region[t] == 1)
            for (int k = 0; k < 4; k++)
                near[m->cells[4 * t + (size_t)k]] = 1;
    for (size_t i = 0; i < np; i++)
        map[i] = -1;
    for (size_t t = 0; t < nc && !s; t++) {
        const vm_index *c = m->cells + 4 * t;
        if (!near[c[0]] && !near[c[1]] && !near[c[2]] && !near[c[3]]) continue;
        vm_index n[4];
        for (int k = 0; k < 4 && !s; k++) {
            if (map[c[k]] < 0) {
                map[c[k]] = vm_mesh_add_point(&sub, m->points + 3 * (size_t)c[k], err);
                if (map[c[k]] < 0) s = VM_ERR_NOMEM;
            }
            n[k] = map[c[k]];
        }
        if (!s) s = vm_mesh_add_cell(&sub, n, m->region[t], err);
    }
    if (!s) s = improve(A, v, &sub, 0, err);
    /* out: m's points and tets but region 1's, then sub's region-1 tets */
    if (!s) s = vm_mesh_reserve(&out, np + sub.npoints, nc + sub.ncells, err);
    if (s) goto done;
    memcpy(out.points, m->points, 3 * np * sizeof(double));
    out.npoints = np;
    for (size_t t = 0; t < nc && !s; t++)
        if (m->region[t] != 1) s = vm_mesh_add_cell(&out, m->cells + 4 * t, m->region[t], err);
    if (!s) s = vm_point_index_build(&pm, out.points, out.npoints, np + sub.npoints, err);
    vm_index *smap = NULL; /* sub's points in out */
    if (!s) {
        smap = malloc((sub.npoints ? sub.npoints : 1) * sizeof *smap);
        if (!smap) s = vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    }
    for (size_t i = 0; smap && i < sub.npoints; i++)
        smap[i] = -1;
    for (size_t t = 0; t < sub.ncells && !s; t++) {
        const vm_index *c = sub.cells + 4 * t;
        if (sub.region[t] != 1) continue;
        vm_index n[4];
        for (int k = 0; k < 4 && !s; k++) {
            if (smap[c[k]] < 0) {
                size_t at;
                const double *x = sub.points + 3 * (size_t)c[k];
                smap[c[k]] = vm_point_index_find(&pm, out.points, x, &at);
                if (smap[c[k]] < 0) {
                    smap[c[k]] = vm_mesh_add_point(&out, x, err);
                    if (smap[c[k]] < 0)
                        s = VM_ERR_NOMEM;
                    else
                        pm.slot[at] = smap[c[k]];
                }
            }
            n[k] = smap[c[k]];
        }
        if (!s) s = vm_mesh_add_cell(&out, n, 1, err);
    }
    free(smap);
    if (!s) {
        vm_mesh_free(m);
        *m = out;
        vm_mesh_init(&out, VM_TET4);
    }
done:
    vm_point_index_free(&pm);
    free(map);
    free(near);
    vm_mesh_free(&sub);
    vm_mesh_free(&out);
    return s;
}

enum { TET_DOUBLES = 13 }; /* 4 corners, then 1 (improve it) or 0 (context) */

/* improve_cuts' marks of a point: on an owned tet (P_OWN), on a tet of the rank below (P_LO)
 * or above (P_HI), within one ring of the shared vertices of the lower (P_S1LO) or upper cut
 * (P_S1HI), on a tet that goes down (P_SENT). */
enum { P_OWN = 1, P_LO = 2, P_HI = 4, P_S1LO = 8, P_S1HI = 16, P_SENT = 32 };
/* ... and of a tet: in the band at the lower (T_BANDLO) or upper cut (T_BANDHI), the lower
 * band's context (T_CTXLO), a copy of a tet of the rank below (T_RING_LO) or above
 * (T_RING_HI). */
enum { T_BANDLO = 1, T_BANDHI = 2, T_CTXLO = 4, T_RING_LO = 8, T_RING_HI = 16 };

/* Marks the owned tets' points and the other tets (the rings of the ranks below and above,
 * told apart by their centroid against this rank's z0). */
static void mark_rings(const vm_mesh *m, double z0, uint8_t *pf, uint8_t *tf) {
    vm_slab below; /* the tets of the ranks below: centroid under this rank's z0 */
    memset(&below, 0, sizeof below);
    below.z0 = -INFINITY;
    below.z1 = z0;
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        uint8_t bit = P_OWN;
        if (m->region[t] != 1) {
            int lower = vm_slab_owns(&below, m, t);
            tf[t] = lower ? T_RING_LO : T_RING_HI;
            bit = lower ? P_LO : P_HI;
        }
        for (int k = 0; k < 4; k++)
            pf[c[k]] |= bit;
    }
}

/* The bands: the owned tets with a vertex within one ring (S1) of a cut's shared vertices,
 * S1 being the shared vertices and their neighbours over owned tets. */
static void mark_bands(const vm_mesh *m, uint8_t *pf, uint8_t *tf) {
    for (int side = 0; side < 2; side++) {
        uint8_t ring = side ? P_HI : P_LO, s1 = side ? P_S1HI : P_S1LO;
        for (size_t t = 0; t < m->ncells; t++) {
            const vm_index *c = m->cells + 4 * t;
            if (m->region[t] != 1) continue;
            int touch = 0;
            for (int k = 0; k < 4; k++)
                touch |= (pf[c[k]] & P_OWN) && (pf[c[k]] & ring);
            if (touch)
                for (int k = 0; k < 4; k++)
                    pf[c[k]] |= s1;
        }
        for (size_t t = 0; t < m->ncells; t++) {
            const vm_index *c = m->cells + 4 * t;
            if (m->region[t] != 1) continue;
            for (int k = 0; k < 4; k++)
                if (pf[c[k]] & s1) tf[t] |= side ? T_BANDHI : T_BANDLO;
        }
    }
}

/* Marks with P_SENT the points of the tets marked with any bit of tmask. */
static void mark_sent_points(const vm_mesh *m, const uint8_t *tf, uint8_t tmask, uint8_t *pf) {
    for (size_t t = 0; t < m->ncells; t++)
        if (tf[t] & tmask)
            for (int k = 0; k < 4; k++)
                pf[m->cells[4 * t + (size_t)k]] |= P_SENT;
}

/* The context of the lower band (the owned tets touching it); returns how many tets go
 * down, band and context. */
static unsigned long long mark_context(const vm_mesh *m, uint8_t *pf, uint8_t *tf) {
    mark_sent_points(m, tf, T_BANDLO, pf);
    unsigned long long nsend = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        const vm_index *c = m->cells + 4 * t;
        if (m->region[t] != 1 || (tf[t] & T_BANDLO)) continue;
        int touch = 0;
        for (int k = 0; k < 4; k++)
            touch |= pf[c[k]] & P_SENT ? 1 : 0;
        if (touch) tf[t] |= T_CTXLO;
    }
    for (size_t t = 0; t < m->ncells; t++)
        if (tf[t] & (T_BANDLO | T_CTXLO)) nsend++;
    return nsend;
}

/* 1 when the upper band touches what goes down: a slab too thin for the two bands to stay
 * apart, which cannot be improved this way. */
static int bands_touch(const vm_mesh *m, uint8_t *pf, const uint8_t *tf) {
    mark_sent_points(m, tf, T_BANDLO, pf);
    mark_sent_points(m, tf, T_CTXLO, pf);
    int thin = 0;
    for (size_t t = 0; t < m->ncells && !thin; t++)
        if (tf[t] & T_BANDHI)
            for (int k = 0; k < 4; k++)
                thin |= pf[m->cells[4 * t + (size_t)k]] & P_SENT;
    return thin;
}

/* The nsend tets that go down, TET_DOUBLES each: corners, then 1 (band) or 0 (context).
 * NULL when out of memory. */
static double *pack_band(const vm_mesh *m, const uint8_t *tf, unsigned long long nsend) {
    double *buf = malloc((size_t)nsend * TET_DOUBLES * sizeof *buf);
    if (!buf) return NULL;
    size_t k = 0;
    for (size_t t = 0; t < m->ncells; t++) {
        if (!(tf[t] & (T_BANDLO | T_CTXLO))) continue;
        double *b = buf + TET_DOUBLES * k++;
        for (int q = 0; q < 4; q++)
            memcpy(b + 3 * q, m->points + 3 * (size_t)m->cells[4 * t + (size_t)q],
                   3 * sizeof(double));
        b[12] = (tf[t] & T_BANDLO) ? 1 : 0;
    }
    return buf;
}

/* Collective: every rank learns whether any could not take part (out of memory, too thin);
 * then each fails, those with a problem saying why, the others secondarily. */
static vm_status agree_on_cuts(int local_ok, int thin, int *secondary, vm_error *err) {
    int flags[2] = {local_ok ? 0 : 1, thin}, any[2];
    MPI_Allreduce(flags, any, 2, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (!any[0] && !any[1]) return VM_OK;
    if (!local_ok)
        return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory for --improve");
    if (thin)
        return vm_error_set(err, VM_ERR_ARG,
                            "--improve: the slab of rank %d is too thin for the quality pass "
                            "across its cuts (use fewer ranks)",
                            rank_);
    *secondary = 1;
    return VM_ERR_INTERNAL;
}

/* Collective: sends this rank's nsend tets (send) down, receives the rank above's ([out]
 * *recv, malloc'd, *nrecv tets; none on the top rank). */
static vm_status exchange_bands(const double *send, unsigned long long nsend, double **recv,
                                unsigned long long *nrecv, vm_error *err) {
    int down = rank_ > 0 ? rank_ - 1 : MPI_PROC_NULL;
    int up = rank_ < nranks_ - 1 ? rank_ + 1 : MPI_PROC_NULL;
    MPI_Sendrecv(&nsend, 1, MPI_UNSIGNED_LONG_LONG, down, 1, nrecv, 1, MPI_UNSIGNED_LONG_LONG,
                 up, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    if (up == MPI_PROC_NULL) *nrecv = 0;
    double *buf = malloc(((size_t)*nrecv * TET_DOUBLES + 1) * sizeof *buf);
    /* the sizes are sent either way; a rank out of memory fails after the exchange */
    MPI_Sendrecv(send, (int)(nsend * TET_DOUBLES), MPI_DOUBLE, down, 2, buf ? buf : NULL,
                 buf ? (int)(*nrecv * TET_DOUBLES) : 0, MPI_DOUBLE, up, 2, MPI_COMM_WORLD,
                 MPI_STATUS_IGNORE);
    *recv = buf;
    if (!buf) return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory for --improve");
    return VM_OK;
}

/* Adds m's tets to m2 but the copies of the upper neighbour's (the received tets replace
 * them): the upper band region 1, every other tet a region of its own from *next, odd when
 * this rank keeps it, even when not. */
static vm_status add_own_tets(const vm_mesh *m, const uint8_t *tf, vm_mesh *m2, int32_t *next,
                              vm_error *err) {
    vm_status s = VM_OK;
    for (size_t t = 0; t < m->ncells && !s; t++) {
        if (tf[t] & T_RING_HI) continue;
        int32_t r;
        if (tf[t] & T_RING_LO)
            r = *next; /* the lower neighbour's: context */
        else if (tf[t] & T_BANDLO)
            r = *next; /* now the lower neighbour's */
        else if (tf[t] & T_BANDHI)
            r = 1; /* improved here */
        else
            r = *next + 1; /* kept as it is */
        if (r != 1) *next += 2;
        s = vm_mesh_add_cell(m2, m->cells + 4 * t, r, err);
    }
    return s;
}

/* Adds the nrecv received tets to m2 on its points where they match exactly: the band
 * region 1, the context a region of its own from *next (even: not kept). */
static vm_status add_received_tets(const double *recv, unsigned long long nrecv, vm_mesh *m2,
                                   int32_t *next, vm_error *err) {
    vm_point_index pm = {0, NULL};
    vm_status s =
        vm_point_index_build(&pm, m2->points, m2->npoints, m2->npoints + 4 * (size_t)nrecv, err);
    for (size_t t = 0; t < (size_t)nrecv && !s; t++) {
        const double *b = recv + TET_DOUBLES * t;
        vm_index n[4];
        for (int q = 0; q < 4 && !s; q++) {
            size_t at;
            n[q] = vm_point_index_find(&pm, m2->points, b + 3 * q, &at);
            if (n[q] < 0) {
                n[q] = vm_mesh_add_point(m2, b + 3 * q, err);
                if (n[q] < 0)
                    s = VM_ERR_NOMEM;
                else
                    pm.slot[at] = n[q];
            }
        }
        int32_t r = b[12] != 0 ? 1 : *next;
        if (r != 1) *next += 2;
        if (!s) s = vm_mesh_add_cell(m2, n, r, err);
    }
    vm_point_index_free(&pm);
    return s;
}

/* The phase-2 mesh ([out] m2, initialised): this rank's points, its tets (add_own_tets),
 * then the received ones. Regions: 1 improved; every other tet its own. */
static vm_status phase2_mesh(const vm_mesh *m, const uint8_t *tf, const double *recv,
                             unsigned long long nrecv, vm_mesh *m2, vm_error *err) {
    size_t np = m->npoints;
    vm_status s = vm_mesh_reserve(m2, np + 4 * (size_t)nrecv, m->ncells + (size_t)nrecv, err);
    if (s) return s;
    memcpy(m2->points, m->points, 3 * np * sizeof(double));
    m2->npoints = np;
    int32_t next = 2;
    s = add_own_tets(m, tf, m2, &next, err);
    if (!s) s = add_received_tets(recv, nrecv, m2, &next, err);
    return s;
}

/* The second quality pass, across the cuts (collective: every rank calls it once). The
 * first pass left the tets at each cut as the mesher made them, their shared vertices
 * fixed. Now each rank r > 0 sends rank r - 1 its "band" (owned tets within two vertex
 * rings of the lower cut) and one ring of context around it, and stops owning the band;
 * rank r - 1 takes the band into its mesh beside its own band at its upper cut, holds
 * everything else fixed (every other tet is a material of its own) and improves the two
 * bands as one material. The context's vertices on the band's rim stay fixed, so the band
 * meets the sender's remaining tets exactly. [in,out] m: this rank's tets (odd region: kept,
 * even: dropped at the end). */
static vm_status improve_cuts(const args *A, const vm_volume *v, vm_mesh *m, double z0,
                              int *secondary, vm_error *err) {
    size_t np = m->npoints, nc = m->ncells;
    uint8_t *pf = calloc(np ? np : 1, 1), *tf = calloc(nc ? nc : 1, 1);
    double *sendbuf = NULL, *recvbuf = NULL;
    unsigned long long nsend = 0, nrecv = 0;
    int local_ok = pf && tf, thin = 0;
    if (local_ok) {
        mark_rings(m, z0, pf, tf);
        mark_bands(m, pf, tf);
        nsend = mark_context(m, pf, tf);
        thin = bands_touch(m, pf, tf);
        if (nsend > (unsigned long long)(INT32_MAX / TET_DOUBLES)) local_ok = 0;
    }
    if (local_ok && !thin && nsend) {
        sendbuf = pack_band(m, tf, nsend);
        if (!sendbuf) local_ok = 0;
    }
    vm_mesh m2;
    vm_mesh_init(&m2, VM_TET4);
    vm_status s = agree_on_cuts(local_ok, thin, secondary, err);
    if (!s) s = exchange_bands(sendbuf, nsend, &recvbuf, &nrecv, err);
    if (!s) s = phase2_mesh(m, tf, recvbuf, nrecv, &m2, err);
    if (!s) s = improve_region1(A, v, &m2, err);
    if (!s) {
        vm_mesh_free(m);
        *m = m2;
        vm_mesh_init(&m2, VM_TET4);
    }
    vm_mesh_free(&m2);
    free(pf);
    free(tf);
    free(sendbuf);
    free(recvbuf);
    return s;
}

/* This rank's slab: the masked volume meshed in index space, each tet marked 1 (owned) or 2
 * (another slab's); with --improve, the first quality pass over the owned tets with the
 * vertices they share with other slabs fixed. [out] m (empty on error), z0, z1: the slab's
 * z range (index space), seconds. VM_ERR_EMPTY: no tets here. */
static vm_status slab_mesh(const args *A, vm_volume *v, int64_t nz, vm_mesh *m, double *z0,
                           double *z1, double *seconds, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    vm_slab_grid g;
    vm_slab sl;
    grid_of(A, nz, &g);
    rank_slab(&g, &sl);
    *z0 = sl.z0;
    *z1 = sl.z1;
    if (A->improve && nranks_ > 1 && g.blocks < nranks_) /* the same answer on every rank */
        return vm_error_set(
            err, VM_ERR_ARG,
            "--improve: %d ranks but only %lld slabs of %lld cells along z (use "
            "at most %lld ranks)",
            nranks_, (long long)g.blocks, (long long)g.block, (long long)g.blocks);
    if (sl.cell1 <= sl.cell0) return VM_ERR_EMPTY; /* more ranks than blocks */
    vm_mesh_options mo = A->mo;
    vm_slab_crop_options(&g, &sl, &mo); /* v holds the slab's planes */
    double frame[9]; /* the file's frame, in which the mesher measures (the lift) */
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            frame[3 * r + c] = v->direction[r][c] * v->spacing[c];
    mo.crop_frame = frame;
    for (int a = 0; a < 3; a++) {
        v->origin[a] = 0;
        v->spacing[a] = 1;
        for (int b = 0; b < 3; b++)
            v->direction[a][b] = a == b;
    }
    double t0 = MPI_Wtime();
    vm_status s = vm_mesh_volume(v, &mo, m, NULL, err);
    if (s) return s;
    /* The quality pass reads v in the mesh's frame: plane 0 of the crop is plane lo. */
    v->origin[2] = (double)mo.z_offset;
    for (size_t t = 0; t < m->ncells; t++)
        m->region[t] = vm_slab_owns(&sl, m, t) ? 1 : 2;
    if (A->improve && nranks_ > 1) {
        /* The other slabs' tets are other materials: a vertex with tets of two around it
         * stays where it is (max_interface_move 0) and no operation mixes materials, so the
         * faces and vertices at the cut stay those the neighbour has. */
        s = keep_ring(m, err);
        if (!s) s = improve(A, v, m, 1, err);
    } else if (A->improve) {
        s = improve(A, v, m, 0, err);
    }
    *seconds = MPI_Wtime() - t0;
    if (s) vm_mesh_free(m);
    return s;
}

/* Writes the kept tets of m (odd regions) in world coordinates of frame to piece_file with
 * a cell field "rank". [out] ntets; VM_ERR_EMPTY when there are none (nothing written). */
static vm_status write_piece(const args *A, const vm_mesh *m, const vm_volume *frame,
                             const char *piece_file, size_t *ntets, vm_error *err) {
    vm_mesh piece;
    vm_status s = own_tets(m, frame, &piece, err);
    if (s) return s;
    *ntets = piece.ncells;
    if (!piece.ncells) {
        vm_mesh_free(&piece);
        return VM_ERR_EMPTY;
    }
    double *rk = malloc(piece.ncells * sizeof *rk);
    if (!rk) {
        vm_mesh_free(&piece);
        return vm_error_set(err, VM_ERR_NOMEM, "volmesh_mpi: out of memory");
    }
    for (size_t t = 0; t < piece.ncells; t++)
        rk[t] = rank_;
    s = vm_mesh_set_field(&piece, 1, "rank", 1, rk, err);
    free(rk);
    if (!s) s = vm_mesh_write_vtu(piece_file, &piece, A->compress, err);
    vm_mesh_free(&piece);
    if (s) *ntets = 0;
    return s;
}

int main(int argc, char **argv) {
    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &nranks_);
    /* a rank's temporary files go when it gets SIGINT or SIGTERM (a batch system's cancel) */
    vm_output_remove_on_signals();
    args A;
    int rc = parse_args(argc, argv, &A);
    if (!rc && A.help) {
        if (rank_ == 0) fputs(help, stdout);
        MPI_Finalize();
        return EXIT_OK;
    }
    if (rc) {
        MPI_Finalize();
        return rc;
    }
    vm_error err;
    vm_error_clear(&err);
    vm_volume v;
    memset(&v, 0, sizeof v);
    vm_status s;
    int64_t nz = 0;
    int secondary = 0; /* failed because another rank did (that one speaks) */
    if (A.phantom) {
        /* made whole; the rank keeps only its planes */
        s = vm_phantom_make(A.kind, (int)A.phantom_n, 0.0, 1, &v, NULL, &err);
        if (!s && A.balance && nranks_ > 1) s = balance_whole(&A, &v, &err);
        if (!s) s = crop_planes(&A, &v, &nz, &err);
    } else {
        s = A.balance && nranks_ > 1 ? balance_file(&A, &err) : VM_OK;
        if (s == VM_ERR_INTERNAL && !err.message[0]) secondary = 1;
        if (!s) s = read_planes(&A, &v, &nz, &err);
    }
    /* the data range of this rank's planes (together they cover the volume), for the
     * message when no rank has material */
    double range[2] = {INFINITY, INFINITY}; /* min and -max, reduced with MPI_MIN */
    if (!s && v.data && v.dims[2] > 0) {
        double a, b;
        vm_volume_stats(&v, &a, &b, NULL);
        if (!isnan(a)) range[0] = a, range[1] = -b;
    }
    char piece_file[4096];
    piece_path(A.out, rank_, piece_file, sizeof piece_file);
    /* the pieces and OUT.pvtu are renamed together once every rank has written its own */
    if (!s) s = vm_output_hold(piece_file, &err);
    if (!s && rank_ == 0) s = vm_output_hold(A.out, &err);
    size_t ntets = 0;
    double secs = 0, z0 = 0, z1 = 0;
    vm_volume frame = v; /* the index-to-world mapping; v itself is meshed in index space */
    frame.data = NULL;
    vm_mesh m;
    vm_mesh_init(&m, VM_TET4);
    if (!s) s = slab_mesh(&A, &v, nz, &m, &z0, &z1, &secs, &err);
    if (A.improve && nranks_ > 1) {
        /* collective: every rank goes through it, whatever happened so far */
        int bad = s && s != VM_ERR_EMPTY, anybad;
        MPI_Allreduce(&bad, &anybad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        if (anybad && !bad) secondary = 1, s = VM_ERR_INTERNAL;
        if (!anybad) {
            double t0 = MPI_Wtime();
            vm_status s2 = improve_cuts(&A, &v, &m, z0, &secondary, &err);
            if (s2) s = s2;
            secs += MPI_Wtime() - t0;
        }
    }
    if (!s) s = write_piece(&A, &m, &frame, piece_file, &ntets, &err);
    vm_mesh_free(&m);
    vm_volume_free(&v);

    /* Outcome: the first rank with a real error speaks for all; empty slabs are fine as long
     * as some rank has tets. */
    int mine = (s && s != VM_ERR_EMPTY && !secondary) ? rank_ : nranks_, first;
    MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    unsigned long long nt = ntets, *all = malloc((size_t)nranks_ * sizeof *all);
    double tmax = 0;
    MPI_Allreduce(&secs, &tmax, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    double all_range[2];
    MPI_Allreduce(range, all_range, 2, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    if (!all) MPI_Abort(MPI_COMM_WORLD, EXIT_INPUT);
    MPI_Allgather(&nt, 1, MPI_UNSIGNED_LONG_LONG, all, 1, MPI_UNSIGNED_LONG_LONG,
                  MPI_COMM_WORLD);
    unsigned long long total = 0;
    for (int r = 0; r < nranks_; r++)
        total += all[r];
    if (first == nranks_ && secondary) first = nranks_ + 1; /* cannot happen: someone failed */
    if (first == nranks_ && total == 0) {
        first = 0; /* every slab empty: the material is empty (a rank's own message would
                      give the data range of its planes only) */
        const char *what = A.phantom ? "--phantom" : A.in;
        double lo = all_range[0], hi = -all_range[1];
        if (rank_ == 0 && A.mo.has_lo && A.mo.lo > hi)
            snprintf(err.message, sizeof err.message,
                     "%s: no voxel >= %g (the data range is %g to %g): choose an isovalue "
                     "below %g",
                     what, A.mo.lo, lo, hi, hi);
        else if (rank_ == 0 && A.mo.has_hi && A.mo.hi < lo)
            snprintf(err.message, sizeof err.message,
                     "%s: no voxel <= %g (the data range is %g to %g)", what, A.mo.hi, lo, hi);
        else if (rank_ == 0)
            snprintf(err.message, sizeof err.message, "%s: no grid point is in the material",
                     what);
    }
    if (first != nranks_) {
        vm_output_discard(); /* leave nothing behind */
        if (rank_ == first) fprintf(stderr, "volmesh_mpi: %s\n", err.message);
        free(all);
        free(cuts_);
        MPI_Finalize();
        return EXIT_INPUT;
    }
    rc = 0;
    if (rank_ == 0) rc = write_pvtu(A.out, all, nranks_);
    MPI_Bcast(&rc, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rc) {
        vm_output_discard();
    } else {
        /* every rank renames its files; when one cannot, the others remove theirs */
        vm_error cerr;
        vm_error_clear(&cerr);
        int bad = vm_output_commit(&cerr) != VM_OK, anybad;
        if (bad) fprintf(stderr, "volmesh_mpi: %s\n", cerr.message);
        MPI_Allreduce(&bad, &anybad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        if (anybad) {
            if (ntets) remove(piece_file);
            if (rank_ == 0) remove(A.out);
            rc = EXIT_INPUT;
        }
    }
    if (!rc && rank_ == 0 && !A.quiet) {
        printf("%s: %d ranks, %llu tets (", A.out, nranks_, total);
        for (int r = 0; r < nranks_; r++)
            printf("%s%llu", r ? " + " : "", all[r]);
        printf("), slowest rank %.3f s\n", tmax);
    }
    free(all);
    free(cuts_);
    MPI_Finalize();
    return rc;
}
