# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_xdmf_dolfinx.py — FEniCSx (Debian python3-dolfinx-real) solves Poisson
-Δu = 1, u = 0 on the boundary, on the .xdmf mesh of a ball of radius R (the sphere phantom of
volmesh demo, R = 0.35 (n - 1) voxels): read_mesh(name="mesh"), read_meshtags "cell_tags" (one
label, every cell) and "facet_tags" (the Dirichlet boundary, tag 1); P1 on the linear mesh and
P2 on the --order 2 mesh (Tetrahedron_10 with its curved boundary, Triangle_6 facet tags); max u
must be within 3% of the exact R^2/6. Exit 0 pass, 1 fail, 77 skip when dolfinx cannot be imported
(scripts/deps.sh --tests installs it) or volmesh was built without XDMF."""
import logging
import os
import subprocess
import sys
import tempfile

try:
    import numpy as np
    from mpi4py import MPI
    from petsc4py import PETSc
    import dolfinx
    import ufl
    from dolfinx import fem
    from dolfinx.fem.petsc import LinearProblem
    from dolfinx.io import XDMFFile
except ImportError as exc:
    print(f"skipped: cannot import dolfinx (Debian: python3-dolfinx-real): {exc}")
    sys.exit(77)

from harness import check, failures, need_cli  # noqa: E402

CLI = need_cli()
SIZE = 32          # phantom grid points a side
RADIUS = 0.35 * (SIZE - 1)  # mesher/phantom.c: sphere_r * (n - 1), in voxels (spacing 1)
TOLERANCE = 0.03   # the bound on |max u - R^2/6| / (R^2/6)


def solve(path, degree):
    """Reads path as dolfinx does, checks its tags, solves Poisson with P(degree)."""
    with XDMFFile(MPI.COMM_WORLD, path, "r") as xdmf:
        mesh = xdmf.read_mesh(name="mesh")
        cells = xdmf.read_meshtags(mesh, name="cell_tags")
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        facets = xdmf.read_meshtags(mesh, name="facet_tags")
    ncells = mesh.topology.index_map(3).size_local
    check(cells.values.size == ncells and set(np.unique(cells.values)) == {1},
          f"{path} cell_tags: {cells.values.size} values {set(np.unique(cells.values))}, "
          f"{ncells} cells")
    check(set(np.unique(facets.values)) == {1}, f"{path} facet_tags {set(np.unique(facets.values))}")
    # every exterior facet of the mesh is tagged (the boundary is the outer one)
    exterior = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    check(np.array_equal(np.sort(exterior), np.sort(facets.find(1))),
          f"{path} facet tag 1: {facets.find(1).size} facets, exterior {exterior.size}")
    space = fem.FunctionSpace(mesh, ("Lagrange", degree))
    fixed = fem.locate_dofs_topological(space, mesh.topology.dim - 1, facets.find(1))
    bc = fem.dirichletbc(PETSc.ScalarType(0), fixed, space)
    u, v = ufl.TrialFunction(space), ufl.TestFunction(space)
    a = ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx
    rhs = fem.Constant(mesh, PETSc.ScalarType(1)) * v * ufl.dx
    problem = LinearProblem(a, rhs, bcs=[bc], petsc_options={
        "ksp_type": "cg", "pc_type": "gamg", "ksp_rtol": 1e-10})
    uh = problem.solve()
    umax = float(uh.x.array.max())
    exact = RADIUS * RADIUS / 6
    err = abs(umax - exact) / exact
    print(f"{path}: ball R = {RADIUS:g}, {ncells} tets, P{degree}: max u = {umax:.6g}, "
          f"R^2/6 = {exact:.6g}, relative error {100 * err:.2f}%")
    check(err <= TOLERANCE, f"{path}: max u {umax:.6g} is {100 * err:.2f}% from R^2/6 = "
          f"{exact:.6g}")


def main():
    logging.getLogger().setLevel(logging.WARNING)  # FFCx reports each JIT build at INFO
    work = tempfile.mkdtemp(prefix="xdmf_dolfinx_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    r = subprocess.run([CLI, "demo", "--shape", "sphere", "--size", str(SIZE), "-q"],
                       capture_output=True, text=True)
    check(r.returncode == 0, f"volmesh demo: {r.stderr.strip()}")
    for order in (1, 2):
        out = f"ball{order}.xdmf"
        r = subprocess.run([CLI, "mesh", "phantom.nrrd", "--iso", "0", "--order", str(order),
                            "-o", out, "-q"], capture_output=True, text=True)
        if r.returncode != 0 and "without XDMF" in r.stderr:
            print(f"skipped: {r.stderr.strip()}")
            return 77
        check(r.returncode == 0, f"volmesh mesh --order {order}: {r.stderr.strip()}")
        if r.returncode == 0:
            solve(out, order)
    print("xdmf dolfinx: %d failures" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
