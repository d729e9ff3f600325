# SPDX-License-Identifier: BSD-3-Clause
"""organ.py — issue 33: a large synthetic CT-like image for the graded mesher's speed.

    /usr/bin/python3 bench/organ.py --cli build/volmesh [--work /tmp] [--max-edge 8]
                                    [--threads N] [--make-only] [--check-components]

Writes WORK/organ.nrrd (once; it is deterministic, seed 33): 438 x 353 x 165 short voxels of
0.8 x 0.8 x 1.5 mm, an abdomen-like body of soft tissue (40 HU, air -1000 HU outside) holding
8 objects above the iso of 150 HU: an aorta tree (trunk 4 mm, renal, iliac and small branches
down to 1 mm radius), a vena cava with a branch, a liver with two vessels through it (genus 2),
a spleen, a spine, two kidneys and a bowel loop (a torus of 3 mm tube radius); Gaussian noise
of 6 HU. Then times `volmesh mesh organ.nrrd --iso 150 --max-edge 8 -o organ.vtu --verbose`
under GNU `time -v` and prints tets, components, boundary Euler, wall/CPU/system time, peak
RSS and the stage times as one JSON line. --check-components counts the voxels' 6-connected
components above the iso with scipy (8 expected). The image stays out of git (WORK is /tmp).
"""

import argparse
import json
import os
import re
import subprocess
import sys

SHAPE = (165, 353, 438)  # z, y, x: x fastest in the file
SPACING = (0.8, 0.8, 1.5)  # x, y, z (mm)
ISO = 150
SEED = 33
BLUR = 0.4  # mm: the partial-volume edge of every object


def coords():
    import numpy as np
    z = np.arange(SHAPE[0], dtype=np.float32) * SPACING[2]
    y = np.arange(SHAPE[1], dtype=np.float32) * SPACING[1]
    x = np.arange(SHAPE[2], dtype=np.float32) * SPACING[0]
    return x, y, z


def box(lo, hi):
    """Index slices (z, y, x) of the voxels within the world box lo..hi (mm)."""
    sl = []
    for axis, n, h in ((2, SHAPE[0], SPACING[2]), (1, SHAPE[1], SPACING[1]),
                       (0, SHAPE[2], SPACING[0])):
        a = max(0, int(lo[axis] / h) - 1)
        b = min(n, int(hi[axis] / h) + 2)
        sl.append(slice(a, max(a, b)))
    return tuple(sl)


def smooth(d):
    """Inside fraction (0..1) at signed depth d mm (positive inside)."""
    import numpy as np
    return 0.5 * (1.0 + np.tanh(d / BLUR))


def capsules_depth(segs, lo, hi, sl=None):
    """Largest signed depth over the capsules segs = [(p, q, rp, rq)] in box lo..hi (or sl)."""
    import numpy as np
    x, y, z = coords()
    sl = sl or box(lo, hi)
    Z, Y, X = np.meshgrid(z[sl[0]], y[sl[1]], x[sl[2]], indexing="ij")
    depth = np.full(Z.shape, -1e3, dtype=np.float32)
    for p, q, rp, rq in segs:
        p = np.asarray(p, np.float32)
        q = np.asarray(q, np.float32)
        d = q - p
        t = ((X - p[0]) * d[0] + (Y - p[1]) * d[1] + (Z - p[2]) * d[2]) / float(d @ d)
        np.clip(t, 0.0, 1.0, out=t)
        dist = np.sqrt((X - p[0] - t * d[0]) ** 2 + (Y - p[1] - t * d[1]) ** 2
                       + (Z - p[2] - t * d[2]) ** 2)
        np.maximum(depth, (rp + t * (rq - rp)) - dist, out=depth)
    return sl, depth


def tree_box(segs, margin=6.0):
    lo = [min(min(p[a], q[a]) for p, q, _, _ in segs) - margin for a in range(3)]
    hi = [max(max(p[a], q[a]) for p, q, _, _ in segs) + margin for a in range(3)]
    return lo, hi


