/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_mesh_check.c — element metrics and vm_mesh_check on meshes with known
 * answers (regular, inverted, flat tets; cubes split into tets; voxel rings; hex blocks;
 * non-manifold contacts; closed and open surfaces). */
#include "test.h"
#include <string.h>

/* --- builders ---------------------------------------------------------------------------- */

static vm_index add_pt(vm_mesh *m, double x, double y, double z) {
    const double p[3] = {x, y, z};
    vm_index i = vm_mesh_add_point(m, p, NULL);
    CHECK(i >= 0);
    return i;
}

static void add_cell(vm_mesh *m, const vm_index *nodes) {
    CHECK(vm_mesh_add_cell(m, nodes, 1, NULL) == VM_OK);
}

static double tet_vol_of(const vm_mesh *m, const vm_index n[4]) {
    double p[4][3];
    for (int i = 0; i < 4; i++)
        memcpy(p[i], m->points + 3 * n[i], sizeof p[i]);
    return vm_tet_signed_volume((const double(*)[3])p);
}

/* Adds a tet, swapping two nodes when needed so that it is positively oriented. */
static void add_tet_pos(vm_mesh *m, vm_index a, vm_index b, vm_index c, vm_index d) {
    vm_index n[4] = {a, b, c, d};
    if (tet_vol_of(m, n) < 0) {
        n[1] = c;
        n[2] = b;
    }
    add_cell(m, n);
}

/* Lattice of unit cubes: cube (i,j,k) in [0,4)^3 is present when cubes[k][j][i]. Point ids are
 * shared through a lattice map. as_hex: one hex per cube; else 6 Kuhn tets per cube (all
 * cubes cut along the (0,0,0)-(1,1,1) diagonal, so neighbouring cubes conform). */
