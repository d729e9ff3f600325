/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/render.c — software rendering of a mesh to an RGB image: camera fit, crinkle
 * cut-away, z-buffered half-space triangle rasterisation with flat Lambert shading, edges
 * from the distance to the face's edges, and box-filtered supersampling.
 * Rasterisation follows J. Pineda, "A Parallel Algorithm for Polygon Rasterization",
 * SIGGRAPH 1988 (edge functions); depth is interpolated in screen space, so perspective
 * stores 1/depth (Foley, van Dam et al., "Computer Graphics", 2nd ed., section 15.4). */
#include "../core/core.h"
#include "volmesh/quality.h"
#include "volmesh/render.h"
#include "../core/vec3.h"
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define DEG2RAD (3.14159265358979323846 / 180.0)
#define HALF_FOV_DEG 15.0 /* half the perspective field of view (30 degrees, a normal lens) */
/* Option ranges (include/volmesh/render.h documents them). */
#define MAX_IMAGE_SIDE 16384 /* pixels per side */
#define MAX_SUPERSAMPLE 4    /* samples per pixel side: 16 per pixel at most */
#define MIN_EDGE_WIDTH 0.25  /* pixels */
#define MAX_EDGE_WIDTH 8.0
/* Hidden highlighted cells: the sample becomes HIDDEN_KEEP of its colour plus HIDDEN_TINT of
 * the highlight colour (over half the tint, so it reads through the surface in front). */
#define HIDDEN_KEEP 0.45f
#define HIDDEN_TINT 0.55f

void vm_render_options_default(vm_render_options *o) {
    memset(o, 0, sizeof *o);
    o->width = 800;
    o->height = 600;
    o->azimuth = 30.0;
    o->elevation = 20.0;
    o->background[0] = o->background[1] = o->background[2] = 255;
    o->cut = VM_CUT_NONE;
    o->show_edges = 1;
    o->edge_width = 1.0;
    o->highlight_threshold = 10.0;
    o->supersample = 2;
}

/* Light, desaturated colours that stay readable under shading and never look red. */
static const unsigned char palette[12][3] = {
    {170, 195, 225}, {235, 200, 145}, {155, 205, 165}, {200, 175, 225},
    {240, 225, 135}, {140, 205, 210}, {215, 190, 160}, {185, 215, 125},
    {175, 175, 205}, {235, 180, 210}, {205, 205, 205}, {125, 175, 235}};

void vm_render_region_color(int r, unsigned char rgb[3]) {
    int i = r % 12;
    if (i < 0) i += 12;
    memcpy(rgb, palette[i], 3);
}

/* ---- camera ---------------------------------------------------------------------------- */

typedef struct camera {
    double centre[3];
    double right[3], up[3], fwd[3]; /* fwd points from the eye into the scene */
    int ortho;
    double dist;           /* perspective: eye distance from the centre */
    double scale, cx, cy;  /* samples per projected unit, projected centre of the fit */
    int w, h;              /* sample grid */
} camera;

/* Screen position (x right, y down, in samples) and depth key (smaller is nearer, linear in
 * screen space for both projections). */
static void project(const camera *c, const double p[3], double out[3]) {
    double d[3];
    vm__sub3(p, c->centre, d);
    double x = vm__dot3(d, c->right), y = vm__dot3(d, c->up), z = vm__dot3(d, c->fwd);
    if (!c->ortho) {
        double depth = c->dist + z;
        x /= depth;
        y /= depth;
        z = -1.0 / depth;
    }
    out[0] = 0.5 * c->w + c->scale * (x - c->cx);
    out[1] = 0.5 * c->h - c->scale * (y - c->cy);
    out[2] = z;
}

/* Direction from a point towards the eye (unit). */
static void to_eye(const camera *c, const double p[3], double v[3]) {
    if (c->ortho) {
        for (int i = 0; i < 3; i++)
            v[i] = -c->fwd[i];
        return;
    }
    for (int i = 0; i < 3; i++)
        v[i] = c->centre[i] - c->dist * c->fwd[i] - p[i];
    double n = vm__norm3(v);
    if (n > 0)
        for (int i = 0; i < 3; i++)
            v[i] /= n;
}

/* Sets up the view around the bounding box of m's finite points and frames them all.
 * Returns 0 when m has no finite point. */
