# SPDX-License-Identifier: BSD-3-Clause
"""reference.py — runs volmesh, TetGen and CGAL Mesh_3 on the same inputs and tabulates them.

Used by tests/reference/test_reference.sh (prints the tables, checks what volmesh promises) and
by bench/reference (writes docs/REFERENCE.md). All statistics come from refstats.py, the same
code for every mesher.

usage: reference.py --cli VOLMESH --work DIR [--data DIR] [--cgal PROGRAM] [--size N]
                    [--cases a,b,...] [--json OUT] [--markdown OUT] [--check]
                    [--assert-quality] [--cgal-skip a,b]

Exit 0 when every check passed (or --check was not given), 1 when one failed, 2 on bad usage.
"""

import argparse
import datetime
import json
import os
import platform
import re
import shutil
import subprocess
import sys
import time

import numpy as np

sys.dont_write_bytecode = True  # no __pycache__ in the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import refstats as R  # noqa: E402

PHANTOMS = ["sphere", "torus", "genus3", "two-spheres", "plate", "cut-sphere"]
# (case name, file in the shared data folder, isovalue)
SHARED = [
    ("ct_head_quarter-500", "ct_head_quarter.nrrd", 500.0),
    ("ct_head_quarter-1150", "ct_head_quarter.nrrd", 1150.0),
    ("HeadMRVolume-50", "HeadMRVolume.mhd", 50.0),
    ("ironProt-128", "ironProt.vtk", 128.0),
    ("hydrogen-0.1", "hydrogen.vti", 0.1),
    ("avg152T1-100", "avg152T1_RL_nifti.nii.gz", 100.0),
]

# TetGen: -p (mesh the PLC), -q1.414 (radius-edge bound, TetGen's usual quality switch), -a (a
# volume bound: TETGEN_VOLUME_FACTOR times our mean tet volume; TetGen's count is dominated by
# refining around our surface triangles, so this lands within about 1.5x of our count), -Q quiet,
# -F no .face/.edge files.
TETGEN_VOLUME_FACTOR = 10.0
# CGAL: with facet and cell size h, CGAL's labeled-image meshes come out at about
# CGAL_COUNT_CONSTANT * volume / h^3 tets (measured on the phantoms), so h is chosen from our
# count. Facet angle 25 degrees, radius-edge ratio 2 (CGAL's guarantee needs >= 2), facet
# distance half the smallest voxel spacing.
CGAL_COUNT_CONSTANT = 4.3
CGAL_FACET_ANGLE = 25.0
CGAL_RADIUS_EDGE = 2.0
TIMEOUT = 600


def run(cmd, cwd, timeout=TIMEOUT):
    start = time.monotonic()
    try:
        proc = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout} s", time.monotonic() - start
    return proc, None, time.monotonic() - start


def tetgen_version():
    exe = shutil.which("tetgen")
    if not exe:
        return None
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "tetgen"],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
        return f"TetGen (Debian package {out})" if out else "TetGen"
    except OSError:
        return "TetGen"


def cgal_version():
    try:
        with open("/usr/include/CGAL/version.h") as fh:
            m = re.search(r'#define CGAL_VERSION\s+(\S+)', fh.read())
        return f"CGAL {m.group(1)}" if m else "CGAL"
    except OSError:
        return None


