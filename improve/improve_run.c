/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_run.c — one run of the improvement pass over a working mesh (the whole
 * mesh, or one part of it for improve_parts.c): setting up the stars, classes and
 * constraints, the rounds (schedule after Klingner and Shewchuk 2007), measuring the moves;
 * and reading planes. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "improve_internal.h"
#include "../core/vec3.h"

/* --- setting up the working mesh --------------------------------------------------------- */

/* Faces opposite node 0..3, ordered so their normals point out of a positive tet. */
static const int tet_face[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/* Scales of the face-angle terms of the quality: 10 and 160 degrees (ABAQUS's face-angle
 * limits) score 2/3, as the dihedral and volume-measure terms do at theirs (10/15 = 2/3,
 * (180 - 160)/30 = 2/3). */
#define FACE_ANGLE_SCALE_MIN 15.0
#define FACE_ANGLE_SCALE_MAX 30.0
/* A vertex within this of a grid face (index units) lies on that border plane. */
#define GRID_FACE_TOL 1e-6
/* Without a volume: within this fraction of the box's extent of a box face. */
#define BOX_FACE_TOL 1e-9
/* Interface faces around a vertex within 25 degrees of their mean normal (cos 25 degrees)
 * make a nearly flat interface. */
#define IFACE_COS_MAX_ANGLE 0.90630778703665
/* The most interface faces around one vertex interface_plane looks at. */
#define IFACE_MAX_FACES 64

/* Frees what only the rounds need (stars, qualities, the guard, scratch), before writing
 * back, so the output arrays do not come on top of them. */
static void imp_free_rounds(vm__imp *w) {
    if (w->star)
        for (size_t i = 0; i < w->npt; i++) free(w->star[i].t);
    free(w->star);
    w->star = NULL;
    free(w->q);
    w->q = NULL;
    free(w->buf);
    w->buf = NULL;
    w->buf_cap = 0;
    free(w->qbuf);
    w->qbuf = NULL;
    w->qbuf_cap = 0;
    free(w->touched);
    w->touched = NULL;
    vm__imp_guard_free(w);
}

/* B = A^-1 by cofactors; 0 (B untouched) when A is singular or not finite. */
int vm__imp_invert3(double A[3][3], double B[3][3]) {
    double det = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) -
                 A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) +
                 A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
    if (!(fabs(det) > 0.0) || !isfinite(det)) return 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            int r1 = (c + 1) % 3, r2 = (c + 2) % 3, c1 = (r + 1) % 3, c2 = (r + 2) % 3;
            B[r][c] = (A[r1][c1] * A[r2][c2] - A[r1][c2] * A[r2][c1]) / det;
        }
    return 1;
}

/* The field at the voxel nearest to index-space point ijk (clamped to the grid). */
static double field_at(const vm__imp *w, const double ijk[3]) {
    int64_t i[3];
    for (int a = 0; a < 3; a++) {
        double x = floor(ijk[a] + 0.5);
        if (x < 0) x = 0;
        if (x > (double)(w->v->dims[a] - 1)) x = (double)(w->v->dims[a] - 1);
        i[a] = (int64_t)x;
    }
    return vm__imp_voxel(w, i[0], i[1], i[2]);
}

