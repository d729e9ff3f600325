/* tests/mesher/test_mesh_hexes_adaptive.c — the 3-refinement transition templates for
 * adaptive hexahedra (mesher/hex_templates.c, issue #5): every template fills its block with
 * valid hexes, and blocks classified from shared corner marks meet conformingly around a
 * refined box (no hanging node, closed boundary, exact volume); and the adaptive hex mesher
 * (mesher/dc_hex_adaptive.c, which makes its transitions by pillowing instead: see
 * docs/ALGORITHMS.md, "Adaptive hexahedra") on the phantoms. */
#include "../../mesher/hex_templates.h"
#include "hex_checks.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static double hex_volume(int c[8][3]) {
    /* six tetrahedra through the diagonal 0-6: exact for planar faces, and the blocks'
     * non-planar faces cancel between neighbours, so only the sum is checked */
    static const int tets[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                   {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    double v = 0;
    for (int t = 0; t < 6; t++) {
        double e[3][3];
        for (int j = 0; j < 3; j++)
            for (int a = 0; a < 3; a++)
                e[j][a] = c[tets[t][j + 1]][a] - c[tets[t][0]][a];
        v += (e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
              e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
              e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0])) /
             6.0;
    }
    return v;
}

/* Every template under each of its symmetries: only valid hexes (positive scaled Jacobian
 * at all eight corners), integer corners inside the block, filling it (volume 9^3) — and
 * the classification finds the symmetry it was given. */
static void hexTemplatesFillTheirBlockWithValidHexes(void) {
    static const struct {
        vm__hex_template t;
        size_t count;
        unsigned canon_marks;
        double min_sj; /* worst corner over all symmetries (exact: 1/3 and 1/5) */
    } cases[] = {{VM_HT_PLAIN, 1, 0x00, 1.0},
                 {VM_HT_EDGE, 5, 0x03, 1.0 / 3},
                 {VM_HT_FACE, 13, 0x0f, 0.2},
                 {VM_HT_FULL, 27, 0xff, 1.0}};
    int hexes[VM_HT_MAX_HEXES][8][3];
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        double worst = 1;
        for (int s = 0; s < 48; s++) {
            size_t n = vm__hex_template_hexes(cases[c].t, s, hexes);
            CHECK(n == cases[c].count);
            double vol = 0;
            for (size_t h = 0; h < n; h++) {
                double p[8][3];
                for (int k = 0; k < 8; k++)
                    for (int a = 0; a < 3; a++) {
                        CHECK(hexes[h][k][a] >= 0 && hexes[h][k][a] <= VM_HT_SIDE);
                        p[k][a] = hexes[h][k][a];
                    }
                double q = vm__hex_template_min_sj(p);
                if (q < worst) worst = q;
                vol += hex_volume(hexes[h]);
            }
            CHECK_NEAR(vol, 729.0, 1e-9);
        }
        printf("  template %d: %zu hexes, worst scaled Jacobian %.4f\n", (int)cases[c].t,
               cases[c].count, worst);
        CHECK_MSG(worst > 0 && worst >= cases[c].min_sj - 1e-9, "template %d: %.4f",
                  (int)cases[c].t, worst);
    }
    /* every single split edge and every face is recognised */
    int sym;
    for (unsigned c = 0; c < 8; c++)
        for (unsigned b = 1; b < 8; b <<= 1)
            if (!(c & b))
                CHECK(vm__hex_template_classify(1u << c | 1u << (c | b), &sym) == VM_HT_EDGE);
    static const unsigned faces[6] = {0x55, 0xaa, 0x33, 0xcc, 0x0f, 0xf0};
    for (int f = 0; f < 6; f++)
        CHECK(vm__hex_template_classify(faces[f], &sym) == VM_HT_FACE);
    /* isolated marks split nothing */
    CHECK(vm__hex_template_classify(0x81, &sym) == VM_HT_PLAIN);
    CHECK(vm__hex_template_classify(0x06, &sym) == VM_HT_PLAIN);
    CHECK(vm__hex_template_classify(0xff, &sym) == VM_HT_FULL);
}

/* What the templates cannot do, the reason the adaptive hex mesher is not built: a block with
 * two or three refined faces (a convex edge or corner of the coarse region, unavoidable
 * around a coarse interior) or two split edges. */
static void hexTemplatesRejectTwoRefinedFaces(void) {
    int sym;
    CHECK(vm__hex_template_classify(0x0f | 0x33, &sym) == VM_HT_UNSUPPORTED); /* z=0, y=0 */
    CHECK(vm__hex_template_classify(0x7f, &sym) == VM_HT_UNSUPPORTED);        /* three */
    CHECK(vm__hex_template_classify(0x07, &sym) == VM_HT_UNSUPPORTED);        /* two edges */
    CHECK(vm__hex_template_classify(0x33 | 0xcc, &sym) == VM_HT_FULL);
    int hexes[VM_HT_MAX_HEXES][8][3];
    CHECK(vm__hex_template_hexes(VM_HT_UNSUPPORTED, 0, hexes) == 0);
}

