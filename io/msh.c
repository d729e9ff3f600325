/* SPDX-License-Identifier: BSD-3-Clause */
/* io/msh.c — Gmsh MSH files, ASCII versions 4.1 and 2.2: writer with one elementary entity
 * and one named physical group per region, reader for both versions. Follows the Gmsh
 * reference manual, section "MSH file format" (4.1) and its "Legacy formats" (2.2). */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "mesh_util.h"

/* Gmsh element type numbers for our kinds (node order equals VTK's for all four). */
static int gmsh_type(vm_cell_kind k) {
    switch (k) {
    case VM_TRI3: return 2;
    case VM_QUAD4: return 3;
    case VM_TET4: return 4;
    case VM_HEX8: return 5;
    }
    return 0;
}

/* Nodes per Gmsh element type 1..31 (0: unknown). */
static int gmsh_type_nodes(int64_t t) {
    static const int n[32] = {0,  2,  3,  4,  4,  8,  6, 5,  3,  6,  9,  10, 27, 18, 14, 1,
                              8,  20, 15, 13, 9,  10, 12, 15, 15, 21, 4,  5,  6,  20, 35, 56};
    return t >= 1 && t < 32 ? n[t] : 0;
}

static int gmsh_type_dim(int64_t t) {
    switch (t) {
    case 15: return 0;
    case 1: case 8: case 26: case 27: case 28: return 1;
    case 2: case 3: case 9: case 10: case 16: case 20: case 21: case 22: case 23: case 24:
    case 25: return 2;
    default: return 3;
    }
}

static vm_status write_msh(const char *path, const vm_mesh *m, int version,
                           const vm_mesh_write_options *opt, vm_error *err);
static vm_status write_msh_nodes(const char *path, const vm_mesh *m, int version, int type,
                                 size_t nn, const vm_mesh_write_options *opt, vm_error *err);

/* Gmsh's second-order types and their node order as positions among the corners and VTK's
 * edges (Gmsh reference manual, "Node ordering": tet10 ends with edges 3-2, 3-1; hex20 goes
 * 0-1, 0-3, 0-4, 1-2, 1-5, 2-3, 2-6, 3-7, 4-5, 4-7, 5-6, 6-7). */
enum { GMSH_TET10 = 11, GMSH_HEX20 = 17 };
static const int GMSH_TET10_ORDER[10] = {0, 1, 2, 3, 4, 5, 6, 7, 9, 8};
static const int GMSH_HEX20_ORDER[20] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  11,
                                         16, 9,  17, 10, 18, 19, 12, 15, 13, 14};

vm_status vm_mesh_write_msh(const char *path, const vm_mesh *m, int version, vm_error *err) {
    if (version != 41 && version != 22)
        return vm_error_set(err, VM_ERR_ARG, "%s: MSH version %d (expected 41 or 22)", path,
                            version);
    vm_mesh_write_options opt;
    vm_mesh_write_options_init(&opt);
    return write_msh(path, m, version, &opt, err);
}

vm_status vm__write_msh(const char *path, const vm_mesh *m, const vm_mesh_write_options *opt,
                        vm_error *err) {
    return write_msh(path, m, opt->format == VM_MESH_MSH2 ? 22 : 41, opt, err);
}

/* Order 1 writes m; order 2 its second-order view (tet10 / hex20, straight edges). */
static vm_status write_msh(const char *path, const vm_mesh *m, int version,
                           const vm_mesh_write_options *opt, vm_error *err) {
    int type = gmsh_type(m->kind);
    if (!type)
        return vm_error_set(err, VM_ERR_ARG, "%s: mesh has unknown cell kind %d", path,
                            (int)m->kind);
    vm_status st = vm__check_nodes(m, VM_ERR_FORMAT, path, err);
    if (st) return st;
    if (opt->order != 2)
        return write_msh_nodes(path, m, version, type, (size_t)vm_cell_nodes(m->kind), opt,
                               err);
    int tet = m->kind == VM_TET4;
    vm__quadratic q;
    st = vm__quadratic_make(path, m, tet ? GMSH_TET10_ORDER : GMSH_HEX20_ORDER, opt, &q, err);
    if (st) return st;
    st = write_msh_nodes(path, &q.view, version, tet ? GMSH_TET10 : GMSH_HEX20, tet ? 10 : 20,
                         opt, err);
    vm__quadratic_free(&q);
    return st;
}

