/* SPDX-License-Identifier: BSD-3-Clause */
/* tests/io/test_gzip_trailer.c — the volume readers that inflate by slabs (gzip NRRD, .nii.gz,
 * compressed MetaImage) check the stream's trailer (issue 31, item 3; RFC 1950, 1952): a
 * flipped CRC-32, ISIZE or Adler-32 or a flipped payload bit is "corrupt compressed data". */
#include <stdint.h>
#include <string.h>
#include <zlib.h>
#include "test.h"

enum { NX = 16, NY = 12, NZ = 10, NV = NX * NY * NZ };

/* Varied samples (uint8), so that the stream holds literals and matches. */
static void samples(unsigned char *p) {
    unsigned x = 777;
    for (int i = 0; i < NV; i++) {
        x = x * 1103515245u + 12345u;
        p[i] = (unsigned char)((x >> 16) % 5 == 0 ? x >> 9 : (unsigned)i / 7);
    }
}

/* Compresses src (n bytes) after a prefix (plen bytes) into dst: gzip or zlib wrapper. */
static size_t squeeze(const unsigned char *prefix, size_t plen, const unsigned char *src,
                      size_t n, unsigned char *dst, size_t cap, int gzip) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (deflateInit2(&zs, 6, Z_DEFLATED, gzip ? 15 + 16 : 15, 8, Z_DEFAULT_STRATEGY) != Z_OK)
        return 0;
    zs.next_out = dst;
    zs.avail_out = (uInt)cap;
    if (plen) {
        zs.next_in = (unsigned char *)prefix;
        zs.avail_in = (uInt)plen;
        deflate(&zs, Z_NO_FLUSH);
    }
    zs.next_in = (unsigned char *)src;
    zs.avail_in = (uInt)n;
    int r = deflate(&zs, Z_FINISH);
    size_t len = cap - zs.avail_out;
    deflateEnd(&zs);
    return r == Z_STREAM_END ? len : 0;
}

/* A file of the given kind holding the samples; flip (0: none) XORs 0x10 into byte
 * `from_end` of the file counted from its end. */
typedef enum { NRRD, NIFTI, MHA } kind;
static const char *write_kind(kind k, int flip_from_end, const char *name) {
    static unsigned char vox[NV], z[4 * NV + 1024], file[4 * NV + 2048];
    samples(vox);
    size_t len = 0;
    if (k == NRRD) {
        char h[256];
        int hl = snprintf(h, sizeof h,
                          "NRRD0004\ntype: uint8\ndimension: 3\nsizes: %d %d %d\n"
                          "spacings: 1 1 1\nencoding: gzip\n\n", NX, NY, NZ);
        memcpy(file, h, (size_t)hl);
        len = (size_t)hl + squeeze(NULL, 0, vox, NV, file + hl, sizeof file - (size_t)hl, 1);
    } else if (k == NIFTI) {
        unsigned char h[352];
        memset(h, 0, sizeof h);
        int32_t sz = 348;
        memcpy(h, &sz, 4);
        int16_t dim[8] = {3, NX, NY, NZ, 1, 1, 1, 1};
        memcpy(h + 40, dim, sizeof dim);
        int16_t dt = 2, bp = 8; /* DT_UNSIGNED_CHAR */
        memcpy(h + 70, &dt, 2);
        memcpy(h + 72, &bp, 2);
        float pix[8] = {1, 1, 1, 1, 1, 1, 1, 1}, vo = 352;
        memcpy(h + 76, pix, sizeof pix);
        memcpy(h + 108, &vo, 4);
        memcpy(h + 344, "n+1", 4);
        len = squeeze(h, sizeof h, vox, NV, file, sizeof file, 1);
    } else {
        size_t zl = squeeze(NULL, 0, vox, NV, z, sizeof z, 0);
        char h[512];
        int hl = snprintf(h, sizeof h,
                          "ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\n"
                          "ElementSpacing = 1 1 1\nElementType = MET_UCHAR\n"
                          "CompressedData = True\nCompressedDataSize = %zu\n"
                          "ElementDataFile = LOCAL\n", NX, NY, NZ, zl);
        memcpy(file, h, (size_t)hl);
        memcpy(file + hl, z, zl);
        len = (size_t)hl + zl;
    }
    CHECK(len > 100);
    if (flip_from_end) file[len - (size_t)flip_from_end] ^= 0x10;
    const char *path = vm_test_tmp(name);
    CHECK(vm_test_write_file(path, file, len) == 0);
    return path;
}

