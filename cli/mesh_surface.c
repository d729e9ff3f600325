/* SPDX-License-Identifier: BSD-3-Clause */
/* cli/mesh_surface.c — `volmesh mesh --elements tri|quad`: a volume in, the boundary surface
 * of its material out (dual contouring, marching cubes, ...), with its checks on one line. */
#include "cli.h"
#include <string.h>

/* --elements tri|quad: extracts, writes and sums up the surface on one line (or JSON). */
int vm_cli_mesh_surface(const vm_volume *v, const char *in, const char *out,
                        const vm_surface_options *so, const vm_mesh_write_options *wo, int json,
                        int quality_fields) {
    vm_mesh m;
    vm_surface_stats st;
    vm_error err;
    vm_error_clear(&err);
    vm_status s = vm_surface_extract(v, so, &m, &st, &err);
    if (s) return vm_cli_fail("%s: %s", in, err.message);
    if (quality_fields && (s = vm_mesh_add_quality_fields(&m, NULL, &err)) != VM_OK) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    s = vm_mesh_write_as(out, &m, wo, &err);
    if (s) {
        vm_mesh_free(&m);
        return vm_cli_fail_err(&err);
    }
    vm_quality_summary q;
    s = vm_quality_report(&m, &q, &err);
    vm_mesh_free(&m);
    if (s) return vm_cli_fail_err(&err);
    double min_angle = 0, worst_aspect = 0;
    vm_quality_lookup(&q, "min_angle.min", &min_angle);
    vm_quality_lookup(&q, "aspect_ratio.max", &worst_aspect);
    const vm_mesh_report *r = &q.check;
    const char *method = vm_surface_method_name(so->method);
    if (json) {
        vm_cli_json_summary_open(out);
        printf("\"method\": \"%s\", \"kind\": \"%s\", \"faces\": %zu, "
               "\"points\": %zu, \"closed\": %s, \"open_edges\": %zu, "
               "\"nonmanifold_edges\": %zu, \"nonmanifold_vertices\": %zu, \"euler\": %ld, "
               "\"components\": %zu, \"self_intersections\": %zu, \"degenerate\": %zu, "
               "\"volume\": %.17g, \"min_angle\": %.6f, \"max_aspect_ratio\": %.6g, "
               "\"centre_vertices\": %zu, \"seconds\": %.4f}\n",
               method, so->elements == VM_QUAD4 ? "quad4" : "tri3", r->cells, r->points,
               r->boundary_closed ? "true" : "false", r->boundary_open_edges,
               r->boundary_nonmanifold_edges, r->boundary_nonmanifold_vertices,
               r->boundary_euler, r->components, r->boundary_self_intersections, r->degenerate,
               r->volume, min_angle, worst_aspect, st.centre_vertices, st.seconds);
    } else {
        const char *kind = so->elements == VM_QUAD4 ? "quads" : "triangles";
        printf("%s: %s %zu %s, %zu points, %s (Euler %ld), %zu component%s, "
               "%zu self-intersection%s, min angle %.2f deg, worst aspect ratio %.3g, "
               "volume %.6g, %.3f s\n",
               out, method, r->cells, kind, r->points,
               r->boundary_closed && !r->boundary_nonmanifold_vertices ? "closed" : "OPEN",
               r->boundary_euler, r->components, r->components == 1 ? "" : "s",
               r->boundary_self_intersections, r->boundary_self_intersections == 1 ? "" : "s",
               min_angle, worst_aspect, r->volume, st.seconds);
    }
    return VM_EXIT_OK;
}
