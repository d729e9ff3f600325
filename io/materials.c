/* SPDX-License-Identifier: BSD-3-Clause */
/* io/materials.c — the materials table of the solver decks (`--materials FILE`): a CSV of
 * label, name, E, nu, density, one row per label (RFC 4180 without quoting), checked whole
 * before any meshing; and the material a deck writes for a region (the table's, else a
 * placeholder named after the region). */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "io_util.h"
#include "mesh_util.h"
#include "volmesh/io.h"

/* Largest materials file read (a table of labels, not a mesh). */
#define MATERIALS_MAX_FILE ((size_t)1 << 24)
/* Columns of a row: label, name, E, nu, density. */
enum { MATERIAL_COLUMNS = 5 };

/* The placeholder of a region without a row: steel-like in N, mm, t (as the INP deck always
 * wrote), so that a deck solves as written. */
static const double PLACEHOLDER_E = 210000.0, PLACEHOLDER_NU = 0.3,
                    PLACEHOLDER_DENSITY = 7.85e-9;

/* A name every deck takes: a letter, then letters, digits and '_' (Abaqus names; LS-DYNA
 * titles and FEBio names take them as they are). */
static int name_ok(const char *s, size_t n) {
    if (n == 0 || n >= sizeof(((vm_material *)0)->name) || !isalpha((unsigned char)s[0]))
        return 0;
    for (size_t i = 1; i < n; i++)
        if (!isalnum((unsigned char)s[i]) && s[i] != '_') return 0;
    return 1;
}

/* Splits a line at commas into at most max trimmed fields. Returns the field count (max + 1
 * when there are more). */
static int split_fields(const char *s, size_t len, const char **f, size_t *fl, int max) {
    int n = 0;
    const char *p = s, *end = s + len;
    for (;;) {
        const char *q = memchr(p, ',', (size_t)(end - p));
        const char *a = p, *b = q ? q : end;
        while (a < b && isspace((unsigned char)*a))
            a++;
        while (b > a && isspace((unsigned char)b[-1]))
            b--;
        if (n == max) return max + 1;
        f[n] = a;
        fl[n++] = (size_t)(b - a);
        if (!q) return n;
        p = q + 1;
    }
}

/* Checks one row's values and appends it. */
static vm_status add_row(vm__cursor *c, const char **f, const size_t *fl, vm_material **out,
                         size_t *n, size_t *cap) {
    int64_t label = 0;
    double e = 0, nu = 0, rho = 0;
    if (vm__parse_int_tok(f[0], fl[0], &label) || label < INT32_MIN || label > INT32_MAX)
        return vm__cur_fail(c, VM_ERR_FORMAT, "label \"%.*s\" is not an integer",
                            (int)(fl[0] > 30 ? 30 : fl[0]), f[0]);
    if (!name_ok(f[1], fl[1]))
        return vm__cur_fail(c, VM_ERR_FORMAT,
                            "name \"%.*s\" must be a letter then letters, digits or _ (at "
                            "most 63)", (int)(fl[1] > 70 ? 70 : fl[1]), f[1]);
    if (vm__parse_double_tok(f[2], fl[2], &e) || !(e > 0))
        return vm__cur_fail(c, VM_ERR_FORMAT, "E \"%.*s\" is not a number > 0",
                            (int)(fl[2] > 30 ? 30 : fl[2]), f[2]);
    if (vm__parse_double_tok(f[3], fl[3], &nu) || !(nu > -1 && nu < 0.5))
        return vm__cur_fail(c, VM_ERR_FORMAT, "nu \"%.*s\" is not a number in (-1, 0.5)",
                            (int)(fl[3] > 30 ? 30 : fl[3]), f[3]);
    if (vm__parse_double_tok(f[4], fl[4], &rho) || !(rho >= 0))
        return vm__cur_fail(c, VM_ERR_FORMAT, "density \"%.*s\" is not a number >= 0",
                            (int)(fl[4] > 30 ? 30 : fl[4]), f[4]);
    for (size_t i = 0; i < *n; i++) {
        if ((*out)[i].label == (int32_t)label)
            return vm__cur_fail(c, VM_ERR_FORMAT, "label %lld is given twice (one row a label)",
                                (long long)label);
        if (strlen((*out)[i].name) == fl[1] && vm__tok_is(f[1], fl[1], (*out)[i].name))
            return vm__cur_fail(c, VM_ERR_FORMAT,
                                "name %s is given to labels %d and %lld (one material a label)",
                                (*out)[i].name, (int)(*out)[i].label, (long long)label);
    }
    vm_status st = vm__grow((void **)out, cap, *n + 1, sizeof **out, c->err);
    if (st) return vm__cur_fail(c, st, "out of memory");
    vm_material *m = &(*out)[(*n)++];
    memset(m, 0, sizeof *m);
    m->label = (int32_t)label;
    memcpy(m->name, f[1], fl[1]);
    m->young = e;
    m->poisson = nu;
    m->density = rho;
    return VM_OK;
}

