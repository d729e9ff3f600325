# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_outputs_cli.sh — every output is checked before the input is read, and the
# outputs of a run are committed together (issue 31, item 6): a bad -o, --surface or --report
# (extension, missing folder, a folder, options that do not fit the format) is exit 2 naming it
# even when the input does not exist; a run that fails after writing -o leaves no file and
# keeps an older output, and prints no summary of it; spectrum's --csv and --svg likewise.
#
# Run by ctest as `bash test_outputs_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_outputs_cli.XXXXXX") || exit 1
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
# no_leftovers NAME: nothing but the files given stays in WORK (no temporary file either).
no_leftovers() {
    local name=$1
    shift
    local extra
    extra=$(ls -A | grep -v -x -F -e stdout -e stderr $(printf -- '-e %s ' "$@"))
    if [ -z "$extra" ]; then pass; else fail "$name: files left behind" "$extra"; fi
}

mkdir folder.vtu
# --- mesh: each bad output is named although the input does not exist (checked first) -------
M=("$CLI" mesh missing.nrrd --iso 0)
expect_input_error "-o .nrrd" "x.nrrd: unknown mesh format" "${M[@]}" -o x.nrrd
expect_input_error "-o without extension" "unknown mesh format" "${M[@]}" -o x
expect_input_error "-o in a missing folder" "folder nodir does not exist" "${M[@]}" -o nodir/x.vtu
expect_input_error "-o a folder" "folder.vtu: is a folder" "${M[@]}" -o folder.vtu
expect_input_error "-o ending in /" "is a folder" "${M[@]}" -o sub.vtu/
expect_input_error "--deck with .vtu" "analysis deck needs .inp" "${M[@]}" -o x.vtu --deck static
expect_input_error "--order 2 with .mesh" "second-order" "${M[@]}" -o x.mesh --order 2
expect_input_error "--surface in a missing folder" "nodir/s.vtu" "${M[@]}" -o x.vtu \
    --surface nodir/s.vtu
expect_input_error "--surface .nrrd" "s.nrrd: unknown mesh format" "${M[@]}" -o x.vtu \
    --surface s.nrrd
expect_input_error "--report .txt" "r.txt" "${M[@]}" -o x.vtu --report r.txt
expect_input_error "--report in a missing folder" "nodir/r.html" "${M[@]}" -o x.vtu \
    --report nodir/r.html
expect_input_error "--surface same as -o" "same file" "${M[@]}" -o x.vtu --surface x.vtu
if [ "$(id -u)" -ne 0 ]; then
    mkdir ro && chmod 555 ro
    expect_input_error "-o in an unwritable folder" "cannot write in folder ro" "${M[@]}" \
        -o ro/x.vtu
    rmdir ro
fi
no_leftovers "bad mesh outputs" folder.vtu

# --- the other commands ------------------------------------------------------------------------
expect_input_error "report -o .txt" "r.txt" "$CLI" report missing.vtu -o r.txt
expect_input_error "report -o missing folder" "nodir" "$CLI" report missing.vtu -o nodir/r.html
expect_input_error "convert to a folder" "folder.vtu: is a folder" "$CLI" convert missing.obj \
    folder.vtu
expect_input_error "denoise -o missing folder" "nodir" "$CLI" denoise missing.nrrd \
    -o nodir/d.nrrd
expect_input_error "spectrum --csv .txt" "c.txt" "$CLI" spectrum missing.nrrd --csv c.txt
expect_input_error "quality --svg missing folder" "nodir" "$CLI" quality missing.vtu \
    --svg nodir/q.svg
no_leftovers "bad outputs of other commands" folder.vtu

# --- all outputs of a run are committed together ----------------------------------------------
run "$CLI" demo --size 24 --quiet
if [ "$rc" -eq 0 ] && [ -s phantom.nrrd ]; then pass; else fail "demo" "exit $rc"; fi
rm -f demo.vtu demo-surface.vtu demo-report.html
echo old >x.vtu
echo old >old.copy
# A file size limit that the mesh (about 75 KB) passes and the report (about 400 KB) does not:
# writing the report fails after -o and --surface are written.
(
    trap '' XFSZ
    ulimit -f 250
    exec "$CLI" mesh phantom.nrrd --iso 0 --quiet -o x.vtu --surface s.vtu --report r.html
) >"$OUT" 2>"$ERR"
rc=$?
if [ "$rc" -eq 2 ] && grep -q 'r.html' "$ERR"; then pass; else
    fail "a failing --report" "exit $rc (want 2)" "stderr: $(cat "$ERR")"
fi
# the summary describes the mesh written: none is printed when the outputs are not committed
if [ ! -s "$OUT" ]; then pass; else
    fail "a failing --report prints no summary" "stdout: $(head -n 2 "$OUT")"
fi
if cmp -s x.vtu old.copy; then pass; else fail "the older -o survives a failed run"; fi
no_leftovers "a failed run" folder.vtu phantom.nrrd x.vtu old.copy
# the same run without the limit writes all three
run "$CLI" mesh phantom.nrrd --iso 0 --quiet -o x.vtu --surface s.vtu --report r.html
if [ "$rc" -eq 0 ] && [ -s s.vtu ] && [ -s r.html ] && ! cmp -s x.vtu old.copy; then pass; else
    fail "a run that succeeds writes every output" "exit $rc" "stderr: $(cat "$ERR")"
fi
no_leftovers "a run that succeeds" folder.vtu phantom.nrrd x.vtu s.vtu r.html old.copy

# --- spectrum: --csv and --svg are committed together -----------------------------------------
rm -f x.vtu s.vtu r.html
echo old >c.csv
# a limit that the CSV (about 12 KB) passes and the SVG (about 21 KB) does not
(
    trap '' XFSZ
    ulimit -f 16
    exec "$CLI" spectrum phantom.nrrd --csv c.csv --svg s.svg --quiet
) >"$OUT" 2>"$ERR"
rc=$?
if [ "$rc" -eq 2 ] && grep -q 's.svg' "$ERR" && [ ! -s "$OUT" ]; then pass; else
    fail "spectrum: a failing --svg" "exit $rc (want 2)" "stderr: $(cat "$ERR")"
fi
if [ "$(cat c.csv)" = old ]; then pass; else fail "spectrum: the older --csv survives"; fi
no_leftovers "spectrum: a failed run" folder.vtu phantom.nrrd old.copy c.csv
run "$CLI" spectrum phantom.nrrd --csv c.csv --svg s.svg --quiet
if [ "$rc" -eq 0 ] && [ -s s.svg ] && head -n 1 c.csv | grep -q '^isovalue,'; then pass; else
    fail "spectrum writes both files" "exit $rc" "stderr: $(cat "$ERR")"
fi
no_leftovers "spectrum: a run that succeeds" folder.vtu phantom.nrrd old.copy c.csv s.svg

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
