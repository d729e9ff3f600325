#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Builds volmesh (Release) and runs every test with ctest. Tests that need ../shared/data
# skip with a message when it is absent. With --asan: the same in a separate
# AddressSanitizer + UndefinedBehaviorSanitizer build (build-asan).
set -eu
cd "$(dirname "$0")/.."
bash scripts/deps.sh --tests
dir=build
flags=(-DCMAKE_BUILD_TYPE=Release -DVOLMESH_WERROR=ON)
if [ "${1:-}" = "--asan" ]; then
    dir=build-asan
    flags=(-DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOLMESH_SANITIZE=ON -DVOLMESH_WERROR=ON)
    export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
fi
cmake -S . -B "$dir" "${flags[@]}" >/dev/null
cmake --build "$dir" -j"$(nproc)" >/dev/null
cd "$dir"
# ctest runs nproc tests at once, each on nproc threads by default: with OpenMP's default wait
# policy a thread that waits at a join spins and takes a core another test needs (the results
# are the same bytes either way)
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
ctest --output-on-failure -j"$(nproc)" --timeout 1500
