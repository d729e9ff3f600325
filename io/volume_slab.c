/* SPDX-License-Identifier: BSD-3-Clause */
/* io/volume_slab.c — reading a volume by slabs of z planes: mapped files, and the sample
 * decoders every reader ends with (raw by seeking, zlib/gzip by streaming inflate that
 * discards what precedes the slab, ASCII by a streaming parse); zlib manual for inflate. */
#define _DEFAULT_SOURCE
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>
#include "../core/core.h"
#include "io_util.h"

const vm__slab vm__slab_whole = {0, 0, 1, 0, NULL, NULL, NULL, NULL};

/* A pipe or device is read into memory up to 1/PIPE_SHARE of the memory limit. */
enum { PIPE_SHARE = 2 };

static size_t page_size(void) {
    long pg = sysconf(_SC_PAGESIZE);
    return pg > 0 ? (size_t)pg : 4096;
}

vm_status vm__map_file(const char *path, size_t max_bytes, vm__map *m, vm_error *err) {
    memset(m, 0, sizeof *m);
    struct stat sb;
    if (stat(path, &sb) != 0)
        return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    if (S_ISDIR(sb.st_mode))
        return vm_error_set(err, VM_ERR_IO, "%s: is a directory, not a file", path);
    if (!S_ISREG(sb.st_mode) || (uint64_t)sb.st_size >= (uint64_t)SIZE_MAX / 2) {
        /* pipes and devices cannot be mapped: read them to their end (a gzip stream
         * arrives inflated, which every reader takes as well), but never more than half the
         * memory limit (--max-memory, VOLMESH_MAX_MEMORY, else physical memory): the other
         * half is for the samples as floats. /dev/zero has no end. */
        size_t cap = vm__memory_limit() / PIPE_SHARE;
        if (max_bytes < cap) cap = max_bytes;
        size_t len;
        vm_status st = vm__read_gz_file(path, cap, &m->p, &len, err);
        if (st == VM_ERR_NOMEM && err && strstr(err->message, "larger than allowed"))
            st = vm_error_set(err, VM_ERR_NOMEM, "%s: not a regular file, and longer than the "
                              "%zu bytes allowed (half of --max-memory or VOLMESH_MAX_MEMORY)",
                              path, cap);
        m->len = len;
        return st;
    }
    if ((uint64_t)sb.st_size > (uint64_t)max_bytes)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: file of %lld bytes is larger than allowed",
                            path, (long long)sb.st_size);
    int fd = open(path, O_RDONLY);
    if (fd < 0) return vm_error_set(err, VM_ERR_IO, "%s: cannot open (%s)", path, strerror(errno));
    size_t len = (size_t)sb.st_size, pg = page_size();
    size_t maplen = (len + 1 + pg - 1) / pg * pg;
    /* An anonymous (zero) mapping one byte longer than the file, with the file mapped over
     * its start: the byte after the file's last byte is a NUL, as vm__read_file gives. */
    void *base = mmap(NULL, maplen, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (base == MAP_FAILED) {
        close(fd);
        return vm_error_set(err, VM_ERR_NOMEM, "%s: cannot map %zu bytes", path, len);
    }
    if (len > 0 && mmap(base, len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_FIXED, fd, 0) ==
                       MAP_FAILED) {
        int e = errno;
        munmap(base, maplen);
        close(fd);
        return vm_error_set(err, VM_ERR_IO, "%s: cannot map (%s)", path, strerror(e));
    }
    close(fd);
    m->p = base;
    m->len = len;
    m->maplen = maplen;
    return VM_OK;
}

void vm__map_free(vm__map *m) {
    if (!m) return;
    if (m->maplen)
        munmap(m->p, m->maplen);
    else
        free(m->p);
    memset(m, 0, sizeof *m);
}

/* Gives back the whole pages of [from, to) of a mapping once read (they are file pages
 * never written, so a later touch would read them again). */
static void drop_pages(const vm__samples *s, const unsigned char *from, const unsigned char *to) {
    if (!s->mapped || to <= from) return;
    size_t pg = page_size();
    uintptr_t a = ((uintptr_t)from + pg - 1) / pg * pg, b = (uintptr_t)to / pg * pg;
    if (b > a) madvise((void *)a, (size_t)(b - a), MADV_DONTNEED);
}

