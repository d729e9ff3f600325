# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_vti_vtk.py — VTK itself as the judge of the .vti and legacy .vtk readers.

Writes volumes with VTK's own writers (vtkXMLImageDataWriter: ascii, inline binary,
appended raw and base64, zlib or none, UInt32 and UInt64 headers; vtkStructuredPointsWriter:
ASCII and BINARY) into $VM_TEST_TMP, runs `$VM_CLI info FILE --json` and compares dims,
spacing, origin, min, max and mean with what VTK reports. Exit 0 pass, 1 fail, 77 when the
vtk module cannot be imported.
"""
import json
import os
import subprocess
import sys

try:
    import vtk
    from vtk.util import numpy_support  # noqa: F401  (needs numpy too)
    import numpy as np
except ImportError as e:  # pragma: no cover
    print(f"skipped: cannot import vtk/numpy under {sys.executable} ({e})")
    sys.exit(77)

TMP = os.environ.get("VM_TEST_TMP", ".")
CLI = os.environ.get("VM_CLI", "volmesh")
failures = []


def make_image(vtk_type, dims, spacing, origin, extent_start=(0, 0, 0), direction=None):
    img = vtk.vtkImageData()
    e = extent_start
    img.SetExtent(e[0], e[0] + dims[0] - 1, e[1], e[1] + dims[1] - 1, e[2], e[2] + dims[2] - 1)
    img.SetSpacing(*spacing)
    img.SetOrigin(*origin)
    if direction is not None:
        img.SetDirectionMatrix(*direction)
    n = dims[0] * dims[1] * dims[2]
    i = np.arange(n, dtype=np.float64)
    x = i % dims[0]
    y = (i // dims[0]) % dims[1]
    z = i // (dims[0] * dims[1])
    values = 40 * np.sin(x * 0.7) + 3 * y - 2 * z + 0.25 * i
    arr = vtk.vtkDataArray.CreateDataArray(vtk_type)
    arr.SetName("density")
    arr.SetNumberOfComponents(1)
    arr.SetNumberOfTuples(n)
    np_type = {vtk.VTK_UNSIGNED_CHAR: np.uint8, vtk.VTK_SHORT: np.int16,
               vtk.VTK_UNSIGNED_SHORT: np.uint16, vtk.VTK_INT: np.int32,
               vtk.VTK_FLOAT: np.float32, vtk.VTK_DOUBLE: np.float64}[vtk_type]
    if np.issubdtype(np_type, np.integer):
        info = np.iinfo(np_type)
        values = np.clip(np.round(values), info.min, info.max)
    for k, v in enumerate(values.astype(np_type)):
        arr.SetValue(k, v.item())
    img.GetPointData().SetScalars(arr)
    return img


def reference(img):
    """dims, spacing, world origin of voxel (0,0,0), min, max, mean as VTK has them."""
    arr = img.GetPointData().GetScalars()
    vals = np.array([arr.GetTuple1(k) for k in range(arr.GetNumberOfTuples())],
                    dtype=np.float64)
    vals = vals.astype(np.float32).astype(np.float64)  # volmesh stores float
    e = img.GetExtent()
    world = [0.0, 0.0, 0.0]
    img.TransformIndexToPhysicalPoint(e[0], e[2], e[4], world)
    return dict(dims=list(img.GetDimensions()), spacing=list(img.GetSpacing()),
                origin=world, min=vals.min(), max=vals.max(), mean=vals.mean())


def read_back(path):
    """Reads a file back with VTK's own reader, so the comparison is against VTK's view."""
    if path.endswith(".vti"):
        r = vtk.vtkXMLImageDataReader()
    else:
        r = vtk.vtkStructuredPointsReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def check(path, label):
    ref = reference(read_back(path))
    p = subprocess.run([CLI, "info", path, "--json"], capture_output=True, text=True)
    if p.returncode != 0:
        failures.append(f"{label}: volmesh info exited {p.returncode}: {p.stdout}{p.stderr}")
        return
    got = json.loads(p.stdout)
    bad = []
    if got["dims"] != ref["dims"]:
        bad.append(f"dims {got['dims']} != {ref['dims']}")
    for key in ("spacing", "origin"):
        if any(abs(a - b) > 1e-9 * max(1.0, abs(b)) for a, b in zip(got[key], ref[key])):
            bad.append(f"{key} {got[key]} != {ref[key]}")
    for key in ("min", "max", "mean"):
        if got[key] is None or abs(got[key] - ref[key]) > 1e-4 * max(1.0, abs(ref[key])):
            bad.append(f"{key} {got[key]} != {ref[key]}")
    if bad:
        failures.append(f"{label}: " + "; ".join(bad))
    else:
        print(f"ok   {label}")


def main():
    cases = [
        (vtk.VTK_FLOAT, (17, 13, 9), (0.5, 1.0, 2.0), (1.0, -2.0, 3.5), (0, 0, 0), None),
        (vtk.VTK_UNSIGNED_CHAR, (20, 11, 7), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0, 0, 0), None),
        (vtk.VTK_SHORT, (9, 8, 30), (0.3, 0.3, 1.25), (-5.0, 4.0, 2.0), (3, -2, 5), None),
        (vtk.VTK_DOUBLE, (12, 10, 6), (1.0, 2.0, 0.5), (1.0, 2.0, 3.0), (2, 0, 1),
         (0, -1, 0, 1, 0, 0, 0, 0, 1)),
    ]
    for ci, (vt, dims, sp, org, start, direction) in enumerate(cases):
        img = make_image(vt, dims, sp, org, start, direction)
        for mode in ("ascii", "binary", "appended-raw", "appended-base64"):
            for comp in ("none", "zlib"):
                if mode == "ascii" and comp == "zlib":
                    continue
                for header in ("UInt32", "UInt64"):
                    if mode == "ascii" and header == "UInt64":
                        continue
                    name = f"vtkjudge_{ci}_{mode}_{comp}_{header}.vti"
                    path = os.path.join(TMP, name)
                    w = vtk.vtkXMLImageDataWriter()
                    w.SetInputData(img)
                    w.SetFileName(path)
                    if mode == "ascii":
                        w.SetDataModeToAscii()
                    elif mode == "binary":
                        w.SetDataModeToBinary()
                    else:
                        w.SetDataModeToAppended()
                        w.SetEncodeAppendedData(mode == "appended-base64")
                    if comp == "none":
                        w.SetCompressorTypeToNone()
                    else:
                        w.SetCompressorTypeToZLib()
                        w.SetBlockSize(1024)  # several blocks per array
                    w.SetHeaderTypeToUInt64() if header == "UInt64" else w.SetHeaderTypeToUInt32()
                    if not w.Write():
                        failures.append(f"{name}: VTK could not write it")
                        continue
                    check(path, name)
        if direction is None and start == (0, 0, 0):
            for ftype in ("ascii", "binary"):
                name = f"vtkjudge_{ci}_{ftype}.vtk"
                path = os.path.join(TMP, name)
                w = vtk.vtkStructuredPointsWriter()
                w.SetInputData(img)
                w.SetFileName(path)
                w.SetFileTypeToBinary() if ftype == "binary" else w.SetFileTypeToASCII()
                w.Write()
                check(path, name)
    for f in failures:
        print("FAIL " + f)
    print(f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
