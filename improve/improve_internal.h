/* SPDX-License-Identifier: BSD-3-Clause */
/* improve/improve_internal.h — the working mesh shared by the improvement operations
 * (improve.c is the public entry and dispatches; improve_run.c runs the pass over a working
 * mesh, improve_parts.c drives it part by part; improve_mesh.c holds the adjacency and
 * queries; improve_contract.c, improve_flip.c, improve_smooth.c and improve_peel.c are one
 * operation each, improve_guard.c the boundary guard). Private. */
#ifndef VM_IMPROVE_INTERNAL_H
#define VM_IMPROVE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include "volmesh/improve.h"
#include "../core/core.h"

/* Vertex classes: how a vertex may move. */
enum {
    VM__IMP_INTERIOR = 0, /* free */
    VM__IMP_SURF = 1,     /* on the isosurface: moves along it */
    VM__IMP_FLAT = 2,     /* on one border plane, all its boundary faces on it: moves in it */
    VM__IMP_FIXED = 3,    /* rim of a border plane, box edge or corner, junction, crease */
    VM__IMP_IFACE = 4     /* inside, between exactly two regions, on a nearly flat piece of
                             their interface: moves in its tangent plane, bounded */
};

/* The tets around one vertex (unordered). */
typedef struct vm__imp_star {
    vm_index *t;
    int32_t n, cap;
} vm__imp_star;

typedef struct vm__imp {
    /* tets: 4 nodes each, positively oriented; dead tets keep their slot */
    vm_index *tet;
    int32_t *region;
    vm_index *parent;   /* input cell each tet descends from (for cell fields) */
    double *q;          /* cached quality (see vm__imp_quality) */
    uint8_t *dead;
    size_t ntet, tet_cap;
    /* vertices */
    double *p;          /* world positions */
    /* p0, nrm and bound hold only the vertices that may be constrained (on the boundary or
     * between regions), vertex v at index ci[v] (-1 for the others): see vm__imp_p0 etc. */
    int32_t *ci;
    double *p0;         /* input positions */
    uint8_t *cls;       /* VM__IMP_* */
    uint8_t *planes;    /* border planes the vertex lies on (bit 2*axis + side) */
    uint8_t *iso_hi;    /* SURF with a volume: lies on {f = hi} rather than {f = lo} */
    uint8_t *pdead;
    double *nrm;        /* FLAT: plane normal; SURF without a volume and IFACE: tangent-plane
                           normal */
    double *bound;      /* SURF/FLAT/IFACE: largest displacement from p0 (voxels or world) */
    vm__imp_star *star;
    size_t npt;
    /* the volume, when given: world = org + A * ijk */
    const vm_volume *v;
    /* its planes held: plane k at fdata + (k - fk0) nx ny for fk0 <= k < fk1 (the whole
     * volume, or the window a part reads, which holds every plane its vertices can sample;
     * a read outside would be clamped to them) */
    const float *fdata;
    int64_t fk0, fk1;
    double A[3][3], Ainv[3][3], org[3];
    double lo, hi;
    int has_lo, has_hi;
    /* quality scales: q = min(min_dih/s_min, (180-max_dih)/s_max, vm/s_vm) */
    double s_min, s_max, s_vm;
    double s_fmin, s_fmax; /* and min(face angle)/s_fmin, (180-max face angle)/s_fmax */
    double max_edge2;      /* o->max_edge squared (INFINITY: none): a longer edge makes q 0 */
    const vm_improve_options *o;
    /* counters */
    size_t collapses, flips23, flips32, edge_removals, moves, perturbations, peels,
        boundary_flips;
    double max_move_seen;
    unsigned rng;
    /* scratch for local operations */
    vm_index *buf;
    size_t buf_cap;
    double *qbuf;       /* qualities of a candidate position's star (vm__imp_qscratch) */
    size_t qbuf_cap;
    int deep;           /* later rounds: also peel bad tets off the boundary */
    size_t nfrozen;     /* input tets 0..nfrozen-1 have o->frozen flags */
    /* tets whose quality was recomputed below 1 since the last bad list (may repeat, may
     * have died since): with the last list they hold every tet below the targets */
    vm_index *touched;
    size_t ntouched, touched_cap;
    /* while setting up: the boundary faces 4 t + f (face f opposite node f), in order */
    size_t *bfaces, nbfaces;
    int nomem;          /* sticky: an allocation inside an operation failed */
    /* the boundary guard (improve_guard.c): boundary vertices in a hashed uniform grid and
     * each vertex's boundary faces, cached until a tet around it is added or removed */
    struct vm__imp_guard *g;
    /* A part of a bigger mesh (improve_parts.c): input tets 0..nlock-1 with lock[t] set are
     * locked (never killed or replaced) and vlock marks their vertices (never moved or
     * removed); NULL for a whole mesh. */
    const uint8_t *lock;
    size_t nlock;
    uint8_t *vlock;
    uint8_t *below;     /* a part, at the end: per tet, 1 when its quality is below 1 */
} vm__imp;