/* Writes m's cells as Gmsh elements of type with nn nodes each. */
static vm_status write_msh_nodes(const char *path, const vm_mesh *m, int version, int type,
                                 size_t nn, const vm_mesh_write_options *opt, vm_error *err) {
    vm_status st;
    int dim = m->kind == VM_TET4 || m->kind == VM_HEX8 ? 3 : 2;
    size_t nreg = 0;
    int32_t *regions = NULL;
    st = vm__distinct_regions(path, m, &regions, &nreg, err);
    if (st) return st;
    int positive = nreg > 0 && regions[0] >= 1;
    double *box = calloc(nreg ? 6 * nreg : 1, sizeof *box);
    size_t *count = calloc(nreg ? nreg : 1, sizeof *count);
    long *slot = malloc((m->ncells ? m->ncells : 1) * sizeof *slot);
    if (!box || !count || !slot) {
        free(regions);
        free(box);
        free(count);
        free(slot);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    }
    for (size_t r = 0; r < nreg; r++)
        for (int d = 0; d < 3; d++) {
            box[6 * r + (size_t)d] = INFINITY;
            box[6 * r + 3 + (size_t)d] = -INFINITY;
        }
    for (size_t c = 0; c < m->ncells; c++) {
        long r = vm__region_slot(regions, nreg, m->region[c]);
        slot[c] = r;
        count[r]++;
        for (size_t k = 0; k < nn; k++) {
            const double *p = m->points + 3 * (size_t)m->cells[c * nn + k];
            for (int d = 0; d < 3; d++) {
                double *b = box + 6 * (size_t)r;
                if (p[d] < b[d]) b[d] = p[d];
                if (p[d] > b[3 + d]) b[3 + d] = p[d];
            }
        }
    }
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) goto done;
    FILE *fp = o.fp;
    /* Progress: node by node, then element by element. */
    vm__out_meter(&o, opt->progress, opt->progress_user, (double)m->npoints + m->ncells);
    fprintf(fp, "$MeshFormat\n%s 0 8\n$EndMeshFormat\n", version == 41 ? "4.1" : "2.2");
    fprintf(fp, "$PhysicalNames\n%zu\n", nreg);
    for (size_t r = 0; r < nreg; r++) {
        char name[32];
        vm__region_name(regions[r], name, sizeof name);
        fprintf(fp, "%d %lld \"%s\"\n", dim, positive ? (long long)regions[r] : (long long)r + 1,
                name);
    }
    fprintf(fp, "$EndPhysicalNames\n");
    if (version == 41) {
        fprintf(fp, "$Entities\n0 0 %zu %zu\n", dim == 2 ? nreg : 0, dim == 3 ? nreg : 0);
        for (size_t r = 0; r < nreg; r++) {
            long long tag = positive ? (long long)regions[r] : (long long)r + 1;
            const double *b = box + 6 * r;
            fprintf(fp, "%lld %.17g %.17g %.17g %.17g %.17g %.17g 1 %lld 0\n", tag, b[0], b[1],
                    b[2], b[3], b[4], b[5], tag);
        }
        fprintf(fp, "$EndEntities\n");
        /* All nodes in one block on the first entity; elements find nodes by tag. */
        long long first = nreg ? (positive ? (long long)regions[0] : 1) : 1;
        fprintf(fp, "$Nodes\n%d %zu %d %zu\n", m->npoints ? 1 : 0, m->npoints,
                m->npoints ? 1 : 0, m->npoints);
        if (m->npoints) {
            fprintf(fp, "%d %lld 0 %zu\n", dim, first, m->npoints);
            for (size_t i = 0; i < m->npoints; i++)
                fprintf(fp, "%zu\n", i + 1);
            for (size_t i = 0; i < m->npoints; i++) {
                const double *p = m->points + 3 * i;
                fprintf(fp, "%.17g %.17g %.17g\n", p[0], p[1], p[2]);
                vm__out_step(&o, 1.0);
            }
        }
        fprintf(fp, "$EndNodes\n$Elements\n%zu %zu %d %zu\n", nreg, m->ncells,
                m->ncells ? 1 : 0, m->ncells);
        for (size_t r = 0; r < nreg; r++) {
            fprintf(fp, "%d %lld %d %zu\n", dim,
                    positive ? (long long)regions[r] : (long long)r + 1, type, count[r]);
            for (size_t c = 0; c < m->ncells; c++) {
                if (slot[c] != (long)r) continue;
                fprintf(fp, "%zu", c + 1);
                for (size_t k = 0; k < nn; k++)
                    fprintf(fp, " %lld", (long long)m->cells[c * nn + k] + 1);
                fputc('\n', fp);
                vm__out_step(&o, 1.0);
            }
        }
        fprintf(fp, "$EndElements\n");
    } else {
        fprintf(fp, "$Nodes\n%zu\n", m->npoints);
        for (size_t i = 0; i < m->npoints; i++) {
            const double *p = m->points + 3 * i;
            fprintf(fp, "%zu %.17g %.17g %.17g\n", i + 1, p[0], p[1], p[2]);
            vm__out_step(&o, 1.0);
        }
        fprintf(fp, "$EndNodes\n$Elements\n%zu\n", m->ncells);
        for (size_t c = 0; c < m->ncells; c++) {
            long long tag = positive ? (long long)m->region[c] : (long long)slot[c] + 1;
            fprintf(fp, "%zu %d 2 %lld %lld", c + 1, type, tag, tag);
            for (size_t k = 0; k < nn; k++)
                fprintf(fp, " %lld", (long long)m->cells[c * nn + k] + 1);
            fputc('\n', fp);
            vm__out_step(&o, 1.0);
        }
        fprintf(fp, "$EndElements\n");
    }
    st = vm__out_commit(&o, err);
