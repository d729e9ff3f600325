# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_sizing_cli.sh — graded sizing from the command line: --size-field (an image
# with its own geometry) changes the density where it asks, bad size fields and options that
# do not go together are refused with one line and exit 2, --max-edge sizes label meshes
# (fewer tets, every label kept), and on the CT head (when ../shared/data is there) a coarse
# --distance keeps the voxels' topology (the safety net), the quality pass says when a mesh
# misses its targets, and the default graded mesh keeps one-voxel cavities and thin bone within
# the distance bound; --no-coarsen keeps the stuffed mesh.
#
# Run by ctest as `bash test_sizing_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u
if [ -z "${VM_CLI:-}" ] || [ ! -x "$VM_CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
work=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_sizing_cli.XXXXXX") || exit 1
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
json() { /usr/bin/python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

# A ball of radius 10 (world units) in a 32^3 MetaImage with spacing 1 and origin (5,5,5);
# size fields: 2 on x < 20 and 16 beyond (own grid: 5^3, spacing 10, origin 0); one with a 0;
# labels: two nested balls.
/usr/bin/python3 - <<'PY'
import math, struct
def mha(path, n, sp, org, vals, typ="MET_FLOAT", fmt="f"):
    hdr = ("ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementSpacing = %g %g %g\n"
           "Offset = %g %g %g\nElementType = %s\nElementDataFile = LOCAL\n"
           % (n, n, n, sp, sp, sp, org, org, org, typ))
    open(path, "wb").write(hdr.encode() + struct.pack("<%d%s" % (len(vals), fmt), *vals))
n = 32
ball, labels = [], []
for k in range(n):
    for j in range(n):
        for i in range(n):
            r = math.sqrt((i - 15.5) ** 2 + (j - 15.5) ** 2 + (k - 15.5) ** 2)
            ball.append(10.0 - r)
            labels.append(2 if r < 5 else 1 if r < 12 else 0)
mha("ball.mha", n, 1.0, 5.0, ball)
mha("labels.mha", n, 1.0, 5.0, labels, "MET_UCHAR", "B")
sf = [2.0 if 10 * i < 20 else 16.0 for k in range(5) for j in range(5) for i in range(5)]
mha("size.mha", 5, 10.0, 0.0, sf)
sf[17] = 0.0
mha("zero.mha", 5, 10.0, 0.0, sf)
PY

# 1. the size field sets the density: tets with centroid x < 20 (world) far outnumber those
# beyond (the ball is centred at x = 20.5)
"$VM_CLI" mesh ball.mha --iso 0 --size-field size.mha --no-improve -o sized.vtu -q 2>err.txt
rc=$?
"$VM_CLI" mesh ball.mha --iso 0 --graded --no-improve -o plain.vtu -q 2>>err.txt
if [ "$rc" -eq 0 ] && [ -s sized.vtu ]; then
    counts=$(/usr/bin/python3 - <<'PY'
import sys, os
sys.path.insert(0, os.path.join(os.environ.get("VM_SOURCE_DIR", ""), "tests", "reference"))
try:
    import refstats as R
except ImportError:
    print("skip"); sys.exit()
p, t = R.read_vtu_tets("sized.vtu")
c = p[t].mean(axis=1)
left, right = int((c[:, 0] < 20.5).sum()), int((c[:, 0] >= 20.5).sum())
p2, t2 = R.read_vtu_tets("plain.vtu")
print(left, right, len(t2))
PY
)
    set -- $counts
    if [ "${1:-}" = skip ]; then
        echo "note: refstats (numpy) missing: only the exit status checked"
        ok
    elif [ $# -eq 3 ] && [ "$1" -ge $((4 * $2)) ] && [ "$(($1 + $2))" -gt "$3" ]; then
        ok
    else
        bad "size field: tets left/right/plain = $counts"
    fi
else
    bad "size field: exit $rc: $(cat err.txt)"
fi

# 2. refusals: one line naming the problem, exit 2, no output file
refuse() { # NAME WORD ARGS...
    local name=$1 word=$2
    shift 2
    rm -f out.vtu
    "$VM_CLI" "$@" >out.txt 2>err.txt
    local rc=$?
    if [ "$rc" -eq 2 ] && [ "$(wc -l <err.txt)" -eq 1 ] && grep -q -- "$word" err.txt &&
        [ ! -e out.vtu ]; then
        ok
    else
        bad "$name: exit $rc, stderr: $(cat err.txt)"
    fi
}
refuse "size 0" "size-field" mesh ball.mha --iso 0 --size-field zero.mha -o out.vtu
refuse "missing size field" "nothere.mha" mesh ball.mha --iso 0 --size-field nothere.mha -o out.vtu
refuse "size field with labels" "--labels" mesh labels.mha --labels all --size-field size.mha -o out.vtu
refuse "distance with labels" "--labels" mesh labels.mha --labels all --distance 1 -o out.vtu
refuse "tets with labels" "--labels" mesh labels.mha --labels all --tets 1000 -o out.vtu
refuse "tets of 0" "--tets" mesh ball.mha --iso 0 --tets 0 -o out.vtu
refuse "graded with labels" "--labels" mesh labels.mha --labels all --graded -o out.vtu
refuse "no layers" "--min-layers" mesh ball.mha --iso 0 --min-layers 0 -o out.vtu
refuse "layers with labels" "--labels" mesh labels.mha --labels all --max-edge 8 --min-layers 2 -o out.vtu
refuse "graded with hexes" "tetrahedra" mesh ball.mha --iso 0 --max-edge 4 --elements hex -o out.vtu
refuse "graded with slabs" "slabs" mesh ball.mha --iso 0 --max-edge 4 --slabs 2 -o out.vtu

# 3. --max-edge with --labels: interior cells grow, every label is kept
"$VM_CLI" mesh labels.mha --labels all --json -o uni.vtu >uni.json 2>err.txt
rc1=$?
"$VM_CLI" mesh labels.mha --labels all --max-edge 8 --json -o big.vtu >big.json 2>>err.txt
rc2=$?
if [ "$rc1" -eq 0 ] && [ "$rc2" -eq 0 ]; then
    a=$(json 'd["elements"]' <uni.json 2>/dev/null || echo 0)
    b=$(json 'd["elements"]' <big.json 2>/dev/null || echo 0)
    la=$(json 'len(d["labels"])' <big.json 2>/dev/null || echo 0)
    if [ "$b" -gt 0 ] && [ "$b" -lt "$a" ] && [ "$la" -eq 2 ]; then
        ok
    else
        bad "labels --max-edge 8: $b tets (uniform $a), $la labels"
    fi
else
    bad "labels --max-edge: exit $rc1 $rc2: $(cat err.txt)"
fi

# 4. the CT head at a coarse --distance keeps the voxels' topology (Euler -12, 8 components)
ct="${VM_SHARED_DATA:-}/ct_head_quarter.nrrd"
if [ -n "${VM_SHARED_DATA:-}" ] && [ -f "$ct" ]; then
    "$VM_CLI" mesh "$ct" --iso 500 --distance 4 --no-improve --json -o ct.vtu >ct.json 2>err.txt
    e=$(json '(d["boundary_euler"], d["components"])' <ct.json 2>/dev/null)
    if [ "$e" = "(-12, 8)" ]; then ok; else bad "CT head --distance 4: $e $(cat err.txt)"; fi
    # 6. the quality pass's line shows when the mesh misses 15..150 degrees, whatever the
    # count of tets past 10..165 (a crop of the CT head whose stuffed mesh the pass left at
    # 13.5 degrees on 2026-12-05, with no line)
    /usr/bin/python3 - "$ct" <<'PY'
import gzip, struct, sys
raw = open(sys.argv[1], "rb").read()
head, body = raw.split(b"\n\n", 1)
nx, ny, nz = 64, 64, 93
assert b"sizes: 64 64 93" in head and b"uint16" in head and b"gzip" in head
v = struct.unpack("<%dH" % (nx * ny * nz), gzip.decompress(body))
x0, y0, z0, cx, cy, cz = 10, 10, 30, 24, 24, 32
out = [v[x + nx * (y + ny * z)] for z in range(z0, z0 + cz) for y in range(y0, y0 + cy)
       for x in range(x0, x0 + cx)]
hdr = ("ObjectType = Image\nNDims = 3\nDimSize = %d %d %d\nElementSpacing = 3.2 3.2 1.5\n"
       "Offset = 0 0 0\nElementType = MET_USHORT\nElementDataFile = LOCAL\n" % (cx, cy, cz))
open("crop.mha", "wb").write(hdr.encode() + struct.pack("<%dH" % len(out), *out))
PY
    "$VM_CLI" mesh crop.mha --iso 500 --graded --no-coarsen -o crop.vtu >crop.txt 2>err.txt
    lo=$(sed -n 's/.*dihedral \([0-9.]*\)\.\.\([0-9.]*\) deg.*/\1 \2/p' crop.txt | head -1)
    if [ -z "$lo" ]; then
        bad "crop: no summary $(cat crop.txt err.txt)"
    elif /usr/bin/python3 -c "import sys; a, b = map(float, '$lo'.split()); sys.exit(not (a < 15 or b > 150))"; then
        if grep -E -q "^quality pass: (dihedral angles .*outside the targets 15..150|[0-9]+ tets still fail)" crop.txt; then ok; else bad "crop: $lo and no line: $(cat crop.txt)"; fi
    elif grep -q "^quality pass" crop.txt; then
        bad "crop: $lo within the targets, yet: $(cat crop.txt)"
    else
        ok
    fi
    # 7. the graded CT head keeps one-voxel cavities and thin bone within the distance bound:
    # isosurface points (index space) that were 0.6 to 0.85 voxel from the boundary on
    # 2026-12-05, when a warp in their base cell replaced the cut on their edge, and two on
    # the rims of the border planes z = 92 and z = 0 that were 1.0 voxel from it on
    # 2026-12-06, when the quality pass contracted the rim vertex beside them (the check
    # that a contraction keeps the removed surface vertex near the boundary); the bound is
    # D + 5% of a voxel (D: half the edge of a cube of one voxel's volume, the default)
    "$VM_CLI" --threads 2 mesh "$ct" --iso 500 --graded -o head.mesh >head.txt 2>err.txt
    if /usr/bin/python3 - <<'PY'
import sys
pts, tets, sec = [], [], None
with open("head.mesh") as f:
    lines = iter(f.read().split("\n"))
for line in lines:
    w = line.split()
    if w in (["Vertices"], ["Tetrahedra"]):
        sec, n = w[0], int(next(lines))
        for _ in range(n):
            v = next(lines).split()
            (pts if sec == "Vertices" else tets).append(
                tuple(map(float, v[:3])) if sec == "Vertices" else tuple(int(x) - 1 for x in v[:4]))
count = {}
for t in tets:
    for f in ((t[1], t[2], t[3]), (t[0], t[2], t[3]), (t[0], t[1], t[3]), (t[0], t[1], t[2])):
        k = tuple(sorted(f))
        count[k] = count.get(k, 0) + 1
tris = [k for k, c in count.items() if c == 1]
def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
def dot(a, b): return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
def dist2(p, a, b, c):
    # nearest point of triangle abc to p, by its Voronoi regions (Ericson, ch. 5.1.5)
    ab, ac, ap = sub(b, a), sub(c, a), sub(p, a)
    d1, d2 = dot(ab, ap), dot(ac, ap)
    if d1 <= 0 and d2 <= 0: return dot(ap, ap)
    bp = sub(p, b); d3, d4 = dot(ab, bp), dot(ac, bp)
    if d3 >= 0 and d4 <= d3: return dot(bp, bp)
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        v = d1 / (d1 - d3); q = tuple(a[i] + v * ab[i] for i in range(3)); return dot(sub(p, q), sub(p, q))
    cp = sub(p, c); d5, d6 = dot(ab, cp), dot(ac, cp)
    if d6 >= 0 and d5 <= d6: return dot(cp, cp)
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        w = d2 / (d2 - d6); q = tuple(a[i] + w * ac[i] for i in range(3)); return dot(sub(p, q), sub(p, q))
    va = d3 * d6 - d5 * d4
    if va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6)); q = tuple(b[i] + w * (c[i] - b[i]) for i in range(3))
        return dot(sub(p, q), sub(p, q))
    den = 1 / (va + vb + vc); v, w = vb * den, vc * den
    q = tuple(a[i] + v * ab[i] + w * ac[i] for i in range(3)); return dot(sub(p, q), sub(p, q))
sp = (3.2, 3.2, 1.5)
voxel = (sp[0] * sp[1] * sp[2]) ** (1 / 3)
bound = 0.55 * voxel
worst = 0
for ijk in ((33, 41.65, 26), (32.71, 42, 23), (33, 46.62, 32), (25.98, 45, 64), (40, 42.96, 55),
            (57, 12.2, 92), (26, 3.05, 0)):
    p = tuple(ijk[i] * sp[i] for i in range(3))
    near = [t for t in tris if min(dot(sub(p, pts[i]), sub(p, pts[i])) for i in t) < 100]
    d = min((dist2(p, pts[t[0]], pts[t[1]], pts[t[2]]) for t in near), default=1e9) ** 0.5
    worst = max(worst, d / voxel)
    if d > bound:
        print("isosurface point", ijk, "is %.3f voxel from the boundary" % (d / voxel))
sys.exit(worst > 0.55)
PY
    then ok; else bad "CT head --graded: cavities and thin bone beyond D + 5% $(cat head.txt err.txt)"; fi
    # 8. a job of the quality pass whose bad tets a job before it mended (none left to work
    # on) is skipped: on this mesh the pass ended "improve: out of memory" (2026-12-07)
    if "$VM_CLI" mesh "$ct" --iso 500 --graded --distance 1.242893 -o d.vtu >d.txt 2>err.txt &&
        grep -q "15\.[0-9]*\.\.1[0-4][0-9]\.[0-9]* deg\|15\.[0-9]*\.\.150\.00 deg" d.txt; then
        ok
    else
        bad "CT head --distance 1.242893: $(cat d.txt err.txt)"
    fi
    # 9. the quality targets at distances where the pass missed them (2026-12-07): at 1.15
    # the stuffing's cuts a hair beyond the top border plane stayed as clusters of points
    # 0.03 mm apart (0.59 degrees: their triangles were read beyond the volume and refused);
    # at 1.45 a tet on a flat triangle of the bottom plane kept 13.05 degrees (no flip in a
    # border plane)
    for d in 1.15 1.45; do
        if "$VM_CLI" mesh "$ct" --iso 500 --graded --distance $d -o d.vtu >d.txt 2>err.txt &&
            grep -q "15\.[0-9]*\.\.1[0-4][0-9]\.[0-9]* deg\|15\.[0-9]*\.\.150\.00 deg" d.txt &&
            ! grep -q "quality pass:" d.txt err.txt; then
            ok
        else
            bad "CT head --distance $d: $(cat d.txt err.txt)"
        fi
    done
else
    echo "note: ../shared/data/ct_head_quarter.nrrd missing: the CT head case skipped"
fi

# 5. --no-coarsen keeps the stuffed mesh: more tets than the default, the same topology
"$VM_CLI" mesh ball.mha --iso 0 --no-coarsen --no-improve --json -o stuffed.vtu >st.json 2>err.txt
"$VM_CLI" mesh ball.mha --iso 0 --graded --no-improve --json -o coarse.vtu >co.json 2>>err.txt
s=$(json '(d["elements"], d["boundary_euler"], d["components"])' <st.json 2>/dev/null)
c=$(json '(d["elements"], d["boundary_euler"], d["components"])' <co.json 2>/dev/null)
if /usr/bin/python3 -c "s, c = $s, $c; import sys; sys.exit(not (s[1:] == c[1:] == (2, 1) and c[0] * 2 <= s[0]))" 2>/dev/null; then
    ok
else
    bad "--no-coarsen: stuffed $s, coarsened $c $(cat err.txt)"
fi

echo "test_sizing_cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
