#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
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

# per-label sizes: label 1 refined to half a voxel, label 3 coarse inside; conforming, volumes kept
out=$("$VM_CLI" mesh seg.raw $raw --labels all --size-per-label 1:0.5,3:4 -o s.vtu --json) || bad "size-per-label: $out"
[ "$(echo "$out" | json "d['inverted'], d['overshared_faces'], d['boundary_closed'], d['cell_size']")" = "0 0 True 0.5" ] && ok || bad "size-per-label valid: $out"
echo "$out" | json "all(abs(l['volume'] - l['voxel_volume']) <= 0.02 * l['voxel_volume'] for l in d['labels']) and [l['size'] for l in d['labels']] == [0.5, 1, 4, 1]" | grep -q True && ok || bad "size-per-label volumes: $out"
base=$("$VM_CLI" mesh seg.raw $raw --labels all -o t.vtu --json --no-improve)
co=$("$VM_CLI" mesh seg.raw $raw --labels all --size-per-label 3:4 -o t.vtu --json --no-improve)
[ "$(echo "$co" | json "d['labels'][2]['elements'] < $(echo "$base" | json "d['labels'][2]['elements']") and d['coarse_cells'] > 0")" = True ] && ok || bad "coarse label has fewer tets: $co"
out=$("$VM_CLI" mesh seg.raw $raw --labels all --adaptive -o u.vtu --json) || bad "adaptive: $out"
[ "$(echo "$out" | json "d['inverted'], d['boundary_closed'], d['elements'] < $(echo "$base" | json "d['elements']")")" = "0 True True" ] && ok || bad "adaptive: $out"
# the quality pass runs by default, per material, and --verbose times every stage
err=$("$VM_CLI" mesh seg.raw $raw --labels all -o v.vtu --verbose 2>&1 >v.txt) || bad "verbose: $err"
for stage in read labels repair mesh improve write; do
    printf '%s\n' "$err" | grep -q "^volmesh: $stage  *[0-9.]* s$" && ok || bad "no $stage time: $err"
done
grep -q "^quality pass: dihedral" v.txt && ok || bad "no quality pass line: $(cat v.txt)"
out=$("$VM_CLI" mesh seg.raw $raw --labels all -o w.vtu --json --no-improve)
echo "$out" | json "'improve' in d" | grep -q False && ok || bad "--no-improve ran the pass: $out"

# labels smaller than a --size cell: 9 and 10 one voxel each in one 3^3 block of background
# (9 takes the block, 10 cannot: it is named as lost), 11 two voxels inside label 1 (kept as
# its block); the count printed is the labels the mesh holds, and the report names the lost
/usr/bin/python3 - <<'PY'
n = 24
b = bytearray(open("seg.raw", "rb").read())
b[0] = 9
b[1 + n * (1 + n * 1)] = 10
b[7 + n * (7 + n * 7)] = 11
b[8 + n * (7 + n * 7)] = 11
open("tiny.raw", "wb").write(bytes(b))
PY
out=$("$VM_CLI" mesh tiny.raw $raw --labels all --size 3 -o k.vtu --json --report k.html 2>k.err) || bad "tiny labels: $out"
[ "$(echo "$out" | json "d['labels_meshed'], d['labels_asked'], d['labels_lost']")" = "6 7 [10]" ] && ok || bad "tiny labels counts: $out"
echo "$out" | json "[l['label'] for l in d['labels'] if l['rescued']]" | grep -qx "\[9, 11\]" && ok || bad "tiny labels rescued: $out"
echo "$out" | json "sum(l['elements'] for l in d['labels']) == d['elements']" | grep -q True && ok || bad "per-label elements sum: $out"
grep -q "warning: label 10 (1 voxel in) has no element and is not in the mesh" k.err && ok || bad "lost label not named: $(cat k.err)"
grep -q "warning: label 11 (2 voxels in) is most frequent in no 3^3 block" k.err && ok || bad "rescued label not named: $(cat k.err)"
/usr/bin/python3 - <<'PY' && ok || bad "k.vtu regions are the labels counted"
import vtk, sys
r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName("k.vtu"); r.Update()
reg = r.GetOutput().GetCellData().GetArray("region")
sys.exit(0 if sorted({int(reg.GetValue(i)) for i in range(reg.GetNumberOfTuples())}) == [1, 2, 3, 7, 9, 11] else 1)
PY
grep -q "<tr class=\"bad\"><td>10</td><td>0 (asked for, not in the mesh)" k.html && grep -q "<li class=\"bad\">label 10 (1 voxel in) has no element" k.html && ok || bad "k.html names label 10"
txt=$("$VM_CLI" mesh tiny.raw $raw --labels all --size 3 -o k.vtu 2>/dev/null)
printf '%s\n' "$txt" | head -1 | grep -q ", 6 labels (of 7 asked for), " && ok || bad "summary count: $txt"
printf '%s\n' "$txt" | grep -q "^  label 10: 0 tets.*(LOST)$" && ok || bad "summary lost line: $txt"
# --min-island names the pieces it relabels, and the labels it removes whole
err=$("$VM_CLI" mesh tiny.raw $raw --labels all --min-island 3 -o m.vtu 2>&1 >m.txt) || bad "min-island: $err"
for l in 9 10 11; do
    printf '%s\n' "$err" | grep -q "warning: label $l ([0-9]* voxels\? in) has no element and is not in the mesh: --min-island relabelled all its pieces" && ok || bad "min-island label $l: $err"
done
head -1 m.txt | grep -q ", 4 labels (of 7 asked for), " && ok || bad "min-island count: $(cat m.txt)"

for args in "--labels 99 -o x.vtu" "--labels 1,x -o x.vtu" "--labels all --iso 0 -o x.vtu" \
            "--iso 0 --min-island 3 -o x.vtu" "--labels 2,99 -o x.inp" \
            "--labels all --size-per-label 99:2 -o x.vtu" "--labels all --size-per-label 1:0 -o x.vtu" \
            "--labels all --size-per-label 1:-2 -o x.vtu" "--labels all --size-per-label 1:x -o x.vtu" \
            "--labels all --size-per-label 1 -o x.vtu" "--labels all --size-per-label 1:2,,3:1 -o x.vtu" \
            "--labels all --size-per-label 3:4 --elements hex -o x.vtu" "--iso 0 --size-per-label 1:2 -o x.vtu"; do
    err=$("$VM_CLI" mesh seg.raw $raw $args 2>&1 >/dev/null); rc=$?
    lines=$(printf '%s\n' "$err" | wc -l)
    if [ $rc = 2 ] && [ "$lines" = 1 ] && [ "${err#volmesh: }" != "$err" ] && [ ! -e x.vtu ] && [ ! -e x.inp ]; then ok; else bad "mesh $args: rc $rc, '$err'"; fi
done
err=$("$VM_CLI" mesh seg.raw $raw --labels 99 -o x.vtu 2>&1)
[ "$err" = "volmesh: seg.raw: mesh: label 99 is not in the volume (labels present: 0-3, 7)" ] && ok || bad "message: $err"
ls *.tmp-* >/dev/null 2>&1 && bad "temp files left" || ok
echo "$pass passed, $fail failed"
[ $fail = 0 ]
