# SPDX-License-Identifier: BSD-3-Clause
"""refstats — one statistics module for every mesher in the reference comparison.

Everything the tables in docs/REFERENCE.md report is computed here, with the same code for
volmesh, TetGen and CGAL Mesh_3, so the rows are comparable. Nothing here calls volmesh's
library: the volumes are read with VTK's readers (and a small NRRD reader below, since
VTK 9.1's Python NRRD reader needs MPI), the meshes are read from their files.

Conventions
- A volume is an array f[k, j, i] (x fastest) with origin o, spacing s and direction D; the
  grid point (i, j, k) sits at o + D @ (s * (i, j, k)). The material is {f >= iso} (or
  {f <= iso} with invert).
- Dihedral angles are the six interior angles between face planes of a tet, in degrees. A
  sliver below X degrees is a tet whose smallest dihedral angle is below X.
- Radius ratio is 3 * inradius / circumradius (1 for the regular tet, 0 for a flat one).
- Boundary faces are the triangles used by exactly one tet; the boundary Euler characteristic is
  V - E + F of those triangles. Components are the vertex-connected groups of tets.
- Hausdorff distances are in physical units, measured against the isosurface of the volume
  (VTK flying edges on the grid, i.e. linear interpolation along grid edges): "out" is the
  largest distance from a boundary vertex of the mesh to the isosurface or to the flat box
  faces that close the material where it reaches the volume's border, "in" the
  largest distance from an isosurface vertex to the mesh's boundary triangles. A lost
  component shows as a large "in".
"""

import gzip
import json
import os
import re
import subprocess

import numpy as np

try:
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk, numpy_to_vtkIdTypeArray, vtk_to_numpy
except ImportError:  # the caller reports the skip
    vtk = None


# ---------------------------------------------------------------------------------------------
# Volumes


class Volume:
    def __init__(self, f, origin, spacing, direction):
        self.f = f  # [k, j, i]
        self.origin = np.asarray(origin, dtype=float)
        self.spacing = np.asarray(spacing, dtype=float)
        self.direction = np.asarray(direction, dtype=float).reshape(3, 3)

    @property
    def dims(self):  # (nx, ny, nz)
        return tuple(int(n) for n in self.f.shape[::-1])

    def to_physical(self, ijk):
        """Index coordinates (N x 3, i j k) to physical points."""
        return self.origin + (np.asarray(ijk, dtype=float) * self.spacing) @ self.direction.T

    def to_index(self, xyz):
        return ((np.asarray(xyz, dtype=float) - self.origin) @ self.direction) / self.spacing


_NRRD_TYPES = {
    "uchar": "u1", "unsigned char": "u1", "uint8": "u1", "uint8_t": "u1",
    "signed char": "i1", "int8": "i1", "int8_t": "i1",
    "short": "i2", "int16": "i2", "int16_t": "i2", "signed short": "i2",
    "ushort": "u2", "unsigned short": "u2", "uint16": "u2", "uint16_t": "u2",
    "int": "i4", "int32": "i4", "int32_t": "i4", "signed int": "i4",
    "uint": "u4", "unsigned int": "u4", "uint32": "u4", "uint32_t": "u4",
    "float": "f4", "double": "f8",
}


