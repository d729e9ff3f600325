# SPDX-License-Identifier: BSD-3-Clause
"""tests/python/pytest/test_volmesh.py — the volmesh Python API (docs/PYTHON.md), run by
tests/python/test_python.sh on the package installed into a fresh venv: reading volumes with
their geometry, meshing numpy arrays and label volumes, meshio round trips, writers, quality,
errors, progress and the GIL released while the library works."""
import json
import os
import signal
import subprocess
import sys
import threading
import time

import meshio
import numpy as np
import pytest

import volmesh

DATA = os.environ.get("VM_SHARED_DATA", "")
CLI = os.environ.get("VM_CLI", "")


def ball(n=48, radius=0.5):
    """A ball as a signed field (positive inside) on [-1, 1]^3, indexed [z, y, x]."""
    z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
    return (radius - np.sqrt(x * x + y * y + z * z)).astype(np.float32)


def two_blocks(n=24):
    """A label volume: label 1 in one block, label 2 in the block beside it, 0 around."""
    a = np.zeros((n, n, n), dtype=np.uint8)
    a[4:20, 4:20, 4:12] = 1
    a[4:20, 4:20, 12:20] = 2
    return a


def shared(name):
    path = os.path.join(DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"{path} is absent")
    return path


def test_versionIsTheLibrarys():
    assert volmesh.__version__.count(".") == 2


def test_readKeepsSpacingOriginAndTheZYXLayout():
    path = shared("ct_head_quarter.nrrd")
    v = volmesh.read(path)
    info = json.loads(subprocess.run([CLI, "info", path, "--json"], capture_output=True,
                                     check=True, text=True).stdout)
    nx, ny, nz = info["dims"]
    assert v.array.shape == (nz, ny, nx)
    assert v.array.dtype == np.float32
    assert v.spacing == pytest.approx(tuple(info["spacing"]))
    assert v.origin == pytest.approx(tuple(info["origin"]))
    assert v.array.max() == pytest.approx(info["max"])
    assert v.array.min() == pytest.approx(info["min"])
    # the library's own memory, not a copy
    assert not v.array.flags["OWNDATA"]
    assert v.array.flags["WRITEABLE"]


def test_readsATiffStackLikeTheProgram(tmp_path):
    """The package carries the optional readers its build machine has (here libtiff):
    a multi-page 16-bit stack reads with the program's dims and values."""
    Image = pytest.importorskip("PIL.Image")
    pages = [Image.fromarray((np.arange(12, dtype=np.uint16).reshape(3, 4) + 100 * k))
             for k in range(5)]
    path = str(tmp_path / "stack.tif")
    pages[0].save(path, save_all=True, append_images=pages[1:])
    v = volmesh.read(path)
    assert v.array.shape == (5, 3, 4)
    assert v.array[2, 1, 3] == 200 + 7
    info = json.loads(subprocess.run([CLI, "info", path, "--json"], capture_output=True,
                                     check=True, text=True).stdout)
    assert info["dims"] == [4, 3, 5]


def test_meshOfANumpyBallIsValidWithItsVolumeAndWorldCoordinates():
    m = volmesh.mesh(ball(), iso=0.0, spacing=(0.5, 0.5, 0.5), origin=(10, 20, 30))
    assert list(m.cells) == ["tetra"]
    assert m.points.shape[1] == 3 and m.points.dtype == np.float64
    q = volmesh.quality(m)
    assert q["inverted"] == 0 and q["boundary_closed"] and q["boundary_euler"] == 2
    assert q["min_dihedral"] >= 15.0
    # radius 0.5 of [-1, 1] over 47 cells = 11.75 voxels = 5.875 world units
    assert q["volume"] == pytest.approx(4 / 3 * np.pi * 5.875 ** 3, rel=0.02)
    centre = m.points.mean(axis=0)
    assert centre == pytest.approx([10 + 23.5 * 0.5, 20 + 23.5 * 0.5, 30 + 23.5 * 0.5], abs=0.1)