static void build_cubes(vm_mesh *m, const char cubes[4][4][4], int as_hex) {
    vm_mesh_init(m, as_hex ? VM_HEX8 : VM_TET4);
    vm_index id[5][5][5];
    memset(id, -1, sizeof id);
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                if (!cubes[k][j][i]) continue;
                vm_index c[8]; /* VTK hex order */
                static const int off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                              {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
                for (int v = 0; v < 8; v++) {
                    int x = i + off[v][0], y = j + off[v][1], z = k + off[v][2];
                    if (id[z][y][x] < 0) id[z][y][x] = add_pt(m, x, y, z);
                    c[v] = id[z][y][x];
                }
                if (as_hex) {
                    add_cell(m, c);
                    continue;
                }
                /* Kuhn: walk from corner 0 to corner 6 along each order of the axes. */
                static const int bit_to_vtk[8] = {0, 1, 3, 2, 4, 5, 7, 6};
                static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                                {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
                for (int p = 0; p < 6; p++) {
                    int b1 = 1 << perms[p][0], b2 = b1 | (1 << perms[p][1]);
                    add_tet_pos(m, c[0], c[bit_to_vtk[b1]], c[bit_to_vtk[b2]], c[6]);
                }
            }
}

static void build_regular_tet(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    add_pt(m, 0, 0, 0);
    add_pt(m, 1, 0, 0);
    add_pt(m, 0.5, sqrt(3.0) / 2, 0);
    add_pt(m, 0.5, sqrt(3.0) / 6, sqrt(2.0 / 3.0));
    const vm_index n[4] = {0, 1, 2, 3};
    add_cell(m, n);
}

static void build_inverted_tet(vm_mesh *m) {
    build_regular_tet(m);
    vm_index t = m->cells[1];
    m->cells[1] = m->cells[2];
    m->cells[2] = t;
}

static void build_flat_tet(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    add_pt(m, 0, 0, 0);
    add_pt(m, 1, 0, 0);
    add_pt(m, 0, 1, 0);
    add_pt(m, 1, 1, 0);
    const vm_index n[4] = {0, 1, 2, 3};
    add_cell(m, n);
}

static void unit_cube_points(vm_mesh *m) {
    static const double c[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                   {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    for (int i = 0; i < 8; i++)
        add_pt(m, c[i][0], c[i][1], c[i][2]);
}

static void build_cube_5_tets(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    unit_cube_points(m);
    add_tet_pos(m, 0, 1, 3, 4);
    add_tet_pos(m, 2, 1, 3, 6);
    add_tet_pos(m, 5, 1, 4, 6);
    add_tet_pos(m, 7, 3, 4, 6);
    add_tet_pos(m, 1, 3, 4, 6);
}

static void build_cube_6_tets(vm_mesh *m) {
    static const char one[4][4][4] = {{{1}}};
    build_cubes(m, one, 0);
}

static void build_two_cubes_tets(vm_mesh *m) {
    static const char two[4][4][4] = {{{1, 1}}};
    build_cubes(m, two, 0);
}

static void build_two_cubes_hex(vm_mesh *m) {
    static const char two[4][4][4] = {{{1, 1}}};
    build_cubes(m, two, 1);
}

static const char ring[4][4][4] = {{{1, 1, 1}, {1, 0, 1}, {1, 1, 1}}};

static void build_ring_tets(vm_mesh *m) {
    build_cubes(m, ring, 0);
}

static void build_ring_hex(vm_mesh *m) {
    build_cubes(m, ring, 1);
}

static void build_single_hex(vm_mesh *m) {
    static const char one[4][4][4] = {{{1}}};
    build_cubes(m, one, 1);
}

static void build_hex_block(vm_mesh *m) {
    static const char block[4][4][4] = {{{1, 1}, {1, 1}}, {{1, 1}, {1, 1}}};
    build_cubes(m, block, 1);
}

static void build_hex_collapsed_corner(vm_mesh *m) {
    build_single_hex(m);
    memcpy(m->points + 3 * 6, m->points + 3 * 5, 3 * sizeof(double)); /* node 6 onto node 5 */
}

static void build_hex_pushed_corner(vm_mesh *m) {
    build_single_hex(m);
    const double inside[3] = {0.2, 0.2, 0.2}; /* node 6 pushed through to near node 0 */
    memcpy(m->points + 3 * 6, inside, sizeof inside);
}

static void build_tets_sharing_edge(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    add_pt(m, 0, 0, 0);
    add_pt(m, 1, 0, 0);
    add_pt(m, 0, 1, 0);
    add_pt(m, 0, 0, 1);
    add_pt(m, 0, -1, 0);
    add_pt(m, 0, 0, -1);
    add_tet_pos(m, 0, 1, 2, 3);
    add_tet_pos(m, 0, 1, 4, 5);
}

static void build_tets_sharing_vertex(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    add_pt(m, 0, 0, 0);
    add_pt(m, 1, 0, 0);
    add_pt(m, 0, 1, 0);
    add_pt(m, 0, 0, 1);
    add_pt(m, -1, 0, 0);
    add_pt(m, 0, -1, 0);
    add_pt(m, 0, 0, -1);
    add_tet_pos(m, 0, 1, 2, 3);
    add_tet_pos(m, 0, 4, 5, 6);
}

static void build_three_tets_on_a_face(vm_mesh *m) {
    vm_mesh_init(m, VM_TET4);
    add_pt(m, 0, 0, 0);
    add_pt(m, 1, 0, 0);
    add_pt(m, 0, 1, 0);
    add_pt(m, 0.2, 0.2, 1);
    add_pt(m, 0.2, 0.2, -1);
    add_pt(m, 0.3, 0.3, 2);
    add_tet_pos(m, 0, 1, 2, 3);
    add_tet_pos(m, 0, 1, 2, 4);
    add_tet_pos(m, 0, 1, 2, 5);
}

static void build_octahedron(vm_mesh *m, int open) {
    vm_mesh_init(m, VM_TRI3);
    add_pt(m, 1, 0, 0);
    add_pt(m, -1, 0, 0);
    add_pt(m, 0, 1, 0);
    add_pt(m, 0, -1, 0);
    add_pt(m, 0, 0, 1);
    add_pt(m, 0, 0, -1);
    /* Outward: for each octant (sx, sy, sz) the triangle (x, y, z) ordered counter-clockwise
     * seen from outside. */
    static const vm_index f[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                     {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
    for (int i = 0; i < (open ? 7 : 8); i++)
        add_cell(m, f[i]);
}

static void build_closed_octahedron(vm_mesh *m) {
    build_octahedron(m, 0);
}

static void build_open_octahedron(vm_mesh *m) {
    build_octahedron(m, 1);
}

static void build_quad_cube_surface(vm_mesh *m) {
    vm_mesh_init(m, VM_QUAD4);
    unit_cube_points(m);
    static const vm_index f[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                     {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    for (int i = 0; i < 6; i++)
        add_cell(m, f[i]);
}

/* --- golden table ------------------------------------------------------------------------ */

#define ANY (-99)
#define ANYF NAN

typedef struct golden {
    const char *name;
    void (*build)(vm_mesh *m);
    long inverted, degenerate, overshared, bfaces, open_edges, nm_edges, nm_vertices, closed,
        euler, components, bcomponents;
    double volume, min_dihedral, max_dihedral, min_sj;
} golden;

static const double regular_volume = 0.11785113019775792; /* 1 / (6 sqrt 2) */
static const double regular_dihedral = 70.52877936550931; /* acos(1/3) */

static const golden goldens[] = {
    {"a regular tet is closed with euler 2 and dihedrals of 70.53 degrees", build_regular_tet,
     0, 0, 0, 4, 0, 0, 0, 1, 2, 1, 1, 0.11785113019775792, 70.52877936550931, 70.52877936550931,
     1.0},
    {"an inverted tet is counted as inverted with negative volume", build_inverted_tet, 1, 0, 0,
     4, 0, 0, 0, 1, 2, 1, 1, -0.11785113019775792, 70.52877936550931, 70.52877936550931, -1.0},
    {"a flat tet is degenerate and inverted with dihedrals 0 and 180", build_flat_tet, 1, 1, 0,
     4, 0, 0, 0, 1, 2, 1, 1, 0.0, 0.0, 180.0, 0.0},
    {"a cube split into 5 tets is closed with euler 2 and volume 1", build_cube_5_tets, 0, 0, 0,
     12, 0, 0, 0, 1, 2, 1, 1, 1.0, ANYF, ANYF, ANYF},
    {"a cube split into 6 kuhn tets is closed with euler 2 and volume 1", build_cube_6_tets, 0,
     0, 0, 12, 0, 0, 0, 1, 2, 1, 1, 1.0, 45.0, 90.0, ANYF},
    {"two tet cubes sharing a face conform and enclose volume 2", build_two_cubes_tets, 0, 0, 0,
     20, 0, 0, 0, 1, 2, 1, 1, 2.0, 45.0, 90.0, ANYF},
    {"a ring of 8 tet cubes is a closed torus with euler 0", build_ring_tets, 0, 0, 0, 64, 0, 0,
     0, 1, 0, 1, 1, 8.0, 45.0, 90.0, ANYF},
    {"two tets sharing only an edge have a non-manifold boundary edge", build_tets_sharing_edge,
     0, 0, 0, 8, 0, 1, 2, 0, 3, 2, 1, ANYF, ANYF, ANYF, ANYF},
    {"two tets sharing only a vertex have a non-manifold boundary vertex",
     build_tets_sharing_vertex, 0, 0, 0, 8, 0, 0, 1, 1, 3, 2, 2, 1.0 / 3.0, ANYF, ANYF, ANYF},
    {"three tets on one face make that face overshared", build_three_tets_on_a_face, 0, 0, 1, 9,
     0, 3, 3, 0, ANY, 1, 1, ANYF, ANYF, ANYF, ANYF},
    {"a single unit hex has scaled jacobian 1 and euler 2", build_single_hex, 0, 0, 0, 6, 0, 0,
     0, 1, 2, 1, 1, 1.0, 0.0, 0.0, 1.0},
    {"a 2x2x2 block of hexes is closed with euler 2 and scaled jacobian 1", build_hex_block, 0,
     0, 0, 24, 0, 0, 0, 1, 2, 1, 1, 8.0, 0.0, 0.0, 1.0},
    {"two hexes sharing a face conform", build_two_cubes_hex, 0, 0, 0, 10, 0, 0, 0, 1, 2, 1, 1,
     2.0, 0.0, 0.0, 1.0},
    {"a ring of 8 hexes is a closed torus with euler 0", build_ring_hex, 0, 0, 0, 32, 0, 0, 0,
     1, 0, 1, 1, 8.0, 0.0, 0.0, 1.0},
    {"a hex with a corner collapsed onto its neighbour is inverted", build_hex_collapsed_corner,
     1, 0, 0, 6, 0, 0, 0, 1, 2, 1, 1, ANYF, 0.0, 0.0, 0.0},
    {"a hex with a corner pushed through the cell is inverted", build_hex_pushed_corner, 1, 0,
     0, 6, 0, 0, 0, 1, 2, 1, 1, ANYF, 0.0, 0.0, ANYF},
    {"a closed octahedron surface has euler 2 and encloses 4/3", build_closed_octahedron, 0, 0,
     0, 8, 0, 0, 0, 1, 2, 1, 1, 4.0 / 3.0, 0.0, 0.0, 0.0},
    {"an open octahedron surface has 3 open edges, euler 1 and open fans",
     build_open_octahedron, 0, 0, 0, 7, 3, 0, 3, 0, 1, 1, 1, ANYF, 0.0, 0.0, 0.0},
    {"a quad surface of a unit cube is closed with euler 2 and encloses 1",
     build_quad_cube_surface, 0, 0, 0, 6, 0, 0, 0, 1, 2, 1, 1, 1.0, 0.0, 0.0, 0.0},
};

#define EXPECT_COUNT(field, want)                                                              \
    do {                                                                                       \
        if ((want) != ANY && (long)(field) != (want)) {                                        \
            fprintf(stderr, "  [%s] %s = %ld, expected %ld\n", g->name, #field, (long)(field), \
                    (long)(want));                                                             \
            vm_test_failures++;                                                                \
        }                                                                                      \
    } while (0)

#define EXPECT_REAL(field, want)                                                               \
    do {                                                                                       \
        if (!isnan(want) && !(fabs((field) - (want)) <= 1e-9 * (1 + fabs(want)))) {            \
            fprintf(stderr, "  [%s] %s = %.12g, expected %.12g\n", g->name, #field,            \
                    (double)(field), (double)(want));                                          \
            vm_test_failures++;                                                                \
        }                                                                                      \
    } while (0)

static void everyGoldenMeshGetsItsKnownReport(void) {
    for (size_t i = 0; i < sizeof goldens / sizeof goldens[0]; i++) {
        const golden *g = &goldens[i];
        vm_mesh m;
        vm_mesh_report r;
        vm_error eb, *err = &eb;
        g->build(&m);
        vm_status st = vm_mesh_check(&m, &r, err);
        CHECK_MSG(st == VM_OK, "[%s] %s", g->name, err->message);
        CHECK(r.cells == m.ncells && r.points == m.npoints);
        EXPECT_COUNT(r.inverted, g->inverted);
        EXPECT_COUNT(r.degenerate, g->degenerate);
        EXPECT_COUNT(r.overshared_faces, g->overshared);
        EXPECT_COUNT(r.boundary_faces, g->bfaces);
        EXPECT_COUNT(r.boundary_open_edges, g->open_edges);
        EXPECT_COUNT(r.boundary_nonmanifold_edges, g->nm_edges);
        EXPECT_COUNT(r.boundary_nonmanifold_vertices, g->nm_vertices);
        EXPECT_COUNT(r.boundary_closed, g->closed);
        EXPECT_COUNT(r.boundary_euler, g->euler);
        EXPECT_COUNT(r.components, g->components);
        EXPECT_COUNT(r.boundary_components, g->bcomponents);
        EXPECT_REAL(r.volume, g->volume);
        EXPECT_REAL(r.min_dihedral, g->min_dihedral);
        EXPECT_REAL(r.max_dihedral, g->max_dihedral);
        EXPECT_REAL(r.min_scaled_jacobian, g->min_sj);
        vm_mesh_free(&m);
    }
}

/* --- metrics ----------------------------------------------------------------------------- */

static void tetMetricsMatchVerdictOnRegularFlatAndDegenerateTets(void) {
    vm_mesh m;
    build_regular_tet(&m);
    double p[4][3];
    memcpy(p, m.points, sizeof p);
    CHECK_NEAR(vm_tet_signed_volume((const double(*)[3])p), regular_volume, 1e-15);
    CHECK_NEAR(vm_tet_min_dihedral((const double(*)[3])p), regular_dihedral, 1e-9);
    CHECK_NEAR(vm_tet_max_dihedral((const double(*)[3])p), regular_dihedral, 1e-9);
    CHECK_NEAR(vm_tet_scaled_jacobian((const double(*)[3])p), 1.0, 1e-12);
    vm_mesh_free(&m);

    /* Right-corner tet: dihedrals 90 (three edges at the corner) and 54.7356 (the others). */
    const double right[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    CHECK_NEAR(vm_tet_signed_volume(right), 1.0 / 6.0, 1e-15);
    CHECK_NEAR(vm_tet_min_dihedral(right), 54.735610317245346, 1e-9);
    CHECK_NEAR(vm_tet_max_dihedral(right), 90.0, 1e-9);
    CHECK_NEAR(vm_tet_scaled_jacobian(right), sqrt(2.0) / 2.0, 1e-12);

    /* All points on one spot, collinear points, NaN: defined values, never NaN. */
    const double same[4][3] = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
    const double line[4][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
    const double bad[4][3] = {{NAN, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    const double(*cases[3])[3] = {same, line, bad};
    for (int i = 0; i < 3; i++) {
        CHECK(vm_tet_signed_volume(cases[i]) == 0.0);
        CHECK(vm_tet_min_dihedral(cases[i]) == 0.0);
        CHECK(vm_tet_max_dihedral(cases[i]) == 180.0);
        CHECK(vm_tet_scaled_jacobian(cases[i]) == 0.0);
    }
}

static void hexScaledJacobianIsOneForABoxAndFallsForAShearedHex(void) {
    const double box[8][3] = {{0, 0, 0}, {2, 0, 0}, {2, 3, 0}, {0, 3, 0},
                              {0, 0, 5}, {2, 0, 5}, {2, 3, 5}, {0, 3, 5}};
    CHECK_NEAR(vm_hex_min_scaled_jacobian(box), 1.0, 1e-12);
    CHECK_NEAR(vm_hex_volume(box), 30.0, 1e-12);
    /* Top face shifted by 1 in x over height 1: corner Jacobian 1/sqrt(2). */
    const double shear[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                {1, 0, 1}, {2, 0, 1}, {2, 1, 1}, {1, 1, 1}};
    CHECK_NEAR(vm_hex_min_scaled_jacobian(shear), sqrt(0.5), 1e-12);
    CHECK_NEAR(vm_hex_volume(shear), 1.0, 1e-12);
    /* A twisted (non-planar faces) hex: volume from the exact trilinear formula equals the
     * average of the two 5-tet splits only for planar faces, so compare with a fine
     * midpoint-rule integral of det(J). */
    const double tw[8][3] = {{0, 0, 0}, {1, 0, 0},   {1, 1, 0.3}, {0, 1, 0},
                             {0, 0, 1}, {1.2, 0, 1}, {1, 1, 1},   {0, 1.1, 1.4}};
    double vol = 0.0;
    const int n = 40;
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++)
            for (int c = 0; c < n; c++) {
                double u = (a + 0.5) / n, v = (b + 0.5) / n, w = (c + 0.5) / n;
                double J[3][3] = {{0}};
                static const int xi[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                             {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
                for (int k = 0; k < 8; k++) {
                    double fu = xi[k][0] ? u : 1 - u, fv = xi[k][1] ? v : 1 - v,
                           fw = xi[k][2] ? w : 1 - w;
                    double du = (xi[k][0] ? 1 : -1) * fv * fw,
                           dv = (xi[k][1] ? 1 : -1) * fu * fw,
                           dw = (xi[k][2] ? 1 : -1) * fu * fv;
                    for (int d = 0; d < 3; d++) {
                        J[d][0] += du * tw[k][d];
                        J[d][1] += dv * tw[k][d];
                        J[d][2] += dw * tw[k][d];
                    }
                }
                vol += (J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1]) -
                        J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0]) +
                        J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0])) /
                       (n * n * n);
            }
    CHECK_NEAR(vm_hex_volume(tw), vol, 1e-4);
}

/* --- boundary extraction ----------------------------------------------------------------- */

static void boundaryOfATetBlockIsAnOutwardClosedSurface(void) {
    static const char block[4][4][4] = {{{1, 1}, {1, 1}}, {{1, 1}, {1, 1}}};
    vm_mesh m, s;
    vm_error eb, *err = &eb;
    vm_mesh_report r;
    build_cubes(&m, block, 0);
    for (size_t c = 0; c < m.ncells; c++)
        m.region[c] = (int32_t)(c / 6);
    double *cf = malloc(m.ncells * sizeof *cf);
    for (size_t c = 0; c < m.ncells; c++)
        cf[c] = (double)c;
    CHECK_OK(vm_mesh_set_field(&m, 1, "cell_id", 1, cf, err), err);
    free(cf);
    CHECK_OK(vm_mesh_boundary(&m, &s, err), err);
    CHECK(s.kind == VM_TRI3);
    CHECK(s.ncells == 48);  /* 6 faces x 4 squares x 2 triangles */
    CHECK(s.npoints == 26); /* 27 lattice points minus the centre */
    const vm_field *f = vm_mesh_find_field(&s, 1, "cell_id");
    CHECK(f != NULL);
    for (size_t i = 0; f && i < s.ncells; i++)
        CHECK(s.region[i] == (int32_t)(f->data[i] / 6));
    CHECK_OK(vm_mesh_check(&s, &r, err), err);
    CHECK(r.boundary_closed == 1);
    CHECK(r.boundary_euler == 2);
    CHECK(r.boundary_nonmanifold_vertices == 0);
    CHECK_NEAR(r.volume, 8.0, 1e-12); /* positive: faces point outward */
    vm_mesh_free(&m);
    vm_mesh_free(&s);
}

static void boundaryOfAHexBlockIsQuadsPointingOutward(void) {
    vm_mesh m, s;
    vm_error eb, *err = &eb;
    vm_mesh_report r;
    build_hex_block(&m);
    CHECK_OK(vm_mesh_boundary(&m, &s, err), err);
    CHECK(s.kind == VM_QUAD4 && s.ncells == 24 && s.npoints == 26);
    CHECK_OK(vm_mesh_check(&s, &r, err), err);
    CHECK(r.boundary_closed == 1 && r.boundary_euler == 2);
    CHECK_NEAR(r.volume, 8.0, 1e-12);
    vm_mesh_free(&m);
    vm_mesh_free(&s);
}

static void boundaryOfASurfaceMeshIsRefused(void) {
    vm_mesh m, s;
    vm_error eb, *err = &eb;
    build_closed_octahedron(&m);
    CHECK(vm_mesh_boundary(&m, &s, err) == VM_ERR_UNSUPPORTED);
    CHECK(s.ncells == 0);
    vm_mesh_free(&m);
}

static void outOfRangeNodesAreAnErrorNotACrash(void) {
    vm_mesh m;
    vm_mesh_report r;
    vm_error eb, *err = &eb;
    build_regular_tet(&m);
    m.cells[3] = 7;
    CHECK(vm_mesh_check(&m, &r, err) == VM_ERR_ARG);
    CHECK(strstr(err->message, "node 7") != NULL);
    vm_mesh_free(&m);
}

static void anEmptyMeshReportsZeros(void) {
    vm_mesh m;
    vm_mesh_report r;
    vm_error eb, *err = &eb;
    vm_mesh_init(&m, VM_TET4);
    CHECK_OK(vm_mesh_check(&m, &r, err), err);
    CHECK(r.cells == 0 && r.boundary_faces == 0 && r.components == 0 && r.volume == 0.0);
    CHECK(r.min_dihedral == 0.0 && r.max_dihedral == 0.0);
}

static void aVoxelBlockWithAHoleHasTwoBoundaryComponents(void) {
    /* 3x3x3 cubes minus the centre: the cavity gives a second boundary sphere, euler 4. */
    char cubes[4][4][4];
    memset(cubes, 0, sizeof cubes);
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++)
                cubes[k][j][i] = !(i == 1 && j == 1 && k == 1);
    for (int hex = 0; hex < 2; hex++) {
        vm_mesh m;
        vm_mesh_report r;
        vm_error eb, *err = &eb;
        build_cubes(&m, (const char(*)[4][4])cubes, hex);
        CHECK_OK(vm_mesh_check(&m, &r, err), err);
        CHECK(r.boundary_closed == 1);
        CHECK(r.boundary_euler == 4);
        CHECK(r.boundary_components == 2);
        CHECK(r.components == 1);
        CHECK(r.inverted == 0 && r.overshared_faces == 0);
        CHECK_NEAR(r.volume, 26.0, 1e-12);
        vm_mesh_free(&m);
    }
}

/* --- boundary self-intersections -------------------------------------------------------- */

/* One case: up to 8 points and up to 4 triangles of a tri3 surface, and the expected number
 * of intersecting pairs. */
typedef struct pair_case {
    const char *name;
    int npts;
    double p[8][3];
    int ntri;
    vm_index t[4][3];
    size_t pairs;
} pair_case;

static const pair_case pair_cases[] = {
    {"two triangles crossing", 6,
     {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, -1}, {0.5, 0.5, 1}, {3, 3, 0}},
     2, {{0, 1, 2}, {3, 4, 5}}, 1},
    {"two triangles apart", 6,
     {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 1}, {2, 0, 1}, {0, 2, 1}},
     2, {{0, 1, 2}, {3, 4, 5}}, 0},
    {"a corner touching the other's inside", 6,
     {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, 0}, {0.5, 0.5, 1}, {1.5, 0.5, 1}},
     2, {{0, 1, 2}, {3, 4, 5}}, 1},
    {"coplanar, one inside the other", 6,
     {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0.5, 0.5, 0}, {1, 0.5, 0}, {0.5, 1, 0}},
     2, {{0, 1, 2}, {3, 4, 5}}, 1},
    {"hinge: common edge, bent", 4,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, -1, 0.3}},
     2, {{0, 1, 2}, {1, 0, 3}}, 0},
    {"flat neighbours: common edge, coplanar", 4,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, -1, 0}},
     2, {{0, 1, 2}, {1, 0, 3}}, 0},
    {"fold: common edge, coplanar on one side", 4,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.6, 0.8, 0}},
     2, {{0, 1, 2}, {1, 0, 3}}, 1},
    {"fan: common vertex, apart", 5,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0.2}, {0, -1, 0.5}},
     2, {{0, 1, 2}, {0, 3, 4}}, 0},
    {"common vertex, the far edge pierces", 5,
     {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, -1}, {0.5, 0.5, 1}},
     2, {{0, 1, 2}, {0, 3, 4}}, 1},
    {"common vertex, coplanar wedges overlapping", 5,
     {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {2, 1, 0}, {1, 2, 0}},
     2, {{0, 1, 2}, {0, 3, 4}}, 1},
    {"closed tetrahedron", 4,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
     4, {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}, 0},
    {"inside-out tetrahedron (no crossing)", 4,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.6, 0.6, -0.5}},
     4, {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}, 0},
};

