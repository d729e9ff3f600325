/* SPDX-License-Identifier: BSD-3-Clause */
/* io/modulus.c — materials from the image, as Bonemat does (Taddei et al., "The material
 * mapping strategy influences the accuracy of CT-based finite element models of bones", Med.
 * Eng. Phys. 29, 2007): v = the mean image value over each element (the voxels whose centres
 * lie in it), E = a formula in v, the elements binned into at most N materials. The formula
 * is parsed by recursive descent into postfix code: numbers, v, + - * / ^, parentheses. */
#include <ctype.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "mesh_util.h"

/* ---- the formula ---------------------------------------------------------------------- */

enum { OP_NUM, OP_V, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW, OP_NEG };
/* Longest formula taken (characters), and so at most this many postfix items. */
enum { EXPR_MAX = 1024 };

struct vm_expr {
    int op[EXPR_MAX];
    double num[EXPR_MAX];
    int n;
};

typedef struct expr_parser {
    const char *text, *p;
    vm_expr *e;
    vm_error *err;
    int failed;
} expr_parser;

static void skip_space(expr_parser *ps) {
    while (isspace((unsigned char)*ps->p)) ps->p++;
}

/* Records "--modulus 'TEXT': WHAT at column N" once. */
static void expr_fail(expr_parser *ps, const char *what) {
    if (ps->failed) return;
    ps->failed = 1;
    vm_error_set(ps->err, VM_ERR_ARG, "--modulus '%s': %s at column %d", ps->text, what,
                 (int)(ps->p - ps->text) + 1);
}

static void emit(expr_parser *ps, int op, double num) {
    if (ps->e->n >= EXPR_MAX) {
        expr_fail(ps, "formula too long");
        return;
    }
    ps->e->op[ps->e->n] = op;
    ps->e->num[ps->e->n++] = num;
}

static void parse_sum(expr_parser *ps);
static void parse_unary(expr_parser *ps);

/* primary: a number, v, or a parenthesised sum. */
static void parse_primary(expr_parser *ps) {
    skip_space(ps);
    if (ps->failed) return;
    if (*ps->p == '(') {
        ps->p++;
        parse_sum(ps);
        skip_space(ps);
        if (*ps->p != ')') {
            expr_fail(ps, "expected ')'");
            return;
        }
        ps->p++;
    } else if (*ps->p == 'v' && !isalnum((unsigned char)ps->p[1]) && ps->p[1] != '_') {
        ps->p++;
        emit(ps, OP_V, 0);
    } else if (isdigit((unsigned char)*ps->p) || *ps->p == '.') {
        char *end;
        double d = strtod(ps->p, &end);
        if (end == ps->p || !isfinite(d)) {
            expr_fail(ps, "bad number");
            return;
        }
        ps->p = end;
        emit(ps, OP_NUM, d);
    } else {
        expr_fail(ps, *ps->p ? "expected a number, v or '('" : "unexpected end");
    }
}

/* power: primary ['^' unary] (right-associative; -2^2 is -(2^2)). */
static void parse_power(expr_parser *ps) {
    parse_primary(ps);
    skip_space(ps);
    if (!ps->failed && *ps->p == '^') {
        ps->p++;
        parse_unary(ps);
        emit(ps, OP_POW, 0);
    }
}

static void parse_unary(expr_parser *ps) {
    skip_space(ps);
    if (*ps->p == '-' || *ps->p == '+') {
        int neg = *ps->p == '-';
        ps->p++;
        parse_unary(ps);
        if (neg) emit(ps, OP_NEG, 0);
        return;
    }
    parse_power(ps);
}

static void parse_product(expr_parser *ps) {
    parse_unary(ps);
    for (skip_space(ps); !ps->failed && (*ps->p == '*' || *ps->p == '/'); skip_space(ps)) {
        int op = *ps->p++ == '*' ? OP_MUL : OP_DIV;
        parse_unary(ps);
        emit(ps, op, 0);
    }
}

static void parse_sum(expr_parser *ps) {
    parse_product(ps);
    for (skip_space(ps); !ps->failed && (*ps->p == '+' || *ps->p == '-'); skip_space(ps)) {
        int op = *ps->p++ == '+' ? OP_ADD : OP_SUB;
        parse_product(ps);
        emit(ps, op, 0);
    }
}

vm_status vm_expr_parse(const char *text, vm_expr **out, vm_error *err) {
    *out = NULL;
    if (strlen(text) >= EXPR_MAX)
        return vm_error_set(err, VM_ERR_ARG, "--modulus: the formula is longer than %d "
                            "characters", EXPR_MAX - 1);
    vm_expr *e = calloc(1, sizeof *e);
    if (!e) return vm_error_set(err, VM_ERR_NOMEM, "--modulus: out of memory");
    expr_parser ps = {text, text, e, err, 0};
    parse_sum(&ps);
    skip_space(&ps);
    if (!ps.failed && *ps.p) expr_fail(&ps, "unexpected character");
    if (ps.failed) {
        free(e);
        return VM_ERR_ARG;
    }
    *out = e;
    return VM_OK;
}