def test_meshioRoundTripKeepsPointsCellsAndRegions(tmp_path):
    m = volmesh.mesh(ball(32), iso=0.0, improve=False)
    path = tmp_path / "ball.vtu"
    m.write(path)
    r = meshio.read(path)
    assert np.array_equal(r.points, m.points)
    assert np.array_equal(r.cells_dict["tetra"], m.cells["tetra"])
    back = volmesh.read_mesh(path)
    assert np.array_equal(back.points, m.points)
    mm = m.to_meshio()
    assert isinstance(mm, meshio.Mesh)
    mm.write(tmp_path / "via_meshio.vtu")
    again = volmesh.read_mesh(tmp_path / "via_meshio.vtu")
    assert np.array_equal(again.cells["tetra"], m.cells["tetra"])


def test_labelsMeshEveryChosenLabelWithItsLabelAsCellData(tmp_path):
    m = volmesh.mesh(two_blocks(), labels="all")
    assert set(np.unique(m.cell_data["label"])) == {1, 2}
    assert volmesh.quality(m)["inverted"] == 0
    only2 = volmesh.mesh(two_blocks(), labels=[2])
    assert set(np.unique(only2.cell_data["label"])) == {2}
    path = tmp_path / "blocks.inp"
    m.write(path)
    text = path.read_text()
    assert "*ELEMENT" in text.upper()
    m.write(tmp_path / "blocks.vtu")
    r = meshio.read(tmp_path / "blocks.vtu")
    assert set(np.unique(r.cell_data["region"][0])) == {1, 2}


def test_hexesTrianglesAndTheOtherElementKinds():
    h = volmesh.mesh(ball(24), iso=0.0, elements="hex")
    assert list(h.cells) == ["hexahedron"]
    assert volmesh.quality(h)["inverted"] == 0
    for method in ("dc", "mc", "asc", "cover"):
        s = volmesh.mesh(ball(24), iso=0.0, elements="tri", method=method)
        assert list(s.cells) == ["triangle"], method
        assert volmesh.quality(s)["boundary_euler"] == 2, method
    a = volmesh.mesh(ball(48), iso=0.0, adaptive=True)
    u = volmesh.mesh(ball(48), iso=0.0)
    assert len(a.cells["tetra"]) < len(u.cells["tetra"])


def test_writeEveryFormatTheProgramWrites(tmp_path):
    m = volmesh.mesh(ball(24), iso=0.0)
    for ext in ("vtu", "vtk", "inp", "msh", "mesh"):
        m.write(tmp_path / f"b.{ext}")
        back = volmesh.read_mesh(tmp_path / f"b.{ext}")
        assert len(back.cells["tetra"]) == len(m.cells["tetra"]), ext
    m.write(tmp_path / "q.inp", order=2, deck="static")
    assert "C3D10" in (tmp_path / "q.inp").read_text()
    s = volmesh.mesh(ball(24), iso=0.0, elements="tri")
    for ext in ("stl", "off", "ply", "obj"):
        s.write(tmp_path / f"s.{ext}")
        assert len(volmesh.read_mesh(tmp_path / f"s.{ext}").cells["triangle"]) == len(
            s.cells["triangle"]), ext


def test_vtuCompressLevelsHoldTheSameMeshAndBadOnesAreRefused(tmp_path):
    m = volmesh.mesh(ball(24), iso=0.0)
    sizes = {}
    for level in ("fast", "best", "none", True, False):
        path = tmp_path / f"c-{level}.vtu"
        m.write(path, compress=level)
        sizes[level] = path.stat().st_size
        back = volmesh.read_mesh(path)
        assert np.array_equal(back.cells["tetra"], m.cells["tetra"]), level
        assert np.array_equal(back.points, m.points), level
    assert sizes["fast"] == sizes[True] and sizes["none"] == sizes[False]
    assert sizes["best"] <= sizes["fast"] < sizes["none"]
    for bad in ("zip", 2, None):
        with pytest.raises(ValueError, match="compress"):
            m.write(tmp_path / "bad.vtu", compress=bad)
    assert not (tmp_path / "bad.vtu").exists()


def test_qualityHasTheKeysOfTheProgramsJson(tmp_path):
    m = volmesh.mesh(ball(24), iso=0.0)
    path = tmp_path / "b.vtu"
    m.write(path)
    cli = json.loads(subprocess.run([CLI, "quality", str(path), "--json"], capture_output=True,
                                    check=True, text=True).stdout)
    q = volmesh.quality(m)
    assert set(q) == set(cli)
    assert q["min_dihedral"] == pytest.approx(cli["min_dihedral"])


