/* io/vtk_legacy.c — placeholder until the vtk reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_vtk(const char *path, vm_volume *v, vm_error *err) {
    (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: vtk reader not built yet", path);
}
