#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""bench/hex_adaptive.py — uniform against adaptive hexahedra (`--elements hex` with and
without `--adaptive`) on analytic phantoms: hex counts, their ratio, min scaled Jacobian,
inverted hexes, boundary Euler characteristic and components, volume and the distance to the
isosurface (`--distance-check`, voxels). Prints a Markdown table (docs/BENCHMARKS.md).

usage: bench/hex_adaptive.py [--volmesh build/volmesh] [--sizes 64,128]
                             [--shapes sphere,torus,...]
The phantoms are the fields of mesher/phantom.c (signed distances, > 0 inside, iso 0) plus
three more of that kind (ellipsoid, capsule, hollow sphere), written as NRRD by numpy."""
import argparse, json, os, subprocess, sys, tempfile, time
import numpy as np

SHAPES = ["sphere", "torus", "genus3", "two-spheres", "cut-sphere", "ellipsoid", "capsule",
          "hollow", "plate"]


def field(kind, n):
    n1 = n - 1
    c = 0.5 * n1
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64),) * 3, indexing="ij")
    cx = 0.15 * n1 if kind == "cut-sphere" else c
    cz = np.floor(c) if kind == "plate" else c
    dx, dy, dz = x - cx, y - c, z - cz

    def torus(x, y, z, R, r):
        q = np.sqrt(x * x + y * y) - R
        return r - np.sqrt(q * q + z * z)

    if kind in ("sphere", "cut-sphere"):
        f = 0.35 * n1 - np.sqrt(dx * dx + dy * dy + dz * dz)
    elif kind == "torus":
        f = torus(dx, dy, dz, 0.28 * n1, 0.12 * n1)
    elif kind == "genus3":
        R, r = 0.13 * n1, 0.055 * n1
        d = 1.9 * R
        f = np.maximum(torus(dx + d, dy, dz, R, r),
                       np.maximum(torus(dx, dy, dz, R, r), torus(dx - d, dy, dz, R, r)))
    elif kind == "two-spheres":
        r, o = 0.2 * n1, 0.25 * n1
        f = np.maximum(r - np.sqrt((dx + o) ** 2 + dy * dy + dz * dz),
                       r - np.sqrt((dx - o) ** 2 + dy * dy + dz * dz))
    elif kind == "ellipsoid":
        q = np.sqrt((dx / 0.4) ** 2 + (dy / 0.25) ** 2 + (dz / 0.15) ** 2) / n1
        f = 0.15 * n1 * (1 - q)
    elif kind == "capsule":  # a rod along x, radius 0.1
        t = np.clip(dx, -0.3 * n1, 0.3 * n1)
        f = 0.1 * n1 - np.sqrt((dx - t) ** 2 + dy * dy + dz * dz)
    elif kind == "hollow":  # a spherical shell
        rr = np.sqrt(dx * dx + dy * dy + dz * dz)
        f = np.minimum(0.4 * n1 - rr, rr - 0.25 * n1)
    elif kind == "plate":
        a = 0.35 * n1
        f = np.minimum(0.6 - np.abs(dz), np.minimum(a - np.abs(dx), a - np.abs(dy)))
    else:
        raise SystemExit("unknown shape " + kind)
    return f.astype("<f4")


def write_nrrd(path, f):
    n = f.shape
    with open(path, "wb") as fh:
        fh.write(b"NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nendian: little\n"
                 b"encoding: raw\n\n" % (n[2], n[1], n[0]))
        fh.write(f.tobytes())


def run(volmesh, path, out, adaptive):
    cmd = [volmesh, "mesh", path, "--iso", "0", "--elements", "hex", "--distance-check",
           "--json", "-q", "-o", out] + (["--adaptive"] if adaptive else [])
    t = time.time()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.time() - t
    if p.returncode not in (0, 1):
        raise SystemExit("%s failed: %s" % (" ".join(cmd), p.stderr.strip()))
    j = json.loads(p.stdout.strip().splitlines()[-1])
    j["wall"] = wall
    return j


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--volmesh", default="build/volmesh")
    ap.add_argument("--sizes", default="64")
    ap.add_argument("--shapes", default=",".join(SHAPES))
    a = ap.parse_args()
    print("| phantom | uniform hexes | adaptive hexes | ratio | min SJ u / a | inverted a |"
          " Euler u / a | comp. u / a | volume diff | distance a (vox) | wall u / a (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for n in [int(s) for s in a.sizes.split(",")]:
            for kind in a.shapes.split(","):
                vol = os.path.join(d, "%s%d.nrrd" % (kind, n))
                write_nrrd(vol, field(kind, n))
                u = run(a.volmesh, vol, os.path.join(d, "u.vtu"), False)
                x = run(a.volmesh, vol, os.path.join(d, "a.vtu"), True)
                dv = (x["volume"] - u["volume"]) / u["volume"]
                print("| %s-%d | %d | %d | %.2fx | %.4f / %.4f | %d | %d / %d | %d / %d |"
                      " %+.2f%% | %.3f | %.1f / %.1f |" % (
                          kind, n, u["elements"], x["elements"],
                          u["elements"] / max(1, x["elements"]), u["min_scaled_jacobian"],
                          x["min_scaled_jacobian"], x["inverted"], u["boundary_euler"],
                          x["boundary_euler"], u["components"], x["components"], 100 * dv,
                          x["surface_distance"]["hausdorff"], u["wall"], x["wall"]),
                      flush=True)


if __name__ == "__main__":
    sys.exit(main())
