/* SPDX-License-Identifier: BSD-3-Clause */
/* quality/png.c — PNG encoding of RGB images (8-bit truecolour, adaptive per-row filters).
 * Follows the PNG specification (ISO/IEC 15948:2003, W3C PNG 2nd ed.): sections 5 (chunks,
 * CRC-32), 9 (filter types 0-4 and the Paeth predictor) and 10 (zlib/deflate compression). */
#include "../core/core.h"
#include "../io/io_util.h"
#include "volmesh/render.h"
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

void vm_image_free(vm_image *img) {
    if (!img) return;
    free(img->pixels);
    memset(img, 0, sizeof *img);
}

static void put_be32(unsigned char *p, uint32_t v) {
    p[0] = (unsigned char)(v >> 24);
    p[1] = (unsigned char)(v >> 16);
    p[2] = (unsigned char)(v >> 8);
    p[3] = (unsigned char)v;
}

/* Writes one chunk (length, type, data, CRC over type and data) at out; returns its size. */
static size_t put_chunk(unsigned char *out, const char type[4], const unsigned char *data,
                        size_t len) {
    put_be32(out, (uint32_t)len);
    memcpy(out + 4, type, 4);
    if (len) memcpy(out + 8, data, len);
    uLong crc = crc32(0L, Z_NULL, 0);
    crc = crc32(crc, out + 4, 4);
    /* crc32 takes a uInt length; the IDAT is compressed in one piece below UINT_MAX. */
    if (len) crc = crc32(crc, out + 8, (uInt)len);
    put_be32(out + 8 + len, (uint32_t)crc);
    return len + 12;
}

/* The Paeth predictor (PNG spec 9.4): the neighbour nearest to a + b - c. */
static unsigned char paeth(int a, int b, int c) {
    int p = a + b - c;
    int pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
    if (pa <= pb && pa <= pc) return (unsigned char)a;
    if (pb <= pc) return (unsigned char)b;
    return (unsigned char)c;
}

/* Filters row cur (prev: the row above, or NULL for the first) with filter type t into out
 * (n bytes, 3 bytes per pixel); returns the sum of |filtered byte| read as signed, the
 * heuristic of PNG spec 12.8 for choosing a filter per row. */
static unsigned long filter_row(int t, const unsigned char *cur, const unsigned char *prev,
                                size_t n, unsigned char *out) {
    unsigned long cost = 0;
    for (size_t i = 0; i < n; i++) {
        int a = i >= 3 ? cur[i - 3] : 0;
        int b = prev ? prev[i] : 0;
        int c = (prev && i >= 3) ? prev[i - 3] : 0;
        int pred = 0;
        switch (t) {
        case 1: pred = a; break;
        case 2: pred = b; break;
        case 3: pred = (a + b) / 2; break;
        case 4: pred = paeth(a, b, c); break;
        default: pred = 0; break;
        }
        unsigned char v = (unsigned char)(cur[i] - pred);
        out[i] = v;
        cost += v < 128 ? v : 256u - v;
    }
    return cost;
}

vm_status vm_image_encode_png(const vm_image *img, unsigned char **buf, size_t *len,
                              vm_error *err) {
    *buf = NULL;
    *len = 0;
    if (!img || !img->pixels || img->width <= 0 || img->height <= 0)
        return vm_error_set(err, VM_ERR_ARG, "png: the image is empty");
    size_t w = (size_t)img->width, h = (size_t)img->height, row, raw;
    if (vm__mul_overflows(w, 3, &row) || vm__mul_overflows(row + 1, h, &raw) || raw > 0x7f000000u ||
        w > 0x7fffffffu || h > 0x7fffffffu)
        return vm_error_set(err, VM_ERR_NOMEM, "png: a %d x %d image is too large",
                            img->width, img->height);
    unsigned char *filtered = malloc(raw);
    unsigned char *trial = malloc(row);
    uLong bound = compressBound((uLong)raw);
    size_t cap = (size_t)bound + 8 + 25 + 12 + 12;
    unsigned char *out = malloc(cap);
    if (!filtered || !trial || !out) {
        free(filtered);
        free(trial);
        free(out);
        return vm_error_set(err, VM_ERR_NOMEM, "png: out of memory for a %d x %d image",
                            img->width, img->height);
    }
    for (size_t y = 0; y < h; y++) {
        const unsigned char *cur = img->pixels + y * row;
        const unsigned char *prev = y ? cur - row : NULL;
        unsigned char *dst = filtered + y * (row + 1);
        unsigned long best = 0;
        for (int t = 0; t <= 4; t++) {
            unsigned long cost = filter_row(t, cur, prev, row, trial);
            if (t == 0 || cost < best) {
                best = cost;
                dst[0] = (unsigned char)t;
                memcpy(dst + 1, trial, row);
            }
        }
    }
    free(trial);

    /* Signature, IHDR, then the IDAT written in place after room for its header. */
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    memcpy(out, sig, 8);
    unsigned char ihdr[13];
    put_be32(ihdr, (uint32_t)w);
    put_be32(ihdr + 4, (uint32_t)h);
    ihdr[8] = 8;  /* bit depth */
    ihdr[9] = 2;  /* colour type: truecolour */
    ihdr[10] = 0; /* deflate */
    ihdr[11] = 0; /* adaptive filtering */
    ihdr[12] = 0; /* no interlace */
    size_t at = 8 + put_chunk(out + 8, "IHDR", ihdr, sizeof ihdr);
    uLongf zlen = bound;
    int zs = compress2(out + at + 8, &zlen, filtered, (uLong)raw, 9);
    free(filtered);
    if (zs != Z_OK) {
        free(out);
        return vm_error_set(err, zs == Z_MEM_ERROR ? VM_ERR_NOMEM : VM_ERR_INTERNAL,
                            "png: deflate failed (%s)", zError(zs));
    }
    /* The compressed bytes are already in place: write the chunk's length, type and CRC
     * around them (put_chunk would memcpy the data onto itself). */
    put_be32(out + at, (uint32_t)zlen);
    memcpy(out + at + 4, "IDAT", 4);
    uLong crc = crc32(crc32(0L, Z_NULL, 0), out + at + 4, (uInt)(4 + zlen));
    put_be32(out + at + 8 + zlen, (uint32_t)crc);
    at += 12 + (size_t)zlen;
    at += put_chunk(out + at, "IEND", NULL, 0);
    *buf = out;
    *len = at;
    return VM_OK;
}

vm_status vm_image_write_png(const char *path, const vm_image *img, vm_error *err) {
    unsigned char *buf = NULL;
    size_t len = 0;
    vm_status st = vm_image_encode_png(img, &buf, &len, err);
    if (st) return st;
    vm_outfile o;
    st = vm__out_open(&o, path, err);
    if (st) {
        free(buf);
        return st;
    }
    fwrite(buf, 1, len, o.fp); /* a short write sets the stream's error: commit names it */
    free(buf);
    return vm__out_commit(&o, err);
}
