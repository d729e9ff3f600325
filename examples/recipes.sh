#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# examples/recipes.sh — the common jobs, one command each, on a phantom volume (no data
# needed). Run it in an empty folder:  bash examples/recipes.sh [path/to/volmesh]
# Each step is a recipe to copy; replace phantom.nrrd and the isovalues with your own.
set -eu
VOLMESH=${1:-volmesh}
say() { printf '\n## %s\n' "$*"; }

say "a volume to work on: a 32^3 torus (signed field, material f >= 0)"
"$VOLMESH" demo --size 32 --shape torus >/dev/null   # also writes demo.vtu and a report

say "look at the volume: size, spacing, value range, histogram"
"$VOLMESH" info phantom.nrrd

say "choose the isovalue: the contour spectrum suggests material boundaries"
"$VOLMESH" spectrum phantom.nrrd --n 64 --svg spectrum.svg | tail -n 4

say "tetrahedra filling f >= 0, with the boundary surface and an HTML quality report"
"$VOLMESH" mesh phantom.nrrd --iso 0 -o torus.vtu --surface torus-surface.vtu \
    --report torus-report.html --quiet

say "fewer tets: coarse cells inside (adaptive octree), same surface"
"$VOLMESH" mesh phantom.nrrd --iso 0 --adaptive -o torus-adaptive.vtu --quiet

say "an interval volume: the shell 0 <= f <= 4"
"$VOLMESH" mesh phantom.nrrd --range 0:4 -o shell.vtu --quiet

say "hexahedra instead of tetrahedra"
"$VOLMESH" mesh phantom.nrrd --iso 0 --elements hex -o torus-hex.vtu --quiet || \
    echo "(hex meshing is work in progress: see the issues)"

say "noisy scan: denoise first (parameters from the data)"
"$VOLMESH" denoise phantom.nrrd -o smooth.nrrd --quiet
"$VOLMESH" mesh smooth.nrrd --iso 0 -o smooth.vtu --quiet

say "a CalculiX/ABAQUS deck with a static step (bottom fixed, top loaded), quadratic tets"
"$VOLMESH" mesh phantom.nrrd --iso 0 -o torus.inp --deck static --order 2 --quiet
if command -v ccx >/dev/null 2>&1; then
    ccx torus >/dev/null && echo "CalculiX solved torus.inp (results in torus.frd, torus.dat)"
fi

say "other solvers' formats from a mesh you have"
"$VOLMESH" convert torus.vtu torus.msh      # Gmsh 4.1, physical group per region
"$VOLMESH" convert torus.vtu torus.mesh     # MEDIT (MMG, FreeFEM)
"$VOLMESH" convert torus.vtu torus.stl      # the boundary, for CAD or printing

say "gate a pipeline on quality: exit 1 when a bar is not met"
"$VOLMESH" quality torus.vtu --abaqus --require "min_dihedral>=10" \
    --require "abaqus_failures<=0" --svg torus-quality.svg | head -n 12
