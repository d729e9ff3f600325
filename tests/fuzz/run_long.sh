#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Longer fuzzing than CI's 2000 mutations per reader. Usage: tests/fuzz/run_long.sh [MUTATIONS]
# Uses the corpus-and-mutation drivers of an ASan+UBSan build (build-asan); with clang and
# -DVOLMESH_FUZZ=ON the libFuzzer targets fuzz_<reader> can be run on the same corpora.
set -eu
cd "$(dirname "$0")/../.."
n=${1:-200000}
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOLMESH_SANITIZE=ON >/dev/null
cmake --build build-asan -j"$(nproc)" >/dev/null
export VM_TEST_TMP=$(mktemp -d)
for corpus in tests/fuzz/corpus/*/; do
    name=$(basename "$corpus")
    echo "fuzz_$name: $n mutations"
    "build-asan/tests/fuzz_${name}_driver" "$corpus" "$n"
done
rm -rf "$VM_TEST_TMP"
