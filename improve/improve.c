/* improve/improve.c — the quality-improvement pass: rounds of edge contraction (seed 001 §6),
 * flips, optimisation-based smoothing and random perturbation over the tets below the targets
 * (schedule after Klingner and Shewchuk 2007, "Aggressive tetrahedral mesh improvement"). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "improve_internal.h"
#include "volmesh/quality.h"
#include "../core/vec3.h"

void vm_improve_options_default(vm_improve_options *o) {
    memset(o, 0, sizeof *o);
    o->lo = 0.0;
    o->hi = 0.0;
    o->has_lo = 1;
    o->has_hi = 0;
    o->max_surface_move = 0.8;
    o->max_surface_move_free = 0.1;
    o->max_interface_move = 0.1;
    o->surface_tolerance = 0.5;
    o->surface_band = 0.3;
    o->target_min_dihedral = 15.0;
    o->target_max_dihedral = 150.0;
    o->target_volume_measure = 0.03;
    o->max_passes = 12;
    o->contract = o->flip = o->smooth = o->perturb = 1;
    o->seed = 1;
    o->mark_unfixed = 0;
}

/* --- whole-mesh figures ------------------------------------------------------------------ */

typedef struct figures {
    double dmin, dmax, volume;
    size_t s5, s10, abaqus, inverted, unfixed;
} figures;

/* 1 when the tet fails the ABAQUS check or the bar; *fail_abaqus tells which. */
static int tet_figures(const double p[4][3], figures *f, int *abaqus) {
    double lo = vm_tet_min_dihedral(p), hi = vm_tet_max_dihedral(p);
    double vol = vm_tet_signed_volume(p), vm = vm__imp_volume_measure(p);
    if (lo < f->dmin) f->dmin = lo;
    if (hi > f->dmax) f->dmax = hi;
    f->volume += vol;
    f->s5 += lo < 5.0;
    f->s10 += lo < 10.0;
    f->inverted += !(vol > 0.0);
    /* ABAQUS's element check (as the quality report counts it): volume measure, and the
     * angles of the faces */
    *abaqus = vm < 0.02 || vm_tet_min_face_angle(p) < 10.0 || vm_tet_max_face_angle(p) > 160.0;
    f->abaqus += (size_t)*abaqus;
    int bad = *abaqus || lo < 10.0 || hi > 165.0 || !(vol > 0.0);
    f->unfixed += (size_t)bad;
    return bad;
}

/* The cosines of the thresholds above; a cosine this close to one takes the exact path. */
#define COS5 0.9961946980917455
#define COS10 0.984807753012208
#define COS160 (-0.9396926207859083)
#define COS165 (-0.9659258262890682)
#define FIG_EPS 1e-9
#define FIG_DEG (180.0 / 3.14159265358979323846)

static int near_cos(double c, double ref) { return fabs(c - ref) < FIG_EPS; }

/* The figures of tets [t0, t1): the same counts and extremes as tet_figures over each of them,
 * but the thresholds compared on cosines (no atan2) wherever a cosine is clearly on one side;
 * the extremes are measured exactly only for the tets that may hold them. */
