#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_label_edge_cli.sh — `volmesh mesh --labels --label-edge LABEL=L,...` as a user
# runs it: on two face-sharing blocks (anisotropic voxels), the label given the short edge
# has the denser mesh and swapping the edges swaps the densities, the mesh stays valid with
# the quality pass's angles; every bad --label-edge is one line on stderr, exit 2, no file.
#
# Run by ctest with VM_CLI set. Exit 0 pass, 1 fail, 77 skip (no program to test).
set -u
if [ -z "${VM_CLI:-}" ] || [ ! -x "$VM_CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_label_edge_cli.XXXXXX") || exit 1
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

# 66 x 34 x 26 voxels of 1 x 1 x 1.25 (world diagonal 1.887): label 1 at x < 33, label 2
# beyond, one voxel of background around
/usr/bin/python3 - <<'PY'
nx, ny, nz = 66, 34, 26
out = bytearray(nx * ny * nz)
for k in range(1, nz - 1):
    for j in range(1, ny - 1):
        for i in range(1, nx - 1):
            out[i + nx * (j + ny * k)] = 1 if i < nx // 2 else 2
open("blocks.raw", "wb").write(bytes(out))
PY
raw="--raw-dims 66x34x26 --raw-type uint8 --raw-spacing 1,1,1.25"

# 1. density per label follows the edges, both ways; valid; angles of the quality pass
dens='[l["elements"] / l["volume"] for l in d["labels"]]'
a=$("$VM_CLI" mesh blocks.raw $raw --labels all --label-edge 1=1.9,2=30 --json -o a.vtu 2>err.txt)
rc1=$?
b=$("$VM_CLI" mesh blocks.raw $raw --labels all --label-edge 2=1.9,1=30 --json -o b.vtu 2>>err.txt)
rc2=$?
if [ "$rc1" -eq 0 ] && [ "$rc2" -eq 0 ]; then
    for out in "$a" "$b"; do
        v=$(echo "$out" | json 'd["inverted"], d["overshared_faces"], d["boundary_closed"], d["boundary_euler"], d["labels_meshed"]')
        [ "$v" = "0 0 True 2 2" ] && ok || bad "valid: $v"
        q=$(echo "$out" | json 'd["improve"]["min_dihedral_after"] >= 15 and d["improve"]["max_dihedral_after"] <= 150')
        [ "$q" = True ] && ok || bad "dihedral: $(echo "$out" | json 'd["improve"]')"
    done
    ra=$(echo "$a" | json "(lambda x: x[0] / x[1])($dens)")
    rb=$(echo "$b" | json "(lambda x: x[1] / x[0])($dens)")
    echo "density ratios: $ra, swapped $rb"
    /usr/bin/python3 -c "import sys; sys.exit(0 if $ra >= 4 and $rb >= 4 else 1)" && ok ||
        bad "density ratios $ra $rb"
    # the sizes (voxels) reported per label are the edges over the voxel diagonal
    s=$(echo "$a" | json '[round(l["size"] * 1.887, 1) for l in d["labels"]]')
    [ "$s" = "[1.9, 30.0]" ] && ok || bad "sizes: $s"
else
    bad "label edges: exit $rc1 $rc2: $(cat err.txt)"
fi

# 2. --max-edge gives the labels not listed their size
c=$("$VM_CLI" mesh blocks.raw $raw --labels all --max-edge 30 --label-edge 1=1.9 --json --no-improve -o c.vtu 2>err.txt)
s=$(echo "$c" | json '[round(l["size"] * 1.887, 1) for l in d["labels"]]' 2>/dev/null)
[ "$s" = "[1.9, 30.0]" ] && ok || bad "--max-edge with --label-edge: $s $(cat err.txt)"

# 3. refusals: one line naming the option and the problem, exit 2, no output file
refuse() { # NAME WORD ARGS...
    local name=$1 word=$2
    shift 2
    rm -f out.vtu
    "$VM_CLI" mesh blocks.raw $raw "$@" -o out.vtu >out.txt 2>err.txt
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q -- "$word" err.txt &&
        [ ! -e out.vtu ]; then
        ok
    else
        bad "$name: exit $rc, stderr: $(cat err.txt)"
    fi
}
refuse "absent label" "--label-edge names label 9, which is not meshed" --labels all --label-edge 9=2
refuse "label not chosen" "label 2, which is not meshed" --labels 1 --label-edge 2=2
refuse "edge 0" "--label-edge: edge '0' of label 1 is not a length > 0" --labels all --label-edge 1=0
refuse "negative edge" "edge '-3' of label 1" --labels all --label-edge 1=-3
refuse "nan edge" "--label-edge" --labels all --label-edge 1=nan
refuse "no edge" "not a list of LABEL=L" --labels all --label-edge 1
refuse "colon" "not a list of LABEL=L" --labels all --label-edge 1:2
refuse "not a number" "not a list of LABEL=L" --labels all --label-edge 1=x
refuse "empty item" "not a list of LABEL=L" --labels all --label-edge 1=2,,2=3
refuse "trailing comma" "not a list of LABEL=L" --labels all --label-edge 1=2,
refuse "no label" "not a list of LABEL=L" --labels all --label-edge =2
refuse "no value" "--label-edge" --labels all --label-edge
refuse "two edges" "label 1 has two sizes" --labels all --label-edge 1=2,1=3
refuse "edge and size" "label 1 has two sizes" --labels all --label-edge 1=2 --size-per-label 1:2
refuse "too fine" "below 1/8 of the voxel diagonal" --labels all --label-edge 1=0.2
refuse "without labels" "go with --labels" --iso 1 --label-edge 1=2
refuse "hexes" "need tets" --labels all --elements hex --label-edge 2=30

echo "test_label_edge_cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
