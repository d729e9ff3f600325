# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_distance_cli.sh — what the reports say about size and fidelity: `mesh
# --distance-check` (text and JSON) and `mesh --report`, `quality --volume` and `report
# --volume` (the two-sided distance to the isosurface in world units), the edge-length
# histogram, the cells per label, and the refusals of options that do not go together.
#
# Run by ctest as `bash test_distance_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u
if [ -z "${VM_CLI:-}" ] || [ ! -x "$VM_CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_distance_cli.XXXXXX") || exit 1
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

# A sphere of radius 6 (world units) in a 32^3 NRRD with spacing 0.5 and an origin: the field
# is the signed distance R - |x - c| in world units, so --iso t is the sphere of radius 6 - t.
/usr/bin/python3 - <<'PY'
import math, struct
n, h, o = 32, 0.5, (10.0, -4.0, 3.0)
c = [o[a] + h * (n - 1) / 2 for a in range(3)]
vals = []
for k in range(n):
    for j in range(n):
        for i in range(n):
            x = (o[0] + h * i - c[0], o[1] + h * j - c[1], o[2] + h * k - c[2])
            vals.append(6.0 - math.sqrt(sum(t * t for t in x)))
hdr = ("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\nspace dimension: 3\n"
       "space directions: (%g,0,0) (0,%g,0) (0,0,%g)\nspace origin: (%g,%g,%g)\n"
       "encoding: raw\nendian: little\n\n" % (n, n, n, h, h, h, *o))
open("sphere.nrrd", "wb").write(hdr.encode() + struct.pack("<%df" % len(vals), *vals))
n = 24
out = bytearray(n * n * n)
for k in range(n):
    for j in range(n):
        for i in range(n):
            v = 0
            if 4 <= i < 16 and 4 <= j < 16 and 4 <= k < 16:
                v = 3 if i >= 10 else (1 if j < 10 else 2)
            elif 18 <= i < 22 and 18 <= j < 22 and 18 <= k < 22:
                v = 7
            out[i + n * (j + n * k)] = v
open("seg.raw", "wb").write(bytes(out))
PY

# --- mesh --distance-check: a line after the summary, or a JSON key -------------------------
out=$("$VM_CLI" mesh sphere.nrrd --iso 0 -o s.vtu --distance-check --quiet) || bad "mesh --distance-check: $out"
line=$(echo "$out" | grep '^distance to the isosurface: Hausdorff ')
[ -n "$line" ] && ok || bad "distance line: $out"
h=$(echo "$line" | sed 's/.*Hausdorff \([0-9.e+-]*\).*/\1/')
/usr/bin/python3 -c "import sys; sys.exit(0 if 0 < float('$h') <= 0.25 else 1)" && ok ||
    bad "within half a voxel (0.25): $line"
out=$("$VM_CLI" mesh sphere.nrrd --iso 0 -o s.vtu --distance-check --json) || bad "--json: $out"
echo "$out" | json "d['surface_distance']['hausdorff'] <= 0.25 and d['surface_distance']['mesh_samples'] > 1000 and d['surface_distance']['surface_samples'] > 1000 and d['elements'] > 0" |
    grep -q True && ok || bad "JSON surface_distance: $out"
out=$("$VM_CLI" mesh sphere.nrrd --iso 0 -o s.vtu --json) || bad "plain mesh: $out"
echo "$out" | json "'surface_distance' in d" | grep -q False && ok || bad "no distance unless asked: $out"
# hexes too
out=$("$VM_CLI" mesh sphere.nrrd --iso 0 --elements hex -o x.vtu --distance-check --json) || bad "hex: $out"
echo "$out" | json "d['surface_distance']['hausdorff'] <= 0.375" | grep -q True && ok || bad "hex distance: $out"

# --- mesh --report: the HTML gives the distance both ways, the edges, no regions table ------
"$VM_CLI" mesh sphere.nrrd --iso 0 -o s.vtu --report r.html --quiet >/dev/null || bad "mesh --report"
grep -q 'Distance to the isosurface' r.html && grep -q 'boundary &rarr; isosurface' r.html &&
    grep -q 'isosurface &rarr; boundary' r.html && ok || bad "report has the distance"
grep -q 'edge length (each edge once)' r.html && grep -q 'edge_length' r.html && ok || bad "report has edge lengths"
grep -q '<h2>Regions</h2>' r.html && bad "one region: no regions table" || ok

# --- quality --volume: text, JSON, --require on the distance keys ---------------------------
out=$("$VM_CLI" quality s.vtu --volume sphere.nrrd --iso 0 --quiet) || bad "quality --volume: $out"
echo "$out" | grep -q '^distance     Hausdorff ' && ok || bad "quality text distance: $out"
echo "$out" | grep -q '^edges        [0-9]*, length ' && ok || bad "quality text edges: $out"
echo "$out" | grep -q '^edge_length (each edge once' && ok || bad "quality text edge histogram: $out"
"$VM_CLI" quality s.vtu --volume sphere.nrrd --iso 0 --require "hausdorff<=0.25" \
    --require "surface_to_mesh_mean<=0.1" --quiet >/dev/null && ok || bad "require met"
