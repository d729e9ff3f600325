#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Installs volmesh into a scratch prefix, builds examples/ against it with find_package and
# with pkg-config, and runs the examples on phantoms (mesh_file, mesh_quality, phantom_pipeline).
set -u
src=${VM_SOURCE_DIR:?}
build=$(cd "$(dirname "$VM_CLI")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0
cmake --install "$build" --prefix "$work/prefix" >/dev/null || { echo "install failed"; exit 1; }
for f in include/volmesh/volmesh.h lib/libvolmesh.a lib/pkgconfig/volmesh.pc lib/cmake/volmesh/volmeshConfig.cmake bin/volmesh; do
    [ -e "$work/prefix/$f" ] || { echo "missing installed file $f"; fail=$((fail+1)); }
done
cmake -S "$src/examples" -B "$work/ex" -DCMAKE_PREFIX_PATH="$work/prefix" >/dev/null &&
    cmake --build "$work/ex" >/dev/null || { echo "find_package build failed"; fail=$((fail+1)); }
if command -v pkg-config >/dev/null 2>&1; then
    PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" cc -o "$work/ex_pc" "$src/examples/mesh_file.c" \
        $(PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig" pkg-config --cflags --libs --static volmesh) ||
        { echo "pkg-config build failed"; fail=$((fail+1)); }
fi
(cd "$work" && "$VM_CLI" demo --size 24 >/dev/null) || { echo "demo failed"; fail=$((fail+1)); }
out=$("$work/ex/mesh_file" "$work/phantom.nrrd" 0 "$work/ex.vtu") || { echo "example failed: $out"; fail=$((fail+1)); }
case "$out" in *" 0 inverted, boundary Euler 0,"*) ;; *) echo "unexpected example output: $out"; fail=$((fail+1));; esac
[ -s "$work/ex.vtu" ] || { echo "example wrote no mesh"; fail=$((fail+1)); }
out=$("$work/ex/mesh_quality" "$work/ex.vtu") || { echo "mesh_quality failed: $out"; fail=$((fail+1)); }
case "$out" in *" 0 inverted, boundary closed, Euler 0, 1 components"*) ;; *) echo "unexpected mesh_quality output: $out"; fail=$((fail+1));; esac
out=$("$work/ex/phantom_pipeline" "$work/deck.inp" 32) || { echo "phantom_pipeline failed: $out"; fail=$((fail+1)); }
case "$out" in *"boundary Euler 0 (expected 0)"*"ABAQUS failures "*" -> 0"*) ;; *) echo "unexpected phantom_pipeline output: $out"; fail=$((fail+1));; esac
grep -q '^\*STATIC' "$work/deck.inp" || { echo "phantom_pipeline deck has no *STATIC step"; fail=$((fail+1)); }
out=$("$work/ex/mesh_quality" "$work/nonexistent.vtu" 2>&1) && { echo "mesh_quality accepted a missing file"; fail=$((fail+1)); }
echo "$((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
