/* io/nrrd.c — placeholder until the nrrd reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_nrrd(const char *path, vm_volume *v, vm_error *err) {
    (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: nrrd reader not built yet", path);
}

vm_status vm_volume_write_nrrd(const char *path, const vm_volume *v, int gzip, vm_error *err) {
    (void)v;
    (void)gzip;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: nrrd writer not built yet", path);
}