static void boundarySelfIntersectionsCountCrossingNotTouchingNeighbours(void) {
    for (size_t c = 0; c < sizeof pair_cases / sizeof pair_cases[0]; c++) {
        const pair_case *pc = &pair_cases[c];
        vm_mesh m;
        vm_mesh_report r;
        vm_error err;
        vm_mesh_init(&m, VM_TRI3);
        for (int i = 0; i < pc->npts; i++)
            add_pt(&m, pc->p[i][0], pc->p[i][1], pc->p[i][2]);
        for (int i = 0; i < pc->ntri; i++)
            add_cell(&m, pc->t[i]);
        CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
        CHECK_MSG(r.boundary_self_intersections == pc->pairs, "%s: %zu pairs, expected %zu",
                  pc->name, r.boundary_self_intersections, pc->pairs);
        /* the answer does not depend on the order of the triangles or of their corners */
        for (size_t i = 0; i < m.ncells / 2; i++)
            for (int k = 0; k < 3; k++) {
                vm_index x = m.cells[3 * i + (size_t)k];
                m.cells[3 * i + (size_t)k] = m.cells[3 * (m.ncells - 1 - i) + (size_t)k];
                m.cells[3 * (m.ncells - 1 - i) + (size_t)k] = x;
            }
        for (size_t i = 0; i < m.ncells; i++) {
            vm_index x = m.cells[3 * i];
            m.cells[3 * i] = m.cells[3 * i + 1];
            m.cells[3 * i + 1] = m.cells[3 * i + 2];
            m.cells[3 * i + 2] = x;
        }
        CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
        CHECK_MSG(r.boundary_self_intersections == pc->pairs,
                  "%s, reordered: %zu pairs, expected %zu", pc->name,
                  r.boundary_self_intersections, pc->pairs);
        vm_mesh_free(&m);
    }
}

