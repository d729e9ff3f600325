/* SPDX-License-Identifier: BSD-3-Clause */
/* io/number_text.c — real numbers as text for the fixed-width fields of solver decks: the
 * shortest of %.15g, %.16g, %.17g (and their exponent forms) that reads back to the same
 * double, else the most significant digits that fit (CalculiX reads 20 characters a field,
 * Nastran's large field and LS-DYNA's node fields 16). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "mesh_util.h"

/* Digits tried for an exact round trip (17 always suffices for an IEEE double), and the
 * fewest kept when a field is narrow. */
enum { EXACT_FIRST = 15, EXACT_LAST = 17, FEWEST_DIGITS = 1 };

/* Room for any candidate: sign, 17 digits, point, "E-308" and a spare point. */
#define CANDIDATE_ROOM 40

/* Rewrites an exponent "e-07" as "E-7" (uppercase, no leading zeros, no '+'), which every
 * deck reader takes and which saves up to three characters. */
static void compact_exponent(char *s) {
    char *e = strpbrk(s, "eE");
    if (!e) return;
    *e = 'E';
    char *p = e + 1, *q = p;
    if (*q == '+') q++;
    else if (*q == '-') *p++ = *q++;
    while (q[0] == '0' && q[1])
        q++;
    memmove(p, q, strlen(q) + 1);
}

/* Adds a decimal point where a number has none ("12" -> "12.", "1E-7" -> "1.E-7"): Nastran
 * reads a field without one as an integer. */
static void ensure_point(char *s) {
    if (strchr(s, '.') || strpbrk(s, "nNiI")) return;
    char *e = strchr(s, 'E');
    size_t at = e ? (size_t)(e - s) : strlen(s);
    memmove(s + at + 1, s + at, strlen(s + at) + 1);
    s[at] = '.';
}

/* The shorter of v's %g and %e texts with digits significant digits, compacted. */
static void shortest_with(double v, int digits, int need_point, char *out) {
    char g[CANDIDATE_ROOM], e[CANDIDATE_ROOM];
    /* digits <= 17: a finite double's text fits the room; a cut one would only be longer */
    if (snprintf(g, sizeof g, "%.*g", digits, v) >= (int)sizeof g) g[0] = '\0';
    if (snprintf(e, sizeof e, "%.*e", digits - 1, v) >= (int)sizeof e) e[0] = '\0';
    compact_exponent(g);
    compact_exponent(e);
    if (need_point) {
        ensure_point(g);
        ensure_point(e);
    }
    strcpy(out, !g[0] || (e[0] && strlen(e) < strlen(g)) ? e : g);
}

int vm__format_real(double v, int width, int need_point, char *out, size_t cap) {
    char best[CANDIDATE_ROOM] = "";
    if (!isfinite(v)) {
        snprintf(best, sizeof best, "%g", v);
    } else {
        int exact = 0;
        for (int d = EXACT_FIRST; d <= EXACT_LAST && !exact; d++) {
            shortest_with(v, d, need_point, best);
            exact = strtod(best, NULL) == v;
        }
        /* Too wide even exact: the most digits that fit (15 when the exponent has at most
         * two digits and the field 20 characters). */
        for (int d = EXACT_FIRST; (int)strlen(best) > width && d >= FEWEST_DIGITS; d--) {
            shortest_with(v, d, need_point, best);
            /* rounded up past DBL_MAX: one unit of the last digit kept toward zero */
            if (isinf(strtod(best, NULL)))
                shortest_with(v - copysign(pow(10.0, floor(log10(fabs(v))) - d + 1), v), d,
                              need_point, best);
        }
    }
    snprintf(out, cap, "%s", best);
    return (int)strlen(out);
}
