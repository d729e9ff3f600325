/* SPDX-License-Identifier: BSD-3-Clause */
/* io/io_util.c — file reading, zlib inflation and sample conversion shared by every reader
 * and writer (zlib manual: inflateInit2 windowBits 15+32 detects
 * zlib and gzip headers). */
#define _POSIX_C_SOURCE 200809L
#include "io_util.h"
#include <ctype.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include "../core/core.h"

static vm_status check_regular(const char *path, struct stat *sb, vm_error *err) {
    if (stat(path, sb) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    if (S_ISDIR(sb->st_mode))
        return vm_error_set(err, VM_ERR_IO, "%s: is a directory, not a file", path);
    return VM_OK;
}

vm_status vm__read_file(const char *path, size_t max_bytes, unsigned char **buf, size_t *len,
                        vm_error *err) {
    struct stat sb;
    *buf = NULL;
    *len = 0;
    vm_status st = check_regular(path, &sb, err);
    if (st) return st;
    if ((uint64_t)sb.st_size > (uint64_t)max_bytes)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: file of %lld bytes is larger than allowed",
                            path, (long long)sb.st_size);
    FILE *fp = fopen(path, "rb");
    if (!fp) return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    size_t n = (size_t)sb.st_size;
    unsigned char *b = malloc(n + 1);
    if (!b) {
        fclose(fp);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for %zu bytes", path, n);
    }
    size_t got = fread(b, 1, n, fp);
    int bad = ferror(fp);
    fclose(fp);
    if (bad || got != n) {
        free(b);
        return vm_error_set(err, VM_ERR_IO, "%s: read error", path);
    }
    b[n] = 0;
    *buf = b;
    *len = n;
    return VM_OK;
}

vm_status vm__read_gz_file(const char *path, size_t max_bytes, unsigned char **buf,
                           size_t *len, vm_error *err) {
    struct stat sb;
    *buf = NULL;
    *len = 0;
    vm_status st = check_regular(path, &sb, err);
    if (st) return st;
    gzFile gz = gzopen(path, "rb");
    if (!gz) return vm_error_set(err, VM_ERR_IO, "%s: cannot open", path);
    size_t cap = 1 << 16, n = 0;
    unsigned char *b = malloc(cap + 1);
    if (!b) {
        gzclose(gz);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
    }
    for (;;) {
        if (n == cap) {
            if (cap >= max_bytes) {
                free(b);
                gzclose(gz);
                return vm_error_set(err, VM_ERR_NOMEM, "%s: uncompressed data is larger than "
                                    "allowed", path);
            }
            size_t ncap = cap * 2 > max_bytes ? max_bytes : cap * 2;
            unsigned char *nb = realloc(b, ncap + 1);
            if (!nb) {
                free(b);
                gzclose(gz);
                return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", path);
            }
            b = nb;
            cap = ncap;
        }
        size_t want = cap - n;
        if (want > (1u << 30)) want = 1u << 30;
        int r = gzread(gz, b + n, (unsigned)want);
        if (r < 0) {
            int code;
            const char *msg = gzerror(gz, &code);
            vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt compressed data (%s)", path,
                         msg ? msg : "zlib error");
            free(b);
            gzclose(gz);
            return VM_ERR_FORMAT;
        }
        if (r == 0) break;
        n += (size_t)r;
    }
    /* gzread stops quietly at a truncated gzip member: ask whether it ended cleanly. */
    int code = Z_OK;
    gzerror(gz, &code);
    gzclose(gz);
    if (code != Z_OK && code != Z_STREAM_END) {
        free(b);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: compressed data is truncated", path);
    }
    b[n] = 0;
    *buf = b;
    *len = n;
    return VM_OK;
}

/* Inflates the start of a gzip or zlib stream: at most cap bytes (a header to parse). */
vm_status vm__gz_prefix(const char *path, const unsigned char *p, size_t n, unsigned char *out,
                        size_t cap, size_t *got, vm_error *err) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    *got = 0;
    if (inflateInit2(&zs, 15 + 32) != Z_OK)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: cannot start zlib", path);
    zs.next_in = (unsigned char *)p;
    zs.avail_in = (uInt)(n < (1u << 30) ? n : (1u << 30));
    zs.next_out = out;
    zs.avail_out = (uInt)cap;
    int r = inflate(&zs, Z_SYNC_FLUSH);
    *got = cap - zs.avail_out;
    inflateEnd(&zs);
    if (r != Z_OK && r != Z_STREAM_END && r != Z_BUF_ERROR)
        return vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt compressed data", path);
    return VM_OK;
}

