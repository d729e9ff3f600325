/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/quality/test_huge_coordinates.c — coordinates near +-DBL_MAX end quickly (issue 31,
 * item 2): the self-intersection grid is sized even when the span overflows, vm_mesh_check
 * refuses the mesh naming the point, and `volmesh quality` on such an OBJ exits 2. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <string.h>
#include <unistd.h>
#include "core/self_intersect.h"
#include "test.h"

/* A hang is a failure: the alarm ends the program (ctest reports it). */
enum { DEADLINE_S = 30 };

static const double huge[4][3] = {
    {-1e308, -1e308, -1e308}, {1e308, -1e308, -1e308}, {-1e308, 1e308, -1e308},
    {-1e308, -1e308, 1e308}};
static const vm_index faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};

static void selfIntersectionsOfAnOverflowingSpanFinish(void) {
    alarm(DEADLINE_S);
    size_t pairs = 99;
    uint8_t flags[4];
    vm_error err;
    vm_status st = vm__self_intersections(&huge[0][0], &faces[0][0], 4, &pairs, flags, &err);
    CHECK(st == VM_OK || st == VM_ERR_NOMEM);
    alarm(0);
}

static void meshCheckRefusesHugeCoordinatesNamingThePoint(void) {
    alarm(DEADLINE_S);
    vm_mesh m;
    vm_mesh_init(&m, VM_TRI3);
    for (int i = 0; i < 4; i++) vm_mesh_add_point(&m, huge[i], NULL);
    for (int f = 0; f < 4; f++) vm_mesh_add_cell(&m, faces[f], 0, NULL);
    vm_mesh_report r;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = vm_mesh_check(&m, &r, &err);
    CHECK_MSG(st == VM_ERR_ARG && strstr(err.message, "point 0, coordinate x"), "%d %s",
              (int)st, err.message);
    vm_mesh_free(&m);
    alarm(0);
}

static void qualityOfAHugeObjExits2WithOneLine(void) {
    alarm(DEADLINE_S);
    const char *obj = vm_test_tmp("huge.obj");
    char text[512];
    size_t n = 0;
    for (int i = 0; i < 4; i++)
        n += (size_t)snprintf(text + n, sizeof text - n, "v %g %g %g\n", huge[i][0], huge[i][1],
                              huge[i][2]);
    for (int f = 0; f < 4; f++)
        n += (size_t)snprintf(text + n, sizeof text - n, "f %d %d %d\n", faces[f][0] + 1,
                              faces[f][1] + 1, faces[f][2] + 1);
    CHECK(vm_test_write_file(obj, text, n) == 0);
    char args[4200], *out = NULL;
    snprintf(args, sizeof args, "quality '%s'", obj);
    int rc = vm_test_cli(args, &out);
    CHECK_MSG(rc == 2, "exit %d: %s", rc, out ? out : "");
    CHECK_MSG(out && strstr(out, "coordinate"), "%s", out ? out : "");
    free(out);
    alarm(0);
}

int main(void) {
    static const vm_test_case cases[] = {
        {"selfIntersectionsOfAnOverflowingSpanFinish", selfIntersectionsOfAnOverflowingSpanFinish},
        {"meshCheckRefusesHugeCoordinatesNamingThePoint",
         meshCheckRefusesHugeCoordinatesNamingThePoint},
        {"qualityOfAHugeObjExits2WithOneLine", qualityOfAHugeObjExits2WithOneLine},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