static int camera_fit(camera *c, const vm_mesh *m, const vm_render_options *o, int w, int h) {
    double lo[3] = {DBL_MAX, DBL_MAX, DBL_MAX}, hi[3] = {-DBL_MAX, -DBL_MAX, -DBL_MAX};
    size_t nfin = 0;
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        nfin++;
        for (int d = 0; d < 3; d++) {
            if (p[d] < lo[d]) lo[d] = p[d];
            if (p[d] > hi[d]) hi[d] = p[d];
        }
    }
    if (!nfin) return 0;
    memset(c, 0, sizeof *c);
    c->w = w;
    c->h = h;
    c->ortho = o->orthographic != 0;
    double radius = 0.0;
    for (int d = 0; d < 3; d++) {
        c->centre[d] = 0.5 * (lo[d] + hi[d]);
        radius += 0.25 * (hi[d] - lo[d]) * (hi[d] - lo[d]);
    }
    radius = sqrt(radius);
    if (!(radius > 0)) radius = 1.0;
    /* A frame (r0, f0, u) with u up: with u = +z it is x, y, z. */
    double u[3] = {o->up[0], o->up[1], o->up[2]}, r0[3] = {0, 0, 0}, f0[3];
    double ul = vm__norm3(u);
    if (!(ul > 0)) {
        u[0] = u[1] = 0;
        u[2] = ul = 1;
    }
    for (int d = 0; d < 3; d++)
        u[d] /= ul;
    int least = 0;
    for (int d = 1; d < 3; d++)
        if (fabs(u[d]) < fabs(u[least])) least = d;
    r0[least] = 1.0;
    for (int d = 0; d < 3; d++)
        r0[d] -= u[least] * u[d];
    double rl = vm__norm3(r0);
    for (int d = 0; d < 3; d++)
        r0[d] /= rl;
    vm__cross3(u, r0, f0);
    double az = o->azimuth * DEG2RAD, el = o->elevation * DEG2RAD;
    for (int d = 0; d < 3; d++) {
        double eye = cos(el) * (sin(az) * r0[d] - cos(az) * f0[d]) + sin(el) * u[d];
        c->fwd[d] = -eye;
        c->right[d] = cos(az) * r0[d] + sin(az) * f0[d];
    }
    vm__cross3(c->right, c->fwd, c->up);
    /* The eye sits on the sphere seen under a 30 degree field of view. */
    c->dist = radius / sin(HALF_FOV_DEG * DEG2RAD);
    c->scale = 1.0;
    return 1;
}

/* The framed points fill this fraction of the image: a 4 per cent margin on each side. */
#define FRAME_FILL 0.92

/* Zooms and centres the view on points (nidx indices into them, or all npoints when idx is
 * NULL), leaving a 4 per cent margin. */
static void camera_frame(camera *c, const double *points, size_t npoints, const vm_index *idx,
                         size_t nidx) {
    double plo[2] = {DBL_MAX, DBL_MAX}, phi[2] = {-DBL_MAX, -DBL_MAX};
    camera unit = *c;
    unit.w = unit.h = 0;
    unit.scale = 1.0;
    unit.cx = unit.cy = 0.0;
    size_t n = idx ? nidx : npoints;
    for (size_t i = 0; i < n; i++) {
        const double *p = points + 3 * (idx ? (size_t)idx[i] : i);
        if (!isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2])) continue;
        double s[3];
        project(&unit, p, s);
        double py = -s[1];
        if (s[0] < plo[0]) plo[0] = s[0];
        if (s[0] > phi[0]) phi[0] = s[0];
        if (py < plo[1]) plo[1] = py;
        if (py > phi[1]) phi[1] = py;
    }
    if (plo[0] > phi[0]) return; /* nothing finite: keep the frame */
    double ex = phi[0] - plo[0], ey = phi[1] - plo[1];
    double sx = ex > 0 ? FRAME_FILL * c->w / ex : DBL_MAX;
    double sy = ey > 0 ? FRAME_FILL * c->h / ey : DBL_MAX;
    c->scale = sx < sy ? sx : sy;
    if (c->scale == DBL_MAX) c->scale = 1.0; /* a single point */
    c->cx = 0.5 * (plo[0] + phi[0]);
    c->cy = 0.5 * (plo[1] + phi[1]);
}

/* ---- the faces to draw ------------------------------------------------------------------ */

typedef struct faces {
    int k;                 /* 3 or 4 nodes per face */
    size_t n;
    const vm_index *nodes; /* k per face */
    const double *points;
    size_t npoints;
    const int32_t *region; /* per face */
    const double *cellid;  /* per face: the cell of m it belongs to (NULL: face i is cell i) */
    vm_mesh surf;          /* owns the arrays above for volume meshes */
} faces;

static size_t face_cell(const faces *f, size_t i) {
    return f->cellid ? (size_t)f->cellid[i] : i;
}