def one_case(args, name, volume_path, iso, expected, case_dir, prepare=None):
    """Meshes one input with the three meshers; returns a dict of rows and notes."""
    os.makedirs(case_dir, exist_ok=True)
    result = {"case": name, "input": os.path.basename(volume_path), "iso": iso, "rows": {},
              "notes": [], "failures": [], "shortfalls": []}
    vol = R.read_volume(volume_path)
    mask = R.inside_mask(vol, iso)
    grid = R.grid_topology(mask)
    result["dims"] = list(vol.dims)
    result["spacing"] = [float(s) for s in vol.spacing]
    result["grid"] = {"euler": grid["euler"], "components": grid["components"]}
    if expected is None:
        expected = {"euler": grid["euler"], "components": grid["components"],
                    "source": "thresholded volume"}
    else:
        expected["source"] = "phantom"
        if expected["euler"] != grid["euler"] or expected["components"] != grid["components"]:
            result["notes"].append(
                f"the phantom's grid has Euler {grid['euler']} and {grid['components']} "
                f"component(s), the phantom {expected['euler']} and {expected['components']}")
    result["expected"] = expected
    iso_surface = R.isosurface(vol, iso)

    # volmesh
    ours_vtu = os.path.join(case_dir, "ours.vtu")
    ours_surf = os.path.join(case_dir, "ours-surface.vtu")
    proc, err, secs = run([args.cli, "mesh", volume_path, "--iso", repr(iso), "-o", ours_vtu,
                           "--surface", ours_surf, "--json", "--quiet"], case_dir)
    if proc is None or proc.returncode != 0:
        msg = err or (proc.stderr.strip() or f"exit {proc.returncode}")
        result["failures"].append(f"volmesh failed: {msg}")
        return result
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    points, tets = R.read_vtu_tets(ours_vtu)
    ours = R.mesh_stats(points, tets, strict_orientation=True)
    ours["hausdorff_out"], ours["hausdorff_in"] = R.hausdorff(vol, iso, points, ours["_boundary"],
                                                              iso_surface)
    ours["seconds"] = summary.get("seconds")
    result["rows"]["volmesh"] = R.public(ours)
    n_ours = ours["elements"]
    v_ours = ours["volume"]

    # Checks of what volmesh promises.
    if ours["inverted"]:
        result["failures"].append(f"volmesh: {ours['inverted']} inverted or flat tets")
    if not ours["boundary_closed"]:
        result["failures"].append("volmesh: boundary not closed")
    if ours["boundary_euler"] != expected["euler"]:
        result["failures"].append(f"volmesh: boundary Euler {ours['boundary_euler']}, "
                                  f"{expected['source']} {expected['euler']}")
    if ours["components"] != expected["components"]:
        result["failures"].append(f"volmesh: {ours['components']} components, "
                                  f"{expected['source']} {expected['components']}")
    if summary.get("inverted", 0) != 0 or summary.get("elements") != n_ours:
        result["failures"].append("volmesh: its --json summary disagrees with the mesh file "
                                  f"(elements {summary.get('elements')} vs {n_ours})")

    # TetGen on our boundary surface.
    if args.tetgen:
        spts, stris = R.read_vtu_triangles(ours_surf)
        holes = R.surface_cavity_points(spts, stris, ours_vtu, 0.05 * float(vol.spacing.min()))
        smesh = os.path.join(case_dir, "surface.smesh")
        R.write_smesh(smesh, spts, stris, holes)
        a = TETGEN_VOLUME_FACTOR * v_ours / max(n_ours, 1)
        switches = f"-pq1.414a{a:.6g}QF"
        proc, err, secs = run([args.tetgen, switches, "surface.smesh"], case_dir)
        stem = os.path.join(case_dir, "surface.1")
        if proc is None or proc.returncode != 0 or not os.path.exists(stem + ".ele"):
            if proc is None:
                msg = err
            else:
                said = (proc.stdout + proc.stderr).strip().splitlines()
                msg = said[-1].strip() if said else f"exit {proc.returncode}"
            result["rows"]["TetGen"] = {"failed": msg, "switches": switches}
            # TetGen's own check of its input: does our boundary surface self-intersect?
            proc, err, _ = run([args.tetgen, "-d", "surface.smesh"], case_dir, timeout=300)
            m = re.search(r"Found (\d+) pairs of faces are intersecting",
                          (proc.stdout + proc.stderr) if proc else "")
            if m:
                result["rows"]["TetGen"]["failed"] = (f"volmesh's surface self-intersects "
                                                      f"({m.group(1)} triangle pairs, tetgen -d)")
                result["notes"].append(f"volmesh's boundary surface self-intersects: tetgen -d "
                                       f"finds {m.group(1)} pairs of intersecting triangles, "
                                       f"so TetGen cannot mesh it")
                result["shortfalls"].append(f"volmesh's boundary self-intersects "
                                            f"({m.group(1)} pairs, tetgen -d)")
        else:
            p, t = R.read_tetgen(stem)
            st = R.mesh_stats(p, t)
            st["hausdorff_out"], st["hausdorff_in"] = R.hausdorff(vol, iso, p, st["_boundary"],
                                                                  iso_surface)
            st["seconds"] = secs
            st["switches"] = switches
            st["holes"] = int(len(holes))
            result["rows"]["TetGen"] = R.public(st)

    # CGAL Mesh_3 on the thresholded image.
    if args.cgal and name not in args.cgal_skip:
        inr = os.path.join(case_dir, "labels.inr")
        R.write_inr(inr, vol, mask)
        h = (CGAL_COUNT_CONSTANT * v_ours / max(n_ours, 1)) ** (1.0 / 3.0)
        dist = 0.5 * float(vol.spacing.min())
        crit = [CGAL_FACET_ANGLE, h, dist, CGAL_RADIUS_EDGE, h]
        out = os.path.join(case_dir, "cgal.txt")
        proc, err, secs = run([args.cgal, inr, out] + [f"{c:.6g}" for c in crit], case_dir)
        if proc is None or proc.returncode != 0:
            msg = err or (proc.stderr.strip() or f"exit {proc.returncode}")
            result["rows"]["CGAL"] = {"failed": msg}
        else:
            p, t = R.read_cgal_text(out, vol)
            st = R.mesh_stats(p, t)
            if st["elements"]:
                st["hausdorff_out"], st["hausdorff_in"] = R.hausdorff(vol, iso, p, st["_boundary"],
                                                                      iso_surface)
            st["seconds"] = secs
            st["criteria"] = {"facet_angle": crit[0], "facet_size": crit[1],
                              "facet_distance": crit[2], "cell_radius_edge_ratio": crit[3],
                              "cell_size": crit[4]}
            result["rows"]["CGAL"] = R.public(st)
    elif args.cgal:
        result["rows"]["CGAL"] = {"failed": "skipped (--cgal-skip)"}

    # What each reference got right or wrong about the topology, and the optional quality check.
    for ref in ("TetGen", "CGAL"):
        row = result["rows"].get(ref)
        if not row or "failed" in row:
            continue
        if row["components"] != expected["components"]:
            result["notes"].append(f"{ref} has {row['components']} components where the "
                                   f"{expected['source']} has {expected['components']}")
        if row["boundary_euler"] != expected["euler"]:
            result["notes"].append(f"{ref}'s boundary Euler characteristic is "
                                   f"{row['boundary_euler']}, the {expected['source']}'s "
                                   f"{expected['euler']}")
        if row["inverted"]:
            result["notes"].append(f"{ref} has {row['inverted']} inverted or flat tets")
        if ours["min_dihedral"] < row["min_dihedral"]:
            result["shortfalls"].append(
                f"volmesh min dihedral {ours['min_dihedral']:.2f} < {ref}'s "
                f"{row['min_dihedral']:.2f}")
    return result


