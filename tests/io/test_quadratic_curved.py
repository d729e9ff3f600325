# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/test_quadratic_curved.py — `volmesh mesh --order 2` curves the boundary of tets: on
an origin-centred sphere phantom (f = |x| - 0.7 on 128^3 points spanning [-1, 1], material
f <= 0, --size 10), the tetra10 mesh has the linear mesh's corners and cells, its boundary
mid-edge nodes lie on the sphere (to the trilinear field's accuracy) where the straight ones
lie inside, its volume (det J integrated by a degree-3 exact rule) is at least 3 times nearer
4/3 pi 0.7^3 than the linear mesh's, and det J is positive at every corner, edge middle,
centroid and Gauss point of every tet. The .msh and .inp of the same run carry the same
curved nodes. Exit 0 pass, 1 fail, 77 skip when meshio or numpy cannot be imported."""
import os
import sys
import tempfile

try:
    import meshio
    import numpy as np
except ImportError as exc:
    print(f"skipped: cannot import meshio/numpy ({exc})")
    sys.exit(77)

from harness import check, failures, need_cli, run  # noqa: E402

CLI = need_cli()
N, RADIUS, SIZE = 128, 0.7, "10"
WANT_RATIO = 3.0  # the issue: the quadratic volume error at least 3x smaller
TET_EDGES = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)]


def write_sphere(path):
    h = 2.0 / (N - 1)
    g = -1 + h * np.arange(N)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    vals = (np.sqrt(x * x + y * y + z * z) - RADIUS).astype("<f4")
    head = ("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\n"
            "space: right-anterior-superior\nspace directions: (%r,0,0) (0,%r,0) (0,0,%r)\n"
            "space origin: (-1,-1,-1)\nencoding: raw\nendian: little\n\n") % (N, N, N, h, h, h)
    with open(path, "wb") as f:
        f.write(head.encode() + vals.tobytes())


def jacobians(x, lam):
    """det J of each tetra10 (nodes x[cell, 10, 3], VTK order) at barycentric point lam."""
    dl = np.array([[-1, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    jac = np.zeros((x.shape[0], 3, 3))
    for n in range(10):
        if n < 4:
            dn = (4 * lam[n] - 1) * dl[n]
        else:
            p, q = TET_EDGES[n - 4]
            dn = 4 * (lam[q] * dl[p] + lam[p] * dl[q])
        jac += x[:, n, :, None] * dn[None, None, :]
    return np.linalg.det(jac)


def main():
    work = tempfile.mkdtemp(prefix="curved_", dir=os.environ.get("VM_TEST_TMP", "."))
    os.chdir(work)
    write_sphere("sphere.nrrd")
    base = ["mesh", "sphere.nrrd", "--range", ":0", "--size", SIZE, "-q"]
    run(*base, "-o", "lin.vtu")
    run(*base, "--order", "2", "-o", "quad.vtu")
    run(*base, "--order", "2", "-o", "quad.msh")
    run(*base, "--order", "2", "-o", "quad.inp")
    if failures:
        return 1
    lin, quad = meshio.read("lin.vtu"), meshio.read("quad.vtu")
    c1, c2 = lin.cells[0].data, quad.cells[0].data
    check(quad.cells[0].type == "tetra10", f"quad.vtu cells {quad.cells[0].type}")
    check(np.array_equal(c2[:, :4], c1), "the corners' connectivity differs from the linear")
    check(np.array_equal(quad.points[:len(lin.points)], lin.points),
          "the corner coordinates differ from the linear mesh's")
    p1 = lin.points
    a, b, c, d = (p1[c1[:, i]] for i in range(4))
    v_lin = np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)).sum() / 6
    x = quad.points[c2]
    # degree-3 exact rule: centroid -4/5, the four (1/2, 1/6, 1/6, 1/6) points 9/20
    rule = [(np.full(4, 0.25), -0.8)] + [(np.where(np.arange(4) == k, 0.5, 1 / 6), 0.45)
                                          for k in range(4)]
    v_quad = sum(w * jacobians(x, lam) for lam, w in rule).sum() / 6
    exact = 4 / 3 * np.pi * RADIUS ** 3
    e_lin, e_quad = abs(v_lin - exact) / exact, abs(v_quad - exact) / exact
    print(f"sphere R {RADIUS}: {len(c1)} tets; volume error linear {100 * e_lin:.4f}%, "
          f"curved quadratic {100 * e_quad:.4f}% ({e_lin / max(e_quad, 1e-300):.1f}x)")
    check(e_quad * WANT_RATIO <= e_lin,
          f"quadratic volume error {e_quad:.3g} not {WANT_RATIO}x below linear {e_lin:.3g}")
    ga, gb = 0.5854101966249685, 0.1381966011250105
    points = [np.eye(4)[k] for k in range(4)] + [np.full(4, 0.25)]
    points += [np.where(np.arange(4) == k, ga, gb) for k in range(4)]
    points += [(np.eye(4)[p] + np.eye(4)[q]) / 2 for p, q in TET_EDGES]
    worst = min(float(jacobians(x, lam).min()) for lam in points)
    check(worst > 0, f"a curved tet has det J {worst:.3g} <= 0")
    # boundary mid-edge nodes: on the sphere, where the straight middles are inside it
    faces = np.sort(np.concatenate([c1[:, [0, 1, 2]], c1[:, [0, 1, 3]], c1[:, [0, 2, 3]],
                                    c1[:, [1, 2, 3]]]), axis=1)
    uniq, count = np.unique(faces, axis=0, return_counts=True)
    outer = uniq[count == 1]
    edges = {tuple(sorted(e)) for f in outer for e in ((f[0], f[1]), (f[1], f[2]), (f[0], f[2]))}
    mid_of = {}
    for k, (p, q) in enumerate(TET_EDGES):
        for cell in c2:
            mid_of.setdefault(tuple(sorted((cell[p], cell[q]))), cell[4 + k])
    r_mid = np.array([np.linalg.norm(quad.points[mid_of[e]]) for e in edges])
    r_straight = np.array([np.linalg.norm((p1[e[0]] + p1[e[1]]) / 2) for e in edges])
    dev_curved = np.abs(r_mid - RADIUS).max()
    dev_straight = np.abs(r_straight - RADIUS).max()
    print(f"boundary mid-edge nodes: {len(edges)}, max | |x| - R |: curved {dev_curved:.2e}, "
          f"straight {dev_straight:.2e}")
    check(dev_curved * 3 < dev_straight,
          f"curved mid-edge nodes {dev_curved:.3g} from the sphere, straight {dev_straight:.3g}")
    msh = meshio.read("quad.msh")
    check(np.allclose(np.sort(msh.points, axis=0), np.sort(quad.points, axis=0), rtol=0,
                      atol=1e-12), "quad.msh has other nodes than quad.vtu")
    inp = meshio.read("quad.inp")
    check(np.allclose(np.sort(inp.points, axis=0), np.sort(quad.points, axis=0), rtol=0,
                      atol=1e-12), "quad.inp has other nodes than quad.vtu")
    print("quadratic curved: %d failures" % len(failures))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
