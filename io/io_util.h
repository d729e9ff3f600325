/* SPDX-License-Identifier: BSD-3-Clause */
/* io/io_util.h — private helpers shared by the readers and writers: whole-file reads,
 * zlib/gzip inflation, sample conversion, header-line parsing, atomic output files. */
#ifndef VM_IO_UTIL_H
#define VM_IO_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "../core/core.h"
#include "volmesh/error.h"
#include "volmesh/io.h"
#include "volmesh/volume.h"

/* Reads the whole file (refusing directories and files above max_bytes).
 * [out] *buf (malloc'd, one extra NUL byte appended), *len. */
vm_status vm__read_file(const char *path, size_t max_bytes, unsigned char **buf, size_t *len,
                        vm_error *err);

/* Reads a file that may be gzip-compressed (or plain), fully, up to max_bytes of output. */
vm_status vm__read_gz_file(const char *path, size_t max_bytes, unsigned char **buf,
                           size_t *len, vm_error *err);

/* Inflates src (zlib or gzip stream, detected) into exactly dst_len bytes of dst.
 * A stream that ends early is VM_ERR_FORMAT "PATH: compressed data is truncated ...". */
vm_status vm__inflate_exact(const char *path, const unsigned char *src, size_t src_len,
                            unsigned char *dst, size_t dst_len, vm_error *err);

/* Inflates the first up to cap bytes of the gzip or zlib stream at p (n bytes) into out, to
 * parse a header inside the stream. [out] *got: bytes inflated (fewer when the stream ends
 * or is cut short); corrupt data is VM_ERR_FORMAT "PATH: corrupt compressed data". */
vm_status vm__gz_prefix(const char *path, const unsigned char *p, size_t n, unsigned char *out,
                        size_t cap, size_t *got, vm_error *err);

/* Converts n samples of type t at src (native or swapped byte order) into floats; with
 * OpenMP, blocks of samples on several threads (elementwise, so the same for any count). */
void vm__samples_to_float(const void *src, vm_scalar_type t, int swap, size_t n, float *dst);
/* The same on the calling thread only (for small pieces inside a serial loop). */
void vm__samples_to_float_serial(const void *src, vm_scalar_type t, int swap, size_t n,
                                 float *dst);

/* ---- Volumes read by slabs ----------------------------------------------------------- */

/* A file mapped read-only (private copy-on-write pages: a parser may write NULs into the
 * header), with one NUL byte after the last byte like vm__read_file. Only the pages that are
 * touched are read; vm__map_drop gives pages back once they have been used. */
typedef struct vm__map {
    unsigned char *p;
    size_t len;    /* file size */
    size_t maplen; /* bytes mapped (len + 1 rounded up to pages) */
} vm__map;
vm_status vm__map_file(const char *path, size_t max_bytes, vm__map *m, vm_error *err);
void vm__map_free(vm__map *m);

/* Where a forward reader stopped in a stream of samples (vm_volume_reader): a gzip/zlib
 * stream's inflate state, or an ASCII text's position, so that the next slab further on
 * goes on from there instead of from the start. live = 0: nothing kept. */
typedef struct vm__resume {
    int live, enc;
    size_t avail, skip; /* the stream it belongs to (vm__samples avail, skip) */
    void *zs;           /* ZLIB: the z_stream (heap) */
    size_t in_done;     /* ZLIB: compressed bytes handed to inflate, from the stream's start */
    size_t done;        /* ZLIB: bytes inflated; ASCII: byte offset after the last value */
    size_t index;       /* ASCII: values parsed */
} vm__resume;
/* Ends a cursor's inflate stream, if any (live = 0). */
void vm__resume_end(vm__resume *c);

/* Which planes a reader returns: z0 <= k < z1, or (all = 1) the whole volume; header_only
 * sets the header and dims of the whole volume and reads no sample. into (NULL: allocate)
 * is where the slab's floats go, owned by the caller; cursor (NULL: none) lets a gzip stream
 * or ASCII text go on from where the previous read of the same file stopped. spacing (NULL:
 * the file's) replaces the voxel spacing, applied by vm__slab_finish before it moves the
 * origin; series (NULL: the default) is the DICOM series choice. */
