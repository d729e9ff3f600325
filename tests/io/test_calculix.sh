#!/usr/bin/env bash
# tests/io/test_calculix.sh — CalculiX solves the static deck volmesh writes: the CT head bone
# (shared data, iso 1150, size 3) is meshed, converted with --deck static, run through ccx,
# and the .dat/.frd must hold finite, non-zero displacements. Skips (77) when the shared data
# or ccx is absent; CI installs ccx (Debian calculix-ccx) through scripts/deps.sh --tests.
set -u
data="${VM_SHARED_DATA:-}/ct_head_quarter.nrrd"
if [ ! -f "$data" ]; then
    echo "skipped: shared data $data is absent"
    exit 77
fi
if ! command -v ccx >/dev/null 2>&1; then
    echo "skipped: ccx (CalculiX) is not installed; CI installs it with scripts/deps.sh --tests"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-/tmp}/calculix.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail=0
"$VM_CLI" mesh "$data" --iso 1150 --size 3 -o bone.vtu >mesh.log 2>&1 || { cat mesh.log; exit 1; }
"$VM_CLI" convert bone.vtu bone.inp --deck static || exit 1
grep -q '^\*STEP' bone.inp || { echo "deck has no *STEP"; exit 1; }
# ccx takes the job name without .inp; OMP_NUM_THREADS keeps it polite on CI machines.
OMP_NUM_THREADS=2 timeout 600 ccx bone >ccx.log 2>&1
rc=$?
if [ "$rc" != 0 ] || grep -q '\*ERROR' ccx.log; then
    echo "ccx failed (exit $rc):"; tail -20 ccx.log; exit 1
fi
echo "ccx bone: $(grep -c '' bone.inp) deck lines, $(grep 'Total CalculiX Time' ccx.log)"
[ -s bone.frd ] || { echo "no bone.frd"; fail=$((fail+1)); }
grep -q 'DISP' bone.frd || { echo "bone.frd has no DISP block"; fail=$((fail+1)); }
# .dat: "displacements (vx,vy,vz) for set LOADED ..." then "node ux uy uz" lines.
awk '
    /displacements/ { inblock = 1; next }
    inblock && NF == 4 && $1 ~ /^[0-9]+$/ {
        n++
        for (i = 2; i <= 4; i++) {
            v = $i
            if (v ~ /[nN][aA][nN]|[iI][nN][fF]/) bad++
            a = v < 0 ? -v : v
            if (a > max) max = a
        }
    }
    END {
        printf "bone.dat: %d loaded nodes, max |u| %g, %d non-finite\n", n, max, bad
        exit !(n > 0 && max > 0 && bad == 0)
    }' bone.dat || { echo "displacements missing, zero or non-finite"; fail=$((fail+1)); }
# .frd displacement records (" -1 node ux uy uz") must be finite too.
if grep -A100000 'DISP' bone.frd | grep -E '^ -1' | grep -qiE 'nan|inf'; then
    echo "bone.frd holds non-finite displacements"; fail=$((fail+1))
fi
echo "$((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
