# SPDX-License-Identifier: BSD-3-Clause
"""sizing.py — issue 33: volmesh's graded mesher against CGAL Mesh_3 at the same distance bound.

    /usr/bin/python3 bench/sizing.py --cli build/volmesh [--cgal PATH] [--markdown
        docs/BENCHMARKS.md] [--head /work/shared/data/ct_head_quarter.nrrd] [--work DIR]

For the CT head at iso 500 and the 64³ phantoms (volmesh demo), with D = half a voxel (the
graded mesher's default: half the edge of a cube of one voxel's volume):
- volmesh `mesh --graded --distance D` (with its quality pass) and the uniform dual-contouring
  mesh (`--no-improve`, for its count);
- CGAL Mesh_3 on the thresholded image (tests/reference/cgal_mesh3.cpp, built by
  tests/reference/build_cgal.sh when --cgal is not given): facet distance D, facet angle 25,
  radius-edge 3, no size bound;
each measured by the same code (tests/reference/refstats.py): tets, wall time, dihedral
angles, the boundary's Euler characteristic and closure, the components, and the distance
both ways between the boundary and the isosurface (VTK's, of the trilinear field) at the
vertices. With --markdown it rewrites the block between the sizing markers of that page
(bench/run keeps the block). A few minutes on a quiet 2-core machine.
"""

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.dont_write_bytecode = True
sys.path.insert(0, os.path.join(ROOT, "tests", "reference"))
import refstats as R  # noqa: E402

BEGIN = "<!-- sizing:begin (bench/sizing.py writes this block) -->"
END = "<!-- sizing:end -->"
SHAPES = ["sphere", "torus", "genus3", "two-spheres", "cut-sphere"]


def timed(cmd, cwd):
    t = time.monotonic()
    p = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.monotonic() - t
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()[:300]}")
    return p.stdout, wall


def measure(vol, iso, points, tets):
    st = R.mesh_stats(points, tets)
    tris = R.boundary_triangles(tets)
    out, inn = R.hausdorff(vol, iso, points, tris)
    return {"tets": int(st["elements"]), "min_dihedral": float(st["min_dihedral"]),
            "max_dihedral": float(st["max_dihedral"]),
            "mean_min_dihedral": float(st["mean_min_dihedral"]),
            "euler": int(st["boundary_euler"]),
            "closed": bool(st["boundary_closed"]), "components": int(st["components"]),
            "to_surface": out, "from_surface": inn}


def case(name, path, iso, args, work):
    vol = R.read_volume(path)
    sp = [float(x) for x in vol.spacing]
    d = 0.5 * (sp[0] * sp[1] * sp[2]) ** (1.0 / 3.0)
    row = {"case": name, "D": d, "voxel": 2 * d}
    out, wall = timed([args.cli, "mesh", path, "--iso", str(iso), "--graded", "--distance",
                       f"{d:.9g}", "-o", "g.vtu", "-q"], work)
    p, t = R.read_vtu_tets(os.path.join(work, "g.vtu"))
    row["volmesh"] = dict(measure(vol, iso, p, t), seconds=wall)
    out, wall = timed([args.cli, "mesh", path, "--iso", str(iso), "--no-improve", "-o",
                       "u.vtu", "-q"], work)
    p, t = R.read_vtu_tets(os.path.join(work, "u.vtu"))
    row["uniform"] = {"tets": len(t), "seconds": wall}
    if args.cgal:
        R.write_inr(os.path.join(work, "c.inr"), vol, R.inside_mask(vol, iso))
        out, wall = timed([args.cgal, "c.inr", "c.txt", "25", "0", f"{d:.9g}", "3", "0"], work)
        p, t = R.read_cgal_text(os.path.join(work, "c.txt"), vol)
        row["cgal"] = dict(measure(vol, iso, p, t), seconds=wall)
    print(json.dumps(row), flush=True)
    return row


