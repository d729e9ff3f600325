/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_render.c — vm_render_mesh and the PNG encoder on meshes whose pictures
 * are known in outline: a single tet, a block of hexes, a tet ball, a hex torus; the PNG is
 * decoded here with zlib (chunks, CRCs, filters) and written with a raw dump beside it for
 * tests/quality/test_render_png.py to decode independently. */
#define _POSIX_C_SOURCE 200809L
#include "test.h"
#include "volmesh/render.h"
#include <dirent.h>
#include <string.h>
#include <zlib.h>

/* --- meshes ------------------------------------------------------------------------------ */

static void single_tet(vm_mesh *m) {
    static const double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    vm_mesh_init(m, VM_TET4);
    for (int i = 0; i < 4; i++)
        vm_mesh_add_point(m, p[i], NULL);
    vm_index n[4] = {0, 1, 2, 3};
    CHECK_OK(vm_mesh_add_cell(m, n, 0, NULL), NULL);
}

/* Grid points (n+1)^3 of [-1,1]^3, optionally pushed radially onto the ball: p |p|_inf/|p|
 * maps the cube's surface onto the unit sphere. */
static void grid_points(vm_mesh *m, int n, int ball) {
    for (int k = 0; k <= n; k++)
        for (int j = 0; j <= n; j++)
            for (int i = 0; i <= n; i++) {
                double p[3] = {-1 + 2.0 * i / n, -1 + 2.0 * j / n, -1 + 2.0 * k / n};
                double inf = fmax(fabs(p[0]), fmax(fabs(p[1]), fabs(p[2])));
                double l2 = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                if (ball && l2 > 0)
                    for (int d = 0; d < 3; d++)
                        p[d] *= inf / l2;
                vm_mesh_add_point(m, p, NULL);
            }
}

static vm_index grid_node(int n, int i, int j, int k) {
    return (vm_index)(i + (n + 1) * (j + (n + 1) * k));
}

/* n^3 hexes filling [-1,1]^3, region = 1 + (i >= n/2). */
static void hex_block(vm_mesh *m, int n) {
    vm_mesh_init(m, VM_HEX8);
    grid_points(m, n, 0);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                vm_index h[8] = {grid_node(n, i, j, k),         grid_node(n, i + 1, j, k),
                                 grid_node(n, i + 1, j + 1, k), grid_node(n, i, j + 1, k),
                                 grid_node(n, i, j, k + 1),     grid_node(n, i + 1, j, k + 1),
                                 grid_node(n, i + 1, j + 1, k + 1),
                                 grid_node(n, i, j + 1, k + 1)};
                CHECK_OK(vm_mesh_add_cell(m, h, 1 + (2 * i >= n), NULL), NULL);
            }
}

/* The unit ball: each grid cube cut into six Kuhn tets along its main diagonal, all made
 * positive. */
