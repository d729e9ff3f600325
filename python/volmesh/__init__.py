# SPDX-License-Identifier: BSD-3-Clause
"""volmesh: finite-element meshes from 3-D images, in Python.

    import volmesh
    vol = volmesh.read("seg.nii.gz")              # any format the volmesh program reads
    m = volmesh.mesh(vol, labels="all")           # one conforming tet mesh of every label
    m.write("seg.inp")                            # ABAQUS / CalculiX deck, a section per label
    print(volmesh.quality(m)["min_dihedral"])

Arrays are numpy arrays indexed [z, y, x], as in SimpleITK and scikit-image; spacing, origin
and direction are in (x, y, z) order. The C library (libvolmesh) does the work with the GIL
released. Every failure of the library raises volmesh.Error with its one-line message.
"""
import json as _json
import math as _math
import os as _os

import numpy as _np

from . import _volmesh

__version__ = _volmesh.version
__all__ = ["Error", "Volume", "Mesh", "read", "read_mesh", "mesh", "quality", "set_threads",
           "threads", "__version__"]


class Error(RuntimeError):
    """A failure of the volmesh library; str(e) is its one-line message, naming the file
    or the argument and the problem."""


_volmesh._set_error_class(Error)

_INDEX = _np.int32 if _volmesh.index_bytes == 4 else _np.int64
# volmesh's cell kinds and meshio's names for them
_MESHIO = {"tet4": "tetra", "hex8": "hexahedron", "tri3": "triangle", "quad4": "quad"}
_KINDS = {v: k for k, v in _MESHIO.items()}
_ELEMENTS = {"tet": "tet4", "tetra": "tet4", "hex": "hex8", "hexahedron": "hex8",
             "tri": "tri3", "triangle": "tri3", "quad": "quad4"}


def _vec3(name, value, default):
    v = default if value is None else value
    try:
        t = tuple(float(x) for x in v)
    except TypeError:
        raise TypeError(f"{name} must be a sequence of 3 numbers") from None
    if len(t) != 3:
        raise ValueError(f"{name} must have 3 values (x, y, z), not {len(t)}")
    return t


class Volume:
    """A scalar volume: .array (numpy float32, [z, y, x]), .spacing, .origin (x, y, z) and
    .direction (3x3: column c is the world direction of index axis c, i.e. x, y, z)."""

    def __init__(self, array, spacing=None, origin=None, direction=None):
        a = _np.asarray(array)
        if a.ndim != 3:
            raise ValueError(f"a volume is 3-D, this array has {a.ndim} dimensions")
        if a.size == 0:
            raise ValueError("the array is empty")
        self.array = a
        self.spacing = _vec3("spacing", spacing, (1.0, 1.0, 1.0))
        if not all(s > 0 and _np.isfinite(s) for s in self.spacing):
            raise ValueError(f"spacing must be finite and positive, not {self.spacing}")
        self.origin = _vec3("origin", origin, (0.0, 0.0, 0.0))
        d = _np.eye(3) if direction is None else _np.asarray(direction, dtype=float)
        if d.shape != (3, 3):
            raise ValueError(f"direction must be 3x3, not {d.shape}")
        self.direction = d

    @property
    def shape(self):
        return self.array.shape

    def __repr__(self):
        nz, ny, nx = self.array.shape
        return (f"<volmesh.Volume {nx}x{ny}x{nz} (x, y, z) {self.array.dtype}, "
                f"spacing {self.spacing}, origin {self.origin}>")