static void chunk_figures(const double *pts, const vm_index *cells, size_t t0, size_t t1,
                          figures *f, double *unfixed_field) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    memset(f, 0, sizeof *f);
    f->dmin = 180.0;
    f->dmax = 0.0;
    double cdmin = -1.0, cdmax = 1.0; /* cosines of f->dmin and f->dmax */
    for (size_t t = t0; t < t1; t++) {
        double p[4][3];
        for (int k = 0; k < 4; k++) memcpy(p[k], pts + 3 * (size_t)cells[4 * t + k], sizeof p[k]);
        const double(*cp)[3] = (const double(*)[3])p;
        double vol = vm_tet_signed_volume(cp), el[4][4], lmax2 = 0.0;
        for (int i = 0; i < 4; i++)
            for (int j = i + 1; j < 4; j++) {
                double e[3] = {p[j][0] - p[i][0], p[j][1] - p[i][1], p[j][2] - p[i][2]};
                double l2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
                if (l2 > lmax2) lmax2 = l2;
                el[i][j] = el[j][i] = sqrt(l2);
            }
        int exact = !isfinite(vol) || !isfinite(lmax2) ||
                    !(6.0 * vol > 1e-11 * lmax2 * sqrt(lmax2));
        double cmax = -2.0, cmin = 2.0, fcmax = -2.0, fcmin = 2.0, n[4][3], dc[6];
        if (!exact) {
            double len[4];
            for (int g = 0; g < 4; g++) {
                double u[3], w[3];
                vm__sub3(p[fo[g][1]], p[fo[g][0]], u);
                vm__sub3(p[fo[g][2]], p[fo[g][0]], w);
                vm__cross3(u, w, n[g]);
                len[g] = sqrt(vm__dot3(n[g], n[g]));
                for (int k = 0; k < 3; k++) {
                    int o = fo[g][k], i = fo[g][(k + 1) % 3], j = fo[g][(k + 2) % 3];
                    vm__sub3(p[i], p[o], u);
                    vm__sub3(p[j], p[o], w);
                    double cs = vm__dot3(u, w) / (el[o][i] * el[o][j]);
                    if (cs > fcmax) fcmax = cs;
                    if (cs < fcmin) fcmin = cs;
                }
            }
            for (int g = 0, k = 0; g < 4; g++)
                for (int h = g + 1; h < 4; h++, k++) {
                    double cs = -vm__dot3(n[g], n[h]) / (len[g] * len[h]);
                    dc[k] = cs;
                    if (cs > cmax) cmax = cs;
                    if (cs < cmin) cmin = cs;
                }
            exact = !isfinite(cmax) || !isfinite(cmin) || !isfinite(fcmax) ||
                    !isfinite(fcmin) || near_cos(cmax, COS5) || near_cos(cmax, COS10) ||
                    near_cos(cmin, COS165) || near_cos(fcmax, COS10) || near_cos(fcmin, COS160);
        }
        int bad;
        if (exact) {
            int ab;
            bad = tet_figures(cp, f, &ab);
            cdmin = cos(f->dmin / FIG_DEG);
            cdmax = cos(f->dmax / FIG_DEG);
        } else {
            /* here vol > 0 */
            f->volume += vol;
            f->s5 += cmax > COS5;
            f->s10 += cmax > COS10;
            int ab = vm__imp_volume_measure(cp) < 0.02 || fcmax > COS10 || fcmin < COS160;
            f->abaqus += (size_t)ab;
            bad = ab || cmax > COS10 || cmin < COS165;
            f->unfixed += (size_t)bad;
            /* Only the dihedrals that may be the chunk's extremes, measured as
             * vm_tet_min_dihedral and vm_tet_max_dihedral measure them. */
            if (cmax > cdmin - FIG_EPS || cmin < cdmax + FIG_EPS)
                for (int g = 0, k = 0; g < 4; g++)
                    for (int h = g + 1; h < 4; h++, k++) {
                        if (!(dc[k] > cdmin - FIG_EPS) && !(dc[k] < cdmax + FIG_EPS)) continue;
                        double ng[3] = {-n[h][0], -n[h][1], -n[h][2]};
                        double a = vm__angle_deg(n[g], ng);
                        if (a < f->dmin) {
                            f->dmin = a;
                            cdmin = cos(a / FIG_DEG);
                        }
                        if (a > f->dmax) {
                            f->dmax = a;
                            cdmax = cos(a / FIG_DEG);
                        }
                    }
        }
        if (unfixed_field) unfixed_field[t] = bad;
    }
}

/* Fixed chunks summed in their order: the same figures for any thread count. */
#define FIG_CHUNK ((size_t)1 << 15)

static int mesh_figures(const double *pts, const vm_index *cells, size_t n, figures *f,
                        double *unfixed_field) {
    size_t nc = (n + FIG_CHUNK - 1) / FIG_CHUNK;
    figures *part = malloc((nc ? nc : 1) * sizeof *part);
    if (!part) return 0;
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(dynamic, 1)
#endif
    for (size_t c = 0; c < nc; c++) {
        size_t t1 = (c + 1) * FIG_CHUNK < n ? (c + 1) * FIG_CHUNK : n;
        chunk_figures(pts, cells, c * FIG_CHUNK, t1, &part[c], unfixed_field);
    }
    memset(f, 0, sizeof *f);
    f->dmin = 180.0;
    f->dmax = 0.0;
    for (size_t c = 0; c < nc; c++) {
        const figures *g = &part[c];
        if (g->dmin < f->dmin) f->dmin = g->dmin;
        if (g->dmax > f->dmax) f->dmax = g->dmax;
        f->volume += g->volume;
        f->s5 += g->s5;
        f->s10 += g->s10;
        f->abaqus += g->abaqus;
        f->inverted += g->inverted;
        f->unfixed += g->unfixed;
    }
    free(part);
    return 1;
}

