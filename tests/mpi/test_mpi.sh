#!/usr/bin/env bash
# volmesh_mpi under `mpiexec -np 2` (and 3): the pieces of OUT.pvtu, read by VTK and merged by
# coincident points, form a conforming tet mesh with the invariants of the single-process
# mesh (0 inverted, interior faces shared by exactly two tets, closed boundary, Euler
# characteristic, components, volume against the analytic value) and are that mesh tet for
# tet (tests/mpi/check_pvtu.py): torus, genus-3 and sphere, uniform, --size 2 and adaptive,
# 2 and 3 ranks, and a volume with spacing, origin and a left-handed direction; with
# --improve the pieces conform and keep the quality bar. Bad input: exit 2, one line, no
# file. Skips (77) when volmesh_mpi was not built (no MPI at configure time).
set -u
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

# one VOLUME EULER RANKS PIECES [mesh options]: PIECES slabs hold material
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
    res=$(run "$np" "$VM_MPI" "$vol.nrrd" --iso 0 "$@" -o out.pvtu 2>&1) || { bad "$tag: $res"; return; }
    [ "$(ls out_*.vtu | wc -l)" = "$pieces" ] || { bad "$tag: pieces $(ls out_*.vtu)"; return; }
    res=$($check out.pvtu single.vtu --pieces "$pieces" --euler "$euler" --components 1 $extra 2>&1) &&
        ok || bad "$tag: $res"
}
# every cut must cross the material: the torus and genus-3 lie flat around z = n/2, the
# sphere reaches through three slabs; adaptive cuts fall on multiples of 2^L cells
one torus 0 2 2
[ $full = 1 ] && one torus 0 2 2 --size 2
[ $full = 1 ] && one torus 0 2 2 --adaptive --max-level 3
[ $full = 1 ] && one genus3 -4 2 2 --adaptive --max-level 1
one sphere 2 3 3
one sphere 2 2 2 --adaptive

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

# --phantom gives the same volume as `volmesh demo`
[ $full = 1 ] && {
"$VM_CLI" mesh torus.nrrd --iso 0 --no-improve -o single.vtu --quiet >/dev/null
rm -f out*
res=$(run 2 "$VM_MPI" --phantom torus:$n -o out.pvtu 2>&1) &&
    $check out.pvtu single.vtu --pieces 2 --euler 0 --components 1 >/dev/null && ok ||
    bad "--phantom torus: $res"
}

# The judge can fail: the pieces against a different single-process mesh, and a pvtu whose
# second piece is gone (the boundary opens at the cut).
rm -f out*
run 2 "$VM_MPI" torus.nrrd --iso 0 -o out.pvtu --quiet || bad "torus for the judge"
"$VM_CLI" mesh torus.nrrd --iso 0 --no-improve -o single.vtu --quiet >/dev/null
"$VM_CLI" mesh torus.nrrd --iso 0.5 --no-improve -o other.vtu --quiet >/dev/null
$check out.pvtu other.vtu --pieces 2 --euler 0 --components 1 >/dev/null && bad "judge accepted another mesh" || ok
sed '/out_1.vtu/d' out.pvtu > half.pvtu
$check half.pvtu single.vtu --pieces 1 --euler 0 --components 1 >/dev/null && bad "judge accepted half a torus" || ok

# Physical frame: spacing, origin and a left-handed direction (z flipped), as NRRD. The mesh
# is volmesh mesh's, with positive tets.
/usr/bin/python3 - <<'PY' || bad "writing the framed volume"
import re, zlib
raw = open("torus.nrrd", "rb").read()
head, data = raw.split(b"\n\n", 1)
h = head.decode()
h = re.sub(r"space directions:.*", "space directions: (0.5,0,0) (0,0.75,0) (0,0,-1.25)", h)
h = re.sub(r"space origin:.*", "space origin: (10,-3,7.5)", h)
if "space directions" not in h:
    h += "\nspace: right-anterior-superior\nspace directions: (0.5,0,0) (0,0.75,0) (0,0,-1.25)\nspace origin: (10,-3,7.5)"
    h = re.sub(r"\nspacings:.*", "", h)