static void tet_ball(vm_mesh *m, int n) {
    static const int perm[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                   {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
    vm_mesh_init(m, VM_TET4);
    grid_points(m, n, 1);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++)
                for (int t = 0; t < 6; t++) {
                    int at[3] = {i, j, k};
                    vm_index tet[4];
                    tet[0] = grid_node(n, at[0], at[1], at[2]);
                    for (int s = 0; s < 3; s++) {
                        at[perm[t][s]]++;
                        tet[s + 1] = grid_node(n, at[0], at[1], at[2]);
                    }
                    double p[4][3];
                    for (int c = 0; c < 4; c++)
                        memcpy(p[c], m->points + 3 * (size_t)tet[c], sizeof p[c]);
                    if (vm_tet_signed_volume((const double(*)[3])p) < 0) {
                        vm_index s = tet[1];
                        tet[1] = tet[2];
                        tet[2] = s;
                    }
                    CHECK_OK(vm_mesh_add_cell(m, tet, 0, NULL), NULL);
                }
}

/* A solid torus of hexes around +z: ring radius 1, tube radius 0.4, nr segments around the
 * ring, an nc x nc square cross-section pushed onto the tube's disc. */
static void hex_torus(vm_mesh *m, int nr, int nc) {
    vm_mesh_init(m, VM_HEX8);
    for (int a = 0; a < nr; a++) {
        double th = 2 * 3.14159265358979 * a / nr;
        for (int k = 0; k <= nc; k++)
            for (int j = 0; j <= nc; j++) {
                double s = -1 + 2.0 * j / nc, t = -1 + 2.0 * k / nc;
                double inf = fmax(fabs(s), fabs(t)), l2 = hypot(s, t);
                if (l2 > 0) {
                    s *= inf / l2;
                    t *= inf / l2;
                }
                double rr = 1.0 + 0.4 * s;
                double p[3] = {rr * cos(th), rr * sin(th), 0.4 * t};
                vm_mesh_add_point(m, p, NULL);
            }
    }
    int per = (nc + 1) * (nc + 1);
    for (int a = 0; a < nr; a++)
        for (int k = 0; k < nc; k++)
            for (int j = 0; j < nc; j++) {
                int b = (a + 1) % nr;
                vm_index h[8] = {a * per + k * (nc + 1) + j,       a * per + k * (nc + 1) + j + 1,
                                 b * per + k * (nc + 1) + j + 1,   b * per + k * (nc + 1) + j,
                                 a * per + (k + 1) * (nc + 1) + j, a * per + (k + 1) * (nc + 1) + j + 1,
                                 b * per + (k + 1) * (nc + 1) + j + 1,
                                 b * per + (k + 1) * (nc + 1) + j};
                double p[8][3];
                for (int c = 0; c < 8; c++)
                    memcpy(p[c], m->points + 3 * (size_t)h[c], sizeof p[c]);
                if (vm_hex_volume((const double(*)[3])p) < 0)
                    for (int c = 0; c < 4; c++) {
                        vm_index s = h[c];
                        h[c] = h[c + 4];
                        h[c + 4] = s;
                    }
                CHECK_OK(vm_mesh_add_cell(m, h, 3, NULL), NULL);
            }
}

/* --- image helpers ------------------------------------------------------------------------ */

static const unsigned char *px(const vm_image *img, int x, int y) {
    return img->pixels + 3 * ((size_t)y * (size_t)img->width + (size_t)x);
}

static int is_bg(const vm_image *img, int x, int y, const unsigned char bg[3]) {
    return memcmp(px(img, x, y), bg, 3) == 0;
}

static double lum(const unsigned char *p) {
    return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
}

static int is_red(const unsigned char *p) {
    return p[0] > 100 && p[0] > 2 * p[1] && p[0] > 2 * p[2];
}

typedef struct coverage {
    size_t covered, red;
    int x0, x1, y0, y1; /* bounding box of covered pixels */
} coverage;

static coverage cover(const vm_image *img, const unsigned char bg[3]) {
    coverage c = {0, 0, img->width, -1, img->height, -1};
    for (int y = 0; y < img->height; y++)
        for (int x = 0; x < img->width; x++) {
            if (is_bg(img, x, y, bg)) continue;
            c.covered++;
            if (is_red(px(img, x, y))) c.red++;
            if (x < c.x0) c.x0 = x;
            if (x > c.x1) c.x1 = x;
            if (y < c.y0) c.y0 = y;
            if (y > c.y1) c.y1 = y;
        }
    return c;
}

static int corners_are_bg(const vm_image *img, const unsigned char bg[3]) {
    int w = img->width - 1, h = img->height - 1;
    return is_bg(img, 0, 0, bg) && is_bg(img, w, 0, bg) && is_bg(img, 0, h, bg) &&
           is_bg(img, w, h, bg);
}

static vm_render_options opts(int w, int h) {
    vm_render_options o;
    vm_render_options_default(&o);
    o.width = w;
    o.height = h;
    return o;
}

/* The fit fills 92 per cent of the limiting side, centred: the silhouette's box touches the
 * 4 per cent margins on that side (within a pixel or two of anti-aliasing). */
static void check_fit(const coverage *c, int w, int h) {
    double fx = (c->x1 - c->x0 + 1) / (double)w, fy = (c->y1 - c->y0 + 1) / (double)h;
    CHECK_MSG(fabs(fx - 0.92) < 0.02 || fabs(fy - 0.92) < 0.02, "fit %.3f x %.3f", fx, fy);
    CHECK_MSG(fx < 0.95 && fy < 0.95, "fit %.3f x %.3f", fx, fy);
    CHECK_NEAR(0.5 * (c->x0 + c->x1 + 1), 0.5 * w, 2.0);
    CHECK_NEAR(0.5 * (c->y0 + c->y1 + 1), 0.5 * h, 2.0);
}

/* --- rendering ---------------------------------------------------------------------------- */

static void renderSingleTetIsFramedByBackground(void) {
    vm_mesh m;
    single_tet(&m);
    vm_error err;
    for (int ortho = 0; ortho <= 1; ortho++) {
        vm_render_options o = opts(200, 150);
        o.orthographic = ortho;
        vm_image img;
        CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
        CHECK(img.width == 200 && img.height == 150 && img.pixels != NULL);
        coverage c = cover(&img, o.background);
        CHECK(corners_are_bg(&img, o.background));
        CHECK_MSG(c.covered > 200 * 150 / 10, "covered %zu", c.covered);
        CHECK(c.red == 0);
        check_fit(&c, 200, 150);
        vm_image_free(&img);
        CHECK(img.pixels == NULL && img.width == 0);
    }
    vm_mesh_free(&m);
}

static void renderHexBlockCoversCentreAndFillsFrame(void) {
    vm_mesh m;
    hex_block(&m, 4);
    vm_error err;
    for (int ortho = 0; ortho <= 1; ortho++) {
        vm_render_options o = opts(320, 240);
        o.orthographic = ortho;
        o.background[0] = 10;
        o.background[1] = 20;
        o.background[2] = 30;
        vm_image img;
        CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
        coverage c = cover(&img, o.background);
        CHECK(!is_bg(&img, 160, 120, o.background));
        CHECK(corners_are_bg(&img, o.background));
        check_fit(&c, 320, 240);
        vm_image_free(&img);
    }
    vm_mesh_free(&m);
}

static void renderBallShadingVariesAndCentreIsBrightest(void) {
    vm_mesh m;
    tet_ball(&m, 10);
    vm_error err;
    vm_render_options o = opts(240, 240);
    o.orthographic = 1;
    o.show_edges = 0;
    o.azimuth = 0;
    o.elevation = 0;
    vm_image img;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    coverage c = cover(&img, o.background);
    CHECK(corners_are_bg(&img, o.background));
    CHECK(!is_bg(&img, 120, 120, o.background));
    check_fit(&c, 240, 240);
    /* A disc of radius 0.46 * 240 = 110: covered inside, background outside. */
    CHECK(!is_bg(&img, 120 + 100, 120, o.background));
    CHECK(is_bg(&img, 120 + 85, 120 + 85, o.background));
    int seen[256] = {0}, distinct = 0;
    for (int y = 0; y < 240; y++)
        for (int x = 0; x < 240; x++)
            if (!is_bg(&img, x, y, o.background)) {
                int l = (int)lum(px(&img, x, y));
                if (!seen[l]++) distinct++;
            }
    CHECK_MSG(distinct > 40, "%d distinct grey levels", distinct);
    /* The headlight: the middle faces the viewer, the rim is grazing. */
    double mid = lum(px(&img, 122, 124)), rim = lum(px(&img, 120 + 105, 120));
    CHECK_MSG(mid > rim + 40, "middle %.0f rim %.0f", mid, rim);
    vm_image_free(&img);
    vm_mesh_free(&m);
}

static void renderTorusFromAboveShowsTheHole(void) {
    vm_mesh m;
    hex_torus(&m, 48, 4);
    vm_error err;
    vm_render_options o = opts(300, 300);
    o.orthographic = 1;
    o.elevation = 90;
    vm_image img;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    coverage c = cover(&img, o.background);
    check_fit(&c, 300, 300);
    /* Outer radius 1.4 fills 0.46 * 300 = 138 pixels; the hole has radius 0.6 -> 59 px. */
    CHECK(is_bg(&img, 150, 150, o.background));
    CHECK(is_bg(&img, 150 + 40, 150, o.background));
    CHECK(!is_bg(&img, 150 + 99, 150, o.background));
    CHECK(!is_bg(&img, 150, 150 - 99, o.background));
    CHECK(c.red == 0);
    vm_image_free(&img);
    vm_mesh_free(&m);
}

static void renderEdgesDarkenPixelsOnlyWhenShown(void) {
    vm_mesh m;
    hex_block(&m, 3);
    vm_error err;
    vm_render_options o = opts(300, 300);
    o.show_edges = 0;
    vm_image plain, edged;
    CHECK_OK(vm_render_mesh(&m, &o, &plain, &err), &err);
    o.show_edges = 1;
    o.edge_width = 1.5;
    CHECK_OK(vm_render_mesh(&m, &o, &edged, &err), &err);
    /* Anti-aliasing mixes faces with the white background or with each other, never
     * darker than the darkest face: darker pixels are edges. */
    double lmin = 255;
    for (int y = 0; y < 300; y++)
        for (int x = 0; x < 300; x++)
            if (!is_bg(&plain, x, y, o.background) && lum(px(&plain, x, y)) < lmin)
                lmin = lum(px(&plain, x, y));
    size_t dark = 0;
    for (int y = 0; y < 300; y++)
        for (int x = 0; x < 300; x++)
            if (lum(px(&edged, x, y)) < lmin - 15) dark++;
    CHECK_MSG(dark > 500, "%zu edge pixels (darkest face %.0f)", dark, lmin);
    vm_image_free(&plain);
    vm_image_free(&edged);
    vm_mesh_free(&m);
}

static void renderHighlightIsRedOnlyWhenCellsQualify(void) {
    vm_mesh m;
    tet_ball(&m, 8);
    double *x = malloc(m.ncells * sizeof *x);
    for (size_t c = 0; c < m.ncells; c++) {
        double s = 0;
        for (int i = 0; i < 4; i++)
            s += m.points[3 * (size_t)m.cells[4 * c + (size_t)i]] / 4;
        x[c] = s;
    }
    vm_error err;
    CHECK_OK(vm_mesh_set_field(&m, 1, "x", 1, x, &err), &err);
    vm_render_options o = opts(200, 200);
    o.azimuth = 0; /* +x to the right */
    o.elevation = 0;
    o.highlight = "x";
    vm_image img;

    o.highlight_threshold = -5; /* no cell has x < -5 */
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    CHECK(cover(&img, o.background).red == 0);
    vm_image_free(&img);

    o.highlight_threshold = -0.3; /* the left part */
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    size_t left = 0, right = 0;
    for (int y = 0; y < 200; y++)
        for (int xx = 0; xx < 200; xx++)
            if (is_red(px(&img, xx, y))) {
                if (xx < 100)
                    left++;
                else
                    right++;
            }
    CHECK_MSG(left > 1000 && right == 0, "red left %zu right %zu", left, right);
    vm_image_free(&img);

    o.highlight_above = 1; /* x > -0.3: the rest */
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    CHECK(is_red(px(&img, 150, 100)) && !is_red(px(&img, 30, 100)));
    vm_image_free(&img);

    /* The same through highlight_values, and through a metric computed on the fly. */
    o.highlight = NULL;
    o.highlight_values = x;
    o.highlight_above = 0;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    CHECK(is_red(px(&img, 30, 100)) && !is_red(px(&img, 150, 100)));
    vm_image_free(&img);
    o.highlight_values = NULL;
    o.highlight = "min_dihedral";
    o.highlight_threshold = 0.0;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    CHECK(cover(&img, o.background).red == 0);
    vm_image_free(&img);
    o.highlight_threshold = 180.0;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    coverage all = cover(&img, o.background);
    CHECK_MSG(all.red > all.covered / 2, "red %zu of %zu", all.red, all.covered);
    vm_image_free(&img);

    /* Cells deep inside: invisible unless shown through the surface. */
    for (size_t c = 0; c < m.ncells; c++) {
        double ctr[3] = {0, 0, 0};
        for (int i = 0; i < 4; i++)
            for (int d = 0; d < 3; d++)
                ctr[d] += m.points[3 * (size_t)m.cells[4 * c + (size_t)i] + (size_t)d] / 4;
        x[c] = sqrt(ctr[0] * ctr[0] + ctr[1] * ctr[1] + ctr[2] * ctr[2]);
    }
    o.highlight = NULL;
    o.highlight_values = x;
    o.highlight_threshold = 0.4;
    o.highlight_above = 0;
    for (int hidden = 0; hidden <= 1; hidden++) {
        o.highlight_hidden = hidden;
        CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
        const unsigned char *mid = px(&img, 100, 100);
        int tinted = mid[0] > mid[1] + 40 && mid[0] > mid[2] + 40;
        CHECK_MSG(tinted == hidden, "hidden %d: centre %d %d %d", hidden, mid[0], mid[1],
                  mid[2]);
        CHECK(!is_red(px(&img, 100, 15)) && !is_red(px(&img, 15, 100)));
        vm_image_free(&img);
    }

    o.highlight_values = NULL;
    o.highlight = "no_such_metric";
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "no_such_metric") != NULL);
    CHECK(img.pixels == NULL);
    double *xyz = calloc(3 * m.ncells, sizeof *xyz);
    CHECK_OK(vm_mesh_set_field(&m, 1, "vec", 3, xyz, &err), &err);
    o.highlight = "vec";
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    free(xyz);
    free(x);
    vm_mesh_free(&m);
}

