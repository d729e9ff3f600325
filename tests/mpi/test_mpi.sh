#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# volmesh_mpi under `mpiexec -np 2` (and 3): the pieces of OUT.pvtu, read by VTK and merged by
# coincident points, form a conforming tet mesh with the invariants of the single-process
# mesh (0 inverted, interior faces shared by exactly two tets, closed boundary, Euler
# characteristic, components, volume against the analytic value) and are that mesh tet for
# tet (tests/mpi/check_pvtu.py): torus, genus-3 and sphere, uniform, --size 2 and adaptive,
# 2 and 3 ranks (each meshing a crop of the volume: its planes and the ghost band), crops of
# adaptive meshes starting at odd multiples of the block size, --balance (slabs of equal
# material, a smaller largest piece), --phantom, and a volume with
# spacing, origin and a left-handed direction; the judge fails a wrong mesh. The quality pass
# is test_mpi_improve.sh, slab reads and bad input test_mpi_input.sh. Skips (77) when
# volmesh_mpi was not built (no MPI at configure time).
set -u
. "${VM_SOURCE_DIR}/tests/mpi/common.sh"

# every cut must cross the material: the torus and genus-3 lie flat around z = n/2, the
# sphere reaches through three slabs; adaptive cuts fall on multiples of 2^L cells
one torus 0 2 2
[ $full = 1 ] && one torus 0 2 2 --size 2
[ $full = 1 ] && one torus 0 2 2 --adaptive --max-level 3
[ $full = 1 ] && one genus3 -4 2 2 --adaptive --max-level 1
one sphere 2 3 3
one sphere 2 2 2 --adaptive

# a crop whose ghost band starts at an odd multiple of the block size (rank 1: blocks of 4
# from cell 4), where the tets split by the parity of the whole grid
[ $full = 1 ] && MPI_ONLY="--ghost 6" one sphere 2 3 3 --adaptive --max-level 2

# --balance: slabs of about equal material instead of equal planes; still the single mesh
# tet for tet, and the largest piece of the sphere on 4 ranks is smaller than with equal
# planes (whose polar slabs hold few tets)
MPI_ONLY=--balance one sphere 2 4 4
[ $full = 1 ] && MPI_ONLY=--balance one sphere 2 3 3 --adaptive --max-level 2
largest() { sed -n 's/.*tets (\(.*\)),.*/\1/p' | tr -d ' ' | tr '+' '\n' | sort -n | tail -1; }
eq=$(run 4 "$VM_MPI" sphere.nrrd --iso 0 -o out.pvtu 2>&1 | largest)
bal=$(run 4 "$VM_MPI" sphere.nrrd --iso 0 --balance -o out.pvtu 2>&1 | largest)
[ -n "$eq" ] && [ -n "$bal" ] && [ "$bal" -lt $((eq * 3 / 4)) ] && ok ||
    bad "--balance: largest piece $bal tets, equal planes $eq"

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

finish test_mpi
