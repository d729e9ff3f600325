/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_self_intersect_tetgen.c — the boundary self-intersection count of
 * vm_mesh_check against an independent judge: TetGen's `-d` (detect intersecting facets) on
 * the same surface. Skips when tetgen or ../shared/data is absent. */
#define _POSIX_C_SOURCE 200809L /* popen */
#include "test.h"
#include <stdint.h>
#include <string.h>

static uint64_t rng_state;

/* A pair of triangles as their six sorted corner ids, smaller triangle first. */
typedef struct tri_pair {
    long v[6];
} tri_pair;

static int pair_cmp(const void *x, const void *y) {
    const long *a = ((const tri_pair *)x)->v, *b = ((const tri_pair *)y)->v;
    for (int k = 0; k < 6; k++)
        if (a[k] != b[k]) return a[k] < b[k] ? -1 : 1;
    return 0;
}

static void sort3(long *a) {
    for (int i = 1; i < 3; i++)
        for (int j = i; j > 0 && a[j - 1] > a[j]; j--) {
            long x = a[j];
            a[j] = a[j - 1];
            a[j - 1] = x;
        }
}

/* Writes surf as a TetGen .smesh (0-based points, triangles, no holes or regions). */
static int write_smesh(const char *path, const vm_mesh *surf) {
    FILE *f = fopen(path, "w");
    if (!f) return -1;
    fprintf(f, "%zu 3 0 0\n", surf->npoints);
    for (size_t i = 0; i < surf->npoints; i++)
        fprintf(f, "%zu %.17g %.17g %.17g\n", i, surf->points[3 * i], surf->points[3 * i + 1],
                surf->points[3 * i + 2]);
    fprintf(f, "%zu 0\n", surf->ncells);
    for (size_t c = 0; c < surf->ncells; c++)
        fprintf(f, "3 %lld %lld %lld\n", (long long)surf->cells[3 * c],
                (long long)surf->cells[3 * c + 1], (long long)surf->cells[3 * c + 2]);
    fprintf(f, "0\n0\n");
    return fclose(f);
}

/* Runs tetgen -d on path; returns the number of distinct triangle pairs it lists (it may
 * list a pair more than once), or -1 when it could not run. */
static long tetgen_pairs(const char *path) {
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "tetgen -d '%s' 2>&1", path);
    FILE *p = popen(cmd, "r");
    if (!p) return -1;
    size_t n = 0, cap = 0;
    tri_pair *list = NULL;
    char line[512];
    int found = 0;
    while (fgets(line, sizeof line, p)) {
        if (strstr(line, "pairs of faces are intersecting") || strstr(line, "No faces"))
            found = 1;
        const char *s = strchr(line, '(');
        long a[3], b[3];
        if (!s || sscanf(s, "(%ld, %ld, %ld) and (%ld, %ld, %ld)", &a[0], &a[1], &a[2], &b[0],
                         &b[1], &b[2]) != 6)
            continue;
        sort3(a);
        sort3(b);
        int a_first = a[0] < b[0] || (a[0] == b[0] && (a[1] < b[1] || (a[1] == b[1] && a[2] < b[2])));
        if (n == cap) {
            cap = cap ? 2 * cap : 256;
            tri_pair *g = realloc(list, cap * sizeof *g);
            if (!g) break;
            list = g;
        }
        for (int k = 0; k < 3; k++) {
            list[n].v[k] = a_first ? a[k] : b[k];
            list[n].v[k + 3] = a_first ? b[k] : a[k];
        }
        n++;
    }
    int rc = pclose(p);
    if (n) qsort(list, n, sizeof *list, pair_cmp);
    long distinct = 0;
    for (size_t i = 0; i < n; i++)
        if (i == 0 || pair_cmp(&list[i - 1], &list[i]) != 0) distinct++;
    free(list);
    if (!found && (rc != 0 || n == 0)) return -1;
    return distinct;
}

static void countAgreesWithTetgenOnAJitteredHeadSurface(void) {
    if (system("command -v tetgen >/dev/null 2>&1") != 0) {
        vm_test_skip("tetgen is not installed");
        return;
    }
    const char *path = vm_test_shared("ct_head_quarter.nrrd");
    if (!path) return;
    vm_volume v;
    vm_error err;
    vm_status s = vm_volume_read(path, &v, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) return;
    vm_mesh_options o;
    vm_mesh_options_default(&o);
    o.lo = 500;
    vm_mesh m, surf;
    s = vm_mesh_volume(&v, &o, &m, NULL, &err);
    CHECK_OK(s, &err);
    if (s != VM_OK) {
        vm_volume_free(&v);
        return;
    }
    CHECK_OK(vm_mesh_boundary(&m, &surf, &err), &err);
    /* Shake every boundary point by up to a quarter voxel per axis: the surface then cuts
     * itself in many places, with no two points left in the same spot (TetGen would merge
     * those and see a shared vertex where vm_mesh_check sees two touching ones). */
    rng_state = 0x5e1f0000ull;
    for (size_t i = 0; i < surf.npoints; i++)
        for (int a = 0; a < 3; a++)
            surf.points[3 * i + a] += 0.5 * (vm_test_uniform(&rng_state) - 0.5) * v.spacing[a];
    vm_mesh_report r;
    CHECK_OK(vm_mesh_check(&surf, &r, &err), &err);
    const char *smesh = vm_test_tmp("selfx_head.smesh");
    CHECK(write_smesh(smesh, &surf) == 0);
    long tg = tetgen_pairs(smesh);
    printf("  jittered ct head iso 500 boundary, %zu triangles: vm_mesh_check %zu pairs, "
           "tetgen -d %ld distinct pairs\n",
           surf.ncells, r.boundary_self_intersections, tg);
    CHECK_MSG(tg >= 0, "tetgen -d did not run on %s", smesh);
    CHECK(r.boundary_self_intersections > 100);
    CHECK_MSG((long)r.boundary_self_intersections == tg, "vm_mesh_check %zu, tetgen %ld",
              r.boundary_self_intersections, tg);
    vm_mesh_free(&surf);
    vm_mesh_free(&m);
    vm_volume_free(&v);
}

TEST_MAIN(T(countAgreesWithTetgenOnAJitteredHeadSurface))