static void aTetBlockHasNoSelfIntersectionAndTwoOverlappingTetsHave(void) {
    static const char block[4][4][4] = {{{1, 1, 1}, {1, 1, 1}}, {{1, 1, 1}, {1, 0, 1}}};
    vm_mesh m;
    vm_mesh_report r;
    vm_error err;
    build_cubes(&m, block, 0);
    CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
    CHECK(r.inverted == 0 && r.boundary_closed == 1);
    CHECK_MSG(r.boundary_self_intersections == 0, "%zu pairs", r.boundary_self_intersections);
    vm_mesh_free(&m);

    /* Two positive tets sharing a face, the second folded back over the first: valid
     * elements and a closed manifold boundary, yet the boundary crosses itself. */
    vm_mesh_init(&m, VM_TET4);
    add_pt(&m, 0, 0, 0);
    add_pt(&m, 4, 0, 0);
    add_pt(&m, 0, 4, 0);
    add_pt(&m, 1, 1, 3);
    add_pt(&m, 3, 3, 1); /* above the common face too, and outside the first tet */
    add_tet_pos(&m, 0, 1, 2, 3);
    add_tet_pos(&m, 0, 1, 2, 4);
    CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
    CHECK(r.inverted == 0 && r.boundary_closed == 1);
    CHECK_MSG(r.boundary_self_intersections > 0, "folded pair: %zu",
              r.boundary_self_intersections);
    vm_mesh_free(&m);
}