class Mesh:
    """A mesh: .points (n, 3) float64; .cells {meshio cell type: (m, k) array};
    .cell_data {name: array aligned with the cells} ("label" for label meshes, else
    "region"); .point_data {name: array}."""

    def __init__(self, points, cells, cell_data=None, point_data=None):
        self.points = _np.ascontiguousarray(points, dtype=_np.float64).reshape(-1, 3)
        if len(cells) != 1:
            raise ValueError("a volmesh mesh has one cell type")
        (ctype, conn), = cells.items()
        if ctype not in _KINDS:
            raise ValueError(f"cell type '{ctype}' is not one of {sorted(_KINDS)}")
        self.cells = {ctype: _np.asarray(conn)}
        self.cell_data = dict(cell_data or {})
        self.point_data = dict(point_data or {})

    @property
    def cell_type(self):
        return next(iter(self.cells))

    def _parts(self):
        kind = _KINDS[self.cell_type]
        conn = _np.ascontiguousarray(self.cells[self.cell_type], dtype=_INDEX)
        region = self.cell_data.get("label", self.cell_data.get("region"))
        if region is None:
            region = _np.zeros(len(conn), dtype=_np.int32)
        region = _np.ascontiguousarray(region, dtype=_np.int32)
        if len(region) != len(conn):
            raise ValueError(f"{len(region)} region values for {len(conn)} cells")
        return (kind, self.points, conn, region)

    def write(self, path, *, format=None, order=1, deck=None, compress=True, ascii=False):
        """Writes every format volmesh writes, from the extension or format= (vtu, vtk, inp,
        msh, msh2, mesh, stl, off, ply, obj, exo). order=2 and deck="static" for .inp.
        compress (.vtu): "fast" or True (zlib level 1), "best" (level 6), "none" or False."""
        levels = {"none": 0, "fast": 1, "best": 2, False: 0, True: 1}
        if not isinstance(compress, (bool, str)) or compress not in levels:
            raise ValueError(f"compress must be 'fast', 'best', 'none' or a bool, not {compress!r}")
        if order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, not {order!r}")
        if deck not in (None, "static"):
            raise ValueError(f"deck must be None or 'static', not {deck!r}")
        _volmesh.write_mesh(_os.fspath(path), self._parts(), format or "", order,
                            deck == "static", levels[compress], bool(ascii))

    def to_meshio(self):
        """The same mesh as a meshio.Mesh (cell data as lists of one array)."""
        import meshio
        return meshio.Mesh(self.points, [(self.cell_type, self.cells[self.cell_type])],
                           point_data=self.point_data,
                           cell_data={k: [v] for k, v in self.cell_data.items()})

    def __repr__(self):
        return (f"<volmesh.Mesh {len(self.points)} points, "
                f"{len(self.cells[self.cell_type])} {self.cell_type}>")


def _mesh_from_parts(parts, labels=False):
    kind, pts, cells, region, npoints, ncells, cell_fields, point_fields = parts
    nn = {"tet4": 4, "hex8": 8, "tri3": 3, "quad4": 4}[kind]
    m = Mesh.__new__(Mesh)
    m.points = _np.frombuffer(pts, dtype=_np.float64).reshape(npoints, 3)
    m.cells = {_MESHIO[kind]: _np.frombuffer(cells, dtype=_INDEX).reshape(ncells, nn)}
    m.cell_data = {"label" if labels else "region": _np.frombuffer(region, dtype=_np.int32)}
    for name, ncomp, buf in cell_fields:
        a = _np.frombuffer(buf, dtype=_np.float64)
        m.cell_data[name] = a if ncomp == 1 else a.reshape(ncells, ncomp)
    m.point_data = {}
    for name, ncomp, buf in point_fields:
        a = _np.frombuffer(buf, dtype=_np.float64)
        m.point_data[name] = a if ncomp == 1 else a.reshape(npoints, ncomp)
    return m


def read(path):
    """Reads a volume: every format `volmesh info` reads (NRRD, NIfTI, MetaImage, VTK, VTI).
    The array is the library's own memory, not copied."""
    data, dims, spacing, origin, direction, _type, _format = _volmesh.read_volume(
        _os.fspath(path))
    nx, ny, nz = dims
    a = _np.frombuffer(data, dtype=_np.float32).reshape(nz, ny, nx)
    return Volume(a, spacing, origin, _np.array(direction, dtype=float).reshape(3, 3))


def read_mesh(path):
    """Reads a mesh: every format `volmesh quality` reads."""
    return _mesh_from_parts(_volmesh.read_mesh(_os.fspath(path)))