/* Length of the shortest non-zero edge at vertex i (0 when it has none). */
static double shortest_edge(const vm__imp *w, size_t i) {
    const vm__imp_star *s = &w->star[i];
    const double *pa = w->p + 3 * i;
    double L = INFINITY;
    for (int32_t j = 0; j < s->n; j++)
        for (int k = 0; k < 4; k++) {
            const double *pb = w->p + 3 * (size_t)w->tet[4 * (size_t)s->t[j] + k];
            double d = (pa[0] - pb[0]) * (pa[0] - pb[0]) + (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                       (pa[2] - pb[2]) * (pa[2] - pb[2]);
            if (d > 0.0 && d < L) L = d;
        }
    return isfinite(L) ? sqrt(L) : 0.0;
}

/* 1 when the tets around vertex i belong to more than one region. */
static int regions_mixed(const vm__imp *w, size_t i) {
    const vm__imp_star *s = &w->star[i];
    for (int32_t j = 1; j < s->n; j++)
        if (w->region[s->t[j]] != w->region[s->t[0]]) return 1;
    return 0;
}

/* The (unnormalised) normal (Q - P) x (R - P) of the triangle of vertices c = (P, Q, R). */
static void face_normal(const vm__imp *w, const vm_index c[3], double nn[3]) {
    double u[3], v[3];
    vm__sub3(w->p + 3 * (size_t)c[1], w->p + 3 * (size_t)c[0], u);
    vm__sub3(w->p + 3 * (size_t)c[2], w->p + 3 * (size_t)c[0], v);
    vm__cross3(u, v, nn);
}

/* For vertex i inside the mesh with tets of several regions: 1 when exactly two regions meet
 * there and their interface faces around i are nearly coplanar (unit normals, oriented from
 * the lower region to the higher, within 25 degrees of their mean); the mean normal goes to
 * w->nrm. */
static int interface_plane(vm__imp *w, size_t i) {
    const vm__imp_star *s = &w->star[i];
    int32_t ra = w->region[s->t[0]], rb = ra;
    for (int32_t j = 1; j < s->n; j++) {
        int32_t r = w->region[s->t[j]];
        if (r == ra || r == rb) continue;
        if (ra != rb) return 0; /* a third region: a junction */
        rb = r;
    }
    int32_t lo = ra < rb ? ra : rb;
    double sum[3] = {0, 0, 0}, fn[IFACE_MAX_FACES][3];
    int nf = 0;
    for (int32_t j = 0; j < s->n; j++) {
        size_t t = (size_t)s->t[j];
        if (w->region[t] != lo) continue;
        const vm_index *n = w->tet + 4 * t;
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {n[tet_face[f][0]], n[tet_face[f][1]], n[tet_face[f][2]]};
            if (n[f] == (vm_index)i) continue; /* the face must contain i */
            long u = vm__imp_face_other(w, t, c[0], c[1], c[2]);
            if (u < 0 || w->region[u] == lo) continue;
            if (nf == IFACE_MAX_FACES) return 0;
            double *m = fn[nf];
            face_normal(w, c, m);
            double l = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
            if (!(l > 0.0)) return 0;
            for (int k = 0; k < 3; k++) {
                m[k] /= l;
                sum[k] += m[k];
            }
            nf++;
        }
    }
    double l = sqrt(sum[0] * sum[0] + sum[1] * sum[1] + sum[2] * sum[2]);
    if (nf < 3 || !(l > 0.0)) return 0;
    for (int k = 0; k < 3; k++) sum[k] /= l;
    for (int f = 0; f < nf; f++)
        if (fn[f][0] * sum[0] + fn[f][1] * sum[1] + fn[f][2] * sum[2] < IFACE_COS_MAX_ANGLE)
            return 0; /* more than 25 degrees off */
    memcpy(vm__imp_nrm(w, (vm_index)i), sum, sizeof sum);
    return 1;
}

/* Fills w->bfaces with the boundary faces of the tets in order (4 t + f), passing over the
 * tets inside[] marks (when given): chunks of tets
 * searched in parallel, joined in chunk order. VM_ERR_NOMEM on out-of-memory (the caller
 * sets the message). */
#define BF_CHUNK ((size_t)1 << 14)
static vm_status find_boundary_faces(vm__imp *w, const uint8_t *inside) {
    size_t nt = w->ntet, nc = (nt + BF_CHUNK - 1) / BF_CHUNK;
    size_t **lists = calloc(nc + 1, sizeof *lists), *cnt = calloc(nc + 1, sizeof *cnt);
    int fail = !lists || !cnt;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (size_t c = 0; c < nc; c++) {
        if (!lists || !cnt) continue;
        size_t t1 = (c + 1) * BF_CHUNK < nt ? (c + 1) * BF_CHUNK : nt, cap = 0, k = 0;
        size_t *l = NULL;
        for (size_t t = c * BF_CHUNK; t < t1; t++)
            for (int f = 0; f < 4; f++) {
                const vm_index *n = w->tet + 4 * t;
                if (w->dead[t] || (inside && inside[t]) ||
                    vm__imp_face_other(w, t, n[tet_face[f][0]], n[tet_face[f][1]],
                                       n[tet_face[f][2]]) >= 0)
                    continue;
                if (k == cap) {
                    cap = cap ? 2 * cap : 256;
                    size_t *nl = realloc(l, cap * sizeof *nl);
                    if (!nl) {
                        k = SIZE_MAX; /* this chunk failed */
                        t = t1;
                        break;
                    }
                    l = nl;
                }
                l[k++] = 4 * t + (size_t)f;
            }
        lists[c] = l;
        cnt[c] = k;
    }
    size_t total = 0;
    for (size_t c = 0; !fail && c < nc; c++) {
        if (cnt[c] == SIZE_MAX) fail = 1;
        else total += cnt[c];
    }
    w->bfaces = fail ? NULL : malloc((total + 1) * sizeof *w->bfaces);
    if (w->bfaces) {
        w->nbfaces = 0;
        for (size_t c = 0; c < nc; c++) {
            if (cnt[c]) memcpy(w->bfaces + w->nbfaces, lists[c], cnt[c] * sizeof *w->bfaces);
            w->nbfaces += cnt[c];
        }
    }
    for (size_t c = 0; lists && c < nc; c++) free(lists[c]);
    free(lists);
    free(cnt);
    return w->bfaces ? VM_OK : VM_ERR_NOMEM;
}