# Inputs where volmesh does not keep its quality and self-intersection promises yet (the four
# head volumes were listed until the quality pass and the boundary guard landed). Take an input
# off the list as soon as it holds: the check fails until then.
KNOWN_SHORT = ()


def settle_shortfalls(res, known_short):
    """Promises volmesh does not keep yet (a worse min dihedral than a reference, a
    self-intersecting boundary) fail the case unless the case is on the known-short list;
    a listed case that now keeps them fails too, so the list only ever shrinks."""
    short = res.pop("shortfalls", [])
    res["short"] = list(short)
    if res["case"] in known_short:
        if short:
            res["notes"].extend(f"known short (KNOWN_SHORT in reference.py): {s}" for s in short)
        else:
            res["failures"].append("listed as known short but every promise now holds: "
                                   "take it off KNOWN_SHORT in reference.py")
    else:
        res["failures"].extend(short)


def phantom_case(args, shape):
    case_dir = os.path.join(args.work, shape)
    os.makedirs(case_dir, exist_ok=True)
    proc, err, _ = run([args.cli, "demo", "--shape", shape, "--size", str(args.size)], case_dir)
    if proc is None or proc.returncode != 0:
        return {"case": shape, "rows": {}, "notes": [],
                "failures": [f"volmesh demo failed: {err or proc.stderr.strip()}"]}
    m = re.search(r"expected boundary Euler characteristic (-?\d+)", proc.stdout + proc.stderr)
    euler = int(m.group(1)) if m else None
    # The phantoms are connected except two-spheres.
    expected = {"euler": euler, "components": 2 if shape == "two-spheres" else 1}
    name = f"{shape}-{args.size}"
    res = one_case(args, name, os.path.join(case_dir, "phantom.nrrd"), 0.0, expected, case_dir)
    if euler is None:
        res["failures"].append("volmesh demo did not print the expected Euler characteristic")
    return res


