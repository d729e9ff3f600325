/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/slabs.c — meshing by slabs along z: the slab geometry (blocks, ghost band, planes),
 * ownership of tets by centroid, and vm_mesh_volume_slabs (pieces merged by the point index
 * of core/point_index.c), which meshes slab after slab in one process (docs/ALGORITHMS.md,
 * "Meshing by slabs"; the same decomposition as volmesh_mpi, docs/MPI.md). */
#include "volmesh/slabs.h"
#include "../core/core.h"
#include "mesher_internal.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

int64_t vm_slab_default_ghost(const vm_mesh_options *o) {
    /* + 8: a lifted grid point's position depends on those of its 7 colours before it
     * (dc_lift.c), a chain of up to 7 neighbours, one cell each */
    return 14 + (o->adaptive ? ((int64_t)2 << o->max_level) + 8 : 0);
}

void vm_slab_grid_init(int64_t nz, const vm_mesh_options *o, int64_t ghost, vm_slab_grid *g) {
    /* the sampling grid along z as vm_mesh_volume makes it: every plane at cell size 1,
     * else m points (nz - 1) / (m - 1) voxels apart */
    int64_t S = o->cell_size, m = nz;
    g->nz = nz;
    g->step = 1;
    if (S > 1) {
        m = (nz - 1 + S - 1) / S + 1;
        if (m < 2) m = 2;
        g->step = (double)(nz - 1) / (double)(m - 1);
    }
    g->cells = m - 1;
    g->block = o->adaptive ? (int64_t)1 << o->max_level : 1;
    g->blocks = (g->cells + g->block - 1) / g->block;
    g->ghost = ghost > 0 ? ghost : vm_slab_default_ghost(o);
}

void vm_slab_of_blocks(const vm_slab_grid *g, int64_t b0, int64_t b1, vm_slab *s) {
    memset(s, 0, sizeof *s);
    s->cell0 = b0 * g->block;
    s->cell1 = b1 * g->block < g->cells ? b1 * g->block : g->cells;
    s->z0 = b0 == 0 ? -INFINITY : (double)s->cell0 * g->step;
    s->z1 = b1 >= g->blocks ? INFINITY : (double)s->cell1 * g->step;
    if (s->cell1 <= s->cell0) return;
    if (b0 == 0 && b1 >= g->blocks) {
        s->whole = 1;
        s->plane1 = g->nz;
        return;
    }
    /* The band below starts on a block, where the cropped mesher's octree blocks and tet
     * parities are the whole grid's (it would leave out the planes below one anyway). */
    int64_t c = s->cell0 - g->ghost, g0 = c < 0 ? 0 : c / g->block * g->block;
    double lo = floor((double)g0 * g->step) - 1;
    double hi = ceil((double)(s->cell1 + g->ghost) * g->step) + 1;
    s->plane0 = lo < 0 ? 0 : (int64_t)lo;
    s->plane1 = hi > (double)(g->nz - 1) ? g->nz : (int64_t)hi + 1;
}

void vm_slab_part(const vm_slab_grid *g, int i, int n, vm_slab *s) {
    vm_slab_of_blocks(g, g->blocks * i / n, g->blocks * (i + 1) / n, s);
}

void vm_slab_crop_options(const vm_slab_grid *g, const vm_slab *s, vm_mesh_options *o) {
    o->z_offset = s->whole ? 0 : s->plane0;
    o->full_nz = s->whole ? 0 : g->nz;
}

static double centroid_z(const vm_mesh *m, size_t t) {
    const vm_index *c = m->cells + 4 * t;
    const double *p = m->points;
    return ((p[3 * c[0] + 2] + p[3 * c[1] + 2]) + (p[3 * c[2] + 2] + p[3 * c[3] + 2])) * 0.25;
}

int vm_slab_owns(const vm_slab *s, const vm_mesh *m, size_t t) {
    double cz = centroid_z(m, t);
    return cz >= s->z0 && cz < s->z1;
}