void vm__imp_scales(vm__imp *w, const vm_improve_options *o) {
    w->s_min = o->target_min_dihedral;
    w->s_max = 180.0 - o->target_max_dihedral;
    w->s_vm = o->target_volume_measure;
    w->s_fmin = FACE_ANGLE_SCALE_MIN;
    w->s_fmax = FACE_ANGLE_SCALE_MAX;
    w->max_edge2 = o->max_edge > 0.0 ? o->max_edge * o->max_edge : INFINITY;
}

/* Copies the options into w and allocates its per-tet and per-vertex arrays; fills the tets,
 * regions, parents, positions and, in a part, the locked vertices. */
static vm_status imp_alloc(vm__imp *w, const vm_mesh *m, const vm_volume *v,
                           const vm_improve_options *o, const vm__imp_sub *sx, vm_error *err) {
    size_t np = m->npoints, nt = m->ncells;
    w->o = o;
    w->v = v;
    if (v && sx && sx->planes) {
        w->fdata = sx->planes;
        w->fk0 = sx->k0;
        w->fk1 = sx->k1;
    } else if (v) {
        w->fdata = v->data;
        w->fk0 = 0;
        w->fk1 = v->dims[2];
    }
    w->lo = o->lo;
    w->hi = o->hi;
    w->has_lo = o->has_lo;
    w->has_hi = o->has_hi;
    vm__imp_scales(w, o);
    w->rng = o->seed ? o->seed : 1u;
    if (sx) w->rng = sx->seed ? sx->seed : 1u;
    w->npt = np;
    /* The pass mostly removes tets; the few flips add are appended (growing by half). */
    w->tet_cap = nt + nt / 64 + 1024;
    w->tet = malloc(4 * w->tet_cap * sizeof *w->tet);
    w->region = malloc(w->tet_cap * sizeof *w->region);
    /* which input tet each tet descends from: only to carry cell fields */
    w->parent = m->ncell_fields || sx ? malloc(w->tet_cap * sizeof *w->parent) : NULL;
    w->q = malloc(w->tet_cap * sizeof *w->q);
    w->dead = calloc(w->tet_cap, 1);
    w->p = malloc(3 * np * sizeof *w->p);
    w->ci = malloc((np + 1) * sizeof *w->ci);
    w->cls = calloc(np, 1);
    w->planes = calloc(np, 1);
    w->iso_hi = calloc(np, 1);
    w->pdead = calloc(np, 1);
    w->star = calloc(np, sizeof *w->star);
    if (!w->tet || !w->region || ((m->ncell_fields || sx) && !w->parent) || !w->q || !w->dead ||
        !w->p || !w->ci || !w->cls || !w->planes || !w->iso_hi || !w->pdead || !w->star)
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for %zu tets", nt);
    memcpy(w->p, m->points, 3 * np * sizeof *w->p);
    memcpy(w->tet, m->cells, 4 * nt * sizeof *w->tet);
    for (size_t t = 0; t < nt; t++) {
        w->region[t] = m->region ? m->region[t] : 0;
        if (w->parent) w->parent[t] = (vm_index)t;
    }
    w->ntet = nt;
    w->nfrozen = o->frozen ? nt : 0;
    if (sx) {
        /* a part: the locked tets' vertices stay as they are */
        w->lock = sx->lock;
        w->nlock = nt;
        w->vlock = calloc(np + 1, 1);
        if (!w->vlock) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        for (size_t t = 0; t < nt; t++)
            if (sx->lock[t])
                for (int k = 0; k < 4; k++) w->vlock[w->tet[4 * t + k]] = 1;
    }
    return VM_OK;
}

/* Links every tet into its vertices' stars (sized exactly) and caches each tet's quality. */
static vm_status imp_stars(vm__imp *w, const vm__imp_sub *sx, vm_error *err) {
    size_t np = w->npt, nt = w->ntet;
    for (size_t t = 0; t < 4 * nt; t++) w->star[w->tet[t]].cap++;
    for (size_t i = 0; i < np; i++) {
        if (w->star[i].cap == 0) continue;
        w->star[i].t = malloc((size_t)w->star[i].cap * sizeof *w->star[i].t);
        if (!w->star[i].t)
            return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for the stars");
    }
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 4; k++) {
            vm__imp_star *s = &w->star[w->tet[4 * t + k]];
            s->t[s->n++] = (vm_index)t;
        }
    /* In a part, only the tets around the free tets' vertices are ever looked at: the other
     * locked tets (often most of them) take 1 in place of their quality. */
    uint8_t *seen = NULL;
    if (sx) {
        seen = calloc(np + 1, 1);
        if (!seen) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        for (size_t t = 0; t < nt; t++)
            if (!sx->lock[t])
                for (int k = 0; k < 4; k++) seen[w->tet[4 * t + k]] = 1;
    }
    /* Each tet's quality on its own: any thread count gives the same values. A part's tets
     * known to meet the targets (most of them) wait until an operation reads theirs. */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (size_t t = 0; t < nt; t++) {
        const vm_index *n = w->tet + 4 * t;
        if (seen && sx->lock[t] && !seen[n[0]] && !seen[n[1]] && !seen[n[2]] && !seen[n[3]])
            w->q[t] = 1.0;
        else if (sx && sx->below && !sx->below[t])
            w->q[t] = NAN; /* at or above the targets: measured when first read */
        else
            w->q[t] = vm__imp_tet_q(w, t);
    }
    free(seen);
    return VM_OK;
}

