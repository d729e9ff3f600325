/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_peel.c — peeling bad tets off the boundary: a tet with two boundary faces is
 * removed (a 2-2 flip of the surface edge between them), a tet with three boundary faces is
 * removed with its apex (the three faces become one), when the surface moves by less than the
 * surface bound and its topology stays (cf. Klingner and Shewchuk 2007, boundary changes). */
#include <math.h>
#include <string.h>
#include "improve_internal.h"
#include "../core/vec3.h"

/* Faces opposite node i with outward normals for a positive tet. */
static const int face_of[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};

/* Unnormalised outward normal of the face of t opposite its node i. */
static void face_normal(const vm__imp *w, size_t t, int i, double n[3]) {
    const vm_index *v = w->tet + 4 * t;
    const double *p = w->p + 3 * (size_t)v[face_of[i][0]], *q = w->p + 3 * (size_t)v[face_of[i][1]],
                 *r = w->p + 3 * (size_t)v[face_of[i][2]];
    double u[3], s[3];
    vm__sub3(q, p, u);
    vm__sub3(r, p, s);
    vm__cross3(u, s, n);
}

/* Position of vertex a where the surface bound is measured: index space with a volume. */
static void measure_pos(const vm__imp *w, vm_index a, double x[3]) {
    if (w->v) vm__imp_to_index(w, w->p + 3 * (size_t)a, x);
    else memcpy(x, w->p + 3 * (size_t)a, 3 * sizeof *x);
}

/* Largest surface change allowed for tet t: with a volume, the bound of a surface vertex less
 * the band its vertices may already be off the isosurface; else the free bound times the
 * tet's longest edge. */
static double peel_bound(const vm__imp *w, size_t t) {
    if (w->v) return w->o->surface_tolerance - w->o->surface_band;
    double L = 0.0;
    for (int i = 0; i < 4; i++)
        for (int j = i + 1; j < 4; j++) {
            double d[3];
            vm__sub3(w->p + 3 * (size_t)w->tet[4 * t + i], w->p + 3 * (size_t)w->tet[4 * t + j], d);
            double l = sqrt(vm__dot3(d, d));
            if (l > L) L = l;
        }
    return w->o->max_surface_move_free * L;
}

/* 1 when face (a, b, c) lies on a border plane (all three vertices share a plane bit). */
static int on_border(const vm__imp *w, vm_index a, vm_index b, vm_index c) {
    return (w->planes[a] & w->planes[b] & w->planes[c]) != 0;
}

/* 1 when edge cd has a boundary face among the tets around it, tet t excepted. */
static int edge_on_boundary(const vm__imp *w, size_t t, vm_index c, vm_index d) {
    const vm__imp_star *s = &w->star[c];
    for (int32_t i = 0; i < s->n; i++) {
        size_t u = (size_t)s->t[i];
        if (u == t || !vm__imp_has(w, u, d)) continue;
        for (int k = 0; k < 4; k++) {
            vm_index e = w->tet[4 * u + k];
            if (e == c || e == d) continue;
            if (vm__imp_face_other(w, u, c, d, e) < 0) return 1;
        }
    }
    return 0;
}

/* 1 when the tets around vertex a belong to more than one region (a material interface). */
static int on_interface(const vm__imp *w, vm_index a) {
    const vm__imp_star *s = &w->star[a];
    for (int32_t j = 1; j < s->n; j++)
        if (w->region[s->t[j]] != w->region[s->t[0]]) return 1;
    return 0;
}

