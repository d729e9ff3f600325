/* volmesh/io.h — reading volumes and reading/writing meshes.
 *
 * Readers check every size before allocating, never trust a header, and report problems as
 * "PATH: what is wrong". Writers write to PATH.tmp-XXXX and rename, so a failure never leaves
 * a half-written file behind. */
#ifndef VOLMESH_IO_H
#define VOLMESH_IO_H

#include "error.h"
#include "mesh.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads any supported volume, choosing the format from the extension (.nrrd .nhdr .nii
 * .nii.gz .hdr .img .mha .mhd .vtk .vti). [out] v, free with vm_volume_free. */
vm_status vm_volume_read(const char *path, vm_volume *v, vm_error *err);

/* Format-specific readers (same contract as vm_volume_read). */
vm_status vm_volume_read_nrrd(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_nifti(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_metaimage(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_vtk(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_vti(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_raw(const char *path, const vm_raw_options *opt, vm_volume *v,
                             vm_error *err);

/* Writes v as NRRD (attached data, float32 samples, little endian); gzip != 0 compresses. */
vm_status vm_volume_write_nrrd(const char *path, const vm_volume *v, int gzip, vm_error *err);

/* Mesh writing: format from the extension (.vtu; more formats as they land). */
vm_status vm_mesh_write(const char *path, const vm_mesh *m, vm_error *err);
vm_status vm_mesh_write_vtu(const char *path, const vm_mesh *m, int compress, vm_error *err);

/* Mesh reading: format from the extension. [out] m, free with vm_mesh_free. */
vm_status vm_mesh_read(const char *path, vm_mesh *m, vm_error *err);
vm_status vm_mesh_read_vtu(const char *path, vm_mesh *m, vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