/* --- setting up the working mesh --------------------------------------------------------- */

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
    free(w->touched);
    w->touched = NULL;
    vm__imp_guard_free(w);
}

static void imp_free(vm__imp *w) {
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

/* For vertex i inside the mesh with tets of several regions: 1 when exactly two regions meet
 * there and their interface faces around i are nearly coplanar (unit normals, oriented from
 * the lower region to the higher, within 25 degrees of their mean); the mean normal goes to
 * w->nrm. */
static int interface_plane(vm__imp *w, size_t i) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    const vm__imp_star *s = &w->star[i];
    int32_t ra = w->region[s->t[0]], rb = ra;
    for (int32_t j = 1; j < s->n; j++) {
        int32_t r = w->region[s->t[j]];
        if (r == ra || r == rb) continue;
        if (ra != rb) return 0; /* a third region: a junction */
        rb = r;
    }
    int32_t lo = ra < rb ? ra : rb;
    double sum[3] = {0, 0, 0}, fn[64][3];
    int nf = 0;
    for (int32_t j = 0; j < s->n; j++) {
        size_t t = (size_t)s->t[j];
        if (w->region[t] != lo) continue;
        const vm_index *n = w->tet + 4 * t;
        for (int f = 0; f < 4; f++) {
            vm_index c[3] = {n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]};
            if (n[f] == (vm_index)i) continue; /* the face must contain i */
            long u = vm__imp_face_other(w, t, c[0], c[1], c[2]);
            if (u < 0 || w->region[u] == lo) continue;
            if (nf == 64) return 0;
            const double *P = w->p + 3 * (size_t)c[0], *Q = w->p + 3 * (size_t)c[1],
                         *R = w->p + 3 * (size_t)c[2];
            double a[3], b[3], *m = fn[nf];
            for (int k = 0; k < 3; k++) {
                a[k] = Q[k] - P[k];
                b[k] = R[k] - P[k];
            }
            m[0] = a[1] * b[2] - a[2] * b[1];
            m[1] = a[2] * b[0] - a[0] * b[2];
            m[2] = a[0] * b[1] - a[1] * b[0];
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
        if (fn[f][0] * sum[0] + fn[f][1] * sum[1] + fn[f][2] * sum[2] < 0.90630778703665)
            return 0; /* more than 25 degrees off (cos 25 degrees) */
    memcpy(vm__imp_nrm(w, (vm_index)i), sum, sizeof sum);
    return 1;
}

/* Fills w->bfaces with the boundary faces of the tets in order (4 t + f): chunks of tets
 * searched in parallel, joined in chunk order. 0 on out-of-memory. */
#define BF_CHUNK ((size_t)1 << 14)
static int find_boundary_faces(vm__imp *w) {
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
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
                if (w->dead[t] ||
                    vm__imp_face_other(w, t, n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]) >= 0)
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
    return w->bfaces != NULL;
}

