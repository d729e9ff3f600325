/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_inrimage.c — the INRIMAGE-4 reader against files written here: every sample
 * type in both byte orders with its spacing, the gzipped file and slabs like the plain one,
 * and lying or truncated headers refused in one line (exit 2 from the CLI). */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <string.h>
#include <zlib.h>
#include "test.h"

enum { NX = 5, NY = 4, NZ = 6, NVOX = NX * NY * NZ };

/* Value of voxel n (distinct, exact in every type used, negative for signed types). */
static double value(size_t n, int sgn) { return (double)n * 2.0 - (sgn ? 100.0 : 0.0); }

/* A header padded to 256 bytes with newlines; body: the KEY=VALUE lines. */
static size_t make_header(char *out, const char *body) {
    int n = snprintf(out, 4096, "#INRIMAGE-4#{\n%s", body);
    size_t len = (size_t)n, total = (len + 4 + 255) / 256 * 256;
    memset(out + len, '\n', total - len - 4);
    memcpy(out + total - 4, "##}\n", 4);
    return total;
}

/* Writes a header with body then bytes of data to path (gzipped when gz). */
static void write_inr(const char *path, const char *body, const void *data, size_t bytes,
                      int gz) {
    char head[4096];
    size_t hl = make_header(head, body);
    if (gz) {
        gzFile f = gzopen(path, "wb");
        CHECK(f != NULL);
        if (!f) return;
        gzwrite(f, head, (unsigned)hl);
        if (bytes) gzwrite(f, data, (unsigned)bytes);
        gzclose(f);
        return;
    }
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (!f) return;
    fwrite(head, 1, hl, f);
    if (bytes) fwrite(data, 1, bytes, f);
    fclose(f);
}

/* Stores value n as a sample of size ts bytes (signed or float) in order big at dst. */
static void put(unsigned char *dst, size_t ts, int flt, int sgn, int big, double x) {
    unsigned char b[8];
    if (flt && ts == 4) {
        float f = (float)x;
        memcpy(b, &f, 4);
    } else if (flt) {
        memcpy(b, &x, 8);
    } else {
        int64_t i = (int64_t)x;
        uint64_t u = sgn ? (uint64_t)i : (uint64_t)x;
        for (size_t k = 0; k < 8; k++) b[k] = (unsigned char)(u >> (8 * k));
        /* b is little endian here */
        for (size_t k = 0; k < ts; k++) dst[big ? ts - 1 - k : k] = b[k];
        return;
    }
    /* host (little endian on every machine these tests run on) to the file's order */
    uint16_t one = 1;
    int host_little = *(unsigned char *)&one == 1;
    for (size_t k = 0; k < ts; k++) dst[(big == host_little) ? ts - 1 - k : k] = b[k];
}

typedef struct type_case {
    const char *type;
    int bits;
    const char *cpu;
    vm_scalar_type want;
} type_case;