def test_errorsCarryTheLibrarysOneLineMessage(tmp_path):
    missing = str(tmp_path / "missing.nrrd")
    with pytest.raises(volmesh.Error, match="missing.nrrd"):
        volmesh.read(missing)
    assert issubclass(volmesh.Error, RuntimeError)
    # an empty selection names the data's maximum
    top = f"{float(ball(16).max()):g}"
    with pytest.raises(volmesh.Error, match="data range is .* to " + top.replace(".", r"\.")):
        volmesh.mesh(ball(16), iso=2.0)
    with pytest.raises(volmesh.Error):
        volmesh.mesh(two_blocks(), labels=[7])
    with pytest.raises(volmesh.Error, match="no such folder|cannot|directory"):
        volmesh.mesh(ball(16), iso=0.0).write(tmp_path / "nofolder" / "x.vtu")


def test_badArgumentsRaiseValueErrorOrTypeError():
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16))  # no material
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), iso=0.0, labels="all")
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), iso=0.0, elements="prism")
    with pytest.raises(ValueError):
        volmesh.mesh(np.zeros((4, 4)), iso=0.0)
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), iso=0.0, spacing=(1, 0, 1))
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), range=(None, None))
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), iso=0.0, size=0)
    with pytest.raises(TypeError):
        volmesh.mesh(ball(16), iso=0.0, progress=3)
    with pytest.raises(TypeError):
        volmesh.quality("mesh.vtu")
    with pytest.raises(ValueError):
        volmesh.mesh(ball(16), iso=0.0).write("x.inp", order=3)


def test_progressIsCalledAndItsExceptionStopsTheCall():
    seen = []
    volmesh.mesh(ball(32), iso=0.0, progress=lambda s, d, t: seen.append((s, d, t)))
    assert seen and all(0 <= d <= t for _, d, t in seen)
    assert {"contour", "improve"} <= {s for s, _, _ in seen}

    def boom(stage, done, total):
        raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        volmesh.mesh(ball(32), iso=0.0, progress=boom)


def test_aRaisingProgressCallbackCancelsAndIsNotCalledAgain():
    calls = []

    def boom(stage, done, total):
        calls.append(stage)
        raise ValueError("enough")

    with pytest.raises(ValueError, match="enough"):
        volmesh.mesh(ball(96, radius=0.8), iso=0.0, progress=boom)
    assert calls == ["contour"]  # the run stopped at the exception: no later stage called


def sigint_soon(delay):
    """Sends SIGINT to this process from another thread after delay seconds; returns a list
    that receives the time it was sent."""
    sent = []

    def fire():
        sent.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    threading.Timer(delay, fire).start()
    return sent


def test_ctrlCStopsALongMeshWithKeyboardInterrupt():
    # SIGINT arrives while the library works without the GIL (the first progress call says
    # the run is under way): KeyboardInterrupt from mesh() within seconds (the whole run,
    # 5.6 M tets, took 20 s on two cores under load 8; without the library's cancellation
    # Ctrl-C waited for its end)
    seen, timer = [], []

    def watch(stage, done, total):
        if not timer:
            timer.append(sigint_soon(0.2))
        seen.append((stage, done, total))

    with pytest.raises(KeyboardInterrupt):
        volmesh.mesh(ball(160, radius=0.8), iso=0.0, progress=watch)
    returned = time.monotonic()
    sent = timer[0] if timer else []
    assert sent, "the signal was not sent"
    assert returned - sent[0] < 10.0, returned - sent[0]


CTRL_C_CHILD = """
import sys, time, numpy as np, volmesh
n = int(sys.argv[1])
z, y, x = np.mgrid[-1:1:n * 1j, -1:1:n * 1j, -1:1:n * 1j]
data = (0.8 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
print("meshing", flush=True)
try:
    for _ in range(20):  # far longer than the test waits, unless Ctrl-C stops it
        volmesh.mesh(data, iso=0.0)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
"""