static const char *name_of(kind k) {
    return k == NRRD ? "t.nrrd" : k == NIFTI ? "t.nii.gz" : "t.mha";
}

static void intactStreamsReadTheSamples(void) {
    unsigned char vox[NV];
    samples(vox);
    for (kind k = NRRD; k <= MHA; k++) {
        const char *path = write_kind(k, 0, name_of(k));
        vm_volume v;
        vm_error err;
        CHECK_OK(vm_volume_read(path, &v, &err), &err);
        int same = v.data != NULL;
        for (int i = 0; same && i < NV; i++) same = v.data[i] == (float)vox[i];
        CHECK_MSG(same, "kind %d: samples differ", (int)k);
        vm_volume_free(&v);
    }
}

/* The trailer's bytes: gzip's CRC-32 (8..5 from the end) and ISIZE (4..1); zlib's
 * Adler-32 (4..1). Each flip is refused, whole and as the last slab. */
static void aFlippedTrailerIsCorruptCompressedData(void) {
    static const struct {
        kind k;
        int from_end;
    } flips[] = {{NRRD, 8}, {NRRD, 6}, {NRRD, 4}, {NRRD, 1}, {NIFTI, 7},
                 {NIFTI, 5}, {NIFTI, 3}, {NIFTI, 2}, {MHA, 4}, {MHA, 1}};
    for (size_t c = 0; c < sizeof flips / sizeof flips[0]; c++) {
        const char *path = write_kind(flips[c].k, flips[c].from_end, name_of(flips[c].k));
        for (int slab = 0; slab < 2; slab++) {
            vm_volume v;
            vm_error err;
            vm_error_clear(&err);
            vm_status st = slab ? vm_volume_read_slab(path, NZ - 3, NZ, &v, &err)
                                : vm_volume_read(path, &v, &err);
            CHECK_MSG(st == VM_ERR_FORMAT, "case %zu slab %d: status %d", c, slab, (int)st);
            CHECK_MSG(strstr(err.message, "corrupt compressed data") != NULL &&
                          strstr(err.message, path) != NULL,
                      "case %zu slab %d: %s", c, slab, err.message);
            if (!st) vm_volume_free(&v);
        }
    }
}

/* A flipped bit anywhere in the deflate payload: never read as different samples. */
static void aFlippedPayloadBitIsNeverReadAsData(void) {
    for (kind k = NRRD; k <= MHA; k++) {
        for (int from_end = 40; from_end < 400; from_end += 37) {
            const char *path = write_kind(k, from_end, name_of(k));
            vm_volume v;
            vm_error err;
            vm_error_clear(&err);
            vm_status st = vm_volume_read(path, &v, &err);
            CHECK_MSG(st == VM_ERR_FORMAT, "kind %d at -%d: status %d", (int)k, from_end,
                      (int)st);
            CHECK_MSG(strstr(err.message, "compressed data") != NULL &&
                          strstr(err.message, path) != NULL,
                      "kind %d at -%d: %s", (int)k, from_end, err.message);
            if (!st) vm_volume_free(&v);
        }
    }
}

int main(void) {
    static const vm_test_case cases[] = {
        {"intactStreamsReadTheSamples", intactStreamsReadTheSamples},
        {"aFlippedTrailerIsCorruptCompressedData", aFlippedTrailerIsCorruptCompressedData},
        {"aFlippedPayloadBitIsNeverReadAsData", aFlippedPayloadBitIsNeverReadAsData},
    };
    return vm_test_run(cases, sizeof cases / sizeof cases[0]);
}
