/* mesher/surface_mc.c — marching cubes surfaces.
 * Not built yet: refuses with VM_ERR_UNSUPPORTED. */
#include "surface_internal.h"

vm_status vm__surface_mc(const vm__surface_grid *g, const vm_surface_options *o,
                         vm_mesh *surf, vm_surface_stats *st, vm_error *err) {
    (void)g;
    (void)o;
    (void)surf;
    (void)st;
    return vm_error_set(err, VM_ERR_UNSUPPORTED, "surface: --method mc is not built yet");
}