static void cell_centroid(const vm_mesh *m, size_t c, double out[3]) {
    int nn = vm_cell_nodes(m->kind);
    out[0] = out[1] = out[2] = 0.0;
    for (int i = 0; i < nn; i++) {
        const double *p = m->points + 3 * (size_t)m->cells[c * (size_t)nn + (size_t)i];
        for (int d = 0; d < 3; d++)
            out[d] += p[d] / nn;
    }
}

/* The faces of the kept cells (keep == NULL: all): for a volume mesh the boundary of the kept
 * set, each face knowing its cell through a cell field; for a surface mesh the kept faces. */
static vm_status collect_faces(const vm_mesh *m, const unsigned char *keep, faces *f,
                               vm_error *err) {
    memset(f, 0, sizeof *f);
    vm_mesh_init(&f->surf, VM_TRI3);
    int nn = vm_cell_nodes(m->kind);
    size_t nkept = 0;
    for (size_t c = 0; c < m->ncells; c++)
        if (!keep || keep[c]) nkept++;
    if (m->kind == VM_TRI3 || m->kind == VM_QUAD4) {
        f->k = nn;
        f->points = m->points;
        f->npoints = m->npoints;
        if (!keep) {
            f->n = m->ncells;
            f->nodes = m->cells;
            f->region = m->region;
            return VM_OK;
        }
        /* Keep the selection in the surf arrays (only cells, region and the cell field). */
        vm_mesh_init(&f->surf, m->kind);
        vm_status st = vm_mesh_reserve(&f->surf, 0, nkept ? nkept : 1, err);
        double *ids = nkept ? malloc(nkept * sizeof *ids) : NULL;
        if (st || (nkept && !ids)) {
            free(ids);
            vm_mesh_free(&f->surf);
            return st ? st : vm_error_set(err, VM_ERR_NOMEM, "render: out of memory");
        }
        size_t j = 0;
        for (size_t c = 0; c < m->ncells; c++) {
            if (!keep[c]) continue;
            memcpy(f->surf.cells + j * (size_t)nn, m->cells + c * (size_t)nn,
                   (size_t)nn * sizeof(vm_index));
            f->surf.region[j] = m->region[c];
            ids[j++] = (double)c;
        }
        f->surf.ncells = nkept;
        st = nkept ? vm_mesh_set_field(&f->surf, 1, "cell", 1, ids, err) : VM_OK;
        free(ids);
        if (st) {
            vm_mesh_free(&f->surf);
            return st;
        }
        f->n = nkept;
        f->nodes = f->surf.cells;
        f->region = f->surf.region;
        f->cellid = nkept ? f->surf.cell_fields[0].data : NULL;
        return VM_OK;
    }
    f->k = m->kind == VM_HEX8 ? 4 : 3;
    if (!nkept) return VM_OK;
    /* A mesh that borrows m's points and holds only the kept cells and their ids. */
    vm_mesh sub;
    vm_mesh_init(&sub, m->kind);
    sub.npoints = m->npoints;
    sub.points = m->points;
    size_t nidx;
    if (vm__mul_overflows(nkept, (size_t)nn, &nidx) || nidx > SIZE_MAX / sizeof(vm_index))
        return vm_error_set(err, VM_ERR_NOMEM, "render: too many cells");
    vm_field idf;
    memset(&idf, 0, sizeof idf);
    strcpy(idf.name, "cell");
    idf.ncomp = 1;
    sub.cells = malloc(nidx * sizeof(vm_index));
    sub.region = malloc(nkept * sizeof(int32_t));
    idf.data = malloc(nkept * sizeof(double));
    vm_status st = VM_OK;
    if (!sub.cells || !sub.region || !idf.data) {
        st = vm_error_set(err, VM_ERR_NOMEM, "render: out of memory for %zu cells", nkept);
    } else {
        size_t j = 0;
        for (size_t c = 0; c < m->ncells; c++) {
            if (keep && !keep[c]) continue;
            memcpy(sub.cells + j * (size_t)nn, m->cells + c * (size_t)nn,
                   (size_t)nn * sizeof(vm_index));
            sub.region[j] = m->region[c];
            idf.data[j++] = (double)c;
        }
        sub.ncells = nkept;
        sub.cell_fields = &idf;
        sub.ncell_fields = 1;
        st = vm_mesh_boundary(&sub, &f->surf, err);
    }
    free(sub.cells);
    free(sub.region);
    free(idf.data);
    if (st) return st;
    f->n = f->surf.ncells;
    f->nodes = f->surf.cells;
    f->points = f->surf.points;
    f->npoints = f->surf.npoints;
    f->region = f->surf.region;
    f->cellid = f->surf.ncell_fields ? f->surf.cell_fields[0].data : NULL;
    return VM_OK;
}