static vm_status imp_init(vm__imp *w, const vm_mesh *m, const vm_volume *v,
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
    w->s_min = o->target_min_dihedral;
    w->s_max = 180.0 - o->target_max_dihedral;
    w->s_vm = o->target_volume_measure;
    w->s_fmin = 15.0; /* face angles: 10 and 160 degrees (ABAQUS) score 2/3, as the others */
    w->s_fmax = 30.0;
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
    /* Stars, sized exactly. */
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
    /* Each tet's quality on its own: any thread count gives the same values. */
#ifdef VM_HAVE_OPENMP
#pragma omp parallel for schedule(static, 4096)
#endif
    for (size_t t = 0; t < nt; t++) {
        const vm_index *n = w->tet + 4 * t;
        if (seen && sx->lock[t] && !seen[n[0]] && !seen[n[1]] && !seen[n[2]] && !seen[n[3]])
            w->q[t] = 1.0;
        else
            w->q[t] = vm__imp_tet_q(w, t);
    }
    free(seen);
    if (v) {
        for (int r = 0; r < 3; r++) {
            w->org[r] = v->origin[r];
            for (int c = 0; c < 3; c++) w->A[r][c] = v->direction[r][c] * v->spacing[c];
        }
        if (!vm__imp_invert3(w->A, w->Ainv))
            return vm_error_set(err, VM_ERR_ARG, "improve: the volume's index frame is singular");
    }
    /* Border planes: the grid's faces in index space, or the bounding box without a volume. */
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
                if (fabs(ijk[a]) < 1e-6) bits |= (uint8_t)(1u << (2 * a));
                if (fabs(ijk[a] - (double)(v->dims[a] - 1)) < 1e-6) bits |= (uint8_t)(2u << (2 * a));
            }
        } else {
            for (int a = 0; a < 3; a++) {
                if (w->p[3 * i + a] - bmin[a] <= 1e-9 * ext) bits |= (uint8_t)(1u << (2 * a));
                if (bmax[a] - w->p[3 * i + a] <= 1e-9 * ext) bits |= (uint8_t)(2u << (2 * a));
            }
        }
        w->planes[i] = bits;
    }
    /* Boundary faces: which vertices are on the boundary, their normals, and whether all
     * their faces lie on one border plane. */
    static const int fo[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    uint8_t *bnd = calloc(np, 1), *nonbox = calloc(np, 1), *boxmask = calloc(np, 1);
    if (!bnd || !nonbox || !boxmask) {
        free(bnd);
        free(nonbox);
        free(boxmask);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    if (!find_boundary_faces(w)) {
        free(bnd);
        free(nonbox);
        free(boxmask);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    /* The vertices that may be constrained: on a boundary face, or between regions. */
    for (size_t e = 0; e < w->nbfaces; e++) {
        const vm_index *n = w->tet + 4 * (w->bfaces[e] / 4);
        int f = (int)(w->bfaces[e] % 4);
        for (int k = 0; k < 3; k++) bnd[n[fo[f][k]]] = 1;
    }
    size_t nc = 0;
    for (size_t i = 0; i < np; i++) {
        int mixed = 0;
        const vm__imp_star *s = &w->star[i];
        for (int32_t j = 1; j < s->n && !mixed; j++)
            mixed = w->region[s->t[j]] != w->region[s->t[0]];
        w->ci[i] = bnd[i] || mixed ? (int32_t)nc++ : -1;
    }
    w->p0 = malloc((3 * nc + 1) * sizeof *w->p0);
    w->nrm = calloc(3 * nc + 1, sizeof *w->nrm);
    w->bound = calloc(nc + 1, sizeof *w->bound);
    if (!w->p0 || !w->nrm || !w->bound) {
        free(bnd);
        free(nonbox);
        free(boxmask);
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t i = 0; i < np; i++)
        if (w->ci[i] >= 0)
            memcpy(w->p0 + 3 * (size_t)w->ci[i], sx ? sx->p0 + 3 * i : w->p + 3 * i,
                   3 * sizeof *w->p0);
    for (size_t e = 0; e < w->nbfaces; e++) {
        size_t t = w->bfaces[e] / 4;
        int f = (int)(w->bfaces[e] % 4);
        const vm_index *n = w->tet + 4 * t;
        vm_index c[3] = {n[fo[f][0]], n[fo[f][1]], n[fo[f][2]]};
        const double *P = w->p + 3 * (size_t)c[0], *Q = w->p + 3 * (size_t)c[1],
                     *R = w->p + 3 * (size_t)c[2];
        double u[3], vv[3], nn[3];
        for (int k = 0; k < 3; k++) {
            u[k] = Q[k] - P[k];
            vv[k] = R[k] - P[k];
        }
        nn[0] = u[1] * vv[2] - u[2] * vv[1];
        nn[1] = u[2] * vv[0] - u[0] * vv[2];
        nn[2] = u[0] * vv[1] - u[1] * vv[0];
        uint8_t common = w->planes[c[0]] & w->planes[c[1]] & w->planes[c[2]];
        for (int k = 0; k < 3; k++) {
            bnd[c[k]] = 1;
            if (common) boxmask[c[k]] |= common;
            else nonbox[c[k]] = 1;
            double *nk = vm__imp_nrm(w, c[k]);
            for (int j = 0; j < 3; j++) nk[j] += nn[j];
        }
    }
    for (size_t i = 0; i < np; i++) {
        if (w->ci[i] >= 0) {
            double *nn = vm__imp_nrm(w, (vm_index)i);
            double l = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
            if (l > 0.0)
                for (int k = 0; k < 3; k++) nn[k] /= l;
        }
        int regions_mixed = 0;
        const vm__imp_star *s = &w->star[i];
        for (int32_t j = 1; j < s->n; j++)
            if (w->region[s->t[j]] != w->region[s->t[0]]) regions_mixed = 1;
        int nplanes = __builtin_popcount(w->planes[i]);
        if (s->n == 0) w->cls[i] = VM__IMP_FIXED;
        else if (regions_mixed)
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
        if (w->cls[i] == VM__IMP_SURF) {
            if (v) {
                double ijk[3];
                vm__imp_to_index(w, w->p + 3 * i, ijk);
                double f = field_at(w, ijk);
                w->iso_hi[i] = w->has_hi && (!w->has_lo || fabs(f - w->hi) < fabs(f - w->lo));
                w->bound[w->ci[i]] = o->max_surface_move;
            } else {
                double L = INFINITY;
                for (int32_t j = 0; j < s->n; j++)
                    for (int k = 0; k < 4; k++) {
                        const double *pb = w->p + 3 * (size_t)w->tet[4 * (size_t)s->t[j] + k];
                        const double *pa = w->p + 3 * i;
                        double d = (pa[0] - pb[0]) * (pa[0] - pb[0]) +
                                   (pa[1] - pb[1]) * (pa[1] - pb[1]) +
                                   (pa[2] - pb[2]) * (pa[2] - pb[2]);
                        if (d > 0.0 && d < L) L = d;
                    }
                w->bound[w->ci[i]] = isfinite(L) ? o->max_surface_move_free * sqrt(L) : 0.0;
            }
        }
    }
    free(bnd);
    free(nonbox);
    free(boxmask);
    return VM_OK;
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
        if (w->dead[t] || w->q[t] >= 1.0) continue;
        for (int k = 0; k < 4; k++) {
            vm_index a = w->tet[4 * t + k];
            if (stamp[a] == round) continue;
            stamp[a] = round;
            out[c++] = a;
        }
    }
    return c;
}

/* The bar of the pass: the set-up (figures, stars and qualities, boundary guard: about 40 %
 * of the time on a big mesh that needs little work) fills the first SETUP_SHARE, the final
 * figures the last FINAL_SHARE, the rounds what is between; the end of the pass, whatever
 * its outcome, reports 1 of 1. */
#define SETUP_SHARE 0.25
#define FINAL_SHARE 0.1
static void show(const vm_improve_options *o, double done) {
    if (o->progress) o->progress("improve", done, 1.0, o->progress_user);
}

/* Rounds shrink fast (the first does most of the work), so round r + x (x: how far into the
 * round) shows as 1 - 2^-(r + x) of the rounds' share. */
static void show_rounds(const vm_improve_options *o, double x) {
    show(o, SETUP_SHARE + (1.0 - SETUP_SHARE - FINAL_SHARE) * (1.0 - pow(0.5, x)));
}

/* Progress within a round: phase 0..3 (contract, flip, peel, smooth), item i of n. */
static void report(const vm_improve_options *o, int pass, int phase, size_t i, size_t n) {
    if (!o->progress || (i & 1023) != 0 || n == 0) return;
    show_rounds(o, pass + (phase + (double)i / (double)n) / 4.0);
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
    for (pass = 0; pass < o->max_passes && !w->nomem; pass++) {
        size_t ops = 0;
        w->deep = pass >= 1;
        if (!next_bad_list(w, &l, &n) || n == 0) break;
        if (o->contract)
            for (size_t i = 0; i < n && !w->nomem; i++) {
                report(o, pass, 0, i, n);
                if (!w->dead[l[i].t] && w->q[l[i].t] < 1.0) ops += (size_t)vm__imp_contract_tet(w, l[i].t);
            }
        if (o->flip)
            for (size_t i = 0; i < n && !w->nomem; i++) {
                report(o, pass, 1, i, n);
                if (!w->dead[l[i].t] && w->q[l[i].t] < 1.0) ops += (size_t)vm__imp_flip_tet(w, l[i].t);
            }
        if (w->deep)
            for (size_t i = 0; i < n && !w->nomem; i++) {
                report(o, pass, 2, i, n);
                if (!w->dead[l[i].t] && w->q[l[i].t] < 2.0 / 3.0) ops += (size_t)vm__imp_peel_tet(w, l[i].t);
            }
        if (!next_bad_list(w, &l, &n)) break;
        vm_index *vs = malloc((4 * n + 1) * sizeof *vs);
        if (!vs) {
            w->nomem = 1;
            break;
        }
        if (o->smooth) {
            size_t nv = bad_vertices(w, l, n, vs, stamp, ++round);
            for (size_t i = 0; i < nv; i++) {
                report(o, pass, 3, i, nv);
                ops += (size_t)vm__imp_smooth_vertex(w, vs[i], 6);
            }
        }
        if (o->perturb && pass >= 1) {
            size_t nv = bad_vertices(w, l, n, vs, stamp, ++round);
            for (size_t i = 0; i < nv; i++) ops += (size_t)vm__imp_perturb_vertex(w, vs[i], 24);
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
    for (int extra = 0; extra < 4 && !w->nomem; extra++) {
        size_t ops = 0;
        if (!next_bad_list(w, &l, &n)) break;
        for (size_t i = 0; i < n && !w->nomem; i++) {
            size_t t = l[i].t;
            if (w->dead[t] || w->q[t] >= 2.0 / 3.0) continue;
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
    show(o, 1.0 - FINAL_SHARE);
    *passes = pass;
    return ops_total;
}

/* --- writing back ------------------------------------------------------------------------- */

static vm_status write_back(vm__imp *w, vm_mesh *m, const vm_improve_options *o,
                            vm_error *err) {
    size_t nt = 0, np = 0;
    vm_index *map = malloc((w->npt + 1) * sizeof *map);
    if (!map) return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    for (size_t i = 0; i < w->npt; i++) map[i] = -1;
    for (size_t t = 0; t < w->ntet; t++) {
        if (w->dead[t]) continue;
        nt++;
        for (int k = 0; k < 4; k++) {
            vm_index a = w->tet[4 * t + k];
            if (map[a] < 0) map[a] = 0;
        }
    }
    /* Points keep their input order. */
    for (size_t i = 0; i < w->npt; i++)
        if (map[i] >= 0) map[i] = (vm_index)np++;
    vm_index *par = m->ncell_fields ? malloc((nt + 1) * sizeof *par) : NULL;
    size_t npf = m->npoint_fields;
    double **pf_new = calloc(npf + 1, sizeof *pf_new);
    double **cf_new = calloc(m->ncell_fields + 1, sizeof *cf_new);
    int fail = (m->ncell_fields && !par) || !cf_new || !pf_new;
    for (size_t f = 0; f < npf; f++) {
        pf_new[f] = fail ? NULL : malloc((np + 1) * (size_t)m->point_fields[f].ncomp * sizeof(double));
        if (!pf_new[f]) fail = 1;
    }
    for (size_t f = 0; !fail && f < m->ncell_fields; f++) {
        cf_new[f] = malloc((nt + 1) * (size_t)m->cell_fields[f].ncomp * sizeof(double));
        if (!cf_new[f]) fail = 1;
    }
    if (!fail && vm_mesh_reserve(m, np, nt, err) != VM_OK) fail = 2;
    if (fail) {
        if (pf_new)
            for (size_t f = 0; f < npf; f++) free(pf_new[f]);
        free(pf_new);
        free(map);
        free(par);
        if (cf_new)
            for (size_t f = 0; f < m->ncell_fields; f++) free(cf_new[f]);
        free(cf_new);
        return fail == 2 ? err->status
                         : vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    }
    for (size_t f = 0; f < npf; f++) {
        int nc = m->point_fields[f].ncomp;
        for (size_t i = 0; i < w->npt; i++)
            if (map[i] >= 0)
                memcpy(pf_new[f] + (size_t)map[i] * (size_t)nc,
                       m->point_fields[f].data + i * (size_t)nc, (size_t)nc * sizeof(double));
        free(m->point_fields[f].data);
        m->point_fields[f].data = pf_new[f];
    }
    for (size_t i = 0; i < w->npt; i++)
        if (map[i] >= 0) memcpy(m->points + 3 * (size_t)map[i], w->p + 3 * i, 3 * sizeof(double));
    size_t c = 0;
    for (size_t t = 0; t < w->ntet; t++) {
        if (w->dead[t]) continue;
        for (int k = 0; k < 4; k++) m->cells[4 * c + k] = map[w->tet[4 * t + k]];
        m->region[c] = w->region[t];
        if (par) par[c] = w->parent[t];
        c++;
    }
    for (size_t f = 0; f < m->ncell_fields; f++) {
        int nc = m->cell_fields[f].ncomp;
        for (size_t i = 0; i < nt; i++)
            memcpy(cf_new[f] + i * (size_t)nc, m->cell_fields[f].data + (size_t)par[i] * (size_t)nc,
                   (size_t)nc * sizeof(double));
        free(m->cell_fields[f].data);
        m->cell_fields[f].data = cf_new[f];
    }
    m->npoints = np;
    m->ncells = nt;
    free(cf_new);
    free(pf_new);
    free(par);
    free(map);
    (void)o;
    return VM_OK;
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
 * part's options carry no progress callback, so show() draws nothing there). */
static vm_status imp_run(vm__imp *w, vm_mesh *m, const vm_volume *v,
                         const vm_improve_options *o, vm__imp_sub *x, int *passes,
                         double *maxmove, double *maxiface, vm_error *err) {
    show(o, 0.25 * SETUP_SHARE);
    vm_status s = imp_init(w, m, v, o, x, err);
    if (x) {
        vm_mesh_free(m);
        free(x->p0);
        x->p0 = NULL;
    }
    show(o, 0.75 * SETUP_SHARE);
    if (s == VM_OK && !vm__imp_guard_init(w))
        s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory for the boundary guard");
    show(o, SETUP_SHARE);
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

vm_status vm__imp_sub_run(vm__imp *w, vm_mesh *m, const vm_volume *v,
                          const vm_improve_options *o, vm__imp_sub *x, int *passes,
                          double *maxmove, double *maxiface, vm_error *err) {
    memset(w, 0, sizeof *w);
    return imp_run(w, m, v, o, x, passes, maxmove, maxiface, err);
}

void vm__imp_sub_free(vm__imp *w) { imp_free(w); }

/* The pass over the whole mesh at once (the only way before parts). */
static vm_status one_pass(vm__imp *w, vm_mesh *m, const vm_volume *v,
                          const vm_improve_options *o, int *passes, double *maxmove,
                          double *maxiface, vm_error *err) {
    vm_status s = imp_run(w, m, v, o, NULL, passes, maxmove, maxiface, err);
    return s == VM_OK ? write_back(w, m, o, err) : s;
}

vm_status vm__imp_read_planes(const vm_volume *info, vm_plane_source src, void *user,
                              int64_t k0, int64_t k1, float **out, vm_error *err) {
    *out = NULL;
    size_t n, bytes;
    if (!vm__mul_size((size_t)info->dims[0] * (size_t)info->dims[1], (size_t)(k1 - k0), &n) ||
        !vm__mul_size(n, sizeof **out, &bytes) || bytes > vm__memory_limit())
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

/* The one pass over a volume given by its planes: reads them all first. */
static vm_status one_pass_planes(vm__imp *w, vm_mesh *m, const vm_volume *info,
                                 vm_plane_source src, void *user, const vm_improve_options *o,
                                 int *passes, double *maxmove, double *maxiface,
                                 vm_error *err) {
    vm_volume whole = *info;
    vm_status s = vm__imp_read_planes(info, src, user, 0, info->dims[2], &whole.data, err);
    if (s == VM_OK) s = one_pass(w, m, &whole, o, passes, maxmove, maxiface, err);
    free(whole.data);
    return s;
}

/* vm_mesh_improve, with the volume in memory (src NULL) or given by its planes (v: its dims
 * and geometry). */
static vm_status improve(vm_mesh *m, const vm_volume *v, vm_plane_source src, void *user,
                         const vm_improve_options *o, vm_improve_report *r, vm_error *err) {
    double t0 = vm__now();
    vm_improve_options def;
    if (!o) {
        vm_improve_options_default(&def);
        o = &def;
    }
    if (m->kind != VM_TET4)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "improve: only tet4 meshes can be improved, not %s",
                            vm_cell_kind_name(m->kind));
    if (m->ncells == 0)
        return vm_error_set(err, VM_ERR_EMPTY, "improve: the mesh has no cells");
    if (!(o->target_min_dihedral > 0.0) || !(o->target_max_dihedral < 180.0) ||
        !(o->target_volume_measure > 0.0) || !(o->max_surface_move >= 0.0) ||
        !(o->max_surface_move_free >= 0.0) || !(o->max_interface_move >= 0.0) ||
        !(o->surface_band >= 0.0) ||
        !(o->surface_tolerance >= o->surface_band))
        return vm_error_set(err, VM_ERR_ARG, "improve: targets and bounds must be positive");
    if (v && !o->has_lo && !o->has_hi)
        return vm_error_set(err, VM_ERR_ARG, "improve: a volume needs lo or hi material bounds");
    for (size_t i = 0; i < 4 * m->ncells; i++)
        if (m->cells[i] < 0 || (size_t)m->cells[i] >= m->npoints)
            return vm_error_set(err, VM_ERR_ARG, "improve: cell %zu has node %lld outside 0..%zu",
                                i / 4, (long long)m->cells[i], m->npoints - 1);
    figures fb;
    if (!mesh_figures(m->points, m->cells, m->ncells, &fb, NULL))
        return vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
    if (fb.inverted)
        return vm_error_set(err, VM_ERR_ARG, "improve: %zu tets are inverted or flat",
                            fb.inverted);
    show(o, 0.1 * SETUP_SHARE);
    size_t nt0 = m->ncells, np0 = m->npoints;
    vm__imp w;
    memset(&w, 0, sizeof w);
    double maxmove = 0.0, maxiface = 0.0;
    int passes = 0;
    size_t nparts = vm__imp_parts_count(m, o);
    vm_status s = VM_OK;
    if (nparts > 1) {
        vm_improve_report pr;
        memset(&pr, 0, sizeof pr);
        s = vm__imp_parts_run(m, v, src, user, o, nparts, &pr, err);
        w.collapses = pr.collapses;
        w.flips23 = pr.flips23;
        w.flips32 = pr.flips32;
        w.edge_removals = pr.edge_removals;
        w.moves = pr.moves;
        w.perturbations = pr.perturbations;
        w.peels = pr.peels;
        w.boundary_flips = pr.boundary_flips;
        passes = pr.passes;
        maxmove = pr.max_surface_move;
        maxiface = pr.max_interface_move;
        show(o, 1.0 - FINAL_SHARE);
    } else if (src) {
        s = one_pass_planes(&w, m, v, src, user, o, &passes, &maxmove, &maxiface, err);
    } else {
        s = one_pass(&w, m, v, o, &passes, &maxmove, &maxiface, err);
    }
    figures fa;
    memset(&fa, 0, sizeof fa);
    if (s == VM_OK) {
        double *uf = NULL;
        if (o->mark_unfixed) {
            uf = malloc((m->ncells + 1) * sizeof *uf);
            if (!uf) s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        }
        if (s == VM_OK && !mesh_figures(m->points, m->cells, m->ncells, &fa, uf))
            s = vm_error_set(err, VM_ERR_NOMEM, "improve: out of memory");
        if (uf && s == VM_OK) s = vm_mesh_set_field(m, 1, "improve_unfixed", 1, uf, err);
        free(uf);
    }
    if (r) {
        memset(r, 0, sizeof *r);
        r->tets_before = nt0;
        r->points_before = np0;
        r->min_dihedral_before = fb.dmin;
        r->max_dihedral_before = fb.dmax;
        r->slivers_5_before = fb.s5;
        r->slivers_10_before = fb.s10;
        r->abaqus_before = fb.abaqus;
        r->volume_before = fb.volume;
        r->min_dihedral_after = fa.dmin;
        r->max_dihedral_after = fa.dmax;
        r->slivers_5_after = fa.s5;
        r->slivers_10_after = fa.s10;
        r->abaqus_after = fa.abaqus;
        r->inverted_after = fa.inverted;
        r->unfixed = fa.unfixed;
        r->volume_after = fa.volume;
        r->max_surface_move = maxmove;
        r->max_interface_move = maxiface;
        r->collapses = w.collapses;
        r->flips23 = w.flips23;
        r->flips32 = w.flips32;
        r->edge_removals = w.edge_removals;
        r->moves = w.moves;
        r->perturbations = w.perturbations;
        r->peels = w.peels;
        r->boundary_flips = w.boundary_flips;
        r->passes = passes;
        r->tets_after = m->ncells;
        r->points_after = m->npoints;
        r->seconds = vm__now() - t0;
    }
    imp_free(&w);
    show(o, 1.0);
    return s;
}

vm_status vm_mesh_improve(vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                          vm_improve_report *r, vm_error *err) {
    return improve(m, v, NULL, NULL, o, r, err);
}

vm_status vm_mesh_improve_planes(vm_mesh *m, const vm_volume *info, vm_plane_source source,
                                 void *source_user, const vm_improve_options *o,
                                 vm_improve_report *r, vm_error *err) {
    if (!info || !source)
        return vm_error_set(err, VM_ERR_ARG, "improve: a plane source needs the volume's info");
    if (info->dims[0] < 1 || info->dims[1] < 1 || info->dims[2] < 1)
        return vm_error_set(err, VM_ERR_ARG, "improve: the volume has no voxels");
    return improve(m, info, source, source_user, o, r, err);
}