def _read_nrrd(path):
    """Attached-data NRRD with raw or gzip encoding (what the demo and the shared CT use)."""
    with open(path, "rb") as fh:
        data = fh.read()
    end = data.find(b"\n\n")
    if not data.startswith(b"NRRD") or end < 0:
        raise ValueError(f"{path}: not an attached-data NRRD")
    fields = {}
    for line in data[:end].decode("latin-1").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        key, value = line.split(":", 1)
        fields[key.strip().lower()] = value.strip().lstrip("=").strip()
    sizes = [int(v) for v in fields["sizes"].split()]
    if len(sizes) != 3:
        raise ValueError(f"{path}: only scalar 3-D NRRD is supported here")
    dtype = np.dtype(_NRRD_TYPES[fields["type"].lower()])
    if dtype.itemsize > 1:
        dtype = dtype.newbyteorder("<" if fields.get("endian", "little") == "little" else ">")
    body = data[end + 2:]
    encoding = fields.get("encoding", "raw").lower()
    if encoding in ("gzip", "gz"):
        body = gzip.decompress(body)
    elif encoding != "raw":
        raise ValueError(f"{path}: encoding {encoding} not supported here")
    count = sizes[0] * sizes[1] * sizes[2]
    f = np.frombuffer(body, dtype=dtype, count=count).reshape(sizes[::-1])
    origin = np.zeros(3)
    spacing = np.ones(3)
    direction = np.eye(3)
    if "space directions" in fields:
        vecs = [np.array([float(x) for x in v.split(",")])
                for v in re.findall(r"\(([^)]*)\)", fields["space directions"])]
        spacing = np.array([np.linalg.norm(v) for v in vecs])
        direction = np.stack([v / n for v, n in zip(vecs, spacing)], axis=1)
    elif "spacings" in fields:
        spacing = np.array([float(v) for v in fields["spacings"].split()])
    if "space origin" in fields:
        origin = np.array([float(x) for x in fields["space origin"].strip("()").split(",")])
    return Volume(f, origin, spacing, direction)


def read_volume(path):
    low = path.lower()
    if low.endswith(".nrrd"):
        return _read_nrrd(path)
    if low.endswith((".mhd", ".mha")):
        reader = vtk.vtkMetaImageReader()
    elif low.endswith(".vti"):
        reader = vtk.vtkXMLImageDataReader()
    elif low.endswith(".vtk"):
        reader = vtk.vtkStructuredPointsReader()
    elif low.endswith((".nii", ".nii.gz")):
        reader = vtk.vtkNIFTIImageReader()
    else:
        raise ValueError(f"{path}: no reader here")
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    nx, ny, nz = image.GetDimensions()
    f = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
    origin = np.array(image.GetOrigin(), dtype=float)
    direction = np.eye(3)
    if hasattr(image, "GetDirectionMatrix"):
        m = image.GetDirectionMatrix()
        direction = np.array([[m.GetElement(r, c) for c in range(3)] for r in range(3)])
    if low.endswith((".nii", ".nii.gz")):
        # VTK leaves the NIfTI transform aside: world = M @ (spacing * ijk) + t.
        m = reader.GetSFormMatrix() or reader.GetQFormMatrix()
        if m is not None:
            direction = np.array([[m.GetElement(r, c) for c in range(3)] for r in range(3)])
            origin = np.array([m.GetElement(r, 3) for r in range(3)])
    return Volume(f, origin, image.GetSpacing(), direction)


def inside_mask(vol, iso, invert=False):
    f = vol.f.astype(np.float64)
    return f <= iso if invert else f >= iso


# ---------------------------------------------------------------------------------------------
# Connected components (vectorised union-find: hook roots to the smaller root, then jump)


def components_from_edges(n, u, v):
    """Labels 0..C-1 of the connected components of a graph with n nodes and edges (u, v)."""
    parent = np.arange(n, dtype=np.int64)
    u = np.asarray(u, dtype=np.int64)
    v = np.asarray(v, dtype=np.int64)
    while True:
        pu = parent[u]
        pv = parent[v]
        differ = pu != pv
        if not differ.any():
            break
        u, v, pu, pv = u[differ], v[differ], pu[differ], pv[differ]
        np.minimum.at(parent, np.maximum(pu, pv), np.minimum(pu, pv))
        while True:
            jumped = parent[parent]
            if np.array_equal(jumped, parent):
                break
            parent = jumped
    _, labels = np.unique(parent, return_inverse=True)
    return labels


