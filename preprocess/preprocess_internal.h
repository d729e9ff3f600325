/* SPDX-License-Identifier: BSD-3-Clause */
/* preprocess/preprocess_internal.h — what the preprocessing filters share (not public). */
#ifndef VM_PREPROCESS_INTERNAL_H
#define VM_PREPROCESS_INTERNAL_H

#include "../core/core.h"


#endif
