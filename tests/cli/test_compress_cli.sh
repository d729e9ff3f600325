# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_compress_cli.sh — --compress fast|best|none (mesh, convert): a bad value is
# exit 2 with one line naming it, before the input is read and with no output left; each
# level writes the same bytes on 1 and 2 threads, and the same mesh (converted to MEDIT text,
# byte for byte) whatever the level; --no-compress is --compress none.
#
# Run by ctest as `bash test_compress_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_compress_cli.XXXXXX") || exit 1
trap 'rm -rf "$WORK"' EXIT
cd "$WORK" || exit 1
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
run() {
    "$@" >"$OUT" 2>"$ERR"
    rc=$?
}
# expect_input_error NAME WORD CMD...: exit 2, nothing on stdout, one stderr line with WORD.
expect_input_error() {
    local name=$1 word=$2
    shift 2
    run "$@"
    if [ "$rc" -eq 2 ] && [ ! -s "$OUT" ] && [ "$(wc -l <"$ERR")" -eq 1 ] &&
        grep -q '^volmesh: ' "$ERR" && grep -qF -- "$word" "$ERR"; then pass; else
        fail "$name" "exit $rc (want 2)" "stdout: $(head -n 2 "$OUT")" "stderr: $(cat "$ERR")"
    fi
}

# --- bad values: named, before the (missing) input is read, no file made ---------------------
expect_input_error "mesh --compress 9" "--compress: '9' is not fast, best or none" \
    "$CLI" mesh missing.nrrd --iso 0 -o x.vtu --compress 9
expect_input_error "mesh --compress FAST" "'FAST'" "$CLI" mesh missing.nrrd --iso 0 -o x.vtu \
    --compress FAST
expect_input_error "mesh --compress without a value" "--compress needs a value" \
    "$CLI" mesh missing.nrrd --iso 0 -o x.vtu --compress
expect_input_error "convert --compress zip" "--compress: 'zip'" "$CLI" convert missing.vtu \
    y.vtu --compress zip
if [ -z "$(ls -A | grep -v -x -e stdout -e stderr)" ]; then pass; else
    fail "bad values leave no file" "$(ls -A)"
fi

# --- each level: the same bytes on 1 and 2 threads, the same mesh ----------------------------
run "$CLI" demo --size 40 --quiet
if [ "$rc" -eq 0 ] && [ -s phantom.nrrd ]; then pass; else fail "demo" "exit $rc"; fi
for level in fast best none; do
    for t in 1 2; do
        run "$CLI" --threads "$t" mesh phantom.nrrd --iso 0 --no-improve --quiet \
            -o "$level-$t.vtu" --surface "$level-$t-s.vtu" --compress "$level"
        [ "$rc" -eq 0 ] || fail "mesh --compress $level on $t threads" "exit $rc" "$(cat "$ERR")"
    done
    if cmp -s "$level-1.vtu" "$level-2.vtu" && cmp -s "$level-1-s.vtu" "$level-2-s.vtu"; then
        pass
    else
        fail "--compress $level: 1 and 2 threads write different bytes"
    fi
    if [ "$level" = none ]; then
        if grep -q 'compressor=' "$level-1.vtu" "$level-1-s.vtu"; then
            fail "--compress none names a compressor"
        else pass; fi
    elif grep -q 'compressor="vtkZLibDataCompressor"' "$level-1.vtu" &&
        grep -q 'compressor="vtkZLibDataCompressor"' "$level-1-s.vtu"; then
        pass
    else
        fail "--compress $level (the mesh and --surface) names no zlib compressor"
    fi
    run "$CLI" convert "$level-1.vtu" "$level.mesh" --quiet
    [ "$rc" -eq 0 ] || fail "convert $level-1.vtu" "exit $rc" "$(cat "$ERR")"
done
if cmp -s fast.mesh best.mesh && cmp -s fast.mesh none.mesh && [ -s fast.mesh ]; then pass; else
    fail "the levels hold different meshes"
fi
size() { wc -c <"$1"; }
if [ "$(size best-1.vtu)" -lt "$(size none-1.vtu)" ] &&
    [ "$(size fast-1.vtu)" -lt "$(size none-1.vtu)" ]; then pass; else
    fail "compressed files are not smaller" "$(ls -l ./*-1.vtu)"
fi
run "$CLI" mesh phantom.nrrd --iso 0 --no-improve --quiet -o nc.vtu --no-compress
if [ "$rc" -eq 0 ] && cmp -s nc.vtu none-1.vtu; then pass; else
    fail "--no-compress is not --compress none"
fi
# convert --compress best writes what mesh --compress best wrote
run "$CLI" convert fast-1.vtu cb.vtu --compress best --quiet
if [ "$rc" -eq 0 ] && cmp -s cb.vtu best-1.vtu; then pass; else
    fail "convert --compress best" "exit $rc" "$(cat "$ERR")"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