def test_ctrlCStopsAChildPythonWithoutACallback():
    child = subprocess.Popen([sys.executable, "-c", CTRL_C_CHILD, "128"],
                             stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "meshing"
    time.sleep(1.0)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=60)
    took = time.monotonic() - sent
    assert out.strip() == "interrupted", out
    assert child.returncode == 0
    assert took < 10.0, took


def test_theGilIsReleasedWhileA128CubedMeshRuns():
    data = ball(128, radius=0.8)
    count = [0]
    stop = threading.Event()

    def counter():
        while not stop.is_set():
            count[0] += 1
            time.sleep(0.001)

    t = threading.Thread(target=counter)
    t.start()
    time.sleep(0.05)
    before = count[0]
    m = volmesh.mesh(data, iso=0.0, improve=False)
    during = count[0] - before
    stop.set()
    t.join()
    assert len(m.cells["tetra"]) > 100000
    # with the GIL held for the whole call the counter could not move at all
    assert during >= 20, during


def test_threadsKeywordGivesTheSameMesh():
    one = volmesh.mesh(ball(32), iso=0.0, threads=1)
    two = volmesh.mesh(ball(32), iso=0.0, threads=2)
    assert np.array_equal(one.points, two.points)
    assert np.array_equal(one.cells["tetra"], two.cells["tetra"])