done:
    free(regions);
    free(box);
    free(count);
    free(slot);
    return st;
}

/* ======================================================================================= */
/* Reader                                                                                   */
/* ======================================================================================= */

typedef struct msh_elem {
    int64_t tag;
    int dim, type;
    int64_t phys, entity; /* phys 0: none */
    int64_t nodes[8];
} msh_elem;

typedef struct msh_name {
    int dim;
    int64_t tag;
    int32_t region; /* parsed from REGION_r */
    int is_region;
} msh_name;

typedef struct msh_entity {
    int dim;
    int64_t tag, phys;
} msh_entity;

typedef struct msh_reader {
    vm__cursor c;
    vm_mesh *m;
    int version; /* 22 or 41 */
    vm__idmap nodes;
    msh_elem *el;
    size_t nel, capel;
    msh_name *names;
    size_t nnames, capnames;
    msh_entity *ent;
    size_t nent, capent;
} msh_reader;

/* Reads the next token and requires it to be word. */
static vm_status expect(msh_reader *r, const char *word) {
    const char *t;
    size_t n;
    if (!vm__cur_token(&r->c, &t, &n))
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "file ends where %s was expected", word);
    if (!vm__tok_is(t, n, word))
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "expected %s, found \"%.*s\"", word,
                            (int)(n > 40 ? 40 : n), t);
    return VM_OK;
}

static vm_status skip_section(msh_reader *r, const char *name, size_t nlen) {
    char end[80];
    snprintf(end, sizeof end, "$End%.*s", (int)(nlen > 60 ? 60 : nlen), name);
    const char *t;
    size_t n;
    while (vm__cur_token(&r->c, &t, &n))
        if (vm__tok_is(t, n, end)) return VM_OK;
    return vm__cur_fail(&r->c, VM_ERR_FORMAT, "section $%.*s has no %s", (int)(nlen > 60 ? 60 : nlen),
                        name, end);
}

static vm_status read_format(msh_reader *r) {
    const char *t;
    size_t n;
    if (!vm__cur_token(&r->c, &t, &n))
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "file ends in $MeshFormat");
    double v;
    if (vm__parse_double_tok(t, n, &v) != VM_OK)
        return vm__cur_fail(&r->c, VM_ERR_FORMAT, "bad MSH version \"%.*s\"",
                            (int)(n > 20 ? 20 : n), t);
    if (v == 2.2 || v == 2.1 || v == 2.0)
        r->version = 22;
    else if (v == 4.1)
        r->version = 41;
    else
        return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED,
                            "MSH version %g is not supported (2.2 and 4.1 are)", v);
    int64_t ft, ds;
    vm_status st = vm__cur_int(&r->c, 0, 1, "file type", &ft);
    if (!st) st = vm__cur_int(&r->c, 1, 16, "data size", &ds);
    if (st) return st;
    if (ft != 0)
        return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED,
                            "binary MSH is not supported (save it as ASCII)");
    return expect(r, "$EndMeshFormat");
}

