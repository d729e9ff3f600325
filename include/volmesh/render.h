/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/render.h — a small software renderer: pictures of a mesh as RGB images, and a PNG
 * encoder, with no graphics library (only zlib).
 *
 * vm_render_mesh draws the boundary of a volume mesh (or the faces of a surface mesh) with a
 * z-buffer, flat-shaded per face (ambient + a headlight + a key light above-left), coloured by
 * region, with the element edges as thin dark lines and, optionally, a cut-away that opens the
 * volume to show the elements inside and a set of highlighted cells (e.g. slivers) in red.
 * The pictures are meant for the HTML quality report and the documentation: see
 * docs/RENDER.md for examples and timings. */
#ifndef VOLMESH_RENDER_H
#define VOLMESH_RENDER_H

#include <stddef.h>
#include "error.h"
#include "mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

/* An 8-bit RGB image: pixels holds 3*width*height bytes, row by row from the top, each pixel
 * R, G, B. An image filled by the library owns its pixels (malloc'd); free with
 * vm_image_free. A zeroed struct is an empty image. */
typedef struct vm_image {
    int width, height;
    unsigned char *pixels;
} vm_image;

/* Frees the pixels and zeroes the struct. img may be NULL. */
void vm_image_free(vm_image *img);

/* ---- rendering ----------------------------------------------------------------------- */

/* Where the cut-away plane comes from. */
typedef enum vm_render_cut {
    VM_CUT_NONE = 0,  /* draw the whole mesh */
    VM_CUT_PLANE = 1, /* cut_normal and cut_offset below */
    VM_CUT_AUTO = 2   /* through the centre of the bounding box, facing the viewer's right
                       * and turned 45 degrees towards the viewer: removes the near right
                       * half, so the cut face is seen obliquely */
} vm_render_cut;

typedef struct vm_render_options {
    /* Size of the picture in pixels, 1..16384 each. Default 800 x 600. */
    int width, height;

    /* View direction: the camera looks at the centre of the bounding box from
     * azimuth (degrees about the up axis) and elevation (degrees above the plane normal to
     * it, -90..90). up (need not be unit length; zero means +z, the default) points up in the
     * picture. With up = +z, azimuth 0 looks from -y towards +y with +x to the right, 90 looks
     * from +x, and elevation 90 looks straight down with +y up in the picture. In general
     * azimuth 0 has the world axis least aligned with up (x first) to the right.
     * Default azimuth 30, elevation 20. */
    double azimuth, elevation;
    double up[3];

    /* 1: parallel projection; 0: perspective with a 30 degree vertical field of view.
     * Either way the zoom is chosen so that what is drawn (the whole mesh, or what a cut
     * leaves) fills 92 per cent of the limiting side of the picture, centred. Default 0. */
    int orthographic;

    /* Background colour, RGB. Default white (255, 255, 255). */
    unsigned char background[3];

    /* Cut-away (VM_CUT_NONE by default). With VM_CUT_PLANE, every cell whose centroid c has
     * dot(cut_normal, c) > cut_offset is removed (cut_normal need not be unit length; a zero
     * normal is VM_ERR_ARG). With VM_CUT_AUTO, cut_normal and cut_offset are ignored. The
     * remaining cells are drawn by their own boundary ("crinkle" cut), so the elements
     * at the cut show as whole elements with their edges. */
    vm_render_cut cut;
    double cut_normal[3], cut_offset;

    /* 1: draw element edges as dark lines about edge_width pixels wide, depth-correct, fading
     * out on faces smaller than a few pixels so that fine meshes do not turn black.
     * Default 1, edge_width 1.0 (0.25..8). */
    int show_edges;
    double edge_width;

    /* Highlighted cells, drawn red wherever their faces are visible. The per-cell value is
     * taken from, in this order: highlight_values (ncells doubles, owned by the caller) when
     * not NULL; else the one-component cell field of m called highlight; else the quality
     * metric of m's kind called highlight (vm_quality_find_metric, e.g. "min_dihedral"),
     * computed for the cells drawn. A cell is highlighted when its value is below
     * highlight_threshold (highlight_above == 0) or above it (highlight_above == 1); NaN is
     * never highlighted. highlight == NULL and highlight_values == NULL: nothing is
     * highlighted (the default). A name that is neither a field nor a metric is VM_ERR_ARG.
     * highlight_hidden == 1 also shows highlighted cells hidden behind the visible
     * surface, tinted through it (default 0). Default threshold 10 (degrees, for
     * "min_dihedral"), highlight_above 0. */
    const char *highlight;
    const double *highlight_values;
    double highlight_threshold;
    int highlight_above;
    int highlight_hidden;

    /* Anti-aliasing: each pixel is the average of supersample x supersample samples
     * (1..4). Default 2. */
    int supersample;
} vm_render_options;

/* Fills o with the defaults above. */
void vm_render_options_default(vm_render_options *o);

/* Colour of region r in pictures: a fixed palette of 12 light colours (no red: red is for
 * highlighted cells), repeating for larger or negative r. [out] rgb. */
void vm_render_region_color(int r, unsigned char rgb[3]);

/* Colour of highlighted cells (220, 30, 30) before shading. */
#define VM_RENDER_HIGHLIGHT_R 220
#define VM_RENDER_HIGHLIGHT_G 30
#define VM_RENDER_HIGHLIGHT_B 30

/* Draws m (tet4, hex8: the boundary of the kept cells; tri3, quad4: the kept faces, lit
 * on both sides) into a new image. o may be NULL for the defaults. [out] img (owns its
 * pixels; left empty on error). A cut that removes every cell gives a picture of the
 * background only (VM_OK).
 * Errors: VM_ERR_EMPTY for a mesh without cells, VM_ERR_ARG for a bad option value (size,
 * supersample, edge width, zero cut normal, unknown highlight name, a highlight field with
 * more than one component, a node index outside 0..npoints-1), VM_ERR_NOMEM (also when
 * the samples exceed VOLMESH_MAX_MEMORY). Time: O(cells) to find the boundary, plus the
 * pixels of the faces drawn: about 1.3 s CPU for a million tets at 800 x 600, nearly all of
 * it vm_mesh_boundary (docs/RENDER.md). Memory: 7 bytes per sample (8 with
 * highlight_hidden; supersample^2 samples per pixel) plus the boundary mesh. */
vm_status vm_render_mesh(const vm_mesh *m, const vm_render_options *o, vm_image *img,
                         vm_error *err);

/* ---- PNG ------------------------------------------------------------------------------ */

/* Encodes img as a PNG file in memory (8-bit RGB, not interlaced, each row with the filter
 * that minimises the sum of absolute filtered bytes, deflate level 9): the signature, IHDR,
 * one IDAT and IEND, nothing else. [out] *buf (malloc'd; the caller frees it with free())
 * and *len. About 0.1 s for 800 x 600. Errors: VM_ERR_ARG for an empty image (zero size or
 * no pixels), VM_ERR_NOMEM (also for images above about 2 GB of filtered data). */
vm_status vm_image_encode_png(const vm_image *img, unsigned char **buf, size_t *len,
                              vm_error *err);

/* Writes img as a PNG file (as vm_image_encode_png) to PATH.tmp-PID and renames it to path,
 * so a failure leaves no partial file. Errors: those of vm_image_encode_png, VM_ERR_IO. */
vm_status vm_image_write_png(const char *path, const vm_image *img, vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
