/* SPDX-License-Identifier: BSD-3-Clause */
/* preprocess/preprocess_internal.h — what the preprocessing filters share (not public). */
#ifndef VM_PREPROCESS_INTERNAL_H
#define VM_PREPROCESS_INTERNAL_H

#include "../core/core.h"

/* The inverse (inv) of v's index-to-world matrix M = D diag(spacing), and its determinant
 * (*det); VM_ERR_ARG, its message starting with who (the filter's name), when M is singular.
 * Defined in denoise.c. */
vm_status vm__frame_inverse(const vm_volume *v, const char *who, double inv[3][3], double *det,
                            vm_error *err);

#endif
