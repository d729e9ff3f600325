# SPDX-License-Identifier: BSD-3-Clause
"""big.py — big volumes (issue #12): 256³ and 512³ sphere phantoms meshed end to end.

    /usr/bin/python3 bench/big.py --cli build/volmesh [--sizes 256,512] [--work DIR]
                                  [--markdown docs/BENCHMARKS.md] [--timeout S]

Makes the phantoms (the field of `volmesh demo --shape sphere`: 0.35 (n-1) minus the distance
to the centre, written as raw float NRRD by numpy, slab by slab), then times with GNU
`time -v` (wall, peak resident set): volmesh --adaptive, uniform at --size 2, uniform at full
resolution where it fits in memory (on 512³ it is shown refused by --max-memory), each with
its quality pass, and VTK's flying edges (the surface only). Stage times come from
volmesh --verbose. With --markdown it rewrites the block between the big-volume markers of
that page (bench/run keeps the block when it rewrites the rest).
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True
sys.path.insert(0, HERE)
import bench as B  # noqa: E402  (FE_SCRIPT, machine)

BEGIN = "<!-- big-volumes:begin (bench/big.py writes this block) -->"
END = "<!-- big-volumes:end -->"
GNU_TIME = "/usr/bin/time"


def make_phantom(n, path):
    """The sphere phantom of volmesh (mesher/phantom.c) as a raw float NRRD."""
    if os.path.exists(path):
        return
    import numpy as np
    c, r = 0.5 * (n - 1), 0.35 * (n - 1)
    i = np.arange(n, dtype=np.float64) - c
    yy, xx = np.meshgrid(i, i, indexing="ij")
    tmp = path + ".part"
    with open(tmp, "wb") as fp:
        fp.write((f"NRRD0004\ntype: float\ndimension: 3\nsizes: {n} {n} {n}\n"
                  "spacings: 1 1 1\nendian: little\nencoding: raw\n\n").encode())
        for k in range(n):
            fp.write((r - np.sqrt(xx * xx + yy * yy + i[k] * i[k])).astype("<f4").tobytes())
    os.replace(tmp, path)


def run(cmd, cwd, timeout):
    """(wall s, peak MB, stdout, stderr, exit code) of cmd under GNU time -v."""
    start = time.monotonic()
    try:
        p = subprocess.run([GNU_TIME, "-v"] + cmd, cwd=cwd, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None
    wall = time.monotonic() - start
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): ([\d.]+)",
                                           p.stderr))
    return (wall, (int(m.group(1)) / 1024.0 if m else 0.0), p.stdout, p.stderr, p.returncode,
            cpu)


def stages(stderr):
    return {m.group(1): float(m.group(2))
            for m in re.finditer(r"^volmesh: (\w+)\s+([\d.]+) s$", stderr, re.M)}


def volmesh_case(cli, vol, label, extra, work, timeout):
    out = os.path.join(work, "big.vtu")
    cmd = [cli, "mesh", vol, "--iso", "0", "-o", out, "--json", "--quiet", "--verbose"] + extra
    r = run(cmd, work, timeout)
    row = {"tool": "volmesh " + label, "cmd": " ".join(["volmesh", "mesh", "IN", "--iso", "0"]
                                                      + extra)}
    if r is None:
        row["failed"] = f"timed out after {timeout} s"
        return row
    wall, peak, so, se, rc, cpu = r
    if rc not in (0, 1):
        msg = [ln for ln in se.splitlines() if ln.startswith("volmesh") and ":" in ln
               and not re.match(r"^volmesh: \w+\s+[\d.]+ s$", ln)]
        # the phantom's name, not the work directory it happened to be written in
        row["failed"] = (msg[-1].replace(vol, os.path.basename(vol)) if msg else f"exit {rc}")
        return row
    js = json.loads(so.strip().splitlines()[-1])
    row.update(wall=wall, cpu=cpu, peak_mb=peak, tets=js["elements"], min_dih=js["min_dihedral"],
               euler=js["boundary_euler"], closed=js["boundary_closed"],
               stages=stages(se))
    if os.path.exists(out):
        os.remove(out)
    return row


def flying_edges(vol, work, timeout):
    out = os.path.join(work, "big-fe.vtp")
    ref = os.path.join(HERE, "..", "tests", "reference")
    r = run(["/usr/bin/python3", "-c", B.FE_SCRIPT, ref, vol, "0", out], work, timeout)
    row = {"tool": "VTK flying edges (surface only)"}
    if r is None or r[4] != 0:
        row["failed"] = "timed out" if r is None else f"exit {r[4]}"
        return row
    js = json.loads(r[2].strip().splitlines()[-1])
    row.update(wall=r[0], cpu=r[5], peak_mb=r[1], tris=js["triangles"], inner=js["filter_seconds"])
    if os.path.exists(out):
        os.remove(out)
    return row


def fmt_count(x):
    return f"{x / 1e6:.2f} M" if x >= 1e6 else f"{x / 1e3:.1f} k"


def table(results, vol_mb):
    lines = ["| input | tool | wall s | CPU s | read | mesh | improve | write | elements "
             "| min dih | peak MB | MB beyond the volume | bytes/tet beyond |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, rows in results:
        for r in rows:
            if "failed" in r:
                lines.append(f"| {name} | {r['tool']} | {r['failed']} ||||||||||| ")
                continue
            st = r.get("stages", {})
            beyond = r["peak_mb"] - vol_mb[name]
            cpu = f"{r['cpu']:.1f}" if r.get("cpu") else "–"
            if "tets" in r:
                per = beyond * 1048576.0 / r["tets"]
                lines.append(
                    f"| {name} | {r['tool']} | {r['wall']:.1f} | {cpu} | {st.get('read', 0):.1f} | "
                    f"{st.get('mesh', 0):.1f} | {st.get('improve', 0):.1f} | "
                    f"{st.get('write', 0):.1f} | {fmt_count(r['tets'])} tets | "
                    f"{r['min_dih']:.1f} | {r['peak_mb']:.0f} | {beyond:.0f} | {per:.0f} |")
            else:
                lines.append(
                    f"| {name} | {r['tool']} | {r['wall']:.1f} | {cpu} | – | {r['inner']:.2f} | – | – "
                    f"| {fmt_count(r['tris'])} tris | – | {r['peak_mb']:.0f} | – | – |")
    return "\n".join(lines)


def block(results, meta, vol_mb):
    m = meta["machine"]
    cpu = m.get("Model name", "?")
    return f"""{BEGIN}
