#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# tests/io/test_calculix.sh — CalculiX solves the static decks volmesh writes: the CT head bone
# (shared data, iso 1150, size 3) in tetrahedra, and an adaptive hexahedral sphere (C3D8, the
# transitions made by pillowing) from a built-in phantom. Each mesh is converted with --deck
# static, run through ccx, and its .dat/.frd must hold finite, non-zero displacements. Skips (77) when the shared data
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
# solve JOB: convert JOB.vtu to a static deck, run ccx, check its displacements.
solve() {
    local job=$1 rc
    "$VM_CLI" convert "$job.vtu" "$job.inp" --deck static || { fail=$((fail+1)); return; }
    grep -q '^\*STEP' "$job.inp" || { echo "$job: deck has no *STEP"; fail=$((fail+1)); return; }
    # ccx takes the job name without .inp; OMP_NUM_THREADS keeps it polite on CI machines.
    OMP_NUM_THREADS=2 timeout 600 ccx "$job" >"$job.ccx.log" 2>&1
    rc=$?
    if [ "$rc" != 0 ] || grep -q '\*ERROR' "$job.ccx.log"; then
        echo "ccx $job failed (exit $rc):"; tail -20 "$job.ccx.log"; fail=$((fail+1)); return
    fi
    echo "ccx $job: $(grep -c '' "$job.inp") deck lines, $(grep 'Total CalculiX Time' "$job.ccx.log")"
    [ -s "$job.frd" ] || { echo "no $job.frd"; fail=$((fail+1)); return; }
    grep -q 'DISP' "$job.frd" || { echo "$job.frd has no DISP block"; fail=$((fail+1)); }
    # .dat: "displacements (vx,vy,vz) for set LOADED ..." then "node ux uy uz" lines.
    awk -v job="$job" '
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
            printf "%s.dat: %d loaded nodes, max |u| %g, %d non-finite\n", job, n, max, bad
            exit !(n > 0 && max > 0 && bad == 0)
        }' "$job.dat" || { echo "$job: displacements missing, zero or non-finite"; fail=$((fail+1)); }
    # .frd displacement records (" -1 node ux uy uz") must be finite too.
    if grep -A100000 'DISP' "$job.frd" | grep -E '^ -1' | grep -qiE 'nan|inf'; then
        echo "$job.frd holds non-finite displacements"; fail=$((fail+1))
    fi
}
"$VM_CLI" mesh "$data" --iso 1150 --size 3 -o bone.vtu >mesh.log 2>&1 || { cat mesh.log; exit 1; }
solve bone
# The adaptive hex sphere: demo writes its phantom volume (phantom.nrrd) in its own folder.
mkdir demo && (cd demo && "$VM_CLI" demo --shape sphere --size 40 --quiet >demo.log 2>&1) ||
    { cat demo/demo.log; exit 1; }
"$VM_CLI" mesh demo/phantom.nrrd --iso 0 --elements hex --adaptive -o hexes.vtu -q \
    >hexmesh.log 2>&1 || { cat hexmesh.log; exit 1; }
grep -q '0 inverted' hexmesh.log || { cat hexmesh.log; echo "hex mesh not valid"; fail=$((fail+1)); }
grep -q 'TYPE=C3D8' <("$VM_CLI" convert hexes.vtu hexes-check.inp && cat hexes-check.inp) ||
    { echo "hex deck has no C3D8 elements"; fail=$((fail+1)); }
solve hexes
echo "$((fail == 0 ? 2 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
