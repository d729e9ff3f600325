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
    o->compress = VM_COMPRESS_FAST;
}

int vm_compress_parse(const char *name, vm_compress *out) {
    static const struct {
        const char *name;
        vm_compress c;
    } names[] = {
        {"fast", VM_COMPRESS_FAST}, {"best", VM_COMPRESS_BEST}, {"none", VM_COMPRESS_NONE}};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strcmp(name, names[i].name) == 0) {
            *out = names[i].c;
            return 1;
        }
    return 0;
}
