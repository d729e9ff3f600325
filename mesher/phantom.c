/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/phantom.c — analytic test volumes with known volume, Euler characteristic and
 * component count: sphere, torus, genus-3 (three fused tori), two spheres, a one-voxel
 * plate and a sphere cut by the volume border. Fields are signed distances (> 0 inside). */
#include <math.h>
#include <string.h>
#include "volmesh/mesher.h"

#define PI 3.14159265358979323846

/* The shapes' sizes, as fractions of the index box's extent n - 1 (the plate's thickness in
 * voxels). All are centred in the box and inside it, but the cut sphere, whose centre sits
 * near the x = 0 face so that the border cuts it. */
static const double sphere_r = 0.35;                     /* sphere, cut sphere */
static const double torus_R = 0.28, torus_r = 0.12;      /* ring and tube radii */
static const double genus3_R = 0.13, genus3_r = 0.055;   /* each of the three tori */
static const double genus3_gap = 1.9;                    /* centre spacing, in ring radii */
static const double spheres_r = 0.2, spheres_off = 0.25; /* two spheres, centres at +-off */
static const double plate_half = 0.35, plate_half_thick = 0.6; /* half side; half thickness */
static const double cut_centre = 0.15;                         /* the cut sphere's centre x */

typedef struct {
    vm_phantom_kind kind;
    double n1;   /* n - 1: the extent of the index box */
    double c[3]; /* centre */
} shape;

static double torus(double x, double y, double z, double R, double r) {
    double q = sqrt(x * x + y * y) - R;
    return r - sqrt(q * q + z * z);
}

/* The signed distance (> 0 inside) of shape s at index position (x, y, z). */
static double field(const shape *s, double x, double y, double z) {
    double n1 = s->n1, dx = x - s->c[0], dy = y - s->c[1], dz = z - s->c[2];
    switch (s->kind) {
    case VM_PHANTOM_SPHERE: return sphere_r * n1 - sqrt(dx * dx + dy * dy + dz * dz);
    case VM_PHANTOM_TORUS: return torus(dx, dy, dz, torus_R * n1, torus_r * n1);
    case VM_PHANTOM_GENUS3: {
        double R = genus3_R * n1, r = genus3_r * n1, d = genus3_gap * R;
        double a = torus(dx + d, dy, dz, R, r), b = torus(dx, dy, dz, R, r);
        double e = torus(dx - d, dy, dz, R, r);
        return fmax(a, fmax(b, e));
    }
    case VM_PHANTOM_TWO_SPHERES: {
        double r = spheres_r * n1, o = spheres_off * n1;
        double a = r - sqrt((dx + o) * (dx + o) + dy * dy + dz * dz);
        double b = r - sqrt((dx - o) * (dx - o) + dy * dy + dz * dz);
        return fmax(a, b);
    }
    case VM_PHANTOM_PLATE: {
        double a = plate_half * n1;
        return fmin(plate_half_thick - fabs(dz), fmin(a - fabs(dx), a - fabs(dy)));
    }
    case VM_PHANTOM_CUT_SPHERE: return sphere_r * n1 - sqrt(dx * dx + dy * dy + dz * dz);
    }
    return -1.0;
}

/* The shape of a phantom of n^3 points: its size and centre. */
static void make_shape(vm_phantom_kind kind, int n, shape *s) {
    s->kind = kind;
    s->n1 = n - 1;
    s->c[0] = s->c[1] = s->c[2] = 0.5 * (n - 1);
    if (kind == VM_PHANTOM_PLATE) s->c[2] = floor(0.5 * (n - 1)); /* plate on a voxel layer */
    if (kind == VM_PHANTOM_CUT_SPHERE) s->c[0] = cut_centre * (n - 1);
}

/* Volume inside the index box [0, n-1]^3 by the midpoint rule on a grid `sub` times finer. */
static double numeric_volume(const shape *s, int sub) {
    long m = (long)(s->n1 * sub + 0.5);
    double h = s->n1 / (double)m, count = 0;
    for (long k = 0; k < m; k++)
        for (long j = 0; j < m; j++)
            for (long i = 0; i < m; i++)
                if (field(s, (i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h) >= 0) count += 1;
    return count * h * h * h;
}

/* The shape's volume inside the index box: closed form, numeric for the genus-3 solid. */
static double exact_volume(const shape *s, int n) {
    double n1 = s->n1;
    switch (s->kind) {
    case VM_PHANTOM_SPHERE: return 4.0 / 3.0 * PI * pow(sphere_r * n1, 3);
    case VM_PHANTOM_TORUS: return 2.0 * PI * PI * torus_R * n1 * pow(torus_r * n1, 2);
    case VM_PHANTOM_TWO_SPHERES: return 2.0 * 4.0 / 3.0 * PI * pow(spheres_r * n1, 3);
    case VM_PHANTOM_PLATE: return pow(2 * plate_half * n1, 2) * (2 * plate_half_thick);
    case VM_PHANTOM_CUT_SPHERE: {
        double r = sphere_r * n1, h = r - s->c[0];
        return 4.0 / 3.0 * PI * r * r * r - PI * h * h * (3 * r - h) / 3.0;
    }
    case VM_PHANTOM_GENUS3: return numeric_volume(s, n <= 96 ? 3 : 2);
    }
    return 0;
}

static unsigned long long rng_next(unsigned long long *st) {
    unsigned long long z = (*st += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static double gaussian(unsigned long long *st) {
    double u1 = ((double)(rng_next(st) >> 11) + 0.5) / 9007199254740992.0;
    double u2 = ((double)(rng_next(st) >> 11) + 0.5) / 9007199254740992.0;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * PI * u2);
}

vm_status vm_phantom_make(vm_phantom_kind kind, int n, double noise, unsigned seed,
                          vm_volume *v, vm_phantom_info *info, vm_error *err) {
    if (n < 8 || n > 4096)
        return vm_error_set(err, VM_ERR_ARG, "phantom: size %d is outside 8..4096", n);
    int64_t dims[3] = {n, n, n};
    vm_status st = vm_volume_alloc(v, dims, err);
    if (st) return st;
    strcpy(v->format, "phantom");
    shape s;
    make_shape(kind, n, &s);
    unsigned long long rs = seed;
    size_t idx = 0;
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double f = field(&s, i, j, k);
                if (noise > 0) f += noise * gaussian(&rs);
                v->data[idx++] = (float)f;
            }
    if (info) {
        static const char *names[] = {"sphere", "torus", "genus3", "two-spheres", "plate",
                                      "cut-sphere"};
        static const int euler[] = {2, 0, -4, 4, 2, 2}, comps[] = {1, 1, 1, 2, 1, 1};
        info->name = names[kind];
        info->euler = euler[kind];
        info->components = comps[kind];
        info->volume = exact_volume(&s, n);
    }
    return VM_OK;
}

int vm_phantom_parse(const char *name, vm_phantom_kind *kind) {
    static const struct {
        const char *name;
        vm_phantom_kind kind;
    } table[] = {{"sphere", VM_PHANTOM_SPHERE},       {"torus", VM_PHANTOM_TORUS},
                 {"genus3", VM_PHANTOM_GENUS3},       {"two-spheres", VM_PHANTOM_TWO_SPHERES},
                 {"plate", VM_PHANTOM_PLATE},         {"cut-sphere", VM_PHANTOM_CUT_SPHERE}};
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (strcmp(name, table[i].name) == 0) {
            *kind = table[i].kind;
            return 0;
        }
    return -1;
}
