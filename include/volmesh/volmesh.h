/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/volmesh.h — the whole public API of libvolmesh. */
#ifndef VOLMESH_H
#define VOLMESH_H

#define VOLMESH_VERSION "0.1.0"

#include "dicom.h"
#include "error.h"
#include "improve.h"
#include "io.h"
#include "labels.h"
#include "mesh.h"
#include "mesher.h"
#include "preprocess.h"
#include "quality.h"
#include "render.h"
#include "slabs.h"
#include "surface.h"
#include "volume.h"

/* Threads for the stages that run in parallel (denoising, VTU compression, mesh checks):
 * n > 0 uses n, n <= 0 all processors. Results are identical for any count. Without OpenMP
 * at build time everything runs on one thread and this does nothing. Returns the count in
 * force before the call (OpenMP's default: OMP_NUM_THREADS, else one per processor). */
int vm_set_threads(int n);

/* Threads the parallel stages use now (1 without OpenMP). */
int vm_threads(void);

/* Version string of the linked library. */
const char *vm_version(void);

#endif