# ---------------------------------------------------------------------------------------------
# Tables


def fmt(v, digits=2):
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if v == 0:
            return "0"
        if abs(v) >= 1000:
            return f"{v:.0f}"
        if abs(v) < 0.01:
            return f"{v:.1e}"
        return f"{v:.{digits}f}"
    return str(v)


COLUMNS = ["mesher", "tets", "min dih", "max dih", "<5°", "<10°", "RR min", "RR mean",
           "χ∂", "comp", "volume", "H out", "H in", "inv", "s"]


def table(result):
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for mesher in ("volmesh", "TetGen", "CGAL"):
        row = result["rows"].get(mesher)
        if row is None:
            continue
        if "failed" in row:
            lines.append(f"| {mesher} | failed: {row['failed']} |" + " |" * (len(COLUMNS) - 2))
            continue
        cells = [mesher, row["elements"], row["min_dihedral"], row["max_dihedral"],
                 row["slivers_5"], row["slivers_10"], row["rr_min"], row["rr_mean"],
                 row["boundary_euler"], row["components"], row["volume"],
                 row.get("hausdorff_out"), row.get("hausdorff_in"), row["inverted"],
                 row.get("seconds")]
        lines.append("| " + " | ".join(fmt(c) for c in cells) + " |")
    return lines


def heading(result):
    exp = result.get("expected", {})
    dims = "×".join(str(d) for d in result.get("dims", []))
    spacing = " ".join(fmt(s) for s in result.get("spacing", []))
    return (f"{result['case']} — {result.get('input', '')} iso {fmt(result.get('iso'))}, "
            f"{dims}, spacing {spacing}; expected ({exp.get('source', '?')}): "
            f"χ∂ {exp.get('euler')}, {exp.get('components')} component(s)")


def print_results(results, out=sys.stdout):
    for res in results:
        print("", file=out)
        print("### " + heading(res), file=out)
        print("", file=out)
        for line in table(res):
            print(line, file=out)
        for note in res["notes"]:
            print(f"- note: {note}", file=out)
        for failure in res["failures"]:
            print(f"- FAIL: {failure}", file=out)


