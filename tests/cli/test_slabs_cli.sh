#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# `volmesh mesh --slabs N|auto`: meshing slab after slab writes the whole volume's mesh tet
# for tet (judged by VTK + numpy: the same points, the same tets with the same node order and
# regions, in any order) from a gzip NRRD (the demo phantom), uniform, adaptive and at
# --size 2, with 0 inverted and a closed boundary of the torus's Euler characteristic; the
# quality pass still runs, without a read of the whole volume (one pass: all the planes from
# the reader; by parts: each part's); auto picks slabs within a quarter of
# --max-memory and one slab without it; bad counts, options that do not go with slabs, a
# budget too small and a file truncated after its first slabs exit 2 with one line naming
# the problem and leave no output file.
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }
"$VM_CLI" demo --shape torus --size 40 >/dev/null || bad "demo"

# same A.vtu B.vtu: the same points and tets (corners in node order, region), in any order
same() { /usr/bin/python3 "${VM_SOURCE_DIR:?}/tests/cli/same_tets.py" "$1" "$2" >/dev/null; }

# The whole mesh and the slabs' (--no-improve), for each set of options.
for opts in "" "--adaptive --max-level 2" "--size 2"; do
    "$VM_CLI" mesh phantom.nrrd --iso 0 --no-improve $opts -o whole.vtu --quiet >/dev/null ||
        bad "whole $opts"
    for n in 2 3 7; do
        out=$("$VM_CLI" mesh phantom.nrrd --iso 0 --no-improve $opts --slabs $n -o s.vtu --json) ||
            { bad "--slabs $n $opts: $out"; continue; }
        [ "$(echo "$out" | json "['inverted']")" = 0 ] &&
            [ "$(echo "$out" | json "['boundary_closed']")" = True ] &&
            [ "$(echo "$out" | json "['boundary_euler']")" = 0 ] && ok ||
            bad "--slabs $n $opts: $out"
        res=$(same whole.vtu s.vtu 2>&1) && ok || bad "--slabs $n $opts: $res"
    done
done

# The quality pass runs after slabs too (reading its planes from the file, no read stage).
err=$("$VM_CLI" mesh phantom.nrrd --iso 0 --slabs 3 -o i.vtu --json --verbose 2>&1 >i.json) ||
    bad "--slabs 3 with the quality pass: $err"
md=$(json "['min_dihedral']" <i.json)
/usr/bin/python3 -c "import sys; sys.exit(0 if $md >= 15 else 1)" && ok || bad "--slabs 3 improved: $md"
stages=$(printf '%s\n' "$err" | sed -n 's/^volmesh: \([a-z]*\) .* s$/\1/p' | tr '\n' ' ')
[ "$stages" = "mesh improve write check " ] && ok || bad "--slabs stages: '$stages'"
# by parts, each part reading its own planes
err=$("$VM_CLI" --threads 2 mesh phantom.nrrd --iso 0 --slabs 3 --improve-parts 3 -o p.vtu --json \
    2>&1 >p.json) || bad "--slabs 3 --improve-parts 3: $err"
md=$(json "['min_dihedral']" <p.json)
inv=$(json "['inverted']" <p.json)
eul=$(json "['boundary_euler']" <p.json)
closed=$(json "['boundary_closed']" <p.json)
vol=$(json "['volume']" <p.json)
"$VM_CLI" mesh phantom.nrrd --iso 0 --improve-parts 3 -o w.vtu --json 2>/dev/null >w.json ||
    bad "--improve-parts 3 without slabs"
wvol=$(json "['volume']" <w.json)
[ "$inv" = 0 ] && [ "$eul" = 0 ] && [ "$closed" = True ] &&
    /usr/bin/python3 -c "import sys; sys.exit(0 if $md >= 15 and abs($vol - $wvol) <= 0.005 * $wvol else 1)" &&
    ok || bad "--slabs 3 --improve-parts 3: min dihedral $md, $inv inverted, Euler $eul, closed $closed, volume $vol against $wvol"