def mesh(source, *, iso=None, range=None, labels=None, elements="tet", invert=False,
         spacing=None, origin=None, direction=None, adaptive=False, size=1, error=0.5,
         max_level=4, method=None, improve=True, min_island=1, smooth=True, threads=None,
         progress=None, label_edge=None, graded=False, max_edge=None, min_edge=None,
         distance=None, size_field=None, grading=None, tets=None, coarsen=True,
         min_layers=None):
    """Meshes the material of source (a Volume, or a 3-D numpy array indexed [z, y, x]).

    The material: iso=V (f >= V; invert=True: f <= V), range=(lo, hi) with None for an open
    side, or labels="all" / a list of labels (a segmentation: one conforming mesh, cell data
    "label"). elements: "tet" or "hex" (volume), "tri" or "quad" (the closed boundary surface,
    method "dc", "mc", "asc" or "cover"). spacing, origin and direction override the
    volume's. adaptive, size (in voxels), error and max_level as in `volmesh mesh`.
    label_edge={label: L} (with labels; tets): no edge longer than L (world units) inside
    that label's interior, as `volmesh mesh --label-edge` (docs/SIZING.md).
    Graded sizing in world units (tets; docs/SIZING.md), as `volmesh mesh --graded` and its
    options: max_edge, min_edge, distance (lengths), size_field (a Volume or a path: the
    largest edge at each point), grading (ratio >= 1.1), tets (a target count), min_layers
    (thin parts at least N elements thick, --min-layers), coarsen (False keeps the stuffed
    mesh, --no-coarsen). Any of them sets graded=True; max_edge also
    sizes label meshes.
    improve runs the quality pass. threads sets the thread count for this call. progress:
    a callable(stage, done, total), called from the calling thread with the GIL held, at most
    about ten times a second; an exception it raises (or KeyboardInterrupt on Ctrl-C) cancels
    the run, which stops within about a second, and is raised from mesh()."""
    if isinstance(source, Volume):
        vol = Volume(source.array,
                     source.spacing if spacing is None else spacing,
                     source.origin if origin is None else origin,
                     source.direction if direction is None else direction)
    else:
        vol = Volume(source, spacing, origin, direction)
    chosen = [x is not None for x in (iso, range, labels)]
    if sum(chosen) != 1:
        raise ValueError("give exactly one of iso=, range= or labels=")
    req = {}
    if iso is not None:
        iso = float(iso)
        req.update(has_lo=not invert, lo=iso, has_hi=bool(invert), hi=iso)
    elif range is not None:
        try:
            lo, hi = range
        except (TypeError, ValueError):
            raise ValueError("range must be a (lo, hi) tuple, None for an open side") from None
        if lo is None and hi is None:
            raise ValueError("range: give at least one bound")
        req.update(has_lo=lo is not None, lo=float(lo or 0.0), has_hi=hi is not None,
                   hi=float(hi or 0.0))
    else:
        if isinstance(labels, str):
            if labels != "all":
                raise ValueError(f"labels must be 'all' or a list of labels, not {labels!r}")
            req["labels"] = "all"
        else:
            req["labels"] = [int(x) for x in labels]
            if not req["labels"]:
                raise ValueError("labels: the list is empty")
    if label_edge is not None:
        if labels is None or not isinstance(label_edge, dict):
            raise ValueError("label_edge must be a dict {label: edge} and goes with labels=")
        pairs = []
        for lab, edge in label_edge.items():
            if isinstance(lab, bool) or not isinstance(lab, (int, _np.integer)) or \
                    not -2**31 <= lab < 2**31:
                raise ValueError(f"label_edge: {lab!r} is not a label")
            edge = float(edge)
            if not (edge > 0 and _math.isfinite(edge)):
                raise ValueError(f"label_edge: edge {edge!r} of label {lab} is not a length > 0")
            pairs.append((int(lab), edge))
        req["label_edge"] = pairs
    sizing = {"max_edge": max_edge, "min_edge": min_edge, "distance": distance}
    for name, value in sizing.items():
        if value is None:
            continue
        value = float(value)
        if not (value > 0 and _math.isfinite(value)):
            raise ValueError(f"{name} must be a length > 0, not {value!r}")
        req[name] = value
    if grading is not None:
        grading = float(grading)
        if not (grading >= 1.1 and _math.isfinite(grading)):
            raise ValueError(f"grading must be a ratio >= 1.1, not {grading!r}")
        req["grading"] = grading
    if tets is not None:
        if not isinstance(tets, (int, _np.integer)) or isinstance(tets, bool) or tets < 1:
            raise ValueError(f"tets must be a whole number >= 1, not {tets!r}")
        req["tets"] = int(tets)
    if min_layers is not None:
        if not isinstance(min_layers, (int, _np.integer)) or isinstance(min_layers, bool) or \
                not 1 <= min_layers <= 100:
            raise ValueError(f"min_layers must be a whole number from 1 to 100, not {min_layers!r}")
        req["min_layers"] = int(min_layers)
    if size_field is not None:
        sf = size_field if isinstance(size_field, Volume) else read(size_field)
        sfa = _np.ascontiguousarray(sf.array, dtype=_np.float32)
        if sfa.ndim != 3:
            raise ValueError("size_field must be a 3-D volume")
        sz_, sy_, sx_ = sfa.shape
        req["size_field"] = (sfa, (sx_, sy_, sz_), tuple(float(x) for x in sf.spacing),
                             tuple(float(x) for x in sf.origin),
                             tuple(_np.asarray(sf.direction, dtype=float).ravel()))
    if not coarsen:
        req["coarsen"] = False
    graded = bool(graded) or any(k in req for k in ("min_edge", "distance", "grading", "tets",
                                                    "size_field", "coarsen", "min_layers")) or \
        ("max_edge" in req and labels is None)
    if graded:
        if labels is not None:
            raise ValueError("graded sizing (distance, min_edge, grading, tets, size_field, "
                             "min_layers, coarsen) does not go with labels=; max_edge does")
        req["graded"] = True
    if elements not in _ELEMENTS:
        raise ValueError(f"elements must be one of {sorted(_ELEMENTS)}, not {elements!r}")
    req["elements"] = _ELEMENTS[elements]
    if method is not None:
        if req["elements"] not in ("tri3", "quad4"):
            raise ValueError("method= is for elements='tri' or 'quad'")
        req["method"] = str(method)
    for name, value in (("size", size), ("max_level", max_level), ("min_island", min_island)):
        if not isinstance(value, (int, _np.integer)) or isinstance(value, bool) or value < 1:
            raise ValueError(f"{name} must be a whole number >= 1, not {value!r}")
    if not error > 0:
        raise ValueError(f"error must be > 0, not {error!r}")
    if progress is not None and not callable(progress):
        raise TypeError("progress must be callable(stage, done, total)")
    req.update(size=int(size), adaptive=bool(adaptive), error=float(error),
               max_level=int(max_level), improve=bool(improve), min_island=int(min_island),
               smooth=bool(smooth))
    data = _np.ascontiguousarray(vol.array, dtype=_np.float32)
    nz, ny, nx = data.shape
    before = None if threads is None else _volmesh.set_threads(int(threads))
    try:
        parts = _volmesh.mesh(data, (nx, ny, nz), vol.spacing, vol.origin,
                              tuple(_np.asarray(vol.direction, dtype=float).ravel()), progress,
                              **req)
    finally:
        if before is not None:
            _volmesh.set_threads(before)
    return _mesh_from_parts(parts, labels=labels is not None)


def quality(m, name="mesh"):
    """Element quality and mesh checks: a dict with the keys of `volmesh quality --json`
    (elements, inverted, boundary_closed, boundary_euler, min_dihedral, metrics, ...)."""
    if not isinstance(m, Mesh):
        raise TypeError(f"quality() takes a volmesh.Mesh, not {type(m).__name__}")
    return _json.loads(_volmesh.quality_json(m._parts(), str(name)))


def set_threads(n):
    """Sets how many threads the parallel stages use (n <= 0: one per processor); returns
    the number before."""
    return _volmesh.set_threads(int(n))


def threads():
    """How many threads the parallel stages use."""
    return _volmesh.threads()