static void inrReadsEveryTypeInBothByteOrdersWithItsSpacing(void) {
    static const type_case cases[] = {
        {"unsigned fixed", 8, "decm", VM_SCALAR_UINT8},
        {"signed fixed", 8, "sun", VM_SCALAR_INT8},
        {"unsigned fixed", 16, "sun", VM_SCALAR_UINT16},
        {"signed fixed", 16, "pc", VM_SCALAR_INT16},
        {"unsigned fixed", 32, "sgi", VM_SCALAR_UINT32},
        {"signed fixed", 32, "alpha", VM_SCALAR_INT32},
        {"signed fixed", 64, "sun", VM_SCALAR_INT64},
        {"float", 32, "decm", VM_SCALAR_FLOAT32},
        {"float", 32, "sgi", VM_SCALAR_FLOAT32},
        {"float", 64, "sun", VM_SCALAR_FLOAT64},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const type_case *t = &cases[c];
        int flt = t->type[0] == 'f', sgn = t->type[0] == 's', big = t->cpu[1] == 'u' || t->cpu[1] == 'g';
        size_t ts = (size_t)t->bits / 8;
        unsigned char data[NVOX * 8];
        for (size_t n = 0; n < NVOX; n++) {
            double x = value(n, sgn);
            if (t->bits == 8) x = sgn ? (double)(n % 200) - 100 : (double)(n % 256);
            put(data + n * ts, ts, flt, sgn, big, flt ? x + 0.25 : x);
        }
        char body[512], name[64];
        snprintf(body, sizeof body,
                 "XDIM=%d\nYDIM=%d\nZDIM=%d\nVDIM=1\nTYPE=%s\nPIXSIZE=%d bits\nSCALE=2**0\n"
                 "CPU=%s\nVX=0.5\nVY=0.75\nVZ=2\n#GEOMETRY=CARTESIAN\n",
                 NX, NY, NZ, t->type, t->bits, t->cpu);
        snprintf(name, sizeof name, "inr_type_%zu.inr", c);
        const char *path = vm_test_tmp(name);
        write_inr(path, body, data, NVOX * ts, 0);
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read(path, &v, &err), &err);
        if (!v.data) continue;
        CHECK(v.dims[0] == NX && v.dims[1] == NY && v.dims[2] == NZ && v.type == t->want);
        CHECK(v.spacing[0] == 0.5 && v.spacing[1] == 0.75 && v.spacing[2] == 2.0);
        CHECK(strcmp(v.format, "inrimage") == 0);
        size_t bad = 0;
        for (size_t n = 0; n < NVOX; n++) {
            double x = value(n, sgn);
            if (t->bits == 8) x = sgn ? (double)(n % 200) - 100 : (double)(n % 256);
            if (flt) x += 0.25;
            if (v.data[n] != (float)x && bad++ == 0)
                CHECK_MSG(0, "%s %d %s: voxel %zu is %g, expected %g", t->type, t->bits, t->cpu,
                          n, v.data[n], x);
        }
        vm_volume_free(&v);
    }
}

static const char FLOAT_BODY[] = "XDIM=5\nYDIM=4\nZDIM=6\nVDIM=1\nTYPE=float\nPIXSIZE=32 bits\n"
                                 "CPU=decm\nVX=1.5\nVY=1.5\nVZ=3\n";

static void inrGzAndSlabsReadLikeThePlainFile(void) {
    float data[NVOX];
    for (size_t n = 0; n < NVOX; n++) data[n] = (float)value(n, 1) * 0.5f;
    const char *plain = vm_test_tmp("inr_plain.inr"), *gz = vm_test_tmp("inr_packed.inr.gz");
    write_inr(plain, FLOAT_BODY, data, sizeof data, 0);
    write_inr(gz, FLOAT_BODY, data, sizeof data, 1);
    vm_volume a, b, s;
    vm_error err;
    CHECK_OK(vm_volume_read(plain, &a, &err), &err);
    CHECK_OK(vm_volume_read_inrimage(gz, &b, &err), &err);
    CHECK(a.data && b.data && memcmp(a.data, data, sizeof data) == 0 &&
          memcmp(b.data, data, sizeof data) == 0);
    CHECK(b.spacing[2] == 3.0);
    for (int g = 0; g < 2; g++) {
        CHECK_OK(vm_volume_read_slab(g ? gz : plain, 2, 5, &s, &err), &err);
        CHECK(s.dims[2] == 3 && s.data && memcmp(s.data, data + 2 * NX * NY, 3 * NX * NY * 4) == 0);
        CHECK_NEAR(s.origin[2], 6.0, 1e-12);
        vm_volume_free(&s);
    }
    /* the CLI reads it, with the spacing replaced on demand */
    char args[4400], *out = NULL;
    snprintf(args, sizeof args, "info '%s' --json", gz);
    CHECK(vm_test_cli(args, &out) == 0);
    CHECK_MSG(out && strstr(out, "\"format\": \"inrimage\", \"dims\": [5, 4, 6], \"type\": "
                                 "\"float32\"") && strstr(out, "\"spacing\": [1.5, 1.5, 3]"),
              "%s", out ? out : "");
    free(out);
    vm_volume_free(&a);
    vm_volume_free(&b);
}

