# SPDX-License-Identifier: BSD-3-Clause
"""tests/cli/same_tets.py — independent judge (VTK + numpy) that two tet meshes in VTU files
are the same mesh: the same points, each once, and the same tets (four corners in node
order, and the region), in any order. Prints "same" and exits 0, or says how they differ
and exits 1. Used by tests/cli/test_slabs_cli.sh and bench/slabs.py.
usage: same_tets.py A.vtu B.vtu"""
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader


def tets(path):
    r = vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    g = r.GetOutput()
    p = vtk_to_numpy(g.GetPoints().GetData()).astype(np.float64)
    c = vtk_to_numpy(g.GetCells().GetConnectivityArray()).reshape(-1, 4)
    reg = vtk_to_numpy(g.GetCellData().GetArray("region")).astype(np.float64)
    if len(np.unique(p, axis=0)) != len(p):
        sys.exit(f"{path}: a point appears twice")
    t = np.concatenate([p[c].reshape(-1, 12), reg[:, None]], axis=1)
    return t[np.lexsort(t.T[::-1])], len(p)


a, na = tets(sys.argv[1])
b, nb = tets(sys.argv[2])
if na != nb or a.shape != b.shape or not np.array_equal(a, b):
    sys.exit(f"{sys.argv[2]}: {len(b)} tets, {nb} points; {sys.argv[1]}: {len(a)}, {na}: "
             "not the same")
print("same")
