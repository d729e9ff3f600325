# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_cli.sh — the volmesh program as a user meets it: help and version, `info --json`
# on the shared volumes against data/README.md, bad input (exit 2, one "volmesh: " line), `demo`.
#
# Run by ctest as `bash test_cli.sh` with VM_CLI (the program), VM_SHARED_DATA (../shared/data),
# VM_TEST_TMP and VM_SOURCE_DIR set. Exit 0 pass, 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ]; then CLI=$(command -v volmesh || true); fi
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
DATA=${VM_SHARED_DATA:-}
PY=/usr/bin/python3

# Everything this test writes goes in one fresh folder, removed at the end.
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_cli.XXXXXX") || {
    echo "cannot make a temporary folder"
    exit 1
}
trap 'rm -rf "$WORK"' EXIT
OUT=$WORK/stdout
ERR=$WORK/stderr

passed=0
failed=0
pass() { passed=$((passed + 1)); }
fail() {
    failed=$((failed + 1))
    echo "FAIL: $1"
    shift
    for line in "$@"; do echo "      $line"; done
}

# run CMD...: runs in the current folder, leaving stdout in $OUT, stderr in $ERR, status in $rc.
run() {
    "$@" >"$OUT" 2>"$ERR"
    rc=$?
}

shown() { printf '%s' "$*" | sed "s|$CLI|volmesh|"; }

# expect_usage NAME CMD...: exit 0, usage text on stdout, nothing on stderr.
expect_usage() {
    local name=$1
    shift
    run "$@"
    if [ "$rc" -eq 0 ] && head -n 1 "$OUT" | grep -q '^usage: volmesh' && [ ! -s "$ERR" ]; then
        pass
    else
        fail "$name: $(shown "$*")" "exit $rc (want 0)" "stdout: $(head -n 2 "$OUT")" \
            "stderr: $(head -n 2 "$ERR")"
    fi
}

# expect_input_error NAME WORD CMD...: exit 2, nothing on stdout, exactly one line on stderr
# starting "volmesh: " and containing WORD (the file or option at fault; "" for any).
expect_input_error() {
    local name=$1 word=$2
    shift 2
    run "$@"
    local lines
    lines=$(wc -l <"$ERR")
    if [ "$rc" -eq 2 ] && [ ! -s "$OUT" ] && [ "$lines" -eq 1 ] &&
        head -n 1 "$ERR" | grep -q '^volmesh: ' && grep -qF -- "$word" "$ERR"; then
        pass
    else
        fail "$name: $(shown "$*")" "exit $rc (want 2), $lines stderr lines (want 1 naming '$word')" \
            "stderr: $(head -n 3 "$ERR")" "stdout: $(head -n 2 "$OUT")"
    fi
}