static vm_status read_physical_names(msh_reader *r) {
    int64_t n;
    vm_status st = vm__cur_int(&r->c, 0, INT32_MAX, "number of physical names", &n);
    if (!st) st = vm__check_count(&r->c, (uint64_t)n, 6, "physical names");
    for (int64_t i = 0; i < n && !st; i++) {
        int64_t dim, tag;
        st = vm__cur_int(&r->c, 0, 3, "physical dimension", &dim);
        if (!st) st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "physical tag", &tag);
        if (st) break;
        /* The name is the rest of the line, in double quotes. */
        const char *s;
        size_t len;
        if (!vm__cur_line(&r->c, &s, &len)) {
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "file ends in $PhysicalNames");
            break;
        }
        const char *q1 = memchr(s, '"', len);
        const char *q2 = q1 ? memchr(q1 + 1, '"', (size_t)(s + len - q1 - 1)) : NULL;
        if (!q2) {
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "physical name is not in double quotes");
            break;
        }
        st = vm__grow((void **)&r->names, &r->capnames, r->nnames + 1, sizeof *r->names,
                      r->c.err);
        if (st) break;
        msh_name *nm = &r->names[r->nnames++];
        nm->dim = (int)dim;
        nm->tag = tag;
        nm->is_region = vm__region_parse(q1 + 1, (size_t)(q2 - q1 - 1), &nm->region) == VM_OK;
    }
    return st ? st : expect(r, "$EndPhysicalNames");
}

static vm_status read_entities(msh_reader *r) {
    int64_t cnt[4];
    vm_status st = VM_OK;
    for (int d = 0; d < 4 && !st; d++)
        st = vm__cur_int(&r->c, 0, INT32_MAX, "number of entities", &cnt[d]);
    for (int d = 0; d < 4 && !st; d++) {
        st = vm__check_count(&r->c, (uint64_t)cnt[d], 8, "entities");
        for (int64_t i = 0; i < cnt[d] && !st; i++) {
            int64_t tag, np = 0, ph, nb, dummy;
            double x;
            st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "entity tag", &tag);
            for (int k = 0; k < (d == 0 ? 3 : 6) && !st; k++)
                st = vm__cur_double(&r->c, "entity coordinate", &x);
            if (!st) st = vm__cur_int(&r->c, 0, INT32_MAX, "number of physical tags", &np);
            int64_t first = 0;
            for (int64_t k = 0; k < np && !st; k++) {
                st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "physical tag", &ph);
                if (k == 0) first = ph;
            }
            if (!st && d > 0) {
                st = vm__cur_int(&r->c, 0, INT32_MAX, "number of bounding entities", &nb);
                for (int64_t k = 0; k < nb && !st; k++)
                    st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "bounding entity", &dummy);
            }
            if (st) break;
            st = vm__grow((void **)&r->ent, &r->capent, r->nent + 1, sizeof *r->ent, r->c.err);
            if (st) break;
            r->ent[r->nent].dim = d;
            r->ent[r->nent].tag = tag;
            r->ent[r->nent].phys = first;
            r->nent++;
        }
    }
    return st ? st : expect(r, "$EndEntities");
}

static vm_status add_node(msh_reader *r, int64_t tag, const double xyz[3]) {
    vm_index ix = vm_mesh_add_point(r->m, xyz, r->c.err);
    if (ix < 0) return vm__cur_fail(&r->c, VM_ERR_NOMEM, "out of memory for nodes");
    vm_status st = vm__idmap_add(&r->nodes, tag, ix, r->c.err);
    return st ? vm__cur_fail(&r->c, st, "out of memory for nodes") : VM_OK;
}

