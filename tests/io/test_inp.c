/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_inp.c — ABAQUS/CalculiX .inp writer and reader: exact round trips for tet,
 * hex, tri and quad meshes (also through C3D10/C3D20 and a static deck), the boundary
 * surfaces name the right element faces, the static deck's sets are the z slabs, malformed
 * decks are refused with one-line errors. (test_calculix.sh runs ccx on a deck.) */
#include "mesh_fixtures.h"
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include "io/mesh_util.h"

static vm_mesh_write_options opts(int order, vm_deck_kind deck) {
    vm_mesh_write_options o;
    vm_mesh_write_options_init(&o);
    o.order = order;
    o.deck = deck;
    return o;
}

static void inp_round_trip_is_exact_for_every_kind(void) {
    vm_mesh m;
    fx_block(&m, 2, 0);
    fx_round_trip_within(&m, "rt_tet.inp", NULL, vm_mesh_read_inp, 1, FX_DIGITS15_TOL);
    vm_mesh_free(&m);
    fx_block(&m, 2, 1);
    fx_round_trip_within(&m, "rt_hex.inp", NULL, vm_mesh_read_inp, 1, FX_DIGITS15_TOL);
    vm_mesh_free(&m);
    fx_surface(&m, 0);
    fx_round_trip_within(&m, "rt_tri.inp", NULL, vm_mesh_read_inp, 1, FX_DIGITS15_TOL);
    vm_mesh_free(&m);
    fx_surface(&m, 1);
    fx_round_trip_within(&m, "rt_quad.inp", NULL, vm_mesh_read_inp, 1, FX_DIGITS15_TOL);
    vm_mesh_free(&m);
}

static void inp_second_order_and_deck_read_back_as_the_first_order_mesh(void) {
    for (int hex = 0; hex < 2; hex++) {
        vm_mesh m;
        fx_block(&m, 2, hex);
        vm_mesh_write_options o = opts(2, VM_DECK_STATIC);
        fx_round_trip_within(&m, hex ? "rt_c3d20.inp" : "rt_c3d10.inp", &o, vm_mesh_read_inp,
                             1, FX_DIGITS15_TOL);
        o = opts(1, VM_DECK_STATIC);
        fx_round_trip_within(&m, hex ? "rt_deck_hex.inp" : "rt_deck_tet.inp", &o,
                             vm_mesh_read_inp, 1, FX_DIGITS15_TOL);
        vm_mesh_free(&m);
    }
}

/* Deck numbers: at most 20 characters (16 for the wide fields, with a point when asked), the
 * exact double whenever some text of 15 to 17 digits fits, else 15 digits or fewer. */
