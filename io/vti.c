/* io/vti.c — placeholder until the vti reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_vti(const char *path, vm_volume *v, vm_error *err) {
    (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: vti reader not built yet", path);
}