static vm_status read_nodes(msh_reader *r) {
    vm_status st = VM_OK;
    if (r->version == 22) {
        int64_t n;
        st = vm__cur_int(&r->c, 0, INT64_MAX, "number of nodes", &n);
        if (!st) st = vm__check_count(&r->c, (uint64_t)n, 8, "nodes");
        for (int64_t i = 0; i < n && !st; i++) {
            int64_t tag;
            double p[3];
            st = vm__cur_int(&r->c, 1, INT64_MAX, "node tag", &tag);
            for (int d = 0; d < 3 && !st; d++)
                st = vm__cur_double(&r->c, "node coordinate", &p[d]);
            if (!st) st = add_node(r, tag, p);
        }
        return st ? st : expect(r, "$EndNodes");
    }
    int64_t nblocks, nnodes, lo, hi;
    st = vm__cur_int(&r->c, 0, INT64_MAX, "number of node blocks", &nblocks);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "number of nodes", &nnodes);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "minimum node tag", &lo);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "maximum node tag", &hi);
    if (!st) st = vm__check_count(&r->c, (uint64_t)nnodes, 8, "nodes");
    if (!st) st = vm__check_count(&r->c, (uint64_t)nblocks, 8, "node blocks");
    int64_t *tags = NULL;
    size_t captags = 0;
    for (int64_t b = 0; b < nblocks && !st; b++) {
        int64_t dim, etag, param, n = 0;
        st = vm__cur_int(&r->c, 0, 3, "entity dimension", &dim);
        if (!st) st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "entity tag", &etag);
        if (!st) st = vm__cur_int(&r->c, 0, 1, "parametric flag", &param);
        if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "nodes in block", &n);
        if (!st) st = vm__check_count(&r->c, (uint64_t)n, 8, "nodes");
        if (!st) st = vm__grow((void **)&tags, &captags, (size_t)n, sizeof *tags, r->c.err);
        for (int64_t i = 0; i < n && !st; i++)
            st = vm__cur_int(&r->c, 1, INT64_MAX, "node tag", &tags[i]);
        for (int64_t i = 0; i < n && !st; i++) {
            double p[3], u;
            for (int d = 0; d < 3 && !st; d++)
                st = vm__cur_double(&r->c, "node coordinate", &p[d]);
            for (int64_t k = 0; k < (param ? dim : 0) && !st; k++)
                st = vm__cur_double(&r->c, "parametric coordinate", &u);
            if (!st) st = add_node(r, tags[i], p);
        }
    }
    free(tags);
    if (!st && r->m->npoints != (size_t)nnodes)
        st = vm__cur_fail(&r->c, VM_ERR_FORMAT, "$Nodes announces %" PRId64 " nodes, has %zu",
                          nnodes, r->m->npoints);
    return st ? st : expect(r, "$EndNodes");
}

static int64_t entity_phys(const msh_reader *r, int dim, int64_t tag) {
    for (size_t i = 0; i < r->nent; i++)
        if (r->ent[i].dim == dim && r->ent[i].tag == tag) return r->ent[i].phys;
    return 0;
}

static vm_status add_elem(msh_reader *r, int64_t tag, int64_t type, int64_t phys,
                          int64_t entity, const int64_t *nodes) {
    int dim = gmsh_type_dim(type);
    if (type < 2 || type > 5) {
        if (dim == 3)
            return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED,
                                "element type %" PRId64 " is not supported (volume elements: "
                                "4-node tetrahedra and 8-node hexahedra)", type);
        if (dim == 2)
            return vm__cur_fail(&r->c, VM_ERR_UNSUPPORTED,
                                "element type %" PRId64 " is not supported (surface elements: "
                                "3-node triangles and 4-node quadrangles)", type);
        return VM_OK; /* points and lines are not mesh cells */
    }
    vm_status st = vm__grow((void **)&r->el, &r->capel, r->nel + 1, sizeof *r->el, r->c.err);
    if (st) return vm__cur_fail(&r->c, st, "out of memory for elements");
    msh_elem *e = &r->el[r->nel++];
    memset(e, 0, sizeof *e);
    e->tag = tag;
    e->type = (int)type;
    e->dim = dim;
    e->phys = phys;
    e->entity = entity;
    memcpy(e->nodes, nodes, (size_t)gmsh_type_nodes(type) * sizeof(int64_t));
    return VM_OK;
}