static void renderCutRemovesOneSideAndOpensTheVolume(void) {
    vm_mesh m;
    tet_ball(&m, 10);
    vm_error err;
    vm_render_options o = opts(240, 240);
    o.orthographic = 1;
    o.azimuth = 0;
    o.elevation = 0;
    vm_image whole, cut;
    CHECK_OK(vm_render_mesh(&m, &o, &whole, &err), &err);
    o.cut = VM_CUT_PLANE;
    o.cut_normal[0] = 2.0; /* x > 0.25 removed: the right part of the picture */
    o.cut_offset = 0.5;
    CHECK_OK(vm_render_mesh(&m, &o, &cut, &err), &err);
    /* Cells with centroid x <= 0.25 are kept: x from -1 to 0.25 plus part of a cell (0.2),
     * framed by the full height (2 units in 0.92 * 240 pixels): 137 to 170 pixels wide. */
    coverage c1 = cover(&cut, o.background);
    check_fit(&c1, 240, 240);
    int wide = c1.x1 - c1.x0 + 1;
    CHECK_MSG(wide >= 135 && wide <= 172, "the kept part is %d pixels wide", wide);
    CHECK(!is_bg(&whole, 120 + 100, 120, o.background));
    vm_image_free(&cut);

    /* Seen from the side of the removed part, the cut shows the tets inside: more distinct
     * face orientations than the sphere's own faces would give near the centre. */
    o.azimuth = 60;
    o.elevation = 10;
    o.cut = VM_CUT_AUTO;
    CHECK_OK(vm_render_mesh(&m, &o, &cut, &err), &err);
    vm_image_free(&whole);
    o.cut = VM_CUT_NONE;
    CHECK_OK(vm_render_mesh(&m, &o, &whole, &err), &err);
    coverage cw = cover(&whole, o.background), cc = cover(&cut, o.background);
    CHECK_MSG(cc.covered < cw.covered * 0.9 && cc.covered > cw.covered * 0.4,
              "cut covers %zu, whole %zu", cc.covered, cw.covered);
    /* The camera frames what is drawn: the kept part fills the picture too. */
    check_fit(&cc, 240, 240);
    vm_image_free(&cut);
    vm_image_free(&whole);

    /* A cut that keeps nothing: background only. A zero normal: refused. */
    o.cut = VM_CUT_PLANE;
    o.cut_normal[0] = 1;
    o.cut_offset = -10;
    CHECK_OK(vm_render_mesh(&m, &o, &cut, &err), &err);
    CHECK(cover(&cut, o.background).covered == 0);
    vm_image_free(&cut);
    o.cut_normal[0] = 0;
    CHECK(vm_render_mesh(&m, &o, &cut, &err) == VM_ERR_ARG);
    vm_mesh_free(&m);
}