double vm_expr_eval(const vm_expr *e, double v) {
    double st[EXPR_MAX];
    int top = 0;
    for (int i = 0; i < e->n; i++) {
        switch (e->op[i]) {
        case OP_NUM: st[top++] = e->num[i]; break;
        case OP_V: st[top++] = v; break;
        case OP_NEG: st[top - 1] = -st[top - 1]; break;
        default: {
            double b = st[--top], a = st[top - 1];
            st[top - 1] = e->op[i] == OP_ADD   ? a + b
                          : e->op[i] == OP_SUB ? a - b
                          : e->op[i] == OP_MUL ? a * b
                          : e->op[i] == OP_DIV ? a / b
                                               : pow(a, b);
        }
        }
    }
    return top == 1 ? st[0] : NAN;
}

void vm_expr_free(vm_expr *e) { free(e); }

/* ---- the mean image value of each element ----------------------------------------------- */

/* The hex's 6 tets around its diagonal 0-6 (VTK corner order). */
static const int HEX_TETS[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                   {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};

/* 1 when p lies in the tet a b c d (closed, either orientation). */
static int in_tet(const double a[3], const double b[3], const double c[3], const double d[3],
                  const double p[3]) {
    const double *v[4] = {a, b, c, d};
    double tot = 0, part[4];
    for (int k = 0; k < 4; k++) {
        const double *q[4] = {v[0], v[1], v[2], v[3]};
        q[k] = p;
        double e1[3], e2[3], e3[3];
        for (int t = 0; t < 3; t++) {
            e1[t] = q[1][t] - q[0][t];
            e2[t] = q[2][t] - q[0][t];
            e3[t] = q[3][t] - q[0][t];
        }
        part[k] = e1[0] * (e2[1] * e3[2] - e2[2] * e3[1]) - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0]) +
                  e1[2] * (e2[0] * e3[1] - e2[1] * e3[0]);
    }
    for (int k = 0; k < 4; k++) tot += part[k];
    if (tot == 0) return 0;
    for (int k = 0; k < 4; k++)
        if (part[k] * tot < -1e-12 * fabs(tot)) return 0;
    return 1;
}

/* Mean of the voxels whose centres lie in cell c (index-space corners x), else the voxel
 * nearest its centroid. */
