/* io/vtu.c — placeholder until the VTU writer lands. */
#include "volmesh/io.h"

vm_status vm_mesh_write_vtu(const char *path, const vm_mesh *m, int compress, vm_error *err) {
    (void)m;
    (void)compress;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: vtu writer not built yet", path);
}

vm_status vm_mesh_read_vtu(const char *path, vm_mesh *m, vm_error *err) {
    (void)m;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: vtu reader not built yet", path);
}