/* ---- highlight -------------------------------------------------------------------------- */

typedef struct highlight {
    const double *values;         /* per cell of m, or NULL */
    const vm_metric_info *metric; /* else computed per cell */
    double threshold;
    int above;
} highlight;

static vm_status highlight_setup(const vm_mesh *m, const vm_render_options *o, highlight *h,
                                 int *on, vm_error *err) {
    memset(h, 0, sizeof *h);
    h->threshold = o->highlight_threshold;
    h->above = o->highlight_above != 0;
    *on = 1;
    if (o->highlight_values) {
        h->values = o->highlight_values;
        return VM_OK;
    }
    if (!o->highlight) {
        *on = 0;
        return VM_OK;
    }
    const vm_field *fld = vm_mesh_find_field(m, 1, o->highlight);
    if (fld) {
        if (fld->ncomp != 1)
            return vm_error_set(err, VM_ERR_ARG,
                                "render: highlight field '%s' has %d components, needs 1",
                                o->highlight, fld->ncomp);
        h->values = fld->data;
        return VM_OK;
    }
    h->metric = vm_quality_find_metric(m->kind, o->highlight);
    if (!h->metric)
        return vm_error_set(err, VM_ERR_ARG,
                            "render: highlight '%s' is neither a cell field nor a %s metric",
                            o->highlight, vm_cell_kind_name(m->kind));
    return VM_OK;
}

static int highlighted(const vm_mesh *m, const highlight *h, size_t c) {
    double v;
    if (h->values) {
        v = h->values[c];
    } else {
        int nn = vm_cell_nodes(m->kind);
        double p[8][3];
        for (int i = 0; i < nn; i++)
            memcpy(p[i], m->points + 3 * (size_t)m->cells[c * (size_t)nn + (size_t)i],
                   sizeof p[i]);
        v = h->metric->eval((const double(*)[3])p);
    }
    if (isnan(v)) return 0;
    return h->above ? v > h->threshold : v < h->threshold;
}

/* ---- rasterisation ---------------------------------------------------------------------- */

typedef struct raster {
    int w, h;
    unsigned char *rgb; /* 3 per sample */
    float *z;           /* depth key per sample */
    unsigned char *mask; /* hidden-highlight marks, or NULL */
} raster;

#define EDGE_DARK 0.3f /* an edge line is the face colour at 30 per cent */

/* One triangle (screen coordinates and depth keys in v) in colour col. Edges whose bit is set
 * in edge_mask (bit i: v[i] to v[i+1]) are darkened within half_width samples, with opacity
 * edge_alpha. mark_hidden != 0: instead of drawing, marks the samples where the triangle
 * lies behind what is drawn. */