/* The volume's index frame, and the border planes each vertex lies on (w->planes): the
 * grid's faces in index space, or the bounding box (the whole mesh's for a part) without a
 * volume. */
static vm_status imp_border_planes(vm__imp *w, const vm_volume *v, const vm__imp_sub *sx,
                                   vm_error *err) {
    size_t np = w->npt;
    if (v) {
        for (int r = 0; r < 3; r++) {
            w->org[r] = v->origin[r];
            for (int c = 0; c < 3; c++) w->A[r][c] = v->direction[r][c] * v->spacing[c];
        }
        if (!vm__imp_invert3(w->A, w->Ainv))
            return vm_error_set(err, VM_ERR_ARG, "improve: the volume's index frame is singular");
    }
    double bmin[3] = {INFINITY, INFINITY, INFINITY}, bmax[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < np; i++)
        for (int a = 0; a < 3; a++) {
            double x = w->p[3 * i + a];
            if (x < bmin[a]) bmin[a] = x;
            if (x > bmax[a]) bmax[a] = x;
        }
    if (sx)
        for (int a = 0; a < 3; a++) {
            bmin[a] = sx->box[a];
            bmax[a] = sx->box[3 + a];
        }
    double ext = 0.0;
    for (int a = 0; a < 3; a++)
        if (bmax[a] - bmin[a] > ext) ext = bmax[a] - bmin[a];
    for (size_t i = 0; i < np; i++) {
        uint8_t bits = 0;
        if (v) {
            double ijk[3];
            vm__imp_to_index(w, w->p + 3 * i, ijk);
            for (int a = 0; a < 3; a++) {
                if (fabs(ijk[a]) < GRID_FACE_TOL) bits |= (uint8_t)(1u << (2 * a));
                if (fabs(ijk[a] - (double)(v->dims[a] - 1)) < GRID_FACE_TOL)
                    bits |= (uint8_t)(2u << (2 * a));
            }
        } else {
            for (int a = 0; a < 3; a++) {
                if (w->p[3 * i + a] - bmin[a] <= BOX_FACE_TOL * ext)
                    bits |= (uint8_t)(1u << (2 * a));
                if (bmax[a] - w->p[3 * i + a] <= BOX_FACE_TOL * ext)
                    bits |= (uint8_t)(2u << (2 * a));
            }
        }
        w->planes[i] = bits;
    }
    return VM_OK;
}

/* The vertices that may be constrained, on a boundary face (bnd) or between regions, get a
 * slot (w->ci) with their starting position (w->p0), a zero normal and bound. */
static vm_status imp_constrained(vm__imp *w, const vm__imp_sub *sx, uint8_t *bnd,
                                 vm_error *err) {
    size_t np = w->npt;
    for (size_t e = 0; e < w->nbfaces; e++) {
        const vm_index *n = w->tet + 4 * (w->bfaces[e] / 4);
        int f = (int)(w->bfaces[e] % 4);
        for (int k = 0; k < 3; k++) bnd[n[tet_face[f][k]]] = 1;
    }
    size_t nc = 0;
    for (size_t i = 0; i < np; i++)
        w->ci[i] = bnd[i] || regions_mixed(w, i) ? (int32_t)nc++ : -1;
    w->p0 = malloc((3 * nc + 1) * sizeof *w->p0);
    w->nrm = calloc(3 * nc + 1, sizeof *w->nrm);
    w->bound = calloc(nc + 1, sizeof *w->bound);
    if (!w->p0 || !w->nrm || !w->bound)
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t i = 0; i < np; i++)
        if (w->ci[i] >= 0)
            memcpy(w->p0 + 3 * (size_t)w->ci[i], sx ? sx->p0 + 3 * i : w->p + 3 * i,
                   3 * sizeof *w->p0);
    return VM_OK;
}