# check_json NAME EXPECTED_JSON: checks the `info --json` output in $OUT against the expected
# values: exact dims, type and format; spacing, origin, min, max, mean within a relative
# tolerance of 1e-4; and the shape of the object (every documented key, 16 histogram bins
# that count every finite voxel).
check_json() {
    local name=$1 expected=$2 msg
    if msg=$("$PY" -c '
import json, math, sys
want = json.loads(sys.argv[1])
try:
    got = json.load(open(sys.argv[2]))
except ValueError as e:
    print("output is not JSON: %s" % e)
    sys.exit(1)
bad = []
keys = ["file", "format", "dims", "type", "spacing", "origin", "direction", "voxels",
        "nonfinite", "min", "max", "mean", "histogram"]
missing = [k for k in keys if k not in got]
if missing:
    print("missing keys: %s" % ", ".join(missing))
    sys.exit(1)
def close(a, b):
    return isinstance(a, (int, float)) and math.isclose(a, b, rel_tol=1e-4, abs_tol=1e-12)
for k, v in want.items():
    g = got[k]
    if isinstance(v, list):
        ok = isinstance(g, list) and len(g) == len(v) and all(
            (x == y) if isinstance(y, int) and k == "dims" else close(x, y)
            for x, y in zip(g, v))
    elif isinstance(v, str) or k == "voxels":
        ok = g == v
    else:
        ok = close(g, v)
    if not ok:
        bad.append("%s is %r, want %r" % (k, g, v))
d = got["dims"]
if got["voxels"] != d[0] * d[1] * d[2]:
    bad.append("voxels %r is not the product of dims %r" % (got["voxels"], d))
h = got["histogram"]
if len(h) != 16 or sum(h) != got["voxels"] - got["nonfinite"]:
    bad.append("histogram %r does not have 16 bins counting every finite voxel" % (h,))
if len(got["direction"]) != 3 or any(len(r) != 3 for r in got["direction"]):
    bad.append("direction is not 3x3")
print("; ".join(bad))
sys.exit(1 if bad else 0)
' "$expected" "$OUT" 2>&1); then
        pass
    else
        fail "$name" "$msg"
    fi
}

# ---- help, version, usage errors ----------------------------------------------------------
cd "$WORK" || exit 1
expect_usage "help" "$CLI" --help
expect_usage "help (-h)" "$CLI" -h
expect_usage "info help" "$CLI" info --help
expect_usage "demo help" "$CLI" demo --help

run "$CLI" --version
if [ "$rc" -eq 0 ] && grep -qE '^volmesh [0-9]+\.[0-9]+\.[0-9]+' "$OUT" && [ ! -s "$ERR" ]; then
    pass
else
    fail "version: volmesh --version" "exit $rc, stdout: $(head -n 1 "$OUT")"
fi

# No command at all: the usage, on stderr since it answers a mistake, and exit 2.
run "$CLI"
if [ "$rc" -eq 2 ] && head -n 1 "$ERR" | grep -q '^usage: volmesh' && [ ! -s "$OUT" ]; then
    pass
else
    fail "no arguments: volmesh" "exit $rc (want 2)" "stderr: $(head -n 1 "$ERR")"
fi

expect_input_error "unknown command" "frobnicate" "$CLI" frobnicate
expect_input_error "info without a file" "info" "$CLI" info

# ---- info --json on the shared volumes ----------------------------------------------------
if [ -z "$DATA" ] || [ ! -d "$DATA" ]; then
    echo "note: shared data folder '${DATA:-VM_SHARED_DATA unset}' is absent;" \
        "skipping the checks of the six shared volumes (a fresh clone has no ../shared)"
elif [ ! -x "$PY" ]; then
    echo "note: $PY is absent; skipping the JSON checks of the shared volumes"
else
    # Expected values: data/README.md (dims, type, spacing; min/max/mean from VTK's readers).
    check_volume() {
        local file=$1 expected=$2
        if [ ! -f "$DATA/$file" ]; then
            fail "info --json $file" "$DATA/$file is missing"
            return
        fi
        run "$CLI" info --json "$DATA/$file"
        if [ "$rc" -ne 0 ]; then
            fail "info --json $file" "exit $rc" "stderr: $(head -n 2 "$ERR")"
            return
        fi
        check_json "info --json $file" "$expected"
    }
    check_volume ct_head_quarter.nrrd '{"format": "nrrd", "dims": [64, 64, 93],
        "type": "uint16", "spacing": [3.2, 3.2, 1.5], "voxels": 380928,
        "min": 0, "max": 3926, "mean": 507.687324}'
    check_volume HeadMRVolume.mhd '{"format": "metaimage", "dims": [48, 62, 42],
        "type": "uint8", "spacing": [4, 4, 4], "min": 0, "max": 255, "mean": 24.468222}'
    # The brain's origin comes from its sform (MNI space), in NIfTI's RAS world.
    check_volume avg152T1_RL_nifti.nii.gz '{"format": "nifti", "dims": [91, 109, 91],
        "type": "uint8", "spacing": [2, 2, 2], "origin": [-90, -126, -72],
        "min": 0, "max": 255, "mean": 82.897162}'
    check_volume ironProt.vtk '{"format": "vtk", "dims": [68, 68, 68], "type": "uint8",
        "spacing": [1, 1, 1], "min": 0, "max": 255, "mean": 13.138259}'
    check_volume hydrogen.vti '{"format": "vti", "dims": [64, 64, 64], "type": "float32",
        "spacing": [1, 1, 1], "min": 0, "max": 1, "mean": 0.018524}'
    # Not README's 0.383128: frogtissue.mhd says CompressedDataSize = 260020, but its .zraw
    # holds one complete 262087-byte zlib stream. VTK's reader stops at the stated size and
    # leaves the last ~1M voxels zero (mean 0.383128); volmesh inflates the whole stream, as
    # Python's zlib does on the same bytes, which gives 0.3842138.
    check_volume frogtissue.mhd '{"format": "metaimage", "dims": [500, 470, 136],
        "type": "uint8", "spacing": [1, 1, 1.5], "min": 0, "max": 29, "mean": 0.3842138}'