## Big volumes (issue #12)

Written by `bench/big.py` on {meta['date']} (volmesh commit {meta['commit']}): sphere phantoms
(the field of `volmesh demo --shape sphere`) meshed end to end, one run each, `/usr/bin/time
-v` for the wall time and the peak resident set. Machine: {cpu}, {m.get('nproc', '?')} CPUs,
{m.get('memory', '?')} memory, load average {meta['load']} when the run started (the machine is
shared, so the wall times are several times the unloaded figures; the stage columns are
`volmesh --verbose`). "Beyond the volume" subtracts the float volume itself
(n³ × 4 bytes). The 512³ target (< 60 s, < 4 GiB end to end) is for `--adaptive`: a uniform
512³ mesh would be about 120 M tets, which `--max-memory 8G` refuses up front; uniform runs
are shown at `--size 2`. Flying edges makes the surface only (its "mesh" column is the
filter alone).

{table(results, vol_mb)}
{END}"""


def write_block(path, text):
    page = open(path).read() if os.path.exists(path) else ""
    if BEGIN in page and END in page:
        a, b = page.index(BEGIN), page.index(END) + len(END)
        page = page[:a] + text + page[b:]
    else:
        page = page.rstrip("\n") + "\n\n" + text + "\n"
    with open(path, "w") as fp:
        fp.write(page)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", required=True)
    ap.add_argument("--work", default="build-bench/big")
    ap.add_argument("--sizes", default="256,512")
    ap.add_argument("--markdown")
    ap.add_argument("--timeout", type=int, default=1800)
    ap.add_argument("--from-json", help="only rewrite --markdown from a saved big.json")
    args = ap.parse_args()
    if args.from_json:
        with open(args.from_json) as fp:
            saved = json.load(fp)
        text = block(saved["results"], saved["meta"], saved["vol_mb"])
        if args.markdown:
            write_block(args.markdown, text)
        else:
            print(text)
        return
    cli = os.path.abspath(args.cli)
    os.makedirs(args.work, exist_ok=True)
    work = os.path.abspath(args.work)
    load = os.getloadavg()[0]
    results, vol_mb = [], {}
    for n in [int(s) for s in args.sizes.split(",")]:
        vol = os.path.join(work, f"sphere-{n}.nrrd")
        make_phantom(n, vol)
        name = f"sphere-{n}³"
        vol_mb[name] = n ** 3 * 4 / 1048576.0
        cases = [("--adaptive", ["--adaptive"]), ("--size 2", ["--size", "2"])]
        if n <= 256:
            cases.append(("uniform", []))
        else:
            cases.append(("uniform (--max-memory 8G)", ["--max-memory", "8G"]))
        rows = []
        for label, extra in cases:
            print(f"big.py: {name} volmesh {label}", file=sys.stderr, flush=True)
            rows.append(volmesh_case(cli, vol, label, extra, work, args.timeout))
        print(f"big.py: {name} flying edges", file=sys.stderr, flush=True)
        rows.append(flying_edges(vol, work, args.timeout))
        results.append((name, rows))
        for r in rows:
            print(json.dumps({k: v for k, v in r.items() if k != "cmd"}), flush=True)
    commit = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"],
                            stdout=subprocess.PIPE, text=True).stdout.strip() or "?"
    meta = {"machine": B.machine(), "date": time.strftime("%Y-%m-%d"), "commit": commit,
            "load": f"{load:.1f}"}
    with open(os.path.join(work, "big.json"), "w") as fp:
        json.dump({"results": results, "meta": meta, "vol_mb": vol_mb}, fp, indent=1)
    text = block(results, meta, vol_mb)
    if args.markdown:
        write_block(args.markdown, text)
    else:
        print(text)


if __name__ == "__main__":
    main()
