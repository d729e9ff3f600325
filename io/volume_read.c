/* io/volume_read.c — picks the volume reader from the file name; whole, header-only and
 * slab reads all go through the same reader of each format. */
#include <assert.h>
#include <string.h>
#include "io_util.h"
#include "volmesh/io.h"

static vm_status read_any(const char *path, const vm__slab *rq, vm_volume *v, vm_error *err) {
    memset(v, 0, sizeof *v);
    if (vm__ends_with(path, ".nrrd") || vm__ends_with(path, ".nhdr"))
        return vm__read_nrrd(path, rq, v, err);
    if (vm__ends_with(path, ".nii") || vm__ends_with(path, ".nii.gz") ||
        vm__ends_with(path, ".hdr") || vm__ends_with(path, ".img") ||
        vm__ends_with(path, ".img.gz"))
        return vm__read_nifti(path, rq, v, err);
    if (vm__ends_with(path, ".mha") || vm__ends_with(path, ".mhd"))
        return vm__read_metaimage(path, rq, v, err);
    if (vm__ends_with(path, ".vtk")) return vm__read_vtk(path, rq, v, err);
    if (vm__ends_with(path, ".vti")) return vm__read_vti(path, rq, v, err);
    return vm_error_set(err, VM_ERR_UNSUPPORTED,
                        "%s: unknown volume format (expected .nrrd .nhdr .nii .nii.gz .hdr .img "
                        ".mha .mhd .vtk .vti, or a raw file with --raw-dims)",
                        path);
}

vm_status vm_volume_read(const char *path, vm_volume *v, vm_error *err) {
    return read_any(path, &vm__slab_whole, v, err);
}

vm_status vm_volume_read_info(const char *path, vm_volume *v, vm_error *err) {
    assert(path && v);
    vm__slab rq = {0, 0, 0, 1};
    return read_any(path, &rq, v, err);
}

vm_status vm_volume_read_slab(const char *path, int64_t z0, int64_t z1, vm_volume *v,
                              vm_error *err) {
    assert(path && v);
    vm__slab rq = {z0, z1, 0, 0};
    return read_any(path, &rq, v, err);
}

vm_status vm_volume_read_raw_info(const char *path, const vm_raw_options *opt, vm_volume *v,
                                  vm_error *err) {
    assert(path && opt && v);
    vm__slab rq = {0, 0, 0, 1};
    return vm__read_raw(path, opt, &rq, v, err);
}

vm_status vm_volume_read_raw_slab(const char *path, const vm_raw_options *opt, int64_t z0,
                                  int64_t z1, vm_volume *v, vm_error *err) {
    assert(path && opt && v);
    vm__slab rq = {z0, z1, 0, 0};
    return vm__read_raw(path, opt, &rq, v, err);
}