vm_status vm__slab_check(const char *path, const vm__slab *rq, const int64_t dims[3],
                         size_t tsize, size_t *count, size_t *first, size_t *n,
                         vm_error *err) {
    *first = *n = 0;
    if (rq->all) {
        vm_status st = vm__check_dims(dims, tsize + sizeof(float), path, count, err);
        *n = *count;
        return st;
    }
    /* Slab and header reads: the whole volume need not fit in memory, only its size in a
     * size_t; the slab's floats must fit within the memory limit. */
    size_t c = 1, bytes;
    for (int a = 0; a < 3; a++) {
        if (dims[a] < 1)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: dimension %d is %lld (must be >= 1)",
                                path, a, (long long)dims[a]);
        if ((uint64_t)dims[a] > SIZE_MAX || vm__mul_overflows(c, (size_t)dims[a], &c))
            c = 0;
    }
    if (c == 0 || vm__mul_overflows(c, tsize + sizeof(float), &bytes))
        return vm_error_set(err, VM_ERR_NOMEM, "%s: dimensions %lldx%lldx%lld overflow", path,
                            (long long)dims[0], (long long)dims[1], (long long)dims[2]);
    *count = c;
    if (rq->header_only) return VM_OK;
    if (rq->z0 < 0 || rq->z1 > dims[2] || rq->z0 >= rq->z1)
        return vm_error_set(err, VM_ERR_ARG,
                            "%s: slab of planes %lld..%lld is outside the volume's planes "
                            "0..%lld (need 0 <= z0 < z1 <= %lld)",
                            path, (long long)rq->z0, (long long)rq->z1 - 1,
                            (long long)dims[2] - 1, (long long)dims[2]);
    int64_t sd[3] = {dims[0], dims[1], rq->z1 - rq->z0};
    size_t sn;
    vm_status st = vm__check_dims(sd, sizeof(float), path, &sn, err);
    if (st) return st;
    *first = (size_t)dims[0] * (size_t)dims[1] * (size_t)rq->z0;
    *n = sn;
    return VM_OK;
}

vm_status vm__slab_alloc(const char *path, const vm__slab *rq, size_t n, vm_volume *v,
                         vm_error *err) {
    v->data = rq->into ? rq->into : malloc((n ? n : 1) * sizeof(float));
    if (!v->data)
        return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory for %zu voxels", path, n);
    return VM_OK;
}

void vm__slab_release(vm_volume *v, const vm__slab *rq) {
    if (rq->into && v->data == rq->into) v->data = NULL;
    vm_volume_free(v);
}

void vm__resume_end(vm__resume *c) {
    if (c->zs) {
        inflateEnd(c->zs);
        free(c->zs);
    }
    memset(c, 0, sizeof *c);
}

/* 1 when c holds a position of stream s (encoding enc) at or before sample byte `from`
 * (ZLIB: decompressed bytes from the stream's start; ASCII: the value index). A cursor of
 * another stream, or one past `from`, is ended. */
static int resume_here(vm__resume *c, const vm__samples *s, size_t from) {
    if (!c || !c->live) return 0;
    size_t at = s->enc == VM__ENC_ZLIB ? c->done : c->index;
    if (c->enc == s->enc && c->avail == s->avail && c->skip == s->skip && from >= at) return 1;
    vm__resume_end(c);
    return 0;
}

/* Allocates the slab's floats and decodes them, unless only the header is asked for. */
vm_status vm__slab_read(const char *path, const vm__slab *rq, const vm__samples *src,
                        size_t first, size_t n, vm_volume *v, vm_error *err) {
    vm_status st = vm__check_geometry(v, path, err);
    if (st || rq->header_only) return st;
    st = vm__slab_alloc(path, rq, n, v, err);
    if (!st) st = vm__samples_decode(src, rq, first, n, v->data, err);
    return st;
}

/* Copies a header's dims, type and geometry into v and names the format. */
void vm__volume_set_header(vm_volume *v, const int64_t dims[3], vm_scalar_type type,
                           const double spacing[3], const double origin[3],
                           const double direction[3][3], const char *format) {
    memcpy(v->dims, dims, sizeof v->dims);
    v->type = type;
    memcpy(v->spacing, spacing, sizeof v->spacing);
    memcpy(v->origin, origin, sizeof v->origin);
    memcpy(v->direction, direction, sizeof v->direction);
    snprintf(v->format, sizeof v->format, "%s", format);
}

/* Moves v's origin to the slab's first plane and its dims to the slab's planes. */
void vm__slab_finish(vm_volume *v, const vm__slab *rq) {
    if (rq->spacing) memcpy(v->spacing, rq->spacing, sizeof v->spacing);
    if (rq->all || rq->header_only) return;
    for (int r = 0; r < 3; r++)
        v->origin[r] += v->direction[r][2] * (double)rq->z0 * v->spacing[2];
    v->dims[2] = rq->z1 - rq->z0;
}