typedef struct vm__slab {
    int64_t z0, z1;
    int all, header_only;
    float *into;
    vm__resume *cursor;
    const double *spacing;
    const char *series;
} vm__slab;
extern const vm__slab vm__slab_whole;

/* How the samples are stored. */
enum { VM__ENC_RAW, VM__ENC_ZLIB, VM__ENC_ASCII };
typedef struct vm__samples {
    const char *path;        /* for messages */
    const unsigned char *p;  /* RAW: sample 0; ZLIB: the zlib/gzip stream; ASCII: the text */
    size_t avail;            /* bytes from p to the end of the data */
    int enc;
    size_t skip;             /* ZLIB: decompressed bytes before sample 0 */
    vm_scalar_type type;
    int swap;
    int mapped;              /* p lies in a vm__map's mapping (maplen != 0, not a buffer read
                                from a pipe): pages are given back as they are read */
    size_t count;            /* ZLIB: samples in the stream (0: unknown); a read that reaches
                                the last one checks the stream's trailer (CRC-32, ISIZE) */
} vm__samples;

/* Checks dims for the request: a whole read as vm__check_dims(dims, tsize + 4) (within
 * the memory limit); a slab or header read only against overflow, then the z range
 * (0 <= z0 < z1 <= nz, "PATH: slab of planes ... is outside ...") and the slab's floats
 * against the memory limit. [out] *count: nx*ny*nz; *first: index of the slab's first
 * sample; *n: samples to read (0 for header_only). */
vm_status vm__slab_check(const char *path, const vm__slab *rq, const int64_t dims[3],
                         size_t tsize, size_t *count, size_t *first, size_t *n,
                         vm_error *err);

/* v->data = n floats ("PATH: out of memory for N voxels"), or rq->into when given. */
vm_status vm__slab_alloc(const char *path, const vm__slab *rq, size_t n, vm_volume *v,
                         vm_error *err);

/* vm_volume_free(v) after a failed read, leaving rq->into (the caller's) alone. */
void vm__slab_release(vm_volume *v, const vm__slab *rq);

/* The words (runs of characters other than white space and ',') of the n bytes at p, counting
 * up to stop: an ASCII reader refuses a text with fewer than its values before allocating
 * them, so that a truncated file is reported as such and not as a lack of memory. */
size_t vm__count_words(const unsigned char *p, size_t n, size_t stop);

/* Decodes samples first .. first+n-1 of s into dst (RAW by seeking, ZLIB by streaming
 * inflate discarding what precedes, ASCII by a streaming parse skipping values; with
 * rq->cursor, ZLIB and ASCII go on from the cursor when first is at or past it). RAW callers
 * check the data size first; ZLIB and ASCII report truncation here. */
vm_status vm__samples_decode(const vm__samples *s, const vm__slab *rq, size_t first, size_t n,
                             float *dst, vm_error *err);

/* The samples of the slab rq into v (its header set): nothing for a header-only request,
 * else v->data from vm__slab_alloc filled by vm__samples_decode of samples first ..
 * first+n-1. The caller then calls vm__slab_finish (after any scaling of the samples). */
vm_status vm__slab_read(const char *path, const vm__slab *rq, const vm__samples *src,
                        size_t first, size_t n, vm_volume *v, vm_error *err);

/* Sets v's header as a file states it: dims, sample type, spacing, origin, direction
 * (columns: the axes' unit vectors) and the format name. */
void vm__volume_set_header(vm_volume *v, const int64_t dims[3], vm_scalar_type type,
                           const double spacing[3], const double origin[3],
                           const double direction[3][3], const char *format);

/* 1 when s is a voxel spacing every reader accepts (finite, VM_SPACING_MIN..MAX). */
static inline int vm__spacing_in_range(double s) {
    return s >= VM_SPACING_MIN && s <= VM_SPACING_MAX; /* false for NaN */
}