def grid_components(mask, connectivity=6):
    """Labels (-1 outside the mask) and count of the 6-connected components of a boolean grid."""
    idx = -np.ones(mask.shape, dtype=np.int64)
    n = int(mask.sum())
    idx[mask] = np.arange(n)
    us, vs = [], []
    for axis in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[axis] = slice(0, -1)
        b[axis] = slice(1, None)
        both = mask[tuple(a)] & mask[tuple(b)]
        us.append(idx[tuple(a)][both])
        vs.append(idx[tuple(b)][both])
    if connectivity != 6:
        raise ValueError("only 6-connectivity")
    labels = components_from_edges(n, np.concatenate(us), np.concatenate(vs))
    out = -np.ones(mask.shape, dtype=np.int64)
    out[mask] = labels
    return out, (int(labels.max()) + 1 if n else 0)


def grid_topology(mask):
    """Topology the mesher promises for the inside grid points: boundary Euler characteristic
    2 (V - E + F - C + S) of the cubical complex of inside points, where S counts the cubes whose
    only two outside corners are antipodal (the mesher fills such a cube around its centre), and
    the number of 6-connected components."""
    m = mask
    V = int(m.sum())
    E = int((m[1:] & m[:-1]).sum() + (m[:, 1:] & m[:, :-1]).sum() + (m[:, :, 1:] & m[:, :, :-1]).sum())
    F = int((m[:, 1:, 1:] & m[:, 1:, :-1] & m[:, :-1, 1:] & m[:, :-1, :-1]).sum()
            + (m[1:, :, 1:] & m[1:, :, :-1] & m[:-1, :, 1:] & m[:-1, :, :-1]).sum()
            + (m[1:, 1:, :] & m[1:, :-1, :] & m[:-1, 1:, :] & m[:-1, :-1, :]).sum())
    corners = {}
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                corners[(dx, dy, dz)] = m[dz:m.shape[0] - 1 + dz, dy:m.shape[1] - 1 + dy,
                                          dx:m.shape[2] - 1 + dx]
    count = sum(c.astype(np.int8) for c in corners.values())
    C = int((count == 8).sum())
    S = 0
    for c in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)):
        anti = tuple(1 - x for x in c)
        S += int(((count == 6) & ~corners[c] & ~corners[anti]).sum())
    _, ncomp = grid_components(m)
    return {"euler": 2 * (V - E + F - C + S), "components": ncomp, "V": V, "E": E, "F": F,
            "C": C, "S": S}


# ---------------------------------------------------------------------------------------------
# Meshes


def read_vtu_tets(path):
    import meshio
    mesh = meshio.read(path)
    tets = [c.data for c in mesh.cells if c.type == "tetra"]
    tets = np.concatenate(tets) if tets else np.zeros((0, 4), dtype=np.int64)
    return np.asarray(mesh.points, dtype=float), np.asarray(tets, dtype=np.int64)


def read_vtu_triangles(path):
    import meshio
    mesh = meshio.read(path)
    tris = [c.data for c in mesh.cells if c.type == "triangle"]
    tris = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    return np.asarray(mesh.points, dtype=float), np.asarray(tris, dtype=np.int64)


def _read_numbered_table(path, columns):
    """Rows of a TetGen .node/.ele file: first line is the header, '#' starts a comment."""
    rows = []
    with open(path) as fh:
        lines = [ln.split("#", 1)[0].split() for ln in fh]
    lines = [ln for ln in lines if ln]
    header = [int(float(x)) for x in lines[0]]
    for ln in lines[1:header[0] + 1]:
        rows.append([float(x) for x in ln[:columns + 1]])
    return header, np.array(rows, dtype=float).reshape(-1, columns + 1)


def read_tetgen(stem):
    """TetGen's STEM.node and STEM.ele (first-order tets)."""
    _, nodes = _read_numbered_table(stem + ".node", 3)
    header, ele = _read_numbered_table(stem + ".ele", 4)
    if header[1] != 4:
        raise ValueError(f"{stem}.ele: {header[1]} nodes per tet, expected 4")
    base = int(nodes[0, 0]) if len(nodes) else 0
    order = np.argsort(nodes[:, 0])
    points = nodes[order, 1:4]
    tets = ele[:, 1:5].astype(np.int64) - base
    return points, tets


