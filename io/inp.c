/* SPDX-License-Identifier: BSD-3-Clause */
/* io/inp.c — ABAQUS / CalculiX input decks (.inp): writer with element sets, boundary node
 * sets and element-face surfaces per region and per interface between two regions,
 * placeholder material and an optional static step; reader for the mesh part. Follows the
 * Abaqus Keywords Reference (*NODE, *ELEMENT, *ELSET, *NSET, *SURFACE, *SOLID SECTION,
 * *STEP, *STATIC, *BOUNDARY, *CLOAD) and the CalculiX CrunchiX User's Manual (element and
 * face numbering as in Abaqus). */
#include <ctype.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/volmesh.h"

/* ======================================================================================= */
/* Writer                                                                                   */
/* ======================================================================================= */

/* Writes a list of ids, 16 per line (Abaqus data lines hold at most 16 entries). */
static void write_id_list(FILE *fp, const int64_t *ids, size_t n) {
    for (size_t i = 0; i < n; i++)
        fprintf(fp, "%" PRId64 "%s", ids[i], (i % 16 == 15 || i + 1 == n) ? "\n" : ", ");
}

static int cmp_i64(const void *a, const void *b) {
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static size_t sort_unique(int64_t *v, size_t n) {
    qsort(v, n, sizeof *v, cmp_i64);
    size_t k = 0;
    for (size_t i = 0; i < n; i++)
        if (k == 0 || v[k - 1] != v[i]) v[k++] = v[i];
    return k;
}

/* Abaqus element face / edge counts: S1..S4 of a tet, S1..S6 of a hex; 6 and 12 mid-edge
 * nodes of C3D10 / C3D20 (Abaqus Analysis User's Guide, 28.1.4). */
enum { TET_FACES = 4, HEX_FACES = 6, TET_EDGES = 6, HEX_EDGES = 12 };

/* Most entries on one Abaqus data line, and the first mid-edge node of C3D20 that goes on
 * the continuation line (8 corners + 7 mid-edge nodes = 15 entries after the element id). */
enum { C3D20_FIRST_CONTINUED = 7 };

/* Room for the ids of one face (at most 8 nodes, with mid-edge nodes) before deduplicating. */
#define FACE_ID_ROOM 16

/* Placeholder load of the static deck: a total force in -z (model units) spread evenly. */
static const double DECK_TOTAL_FORCE = 100.0;

/* A mesh on its way to a deck: what the sections need besides the mesh itself. */
typedef struct inp_writer {
    const char *path;
    const vm_mesh *m;
    const vm_mesh_write_options *opt;
    vm_error *err;
    FILE *fp;
    vm_outfile o;
    int volume, order2, ne, nf;
    size_t nn, nnodes;
    const char *etype;
    vm_index *mid; /* order 2: mid-edge node of cell*ne + edge */
    double *xyz;   /* order 2: every node's coordinates (mid-edge nodes curved as opt says) */
    size_t nmid, nb, nregions, nif, idcap;
    uint64_t *bfaces;
    vm__iface *ifaces;
    int32_t *regions;
    int64_t *ids; /* scratch list of node / element ids */
    vm__deck_nodes deck;
} inp_writer;

/* Frees what prepare_deck_data allocated. */
static void inp_writer_free(inp_writer *w) {
    free(w->mid);
    free(w->xyz);
    free(w->bfaces);
    free(w->ifaces);
    free(w->regions);
    free(w->ids);
    free(w->deck.fixed);
    free(w->deck.loaded);
}

/* The static deck's node sets, from the z of every node (mid-edge nodes as written). */
static vm_status prepare_static_deck(inp_writer *w) {
    const vm_mesh *m = w->m;
    double *zs = malloc((w->nnodes ? w->nnodes : 1) * sizeof *zs);
    if (!zs) return vm_error_set(w->err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    const double *xyz = w->order2 ? w->xyz : m->points;
    for (size_t i = 0; i < w->nnodes; i++)
        zs[i] = xyz[3 * i + 2];
    vm_status st = vm__deck_sets(w->path, m, zs, w->mid, w->ne, w->nnodes, &w->deck, w->err);
    free(zs);
    return st;
}

/* Mid-edge nodes, boundary and interface faces, regions, the id scratch and the deck sets. */
static vm_status prepare_deck_data(inp_writer *w) {
    const vm_mesh *m = w->m;
    vm_status st = VM_OK;
    if (w->order2) st = vm__mid_nodes(w->path, m, &w->mid, &w->nmid, w->err);
    if (st) return st;
    w->nnodes = m->npoints + w->nmid;
    if (w->order2) {
        w->xyz = malloc(3 * (w->nnodes + 1) * sizeof *w->xyz);
        if (!w->xyz) return vm_error_set(w->err, VM_ERR_NOMEM, "%s: out of memory", w->path);
        vm__mid_average(m, w->mid, m->points, 3, w->xyz);
        st = vm__mid_curve(w->path, m, w->mid, w->nmid, w->opt, w->xyz, w->err);
        if (st) return st;
    }
    if (w->volume) st = vm__boundary_faces(w->path, m, &w->bfaces, &w->nb, w->err);
    if (!st) st = vm__distinct_regions(w->path, m, &w->regions, &w->nregions, w->err);
    if (!st && w->volume && w->nregions > 1)
        st = vm__interface_faces(w->path, m, &w->ifaces, &w->nif, w->err);
    if (st) return st;
    /* room for every node once, and slack beyond the one face's ids checked before each */
    w->idcap = (m->ncells > w->nnodes ? m->ncells : w->nnodes) + 4 * FACE_ID_ROOM;
    w->ids = malloc((w->idcap ? w->idcap : 1) * sizeof *w->ids);
    if (!w->ids) return vm_error_set(w->err, VM_ERR_NOMEM, "%s: out of memory", w->path);
    if (w->opt->deck == VM_DECK_STATIC) st = prepare_static_deck(w);
    return st;
}

/* One *NODE data line; every coordinate at most VM__INP_FIELD characters. */
static void write_node_line(FILE *fp, size_t id, double x, double y, double z) {
    char a[32], b[32], c[32];
    vm__format_real(x, VM__INP_FIELD, 0, a, sizeof a);
    vm__format_real(y, VM__INP_FIELD, 0, b, sizeof b);
    vm__format_real(z, VM__INP_FIELD, 0, c, sizeof c);
    fprintf(fp, "%zu, %s, %s, %s\n", id, a, b, c);
}

/* *NODE: the mesh points, then (order 2) each mid-edge node, in id order (at the middle of
 * its edge, or curved onto the surface). */
static vm_status write_nodes(inp_writer *w) {
    const vm_mesh *m = w->m;
    FILE *fp = w->fp;
    fprintf(fp, "*NODE, NSET=NALL\n");
    for (size_t i = 0; i < m->npoints; i++) {
        const double *p = m->points + 3 * i;
        write_node_line(fp, i + 1, p[0], p[1], p[2]);
        vm__out_step(&w->o, 1.0);
    }
    if (!w->order2) return VM_OK;
    for (size_t i = m->npoints; i < w->nnodes; i++) {
        const double *p = w->xyz + 3 * i;
        write_node_line(fp, i + 1, p[0], p[1], p[2]);
        vm__out_step(&w->o, 1.0);
    }
    return VM_OK;
}

/* *ELEMENT: the corner order of C3D4/C3D8/S3/S4 (and the edge order of C3D10/C3D20) is
 * VTK's; then one *ELSET per region. */
static void write_elements(inp_writer *w) {
    const vm_mesh *m = w->m;
    FILE *fp = w->fp;
    int ne = w->ne;
    fprintf(fp, "*ELEMENT, TYPE=%s, ELSET=EALL\n", w->etype);
    for (size_t c = 0; c < m->ncells; c++) {
        fprintf(fp, "%zu", c + 1);
        for (size_t k = 0; k < w->nn; k++)
            fprintf(fp, ", %lld", (long long)m->cells[c * w->nn + k] + 1);
        for (int k = 0; k < ne; k++) {
            int continued = ne == HEX_EDGES && k == C3D20_FIRST_CONTINUED;
            if (continued) fprintf(fp, ",\n");
            fprintf(fp, continued ? "%lld" : ", %lld",
                    (long long)w->mid[c * (size_t)ne + (size_t)k] + 1);
        }
        fputc('\n', fp);
        vm__out_step(&w->o, 1.0);
    }
    for (size_t r = 0; r < w->nregions; r++) {
        char name[32];
        vm__region_name(w->regions[r], name, sizeof name);
        size_t n = 0;
        for (size_t c = 0; c < m->ncells; c++)
            if (m->region[c] == w->regions[r]) w->ids[n++] = (int64_t)c + 1;
        fprintf(fp, "*ELSET, ELSET=%s\n", name);
        write_id_list(fp, w->ids, n);
    }
}

/* Appends to ids[*n] the nodes of local face f of cell c: its corners and, at order 2, the
 * mid-edge node of each of its edges. */
static void face_node_ids(const inp_writer *w, size_t c, int f, int64_t *ids, size_t *n) {
    const vm_mesh *m = w->m;
    int fk = m->kind == VM_TET4 ? 3 : 4;
    const int(*edges)[2] = m->kind == VM_TET4 ? vm__tet_edges : vm__hex_edges;
    for (int j = 0; j < fk; j++) {
        int a = fk == 3 ? vm__tet_faces[f][j] : vm__hex_faces[f][j];
        int b = fk == 3 ? vm__tet_faces[f][(j + 1) % 3] : vm__hex_faces[f][(j + 1) % 4];
        ids[(*n)++] = (int64_t)m->cells[c * w->nn + (size_t)a] + 1;
        if (!w->order2) continue;
        for (int k = 0; k < w->ne; k++)
            if ((edges[k][0] == a && edges[k][1] == b) ||
                (edges[k][0] == b && edges[k][1] == a))
                ids[(*n)++] = (int64_t)w->mid[c * (size_t)w->ne + (size_t)k] + 1;
    }
}

/* *NSET name of the nodes (mid-edge nodes too) of the n faces faces[i] (cell*nf + face). */
static void write_face_nset(inp_writer *w, const char *name, const uint64_t *faces,
                            size_t stride, size_t n) {
    uint64_t nf = (uint64_t)w->nf;
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        uint64_t f = *(const uint64_t *)(const void *)((const char *)faces + i * stride);
        if (k + FACE_ID_ROOM > w->idcap) k = sort_unique(w->ids, k);
        face_node_ids(w, (size_t)(f / nf), (int)(f % nf), w->ids, &k);
    }
    k = sort_unique(w->ids, k);
    if (k == 0) return;
    fprintf(w->fp, "*NSET, NSET=%s\n", name);
    write_id_list(w->fp, w->ids, k);
}

/* The outer boundary as a whole: *NSET NB_OUTER and *SURFACE OUTER. */
static void write_outer_boundary(inp_writer *w) {
    uint64_t nf = (uint64_t)w->nf;
    if (w->nb == 0) return;
    write_face_nset(w, "NB_OUTER", w->bfaces, sizeof *w->bfaces, w->nb);
    fprintf(w->fp, "*SURFACE, NAME=OUTER, TYPE=ELEMENT\n");
    for (size_t i = 0; i < w->nb; i++)
        fprintf(w->fp, "%zu, S%d\n", (size_t)(w->bfaces[i] / nf) + 1,
                (int)(w->bfaces[i] % nf) + 1);
}

/* Per region, the *NSET NB_ of its boundary nodes and the *SURFACE SURF_ of its boundary
 * faces; the whole outer boundary; per touching pair of regions, the *SURFACE IFACE_ on the
 * lower region's side and the *NSET NIF_ of its nodes. */
static void write_boundary_sets(inp_writer *w) {
    const vm_mesh *m = w->m;
    FILE *fp = w->fp;
    uint64_t nf = (uint64_t)w->nf;
    for (size_t r = 0; r < w->nregions; r++) {
        char name[32];
        vm__region_name(w->regions[r], name, sizeof name);
        size_t n = 0;
        for (size_t i = 0; i < w->nb; i++) {
            size_t c = (size_t)(w->bfaces[i] / nf);
            if (m->region[c] != w->regions[r]) continue;
            if (n + FACE_ID_ROOM > w->idcap) n = sort_unique(w->ids, n);
            face_node_ids(w, c, (int)(w->bfaces[i] % nf), w->ids, &n);
        }
        n = sort_unique(w->ids, n);
        if (n == 0) continue;
        fprintf(fp, "*NSET, NSET=NB_%s\n", name);
        write_id_list(fp, w->ids, n);
    }
    for (size_t r = 0; r < w->nregions; r++) {
        char name[32];
        vm__region_name(w->regions[r], name, sizeof name);
        int any = 0;
        for (size_t i = 0; i < w->nb; i++) {
            size_t c = (size_t)(w->bfaces[i] / nf);
            if (m->region[c] != w->regions[r]) continue;
            if (!any) fprintf(fp, "*SURFACE, NAME=SURF_%s, TYPE=ELEMENT\n", name);
            any = 1;
            fprintf(fp, "%zu, S%d\n", c + 1, (int)(w->bfaces[i] % nf) + 1);
        }
    }
    write_outer_boundary(w);
    for (size_t i = 0, first = 0; i < w->nif; i++) {
        const vm__iface *f = &w->ifaces[i];
        char a[32], b[32], name[80];
        vm__region_name(f->region, a, sizeof a);
        vm__region_name(f->other, b, sizeof b);
        if (i == first) fprintf(fp, "*SURFACE, NAME=IFACE_%s_%s, TYPE=ELEMENT\n", a, b);
        fprintf(fp, "%zu, S%d\n", (size_t)(f->face / nf) + 1, (int)(f->face % nf) + 1);
        if (i + 1 < w->nif && f[1].region == f->region && f[1].other == f->other) continue;
        snprintf(name, sizeof name, "NIF_%s_%s", a, b);
        write_face_nset(w, name, &w->ifaces[first].face, sizeof *w->ifaces, i + 1 - first);
        first = i + 1;
    }
}

/* A number of a material line (at most VM__INP_FIELD characters). */
static const char *inp_real(double v, char *buf, size_t cap) {
    vm__format_real(v, VM__INP_FIELD, 0, buf, cap);
    return buf;
}

/* One material per region, named after it or from opt's table, each with its section; then
 * the static step when asked. */
static void write_material_and_step(inp_writer *w) {
    FILE *fp = w->fp;
    char e[32], nu[32], rho[32];
    for (size_t r = 0; r < w->nregions; r++) {
        char name[32];
        vm_material mat;
        vm__region_name(w->regions[r], name, sizeof name);
        vm__material_of_region(w->opt, w->regions[r], &mat);
        if (vm__material_is_placeholder(w->opt, w->regions[r]))
            fprintf(fp, "** placeholder material of %s (steel-like, units N, mm, t): replace it "
                        "or give --materials\n", name);
        fprintf(fp, "*MATERIAL, NAME=%s\n*ELASTIC\n%s, %s\n*DENSITY\n%s\n", mat.name,
                inp_real(mat.young, e, sizeof e), inp_real(mat.poisson, nu, sizeof nu),
                inp_real(mat.density, rho, sizeof rho));
        if (w->volume)
            fprintf(fp, "*SOLID SECTION, ELSET=%s, MATERIAL=%s\n", name, mat.name);
        else
            fprintf(fp, "*SHELL SECTION, ELSET=%s, MATERIAL=%s\n1.0\n", name, mat.name);
    }
    if (w->opt->deck != VM_DECK_STATIC) return;
    fprintf(fp, "** static deck: nodes of the lowest z slab (1%% of the z extent) fixed,\n"
                "** a total force of 100 in -z spread over the nodes of the top slab\n");
    fprintf(fp, "*NSET, NSET=FIXED\n");
    write_id_list(fp, w->deck.fixed, w->deck.nfixed);
    fprintf(fp, "*NSET, NSET=LOADED\n");
    write_id_list(fp, w->deck.loaded, w->deck.nloaded);
    char load[32];
    vm__format_real(-DECK_TOTAL_FORCE / (double)w->deck.nloaded, VM__INP_FIELD, 0, load,
                    sizeof load);
    fprintf(fp, "*STEP\n*STATIC\n*BOUNDARY\nFIXED, 1, 3\n*CLOAD\nLOADED, 3, %s\n", load);
    fprintf(fp, "*NODE FILE\nU\n*EL FILE\nS\n*NODE PRINT, NSET=LOADED\nU\n*END STEP\n");
}

int vm_inp_split_path(const char *deck, char *out, size_t cap) {
    size_t n = strlen(deck);
    if (n >= 4 && strcmp(deck + n - 4, ".inp") == 0) n -= 4;
    int k = snprintf(out, cap, "%.*s_mesh.inp", (int)n, deck);
    return k > 0 && (size_t)k < cap;
}

/* The line that includes the mesh file: its name without the folder (the deck's folder). */
static void write_include(FILE *fp, const char *mesh_path) {
    const char *base = strrchr(mesh_path, '/');
    fprintf(fp, "*INCLUDE, INPUT=%s\n", base ? base + 1 : mesh_path);
}

/* Checks the mesh, gathers the sets, then writes the deck section by section (with split,
 * the mesh sections to their own file, which the deck includes). */
vm_status vm_mesh_write_inp(const char *path, const vm_mesh *m,
                            const vm_mesh_write_options *opt, vm_error *err) {
    vm_mesh_write_options def;
    if (!opt) {
        vm_mesh_write_options_init(&def);
        opt = &def;
    }
    inp_writer w;
    memset(&w, 0, sizeof w);
    w.path = path;
    w.m = m;
    w.opt = opt;
    w.err = err;
    w.volume = m->kind == VM_TET4 || m->kind == VM_HEX8;
    w.order2 = opt->order == 2;
    if (vm_cell_nodes(m->kind) == 0)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    if (w.order2 && !w.volume)
        return vm_error_set(err, VM_ERR_UNSUPPORTED,
                            "%s: second-order elements are written for tet4 and hex8 meshes, "
                            "not %s", path, vm_cell_kind_name(m->kind));
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    w.etype = m->kind == VM_TET4   ? (w.order2 ? "C3D10" : "C3D4")
              : m->kind == VM_HEX8 ? (w.order2 ? "C3D20" : "C3D8")
              : m->kind == VM_TRI3 ? "S3"
                                   : "S4";
    w.nn = (size_t)vm_cell_nodes(m->kind);
    w.ne = !w.order2 ? 0 : m->kind == VM_TET4 ? TET_EDGES : HEX_EDGES;
    w.nf = m->kind == VM_TET4 ? TET_FACES : HEX_FACES;
    char mesh_path[4096];
    vm_outfile mo;
    memset(&mo, 0, sizeof mo);
    if (opt->split && !vm_inp_split_path(path, mesh_path, sizeof mesh_path))
        return vm_error_set(err, VM_ERR_ARG, "%s: path too long for its mesh file", path);
    st = prepare_deck_data(&w);
    if (!st) st = vm__out_open(&w.o, path, err);
    if (!st && opt->split && (st = vm__out_open(&mo, mesh_path, err))) vm__out_abort(&w.o);
    if (!st && opt->deck == VM_DECK_STATIC && !(w.deck.nfixed > 0 && w.deck.nloaded > 0)) {
        vm__out_abort(&w.o);
        if (opt->split) vm__out_abort(&mo);
        st = vm_error_set(err, VM_ERR_EMPTY, "%s: the mesh has no elements to load", path);
    }
    if (st) {
        inp_writer_free(&w);
        return st;
    }
    /* Progress: node by node (mid-edge nodes too), element by element, then the sets as one
     * tenth of the elements. */
    vm__out_meter(&w.o, opt->progress, opt->progress_user,
                  (double)w.nnodes + 1.1 * (double)m->ncells);
    fprintf(w.o.fp, "*HEADING\nvolmesh %s mesh: %zu nodes, %zu %s elements, %zu regions\n",
            vm_cell_kind_name(m->kind), w.nnodes, m->ncells, w.etype, w.nregions);
    fprintf(w.o.fp, "** written by volmesh %s; node and element order as in the source mesh\n",
            vm_version());
    w.fp = opt->split ? mo.fp : w.o.fp;
    if (opt->split) {
        write_include(w.o.fp, mesh_path);
        fprintf(w.fp, "** the mesh of %s, which includes it (volmesh %s)\n", path,
                vm_version());
    }
    st = write_nodes(&w);
    if (!st) {
        write_elements(&w);
        if (w.volume) write_boundary_sets(&w);
        w.fp = w.o.fp;
        write_material_and_step(&w);
        if (opt->split) st = vm__out_commit(&mo, err);
        if (!st) st = vm__out_commit(&w.o, err);
        else vm__out_abort(&w.o);
    } else {
        vm__out_abort(&w.o);
        if (opt->split) vm__out_abort(&mo);
    }
    inp_writer_free(&w);
    return st;
}

/* ======================================================================================= */
/* Reader                                                                                   */
/* ======================================================================================= */

enum { EK_NONE, EK_TET, EK_HEX, EK_TRI, EK_QUAD };

typedef struct inp_elem {
    int64_t id;
    int kind;
    int32_t ordinal; /* of the ELSET= named on its *ELEMENT line, 0 if none */
    int64_t nodes[8];
} inp_elem;

typedef struct inp_reader {
    vm__cursor c;
    vm_mesh *m;
    vm__idmap nodes;
    inp_elem *el;
    size_t nel, capel;
    int64_t *mid; /* node ids used as mid-edge nodes */
    size_t nmid, capmid;
    vm__idmap regions; /* element id -> region, from ELSET REGION_r */
    char (*elset_names)[81];
    size_t nelset_names, capnames;
} inp_reader;

/* Parameter value of key in a keyword line ("*ELEMENT, TYPE=C3D4, ELSET=X"), copied to out
 * (upper-cased, trimmed). Returns 1 when present. */
static int kw_param(const char *line, size_t len, const char *key, char *out, size_t cap) {
    size_t kl = strlen(key);
    const char *p = memchr(line, ',', len), *end = line + len;
    while (p && p < end) {
        p++;
        while (p < end && isspace((unsigned char)*p))
            p++;
        const char *q = p;
        while (q < end && *q != ',' && *q != '=')
            q++;
        const char *ke = q;
        while (ke > p && isspace((unsigned char)ke[-1]))
            ke--;
        if ((size_t)(ke - p) == kl && vm__tok_is(p, kl, key)) {
            size_t n = 0;
            if (q < end && *q == '=') {
                q++;
                while (q < end && isspace((unsigned char)*q))
                    q++;
                while (q < end && *q != ',' && n + 1 < cap)
                    out[n++] = (char)toupper((unsigned char)*q++);
                while (n > 0 && isspace((unsigned char)out[n - 1]))
                    n--;
            }
            out[n] = 0;
            return 1;
        }
        p = memchr(q, ',', (size_t)(end - q));
    }
    return 0;
}

/* The keyword of a line starting with '*': upper-cased, spaces removed, up to ','. */
static void kw_name(const char *line, size_t len, char *out, size_t cap) {
    size_t n = 0;
    for (size_t i = 1; i < len && line[i] != ',' && n + 1 < cap; i++)
        if (!isspace((unsigned char)line[i])) out[n++] = (char)toupper((unsigned char)line[i]);
    out[n] = 0;
}

/* Splits a data line into comma-separated fields; numbers only. Returns the count, or -1
 * when a field is not an integer (for id lists) — *bad points at it. */
static int split_ints(const char *s, size_t len, int64_t *out, int max, const char **bad,
                      size_t *badlen) {
    int n = 0;
    const char *p = s, *end = s + len;
    while (p < end) {
        const char *q = memchr(p, ',', (size_t)(end - p));
        const char *fe = q ? q : end;
        const char *a = p, *b = fe;
        while (a < b && isspace((unsigned char)*a))
            a++;
        while (b > a && isspace((unsigned char)b[-1]))
            b--;
        if (a < b) {
            if (n == max || vm__parse_int_tok(a, (size_t)(b - a), &out[n]) != VM_OK) {
                *bad = a;
                *badlen = (size_t)(b - a);
                return -1;
            }
            n++;
        }
        p = q ? q + 1 : end;
    }
    return n;
}

static int elem_kind(const char *type, int *nodes, int *corners) {
    /* C3D4, C3D4H, C3D10, C3D10M, C3D8R, C3D20R, S3, S3R, S4R, ... */
    if (strncmp(type, "C3D", 3) == 0) {
        const char *q = type + 3;
        int n = 0;
        while (isdigit((unsigned char)*q))
            n = n * 10 + (*q++ - '0');
        if (n == 4 || n == 10) {
            *nodes = n;
            *corners = 4;
            return EK_TET;
        }
        if (n == 8 || n == 20) {
            *nodes = n;
            *corners = 8;
            return EK_HEX;
        }
        return EK_NONE;
    }
    if (type[0] == 'S' && (type[1] == '3' || type[1] == '4') && !isdigit((unsigned char)type[2])) {
        *nodes = *corners = type[1] - '0';
        return type[1] == '3' ? EK_TRI : EK_QUAD;
    }
    if (strcmp(type, "STRI3") == 0) {
        *nodes = *corners = 3;
        return EK_TRI;
    }
    return EK_NONE;
}

/* Next data line of the current keyword's block, blank and "**" comment lines skipped.
 * Returns 0 at the next keyword line (left for the keyword loop) or at the end of the file.
 * [out] *save: where the line starts (the cursor goes back there for a message about it). */
static int next_data_line(inp_reader *r, const char **s, size_t *len, const char **save) {
    for (;;) {
        *save = r->c.p;
        if (!vm__cur_line(&r->c, s, len)) return 0;
        size_t k = 0;
        while (k < *len && isspace((unsigned char)(*s)[k]))
            k++;
        if (k == *len) continue;
        if ((*s)[k] == '*') {
            if (k + 1 < *len && (*s)[k + 1] == '*') continue;
            r->c.p = *save;
            return 0;
        }
        return 1;
    }
}

/* *NODE data lines: id, x, y[, z]. */
static vm_status read_nodes(inp_reader *r) {
    const char *s, *save;
    size_t len;
    while (next_data_line(r, &s, &len, &save)) {
        double v[4] = {0, 0, 0, 0};
        int n = 0;
        const char *p = s, *end = s + len;
        int64_t id = 0;
        while (p < end && n <= 4) {
            const char *q = memchr(p, ',', (size_t)(end - p));
            const char *a = p, *b = q ? q : end;
            while (a < b && isspace((unsigned char)*a))
                a++;
            while (b > a && isspace((unsigned char)b[-1]))
                b--;
            vm_status ok = n == 0 ? vm__parse_int_tok(a, (size_t)(b - a), &id)
                                  : vm__parse_double_tok(a, (size_t)(b - a), &v[n - 1]);
            if (a < b || n == 0) {
                if (ok != VM_OK) {
                    r->c.p = save;
                    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "bad node line \"%.*s\"",
                                        (int)(len > 60 ? 60 : len), s);
                }
                n++;
            }
            p = q ? q + 1 : end;
            if (n == 4) break;
        }
        if (n < 3) {
            r->c.p = save;
            return vm__cur_fail(&r->c, VM_ERR_FORMAT, "node line needs an id and coordinates");
        }
        vm_index ix = vm_mesh_add_point(r->m, v, r->c.err);
        if (ix < 0) return vm__cur_fail(&r->c, VM_ERR_NOMEM, "out of memory for nodes");
        vm_status st = vm__idmap_add(&r->nodes, id, ix, r->c.err);
        if (st) return vm__cur_fail(&r->c, st, "out of memory for nodes");
    }
    return VM_OK;
}