int64_t vm_slab_planes_held(const vm_slab_grid *g, int n) {
    int64_t most = 0;
    for (int i = 0; i < n; i++) {
        vm_slab s;
        vm_slab_part(g, i, n, &s);
        if (s.plane1 - s.plane0 > most) most = s.plane1 - s.plane0;
    }
    return most;
}

int vm_slab_count_within(const vm_slab_grid *g, int64_t max_planes) {
    for (int64_t n = 1; n <= g->blocks && n <= 1 << 30; n++)
        if (vm_slab_planes_held(g, (int)n) <= max_planes) return (int)n;
    return 0;
}

void vm_mesh_index_to_world(vm_mesh *m, const vm_volume *frame) {
    for (size_t i = 0; i < m->npoints; i++) {
        double ijk[3];
        memcpy(ijk, m->points + 3 * i, sizeof ijk);
        vm_volume_index_to_world(frame, ijk, m->points + 3 * i);
    }
    int nn = vm_cell_nodes(m->kind);
    if (vm_volume_frame_determinant(frame) < 0 && (nn == 4 || nn == 8))
        for (size_t t = 0; t < m->ncells; t++)
            vm__mirror_cell(m->cells + (size_t)nn * t, nn);
}

/* ---- one process, slab after slab ---- */

/* Points of the merged mesh that tets of later slabs share: their index coordinates (the
 * crops' exact doubles) and their numbers in the merged mesh. */
typedef struct shared_points {
    double *xyz;
    vm_index *id;
    size_t n, cap, idcap;
} shared_points;

enum { USED_BELOW = 1, USED_ABOVE = 2 };

/* Appends the tets of part (slab s's crop, index space) that s owns to mesh (index space),
 * their points merged with those of earlier slabs in sh, and enters the points that tets
 * above s share in sh. [in,out] mesh, sh. */
static vm_status append_owned(vm_mesh *mesh, const vm_mesh *part, const vm_slab *s,
                              shared_points *sh, vm_error *err) {
    size_t np = part->npoints, nc = part->ncells, nown = 0, nabove = 0;
    uint8_t *own = malloc(nc ? nc : 1), *used = calloc(np ? np : 1, 1);
    vm_index *map = malloc((np ? np : 1) * sizeof *map);
    vm_point_index pi = {0, NULL};
    vm_status st = VM_OK;
    if (!own || !used || !map) {
        st = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory merging a slab");
        goto done;
    }
    for (size_t t = 0; t < nc; t++) {
        double cz = centroid_z(part, t);
        own[t] = cz >= s->z0 && cz < s->z1;
        nown += own[t];
        if (!own[t])
            for (int k = 0; k < 4; k++)
                used[part->cells[4 * t + (size_t)k]] |= cz < s->z0 ? USED_BELOW : USED_ABOVE;
    }
    for (size_t i = 0; i < np; i++) {
        map[i] = -1;
        nabove += (used[i] & USED_ABOVE) != 0;
    }
    /* No later crop reaches below this one's first plane: forget the points there. */
    size_t kept = 0;
    for (size_t i = 0; i < sh->n; i++)
        if (sh->xyz[3 * i + 2] >= (double)s->plane0) {
            memmove(sh->xyz + 3 * kept, sh->xyz + 3 * i, 3 * sizeof(double));
            sh->id[kept++] = sh->id[i];
        }
    sh->n = kept;
    st = vm_point_index_build(&pi, sh->xyz, sh->n, sh->n + nabove, err);
    if (!st)
        st = vm__grow((void **)&sh->xyz, &sh->cap, sh->n + nabove, 3 * sizeof(double), err);
    if (!st) st = vm__grow((void **)&sh->id, &sh->idcap, sh->n + nabove, sizeof(vm_index), err);
    if (!st) st = vm_mesh_reserve(mesh, mesh->npoints + np, mesh->ncells + nown, err);
    for (size_t t = 0; t < nc && !st; t++) {
        if (!own[t]) continue;
        vm_index nodes[4];
        for (int k = 0; k < 4; k++) {
            vm_index i = part->cells[4 * t + (size_t)k];
            if (map[i] < 0) {
                const double *x = part->points + 3 * (size_t)i;
                size_t at = 0;
                vm_index found = used[i] ? vm_point_index_find(&pi, sh->xyz, x, &at) : -1;
                if (found >= 0) {
                    map[i] = sh->id[found];
                } else if (used[i] & USED_BELOW) {
                    /* a tet below shares it, so the slab below must have entered it: the
                     * crops disagree (a ghost band too thin for these options) */
                    st = vm_error_set(err, VM_ERR_INTERNAL,
                                      "mesh: slabs: a point at z %g shared with the slab below "
                                      "is not in its mesh (ghost band too thin?)",
                                      x[2]);
                    break;
                } else {
                    map[i] = (vm_index)mesh->npoints;
                    memcpy(mesh->points + 3 * mesh->npoints++, x, 3 * sizeof(double));
                    if (used[i] & USED_ABOVE) {
                        memcpy(sh->xyz + 3 * sh->n, x, 3 * sizeof(double));
                        sh->id[sh->n] = map[i];
                        pi.slot[at] = (vm_index)sh->n++;
                    }
                }
            }
            nodes[k] = map[i];
        }
        if (!st) {
            memcpy(mesh->cells + 4 * mesh->ncells, nodes, sizeof nodes);
            mesh->region[mesh->ncells++] = part->region[t];
        }
    }
done:
    vm_point_index_free(&pi);
    free(own);
    free(used);
    free(map);
    return st;
}