static void renderBoundarySurfaceMatchesTheVolume(void) {
    vm_mesh m, s;
    hex_torus(&m, 24, 2);
    vm_error err;
    CHECK_OK(vm_mesh_boundary(&m, &s, &err), &err);
    vm_render_options o = opts(200, 150);
    vm_image a, b;
    CHECK_OK(vm_render_mesh(&m, &o, &a, &err), &err);
    CHECK_OK(vm_render_mesh(&s, &o, &b, &err), &err);
    double diff = 0;
    for (size_t i = 0; i < 3u * 200 * 150; i++)
        diff += abs(a.pixels[i] - b.pixels[i]);
    CHECK_MSG(diff / (3.0 * 200 * 150) < 0.5, "mean difference %g", diff / (3.0 * 200 * 150));
    vm_image_free(&b);
    /* A surface cut at z > 0 keeps the lower half of the faces. */
    o.cut = VM_CUT_PLANE;
    o.cut_normal[2] = 1;
    CHECK_OK(vm_render_mesh(&s, &o, &b, &err), &err);
    CHECK(cover(&b, o.background).covered < cover(&a, o.background).covered);
    vm_image_free(&a);
    vm_image_free(&b);
    vm_mesh_free(&s);
    vm_mesh_free(&m);
    /* And for triangles: a tet ball and its boundary. */
    tet_ball(&m, 5);
    CHECK_OK(vm_mesh_boundary(&m, &s, &err), &err);
    o = opts(200, 150);
    CHECK_OK(vm_render_mesh(&m, &o, &a, &err), &err);
    CHECK_OK(vm_render_mesh(&s, &o, &b, &err), &err);
    diff = 0;
    for (size_t i = 0; i < 3u * 200 * 150; i++)
        diff += abs(a.pixels[i] - b.pixels[i]);
    CHECK_MSG(diff / (3.0 * 200 * 150) < 0.5, "mean difference %g", diff / (3.0 * 200 * 150));
    vm_image_free(&a);
    vm_image_free(&b);
    vm_mesh_free(&s);
    vm_mesh_free(&m);
}

