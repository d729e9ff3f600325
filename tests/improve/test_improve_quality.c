/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/improve/test_improve_quality.c — the quality pass's tet measure (improve_mesh.c) and
 * the cosine-level measures it is made of (quality/tet_internal.h): the quality that leaves
 * a term unmeasured when its cosine puts it above the others is, to the last bit, the minimum
 * of all five terms measured; the test on cosines against a bar gives the answer of the
 * quality against it; the cosines are those of the angles; vm__cos_below bounds the cosine
 * from below. Tets of every shape: near-regular, needles, caps, slivers, wedges, flat ones,
 * at scales from 1e-3 to 1e3. */
#include "improve/improve_internal.h"
#include "quality/tet_internal.h"
#include "test.h"
#include "volmesh/improve.h"
#include "volmesh/quality.h"
#include <math.h>
#include <stdint.h>
#include <string.h>

#define DEG (180.0 / 3.14159265358979323846)
#define NTETS 200000

/* A tet of shape kind (0..5) from the noise *st, positively oriented unless flat. */
static void random_tet(uint64_t *st, int kind, double p[4][3]) {
    static const double reg[4][3] = {{0, 0, 0}, {1, 0, 0}, {0.5, 0.8660254, 0}, {0.5, 0.2886751, 0.8164966}};
    double noise = kind == 0 ? 0.3 : 0.05, scale = pow(10.0, 6.0 * vm_test_uniform(st) - 3.0);
    for (int k = 0; k < 4; k++)
        for (int d = 0; d < 3; d++) p[k][d] = reg[k][d] + noise * (2 * vm_test_uniform(st) - 1);
    double e = 0.01 + 0.3 * vm_test_uniform(st);
    switch (kind) {
    case 1: /* needle: three corners close together */
        for (int d = 0; d < 3; d++) p[1][d] = p[0][d] + e * (p[1][d] - p[0][d]);
        for (int d = 0; d < 3; d++) p[2][d] = p[0][d] + e * (p[2][d] - p[0][d]);
        break;
    case 2: /* cap: the apex near the opposite face */
        p[3][2] = e * e * p[3][2];
        break;
    case 3: /* sliver: four corners of a square, two lifted a little */
        p[0][0] = 0, p[0][1] = 0, p[0][2] = 0;
        p[1][0] = 1, p[1][1] = 1, p[1][2] = 0;
        p[2][0] = 1, p[2][1] = 0, p[2][2] = e * e;
        p[3][0] = 0, p[3][1] = 1, p[3][2] = e * e;
        break;
    case 4: /* wedge: one short edge */
        for (int d = 0; d < 3; d++) p[1][d] = p[0][d] + e * e * (p[1][d] - p[0][d]);
        break;
    case 5: /* flat: the apex in the base plane up to round-off */
        p[0][2] = p[1][2] = p[2][2] = 0.0;
        p[3][2] = 1e-14 * vm_test_uniform(st);
        break;
    }
    for (int k = 0; k < 4; k++)
        for (int d = 0; d < 3; d++) p[k][d] = scale * (p[k][d] + 3.0);
    if (vm_tet_signed_volume((const double(*)[3])p) < 0)
        for (int d = 0; d < 3; d++) {
            double t = p[2][d];
            p[2][d] = p[3][d];
            p[3][d] = t;
        }
}

/* The angle at corner k of face f, as the pass measures it (atan2 of the edges from it). */
static double corner(const double p[4][3], int f, int k) {
    static const int fo[4][3] = VM__TET_FACE_NODES;
    double u[3], v[3], c[3];
    int o = fo[f][k], i = fo[f][(k + 1) % 3], j = fo[f][(k + 2) % 3];
    vm__sub3(p[i], p[o], u);
    vm__sub3(p[j], p[o], v);
    vm__cross3(u, v, c);
    return atan2(sqrt(vm__dot3(c, c)), vm__dot3(u, v)) * DEG;
}

/* Every term measured: the quality as the pass measured it before it left terms out. */
static double all_terms(const vm__imp *w, const double p[4][3]) {
    double cmax, cmin;
    if (!vm__tet_dihedral_cosines(p, &cmax, &cmin)) return -1.0;
    double fmin = 180.0, fmax = 0.0;
    for (int f = 0; f < 4; f++)
        for (int k = 0; k < 3; k++) {
            double a = corner(p, f, k);
            fmin = a < fmin ? a : fmin;
            fmax = a > fmax ? a : fmax;
        }
    double t[5] = {acos(cmax) * DEG / w->s_min, (180.0 - acos(cmin) * DEG) / w->s_max,
                   vm__imp_volume_measure(p) / w->s_vm, fmin / w->s_fmin,
                   (180.0 - fmax) / w->s_fmax};
    double q = t[0];
    for (int i = 1; i < 5; i++) q = t[i] < q ? t[i] : q;
    return q;
}

static void scales(vm__imp *w) {
    vm_improve_options o;
    vm_improve_options_default(&o);
    memset(w, 0, sizeof *w);
    vm__imp_scales(w, &o);
}

static void qualityIsTheMinimumOfEveryTermToTheLastBit(void) {
    vm__imp w;
    scales(&w);
    uint64_t st = 32;
    size_t differ = 0, skipped_kinds[6] = {0};
    for (size_t i = 0; i < NTETS; i++) {
        double p[4][3];
        int kind = (int)(i % 6);
        random_tet(&st, kind, p);
        const double(*cp)[3] = (const double(*)[3])p;
        double q = vm__imp_quality(&w, cp), r = all_terms(&w, cp);
        if (memcmp(&q, &r, sizeof q) != 0) {
            if (differ++ < 5)
                fprintf(stderr, "  tet %zu (kind %d): quality %.17g, all terms %.17g\n", i,
                        kind, q, r);
        }
        skipped_kinds[kind] += q < 0;
    }
    CHECK_MSG(differ == 0, "%zu of %d tets differ", differ, NTETS);
    /* the flat ones are refused, the others measured */
    CHECK(skipped_kinds[5] > 0);
    CHECK(skipped_kinds[0] == 0);
}