/* 1 when tet t is locked / vertex a is locked (see vm__imp.lock). */
static inline int vm__imp_locked(const vm__imp *w, size_t t) {
    return t < w->nlock && w->lock[t];
}
static inline int vm__imp_vlocked(const vm__imp *w, vm_index a) {
    return w->vlock && w->vlock[a];
}

/* Quality levels (see vm__imp_quality): 1 meets the targets; above VM__IMP_Q_ABAQUS a tet
 * passes ABAQUS's check with the default targets (each term's scale puts ABAQUS's limit at
 * 2/3). */
#define VM__IMP_Q_ABAQUS (2.0 / 3.0)
/* An operation must raise the worst quality it touches by more than this (round-off is no
 * gain, and a zero-gain change could cycle). */
#define VM__IMP_GAIN 1e-9

/* Input position, constraint normal and bound of a constrained vertex a (ci[a] >= 0). */
static inline double *vm__imp_p0(const vm__imp *w, vm_index a) {
    return w->p0 + 3 * (size_t)w->ci[a];
}
static inline double *vm__imp_nrm(const vm__imp *w, vm_index a) {
    return w->nrm + 3 * (size_t)w->ci[a];
}
static inline double vm__imp_bound(const vm__imp *w, vm_index a) { return w->bound[w->ci[a]]; }

/* The quality's scales from the targets of o (all vm__imp_quality reads of w). */
void vm__imp_scales(vm__imp *w, const vm_improve_options *o);
/* Normalised quality of a tet (>= 1 meets the targets, > 2/3 passes ABAQUS with the default
 * targets); -1 when it is not clearly positive. */
double vm__imp_quality(const vm__imp *w, const double p[4][3]);
/* ABAQUS volume measure V / (volume of the regular tet with the same circumradius). */
double vm__imp_volume_measure(const double p[4][3]);
double vm__imp_tet_q(const vm__imp *w, size_t t);
/* A bar for vm__imp_quality_above: the limits quality > f puts on the angles' cosines. */
typedef struct vm__imp_bar {
    double f;
    int fast; /* 0: the test measures the quality */
    double c_dmin, c_dmax, c_fmin, c_fmax;
} vm__imp_bar;
void vm__imp_bar_set(const vm__imp *w, double f, vm__imp_bar *b);
/* vm__imp_quality(w, p) > b->f, decided on the cosines (no inverse trigonometry) where they
 * are clearly on one side of their limits: the same answer, several times faster when no
 * limit is near. */
int vm__imp_quality_above(const vm__imp *w, const double p[4][3], const vm__imp_bar *b);
/* 1 when an angle's cosine c is clearly below (+1) or above (-1) the limit l of a bar, 0
 * when within the tie (measure then). */
int vm__imp_cos_side(double c, double l);
/* vm__imp_quality_above for tet t with vertex a at x. */
int vm__imp_tet_above_moved(const vm__imp *w, size_t t, vm_index a, const double x[3],
                            const vm__imp_bar *b);
/* Recomputes w->q[t], noting t in w->touched when it is below the targets. */
void vm__imp_requal(vm__imp *w, size_t t);
/* w->q[t] = q, the quality tet t has now as vm__imp_requal would measure it (a value
 * measured on the same points), noting t in w->touched when it is below the targets. */
void vm__imp_set_q(vm__imp *w, size_t t, double q);
/* w->q[t], measured now when it is not known yet (NaN: a part's tet known to be at or above
 * the targets, its value not needed until an operation reads it). */
