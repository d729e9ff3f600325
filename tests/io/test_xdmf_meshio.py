# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_xdmf_meshio.py — the .xdmf + .h5 of a two-label volume (two blocks stacked in
z, tets and hexes, first and second order) read back by meshio with the VTU's node and element
counts: the Grid "mesh", "cell_tags" (each cell's label) and "facet_tags" (1 on the outer
boundary, 2 on the one interface). meshio's XDMF reader takes a file of one Grid, so each Grid
is handed to it in a file of its own, the DataItems unchanged. Also: .xdmf refused with one
line, exit 2 and no file for a surface mesh and a bad output folder. Exit 0 pass, 1 fail, 77
skip when meshio/numpy cannot be imported or volmesh was built without XDMF."""
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

try:
    import meshio
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import meshio/numpy ({exc})")
    sys.exit(77)

from harness import check, failures, need_cli, run  # noqa: E402

CLI = need_cli()


def grids(path):
    """Each Grid of path read by meshio from a one-Grid copy of the file."""
    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    out = {}
    for g in domain.findall("Grid"):
        doc = ET.Element("Xdmf", Version="3.0")
        ET.SubElement(doc, "Domain").append(g)
        one = f"{path[:-5]}_{g.get('Name')}.xdmf"
        ET.ElementTree(doc).write(one)
        out[g.get("Name")] = meshio.read(one)
    return out


def main():
    work = tempfile.mkdtemp(prefix="xdmf_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    n = 16
    vol = bytearray(n * n * n)
    for k in range(2, 14):
        for j in range(2, 14):
            for i in range(2, 14):
                vol[i + n * (j + n * k)] = 1 if k < 8 else 2
    open("two.raw", "wb").write(bytes(vol))
    raw = ["--raw-dims", "16x16x16", "--raw-type", "uint8", "-q", "--labels", "all"]
    run("mesh", "two.raw", *raw, "-o", "probe.vtu")
    r = subprocess.run([CLI, "convert", "probe.vtu", "probe.xdmf"], capture_output=True,
                       text=True)
    if r.returncode != 0 and "without XDMF" in r.stderr:
        print(f"skipped: {r.stderr.strip()}")
        sys.exit(77)
    for elements in ("tet", "hex"):
        run("mesh", "two.raw", *raw, "--elements", elements, "-o", f"{elements}.vtu")
        ref = meshio.read(f"{elements}.vtu")
        reg = np.concatenate([np.asarray(d).ravel() for d in ref.cell_data["region"]])
        corners = np.concatenate([c.data for c in ref.cells])
        nc = corners.shape[1]
        for order in (1, 2):
            out = f"{elements}_o{order}.xdmf"
            run("convert", f"{elements}.vtu", out, "--order", str(order))
            check(os.path.exists(out[:-5] + ".h5"), f"{out}: no sibling .h5")
            if not os.path.exists(out):
                continue
            g = grids(out)
            check(sorted(g) == ["cell_tags", "facet_tags", "mesh"], f"{out}: grids {sorted(g)}")
            mesh = g["mesh"]
            ncells = sum(len(c.data) for c in mesh.cells)
            check(ncells == len(corners), f"{out}: {ncells} cells, the VTU {len(corners)}")
            want_kind = {("tet", 1): "tetra", ("tet", 2): "tetra10",
                         ("hex", 1): "hexahedron", ("hex", 2): "hexahedron20"}[elements, order]
            check(mesh.cells[0].type == want_kind, f"{out}: cells {mesh.cells[0].type}")
            if order == 1:
                check(len(mesh.points) == len(ref.points),
                      f"{out}: {len(mesh.points)} nodes, the VTU {len(ref.points)}")
                check(np.array_equal(mesh.points, ref.points), f"{out}: coordinates differ")
                check(np.array_equal(mesh.cells[0].data, corners), f"{out}: connectivity")
            else:
                check(np.array_equal(mesh.cells[0].data[:, :nc], corners),
                      f"{out}: corner connectivity")
                check(np.array_equal(mesh.points[:len(ref.points)], ref.points),
                      f"{out}: corner coordinates")
            tags = g["cell_tags"]
            tv = np.asarray(tags.cell_data["cell_tags"][0]).ravel()
            check(np.array_equal(tv, reg), f"{out}: cell_tags are not the regions")
            ft = g["facet_tags"]
            fv = np.asarray(ft.cell_data["facet_tags"][0]).ravel()
            # the two blocks: outer faces of a 12x12x12 box, one 12x12 interface
            per_face = 2 if elements == "tet" else 1
            want_outer = 6 * 12 * 12 * per_face
            want_iface = 12 * 12 * per_face
            check(sorted(set(fv.tolist())) == [1, 2], f"{out}: facet tags {set(fv.tolist())}")
            check(int((fv == 1).sum()) == want_outer and int((fv == 2).sum()) == want_iface,
                  f"{out}: {int((fv == 1).sum())} outer / {int((fv == 2).sum())} interface "
                  f"facets, want {want_outer} / {want_iface}")
            fkind = {("tet", 1): "triangle", ("tet", 2): "triangle6",
                     ("hex", 1): "quad", ("hex", 2): "quad8"}[elements, order]
            check(ft.cells[0].type == fkind, f"{out}: facets {ft.cells[0].type}")
    # refusals: one line, exit 2, neither file left behind
    run("mesh", "two.raw", *raw[:-2], "--range", "1:", "--elements", "tri", "-o", "surf.vtu")
    for args, out in ((["convert", "surf.vtu", "surf.xdmf"], "surf.xdmf"),
                      (["convert", "tet.vtu", "nodir/x.xdmf"], "nodir/x.xdmf")):
        r = run(*args, expect=2)
        check(len(r.stderr.strip().splitlines()) == 1, f"{args}: stderr {r.stderr!r}")
        check(not os.path.exists(out) and not os.path.exists(out[:-5] + ".h5"),
              f"{args}: left a file")
    left = [f for f in os.listdir(".") if ".tmp-" in f]
    check(not left, f"temporary files left: {left}")
    print("xdmf: %d failures" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