/* Sums the boundary faces' normals at their vertices (normalised after), and notes which
 * border planes all of a vertex's boundary faces lie on (boxmask) or that one lies on none
 * (nonbox). */
static void imp_boundary_normals(vm__imp *w, uint8_t *bnd, uint8_t *nonbox, uint8_t *boxmask) {
    for (size_t e = 0; e < w->nbfaces; e++) {
        size_t t = w->bfaces[e] / 4;
        int f = (int)(w->bfaces[e] % 4);
        const vm_index *n = w->tet + 4 * t;
        vm_index c[3] = {n[tet_face[f][0]], n[tet_face[f][1]], n[tet_face[f][2]]};
        double nn[3];
        face_normal(w, c, nn);
        uint8_t common = w->planes[c[0]] & w->planes[c[1]] & w->planes[c[2]];
        for (int k = 0; k < 3; k++) {
            bnd[c[k]] = 1;
            if (common) boxmask[c[k]] |= common;
            else nonbox[c[k]] = 1;
            double *nk = vm__imp_nrm(w, c[k]);
            for (int j = 0; j < 3; j++) nk[j] += nn[j];
        }
    }
    for (size_t i = 0; i < w->npt; i++)
        if (w->ci[i] >= 0) {
            double *nn = vm__imp_nrm(w, (vm_index)i);
            double l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
            if (l > 0.0)
                for (int k = 0; k < 3; k++) nn[k] /= l;
        }
}

/* The class of vertex i (VM__IMP_*) and, for a vertex that moves within bounds, its bound
 * (and for an isosurface vertex, which of the two isosurfaces it lies on). */
static void imp_classify(vm__imp *w, size_t i, const uint8_t *bnd, const uint8_t *nonbox,
                         const uint8_t *boxmask) {
    const vm_improve_options *o = w->o;
    const vm__imp_star *s = &w->star[i];
    int nplanes = __builtin_popcount(w->planes[i]);
    if (s->n == 0) w->cls[i] = VM__IMP_FIXED;
    else if (regions_mixed(w, i))
        w->cls[i] = !bnd[i] && o->max_interface_move > 0.0 && interface_plane(w, i)
                        ? VM__IMP_IFACE
                        : VM__IMP_FIXED;
    else if (!bnd[i]) w->cls[i] = VM__IMP_INTERIOR;
    else if (w->planes[i] == 0) w->cls[i] = VM__IMP_SURF;
    else if (!nonbox[i] && nplanes == 1 && boxmask[i] == w->planes[i])
        w->cls[i] = VM__IMP_FLAT;
    else w->cls[i] = VM__IMP_FIXED;
    if (w->cls[i] == VM__IMP_IFACE)
        w->bound[w->ci[i]] = o->max_interface_move * shortest_edge(w, i);
    /* a rim vertex of a border plane: which isosurface its faces off the plane follow (the
     * boundary triangles' check, vm__imp_chord_ok) */
    int rim = w->cls[i] == VM__IMP_FIXED && w->planes[i] && bnd[i];
    if (w->cls[i] != VM__IMP_SURF && !rim) return;
    if (w->v) {
        double ijk[3];
        vm__imp_to_index(w, w->p + 3 * i, ijk);
        double f = field_at(w, ijk);
        w->iso_hi[i] = w->has_hi && (!w->has_lo || fabs(f - w->hi) < fabs(f - w->lo));
        if (!rim) w->bound[w->ci[i]] = o->max_surface_move;
    } else if (!rim) {
        double L = shortest_edge(w, i);
        w->bound[w->ci[i]] = L > 0.0 ? o->max_surface_move_free * L : 0.0;
    }
}

/* The boundary and its classes: boundary faces, constrained vertices, their normals and
 * each vertex's class. */
static vm_status imp_boundary_classes(vm__imp *w, const vm__imp_sub *sx, vm_error *err) {
    size_t np = w->npt;
    uint8_t *bnd = calloc(np, 1), *nonbox = calloc(np, 1), *boxmask = calloc(np, 1);
    vm_status s = VM_OK;
    if (!bnd || !nonbox || !boxmask || find_boundary_faces(w, sx ? sx->inside : NULL) != VM_OK)
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    if (s == VM_OK) s = imp_constrained(w, sx, bnd, err);
    if (s == VM_OK) {
        imp_boundary_normals(w, bnd, nonbox, boxmask);
        for (size_t i = 0; i < np; i++) imp_classify(w, i, bnd, nonbox, boxmask);
    }
    free(bnd);
    free(nonbox);
    free(boxmask);
    return s;
}

