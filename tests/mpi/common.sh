# SPDX-License-Identifier: BSD-3-Clause
# tests/mpi/common.sh — sourced by the tests/mpi/test_mpi*.sh scripts: skips (77) when
# volmesh_mpi was not built, sets Open MPI up for a container (root, fewer cores than ranks),
# makes the torus, genus-3 and sphere phantoms (40^3, 28^3 under the sanitizers) in a scratch
# folder, and defines run (mpiexec -np N ...), ok / bad (counters), one (a meshing case
# checked tet for tet against volmesh mesh) and finish (the summary line and exit code).
if [ -z "${VM_MPI:-}" ] || [ ! -x "${VM_MPI}" ]; then
    echo "skip: volmesh_mpi not built (configure with MPI: Debian libopenmpi-dev)"
    exit 77
fi
mpiexec=${VM_MPIEXEC:-mpiexec}
command -v "$mpiexec" >/dev/null 2>&1 || { echo "skip: no $mpiexec"; exit 77; }
# Open MPI in a container, as root, on fewer cores than ranks.
export OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_btl=self,vader
export OMPI_MCA_rmaps_base_oversubscribe=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMP_NUM_THREADS=1
# Under LeakSanitizer, Open MPI's own start-up allocations (kept until exit) are suppressed;
# they are found by full stacks only.
supp="${VM_SOURCE_DIR}/tests/mpi/lsan.supp"
run() {
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0" \
        LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$supp:fast_unwind_on_malloc=0" \
        "$mpiexec" --allow-run-as-root --oversubscribe -np "$@"
}
check="/usr/bin/python3 ${VM_SOURCE_DIR}/tests/mpi/check_pvtu.py"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }

# Under the sanitizers: 28^3 and the cases marked "full" left out (each mpirun start costs
# seconds there).
n=40 full=1
[ -n "${VM_SANITIZED:-}" ] && n=28 full=0
torus_volume=$(/usr/bin/python3 -c "import math; m=$n-1; print(2*math.pi**2*0.28*m*(0.12*m)**2)")
sphere_volume=$(/usr/bin/python3 -c "import math; m=$n-1; print(4/3*math.pi*(0.35*m)**3)")

"$VM_CLI" demo --shape torus --size $n >/dev/null && mv phantom.nrrd torus.nrrd || bad "demo torus"
"$VM_CLI" demo --shape genus3 --size $n >/dev/null && mv phantom.nrrd genus3.nrrd || bad "demo genus3"
"$VM_CLI" demo --shape sphere --size $n >/dev/null && mv phantom.nrrd sphere.nrrd || bad "demo sphere"

# one VOLUME EULER RANKS PIECES [mesh options]: PIECES slabs hold material; volmesh_mpi
# also gets $MPI_ONLY
one() {
    local vol=$1 euler=$2 np=$3 pieces=$4
    shift 4
    local tag="$vol np=$np $*" extra=""
    [ "$vol" = torus ] && extra="--volume $torus_volume"
    [ "$vol" = sphere ] && extra="--volume $sphere_volume"
    "$VM_CLI" mesh "$vol.nrrd" --iso 0 --no-improve "$@" -o single.vtu --quiet >/dev/null ||
        { bad "$tag: volmesh mesh"; return; }
    rm -f out*.vtu out.pvtu
    local res
    res=$(run "$np" "$VM_MPI" "$vol.nrrd" --iso 0 "$@" ${MPI_ONLY:-} -o out.pvtu 2>&1) ||
        { bad "$tag ${MPI_ONLY:-}: $res"; return; }
    [ "$(ls out_*.vtu | wc -l)" = "$pieces" ] || { bad "$tag: pieces $(ls out_*.vtu)"; return; }
    res=$($check out.pvtu single.vtu --pieces "$pieces" --euler "$euler" --components 1 $extra 2>&1) &&
        ok || bad "$tag: $res"
}

finish() {
    echo "$1: $pass passed, $fail failed"
    [ $fail = 0 ]
}