/* Exit 2 from `volmesh info PATH`, one line naming the path and containing phrase. */
static void expect_refused(const char *path, const char *phrase) {
    char args[4400], *out = NULL;
    snprintf(args, sizeof args, "info '%s'", path);
    int rc = vm_test_cli(args, &out);
    const char *o = out ? out : "";
    CHECK_MSG(rc == 2, "info %s exited %d: %s", path, rc, o);
    CHECK_MSG(strstr(o, path) && strstr(o, phrase), "info %s printed '%s', without '%s'", path,
              o, phrase);
    CHECK_MSG(strchr(o, '\n') == o + strlen(o) - 1, "info %s: not one line: %s", path, o);
    free(out);
}

static void inrRefusesLyingAndTruncatedHeadersInOneLine(void) {
    float data[NVOX] = {0};
    static const struct {
        const char *body;
        size_t bytes;
        int gz;
        const char *phrase;
    } cases[] = {
        {FLOAT_BODY, sizeof data - 4, 0, "data is truncated (got 476 of the 480 bytes"},
        {"XDIM=50\nYDIM=40\nZDIM=60\nTYPE=float\nPIXSIZE=32 bits\n", sizeof data, 0,
         "data is truncated (got 480 of the 480000 bytes that 50x40x60 samples"},
        {"XDIM=500000\nYDIM=400000\nZDIM=600000\nTYPE=float\nPIXSIZE=32 bits\n", sizeof data,
         0, "dimensions 500000x400000x600000 need"},
        {FLOAT_BODY, 100, 1, "compressed data is truncated"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nVDIM=3\nTYPE=float\nPIXSIZE=32 bits\n", sizeof data, 0,
         "VDIM=3 (vector samples)"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=complex\nPIXSIZE=32 bits\n", sizeof data, 0,
         "TYPE=complex is not"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=12 bits\n", sizeof data, 0,
         "PIXSIZE=12 bits does not fit TYPE=float"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=32\n", sizeof data, 0,
         "PIXSIZE=32 is not 'N bits'"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=32 bits\nCPU=vax\n", sizeof data, 0,
         "CPU=vax is not"},
        {"XDIM=0\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=32 bits\n", sizeof data, 0,
         "XDIM=0 is not a positive whole number"},
        {"XDIM=5\nZDIM=6\nTYPE=float\nPIXSIZE=32 bits\n", sizeof data, 0, "header has no YDIM"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=32 bits\nVX=0\n", sizeof data, 0,
         "VX=0 is not a spacing"},
        {"XDIM=5\nYDIM=4\nZDIM=6\nTYPE=float\nPIXSIZE=32 bits\nVZ=nan\n", sizeof data, 0,
         "VZ=nan is not a spacing"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        char name[64];
        snprintf(name, sizeof name, "inr_bad_%zu.inr%s", c, cases[c].gz ? ".gz" : "");
        const char *path = vm_test_tmp(name);
        write_inr(path, cases[c].body, data, cases[c].bytes, cases[c].gz);
        expect_refused(path, cases[c].phrase);
    }
    /* headers that are not one: no magic, no end, not a multiple of 256, empty */
    const char *p = vm_test_tmp("inr_nomagic.inr");
    CHECK(vm_test_write_file(p, "#INRIMAGE-3#{\nXDIM=1\n##}\n", 25) == 0);
    expect_refused(p, "not an INRIMAGE-4 file");
    p = vm_test_tmp("inr_noend.inr");
    CHECK(vm_test_write_file(p, "#INRIMAGE-4#{\nXDIM=1\nYDIM=1\n", 28) == 0);
    expect_refused(p, "header has no '##}' line (file cut short)");
    p = vm_test_tmp("inr_short_header.inr");
    static const char short_header[] = "#INRIMAGE-4#{\nXDIM=1\nYDIM=1\nZDIM=1\nTYPE=unsigned "
                                       "fixed\nPIXSIZE=8 bits\n##}\nA";
    CHECK(vm_test_write_file(p, short_header, strlen(short_header)) == 0);
    expect_refused(p, "header of 74 bytes is not a multiple of 256");
    p = vm_test_tmp("inr_empty.inr");
    CHECK(vm_test_write_file(p, "", 0) == 0);
    expect_refused(p, "not an INRIMAGE-4 file");
}

TEST_MAIN(T(inrReadsEveryTypeInBothByteOrdersWithItsSpacing),
          T(inrGzAndSlabsReadLikeThePlainFile), T(inrRefusesLyingAndTruncatedHeadersInOneLine))
