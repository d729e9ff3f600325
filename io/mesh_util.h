/* SPDX-License-Identifier: BSD-3-Clause */
/* io/mesh_util.h — private helpers of the finite-element and surface mesh formats: a text
 * cursor with strict number parsing and "PATH: line N: problem" errors, id-to-index maps,
 * boundary faces with their element and local face, region lists. */
#ifndef VM_MESH_UTIL_H
#define VM_MESH_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "volmesh/error.h"
#include "volmesh/io.h"
#include "volmesh/mesh.h"

/* Largest file any mesh reader reads whole (bytes). */
#define VM__MESH_MAX_FILE ((size_t)1 << 36)

/* --- writers with progress --------------------------------------------------------------- */

/* The writers behind vm_mesh_write_as, taking its options (non-NULL, already validated):
 * the public vm_mesh_write_FORMAT functions call them with the defaults. They report stage
 * "write" through opt->progress. msh takes its version from opt->format (VM_MESH_MSH2: 2.2,
 * otherwise 4.1). */
vm_status vm__write_vtu(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_vtk(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_msh(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_medit(const char *path, const vm_mesh *m,
                          const vm_mesh_write_options *opt, vm_error *err);
vm_status vm__write_stl(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_off(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_ply(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
vm_status vm__write_obj(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err);
/* The solver decks of tet4 / hex8 meshes, one part and material per region: Nastran bulk
 * data (io/nastran.c), LS-DYNA keywords (io/lsdyna.c), COMSOL text mesh (io/comsol.c,
 * no materials), FEBio 4.0 (io/febio.c, with opt->deck). */
vm_status vm__write_nastran(const char *path, const vm_mesh *m,
                            const vm_mesh_write_options *opt, vm_error *err);
vm_status vm__write_lsdyna(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err);
vm_status vm__write_comsol(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err);
vm_status vm__write_febio(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                          vm_error *err);

/* --- numbers as text (io/number_text.c) ------------------------------------------------- */

/* Deck field width limits: CalculiX / ABAQUS read at most 20 characters per number; Nastran
 * large-field and LS-DYNA fixed node fields hold 16. */
enum { VM__INP_FIELD = 20, VM__WIDE_FIELD = 16 };

/* Writes v into out (cap >= 32) as the shortest text among %.15g, %.16g, %.17g (and their
 * exponent forms, exponent written "E-7") at the first precision that reads back exactly;
 * when that is wider than width characters, the most significant digits (15 or fewer) whose
 * text fits. need_point: always with a decimal point (Nastran reads "12" as an integer).
 * Returns the length written. Non-finite values are written as %g gives them. */
int vm__format_real(double v, int width, int need_point, char *out, size_t cap);

/* --- the static decks' node sets (io/deck_sets.c) ------------------------------------ */

typedef struct vm__deck_nodes {
    int64_t *fixed, *loaded; /* node ids (1-based), sorted; free both */
    size_t nfixed, nloaded;
} vm__deck_nodes;

/* Fixed: nodes within 1% of the z extent above the lowest z (a piece reaching it at fewer
 * than 3 nodes gets its own lowest slab, or all its nodes); loaded: within 1% below the
 * highest z. zs: z of each of nnodes nodes (corners, then mid-edge nodes mid[cell *
 * nmid_per_cell + k] when nmid_per_cell > 0). [out] *d (free its arrays even on error). */
vm_status vm__deck_sets(const char *path, const vm_mesh *m, const double *zs,
                        const vm_index *mid, int nmid_per_cell, size_t nnodes,
                        vm__deck_nodes *d, vm_error *err);

/* --- second-order elements (io/mid_nodes.c) -------------------------------------------- */

/* Mid-edge nodes of a tet4 / hex8 mesh: mid[cell * ne + e] (ne 6 or 12, edges in the order
 * of vm__tet_edges / vm__hex_edges, which is VTK's and Abaqus's) = node number npoints + k,
 * one k per distinct edge. [out] *mid (malloc'd, free it), *nmid (distinct edges). */
vm_status vm__mid_nodes(const char *path, const vm_mesh *m, vm_index **mid, size_t *nmid,
                        vm_error *err);
/* out[(npoints + nmid) * ncomp]: vals (npoints * ncomp) followed by each mid-edge node's
 * mean of its edge's two ends (coordinates: the straight edge's middle). */
void vm__mid_average(const vm_mesh *m, const vm_index *mid, const double *vals, int ncomp,
                     double *out);

/* A second-order view of m (curved by vm__mid_curve as opt asks; opt may be NULL): view.cells holds nn + ne nodes a cell (view.kind stays m's:
 * callers use the counts), in the order order[k] (k-th written = corner j < nn or mid-edge
 * node j - nn of vm__*_edges; NULL: corners then edges, VTK's order); view.points and the
 * point fields are extended to the mid-edge nodes (each the mean of its edge's ends); cell
 * fields and regions are m's. Tet4 / hex8 only (else VM_ERR_UNSUPPORTED). [out] q, free
 * with vm__quadratic_free (owns everything in view but what m owns). */
typedef struct vm__quadratic {
    vm_mesh view;
    vm_index *mid;
} vm__quadratic;
vm_status vm__quadratic_make(const char *path, const vm_mesh *m, const int *order,
                             const vm_mesh_write_options *opt, vm__quadratic *q,
                             vm_error *err);

/* Curved boundary (io/mid_curve.c): with opt->curve_volume set and m tet4, moves each
 * mid-edge node of an outer boundary edge in pts ((npoints + nmid) * 3, the mid-edge nodes
 * straight) onto the level set curve_lo or curve_hi (the one nearer its straight value) of
 * the volume's trilinear field, then pulls nodes back toward the middle until every curved
 * tet keeps a positive Jacobian determinant; nodes on the volume's box faces stay straight.
 * Does nothing (VM_OK) otherwise. opt may be NULL. */
vm_status vm__mid_curve(const char *path, const vm_mesh *m, const vm_index *mid, size_t nmid,
                        const vm_mesh_write_options *opt, double *pts, vm_error *err);
/* The volume's world-to-index frame (io/mid_curve.c): inv = (D * diag(spacing))^-1, 0 when
 * singular; vm__to_index: idx = inv * (x - origin), inv row-major (&inv[0][0]). */
int vm__index_frame(const vm_volume *v, double inv[3][3]);
void vm__to_index(const vm_volume *v, const double *inv, const double x[3], double idx[3]);
void vm__quadratic_free(vm__quadratic *q);

/* --- materials (io/materials.c) --------------------------------------------------------- */

/* The material a deck writes for region: opt's row for it, else the placeholder named
 * MAT_REGION_r (steel-like, N mm t). opt may be NULL. [out] out. */
void vm__material_of_region(const vm_mesh_write_options *opt, int32_t region,
                            vm_material *out);
/* 1 when opt has no row for region (the deck says so in a comment). */
int vm__material_is_placeholder(const vm_mesh_write_options *opt, int32_t region);

/* --- text cursor ------------------------------------------------------------------------- */

typedef struct vm__cursor {
    const char *path;
    const char *start, *p, *end;
    char comment; /* a character starting a comment that runs to the end of the line, or 0 */
    vm_error *err;
} vm__cursor;

void vm__cur_init(vm__cursor *c, const char *path, const void *buf, size_t len, char comment,
                  vm_error *err);

/* Starts a mesh reader: m empty (of kind), the whole file (at most VM__MESH_MAX_FILE bytes)
 * in *buf, c a cursor over it (comment as in vm__cur_init). On failure *buf is NULL. */
vm_status vm__mesh_read_begin(const char *path, vm_mesh *m, vm_cell_kind kind, char comment,
                              unsigned char **buf, vm__cursor *c, vm_error *err);

/* Ends a mesh reader with status st: frees buf, and m too when st is an error. Returns st. */
vm_status vm__mesh_read_end(vm_mesh *m, unsigned char *buf, vm_status st);

/* Records "PATH: line N: MESSAGE" (N = line of the cursor) and returns status. */
vm_status vm__cur_fail(const vm__cursor *c, vm_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Next white-space separated token (comments skipped). Returns 0 at the end of the data. */
int vm__cur_token(vm__cursor *c, const char **tok, size_t *len);

/* Next token, which must be a number: a decimal integer in [lo, hi], or a finite double.
 * On a missing or bad token fills the error ("expected WHAT") and returns its status. */
vm_status vm__cur_int(vm__cursor *c, int64_t lo, int64_t hi, const char *what, int64_t *v);
vm_status vm__cur_double(vm__cursor *c, const char *what, double *v);

/* Rest of the current line (without the line break), then moves to the next line.
 * Returns 0 at the end of the data. */
int vm__cur_line(vm__cursor *c, const char **s, size_t *len);

/* Skips white space and comments without consuming a token; 1 when data remain. */
int vm__cur_more(vm__cursor *c);

/* Bytes left after the cursor. */
size_t vm__cur_left(const vm__cursor *c);

/* Token equality, case-insensitive. */
int vm__tok_is(const char *tok, size_t len, const char *word);

/* Parses a whole token as an integer / finite double; VM_ERR_FORMAT when it is not one. */
vm_status vm__parse_int_tok(const char *tok, size_t len, int64_t *v);
vm_status vm__parse_double_tok(const char *tok, size_t len, double *v);

/* Refuses a count that cannot fit in the remaining bytes (each item needs at least
 * min_bytes) or in memory. */
vm_status vm__check_count(const vm__cursor *c, uint64_t count, size_t min_bytes,
                          const char *what);

/* --- ids ------------------------------------------------------------------------------- */

/* Maps file ids (any int64, unique) to 0-based indices. */
typedef struct vm__idmap {
    int64_t *ids;    /* sorted */
    vm_index *index; /* index[k] belongs to ids[k] */
    size_t n, cap;
} vm__idmap;

vm_status vm__idmap_add(vm__idmap *m, int64_t id, vm_index index, vm_error *err);
/* Sorts the map; when ids repeat, returns VM_ERR_FORMAT with the first duplicated id in
 * *dup (the caller writes the message). */
vm_status vm__idmap_finish(vm__idmap *m, int64_t *dup);
/* Index of id, or -1. */
vm_index vm__idmap_find(const vm__idmap *m, int64_t id);
void vm__idmap_free(vm__idmap *m);

/* --- mesh helpers ----------------------------------------------------------------------- */

/* Local faces in ABAQUS order (S1..S4 for tets, S1..S6 for hexes), as VTK node positions. */
extern const int vm__tet_faces[4][3];
extern const int vm__hex_faces[6][4];
/* Edges in ABAQUS / VTK quadratic order (C3D10, C3D20). */
extern const int vm__tet_edges[6][2];
extern const int vm__hex_edges[12][2];

/* Boundary faces of a tet4/hex8 mesh (faces used by exactly one cell), as cell*nfaces+face
 * in increasing order. [out] *faces (malloc'd, free it), *n. */
vm_status vm__boundary_faces(const char *path, const vm_mesh *m, uint64_t **faces, size_t *n,
                             vm_error *err);

/* A face between two cells of different regions, named from the side of the lower region:
 * face = cell*nfaces+face of that cell, region = its region, other = the region across. */
typedef struct vm__iface {
    uint64_t face;
    int32_t region, other;
} vm__iface;

/* Interface faces of a tet4/hex8 mesh, sorted by (region, other, face). [out] *faces
 * (malloc'd, NULL when none), *n. */
vm_status vm__interface_faces(const char *path, const vm_mesh *m, vm__iface **faces, size_t *n,
                              vm_error *err);

/* Sorted distinct region ids of m. [out] *regions (malloc'd), *n. */
vm_status vm__distinct_regions(const char *path, const vm_mesh *m, int32_t **regions,
                               size_t *n, vm_error *err);

struct vm_outfile;
/* The start every solid deck writer with fixed-width ids shares (Nastran, LS-DYNA): m holds
 * tet4 or hex8 (else VM_ERR_UNSUPPORTED: "PATH: <what> for tet4 and hex8 meshes"), at most max_id nodes and elements,
 * valid nodes; then its sorted regions ([out] *regions, malloc'd) and the open output ([out]
 * o, its write meter started). On an error nothing is left open or allocated. */
vm_status vm__solid_deck_open(const char *path, const vm_mesh *m, const char *what,
                              long long max_id, const vm_mesh_write_options *opt,
                              int32_t **regions, size_t *nregions, struct vm_outfile *o,
                              vm_error *err);

/* Index of r in the sorted list, or -1. */
long vm__region_slot(const int32_t *regions, size_t n, int32_t r);

/* Writes "REGION_<r>" (negative: "REGION_M<|r|>") into out. */
void vm__region_name(int32_t r, char *out, size_t cap);
/* Parses a region name as written by vm__region_name (case-insensitive); 1 on success. */
vm_status vm__region_parse(const char *s, size_t len, int32_t *r);

/* The surface a surface format writes: m itself when tri3/quad4, else its boundary (owned by
 * *tmp, free with vm_mesh_free). [out] *surf points to m or to tmp. */
vm_status vm__surface_of(const char *path, const vm_mesh *m, vm_mesh *tmp,
                         const vm_mesh **surf, vm_error *err);

/* Builds a surface mesh from polygons given as (count, indices) with per-face regions:
 * all quads give quad4, otherwise tri3 (quads split along 0-2). */
typedef struct vm__polys {
    vm_index *idx;   /* concatenated indices */
    uint8_t *count;  /* 3 or 4 per face */
    int32_t *region; /* per face */
    size_t nfaces, nidx, cap_f, cap_i;
} vm__polys;
vm_status vm__polys_add(vm__polys *p, const vm_index *idx, int count, int32_t region,
                        vm_error *err);
/* Moves the faces into m (whose points are already set) and frees p. */
vm_status vm__polys_finish(const char *path, vm__polys *p, vm_mesh *m, vm_error *err);
void vm__polys_free(vm__polys *p);

/* Big-endian and little-endian stores and loads. */
void vm__put_be32(unsigned char *b, uint32_t v);
void vm__put_be64(unsigned char *b, uint64_t v);
uint32_t vm__get_be32(const unsigned char *b);
uint64_t vm__get_be64(const unsigned char *b);
void vm__put_le16(unsigned char *b, uint16_t v);
void vm__put_le32(unsigned char *b, uint32_t v);
void vm__put_le64(unsigned char *b, uint64_t v);
uint16_t vm__get_le16(const unsigned char *b);
uint32_t vm__get_le32(const unsigned char *b);
uint64_t vm__get_le64(const unsigned char *b);
double vm__bits_double(uint64_t u);
uint64_t vm__double_bits(double d);
float vm__bits_float(uint32_t u);
uint32_t vm__float_bits(float f);

/* VM_OK when the Exodus II library can be loaded; else the writer's one-line refusal, naming
 * path and the library (io/exodus.c). */
vm_status vm__exodus_check(const char *path, vm_error *err);

#endif
