/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/error.h — one status convention for the whole library.
 *
 * Every fallible function returns a vm_status (VM_OK == 0, errors negative) and, when the
 * caller passes a vm_error, fills its message with one line naming the file or argument and
 * the problem, e.g. "head.nrrd: data is truncated (got 1024 of 762880 bytes)".
 * The library never prints, never exits and never aborts on bad input. */
#ifndef VOLMESH_ERROR_H
#define VOLMESH_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum vm_status {
    VM_OK = 0,
    VM_ERR_IO = -1,          /* cannot open/read/write a file */
    VM_ERR_FORMAT = -2,      /* malformed, truncated or lying file contents */
    VM_ERR_NOMEM = -3,       /* allocation failed or a size exceeds the memory limit */
    VM_ERR_ARG = -4,         /* bad option value given by the user (not a caller bug) */
    VM_ERR_EMPTY = -5,       /* the selection contains nothing to mesh */
    VM_ERR_UNSUPPORTED = -6, /* valid input using a feature volmesh does not handle */
    VM_ERR_INTERNAL = -7,    /* an invariant the library checks did not hold */
    VM_ERR_CANCELLED = -8    /* a progress callback returned nonzero (volmesh/mesh.h) */
} vm_status;

/* [out] holder of the last error; message is one line without trailing newline. */
typedef struct vm_error {
    vm_status status;
    char message[512];
} vm_error;

/* Records status and a printf-style message in err (err may be NULL) and returns status,
 * so that `return vm_error_set(err, VM_ERR_FORMAT, "%s: bad header", path);` reads well. */
vm_status vm_error_set(vm_error *err, vm_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Clears err to VM_OK with an empty message (err may be NULL). */
void vm_error_clear(vm_error *err);

/* Short constant name of a status ("ok", "i/o error", ...). Never NULL. */
const char *vm_status_string(vm_status status);

#ifdef __cplusplus
}
#endif
#endif
