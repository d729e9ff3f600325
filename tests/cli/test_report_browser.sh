#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The HTML report as a user sees it: `volmesh demo` writes demo-report.html; headless
# Chromium renders it to a screenshot, which must show the mesh pictures (mesh-coloured
# pixels in the picture area) and no broken images.
set -u
chromium=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chromium" ]; then
    echo "skipped: chromium is not installed (scripts/deps.sh --tests installs it)"
    exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
"$VM_CLI" demo --size 32 >/dev/null || { echo "demo failed"; echo "0 passed, 1 failed"; exit 1; }
timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$work/profile" --window-size=1100,2400 \
    --screenshot="$work/shot.png" "file://$work/demo-report.html" >/dev/null 2>&1
/usr/bin/python3 - "$work/shot.png" "$work/demo-report.html" <<'PY'
import sys, vtk
from vtk.util.numpy_support import vtk_to_numpy
fails = []
html = open(sys.argv[2]).read()
if html.count("data:image/png;base64,") != 2: fails.append("expected two inline pictures")
if "<svg" not in html: fails.append("no inline histogram SVG")
if "http://" in html.replace("http://www.w3.org", "") or "https://" in html:
    fails.append("the page refers to the network")
r = vtk.vtkPNGReader(); r.SetFileName(sys.argv[1]); r.Update()
img = r.GetOutput()
if img.GetNumberOfPoints() == 0:
    fails.append("no screenshot")
else:
    w, h, _ = img.GetDimensions()
    px = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(h, w, -1)[::-1, :, :3].astype(int)
    # mesh faces are shades of tan: red > green > blue, clearly coloured
    tan = (px[:, :, 0] > px[:, :, 2] + 40) & (px[:, :, 1] > px[:, :, 2] + 15)
    rows = tan.any(axis=1).nonzero()[0]
    print("screenshot %dx%d, %d mesh-coloured pixels in rows %s..%s" %
          (w, h, tan.sum(), rows.min() if len(rows) else "-", rows.max() if len(rows) else "-"))
    if tan.sum() < 20000: fails.append("the pictures do not show (only %d mesh pixels)" % tan.sum())
for f in fails: print("FAIL:", f)
print("%d passed, %d failed" % (0 if fails else 1, len(fails)))
sys.exit(1 if fails else 0)
PY
