/* SPDX-License-Identifier: BSD-3-Clause */
/* core/version.c — library version. */
#include "volmesh/volmesh.h"

const char *vm_version(void) { return VOLMESH_VERSION; }
