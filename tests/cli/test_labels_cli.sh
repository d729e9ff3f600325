#!/usr/bin/env bash
# `volmesh mesh --labels` as a user runs it: a small segmentation (three blocks meeting on one
# line, plus a separate block of label 7) meshed into every format with the labels carried,
# a subset of labels, and the refusals (absent label, bad list, mixed options).
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }
/usr/bin/python3 - <<'PY'
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
raw="--raw-dims 24x24x24 --raw-type uint8 --raw-spacing 1,1,2"

out=$("$VM_CLI" mesh seg.raw $raw --labels all -o a.vtu --json) || bad "labels all: $out"
[ "$(echo "$out" | json "d['inverted'], d['overshared_faces'], d['boundary_closed']")" = "0 0 True" ] && ok || bad "valid: $out"
[ "$(echo "$out" | json "[l['label'] for l in d['labels']]")" = "[1, 2, 3, 7]" ] && ok || bad "labels: $out"
echo "$out" | json "all(abs(l['volume'] - l['voxel_volume']) <= 0.02 * l['voxel_volume'] for l in d['labels'])" | grep -q True && ok || bad "volumes: $out"
echo "$out" | json "[l['meshed_voxels'] for l in d['labels']] == [432, 432, 864, 64] and d['labels'][3]['voxel_volume'] == 128" | grep -q True && ok || bad "voxel counts: $out"
/usr/bin/python3 - <<'PY' && ok || bad "a.vtu region array"
import vtk, sys
r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName("a.vtu"); r.Update()
reg = r.GetOutput().GetCellData().GetArray("region")
sys.exit(0 if sorted({int(reg.GetValue(i)) for i in range(reg.GetNumberOfTuples())}) == [1, 2, 3, 7] else 1)
PY

"$VM_CLI" mesh seg.raw $raw --labels 1,3 -o b.inp --quiet >/dev/null || bad "labels 1,3"
grep -q "^\*ELSET, ELSET=REGION_1$" b.inp && grep -q "^\*ELSET, ELSET=REGION_3$" b.inp && ! grep -q "REGION_2" b.inp && ok || bad "b.inp element sets"
grep -q "^\*SURFACE, NAME=IFACE_REGION_1_REGION_3, TYPE=ELEMENT$" b.inp && ok || bad "b.inp interface surface"

"$VM_CLI" mesh seg.raw $raw --labels 1-3 --elements hex -o c.msh --quiet >/dev/null || bad "hex msh"
grep -q '"REGION_2"' c.msh && ! grep -q '"REGION_7"' c.msh && ok || bad "c.msh physical groups"
"$VM_CLI" mesh seg.raw $raw --labels all -o d.mesh --quiet >/dev/null || bad "medit"
out=$("$VM_CLI" quality d.mesh --json 2>&1) && [ "$(echo "$out" | json "d['inverted']")" = 0 ] && ok || bad "quality of d.mesh: $out"

out=$("$VM_CLI" mesh seg.raw $raw --labels all --size 2 --no-smooth -o e.vtu --json) || bad "size 2"
echo "$out" | json "abs(d['volume'] - sum(l['voxel_volume'] for l in d['labels'])) < 1e-6" | grep -q True && ok || bad "staircase volume: $out"

for args in "--labels 99 -o x.vtu" "--labels 1,x -o x.vtu" "--labels all --iso 0 -o x.vtu" \
            "--iso 0 --min-island 3 -o x.vtu" "--labels all --adaptive -o x.vtu" "--labels 2,99 -o x.inp"; do
    err=$("$VM_CLI" mesh seg.raw $raw $args 2>&1 >/dev/null); rc=$?
    lines=$(printf '%s\n' "$err" | wc -l)
    if [ $rc = 2 ] && [ "$lines" = 1 ] && [ "${err#volmesh: }" != "$err" ] && [ ! -e x.vtu ] && [ ! -e x.inp ]; then ok; else bad "mesh $args: rc $rc, '$err'"; fi
done
err=$("$VM_CLI" mesh seg.raw $raw --labels 99 -o x.vtu 2>&1)
[ "$err" = "volmesh: seg.raw: mesh: label 99 is not in the volume (labels present: 0-3, 7)" ] && ok || bad "message: $err"
ls *.tmp-* >/dev/null 2>&1 && bad "temp files left" || ok
echo "$pass passed, $fail failed"
[ $fail = 0 ]
