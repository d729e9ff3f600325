# SPDX-License-Identifier: BSD-3-Clause
"""stages.py — issue 32: each stage's time on 1 and 2 threads, and a gyroid end to end.

    /usr/bin/python3 bench/stages.py --cli build/volmesh [--markdown docs/BENCHMARKS.md]
        [--head /work/shared/data/ct_head_quarter.nrrd] [--gyroid 256] [--reps 1]
        [--threads 1,2] [--work DIR] [--from-json DIR/stages.json]

Per stage (`volmesh --verbose`: read, mesh, improve, write, check) the CT head at iso 500 on
each thread count, the median of --reps runs (the thread counts taken in turn, run by run);
then a gyroid of n³ voxels (sin x cos y +
sin y cos z + sin z cos x >= 0, four periods across the box, float NRRD written by numpy slab
by slab) meshed end to end on the most threads: tets/s and bytes per tet (GNU `time -v`'s
peak resident set over the tets, with and without the float volume). With --markdown it
rewrites the block between the stages markers of that page (bench/run keeps the block).
--gyroid 0 leaves the gyroid out. The whole run is a few minutes on a quiet 2-core machine
(the 256³ gyroid is about 40 M tets).
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True
sys.path.insert(0, HERE)
import big as BIG  # noqa: E402  (run, stages)
import bench as B  # noqa: E402  (machine)

BEGIN = "<!-- stages:begin (bench/stages.py writes this block) -->"
END = "<!-- stages:end -->"
STAGES = ["read", "mesh", "improve", "write", "check"]


def make_gyroid(n, path):
    """The gyroid sin x cos y + sin y cos z + sin z cos x, four periods across n voxels."""
    if os.path.exists(path):
        return
    import numpy as np
    k = 2.0 * np.pi * 4.0 / n
    i = np.arange(n, dtype=np.float64) * k
    yy, xx = np.meshgrid(i, i, indexing="ij")
    tmp = path + ".part"
    with open(tmp, "wb") as fp:
        fp.write((f"NRRD0004\ntype: float\ndimension: 3\nsizes: {n} {n} {n}\n"
                  "spacings: 1 1 1\nendian: little\nencoding: raw\n\n").encode())
        for z in i:
            f = np.sin(xx) * np.cos(yy) + np.sin(yy) * np.cos(z) + np.sin(z) * np.cos(xx)
            fp.write(f.astype("<f4").tobytes())
    os.replace(tmp, path)


def mesh_once(cli, vol, iso, threads, work, timeout):
    """One `volmesh mesh` run: a dict of wall, cpu, peak_mb, tets, stages, or failed."""
    out = os.path.join(work, "stages.vtu")
    cmd = [cli, "--threads", str(threads), "mesh", vol, "--iso", str(iso), "-o", out, "--json",
           "--quiet", "--verbose"]
    r = BIG.run(cmd, work, timeout)
    if r is None:
        return {"failed": f"timed out after {timeout} s"}
    wall, peak, so, se, rc, cpu = r
    if rc not in (0, 1):
        return {"failed": f"exit {rc}: {se.strip().splitlines()[-1] if se.strip() else ''}"}
    js = json.loads(so.strip().splitlines()[-1])
    row = {"wall": wall, "cpu": cpu, "peak_mb": peak, "tets": js["elements"],
           "min_dih": js["min_dihedral"], "stages": BIG.stages(se),
           "bytes": os.path.getsize(out) if os.path.exists(out) else 0}
    if os.path.exists(out):
        os.remove(out)
    return row


def median_row(rows):
    """The run of median wall time, its stages the medians of each stage."""
    ok = [r for r in rows if "failed" not in r]
    if not ok:
        return rows[0]
    mid = sorted(ok, key=lambda r: r["wall"])[len(ok) // 2]
    row = dict(mid)
    row["stages"] = {s: statistics.median([r["stages"].get(s, 0.0) for r in ok])
                     for s in STAGES}
    row["reps"] = len(ok)
    return row


def head_table(head, head_passive=True):
    """Stage rows: one line per stage, one column per thread count, the ratio, and the most
    threads again with OMP_WAIT_POLICY=passive when that was run (key "Np")."""
    threads = sorted((t for t in head if t.isdigit()), key=int)
    lines = ["| stage | " + " | ".join(f"{t} thread{'s' if t != '1' else ''} s" for t in threads)
             + (f" | {threads[0]} ÷ {threads[-1]} |" if len(threads) > 1 else " |"),
             "|---|" + "---|" * (len(threads) + (1 if len(threads) > 1 else 0))]
    passive = head_passive and threads[-1] + "p" in head
    if passive:
        lines[0] += f" {threads[-1]} threads, passive wait s |"
        lines[1] += "---|"
    for s in STAGES + ["wall", "cpu"]:
        cols = threads + ([threads[-1] + "p"] if passive else [])
        vals = [head[t][s] if s in ("wall", "cpu") else head[t]["stages"].get(s, 0.0)
                for t in cols]
        n = len(threads)
        ratio = (f" | {vals[0] / vals[n - 1]:.2f}×" if n > 1 and vals[n - 1] > 0 else
                 (" | –" if n > 1 else ""))
        name = {"wall": "end to end (wall)", "cpu": "CPU, user + system"}.get(s, s)
        lines.append(f"| {name} | "
                     + " | ".join(f"{v:.3f}" for v in vals[:n]) + ratio
                     + (f" | {vals[n]:.3f}" if passive else "") + " |")
    return "\n".join(lines)


def block(res, meta):
    m = meta["machine"]
    parts = [BEGIN, "## Stage times on 1 and 2 threads (issue 32)", "",
             f"Written by `bench/stages.py` on {meta['date']} (volmesh commit {meta['commit']}). "
             f"Machine: {m.get('Model name', '?')}, {m.get('nproc', '?')} CPUs, "
             f"{m.get('memory', '?')} memory, load average {meta['load']} when the run started "
             "(a shared machine: with other work on the cores, two threads cannot show their "
             "speed-up, so read the ratios as a floor). The last column runs the most threads "
             "again with `OMP_WAIT_POLICY=passive`: on a busy machine OpenMP's threads that "
             "spin at the end of each parallel loop take cores from the others' work."]
    head = res.get("head")
    if head and all("failed" not in r for r in head.values()):
        any_row = head[min((t for t in head if t.isdigit()), key=int)]
        parts += ["", f"CT head (`ct_head_quarter.nrrd`) at iso 500, {any_row['tets']:,} tets, "
                  f"`volmesh --threads N mesh … --verbose`, median of {any_row.get('reps', 1)} "
                  "run(s):", "", head_table(head)]
    elif head:
        parts += ["", "CT head: " + "; ".join(f"{t} threads: {r.get('failed', 'ok')}"
                                               for t, r in head.items())]
    g = res.get("gyroid")
    if g and "failed" not in g:
        tets = g["tets"]
        st = g["stages"]
        parts += ["", f"Gyroid {g['n']}³ (four periods, f >= 0), uniform, on {g['threads']} "
                  f"threads, one run: {tets:,} tets in {g['wall']:.1f} s wall "
                  f"({g['cpu']:.1f} s CPU) = **{tets / g['wall']:,.0f} tets/s** end to end; "
                  f"peak resident set {g['peak_mb']:.0f} MB = "
                  f"**{g['peak_mb'] * 1048576 / tets:.0f} bytes per tet** "
                  f"({(g['peak_mb'] - g['vol_mb']) * 1048576 / tets:.0f} beyond "
                  f"the {g['vol_mb']:.0f} MB float volume); file {g['bytes'] / 1e6:.0f} MB "
                  f"({g['bytes'] / tets:.1f} bytes per tet); min dihedral "
                  f"{g['min_dih']:.2f}°. Stages: "
                  + ", ".join(f"{s} {st.get(s, 0.0):.1f} s" for s in STAGES) + "."]
    elif g:
        parts += ["", f"Gyroid {g.get('n', '?')}³: {g['failed']}"]
    parts.append(END)
    return "\n".join(parts)


def write_block(path, text):
    """Replaces the stages block of the page at path (or appends it)."""
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
    ap.add_argument("--work", default="build-bench/stages")
    ap.add_argument("--head", default="/work/shared/data/ct_head_quarter.nrrd")
    ap.add_argument("--gyroid", type=int, default=256)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--markdown")
    ap.add_argument("--timeout", type=int, default=1800)
    ap.add_argument("--from-json", help="only rewrite --markdown from a saved stages.json")
    args = ap.parse_args()
    if args.from_json:
        with open(args.from_json) as fp:
            saved = json.load(fp)
        text = block(saved["results"], saved["meta"])
        if args.markdown:
            write_block(args.markdown, text)
        else:
            print(text)
        return
    cli = os.path.abspath(args.cli)
    os.makedirs(args.work, exist_ok=True)
    work = os.path.abspath(args.work)
    load = os.getloadavg()[0]
    threads = [t.strip() for t in args.threads.split(",") if t.strip()]
    res = {}
    if os.path.exists(args.head):
        # the thread counts interleaved, rep by rep: a machine whose speed drifts during the
        # run (a shared one) then weighs on every column alike
        cols = threads + ([threads[-1] + "p"] if len(threads) > 1 else [])
        rows = {c: [] for c in cols}
        saved = os.environ.get("OMP_WAIT_POLICY")
        for rep in range(args.reps):
            for c in cols:
                t = c.rstrip("p")
                print(f"stages.py: CT head, {t} thread(s){', passive wait' if c != t else ''}"
                      f", run {rep + 1} of {args.reps}", file=sys.stderr, flush=True)
                if c != t:
                    os.environ["OMP_WAIT_POLICY"] = "passive"
                rows[c].append(mesh_once(cli, args.head, 500, t, work, args.timeout))
                if saved is None:
                    os.environ.pop("OMP_WAIT_POLICY", None)
                else:
                    os.environ["OMP_WAIT_POLICY"] = saved
        res["head"] = {c: median_row(rows[c]) for c in cols}
        for c in cols:
            print(json.dumps(res["head"][c]), flush=True)
    if args.gyroid:
        n = args.gyroid
        vol = os.path.join(work, f"gyroid-{n}.nrrd")
        make_gyroid(n, vol)
        t = threads[-1]
        print(f"stages.py: gyroid {n}³, {t} thread(s)", file=sys.stderr, flush=True)
        g = mesh_once(cli, vol, 0, t, work, args.timeout)
        g.update(n=n, threads=t, vol_mb=n ** 3 * 4 / 1048576.0)
        res["gyroid"] = g
        print(json.dumps(g), flush=True)
    commit = subprocess.run(["git", "-C", HERE, "rev-parse", "--short", "HEAD"],
                            stdout=subprocess.PIPE, text=True).stdout.strip() or "?"
    meta = {"machine": B.machine(), "date": time.strftime("%Y-%m-%d"), "commit": commit,
            "load": f"{load:.1f}"}
    with open(os.path.join(work, "stages.json"), "w") as fp:
        json.dump({"results": res, "meta": meta}, fp, indent=1)
    text = block(res, meta)
    if args.markdown:
        write_block(args.markdown, text)
    else:
        print(text)


if __name__ == "__main__":
    main()