/* Sets w up for m: arrays, stars and qualities, border planes, boundary classes. */
static vm_status imp_init(vm__imp *w, const vm_mesh *m, const vm_volume *v,
                          const vm_improve_options *o, const vm__imp_sub *sx, vm_error *err) {
    vm_status s = imp_alloc(w, m, v, o, sx, err);
    if (s == VM_OK) s = imp_stars(w, sx, err);
    if (s == VM_OK) s = imp_border_planes(w, v, sx, err);
    if (s == VM_OK) s = imp_boundary_classes(w, sx, err);
    return s;
}

/* --- the rounds --------------------------------------------------------------------------- */

typedef struct tq {
    double q;
    size_t t;
} tq;

static int tq_cmp(const void *pa, const void *pb) {
    const tq *a = pa, *b = pb;
    if (a->q != b->q) return a->q < b->q ? -1 : 1;
    return a->t < b->t ? -1 : a->t > b->t;
}

/* 1 when tet t is one of the input tets o->frozen keeps off the lists; in a part, also when
 * it has a locked vertex (it waits for the bands over the part's border, where it is free:
 * here little can be done for it, at the price of the longest searches). */
static int frozen(const vm__imp *w, size_t t) {
    if (t < w->nfrozen && w->o->frozen[t]) return 1;
    if (!w->vlock) return 0;
    const vm_index *n = w->tet + 4 * t;
    return w->vlock[n[0]] || w->vlock[n[1]] || w->vlock[n[2]] || w->vlock[n[3]];
}

/* Tets with q below 1 (the targets) and not frozen, worst first. The first list scans the
 * mesh; later ones take the previous list and the tets touched since (every other tet kept
 * its quality, at or above 1), so a round costs what it changes, not the mesh size. The
 * list is the same either way: the tets below 1 in (q, id) order. */
static tq *bad_list(vm__imp *w, const tq *prev, size_t nprev, size_t *n) {
    size_t c = 0;
    tq *l;
    if (!prev) {
        for (size_t t = 0; t < w->ntet; t++)
            c += !w->dead[t] && w->q[t] < 1.0 && !frozen(w, t);
        l = malloc((c ? c : 1) * sizeof *l);
        if (!l) return NULL;
        c = 0;
        for (size_t t = 0; t < w->ntet; t++)
            if (!w->dead[t] && w->q[t] < 1.0 && !frozen(w, t)) {
                l[c].q = w->q[t];
                l[c].t = t;
                c++;
            }
    } else {
        l = malloc((nprev + w->ntouched + 1) * sizeof *l);
        if (!l) return NULL;
        for (size_t i = 0; i < nprev + w->ntouched; i++) {
            size_t t = i < nprev ? prev[i].t : (size_t)w->touched[i - nprev];
            if (w->dead[t] || !(w->q[t] < 1.0) || frozen(w, t)) continue;
            l[c].q = w->q[t];
            l[c].t = t;
            c++;
        }
    }
    w->ntouched = 0;
    qsort(l, c, sizeof *l, tq_cmp);
    /* a tet listed twice sorts next to itself */
    size_t u = 0;
    for (size_t i = 0; i < c; i++)
        if (u == 0 || l[i].t != l[u - 1].t) l[u++] = l[i];
    *n = u;
    return l;
}

/* Replaces *l (n entries) by the current bad list; 0 on out-of-memory (*l freed). */
static int next_bad_list(vm__imp *w, tq **l, size_t *n) {
    size_t m = 0;
    tq *nl = bad_list(w, *l, *n, &m);
    free(*l);
    *l = nl;
    *n = nl ? m : 0;
    if (!nl) w->nomem = 1;
    return nl != NULL;
}

/* Vertices of the still-bad tets of the list, each once (stamp marks). */
static size_t bad_vertices(const vm__imp *w, const tq *l, size_t n, vm_index *out,
                           uint32_t *stamp, uint32_t round) {
    size_t c = 0;
    for (size_t i = 0; i < n; i++) {
        size_t t = l[i].t;
        if (w->dead[t] || vm__imp_q(w, t) >= 1.0) continue;
        for (int k = 0; k < 4; k++) {
            vm_index a = w->tet[4 * t + k];
            if (stamp[a] == round) continue;
            stamp[a] = round;
            out[c++] = a;
        }
    }
    return c;
}

/* Rounds shrink fast (the first does most of the work), so round r + x (x: how far into the
 * round) shows as 1 - 2^-(r + x) of the rounds' share. */
static void show_rounds(const vm_improve_options *o, double x) {
    vm__imp_show(o, VM__IMP_SETUP_SHARE + (1.0 - VM__IMP_SETUP_SHARE - VM__IMP_FINAL_SHARE) *
                                              (1.0 - pow(0.5, x)));
}

/* Progress within a round: phase 0..3 (contract, flip, peel, smooth), item i of n. */
static void report(const vm_improve_options *o, int pass, int phase, size_t i, size_t n) {
    if (!o->progress || (i & 1023) != 0 || n == 0) return;
    show_rounds(o, pass + (phase + (double)i / (double)n) / 4.0);
}