static inline double vm__imp_q(const vm__imp *w, size_t t) {
    double q = w->q[t];
    if (q != q) {
        q = vm__imp_tet_q(w, t);
        ((vm__imp *)w)->q[t] = q; /* w itself is never const: a cache of the run's own */
    }
    return q;
}
/* Quality of tet t with vertex a replaced by position x (a must be in t). */
double vm__imp_tet_q_moved(const vm__imp *w, size_t t, vm_index a, const double x[3]);

/* Appends a tet (nodes positively oriented) and links it; returns its id or -1 (nomem). */
long vm__imp_add_tet(vm__imp *w, const vm_index n[4], int32_t region, vm_index parent);
void vm__imp_kill_tet(vm__imp *w, size_t t);
int vm__imp_star_add(vm__imp *w, vm_index v, vm_index t);
void vm__imp_star_remove(vm__imp *w, vm_index v, vm_index t);
/* 1 when tet t contains vertex a. */
int vm__imp_has(const vm__imp *w, size_t t, vm_index a);
/* The tet other than t containing a, b and c, or -1 (boundary face). */
long vm__imp_face_other(const vm__imp *w, size_t t, vm_index a, vm_index b, vm_index c);
/* Grows the scratch buffer to hold n indices; VM_ERR_NOMEM (and w->nomem set) on failure. */
vm_status vm__imp_scratch(vm__imp *w, size_t n);
/* Grows w->qbuf to hold n qualities; VM_ERR_NOMEM (and w->nomem set) on failure. */
vm_status vm__imp_qscratch(vm__imp *w, size_t n);
unsigned vm__imp_rand(vm__imp *w);
double vm__imp_rand01(vm__imp *w);

/* Voxel (i, j, k) of the volume (in the grid) from the planes held. */
static inline double vm__imp_voxel(const vm__imp *w, int64_t i, int64_t j, int64_t k) {
    if (k < w->fk0) k = w->fk0;
    if (k >= w->fk1) k = w->fk1 - 1;
    return w->fdata[i + w->v->dims[0] * (j + w->v->dims[1] * (k - w->fk0))];
}

/* B = A^-1; 0 when A is singular. */
int vm__imp_invert3(double A[3][3], double B[3][3]);

/* World <-> index space and the trilinear field (with a volume). */
void vm__imp_to_index(const vm__imp *w, const double x[3], double ijk[3]);
void vm__imp_to_world(const vm__imp *w, const double ijk[3], double x[3]);
/* Moves x (world) onto the isosurface of vertex a; returns 0 when Newton fails or the
 * result is farther than the bound from p0[a]. */
int vm__imp_project(const vm__imp *w, vm_index a, double x[3]);
/* 1 when moving vertex a to x keeps its constraints (plane, surface bound). Projects x when
 * a is a surface vertex and a volume is given. */
/* Unit normal of the constraint of boundary vertex a: the field gradient (world) for a
 * surface vertex with a volume, else the stored plane normal. */
void vm__imp_normal(const vm__imp *w, vm_index a, double n[3]);
int vm__imp_constrain(const vm__imp *w, vm_index a, double x[3]);

/* The surface_chords check: 1 when, with surface vertex a (and b, b < 0: none, merged into
 * it) at x, the edge midpoints and centres of the boundary faces around them (those with a
 * vertex inside a flat border face, or lying in a border plane, left out) lie within
 * CHORD_SHARE times surface_chords of surface_tolerance of the isosurface (first-order
 * distance, index voxels) or no farther than the farthest of them now; 1 as well when the
 * check is off or neither is a surface vertex nor a border plane's rim vertex. */
int vm__imp_chord_ok(vm__imp *w, vm_index a, vm_index b, const double x[3]);

/* 1 when the surface vertices and border rim vertices among a and b that a
 * contraction moves to x stay within CHORD_SHARE times surface_chords (at least 1) of
 * surface_tolerance of the boundary faces around the merged vertex (index voxels): the
 * isosurface they stood on stays near the boundary (no vertex at a bulge's tip goes). */
int vm__imp_kept_near(vm__imp *w, vm_index a, vm_index b, const double x[3]);

