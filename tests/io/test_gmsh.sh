#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# tests/io/test_gmsh.sh — gmsh reads the MSH 4.1 and 2.2 files volmesh writes (the demo torus
# and a converted surface) and reports the node and element counts we wrote; `gmsh -check`
# also runs its coherence checks (duplicate nodes/elements). Skips (77) when gmsh is absent;
# CI installs it (Debian gmsh) through scripts/deps.sh --tests.
set -u
if ! command -v gmsh >/dev/null 2>&1; then
    echo "skipped: gmsh is not installed; CI installs it with scripts/deps.sh --tests"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-/tmp}/gmsh.XXXXXX")
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail=0
"$VM_CLI" demo --size 32 >demo.log 2>&1 || { cat demo.log; exit 1; }
check() { # file points cells
    out=$(timeout 300 gmsh -check -nt 1 "$1" 2>&1)
    if [ $? != 0 ] || echo "$out" | grep -q 'Error'; then
        echo "gmsh -check $1 failed:"; echo "$out" | tail -5; fail=$((fail+1)); return
    fi
    nodes=$(echo "$out" | sed -n 's/^Info *: \([0-9]*\) nodes$/\1/p' | head -1)
    elems=$(echo "$out" | sed -n 's/^Info *: \([0-9]*\) elements$/\1/p' | head -1)
    echo "gmsh -check $1: $nodes nodes, $elems elements (ours: $2, $3)"
    [ "$nodes" = "$2" ] && [ "$elems" = "$3" ] || { echo "  counts differ"; fail=$((fail+1)); }
}
for src in demo.vtu demo-surface.vtu; do
    line=$("$VM_CLI" convert "$src" "${src%.vtu}.msh") || { fail=$((fail+1)); continue; }
    "$VM_CLI" convert "$src" "${src%.vtu}.msh2" >/dev/null || { fail=$((fail+1)); continue; }
    # "demo.vtu: P points, C tet4 cells -> ..."
    p=$(echo "$line" | sed -n 's/^[^:]*: \([0-9]*\) points, \([0-9]*\) .*/\1/p')
    c=$(echo "$line" | sed -n 's/^[^:]*: \([0-9]*\) points, \([0-9]*\) .*/\2/p')
    check "${src%.vtu}.msh" "$p" "$c"
    cp "${src%.vtu}.msh2" "${src%.vtu}_v2.msh" # gmsh picks the reader from .msh
    check "${src%.vtu}_v2.msh" "$p" "$c"
done
# gmsh re-saves our 4.1 file and we read its output back: same counts.
timeout 300 gmsh -nt 1 demo.msh -save -format msh41 -o resaved.msh >resave.log 2>&1 &&
    back=$("$VM_CLI" convert resaved.msh resaved.vtu) || { echo "gmsh re-save failed"; tail -3 resave.log; fail=$((fail+1)); }
echo "gmsh re-saved demo.msh, volmesh read it: ${back:-nothing}"
echo "$((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
