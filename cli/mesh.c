/* cli/mesh.c — `volmesh mesh`: volume in, tetrahedral mesh (and its surface) out; with
 * --labels a segmentation in, one multi-material mesh out (cli/mesh_labels.c); with
 * --elements tri|quad the surface alone, by one of four methods (cli/mesh_surface.c). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "cli.h"

/* --verbose: one line per stage with its wall time, on stderr. */
static double stage_clock(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void stage_done(int verbose, const char *stage, double *t) {
    double now = stage_clock();
    if (verbose) fprintf(stderr, "volmesh: %-8s %8.3f s\n", stage, now - *t);
    *t = now;
}

static const char *mesh_help =
    "usage: volmesh mesh FILE -o OUT.vtu (--iso V | --range A:B | --labels L) [options]\n"
    "\n"
    "Fills the material with tetrahedra (or hexahedra) by dual contouring (LBIE): the material is\n"
    "{f >= V} for --iso, or {A <= f <= B} for --range (either side may be left open:\n"
    "A: or :B). Material touching the volume border is closed by flat faces on the box.\n"
    "Coordinates are physical (spacing, origin and direction of the volume).\n"
    "\n"
    "  -o, --output OUT        mesh file; format from the extension (.vtu: zlib-compressed\n"
    "                          VTK XML with cell data 'region')\n"
    "  --iso V                 material is f >= V\n"
    "  --range A:B             material is A <= f <= B (interval volume)\n"
    "  --invert                with --iso: material is f <= V instead\n"
    "  --labels all|1,3,7      FILE is a label volume (segmentation): one conforming mesh of\n"
    "                          the chosen labels (all: every non-zero label; ranges 2-5\n"
    "                          allowed), each element's region = its label; other labels\n"
    "                          and 0 are background. Materials meet on shared faces. See\n"
    "                          docs/LABELS.md\n"
    "  --min-island N          with --labels: pieces of a label smaller than N voxels (after\n"
    "                          --size) join their most common neighbour (default 1: keep all)\n"
    "  --no-smooth             with --labels: keep the voxel staircase (exact volumes)\n"
    "  --size-per-label L:S,.. with --labels, tets: cells of S voxels inside label L\n"
    "  --size S                cell size in voxels (default 1; S > 1 resamples coarser;\n"
    "                          with --labels: the most frequent label of each S^3 block)\n"
    "  --elements tet|hex|tri|quad\n"
    "                          tetrahedra (default) or hexahedra (one per inside voxel,\n"
    "                          corners on the dual-contouring vertices; with --adaptive\n"
    "                          interior 3^L blocks become one hex, all-hex transitions);\n"
    "                          tri or quad: only the boundary surface, closed and oriented\n"
    "                          outward (see docs/SURFACES.md); -o X.vtu|.stl|.off|.ply|.obj\n"
    "  --method dc|mc|asc|cover  with tri/quad: dc (default) the boundary of the dual-\n"
    "                          contouring mesh (quads: of the hex mesh); mc marching cubes\n"
    "                          with the topology of the trilinear interpolant; asc adaptive\n"
    "                          skeleton climbing; cover disk covering (quad: dc only)\n"
    "  --adaptive              octree cells: large inside, 2x2x2 on simple flat boundary\n"
    "                          (hexes: exact interior cubes merged, the boundary uniform)\n"
    "  --error E               adaptive tets: boundary error in voxels (>= 0, default 0.5;\n"
    "                          hexes: checked, no effect: their boundary is always the\n"
    "                          uniform one); asc, cover: allowed geometric error (> 0, 0.5)\n"
    "  --max-level L           adaptive: largest cell 2^L cells (default 4; hexes: up to L\n"
    "                          levels, hexes of 3^L cells a side where the interior fits);\n"
    "                          asc: largest box 2^L cells\n"
    "  --surface SURF.vtu      also write the boundary triangles\n"
    "  --denoise M             smooth the volume first: bilateral or diffusion (parameters\n"
    "                          from the data; see volmesh denoise for control)\n"
    "  --no-improve            skip the quality pass (tets: edge contraction, flips, smoothing;\n"
    "                          hexes: boundary pillow layer, untangling, smoothing;\n"
    "                          tri --method cover: the pass over the kept-fine triangles)\n"
    ;
static const char *mesh_help2 =
    "  --quality-fields        add per-cell quality arrays (min_dihedral, radius_ratio, ...)\n"
    "  --report REPORT.html    also write the HTML quality report (see volmesh report)\n"
    "  --no-compress           write the VTU without zlib\n"
    "  --deck static           with -o X.inp: a complete static step (bottom fixed, top\n"
    "                          loaded) that CalculiX/ABAQUS solve as is\n"
    "  --order 2               with -o X.inp: quadratic elements (C3D10)\n"
    "  --max-memory SIZE       refuse (exit 2) before reading or meshing when the run would\n"
    "                          need more than SIZE bytes (suffix K, M, G, T: powers of 1024)\n"
    "  --slabs N|auto          tets: mesh by N slabs along z, each read and meshed on its own\n"
    "                          (the same mesh, without the whole volume in memory; the\n"
    "                          quality pass by parts reads the planes each part reaches,\n"
    "                          the one pass below 400 000 tets all of them); auto: the\n"
    "                          fewest slabs whose planes fit in a quarter of --max-memory\n"
    "                          (one slab without it). See docs/ALGORITHMS.md\n"
    "  --json                  print the summary as one JSON object\n"
    "  --quiet                 no progress bar (nor the status line of writing and checking)\n"
    "  --verbose               print the time of each stage (read, denoise, mesh, improve,\n"
    "                          write, check, report) on stderr\n"
    "  raw input: --raw-dims NXxNYxNZ --raw-type T [--raw-endian E] [--raw-spacing S]\n"
    "             [--raw-origin O] [--raw-header N]   (see volmesh info --help)\n"
    "\n"
    "After meshing, a quality pass (edge contraction, flips, optimising smoothing; the\n"
    "boundary stays within half a voxel of the isosurface) raises the worst tets. Prints\n"
    "one summary line: elements, points, boundary Euler characteristic, volume, min/max\n"
    "dihedral angle, slivers, time (with --labels: interfaces kept, and one more line per\n"
    "label with its element count and volume against its voxels). Exit 0 ok, 1 the mesh\n"
    "was written but has inverted elements (only possible with --no-improve), 2 bad input\n"
    "or empty selection (such as a --labels label absent from the volume).\n"
    "With --elements tri|quad the summary line gives faces, points, closed, Euler\n"
    "characteristic, components, self-intersections, min angle, worst aspect ratio, volume\n"
    "and time.\n";

static int parse_range(const char *s, vm_mesh_options *o) {
    const char *colon = strchr(s, ':');
    if (!colon) return vm_cli_fail("--range: '%s' is not A:B (either side may be empty)", s);
    char a[128], b[128];
    size_t la = (size_t)(colon - s);
    if (la >= sizeof a || strlen(colon + 1) >= sizeof b)
        return vm_cli_fail("--range: '%s' is too long", s);
    memcpy(a, s, la);
    a[la] = 0;
    strcpy(b, colon + 1);
    o->has_lo = a[0] != 0;
    o->has_hi = b[0] != 0;
    if (!o->has_lo && !o->has_hi) return vm_cli_fail("--range: give at least one bound (A: or :B)");
    if (o->has_lo && vm_cli_double("--range", a, &o->lo)) return VM_EXIT_INPUT;
    if (o->has_hi && vm_cli_double("--range", b, &o->hi)) return VM_EXIT_INPUT;
    return 0;
}

int vm_cli_report_checked(const vm_mesh *m, const vm_mesh_report *checked,
                          const vm_mesh_stats *st, int json, const char *out) {
    const vm_mesh_report r = *checked;
    if (json) {
        printf("{\"output\": \"%s\", \"elements\": %zu, \"points\": %zu, \"inverted\": %zu, "
               "\"boundary_faces\": %zu, \"boundary_closed\": %s, \"boundary_euler\": %ld, "
               "\"boundary_self_intersections\": %zu, \"components\": %zu, "
               "\"volume\": %.17g, \"min_dihedral\": %.6f, \"max_dihedral\": %.6f, "
               "\"slivers_5\": %zu, \"slivers_10\": %zu, \"min_scaled_jacobian\": %.6f, "
               "\"repaired_points\": %zu, \"seconds\": %.3f}\n",
               out, m->ncells, m->npoints, r.inverted, r.boundary_faces,
               r.boundary_closed ? "true" : "false", r.boundary_euler,
               r.boundary_self_intersections, r.components, r.volume, r.min_dihedral,
               r.max_dihedral, r.slivers_5, r.slivers_10, r.min_scaled_jacobian,
               st ? st->repaired_points : 0, st ? st->seconds : 0.0);
    } else if (m->kind == VM_HEX8) {
        printf("%s: %zu hexes, %zu points, boundary %s (Euler %ld), %zu component%s, volume %.6g, "
               "%zu inverted, min scaled Jacobian %.3f, %.2f s\n",
               out, m->ncells, m->npoints, r.boundary_closed ? "closed" : "OPEN",
               r.boundary_euler, r.components, r.components == 1 ? "" : "s", r.volume,
               r.inverted, r.min_scaled_jacobian, st ? st->seconds : 0.0);
    } else {
        printf("%s: %zu tets, %zu points, boundary %s (Euler %ld), %zu component%s, volume %.6g, "
               "dihedral %.2f..%.2f deg, slivers <5deg %zu <10deg %zu, %.2f s\n",
               out, m->ncells, m->npoints, r.boundary_closed ? "closed" : "OPEN",
               r.boundary_euler, r.components, r.components == 1 ? "" : "s", r.volume,
               r.min_dihedral, r.max_dihedral, r.slivers_5, r.slivers_10,
               st ? st->seconds : 0.0);
    }
    if (r.inverted) {
        /* Written so it can be inspected, but not fit for a solver: say so and exit 1. */
        fprintf(stderr, "volmesh: %s: warning: %zu inverted element%s (without --no-improve "
                "the quality pass untangles them)\n", out, r.inverted,
                r.inverted == 1 ? "" : "s");
        return VM_EXIT_CHECK;
    }
    return VM_EXIT_OK;
}

/* Parses a byte count with an optional K, M, G or T suffix (powers of 1024, "iB"/"B" allowed
 * after it): "4G", "512MiB", "1000000". 0 on success. */
static int parse_bytes(const char *s, double *bytes) {
    char *end = NULL;
    double v = strtod(s, &end);
    if (end == s || !isfinite(v) || v <= 0) return -1;
    double unit = 1;
    switch (*end) {
    case 'K': case 'k': unit = 1024.0; end++; break;
    case 'M': case 'm': unit = 1048576.0; end++; break;
    case 'G': case 'g': unit = 1073741824.0; end++; break;
    case 'T': case 't': unit = 1099511627776.0; end++; break;
    default: break;
    }
    if (strcmp(end, "iB") == 0 || strcmp(end, "B") == 0) end += strlen(end);
    if (*end) return -1;
    *bytes = v * unit;
    return 0;
}

/* Peak memory of a run beyond the volume, from the cells the mesher will see (measured on
 * the sphere phantoms and the CT head, docs/BENCHMARKS.md, rounded up; upper bounds, kept
 * when the mesher's own peak fell to under 100 bytes per tet, 2026-12-02):
 *  - uniform tets: about 5.3 tets per inside cell, ~200 bytes per tet at the peak (the
 *    quality pass included): 1100 bytes per inside cell; hexes: 300 bytes per inside cell;
 *  - adaptive tets: the grid state of the mesher (bit sets of inside points, boundary and
 *    coarse cells, the octree's 4-bit codes while it is built: under 1.5 bytes per cell,
 *    2 here), and up to 9 tets per boundary cell (one with mixed corners) plus 0.05 per
 *    inside cell, at 200 bytes per tet.
 * At cell size S > 1 the counts are those of the resampled grid, estimated as 1/S^3. */
#define MEM_PER_INSIDE_TET 1100.0
#define MEM_PER_INSIDE_HEX 300.0
#define MEM_ADAPTIVE_PER_CELL 2.0
#define MEM_ADAPTIVE_TETS_PER_BOUNDARY 9.0
#define MEM_ADAPTIVE_TETS_PER_INSIDE 0.05
#define MEM_PER_TET 200.0

static int in_range(const vm_mesh_options *o, float f) {
    return (!o->has_lo || f >= o->lo) && (!o->has_hi || f <= o->hi);
}

/* Cells of the padded grid (one cell beyond every face) whose corners are partly in the
 * material: the mesher's boundary cells. */
static size_t boundary_cells(const vm_volume *v, const vm_mesh_options *o) {
    const int64_t *n = v->dims;
    size_t count = 0;
#ifdef _OPENMP
#pragma omp parallel for schedule(static) reduction(+ : count)
#endif
    for (int64_t k = -1; k < n[2]; k++)
        for (int64_t j = -1; j < n[1]; j++)
            for (int64_t i = -1; i < n[0]; i++) {
                int any = 0, all = 1;
                for (int c = 0; c < 8; c++) {
                    int64_t x = i + (c & 1), y = j + ((c >> 1) & 1), z = k + (c >> 2);
                    int in = x >= 0 && y >= 0 && z >= 0 && x < n[0] && y < n[1] && z < n[2] &&
                             in_range(o, v->data[x + n[0] * (y + n[1] * z)]);
                    any |= in;
                    all &= in;
                }
                count += any && !all;
            }
    return count;
}

/* --max-memory: estimates the peak of meshing v and refuses when it exceeds limit. */
static int check_memory(const char *in, const vm_volume *v, const vm_mesh_options *o,
                        int denoise, double limit) {
    size_t n = vm_volume_count(v), inside = 0;
    for (size_t i = 0; i < n; i++)
        inside += in_range(o, v->data[i]);
    double s3 = (double)o->cell_size * o->cell_size * o->cell_size;
    double cells = (double)inside / s3, need = (denoise ? 2.0 : 1.0) * 4.0 * (double)n;
    if (o->adaptive && o->elements == VM_TET4) {
        double grid = 1;
        for (int a = 0; a < 3; a++)
            grid *= (double)(v->dims[a] - 1) / o->cell_size + 3;
        double bnd = (double)boundary_cells(v, o) / (o->cell_size * o->cell_size);
        double tets =
            MEM_ADAPTIVE_TETS_PER_BOUNDARY * bnd + MEM_ADAPTIVE_TETS_PER_INSIDE * cells;
        need += MEM_ADAPTIVE_PER_CELL * grid + MEM_PER_TET * tets;
    } else {
        need += (o->elements == VM_HEX8 ? MEM_PER_INSIDE_HEX : MEM_PER_INSIDE_TET) * cells;
    }
    if (need <= limit) return 0;
    /* MiB below a GiB, so that small limits do not read "0.00 GiB" */
    int gib = limit >= 1073741824.0;
    double unit = gib ? 1073741824.0 : 1048576.0;
    return vm_cli_fail("%s: meshing needs about %.*f %s (%zu voxels in the material), more "
                       "than --max-memory %.*f %s: try --size %d (about 8x less)%s",
                       in, gib ? 2 : 1, need / unit, gib ? "GiB" : "MiB", inside, gib ? 2 : 1,
                       limit / unit, gib ? "GiB" : "MiB", 2 * o->cell_size,
                       o->adaptive ? "" : " or --adaptive");
}

/* --slabs: the planes come from a reader that goes on where the previous slab ended (the
 * mesher reads forward; the quality pass's parts read windows in any order). */
static vm_status read_planes(int64_t z0, int64_t z1, vm_volume *out, void *user,
                             vm_error *err) {
    return vm_volume_reader_read(user, z0, z1, out->data, err);
}

/* The failure of a stage that reads in: a reader's message names the file already, a
 * stage's is given the file's name. */
static int fail_reading(const char *in, const vm_error *err) {
    return strncmp(err->message, in, strlen(in)) == 0 ? vm_cli_fail_err(err)
                                                      : vm_cli_fail("%s: %s", in, err->message);
}

/* --slabs N (0: auto) of in (raw: its description or NULL): meshes slab after slab, each
 * read on its own ([out] m, st). Returns 0, an exit code > 0 after printing why, or -1 when
 * the volume goes in one slab (the caller reads it whole, as without --slabs). */
static int mesh_slabs(const char *in, const vm_raw_options *raw, const vm_mesh_options *o,
                      int n, double max_memory, int verbose, vm_mesh *m, vm_mesh_stats *st,
                      double *t) {
    vm_volume info;
    vm_volume_reader *r = NULL;
    vm_error err;
    vm_error_clear(&err);
    if (vm_volume_reader_open(in, raw, &info, &r, &err)) return vm_cli_fail_err(&err);
    if (n == 0 && max_memory > 0 && info.dims[2] >= 2) {
        /* the planes of a slab within a quarter of the limit: the mesh, the mesher's grid
         * and the quality pass take the rest */
        vm_slab_grid g;
        vm_slab_grid_init(info.dims[2], o, 0, &g);
        double plane = 4.0 * (double)info.dims[0] * (double)info.dims[1];
        n = vm_slab_count_within(&g, (int64_t)(max_memory / 4 / plane));
        if (n == 0) {
            int64_t least = vm_slab_planes_held(&g, (int)g.blocks);
            vm_volume_reader_close(r);
            vm_volume_free(&info);
            return vm_cli_fail(
                "%s: --slabs auto: the thinnest slabs hold %lld planes (%.1f MiB), "
                "more than a quarter of --max-memory (%.1f MiB)",
                in, (long long)least, (double)least * plane / 1048576.0,
                max_memory / 4 / 1048576.0);
        }
        if (verbose)
            fprintf(stderr, "volmesh: --slabs auto: %d slab%s of at most %lld planes\n", n,
                    n == 1 ? "" : "s", (long long)vm_slab_planes_held(&g, n));
    }
    if (n <= 1) {
        vm_volume_reader_close(r);
        vm_volume_free(&info);
        return -1;
    }
    vm_slab_options so = {n, 0, read_planes, r};
    vm_status s = vm_mesh_volume_slabs(&info, o, &so, m, st, &err);
    vm_volume_reader_close(r);
    vm_volume_free(&info);
    if (s) return fail_reading(in, &err);
    stage_done(verbose, "mesh", t);
    return 0;
}

int vm_cmd_mesh(int argc, char **argv) {
    const char *in = NULL, *out = NULL, *surface = NULL;
    int json = 0, quiet = 0, invert = 0, have_iso = 0, have_range = 0, is_raw = 0, compress = 1;
    int improve = 1, improve_parts = 0, quality_fields = 0, verbose = 0, have_labels = 0;
    int surface_elements = 0, have_method = 0, have_error = 0, slabs = 1, have_slabs = 0;
    vm_surface_options so;
    vm_surface_options_default(&so);
    const char *labels_arg = NULL;
    vm_label_size *label_sizes = NULL;
    vm_label_options lo;
    vm_label_options_default(&lo);
    vm_mesh_write_options wo;
    vm_mesh_write_options_init(&wo);
    wo.progress = vm_cli_progress;
    wo.progress_user = &quiet;
    const char *denoise = NULL, *report = NULL;
    double max_memory = 0;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    vm_raw_options raw;
    memset(&raw, 0, sizeof raw);
    raw.type = VM_SCALAR_UINT8;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (vm_cli_is(a, "--help", "-h")) {
            fputs(mesh_help, stdout);
            fputs(mesh_help2, stdout);
            return VM_EXIT_OK;
        }
        int needs = vm_cli_is(a, "-o", "--output") || vm_cli_is(a, "--iso", NULL) ||
                    vm_cli_is(a, "--range", NULL) || vm_cli_is(a, "--size", NULL) ||
                    vm_cli_is(a, "--surface", NULL) || vm_cli_is(a, "--max-level", NULL) ||
                    vm_cli_is(a, "--elements", NULL) || vm_cli_is(a, "--denoise", NULL) ||
                    vm_cli_is(a, "--report", NULL) || vm_cli_is(a, "--deck", NULL) ||
                    vm_cli_is(a, "--order", NULL) || vm_cli_is(a, "--labels", NULL) ||
                    vm_cli_is(a, "--min-island", NULL) || vm_cli_is(a, "--max-memory", NULL) ||
                    vm_cli_is(a, "--size-per-label", NULL) || vm_cli_is(a, "--method", NULL) ||
                    vm_cli_is(a, "--error", NULL) || vm_cli_is(a, "--slabs", NULL) ||
                    vm_cli_is(a, "--improve-parts", NULL);
        if (needs && vm_cli_need_value("mesh", i, argc, argv)) return VM_EXIT_INPUT;
        if (vm_cli_is(a, "-o", "--output")) {
            out = argv[++i];
        } else if (vm_cli_is(a, "--surface", NULL)) {
            surface = argv[++i];
        } else if (vm_cli_is(a, "--iso", NULL)) {
            if (vm_cli_double(a, argv[++i], &o.lo)) return VM_EXIT_INPUT;
            have_iso = 1;
        } else if (vm_cli_is(a, "--range", NULL)) {
            int rc = parse_range(argv[++i], &o);
            if (rc) return rc;
            have_range = 1;
        } else if (vm_cli_is(a, "--size", NULL)) {
            long s;
            if (vm_cli_int(a, argv[++i], 1, 1024, &s)) return VM_EXIT_INPUT;
            o.cell_size = (int)s;
        } else if (vm_cli_is(a, "--elements", NULL)) {
            const char *e = argv[++i];
            if (strcmp(e, "tet") == 0)
                o.elements = VM_TET4;
            else if (strcmp(e, "hex") == 0)
                o.elements = VM_HEX8;
            else if (strcmp(e, "tri") == 0)
                surface_elements = VM_TRI3;
            else if (strcmp(e, "quad") == 0)
                surface_elements = VM_QUAD4;
            else
                return vm_cli_fail("--elements: '%s' is not tet, hex, tri or quad", e);
        } else if (vm_cli_is(a, "--method", NULL)) {
            if (vm_surface_method_parse(argv[++i], &so.method))
                return vm_cli_fail("--method: '%s' is not dc, mc, asc or cover", argv[i]);
            have_method = 1;
        } else if (vm_cli_is(a, "--error", NULL)) {
            if (vm_cli_double(a, argv[++i], &so.error)) return VM_EXIT_INPUT;
            o.error = so.error; /* checked below, once the kind of output is known */
            have_error = 1;
        } else if (vm_cli_is(a, "--labels", NULL)) {
            labels_arg = argv[++i];
            have_labels = 1;
        } else if (vm_cli_is(a, "--min-island", NULL)) {
            long n;
            if (vm_cli_int(a, argv[++i], 1, 2147483647L, &n)) return VM_EXIT_INPUT;
            lo.min_island = (size_t)n;
        } else if (vm_cli_is(a, "--size-per-label", NULL)) {
            free(label_sizes);
            if (vm_cli_parse_label_sizes(argv[++i], &label_sizes, &lo.nsizes))
                return VM_EXIT_INPUT;
            lo.sizes = label_sizes;
        } else if (vm_cli_is(a, "--no-smooth", NULL)) {
            lo.smooth = 0;
        } else if (vm_cli_is(a, "--adaptive", NULL)) {
            o.adaptive = 1;
        } else if (vm_cli_is(a, "--max-level", NULL)) {
            long l;
            if (vm_cli_int(a, argv[++i], 1, 10, &l)) return VM_EXIT_INPUT;
            o.max_level = (int)l;
            so.max_level = (int)l;
        } else if (vm_cli_is(a, "--denoise", NULL)) {
            denoise = argv[++i];
            if (strcmp(denoise, "bilateral") != 0 && strcmp(denoise, "diffusion") != 0)
                return vm_cli_fail("--denoise: '%s' is not bilateral or diffusion", denoise);
        } else if (vm_cli_is(a, "--report", NULL)) {
            report = argv[++i];
        } else if (vm_cli_is(a, "--deck", NULL)) {
            if (strcmp(argv[++i], "static") != 0)
                return vm_cli_fail("--deck: '%s' is not static", argv[i]);
            wo.deck = VM_DECK_STATIC;
        } else if (vm_cli_is(a, "--order", NULL)) {
            long ord;
            if (vm_cli_int(a, argv[++i], 1, 2, &ord)) return VM_EXIT_INPUT;
            wo.order = (int)ord;
        } else if (vm_cli_is(a, "--max-memory", NULL)) {
            if (parse_bytes(argv[++i], &max_memory) || max_memory < 1048576.0)
                return vm_cli_fail("--max-memory: '%s' is not a size of at least 1M (e.g. 4G)",
                                   argv[i]);
        } else if (vm_cli_is(a, "--slabs", NULL)) {
            long n = 0; /* 0: auto */
            if (strcmp(argv[++i], "auto") != 0 && vm_cli_int(a, argv[i], 1, 1 << 20, &n))
                return VM_EXIT_INPUT;
            slabs = (int)n;
            have_slabs = 1;
        } else if (vm_cli_is(a, "--verbose", "-v")) {
            verbose = 1;
        } else if (vm_cli_is(a, "--no-improve", NULL)) {
            improve = 0;
        } else if (vm_cli_is(a, "--improve-parts", NULL)) {
            long n = 0; /* 0: auto */
            if (strcmp(argv[++i], "auto") != 0 && vm_cli_int(a, argv[i], 1, 1 << 16, &n))
                return VM_EXIT_INPUT;
            improve_parts = (int)n;
        } else if (vm_cli_is(a, "--quality-fields", NULL)) {
            quality_fields = 1;
        } else if (vm_cli_is(a, "--invert", NULL)) {
            invert = 1;
        } else if (vm_cli_is(a, "--json", NULL)) {
            json = 1;
        } else if (vm_cli_is(a, "--quiet", "-q")) {
            quiet = 1;
        } else if (vm_cli_is(a, "--no-compress", NULL)) {
            compress = 0;
        } else {
            int r = vm_cli_raw_option(argc, argv, &i, &raw, &is_raw);
            if (r < 0) return VM_EXIT_INPUT;
            if (r > 0) continue;
            if (a[0] == '-' && a[1]) return vm_cli_fail("mesh: unknown option %s", a);
            if (in) return vm_cli_fail("mesh: more than one input file ('%s', '%s')", in, a);
            in = a;
        }
    }
    if (!in) return vm_cli_fail("mesh: no input file (see volmesh mesh --help)");
    if (!out) return vm_cli_fail("mesh: no output file (-o OUT.vtu)");
    if (have_iso + have_range + have_labels != 1)
        return vm_cli_fail("mesh: give exactly one of --iso V, --range A:B or --labels L");
    if (have_labels && denoise) {
        free(label_sizes);
        return vm_cli_fail("mesh: --denoise does not go with --labels");
    }
    if (!have_labels && (lo.min_island != 1 || !lo.smooth || lo.nsizes)) {
        free(label_sizes);
        return vm_cli_fail("mesh: --min-island, --no-smooth and --size-per-label go with --labels");
    }
    char problem[200] = "";
    if (invert && !have_iso)
        snprintf(problem, sizeof problem, "mesh: --invert goes with --iso");
    else if (!surface_elements && have_method)
        snprintf(problem, sizeof problem, "mesh: --method goes with --elements tri or quad");
    else if (have_error && !surface_elements && !o.adaptive)
        snprintf(problem, sizeof problem,
                 "mesh: --error goes with --adaptive or --elements tri|quad");
    else if (have_error && surface_elements && !(so.error > 0))
        snprintf(problem, sizeof problem, "--error: %g must be > 0 (voxels)", so.error);
    else if (have_error && !surface_elements && !(o.error >= 0))
        snprintf(problem, sizeof problem, "--error: %g must be >= 0 (voxels)", o.error);
    else if (surface_elements && (have_labels || o.adaptive || surface || report || wo.deck ||
                                  wo.order != 1))
        snprintf(problem, sizeof problem,
                 "mesh: --elements %s writes a surface: no --labels, --adaptive, --surface, "
                 "--report, --deck or --order",
                 surface_elements == VM_QUAD4 ? "quad" : "tri");
    else if (have_slabs &&
             (have_labels || denoise || surface_elements || o.elements != VM_TET4))
        snprintf(problem, sizeof problem,
                 "mesh: --slabs meshes tetrahedra: not with --labels, --denoise or --elements "
                 "hex|tri|quad");
    if (problem[0]) {
        free(label_sizes);
        return vm_cli_fail("%s", problem);
    }
    if (have_iso && invert) {
        o.has_lo = 0;
        o.has_hi = 1;
        o.hi = o.lo;
    }
    if (is_raw && raw.dims[0] == 0) return vm_cli_fail("%s: raw input needs --raw-dims NXxNYxNZ", in);
    if (max_memory > 0) {
        /* Every large allocation (the volume while reading, the mesher's arrays) checks this
         * limit too, so a run the estimate lets through still stops cleanly. */
        char lim[32];
        snprintf(lim, sizeof lim, "%.0f", max_memory);
        setenv("VOLMESH_MAX_MEMORY", lim, 1);
    }
    int32_t *labels = NULL;
    if (have_labels) {
        int lrc = vm_cli_parse_labels(labels_arg, &labels, &lo.nlabels);
        if (lrc) return lrc;
        lo.labels = labels;
        lo.elements = o.elements;
        lo.cell_size = o.cell_size;
        lo.adaptive = o.adaptive;
        lo.max_level = o.max_level;
    }
    vm_volume v;
    memset(&v, 0, sizeof v);
    vm_mesh m;
    vm_mesh_stats st;
    vm_error err;
    vm_error_clear(&err);
    vm_status s = VM_OK;
    o.progress = vm_cli_progress;
    o.progress_user = &quiet;
    double t = stage_clock();
    int rc = -1;
    vm_volume_reader *planes = NULL; /* --slabs: the quality pass reads its planes from it */
    if (have_slabs) {
        rc = mesh_slabs(in, is_raw ? &raw : NULL, &o, slabs, max_memory, verbose, &m, &st, &t);
        if (rc > 0) return rc;
        /* the quality pass projects onto the isosurface: by parts, each part reads the
         * planes it reaches (v: the header only) */
        if (rc == 0 && improve &&
            vm_volume_reader_open(in, is_raw ? &raw : NULL, &v, &planes, &err) != VM_OK) {
            vm_mesh_free(&m);
            return vm_cli_fail_err(&err);
        }
    }
    if (rc < 0) { /* one slab: the whole volume, as without --slabs */
        rc = vm_cli_read_volume(in, is_raw ? &raw : NULL, &v);
        if (rc) {
            free(labels);
            return rc;
        }
        stage_done(verbose, "read", &t);
        if (have_labels) {
            lo.progress = vm_cli_progress;
            lo.progress_user = &quiet;
            wo.compress = compress;
            rc = vm_cli_mesh_labels(&v, in, out, surface, &lo, &wo, json, quality_fields,
                                    report, improve, verbose);
            free(labels);
            free(label_sizes);
            vm_volume_free(&v);
            return rc;
        }
        if (max_memory > 0 &&
            (rc = check_memory(in, &v, &o, denoise != NULL, max_memory)) != 0) {
            vm_volume_free(&v);
            return rc;
        }
        if (denoise) {
            vm_volume den;
            s = strcmp(denoise, "diffusion") == 0
                    ? vm_denoise_diffusion(&v, 0, 0, 0, &den, vm_cli_progress, &quiet, &err)
                    : vm_denoise_bilateral(&v, 0, 0, &den, vm_cli_progress, &quiet, &err);
            if (s) {
                vm_volume_free(&v);
                return vm_cli_fail("%s: %s", in, err.message);
            }
            vm_volume_free(&v);
            v = den;
            stage_done(verbose, "denoise", &t);
        }
        if (surface_elements) {
            so.lo = o.lo;
            so.hi = o.hi;
            so.has_lo = o.has_lo;
            so.has_hi = o.has_hi;
            so.elements = (vm_cell_kind)surface_elements;
            so.cell_size = o.cell_size;
            so.improve = improve;
            so.progress = vm_cli_progress;
            so.progress_user = &quiet;
            wo.compress = compress;
            rc = vm_cli_mesh_surface(&v, in, out, &so, &wo, json, quality_fields);
            vm_volume_free(&v);
            if (!rc) stage_done(verbose, "surface", &t);
            return rc;
        }
        s = vm_mesh_volume(&v, &o, &m, &st, &err);
        if (!s) stage_done(verbose, "mesh", &t);
        if (s) {
            vm_volume_free(&v);
            /* name the input, the library names the stage */
            return vm_cli_fail("%s: %s", in, err.message);
        }
    }
    vm_improve_report ir;
    int improved = 0;
    if (improve && m.kind == VM_TET4) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        io.lo = o.lo;
        io.hi = o.hi;
        io.has_lo = o.has_lo;
        io.has_hi = o.has_hi;
        io.parts = improve_parts;
        io.progress = vm_cli_progress;
        io.progress_user = &quiet;
        s = planes ? vm_mesh_improve_planes(&m, &v, read_planes, planes, &io, &ir, &err)
                   : vm_mesh_improve(&m, &v, &io, &ir, &err);
        vm_volume_reader_close(planes);
        planes = NULL;
        if (s) {
            vm_volume_free(&v);
            vm_mesh_free(&m);
            return fail_reading(in, &err);
        }
        improved = 1;
        st.seconds += ir.seconds;
        stage_done(verbose, "improve", &t);
    }
    vm_hex_improve_report hr;
    int hex_improved = 0;
    if (improve && m.kind == VM_HEX8) {
        vm_hex_improve_options ho;
        vm_hex_improve_options_default(&ho);
        ho.progress = vm_cli_progress;
        ho.progress_user = &quiet;
        ho.lo = o.lo;
        ho.hi = o.hi;
        ho.has_lo = o.has_lo;
        ho.has_hi = o.has_hi;
        s = vm_mesh_improve_hexes(&m, &v, &ho, &hr, &err);
        if (s) {
            vm_volume_free(&v);
            vm_mesh_free(&m);
            return vm_cli_fail("%s: %s", in, err.message);
        }
        hex_improved = 1;
        st.seconds += hr.seconds;
        stage_done(verbose, "improve", &t);
    }
    vm_volume_free(&v);
    if (quality_fields && (s = vm_mesh_add_quality_fields(&m, NULL, &err)) != VM_OK) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    wo.compress = compress;
    s = vm_mesh_write_as(out, &m, &wo, &err);
    if (!s && surface) {
        vm_mesh surf;
        vm_mesh_write_options sw;
        vm_mesh_write_options_init(&sw);
        sw.progress = vm_cli_progress;
        sw.progress_user = &quiet;
        s = vm_mesh_boundary(&m, &surf, &err);
        if (!s) s = vm_mesh_write_as(surface, &surf, &sw, &err);
        vm_mesh_free(&surf);
    }
    if (s) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    stage_done(verbose, "write", &t);
    vm_mesh_report checked;
    vm_error cerr;
    int checked_ok = vm_mesh_check_with(&m, vm_cli_progress, &quiet, &checked, &cerr) == VM_OK;
    if (!checked_ok) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&cerr);
    }
    stage_done(verbose, "check", &t);
    rc = vm_cli_report_checked(&m, &checked, &st, json, out);
    if (!rc && report) {
        rc = vm_cli_write_report(report, &m, out, &checked, quiet);
        if (!rc) stage_done(verbose, "report", &t);
    }
    if (!rc && improved && !json && ir.unfixed)
        printf("quality pass: %zu tets still below the targets (min dihedral 15, max 150, "
               "ABAQUS); see volmesh quality\n", ir.unfixed);
    if (!rc && hex_improved && !json && hr.below_02_after)
        printf("quality pass: %zu hexes still below scaled Jacobian 0.2 (worst %.3f); see "
               "volmesh quality\n", hr.below_02_after, hr.min_sj_after);
    vm_mesh_free(&m);
    return rc;
}
