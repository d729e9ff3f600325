# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_quality_cli.sh — `volmesh quality` as a user meets it: --help, the text table,
# --json keys (checked with python), --svg, --per-cell-csv, --require (met, unmet, unknown key,
# malformed), --abaqus, and bad input (exit 2, one "volmesh: " line).
#
# Run by ctest as `bash test_quality_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
PY=/usr/bin/python3
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_quality_cli.XXXXXX") || exit 1
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
# expect NAME RC CMD...: exit status RC.
expect() {
    local name=$1 want=$2
    shift 2
    run "$@"
    if [ "$rc" -eq "$want" ]; then pass; else
        fail "$name" "exit $rc (want $want)" "stdout: $(head -n 3 "$OUT")" "stderr: $(head -n 3 "$ERR")"
    fi
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

# --- help and usage -------------------------------------------------------------------------
run "$CLI" quality --help
if [ "$rc" -eq 0 ] && head -n 1 "$OUT" | grep -q '^usage: volmesh quality' && [ ! -s "$ERR" ]; then
    pass
else fail "quality --help" "exit $rc"; fi
expect_input_error "no file" "no mesh file" "$CLI" quality
expect_input_error "unknown option" "--bogus" "$CLI" quality x.vtu --bogus
expect_input_error "missing file" "missing.vtu" "$CLI" quality missing.vtu
expect_input_error "--svg without value" "--svg" "$CLI" quality x.vtu --svg
printf 'not a mesh\n' >garbage.vtu
expect_input_error "garbage file" "garbage.vtu" "$CLI" quality garbage.vtu

# --- a real mesh: the demo torus --------------------------------------------------------------
run "$CLI" demo --size 24
if [ "$rc" -ne 0 ] || [ ! -s demo.vtu ]; then
    fail "demo --size 24 writes demo.vtu" "exit $rc" "$(head -n 3 "$ERR")"
    echo "$passed passed, $failed failed"
    exit 1
fi
expect "text report" 0 "$CLI" quality demo.vtu
for word in "elements" "inverted" "boundary     closed" "Euler characteristic 0" "slivers" \
    "ABAQUS" "min_dihedral" "radius_ratio" "volume_measure" "histograms"; do
    if grep -qF -- "$word" "$OUT"; then pass; else fail "text report shows '$word'"; fi
done

expect "json report" 0 "$CLI" quality demo.vtu --json --svg q.svg --per-cell-csv cells.csv
cp "$OUT" report.json
if "$PY" - report.json cells.csv q.svg <<'PYEOF'; then pass; else fail "json/csv/svg contents"; fi
import csv, json, sys
import xml.dom.minidom
r = json.load(open(sys.argv[1]))
need = ["elements", "inverted", "min_dihedral", "max_dihedral", "slivers_5", "slivers_10",
        "abaqus_failures", "boundary_euler", "volume", "min_scaled_jacobian", "metrics"]
missing = [k for k in need if k not in r]
assert not missing, missing
assert r["kind"] == "tet4" and r["elements"] > 100 and r["inverted"] == 0, r
assert r["boundary_euler"] == 0 and r["boundary_closed"] is True, "torus"
m = r["metrics"]
for name in ("min_dihedral", "max_dihedral", "radius_ratio", "aspect_ratio", "edge_ratio",
             "min_face_angle", "max_face_angle", "scaled_jacobian", "volume_measure", "volume"):
    s = m[name]
    assert s["min"] <= s["mean"] <= s["max"], name
    assert sum(s["histogram"]["counts"]) == r["elements"], name
    assert len(s["histogram"]["counts"]) == r["histogram_bins"] == 20
assert abs(m["min_dihedral"]["min"] - r["min_dihedral"]) < 1e-9
rows = list(csv.DictReader(open(sys.argv[2])))
assert len(rows) == r["elements"]
assert abs(min(float(x["min_dihedral"]) for x in rows) - r["min_dihedral"]) < 1e-12
assert abs(sum(float(x["volume"]) for x in rows) - r["volume"]) < 1e-9 * abs(r["volume"])
svg = xml.dom.minidom.parse(sys.argv[3])
assert len(svg.getElementsByTagName("g")) == len(m) + 1, "one panel per metric, one for edges"
PYEOF

# --- requirements ----------------------------------------------------------------------------
expect "requirement met" 0 "$CLI" quality demo.vtu --require "inverted==0" --require "elements>0"
expect "requirement with spaces" 0 "$CLI" quality demo.vtu --require "min_dihedral >= 0"
expect "unmet requirement" 1 "$CLI" quality demo.vtu --require "min_dihedral>=89" --json
if grep -q "requirement not met: min_dihedral>=89" "$ERR"; then pass; else
    fail "unmet requirement is named" "$(cat "$ERR")"; fi
expect "metric requirement" 1 "$CLI" quality demo.vtu --require "radius_ratio.max<1"
expect_input_error "unknown key" "no key 'bogus'" "$CLI" quality demo.vtu --require "bogus>=1"
expect_input_error "malformed requirement" "no comparison" "$CLI" quality demo.vtu --require "inverted"
expect_input_error "requirement without number" "does not end in a number" \
    "$CLI" quality demo.vtu --require "inverted==zero"

# --- ABAQUS: the demo torus passes or not; the exit status must match the JSON count ---------
n=$("$PY" -c 'import json,sys; print(json.load(open(sys.argv[1]))["abaqus_failures"])' report.json)
if [ "$n" -eq 0 ]; then want=0; else want=1; fi
expect "--abaqus exit status" "$want" "$CLI" quality demo.vtu --abaqus

# --- hex mesh: no dihedral keys ----------------------------------------------------------------
"$PY" - <<'PYEOF'
import vtk
g = vtk.vtkUnstructuredGrid(); p = vtk.vtkPoints(); p.SetDataTypeToDouble()
for z in (0, 1):
    for y in (0, 1):
        for x in (0, 1, 2):
            p.InsertNextPoint(x, y, z)
g.SetPoints(p)
idx = lambda x, y, z: x + 3 * y + 6 * z
for x in (0, 1):
    g.InsertNextCell(12, 8, [idx(x, 0, 0), idx(x + 1, 0, 0), idx(x + 1, 1, 0), idx(x, 1, 0),
                             idx(x, 0, 1), idx(x + 1, 0, 1), idx(x + 1, 1, 1), idx(x, 1, 1)])
w = vtk.vtkXMLUnstructuredGridWriter(); w.SetFileName("hex.vtu"); w.SetInputData(g); w.Write()
PYEOF
expect "hex report" 0 "$CLI" quality hex.vtu --json --require "skew.max<=0" --require "volume==2"
if grep -q '"min_dihedral": null' "$OUT" && grep -q '"kind": "hex8"' "$OUT"; then pass; else
    fail "hex json" "$(head -c 300 "$OUT")"; fi
expect_input_error "dihedral of hexes" "no key 'min_dihedral'" \
    "$CLI" quality hex.vtu --require "min_dihedral>=10"

# --- unwritable outputs ------------------------------------------------------------------------
expect_input_error "unwritable svg" "nonexistent-dir" "$CLI" quality demo.vtu --svg /nonexistent-dir/q.svg
if ls "$WORK" | grep -q 'tmp-'; then fail "temporary files left behind" "$(ls "$WORK")"; else pass; fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
