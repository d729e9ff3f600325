# SPDX-License-Identifier: BSD-3-Clause
"""tests/surface/test_surface_asc_vtk.py — VTK as the judge of adaptive skeleton climbing.

Runs surface_test_surface_asc_export (beside $VM_CLI in the build tree), which writes each
input volume (phantoms at 64^3; ironProt, hydrogen and the CT head when ../shared/data is
there) as NRRD and volmesh's asc surfaces at max levels 0 and 4 as VTU. For each input, VTK's
vtkFlyingEdges3D (marching cubes) contours the same volume at the same isovalue; the test
prints the triangle counts and the reduction MC / asc level 4, and checks with VTK's own
filters that the asc surfaces have no boundary or non-manifold edges (vtkFeatureEdges), and
for the phantoms that their volumes (vtkMassProperties) agree with marching cubes.
Exit 0 pass, 1 fail, 77 when vtk cannot be imported or the exporter is not built.
"""
import os
import shutil
import subprocess
import sys
import tempfile

try:
    import numpy as np
    import vtk
    from vtk.util import numpy_support
except ImportError as e:  # pragma: no cover
    print(f"skipped: cannot import vtk under {sys.executable} ({e})")
    sys.exit(77)

TMP = os.environ.get("VM_TEST_TMP", ".")
CLI = os.environ.get("VM_CLI", "")
EXPORTER = os.path.join(os.path.dirname(CLI), "tests", "surface_test_surface_asc_export")
failures = []

# Smallest accepted reduction MC triangles / asc level-4 triangles (measured minus ~10%).
MIN_RATIO = {"sphere": 8.0, "torus": 3.5, "genus3": 1.7, "two-spheres": 4.5,
             "ironProt": 1.7, "hydrogen": 3.2, "ct_head": 2.2}


def check(cond, msg):
    if not cond:
        failures.append(msg)
        print("  FAILED: " + msg)


def read_nrrd(path):
    """The raw float NRRD that vm_volume_write_nrrd writes (axis-aligned), as vtkImageData
    (vtkNrrdReader is replaced by an MPI reader in Debian's VTK)."""
    with open(path, "rb") as f:
        data = f.read()
    head, _, body = data.partition(b"\n\n")
    fields = {}
    for line in head.decode().splitlines()[1:]:
        if ":" in line and not line.startswith("#"):
            k, v = line.split(":", 1)
            fields[k.strip()] = v.strip()
    assert fields["type"] == "float" and fields["encoding"] == "raw", fields
    dims = [int(x) for x in fields["sizes"].split()]
    dirs = [[float(c) for c in d.strip("()").split(",")]
            for d in fields["space directions"].split()]
    origin = [float(c) for c in fields["space origin"].strip("()").split(",")]
    arr = np.frombuffer(body, dtype="<f4", count=dims[0] * dims[1] * dims[2])
    img = vtk.vtkImageData()
    img.SetDimensions(*dims)
    img.SetSpacing(dirs[0][0], dirs[1][1], dirs[2][2])
    img.SetOrigin(*origin)
    va = numpy_support.numpy_to_vtk(arr.astype(np.float32), deep=1)
    va.SetName("f")
    img.GetPointData().SetScalars(va)
    return img


def read_surface(path):
    r = vtk.vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = vtk.vtkGeometryFilter()
    g.SetInputConnection(r.GetOutputPort())
    g.Update()
    return g.GetOutput()


def open_edges(poly):
    fe = vtk.vtkFeatureEdges()
    fe.SetInputData(poly)
    fe.BoundaryEdgesOn()
    fe.NonManifoldEdgesOn()
    fe.FeatureEdgesOff()
    fe.ManifoldEdgesOff()
    fe.Update()
    return fe.GetOutput().GetNumberOfCells()


def volume(poly):
    m = vtk.vtkMassProperties()
    m.SetInputData(poly)
    m.Update()
    return m.GetVolume()


def main():
    if not os.path.exists(EXPORTER):
        print(f"skipped: {EXPORTER} is not built")
        return 77
    # A folder of its own: ctest may run the exporter as its own test at the same time.
    work = tempfile.mkdtemp(prefix="asc_vtk.", dir=TMP)
    env = dict(os.environ, VM_TEST_TMP=work)
    try:
        return judge(work, env)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def judge(TMP, env):
    res = subprocess.run([EXPORTER], cwd=TMP, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        print(res.stdout + res.stderr)
        print("FAILED: the exporter failed")
        return 1
    with open(os.path.join(TMP, "asc_cases.txt")) as f:
        cases = [line.split() for line in f if line.strip()]
    print(f"{'input':12} {'iso':>6} {'VTK MC':>8} {'asc L0':>8} {'asc L4':>8} "
          f"{'MC/L4':>6} {'vol L4/MC':>9}")
    for name, iso in cases:
        iso = float(iso)
        img = read_nrrd(os.path.join(TMP, f"asc_{name}.nrrd"))
        fl = vtk.vtkFlyingEdges3D()
        fl.SetInputData(img)
        fl.SetValue(0, iso)
        fl.ComputeNormalsOff()
        fl.Update()
        mc = fl.GetOutput()
        n_mc = mc.GetNumberOfPolys()
        s0 = read_surface(os.path.join(TMP, f"asc_{name}_L0.vtu"))
        s4 = read_surface(os.path.join(TMP, f"asc_{name}_L4.vtu"))
        n0, n4 = s0.GetNumberOfCells(), s4.GetNumberOfCells()
        ratio = n_mc / n4 if n4 else 0.0
        phantom = name in ("sphere", "torus", "genus3", "two-spheres")
        vr = volume(s4) / volume(mc) if phantom else float("nan")
        print(f"{name:12} {iso:6g} {n_mc:8d} {n0:8d} {n4:8d} {ratio:6.2f} {vr:9.4f}")
        check(open_edges(s0) == 0, f"{name}: level 0 has boundary or non-manifold edges")
        check(open_edges(s4) == 0, f"{name}: level 4 has boundary or non-manifold edges")
        check(ratio >= MIN_RATIO.get(name, 1.0),
              f"{name}: MC/asc-L4 triangles {ratio:.2f} below {MIN_RATIO.get(name, 1.0)}")
        if phantom:
            # same unit-cell surface: level 0 has marching cubes' triangles, same volume
            check(abs(n0 - n_mc) <= 0.02 * n_mc, f"{name}: level 0 {n0} vs MC {n_mc} triangles")
            v0 = volume(s0) / volume(mc)
            check(abs(v0 - 1) <= 0.002, f"{name}: level-0 volume / MC volume {v0:.5f}")
            check(abs(vr - 1) <= 0.03, f"{name}: level-4 volume / MC volume {vr:.5f}")
    sys.stdout.flush()
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
