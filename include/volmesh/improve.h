/* volmesh/improve.h — the quality-improvement pass over tetrahedral meshes. */
#ifndef VOLMESH_IMPROVE_H
#define VOLMESH_IMPROVE_H

#include "error.h"
#include "mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifdef __cplusplus
}
#endif
#endif
