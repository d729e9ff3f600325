/* io/volume_read.c — picks the volume reader from the file name. */
#include <string.h>
#include "io_util.h"
#include "volmesh/io.h"

vm_status vm_volume_read(const char *path, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    if (vm__ends_with(path, ".nrrd") || vm__ends_with(path, ".nhdr"))
        return vm_volume_read_nrrd(path, v, err);
    if (vm__ends_with(path, ".nii") || vm__ends_with(path, ".nii.gz") ||
        vm__ends_with(path, ".hdr") || vm__ends_with(path, ".img") ||
        vm__ends_with(path, ".img.gz"))
        return vm_volume_read_nifti(path, v, err);
    if (vm__ends_with(path, ".mha") || vm__ends_with(path, ".mhd"))
        return vm_volume_read_metaimage(path, v, err);
    if (vm__ends_with(path, ".vtk")) return vm_volume_read_vtk(path, v, err);
    if (vm__ends_with(path, ".vti")) return vm_volume_read_vti(path, v, err);
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: unknown volume format (expected .nrrd .nhdr .nii .nii.gz .hdr .img "
                        ".mha .mhd .vtk .vti, or a raw file with --raw-dims)",
                        path);
}
