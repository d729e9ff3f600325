/* SPDX-License-Identifier: BSD-3-Clause */
/* volmesh/io.h — reading volumes and reading/writing meshes.
 *
 * Readers check every size before allocating, never trust a header, and report problems as
 * "PATH: what is wrong". Writers write to PATH.tmp-XXXX and rename, so a failure never leaves
 * a half-written file behind. */
#ifndef VOLMESH_IO_H
#define VOLMESH_IO_H

#include <stdio.h>
#include "error.h"
#include "mesh.h"
#include "volume.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Reads any supported volume. A folder with .tif/.tiff files at its top level is a TIFF
 * stack; any other folder, or a file whose content is DICOM, is read as a DICOM series
 * (volmesh/dicom.h: the series with the most slices); other files by their extension
 * (.nrrd .nhdr .nii .nii.gz .hdr .img .mha .mhd .vtk .vti .tif .tiff .inr .inr.gz). [out] v,
 * free with vm_volume_free. */
vm_status vm_volume_read(const char *path, vm_volume *v, vm_error *err);

/* The limits of every voxel spacing a reader accepts, from a file or from the caller
 * (--spacing): finite and VM_SPACING_MIN <= s <= VM_SPACING_MAX, in the file's unit. Wide
 * enough for metres and for micrometres; outside, physical coordinates lose their digits. */
#define VM_SPACING_MIN 1e-9
#define VM_SPACING_MAX 1e9

/* What a file does not say, or what replaces what it says, for vm_volume_read_with and
 * vm_volume_reader_open_with. Fill with vm_volume_read_options_init, then set fields. */
typedef struct vm_volume_read_options {
    const vm_raw_options *raw; /* NULL, or a headerless raw file's description (not copied:
                                  it must live as long as the call) */
    const char *series;        /* DICOM: NULL for the series with the most slices, a
                                  SeriesInstanceUID, or a 1-based index in decimal ("2") as
                                  listed by vm_dicom_list_series; other formats: ignored */
    int has_spacing;           /* 1: spacing replaces the file's voxel spacing (origin and
                                  direction stay the file's) */
    double spacing[3];         /* sx, sy, sz: finite, VM_SPACING_MIN..VM_SPACING_MAX, else
                                  VM_ERR_ARG "PATH: spacing ... " */
} vm_volume_read_options;

/* Fills o with the defaults: no raw description, default series, the file's spacing. */
void vm_volume_read_options_init(vm_volume_read_options *o);

/* vm_volume_read (or vm_volume_read_raw when opt->raw) with opt's choices; opt may be NULL
 * (then exactly vm_volume_read). [out] v, free with vm_volume_free. */
vm_status vm_volume_read_with(const char *path, const vm_volume_read_options *opt,
                              vm_volume *v, vm_error *err);

