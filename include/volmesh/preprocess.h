/* volmesh/preprocess.h — stages before meshing: denoising and the contour spectrum. */
#ifndef VOLMESH_PREPROCESS_H
#define VOLMESH_PREPROCESS_H

#include "error.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifdef __cplusplus
}
#endif
#endif