static void raster_tri(raster *r, const double v[3][3], const float col[3], int edge_mask,
                       double edge_alpha, double half_width, int mark_hidden) {
    double area = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) -
                  (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]);
    if (!(fabs(area) > 1e-12)) return; /* degenerate, or NaN */
    double xmin = fmin(v[0][0], fmin(v[1][0], v[2][0]));
    double xmax = fmax(v[0][0], fmax(v[1][0], v[2][0]));
    double ymin = fmin(v[0][1], fmin(v[1][1], v[2][1]));
    double ymax = fmax(v[0][1], fmax(v[1][1], v[2][1]));
    if (xmax < 0 || ymax < 0 || xmin > r->w || ymin > r->h) return;
    int x0 = xmin < 0 ? 0 : (int)floor(xmin), x1 = xmax >= r->w ? r->w - 1 : (int)ceil(xmax);
    int y0 = ymin < 0 ? 0 : (int)floor(ymin), y1 = ymax >= r->h ? r->h - 1 : (int)ceil(ymax);
    double sgn = area > 0 ? 1.0 : -1.0, inv = 1.0 / fabs(area);
    /* Edge i runs from v[i] to v[i+1]; its function is positive inside and, divided by the
     * edge's length, is the distance in samples; divided by |area| it is the barycentric
     * weight of the opposite vertex v[i+2]. */
    double a[3], b[3], c[3], len[3];
    for (int i = 0; i < 3; i++) {
        const double *p = v[i], *q = v[(i + 1) % 3];
        a[i] = -sgn * (q[1] - p[1]);
        b[i] = sgn * (q[0] - p[0]);
        c[i] = -(a[i] * p[0] + b[i] * p[1]);
        len[i] = sqrt(a[i] * a[i] + b[i] * b[i]);
    }
    double ew = edge_alpha > 0 ? half_width : -1.0;
    float dark[3] = {col[0] * EDGE_DARK, col[1] * EDGE_DARK, col[2] * EDGE_DARK};
    for (int y = y0; y <= y1; y++) {
        double py = y + 0.5;
        for (int x = x0; x <= x1; x++) {
            double px = x + 0.5;
            double e0 = a[0] * px + b[0] * py + c[0];
            double e1 = a[1] * px + b[1] * py + c[1];
            double e2 = a[2] * px + b[2] * py + c[2];
            if (e0 < 0 || e1 < 0 || e2 < 0) continue;
            /* e_i weights the vertex opposite edge i, which is v[i+2]. */
            double z = (e0 * v[2][2] + e1 * v[0][2] + e2 * v[1][2]) * inv;
            size_t idx = (size_t)y * (size_t)r->w + (size_t)x;
            if (mark_hidden) {
                if (z > r->z[idx]) r->mask[idx] = 1;
                continue;
            }
            if (!(z < r->z[idx])) continue;
            r->z[idx] = (float)z;
            float t = 0.0f;
            if (ew > 0) {
                double e[3] = {e0, e1, e2}, dmin = DBL_MAX;
                for (int i = 0; i < 3; i++)
                    if ((edge_mask >> i & 1) && e[i] / len[i] < dmin) dmin = e[i] / len[i];
                double cover = ew + 0.5 - dmin;
                if (cover > 0) t = (float)((cover > 1 ? 1.0 : cover) * edge_alpha);
            }
            unsigned char *px3 = r->rgb + 3 * idx;
            for (int k = 0; k < 3; k++) {
                float val = col[k] + t * (dark[k] - col[k]);
                px3[k] = (unsigned char)(val < 0 ? 0 : val > 255 ? 255 : val + 0.5f);
            }
        }
    }
}

/* The lights of shade(), set by eye for shaded meshes that stay readable: luminance
 * AMBIENT + HEADLIGHT cos(view) + KEY_LIGHT cos(key), plus SPECULAR cos(view)^SHININESS on
 * glossy faces; the key light shines from the left, above and in front of the eye (the
 * KEY_* weights on the camera's right, up and forward axes). */
#define AMBIENT 0.22
#define HEADLIGHT 0.5
#define KEY_LIGHT 0.33
#define SPECULAR 0.16
#define SHININESS 40.0
#define KEY_LEFT 0.45
#define KEY_UP 0.6
#define KEY_FRONT 0.66

/* Flat shading of a face with unit normal n seen along view (unit, towards the eye):
 * ambient, a headlight, a key light above-left and a faint specular highlight. */
static void shade(const camera *c, const double n_in[3], const double view[3],
                  const unsigned char base[3], int gloss, float out[3]) {
    double n[3] = {n_in[0], n_in[1], n_in[2]};
    double hd = vm__dot3(n, view);
    if (hd < 0) { /* lit on both sides */
        for (int i = 0; i < 3; i++)
            n[i] = -n[i];
        hd = -hd;
    }
    double key[3];
    for (int i = 0; i < 3; i++)
        key[i] = -KEY_LEFT * c->right[i] + KEY_UP * c->up[i] - KEY_FRONT * c->fwd[i];
    double kn = vm__norm3(key);
    double kd = vm__dot3(n, key) / kn;
    if (kd < 0) kd = 0;
    double lum = AMBIENT + HEADLIGHT * hd + KEY_LIGHT * kd;
    double spec = gloss ? SPECULAR * pow(hd, SHININESS) : 0.0;
    for (int i = 0; i < 3; i++)
        out[i] = (float)(base[i] * lum + 255.0 * spec);
}

/* Unit normal of a triangle or quad (quads: cross product of the diagonals). */
static void face_normal(const double p[4][3], int k, double n[3]) {
    double d1[3], d2[3];
    if (k == 4) {
        vm__sub3(p[2], p[0], d1);
        vm__sub3(p[3], p[1], d2);
    } else {
        vm__sub3(p[1], p[0], d1);
        vm__sub3(p[2], p[0], d2);
    }
    vm__cross3(d1, d2, n);
    double l = vm__norm3(n);
    if (l > 0) {
        n[0] /= l;
        n[1] /= l;
        n[2] /= l;
    } else {
        n[0] = n[1] = 0;
        n[2] = 1;
    }
}

