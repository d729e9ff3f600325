#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# `volmesh mesh --elements tri|quad --method M`: every surface format written and read back
# (by volmesh convert and, for VTU/STL/PLY/OBJ, by VTK), the JSON summary of a closed surface
# with the torus's Euler characteristic, and bad requests refused with exit 2, one line and
# no output file.
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }
"$VM_CLI" demo --shape torus --size 32 >/dev/null || bad "demo"

for case in "tri dc" "quad dc" "tri mc"; do
    set -- $case
    for ext in vtu stl off ply obj; do
        out="s-$1-$2.$ext"
        res=$("$VM_CLI" mesh phantom.nrrd --iso 0 --elements "$1" --method "$2" -o "$out" --json --quiet)
        if [ $? != 0 ] || [ ! -s "$out" ]; then bad "$case .$ext: $res"; continue; fi
        [ "$(echo "$res" | json "['closed']")" = True ] && [ "$(echo "$res" | json "['euler']")" = 0 ] &&
            [ "$(echo "$res" | json "['self_intersections']")" = 0 ] && ok || bad "$case .$ext: $res"
        # read back: volmesh quality on the file must see the same closed torus
        q=$("$VM_CLI" quality "$out" --json 2>&1)
        [ "$(echo "$q" | json "['boundary_closed']")" = True ] && [ "$(echo "$q" | json "['boundary_euler']")" = 0 ] && ok || bad "re-read $out: $(echo "$q" | head -c 300)"
    done
done

# the same surface through VTK's readers: triangle counts agree with the summary
res=$("$VM_CLI" mesh phantom.nrrd --iso 0 --elements tri --method mc -o mc.vtu --json --quiet)
faces=$(echo "$res" | json "['faces']")
"$VM_CLI" mesh phantom.nrrd --iso 0 --elements tri --method mc -o mc.stl --quiet >/dev/null
/usr/bin/python3 - "$faces" <<'PY' && ok || bad "VTK reads a different mc surface"
import sys, vtk
want = int(sys.argv[1])
u = vtk.vtkXMLUnstructuredGridReader(); u.SetFileName("mc.vtu"); u.Update()
s = vtk.vtkSTLReader(); s.SetFileName("mc.stl"); s.Update()
got = (u.GetOutput().GetNumberOfCells(), s.GetOutput().GetNumberOfCells())
sys.exit(0 if got == (want, want) else print(got, want) or 1)
PY

# text summary names the method and says closed
line=$("$VM_CLI" mesh phantom.nrrd --iso 0 --elements tri --method mc -o t.off --quiet)
case "$line" in *"mc "*"triangles"*"closed (Euler 0)"*"0 self-intersections"*"min angle"*) ok ;; *) bad "summary: $line" ;; esac

# methods not built yet refuse cleanly (asc and cover are other engineers' work)
for m in asc cover; do
    err=$("$VM_CLI" mesh phantom.nrrd --iso 0 --elements tri --method $m -o x.stl 2>&1 >/dev/null); rc=$?
    case "$rc:$err" in 2:"volmesh: phantom.nrrd: "*) ok ;; 0:*) ok ;; *) bad "--method $m: rc $rc, '$err'" ;; esac
done
rm -f x.stl

for args in "--iso 0 --elements quad --method mc -o x.stl" "--iso 0 --elements tri --method marching -o x.stl" \
            "--iso 0 --elements tri --method mc --error 0 -o x.stl" "--iso 99 --elements tri --method mc -o x.stl" \
            "--iso 99 --elements tri -o x.stl" "--iso 0 --method mc -o x.vtu" \
            "--iso 0 --elements tri --adaptive -o x.vtu" "--iso 0 --elements tri --method mc --error -1 -o x.stl"; do
    err=$("$VM_CLI" mesh phantom.nrrd $args 2>&1 >/dev/null); rc=$?
    lines=$(printf '%s\n' "$err" | wc -l)
    if [ $rc = 2 ] && [ "$lines" = 1 ] && [ "${err#volmesh: }" != "$err" ] && [ ! -e x.stl ] && [ ! -e x.vtu ]; then ok; else bad "mesh $args: rc $rc, '$err'"; fi
done
ls *.tmp-* >/dev/null 2>&1 && bad "temp files left" || ok
echo "$pass passed, $fail failed"
[ $fail = 0 ]
