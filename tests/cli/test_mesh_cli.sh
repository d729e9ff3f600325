#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# `volmesh mesh` as a user runs it: the quality pass on by default, --no-improve, adaptive,
# hexahedra, --quality-fields, --denoise, interval volumes, and bad options.
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }
"$VM_CLI" demo --shape torus --size 40 >/dev/null || bad "demo"

out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o t.vtu --json) || bad "mesh default"
[ "$(echo "$out" | json "['inverted']")" = 0 ] && ok || bad "inverted: $out"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "torus Euler: $out"
md=$(echo "$out" | json "['min_dihedral']")
/usr/bin/python3 -c "import sys; sys.exit(0 if $md >= 15 else 1)" && ok || bad "improved min dihedral $md < 15"
raw=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o r.vtu --json --no-improve | json "['min_dihedral']")
/usr/bin/python3 -c "import sys; sys.exit(0 if $raw <= $md else 1)" && ok || bad "--no-improve $raw above $md"
# the torus comes out of the mesher meeting the targets (the lift); the genus-3 does not,
# and --no-improve leaves it so
mkdir g3 && (cd g3 && "$VM_CLI" demo --shape genus3 --size 40 >/dev/null) || bad "demo genus3"
g3=$("$VM_CLI" mesh g3/phantom.nrrd --iso 0 -o g3/t.vtu --json | json "['min_dihedral']")
g3raw=$("$VM_CLI" mesh g3/phantom.nrrd --iso 0 -o g3/r.vtu --json --no-improve | json "['min_dihedral']")
/usr/bin/python3 -c "import sys; sys.exit(0 if $g3raw < 15 <= $g3 else 1)" && ok ||
    bad "genus-3: --no-improve $g3raw, improved $g3 (want under 15, then 15 or more)"

out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o a.vtu --adaptive --json) || bad "adaptive"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "adaptive Euler: $out"

out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o h.vtu --elements hex --json) || bad "hex"
[ "$(echo "$out" | json "['inverted']")" = 0 ] && [ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "hex: $out"

"$VM_CLI" mesh phantom.nrrd --iso 0 -o q.vtu --quality-fields --quiet >/dev/null || bad "quality fields"
# --verbose times every stage of a run with a report (which measures the distance to the
# isosurface), in order, one line each
err=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o v.vtu --report v.html --verbose 2>&1 >/dev/null) ||
    bad "verbose: $err"
stages=$(printf '%s\n' "$err" | sed -n 's/^volmesh: \([a-z]*\) .* s$/\1/p' | tr '\n' ' ')
[ "$stages" = "read mesh improve write check distance report " ] || bad "verbose stages: '$stages'"
/usr/bin/python3 - <<'PY' && ok || bad "quality fields missing in q.vtu"
import vtk, sys
r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName("q.vtu"); r.Update()
cd = r.GetOutput().GetCellData()
names = [cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())]
sys.exit(0 if "min_dihedral" in names and "region" in names else 1)
PY

out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o d.vtu --denoise bilateral --json) || bad "denoise"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "denoised Euler: $out"

out=$("$VM_CLI" mesh phantom.nrrd --range -2:2 -o s.vtu --json) || bad "range"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "shell Euler: $out"

# Raw hexes of the CT bone keep inverted elements (the quality pass untangles them): the
# mesh is written, a warning names it and the exit status is 1.
ct="${VM_SHARED_DATA:-}/ct_head_quarter.nrrd"
if [ -f "$ct" ]; then
    err=$("$VM_CLI" mesh "$ct" --iso 1150 --elements hex --no-improve -o raw-hex.vtu --quiet 2>&1 >/dev/null); rc=$?
    case "$rc:$err" in 1:*"inverted element"*) ok ;; *) bad "raw hexes: rc $rc, '$err'" ;; esac
    "$VM_CLI" mesh "$ct" --iso 1150 --elements hex -o hex.vtu --quiet >/dev/null && ok || bad "improved CT hexes exit non-zero"
else
    echo "note: no shared data, the raw CT hex case is skipped"
fi

# --max-memory: a generous limit changes nothing; a tight one refuses before meshing (the
# torus has about 8200 inside voxels: ~9 MB by the estimate), naming the remedy; a limit
# below the volume itself is refused while reading.
out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o m.vtu --max-memory 2G --json) || bad "--max-memory 2G"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "--max-memory 2G: $out"
err=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o x.vtu --max-memory 4M 2>&1 >/dev/null)
case "$err" in *"more than --max-memory"*"try --size 2"*) ok ;; *) bad "--max-memory 4M: '$err'" ;; esac
# adaptive runs are estimated from the grid and the boundary cells: the remedy offered is
# --size 2 only, and a limit the estimate fits passes
err=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o x.vtu --adaptive --max-memory 4M 2>&1 >/dev/null)
case "$err" in *"needs about "*" MiB"*"more than --max-memory 4.0 MiB: try --size 2 (about 8x less)") ok ;;
    *) bad "--adaptive --max-memory 4M: '$err'" ;; esac
[ ! -e x.vtu ] && ok || bad "--adaptive --max-memory 4M wrote x.vtu"
out=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o a.vtu --adaptive --no-improve --max-memory 64M --json) ||
    bad "--adaptive --max-memory 64M"
[ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok || bad "--adaptive --max-memory 64M: $out"

for args in "--iso 0 -o x.vtu --denoise blur" "--iso 0 -o x.vtu --elements prism" "--iso 99 -o x.vtu" \
            "--iso 0" "--iso 0 --range 1:2 -o x.vtu" "--iso 0 -o x.vtu --max-level 0 --adaptive" \
            "--iso 0 -o x.vtu --max-memory 4M" "--iso 0 -o x.vtu --max-memory 1.5M" \
            "--iso 0 -o x.vtu --max-memory lots" "--iso 0 -o x.vtu --max-memory 0" \
            "--iso 0 -o x.vtu --elements hex --adaptive --max-level 11" \
            "--iso 0 -o x.vtu --elements hex --adaptive --error -1" \
            "--iso 0 -o x.vtu --elements hex --adaptive --error nan" \
            "--iso 0 -o x.vtu --elements hex --error 0.5"; do
    err=$("$VM_CLI" mesh phantom.nrrd $args 2>&1 >/dev/null); rc=$?
    lines=$(printf '%s\n' "$err" | wc -l)
    if [ $rc = 2 ] && [ "$lines" = 1 ] && [ "${err#volmesh: }" != "$err" ] && [ ! -e x.vtu ]; then ok; else bad "mesh $args: rc $rc, '$err'"; fi
done
ls *.tmp-* >/dev/null 2>&1 && bad "temp files left" || ok
echo "$pass passed, $fail failed"
[ $fail = 0 ]
