#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Builds volmesh (Release) and runs `volmesh demo` in ./demo-out: a torus phantom meshed
# into tetrahedra (demo.vtu), its surface (demo-surface.vtu) and the volume (phantom.nrrd).
set -eu
cd "$(dirname "$0")/.."
bash scripts/deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build -j"$(nproc)" >/dev/null
mkdir -p demo-out
cd demo-out
../build/volmesh demo "$@"
