/* io/raw.c — placeholder until the raw reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_raw(const char *path, const vm_raw_options *opt, vm_volume *v, vm_error *err) {
    (void)opt; (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: raw reader not built yet", path);
}