static int cmp_u32(const void *a, const void *b) {
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static size_t distinct_colours(const vm_image *img) {
    size_t n = (size_t)img->width * (size_t)img->height, count = 0;
    uint32_t *v = malloc(n * sizeof *v);
    for (size_t i = 0; i < n; i++) {
        const unsigned char *p = img->pixels + 3 * i;
        v[i] = (uint32_t)p[0] << 16 | (uint32_t)p[1] << 8 | p[2];
    }
    qsort(v, n, sizeof *v, cmp_u32);
    for (size_t i = 0; i < n; i++)
        if (i == 0 || v[i] != v[i - 1]) count++;
    free(v);
    return count;
}

static void renderIsDeterministicAndSupersamplingSmoothsEdges(void) {
    vm_mesh m;
    tet_ball(&m, 6);
    vm_error err;
    vm_render_options o = opts(160, 120);
    o.show_edges = 0;
    vm_image a, b, c;
    CHECK_OK(vm_render_mesh(&m, &o, &a, &err), &err);
    CHECK_OK(vm_render_mesh(&m, &o, &b, &err), &err);
    CHECK(memcmp(a.pixels, b.pixels, 3u * 160 * 120) == 0);
    o.supersample = 1;
    CHECK_OK(vm_render_mesh(&m, &o, &c, &err), &err);
    /* Anti-aliasing mixes faces with each other and with the background: many more
     * distinct colours than the faces alone give. */
    size_t na = distinct_colours(&a), nc = distinct_colours(&c);
    CHECK_MSG(na > 2 * nc, "%zu colours with 2x2 samples, %zu with one", na, nc);
    vm_image_free(&a);
    vm_image_free(&b);
    vm_image_free(&c);
    vm_mesh_free(&m);
}

static void renderRefusesBadOptionsAndMeshes(void) {
    vm_mesh m;
    single_tet(&m);
    vm_error err;
    vm_image img;
    vm_render_options o = opts(0, 10);
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    CHECK(strstr(err.message, "size") != NULL);
    o = opts(10, 10);
    o.supersample = 5;
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    o = opts(10, 10);
    o.elevation = 91;
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    o = opts(10, 10);
    o.edge_width = 0;
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_ARG);
    o.show_edges = 0; /* the width only matters with edges */
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    vm_image_free(&img);
    CHECK_OK(vm_render_mesh(&m, NULL, &img, &err), &err); /* defaults: 800 x 600 */
    CHECK(img.width == 800 && img.height == 600);
    vm_image_free(&img);
    /* Straight down and straight up, and with another up axis. */
    o = opts(40, 30);
    for (int e = -90; e <= 90; e += 90) {
        o.elevation = e;
        o.up[1] = e == 0 ? 1.0 : 0.0;
        CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
        CHECK(cover(&img, o.background).covered > 40);
        vm_image_free(&img);
    }
    m.cells[3] = 7;
    CHECK(vm_render_mesh(&m, NULL, &img, &err) == VM_ERR_ARG);
    vm_mesh_free(&m);
    vm_mesh_init(&m, VM_TET4);
    CHECK(vm_render_mesh(&m, NULL, &img, &err) == VM_ERR_EMPTY);
    CHECK(img.pixels == NULL);
    vm_mesh_free(&m);
}