/* A B^3 grid of coarse blocks with a refined box of blocks inside (27 cubes each); every
 * other block is filled by the template of its corner marks (a corner is marked when a
 * refined block touches it). The result must be one conforming hex mesh of the cube. */
static void refinedBoxInCoarseGrid(int B, const int lo[3], const int hi[3], size_t expect) {
    int G = B * VM_HT_SIDE + 1;
    size_t ng = (size_t)G * (size_t)G * (size_t)G;
    int32_t *id = malloc(ng * sizeof *id);
    CHECK(id != NULL);
    if (!id) return;
    for (size_t i = 0; i < ng; i++)
        id[i] = -1;
    vm_mesh m;
    vm_error err;
    vm_mesh_init(&m, VM_HEX8);
    size_t cap_cells = (size_t)B * (size_t)B * (size_t)B * VM_HT_MAX_HEXES;
    CHECK_OK(vm_mesh_reserve(&m, ng < 8 * cap_cells ? ng : 8 * cap_cells, cap_cells, &err),
             &err);
    size_t np = 0, nc = 0, unsupported = 0;
#define REFINED(x, y, z)                                                                       \
    ((x) >= lo[0] && (x) <= hi[0] && (y) >= lo[1] && (y) <= hi[1] && (z) >= lo[2] &&           \
     (z) <= hi[2])
    int hexes[VM_HT_MAX_HEXES][8][3];
    for (int z = 0; z < B; z++)
        for (int y = 0; y < B; y++)
            for (int x = 0; x < B; x++) {
                unsigned marks = 0;
                for (unsigned c = 0; c < 8; c++) {
                    int nx = x + (int)(c & 1), ny = y + (int)(c >> 1 & 1),
                        nz = z + (int)(c >> 2);
                    for (int q = 0; q < 8; q++)
                        if (REFINED(nx - (q & 1), ny - (q >> 1 & 1), nz - (q >> 2)))
                            marks |= 1u << c;
                }
                int sym = 0;
                vm__hex_template t =
                    REFINED(x, y, z) ? VM_HT_FULL : vm__hex_template_classify(marks, &sym);
                if (t == VM_HT_UNSUPPORTED) unsupported++;
                size_t n = vm__hex_template_hexes(t, sym, hexes);
                for (size_t h = 0; h < n; h++, nc++)
                    for (int k = 0; k < 8; k++) {
                        int g[3] = {x * VM_HT_SIDE + hexes[h][k][0],
                                    y * VM_HT_SIDE + hexes[h][k][1],
                                    z * VM_HT_SIDE + hexes[h][k][2]};
                        size_t gi = (size_t)g[0] +
                                    (size_t)G * ((size_t)g[1] + (size_t)G * (size_t)g[2]);
                        if (id[gi] < 0) {
                            id[gi] = (int32_t)np;
                            for (int a = 0; a < 3; a++)
                                m.points[3 * np + (size_t)a] = g[a] / 3.0;
                            np++;
                        }
                        m.cells[8 * nc + (size_t)k] = (vm_index)id[gi];
                    }
            }
#undef REFINED
    m.npoints = np;
    m.ncells = nc;
    for (size_t c = 0; c < nc; c++)
        m.region[c] = 1;
    CHECK(unsupported == 0);
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
    double side = B * 3.0;
    printf(
        "  %d^3 blocks, refined %d..%d x %d..%d x %d..%d: %zu hexes (uniform %d), min scaled "
        "Jacobian %.4f, volume %.3f\n",
        B, lo[0], hi[0], lo[1], hi[1], lo[2], hi[2], nc, 27 * B * B * B, r.min_scaled_jacobian,
        r.volume);
    if (expect) CHECK(nc == expect);
    CHECK(r.inverted == 0);
    CHECK(r.overshared_faces == 0);
    CHECK(r.boundary_closed == 1);
    CHECK(r.boundary_nonmanifold_vertices == 0);
    CHECK(r.boundary_euler == 2);
    CHECK(r.components == 1);
    /* the boundary is the cube's six faces, 9 quads per block face where refined, else
     * the templates' patterns; none is split finer than the fine grid */
    CHECK_NEAR(r.volume, side * side * side, 1e-6 * side * side * side);
    vm_mesh_free(&m);
    free(id);
}

static void refinedBoxesMeetCoarseBlocksConformingly(void) {
    /* one refined block in the middle: 26 neighbours are 6 FACE, 12 EDGE, 8 PLAIN */
    refinedBoxInCoarseGrid(3, (const int[3]){1, 1, 1}, (const int[3]){1, 1, 1},
                           27 + 6 * 13 + 12 * 5 + 8 * 1);
    /* a 2x3x1 box off-centre in a 5^3 grid, touching the border (count not pinned) */
    refinedBoxInCoarseGrid(5, (const int[3]){0, 1, 2}, (const int[3]){1, 3, 2}, 0);
    /* a 3x3x3 box: 27 refined blocks in a 7^3 grid */
    refinedBoxInCoarseGrid(7, (const int[3]){2, 2, 2}, (const int[3]){4, 4, 4}, 0);
}

