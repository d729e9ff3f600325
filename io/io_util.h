/* io/io_util.h — private helpers shared by the readers and writers: whole-file reads,
 * zlib/gzip inflation, sample conversion, header-line parsing, atomic output files. */
#ifndef VM_IO_UTIL_H
#define VM_IO_UTIL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "../core/core.h"
#include "volmesh/error.h"
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

/* Converts n samples of type t at src (native or swapped byte order) into floats. */
void vm__samples_to_float(const void *src, vm_scalar_type t, int swap, size_t n, float *dst);

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

/* Atomic output: opens PATH.tmp-PID for writing; commit renames it over path, abort
 * removes it. */
typedef struct vm_outfile {
    FILE *fp;
    char final_path[4096];
    char tmp_path[4200];
    vm__meter meter; /* stage "write"; silent unless vm__out_meter started it */
} vm_outfile;
vm_status vm__out_open(vm_outfile *o, const char *path, vm_error *err);
vm_status vm__out_commit(vm_outfile *o, vm_error *err); /* checks write errors, renames */
void vm__out_abort(vm_outfile *o);

/* Starts the write progress of o (stage "write"; fn may be NULL) over total units of work
 * (points and cells written, bytes compressed: the writer's choice), advanced by
 * vm__out_step and completed by a successful vm__out_commit. */
void vm__out_meter(vm_outfile *o, vm_progress_fn fn, void *user, double total);
static inline void vm__out_step(vm_outfile *o, double units) {
    if (o->meter.fn) vm__meter_add(&o->meter, units);
}

#endif