vm_status vm_materials_read(const char *path, vm_material **out, size_t *n, vm_error *err) {
    *out = NULL;
    *n = 0;
    unsigned char *buf = NULL;
    size_t len = 0, cap = 0;
    vm_status st = vm__read_file(path, MATERIALS_MAX_FILE, &buf, &len, err);
    if (st) return st;
    vm__cursor c;
    vm__cur_init(&c, path, buf, len, 0, err);
    const char *s;
    size_t sl;
    int rows = 0;
    while (!st) {
        const char *save = c.p;
        if (!vm__cur_line(&c, &s, &sl)) break;
        while (sl > 0 && isspace((unsigned char)*s))
            s++, sl--;
        if (sl == 0 || s[0] == '#') continue;
        const char *f[MATERIAL_COLUMNS];
        size_t fl[MATERIAL_COLUMNS];
        int nf = split_fields(s, sl, f, fl, MATERIAL_COLUMNS);
        c.p = save; /* messages name this line */
        if (rows++ == 0 && nf >= 1 && vm__tok_is(f[0], fl[0], "label")) {
            vm__cur_line(&c, &s, &sl); /* the header */
            continue;
        }
        if (nf != MATERIAL_COLUMNS)
            st = vm__cur_fail(&c, VM_ERR_FORMAT,
                              "expected 5 fields label,name,E,nu,density, found %s%d",
                              nf > MATERIAL_COLUMNS ? "more than " : "",
                              nf > MATERIAL_COLUMNS ? MATERIAL_COLUMNS : nf);
        else
            st = add_row(&c, f, fl, out, n, &cap);
        if (!st) vm__cur_line(&c, &s, &sl);
    }
    if (!st && *n == 0)
        st = vm_error_set(err, VM_ERR_EMPTY, "%s: no material rows (label,name,E,nu,density)",
                          path);
    free(buf);
    if (st) {
        free(*out);
        *out = NULL;
        *n = 0;
    }
    return st;
}

void vm_materials_free(vm_material *m) {
    free(m);
}

void vm__material_of_region(const vm_mesh_write_options *opt, int32_t region,
                            vm_material *out) {
    for (size_t i = 0; opt && i < opt->nmaterials; i++)
        if (opt->materials[i].label == region) {
            *out = opt->materials[i];
            return;
        }
    memset(out, 0, sizeof *out);
    out->label = region;
    char rn[32];
    vm__region_name(region, rn, sizeof rn);
    snprintf(out->name, sizeof out->name, "MAT_%s", rn);
    out->young = PLACEHOLDER_E;
    out->poisson = PLACEHOLDER_NU;
    out->density = PLACEHOLDER_DENSITY;
}

int vm__material_is_placeholder(const vm_mesh_write_options *opt, int32_t region) {
    for (size_t i = 0; opt && i < opt->nmaterials; i++)
        if (opt->materials[i].label == region) return 0;
    return 1;
}