def read_cgal_text(path, vol=None):
    """The text written by cgal_mesh3; image coordinates are mapped through vol's origin and
    direction when vol is given (the .inr carries the spacing only)."""
    with open(path) as fh:
        head = fh.readline().split()
        n = int(head[1])
        points = np.loadtxt(fh, max_rows=n, ndmin=2) if n else np.zeros((0, 3))
        head = fh.readline().split()
        m = int(head[1])
        tets = np.loadtxt(fh, max_rows=m, dtype=np.int64, ndmin=2) if m else np.zeros((0, 4), np.int64)
    if vol is not None and n:
        points = vol.origin + points @ vol.direction.T
    return points.reshape(-1, 3), tets.reshape(-1, 4)


def write_inr(path, vol, mask):
    """The thresholded volume as an 8-bit INRIMAGE-4 label image (1 = material) for CGAL."""
    nz, ny, nx = mask.shape
    head = ("#INRIMAGE-4#{\n"
            f"XDIM={nx}\nYDIM={ny}\nZDIM={nz}\nVDIM=1\n"
            "TYPE=unsigned fixed\nPIXSIZE=8 bits\nSCALE=2**0\nCPU=decm\n"
            f"VX={vol.spacing[0]:.17g}\nVY={vol.spacing[1]:.17g}\nVZ={vol.spacing[2]:.17g}\n")
    tail = "##}\n"
    head = head + "\n" * (256 - len(head) - len(tail)) + tail
    assert len(head) == 256
    with open(path, "wb") as fh:
        fh.write(head.encode("ascii"))
        fh.write(np.ascontiguousarray(mask, dtype=np.uint8).tobytes())


def _tet_geometry(points, tets):
    p = points[tets]  # M x 4 x 3
    a = p[:, 1] - p[:, 0]
    b = p[:, 2] - p[:, 0]
    c = p[:, 3] - p[:, 0]
    det = np.einsum("ij,ij->i", a, np.cross(b, c))
    return p, a, b, c, det


def orientation_sign(points, tets):
    """+1 when most tets have positive volume (VTK's order), -1 otherwise."""
    if len(tets) == 0:
        return 1
    det = _tet_geometry(points, tets)[4]
    return 1 if np.sum(det > 0) >= np.sum(det < 0) else -1


def tet_quality(points, tets, sign=1):
    """Per-tet min and max dihedral angle (degrees), radius ratio and signed volume."""
    p, a, b, c, det = _tet_geometry(points, tets)
    vol6 = sign * det
    # Outward normal of the face opposite each vertex (unnormalised), for any orientation.
    faces = ((1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1))
    normals = []
    areas = []
    for (i, j, k) in faces:
        n = np.cross(p[:, j] - p[:, i], p[:, k] - p[:, i]) * np.sign(det)[:, None]
        areas.append(0.5 * np.linalg.norm(n, axis=1))
        normals.append(n)
    unit = [n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None] for n in normals]
    angles = []
    for f in range(4):
        for g in range(f + 1, 4):
            cosine = -np.einsum("ij,ij->i", unit[f], unit[g])
            angles.append(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))
    angles = np.stack(angles, axis=1)
    area = np.sum(areas, axis=0)
    volume = vol6 / 6.0
    inradius = 3.0 * np.abs(volume) / np.maximum(area, 1e-300)
    la, lb, lc = (np.einsum("ij,ij->i", x, x) for x in (a, b, c))
    centre = (la[:, None] * np.cross(b, c) + lb[:, None] * np.cross(c, a)
              + lc[:, None] * np.cross(a, b))
    with np.errstate(divide="ignore", invalid="ignore"):
        circum = np.linalg.norm(centre, axis=1) / np.abs(2.0 * det)
        ratio = np.where(np.abs(det) > 0, 3.0 * inradius / circum, 0.0)
    flat = ~(np.abs(det) > 0)
    dmin = np.where(flat, 0.0, angles.min(axis=1))
    dmax = np.where(flat, 180.0, angles.max(axis=1))
    return dmin, dmax, np.nan_to_num(ratio), volume