vm_status vm__inflate_exact(const char *path, const unsigned char *src, size_t src_len,
                            unsigned char *dst, size_t dst_len, vm_error *err) {
    z_stream zs;
    memset(&zs, 0, sizeof zs);
    if (inflateInit2(&zs, 15 + 32) != Z_OK)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: cannot start zlib", path);
    size_t in_done = 0, out_done = 0;
    int r = Z_OK;
    while (out_done < dst_len) {
        size_t in_chunk = src_len - in_done, out_chunk = dst_len - out_done;
        if (in_chunk > (1u << 30)) in_chunk = 1u << 30;
        if (out_chunk > (1u << 30)) out_chunk = 1u << 30;
        zs.next_in = (unsigned char *)src + in_done;
        zs.avail_in = (uInt)in_chunk;
        zs.next_out = dst + out_done;
        zs.avail_out = (uInt)out_chunk;
        r = inflate(&zs, Z_NO_FLUSH);
        in_done += in_chunk - zs.avail_in;
        out_done += out_chunk - zs.avail_out;
        if (r == Z_STREAM_END) break;
        if (r != Z_OK) break;
        if (zs.avail_in == 0 && in_done == src_len && zs.avail_out != 0) {
            r = Z_BUF_ERROR;
            break;
        }
    }
    /* The output is full: inflate on to the end of the stream, so that zlib reads the trailer
     * and checks it (Adler-32 for zlib, CRC-32 and ISIZE for gzip; RFC 1950, 1952). */
    size_t extra = 0;
    while (out_done == dst_len && r == Z_OK) {
        unsigned char spill[64];
        size_t in_chunk = src_len - in_done;
        if (in_chunk > (1u << 30)) in_chunk = 1u << 30;
        zs.next_in = (unsigned char *)src + in_done;
        zs.avail_in = (uInt)in_chunk;
        zs.next_out = spill;
        zs.avail_out = sizeof spill;
        r = inflate(&zs, Z_NO_FLUSH);
        in_done += in_chunk - zs.avail_in;
        extra += sizeof spill - zs.avail_out;
        if (r == Z_OK && zs.avail_out == sizeof spill && in_done == src_len) r = Z_BUF_ERROR;
    }
    const char *why = zs.msg;
    inflateEnd(&zs);
    if (out_done < dst_len || r != Z_STREAM_END) {
        if (r == Z_DATA_ERROR || r == Z_NEED_DICT || r == Z_STREAM_ERROR)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt compressed data (%s)", path,
                                why ? why : "zlib error");
        if (out_done < dst_len)
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: compressed data is truncated (got %zu of %zu bytes)", path,
                                out_done, dst_len);
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: compressed data is truncated (its checksum is missing)", path);
    }
    if (extra)
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: compressed data holds %zu bytes more than the %zu expected",
                            path, extra, dst_len);
    return VM_OK;
}

int vm__host_little_endian(void) {
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

#define CONVERT(T)                                                                         \
    do {                                                                                   \
        const unsigned char *s = src;                                                      \
        for (size_t i = 0; i < n; i++) {                                                   \
            unsigned char tmp[sizeof(T)];                                                  \
            T val;                                                                         \
            if (swap) {                                                                    \
                for (size_t b = 0; b < sizeof(T); b++) tmp[b] = s[i * sizeof(T) + sizeof(T) - 1 - b]; \
                memcpy(&val, tmp, sizeof(T));                                              \
            } else {                                                                       \
                memcpy(&val, s + i * sizeof(T), sizeof(T));                                \
            }                                                                              \
            dst[i] = (float)val;                                                           \
        }                                                                                  \
    } while (0)

static void convert_block(const void *src, vm_scalar_type t, int swap, size_t n, float *dst) {
    switch (t) {
    case VM_SCALAR_UINT8: CONVERT(uint8_t); break;
    case VM_SCALAR_INT8: CONVERT(int8_t); break;
    case VM_SCALAR_UINT16: CONVERT(uint16_t); break;
    case VM_SCALAR_INT16: CONVERT(int16_t); break;
    case VM_SCALAR_UINT32: CONVERT(uint32_t); break;
    case VM_SCALAR_INT32: CONVERT(int32_t); break;
    case VM_SCALAR_UINT64: CONVERT(uint64_t); break;
    case VM_SCALAR_INT64: CONVERT(int64_t); break;
    case VM_SCALAR_FLOAT32: CONVERT(float); break;
    case VM_SCALAR_FLOAT64: CONVERT(double); break;
    }
}

void vm__samples_to_float_serial(const void *src, vm_scalar_type t, int swap, size_t n,
                                 float *dst) {
    convert_block(src, t, swap, n, dst);
}

void vm__samples_to_float(const void *src, vm_scalar_type t, int swap, size_t n, float *dst) {
    enum { BLOCK = 1 << 16 }; /* samples per task: big enough to amortise, small to balance */
#ifdef VM_HAVE_OPENMP
    if (n >= 4 * (size_t)BLOCK) {
        const unsigned char *s = src;
        size_t ts = vm_scalar_type_size(t);
        int64_t nb = (int64_t)((n + BLOCK - 1) / BLOCK);
#pragma omp parallel for schedule(static)
        for (int64_t b = 0; b < nb; b++) {
            size_t i = (size_t)b * BLOCK, m = n - i < (size_t)BLOCK ? n - i : (size_t)BLOCK;
            convert_block(s + i * ts, t, swap, m, dst + i);
        }
        return;
    }
#endif
    convert_block(src, t, swap, n, dst);
}

int vm__path_sibling(const char *path, const char *name, char *out, size_t cap) {
    if (name[0] == '/') return (size_t)snprintf(out, cap, "%s", name) < cap;
    const char *slash = strrchr(path, '/');
    int dirlen = slash ? (int)(slash - path + 1) : 0;
    return (size_t)snprintf(out, cap, "%.*s%s", dirlen, path, name) < cap;
}

int vm__ends_with(const char *path, const char *suffix) {
    size_t a = strlen(path), b = strlen(suffix);
    return a >= b && strcasecmp(path + a - b, suffix) == 0;
}

char *vm__trim(char *s) {
    while (*s && isspace((unsigned char)*s)) s++;
    size_t n = strlen(s);
    while (n > 0 && isspace((unsigned char)s[n - 1])) s[--n] = 0;
    return s;
}

/* The base64 alphabet: A-Z, a-z, 0-9, '+', '/' in that order. */
int vm__base64_value(int c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
}

int vm__parse_doubles(const char *s, double *out, int max) {
    int count = 0;
    while (*s) {
        while (*s && (isspace((unsigned char)*s) || *s == ',' || *s == '(' || *s == ')')) s++;
        if (!*s) break;
        if (count == max) return -1;
        char *end;
        errno = 0;
        double v = strtod(s, &end);
        if (end == s || errno == ERANGE) return -1;
        out[count++] = v;
        s = end;
    }
    return count;
}

