# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_exodus_sets.py — the Exodus II file of a two-label volume (two blocks stacked
in z, tets and hexes), read by netCDF4 (the container Exodus is): side set and node set 1
BOUNDARY hold the outer faces and their nodes, sets 2 IFACE_REGION_1_REGION_2 the faces
between the labels, seen from the elements of label 1 (block 1), and their nodes, each set's
faces being faces of its elements under Exodus's side numbering; the counts are those of the
VTU. Exit 0 pass, 1 fail, 77 skip when meshio, numpy or netCDF4 cannot be imported or volmesh
was built without Exodus II."""
import os
import subprocess
import sys
import tempfile

try:
    import meshio
    import netCDF4
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import meshio/numpy/netCDF4 ({exc})")
    sys.exit(77)

from harness import check, failures, need_cli, run  # noqa: E402

CLI = need_cli()
# Exodus side k of TETRA / HEX as 0-based corner positions (Exodus II manual, side numbering)
SIDES = {"tetra": [(0, 1, 3), (1, 2, 3), (0, 2, 3), (0, 1, 2)],
         "hexahedron": [(0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (0, 3, 7, 4), (0, 1, 2, 3),
                        (4, 5, 6, 7)]}


def names(ds, var):
    return ["".join(c.decode() for c in row if c not in (b"", b"\x00")).strip()
            for row in ds.variables[var][:].filled(b"")]


def main():
    work = tempfile.mkdtemp(prefix="exodus_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    n = 16
    vol = bytearray(n * n * n)
    for k in range(2, 14):
        for j in range(2, 14):
            for i in range(2, 14):
                vol[i + n * (j + n * k)] = 1 if k < 8 else 2
    open("two.raw", "wb").write(bytes(vol))
    raw = ["--raw-dims", "16x16x16", "--raw-type", "uint8", "-q", "--labels", "all"]
    for elements in ("tet", "hex"):
        run("mesh", "two.raw", *raw, "--elements", elements, "-o", f"{elements}.vtu")
        r = subprocess.run([CLI, "convert", f"{elements}.vtu", f"{elements}.exo"],
                           capture_output=True, text=True)
        if r.returncode != 0 and "Exodus" in r.stderr and not os.path.exists(f"{elements}.exo"):
            print(f"skipped: {r.stderr.strip()}")
            return 77
        ref = meshio.read(f"{elements}.vtu")
        kind = ref.cells[0].type
        cells = ref.cells[0].data
        reg = np.asarray(ref.cell_data["region"][0]).ravel()
        # the elements in file order: block 1 (label 1) then block 2, each in mesh order
        file_cells = np.concatenate([cells[reg == 1], cells[reg == 2]])
        n1 = int((reg == 1).sum())
        per_face = 2 if elements == "tet" else 1
        want = {"BOUNDARY": 6 * 144 * per_face, "IFACE_REGION_1_REGION_2": 144 * per_face}
        ds = netCDF4.Dataset(f"{elements}.exo")
        ss, ns = names(ds, "ss_names"), names(ds, "ns_names")
        check(ss == list(want) and ns == list(want), f"{elements}.exo: sets {ss} / {ns}")
        for sid, name in enumerate(ss, start=1):
            elems = np.asarray(ds.variables[f"elem_ss{sid}"][:]) - 1
            sides = np.asarray(ds.variables[f"side_ss{sid}"][:]) - 1
            nodes = np.asarray(ds.variables[f"node_ns{sid}"][:]) - 1
            check(len(elems) == want.get(name, -1),
                  f"{elements}.exo {name}: {len(elems)} faces, want {want.get(name)}")
            faces = [file_cells[e][list(SIDES[kind][s])] for e, s in zip(elems, sides)]
            fnodes = np.unique(np.concatenate(faces)) if faces else np.array([], int)
            check(np.array_equal(np.sort(nodes), fnodes),
                  f"{elements}.exo {name}: node set is not the faces' {len(fnodes)} nodes")
            # every face is on the boundary (used once) or between the two labels
            keyed = {}
            for c, r in zip(cells, reg):
                for s in SIDES[kind]:
                    keyed.setdefault(tuple(sorted(c[list(s)])), []).append(int(r))
            users = [keyed.get(tuple(sorted(f)), []) for f in faces]
            if name == "BOUNDARY":
                check(all(len(u) == 1 for u in users), f"{elements}.exo: a BOUNDARY face is inner")
            else:
                check(all(sorted(u) == [1, 2] for u in users),
                      f"{elements}.exo: an interface face is not between labels 1 and 2")
                check(bool((elems < n1).all()), f"{elements}.exo: interface not from label 1")
        ds.close()
        m = meshio.read(f"{elements}.exo")
        check(len(m.points) == len(ref.points), f"{elements}.exo: meshio reads other points")
    print("exodus sets: %d failures" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
