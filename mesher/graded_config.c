/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_config.c — the table of cube configurations for the graded mesher: for each
 * mask of inside corners, the Euler characteristic and connectivity of the inside part of the
 * cube's boundary (corners, edges, full faces), which decides whether the cell centre may take
 * either sign without changing the topology (a cone over a disk changes nothing). */
#include "graded_config.h"
#include "graded_internal.h"
#include <string.h>

static gr_config table[256];
static const gr_config *volatile ready;
const gr_config *vm__gr_config = table;

static gr_config classify(int m) {
    gr_config c = {0, GR_CENTRE_FREE};
    if (m == 0 || m == 255) {
        c.simple = 1;
        return c;
    }
    int in[8], V = 0, E = 0, F = 0, parent[8], ambiguous = 0;
    for (int q = 0; q < 8; q++) {
        in[q] = (m >> q) & 1;
        V += in[q];
        parent[q] = q;
    }
    for (int q = 0; q < 8; q++)
        for (int d = 0; d < 3; d++) {
            int r = q | (1 << d);
            if (r == q || !in[q] || !in[r]) continue;
            E++;
            parent[vm__gr_root(parent, q)] = vm__gr_root(parent, r);
        }
    for (int d = 0; d < 3; d++)
        for (int s = 0; s < 2; s++) {
            int a = (d + 1) % 3, b = (d + 2) % 3, base = s << d;
            int c0 = base, c1 = base | 1 << a, c2 = base | 1 << a | 1 << b, c3 = base | 1 << b;
            int n = in[c0] + in[c1] + in[c2] + in[c3];
            if (n == 4) F++;
            if (n == 2 && in[c0] == in[c2]) ambiguous = 1;
        }
    int comps = 0;
    for (int q = 0; q < 8; q++)
        if (in[q] && vm__gr_root(parent, q) == q) comps++;
    int disk = comps == 1 && V - E + F == 1;
    int special = 0;
    if (V == 6)
        for (int q = 0; q < 4; q++)
            if (!in[q] && !in[7 - q]) special = 1;
    c.simple = (uint8_t)(disk && !ambiguous && !special);
    c.centre = special ? GR_CENTRE_IN : disk ? GR_CENTRE_FREE : GR_CENTRE_OUT;
    return c;
}

void vm__gr_config_init(void) {
    if (ready) return;
    gr_config t[256];
    for (int m = 0; m < 256; m++)
        t[m] = classify(m);
    /* Every thread computes the same table, so a race writes equal bytes. */
    memcpy(table, t, sizeof t);
    ready = table;
}
