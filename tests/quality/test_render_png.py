# SPDX-License-Identifier: BSD-3-Clause
"""tests/quality/test_render_png.py — an independent judge of volmesh's PNG encoder.

Runs tests/quality/test_render.c (its binary) with a private VM_TEST_TMP so that it writes
render_torus.png / .rgb (a rendered mesh) and render_card.png / .rgb (a synthetic test card),
then decodes each PNG twice — by hand from the specification (chunks, CRC-32, zlib, the five
filter types) and with VTK's vtkPNGReader (libpng) — and compares with the raw RGB dump.
"""
import os
import struct
import subprocess
import sys
import zlib

import numpy as np

SKIP = 77


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def read_chunks(data):
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail("bad PNG signature")
    at, chunks = 8, []
    while at < len(data):
        if at + 12 > len(data):
            fail("truncated chunk at byte %d" % at)
        (n,) = struct.unpack(">I", data[at:at + 4])
        ctype, body = data[at + 4:at + 8], data[at + 8:at + 8 + n]
        (crc,) = struct.unpack(">I", data[at + 8 + n:at + 12 + n])
        if zlib.crc32(ctype + body) & 0xFFFFFFFF != crc:
            fail("CRC mismatch in chunk %r" % ctype)
        chunks.append((ctype, body))
        at += 12 + n
    return chunks


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    if pa <= pb and pa <= pc:
        return a
    return b if pb <= pc else c


def decode_by_hand(data):
    chunks = read_chunks(data)
    types = [t for t, _ in chunks]
    if types[0] != b"IHDR" or types[-1] != b"IEND" or b"IDAT" not in types:
        fail("chunk order %r" % types)
    w, h, depth, colour, comp, filt, inter = struct.unpack(">IIBBBBB", chunks[0][1])
    if (depth, colour, comp, filt, inter) != (8, 2, 0, 0, 0):
        fail("IHDR says %r, expected 8-bit RGB" % ((depth, colour, comp, filt, inter),))
    raw = zlib.decompress(b"".join(b for t, b in chunks if t == b"IDAT"))
    stride = 3 * w
    if len(raw) != h * (stride + 1):
        fail("inflated %d bytes, expected %d" % (len(raw), h * (stride + 1)))
    out = bytearray(h * stride)
    used = set()
    for y in range(h):
        ftype = raw[y * (stride + 1)]
        used.add(ftype)
        row = raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)]
        base = y * stride
        for i in range(stride):
            a = out[base + i - 3] if i >= 3 else 0
            b = out[base - stride + i] if y else 0
            c = out[base - stride + i - 3] if y and i >= 3 else 0
            if ftype == 0:
                pred = 0
            elif ftype == 1:
                pred = a
            elif ftype == 2:
                pred = b
            elif ftype == 3:
                pred = (a + b) // 2
            elif ftype == 4:
                pred = paeth(a, b, c)
            else:
                fail("row %d has filter type %d" % (y, ftype))
            out[base + i] = (row[i] + pred) & 255
    return w, h, bytes(out), used


def decode_with_vtk(path):
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        return None
    r = vtk.vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    im = r.GetOutput()
    w, h, _ = im.GetDimensions()
    arr = vtk_to_numpy(im.GetPointData().GetScalars()).reshape(h, w, -1)
    return arr[::-1]  # VTK's rows run bottom-up


def main():
    cli = os.environ.get("VM_CLI")
    tmp = os.environ.get("VM_TEST_TMP", ".")
    if not cli:
        print("skipped: VM_CLI not set (run through ctest)")
        return SKIP
    binary = os.path.join(os.path.dirname(cli), "tests", "quality_test_render")
    if not os.path.exists(binary):
        print("skipped: %s not built" % binary)
        return SKIP
    work = os.path.join(tmp, "render_png_py")
    os.makedirs(work, exist_ok=True)
    env = dict(os.environ, VM_TEST_TMP=work)
    run = subprocess.run([binary], cwd=work, env=env, capture_output=True, text=True)
    if run.returncode != 0:
        fail("%s exited %d:\n%s%s" % (binary, run.returncode, run.stdout, run.stderr))

    for name, size in (("render_torus", (320, 200)), ("render_card", (67, 45))):
        png = os.path.join(work, name + ".png")
        with open(png, "rb") as f:
            data = f.read()
        with open(os.path.join(work, name + ".rgb"), "rb") as f:
            want = f.read()
        w, h, got, used = decode_by_hand(data)
        if (w, h) != size:
            fail("%s: %dx%d, expected %dx%d" % (name, w, h, size[0], size[1]))
        if got != want:
            diff = sum(1 for a, b in zip(got, want) if a != b)
            fail("%s: %d bytes differ from the raw dump" % (name, diff))
        if name == "render_card" and len(used) < 3:
            fail("%s: only filter types %r used" % (name, sorted(used)))
        if name == "render_torus":
            px = np.frombuffer(got, dtype=np.uint8).reshape(h, w, 3)
            if (px == 255).all(axis=2).all() or not (px == 255).all(axis=2).any():
                fail("render_torus: expected an object on a white background")
        arr = decode_with_vtk(png)
        if arr is not None:
            if arr.shape[2] != 3 or arr.tobytes() != want:
                fail("%s: vtkPNGReader disagrees with the raw dump" % name)
        print("%s.png: %dx%d, %d bytes, filters %s, CRCs and pixels match%s" % (
            name, w, h, len(data), sorted(used), "" if arr is None else " (also VTK)"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
