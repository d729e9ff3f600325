#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# tests/io/test_calculix.sh — CalculiX solves the static decks volmesh writes: a sphere phantom
# centred on the origin (64^3 on [-1, 1], --range :0 --size 4; nodes near zero need exponent
# numbers, which must fit CalculiX's 20-character fields) as C3D4 and C3D10, a two-label
# volume with a material per label from --materials (tetrahedra, and hexahedra: C3D8), the
# CT head bone
# (shared data, iso 1150, size 3; skipped when absent) in tetrahedra, and an adaptive
# hexahedral sphere (C3D8) from a built-in phantom. Each
# deck is run through ccx, and its .dat/.frd must hold finite, non-zero displacements. Skips
# (77) when ccx is absent; CI installs ccx (Debian calculix-ccx) through scripts/deps.sh --tests.
set -u
data="${VM_SHARED_DATA:-}/ct_head_quarter.nrrd"
if ! command -v ccx >/dev/null 2>&1; then
    echo "skipped: ccx (CalculiX) is not installed; CI installs it with scripts/deps.sh --tests"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-/tmp}/calculix.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail=0 decks=0
# solve JOB: convert JOB.vtu to a static deck, run ccx, check its displacements.
# solve JOB [ready]: as above; with "ready", JOB.inp is already written.
solve() {
    local job=$1 rc
    decks=$((decks+1))
    if [ "${2:-}" != ready ]; then
        "$VM_CLI" convert "$job.vtu" "$job.inp" --deck static || { fail=$((fail+1)); return; }
    fi
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
# widest NUMBER field of the *NODE block of a deck, and how many are in exponent form
node_fields() {
    awk -F', *' '/^\*/ { in_nodes = /^\*NODE/; next }
        in_nodes { for (i = 2; i <= NF; i++) { if (length($i) > w) w = length($i); e += ($i ~ /E/) } }
        END { print w + 0, e + 0 }' "$1"
}
# The origin-centred sphere: f = |x| - 0.7 sampled on 64^3 points spanning [-1, 1].
/usr/bin/python3 - <<'PY' || exit 1
import struct
n, r = 64, 0.7
h = 2.0 / (n - 1)
# an origin one unit in the last place below -1: the grid points of the plane through the
# centre are then about 2e-16 from 0, interior points that no stage moves
o = -1.0 - 2.0 ** -52
vals = []
for k in range(n):
    for j in range(n):
        for i in range(n):
            x, y, z = -1 + i * h, -1 + j * h, -1 + k * h
            vals.append((x * x + y * y + z * z) ** 0.5 - r)
head = ("NRRD0004\ntype: float\ndimension: 3\nsizes: %d %d %d\n"
        "space: right-anterior-superior\nspace directions: (%r,0,0) (0,%r,0) (0,0,%r)\n"
        "space origin: (%r,%r,%r)\nencoding: raw\nendian: little\n\n") % (n, n, n, h, h, h, o, o, o)
with open("sphere.nrrd", "wb") as f:
    f.write(head.encode() + struct.pack("<%df" % len(vals), *vals))
PY
for order in 1 2; do
    job=sphere_o$order
    "$VM_CLI" mesh sphere.nrrd --range :0 --size 4 --deck static --order $order -o $job.inp -q \
        >$job.mesh.log 2>&1 || { cat $job.mesh.log; fail=$((fail+1)); continue; }
    want=$([ $order = 1 ] && echo C3D4 || echo C3D10)
    grep -q "TYPE=$want," $job.inp || { echo "$job: no $want elements"; fail=$((fail+1)); }
    read -r width exps < <(node_fields $job.inp)
    echo "$job: widest node field $width characters, $exps in exponent form"
    [ "$width" -le 20 ] || { echo "$job: a node field is over 20 characters"; fail=$((fail+1)); }
    [ "$exps" -gt 0 ] || { echo "$job: no node near zero (the case this checks)"; fail=$((fail+1)); }
    solve $job ready
done
# Two labels stacked in z, each with its material from --materials: two *MATERIAL, two
# sections, one interface surface; ccx solves it.
/usr/bin/python3 - <<'PY' || exit 1
n = 16
out = bytearray(n * n * n)
for k in range(2, 14):
    for j in range(2, 14):
        for i in range(2, 14):
            out[i + n * (j + n * k)] = 1 if k < 8 else 2
open("two.raw", "wb").write(bytes(out))
PY
raw="--raw-dims 16x16x16 --raw-type uint8"
printf 'label,name,E,nu,density\n1,Bone,17000,0.3,1.9e-9\n2,Cartilage,10,0.45,1.1e-9\n' >mats.csv
if "$VM_CLI" mesh two.raw $raw --labels all --deck static --materials mats.csv -o two.inp -q \
        >two.mesh.log 2>&1; then
    [ "$(grep -c '^\*MATERIAL' two.inp)" = 2 ] && grep -q 'ELSET=REGION_1, MATERIAL=Bone' two.inp &&
        grep -q 'ELSET=REGION_2, MATERIAL=Cartilage' two.inp &&
        grep -q '^\*SURFACE, NAME=IFACE_REGION_1_REGION_2' two.inp ||
        { echo "two.inp: not one material and section per label"; fail=$((fail+1)); }
    solve two ready
else
    cat two.mesh.log; fail=$((fail+1))
fi
# The same two labels in hexahedra (C3D8): a material and section per label, the interface
# surface, and ccx solves it.
if "$VM_CLI" mesh two.raw $raw --labels all --elements hex --deck static --materials mats.csv \
        -o twohex.inp -q >twohex.mesh.log 2>&1; then
    [ "$(grep -c '^\*MATERIAL' twohex.inp)" = 2 ] && grep -q '^\*ELEMENT, TYPE=C3D8' twohex.inp &&
        ! grep -q 'TYPE=C3D4' twohex.inp &&
        grep -q 'ELSET=REGION_1, MATERIAL=Bone' twohex.inp &&
        grep -q 'ELSET=REGION_2, MATERIAL=Cartilage' twohex.inp &&
        grep -q '^\*SURFACE, NAME=IFACE_REGION_1_REGION_2' twohex.inp ||
        { echo "twohex.inp: not C3D8 with one material and section per label"; fail=$((fail+1)); }
    solve twohex ready
else
    cat twohex.mesh.log; fail=$((fail+1))
fi
if [ -f "$data" ]; then
    "$VM_CLI" mesh "$data" --iso 1150 --size 3 -o bone.vtu >mesh.log 2>&1 || { cat mesh.log; exit 1; }
    solve bone
else
    echo "shared data $data is absent: the CT bone deck is not solved"
fi
# The adaptive hex sphere: demo writes its phantom volume (phantom.nrrd) in its own folder.
mkdir demo && (cd demo && "$VM_CLI" demo --shape sphere --size 40 --quiet >demo.log 2>&1) ||
    { cat demo/demo.log; exit 1; }
"$VM_CLI" mesh demo/phantom.nrrd --iso 0 --elements hex --adaptive -o hexes.vtu -q \
    >hexmesh.log 2>&1 || { cat hexmesh.log; exit 1; }
grep -q '0 inverted' hexmesh.log || { cat hexmesh.log; echo "hex mesh not valid"; fail=$((fail+1)); }
grep -q 'TYPE=C3D8' <("$VM_CLI" convert hexes.vtu hexes-check.inp && cat hexes-check.inp) ||
    { echo "hex deck has no C3D8 elements"; fail=$((fail+1)); }
solve hexes
# --split: the mesh in JOB_mesh.inp, *INCLUDEd by the deck, which keeps materials and step.
if "$VM_CLI" mesh demo/phantom.nrrd --iso 0 --size 2 --deck static --split -o split.inp -q \
        >split.log 2>&1; then
    { grep -q '^\*INCLUDE, INPUT=split_mesh.inp$' split.inp && ! grep -q '^\*NODE, NSET=NALL' split.inp &&
        grep -q '^\*NODE, NSET=NALL' split_mesh.inp && ! grep -q '^\*STEP' split_mesh.inp; } ||
        { echo "split.inp: the mesh is not in split_mesh.inp"; fail=$((fail+1)); }
    solve split ready
else
    cat split.log; fail=$((fail+1))
fi
# ... and refused in one line before any meshing for another format, leaving no file
if "$VM_CLI" mesh demo/phantom.nrrd --iso 0 --split -o split.vtu -q >split-vtu.log 2>&1 ||
        [ "$(wc -l <split-vtu.log)" != 1 ] || ! grep -q 'split' split-vtu.log || [ -e split.vtu ]; then
    echo "--split with .vtu: not one line and exit 2"; cat split-vtu.log; fail=$((fail+1))
fi
echo "$decks decks run through ccx; $((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