/* Degenerate input is normal input (issue 31): a triangle that repeats a node, against a
 * good triangle sharing none, one or two of its nodes, in every order. The check counts it
 * as degenerate and never reads past a triangle's three corners (ASan sees that); the quality
 * report of the same surface also completes. */
static void trianglesRepeatingANodeAreCountedNotACrash(void) {
    static const double pts[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
    int cases = 0;
    for (int x = 0; x < 5; x++)
        for (int y = 0; y < 5; y++)
            for (int z = 0; z < 5; z++) {
                if (x != y && y != z && x != z) continue;
                vm_mesh m;
                vm_error err;
                vm_mesh_init(&m, VM_TRI3);
                CHECK_OK(vm_mesh_reserve(&m, 5, 2, &err), &err);
                memcpy(m.points, pts, sizeof pts);
                m.npoints = 5;
                const vm_index good[3] = {0, 1, 2}, bad[3] = {x, y, z};
                CHECK_OK(vm_mesh_add_cell(&m, good, 0, &err), &err);
                CHECK_OK(vm_mesh_add_cell(&m, bad, 0, &err), &err);
                vm_mesh_report r;
                CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
                CHECK_MSG(r.degenerate == 1, "(%d %d %d): %zu degenerate", x, y, z,
                          r.degenerate);
                CHECK_MSG(r.boundary_self_intersections == 0, "(%d %d %d): %zu crossings", x,
                          y, z, r.boundary_self_intersections);
                vm_quality_summary q;
                CHECK_OK(vm_quality_report(&m, &q, &err), &err);
                vm_mesh_free(&m);
                cases++;
            }
    CHECK(cases == 65);
}

/* --- the same report for any thread count ------------------------------------------------ */

/* A jittered n^3 block of unit cubes (6 Kuhn tets or a hex each) with every kind of defect:
 * a plane of cubes left out (two components), a missing interior cube (a cavity), inverted
 * and repeated cells (overshared faces), and a second block, shifted by half a cube, that
 * overlaps the first (its boundary crosses the other's). */
static void build_defective_block(vm_mesh *m, int n, int as_hex) {
    vm_mesh_init(m, as_hex ? VM_HEX8 : VM_TET4);
    uint64_t s = 0x9e3779b97f4a7c15ull;
    size_t side = (size_t)n + 1;
    for (int copy = 0; copy < 2; copy++) {
        vm_index base = (vm_index)m->npoints;
        double shift = copy ? 0.5 * n : 0.0;
        for (size_t q = 0; q < side * side * side; q++) {
            double p[3] = {(double)(q % side), (double)(q / side % side),
                           (double)(q / side / side)};
            for (int d = 0; d < 3; d++) {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                p[d] += 0.2 * ((double)(s >> 11) / 9007199254740992.0 - 0.5) + shift;
            }
            add_pt(m, p[0], p[1], p[2]);
        }
        int cubes = copy ? n / 2 : n;
        for (int k = 0; k < cubes; k++)
            for (int j = 0; j < cubes; j++)
                for (int i = 0; i < cubes; i++) {
                    if (!copy && (i == n / 2 || (i == 3 && j == 3 && k == 3))) continue;
                    vm_index c[8];
                    static const int off[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                                  {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
                    for (int v = 0; v < 8; v++)
                        c[v] = base + (vm_index)((size_t)(i + off[v][0]) +
                                                 side * ((size_t)(j + off[v][1]) +
                                                         side * (size_t)(k + off[v][2])));
                    int bad = (i * 7 + j * 3 + k) % 97 == 0, twice = (i + j * 5 + k * 11) % 89 == 0;
                    if (as_hex) {
                        if (bad) {
                            vm_index t = c[0];
                            c[0] = c[6];
                            c[6] = t;
                        }
                        add_cell(m, c);
                        if (twice) add_cell(m, c);
                        continue;
                    }
                    static const int path[6][2] = {{1, 2}, {1, 5}, {3, 2}, {3, 7}, {4, 5}, {4, 7}};
                    for (int t = 0; t < 6; t++) {
                        vm_index tn[4] = {c[0], c[path[t][0]], c[path[t][1]], c[6]};
                        if (tet_vol_of(m, tn) < 0 && !(bad && t == 2)) {
                            tn[1] = c[path[t][1]];
                            tn[2] = c[path[t][0]];
                        }
                        add_cell(m, tn);
                        if (twice && t == 0) add_cell(m, tn);
                    }
                }
    }
}

/* A double cone of n triangles a side round the z axis, apexes at z = +-1 (points 0 and 1,
 * so every edge at an apex has it as its lower node: buckets of 2n edge instances), closed
 * and outward; with `book`, one more triangle on the edge from the top apex to rim point 0
 * (a third face there: a non-manifold edge). The apexes' grid cells hold all n triangles
 * round them. */
static void build_double_cone(vm_mesh *m, int n, int book) {
    vm_mesh_init(m, VM_TRI3);
    add_pt(m, 0, 0, 1);
    add_pt(m, 0, 0, -1);
    for (int i = 0; i < n; i++) {
        double a = 2.0 * 3.14159265358979323846 * i / n;
        add_pt(m, cos(a), sin(a), 0);
    }
    for (int i = 0; i < n; i++) {
        vm_index r0 = 2 + i, r1 = 2 + (i + 1) % n;
        const vm_index top[3] = {0, r0, r1}, bottom[3] = {1, r1, r0};
        add_cell(m, top);
        add_cell(m, bottom);
    }
    if (book) {
        vm_index x = add_pt(m, 2, 0, 2);
        const vm_index page[3] = {0, 2, x};
        add_cell(m, page);
    }
}

/* Vertices with hundreds of edges and grid cells with hundreds of triangles (the check
 * sorts those lists another way than the short ones) get the known report on 1 to 3
 * threads. */
static void highValenceFansGetTheKnownReportOnAnyThreadCount(void) {
    int before = vm_threads();
    for (int book = 0; book < 2; book++) {
        vm_mesh m;
        build_double_cone(&m, 300, book);
        for (int t = 1; t <= 3; t++) {
            vm_set_threads(t);
            vm_mesh_report r;
            vm_error err;
            CHECK_OK(vm_mesh_check(&m, &r, &err), &err);
            CHECK_MSG(r.boundary_faces == 600 + (size_t)book, "book %d, %d threads", book, t);
            CHECK_MSG(r.boundary_open_edges == (size_t)(2 * book),
                      "book %d, %d threads: %zu open", book, t, r.boundary_open_edges);
            CHECK_MSG(r.boundary_nonmanifold_edges == (size_t)book, "book %d, %d threads", book,
                      t);
            /* the page's far point, and the two ends of the three-face edge */
            CHECK_MSG(r.boundary_nonmanifold_vertices == (size_t)(3 * book),
                      "book %d, %d threads: %zu", book, t, r.boundary_nonmanifold_vertices);
            CHECK(r.boundary_closed == !book);
            /* V - E + F: 302 - 900 + 600, and the page adds a point, two edges and a face */
            CHECK_MSG(r.boundary_euler == 2, "book %d, %d threads: euler %ld", book, t,
                      r.boundary_euler);
            CHECK(r.boundary_components == 1);
            CHECK_MSG(r.boundary_self_intersections == 0, "book %d, %d threads: %zu", book, t,
                      r.boundary_self_intersections);
        }
        vm_mesh_free(&m);
    }
    vm_set_threads(before);
}

#define SAME(field)                                                                            \
    CHECK_MSG(a.field == b.field, "%s, %d threads: " #field " differs from 1 thread's", what, t)

/* vm_mesh_check gives the same report, field for field, on 1, 2 and 3 threads. */
static void checkReportsAreTheSameForAnyThreadCount(void) {
    int before = vm_threads();
    for (int hex = 0; hex < 2; hex++) {
        vm_mesh m;
        build_defective_block(&m, 20, hex);
        const char *what = hex ? "hexes" : "tets";
        vm_error err;
        vm_mesh_report a, b;
        vm_set_threads(1);
        CHECK_OK(vm_mesh_check(&m, &a, &err), &err);
        /* the defects are there to be counted */
        CHECK(a.inverted > 0 && a.overshared_faces > 0 && a.components >= 3);
        CHECK(a.boundary_closed == 0 && a.boundary_faces > 0);
        CHECK(hex ? a.boundary_nonmanifold_edges > 0 : a.boundary_self_intersections > 0);
        for (int t = 2; t <= 3; t++) {
            vm_set_threads(t);
            CHECK_OK(vm_mesh_check(&m, &b, &err), &err);
            SAME(cells);
            SAME(points);
            SAME(inverted);
            SAME(degenerate);
            SAME(overshared_faces);
            SAME(boundary_faces);
            SAME(boundary_open_edges);
            SAME(boundary_nonmanifold_edges);
            SAME(boundary_nonmanifold_vertices);
            SAME(boundary_closed);
            SAME(boundary_euler);
            SAME(components);
            SAME(boundary_components);
            SAME(boundary_self_intersections);
            SAME(volume);
            SAME(min_dihedral);
            SAME(max_dihedral);
            SAME(slivers_5);
            SAME(slivers_10);
            SAME(min_scaled_jacobian);
        }
        vm_mesh_free(&m);
    }
    vm_set_threads(before);
}

TEST_MAIN(T(everyGoldenMeshGetsItsKnownReport), T(checkReportsAreTheSameForAnyThreadCount),
          T(highValenceFansGetTheKnownReportOnAnyThreadCount),
          T(trianglesRepeatingANodeAreCountedNotACrash),
          T(tetMetricsMatchVerdictOnRegularFlatAndDegenerateTets),
          T(hexScaledJacobianIsOneForABoxAndFallsForAShearedHex),
          T(boundaryOfATetBlockIsAnOutwardClosedSurface),
          T(boundaryOfAHexBlockIsQuadsPointingOutward), T(boundaryOfASurfaceMeshIsRefused),
          T(outOfRangeNodesAreAnErrorNotACrash), T(anEmptyMeshReportsZeros),
          T(aVoxelBlockWithAHoleHasTwoBoundaryComponents),
          T(boundarySelfIntersectionsCountCrossingNotTouchingNeighbours),
          T(aTetBlockHasNoSelfIntersectionAndTwoOverlappingTetsHave))