static double cell_mean(const vm_volume *vol, const vm_mesh *m, double x[8][3]) {
    int nn = vm_cell_nodes(m->kind), tet = m->kind == VM_TET4;
    double lo[3], hi[3], cen[3] = {0, 0, 0};
    for (int a = 0; a < 3; a++) {
        lo[a] = hi[a] = x[0][a];
        for (int k = 0; k < nn; k++) {
            lo[a] = fmin(lo[a], x[k][a]);
            hi[a] = fmax(hi[a], x[k][a]);
            cen[a] += x[k][a] / nn;
        }
    }
    int64_t i0[3], i1[3];
    for (int a = 0; a < 3; a++) {
        i0[a] = (int64_t)ceil(lo[a]);
        i1[a] = (int64_t)floor(hi[a]);
        if (i0[a] < 0) i0[a] = 0;
        if (i1[a] > vol->dims[a] - 1) i1[a] = vol->dims[a] - 1;
    }
    double sum = 0;
    size_t count = 0;
    for (int64_t k = i0[2]; k <= i1[2]; k++)
        for (int64_t j = i0[1]; j <= i1[1]; j++)
            for (int64_t i = i0[0]; i <= i1[0]; i++) {
                double p[3] = {(double)i, (double)j, (double)k};
                int inside = 0;
                if (tet)
                    inside = in_tet(x[0], x[1], x[2], x[3], p);
                else
                    for (int t = 0; t < 6 && !inside; t++)
                        inside = in_tet(x[HEX_TETS[t][0]], x[HEX_TETS[t][1]], x[HEX_TETS[t][2]],
                                        x[HEX_TETS[t][3]], p);
                if (!inside) continue;
                sum += vol->data[i + vol->dims[0] * (j + vol->dims[1] * k)];
                count++;
            }
    if (count) return sum / (double)count;
    int64_t q[3];
    for (int a = 0; a < 3; a++) {
        q[a] = (int64_t)floor(cen[a] + 0.5);
        if (q[a] < 0) q[a] = 0;
        if (q[a] > vol->dims[a] - 1) q[a] = vol->dims[a] - 1;
    }
    return vol->data[q[0] + vol->dims[0] * (q[1] + vol->dims[1] * q[2])];
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

vm_status vm_mesh_image_moduli(vm_mesh *m, const vm_volume *vol, const vm_expr *e, int bins,
                               double poisson, vm_material **mats, size_t *nmats,
                               vm_error *err) {
    *mats = NULL;
    *nmats = 0;
    if (m->kind != VM_TET4 && m->kind != VM_HEX8)
        return vm_error_set(err, VM_ERR_ARG, "--modulus: needs a tet or hex mesh, not %s",
                            vm_cell_kind_name(m->kind));
    double inv[3][3];
    if (!vm__index_frame(vol, inv))
        return vm_error_set(err, VM_ERR_ARG, "--modulus: the volume's frame is singular");
    size_t nc = m->ncells, nn = (size_t)vm_cell_nodes(m->kind);
    double *v = malloc((nc + 1) * sizeof *v), *ev = malloc((nc + 1) * sizeof *ev);
    double *sorted = malloc((nc + 1) * sizeof *sorted);
    vm_material *out = calloc((size_t)bins + 1, sizeof *out);
    vm_status st = VM_OK;
    if (!v || !ev || !sorted || !out)
        st = vm_error_set(err, VM_ERR_NOMEM, "--modulus: out of memory for %zu elements", nc);
    for (size_t c = 0; !st && c < nc; c++) {
        double x[8][3];
        for (size_t k = 0; k < nn; k++)
            vm__to_index(vol, &inv[0][0], m->points + 3 * (size_t)m->cells[c * nn + k], x[k]);
        v[c] = cell_mean(vol, m, x);
        ev[c] = vm_expr_eval(e, v[c]);
        if (!isfinite(ev[c]) || ev[c] <= 0)
            st = vm_error_set(err, VM_ERR_ARG,
                              "--modulus: E = %g for the image value %g of element %zu (E must "
                              "be finite and > 0)", ev[c], v[c], c + 1);
    }
    size_t nd = 0;
    if (!st && nc) {
        memcpy(sorted, ev, nc * sizeof *sorted);
        qsort(sorted, nc, sizeof *sorted, cmp_double);
        for (size_t i = 0; i < nc; i++)
            if (i == 0 || sorted[i] != sorted[nd - 1]) sorted[nd++] = sorted[i];
    }
    if (!st && nc) {
        /* few distinct moduli: one material each, exact; else equal-width bins over
         * [min, max], each material the mean modulus of its elements */
        double lo = sorted[0], hi = sorted[nd - 1];
        double *sum = calloc((size_t)bins, sizeof *sum);
        size_t *cnt = calloc((size_t)bins, sizeof *cnt);
        int *slot = malloc((size_t)bins * sizeof *slot);
        if (!sum || !cnt || !slot) {
            st = vm_error_set(err, VM_ERR_NOMEM, "--modulus: out of memory");
        } else {
            for (size_t c = 0; c < nc; c++) {
                size_t b;
                if (nd <= (size_t)bins) {
                    size_t l = 0, r = nd - 1;
                    while (l < r) {
                        size_t mid = (l + r) / 2;
                        if (sorted[mid] < ev[c]) l = mid + 1; else r = mid;
                    }
                    b = l;
                } else {
                    double t = (ev[c] - lo) / (hi - lo) * bins;
                    b = t >= bins ? (size_t)bins - 1 : (size_t)t;
                }
                sum[b] += ev[c];
                cnt[b]++;
                m->region[c] = (int32_t)b; /* renumbered below */
            }
            int used = 0;
            for (int b = 0; b < bins; b++) {
                slot[b] = cnt[b] ? ++used : 0;
                if (!cnt[b]) continue;
                vm_material *mt = &out[used - 1];
                mt->label = used;
                snprintf(mt->name, sizeof mt->name, "E_BIN_%d", used);
                mt->young = nd <= (size_t)bins ? sorted[b] : sum[b] / (double)cnt[b];
                mt->poisson = poisson;
                mt->density = 0;
            }
            for (size_t c = 0; c < nc; c++) {
                int b = m->region[c];
                ev[c] = out[slot[b] - 1].young;
                m->region[c] = slot[b];
            }
            *nmats = (size_t)used;
        }
        free(sum);
        free(cnt);
        free(slot);
    }
    if (!st) st = vm_mesh_set_field(m, 1, "image_mean", 1, v, err);
    if (!st) st = vm_mesh_set_field(m, 1, "modulus", 1, ev, err);
    free(v);
    free(ev);
    free(sorted);
    if (st) {
        free(out);
        *nmats = 0;
        return st;
    }
    *mats = out;
    return VM_OK;
}