fi

# ---- bad input: exit 2 and one line naming the problem ------------------------------------
expect_input_error "missing file" "no-such-file.nrrd" "$CLI" info no-such-file.nrrd
mkdir -p folder.nrrd
expect_input_error "directory" "folder.nrrd" "$CLI" info folder.nrrd
: >empty.nrrd
expect_input_error "empty .nrrd" "empty.nrrd" "$CLI" info empty.nrrd

# A raw-encoded NRRD written by hand whose data stops short (64 bytes wanted, 10 given).
printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n\n0123456789' \
    >short-raw.nrrd
expect_input_error "truncated raw .nrrd" "short-raw.nrrd" "$CLI" info short-raw.nrrd
printf 'NRRD0004\ntype: uchar\ndimension: 3\nsizes: 4 4 4\nencoding: raw\n' >no-data.nrrd
expect_input_error "header-only .nrrd" "no-data.nrrd" "$CLI" info no-data.nrrd

expect_input_error "unknown extension" "volume.xyz" "$CLI" info volume.xyz
expect_input_error "info with two files" "info" "$CLI" info a.nrrd b.nrrd
expect_input_error "unknown info option" "--bogus" "$CLI" info --bogus a.nrrd
expect_input_error "unknown demo option" "--bogus" "$CLI" demo --bogus
expect_input_error "--raw-dims junk" "--raw-dims" "$CLI" info --raw-dims junk a.raw
expect_input_error "--raw-dims zero" "--raw-dims" "$CLI" info --raw-dims 4x0x4 a.raw
expect_input_error "--raw-dims no value" "--raw-dims" "$CLI" info a.raw --raw-dims
expect_input_error "--raw-type junk" "--raw-type" "$CLI" info --raw-dims 2x2x2 --raw-type cheese a.raw
head -c 100 /dev/zero >short.raw
expect_input_error "raw file shorter than its dims" "short.raw" \
    "$CLI" info short.raw --raw-dims 10x10x10
expect_input_error "raw options without --raw-dims" "--raw-dims" \
    "$CLI" info short.raw --raw-type uint16
# The same raw file read with dims that fit is fine.
run "$CLI" info --json short.raw --raw-dims 10x10x1
if [ "$rc" -eq 0 ] && grep -q '"dims": \[10, 10, 1\]' "$OUT"; then
    pass
else
    fail "raw file that fits: volmesh info --json short.raw --raw-dims 10x10x1" "exit $rc" \
        "stderr: $(head -n 2 "$ERR")"
fi

# --threads N before the command: bad counts are usage errors; any count gives the same bytes.
expect_input_error "--threads 0" "--threads" "$CLI" --threads 0 info a.nrrd
# An option whose value is missing names the option that stands in its place, in every
# command (a negative number is a value, not an option).
expect_input_error "--labels before -o" "'-o' in its place" "$CLI" mesh a.nrrd --labels -o x.vtu
expect_input_error "--iso before --adaptive" "--iso needs a value" "$CLI" mesh a.nrrd --iso --adaptive
expect_input_error "spectrum --n before --csv" "--n needs" "$CLI" spectrum a.nrrd --n --csv s.csv
expect_input_error "denoise --sigma-space before -o" "--sigma-space needs" \
    "$CLI" denoise a.nrrd --sigma-space -o b.nrrd
expect_input_error "quality --require before --json" "--require needs" "$CLI" quality m.vtu --require --json
expect_input_error "report -o before a flag" "-o needs" "$CLI" report m.vtu -o --quiet
expect_input_error "convert --format before a flag" "--format needs" "$CLI" convert a.vtu b.inp --format --quiet
expect_input_error "--raw-dims before a flag" "--raw-dims needs" "$CLI" info a.raw --raw-dims --json
# A volume given where a mesh is expected says so and how to mesh it (before opening it).
for cmd in "quality v.nrrd" "report v.nii.gz -o r.html" "convert v.mhd m.vtu"; do
    # shellcheck disable=SC2086
    expect_input_error "volume to $cmd" "image volume, not a mesh" "$CLI" $cmd
