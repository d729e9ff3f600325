#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Runs examples/recipes.sh (the shell recipes of the user guide) in a scratch folder and
# checks that every recipe wrote what it promises and that each mesh passes the checks.
set -u
src=${VM_SOURCE_DIR:?}
cli=${VM_CLI:?}
work=$(mktemp -d "${VM_TEST_TMP:-/tmp}/recipes.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail=0
(cd "$work" && bash "$src/examples/recipes.sh" "$cli" >log.txt 2>&1) ||
    { echo "recipes.sh failed:"; tail -n 20 "$work/log.txt"; fail=$((fail + 1)); }
for f in phantom.nrrd spectrum.svg torus.vtu torus-surface.vtu torus-report.html \
    torus-adaptive.vtu shell.vtu smooth.nrrd smooth.vtu torus.inp torus.msh torus.mesh \
    torus.stl torus-quality.svg; do
    [ -s "$work/$f" ] || { echo "recipe output missing: $f"; fail=$((fail + 1)); }
done
for f in torus.vtu torus-adaptive.vtu shell.vtu smooth.vtu torus.inp torus.msh torus.mesh; do
    [ -s "$work/$f" ] || continue
    "$cli" quality "$work/$f" --require "inverted<=0" --require "boundary_closed>=1" \
        --require "boundary_euler>=0" --require "boundary_euler<=0" >/dev/null ||
        { echo "recipe mesh $f fails the checks"; fail=$((fail + 1)); }
done
grep -q "C3D10" "$work/torus.inp" || { echo "torus.inp is not quadratic"; fail=$((fail + 1)); }
if command -v ccx >/dev/null 2>&1; then
    grep -q "CalculiX solved" "$work/log.txt" || { echo "CalculiX did not solve torus.inp"; fail=$((fail + 1)); }
fi
echo "$((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