static vm_status read_elements(msh_reader *r) {
    vm_status st = VM_OK;
    int64_t nodes[64];
    if (r->version == 22) {
        int64_t n;
        st = vm__cur_int(&r->c, 0, INT64_MAX, "number of elements", &n);
        if (!st) st = vm__check_count(&r->c, (uint64_t)n, 8, "elements");
        for (int64_t i = 0; i < n && !st; i++) {
            int64_t tag, type, ntags = 0, t0 = 0, t1 = 0, x;
            st = vm__cur_int(&r->c, 1, INT64_MAX, "element tag", &tag);
            if (!st) st = vm__cur_int(&r->c, 1, 31, "element type", &type);
            if (!st) st = vm__cur_int(&r->c, 0, 64, "number of tags", &ntags);
            for (int64_t k = 0; k < ntags && !st; k++) {
                st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "element tag value", &x);
                if (k == 0) t0 = x;
                if (k == 1) t1 = x;
            }
            int nn = st ? 0 : gmsh_type_nodes(type);
            for (int k = 0; k < nn && !st; k++)
                st = vm__cur_int(&r->c, 1, INT64_MAX, "element node", &nodes[k]);
            if (!st) st = add_elem(r, tag, type, t0, t1, nodes);
        }
        return st ? st : expect(r, "$EndElements");
    }
    int64_t nblocks, nel, lo, hi;
    st = vm__cur_int(&r->c, 0, INT64_MAX, "number of element blocks", &nblocks);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "number of elements", &nel);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "minimum element tag", &lo);
    if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "maximum element tag", &hi);
    if (!st) st = vm__check_count(&r->c, (uint64_t)nel, 4, "elements");
    if (!st) st = vm__check_count(&r->c, (uint64_t)nblocks, 8, "element blocks");
    for (int64_t b = 0; b < nblocks && !st; b++) {
        int64_t dim, etag, type, n;
        st = vm__cur_int(&r->c, 0, 3, "entity dimension", &dim);
        if (!st) st = vm__cur_int(&r->c, INT32_MIN, INT32_MAX, "entity tag", &etag);
        if (!st) st = vm__cur_int(&r->c, 1, 31, "element type", &type);
        if (!st) st = vm__cur_int(&r->c, 0, INT64_MAX, "elements in block", &n);
        if (!st) st = vm__check_count(&r->c, (uint64_t)n, 4, "elements");
        if (st) break;
        if (gmsh_type_dim(type) != dim) {
            st = vm__cur_fail(&r->c, VM_ERR_FORMAT,
                              "element type %" PRId64 " in a block of dimension %" PRId64, type,
                              dim);
            break;
        }
        int64_t phys = entity_phys(r, (int)dim, etag);
        int nn = gmsh_type_nodes(type);
        for (int64_t i = 0; i < n && !st; i++) {
            int64_t tag;
            st = vm__cur_int(&r->c, 1, INT64_MAX, "element tag", &tag);
            for (int k = 0; k < nn && !st; k++)
                st = vm__cur_int(&r->c, 1, INT64_MAX, "element node", &nodes[k]);
            if (!st) st = add_elem(r, tag, type, phys, etag, nodes);
        }
    }
    return st ? st : expect(r, "$EndElements");
}

static int cmp_elem(const void *a, const void *b) {
    int64_t x = ((const msh_elem *)a)->tag, y = ((const msh_elem *)b)->tag;
    return (x > y) - (x < y);
}