static void inp_numbers_fit_twenty_characters_and_read_back(void) {
    static const struct {
        double v;
        int exact; /* 1: the shortest exact text fits 20 characters */
    } cases[] = {
        {-9.9999999991773336E-07, 0}, {1.6859956894443818e-05, 0}, {0.1, 1},
        {1.0 / 3.0, 1},               {-1e-3 / 7.0, 0},             {-0.0, 1},
        {123456789.0, 1},             {-1.2345678901234567e-100, 0}, {DBL_MAX, 0},
        {5e-324, 1},                  {-0.61353052273411679, 1},     {1e22, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        double v = cases[i].v;
        char s[32];
        int n = vm__format_real(v, VM__INP_FIELD, 0, s, sizeof s);
        double back = strtod(s, NULL);
        CHECK_MSG(n == (int)strlen(s) && n <= VM__INP_FIELD, "%.17g written \"%s\"", v, s);
        /* 15 digits; 13 when the exponent takes three */
        double tol = fabs(v) > 1e-99 && fabs(v) < 1e99 ? 1e-14 : 1e-12;
        CHECK_MSG(fabs(back - v) <= tol * fabs(v), "%.17g read back as %.17g (\"%s\")", v,
                  back, s);
        CHECK_MSG(!cases[i].exact || (back == v && signbit(back) == signbit(v)),
                  "%.17g not exact: \"%s\"", v, s);
        n = vm__format_real(v, VM__WIDE_FIELD, 1, s, sizeof s);
        CHECK_MSG(n <= VM__WIDE_FIELD && strchr(s, '.') != NULL, "wide: %.17g as \"%s\"", v, s);
        CHECK_MSG(fabs(strtod(s, NULL) - v) <= 1e-10 * fabs(v), "wide: %.17g as \"%s\"", v, s);
    }
    char s[32];
    vm__format_real(0.1, VM__INP_FIELD, 0, s, sizeof s);
    CHECK_MSG(strcmp(s, "0.1") == 0, "0.1 written \"%s\"", s);
    vm__format_real(12.0, VM__WIDE_FIELD, 1, s, sizeof s);
    CHECK_MSG(strcmp(s, "12.") == 0, "12 written \"%s\" for Nastran", s);
}

/* A mesh whose nodes sit near zero (exponent numbers) gives *NODE fields of at most 20
 * characters, the width CalculiX reads. */
static void inp_node_fields_near_zero_fit_calculix(void) {
    vm_mesh m;
    fx_block(&m, 2, 0);
    for (size_t i = 0; i < 3 * m.npoints; i++)
        m.points[i] = (m.points[i] - 1.0) * -9.9999999991773336E-07;
    const char *path = vm_test_tmp("near_zero.inp");
    vm_mesh_write_options o = opts(2, VM_DECK_STATIC);
    CHECK_OK(vm_mesh_write_as(path, &m, &o, NULL), NULL);
    FILE *fp = fopen(path, "r");
    CHECK(fp != NULL);
    char line[512];
    int in_nodes = 0;
    size_t widest = 0, nodes = 0;
    while (fp && fgets(line, sizeof line, fp)) {
        if (line[0] == '*') {
            in_nodes = strncmp(line, "*NODE,", 6) == 0;
            continue;
        }
        if (!in_nodes) continue;
        nodes++;
        for (char *f = strtok(line, ",\n"); f; f = strtok(NULL, ",\n")) {
            while (*f == ' ')
                f++;
            if (strlen(f) > widest) widest = strlen(f);
        }
    }
    if (fp) fclose(fp);
    CHECK(nodes > m.npoints);
    CHECK_MSG(widest <= VM__INP_FIELD, "widest node field %zu characters", widest);
    vm_mesh back;
    CHECK_OK(vm_mesh_read_inp(path, &back, NULL), NULL);
    CHECK(fx_same_mesh_within(&m, &back, 1, FX_DIGITS15_TOL * 1e-4));
    vm_mesh_free(&back);
    vm_mesh_free(&m);
}

/* Writes text to the test folder's file name and returns its path. */
static const char *put_text(const char *name, const char *text) {
    const char *path = vm_test_tmp(name);
    CHECK(vm_test_write_file(path, text, strlen(text)) == 0);
    return path;
}

/* A materials table with a header, comments and blank lines reads row by row; each kind of
 * bad row is refused with one line naming the file and the line. */
static void materials_table_reads_rows_and_refuses_bad_ones_by_line(void) {
    vm_material *mt = NULL;
    size_t n = 0;
    vm_error err;
    const char *good = put_text("mat_good.csv", "label, name, E, nu, density\n# bone first\n\n"
                                                "1,Bone,17000,0.3,1.9e-9\r\n-3, Soft_2 ,0.5,"
                                                "0.49,0\n");
    CHECK_OK(vm_materials_read(good, &mt, &n, &err), &err);
    CHECK(n == 2 && mt[0].label == 1 && strcmp(mt[0].name, "Bone") == 0 &&
          mt[0].young == 17000 && mt[0].poisson == 0.3 && mt[0].density == 1.9e-9);
    CHECK(n == 2 && mt[1].label == -3 && strcmp(mt[1].name, "Soft_2") == 0);
    vm_materials_free(mt);
    static const struct {
        const char *text, *says;
    } bad[] = {
        {"1,Bone,17000,0.3\n", "line 1: expected 5 fields"},
        {"1,Bone,17000,0.3,1,9\n", "more than 5"},
        {"label,name,E,nu,density\nx,Bone,1,0.3,1\n", "line 2: label \"x\""},
        {"1,2bone,1,0.3,1\n", "name \"2bone\""},
        {"1,bo ne,1,0.3,1\n", "name \"bo ne\""},
        {"1,Bone,0,0.3,1\n", "E \"0\""},
        {"1,Bone,1,0.5,1\n", "nu \"0.5\""},
        {"1,Bone,1,0.3,-1\n", "density \"-1\""},
        {"1,Bone,1,0.3,1\n1,Other,1,0.3,1\n", "line 2: label 1 is given twice"},
        {"1,Bone,1,0.3,1\n2,BONE,1,0.3,1\n", "name Bone is given to labels 1 and 2"},
        {"# nothing\nlabel,name,E,nu,density\n", "no material rows"},
        {"", "no material rows"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *path = put_text("mat_bad.csv", bad[i].text);
        vm_error_clear(&err);
        mt = NULL;
        vm_status st = vm_materials_read(path, &mt, &n, &err);
        CHECK_MSG(st != VM_OK && mt == NULL && n == 0, "accepted \"%s\"", bad[i].text);
        CHECK_MSG(strncmp(err.message, path, strlen(path)) == 0 && strstr(err.message, bad[i].says)
                      && !strchr(err.message, '\n'),
                  "\"%s\" gave \"%s\"", bad[i].text, err.message);
    }
    CHECK(vm_materials_read(vm_test_tmp("no_such.csv"), &mt, &n, &err) != VM_OK);
}

/* Reads the whole text of a file. */
static char *slurp(const char *path) {
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    size_t got = fread(b, 1, (size_t)n, fp);
    b[got] = 0;
    fclose(fp);
    return b;
}

static int cmp_key(const void *a, const void *b) {
    return memcmp(a, b, 4 * sizeof(long));
}

/* Every "elem, Sk" line of every *SURFACE SURF_* names a boundary face, and together they are
 * exactly the faces vm_mesh_boundary finds (compared by sorted original node numbers). */
static void check_surfaces(const vm_mesh *m, const char *path) {
    static const int tf[4][3] = {{0, 1, 2}, {0, 3, 1}, {1, 3, 2}, {2, 3, 0}};
    static const int hf[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1},
                                 {1, 5, 6, 2}, {2, 6, 7, 3}, {3, 7, 4, 0}};
    int hex = m->kind == VM_HEX8, fk = hex ? 4 : 3;
    size_t nn = (size_t)vm_cell_nodes(m->kind);
    vm_mesh b;
    CHECK(vm_mesh_boundary(m, &b, NULL) == VM_OK);
    long(*want)[4] = calloc(b.ncells + 1, sizeof *want);
    long(*got)[4] = calloc(b.ncells + 64, sizeof *got);
    for (size_t i = 0; i < b.ncells; i++) {
        for (int j = 0; j < fk; j++) {
            const double *p = b.points + 3 * (size_t)b.cells[i * (size_t)fk + (size_t)j];
            long orig = -1;
            for (size_t v = 0; v < m->npoints && orig < 0; v++)
                if (memcmp(m->points + 3 * v, p, 3 * sizeof(double)) == 0) orig = (long)v;
            want[i][j] = orig;
        }
        if (fk == 3) want[i][3] = -1;
    }
    char *text = slurp(path);
    size_t ng = 0;
    /* the region boundaries (interfaces between regions are IFACE_ surfaces) */
    for (char *s = strstr(text, "*SURFACE, NAME=SURF_"); s;
         s = strstr(s + 1, "*SURFACE, NAME=SURF_")) {
        char *line = strchr(s, '\n') + 1;
        long e;
        int f;
        while (sscanf(line, "%ld, S%d", &e, &f) == 2 && ng < b.ncells + 64) {
            CHECK(e >= 1 && (size_t)e <= m->ncells && f >= 1 && f <= (hex ? 6 : 4));
            for (int j = 0; j < fk; j++)
                got[ng][j] = (long)m->cells[(size_t)(e - 1) * nn + (size_t)(hex ? hf[f - 1][j] : tf[f - 1][j])];
            if (fk == 3) got[ng][3] = -1;
            ng++;
            line = strchr(line, '\n') + 1;
        }
    }
    CHECK_MSG(ng == b.ncells, "%zu surface faces, boundary has %zu", ng, b.ncells);
    /* sort the nodes inside each face, then the faces, and compare */
    long(*sets[2])[4] = {want, got};
    for (int k = 0; k < 2; k++) {
        for (size_t i = 0; i < b.ncells; i++)
            for (int a = 1; a < 4; a++)
                for (int c = a; c > 0 && sets[k][i][c - 1] > sets[k][i][c]; c--) {
                    long t = sets[k][i][c];
                    sets[k][i][c] = sets[k][i][c - 1];
                    sets[k][i][c - 1] = t;
                }
        qsort(sets[k], b.ncells, sizeof sets[k][0], cmp_key);
    }
    CHECK(ng != b.ncells || memcmp(want, got, b.ncells * sizeof want[0]) == 0);
    free(text);
    free(want);
    free(got);
    vm_mesh_free(&b);
}

static void inp_surfaces_name_exactly_the_boundary_faces(void) {
    for (int hex = 0; hex < 2; hex++) {
        vm_mesh m;
        fx_block(&m, 2, hex);
        const char *path = vm_test_tmp(hex ? "surf_hex.inp" : "surf_tet.inp");
        CHECK_OK(vm_mesh_write(path, &m, NULL), NULL);
        check_surfaces(&m, path);
        vm_mesh_free(&m);
    }
}

/* Parses the node ids of *NSET, NSET=name. */
static size_t read_nset(const char *text, const char *name, long *ids, size_t cap) {
    char key[64];
    snprintf(key, sizeof key, "*NSET, NSET=%s\n", name);
    const char *s = strstr(text, key);
    if (!s) return 0;
    s += strlen(key);
    size_t n = 0;
    while (*s && *s != '*' && n < cap) {
        char *e;
        long v = strtol(s, &e, 10);
        if (e == s) break;
        ids[n++] = v;
        s = e;
        while (*s == ',' || *s == ' ' || *s == '\n')
            s++;
    }
    return n;
}

/* An octahedron standing on a vertex (4 tets around its vertical axis): only that vertex
 * lies within 1% of the bottom, so the fixed slab widens to the third-lowest node (the
 * equator, z = 1) rather than clamping the whole body, which leaves ccx nothing to solve. */
static void inp_static_deck_widens_a_slab_of_one_node(void) {
    vm_mesh m;
    vm_mesh_init(&m, VM_TET4);
    static const double p[6][3] = {{0, 0, 0}, {1, 0, 1}, {0, 1, 1}, {-1, 0, 1}, {0, -1, 1},
                                   {0, 0, 2}};
    for (int i = 0; i < 6; i++)
        vm_mesh_add_point(&m, p[i], NULL);
    for (int i = 0; i < 4; i++) {
        vm_index c[4] = {0, (vm_index)(1 + i), (vm_index)(1 + (i + 1) % 4), 5};
        double q[4][3];
        for (int k = 0; k < 4; k++)
            memcpy(q[k], p[c[k]], sizeof q[k]);
        if (vm_tet_signed_volume((const double(*)[3])q) < 0) {
            vm_index t = c[1];
            c[1] = c[2];
            c[2] = t;
        }
        vm_mesh_add_cell(&m, c, 1, NULL);
    }
    const char *path = vm_test_tmp("deck_one_node.inp");
    vm_mesh_write_options o = opts(1, VM_DECK_STATIC);
    CHECK_OK(vm_mesh_write_as(path, &m, &o, NULL), NULL);
    char *text = slurp(path);
    long ids[16];
    size_t nf = read_nset(text, "FIXED", ids, 16);
    CHECK_MSG(nf == 5, "%zu fixed nodes, want the 5 of z <= 1", nf);
    for (size_t i = 0; i < nf; i++)
        CHECK(ids[i] != 6); /* the top stays free */
    free(text);
    vm_mesh_free(&m);
}

static void inp_static_deck_fixes_the_bottom_slab_and_loads_the_top(void) {
    vm_mesh m;
    fx_block(&m, 2, 0);
    const char *path = vm_test_tmp("deck_sets.inp");
    vm_mesh_write_options o = opts(1, VM_DECK_STATIC);
    CHECK_OK(vm_mesh_write_as(path, &m, &o, NULL), NULL);
    char *text = slurp(path);
    long ids[256];
    size_t nf = read_nset(text, "FIXED", ids, 256);
    CHECK(nf == 9); /* the 3x3 nodes of the z = min face */
    for (size_t i = 0; i < nf; i++)
        CHECK(m.points[3 * (size_t)(ids[i] - 1) + 2] == 100.0 / 3.0);
    size_t nl = read_nset(text, "LOADED", ids, 256);
    CHECK(nl == 9);
    for (size_t i = 0; i < nl; i++)
        CHECK(m.points[3 * (size_t)(ids[i] - 1) + 2] == 2 * 1.1 + 100.0 / 3.0);
    static const char *const need[] = {"*STEP\n*STATIC\n*BOUNDARY\nFIXED, 1, 3\n*CLOAD\nLOADED, 3, ",
                                       "*NODE FILE\nU\n*EL FILE\nS\n", "*END STEP\n",
                                       "*MATERIAL, NAME=MAT_REGION_M3\n*ELASTIC\n210000, 0.3\n",
                                       "*SOLID SECTION, ELSET=REGION_M3, MATERIAL=",
                                       "*ELSET, ELSET=REGION_7\n", "*NSET, NSET=NB_REGION_0\n",
                                       "*SURFACE, NAME=SURF_REGION_2, TYPE=ELEMENT\n"};
    for (size_t i = 0; i < sizeof need / sizeof need[0]; i++)
        CHECK_MSG(strstr(text, need[i]) != NULL, "deck lacks \"%s\"", need[i]);
    free(text);
    /* second order: the mid-edge nodes of the slab are fixed too, each edge has one node */
    o = opts(2, VM_DECK_STATIC);
    CHECK_OK(vm_mesh_write_as(path, &m, &o, NULL), NULL);
    text = slurp(path);
    CHECK(read_nset(text, "FIXED", ids, 256) == 9 + 16); /* 16 edges on the bottom face */
    const char *nodes = strstr(text, "*NODE, NSET=NALL\n");
    size_t lines = 0;
    for (const char *s = nodes; s && *s && s[1] != '*'; s = strchr(s + 1, '\n'))
        lines++;
    /* one node per distinct edge: count the edges by brute force */
    static const int te[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
    long(*edges)[2] = malloc(6 * m.ncells * sizeof *edges);
    size_t ne = 0;
    for (size_t c = 0; c < m.ncells; c++)
        for (int k = 0; k < 6; k++) {
            long a = m.cells[4 * c + (size_t)te[k][0]], b = m.cells[4 * c + (size_t)te[k][1]];
            if (a > b) {
                long t = a;
                a = b;
                b = t;
            }
            size_t j = 0;
            while (j < ne && !(edges[j][0] == a && edges[j][1] == b))
                j++;
            if (j == ne) {
                edges[ne][0] = a;
                edges[ne][1] = b;
                ne++;
            }
        }
    free(edges);
    CHECK_MSG(lines - 1 == 27 + ne, "%zu lines incl. *NODE, expected 27 + %zu edges", lines, ne);
    free(text);
    vm_mesh_free(&m);
}

static void inp_reader_takes_other_writers_layouts(void) {
    /* continuation lines, element sets by GENERATE, an ELSET= on *ELEMENT, comments, node
     * ids out of order, C3D4H, 2-D coordinates missing z, beams skipped */
    const char *deck =
        "** made by hand\n*Heading\n test\n*Node\n 10, 0., 0., 0.\n 30, 1., 0., 0.\n"
        " 20, 0., 1., 0.\n 40, 0., 0., 1.\n 50, 1., 1., 1.\n*Element, type=C3D4H, elset=PART\n"
        "1, 10, 30,\n 20, 40\n2, 30, 50, 20, 40\n*ELEMENT, TYPE=B31\n9, 10, 50\n"
        "*Elset, elset=REGION_5, generate\n 2, 2, 1\n*Solid Section, elset=PART, material=M\n"
        ",\n*End Step\n";
    const char *path = vm_test_tmp("layouts.inp");
    vm_test_write_file(path, deck, strlen(deck));
    vm_mesh m;
    vm_error err;
    CHECK_OK(vm_mesh_read_inp(path, &m, &err), &err);
    CHECK(m.kind == VM_TET4 && m.npoints == 5 && m.ncells == 2);
    if (m.ncells == 2) {
        CHECK(m.cells[0] == 0 && m.cells[1] == 1 && m.cells[2] == 2 && m.cells[3] == 3);
        CHECK(m.region[0] == 0 && m.region[1] == 5);
    }
    vm_mesh_free(&m);
}

static void inp_reader_refuses_malformed_decks(void) {
    static const char *const bad[] = {
        "",
        "hello\n",
        "*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n",
        "*NODE\n1, x, 0, 0\n",
        "*NODE\n1, 0, 0, 0\n1, 1, 0, 0\n*ELEMENT, TYPE=C3D4\n1, 1, 1, 1, 1\n",
        "*NODE\n1, 0, 0, 0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3\n",
        "*NODE\n1, 0, 0, 0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4, 5\n",
        "*NODE\n1, 0, 0, 0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, z\n",
        "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n5,1,1,1\n6,1,0,1\n7,0,1,1\n8,2,2,2\n"
        "*ELEMENT, TYPE=C3D4\n1, 1, 2, 3, 4\n*ELEMENT, TYPE=C3D8\n2, 1, 2, 3, 4, 5, 6, 7, 8\n",
        "*INCLUDE, INPUT=other.inp\n",
        "*NODE, SYSTEM=C\n1, 0, 0, 0\n",
        "*NODE\n1, 0, 0, 0\n*ELEMENT, TYPE=B31\n1, 1, 1\n",
        "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n"
        "*ELSET, ELSET=REGION_1, GENERATE\n5, 1\n",
        "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n"
        "*ELSET, ELSET=REGION_1\nALL\n",
        "*NODE\n1,0,0,0\n2,1,0,0\n3,0,1,0\n4,0,0,1\n*ELEMENT, TYPE=C3D4\n1,1,2,3,4\n"
        "*ELSET, ELSET=REGION_1\n1\n*ELSET, ELSET=REGION_2\n1\n",
        "*NODE\n1, 1e999, 0, 0\n",
        "*NODE\n99999999999999999999999, 0, 0, 0\n",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        fx_expect_error(vm_mesh_read_inp, "bad.inp", bad[i], strlen(bad[i]));
    vm_mesh m;
    vm_error err;
    CHECK(vm_mesh_read_inp(vm_test_tmp("missing.inp"), &m, &err) == VM_ERR_IO);
}

static void inp_truncated_decks_never_crash(void) {
    vm_mesh m;
    fx_block(&m, 1, 1);
    vm_mesh_write_options o = opts(2, VM_DECK_STATIC);
    CHECK_OK(vm_mesh_write_as(vm_test_tmp("trunc_src.inp"), &m, &o, NULL), NULL);
    vm_mesh_free(&m);
    fx_truncations(vm_mesh_read_inp, "trunc_src.inp", "trunc.inp", 7);
    fx_write_fails_cleanly("inp");
}

/* Every region gets its own *MATERIAL (the table's row, else MAT_REGION_r with the
 * placeholder values) and *SOLID SECTION; the outer boundary and each interface get a
 * *SURFACE and an *NSET. */
static void inp_writes_one_material_and_section_per_region(void) {
    vm_mesh m;
    fx_block(&m, 2, 0); /* regions -3, 0, 1, 2, 7 */
    static const vm_material table[] = {{1, "Bone", 17000, 0.3, 1.9e-9},
                                        {-3, "Soft", 0.5, 0.49, 0}, {99, "Unused", 1, 0, 0}};
    vm_mesh_write_options o = opts(1, VM_DECK_NONE);
    o.materials = table;
    o.nmaterials = 3;
    const char *path = vm_test_tmp("materials.inp");
    CHECK_OK(vm_mesh_write_as(path, &m, &o, NULL), NULL);
    char *text = slurp(path);
    static const char *const need[] = {
        "*MATERIAL, NAME=Bone\n*ELASTIC\n17000, 0.3\n*DENSITY\n1.9E-9\n",
        "*SOLID SECTION, ELSET=REGION_1, MATERIAL=Bone\n",
        "*MATERIAL, NAME=Soft\n*ELASTIC\n0.5, 0.49\n*DENSITY\n0\n",
        "*SOLID SECTION, ELSET=REGION_M3, MATERIAL=Soft\n",
        "*MATERIAL, NAME=MAT_REGION_7\n*ELASTIC\n210000, 0.3\n",
        "*SOLID SECTION, ELSET=REGION_7, MATERIAL=MAT_REGION_7\n",
        "*SOLID SECTION, ELSET=REGION_0, MATERIAL=MAT_REGION_0\n",
        "*SURFACE, NAME=OUTER, TYPE=ELEMENT\n", "*NSET, NSET=NB_OUTER\n",
        "*SURFACE, NAME=IFACE_REGION_1_REGION_2, TYPE=ELEMENT\n",
        "*NSET, NSET=NIF_REGION_1_REGION_2\n"};
    for (size_t i = 0; i < sizeof need / sizeof need[0]; i++)
        CHECK_MSG(text && strstr(text, need[i]) != NULL, "deck lacks \"%s\"", need[i]);
    size_t materials = 0, sections = 0, ifaces = 0, nifs = 0;
    for (const char *p = text; p && (p = strchr(p, '*')) != NULL; p++) {
        materials += strncmp(p, "*MATERIAL,", 10) == 0;
        sections += strncmp(p, "*SOLID SECTION,", 15) == 0;
        ifaces += strncmp(p, "*SURFACE, NAME=IFACE_", 21) == 0;
        nifs += strncmp(p, "*NSET, NSET=NIF_", 16) == 0;
    }
    CHECK_MSG(materials == 5 && sections == 5, "%zu materials, %zu sections for 5 regions",
              materials, sections);
    CHECK_MSG(ifaces > 0 && nifs == ifaces, "%zu interface surfaces, %zu node sets", ifaces,
              nifs);
    CHECK(!strstr(text ? text : "", "Unused"));
    free(text);
    /* the outer surface is exactly the boundary: as many faces as vm_mesh_boundary's */
    vm_mesh b;
    CHECK_OK(vm_mesh_boundary(&m, &b, NULL), NULL);
    text = slurp(path);
    const char *outer = text ? strstr(text, "*SURFACE, NAME=OUTER, TYPE=ELEMENT\n") : NULL;
    size_t lines = 0;
    for (const char *p = outer ? strchr(outer, '\n') + 1 : NULL; p && *p && *p != '*';
         p = strchr(p, '\n') + 1)
        lines++;
    CHECK_MSG(lines == b.ncells, "OUTER has %zu faces, the boundary %zu", lines, b.ncells);
    free(text);
    vm_mesh_free(&b);
    /* materials go to decks only */
    vm_error err;
    CHECK(vm_mesh_write_as(vm_test_tmp("materials.vtu"), &m, &o, &err) == VM_ERR_ARG);
    CHECK(!vm_test_exists(vm_test_tmp("materials.vtu")));
    vm_mesh_free(&m);
}

static void inp_writer_refuses_what_it_cannot_write(void) {
    vm_mesh m;
    fx_surface(&m, 0);
    vm_mesh_write_options o = opts(2, VM_DECK_NONE);
    vm_error err;
    CHECK(vm_mesh_write_as(vm_test_tmp("o2.inp"), &m, &o, &err) == VM_ERR_UNSUPPORTED);
    o = opts(2, VM_DECK_NONE);
    CHECK(vm_mesh_write_as(vm_test_tmp("o2.mesh"), &m, &o, &err) == VM_ERR_ARG);
    CHECK(vm_mesh_write_as(vm_test_tmp("o2.msh"), &m, &o, &err) == VM_ERR_UNSUPPORTED);
    CHECK(!vm_test_exists(vm_test_tmp("o2.msh")));
    o = opts(1, VM_DECK_STATIC);
    CHECK(vm_mesh_write_as(vm_test_tmp("deck.vtk"), &m, &o, &err) == VM_ERR_ARG);
    vm_mesh_free(&m);
    vm_mesh_init(&m, VM_TET4);
    o = opts(1, VM_DECK_STATIC);
    CHECK(vm_mesh_write_as(vm_test_tmp("empty.inp"), &m, &o, &err) == VM_ERR_EMPTY);
    CHECK(!vm_test_exists(vm_test_tmp("empty.inp")));
}

/* `volmesh convert`: every format to every format through the CLI, and usage errors exit 2
 * with one "volmesh: ..." line. */
static void convert_cli_round_trips_and_refuses_bad_usage(void) {
    vm_mesh m;
    fx_block(&m, 2, 0);
    const char *src = vm_test_tmp("cli_src.vtu");
    CHECK_OK(vm_mesh_write(src, &m, NULL), NULL);
    static const char *const exts[] = {"vtk", "inp", "msh", "msh2", "mesh"};
    for (size_t i = 0; i < sizeof exts / sizeof exts[0]; i++) {
        char args[1024], out[256], back[256];
        snprintf(out, sizeof out, "%s", vm_test_tmp("cli_out"));
        snprintf(out + strlen(out), sizeof out - strlen(out), ".%s", exts[i]);
        snprintf(back, sizeof back, "%s", vm_test_tmp("cli_back.vtu"));
        snprintf(args, sizeof args, "convert '%s' '%s'", src, out);
        CHECK(vm_test_cli(args, NULL) == 0);
        snprintf(args, sizeof args, "convert '%s' '%s'", out, back);
        CHECK(vm_test_cli(args, NULL) == 0);
        vm_mesh b;
        CHECK_OK(vm_mesh_read(back, &b, NULL), NULL);
        /* .inp fields hold 20 characters: 15 digits where the exact text is wider */
        CHECK_MSG(fx_same_mesh_within(&m, &b, 1, strcmp(exts[i], "inp") ? 0 : FX_DIGITS15_TOL),
                  "convert via .%s", exts[i]);
        vm_mesh_free(&b);
    }
    char args[1024];
    static const char *const bad[] = {"convert", "convert a.vtu", "convert a.vtu b.xyz",
                                      "convert a.vtu b.mesh --order 2",
                                      "convert a.vtu b.msh --deck static",
                                      "convert a.vtu b.inp --deck dynamic",
                                      "convert a.vtu b.inp --order 3", "convert a.vtu b.inp --bogus",
                                      "convert a.vtu b.obj --ascii", "convert missing.vtu b.inp",
                                      "convert a.vtu b.inp --materials missing.csv",
                                      "convert a.vtu b.inp --materials",
                                      "convert a.vtu b.inp --format nope"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char *out = NULL;
        snprintf(args, sizeof args, "%s", bad[i]);
        int rc = vm_test_cli(args, &out);
        CHECK_MSG(rc == 2, "'%s' exited %d", bad[i], rc);
        CHECK_MSG(out && strncmp(out, "volmesh: ", 9) == 0 && strchr(out, '\n') == out + strlen(out) - 1,
                  "'%s' printed \"%s\"", bad[i], out ? out : "");
        free(out);
    }
    char *help = NULL;
    CHECK(vm_test_cli("convert --help", &help) == 0 && help && strstr(help, "--deck static"));
    free(help);
    vm_mesh_free(&m);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"inp_numbers_fit_twenty_characters_and_read_back",
         inp_numbers_fit_twenty_characters_and_read_back},
        {"inp_node_fields_near_zero_fit_calculix", inp_node_fields_near_zero_fit_calculix},
        {"inp_round_trip_is_exact_for_every_kind", inp_round_trip_is_exact_for_every_kind},
        {"inp_second_order_and_deck_read_back_as_the_first_order_mesh",
         inp_second_order_and_deck_read_back_as_the_first_order_mesh},
        {"inp_surfaces_name_exactly_the_boundary_faces",
         inp_surfaces_name_exactly_the_boundary_faces},
        {"inp_static_deck_fixes_the_bottom_slab_and_loads_the_top",
         inp_static_deck_fixes_the_bottom_slab_and_loads_the_top},
        {"inp_static_deck_widens_a_slab_of_one_node", inp_static_deck_widens_a_slab_of_one_node},
        {"inp_reader_takes_other_writers_layouts", inp_reader_takes_other_writers_layouts},
        {"inp_reader_refuses_malformed_decks", inp_reader_refuses_malformed_decks},
        {"inp_truncated_decks_never_crash", inp_truncated_decks_never_crash},
        {"inp_writer_refuses_what_it_cannot_write", inp_writer_refuses_what_it_cannot_write},
        {"materials_table_reads_rows_and_refuses_bad_ones_by_line",
         materials_table_reads_rows_and_refuses_bad_ones_by_line},
        {"inp_writes_one_material_and_section_per_region",
         inp_writes_one_material_and_section_per_region},
        {"convert_cli_round_trips_and_refuses_bad_usage",
         convert_cli_round_trips_and_refuses_bad_usage},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