/* Turns v (the whole volume's header, dims and geometry set, data NULL) into the slab rq:
 * spacing replaced by rq->spacing when given, then dims[2] = z1 - z0, origin moved to the
 * world position of voxel (0, 0, z0). */
void vm__slab_finish(vm_volume *v, const vm__slab *rq);

/* 1 when this machine is little endian. */
int vm__host_little_endian(void);

/* Directory part of path joined with name (name returned as-is when absolute).
 * [out] out of size cap; returns 0 when it does not fit. */
int vm__path_sibling(const char *path, const char *name, char *out, size_t cap);

/* Case-insensitive check that path ends with suffix. */
int vm__ends_with(const char *path, const char *suffix);

/* Trims leading/trailing white space in place, returns s. */
char *vm__trim(char *s);

/* Parses up to max doubles separated by spaces, commas or parentheses; returns the count
 * parsed, or -1 on a malformed number. */
int vm__parse_doubles(const char *s, double *out, int max);

/* Value 0..63 of a base64 character (RFC 4648, section 4), or -1 for any other. */
int vm__base64_value(int c);

/* The format readers behind vm_volume_read*, reading what rq asks for. */
vm_status vm__read_nrrd(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);
vm_status vm__read_nifti(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);
vm_status vm__read_metaimage(const char *path, const vm__slab *rq, vm_volume *v,
                             vm_error *err);
vm_status vm__read_vtk(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);
vm_status vm__read_vti(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);
vm_status vm__read_raw(const char *path, const vm_raw_options *opt, const vm__slab *rq,
                       vm_volume *v, vm_error *err);
vm_status vm__read_inrimage(const char *path, const vm__slab *rq, vm_volume *v,
                            vm_error *err);
/* TIFF (io/tiff.c): a file, or a folder of slices; without libtiff, VM_ERR_UNSUPPORTED. */
vm_status vm__read_tiff(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err);
/* 1 when path is a folder with a .tif or .tiff file at its top level. */
int vm__tiff_folder(const char *path);

/* Atomic output (io/out_file.c): opens PATH.tmp-PID for writing; commit renames it over
 * path (or, for an output vm_output_hold declared, leaves it for vm_output_commit), abort
 * removes it. The temporary name is registered while it exists, for vm_output_discard and
 * the signal handler. */
typedef struct vm_outfile {
    FILE *fp;
    char final_path[4096];
    char tmp_path[4200];
    int slot;        /* its place in the registry of temporary files; -1: none */
    vm__meter meter; /* stage "write"; silent unless vm__out_meter started it */
} vm_outfile;
vm_status vm__out_open(vm_outfile *o, const char *path, vm_error *err);

/* A temporary name beside path: "PATH.TAG-PID", or, when that name would pass NAME_MAX,
 * "DIR/.vm-HASH.TAG-PID" (HASH: 16 hex digits of path's file name). [out] out of size cap;
 * returns 0 when it does not fit. */
int vm__temp_path(const char *path, const char *tag, char *out, size_t cap);
vm_status vm__out_commit(vm_outfile *o, vm_error *err); /* checks write errors, renames */
/* Registers tmp, a temporary file the caller makes and removes itself, with the outputs'
 * registry, so that a signal removes it too (vm_output_remove_on_signals). Returns an id for
 * vm__temp_untrack (after the file is removed), or -1 when the registry is full. */
int vm__temp_track(const char *tmp);
void vm__temp_untrack(int id);
void vm__out_abort(vm_outfile *o);

/* Starts the write progress of o (stage "write"; fn may be NULL) over total units of work
 * (points and cells written, bytes compressed: the writer's choice), advanced by
 * vm__out_step and completed as vm__out_commit starts. When fn asked to cancel (at any of
 * its calls), vm__out_commit removes the file and returns VM_ERR_CANCELLED. */
void vm__out_meter(vm_outfile *o, vm_progress_fn fn, void *user, double total);
static inline void vm__out_step(vm_outfile *o, double units) {
    if (o->meter.fn) vm__meter_add(&o->meter, units);
}

#endif