/* Edges fade in as a face's mean edge grows from EDGE_FADE_FROM pixels over EDGE_FADE_SPAN
 * more, to opacity EDGE_ALPHA (never quite black). */
#define EDGE_FADE_FROM 4.0
#define EDGE_FADE_SPAN 8.0
#define EDGE_ALPHA 0.85

/* Draws a triangle or quad given by its corners p (k of them) in colour col. */
static void draw_polygon(raster *r, const camera *cam, const double p[4][3], int k,
                         const float col[3], int show_edges, double half_width, int ss,
                         int mark_hidden) {
    double s[4][3];
    for (int i = 0; i < k; i++) {
        project(cam, p[i], s[i]);
        if (!isfinite(s[i][0]) || !isfinite(s[i][1]) || !isfinite(s[i][2])) return;
    }
    double alpha = 0.0;
    if (show_edges) {
        /* Fade edges out on faces a few pixels across (mean edge 4 to 12 pixels), so
         * that a fine mesh reads as a shaded surface rather than a dark mesh of lines. */
        double lsum = 0.0;
        for (int i = 0; i < k; i++) {
            const double *a = s[i], *b = s[(i + 1) % k];
            lsum += hypot(b[0] - a[0], b[1] - a[1]) / ss;
        }
        alpha = (lsum / k - EDGE_FADE_FROM) / EDGE_FADE_SPAN;
        alpha = EDGE_ALPHA * (alpha < 0 ? 0 : alpha > 1 ? 1 : alpha);
    }
    if (k == 3) {
        raster_tri(r, (const double(*)[3])s, col, 7, alpha, half_width, mark_hidden);
        return;
    }
    /* Split along 0-2: the first triangle has the quad's edges 0-1 and 1-2, the second 2-3
     * and 3-0. */
    double t1[3][3], t2[3][3];
    memcpy(t1[0], s[0], sizeof t1[0]);
    memcpy(t1[1], s[1], sizeof t1[1]);
    memcpy(t1[2], s[2], sizeof t1[2]);
    memcpy(t2[0], s[2], sizeof t2[0]);
    memcpy(t2[1], s[3], sizeof t2[1]);
    memcpy(t2[2], s[0], sizeof t2[2]);
    raster_tri(r, (const double(*)[3])t1, col, 3, alpha, half_width, mark_hidden);
    raster_tri(r, (const double(*)[3])t2, col, 3, alpha, half_width, mark_hidden);
}

/* Local faces of each cell kind, for drawing hidden highlighted cells. */
static const int tet_local[4][4] = {{0, 1, 2, 0}, {0, 1, 3, 0}, {1, 2, 3, 0}, {0, 2, 3, 0}};
static const int hex_local[6][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

static void mark_hidden_cell(raster *r, const camera *cam, const vm_mesh *m, size_t c) {
    int nn = vm_cell_nodes(m->kind), nf = 1, k = m->kind == VM_QUAD4 ? 4 : 3;
    const int(*local)[4] = NULL;
    if (m->kind == VM_TET4) {
        nf = 4;
        k = 3;
        local = tet_local;
    } else if (m->kind == VM_HEX8) {
        nf = 6;
        k = 4;
        local = hex_local;
    }
    static const float none[3] = {0, 0, 0};
    const vm_index *cn = m->cells + c * (size_t)nn;
    for (int f = 0; f < nf; f++) {
        double p[4][3];
        for (int i = 0; i < k; i++)
            memcpy(p[i], m->points + 3 * (size_t)cn[local ? local[f][i] : i], sizeof p[i]);
        draw_polygon(r, cam, (const double(*)[3])p, k, none, 0, 0.0, 1, 1);
    }
}

/* ---- the entry point -------------------------------------------------------------------- */

/* Checks the options o and the mesh m before any work. */
static vm_status check_render_args(const vm_mesh *m, const vm_render_options *o,
                                   vm_error *err) {
    if (o->width < 1 || o->width > MAX_IMAGE_SIDE || o->height < 1 ||
        o->height > MAX_IMAGE_SIDE)
        return vm_error_set(err, VM_ERR_ARG, "render: image size %d x %d is not in 1..16384",
                            o->width, o->height);
    if (o->supersample < 1 || o->supersample > MAX_SUPERSAMPLE)
        return vm_error_set(err, VM_ERR_ARG, "render: supersample %d is not in 1..4",
                            o->supersample);
    if (o->show_edges && !(o->edge_width >= MIN_EDGE_WIDTH && o->edge_width <= MAX_EDGE_WIDTH))
        return vm_error_set(err, VM_ERR_ARG, "render: edge width %g is not in 0.25..8",
                            o->edge_width);
    if (!isfinite(o->azimuth) || !(o->elevation >= -90.0 && o->elevation <= 90.0))
        return vm_error_set(err, VM_ERR_ARG,
                            "render: elevation %g is not in -90..90 (or azimuth not finite)",
                            o->elevation);
    if (!isfinite(o->up[0]) || !isfinite(o->up[1]) || !isfinite(o->up[2]))
        return vm_error_set(err, VM_ERR_ARG, "render: the up direction is not finite");
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_UNSUPPORTED, "render: unknown cell kind %d",
                            (int)m->kind);
    if (m->ncells == 0) return vm_error_set(err, VM_ERR_EMPTY, "render: the mesh has no cells");
    return vm__check_nodes(m, VM_ERR_ARG, "render", err);
}

