/* SPDX-License-Identifier: BSD-3-Clause */
/* surface/surface.c — vm_surface_extract: checks the request, runs one surface method
 * (dual contouring, marching cubes, adaptive skeleton climbing, disk covering) and returns
 * the surface in world coordinates. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "../mesher/mesher_internal.h"
#include "surface_internal.h"
#include "surface_cover_internal.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"

void vm_surface_options_default(vm_surface_options *o) {
    memset(o, 0, sizeof *o);
    o->has_lo = 1;
    o->lo = 0.0;
    o->method = VM_SURFACE_DC;
    o->elements = VM_TRI3;
    o->cell_size = 1;
    o->error = 0.5;
    o->max_level = 4;
    o->improve = 1;
}

static const char *const method_names[] = {"dc", "mc", "asc", "cover"};

/* The method named name (surface.h). */
vm_status vm_surface_method_parse(const char *name, vm_surface_method *method) {
    for (int i = 0; i < 4; i++)
        if (strcmp(name, method_names[i]) == 0) {
            *method = (vm_surface_method)i;
            return VM_OK;
        }
    return VM_ERR_ARG;
}

const char *vm_surface_method_name(vm_surface_method method) {
    return (unsigned)method < 4 ? method_names[method] : "?";
}

/* The material bounds of the surface request, given to a mesher or quality-pass option set. */
#define COPY_BOUNDS(dst, src)                                                              \
    do {                                                                                   \
        (dst).lo = (src)->lo;                                                              \
        (dst).hi = (src)->hi;                                                              \
        (dst).has_lo = (src)->has_lo;                                                      \
        (dst).has_hi = (src)->has_hi;                                                      \
    } while (0)

/* dc: the volume mesher, then its boundary (tets give triangles, hexes quads). */
static vm_status surface_dc(const vm_volume *v, const vm_surface_options *o, vm_mesh *surf,
                            vm_error *err) {
    vm_mesh_options mo;
    vm_mesh_options_default(&mo);
    COPY_BOUNDS(mo, o);
    mo.cell_size = o->cell_size;
    mo.elements = o->elements == VM_QUAD4 ? VM_HEX8 : VM_TET4;
    mo.progress = o->progress;
    mo.progress_user = o->progress_user;
    vm_mesh vol;
    vm_status s = vm_mesh_volume(v, &mo, &vol, NULL, err);
    if (s) return s;
    if (o->improve && mo.elements == VM_HEX8) {
        vm_hex_improve_options ho;
        vm_hex_improve_options_default(&ho);
        COPY_BOUNDS(ho, o);
        s = vm_mesh_improve_hexes(&vol, v, &ho, NULL, err);
    } else if (o->improve) {
        vm_improve_options io;
        vm_improve_options_default(&io);
        COPY_BOUNDS(io, o);
        io.progress = o->progress; /* its bar, and a chance to cancel */
        io.progress_user = o->progress_user;
        s = vm_mesh_improve(&vol, v, &io, NULL, err);
    }
    if (!s) s = vm_mesh_boundary(&vol, surf, err);
    vm_mesh_free(&vol);
    if (!s)
        for (size_t c = 0; c < surf->ncells; c++) surf->region[c] = 1;
    return s;
}

/* cover measures disk radii and edge ratios along the grid; with anisotropic spacing an
 * index step along axis a is |spacing[a]| * step[a] long in the world (the direction
 * columns are unit vectors), so its aspect bound holds for the world-space triangles. */
static vm_status cover_world(const vm_volume *v, const vm__surface_grid *g,
                             const vm_surface_options *o, const double step[3], vm_mesh *surf,
                             vm_surface_stats *st, vm_error *err) {
    double scale[3];
    for (int a = 0; a < 3; a++) scale[a] = fabs(v->spacing[a]) * step[a];
    return vm__surface_cover_scaled(g, o, scale, surf, st, err);
}

vm_status vm_surface_extract(const vm_volume *v, const vm_surface_options *o, vm_mesh *surf,
                             vm_surface_stats *stats, vm_error *err) {
    double t0 = vm__now();
    vm_surface_stats st;
    memset(&st, 0, sizeof st);
    vm_mesh_init(surf, o->elements == VM_QUAD4 ? VM_QUAD4 : VM_TRI3);
    if ((unsigned)o->method > VM_SURFACE_COVER)
        return vm_error_set(err, VM_ERR_ARG, "surface: unknown method %d", (int)o->method);
    if (o->elements != VM_TRI3 && o->elements != VM_QUAD4)
        return vm_error_set(err, VM_ERR_ARG, "surface: elements must be triangles or quads");
    if (o->elements == VM_QUAD4 && o->method != VM_SURFACE_DC)
        return vm_error_set(err, VM_ERR_ARG,
                            "surface: quads come only from dual contouring (--method dc), "
                            "not from %s", vm_surface_method_name(o->method));
    if (!(o->error > 0))
        return vm_error_set(err, VM_ERR_ARG, "surface: error %g must be > 0", o->error);
    if (o->max_level < 0 || o->max_level > 10)
        return vm_error_set(err, VM_ERR_ARG, "surface: max level %d is outside 0..10",
                            o->max_level);
    vm_status s = vm__material_check(v, o->has_lo, o->lo, o->has_hi, o->hi, o->cell_size,
                                     "surface", err);
    if (s) return s;

    if (o->method == VM_SURFACE_DC) {
        s = surface_dc(v, o, surf, err);
    } else {
        vm__surface_grid g;
        memset(&g, 0, sizeof g);
        float *resampled = NULL;
        double step[3];
        s = vm__sampling_grid(v, o->cell_size, "surface", g.n, &g.f, &resampled, step, err);
        if (s) return s;
        COPY_BOUNDS(g, o);
        s = o->method == VM_SURFACE_MC    ? vm__surface_mc(&g, o, surf, &st, err)
            : o->method == VM_SURFACE_ASC ? vm__surface_asc(&g, o, surf, &st, err)
                                          : cover_world(v, &g, o, step, surf, &st, err);
        free(resampled);
        if (!s && surf->ncells == 0)
            s = vm_error_set(err, VM_ERR_EMPTY, "surface: no grid point is in the material");
        if (!s) {
            /* Index space to world; a left-handed frame mirrors every face. */
            for (size_t p = 0; p < surf->npoints; p++) {
                double ijk[3];
                for (int a = 0; a < 3; a++) ijk[a] = surf->points[3 * p + a] * step[a];
                vm_volume_index_to_world(v, ijk, surf->points + 3 * p);
            }
            if (vm_volume_frame_determinant(v) < 0) {
                int nn = vm_cell_nodes(surf->kind);
                for (size_t c = 0; c < surf->ncells; c++) {
                    vm_index *f = surf->cells + (size_t)nn * c;
                    vm_index tmp = f[1];
                    f[1] = f[nn - 1];
                    f[nn - 1] = tmp;
                }
            }
        }
    }
    if (s) {
        vm_mesh_free(surf);
        return s;
    }
    st.faces = surf->ncells;
    st.points = surf->npoints;
    st.seconds = vm__now() - t0;
    if (stats) *stats = st;
    return VM_OK;
}
