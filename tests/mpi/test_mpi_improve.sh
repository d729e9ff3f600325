#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# volmesh_mpi --improve under mpiexec: the quality pass on each slab with the vertices it
# shares held fixed (the neighbours' rings and the cut's tets frozen), then across each cut
# on the lower rank (the bands and their ring only); the merged pieces conform, keep the
# invariants (tests/mpi/check_pvtu.py --improved) and reach the bar (dihedral angles >= 10
# degrees), on 3 ranks, and on 2 with adaptive cells outside the sanitizers.
set -u
. "${VM_SOURCE_DIR}/tests/mpi/common.sh"

# --improve: the quality pass on each slab with the shared vertices fixed, then across each
# cut on the lower rank; the pieces still conform and reach the single-process bar
improved() {
    local vol=$1 euler=$2 np=$3
    shift 3
    local tag="$vol np=$np --improve $*" res
    "$VM_CLI" mesh "$vol.nrrd" --iso 0 "$@" -o single.vtu --quiet >/dev/null || { bad "$tag: mesh"; return; }
    rm -f out*.vtu out.pvtu
    res=$(run "$np" "$VM_MPI" "$vol.nrrd" --iso 0 --improve "$@" -o out.pvtu 2>&1) || { bad "$tag: $res"; return; }
    res=$($check out.pvtu single.vtu --pieces "$np" --euler "$euler" --components 1 --improved \
        --min-dihedral 10 2>&1) && ok || bad "$tag: $res"
}
improved sphere 2 3

[ $full = 1 ] && improved torus 0 2 --adaptive --max-level 3

finish test_mpi_improve