/* Cut-away: *keep (per cell, 1 kept) for the cells whose centroid lies on the kept side of
 * the cut plane; NULL when o->cut is VM_CUT_NONE. */
static vm_status cut_mask(const vm_mesh *m, const vm_render_options *o, const camera *cam,
                          unsigned char **keep, vm_error *err) {
    *keep = NULL;
    if (o->cut == VM_CUT_NONE) return VM_OK;
    double n[3], off;
    if (o->cut == VM_CUT_AUTO) {
        for (int d = 0; d < 3; d++)
            n[d] = cam->right[d] - cam->fwd[d];
        off = vm__dot3(n, cam->centre);
    } else {
        memcpy(n, o->cut_normal, sizeof n);
        off = o->cut_offset;
        if (!(vm__norm3(n) > 0) || !isfinite(off))
            return vm_error_set(err, VM_ERR_ARG,
                                "render: cut normal (%g, %g, %g) offset %g is not a plane",
                                n[0], n[1], n[2], off);
    }
    *keep = malloc(m->ncells);
    if (!*keep) return vm_error_set(err, VM_ERR_NOMEM, "render: out of memory");
    for (size_t c = 0; c < m->ncells; c++) {
        double ctr[3];
        cell_centroid(m, c, ctr);
        (*keep)[c] = !(vm__dot3(n, ctr) > off);
    }
    return VM_OK;
}

/* Allocates the sample grid r (sw x sh, background colour, far depth; a hidden-highlight
 * mask when with_mask) and the output pixels of img. */
static vm_status raster_init(raster *r, int sw, int sh, const unsigned char background[3],
                             int with_mask, vm_image *img, int width, int height,
                             vm_error *err) {
    size_t nsamples = (size_t)sw * (size_t)sh;
    memset(r, 0, sizeof *r);
    r->w = sw;
    r->h = sh;
    r->rgb = malloc(3 * nsamples);
    r->z = malloc(nsamples * sizeof(float));
    if (with_mask) r->mask = calloc(nsamples, 1);
    img->pixels = malloc(3 * (size_t)width * (size_t)height);
    if (!r->rgb || !r->z || !img->pixels || (with_mask && !r->mask))
        return vm_error_set(err, VM_ERR_NOMEM, "render: out of memory for %d x %d samples", sw,
                            sh);
    for (size_t i = 0; i < nsamples; i++) {
        memcpy(r->rgb + 3 * i, background, 3);
        r->z[i] = FLT_MAX;
    }
    return VM_OK;
}

/* Draws the faces f, shaded in their region's colour, or the highlight colour where their
 * cell of m is highlighted (hl_on). */
static void draw_faces(raster *r, const camera *cam, const vm_mesh *m, const faces *f,
                       const highlight *hl, int hl_on, const vm_render_options *o) {
    int ss = o->supersample;
    double half_width = 0.5 * o->edge_width * ss;
    for (size_t i = 0; i < f->n; i++) {
        double p[4][3], ctr[3] = {0, 0, 0};
        for (int j = 0; j < f->k; j++) {
            memcpy(p[j], f->points + 3 * (size_t)f->nodes[i * (size_t)f->k + (size_t)j],
                   sizeof p[j]);
            for (int d = 0; d < 3; d++)
                ctr[d] += p[j][d] / f->k;
        }
        double n[3], view[3];
        face_normal((const double(*)[3])p, f->k, n);
        to_eye(cam, ctr, view);
        unsigned char base[3];
        int red = hl_on && highlighted(m, hl, face_cell(f, i));
        if (red) {
            base[0] = VM_RENDER_HIGHLIGHT_R;
            base[1] = VM_RENDER_HIGHLIGHT_G;
            base[2] = VM_RENDER_HIGHLIGHT_B;
        } else {
            vm_render_region_color(f->region[i], base);
        }
        float col[3];
        shade(cam, n, view, base, !red, col);
        draw_polygon(r, cam, (const double(*)[3])p, f->k, col, o->show_edges, half_width, ss,
                     0);
    }
}

