/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_inflate.c — compressed payloads are checked to their last byte (issue 31,
 * item 3): vm__inflate_exact, behind the zlib data of VTI and VTU files, verifies the zlib
 * Adler-32 and the gzip CRC-32 and ISIZE (RFC 1950, 1952), and refuses a flipped checksum, a
 * missing trailer and data longer than announced, with "corrupt compressed data". */
#include <string.h>
#include <zlib.h>
#include "io/io_util.h"
#include "test.h"

enum { N = 4096 };

/* The test payload: varied bytes, so that it compresses into several blocks. */
static void payload(unsigned char *p, size_t n) {
    unsigned x = 12345;
    for (size_t i = 0; i < n; i++) {
        x = x * 1103515245u + 12345u;
        p[i] = (unsigned char)((x >> 16) % 7 == 0 ? x >> 8 : i / 13);
    }
}

/* Compresses src into dst (zlib wrapper, or gzip with gzip != 0); returns the length. */
static size_t squeeze(const unsigned char *src, size_t n, unsigned char *dst, size_t cap,
                      int gzip) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (deflateInit2(&zs, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
        return 0;
    zs.next_in = (unsigned char *)src;
    zs.avail_in = (uInt)n;
    zs.next_out = dst;
    zs.avail_out = (uInt)cap;
    int r = deflate(&zs, Z_FINISH);
    size_t len = cap - zs.avail_out;
    deflateEnd(&zs);
    return r == Z_STREAM_END ? len : 0;
}

/* Inflates len bytes of z into N bytes; returns the status, with the message in err. */
static vm_status unpack(const unsigned char *z, size_t len, unsigned char *out, vm_error *err) {
    vm_error_clear(err);
    return vm__inflate_exact("data.vti", z, len, out, N, err);
}

static void intactZlibAndGzipDataInflateToTheBytes(void) {
    static unsigned char src[N], z[2 * N], out[N];
    payload(src, N);
    for (int gzip = 0; gzip < 2; gzip++) {
        size_t len = squeeze(src, N, z, sizeof z, gzip);
        CHECK(len > 0);
        vm_error err;
        CHECK_OK(unpack(z, len, out, &err), &err);
        CHECK(memcmp(src, out, N) == 0);
    }
}

static void aFlippedChecksumOrLengthIsCorruptData(void) {
    static unsigned char src[N], z[2 * N], out[N];
    payload(src, N);
    /* zlib: the last 4 bytes are the Adler-32; gzip: CRC-32, then ISIZE */
    static const struct {
        int gzip, from_end;
    } flips[] = {{0, 1}, {0, 4}, {1, 8}, {1, 5}, {1, 4}, {1, 1}};
    for (size_t c = 0; c < sizeof flips / sizeof flips[0]; c++) {
        size_t len = squeeze(src, N, z, sizeof z, flips[c].gzip);
        z[len - (size_t)flips[c].from_end] ^= 0x10;
        vm_error err;
        vm_status st = unpack(z, len, out, &err);
        CHECK_MSG(st == VM_ERR_FORMAT, "case %zu: status %d", c, (int)st);
        CHECK_MSG(strstr(err.message, "data.vti: corrupt compressed data") != NULL,
                  "case %zu: %s", c, err.message);
    }
}

static void aMissingTrailerIsTruncatedData(void) {
    static unsigned char src[N], z[2 * N], out[N];
    payload(src, N);
    for (int gzip = 0; gzip < 2; gzip++) {
        size_t len = squeeze(src, N, z, sizeof z, gzip);
        vm_error err;
        vm_status st = unpack(z, len - 4, out, &err);
        CHECK(st == VM_ERR_FORMAT);
        CHECK_MSG(strstr(err.message, "truncated") != NULL, "%s", err.message);
    }
}

static void moreDataThanAnnouncedIsRefused(void) {
    static unsigned char src[N + 100], z[2 * N], out[N];
    payload(src, N + 100);
    size_t len = squeeze(src, N + 100, z, sizeof z, 0);
    vm_error err;
    CHECK(unpack(z, len, out, &err) == VM_ERR_FORMAT);
    CHECK_MSG(strstr(err.message, "100 bytes more than the 4096 expected") != NULL, "%s",
              err.message);
}

TEST_MAIN(T(intactZlibAndGzipDataInflateToTheBytes), T(aFlippedChecksumOrLengthIsCorruptData),
          T(aMissingTrailerIsTruncatedData), T(moreDataThanAnnouncedIsRefused))
