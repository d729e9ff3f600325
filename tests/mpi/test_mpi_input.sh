#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# volmesh_mpi input: each rank reads only its planes (vm_volume_read_slab) of a gzip NRRD
# and meshes them as a crop, on 3 ranks (and the torus on 2 outside the sanitizers), the
# merged pieces checked against volmesh mesh; bad input gives exit 2, one line and no file.
set -u
. "${VM_SOURCE_DIR}/tests/mpi/common.sh"

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

finish test_mpi_input