/* The caller's progress asked to stop (vm_mesh_improve forwards it through a meter; a part's
 * options carry none): the passes end after the operation under way, the mesh whole. */
static int stop_asked(const vm_improve_options *o) {
    return vm__progress_stopped(o->progress, o->progress_user);
}

static size_t run_passes(vm__imp *w, const vm_improve_options *o, int *passes) {
    size_t ops_total = 0;
    uint32_t *stamp = calloc(w->npt, sizeof *stamp);
    if (!stamp) {
        w->nomem = 1;
        return 0;
    }
    uint32_t round = 0;
    int pass;
    tq *l = NULL;
    size_t n = 0;
    for (pass = 0; pass < o->max_passes && !w->nomem && !stop_asked(o); pass++) {
        size_t ops = 0;
        w->deep = pass >= 1;
        if (!next_bad_list(w, &l, &n) || n == 0) break;
        if (o->contract)
            for (size_t i = 0; i < n && !w->nomem && !stop_asked(o); i++) {
                report(o, pass, 0, i, n);
                if (!w->dead[l[i].t] && vm__imp_q(w, l[i].t) < 1.0) ops += (size_t)vm__imp_contract_tet(w, l[i].t);
            }
        if (o->flip)
            for (size_t i = 0; i < n && !w->nomem && !stop_asked(o); i++) {
                report(o, pass, 1, i, n);
                if (!w->dead[l[i].t] && vm__imp_q(w, l[i].t) < 1.0) ops += (size_t)vm__imp_flip_tet(w, l[i].t);
            }
        if (w->deep)
            for (size_t i = 0; i < n && !w->nomem && !stop_asked(o); i++) {
                report(o, pass, 2, i, n);
                if (!w->dead[l[i].t] && vm__imp_q(w, l[i].t) < VM__IMP_Q_ABAQUS)
                    ops += (size_t)vm__imp_peel_tet(w, l[i].t);
            }
        if (!next_bad_list(w, &l, &n)) break;
        vm_index *vs = malloc((4 * n + 1) * sizeof *vs);
        if (!vs) {
            w->nomem = 1;
            break;
        }
        if (o->smooth) {
            size_t nv = bad_vertices(w, l, n, vs, stamp, ++round);
            for (size_t i = 0; i < nv && !stop_asked(o); i++) {
                report(o, pass, 3, i, nv);
                ops += (size_t)vm__imp_smooth_vertex(w, vs[i], 6);
            }
        }
        if (o->perturb && pass >= 1) {
            size_t nv = bad_vertices(w, l, n, vs, stamp, ++round);
            for (size_t i = 0; i < nv && !stop_asked(o); i++)
                ops += (size_t)vm__imp_perturb_vertex(w, vs[i], 24);
        }
        free(vs);
        ops_total += ops;
        show_rounds(o, pass + 1.0);
        /* a part (vlock) often starts with tets only the later rounds' peels and surface
         * flips can fix: it gives them their round */
        if (ops == 0 && (pass >= 1 || !w->vlock)) break;
    }
    /* Last rounds for the few tets still failing ABAQUS's check: long searches around them,
     * their vertices and their neighbours' vertices. */
    w->deep = 1;
    for (int extra = 0; extra < 4 && !w->nomem && !stop_asked(o); extra++) {
        size_t ops = 0;
        if (!next_bad_list(w, &l, &n)) break;
        for (size_t i = 0; i < n && !w->nomem && !stop_asked(o); i++) {
            size_t t = l[i].t;
            if (w->dead[t] || vm__imp_q(w, t) >= VM__IMP_Q_ABAQUS) continue;
            if (vm__imp_contract_tet(w, t) || vm__imp_flip_tet(w, t) || vm__imp_peel_tet(w, t)) {
                ops++;
                continue;
            }
            vm_index vs[4];
            memcpy(vs, w->tet + 4 * t, sizeof vs);
            for (int k = 0; k < 4; k++) {
                const vm__imp_star *st = &w->star[vs[k]];
                for (int32_t j = 0; j < st->n && j < 64; j++)
                    for (int c = 0; c < 4; c++) {
                        vm_index u = w->tet[4 * (size_t)st->t[j] + c];
                        ops += (size_t)vm__imp_smooth_vertex(w, u, 4);
                    }
                ops += (size_t)vm__imp_perturb_vertex(w, vs[k], 200);
            }
        }
        ops_total += ops;
        if (ops == 0) break;
    }
    free(l);
    free(stamp);
    vm__imp_show(o, 1.0 - VM__IMP_FINAL_SHARE);
    *passes = pass;
    return ops_total;
}

/* The largest displacements of isosurface vertices (voxels with a volume) and of interface
 * vertices (world) from their starting positions (for a part: where the pass found them). */
