/* cli/mesh_labels.c — `volmesh mesh --labels`: a label volume (segmentation) in, one
 * conforming multi-material mesh out, with a summary line per label. */
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include "cli.h"

int vm_cli_parse_labels(const char *s, int32_t **labels, size_t *n) {
    *labels = NULL;
    *n = 0;
    if (strcmp(s, "all") == 0) return 0;
    size_t cap = 0;
    const char *p = s;
    for (;;) {
        char *end;
        errno = 0;
        long a = strtol(p, &end, 10), b;
        if (end == p || errno || a < INT32_MIN || a > INT32_MAX) goto bad;
        b = a;
        if (*end == '-' && end > p) {
            const char *q = end + 1;
            b = strtol(q, &end, 10);
            if (end == q || errno || b < a || b > INT32_MAX || b - a > 65535) goto bad;
        }
        for (long x = a; x <= b; x++) {
            if (*n == cap) {
                cap = cap ? 2 * cap : 16;
                int32_t *t = realloc(*labels, cap * sizeof *t);
                if (!t) {
                    free(*labels);
                    *labels = NULL;
                    return vm_cli_fail("--labels: out of memory");
                }
                *labels = t;
            }
            (*labels)[(*n)++] = (int32_t)x;
        }
        if (*end == 0) return 0;
        if (*end != ',') goto bad;
        p = end + 1;
    }
bad:
    free(*labels);
    *labels = NULL;
    *n = 0;
    return vm_cli_fail("--labels: '%s' is not all or a list such as 1,3,7 or 2-5", s);
}

static int report(const vm_mesh *m, const vm_label_stats *st, int json, const char *out) {
    vm_mesh_report r;
    vm_error err;
    vm_error_clear(&err);
    if (vm_mesh_check(m, &r, &err)) return vm_cli_fail_err(&err);
    const char *kind = m->kind == VM_HEX8 ? "hexes" : "tets";
    if (json) {
        printf("{\"output\": \"%s\", \"elements\": %zu, \"points\": %zu, \"inverted\": %zu, "
               "\"overshared_faces\": %zu, \"boundary_faces\": %zu, \"boundary_closed\": %s, "
               "\"boundary_euler\": %ld, \"components\": %zu, \"volume\": %.17g, "
               "\"min_scaled_jacobian\": %.6f, \"island_voxels\": %zu, "
               "\"topology_voxels\": %zu, \"relaxed_vertices\": %zu, \"seconds\": %.3f, "
               "\"labels\": [",
               out, m->ncells, m->npoints, r.inverted, r.overshared_faces, r.boundary_faces,
               r.boundary_closed ? "true" : "false", r.boundary_euler, r.components, r.volume,
               r.min_scaled_jacobian, st->island_voxels, st->topology_voxels,
               st->relaxed_vertices, st->seconds);
        for (size_t i = 0; i < st->nlabels; i++) {
            const vm_label_info *l = &st->labels[i];
            printf("%s{\"label\": %ld, \"elements\": %zu, \"volume\": %.17g, "
                   "\"voxel_volume\": %.17g, \"input_voxels\": %zu, \"meshed_voxels\": %zu}",
                   i ? ", " : "", (long)l->label, l->elements, l->mesh_volume, l->voxel_volume,
                   l->input_voxels, l->meshed_voxels);
        }
        printf("]}\n");
        return VM_EXIT_OK;
    }
    printf("%s: %zu %s, %zu points, %zu labels, boundary %s (Euler %ld), volume %.6g, "
           "%zu inverted, min scaled Jacobian %.3f, %.2f s\n",
           out, m->ncells, kind, m->npoints, st->nlabels,
           r.boundary_closed ? "closed" : "OPEN", r.boundary_euler, r.volume, r.inverted,
           r.min_scaled_jacobian, st->seconds);
    for (size_t i = 0; i < st->nlabels; i++) {
        const vm_label_info *l = &st->labels[i];
        double rel = l->voxel_volume > 0 ? 100.0 * (l->mesh_volume / l->voxel_volume - 1) : 0;
        printf("  label %ld: %zu %s, volume %.6g (voxels %.6g, %+.2f%%), %zu voxels in, "
               "%zu meshed\n",
               (long)l->label, l->elements, kind, l->mesh_volume, l->voxel_volume, rel,
               l->input_voxels, l->meshed_voxels);
    }
    if (st->island_voxels || st->topology_voxels)
        printf("relabelled voxels: %zu by --min-island, %zu to keep each label's boundary a "
               "manifold\n",
               st->island_voxels, st->topology_voxels);
    return VM_EXIT_OK;
}

int vm_cli_mesh_labels(const vm_volume *v, const char *in, const char *out, const char *surface,
                       const vm_label_options *lo, const vm_mesh_write_options *wo, int json,
                       int quality_fields, const char *html) {
    vm_mesh m;
    vm_label_stats st;
    vm_error err;
    vm_error_clear(&err);
    if (vm_mesh_labels(v, lo, &m, &st, &err)) return vm_cli_fail("%s: %s", in, err.message);
    vm_status s = VM_OK;
    if (quality_fields) s = vm_mesh_add_quality_fields(&m, NULL, &err);
    if (!s) s = vm_mesh_write_as(out, &m, wo, &err);
    if (!s && surface) {
        vm_mesh surf;
        s = vm_mesh_boundary(&m, &surf, &err);
        if (!s) s = vm_mesh_write(surface, &surf, &err);
        vm_mesh_free(&surf);
    }
    int rc = s ? vm_cli_fail_err(&err) : report(&m, &st, json, out);
    if (!rc && html) rc = vm_cli_write_report(html, &m, out);
    vm_label_stats_free(&st);
    vm_mesh_free(&m);
    return rc;
}
