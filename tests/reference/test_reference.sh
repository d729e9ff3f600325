# SPDX-License-Identifier: BSD-3-Clause
# tests/reference/test_reference.sh — volmesh beside the reference meshers (issue 9).
#
# For each phantom (volmesh demo, 48^3) and each shared volume, meshes the same input with
# volmesh, with TetGen (the Debian program, run on volmesh's boundary surface; never linked) and
# with CGAL Mesh_3 (tests/reference/cgal_mesh3.cpp on the thresholded image), computes every
# statistic with tests/reference/refstats.py and prints one table per input. Timing is not
# asserted. docs/REFERENCE.md is written by bench/reference, not by this test. To keep the test
# near five minutes, CGAL is not run on avg152T1 (6 min) and ct_head_quarter iso 500 (1 min)
# here; bench/reference runs them.
#
# What is asserted (volmesh's promises):
#   - the boundary Euler characteristic and the number of components equal the phantom's, and
#     for the shared volumes those of the thresholded grid (6-connected inside points,
#     2 (V - E + F - C + S)); so every small component is kept;
#   - the boundary is closed and no tet is inverted or flat.
# What the references get wrong (lost components, other topology) is reported, not asserted.
#
#   - volmesh's min dihedral is at least each reference's, and TetGen's check (tetgen -d) finds
#     no self-intersection in volmesh's boundary. Where these do not hold yet, the case is
#     listed in KNOWN_SHORT in reference.py (issues #4 and #6): reported as "known short" instead
#     of failing, and a listed case that now holds fails the test until it is taken off the
#     list, so the list can only shrink.
#
# Environment: VM_CLI, VM_SHARED_DATA, VM_SOURCE_DIR, VM_TEST_TMP (set by ctest);
# VM_REFERENCE_KNOWN_SHORT=a,b (replaces that list); VM_REFERENCE_SIZE (phantom size, default 48);
# VM_REFERENCE_CASES=a,b (only those inputs, e.g. sphere,ironProt-128). The whole test takes
# about 6 minutes of CPU (12 minutes wall on a busy 2-core machine), most of it on avg152T1.
# Needs /usr/bin/python3 with vtk, numpy and meshio, and tetgen and/or CGAL (libcgal-dev, g++):
# scripts/deps.sh --tests installs them. Exit 0 pass, 1 fail, 77 skip.
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
PY=/usr/bin/python3
if ! "$PY" -c 'import vtk, numpy, meshio' >/dev/null 2>&1; then
    echo "skipped: /usr/bin/python3 with vtk, numpy and meshio is needed (scripts/deps.sh --tests)"
    exit 77
fi
HERE=$(cd "$(dirname "$0")" && pwd)
TMPROOT=${VM_TEST_TMP:-${TMPDIR:-/tmp}}

refs=()
if command -v tetgen >/dev/null 2>&1; then
    refs+=(--tetgen "$(command -v tetgen)")
else
    echo "note: tetgen not installed, TetGen rows left out"
    refs+=(--no-tetgen)
fi
CGAL=$(bash "$HERE/build_cgal.sh" "$TMPROOT/reference-cgal")
case $? in
0) refs+=(--cgal "$CGAL") ;;
77) echo "note: CGAL (libcgal-dev) or g++ not installed, CGAL rows left out" ;;
*) echo "FAIL: cgal_mesh3.cpp does not compile"; exit 1 ;;
esac
if [ "${refs[0]}" = "--no-tetgen" ] && [ -z "$CGAL" ]; then
    echo "skipped: neither tetgen nor CGAL is installed (scripts/deps.sh --tests installs them)"
    exit 77
fi

data=()
if [ -n "${VM_SHARED_DATA:-}" ] && [ -d "$VM_SHARED_DATA" ]; then
    data=(--data "$VM_SHARED_DATA")
else
    echo "note: no shared data folder (VM_SHARED_DATA), phantoms only"
fi
cases=()
if [ -n "${VM_REFERENCE_CASES:-}" ]; then
    cases=(--cases "$VM_REFERENCE_CASES")
elif [ "${VM_SANITIZED:-0}" = 1 ]; then
    # Under ASan the references are the same programs and volmesh runs 3x slower: the
    # phantoms and one real volume are enough to catch a memory error on this path.
    echo "note: sanitizer build, phantoms and ironProt only (the Release run does every input)"
    cases=(--cases sphere,torus,genus3,two-spheres,plate,cut-sphere,ironProt-128)
fi
known=()
[ -n "${VM_REFERENCE_KNOWN_SHORT+set}" ] && known=(--known-short "$VM_REFERENCE_KNOWN_SHORT")

WORK=$(mktemp -d "$TMPROOT/test_reference.XXXXXX") || { echo "cannot make a temporary folder"; exit 1; }
trap 'rm -rf "$WORK"' EXIT

"$PY" "$HERE/reference.py" --cli "$CLI" --work "$WORK" --size "${VM_REFERENCE_SIZE:-48}" \
    --cgal-skip avg152T1-100,ct_head_quarter-500 "${refs[@]}" "${data[@]}" "${cases[@]}" "${known[@]}" --check
rc=$?
[ $rc = 0 ] && exit 0
exit 1
