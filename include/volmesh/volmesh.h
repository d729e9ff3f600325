/* volmesh/volmesh.h — the whole public API of libvolmesh. */
#ifndef VOLMESH_H
#define VOLMESH_H

#define VOLMESH_VERSION "0.1.0"

#include "error.h"
#include "improve.h"
#include "io.h"
#include "labels.h"
#include "mesh.h"
#include "mesher.h"
#include "preprocess.h"
#include "quality.h"
#include "render.h"
#include "surface.h"
#include "volume.h"

/* Version string of the linked library. */
const char *vm_version(void);

#endif
