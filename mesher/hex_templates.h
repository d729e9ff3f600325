/* mesher/hex_templates.h — 3-refinement transition templates for hexahedra (private): the
 * hexes that fill a coarse octree block next to finer blocks without hanging nodes. */
#ifndef VM_HEX_TEMPLATES_H
#define VM_HEX_TEMPLATES_H

#include <stddef.h>

/* Which template fills a coarse block, from its marked corners (corners touched by finer
 * elements). An edge of the block is split in thirds when both its ends are marked, else
 * left whole; a face is then one quad (no split edge), the 4-quad transition (one split
 * edge) or a 3x3 grid (four). PLAIN: no split edge, one hex. EDGE: one split edge, 5 hexes.
 * FACE: the four edges of one face, 13 hexes. FULL: all eight corners, 27 cubes.
 * UNSUPPORTED: any other set (two or three refined faces, two split edges, ...): such a
 * block must be refined (see docs/ALGORITHMS.md, "Adaptive hexahedra"). */
typedef enum vm__hex_template {
    VM_HT_PLAIN = 0,
    VM_HT_EDGE,
    VM_HT_FACE,
    VM_HT_FULL,
    VM_HT_UNSUPPORTED
} vm__hex_template;

enum { VM_HT_MAX_HEXES = 27, VM_HT_SIDE = 9 };

/* Classifies a block from marks (bit c set: corner c = x + 2y + 4z is marked). [out] sym:
 * the cube symmetry (0..47) that carries the template's canonical position onto the block
 * (0 for PLAIN, FULL and UNSUPPORTED). */
vm__hex_template vm__hex_template_classify(unsigned marks, int *sym);

/* The hexes of template t under symmetry sym. [out] out: up to VM_HT_MAX_HEXES hexes, eight
 * corners each in VTK order with a positive Jacobian, every coordinate an integer 0..9 (the
 * block is 9 units wide: thirds of a fine cell for a block of three cells). Every face
 * pattern depends only on the marks of its four corners, so neighbouring blocks classified
 * from the same corner marks meet conformingly. Returns the number of hexes (0 for
 * UNSUPPORTED). */
size_t vm__hex_template_hexes(vm__hex_template t, int sym, int out[][8][3]);

/* Smallest scaled corner Jacobian of the hex with corners p (VTK order); 1 for a cube. */
double vm__hex_template_min_sj(double p[8][3]);

#endif
