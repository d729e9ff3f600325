/* io/nifti.c — placeholder until the nifti reader lands. */
#include "volmesh/io.h"

vm_status vm_volume_read_nifti(const char *path, vm_volume *v, vm_error *err) {
    (void)v;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "%s: nifti reader not built yet", path);
}
