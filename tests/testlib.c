/* tests/testlib.c — the harness behind tests/test.h. */
#define _POSIX_C_SOURCE 200809L
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include "test.h"

int vm_test_failures;
static int skipped_flag;

void vm_test_skip(const char *reason) {
    printf("  skipped: %s\n", reason);
    skipped_flag = 1;
}

int vm_test_run(const vm_test_case *cases, size_t n) {
    int passed = 0, failed = 0, skipped = 0;
    for (size_t i = 0; i < n; i++) {
        vm_test_failures = 0;
        skipped_flag = 0;
        printf("%s\n", cases[i].name);
        fflush(stdout);
        cases[i].fn();
        if (vm_test_failures) {
            printf("  FAILED (%d checks)\n", vm_test_failures);
            failed++;
        } else if (skipped_flag) {
            skipped++;
        } else {
            passed++;
        }
        fflush(stdout);
    }
    printf("%d passed, %d failed, %d skipped\n", passed, failed, skipped);
    if (failed) return 1;
    if (skipped && !passed) return 77;
    return 0;
}

const char *vm_test_shared(const char *name) {
    static char buf[8][4096];
    static int slot;
    const char *dir = getenv("VM_SHARED_DATA");
    if (!dir) dir = "../shared/data";
    char *p = buf[slot++ % 8];
    snprintf(p, 4096, "%s/%s", dir, name);
    struct stat sb;
    if (stat(p, &sb) != 0) {
        char msg[4200];
        snprintf(msg, sizeof msg, "%s not found (../shared/data is absent in a fresh clone)", p);
        vm_test_skip(msg);
        return NULL;
    }
    return p;
}

const char *vm_test_tmp(const char *name) {
    static char buf[8][4096];
    static int slot;
    const char *dir = getenv("VM_TEST_TMP");
    char *p = buf[slot++ % 8];
    snprintf(p, 4096, "%s/%s", dir ? dir : ".", name);
    return p;
}

int vm_test_write_file(const char *path, const void *data, size_t len) {
    FILE *fp = fopen(path, "wb");
    if (!fp) return -1;
    size_t w = fwrite(data, 1, len, fp);
    int bad = fclose(fp) != 0 || w != len;
    return bad ? -1 : 0;
}

int vm_test_exists(const char *path) {
    struct stat sb;
    return stat(path, &sb) == 0;
}

int vm_test_cli(const char *args, char **out) {
    const char *cli = getenv("VM_CLI");
    if (!cli) cli = "volmesh";
    size_t len = strlen(cli) + strlen(args) + 32;
    char *cmd = malloc(len);
    snprintf(cmd, len, "%s %s 2>&1", cli, args);
    FILE *p = popen(cmd, "r");
    free(cmd);
    if (!p) return -1;
    size_t cap = 4096, n = 0;
    char *buf = malloc(cap);
    size_t r;
    while ((r = fread(buf + n, 1, cap - n - 1, p)) > 0) {
        n += r;
        if (cap - n < 2) buf = realloc(buf, cap *= 2);
    }
    buf[n] = 0;
    int status = pclose(p);
    if (out)
        *out = buf;
    else
        free(buf);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

int vm_test_fuzz_volume(const unsigned char *data, size_t size, const char *ext,
                        vm_status (*read)(const char *path, vm_volume *v, vm_error *err)) {
    static char path[4096];
    if (!path[0]) {
        /* keep a lying header from asking for more than a fuzzing run should allocate */
        setenv("VOLMESH_MAX_MEMORY", "268435456", 0);
        char unique[64];
        snprintf(unique, sizeof unique, "fuzz_%ld%s", (long)getpid(), ext);
        snprintf(path, sizeof path, "%s", vm_test_tmp(unique));
    }
    if (vm_test_write_file(path, data, size) != 0) return 0;
    vm_volume v;
    vm_error err;
    vm_error_clear(&err);
    vm_status st = read(path, &v, &err);
    if (st == VM_OK) {
        double lo, hi, mean; /* touch every voxel so a short allocation shows under ASan */
        vm_volume_stats(&v, &lo, &hi, &mean);
        vm_volume_free(&v);
    } else if (err.message[0] == 0 || strchr(err.message, '\n')) {
        fprintf(stderr, "fuzz %s: error %d without a one-line message\n", ext, (int)st);
        abort();
    }
    remove(path);
    return 0;
}