static void renderOverTheMemoryLimitFailsCleanly(void) {
    vm_mesh m;
    tet_ball(&m, 4);
    vm_error err;
    vm_image img;
    setenv("VOLMESH_MAX_MEMORY", "100000", 1);
    vm_render_options o = opts(400, 300);
    CHECK(vm_render_mesh(&m, &o, &img, &err) == VM_ERR_NOMEM);
    CHECK(img.pixels == NULL);
    unsetenv("VOLMESH_MAX_MEMORY");
    vm_mesh_free(&m);
}

/* --- PNG ---------------------------------------------------------------------------------- */

static uint32_t be32(const unsigned char *p) {
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

/* A minimal PNG reader for 8-bit RGB: checks the signature, every chunk's CRC, IHDR and the
 * chunk order, inflates the IDATs and undoes the filters. Returns 0 and the pixels
 * (malloc'd) and the set of filter types used (bit t), or -1 with a reason printed. */
static int png_decode(const unsigned char *buf, size_t len, vm_image *out, int *filters) {
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    memset(out, 0, sizeof *out);
    *filters = 0;
    if (len < 8 || memcmp(buf, sig, 8) != 0) return fprintf(stderr, "  bad signature\n"), -1;
    size_t at = 8, zlen = 0;
    unsigned char *z = NULL;
    int w = 0, h = 0, seen_end = 0, nchunk = 0;
    while (at + 12 <= len && !seen_end) {
        uint32_t n = be32(buf + at);
        if (n > len - at - 12) return fprintf(stderr, "  chunk overruns\n"), free(z), -1;
        const unsigned char *type = buf + at + 4, *data = buf + at + 8;
        uLong crc = crc32(crc32(0L, Z_NULL, 0), type, 4 + n);
        if (crc != be32(data + n)) return fprintf(stderr, "  bad CRC\n"), free(z), -1;
        if (nchunk == 0 && (memcmp(type, "IHDR", 4) != 0 || n != 13))
            return fprintf(stderr, "  IHDR not first\n"), free(z), -1;
        if (memcmp(type, "IHDR", 4) == 0) {
            w = (int)be32(data);
            h = (int)be32(data + 4);
            if (data[8] != 8 || data[9] != 2 || data[10] || data[11] || data[12])
                return fprintf(stderr, "  not 8-bit RGB\n"), free(z), -1;
        } else if (memcmp(type, "IDAT", 4) == 0) {
            z = realloc(z, zlen + n + 1);
            memcpy(z + zlen, data, n);
            zlen += n;
        } else if (memcmp(type, "IEND", 4) == 0) {
            seen_end = n == 0;
        }
        at += 12 + n;
        nchunk++;
    }
    if (!seen_end || at != len) return fprintf(stderr, "  no IEND at the end\n"), free(z), -1;
    size_t row = 3 * (size_t)w;
    uLongf rawlen = (uLongf)((row + 1) * (size_t)h);
    unsigned char *raw = malloc(rawlen + 1);
    uLongf got = rawlen + 1;
    int zs = uncompress(raw, &got, z, (uLong)zlen);
    free(z);
    if (zs != Z_OK || got != rawlen)
        return fprintf(stderr, "  inflate: %d, %lu bytes\n", zs, (unsigned long)got), free(raw),
               -1;
    out->width = w;
    out->height = h;
    out->pixels = malloc(row * (size_t)h);
    for (int y = 0; y < h; y++) {
        int t = raw[(size_t)y * (row + 1)];
        const unsigned char *f = raw + (size_t)y * (row + 1) + 1;
        unsigned char *cur = out->pixels + (size_t)y * row;
        const unsigned char *prev = y ? cur - row : NULL;
        *filters |= 1 << t;
        for (size_t i = 0; i < row; i++) {
            int a = i >= 3 ? cur[i - 3] : 0, b = prev ? prev[i] : 0;
            int c = prev && i >= 3 ? prev[i - 3] : 0, p = a + b - c, pred;
            int pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
            switch (t) {
            case 0: pred = 0; break;
            case 1: pred = a; break;
            case 2: pred = b; break;
            case 3: pred = (a + b) >> 1; break;
            case 4: pred = (pa <= pb && pa <= pc) ? a : pb <= pc ? b : c; break;
            default: free(raw); vm_image_free(out); return fprintf(stderr, "  filter %d\n", t), -1;
            }
            cur[i] = (unsigned char)(f[i] + pred);
        }
    }
    free(raw);
    return 0;
}

/* A test card: gradients, noise, flat areas and stripes, so that every filter has a row
 * where it wins. */
static void test_card(vm_image *img, int w, int h) {
    img->width = w;
    img->height = h;
    img->pixels = malloc(3 * (size_t)w * (size_t)h);
    uint32_t seed = 12345;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            unsigned char *p = img->pixels + 3 * ((size_t)y * (size_t)w + (size_t)x);
            seed = seed * 1664525u + 1013904223u;
            int band = y * 5 / h;
            int noise = (int)(seed >> 24), noise2 = (int)(seed >> 16 & 255);
            int r = band == 0 ? x * 255 / w : band == 1 ? 200 : band == 3 ? (x + y) * 3 : x * y;
            p[0] = (unsigned char)(band == 2 ? noise : r & 255);
            p[1] = (unsigned char)(band == 4 ? (x ^ y) * 7 & 255 : y * 255 / h);
            p[2] = (unsigned char)(band == 2 ? noise2 : (x % 7) * 30);
        }
}