/* The boundary guard: no operation may make two boundary triangles cross. */
int vm__imp_guard_init(vm__imp *w);           /* 0 on out-of-memory */
void vm__imp_guard_free(vm__imp *w);
/* Vertex a has moved (keeps the grid current). */
void vm__imp_guard_moved(vm__imp *w, vm_index a);
/* The boundary faces around v may have changed (a tet with v was added or removed). */
void vm__imp_guard_touch(vm__imp *w, vm_index v);
/* 1 when the triangles nt[0..nn) (vertex ids; vertex mv, when >= 0, taken at x) cross
 * neither each other nor a current boundary face that stays: the faces with a vertex in
 * exv[0..nexv) and the faces rem[0..nrem) are the ones the operation removes. */
int vm__imp_guard_ok(vm__imp *w, const vm_index (*nt)[3], int nn, vm_index mv,
                     const double x[3], const vm_index *exv, int nexv,
                     const vm_index (*rem)[3], int nrem);
/* 1 when moving vertex a to x makes no boundary triangles cross. */
int vm__imp_guard_move_ok(vm__imp *w, vm_index a, const double x[3]);
/* The boundary faces (a, e[2i], e[2i+1]) around vertex a, i < return value; -1 on nomem. */
int vm__imp_guard_faces(vm__imp *w, vm_index a, const vm_index **e);

/* One part of a bigger mesh, for improve_parts.c: what vm__imp_run needs beyond the
 * submesh. The submesh's own bounding box is not the mesh's, nor are its vertices' starting
 * positions the ones the surface bounds count from. */
typedef struct vm__imp_sub {
    const uint8_t *lock;   /* per submesh tet: 1 = locked */
    double *p0;            /* per submesh point: its position when the whole pass began
                              (freed by vm__imp_run once copied, and set to NULL) */
    const double *box;     /* the whole mesh's bounding box (min xyz, max xyz) */
    unsigned seed;         /* of the random perturbations */
    /* the volume's planes k0 <= k < k1, when the part reads a window of them (else NULL:
     * the volume's data) */
    const float *planes;
    int64_t k0, k1;
    /* per submesh tet, when known (else NULL): 0 = at or above the targets as it stands, so
     * its quality is measured only when an operation first reads it (vm__imp_q) */
    const uint8_t *below;
    /* per submesh tet, when known (else NULL): 1 = none of its faces is a boundary face of
     * the submesh (a free tet inside the whole mesh: its neighbours are all in the part) */
    const uint8_t *inside;
} vm__imp_sub;

/* One run of the pass (improve_run.c): sets *w up for m, runs the rounds and measures the
 * moves; the rounds' data is freed, the mesh data stays in *w, which the caller reads and
 * frees with vm__imp_free, also on error. x NULL: m is the whole mesh (the caller writes *w
 * back). x set: m is a part (only its tets, points and regions are read; m is freed, as
 * x->p0, once they are copied, so that they do not stay beside the working data), and the
 * caller reads tet, dead, region, parent (= submesh tet each descends from), p, pdead and
 * below; single-threaded apart from nested parallel set-up loops, o->progress not called.
 * *maxmove and *maxiface as in vm_improve_report. */
vm_status vm__imp_run(vm__imp *w, vm_mesh *m, const vm_volume *v, const vm_improve_options *o,
                      vm__imp_sub *x, int *passes, double *maxmove, double *maxiface,
                      vm_error *err);
void vm__imp_free(vm__imp *w);
/* Reads planes k0 <= k < k1 of the volume info describes from src into a new buffer (*out:
 * nx ny (k1 - k0) floats, the caller frees it), checked against the memory limit
 * (improve_run.c). */
vm_status vm__imp_read_planes(const vm_volume *info, vm_plane_source src, void *user,
                              int64_t k0, int64_t k1, float **out, vm_error *err);

/* How the pass runs on m: 0 the local pass (vm__imp_local_run), 1 the one pass over the
 * whole mesh, N > 1 by N slabs (vm__imp_parts_run). */
size_t vm__imp_parts_count(const vm_mesh *m, const vm_improve_options *o);

/* The whole pass by slabs: m is improved in place; counters, passes and moves go to r
 * (figures are the caller's). v: the volume, or with src its dims and geometry only, each
 * part then reading the planes it reaches from src (one call at a time). */
vm_status vm__imp_parts_run(vm_mesh *m, const vm_volume *v, vm_plane_source src, void *src_user,
                            const vm_improve_options *o, size_t nparts, vm_improve_report *r,
                            vm_error *err);

/* --- The pass by parts (improve_parts.c) and the local pass (improve_local.c) ---------- */

