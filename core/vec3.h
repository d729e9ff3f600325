/* SPDX-License-Identifier: BSD-3-Clause */
/* core/vec3.h — private 3-vector helpers shared by the metric files of quality/.
 * Not part of the public API. */
#ifndef VM_QUALITY_VEC3_H
#define VM_QUALITY_VEC3_H

#include <math.h>

#define VM_RAD2DEG (180.0 / 3.14159265358979323846)

static inline void vm__sub3(const double a[3], const double b[3], double out[3]) {
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline void vm__cross3(const double a[3], const double b[3], double out[3]) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double vm__dot3(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline double vm__norm3(const double a[3]) {
    return sqrt(vm__dot3(a, a));
}

/* a . (b x c) */
static inline double vm__triple(const double a[3], const double b[3], const double c[3]) {
    double t[3];
    vm__cross3(b, c, t);
    return vm__dot3(a, t);
}

/* Angle between a and b in degrees, 0..180; atan2 keeps it accurate near 0 and 180.
 * A zero vector gives 0. */
static inline double vm__angle_deg(const double a[3], const double b[3]) {
    double c[3];
    vm__cross3(a, b, c);
    double s = vm__norm3(c), d = vm__dot3(a, b);
    if (!(s > 0.0) && d == 0.0) return 0.0;
    return atan2(s, d) * VM_RAD2DEG;
}

/* Ratio-type metrics: +inf, NaN (0/0) and anything above the cap become the cap. */
static inline double vm__cap_ratio(double x, double cap) {
    return (x < cap) ? x : cap;
}

#endif