static int bits(int x) {
    int n = 0;
    for (; x; x >>= 1)
        n += x & 1;
    return n;
}

static void pngRoundTripsThroughZlibWithValidCrcs(void) {
    vm_error err;
    int sizes[][2] = {{1, 1}, {2, 3}, {67, 45}, {300, 200}};
    for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
        vm_image img, back;
        test_card(&img, sizes[s][0], sizes[s][1]);
        unsigned char *buf = NULL;
        size_t len = 0;
        CHECK_OK(vm_image_encode_png(&img, &buf, &len, &err), &err);
        int filters = 0;
        CHECK(png_decode(buf, len, &back, &filters) == 0);
        CHECK(back.width == img.width && back.height == img.height);
        CHECK(back.pixels && memcmp(back.pixels, img.pixels, 3 * (size_t)img.width *
                                                              (size_t)img.height) == 0);
        if (sizes[s][0] == 300)
            CHECK_MSG(bits(filters) >= 3, "filters used: %#x (want three kinds or more)",
                      filters);
        free(buf);
        vm_image_free(&img);
        vm_image_free(&back);
    }
    vm_image empty = {0, 0, NULL};
    unsigned char *buf = (unsigned char *)&err;
    size_t len = 7;
    CHECK(vm_image_encode_png(&empty, &buf, &len, &err) == VM_ERR_ARG);
    CHECK(buf == NULL && len == 0);
}

