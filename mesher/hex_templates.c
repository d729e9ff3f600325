/* mesher/hex_templates.c — 3-refinement transition templates for hexahedra, after the
 * node-marking scheme of Schneiders (1996, "Refining quadrilateral and hexahedral element
 * meshes"): edges with both ends marked split in thirds; one template per marked-edge set. */
#include "hex_templates.h"
#include "volmesh/quality.h"
#include <string.h>

/* The metric of quality/ (Verdict's, as the reports measure it). */
double vm__hex_template_min_sj(double p[8][3]) {
    return vm_hex_min_scaled_jacobian((const double(*)[3])p);
}

/* Symmetry s = 8 * permutation + flips: image coordinate a is source coordinate perm[a],
 * mirrored (9 - x) when flip bit a is set. */
static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};

static void sym_point(int s, const int in[3], int out[3]) {
    const int *p = perms[s / 8];
    for (int a = 0; a < 3; a++) {
        int v = in[p[a]];
        out[a] = (s >> a) & 1 ? VM_HT_SIDE - v : v;
    }
}

static unsigned sym_corner(int s, unsigned c) {
    int in[3] = {(int)(c & 1) * VM_HT_SIDE, (int)((c >> 1) & 1) * VM_HT_SIDE,
                 (int)((c >> 2) & 1) * VM_HT_SIDE};
    int o[3];
    sym_point(s, in, o);
    return (unsigned)(o[0] / VM_HT_SIDE) | (unsigned)(o[1] / VM_HT_SIDE) << 1 |
           (unsigned)(o[2] / VM_HT_SIDE) << 2;
}

static unsigned sym_set(int s, unsigned set) {
    unsigned r = 0;
    for (unsigned c = 0; c < 8; c++)
        if (set >> c & 1) r |= 1u << sym_corner(s, c);
    return r;
}

vm__hex_template vm__hex_template_classify(unsigned marks, int *sym) {
    *sym = 0;
    unsigned ends = 0; /* corners of split edges */
    int nsplit = 0;
    for (unsigned c = 0; c < 8; c++)
        for (unsigned b = 1; b < 8; b <<= 1) {
            if (c & b) continue;
            if ((marks >> c & 1) && (marks >> (c | b) & 1)) {
                nsplit++;
                ends |= 1u << c | 1u << (c | b);
            }
        }
    if (nsplit == 0) return VM_HT_PLAIN;
    if (nsplit == 12) return VM_HT_FULL;
    unsigned canon = nsplit == 1 ? 0x03u : nsplit == 4 ? 0x0fu : 0;
    if (!canon) return VM_HT_UNSUPPORTED;
    for (int s = 0; s < 48; s++)
        if (sym_set(s, canon) == ends) {
            *sym = s;
            return nsplit == 1 ? VM_HT_EDGE : VM_HT_FACE;
        }
    return VM_HT_UNSUPPORTED; /* four split edges that are not one face */
}

/* Canonical EDGE: the split edge runs along x at y = z = 0. Its faces y = 0 and z = 0 are the
 * 4-quad transition (nodes at x = 3, 6 on the edge and at distance 3 from it), the other
 * four are whole: two end wedges, a middle cube and two hexes toward y = 9 and z = 9. */
static const int edge_hexes[5][8][3] = {
    {{0, 0, 0}, {3, 0, 0}, {3, 3, 0}, {0, 9, 0}, {0, 0, 9}, {3, 0, 3}, {3, 3, 3}, {0, 9, 9}},
    {{3, 0, 0}, {6, 0, 0}, {6, 3, 0}, {3, 3, 0}, {3, 0, 3}, {6, 0, 3}, {6, 3, 3}, {3, 3, 3}},
    {{9, 0, 0}, {6, 0, 0}, {6, 3, 0}, {9, 9, 0}, {9, 0, 9}, {6, 0, 3}, {6, 3, 3}, {9, 9, 9}},
    {{3, 3, 0}, {6, 3, 0}, {9, 9, 0}, {0, 9, 0}, {3, 3, 3}, {6, 3, 3}, {9, 9, 9}, {0, 9, 9}},
    {{3, 0, 3}, {6, 0, 3}, {9, 0, 9}, {0, 0, 9}, {3, 3, 3}, {6, 3, 3}, {9, 9, 9}, {0, 9, 9}}};

/* The 4-quad transition in the unit square, (u, w): fine edge w = 0 in thirds, coarse edge
 * w = 1, interior nodes at w = 1/3. Scaled by 9 (u, w integers 0..9). */