static void measure_moves(const vm__imp *w, const vm_volume *v, double *maxmove,
                          double *maxiface) {
    for (size_t i = 0; i < w->npt; i++) {
        /* a locked vertex did not move here (and may look like a boundary one) */
        if (vm__imp_vlocked(w, (vm_index)i)) continue;
        if (!w->pdead[i] && w->cls[i] == VM__IMP_IFACE) {
            double d[3];
            const double *q0 = vm__imp_p0(w, (vm_index)i);
            for (int k = 0; k < 3; k++) d[k] = w->p[3 * i + k] - q0[k];
            double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            if (l > *maxiface) *maxiface = l;
        }
        if (w->pdead[i] || w->cls[i] != VM__IMP_SURF) continue;
        double d[3], x0[3], x1[3];
        if (v) {
            vm__imp_to_index(w, vm__imp_p0(w, (vm_index)i), x0);
            vm__imp_to_index(w, w->p + 3 * i, x1);
        } else {
            memcpy(x0, vm__imp_p0(w, (vm_index)i), sizeof x0);
            memcpy(x1, w->p + 3 * i, sizeof x1);
        }
        for (int k = 0; k < 3; k++) d[k] = x1[k] - x0[k];
        double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        if (l > *maxmove) *maxmove = l;
    }
}

/* Sets w up for m, runs the rounds and measures the moves; the rounds' data is freed, the
 * mesh data stays in w. For a part (x), m and x->p0 are freed as soon as w holds them (a
 * part's options carry no progress callback, so vm__imp_show() draws nothing there). */
vm_status vm__imp_run(vm__imp *w, vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                      vm__imp_sub *x, int *passes, double *maxmove, double *maxiface,
                      vm_error *err) {
    memset(w, 0, sizeof *w);
    vm__imp_show(o, 0.25 * VM__IMP_SETUP_SHARE);
    vm_status s = imp_init(w, m, v, o, x, err);
    if (x) {
        vm_mesh_free(m);
        free(x->p0);
        x->p0 = NULL;
    }
    vm__imp_show(o, 0.75 * VM__IMP_SETUP_SHARE);
    if (s == VM_OK && !vm__imp_guard_init(w))
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for the boundary guard");
    vm__imp_show(o, VM__IMP_SETUP_SHARE);
    free(w->bfaces); /* only for setting up */
    w->bfaces = NULL;
    if (s == VM_OK) {
        run_passes(w, o, passes);
        if (w->nomem) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    if (s == VM_OK) measure_moves(w, v, maxmove, maxiface);
    if (s == VM_OK && x) {
        /* what the parts' driver needs of the qualities, which go with the rounds' data */
        w->below = malloc(w->ntet + 1);
        if (!w->below) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        for (size_t t = 0; w->below && t < w->ntet; t++) w->below[t] = w->q[t] < 1.0;
    }
    imp_free_rounds(w);
    return s;
}

/* Frees everything w holds. */
void vm__imp_free(vm__imp *w) {
    imp_free_rounds(w);
    free(w->tet);
    free(w->region);
    free(w->parent);
    free(w->q);
    free(w->dead);
    free(w->p);
    free(w->p0);
    free(w->ci);
    free(w->cls);
    free(w->planes);
    free(w->iso_hi);
    free(w->pdead);
    free(w->nrm);
    free(w->bound);
    free(w->bfaces);
    free(w->vlock);
    free(w->below);
}

/* Planes k0 <= k < k1 from src into a new buffer, within the memory limit. */
vm_status vm__imp_read_planes(const vm_volume *info, vm_plane_source src, void *user,
                              int64_t k0, int64_t k1, float **out, vm_error *err) {
    *out = NULL;
    size_t n, bytes;
    if (vm__mul_overflows((size_t)info->dims[0] * (size_t)info->dims[1], (size_t)(k1 - k0), &n) ||
        vm__mul_overflows(n, sizeof **out, &bytes) || bytes > vm__memory_limit())
        return vm_error_set(err, VM_ERR_NOMEM,
                            "improve: planes %lld..%lld are over the memory limit",
                            (long long)k0, (long long)k1 - 1);
    float *data = malloc(bytes + sizeof *data);
    if (!data)
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for planes %lld..%lld",
                            (long long)k0, (long long)k1 - 1);
    vm_volume planes;
    memset(&planes, 0, sizeof planes);
    planes.dims[0] = info->dims[0];
    planes.dims[1] = info->dims[1];
    planes.dims[2] = k1 - k0;
    planes.data = data;
    vm_status s = src(k0, k1, &planes, user, err);
    if (s != VM_OK) {
        free(data);
        return s;
    }
    *out = data;
    return VM_OK;
}