def summary_lines(results):
    """Facts derived from the numbers, for the top of docs/REFERENCE.md."""
    lines = []
    ours_ok = [r["case"] for r in results
               if not [f for f in r["failures"] if f not in r.get("short", [])]]
    lines.append(f"- volmesh: topology (χ∂, components) equal to the expectation, closed "
                 f"boundary and no inverted tets on {len(ours_ok)} of {len(results)} inputs.")
    for ref in ("TetGen", "CGAL"):
        wrong = []
        better = 0
        total = 0
        for r in results:
            row = r["rows"].get(ref)
            ours = r["rows"].get("volmesh")
            if not row or "failed" in row or not ours:
                continue
            total += 1
            if row["min_dihedral"] > ours["min_dihedral"]:
                better += 1
            exp = r["expected"]
            if row["components"] != exp["components"] or row["boundary_euler"] != exp["euler"]:
                wrong.append(f"{r['case']} (χ∂ {row['boundary_euler']} vs {exp['euler']}, "
                             f"{row['components']} vs {exp['components']} components)")
        failed = [r["case"] for r in results
                  if r["rows"].get(ref) and "failed" in r["rows"][ref]]
        text = f"- {ref}: a better min dihedral than volmesh on {better} of {total} inputs"
        text += "; topology differs from the expectation on " + (
            ", ".join(wrong) if wrong else "none")
        if failed:
            text += "; did not run or failed on " + ", ".join(failed)
        lines.append(text + ".")
    return lines


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cli", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--data")
    ap.add_argument("--cgal")
    ap.add_argument("--tetgen", default=shutil.which("tetgen"))
    ap.add_argument("--no-tetgen", action="store_true")
    ap.add_argument("--size", type=int, default=48)
    ap.add_argument("--cases", default="")
    ap.add_argument("--cgal-skip", default="")
    ap.add_argument("--json")
    ap.add_argument("--markdown")
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--known-short", default=",".join(KNOWN_SHORT),
                    help="cases where volmesh's quality/self-intersection promises are known "
                         "not to hold yet (reported, not failed)")
    ap.add_argument("--from-json", help="only rewrite --markdown from a saved --json")
    ap.add_argument("--merge-json", help="a saved --json whose inputs this run's --cases "
                    "replace; --json and --markdown then hold the merged set, and the page "
                    "names the rerun inputs with their date, version and load")
    args = ap.parse_args()
    if hasattr(sys.stdout, "reconfigure"):
        sys.stdout.reconfigure(encoding="utf-8")
    if args.from_json:
        with open(args.from_json, encoding="utf-8") as fh:
            saved = json.load(fh)
        write_markdown(args.markdown, saved["results"], saved["meta"])
        return 0
    if args.no_tetgen:
        args.tetgen = None
    args.cgal_skip = [c for c in args.cgal_skip.split(",") if c]
    wanted = [c for c in args.cases.split(",") if c]
    known_short = {c for c in args.known_short.split(",") if c}
    os.makedirs(args.work, exist_ok=True)

    results = []
    start = time.monotonic()
    loads = [os.getloadavg()[0]]  # 1-minute load average, sampled after every input
    for shape in PHANTOMS:
        if wanted and shape not in wanted and f"{shape}-{args.size}" not in wanted:
            continue
        results.append(phantom_case(args, shape))
        settle_shortfalls(results[-1], known_short)
        loads.append(os.getloadavg()[0])
        print_results(results[-1:])
        sys.stdout.flush()
    if args.data and os.path.isdir(args.data):
        for name, fname, iso in SHARED:
            if wanted and name not in wanted:
                continue
            path = os.path.join(args.data, fname)
            if not os.path.exists(path):
                print(f"\n(skipped {name}: {path} absent)")
                continue
            results.append(one_case(args, name, path, iso, None, os.path.join(args.work, name)))
            settle_shortfalls(results[-1], known_short)
            loads.append(os.getloadavg()[0])
            print_results(results[-1:])
            sys.stdout.flush()
    elapsed = time.monotonic() - start
    print(f"\n{len(results)} inputs in {elapsed:.0f} s")
    for line in summary_lines(results):
        print(line)

    meta = {"date": datetime.date.today().isoformat(), "machine": platform.processor() or
            platform.machine(), "tetgen": tetgen_version() if args.tetgen else None,
            "cgal": cgal_version() if args.cgal else None, "seconds": elapsed,
            "volmesh": " ".join(x for x in (
                subprocess.run([args.cli, "--version"], stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL, text=True).stdout.strip(),
                f"(code at commit {R.source_version()})" if R.source_version() else "") if x),
            "size": args.size,
            "load": {"min": min(loads), "median": float(np.median(loads)), "max": max(loads),
                     "samples": len(loads)}}
    if args.merge_json:
        meta, results = R.merge_rerun(args.merge_json, meta, results)
    if args.json:
        R.dump(args.json, {"meta": meta, "results": results})
    if args.markdown:
        write_markdown(args.markdown, results, meta)
    failures = sum(len(r["failures"]) for r in results)
    if args.check and failures:
        print(f"\n{failures} check(s) failed")
        return 1
    return 0