"$VM_CLI" quality s.vtu --volume sphere.nrrd --iso 0 --require "hausdorff<=0.00001" --quiet \
    >/dev/null 2>err.txt
[ $? -eq 1 ] && grep -q 'requirement not met: hausdorff' err.txt && ok || bad "require unmet: $(cat err.txt)"
"$VM_CLI" quality s.vtu --require "hausdorff<=1" --quiet >/dev/null 2>err.txt
[ $? -eq 2 ] && grep -q "no key 'hausdorff'" err.txt && ok || bad "hausdorff needs --volume: $(cat err.txt)"
# the same mesh against the isosurface 1 inside: about 1 away, both ways
out=$("$VM_CLI" quality s.vtu --volume sphere.nrrd --iso 1 --json --quiet) || bad "iso 1: $out"
echo "$out" | json "abs(d['surface_distance']['mesh_to_surface_mean'] - 1) < 0.05 and abs(d['surface_distance']['surface_to_mesh_mean'] - 1) < 0.05 and abs(d['surface_distance']['hausdorff'] - 1) < 0.3" |
    grep -q True && ok || bad "moved isosurface: $out"
# --range and --invert select the same surface from the other side
out=$("$VM_CLI" quality s.vtu --volume sphere.nrrd --range 0: --json --quiet) || bad "range: $out"
echo "$out" | json "d['surface_distance']['hausdorff'] <= 0.25" | grep -q True && ok || bad "range: $out"
out=$("$VM_CLI" quality s.vtu --volume sphere.nrrd --iso 0 --invert --json --quiet) || bad "invert: $out"
echo "$out" | json "d['surface_distance']['hausdorff'] <= 0.25" | grep -q True && ok || bad "invert: $out"
# edge lengths in JSON: world units (spacing 0.5), the histogram holds every edge
echo "$out" | json "d['edges'] > 0 and sum(d['edge_length']['histogram']['counts']) == d['edges'] and 0 < d['edge_length']['min'] <= d['edge_length']['mean'] <= d['edge_length']['max'] < 2 and len(d['edge_length']['histogram']['counts']) == 20" |
    grep -q True && ok || bad "JSON edge_length: $out"

# --- report --volume -----------------------------------------------------------------------
"$VM_CLI" report s.vtu -o q.html --volume sphere.nrrd --iso 0 --quiet >/dev/null && ok || bad "report --volume"
grep -q 'Distance to the isosurface' q.html && ok || bad "report --volume has the distance"
"$VM_CLI" report s.vtu -o q2.html --quiet >/dev/null && ok || bad "report"
grep -q 'Distance to the isosurface' q2.html && bad "no distance without --volume" || ok

# --- cells per label ---------------------------------------------------------------------
raw="--raw-dims 24x24x24 --raw-type uint8 --raw-spacing 1,1,2"
out=$("$VM_CLI" mesh seg.raw $raw --labels all -o l.vtu --report l.html --json) || bad "labels: $out"
out=$("$VM_CLI" quality l.vtu --json --quiet) || bad "quality labels: $out"
echo "$out" | json "d['regions'] == 4 and [r['region'] for r in d['cells_per_region']] == [1, 2, 3, 7] and sum(r['cells'] for r in d['cells_per_region']) == d['elements'] and d['surface_distance'] is None" |
    grep -q True && ok || bad "cells per region: $out"
out=$("$VM_CLI" quality l.vtu --quiet) || bad "quality labels text"
echo "$out" | grep -q '^regions      4' && echo "$out" | grep -q '^  region 7 ' && ok || bad "text regions: $out"
grep -q '<h2>Regions</h2>' l.html && ok || bad "label report has the regions table"
"$VM_CLI" quality l.vtu --require "regions==4" --quiet >/dev/null && ok || bad "require regions"

# --- refusals ------------------------------------------------------------------------------
refuse() { # NAME WORD CMD...: exit 2 with a "volmesh: " line naming WORD
    local name=$1 word=$2
    shift 2
    "$@" >o.txt 2>e.txt
    local rc=$?
    [ $rc -eq 2 ] && grep -q '^volmesh: ' e.txt && grep -qF -- "$word" e.txt && ok ||
        bad "$name: exit $rc, $(cat e.txt)"
}
refuse "iso without volume" "--volume" "$VM_CLI" quality s.vtu --iso 0
refuse "volume without iso" "--iso" "$VM_CLI" quality s.vtu --volume sphere.nrrd
refuse "iso and range" "exactly one" "$VM_CLI" report s.vtu -o z.html --volume sphere.nrrd --iso 0 --range 0:
refuse "missing volume" "missing.nrrd" "$VM_CLI" quality s.vtu --volume missing.nrrd --iso 0
refuse "distance-check with labels" "--distance-check" "$VM_CLI" mesh seg.raw $raw --labels all -o z.vtu --distance-check
refuse "distance-check with slabs" "--distance-check" "$VM_CLI" mesh sphere.nrrd --iso 0 --slabs 2 -o z.vtu --distance-check

echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
