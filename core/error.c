/* SPDX-License-Identifier: BSD-3-Clause */
/* core/error.c — the vm_status/vm_error convention (see volmesh/error.h). */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include "volmesh/error.h"

vm_status vm_error_set(vm_error *err, vm_status status, const char *fmt, ...) {
    if (err) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err->message, sizeof err->message, fmt, ap);
        va_end(ap);
        /* one line, whatever a file's quoted text holds: control characters become '?' */
        for (char *c = err->message; *c; c++)
            if ((unsigned char)*c < 0x20 || *c == 0x7f) *c = '?';
        err->status = status;
    }
    return status;
}

void vm_error_clear(vm_error *err) {
    if (err) {
        err->status = VM_OK;
        err->message[0] = '\0';
    }
}

const char *vm_status_string(vm_status status) {
    switch (status) {
    case VM_OK: return "ok";
    case VM_ERR_IO: return "i/o error";
    case VM_ERR_FORMAT: return "bad format";
    case VM_ERR_NOMEM: return "out of memory";
    case VM_ERR_ARG: return "bad argument";
    case VM_ERR_EMPTY: return "empty selection";
    case VM_ERR_UNSUPPORTED: return "unsupported";
    case VM_ERR_INTERNAL: return "internal error";
    case VM_ERR_CANCELLED: return "cancelled";
    }
    return "unknown status";
}