static vm_status build_mesh(msh_reader *r) {
    const char *path = r->c.path;
    vm_mesh *m = r->m;
    int have[6] = {0, 0, 0, 0, 0, 0};
    for (size_t i = 0; i < r->nel; i++)
        have[r->el[i].type] = 1;
    if (have[4] && have[5])
        return vm_error_set(r->c.err, VM_ERR_UNSUPPORTED,
                            "%s: mixes tetrahedra and hexahedra (one element kind per mesh)",
                            path);
    if (r->nel == 0)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: no triangles, quadrangles, "
                            "tetrahedra or hexahedra", path);
    int64_t dup = 0;
    if (vm__idmap_finish(&r->nodes, &dup) != VM_OK)
        return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: node %" PRId64 " is defined twice",
                            path, dup);
    int vol = have[4] || have[5];
    int mixed = !vol && have[2] && have[3];
    m->kind = have[4] ? VM_TET4 : have[5] ? VM_HEX8 : have[2] ? VM_TRI3 : VM_QUAD4;
    qsort(r->el, r->nel, sizeof *r->el, cmp_elem);
    vm__polys polys;
    memset(&polys, 0, sizeof polys);
    for (size_t i = 0; i < r->nel; i++) {
        const msh_elem *e = &r->el[i];
        if (e->dim != (vol ? 3 : 2)) continue;
        if (i > 0 && r->el[i - 1].tag == e->tag && r->el[i - 1].dim == e->dim) {
            vm__polys_free(&polys);
            return vm_error_set(r->c.err, VM_ERR_FORMAT, "%s: element %" PRId64 " is defined "
                                "twice", path, e->tag);
        }
        int nn = gmsh_type_nodes(e->type);
        vm_index v[8];
        for (int k = 0; k < nn; k++) {
            v[k] = vm__idmap_find(&r->nodes, e->nodes[k]);
            if (v[k] < 0) {
                vm__polys_free(&polys);
                return vm_error_set(r->c.err, VM_ERR_FORMAT,
                                    "%s: element %" PRId64 " uses undefined node %" PRId64,
                                    path, e->tag, e->nodes[k]);
            }
        }
        int64_t region = e->phys ? e->phys : e->entity;
        for (size_t k = 0; k < r->nnames; k++)
            if (e->phys && r->names[k].tag == e->phys && r->names[k].dim == e->dim &&
                r->names[k].is_region)
                region = r->names[k].region;
        if (region < INT32_MIN || region > INT32_MAX) region = 0;
        vm_status st = mixed ? vm__polys_add(&polys, v, nn, (int32_t)region, r->c.err)
                             : vm_mesh_add_cell(m, v, (int32_t)region, r->c.err);
        if (st) {
            vm__polys_free(&polys);
            return vm_error_set(r->c.err, st, "%s: out of memory for elements", path);
        }
    }
    return mixed ? vm__polys_finish(path, &polys, m, r->c.err) : VM_OK;
}

vm_status vm_mesh_read_msh(const char *path, vm_mesh *m, vm_error *err) {
    vm_mesh_init(m, VM_TET4);
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm__read_file(path, VM__MESH_MAX_FILE, &buf, &len, err);
    if (st) return st;
    msh_reader r;
    memset(&r, 0, sizeof r);
    r.m = m;
    vm__cur_init(&r.c, path, buf, len, 0, err);
    const char *t;
    size_t n;
    int seen_nodes = 0, seen_elements = 0;
    while (!st && vm__cur_token(&r.c, &t, &n)) {
        if (n < 2 || t[0] != '$') {
            st = vm__cur_fail(&r.c, VM_ERR_FORMAT, r.version ? "expected a $Section, found "
                                                               "\"%.*s\""
                                                             : "not a Gmsh MSH file (\"%.*s\")",
                              (int)(n > 40 ? 40 : n), t);
            break;
        }
        if (!r.version && !vm__tok_is(t, n, "$MeshFormat")) {
            st = vm__cur_fail(&r.c, VM_ERR_FORMAT, "not a Gmsh MSH file (no $MeshFormat)");
            break;
        }
        if (vm__tok_is(t, n, "$MeshFormat")) {
            st = read_format(&r);
        } else if (vm__tok_is(t, n, "$PhysicalNames")) {
            st = read_physical_names(&r);
        } else if (vm__tok_is(t, n, "$Entities") && r.version == 41) {
            st = read_entities(&r);
        } else if (vm__tok_is(t, n, "$Nodes")) {
            if (seen_nodes++)
                st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED, "more than one $Nodes section");
            else
                st = read_nodes(&r);
        } else if (vm__tok_is(t, n, "$Elements")) {
            if (seen_elements++)
                st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED, "more than one $Elements section");
            else
                st = read_elements(&r);
        } else if (vm__tok_is(t, n, "$PartitionedEntities")) {
            st = vm__cur_fail(&r.c, VM_ERR_UNSUPPORTED, "partitioned meshes are not supported");
        } else {
            st = skip_section(&r, t + 1, n - 1);
        }
    }
    if (!st && !r.version)
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: not a Gmsh MSH file (empty)", path);
    if (!st && (!seen_nodes || !seen_elements))
        st = vm_error_set(err, VM_ERR_FORMAT, "%s: no $Nodes or no $Elements section", path);
    if (!st) st = build_mesh(&r);
    vm__idmap_free(&r.nodes);
    free(r.el);
    free(r.names);
    free(r.ent);
    free(buf);
    if (st) vm_mesh_free(m);
    return st;
}