/* Format-specific readers (same contract as vm_volume_read). */
vm_status vm_volume_read_nrrd(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_nifti(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_metaimage(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_vtk(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_vti(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_raw(const char *path, const vm_raw_options *opt, vm_volume *v,
                             vm_error *err);
/* INRIMAGE-4 (.inr, .inr.gz: the whole file gzipped), as CGAL and MedInria write it: the
 * header's XDIM YDIM ZDIM (VDIM 1), TYPE (unsigned fixed, signed fixed, float) with PIXSIZE
 * (8..64 bits), CPU (decm, alpha, pc: little endian; sun, sgi: big endian), VX VY VZ
 * spacing; SCALE is not applied; origin 0, direction the identity; format "inrimage". */
vm_status vm_volume_read_inrimage(const char *path, vm_volume *v, vm_error *err);

/* TIFF (needs a build with libtiff, else VM_ERR_UNSUPPORTED): path is a multi-page file or
 * a folder whose .tif/.tiff files are its slices in natural name order ("s2" before "s10");
 * every page one channel of the same size and sample type (8, 16, 32-bit integers, 32 or
 * 64-bit floats), any compression libtiff decodes, strips or tiles. Spacing from ImageJ's
 * description (1/XResolution, 1/YResolution, spacing=) or OME-XML PhysicalSizeX/Y/Z, in the
 * file's unit (not converted), else 1; origin 0, direction the identity; format "tiff". */
vm_status vm_volume_read_tiff(const char *path, vm_volume *v, vm_error *err);

/* 1 when volmesh was built with libtiff (TIFF inputs are read). */
int vm_tiff_available(void);

/* ---- Reading by slabs -----------------------------------------------------------------
 *
 * For volumes larger than memory, or one slab per MPI rank. vm_volume_read_info reads only
 * the header: [out] v has the whole volume's dims, type, geometry and format, data NULL
 * (vm_volume_free is still fine). vm_volume_read_slab reads planes z0 <= k < z1 (0 <= z0 <
 * z1 <= nz, else VM_ERR_ARG "PATH: slab of planes ... is outside ..."): [out] v is a volume
 * of dims nx, ny, z1 - z0 whose origin is the world position of voxel (0, 0, z0) of the whole
 * volume (same spacing, direction, type, format), free with vm_volume_free. Only the slab's
 * floats are allocated (checked against the memory limit, not the whole volume's size):
 * uncompressed data is read by seeking (files are mapped, pages given back once read), gzip
 * and zlib data by streaming inflate that discards what precedes z0, ASCII by a streaming
 * parse. VTI base64 (inline or appended) and VTI zlib blocks are decoded whole, then cut
 * (docs/FORMATS.md). The file's consistency (size against the header) is checked as in a
 * whole read; values and compressed data after the slab are not read. Slabs concatenated
 * along z equal vm_volume_read, value for value. */
vm_status vm_volume_read_info(const char *path, vm_volume *v, vm_error *err);
vm_status vm_volume_read_slab(const char *path, int64_t z0, int64_t z1, vm_volume *v,
                              vm_error *err);
/* The same for a headerless raw file described by opt. */
vm_status vm_volume_read_raw_info(const char *path, const vm_raw_options *opt, vm_volume *v,
                                  vm_error *err);
vm_status vm_volume_read_raw_slab(const char *path, const vm_raw_options *opt, int64_t z0,
                                  int64_t z1, vm_volume *v, vm_error *err);

/* Reading forward, slab after slab: a reader keeps where the previous slab ended in a gzip
 * or zlib stream (its inflate state) or in ASCII text, so that slabs read in increasing z
 * (each starting at or after the previous one's end) inflate or parse each byte once in all,
 * where vm_volume_read_slab starts from the beginning of the data every time; a slab that
 * starts earlier starts again from the beginning. Uncompressed data is read by offset
 * either way; VTI base64 and zlib blocks are decoded whole for every slab. The file is opened
 * (mapped) again for each read and must not change in between.
 * vm_volume_reader_open reads the header: [out] *r (close with vm_volume_reader_close),
 * [out] info (as vm_volume_read_info; may be NULL); raw: NULL, or the description of a
 * headerless raw file. vm_volume_reader_read reads planes z0 <= k < z1 (as
 * vm_volume_read_slab, same errors) into dst, room for nx * ny * (z1 - z0) floats that the
 * caller owns (nothing else is allocated for the samples). */
typedef struct vm_volume_reader vm_volume_reader;
vm_status vm_volume_reader_open(const char *path, const vm_raw_options *raw, vm_volume *info,
                                vm_volume_reader **r, vm_error *err);
/* The same with opt's choices (series, spacing, raw; opt may be NULL), kept for every
 * later vm_volume_reader_read (opt->raw and opt->series are copied). */
vm_status vm_volume_reader_open_with(const char *path, const vm_volume_read_options *opt,
                                     vm_volume *info, vm_volume_reader **r, vm_error *err);
vm_status vm_volume_reader_read(vm_volume_reader *r, int64_t z0, int64_t z1, float *dst,
                                vm_error *err);
void vm_volume_reader_close(vm_volume_reader *r);

/* Writes v as NRRD (attached data, float32 samples, little endian); gzip != 0 compresses. */
vm_status vm_volume_write_nrrd(const char *path, const vm_volume *v, int gzip, vm_error *err);

/* Mesh writing: format from the extension (.vtu .vtk .inp .msh .msh2 .mesh .stl .off .ply .obj
 * .exo .bdf .k .mphtxt .feb), with the default options of vm_mesh_write_as. */
vm_status vm_mesh_write(const char *path, const vm_mesh *m, vm_error *err);
/* VTU arrays: VM_COMPRESS_NONE raw, VM_COMPRESS_FAST zlib level 1 (the default), or
 * VM_COMPRESS_BEST zlib's default level 6 (about 5% smaller, 4x slower; level 9 is slower
 * still and no smaller on mesh arrays). The arrays are
 * cut into 32 KiB blocks compressed independently (VTK's vtkZLibDataCompressor header), on
 * vm_threads() threads; the bytes are the same for any thread count. */
typedef enum vm_compress {
    VM_COMPRESS_NONE = 0,
    VM_COMPRESS_FAST = 1,
    VM_COMPRESS_BEST = 2
} vm_compress;

/* The compression of a name: "fast", "best" or "none" ([out] *out); returns 0 when the name
 * is none of them. */
int vm_compress_parse(const char *name, vm_compress *out);

/* compress: a vm_compress (VM_COMPRESS_FAST for the default). */
vm_status vm_mesh_write_vtu(const char *path, const vm_mesh *m, int compress, vm_error *err);

/* Mesh reading: format from the extension. [out] m, free with vm_mesh_free. */
vm_status vm_mesh_read(const char *path, vm_mesh *m, vm_error *err);
vm_status vm_mesh_read_vtu(const char *path, vm_mesh *m, vm_error *err);

/* ---- Output files -----------------------------------------------------------------------
 *
 * Every writer writes to a temporary file beside its output and renames it when complete: a
 * failure leaves no file, and an older output survives. A program that writes several files
 * in one run declares them with vm_output_hold, then renames them together with
 * vm_output_commit (or removes them with vm_output_discard) at the end: on any failure, none
 * remains. The registry behind this is process-wide; call these from one thread. */

/* Checks, before any work, that path can be written: a name (not ending in '/'), not a
 * folder, in a folder that exists and is writable. VM_ERR_IO / VM_ERR_ARG, "PATH: why". */
vm_status vm_output_check(const char *path, vm_error *err);

/* Declares path an output of this run: from now on its writer leaves it complete under its
 * temporary name until vm_output_commit. Up to 16 paths; VM_ERR_NOMEM beyond. */
vm_status vm_output_hold(const char *path, vm_error *err);

/* Renames every held output, in the order they were written, and forgets the declarations.
 * After a rename that fails, the remaining temporary files are removed; VM_ERR_IO. */
vm_status vm_output_commit(vm_error *err);

/* Removes every held output's temporary file and forgets the declarations. */
void vm_output_discard(void);

/* Writes an output file of the program's own format through the same machinery as the
 * library's writers: write(fp, user) fills the temporary file (returns 0, or nonzero when it
 * failed; then the file is removed and, unless write set err, VM_ERR_IO "PATH: write failed"),
 * which is then renamed over path, or left for vm_output_commit when path is held. The
 * temporary file is registered for vm_output_discard and vm_output_remove_on_signals.
 * [in] path, write (not NULL); user is passed on. */
typedef int (*vm_output_write_fn)(FILE *fp, void *user, vm_error *err);
vm_status vm_output_write(const char *path, vm_output_write_fn write, void *user,
                          vm_error *err);

/* For programs (not libraries): on SIGINT and SIGTERM, removes the temporary file of every
 * output being written or held, then exits with 130 or 143 (128 + the signal). A signal
 * ignored when this is called stays ignored. */
void vm_output_remove_on_signals(void);

/* ---- Finite-element and surface mesh formats ------------------------------------------
 *
 * Every writer: node order converted to the format's own (positive volumes in its reader's
 * convention), coordinates written losslessly (%.17g, or binary doubles; binary STL can only
 * hold float32; .inp fields hold 20 characters: the shortest exact text, else 15 digits),
 * output written to PATH.tmp-PID and renamed. Every reader: one-line errors
 * "PATH: [line N: ]problem", sizes checked against the file before allocating; [out] m is a
 * mesh to free with vm_mesh_free (left empty on error). Details per format in docs/FORMATS.md.
 * Surface formats (STL, OFF, PLY, OBJ) given a tet4/hex8 mesh write its boundary
 * (vm_mesh_boundary: outward faces, region of their cell). */

typedef enum vm_mesh_format {
    VM_MESH_AUTO = 0, /* from the file name */
    VM_MESH_VTU,      /* .vtu  VTK XML UnstructuredGrid */
    VM_MESH_VTK,      /* .vtk  legacy VTK UNSTRUCTURED_GRID */
    VM_MESH_INP,      /* .inp  ABAQUS / CalculiX input deck */
    VM_MESH_MSH,      /* .msh  Gmsh MSH 4.1 (ASCII) */
    VM_MESH_MSH2,     /* .msh2 Gmsh MSH 2.2 (ASCII); reading .msh accepts either version */
    VM_MESH_MEDIT,    /* .mesh MEDIT ASCII, MeshVersionFormatted 2 */
    VM_MESH_STL,      /* .stl  triangles; binary by default */
    VM_MESH_OFF,      /* .off  Geomview OFF */
    VM_MESH_PLY,      /* .ply  binary little endian by default */
    VM_MESH_OBJ,      /* .obj  Wavefront OBJ */
    VM_MESH_EXODUS,   /* .exo .e  Exodus II (write only; needs a build with libexodusii) */
    VM_MESH_NASTRAN,  /* .bdf  Nastran bulk data (write only; tet4, hex8) */
    VM_MESH_LSDYNA,   /* .k    LS-DYNA keyword deck (write only; tet4, hex8) */
    VM_MESH_COMSOL,   /* .mphtxt COMSOL text mesh (write only; tet4, hex8) */
    VM_MESH_FEBIO,    /* .feb  FEBio input, febio_spec 4.0 (write only; tet4, hex8) */
    VM_MESH_XDMF      /* .xdmf XDMF 3 + sibling .h5, dolfinx's layout (write only; tet4,
                         hex8; needs a build with libhdf5) */
} vm_mesh_format;

/* Analysis deck added to an .inp file. */
typedef enum vm_deck_kind {
    VM_DECK_NONE = 0,  /* mesh, sets, sections and material only */
    VM_DECK_STATIC = 1 /* plus *STEP *STATIC: lowest z slab fixed, top slab loaded in -z */
} vm_deck_kind;

/* One row of a materials table: the material of the elements of region (label) `label`.
 * Linear elastic: Young's modulus E, Poisson's ratio nu, density, in the mesh's units (the
 * placeholder of a region without a row is steel-like in N, mm, t: 210000, 0.3, 7.85e-9). */
typedef struct vm_material {
    int32_t label;
    char name[64]; /* a letter, then letters, digits and '_' */
    double young, poisson, density;
} vm_material;

/* Reads a materials table: CSV rows "label,name,E,nu,density" (an optional first line
 * starting "label" is a header; blank lines and lines starting '#' are skipped). Checked
 * whole: 5 fields a row, an integer label, a name as above, E > 0, -1 < nu < 0.5,
 * density >= 0, no label or name (case-insensitive) twice, at least one row; else
 * VM_ERR_FORMAT / VM_ERR_EMPTY "PATH: line N: problem". [out] *out (free with
 * vm_materials_free), *n. */
vm_status vm_materials_read(const char *path, vm_material **out, size_t *n, vm_error *err);
void vm_materials_free(vm_material *m);

/* The file an INP deck written with split = 1 includes: X.inp -> X_mesh.inp (X_mesh.inp for
 * any other name X). [out] out of size cap; returns 0 when it does not fit. */
int vm_inp_split_path(const char *deck, char *out, size_t cap);

typedef struct vm_mesh_write_options {
    vm_mesh_format format; /* VM_MESH_AUTO: from the extension */
    int ascii;             /* 1: ASCII STL / PLY / VTK instead of binary (default 0) */
    int order;             /* 1 (default) or 2: INP (C3D10 / C3D20), VTU (tetra10 /
                              hexahedron20), MSH and FEBio (tet10 / hex20), XDMF
                              (Tetrahedron_10 / Hexahedron_20), tet4 and hex8
                              meshes: one shared mid-edge node per edge, at its middle */
    vm_deck_kind deck;     /* INP and FEBio (default VM_DECK_NONE) */
    int split;             /* INP: 1 writes the mesh (nodes, elements, sets, surfaces) to
                              X_mesh.inp beside X.inp, which *INCLUDEs it and keeps the
                              materials, sections and step (default 0: one file) */
    int compress;          /* VTU: a vm_compress, VM_COMPRESS_FAST (1, default), _BEST (2)
                              or _NONE (0); any other value is VM_ERR_ARG */
    const vm_material *materials; /* the decks (inp, bdf, k, feb): one material per region,
                                     from this table where it has the region's row (not
                                     owned; may be NULL: placeholders) */
    size_t nmaterials;
    /* Curved second-order tets (order 2, tet4 meshes, every format): mid-edge nodes of
     * outer boundary edges moved onto the level set curve_lo or curve_hi (the material's
     * bounds, as meshed; the nearer one) of this volume's trilinear field by Newton steps
     * along its gradient, and pulled back toward the edge middle wherever a tet's Jacobian
     * determinant (corners, edge middles, centroid, 4 Gauss points) would fall below 0.1 of
     * the straight tet's. Nodes on the volume's box faces, and hexes, stay straight. Not
     * owned; NULL (default): straight edges. */
    const vm_volume *curve_volume;
    double curve_lo, curve_hi;
    int curve_has_lo, curve_has_hi;
    vm_progress_fn progress; /* stage "write" (every format but Exodus); may be NULL */
    void *progress_user;
} vm_mesh_write_options;

/* Fills o with the defaults above. [out] o. */
void vm_mesh_write_options_init(vm_mesh_write_options *o);

/* Format of a name as given to --format ("vtu", "vtk", "inp", "abaqus", "msh", "msh4",
 * "msh2", "mesh", "medit", "stl", "off", "ply", "obj", "exo", "exodus", "bdf", "nastran", "k",
 * "lsdyna", "mphtxt", "comsol", "feb", "febio", "xdmf"), or VM_MESH_AUTO when unknown. */
vm_mesh_format vm_mesh_format_parse(const char *name);

/* Format from the extension of path (case-insensitive), or VM_MESH_AUTO when unknown. */
vm_mesh_format vm_mesh_format_of_path(const char *path);

/* Short name of a format ("inp", "msh2", ...). Never NULL. */
const char *vm_mesh_format_name(vm_mesh_format f);

/* 1 when volmesh was built with Exodus II support. */
int vm_exodus_available(void);

/* 1 when volmesh was built with XDMF support (libhdf5). */
int vm_xdmf_available(void);

/* Writes m in the format opt->format (or from the extension). opt may be NULL (defaults).
 * An option that does not apply to the format (order 2 outside .inp .vtu .msh .feb .xdmf, a deck
 * outside .inp .feb, materials outside the decks) is VM_ERR_ARG. [in] m is not modified. */
vm_status vm_mesh_write_as(const char *path, const vm_mesh *m,
                           const vm_mesh_write_options *opt, vm_error *err);

/* Checks, before any work, vm_output_check(path), then what vm_mesh_write_as would refuse
 * before writing: the format (opt->format, or path's extension), the options that fit it.
 * opt may be NULL (defaults). */
vm_status vm_mesh_write_check(const char *path, const vm_mesh_write_options *opt,
                              vm_error *err);

/* Reads path as format f (VM_MESH_AUTO: from the extension). */
vm_status vm_mesh_read_as(const char *path, vm_mesh_format f, vm_mesh *m, vm_error *err);

/* ABAQUS / CalculiX .inp. Writes *HEADING, *NODE, *ELEMENT (C3D4, C3D8, C3D10/C3D20 with
 * order 2, S3, S4), per region r: *ELSET REGION_r, and for volume meshes *NSET NB_REGION_r
 * (nodes of the region's boundary faces) and *SURFACE SURF_REGION_r, TYPE=ELEMENT (element,
 * face S1..S6 in ABAQUS face numbering); the outer boundary as *NSET NB_OUTER and *SURFACE
 * OUTER; for each pair of regions r < q that share faces *SURFACE IFACE_REGION_r_REGION_q
 * (those faces, from the side of r) and *NSET NIF_REGION_r_REGION_q; per region a *MATERIAL
 * (opt->materials' row, else MAT_REGION_r with E 210000, nu 0.3, density 7.85e-9) and a
 * *SOLID SECTION (shells: *SHELL SECTION, thickness 1). Numbers take at most 20 characters
 * (the shortest exact text, else 15 significant digits). opt->deck adds the analysis step. opt may be NULL. Reading takes *NODE, *ELEMENT of types
 * C3D4*, C3D8*, C3D10*, C3D20* (their corner nodes; nodes used only as mid-edge nodes are
 * dropped), S3*, S4* (volume elements win over shells), region = r of the ELSET REGION_r
 * holding the element, else the ordinal of the ELSET= named on its *ELEMENT line, else 0. */
vm_status vm_mesh_write_inp(const char *path, const vm_mesh *m,
                            const vm_mesh_write_options *opt, vm_error *err);
vm_status vm_mesh_read_inp(const char *path, vm_mesh *m, vm_error *err);

/* Gmsh MSH, ASCII: version 41 (4.1) or 22 (2.2). One elementary entity and one physical
 * group (named REGION_r) per region; physical tag = region when all regions are >= 1, else
 * 1, 2, ... in region order. The reader takes versions 2.2, 4.0 and 4.1 ASCII: elements of
 * the highest dimension present (tet4, hex8, tri3, quad4; lines and points are skipped),
 * region from the physical name REGION_r, else the physical tag, else the entity tag. */
vm_status vm_mesh_write_msh(const char *path, const vm_mesh *m, int version, vm_error *err);
vm_status vm_mesh_read_msh(const char *path, vm_mesh *m, vm_error *err);

/* MEDIT .mesh (ASCII): Vertices, then Tetrahedra / Hexahedra / Triangles / Quadrilaterals
 * with reference = region. Reading also skips Edges, Corners, Ridges, Required* and normal
 * sections; volume elements win over surface elements. */
vm_status vm_mesh_write_medit(const char *path, const vm_mesh *m, vm_error *err);
vm_status vm_mesh_read_medit(const char *path, vm_mesh *m, vm_error *err);

/* Legacy VTK UNSTRUCTURED_GRID (.vtk), version 4.2 layout, ASCII or BINARY (big endian):
 * POINTS double, CELLS, CELL_TYPES, CELL_DATA "region" (int) and the cell fields, POINT_DATA
 * fields (FIELD arrays of doubles). The reader also takes the version 5.1 OFFSETS /
 * CONNECTIVITY layout. */
vm_status vm_mesh_write_vtk(const char *path, const vm_mesh *m, int ascii, vm_error *err);
vm_status vm_mesh_read_vtk(const char *path, vm_mesh *m, vm_error *err);

/* STL: binary (float32 coordinates; region in the 16-bit attribute when 0..65535) or ASCII
 * (%.17g; one `solid REGION_r` per region). Quads are split in two triangles. The reader
 * merges vertices with identical coordinates, in order of first appearance. */
vm_status vm_mesh_write_stl(const char *path, const vm_mesh *m, int ascii, vm_error *err);
vm_status vm_mesh_read_stl(const char *path, vm_mesh *m, vm_error *err);

/* OFF: triangles and quads as polygons; no regions (the format has none: read as 0). */
vm_status vm_mesh_write_off(const char *path, const vm_mesh *m, vm_error *err);
vm_status vm_mesh_read_off(const char *path, vm_mesh *m, vm_error *err);

/* PLY: binary_little_endian (double x y z; face list uchar int; int region) or ascii. */
vm_status vm_mesh_write_ply(const char *path, const vm_mesh *m, int ascii, vm_error *err);
vm_status vm_mesh_read_ply(const char *path, vm_mesh *m, vm_error *err);

/* Wavefront OBJ: v and f lines, one `g REGION_r` group per region. */
vm_status vm_mesh_write_obj(const char *path, const vm_mesh *m, vm_error *err);
vm_status vm_mesh_read_obj(const char *path, vm_mesh *m, vm_error *err);

/* ---- Materials from the image (io/modulus.c) ---------------------------------------------
 *
 * A formula in v: numbers (C syntax, e.g. 6850, 1.5e-3), v, + - * / ^ (power, right-
 * associative, above unary minus: -v^2 = -(v^2)), parentheses; at most 1023 characters.
 * Bad text is VM_ERR_ARG "--modulus 'TEXT': problem at column N". [out] *out: free with
 * vm_expr_free. vm_expr_eval gives NaN or inf where the arithmetic does. */
typedef struct vm_expr vm_expr;
vm_status vm_expr_parse(const char *text, vm_expr **out, vm_error *err);
double vm_expr_eval(const vm_expr *e, double v);
void vm_expr_free(vm_expr *e);

/* Image-based moduli of a tet4 / hex8 mesh (Bonemat's way): v = the mean of the voxels of vol
 * whose centres lie in the element (else the voxel nearest its centroid), E = e(v), which must
 * be finite and > 0 (else VM_ERR_ARG naming the element). When the distinct E number at most
 * bins (>= 1), one material each, exact; else bins equal-width bins over [min E, max E], each
 * material the mean E of its elements. Each element's region becomes its material's number
 * 1..*nmats; cell fields "image_mean" (v) and "modulus" (its material's E) are added. [out]
 * *mats (*nmats rows: label k, name E_BIN_k, E, poisson, density 0; free with free()). */
vm_status vm_mesh_image_moduli(vm_mesh *m, const vm_volume *vol, const vm_expr *e, int bins,
                               double poisson, vm_material **mats, size_t *nmats,
                               vm_error *err);

/* Exodus II (.exo): one element block per region (id = ordinal, name REGION_r); side set and
 * node set 1 BOUNDARY (the outer boundary faces and their nodes), then per pair of regions
 * r < q that share faces, sets 2, 3, ... IFACE_REGION_r_REGION_q (those faces from r's side,
 * and their nodes). VM_ERR_UNSUPPORTED when built without libexodusii. */
vm_status vm_mesh_write_exodus(const char *path, const vm_mesh *m, vm_error *err);

/* XDMF 3 (PATH.xdmf) with the arrays in PATH.h5 (the same name, .h5 for .xdmf), as dolfinx's
 * XDMFFile reads them: Grid "mesh" (read_mesh(name="mesh")), Grid "cell_tags" (the region of
 * each cell) and Grid "facet_tags" (outer boundary faces tagged 1, the faces between two
 * regions 2, 3, ... per pair in increasing (region, other region) order), for
 * read_meshtags(mesh, name=...). The mesh's point and cell fields are Attributes of "mesh".
 * Both files are written to temporary names and renamed. VM_ERR_UNSUPPORTED when built
 * without libhdf5. */
vm_status vm_mesh_write_xdmf(const char *path, const vm_mesh *m,
                             const vm_mesh_write_options *opt, vm_error *err);

#ifdef __cplusplus
}
#endif
#endif