def cell(m, key, fmt):
    return fmt.format(m[key]) if m and key in m else "—"


def block(rows, meta):
    parts = [BEGIN, "## Sized meshes against CGAL Mesh_3 at the same distance bound (issue 33)",
             "", f"bench/sizing.py on {meta['date']}, {meta['machine']}; D = half a voxel "
             "(the edge of a cube of one voxel's volume), volmesh `--graded --distance D` with "
             "its quality pass, CGAL Mesh_3 with facet distance D, facet angle 25, radius-edge 3 "
             "and no size bound on the thresholded image; both measured by "
             "tests/reference/refstats.py (distances at the vertices, in voxels).", "",
             "| case | mesher | tets | uniform ÷ tets | wall s | dihedral ° | mean of each tet's "
             "min dihedral ° | boundary Euler, closed | components | boundary→surface | "
             "surface→boundary |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for who in ("volmesh", "cgal"):
            m = r.get(who)
            if not m:
                continue
            vx = r["voxel"]
            parts.append(
                f"| {r['case']} | {'volmesh graded' if who == 'volmesh' else 'CGAL Mesh_3'} | "
                f"{m['tets']:,} | {r['uniform']['tets'] / max(m['tets'], 1):.1f} | "
                f"{m['seconds']:.2f} | {m['min_dihedral']:.1f}..{m['max_dihedral']:.1f} | "
                f"{m['mean_min_dihedral']:.1f} | {m['euler']}, {'yes' if m['closed'] else 'no'} | "
                f"{m['components']} | "
                f"{m['to_surface'] / vx:.2f} | {m['from_surface'] / vx:.2f} |")
    parts += ["", "The uniform column is the dual-contouring mesh's count (`--no-improve`). "
              "CGAL sees only the thresholded voxels: where its boundary misses thin parts and "
              "small components, the isosurface is far from it (the last column).", END]
    return "\n".join(parts)


def write_block(path, text):
    page = open(path, encoding="utf-8").read() if os.path.exists(path) else ""
    if BEGIN in page and END in page:
        page = page[:page.index(BEGIN)] + text + page[page.index(END) + len(END):]
    else:
        page = page.rstrip("\n") + "\n\n" + text + "\n"
    with open(path, "w", encoding="utf-8") as fp:
        fp.write(page)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", required=True)
    ap.add_argument("--cgal")
    ap.add_argument("--markdown")
    ap.add_argument("--head", default=os.path.join(ROOT, "..", "shared", "data",
                                                   "ct_head_quarter.nrrd"))
    ap.add_argument("--work", default="/tmp/volmesh-sizing")
    args = ap.parse_args()
    args.cli = os.path.abspath(args.cli)
    os.makedirs(args.work, exist_ok=True)
    if not args.cgal:
        p = subprocess.run(["bash", os.path.join(ROOT, "tests", "reference", "build_cgal.sh"),
                            os.path.join(args.work, "cgal")], capture_output=True, text=True)
        args.cgal = p.stdout.strip() or None
        if not args.cgal:
            print("sizing.py: CGAL missing: volmesh only", file=sys.stderr)
    rows = []
    if os.path.exists(args.head):
        rows.append(case("CT head, iso 500", os.path.abspath(args.head), 500, args, args.work))
    for shape in SHAPES:
        d = os.path.join(args.work, shape)
        os.makedirs(d, exist_ok=True)
        timed([args.cli, "demo", "--size", "64", "--shape", shape, "-q"], d)
        rows.append(case(f"{shape} 64³", os.path.join(d, "phantom.nrrd"), 0, args, args.work))
    import platform
    meta = {"date": time.strftime("%Y-%m-%d"),
            "machine": f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}"}
    with open(os.path.join(args.work, "sizing.json"), "w") as fp:
        json.dump({"meta": meta, "rows": rows}, fp, indent=1)
    if args.markdown:
        write_block(args.markdown, block(rows, meta))


if __name__ == "__main__":
    main()