open("framed.nrrd", "wb").write(h.encode() + b"\n\n" + data)
PY
fv=$(/usr/bin/python3 -c "print($torus_volume*0.5*0.75*1.25)")
"$VM_CLI" mesh framed.nrrd --iso 0 --no-improve -o single.vtu --quiet >/dev/null || bad "mesh framed.nrrd"
rm -f out*
res=$(run 2 "$VM_MPI" framed.nrrd --iso 0 -o out.pvtu 2>&1) &&
    res=$($check out.pvtu single.vtu --pieces 2 --euler 0 --components 1 --volume "$fv" 2>&1) &&
    ok || bad "framed volume: $res"

# Each rank reads only its planes (vm_volume_read_slab); with 0 outside the material the
# planes it does not read stay zero pages. The torus and the sphere + 5, gzip-compressed, at
# --iso 5, on 2 and 3 ranks.
for vol in sphere $([ $full = 1 ] && echo torus); do
/usr/bin/python3 - "$vol" <<'PY' || bad "writing the shifted $vol"
import gzip, struct, sys
vol = sys.argv[1]
raw = open(vol + ".nrrd", "rb").read()
head, data = raw.split(b"\n\n", 1)
h = head.decode()
assert "type: float" in h and "endian: little" in h, h
if "encoding: gzip" in h:
    data = gzip.decompress(data)
vals = struct.unpack("<%df" % (len(data) // 4), data)
out = struct.pack("<%df" % len(vals), *[x + 5 for x in vals])
h = h.replace("encoding: raw", "encoding: gzip")
open("shifted_" + vol + ".nrrd", "wb").write(h.encode() + b"\n\n" + gzip.compress(out))
PY
done
shifted() {
    local vol=$1 np=$2 euler=$3 volume=$4
    "$VM_CLI" mesh shifted_$vol.nrrd --iso 5 --no-improve -o single.vtu --quiet >/dev/null ||
        { bad "mesh shifted_$vol.nrrd"; return; }
    rm -f out*
    local res
    res=$(run $np "$VM_MPI" shifted_$vol.nrrd --iso 5 -o out.pvtu 2>&1) &&
        res=$($check out.pvtu single.vtu --pieces $np --euler $euler --components 1 --volume "$volume" 2>&1) &&
        ok || bad "shifted gzip $vol np=$np: $res"
}
[ $full = 1 ] && shifted torus 2 0 "$torus_volume"
shifted sphere 3 2 "$sphere_volume"

# Bad input: exit 2, one line naming the problem, nothing written.
rm -f out*
expect2() {
    local what=$1
    shift
    local err rc
    err=$(run 2 "$VM_MPI" "$@" 2>&1 >/dev/null)
    rc=$?
    if [ $rc != 2 ] || [ "$(echo "$err" | grep -c 'volmesh_mpi:')" != 1 ] || ls out* >/dev/null 2>&1; then
        bad "$what: rc $rc, '$err', files: $(ls out* 2>/dev/null)"
    else
        ok
    fi
}
expect2 "missing file" missing.nrrd --iso 0 -o out.pvtu
expect2 "not .pvtu" torus.nrrd --iso 0 -o out.vtu
expect2 "iso above the data" torus.nrrd --iso 1e9 -o out.pvtu
if [ $full = 1 ]; then
    expect2 "no bound" torus.nrrd -o out.pvtu
    expect2 "bad option" torus.nrrd --iso 0 --bogus -o out.pvtu
    expect2 "bad phantom" --phantom teapot -o out.pvtu
    expect2 "--improve, more ranks than slabs" --phantom sphere:12 --adaptive --improve -o out.pvtu
fi
echo "junk" > junk.nrrd
expect2 "malformed volume" junk.nrrd --iso 0 -o out.pvtu

echo "test_mpi: $pass passed, $fail failed"
[ $fail = 0 ]