/* Most integers of one element entry with its continuation lines (id and 20 nodes of a
 * C3D20 fit with room to spare). */
enum { ELEMENT_MAX_VALUES = 40 };

/* *ELEMENT data lines: id, then the nodes (continued on the next lines when many). */
static vm_status read_elements(inp_reader *r, int kind, int nodes, int corners, int32_t ordinal) {
    int64_t vals[ELEMENT_MAX_VALUES];
    int have = 0;
    const char *s, *save;
    size_t len;
    while (next_data_line(r, &s, &len, &save)) {
        const char *bad = NULL;
        size_t badlen = 0;
        int n = split_ints(s, len, vals + have, ELEMENT_MAX_VALUES - have, &bad, &badlen);
        if (n < 0) {
            r->c.p = save;
            return vm__cur_fail(&r->c, VM_ERR_FORMAT, "bad element entry \"%.*s\"",
                                (int)(badlen > 40 ? 40 : badlen), bad);
        }
        have += n;
        if (have < nodes + 1) continue; /* continuation line follows */
        if (have > nodes + 1) {
            r->c.p = save;
            return vm__cur_fail(&r->c, VM_ERR_FORMAT, "element has %d nodes, its type has %d",
                                have - 1, nodes);
        }
        if (r->nel == r->capel) {
            vm_status st = vm__grow((void **)&r->el, &r->capel, r->nel + 1, sizeof *r->el,
                                    r->c.err);
            if (st) return vm__cur_fail(&r->c, st, "out of memory for elements");
        }
        inp_elem *e = &r->el[r->nel++];
        memset(e, 0, sizeof *e);
        e->id = vals[0];
        e->kind = kind;
        e->ordinal = ordinal;
        memcpy(e->nodes, vals + 1, (size_t)corners * sizeof(int64_t));
        if (nodes > corners) {
            vm_status st = vm__grow((void **)&r->mid, &r->capmid, r->nmid + (size_t)nodes,
                                    sizeof(int64_t), r->c.err);
            if (st) return vm__cur_fail(&r->c, st, "out of memory for elements");
            memcpy(r->mid + r->nmid, vals + 1 + corners,
                   (size_t)(nodes - corners) * sizeof(int64_t));
            r->nmid += (size_t)(nodes - corners);
        }
        have = 0;
    }
    if (have)
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "last element has %d of %d nodes", have - 1,
                            nodes);
    return VM_OK;
}