/* A slot whose tet a part removed (cells[4 t]), until the slots are compacted. */
#define VM__IMP_DEAD_SLOT ((vm_index)-1)

/* The whole mesh while parts of it are worked on: m's arrays, tets in slots (dead ones
 * marked VM__IMP_DEAD_SLOT), and what the parts share. */
typedef struct vm__imp_pstate {
    vm_mesh *m;
    const vm_volume *v;
    vm_improve_options o; /* the caller's options without the progress callback */
    const vm_improve_options *uo;
    size_t nt;      /* slots */
    double *p0;     /* 3 per point: where the pass found it */
    vm_index *par;  /* per slot: the input cell (only with cell fields) */
    uint8_t *below; /* per slot: below the targets when its part last ran */
    uint32_t *loc;  /* per point: its id in the submesh of the part running with it */
    double box[6];
    double row[3]; /* with a volume: world displacement along each axis per voxel */
    vm_plane_source src; /* with a volume given by its planes: where the parts read them */
    void *src_user;
    double kz[3]; /* then: index z of a world point x is kz . (x - the volume's origin) */
    vm_improve_report *r;
} vm__imp_pstate;

/* One part: its tets and the locked tets around it (slots), and what its run gives back. */
/* vm__imp_job's bflag: a tet with no boundary face (any other value: not known). */
#define VM__IMP_BF_INSIDE 2
typedef struct vm__imp_job {
    /* slabs (improve_parts.c): the tets in slots with centroid z in [z0, z1) (or, with key,
     * key in it) */
    double z0, z1;
    /* with key: only the slots 0..nkey-1 with a finite key, taken in place of the centroid
     * (later slots are not marked) */
    const float *key;
    size_t nkey;
    unsigned seed;
    uint32_t *ps; /* slots of the part's tets, in order */
    uint32_t *ls; /* slots of the locked tets, in order */
    size_t nps, nls;
    double zlo, zhi;   /* the z range it reads and writes */
    double lo[3], hi[3]; /* the local pass: the box it reads and writes */
    vm_index (*xt)[4]; /* tets beyond its slots, appended after the batch */
    int32_t *xreg;
    vm_index *xpar;
    uint8_t *xbelow;
    size_t nx, x0; /* x0: the slot of the first, once appended */
    int below_known; /* the local pass: S->below holds for every tet of the job */
    /* the local pass: per slot, VM__IMP_BF_INSIDE for a tet known to have no boundary face
     * (else NULL) */
    const uint8_t *bflag;
    vm_status s;
    vm_error err;
    int passes;
    double maxmove, maxiface;
    size_t cnt[8];
} vm__imp_job;

/* Sets S up over m (copies the positions as p0, the box, the frames); VM_ERR_NOMEM. */
vm_status vm__imp_pstate_init(vm__imp_pstate *S, vm_mesh *m, const vm_volume *v,
                              vm_plane_source src, void *src_user, const vm_improve_options *o,
                              vm_improve_report *r, vm_error *err);
void vm__imp_pstate_free(vm__imp_pstate *S);
/* Builds J's submesh (J->ps, then J->ls locked), improves it and writes it back into its
 * slots and points; tets beyond its slots wait in J->xt. Touches only the tets and points of
 * the submesh: parts that share none may run at the same time.
 * Once the caller's progress asked to stop (polled on thread 0), a job does nothing and
 * ends VM_ERR_CANCELLED. */
void vm__imp_job_run(vm__imp_pstate *S, vm__imp_job *J);
void vm__imp_job_reset(vm__imp_job *J);
/* After a batch of jobs take[0..n): their first error, else their extra tets appended in
 * order (J->x0) and their counters added to S->r; then VM_ERR_CANCELLED when a job was
 * cancelled (it changed nothing: the mesh stays whole). */
vm_status vm__imp_jobs_append(vm__imp_pstate *S, vm__imp_job *jobs, const size_t *take,
                              size_t n, vm_error *err);