def lower_first(text):
    return text[:1].lower() + text[1:]


def load_text(load):
    """The machine's load during the run, for the page's opening paragraph."""
    if not load:
        return "The load average was not recorded."
    return (f"The 1-minute load average, sampled after each input, was {load['min']:.1f} to "
            f"{load['max']:.1f} (median {load['median']:.1f}; this run itself counts about 1), "
            "so the seconds are those of a shared machine.")


def _range(vals, fmt_one):
    lo, hi = fmt_one(min(vals)), fmt_one(max(vals))
    return lo if lo == hi else f"{lo}–{hi}"


def prose_numbers(results):
    """The figures the prose of docs/REFERENCE.md quotes, from this run's rows."""
    def good(row):
        return row and "failed" not in row

    def topo_ok(res, row):
        exp = res["expected"]
        return row["components"] == exp["components"] and row["boundary_euler"] == exp["euler"]

    out = {}
    tg_same = [(res, res["rows"]["TetGen"], res["rows"]["volmesh"]) for res in results
               if good(res["rows"].get("TetGen")) and good(res["rows"].get("volmesh"))
               and topo_ok(res, res["rows"]["TetGen"])]
    if tg_same:
        out["@TG_COUNT@"] = _range([t["elements"] / o["elements"] for _, t, o in tg_same],
                                   lambda x: f"{x:.1f}")
        out["@TG_DIH@"] = _range([t["min_dihedral"] for _, t, _ in tg_same], lambda x: f"{x:.1f}")
        out["@TG_BELOW10@"] = _range([t["slivers_10"] for _, t, _ in tg_same], str)
    heads = []
    for res in results:
        t, o = res["rows"].get("TetGen"), res["rows"].get("volmesh")
        if t is None or not good(o):
            continue
        if "failed" in t:
            why = t["failed"]
            if why in ("exit -11", "exit 139"):
                heads.append(f"crashes on {res['case']} (signal 11, a segmentation fault)")
            elif "terminate called" in why:
                heads.append(f"aborts on {res['case']} (`{why}`)")
            else:
                heads.append(f"fails on {res['case']} (`{why}`)")
        elif not topo_ok(res, t):
            heads.append(f"on {res['case']} finishes but meshes another domain ({t['elements']} "
                         f"tets, {100 * t['volume'] / o['volume']:.2g} % of volmesh's volume, "
                         f"χ∂ {t['boundary_euler']}, {t['components']} components)")
    out["@TG_HEADS@"] = "; ".join(heads) if heads else "runs correctly on every input"
    ph = [res for res in results if res["expected"].get("source") == "phantom"]
    sh = [res for res in results if res["expected"].get("source") != "phantom"]
    cg = lambda rs: [r["rows"]["CGAL"] for r in rs if good(r["rows"].get("CGAL"))]  # noqa: E731
    vm = lambda rs: [r["rows"]["volmesh"] for r in rs  # noqa: E731
                     if good(r["rows"].get("volmesh"))]
    if cg(ph):
        out["@CGAL_DIH_PH@"] = _range([r["min_dihedral"] for r in cg(ph)], lambda x: f"{x:.1f}")
        h = [r["hausdorff_out"] for r in cg(ph)]
        out["@CGAL_H@"] = f"median {np.median(h):.2f} ({_range(h, lambda x: f'{x:.2f}')})"
    if vm(ph):
        h = [r["hausdorff_out"] for r in vm(ph)]
        out["@VM_H@"] = _range(h, lambda x: f"{x:.2f}")
        out["@VM_H_MEDIAN@"] = f"median {np.median(h):.2f} ({out['@VM_H@']})"
    if cg(sh):
        out["@CGAL_DIH_SH@"] = _range([r["min_dihedral"] for r in cg(sh)], lambda x: f"{x:.1f}")
        out["@CGAL_BELOW10_SH@"] = _range([r["slivers_10"] for r in cg(sh)], str)
    if cg(results) and vm(results):
        out["@CGAL_RR@"] = _range([r["rr_mean"] for r in cg(results)], lambda x: f"{x:.2f}")
        out["@VM_RR@"] = _range([r["rr_mean"] for r in vm(results)], lambda x: f"{x:.2f}")
    lost = []
    for res in sh:
        c, o = res["rows"].get("CGAL"), res["rows"].get("volmesh")
        if good(c) and good(o) and not topo_ok(res, c):
            lost.append(f"{res['case']} ({c['components']} of {res['expected']['components']} "
                        f"components, {100 * c['volume'] / o['volume']:.0f} % of the volume)")
    ours = [r for r in results if good(r["rows"].get("volmesh"))]
    kept = [r for r in ours if topo_ok(r, r["rows"]["volmesh"])]
    out["@VM_TOPO@"] = ("on every input" if len(kept) == len(results) else
                        f"on {len(kept)} of {len(results)} inputs (not on "
                        + ", ".join(r["case"] for r in results if r not in kept) + ")")
    best = [r for r in ours
            if all(r["rows"]["volmesh"]["min_dihedral"] >= r["rows"][m]["min_dihedral"]
                   for m in ("TetGen", "CGAL") if good(r["rows"].get(m)))]
    out["@VM_BEST@"] = ("on every input" if len(best) == len(results) else
                        f"on {len(best)} of {len(results)} inputs")
    out["@CGAL_LOST@"] = ", ".join(lost) if lost else "none of them"
    thin = [(abs(1 - r["rows"]["CGAL"]["volume"] / r["rows"]["volmesh"]["volume"]), r)
            for r in ph if good(r["rows"].get("CGAL")) and good(r["rows"].get("volmesh"))]
    if thin:
        d, r = max(thin, key=lambda x: x[0])
        low = r["rows"]["CGAL"]["volume"] < r["rows"]["volmesh"]["volume"]
        out["@CGAL_THIN@"] = (f"{r['case']} is the phantom CGAL gets furthest from in volume: "
                              f"{100 * d:.0f} % {'low' if low else 'high'}")
    return out


