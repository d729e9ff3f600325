# SPDX-License-Identifier: BSD-3-Clause
"""slabs.py — `volmesh mesh --slabs` against the whole-volume run (issue #12): peak memory
and CPU time of the same meshes made slab after slab.

    /usr/bin/python3 bench/slabs.py --cli build/volmesh --slab-read SLAB_READ
                                    --slab-mesh SLAB_MESH [--work DIR]
                                    [--ct ../shared/data/ct_head_quarter.nrrd]

Makes the 512³ sphere phantom of bench/big.py (raw float NRRD) and a gzip copy (level 1),
then runs each case once under GNU `time -v` (wall, CPU = user + system, peak resident set;
the stage columns are `volmesh --verbose`) and prints Markdown tables: the mesh stage alone
(read and mesh, bench/slab_mesh.c), volmesh mesh end to end (every --no-improve slab mesh
compared with the whole run's tet for tet by tests/cli/same_tets.py, VTK + numpy),
and the cost of reading a gzip stream in slabs forward (one vm_volume_reader) or from the
start each time (vm_volume_read_slab, bench/slab_read.c). Build the two drivers as their
headers say.
"""

import argparse
import json
import os
import subprocess
import sys
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True
sys.path.insert(0, HERE)
import big  # noqa: E402  (make_phantom, run, stages)

SAME = os.path.join(HERE, "..", "tests", "cli", "same_tets.py")


def gzip_copy(src, dst):
    if os.path.exists(dst):
        return
    raw = open(src, "rb").read()
    head, data = raw.split(b"\n\n", 1)
    c = zlib.compressobj(1, zlib.DEFLATED, 31)
    with open(dst + ".part", "wb") as fp:
        fp.write(head.replace(b"encoding: raw", b"encoding: gzip") + b"\n\n")
        for i in range(0, len(data), 1 << 24):
            fp.write(c.compress(data[i:i + (1 << 24)]))
        fp.write(c.flush())
    os.replace(dst + ".part", dst)


def mesh(cli, vol, opts, out, work, timeout):
    cmd = [cli, "mesh", vol, "-o", out, "--json", "--quiet", "--verbose"] + opts
    r = big.run(cmd, work, timeout)
    if r is None or r[4] not in (0, 1):
        return {"failed": "timed out" if r is None else r[3].strip().splitlines()[-1]}
    wall, peak, so, se, rc, cpu = r
    js = json.loads(so.strip().splitlines()[-1])
    return {"wall": wall, "cpu": cpu, "peak": peak, "tets": js["elements"],
            "stages": big.stages(se)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cli", required=True)
    ap.add_argument("--slab-read", required=True)
    ap.add_argument("--slab-mesh", required=True)
    ap.add_argument("--work", default="build-bench/slabs")
    ap.add_argument("--ct", default=os.path.join(HERE, "..", "..", "shared", "data",
                                                 "ct_head_quarter.nrrd"))
    ap.add_argument("--timeout", type=int, default=1800)
    a = ap.parse_args()
    cli = os.path.abspath(a.cli)
    os.makedirs(a.work, exist_ok=True)
    work = os.path.abspath(a.work)
    raw = os.path.join(work, "sphere-512.nrrd")
    gz = os.path.join(work, "sphere-512-gz.nrrd")
    big.make_phantom(512, raw)
    gzip_copy(raw, gz)
    print(f"load average {os.getloadavg()[0]:.1f} at the start")
    print("| mesh stage | options | slabs | wall s | CPU s | tets | peak MB |")
    print("|---|---|---|---|---|---|---|")
    for name, vol, opts, counts in (("sphere 512³ raw", raw, ["--adaptive"], [0, 2, 4, 8, 16]),
                                    ("sphere 512³ gzip", gz, ["--adaptive"], [0, 4, 16]),
                                    ("sphere 512³ raw", raw, ["--size", "2"], [0, 8])):
        for n in counts:
            r = big.run([a.slab_mesh, vol, "0"] + opts + ["--slabs", str(n)], work, a.timeout)
            tets = r[2].split(":")[1].split()[0] if r and r[4] == 0 else "failed"
            print(f"| {name} | `{' '.join(opts)}` | {n or 'whole'} | {r[0]:.1f} | {r[5]:.1f} "
                  f"| {int(tets) / 1e6:.2f} M | {r[1]:.0f} |", flush=True)
    print()
    ada = ["--iso", "0", "--adaptive", "--no-improve"]
    cases = [("sphere 512³ raw", raw, ada, [None, 4, 16, "auto:1G"]),
             ("sphere 512³ gzip", gz, ada, [None, 16]),
             ("sphere 512³ raw", raw, ["--iso", "0", "--size", "2", "--no-improve"],
              [None, 8]),
             ("sphere 512³ raw", raw, ["--iso", "0", "--adaptive"], [None, 8])]
    if os.path.exists(a.ct):
        ct = os.path.abspath(a.ct)
        cases += [("CT head quarter", ct, ["--iso", "500", "--adaptive", "--no-improve"],
                   [None, 4]),
                  ("CT head quarter", ct, ["--iso", "500"], [None, 4])]
    print("| input | options | --slabs | wall s | CPU s | mesh s | read s | improve s | tets "
          "| peak MB | same as whole |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, vol, opts, slabs in cases:
        whole = os.path.join(work, "whole.vtu")
        for n in slabs:
            extra = []
            if isinstance(n, str):
                extra = ["--slabs", "auto", "--max-memory", n.split(":")[1]]
            elif n:
                extra = ["--slabs", str(n)]
            out = whole if n is None else os.path.join(work, "slabs.vtu")
            r = mesh(cli, vol, opts + extra, out, work, a.timeout)
            label = "–" if n is None else n.replace(":", " --max-memory ") \
                if isinstance(n, str) else str(n)
            if "failed" in r:
                print(f"| {name} | `{' '.join(opts)}` | {label} | {r['failed']} ||||||||")
                continue
            same = "–"
            if n is not None and "--no-improve" in opts:
                same = subprocess.run(["/usr/bin/python3", SAME, whole, out],
                                      capture_output=True, text=True)
                same = "same" if same.returncode == 0 else "DIFFERENT"
            st = r["stages"]
            print(f"| {name} | `{' '.join(opts)}` | {label} | {r['wall']:.1f} | {r['cpu']:.1f} "
                  f"| {st.get('mesh', 0):.1f} | {st.get('read', 0):.1f} "
                  f"| {st.get('improve', 0):.1f} | {r['tets'] / 1e6:.2f} M | {r['peak']:.0f} "
                  f"| {same} |", flush=True)
        for f in ("whole.vtu", "slabs.vtu"):
            if os.path.exists(os.path.join(work, f)):
                os.remove(os.path.join(work, f))
    print()
    print("| gzip read | slabs | wall s | CPU s | peak MB |")
    print("|---|---|---|---|---|")
    for mode, n in (("whole", None), ("forward", 16), ("restart", 16), ("forward", 4),
                    ("restart", 4)):
        cmd = [a.slab_read, gz, mode] + ([str(n)] if n else [])
        r = big.run(cmd, work, a.timeout)
        print(f"| {mode} | {n or '–'} | {r[0]:.1f} | {r[5]:.1f} | {r[1]:.0f} |", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