def ellipsoid_depth(c, a, bumps, seed):
    """Approximate signed depth (mm) of a bumpy ellipsoid, centre c, semi-axes a."""
    import numpy as np
    rng = np.random.default_rng(seed)
    x, y, z = coords()
    lo = [c[i] - a[i] * 1.3 - 3 for i in range(3)]
    hi = [c[i] + a[i] * 1.3 + 3 for i in range(3)]
    sl = box(lo, hi)
    Z, Y, X = np.meshgrid(z[sl[0]], y[sl[1]], x[sl[2]], indexing="ij")
    u, v, w = (X - c[0]) / a[0], (Y - c[1]) / a[1], (Z - c[2]) / a[2]
    r = np.sqrt(u * u + v * v + w * w)
    depth = (1.0 - r) * min(a)
    for _ in range(bumps):
        k = rng.uniform(1.0, 3.0, 3)
        ph = rng.uniform(0, 2 * np.pi, 3)
        depth += 0.06 * min(a) * np.sin(k[0] * u + ph[0]) * np.sin(k[1] * v + ph[1]) \
            * np.sin(k[2] * w + ph[2])
    return sl, depth.astype(np.float32)


def add(img, sl, depth, hu):
    """Raise the voxels to soft tissue + hu times the inside fraction (the largest wins)."""
    import numpy as np
    np.maximum(img[sl], (40.0 + hu * smooth(depth)).astype(np.float32), out=img[sl])


def make(path):
    """Write the organ image to path (atomically); the same bytes on every run."""
    import numpy as np
    x, y, z = coords()
    img = np.full(SHAPE, -1000.0, dtype=np.float32)
    # body: an elliptic cylinder of soft tissue along z
    Y, X = np.meshgrid(y, x, indexing="ij")
    body = 1.0 - np.sqrt(((X - 175) / 165) ** 2 + ((Y - 141) / 125) ** 2)
    img[:] = (-1000.0 + 1040.0 * smooth(body * 125.0))[None, :, :]

    aorta = [((165, 175, 50), (165, 175, 236), 4.0, 4.0),
             ((165, 175, 130), (120, 180, 128), 2.5, 1.5),        # left renal
             ((165, 175, 110), (230, 195, 112), 2.5, 1.5),        # right renal
             ((165, 175, 50), (120, 165, 10), 3.5, 2.5),          # iliacs
             ((165, 175, 50), (210, 165, 10), 3.5, 2.5),
             ((165, 175, 180), (165, 130, 190), 2.0, 1.2),        # coeliac
             ((165, 130, 190), (150, 100, 196), 1.2, 1.0),
             ((150, 100, 196), (140, 85, 210), 1.0, 1.0),
             ((165, 130, 190), (185, 105, 186), 1.2, 1.0)]
    sl, d = capsules_depth(aorta, *tree_box(aorta))
    add(img, sl, d, 260.0)
    cava = [((200, 165, 70), (200, 165, 236), 4.0, 4.0),
            ((200, 165, 100), (235, 150, 95), 3.0, 1.5),
            ((235, 150, 95), (245, 135, 80), 1.5, 1.0)]
    sl, d = capsules_depth(cava, *tree_box(cava))
    add(img, sl, d, 220.0)
    # liver with two vessels of low density through it (two handles)
    sl, d = ellipsoid_depth((265, 120, 190), (50, 45, 35), 4, SEED + 1)
    holes = [((265, 120, 140), (265, 120, 240), 5.0, 5.0),
             ((290, 40, 195), (290, 200, 195), 4.0, 4.0)]
    _, h = capsules_depth(holes, None, None, sl)
    d = np.minimum(d, -h)
    add(img, sl, d, 150.0)
    for c, a, s in (((80, 120, 185), (25, 35, 30), 2),           # spleen
                    ((95, 190, 130), (20, 15, 35), 3),           # kidneys
                    ((255, 190, 130), (20, 15, 35), 4)):
        sl, d = ellipsoid_depth(c, a, 3, SEED + s)
        add(img, sl, d, 170.0)
    # spine: a column with a vertebra every 30 mm
    sl = box((140, 200, 4), (190, 250, 242))
    Z, Y, X = np.meshgrid(z[sl[0]], y[sl[1]], x[sl[2]], indexing="ij")
    rad = 13.0 + 3.0 * np.cos(2 * np.pi * Z / 30.0)
    d = np.minimum(rad - np.sqrt((X - 165) ** 2 + (Y - 225) ** 2),
                   np.minimum(Z - 6.0, 240.0 - Z))
    add(img, sl, d, 460.0)
    # bowel loop: a torus in the plane z = 90
    sl = box((130, 35, 80), (220, 125, 100))
    Z, Y, X = np.meshgrid(z[sl[0]], y[sl[1]], x[sl[2]], indexing="ij")
    ring = np.sqrt((X - 175) ** 2 + (Y - 80) ** 2) - 30.0
    add(img, sl, 3.0 - np.sqrt(ring * ring + (Z - 90) ** 2), 200.0)

    rng = np.random.default_rng(SEED)
    img += rng.normal(0.0, 6.0, SHAPE).astype(np.float32)
    data = np.clip(np.rint(img), -1024, 3071).astype("<i2")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(("NRRD0004\ntype: short\ndimension: 3\nsizes: %d %d %d\n"
                 "spacings: %g %g %g\nencoding: raw\nendian: little\n\n"
                 % (SHAPE[2], SHAPE[1], SHAPE[0], *SPACING)).encode())
        f.write(data.tobytes())
    os.replace(tmp, path)


