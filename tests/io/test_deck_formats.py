# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_deck_formats.py — the solver decks of a two-label volume (two blocks stacked
in z, tets and hexes, --materials for label 1 only) read back with the VTU's node and element
counts and one block and one material per label: Nastran .bdf by meshio and by a parser of
its fixed columns (GRID*, CTETRA/CHEXA, PSOLID, MAT1*), LS-DYNA .k, COMSOL .mphtxt and FEBio
.feb (with --deck static) by parsers written from their manuals' keywords (no reader of these
is installed here). Exit 0 pass, 1 fail, 77 skip when meshio or numpy cannot be imported."""
import os
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


def reference(vtu):
    """Points, cells per region of the VTU volmesh wrote alongside."""
    m = meshio.read(vtu)
    reg = np.concatenate([np.asarray(d).ravel() for d in m.cell_data["region"]])
    ncells = sum(len(c.data) for c in m.cells)
    return len(m.points), ncells, {int(r): int((reg == r).sum()) for r in np.unique(reg)}


def parse_bdf(path):
    """GRID* pairs of lines, elements by property id, PSOLID pid -> mid, MAT1* mid -> E."""
    lines = [l.rstrip("\n") for l in open(path)]
    i = lines.index("BEGIN BULK") + 1
    grids, elems, psolid, mat1 = 0, {}, {}, {}
    while lines[i] != "ENDDATA":
        l = lines[i]
        key = l[:8].strip()
        if key == "GRID*":
            check(lines[i + 1].startswith("*"), f"{path}: GRID* without its * line")
            float(l[40:56]), float(l[56:72]), float(lines[i + 1][8:24])
            check(all(len(l[k:k + 16]) <= 16 for k in (40, 56)), f"{path}: wide field")
            grids += 1
            i += 1
        elif key in ("CTETRA", "CHEXA"):
            pid = int(l[16:24])
            nodes = [l[k:k + 8] for k in range(24, len(l), 8)]
            if key == "CHEXA":
                i += 1
                check(lines[i].startswith("+"), f"{path}: CHEXA without its continuation")
                nodes += [lines[i][k:k + 8] for k in range(8, len(lines[i]), 8)]
            check(len(nodes) == (4 if key == "CTETRA" else 8), f"{path}: {key} nodes {nodes}")
            elems[pid] = elems.get(pid, 0) + 1
        elif key == "PSOLID":
            psolid[int(l[8:16])] = int(l[16:24])
        elif key == "MAT1*":
            e = l[24:40].strip()
            check("." in e, f"{path}: MAT1 E '{e}' has no decimal point")
            mat1[int(l[8:24])] = float(e)
            i += 1
        elif not l.startswith("$"):
            check(False, f"{path}: unexpected bulk line {l!r}")
        i += 1
    return grids, elems, psolid, mat1


def parse_k(path):
    """Keyword blocks: *NODE count, *ELEMENT_SOLID per part, *PART -> (secid, mid), E per mid."""
    kw, nodes, elems, parts, mats, sections = None, 0, {}, {}, {}, {}
    data = []
    lines = [l.rstrip("\n") for l in open(path)]
    check(lines[0] == "*KEYWORD" and lines[-1] == "*END", f"{path}: not *KEYWORD ... *END")
    for l in lines + ["*END"]:
        if l.startswith("$"):
            continue
        if l.startswith("*"):
            if kw == "*PART":
                pid, secid, mid = (int(data[1][k:k + 10]) for k in (0, 10, 20))
                parts[pid] = (secid, mid)
            elif kw == "*SECTION_SOLID":
                sections[int(data[0][:10])] = int(data[0][10:20])
            elif kw == "*MAT_ELASTIC":
                mats[int(data[0][:10])] = float(data[0][20:30])
            kw, data = l.strip(), []
            continue
        data.append(l)
        if kw == "*NODE":
            float(l[8:24]), float(l[24:40]), float(l[40:56])
            nodes += 1
        elif kw == "*ELEMENT_SOLID":
            pid = int(l[8:16])
            ns = [int(l[k:k + 8]) for k in range(16, 80, 8)]
            check(len(ns) == 8, f"{path}: element line {l!r}")
            elems[pid] = elems.get(pid, 0) + 1
    return nodes, elems, parts, mats, sections


def parse_mphtxt(path):
    """Vertices, then each type: name, vertices per element, elements, entity indices."""
    rows = [l.split("#")[0].strip() for l in open(path)]
    rows = [r for r in rows if r]
    check(rows[0] == "0 1", f"{path}: version line {rows[0]!r}")
    k = rows.index("4 Mesh") + 1
    version, sdim, nv, lowest = (int(rows[k + j]) for j in range(4))
    check(version == 4 and sdim == 3 and lowest == 0, f"{path}: mesh header")
    k += 4
    for j in range(nv):
        check(len(rows[k + j].split()) == 3, f"{path}: vertex row {rows[k + j]!r}")
    k += nv
    ntypes = int(rows[k])
    k += 1
    types = {}
    for _ in range(ntypes):
        name = rows[k].split()[1]
        per, n = int(rows[k + 1]), int(rows[k + 2])
        k += 3
        elems = [list(map(int, rows[k + j].split())) for j in range(n)]
        check(all(len(e) == per and 0 <= min(e) and max(e) < nv for e in elems),
              f"{path}: {name} elements")
        k += n
        ne = int(rows[k])
        check(ne == n, f"{path}: {name}: {ne} entity indices for {n} elements")
        types[name] = (elems, [int(rows[k + 1 + j]) for j in range(ne)])
        k += 1 + ne
    return nv, types


def parse_feb(path):
    root = ET.parse(path).getroot()
    check(root.tag == "febio_spec" and root.get("version") == "4.0", f"{path}: root {root.tag}")
    check(root.find("Module").get("type") == "solid", f"{path}: Module")
    mats = {m.get("name"): float(m.find("E").text) for m in root.find("Material")}
    mesh = root.find("Mesh")
    nodes = len(mesh.find("Nodes"))
    blocks = {e.get("name"): (e.get("type"), len(e)) for e in mesh.findall("Elements")}
    domains = {d.get("name"): d.get("mat") for d in root.find("MeshDomains")}
    sets = {s.get("name"): len(s.text.split(",")) for s in mesh.findall("NodeSet")}
    return root, nodes, mats, blocks, domains, sets


def main():
    work = tempfile.mkdtemp(prefix="decks_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    n = 16
    vol = bytearray(n * n * n)
    for k in range(2, 14):
        for j in range(2, 14):
            for i in range(2, 14):
                vol[i + n * (j + n * k)] = 1 if k < 8 else 2
    open("two.raw", "wb").write(bytes(vol))
    raw = ["--raw-dims", "16x16x16", "--raw-type", "uint8", "-q", "--labels", "all"]
    open("mats.csv", "w").write("label,name,E,nu,density\n1,Bone,17000,0.3,1.9e-9\n")
    for elements in ("tet", "hex"):
        tet = elements == "tet"
        run("mesh", "two.raw", *raw, "--elements", elements, "-o", f"{elements}.vtu")
        npts, ncells, per = reference(f"{elements}.vtu")
        check(sorted(per) == [1, 2], f"{elements}.vtu regions {per}")
        want_blocks = sorted(per.values())
        for ext in ("bdf", "k", "mphtxt", "feb"):
            extra = [] if ext == "mphtxt" else ["--materials", "mats.csv"]
            extra += ["--deck", "static"] if ext == "feb" else []
            out = f"{elements}.{ext}"
            run("convert", f"{elements}.vtu", out, *extra)
            if not os.path.exists(out):
                continue
            if ext == "bdf":
                m = meshio.read(out, file_format="nastran")
                cells = sum(len(c.data) for c in m.cells)
                kind = "tetra" if tet else "hexahedron"
                check(len(m.points) == npts and cells == ncells and
                      all(c.type == kind for c in m.cells), f"meshio {out}: {m}")
                if tet and m.cells:
                    t = m.cells[0].data
                    a, b, c, d = (m.points[t[:, q]] for q in range(4))
                    vol6 = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)
                    check(np.all(vol6 > 0), f"meshio {out}: non-positive tets")
                ref = np.concatenate(m.cell_data["nastran:ref"])
                check(sorted(np.bincount(ref)[1:].tolist()) == want_blocks,
                      f"meshio {out}: property ids {np.bincount(ref)}")
                grids, elems, psolid, mat1 = parse_bdf(out)
                check(grids == npts and sum(elems.values()) == ncells, f"{out}: counts")
                check(sorted(elems) == [1, 2] and psolid == {1: 1, 2: 2} and
                      mat1 == {1: 17000.0, 2: 210000.0}, f"{out}: {elems} {psolid} {mat1}")
            elif ext == "k":
                nodes, elems, parts, mats, sections = parse_k(out)
                check(nodes == npts and sum(elems.values()) == ncells, f"{out}: counts")
                check(sorted(elems.values()) == want_blocks and parts == {1: (1, 1), 2: (2, 2)}
                      and mats == {1: 17000.0, 2: 210000.0} and
                      sections == ({1: 10, 2: 10} if tet else {1: 1, 2: 1}),
                      f"{out}: {elems} {parts} {mats} {sections}")
            elif ext == "mphtxt":
                nv, types = parse_mphtxt(out)
                vol_t, bnd_t = ("tet", "tri") if tet else ("hex", "quad")
                check(nv == npts and sorted(types) == sorted([vol_t, bnd_t]), f"{out}: {types.keys()}")
                elems, ent = types.get(vol_t, ([], []))
                check(len(elems) == ncells and sorted(set(ent)) == [1, 2] and
                      sorted([ent.count(1), ent.count(2)]) == want_blocks, f"{out}: domains")
                faces, fent = types.get(bnd_t, ([], []))
                # the outer boundary of each label and their interface: three boundaries
                check(len(faces) > 0 and sorted(set(fent)) == [0, 1, 2], f"{out}: boundaries")
            else:
                root, nodes, mats, blocks, domains, sets = parse_feb(out)
                check(nodes == npts, f"{out}: {nodes} nodes")
                check(sorted(blocks) == ["REGION_1", "REGION_2"] and
                      all(t == ("tet4" if tet else "hex8") for t, _ in blocks.values()) and
                      sorted(c for _, c in blocks.values()) == want_blocks, f"{out}: {blocks}")
                check(mats == {"Bone": 17000.0, "MAT_REGION_2": 210000.0}, f"{out}: {mats}")
                check(domains == {"REGION_1": "Bone", "REGION_2": "MAT_REGION_2"},
                      f"{out}: {domains}")
                check(sets.get("FIXED", 0) >= 3 and sets.get("LOADED", 0) >= 1, f"{out}: {sets}")
                bc = root.find("Boundary/bc")
                load = root.find("Loads/nodal_load")
                check(bc is not None and bc.get("node_set") == "FIXED" and
                      load is not None and load.get("node_set") == "LOADED", f"{out}: deck")
                if load is not None:
                    f = float(load.find("value").text.split(",")[2]) * sets.get("LOADED", 0)
                    check(abs(f + 100) < 1e-9, f"{out}: total load {f}")
            print(f"{out}: {npts} nodes, {ncells} elements, blocks {want_blocks}: read back")
    # FEBio second order: tet10 blocks, tri6 outer faces, mid-edge nodes at the edge middles
    run("convert", "tet.vtu", "tet10.feb", "--order", "2", "--deck", "static")
    if os.path.exists("tet10.feb"):
        mesh = ET.parse("tet10.feb").getroot().find("Mesh")
        p = np.array([[float(v) for v in n.text.split(",")] for n in mesh.find("Nodes")])
        blocks = mesh.findall("Elements")
        e = np.array([[int(v) - 1 for v in x.text.split(",")] for b in blocks for x in b])
        f = np.array([[int(v) - 1 for v in x.text.split(",")] for x in mesh.find("Surface")])
        tet_edges = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]
        check({b.get("type") for b in blocks} == {"tet10"} and e.shape[1] == 10 and
              f.shape[1] == 6, f"tet10.feb: {[b.get('type') for b in blocks]}, {e.shape}, {f.shape}")
        if e.shape[1] == 10 and f.shape[1] == 6:
            off = max(np.abs(p[e[:, 4 + k]] - 0.5 * (p[e[:, a]] + p[e[:, b]])).max()
                      for k, (a, b) in enumerate(tet_edges))
            off = max(off, max(np.abs(p[f[:, 3 + k]] - 0.5 * (p[f[:, a]] + p[f[:, b]])).max()
                               for k, (a, b) in enumerate([(0, 1), (1, 2), (2, 0)])))
            check(off < 1e-12, f"tet10.feb: a mid-edge node is {off} off its edge's middle")
        print(f"tet10.feb: {len(p)} nodes, {len(e)} tet10, {len(f)} tri6 faces")
    # bad materials files and outputs are refused before meshing: exit 2, one line naming the
    # file and the problem, no output file
    open("short.csv", "w").write("1,Bone,17000\n")
    open("nu.csv", "w").write("label,name,E,nu,density\n1,Bone,17000,0.7,1\n")
    for args, says in ((["--materials", "short.csv", "-o", "bad.inp"], "short.csv: line 1: expected 5"),
                       (["--materials", "nu.csv", "-o", "bad.feb"], "nu.csv: line 2: nu"),
                       (["--materials", "missing.csv", "-o", "bad.inp"], "missing.csv"),
                       (["--materials", "mats.csv", "-o", "bad.vtu"], "bad.vtu: materials"),
                       (["-o", "bad.xyz"], "bad.xyz: unknown mesh format")):
        r = run("mesh", "two.raw", *raw, *args, expect=2)
        check(r.stderr.count("\n") == 1 and says in r.stderr and not os.path.exists(args[-1]),
              f"mesh {args}: {r.stderr!r}")
    # refusals: one line naming the file, exit 2, no file left
    for args in (["tet.vtu", "bad.bdf", "--deck", "static"], ["tet.vtu", "bad.k", "--order", "2"],
                 ["tet.vtu", "bad.mphtxt", "--order", "2"], ["tet.vtu", "bad.feb", "--order", "3"],
                 ["tet.vtu", "bad.mphtxt", "--materials", "mats.csv"], ["tet.bdf", "bad.vtu"]):
        r = run("convert", *args, expect=2)
        check(r.stderr.count("\n") == 1 and r.stderr.startswith("volmesh: ")
              and not os.path.exists(args[1]), f"convert {args}: {r.stderr!r}")


main()
print(f"{0 if failures else 1} passed, {len(failures)} failed")
sys.exit(1 if failures else 0)