/* Most element numbers on one *ELSET data line (Abaqus data lines hold at most 16). */
enum { ELSET_LINE_MAX = 16 };
/* Longest GENERATE range accepted, a bound against a typo that would fill memory. */
#define GENERATE_MAX_RANGE 100000000u

/* *ELSET data lines (element numbers, or first, last[, step] with GENERATE): recorded when
 * the set is a region's. */
static vm_status read_elset(inp_reader *r, int32_t region, int is_region, int generate) {
    const char *s, *save;
    size_t len;
    while (next_data_line(r, &s, &len, &save)) {
        if (!is_region) continue;
        int64_t v[ELSET_LINE_MAX];
        const char *bad = NULL;
        size_t badlen = 0;
        int n = split_ints(s, len, v, ELSET_LINE_MAX, &bad, &badlen);
        if (n < 0) {
            r->c.p = save;
            return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED,
                                "element set entry \"%.*s\" is not an element number",
                                (int)(badlen > 40 ? 40 : badlen), bad);
        }
        if (generate) {
            if (n < 2 || n > 3 || (n == 3 && v[2] <= 0) || v[1] < v[0] ||
                (uint64_t)(v[1] - v[0]) / (uint64_t)(n == 3 ? v[2] : 1) > GENERATE_MAX_RANGE) {
                r->c.p = save;
                return vm__cur_fail(&r->c, VM_ERR_FORMAT, "bad GENERATE range");
            }
            int64_t step = n == 3 ? v[2] : 1;
            for (int64_t id = v[0]; id <= v[1]; id += step) {
                vm_status st = vm__idmap_add(&r->regions, id, (vm_index)region, r->c.err);
                if (st) return vm__cur_fail(&r->c, st, "out of memory for element sets");
                if (id > INT64_MAX - step) break;
            }
            continue;
        }
        for (int i = 0; i < n; i++) {
            vm_status st = vm__idmap_add(&r->regions, v[i], (vm_index)region, r->c.err);
            if (st) return vm__cur_fail(&r->c, st, "out of memory for element sets");
        }
    }
    return VM_OK;
}