def write_nifti_gz(path, labels, spacing=(0.8, 0.8, 1.5), offset=(-10.0, 5.0, 20.0)):
    """A NIfTI-1 .nii.gz of a uint8 label array [z, y, x], with its geometry in the sform."""
    import gzip
    import struct
    nz, ny, nx = labels.shape
    hdr = bytearray(348)
    struct.pack_into("<i", hdr, 0, 348)
    struct.pack_into("<8h", hdr, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", hdr, 70, 2, 8)                    # DT_UINT8, 8 bits
    struct.pack_into("<8f", hdr, 76, 1.0, *spacing, 1, 1, 1, 1)
    struct.pack_into("<f", hdr, 108, 352.0)                   # vox_offset
    struct.pack_into("<hh", hdr, 252, 0, 1)                   # qform 0, sform 1 (scanner)
    struct.pack_into("<4f", hdr, 280, spacing[0], 0, 0, offset[0])
    struct.pack_into("<4f", hdr, 296, 0, spacing[1], 0, offset[1])
    struct.pack_into("<4f", hdr, 312, 0, 0, spacing[2], offset[2])
    hdr[344:348] = b"n+1\0"
    with gzip.open(path, "wb") as fh:
        fh.write(bytes(hdr) + b"\0" * 4 + labels.astype(np.uint8).tobytes())


def test_theTenLinesOfDocsPythonRun(tmp_path, capsys):
    """The example of docs/PYTHON.md, run as written on a segmentation it does not ship."""
    src = os.environ.get("VM_SOURCE_DIR", "")
    doc = open(os.path.join(src, "docs", "PYTHON.md")).read()
    code = doc.split("```python\n", 1)[1].split("```", 1)[0]
    assert 5 <= len(code.strip().splitlines()) <= 10
    write_nifti_gz(tmp_path / "seg.nii.gz", two_blocks())
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        exec(compile(code, "docs/PYTHON.md", "exec"), {})
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "labels [1, 2]" in out
    assert "*ELEMENT" in (tmp_path / "seg.inp").read_text().upper()
    r = meshio.read(tmp_path / "seg.vtu")
    # RAS world coordinates: x is flipped by NIfTI's LPS convention or kept; the extent is
    # 16 voxels of 0.8 along x either way
    assert np.ptp(r.points[:, 0]) == pytest.approx(16 * 0.8, rel=0.1)
    assert np.ptp(r.points[:, 2]) == pytest.approx(16 * 1.5, rel=0.1)


def test_labelEdgeSetsTheDensityOfEachLabel():
    """label_edge={label: L} (world units): the label given the short edge is the denser one,
    both ways round; bad edges raise."""
    a = np.zeros((34, 34, 66), dtype=np.uint8)  # [z, y, x]: two 32^3 blocks
    a[1:33, 1:33, 1:33] = 1
    a[1:33, 1:33, 33:65] = 2
    d = 3 ** 0.5

    def density(m):
        q = volmesh.quality(m)
        assert q["inverted"] == 0
        lab = m.cell_data["label"]
        return [np.count_nonzero(lab == k) for k in (1, 2)]

    fine1 = density(volmesh.mesh(a, labels="all", label_edge={1: d, 2: 16 * d}, improve=False))
    fine2 = density(volmesh.mesh(a, labels="all", label_edge={2: d, 1: 16 * d}, improve=False))
    assert fine1[0] >= 2 * fine1[1] and fine2[1] >= 2 * fine2[0]
    with pytest.raises(ValueError):
        volmesh.mesh(a, labels="all", label_edge={1: 0.0})
    with pytest.raises(ValueError):
        volmesh.mesh(a, iso=0.5, label_edge={1: 2.0})
    with pytest.raises(volmesh.Error, match="label 9"):
        volmesh.mesh(a, labels="all", label_edge={9: 2.0})


def longest_edge(m):
    t = m.cells["tetra"]
    p = m.points
    return max(np.linalg.norm(p[t[:, i]] - p[t[:, j]], axis=1).max()
               for i in range(4) for j in range(i + 1, 4))


def test_gradedSizingKeywordsAreTheProgramsOptions():
    a = ball(64, 0.6)
    uniform = volmesh.mesh(a, iso=0.0, improve=False)
    graded = volmesh.mesh(a, iso=0.0, graded=True)
    stuffed = volmesh.mesh(a, iso=0.0, coarsen=False, improve=False)
    for m in (graded, stuffed):
        q = volmesh.quality(m)
        assert q["inverted"] == 0 and q["boundary_closed"] and q["boundary_euler"] == 2
    assert volmesh.quality(graded)["min_dihedral"] >= 15.0
    n = lambda m: len(m.cells["tetra"])
    assert n(graded) * 4 <= n(stuffed) <= n(uniform)
    bounded = volmesh.mesh(a, iso=0.0, max_edge=3.0)
    assert longest_edge(bounded) <= 3.0 + 1e-9 < longest_edge(graded)
    loose = volmesh.mesh(a, iso=0.0, distance=2.0)
    assert n(loose) < n(graded)
    target = volmesh.mesh(a, iso=0.0, tets=3 * n(graded))
    assert 0.75 * 3 * n(graded) <= n(target) <= 1.25 * 3 * n(graded)
    # a size field of 2 on the left half (x < 32) and 40 on the right
    field = np.full(a.shape, 40.0, dtype=np.float32)
    field[:, :, :32] = 2.0
    sized = volmesh.mesh(a, iso=0.0, size_field=volmesh.Volume(field), improve=False)
    t = sized.cells["tetra"]
    cx = sized.points[t].mean(axis=1)[:, 0]
    assert (cx < 31).sum() >= 4 * (cx > 33).sum()
    with pytest.raises(ValueError):
        volmesh.mesh(a, iso=0.0, distance=0)
    with pytest.raises(ValueError):
        volmesh.mesh(a, iso=0.0, grading=1.0)
    # a plate 3 voxels thick round a ball (tests/mesher/test_mesh_graded.c): with
    # min_layers=2 no tet away from the ball spans it (z extent 0.9 of the thickness), where
    # the default mesh's tets do
    z, y, x = np.mgrid[0:40, 0:40, 0:40].astype(np.float32) - 20.0
    plate = np.maximum(np.minimum(1.5 - np.abs(z), 14.0 - np.hypot(x, y)),
                       8.0 - np.sqrt(x * x + y * y + z * z))
    thin = volmesh.mesh(plate, iso=0.0, graded=True)
    layered = volmesh.mesh(plate, iso=0.0, min_layers=2)
    assert volmesh.quality(layered)["boundary_euler"] == 2
    def span(m):
        p = m.points[m.cells["tetra"]]
        away = np.hypot(p[:, :, 0].mean(axis=1) - 20, p[:, :, 1].mean(axis=1) - 20) > 10
        return (p[away, :, 2].max(axis=1) - p[away, :, 2].min(axis=1)).max()
    assert span(layered) < 0.9 * 3.0 <= span(thin)
    with pytest.raises(ValueError):
        volmesh.mesh(plate, iso=0.0, min_layers=0)
    with pytest.raises(ValueError):
        volmesh.mesh(two_blocks(), labels="all", distance=1.0)