/* The adaptive hex mesher (dc_hex_adaptive.c) on the six phantoms at 64^3 (48^3 under the
 * sanitizers): a valid, conforming, closed mesh with the phantom's topology and volume within
 * 2%, fewer hexes than uniform where an interior block fits (the torus, genus-3 tubes and
 * plate are too thin at 64^3: the same mesh as uniform, whose pass test_mesh_hexes.c
 * checks), and the quality pass reaching 0.2 on the meshes with transitions (measured
 * 0.37 to 0.45). */
static void adaptiveHexMeshOfEachPhantomIsValidAndCoarser(void) {
    static const struct {
        vm_phantom_kind kind;
        double max_ratio; /* adaptive / uniform hexes at most (measured beside) */
    } cases[] = {{VM_PHANTOM_SPHERE, 0.76},       /* 0.748 */
                 {VM_PHANTOM_TORUS, 1.0},         /* 1 */
                 {VM_PHANTOM_GENUS3, 1.0},        /* 1 */
                 {VM_PHANTOM_TWO_SPHERES, 0.99},  /* 0.982 */
                 {VM_PHANTOM_PLATE, 1.0},         /* 1 */
                 {VM_PHANTOM_CUT_SPHERE, 0.765}}; /* 0.754 */
    const char *sanitized = getenv("VM_SANITIZED");
    int small = sanitized && strcmp(sanitized, "1") == 0;
    int n = small ? 48 : 64;
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        vm_volume v;
        vm_phantom_info info;
        vm_error err;
        CHECK_OK(vm_phantom_make(cases[c].kind, n, 0.0, 0, &v, &info, &err), &err);
        vm_mesh uni, ada;
        vm_mesh_stats su, sa;
        if (mesh_hex_levels(&v, 0.0, 0, &uni, &su) == VM_OK &&
            mesh_hex_levels(&v, 0.0, 1, &ada, &sa) == VM_OK) {
            double ratio = (double)ada.ncells / (double)uni.ncells;
            printf("  %s %d^3: %zu uniform, %zu adaptive hexes (%.3f)\n", info.name, n,
                   uni.ncells, ada.ncells, ratio);
            CHECK(ada.ncells <= uni.ncells);
            if (!small)
                CHECK_MSG(ratio <= cases[c].max_ratio, "%s: ratio %.3f", info.name, ratio);
            check_hex_mesh(info.name, &ada, info.euler, (size_t)info.components, info.volume,
                           0.02);
            /* the sphere's pass (a minute on a loaded machine) is in
             * test_mesh_hexes_adaptive_pass.c */
            if (!small && ada.ncells < uni.ncells && cases[c].kind != VM_PHANTOM_SPHERE)
                check_improved(info.name, &ada, &v, 0.0, 0.2, info.volume);
            vm_mesh_free(&ada);
        }
        vm_mesh_free(&uni);
        vm_volume_free(&v);
    }
}

/* --error below 0 or not a number is a bad argument for adaptive hexes (which do not use it:
 * their boundary is the uniform one), named in the message, and leaves no mesh. */
static void adaptiveHexMeshRejectsABadError(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 0, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = 1;
    vm_mesh m;
    const double bad[] = {-0.5, NAN, INFINITY};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o.error = bad[i];
        CHECK(vm_mesh_volume(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
        CHECK_MSG(strstr(err.message, "error") != NULL, "message '%s'", err.message);
        CHECK(m.ncells == 0);
    }
    o.error = 0.0; /* 0 is allowed, and a valid mesh */
    CHECK_OK(vm_mesh_volume(&v, &o, &m, NULL, &err), &err);
    CHECK(m.ncells > 0);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

/* --max-level outside 1..10 is a bad argument for hexes too, named in the message, and
 * leaves no mesh. */
static void adaptiveHexMeshRejectsABadMaxLevel(void) {
    vm_volume v;
    vm_error err;
    CHECK_OK(vm_phantom_make(VM_PHANTOM_SPHERE, 16, 0.0, 0, &v, NULL, &err), &err);
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.elements = VM_HEX8;
    o.adaptive = 1;
    vm_mesh m;
    for (int level = -1; level <= 11; level += 12) {
        o.max_level = level;
        CHECK(vm_mesh_volume(&v, &o, &m, NULL, &err) == VM_ERR_ARG);
        CHECK(strstr(err.message, "max level") != NULL);
        CHECK(m.ncells == 0);
    }
    vm_volume_free(&v);
}

TEST_MAIN(T(hexTemplatesFillTheirBlockWithValidHexes), T(hexTemplatesRejectTwoRefinedFaces),
          T(refinedBoxesMeetCoarseBlocksConformingly),
          T(adaptiveHexMeshOfEachPhantomIsValidAndCoarser), T(adaptiveHexMeshRejectsABadError),
          T(adaptiveHexMeshRejectsABadMaxLevel))
