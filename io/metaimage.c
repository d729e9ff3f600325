/* io/metaimage.c — placeholder until the metaimage reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_metaimage(const char *path, vm_volume *v, vm_error *err) {
    (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: metaimage reader not built yet", path);
}
