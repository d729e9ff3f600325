/* SPDX-License-Identifier: BSD-3-Clause */
/* io/write_options.c — the defaults of the mesh write options, shared by the dispatch
 * (io/mesh_io.c) and the writers' public shortcuts, so that calls run one way:
 * dispatch -> writers -> this file. */
#include <string.h>
#include "volmesh/io.h"

/* Defaults: format from the file name, first order, no deck, compressed where possible. */
void vm_mesh_write_options_init(vm_mesh_write_options *o) {
    memset(o, 0, sizeof *o);
    o->format = VM_MESH_AUTO;
    o->order = 1;
    o->deck = VM_DECK_NONE;
    o->compress = 1;
}