def components(path):
    import numpy as np
    from scipy import ndimage
    with open(path, "rb") as f:
        raw = f.read()
    data = np.frombuffer(raw[raw.index(b"\n\n") + 2:], dtype="<i2").reshape(SHAPE)
    _, n = ndimage.label(data >= ISO)
    return n


def run(cli, path, out, max_edge, threads):
    cmd = ["/usr/bin/time", "-v", cli] + (["--threads", str(threads)] if threads else [])
    cmd += ["mesh", path, "--iso", str(ISO), "--max-edge", str(max_edge), "-o", out,
            "--verbose"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    text = p.stdout + p.stderr
    if p.returncode != 0:
        sys.exit("organ.py: volmesh failed (%d):\n%s" % (p.returncode, text[-3000:]))
    r = {"cmd": " ".join(cmd[2:])}
    m = re.search(r"(\d+) tets, (\d+) points, boundary (\w+) \(Euler (-?\d+)\), (\d+) compon", text)
    if m:
        r.update(tets=int(m.group(1)), points=int(m.group(2)), euler=int(m.group(4)),
                 components=int(m.group(5)))
    for key, pat, conv in (("wall_s", r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)",
                            None),
                           ("user_s", r"User time \(seconds\): (\S+)", float),
                           ("sys_s", r"System time \(seconds\): (\S+)", float),
                           ("peak_mb", r"Maximum resident set size \(kbytes\): (\d+)",
                            lambda s: round(int(s) / 1024.0))):
        m = re.search(pat, text)
        if m:
            if conv is None:
                secs = 0.0
                for part in m.group(1).split(":"):
                    secs = secs * 60 + float(part)
                r[key] = round(secs, 2)
            else:
                r[key] = conv(m.group(1))
    r["stages"] = {k: float(v) for k, v in re.findall(r"volmesh: (\w[\w ]*?)\s+([\d.]+) s", text)}
    m = re.search(r"volmesh:\s+graded: (.*)", text)
    if m:
        r["graded_steps"] = {k: float(v) for k, v in re.findall(r"(\w+) ([\d.]+) s", m.group(1))}
    try:
        with open("/proc/loadavg") as f:
            r["load"] = f.read().split()[0]
    except OSError:
        pass
    return r


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cli", default="build/volmesh")
    ap.add_argument("--work", default="/tmp")
    ap.add_argument("--max-edge", type=float, default=8.0)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--make-only", action="store_true")
    ap.add_argument("--check-components", action="store_true")
    a = ap.parse_args()
    path = os.path.join(a.work, "organ.nrrd")
    if not os.path.exists(path):
        os.makedirs(a.work, exist_ok=True)
        make(path)
    if a.check_components:
        print("organ.nrrd: %d components at iso %d (6-connected)" % (components(path), ISO))
    if a.make_only:
        return
    print(json.dumps(run(a.cli, path, os.path.join(a.work, "organ.vtu"), a.max_edge, a.threads)))


if __name__ == "__main__":
    main()