static const int tr2[4][4][2] = {{{0, 0}, {3, 0}, {3, 3}, {0, 9}},
                                 {{3, 0}, {6, 0}, {6, 3}, {3, 3}},
                                 {{6, 0}, {9, 0}, {9, 9}, {6, 3}},
                                 {{3, 3}, {6, 3}, {9, 9}, {0, 9}}};

/* Canonical FACE (split face z = 0), built as in Schneiders' construction: the 4-quad
 * transition in (x, z) swept along y gives four hexes; the three that touch z = 0 are each
 * split again by the transition in (y, w), swept along their own x direction. 13 hexes. */
static size_t face_hexes(int out[][8][3]) {
    size_t n = 0;
    /* the coarse hex of the first sweep */
    for (int k = 0; k < 8; k++) {
        const int *q = tr2[3][k & 3];
        out[n][k][0] = q[0];
        out[n][k][1] = k < 4 ? 0 : VM_HT_SIDE;
        out[n][k][2] = q[1];
    }
    n++;
    for (int i = 0; i < 3; i++) {
        const int(*Q)[2] = tr2[i]; /* corners (x, z): P00, P10, P11, P01 in (u, w) */
        for (int j = 0; j < 4; j++) {
            for (int k = 0; k < 8; k++) {
                const int *r = tr2[j][k & 3]; /* (v, w) of the second transition */
                int u = k < 4 ? 0 : 1;
                /* bilinear point of Q at (u, w = r[1] / 9); w is 0, 1/3 or 1, so every
                 * coordinate stays an integer */
                int w9 = r[1];
                int x0 = Q[0][0] * (9 - w9) + Q[3][0] * w9,
                    z0 = Q[0][1] * (9 - w9) + Q[3][1] * w9;
                int x1 = Q[1][0] * (9 - w9) + Q[2][0] * w9,
                    z1 = Q[1][1] * (9 - w9) + Q[2][1] * w9;
                out[n][k][0] = (u ? x1 : x0) / 9;
                out[n][k][1] = r[0];
                out[n][k][2] = (u ? z1 : z0) / 9;
            }
            n++;
        }
    }
    return n;
}

static size_t canonical(vm__hex_template t, int out[][8][3]) {
    size_t n = 0;
    switch (t) {
    case VM_HT_PLAIN:
        for (int k = 0; k < 8; k++) {
            int c = (k & 3) == 0 || (k & 3) == 3 ? 0 : 1, d = (k & 3) >= 2;
            out[0][k][0] = c * VM_HT_SIDE;
            out[0][k][1] = d * VM_HT_SIDE;
            out[0][k][2] = (k >= 4) * VM_HT_SIDE;
        }
        return 1;
    case VM_HT_EDGE: memcpy(out, edge_hexes, sizeof edge_hexes); return 5;
    case VM_HT_FACE: return face_hexes(out);
    case VM_HT_FULL:
        for (int z = 0; z < 3; z++)
            for (int y = 0; y < 3; y++)
                for (int x = 0; x < 3; x++, n++)
                    for (int k = 0; k < 8; k++) {
                        int c = (k & 3) == 0 || (k & 3) == 3 ? 0 : 1, d = (k & 3) >= 2;
                        out[n][k][0] = 3 * (x + c);
                        out[n][k][1] = 3 * (y + d);
                        out[n][k][2] = 3 * (z + (k >= 4));
                    }
        return n;
    default: return 0;
    }
}

size_t vm__hex_template_hexes(vm__hex_template t, int sym, int out[][8][3]) {
    int canon[VM_HT_MAX_HEXES][8][3];
    size_t n = canonical(t, canon);
    for (size_t h = 0; h < n; h++) {
        double p[8][3];
        for (int k = 0; k < 8; k++) {
            sym_point(sym, canon[h][k], out[h][k]);
            for (int a = 0; a < 3; a++)
                p[k][a] = out[h][k][a];
        }
        /* mirror images and the hand-written tables may be left-handed: swap to VTK's */
        if (vm__hex_template_min_sj(p) < 0) {
            static const int sw[2][2] = {{1, 3}, {5, 7}};
            for (int q = 0; q < 2; q++)
                for (int a = 0; a < 3; a++) {
                    int tmp = out[h][sw[q][0]][a];
                    out[h][sw[q][0]][a] = out[h][sw[q][1]][a];
                    out[h][sw[q][1]][a] = tmp;
                }
        }
    }
    return n;
}