enum { RAW_CHUNK = 1 << 22, STAGE = 1 << 20, IN_CHUNK = 1 << 22 };

static vm_status decode_raw(const vm__samples *s, size_t first, size_t n, float *dst) {
    size_t tsize = vm_scalar_type_size(s->type);
    const unsigned char *src = s->p + first * tsize;
    size_t per = RAW_CHUNK / tsize;
    for (size_t i = 0; i < n; i += per) {
        size_t m = n - i < per ? n - i : per;
        vm__samples_to_float(src + i * tsize, s->type, s->swap, m, dst + i);
        drop_pages(s, src + i * tsize, src + (i + m) * tsize);
    }
    return VM_OK;
}

/* Inflates until len bytes are at out (or the stream ends or fails); feeds the input in
 * chunks and gives back the pages consumed. [out] *got. Returns the last inflate code. */
static int inflate_into(const vm__samples *s, z_stream *zs, size_t *in_done,
                        unsigned char *out, size_t len, size_t *got) {
    int r = Z_OK;
    *got = 0;
    while (*got < len) {
        if (zs->avail_in == 0 && *in_done < s->avail) {
            size_t c = s->avail - *in_done < IN_CHUNK ? s->avail - *in_done : IN_CHUNK;
            drop_pages(s, s->p, s->p + *in_done);
            zs->next_in = (unsigned char *)s->p + *in_done;
            zs->avail_in = (uInt)c;
            *in_done += c;
        }
        size_t want = len - *got < (size_t)UINT_MAX ? len - *got : (size_t)UINT_MAX;
        zs->next_out = out + *got;
        zs->avail_out = (uInt)want;
        r = inflate(zs, Z_NO_FLUSH);
        size_t made = want - zs->avail_out;
        *got += made;
        if (r == Z_STREAM_END) return r;
        if (r != Z_OK && r != Z_BUF_ERROR) return r;
        /* inflate may hold output back with all input consumed: only no progress at the
         * end of the input means the stream is cut short */
        if (made == 0 && zs->avail_in == 0 && *in_done >= s->avail) return Z_BUF_ERROR;
    }
    return r;
}

static vm_status decode_zlib(const vm__samples *s, vm__resume *cur, size_t first, size_t n,
                             float *dst, vm_error *err) {
    size_t tsize = vm_scalar_type_size(s->type);
    size_t discard = s->skip + first * tsize, want = n * tsize, total = discard + want;
    unsigned char *stage = malloc(STAGE);
    if (!stage) return vm_error_set(err, VM_ERR_NOMEM, "%s: out of memory", s->path);
    z_stream own, *zs = &own;
    size_t in_done = 0, done = 0, got = 0;
    if (resume_here(cur, s, discard)) {
        /* go on where the previous slab stopped: the stream's state is the cursor's, its
         * unread input is at the same offset of this mapping of the file */
        zs = cur->zs;
        in_done = cur->in_done;
        done = cur->done;
        zs->next_in = (unsigned char *)s->p + (in_done - zs->avail_in);
    } else {
        if (cur) {
            cur->zs = calloc(1, sizeof(z_stream));
            zs = cur->zs;
        } else {
            memset(&own, 0, sizeof own);
        }
        if (!zs || inflateInit2(zs, 15 + 32) != Z_OK) {
            free(stage);
            if (cur) vm__resume_end(cur);
            return vm_error_set(err, VM_ERR_NOMEM, "%s: cannot start zlib", s->path);
        }
    }
    int r = Z_OK;
    while (done < discard) { /* the planes before the slab go through the stage */
        size_t c = discard - done < STAGE ? discard - done : STAGE;
        r = inflate_into(s, zs, &in_done, stage, c, &got);
        done += got;
        if (got < c) break;
    }
    size_t out = 0; /* samples written */
    while (done >= discard && out < n) {
        size_t c = (n - out) * tsize < STAGE ? (n - out) * tsize : STAGE / tsize * tsize;
        r = inflate_into(s, zs, &in_done, stage, c, &got);
        done += got;
        size_t m = got / tsize;
        /* inflate is serial: waking threads for each stage costs more than it saves */
        vm__samples_to_float_serial(stage, s->type, s->swap, m, dst + out);
        out += m;
        if (got < c) break;
    }
    /* A read that reaches the last sample inflates on to the stream's end, so that zlib
     * checks its trailer (gzip CRC-32 and ISIZE, zlib Adler-32; RFC 1950, 1952): a payload
     * that decodes to other samples is refused, not read as data. Bytes after the samples
     * (a NIfTI extension, padding) are inflated and dropped. */
    int checked = 0;
    if (done >= total && s->count && first + n == s->count) {
        while (r == Z_OK || r == Z_BUF_ERROR) {
            r = inflate_into(s, zs, &in_done, stage, STAGE, &got);
            if (r == Z_BUF_ERROR) break;
        }
        if (r != Z_STREAM_END) {
            const char *why = zs->msg ? zs->msg : "zlib error"; /* a static string */
            free(stage);
            if (cur)
                vm__resume_end(cur);
            else
                inflateEnd(zs);
            if (r == Z_BUF_ERROR)
                return vm_error_set(err, VM_ERR_FORMAT, "%s: compressed data is truncated "
                                    "(its checksum is missing)", s->path);
            return vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt compressed data (%s)",
                                s->path, why);
        }
        checked = 1;
    }
    free(stage);
    if (cur && done >= total && !checked) { /* keep the stream for the next slab */
        cur->live = 1;
        cur->enc = s->enc;
        cur->avail = s->avail;
        cur->skip = s->skip;
        cur->in_done = in_done;
        cur->done = done;
    } else if (cur) {
        vm__resume_end(cur);
    } else {
        inflateEnd(zs);
    }
    if (done < total) {
        if (r == Z_DATA_ERROR || r == Z_NEED_DICT || r == Z_STREAM_ERROR || r == Z_MEM_ERROR)
            return vm_error_set(err, VM_ERR_FORMAT, "%s: corrupt compressed data", s->path);
        return vm_error_set(err, VM_ERR_FORMAT,
                            "%s: compressed data is truncated (got %zu of %zu bytes)", s->path,
                            done, total);
    }
    return VM_OK;
}