int vm__imp_peel_tet(vm__imp *w, size_t t) {
    const vm_index *n = w->tet + 4 * t;
    int bnd[4], nb = 0;
    if (vm__imp_locked(w, t)) return 0;
    /* Peeling next to another material would turn interface faces into boundary faces or
     * give a surface edge that is an interface edge already: only inside one material. */
    for (int i = 0; i < 4; i++)
        if (on_interface(w, n[i])) return 0;
    for (int i = 0; i < 4; i++) {
        bnd[i] = vm__imp_face_other(w, t, n[face_of[i][0]], n[face_of[i][1]],
                                    n[face_of[i][2]]) < 0;
        if (bnd[i] && on_border(w, n[face_of[i][0]], n[face_of[i][1]], n[face_of[i][2]]))
            return 0;
        nb += bnd[i];
    }
    double bound = peel_bound(w, t);
    if (nb == 3) {
        /* The apex d is the node opposite the interior face; it must hang on t alone. */
        int i;
        for (i = 0; i < 4 && bnd[i]; i++) {}
        vm_index d = n[i];
        if (w->cls[d] != VM__IMP_SURF || w->star[d].n != 1) return 0;
        /* The other three keep other tets (t is not a component of its own). */
        for (int k = 0; k < 4; k++)
            if (k != i && w->star[n[k]].n < 2) return 0;
        double x[4][3];
        for (int k = 0; k < 4; k++) measure_pos(w, n[k], x[k]);
        double u[3], s[3], nn[3], e[3];
        vm__sub3(x[face_of[i][1]], x[face_of[i][0]], u);
        vm__sub3(x[face_of[i][2]], x[face_of[i][0]], s);
        vm__cross3(u, s, nn);
        vm__sub3(x[i], x[face_of[i][0]], e);
        double area2 = sqrt(vm__dot3(nn, nn));
        if (!(area2 > 0.0) || fabs(vm__dot3(e, nn)) / area2 > bound) return 0;
        /* The interior face becomes the boundary in place of the three around d. */
        vm_index nf[1][3] = {{n[face_of[i][0]], n[face_of[i][1]], n[face_of[i][2]]}};
        if (!vm__imp_guard_ok(w, (const vm_index(*)[3])nf, 1, -1, NULL, &d, 1, NULL, 0))
            return 0;
        vm__imp_kill_tet(w, t);
        w->pdead[d] = 1;
        w->peels++;
        return 1;
    }
    if (nb != 2) return 0;
    /* The boundary faces, opposite nodes i (= c) and j (= d), share edge ab of the other two
     * nodes; the faces opposite a and b become boundary faces, cd the new surface edge. */
    int i = -1, j = -1;
    for (int k = 0; k < 4; k++)
        if (bnd[k]) {
            if (i < 0) i = k;
            else j = k;
        }
    vm_index c = n[i], d = n[j]; /* cd becomes the surface edge */
    int ka = -1, kb = -1;
    for (int k = 0; k < 4; k++)
        if (k != i && k != j) {
            if (ka < 0) ka = k;
            else kb = k;
        }
    vm_index a = n[ka], b = n[kb];
    if (edge_on_boundary(w, t, c, d)) return 0;
    /* ab must be in t alone (it is, for a manifold boundary), and a, b keep other tets. */
    if (w->star[a].n < 2 || w->star[b].n < 2) return 0;
    /* The surface moves by the distance between lines ab and cd. */
    double x[4][3];
    for (int k = 0; k < 4; k++) measure_pos(w, n[k], x[k]);
    double ab[3], cd[3], ac[3], m[3];
    vm__sub3(x[kb], x[ka], ab);
    vm__sub3(x[j], x[i], cd);
    vm__sub3(x[i], x[ka], ac);
    vm__cross3(ab, cd, m);
    double ml = sqrt(vm__dot3(m, m));
    if (!(ml > 0.0) || fabs(vm__dot3(ac, m)) / ml > bound) return 0;
    /* No fold: the new boundary faces (faces of t opposite a and b, seen from outside the
     * remaining mesh, so reversed) face the way the old ones did. */
    double o1[3], o2[3], f1[3], f2[3], old[3];
    face_normal(w, t, i, o1);
    face_normal(w, t, j, o2);
    face_normal(w, t, ka, f1);
    face_normal(w, t, kb, f2);
    for (int k = 0; k < 3; k++) old[k] = o1[k] + o2[k];
    if (!(-vm__dot3(f1, old) > 0.0) || !(-vm__dot3(f2, old) > 0.0)) return 0;
    if (!(-vm__dot3(f1, o1) > 0.0) || !(-vm__dot3(f1, o2) > 0.0)) return 0;
    if (!(-vm__dot3(f2, o1) > 0.0) || !(-vm__dot3(f2, o2) > 0.0)) return 0;
    /* Faces bcd and acd replace abd and abc. */
    vm_index nf[2][3] = {{b, c, d}, {a, c, d}}, rf[2][3] = {{a, b, d}, {a, b, c}};
    if (!vm__imp_guard_ok(w, (const vm_index(*)[3])nf, 2, -1, NULL, NULL, 0,
                          (const vm_index(*)[3])rf, 2))
        return 0;
    vm__imp_kill_tet(w, t);
    w->peels++;
    return 1;
}
