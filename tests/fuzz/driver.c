/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/fuzz/driver.c — runs a libFuzzer-style target without libFuzzer: every file of a
 * seed corpus as is, then N seeded mutations of them (bit flips, byte changes, truncation,
 * duplication of a chunk). Usage: driver CORPUS_DIR [MUTATIONS] */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint64_t rng = 0x9e3779b97f4a7c15ull;
static uint64_t next(void) {
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s CORPUS_DIR [MUTATIONS]\n", argv[0]);
        return 2;
    }
    long mutations = argc > 2 ? atol(argv[2]) : 1000;
    DIR *d = opendir(argv[1]);
    if (!d) {
        fprintf(stderr, "%s: no corpus folder\n", argv[1]);
        return 2;
    }
    uint8_t *seeds[256];
    size_t sizes[256], nseeds = 0;
    struct dirent *e;
    while ((e = readdir(d)) && nseeds < 256) {
        if (e->d_name[0] == '.') continue;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", argv[1], e->d_name);
        FILE *fp = fopen(path, "rb");
        if (!fp) continue;
        fseek(fp, 0, SEEK_END);
        long n = ftell(fp);
        fseek(fp, 0, SEEK_SET);
        if (n < 0 || n > (1 << 22)) {
            fclose(fp);
            continue;
        }
        seeds[nseeds] = malloc((size_t)n + 1);
        sizes[nseeds] = fread(seeds[nseeds], 1, (size_t)n, fp);
        fclose(fp);
        nseeds++;
    }
    closedir(d);
    if (!nseeds) {
        fprintf(stderr, "%s: empty corpus\n", argv[1]);
        return 2;
    }
    for (size_t i = 0; i < nseeds; i++) LLVMFuzzerTestOneInput(seeds[i], sizes[i]);
    for (long m = 0; m < mutations; m++) {
        size_t s = next() % nseeds, n = sizes[s];
        uint8_t *buf = malloc(n * 2 + 16);
        memcpy(buf, seeds[s], n);
        int edits = 1 + (int)(next() % 4);
        for (int k = 0; k < edits; k++) {
            switch (next() % 5) {
            case 0: if (n) buf[next() % n] ^= (uint8_t)(1u << (next() % 8)); break;
            case 1: if (n) buf[next() % n] = (uint8_t)next(); break;
            case 2: if (n) n = next() % n; break;
            case 3: if (n) { size_t a = next() % n, len = 1 + next() % 16;
                    if (a + len > n) len = n - a;
                    if (n + len <= sizes[s] * 2 + 16) { memmove(buf + a + len, buf + a, n - a); n += len; } }
                break;
            case 4: if (n) { const char *digits = "0123456789-+e. \n"; buf[next() % n] = (uint8_t)digits[next() % 16]; } break;
            }
        }
        LLVMFuzzerTestOneInput(buf, n);
        free(buf);
    }
    printf("%zu seeds, %ld mutations: no crash\n", nseeds, mutations);
    for (size_t i = 0; i < nseeds; i++) free(seeds[i]);
    return 0;
}
