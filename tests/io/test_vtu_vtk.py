# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_vtu_vtk.py — VTK and meshio, as independent judges, read the VTU files that
tests/io/test_vtu.c writes (vtu_judge_tets.vtu: compressed, a ring of 8 unit cubes as 48 Kuhn
tets; vtu_judge_hex.vtu: uncompressed, a 3x2x1 slab of unit hexes shifted by (10, 20, 30);
vtu_judge_blocks.vtu: compressed, a 30x30x30 box of Kuhn tets, arrays of up to 159 blocks).
Exit 0 pass, 1 fail, 77 skip when vtk or meshio cannot be imported."""
import os
import subprocess
import sys

try:
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    import meshio
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import vtk/meshio ({exc})")
    sys.exit(77)

TMP = os.environ.get("VM_TEST_TMP", ".")
RING = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (2, 1, 0), (2, 2, 0), (1, 2, 0), (0, 2, 0), (0, 1, 0)]
SLAB = [(0, 0, 0), (1, 0, 0), (2, 0, 0), (0, 1, 0), (1, 1, 0), (2, 1, 0)]
BOX = [(q % 30, q // 30 % 30, q // 900) for q in range(30 ** 3)]
CASES = [
    # file, VTK cell type, meshio name, cubes, origin, cells per cube
    ("vtu_judge_tets.vtu", 10, "tetra", RING, (0.0, 0.0, 0.0), 6),
    ("vtu_judge_hex.vtu", 12, "hexahedron", SLAB, (10.0, 20.0, 30.0), 1),
    ("vtu_judge_blocks.vtu", 10, "tetra", BOX, (0.0, 0.0, 0.0), 6),
]
failures = []


def check(cond, what):
    if not cond:
        failures.append(what)
        print(f"  FAILED: {what}")


def ensure_files():
    """The C test writes the files; when run alone, run it to produce them."""
    if all(os.path.exists(os.path.join(TMP, c[0])) for c in CASES):
        return
    cli = os.environ.get("VM_CLI", "")
    exe = os.path.join(os.path.dirname(cli), "tests", "io_test_vtu")
    if os.path.exists(exe):
        subprocess.run([exe], cwd=TMP, env=dict(os.environ), stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, check=False)


def expected_points(cubes, origin):
    pts = set()
    for (i, j, k) in cubes:
        for dx in (0, 1):
            for dy in (0, 1):
                for dz in (0, 1):
                    pts.add((origin[0] + i + dx, origin[1] + j + dy, origin[2] + k + dz))
    return pts


def judge_with_vtk(path, ctype, cubes, origin, per_cube):
    name = os.path.basename(path)
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    ncells = len(cubes) * per_cube
    want_pts = expected_points(cubes, origin)
    check(grid.GetNumberOfPoints() == len(want_pts),
          f"{name}: vtk sees {grid.GetNumberOfPoints()} points, expected {len(want_pts)}")
    check(grid.GetNumberOfCells() == ncells,
          f"{name}: vtk sees {grid.GetNumberOfCells()} cells, expected {ncells}")
    if grid.GetNumberOfPoints() == 0 or grid.GetNumberOfCells() == 0:
        return
    pts = vtk_to_numpy(grid.GetPoints().GetData())
    check(pts.dtype == np.float64, f"{name}: points are {pts.dtype}, expected float64")
    got = {tuple(float(v) for v in p) for p in pts}
    check(got == want_pts, f"{name}: point coordinates differ from the cube lattice")
    types = {grid.GetCellType(i) for i in range(grid.GetNumberOfCells())}
    check(types == {ctype}, f"{name}: cell types {types}, expected {{{ctype}}}")
    region = grid.GetCellData().GetArray("region")
    check(region is not None and region.GetDataType() == vtk.VTK_INT,
          f"{name}: region array missing or not Int32")
    if region is not None:
        reg = vtk_to_numpy(region)
        want = np.repeat(np.arange(len(cubes)), per_cube)
        check(np.array_equal(reg, want), f"{name}: region values {reg[:12]}... wrong")
    temp = grid.GetPointData().GetArray("temperature")
    check(temp is not None, f"{name}: point field temperature missing")
    if temp is not None:
        t = vtk_to_numpy(temp)
        check(np.allclose(t, pts[:, 0] + 2 * pts[:, 1] + 3 * pts[:, 2], rtol=0, atol=1e-12),
              f"{name}: temperature is not x + 2y + 3z")
    vec = grid.GetCellData().GetArray("vec")
    check(vec is not None and vec.GetNumberOfComponents() == 3,
          f"{name}: cell field vec missing or not 3 components")
    if vec is not None:
        v = vtk_to_numpy(vec)
        c = np.arange(ncells, dtype=float)
        check(np.array_equal(v, np.stack([c, -c, 0.5 * c], axis=1)), f"{name}: vec values wrong")

    quality = vtk.vtkMeshQuality()
    quality.SetInputData(grid)
    quality.SetTetQualityMeasureToVolume()
    quality.SetHexQualityMeasureToVolume()
    quality.Update()
    vols = vtk_to_numpy(quality.GetOutput().GetCellData().GetArray("Quality"))
    check(np.all(vols > 0), f"{name}: vtkMeshQuality finds non-positive volumes {vols.min()}")
    check(abs(vols.sum() - len(cubes)) < 1e-9 * len(cubes),
          f"{name}: vtkMeshQuality volumes sum to {vols.sum()}, expected {len(cubes)}")

    sizes = vtk.vtkCellSizeFilter()
    sizes.SetInputData(grid)
    sizes.ComputeVertexCountOff()
    sizes.ComputeLengthOff()
    sizes.ComputeAreaOff()
    sizes.ComputeVolumeOn()
    sizes.Update()
    sv = vtk_to_numpy(sizes.GetOutput().GetCellData().GetArray("Volume"))
    check(np.all(sv > 0), f"{name}: vtkCellSizeFilter finds non-positive volumes")
    check(abs(sv.sum() - len(cubes)) < 1e-9 * len(cubes),
          f"{name}: vtkCellSizeFilter volumes sum to {sv.sum()}, expected {len(cubes)}")


def judge_with_meshio(path, mname, cubes, origin, per_cube):
    name = os.path.basename(path)
    mesh = meshio.read(path)
    want_pts = expected_points(cubes, origin)
    check(mesh.points.shape == (len(want_pts), 3), f"{name}: meshio points {mesh.points.shape}")
    check({tuple(float(v) for v in p) for p in mesh.points} == want_pts,
          f"{name}: meshio coordinates differ from the cube lattice")
    kinds = [b.type for b in mesh.cells]
    check(kinds == [mname], f"{name}: meshio cell blocks {kinds}, expected [{mname}]")
    if kinds == [mname]:
        check(len(mesh.cells[0].data) == len(cubes) * per_cube, f"{name}: meshio cell count")
    reg = mesh.cell_data.get("region")
    check(reg is not None, f"{name}: meshio finds no region cell data")
    if reg is not None:
        want = np.repeat(np.arange(len(cubes)), per_cube)
        check(np.array_equal(np.asarray(reg[0]), want), f"{name}: meshio region values wrong")


def main():
    ensure_files()
    for fname, ctype, mname, cubes, origin, per_cube in CASES:
        path = os.path.join(TMP, fname)
        print(f"{fname}")
        if not os.path.exists(path):
            check(False, f"{path} is missing (tests/io/test_vtu.c writes it)")
            continue
        judge_with_vtk(path, ctype, cubes, origin, per_cube)
        judge_with_meshio(path, mname, cubes, origin, per_cube)
    print(f"{'FAILED' if failures else 'passed'}: {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