/* Skips the data lines of a keyword volmesh does not read. */
static vm_status skip_data(inp_reader *r) {
    const char *s, *save;
    size_t len;
    while (next_data_line(r, &s, &len, &save)) {
    }
    return VM_OK;
}

static int32_t elset_ordinal(inp_reader *r, const char *name, vm_status *st) {
    for (size_t i = 0; i < r->nelset_names; i++)
        if (strcmp(r->elset_names[i], name) == 0) return (int32_t)i + 1;
    *st = vm__grow((void **)&r->elset_names, &r->capnames, r->nelset_names + 1,
                   sizeof *r->elset_names, r->c.err);
    if (*st) return 0;
    snprintf(r->elset_names[r->nelset_names], sizeof r->elset_names[0], "%s", name);
    return (int32_t)++r->nelset_names;
}

static vm_status build_mesh(inp_reader *r) {
    const char *path = r->c.path;
    vm_mesh *m = r->m;
    int have[5] = {0, 0, 0, 0, 0};
    for (size_t i = 0; i < r->nel; i++)
        have[r->el[i].kind]++;
    int kind = have[EK_TET] || have[EK_HEX] ? (have[EK_TET] ? EK_TET : EK_HEX)
                                              : (have[EK_TRI] ? EK_TRI : EK_QUAD);
    if (have[EK_TET] && have[EK_HEX])
        return vm_error_set(r->c.err, VM_ERR_UNSUPPORTED,
                            "%s: mixes tetrahedra and hexahedra (one element kind per mesh)",
                            path);
    if (r->nel == 0)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: no *ELEMENT of a supported type",
                            path);
    int64_t dup = 0;
    if (vm__idmap_finish(&r->nodes, &dup) != VM_OK)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: node %" PRId64 " is defined twice",
                            path, dup);
    if (vm__idmap_finish(&r->regions, &dup) != VM_OK)
        return vm_error_set(r->c.err, VM_ERR_FORMAT,
                            "%s: element %" PRId64 " is in two REGION_ element sets", path, dup);
    int shells_mixed = kind >= EK_TRI && have[EK_TRI] && have[EK_QUAD];
    m->kind = kind == EK_TET ? VM_TET4 : kind == EK_HEX ? VM_HEX8
              : kind == EK_TRI ? VM_TRI3 : VM_QUAD4;
    int corners = kind == EK_TET || kind == EK_QUAD ? 4 : kind == EK_HEX ? 8 : 3;
    vm__polys polys;
    memset(&polys, 0, sizeof polys);
    int use_regions = r->regions.n > 0;
    for (size_t i = 0; i < r->nel; i++) {
        const inp_elem *e = &r->el[i];
        if (!(e->kind == kind || (shells_mixed && e->kind >= EK_TRI))) continue;
        vm_index v[8];
        int nc = shells_mixed ? (e->kind == EK_TRI ? 3 : 4) : corners;
        for (int k = 0; k < nc; k++) {
            v[k] = vm__idmap_find(&r->nodes, e->nodes[k]);
            if (v[k] < 0) {
                vm__polys_free(&polys);
                return vm_error_set(r->c.err, VM_ERR_FORMAT,
                                    "%s: element %" PRId64 " uses undefined node %" PRId64,
                                    path, e->id, e->nodes[k]);
            }
        }
        int32_t region = e->ordinal;
        if (use_regions) {
            /* Binary search by hand: -1 is a valid region id, not "absent". */
            size_t lo = 0, hi = r->regions.n;
            while (lo < hi) {
                size_t md = lo + (hi - lo) / 2;
                if (r->regions.ids[md] < e->id)
                    lo = md + 1;
                else
                    hi = md;
            }
            region = lo < r->regions.n && r->regions.ids[lo] == e->id
                         ? (int32_t)r->regions.index[lo] : 0;
        }
        vm_status st = shells_mixed ? vm__polys_add(&polys, v, nc, region, r->c.err)
                                    : vm_mesh_add_cell(m, v, region, r->c.err);
        if (st) {
            vm__polys_free(&polys);
            return vm_error_set(r->c.err, st, "%s: out of memory for elements", path);
        }
    }
    if (shells_mixed) {
        vm_status st = vm__polys_finish(path, &polys, m, r->c.err);
        if (st) return st;
    }
    /* Drop nodes that serve only as mid-edge nodes of second-order elements. */
    if (r->nmid) {
        unsigned char *keep = calloc(m->npoints ? m->npoints : 1, 1);
        vm_index *map = malloc((m->npoints ? m->npoints : 1) * sizeof *map);
        if (!keep || !map) {
            free(keep);
            free(map);
            return vm_error_set(r->c.err, VM_ERR_NOMEM, "%s: out of memory", path);
        }
        for (size_t i = 0; i < m->npoints; i++)
            keep[i] = 1;
        for (size_t i = 0; i < r->nmid; i++) {
            vm_index ix = vm__idmap_find(&r->nodes, r->mid[i]);
            if (ix >= 0) keep[ix] = 0;
        }
        size_t nn = (size_t)vm_cell_nodes(m->kind);
        for (size_t i = 0; i < m->ncells * nn; i++)
            keep[m->cells[i]] = 1;
        size_t np = 0;
        for (size_t i = 0; i < m->npoints; i++) {
            map[i] = keep[i] ? (vm_index)np : -1;
            if (keep[i]) {
                memmove(m->points + 3 * np, m->points + 3 * i, 3 * sizeof(double));
                np++;
            }
        }
        m->npoints = np;
        for (size_t i = 0; i < m->ncells * nn; i++)
            m->cells[i] = map[m->cells[i]];
        free(keep);
        free(map);
    }
    return VM_OK;
}

