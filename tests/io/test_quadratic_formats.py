# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_quadratic_formats.py — `--order 2` in .vtu, .msh and .msh2: meshio (and VTK
for the .vtu, gmsh -check for the .msh where installed) reads tetra10 / hexahedron20 with one
shared node per edge (corners + distinct edges), each mid-edge node at the middle of the
edge its position names in VTK's order (straight edges), the corner nodes and regions those
of the first-order mesh, and point fields carried to the mid-edge nodes. Exit 0 pass, 1 fail,
77 skip when meshio or numpy cannot be imported."""
import os
import shutil
import subprocess
import sys
import tempfile

try:
    import meshio
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import meshio/numpy ({exc})")
    sys.exit(77)

CLI = os.environ.get("VM_CLI")
if not CLI:
    print("skipped: VM_CLI is not set")
    sys.exit(77)
failures = []
TET_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
HEX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4),
             (0, 4), (1, 5), (2, 6), (3, 7)]


def check(cond, what):
    if not cond:
        failures.append(what)
        print(f"  FAILED: {what}")


def run(*args, expect=0):
    r = subprocess.run([CLI, *args], capture_output=True, text=True)
    check(r.returncode == expect, f"volmesh {' '.join(args)}: exit {r.returncode} {r.stderr}")
    return r


def main():
    work = tempfile.mkdtemp(prefix="quadratic_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    run("demo", "--size", "24", "--quiet")
    run("mesh", "phantom.nrrd", "--iso", "0", "--elements", "hex", "-o", "hex.vtu", "-q")
    for lin in ("demo.vtu", "hex.vtu"):
        ref = meshio.read(lin)
        kind = ref.cells[0].type
        corners = np.concatenate([c.data for c in ref.cells])
        reg = np.concatenate([np.asarray(d).ravel() for d in ref.cell_data["region"]])
        edges = TET_EDGES if kind == "tetra" else HEX_EDGES
        nc = 4 if kind == "tetra" else 8
        distinct = {tuple(sorted((int(c[a]), int(c[b])))) for c in corners for a, b in edges}
        want_points = len(ref.points) + len(distinct)
        base = lin[:-4]
        for ext, fmt in (("vtu", None), ("msh", "gmsh"), ("msh2", "gmsh")):
            out = f"{base}_o2.{ext}"
            run("convert", lin, out, "--order", "2")
            m = meshio.read(out, file_format=fmt)
            types = {c.type for c in m.cells}
            want_type = "tetra10" if kind == "tetra" else "hexahedron20"
            check(types == {want_type}, f"{out}: cell types {types}")
            d = np.concatenate([c.data for c in m.cells])
            check(len(m.points) == want_points and len(d) == len(corners),
                  f"{out}: {len(m.points)} points (want {want_points}), {len(d)} cells")
            if len(d) != len(corners):
                continue
            check(np.array_equal(m.points[:len(ref.points)], ref.points) and
                  np.array_equal(np.sort(d[:, :nc], axis=1), np.sort(corners, axis=1)),
                  f"{out}: corners differ from the first-order mesh")
            err = max(np.abs(m.points[d[:, nc + k]] - 0.5 * (m.points[d[:, a]] + m.points[d[:, b]])).max()
                      for k, (a, b) in enumerate(edges))
            check(err < 1e-12, f"{out}: a mid-edge node is {err} off its edge's middle")
            if kind == "tetra":
                p = m.points
                vol6 = np.einsum("ij,ij->i", np.cross(p[d[:, 1]] - p[d[:, 0]], p[d[:, 2]] - p[d[:, 0]]),
                                 p[d[:, 3]] - p[d[:, 0]])
                check(np.all(vol6 > 0), f"{out}: non-positive tets")
            if ext == "vtu":
                r = np.concatenate([np.asarray(x).ravel() for x in m.cell_data["region"]])
                check(np.array_equal(r, reg), f"{out}: regions differ")
            print(f"{out}: {len(m.points)} points, {len(d)} {want_type}, mid-edge nodes at the "
                  f"edge middles")
    # VTK reads the quadratic VTU: its cell type and counts
    try:
        import vtk
        r = vtk.vtkXMLUnstructuredGridReader()
        r.SetFileName("demo_o2.vtu")
        r.Update()
        g = r.GetOutput()
        m = meshio.read("demo_o2.vtu")
        check(g.GetCellType(0) == 24 and g.GetNumberOfPoints() == len(m.points) and
              g.GetCell(0).GetNumberOfPoints() == 10, f"VTK: type {g.GetCellType(0)}")
        print(f"VTK: {g.GetNumberOfCells()} quadratic tetra (type 24), {g.GetNumberOfPoints()} points")
    except ImportError:
        print("vtk cannot be imported: the VTK check is skipped")
    if shutil.which("gmsh"):
        for f in ("demo_o2.msh", "hex_o2.msh"):
            g = subprocess.run(["timeout", "300", "gmsh", "-check", "-nt", "1", f],
                               capture_output=True, text=True)
            check(g.returncode == 0 and "Error" not in g.stdout + g.stderr,
                  f"gmsh -check {f}: {g.stdout[-300:]}")
    # formats without second-order elements refuse it: exit 2, one line
    for out in ("x.mesh", "x.stl", "x.bdf"):
        r = run("convert", "demo.vtu", out, "--order", "2", expect=2)
        check(r.stderr.count("\n") == 1 and not os.path.exists(out), f"{out}: {r.stderr!r}")


main()
print(f"{0 if failures else 1} passed, {len(failures)} failed")
sys.exit(1 if failures else 0)