/* Tints the samples where a kept highlighted cell lies behind what is drawn. */
static void tint_hidden(raster *r, const camera *cam, const vm_mesh *m,
                        const unsigned char *keep, const highlight *hl) {
    for (size_t c = 0; c < m->ncells; c++)
        if ((!keep || keep[c]) && highlighted(m, hl, c)) mark_hidden_cell(r, cam, m, c);
    static const float tint[3] = {VM_RENDER_HIGHLIGHT_R, VM_RENDER_HIGHLIGHT_G,
                                  VM_RENDER_HIGHLIGHT_B};
    size_t nsamples = (size_t)r->w * (size_t)r->h;
    for (size_t i = 0; i < nsamples; i++) {
        if (!r->mask[i]) continue;
        unsigned char *px = r->rgb + 3 * i;
        for (int k = 0; k < 3; k++)
            px[k] = (unsigned char)(HIDDEN_KEEP * px[k] + HIDDEN_TINT * tint[k] + 0.5f);
    }
}

/* Box filter of the samples r (ss x ss per pixel) down to img (width x height). */
static void downsample(const raster *r, int ss, vm_image *img, int width, int height) {
    img->width = width;
    img->height = height;
    for (int y = 0; y < height; y++)
        for (int x = 0; x < width; x++) {
            unsigned sum[3] = {0, 0, 0};
            for (int j = 0; j < ss; j++) {
                const unsigned char *row =
                    r->rgb + 3 * ((size_t)(y * ss + j) * (size_t)r->w + (size_t)x * (size_t)ss);
                for (int i = 0; i < ss; i++)
                    for (int k = 0; k < 3; k++)
                        sum[k] += row[3 * i + k];
            }
            unsigned char *out = img->pixels + 3 * ((size_t)y * (size_t)width + (size_t)x);
            unsigned nsub = (unsigned)(ss * ss);
            for (int k = 0; k < 3; k++)
                out[k] = (unsigned char)((sum[k] + nsub / 2) / nsub);
        }
}

/* Renders m into img (see render.h): checks, camera, cut-away, faces, raster, highlight
 * tint, box filter. */
vm_status vm_render_mesh(const vm_mesh *m, const vm_render_options *o_in, vm_image *img,
                         vm_error *err) {
    memset(img, 0, sizeof *img);
    vm_render_options o;
    if (o_in)
        o = *o_in;
    else
        vm_render_options_default(&o);
    vm_status st = check_render_args(m, &o, err);
    if (st) return st;
    highlight hl;
    int hl_on = 0;
    st = highlight_setup(m, &o, &hl, &hl_on, err);
    if (st) return st;

    int ss = o.supersample;
    int sw = o.width * ss, sh = o.height * ss;
    size_t nsamples = (size_t)sw * (size_t)sh, bytes;
    if (vm__mul_overflows(nsamples, 3 + sizeof(float) + (o.highlight_hidden ? 1 : 0), &bytes) ||
        bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM, "render: %d x %d at supersample %d is too large",
                            o.width, o.height, ss);
    camera cam;
    if (!camera_fit(&cam, m, &o, sw, sh))
        return vm_error_set(err, VM_ERR_EMPTY, "render: the mesh has no finite point");
    camera_frame(&cam, m->points, m->npoints, NULL, 0);

    unsigned char *keep = NULL;
    st = cut_mask(m, &o, &cam, &keep, err);
    if (st) return st;
    faces f;
    st = collect_faces(m, keep, &f, err);
    if (st) {
        free(keep);
        return st;
    }
    /* Frame what is drawn: the same as the whole mesh without a cut, tighter with one. */
    if (f.n) camera_frame(&cam, f.points, f.npoints, f.nodes, f.n * (size_t)f.k);

    raster r;
    st = raster_init(&r, sw, sh, o.background, o.highlight_hidden && hl_on, img, o.width,
                     o.height, err);
    if (!st) {
        draw_faces(&r, &cam, m, &f, &hl, hl_on, &o);
        if (r.mask) tint_hidden(&r, &cam, m, keep, &hl);
        downsample(&r, ss, img, o.width, o.height);
    }
    free(r.rgb);
    free(r.z);
    free(r.mask);
    free(keep);
    vm_mesh_free(&f.surf);
    if (st) vm_image_free(img);
    return st;
}