static void cosineTestAgainstABarIsTheQualitysAnswer(void) {
    vm__imp w;
    scales(&w);
    uint64_t st = 77;
    static const double bars[] = {0.05, 0.3, 2.0 / 3.0, 0.999999999, 1.0, 1.5};
    size_t differ = 0, above = 0, below = 0;
    for (size_t i = 0; i < NTETS / 2; i++) {
        double p[4][3];
        random_tet(&st, (int)(i % 6), p);
        const double(*cp)[3] = (const double(*)[3])p;
        double q = vm__imp_quality(&w, cp);
        for (size_t b = 0; b < sizeof bars / sizeof bars[0]; b++) {
            /* bars at the tet's own quality too, where the cosines tie */
            double f = b == 0 && q > 0 ? q : bars[b];
            vm__imp_bar bar;
            vm__imp_bar_set(&w, f, &bar);
            int a = vm__imp_quality_above(&w, cp, &bar);
            differ += a != (q > f);
            above += a;
            below += !a;
        }
    }
    CHECK_MSG(differ == 0, "%zu answers differ", differ);
    CHECK(above > 0 && below > 0);
}

static void cosinesAreTheAnglesCosines(void) {
    uint64_t st = 5;
    for (size_t i = 0; i < 20000; i++) {
        double p[4][3], cmax, cmin, fc[12], cfmax, cfmin;
        random_tet(&st, (int)(i % 5), p); /* not the flat ones */
        const double(*cp)[3] = (const double(*)[3])p;
        if (!vm__tet_dihedral_cosines(cp, &cmax, &cmin)) continue;
        double lo, hi, flo, fhi;
        vm__tet_dihedral_range(cp, &lo, &hi);
        vm__tet_face_angle_range(cp, &flo, &fhi);
        vm__tet_face_cosines(cp, fc, &cfmax, &cfmin);
        CHECK_NEAR(cmax, cos(lo / DEG), 1e-9);
        CHECK_NEAR(cmin, cos(hi / DEG), 1e-9);
        CHECK_NEAR(cfmax, cos(flo / DEG), 1e-9);
        CHECK_NEAR(cfmin, cos(fhi / DEG), 1e-9);
        for (int k = 0; k < 12; k++) CHECK(fc[k] <= cfmax && fc[k] >= cfmin);
    }
    /* a regular tet: dihedral acos(1/3), face angles 60 degrees */
    const double reg[4][3] = {{1, 1, 1}, {-1, 1, -1}, {1, -1, -1}, {-1, -1, 1}};
    double cmax = 0.0, cmin = 0.0, fc[12], cfmax, cfmin;
    CHECK(vm__tet_dihedral_cosines(reg, &cmax, &cmin));
    CHECK_NEAR(cmax, 1.0 / 3.0, 1e-15);
    CHECK_NEAR(cmin, 1.0 / 3.0, 1e-15);
    vm__tet_face_cosines(reg, fc, &cfmax, &cfmin);
    CHECK_NEAR(cfmax, 0.5, 1e-15);
    CHECK_NEAR(cfmin, 0.5, 1e-15);
    /* inverted and flat tets are refused */
    const double inv[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    const double flat[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
    CHECK(!vm__tet_dihedral_cosines(inv, &cmax, &cmin));
    CHECK(!vm__tet_dihedral_cosines(flat, &cmax, &cmin));
}

static void cosBelowBoundsTheCosineFromBelow(void) {
    size_t n = 0;
    for (double x = 0.0; x <= 4.0; x += 1e-4, n++) {
        double c = cos(x), b = vm__cos_below(x);
        CHECK_MSG(b <= c + 1e-15, "x %.6g: bound %.17g above cos %.17g", x, b, c);
        /* and close where the pass uses it (limits of 0 to 60 degrees) */
        if (x <= 60.0 / DEG) CHECK_MSG(c - b < 1e-4, "x %.6g: bound %.17g, cos %.17g", x, b, c);
    }
    CHECK(n >= 40000);
    CHECK(vm__cos_below(0.0) == 1.0);
}

static void figuresCountTheTetsUnderAVolumeMeasure(void) {
    /* a regular tet (volume measure 1) and a cap (about 0.01) */
    const double pts[] = {1, 1, 1, -1, 1, -1, 1, -1, -1, -1, -1, 1, 0.3433, 0.3433, -0.3333};
    const vm_index cells[] = {0, 1, 2, 3, 0, 2, 1, 4};
    vm__imp_figures f;
    CHECK(vm__imp_mesh_figures(pts, cells, 2, 0.03, &f) == VM_OK);
    CHECK(f.vm_low == 1);
    CHECK(f.inverted == 0);
    CHECK(f.dmin < 15.0 && f.dmax > 150.0);
    CHECK(vm__imp_mesh_figures(pts, cells, 1, 0.03, &f) == VM_OK);
    CHECK(f.vm_low == 0 && f.abaqus == 0 && f.unfixed == 0);
    CHECK_NEAR(f.dmin, acos(1.0 / 3.0) * DEG, 1e-9);
    CHECK_NEAR(f.volume, 8.0 / 3.0, 1e-12);
}

TEST_MAIN(T(qualityIsTheMinimumOfEveryTermToTheLastBit),
          T(cosineTestAgainstABarIsTheQualitysAnswer), T(cosinesAreTheAnglesCosines),
          T(cosBelowBoundsTheCosineFromBelow), T(figuresCountTheTetsUnderAVolumeMeasure))