# auto: one slab without --max-memory (the very run without --slabs); slabs within a quarter
# of the limit with it (96^3 floats: 36 KiB a plane, 3.4 MiB in all; 8M: 56 planes at most)
"$VM_CLI" mesh phantom.nrrd --iso 0 --no-improve -o whole.vtu --quiet >/dev/null
"$VM_CLI" mesh phantom.nrrd --iso 0 --no-improve --slabs auto -o auto.vtu --quiet >/dev/null &&
    cmp -s whole.vtu auto.vtu && ok || bad "--slabs auto without --max-memory is not the whole run"
mkdir s && (cd s && "$VM_CLI" demo --shape sphere --size 96 >/dev/null) && mv s/phantom.nrrd sphere.nrrd ||
    bad "demo 96"
"$VM_CLI" mesh sphere.nrrd --iso 0 --no-improve --size 2 -o whole.vtu --quiet >/dev/null
err=$("$VM_CLI" mesh sphere.nrrd --iso 0 --no-improve --size 2 --slabs auto --max-memory 12M \
    -o auto.vtu --quiet --verbose 2>&1 >/dev/null) || bad "--slabs auto --max-memory 12M: $err"
k=$(printf '%s\n' "$err" | sed -n 's/^volmesh: --slabs auto: \([0-9]*\) slabs of at most \([0-9]*\) planes$/\1 \2/p')
set -- $k
[ "${1:-0}" -ge 2 ] && [ "${2:-999}" -le 85 ] && ok || bad "--slabs auto at 12M: '$err'"
res=$(same whole.vtu auto.vtu 2>&1) && ok || bad "--slabs auto: $res"

# Refusals: one line, exit 2, no output file.
refuse() { # refuse "WHAT" EXPECTED-SUBSTRING ARGS...
    local what=$1 want=$2
    shift 2
    rm -f x.vtu
    local err rc
    err=$("$VM_CLI" mesh "$@" -o x.vtu --quiet 2>&1 >/dev/null); rc=$?
    [ $rc = 2 ] && [ "$(printf '%s\n' "$err" | wc -l)" = 1 ] && [ ! -e x.vtu ] &&
        case "$err" in *"$want"*) true ;; *) false ;; esac && ok ||
        bad "$what: rc $rc, '$err'"
}
refuse "--slabs 0" "--slabs: '0' is not a whole number from 1 to" phantom.nrrd --iso 0 --slabs 0
refuse "--slabs -3" "--slabs: '-3' is not" phantom.nrrd --iso 0 --slabs -3
refuse "--slabs x" "--slabs: 'x' is not" phantom.nrrd --iso 0 --slabs x
refuse "--slabs 2.5" "--slabs: '2.5' is not" phantom.nrrd --iso 0 --slabs 2.5
refuse "--slabs alone" "--slabs needs a value" phantom.nrrd --iso 0 --slabs
refuse "--slabs with --labels" "--slabs meshes tetrahedra" phantom.nrrd --labels all --slabs 2
refuse "--slabs with hexes" "--slabs meshes tetrahedra" phantom.nrrd --iso 0 --elements hex --slabs 2
refuse "--slabs with tri" "--slabs meshes tetrahedra" phantom.nrrd --iso 0 --elements tri --slabs 2
refuse "--slabs with --denoise" "--slabs meshes tetrahedra" phantom.nrrd --iso 0 --denoise bilateral --slabs 2
refuse "--slabs auto, budget too small" "sphere.nrrd: --slabs auto: the thinnest slabs hold" \
    sphere.nrrd --iso 0 --slabs auto --max-memory 1M
refuse "--slabs, no material" "phantom.nrrd: mesh: no voxel >= 1000" phantom.nrrd --iso 1000 --slabs 3
# a gzip stream cut after its first slabs: the slab that reaches the cut fails, naming the file
/usr/bin/python3 - <<'PY' || bad "writing the cut file"
raw = open("sphere.nrrd", "rb").read()
head, data = raw.split(b"\n\n", 1)
open("cut.nrrd", "wb").write(head + b"\n\n" + data[: len(data) * 2 // 3])
PY
# (--no-improve: the quality pass's whole read would fail on it too)
refuse "--slabs 4 of a cut gzip file" "cut.nrrd: compressed data is truncated" cut.nrrd --iso 0 \
    --slabs 4 --no-improve

echo "test_slabs_cli: $pass passed, $fail failed"
[ $fail = 0 ]