def write_markdown(path, results, meta):
    template = os.path.join(os.path.dirname(os.path.abspath(__file__)), "REFERENCE.md.in")
    with open(template, encoding="utf-8") as fh:
        text = fh.read()
    body = []
    for res in results:
        body.append("### " + heading(res))
        body.append("")
        body.extend(table(res))
        body.append("")
        for note in res["notes"]:
            body.append(f"- {note}")
        for failure in res["failures"]:
            body.append(f"- **volmesh check failed:** {failure}")
        if res["notes"] or res["failures"]:
            body.append("")
    params = []
    for res in results:
        tg = res["rows"].get("TetGen", {})
        cg = res["rows"].get("CGAL", {})
        crit = cg.get("criteria")
        params.append(f"| {res['case']} | `{tg.get('switches', '–')}` | "
                      + (f"h = {crit['cell_size']:.3g}, facet distance {crit['facet_distance']:.3g}"
                         if crit else "–") + " |")
    text = (text.replace("@DATE@", meta["date"])
            .replace("@VOLMESH@", meta.get("volmesh") or "volmesh")
            .replace("@TETGEN@", meta["tetgen"] or "not available")
            .replace("@CGAL@", meta["cgal"] or "not available")
            .replace("@SIZE@", str(meta["size"]))
            .replace("@SECONDS@", f"{meta['seconds']:.0f}")
            .replace("@LOAD@", load_text(meta.get("load")) + "".join(
                f"\nThe rows of {', '.join(r['cases'])} come from a rerun on {r['date']} with "
                f"{r.get('volmesh') or 'volmesh'} ({r['seconds']:.0f} s); "
                + lower_first(load_text(r.get("load"))) for r in meta.get("reruns", [])))
            .replace("@SUMMARY@", "\n".join(summary_lines(results)))
            .replace("@TABLES@", "\n".join(body).rstrip())
            .replace("@PARAMETERS@", "\n".join(params)))
    for key, value in prose_numbers(results).items():
        text = text.replace(key, value)
    text = re.sub(r"@[A-Z0-9_]+@", "(not measured in this run)", text)
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


if __name__ == "__main__":
    sys.exit(main())