def boundary_triangles(tets):
    """Triangles used by exactly one tet, oriented as seen from their tet (outward for
    positively oriented tets)."""
    faces = np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 3, 2]], tets[:, [0, 1, 3]],
                            tets[:, [0, 2, 1]]])
    key = np.sort(faces, axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    return faces[first[counts == 1]]


def surface_euler(tris):
    if len(tris) == 0:
        return 0, True
    verts = np.unique(tris)
    edges = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    uedges, counts = np.unique(edges, axis=0, return_counts=True)
    return len(verts) - len(uedges) + len(tris), bool(np.all(counts == 2))


def mesh_stats(points, tets, strict_orientation=False):
    """Statistics of one tet mesh. With strict_orientation the tets must have positive volume
    in VTK's order (volmesh's promise); otherwise the orientation is the majority's (TetGen
    and CGAL order their vertices the other way)."""
    tets = np.asarray(tets, dtype=np.int64)
    sign = 1 if strict_orientation else orientation_sign(points, tets)
    if len(tets) == 0:
        return {"elements": 0}
    dmin, dmax, ratio, volume = tet_quality(points, tets, sign)
    tris = boundary_triangles(tets if sign > 0 else tets[:, [0, 2, 1, 3]])
    euler, closed = surface_euler(tris)
    u = np.concatenate([tets[:, 0], tets[:, 0], tets[:, 0]])
    v = np.concatenate([tets[:, 1], tets[:, 2], tets[:, 3]])
    used = np.unique(tets)
    remap = -np.ones(len(points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    labels = components_from_edges(len(used), remap[u], remap[v])
    return {
        "elements": int(len(tets)),
        "points": int(len(used)),
        "inverted": int(np.sum(volume <= 0)),
        "min_dihedral": float(dmin.min()),
        "max_dihedral": float(dmax.max()),
        "mean_min_dihedral": float(dmin.mean()),
        "slivers_5": int(np.sum(dmin < 5.0)),
        "slivers_10": int(np.sum(dmin < 10.0)),
        "rr_min": float(ratio.min()),
        "rr_mean": float(ratio.mean()),
        "boundary_euler": int(euler),
        "boundary_closed": closed,
        "components": int(labels.max()) + 1,
        "volume": float(volume.sum()),
        "_boundary": tris,
        "_sign": sign,
    }


# ---------------------------------------------------------------------------------------------
# Distance to the isosurface


def _polydata(points, tris):
    pd = vtk.vtkPolyData()
    pts = vtk.vtkPoints()
    pts.SetData(numpy_to_vtk(np.ascontiguousarray(points, dtype=np.float64), deep=True))
    pd.SetPoints(pts)
    cells = np.hstack([np.full((len(tris), 1), 3, dtype=np.int64), tris]).ravel()
    ca = vtk.vtkCellArray()
    ca.SetCells(len(tris), numpy_to_vtkIdTypeArray(cells, deep=True))
    pd.SetPolys(ca)
    return pd


def isosurface(vol, iso):
    """Flying-edges isosurface of the volume, in physical coordinates: (points, triangles)."""
    image = vtk.vtkImageData()
    nx, ny, nz = vol.dims
    image.SetDimensions(nx, ny, nz)
    arr = numpy_to_vtk(np.ascontiguousarray(vol.f.astype(np.float64)).ravel(), deep=True)
    arr.SetName("f")
    image.GetPointData().SetScalars(arr)
    fe = vtk.vtkFlyingEdges3D()
    fe.SetInputData(image)
    # The material is f >= iso: a grid point exactly at iso is inside (integer data often has
    # them, e.g. single voxels of value iso), so contour a hair below iso to give such points
    # their tiny surface instead of none.
    fe.SetValue(0, float(iso) - 1e-7 * max(1.0, abs(float(iso))))
    fe.ComputeNormalsOff()
    fe.ComputeGradientsOff()
    fe.Update()
    out = fe.GetOutput()
    if out.GetNumberOfPoints() == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    pts = vtk_to_numpy(out.GetPoints().GetData()).astype(float)
    tris = vtk_to_numpy(out.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    return vol.to_physical(pts), tris.astype(np.int64)


def trilinear(vol, ijk):
    f = vol.f.astype(np.float64)
    nz, ny, nx = f.shape
    x = np.clip(ijk[:, 0], 0, nx - 1)
    y = np.clip(ijk[:, 1], 0, ny - 1)
    z = np.clip(ijk[:, 2], 0, nz - 1)
    x0 = np.minimum(np.floor(x).astype(int), nx - 2)
    y0 = np.minimum(np.floor(y).astype(int), ny - 2)
    z0 = np.minimum(np.floor(z).astype(int), nz - 2)
    tx, ty, tz = x - x0, y - y0, z - z0
    out = np.zeros(len(ijk))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = (tx if dx else 1 - tx) * (ty if dy else 1 - ty) * (tz if dz else 1 - tz)
                out += w * f[z0 + dz, y0 + dy, x0 + dx]
    return out


def _distances(from_points, surface_points, surface_tris):
    """Unsigned distance of each point to a triangle surface (VTK's implicit distance)."""
    if len(surface_tris) == 0:
        return np.full(len(from_points), np.inf)
    surface = _polydata(surface_points, surface_tris)
    implicit = vtk.vtkImplicitPolyDataDistance()
    implicit.SetInput(surface)
    # The surface's vertices count too: VTK's distance skips zero-area triangles, which flying
    # edges makes around a grid point that is exactly at the isovalue. Only the vertices of
    # the triangles: a tet mesh's points include its interior ones, and a locator over all of
    # them found an interior vertex nearer than the boundary (the surface-to-boundary
    # distances measured before 2026-12-05 were too small where that happened).
    used = np.unique(surface_tris)
    corners = vtk.vtkPolyData()
    cp = vtk.vtkPoints()
    cp.SetData(numpy_to_vtk(np.ascontiguousarray(surface_points[used], dtype=float), deep=True))
    corners.SetPoints(cp)
    locator = vtk.vtkStaticPointLocator()
    locator.SetDataSet(corners)
    locator.BuildLocator()
    out = np.empty(len(from_points))
    closest = [0.0, 0.0, 0.0]
    for n, p in enumerate(from_points):
        d = abs(implicit.EvaluateFunctionAndGetClosestPoint(p, closest))
        q = surface_points[used[locator.FindClosestPoint(p)]]
        out[n] = min(d, float(np.sqrt(np.sum((q - p) ** 2))))
    return out


def box_distance(vol, iso, xyz, invert=False):
    """Distance from points to the flat faces that close the material where it reaches the
    volume's border: for each of the six box planes, the distance to the point's projection on
    it when the (trilinear) field there is inside, else infinity. The reference boundary is the
    isosurface together with these faces."""
    ijk = vol.to_index(xyz)
    n = np.array(vol.dims, dtype=float) - 1
    best = np.full(len(xyz), np.inf)
    for axis in range(3):
        for side in (0.0, n[axis]):
            proj = ijk.copy()
            proj[:, axis] = side
            proj = np.clip(proj, 0, n)
            fval = trilinear(vol, proj)
            tol = 1e-9 * max(1.0, abs(iso))
            inside = (fval <= iso + tol) if invert else (fval >= iso - tol)
            d = np.linalg.norm(vol.to_physical(proj) - vol.to_physical(ijk), axis=1)
            best = np.where(inside, np.minimum(best, d), best)
    return best


def hausdorff(vol, iso, points, tris, iso_surface=None, invert=False):
    """(out, in): max distance mesh boundary -> isosurface, isosurface -> mesh boundary."""
    ipts, itris = iso_surface if iso_surface is not None else isosurface(vol, iso)
    if len(tris) == 0:
        return float("inf"), float("inf")
    verts = np.unique(tris)
    bp = points[verts]
    d_out = np.minimum(_distances(bp, ipts, itris), box_distance(vol, iso, bp, invert))
    d_in = _distances(ipts, points, tris) if len(ipts) else np.zeros(1)
    return float(d_out.max()), float(d_in.max())


def surface_cavity_points(points, tris, mesh_vtu, step):
    """TetGen's hole points from volmesh's own boundary surface: one point in each cavity of
    the material, that is inside each closed shell of the surface that encloses negative
    volume (the triangles are oriented out of the material, so a cavity's shell faces into
    it). The point is STEP beyond the centroid of one of the shell's triangles, along its
    normal, and is kept only where it lies outside the tet mesh mesh_vtu (the largest
    triangles are tried first)."""
    tris = np.asarray(tris, dtype=np.int64)
    if len(tris) == 0:
        return np.zeros((0, 3))
    edges = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    vlab = components_from_edges(len(points), edges[:, 0], edges[:, 1])
    shell = vlab[tris[:, 0]]
    p0, p1, p2 = points[tris[:, 0]], points[tris[:, 1]], points[tris[:, 2]]
    cross = np.cross(p1 - p0, p2 - p0)
    signed = np.einsum("ij,ij->i", p0, cross) / 6.0  # divergence theorem, per triangle
    area2 = np.linalg.norm(cross, axis=1)
    import vtk  # only here: the rest of refstats does not need VTK to load
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(mesh_vtu)
    reader.Update()
    locator = vtk.vtkStaticCellLocator()
    locator.SetDataSet(reader.GetOutput())
    locator.BuildLocator()
    volume = np.bincount(shell, weights=signed)
    result = []
    for lab in np.nonzero(volume < 0)[0]:
        faces = np.nonzero(shell == lab)[0]
        for t in faces[np.argsort(-area2[faces], kind="stable")][:64]:
            if area2[t] == 0:
                break
            x = (p0[t] + p1[t] + p2[t]) / 3.0 + step * cross[t] / area2[t]
            if locator.FindCell([float(c) for c in x]) < 0:
                result.append(x)
                break
    return np.array(result, dtype=float) if result else np.zeros((0, 3))


def write_smesh(path, points, tris, holes):
    """A TetGen .smesh PLC: the boundary triangles as facets, with hole points for cavities."""
    used = np.unique(tris)
    remap = -np.ones(len(points), dtype=np.int64)
    remap[used] = np.arange(len(used))
    with open(path, "w") as fh:
        fh.write(f"{len(used)} 3 0 0\n")
        for n, p in enumerate(points[used]):
            fh.write(f"{n} {p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n")
        fh.write(f"{len(tris)} 0\n")
        for t in remap[tris]:
            fh.write(f"3 {t[0]} {t[1]} {t[2]}\n")
        fh.write(f"{len(holes)}\n")
        for n, h in enumerate(holes):
            fh.write(f"{n} {h[0]:.17g} {h[1]:.17g} {h[2]:.17g}\n")
        fh.write("0\n")


def public(stats):
    """The statistics without the private arrays, for JSON."""
    return {k: v for k, v in stats.items() if not k.startswith("_")}


SOURCES = ["CMakeLists.txt", "include", "core", "io", "mesher", "quality", "cli"]


def source_version():
    """The last commit that changed volmesh's own code (SOURCES: not its tests, benchmarks or
    docs), with '-dirty' when that code has uncommitted changes: the version measured, which
    edits to the drivers while a run goes on do not change. None outside a git checkout."""
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    try:
        head = subprocess.run(["git", "-C", root, "log", "-1", "--format=%h", "--"] + SOURCES,
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                              text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", root, "diff", "--quiet", "HEAD", "--"] + SOURCES,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode
    except OSError:
        return None
    return (head + ("-dirty" if dirty == 1 else "")) if head else None


def dump(path, obj):
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(obj, fh, indent=1, sort_keys=True)


def merge_rerun(path, meta, results):
    """(meta, results) of the saved run at path with the cases of this run put in its place:
    the rerun's meta goes to the saved meta's list "reruns"."""
    with open(path, encoding="utf-8") as fh:
        saved = json.load(fh)
    fresh = {r["case"]: r for r in results}
    merged = dict(saved["meta"])
    merged["reruns"] = merged.get("reruns", []) + [dict(meta, cases=[r["case"] for r in results])]
    return merged, [fresh.get(r["case"], r) for r in saved["results"]]