static void add_stats(vm_mesh_stats *sum, const vm_mesh_stats *a) {
    sum->inside_voxels += a->inside_voxels;
    sum->boundary_cells += a->boundary_cells;
    sum->interior_cells += a->interior_cells;
    sum->special_cells += a->special_cells;
    sum->surface_vertices += a->surface_vertices;
    sum->relaxed_vertices += a->relaxed_vertices;
    sum->untangled_vertices += a->untangled_vertices;
    sum->lifted_vertices += a->lifted_vertices;
    sum->boundary_crossings += a->boundary_crossings;
    sum->repaired_points += a->repaired_points;
    sum->inverted_cells += a->inverted_cells;
}

vm_status vm_mesh_volume_slabs(const vm_volume *info, const vm_mesh_options *o,
                               const vm_slab_options *so, vm_mesh *mesh, vm_mesh_stats *stats,
                               vm_error *err) {
    double t0 = vm__now();
    vm_mesh_init(mesh, VM_TET4);
    vm_status st = vm__mesh_options_check(o, err);
    if (st) return st;
    if (o->elements != VM_TET4)
        return vm_error_set(err, VM_ERR_ARG, "mesh: slabs are meshed with tetrahedra only");
    if (o->z_offset || o->full_nz)
        return vm_error_set(err, VM_ERR_ARG,
                            "mesh: slabs of a cropped volume are not supported");
    if (so->slabs < 1)
        return vm_error_set(err, VM_ERR_ARG, "mesh: %d slabs (need at least 1)", so->slabs);
    for (int a = 0; a < 3; a++)
        if (info->dims[a] < 2)
            return vm_error_set(
                err, VM_ERR_ARG,
                "mesh: the volume is %lld voxel(s) along axis %d; need at least 2",
                (long long)info->dims[a], a);
    vm_slab_grid g;
    vm_slab_grid_init(info->dims[2], o, so->ghost, &g);
    double frame[3][3]; /* the whole volume's frame, in which the mesher measures (the lift) */
    vm__volume_frame(info, frame);
    int n = so->slabs;
    /* one buffer for the planes of the thickest slab, reused slab after slab */
    int64_t bd[3] = {info->dims[0], info->dims[1], vm_slab_planes_held(&g, n)};
    size_t count, plane = (size_t)bd[0] * (size_t)bd[1];
    st = vm__check_dims(bd, sizeof(float), "mesh: the planes of a slab", &count, err);
    float *buf = st ? NULL : malloc(count * sizeof(float));
    if (!st && !buf)
        st = vm_error_set(err, VM_ERR_NOMEM, "mesh: out of memory for %zu voxels of a slab",
                          count);
    vm__meter meter;
    vm__meter_start(&meter, o->progress, o->progress_user, "slabs", (double)n);
    shared_points sh;
    memset(&sh, 0, sizeof sh);
    vm_mesh_stats sum;
    memset(&sum, 0, sizeof sum);
    double vmin = INFINITY, vmax = -INFINITY;
    int64_t have0 = 0, have1 = 0; /* buf holds planes have0 .. have1 - 1 */
    for (int i = 0; i < n && !st; i++) {
        if (i > 0 && vm__meter_add(&meter, 1)) {
            st = vm__cancelled(err, "mesh");
            break;
        }
        vm_slab s;
        vm_slab_part(&g, i, n, &s);
        if (s.plane1 <= s.plane0) continue;
        /* the ghost planes shared with the previous slab move to the front; the source
         * fills in the rest, each plane once (slabs overlap: s.plane0 <= have1) */
        int64_t keep = have1 - s.plane0;
        if (keep > 0)
            memmove(buf, buf + plane * (size_t)(s.plane0 - have0),
                    plane * (size_t)keep * sizeof(float));
        else
            keep = 0;
        vm_volume in;
        memset(&in, 0, sizeof in);
        in.dims[0] = bd[0];
        in.dims[1] = bd[1];
        in.dims[2] = s.plane1 - s.plane0 - keep;
        in.data = buf + plane * (size_t)keep;
        in.type = VM_SCALAR_FLOAT32;
        /* a slab thinner than the ghost band may need no plane beyond the previous one's */
        if (in.dims[2] > 0)
            st = so->source(s.plane0 + keep, s.plane1, &in, so->source_user, err);
        if (st) break;
        have0 = s.plane0;
        have1 = s.plane1;
        double a, b;
        size_t bad = vm_volume_stats(&in, &a, &b, NULL);
        if (bad) {
            st = vm_error_set(err, VM_ERR_FORMAT,
                              "mesh: the volume has %zu non-finite values (NaN or infinity) in "
                              "planes %lld..%lld",
                              bad, (long long)(s.plane1 - in.dims[2]), (long long)s.plane1 - 1);
            break;
        }
        if (a < vmin) vmin = a;
        if (b > vmax) vmax = b;
        /* the slab's planes in the whole volume's index frame (unit spacing, no origin) */
        vm_volume crop;
        memset(&crop, 0, sizeof crop);
        crop.dims[0] = bd[0];
        crop.dims[1] = bd[1];
        crop.dims[2] = s.plane1 - s.plane0;
        crop.data = buf;
        crop.type = VM_SCALAR_FLOAT32;
        for (int r = 0; r < 3; r++) {
            crop.spacing[r] = 1;
            crop.direction[r][r] = 1;
        }
        vm_mesh_options mo = *o;
        vm_slab_crop_options(&g, &s, &mo);
        mo.crop_frame = &frame[0][0];
        mo.progress = NULL;
        vm_mesh part;
        vm_mesh_stats ps;
        st = vm_mesh_volume(&crop, &mo, &part, &ps, err);
        if (st == VM_ERR_EMPTY) { /* no material in these planes */
            st = VM_OK;
            vm_error_clear(err);
            continue;
        }
        if (st) break;
        add_stats(&sum, &ps);
        st = append_owned(mesh, &part, &s, &sh, err);
        vm_mesh_free(&part);
    }
    free(buf);
    free(sh.xyz);
    free(sh.id);
    if (!st && mesh->ncells == 0) {
        st = vm__material_range(o->has_lo, o->lo, o->has_hi, o->hi, vmin, vmax, "mesh", err);
        if (!st) st = vm_error_set(err, VM_ERR_EMPTY, "mesh: no grid point is in the material");
    }
    if (st) {
        vm_mesh_free(mesh);
        return st;
    }
    vm__meter_end(&meter);
    if (vm__meter_stopped(&meter)) {
        vm_mesh_free(mesh);
        return vm__cancelled(err, "mesh");
    }
    vm_mesh_index_to_world(mesh, info);
    sum.seconds = vm__now() - t0;
    if (stats) *stats = sum;
    return VM_OK;
}