vm_status vm_mesh_read_inp(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    inp_reader r;
    memset(&r, 0, sizeof r);
    r.m = m;
    vm__cur_init(&r.c, path, buf, len, 0, err);
    int seen_keyword = 0;
    const char *s;
    size_t n;
    while (!st) {
        const char *save = r.c.p;
        if (!vm__cur_line(&r.c, &s, &n)) break;
        size_t k = 0;
        while (k < n && isspace((unsigned char)s[k]))
            k++;
        if (k == n) continue;
        s += k;
        n -= k;
        if (n >= 2 && s[0] == '*' && s[1] == '*') continue;
        if (s[0] != '*') {
            r.c.p = save;
            st = vm__cur_fail(&r.c, VM_ERR_FORMAT, seen_keyword ? "data line outside a keyword"
                                                                : "not an Abaqus input file "
                                                                  "(no *keyword line first)");
            break;
        }
        seen_keyword = 1;
        char kw[40], val[96];
        kw_name(s, n, kw, sizeof kw);
        if (strcmp(kw, "NODE") == 0) {
            if (kw_param(s, n, "SYSTEM", val, sizeof val) && strcmp(val, "R") != 0) {
                r.c.p = save;
                st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED, "*NODE, SYSTEM=%s is not supported",
                                  val);
                break;
            }
            st = read_nodes(&r);
        } else if (strcmp(kw, "ELEMENT") == 0) {
            char type[40] = "";
            kw_param(s, n, "TYPE", type, sizeof type);
            int nodes = 0, corners = 0, ek = elem_kind(type, &nodes, &corners);
            if (ek == EK_NONE) {
                st = skip_data(&r); /* beams, springs, masses, ... are not mesh cells */
                continue;
            }
            int32_t ordinal = 0;
            if (kw_param(s, n, "ELSET", val, sizeof val)) {
                ordinal = elset_ordinal(&r, val, &st);
                if (st) break;
            }
            st = read_elements(&r, ek, nodes, corners, ordinal);
        } else if (strcmp(kw, "ELSET") == 0) {
            int32_t region = 0;
            int is_region = kw_param(s, n, "ELSET", val, sizeof val) &&
                            vm__region_parse(val, strlen(val), &region) == VM_OK;
            st = read_elset(&r, region, is_region, kw_param(s, n, "GENERATE", val, sizeof val));
        } else if (strcmp(kw, "INCLUDE") == 0) {
            r.c.p = save;
            st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED,
                              "*INCLUDE is not supported (merge the included file first)");
        } else {
            st = skip_data(&r);
        }
    }
    if (!st) st = build_mesh(&r);
    vm__idmap_free(&r.nodes);
    vm__idmap_free(&r.regions);
    free(r.el);
    free(r.mid);
    free(r.elset_names);
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}
