/* io/mesh_io.c — picks the mesh reader/writer from the file name. */
#include "io_util.h"
#include "volmesh/io.h"

vm_status vm_mesh_write(const char *path, const vm_mesh *m, vm_error *err) {
    if (vm__ends_with(path, ".vtu")) return vm_mesh_write_vtu(path, m, 1, err);
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: unknown mesh format (expected .vtu)",
                        path);
}

vm_status vm_mesh_read(const char *path, vm_mesh *m, vm_error *err) {
    if (vm__ends_with(path, ".vtu")) return vm_mesh_read_vtu(path, m, err);
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: unknown mesh format (expected .vtu)",
                        path);
}
