/* SPDX-License-Identifier: BSD-3-Clause */
/* io/raw.c — headerless raw volumes: the caller describes dims, sample type, byte order,
 * geometry and a header to skip (vm_raw_options); the file must hold at least that much. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "../core/core.h"
#include "io_util.h"
#include "volmesh/io.h"

vm_status vm__read_raw(const char *path, const vm_raw_options *opt, const vm__slab *rq,
                       vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    size_t tsize = vm_scalar_type_size(opt->type);
    if (tsize == 0) return vm_error_set(err, VM_ERR_ARG, "%s: unknown raw sample type", path);
    for (int a = 0; a < 3; a++)
        if (!isfinite(opt->spacing[a]) || opt->spacing[a] < 0.0 || !isfinite(opt->origin[a]))
            return vm_error_set(err, VM_ERR_ARG,
                                "%s: raw spacing must be > 0 (or 0 for 1) and origin finite",
                                path);
    size_t count, first, n;
    vm_status st = vm__slab_check(path, rq, opt->dims, tsize, &count, &first, &n, err);
    if (st) return st;
    size_t need = count * tsize;

    vm__map m;
    st = vm__map_file(path, (size_t)-1, &m, err);
    if (st) return st;
    size_t len = m.len;
    size_t avail = opt->header_bytes >= len ? 0 : len - (size_t)opt->header_bytes;
    if (avail < need) {
        vm__map_free(&m);
        return vm_error_set(err, VM_ERR_FORMAT, "%s: data is truncated (%zu of %zu bytes)",
                            path, avail, need);
    }
    for (int a = 0; a < 3; a++) {
        v->dims[a] = opt->dims[a];
        v->spacing[a] = opt->spacing[a] == 0.0 ? 1.0 : opt->spacing[a];
        v->origin[a] = opt->origin[a];
        v->direction[a][a] = 1.0;
    }
    v->type = opt->type;
    snprintf(v->format, sizeof v->format, "raw");
    int swap = tsize > 1 && (opt->big_endian != 0) == (vm__host_little_endian() != 0);
    vm__samples src = {path, m.p + opt->header_bytes, avail, VM__ENC_RAW, 0, opt->type, swap,
                       m.maplen != 0, 0};
    st = vm__slab_read(path, rq, &src, first, n, v, err);
    if (!st) vm__slab_finish(v, rq);
    vm__map_free(&m);
    if (st) vm__slab_release(v, rq);
    return st;
}

vm_status vm_volume_read_raw(const char *path, const vm_raw_options *opt, vm_volume *v,
                             vm_error *err) {
    return vm__read_raw(path, opt, &vm__slab_whole, v, err);
}