static int ascii_sep(int c) { return isspace(c) || c == ','; }

size_t vm__count_words(const unsigned char *p, size_t n, size_t stop) {
    size_t words = 0, i = 0;
    while (words < stop) {
        while (i < n && ascii_sep(p[i])) i++;
        if (i >= n) break;
        words++;
        while (i < n && !ascii_sep(p[i])) i++;
    }
    return words;
}

static vm_status decode_ascii(const vm__samples *s, vm__resume *cur, size_t first, size_t n,
                              float *dst, vm_error *err) {
    const unsigned char *p = s->p, *end = s->p + s->avail;
    size_t total = first + n, i = 0;
    if (resume_here(cur, s, first)) { /* the values before the cursor are skipped */
        p += cur->done;
        i = cur->index;
    }
    const unsigned char *dropped = p;
    for (; i < total; i++) {
        while (p < end && ascii_sep(*p)) p++;
        if (p >= end)
            return vm_error_set(err, VM_ERR_FORMAT,
                                "%s: data is truncated (%zu of %zu ascii values)", s->path,
                                i, total);
        const unsigned char *w = p;
        while (p < end && !ascii_sep(*p)) p++;
        if (i < first) {
            if (p - dropped > IN_CHUNK) {
                drop_pages(s, dropped, w);
                dropped = w;
            }
            continue;
        }
        char word[400], *e;
        size_t wl = (size_t)(p - w);
        int ok = wl < sizeof word;
        double x = 0;
        if (ok) {
            memcpy(word, w, wl);
            word[wl] = 0;
            x = strtod(word, &e);
            ok = e != word && *e == 0;
        }
        if (!ok) {
            size_t k = 0;
            for (; k < 20 && w + k < p; k++) word[k] = isprint(w[k]) ? (char)w[k] : '?';
            word[k] = 0;
            return vm_error_set(err, VM_ERR_FORMAT, "%s: ascii value %zu ('%s') is not a number",
                                s->path, i, word);
        }
        if (x > FLT_MAX) x = INFINITY;
        if (x < -FLT_MAX) x = -INFINITY;
        dst[i - first] = (float)x;
    }
    if (cur) {
        cur->live = 1;
        cur->enc = s->enc;
        cur->avail = s->avail;
        cur->skip = s->skip;
        cur->done = (size_t)(p - s->p);
        cur->index = total;
    }
    return VM_OK;
}

vm_status vm__samples_decode(const vm__samples *s, const vm__slab *rq, size_t first, size_t n,
                             float *dst, vm_error *err) {
    switch (s->enc) {
    case VM__ENC_RAW: return decode_raw(s, first, n, dst);
    case VM__ENC_ZLIB: return decode_zlib(s, rq->cursor, first, n, dst, err);
    default: return decode_ascii(s, rq->cursor, first, n, dst, err);
    }
}