/* Drops the dead slots and the points no tet uses; permutes the cell fields. */
vm_status vm__imp_parts_finish(vm__imp_pstate *S, vm_error *err);
/* Box and squared longest edge of the tet in slot t. */
void vm__imp_slot_box(const vm__imp_pstate *S, size_t t, double lo[3], double hi[3]);
double vm__imp_slot_edge2(const vm__imp_pstate *S, size_t t);
/* Appends t to the list *l (n entries, room for *cap); 0 on out-of-memory. */
int vm__imp_push_slot(uint32_t **l, size_t *n, size_t *cap, size_t t);
/* Sorts l[0..n) ascending; 0 on out-of-memory. */
int vm__imp_sort_slots(uint32_t *l, size_t n);
/* The cells c0..c1 of a grid (origin lo, cell cs, gd cells a side) that box [a, b] meets. */
void vm__imp_cell_range(const double lo[3], double cs, const size_t gd[3], const double a[3],
                        const double b[3], size_t c0[3], size_t c1[3]);
/* Grows the marked cells of grid (gd cells a side) by r cells along axis k; 0 on nomem. */
int vm__imp_dilate(uint8_t *grid, const size_t gd[3], int k, size_t r);
/* The seed of the random perturbations of part k of a phase. */
unsigned vm__imp_part_seed(unsigned seed, int phase, size_t k);
/* The margin around a part along each axis: twice the farthest a boundary vertex may get
 * from where the pass found it, and a little slack (L: the part's longest edge). */
void vm__imp_part_margin(const vm__imp_pstate *S, double L, double M[3]);

/* The local pass (improve_local.c): only the tets below the targets and a ring of tets
 * around them, by blocks of space run in parallel. */
/* below: per tet of m, 1 when its quality is below 1 (as the pass measures it), or NULL to
 * have them measured. */
vm_status vm__imp_local_run(vm_mesh *m, const vm_volume *v, vm_plane_source src,
                            void *src_user, const vm_improve_options *o, const uint8_t *below,
                            vm_improve_report *r, vm_error *err);

/* The bar of the pass: the set-up (figures, stars and qualities, boundary guard: about 40 %
 * of the time on a big mesh that needs little work) fills the first VM__IMP_SETUP_SHARE,
 * the final figures the last VM__IMP_FINAL_SHARE, the rounds what is between; the end of
 * the pass, whatever its outcome, reports 1 of 1. */
#define VM__IMP_SETUP_SHARE 0.25
#define VM__IMP_FINAL_SHARE 0.1
static inline void vm__imp_show(const vm_improve_options *o, double done) {
    if (o->progress) o->progress("improve", done, 1.0, o->progress_user);
}

/* VM_ERR_CANCELLED "improve: cancelled" (err filled) when the progress callback of o asked
 * to stop (polled: vm_mesh_improve forwards it through a meter), else VM_OK. */
static inline vm_status vm__imp_check(const vm_improve_options *o, vm_error *err) {
    return vm__progress_check(o->progress, o->progress_user, "improve", err);
}

/* --- Whole-mesh figures (improve.c) ------------------------------------------------------ */

/* What the pass reports of a mesh, from one sweep over its tets. */
typedef struct vm__imp_figures {
    double dmin, dmax;   /* smallest and largest dihedral angle (degrees), as
                            vm_tet_min_dihedral and vm_tet_max_dihedral measure them */
    double volume;       /* the signed volumes' sum */
    size_t s5, s10;      /* tets with a dihedral angle below 5 / below 10 degrees */
    size_t abaqus;       /* tets failing ABAQUS's element check */
    size_t inverted;     /* tets not of positive volume */
    size_t unfixed;      /* tets failing ABAQUS, below 10 or above 165 degrees, or inverted */
    size_t vm_low;       /* tets whose volume measure is below the sweep's vm_target */
} vm__imp_figures;

/* The figures of the n tets cells (4 nodes each, into pts: 3 per point), [out] *f; vm_target:
 * the volume measure f->vm_low counts the tets below (0: none). The angles are compared on
 * their cosines, the extremes measured exactly; parallel over fixed chunks summed in order,
 * so the same figures for any thread count. VM_OK, or VM_ERR_NOMEM (no message set). */
vm_status vm__imp_mesh_figures(const double *pts, const vm_index *cells, size_t n,
                               double vm_target, vm__imp_figures *f);

/* The operations: each returns 1 when it changed the mesh. */
int vm__imp_contract_tet(vm__imp *w, size_t t);
int vm__imp_flip_tet(vm__imp *w, size_t t);
int vm__imp_smooth_vertex(vm__imp *w, vm_index a, int iters);
int vm__imp_perturb_vertex(vm__imp *w, vm_index a, int tries);
int vm__imp_peel_tet(vm__imp *w, size_t t);

#endif