static int write_atomic(const char *path, const void *data, size_t len) {
    char tmp[4200];
    snprintf(tmp, sizeof tmp, "%s.part", path);
    if (vm_test_write_file(tmp, data, len)) return -1;
    return rename(tmp, path);
}

static int folder_has_temp_files(const char *dir) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    int found = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strncmp(e->d_name, "render_", 7) == 0 && strstr(e->d_name, ".tmp-")) found = 1;
    closedir(d);
    return found;
}

/* Writes render_torus.png / .rgb and render_card.png / .rgb for test_render_png.py. */
static void pngFilesDecodeToTheRenderedPixels(void) {
    vm_mesh m;
    hex_torus(&m, 36, 3);
    vm_error err;
    vm_render_options o = opts(320, 200);
    o.cut = VM_CUT_AUTO;
    o.highlight = "skew";
    o.highlight_threshold = 0.3;
    o.highlight_above = 1;
    vm_image img, card;
    CHECK_OK(vm_render_mesh(&m, &o, &img, &err), &err);
    test_card(&card, 67, 45);
    const char *names[2] = {"render_torus", "render_card"};
    const vm_image *imgs[2] = {&img, &card};
    for (int i = 0; i < 2; i++) {
        char png[256], rgb[256];
        snprintf(png, sizeof png, "%s.png", names[i]);
        snprintf(rgb, sizeof rgb, "%s.rgb", names[i]);
        char png_path[4096], rgb_path[4096];
        snprintf(png_path, sizeof png_path, "%s", vm_test_tmp(png));
        snprintf(rgb_path, sizeof rgb_path, "%s", vm_test_tmp(rgb));
        CHECK_OK(vm_image_write_png(png_path, imgs[i], &err), &err);
        CHECK(write_atomic(rgb_path, imgs[i]->pixels,
                           3 * (size_t)imgs[i]->width * (size_t)imgs[i]->height) == 0);
        FILE *fp = fopen(png_path, "rb");
        CHECK(fp != NULL);
        if (!fp) continue;
        unsigned char *buf = malloc(1 << 22);
        size_t len = fread(buf, 1, 1 << 22, fp);
        fclose(fp);
        vm_image back;
        int filters;
        CHECK(png_decode(buf, len, &back, &filters) == 0);
        CHECK(back.pixels && back.width == imgs[i]->width &&
              memcmp(back.pixels, imgs[i]->pixels, 3 * (size_t)back.width * (size_t)back.height) == 0);
        vm_image_free(&back);
        free(buf);
    }
    /* Into a folder that does not exist: an I/O error naming the path, nothing left. */
    char missing[4096];
    snprintf(missing, sizeof missing, "%s", vm_test_tmp("no-such-folder/x.png"));
    CHECK(vm_image_write_png(missing, &img, &err) == VM_ERR_IO);
    CHECK(strstr(err.message, "no-such-folder/x.png") != NULL);
    CHECK(!vm_test_exists(missing));
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", vm_test_tmp("."));
    CHECK(!folder_has_temp_files(dir));
    vm_image_free(&img);
    vm_image_free(&card);
    vm_mesh_free(&m);
}

TEST_MAIN(T(renderSingleTetIsFramedByBackground),
          T(renderHexBlockCoversCentreAndFillsFrame),
          T(renderBallShadingVariesAndCentreIsBrightest),
          T(renderTorusFromAboveShowsTheHole),
          T(renderEdgesDarkenPixelsOnlyWhenShown),
          T(renderHighlightIsRedOnlyWhenCellsQualify),
          T(renderCutRemovesOneSideAndOpensTheVolume),
          T(renderBoundarySurfaceMatchesTheVolume),
          T(renderIsDeterministicAndSupersamplingSmoothsEdges),
          T(renderRefusesBadOptionsAndMeshes),
          T(renderOverTheMemoryLimitFailsCleanly),
          T(pngRoundTripsThroughZlibWithValidCrcs),
          T(pngFilesDecodeToTheRenderedPixels))
