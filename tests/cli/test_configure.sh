#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The build on a user's machine (issue 28): optional parts never fail the configure.
# 1. A broken MPI: an mpicc first on PATH whose include folder does not exist (what Debian's
#    python3-vtk9 leaves: openmpi-bin without libopenmpi-dev). Configure and build succeed,
#    with one status line that says why the MPI driver is off.
# 2. A plain configure does not turn warnings into errors; -DVOLMESH_WERROR=ON does.
# 3. clang (when present) builds the library, the program and the tests with -Werror, and the
#    program runs the demo.
# 4. Built with the DICOM codecs switched off (as on a machine without libjpeg-turbo, CharLS
#    and OpenJPEG), tests/io/test_dicom_codecs checks the one-line refusal that names each
#    compressed syntax and the Debian package to build with.
# 5. Without CGAL's headers the CGAL reference is off with one status line (not a failure).
set -u
src=${VM_SOURCE_DIR:?}
if [ -n "${VM_SANITIZED:-}" ]; then
    echo "skipped under the sanitizers: it builds plain trees of its own, which the release suite checks"
    exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0
jobs=$(nproc 2>/dev/null || echo 2)

mkdir -p "$work/bin"
cat > "$work/bin/mpicc" <<'WRAP'
#!/bin/sh
case "$1" in
  -showme:compile|-showme:incdirs) echo "-I/nonexistent/volmesh-test/openmpi/include"; exit 0;;
  -showme:link|-showme:libdirs|-showme:libs) echo "-L/nonexistent/volmesh-test/lib -lmpi"; exit 0;;
  -showme*|-show) echo "cc -I/nonexistent/volmesh-test/openmpi/include -lmpi"; exit 0;;
esac
exec cc -I/nonexistent/volmesh-test/openmpi/include "$@"
WRAP
chmod +x "$work/bin/mpicc"
# The wrapper is named as the C MPI compiler too, so that FindMPI cannot fall back on a
# working Open MPI of the machine (CI installs one for tests/mpi).
out=$(PATH="$work/bin:$PATH" cmake -S "$src" -B "$work/mpi" -DVOLMESH_TESTS=ON \
      -DMPI_C_COMPILER="$work/bin/mpicc" -DVOLMESH_DICOM_JPEG=OFF -DVOLMESH_DICOM_JPEGLS=OFF \
      -DVOLMESH_DICOM_J2K=OFF -DVM_CGAL_INCLUDE_DIR="$work/no-cgal" 2>&1)
if [ $? -ne 0 ]; then
    echo "configure failed with a broken mpicc first on PATH:"; echo "$out" | tail -20
    fail=$((fail+1))
else
    line=$(echo "$out" | grep "volmesh: MPI driver")
    case "$line" in
        *"volmesh_mpi OFF (MPI "*) echo "broken mpicc: $line" ;;
        *) echo "no 'MPI driver OFF (why)' status line: $line"; fail=$((fail+1)) ;;
    esac
    if ! cmake --build "$work/mpi" -j"$jobs" --target volmesh io_test_dicom_codecs >/dev/null 2>&1; then
        echo "build failed after configuring with a broken mpicc"; fail=$((fail+1))
    else
        mkdir -p "$work/tmp"
        if ! log=$(cd "$work/tmp" && VM_TEST_TMP="$work/tmp" VM_CLI="$work/mpi/volmesh" \
                   "$work/mpi/tests/io_test_dicom_codecs" 2>&1); then
            echo "without the DICOM codecs, test_dicom_codecs fails:"; echo "$log" | tail -20
            fail=$((fail+1))
        else
            echo "without the DICOM codecs: $(echo "$log" | tail -1)"
        fi
    fi
    echo "$out" | grep -q "volmesh: DICOM JPEG-LS OFF (VOLMESH_DICOM_JPEGLS is OFF)" ||
        { echo "no 'DICOM JPEG-LS OFF (why)' status line with the codecs off"; fail=$((fail+1)); }
fi
echo "$out" | grep -q "volmesh: CGAL reference OFF (CGAL/make_mesh_3.h not found" ||
    { echo "no 'CGAL reference OFF (why)' status line without CGAL"; fail=$((fail+1)); }
# every optional part's status line says ON, or OFF with a reason in brackets
for part in "OpenMP threads" "Exodus II writer" "TIFF reader" "DICOM JPEG" "DICOM JPEG-LS" \
            "DICOM JPEG 2000" "XDMF" "MPI driver volmesh_mpi" "CGAL reference"; do
    echo "$out" | grep -Eq "volmesh: $part (ON|OFF \(.+\))" ||
        { echo "no status line for $part"; fail=$((fail+1)); }
done
grep -q -- "-Werror" "$work/mpi/CMakeFiles/volmesh_objects.dir/flags.make" 2>/dev/null &&
    { echo "a plain configure turns warnings into errors"; fail=$((fail+1)); }

if command -v clang >/dev/null 2>&1; then
    if ! CC=clang cmake -S "$src" -B "$work/clang" -DVOLMESH_WERROR=ON >/dev/null 2>&1; then
        echo "clang configure failed"; fail=$((fail+1))
    else
        grep -q -- "-Werror" "$work/clang/CMakeFiles/volmesh_objects.dir/flags.make" ||
            { echo "VOLMESH_WERROR=ON does not add -Werror"; fail=$((fail+1)); }
        if ! log=$(cmake --build "$work/clang" -j"$jobs" 2>&1); then
            echo "clang build with -Werror failed:"; echo "$log" | grep -E "error|warning" | head -20
            fail=$((fail+1))
        elif echo "$log" | grep -q "warning:"; then
            echo "clang warns:"; echo "$log" | grep "warning:" | head; fail=$((fail+1))
        else
            (cd "$work" && "$work/clang/volmesh" demo --size 24 --quiet >/dev/null) ||
                { echo "the clang-built volmesh demo failed"; fail=$((fail+1)); }
        fi
    fi
else
    echo "clang not installed: the clang build is not checked here"
fi
echo "$((fail == 0 ? 1 : 0)) passed, $fail failed"
[ "$fail" = 0 ]