done
if [ -n "$DATA" ] && [ -f "$DATA/ironProt.vtk" ]; then
    expect_input_error "legacy VTK image to quality" "image volume, not a mesh" \
        "$CLI" quality "$DATA/ironProt.vtk"
fi
run "$CLI" mesh no-such.nrrd --iso -5 -o x.vtu
if [ "$rc" -eq 2 ] && grep -q "no-such.nrrd" "$ERR" && ! grep -q "needs a value" "$ERR"; then
    pass
else
    fail "--iso -5 is a value" "exit $rc" "stderr: $(head -n 2 "$ERR")"
fi
expect_input_error "--threads junk" "--threads" "$CLI" --threads many info a.nrrd
expect_input_error "--threads without a command" "--threads" "$CLI" --threads 2
mkdir "$WORK/threads" && cd "$WORK/threads" || exit 1
"$CLI" --threads 1 demo --size 24 >/dev/null 2>&1 && mv demo.vtu one.vtu &&
    "$CLI" --threads 2 demo --size 24 >/dev/null 2>&1 && mv demo.vtu two.vtu
if [ -s one.vtu ] && cmp -s one.vtu two.vtu; then
    pass
else
    fail "--threads 1 and --threads 2 demo meshes differ (or were not written)"
fi
# Exodus II is loaded only when a .exo is written: without its library the write fails with
# one line naming the file and the library, and leaves no file behind.
if [ -s one.vtu ]; then
    VOLMESH_EXODUS_LIBRARY=$WORK/no-such-libexo.so \
        expect_input_error "Exodus library missing" "no-such-libexo.so" "$CLI" convert one.vtu one.exo
    if [ -e one.exo ] || ls one.exo.tmp-* >/dev/null 2>&1; then
        fail "Exodus library missing: a file was left behind" "$(ls)"
    else
        pass
    fi
fi
cd "$WORK" || exit 1

# ---- demo in a fresh folder, read back -----------------------------------------------------
DEMO=$WORK/demo
mkdir "$DEMO" && cd "$DEMO" || exit 1
run "$CLI" demo
if [ "$rc" -eq 0 ] && [ -s phantom.nrrd ]; then
    pass
else
    fail "demo: volmesh demo (in an empty folder)" "exit $rc, phantom.nrrd $( [ -s phantom.nrrd ] &&
        echo present || echo absent)" "stderr: $(head -n 2 "$ERR")"
fi
leftovers=$(find . -name '*.tmp-*' | head -n 3)
if [ -z "$leftovers" ]; then
    pass
else
    fail "demo left temporary files" "$leftovers"
fi
if [ -f phantom.nrrd ]; then
    run "$CLI" info --json phantom.nrrd
    if [ "$rc" -ne 0 ]; then
        fail "info --json phantom.nrrd (from demo)" "exit $rc" "stderr: $(head -n 2 "$ERR")"
    elif [ -x "$PY" ]; then
        check_json "info --json phantom.nrrd (from demo)" '{"format": "nrrd",
            "dims": [48, 48, 48], "type": "float32", "spacing": [1, 1, 1]}'
    elif grep -q '"dims": \[48, 48, 48\]' "$OUT"; then
        pass
    else
        fail "info --json phantom.nrrd (from demo)" "dims are not 48x48x48: $(head -c 200 "$OUT")"
    fi

    # A copy of the demo volume cut in half: the gzip stream ends early.
    size=$(wc -c <phantom.nrrd)
    head -c $((size / 2)) phantom.nrrd >half.nrrd
    expect_input_error "truncated gzip .nrrd" "half.nrrd" "$CLI" info half.nrrd
    # The same bytes under a name volmesh has no reader for.
    cp phantom.nrrd phantom.xyz
    expect_input_error "unknown extension (real file)" "phantom.xyz" "$CLI" info phantom.xyz
fi
cd "$WORK" || exit 1

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
