/* SPDX-License-Identifier: BSD-3-Clause */
/* mesher/graded_config.h — what the inside corners of a cube mean to the graded mesher
 * (private): the cubical reading of dual contouring (inside points 6-connected, a cube with
 * exactly two antipodal corners outside filled), per mask of inside corners. */
#ifndef VM_GRADED_CONFIG_H
#define VM_GRADED_CONFIG_H

#include <stdint.h>

enum { GR_CENTRE_FREE = 0, GR_CENTRE_IN = 1, GR_CENTRE_OUT = 2 };

typedef struct gr_config {
    uint8_t simple; /* a coarse leaf may have these corners: no ambiguous face, not the
                       antipodal cube, and the inside part of its boundary is a disk (or
                       empty, or everything) */
    uint8_t centre; /* base cells: the sign the centre must take for the cubical reading */
} gr_config;

/* Indexed by the mask of inside corners (corner q at x = q&1, y = q>>1&1, z = q>>2). */
extern const gr_config *vm__gr_config;
void vm__gr_config_init(void);

#endif
