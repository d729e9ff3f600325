# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_preprocess.sh — `volmesh denoise` and `volmesh spectrum` as a user meets them:
# help, bad input (exit 2, one "volmesh: " line, no output file left), outputs (NRRD with the
# input's geometry, CSV rows, SVG and JSON that parse), the CT head's suggested isovalues.
#
# Run by ctest as `bash test_preprocess.sh` with VM_CLI (the program), VM_SHARED_DATA,
# VM_TEST_TMP set. Exit 0 pass, 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ]; then CLI=$(command -v volmesh || true); fi
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
DATA=${VM_SHARED_DATA:-}
PY=/usr/bin/python3

WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_preprocess.XXXXXX") || {
    echo "cannot make a temporary folder"
    exit 1
}
trap 'rm -rf "$WORK"' EXIT
OUT=$WORK/stdout
ERR=$WORK/stderr
cd "$WORK" || exit 1

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
shown() { printf '%s' "$*" | sed "s|$CLI|volmesh|"; }

expect_usage() {
    local name=$1
    shift
    run "$@"
    if [ "$rc" -eq 0 ] && head -n 1 "$OUT" | grep -q '^usage: volmesh' && [ ! -s "$ERR" ]; then
        pass
    else
        fail "$name: $(shown "$*")" "exit $rc (want 0)" "stdout: $(head -n 2 "$OUT")"
    fi
}

# expect_input_error NAME WORD CMD...: exit 2, nothing on stdout, one stderr line
# "volmesh: ..." containing WORD, and no file matching out* or *.tmp-* left in the folder.
expect_input_error() {
    local name=$1 word=$2
    shift 2
    run "$@"
    local lines left
    lines=$(wc -l <"$ERR")
    left=$(ls -A | grep -E '^out|\.tmp-' || true)
    if [ "$rc" -eq 2 ] && [ ! -s "$OUT" ] && [ "$lines" -eq 1 ] &&
        head -n 1 "$ERR" | grep -q '^volmesh: ' && grep -qF -- "$word" "$ERR" && [ -z "$left" ]; then
        pass
    else
        fail "$name: $(shown "$*")" "exit $rc (want 2), $lines stderr lines (want 1 naming '$word')" \
            "stderr: $(head -n 3 "$ERR")" "files left: $left"
    fi
    rm -f out* ./*.tmp-*
}

# make_nrrd FILE NX NY NZ SX SY SZ AWK_EXPR: an ASCII NRRD whose sample (i,j,k) is AWK_EXPR.
make_nrrd() {
    local file=$1 nx=$2 ny=$3 nz=$4 sx=$5 sy=$6 sz=$7 expr=$8
    {
        printf 'NRRD0004\ntype: float\ndimension: 3\nsizes: %s %s %s\n' "$nx" "$ny" "$nz"
        printf 'spacings: %s %s %s\nencoding: ascii\n\n' "$sx" "$sy" "$sz"
        awk -v nx="$nx" -v ny="$ny" -v nz="$nz" "BEGIN {
            srand(7);
            for (k = 0; k < nz; k++) for (j = 0; j < ny; j++) for (i = 0; i < nx; i++)
                printf \"%.6f\\n\", $expr }"
    } >"$file"
}

# A noisy ball (distance field, radius 6, noise ~0.6) on 20x20x16 samples, spacing 1 1 1.5;
# a constant volume.
make_nrrd ball.nrrd 20 20 16 1 1 1.5 \
    '6 - sqrt((i-9.5)^2 + (j-9.5)^2 + ((k-7.5)*1.5)^2) + (rand() + rand() + rand() - 1.5)'
make_nrrd flat.nrrd 6 6 6 1 1 1 '3'

# ---- help ---------------------------------------------------------------------------------
expect_usage "denoise help" "$CLI" denoise --help
expect_usage "spectrum help" "$CLI" spectrum -h

# ---- denoise: bad input -------------------------------------------------------------------
expect_input_error "denoise without input" "no input" "$CLI" denoise
expect_input_error "denoise without -o" "-o" "$CLI" denoise ball.nrrd
expect_input_error "denoise missing file" "no-such.nrrd" "$CLI" denoise no-such.nrrd -o out.nrrd
expect_input_error "denoise unknown method" "median" "$CLI" denoise ball.nrrd -o out.nrrd \
    --method median
expect_input_error "denoise output not NRRD" "out.vti" "$CLI" denoise ball.nrrd -o out.vti
# the extension's case does not matter, as for every reader and writer
if "$CLI" denoise ball.nrrd -o upper.NRRD >/dev/null 2>&1 && [ -s upper.NRRD ] &&
    "$CLI" info upper.NRRD >/dev/null 2>&1; then pass; else fail "denoise -o upper.NRRD"; fi
rm -f upper.NRRD
expect_input_error "denoise negative sigma" "--sigma-space" "$CLI" denoise ball.nrrd -o out.nrrd \
    --sigma-space -1
expect_input_error "denoise bad number" "--sigma-range" "$CLI" denoise ball.nrrd -o out.nrrd \
    --sigma-range abc
expect_input_error "denoise kappa with bilateral" "--kappa" "$CLI" denoise ball.nrrd -o out.nrrd \
    --kappa 2
expect_input_error "denoise sigma with diffusion" "--sigma-space" "$CLI" denoise ball.nrrd \
    -o out.nrrd --method diffusion --sigma-space 2
expect_input_error "denoise unstable dt" "stability" "$CLI" denoise ball.nrrd -o out.nrrd \
    --method diffusion --dt 0.5
expect_input_error "denoise zero iterations" "--iterations" "$CLI" denoise ball.nrrd -o out.nrrd \
    --method diffusion --iterations 0
expect_input_error "denoise huge sigma" "sigma-space" "$CLI" denoise ball.nrrd -o out.nrrd \
    --sigma-space 1000
expect_input_error "denoise unknown option" "--frobnicate" "$CLI" denoise ball.nrrd -o out.nrrd \
    --frobnicate

# ---- denoise: outputs keep the geometry ---------------------------------------------------
for method in bilateral diffusion; do
    run "$CLI" denoise ball.nrrd -o "den-$method.nrrd" --method "$method"
    if [ "$rc" -eq 0 ] && [ -s "den-$method.nrrd" ] && grep -q "$method" "$OUT" &&
        [ ! -s "$ERR" ]; then
        pass
    else
        fail "denoise --method $method" "exit $rc" "stdout: $(head -n 2 "$OUT")" \
            "stderr: $(head -n 2 "$ERR")"
    fi
    run "$CLI" info --json "den-$method.nrrd"
    if [ "$rc" -eq 0 ] && grep -q '"dims": \[20, 20, 16\]' "$OUT" &&
        grep -q '"spacing": \[1, 1, 1.5\]' "$OUT"; then
        pass
    else
        fail "denoised $method keeps dims and spacing" "$(head -c 300 "$OUT")"
    fi
done
run "$CLI" denoise ball.nrrd -o quiet.nrrd --method diffusion --kappa 3 --dt 0.1 --iterations 4 \
    --quiet
if [ "$rc" -eq 0 ] && [ ! -s "$OUT" ] && [ ! -s "$ERR" ] && [ -s quiet.nrrd ]; then
    pass
else
    fail "denoise --quiet prints nothing" "exit $rc" "stdout: $(head -n 2 "$OUT")"
fi
rm -f quiet.nrrd
# the noisy ball has specks around it at the level 0; the denoised one is a single component
run "$CLI" spectrum den-diffusion.nrrd --range -1:1 --n 3 --json
if [ "$rc" -eq 0 ] && grep -q '"components": \[[0-9]*, 1, ' "$OUT"; then
    pass
else
    fail "denoised ball is one component at 0" "$(grep -o '"components": [^]]*]' "$OUT")"
fi

# ---- spectrum: bad input ------------------------------------------------------------------
expect_input_error "spectrum without input" "no input" "$CLI" spectrum
expect_input_error "spectrum constant volume" "constant" "$CLI" spectrum flat.nrrd
expect_input_error "spectrum bad --n" "--n" "$CLI" spectrum ball.nrrd --n 1
expect_input_error "spectrum bad --range" "--range" "$CLI" spectrum ball.nrrd --range 5
expect_input_error "spectrum empty --range" "--range" "$CLI" spectrum ball.nrrd --range 3:1
expect_input_error "spectrum missing file" "nope.nrrd" "$CLI" spectrum nope.nrrd --csv out.csv
expect_input_error "spectrum unwritable csv" "no-dir/out.csv" "$CLI" spectrum ball.nrrd \
    --csv no-dir/out.csv

# ---- spectrum: outputs --------------------------------------------------------------------
run "$CLI" spectrum ball.nrrd --n 64 --csv spec.csv --svg spec.svg
if [ "$rc" -eq 0 ] && grep -q 'suggested\|no suggested' "$OUT" && grep -q 'intervals' "$OUT"; then
    pass
else
    fail "spectrum table" "exit $rc" "$(head -n 3 "$OUT")" "$(head -n 2 "$ERR")"
fi
if [ "$(head -n 1 spec.csv)" = "isovalue,area,volume,gradient_integral,components" ] &&
    [ "$(wc -l <spec.csv)" -eq 65 ]; then
    pass
else
    fail "spectrum CSV has the header and 64 rows" "$(head -n 2 spec.csv)"
fi
if [ -n "$(ls -A | grep '\.tmp-' || true)" ]; then
    fail "spectrum left temporary files" "$(ls -A)"
else
    pass
fi
if [ -x "$PY" ]; then
    if msg=$("$PY" -c '
import sys, xml.etree.ElementTree as ET
root = ET.parse(sys.argv[1]).getroot()
ns = "{http://www.w3.org/2000/svg}"
texts = " ".join(t.text or "" for t in root.iter(ns + "text"))
lines = list(root.iter(ns + "polyline"))
bad = []
if len(lines) != 5: bad.append("%d curves, want 5" % len(lines))
for word in ("isovalue", "area", "volume", "gradient integral", "components", "suggested"):
    if word not in texts: bad.append("no label %r" % word)
print("; ".join(bad)); sys.exit(1 if bad else 0)' spec.svg 2>&1); then
        pass
    else
        fail "spectrum SVG parses, with 5 curves, axis labels and a legend" "$msg"
    fi
    run "$CLI" spectrum ball.nrrd --n 33 --range -2:2 --json
    if msg=$("$PY" -c '
import json, math, sys
d = json.load(open(sys.argv[1]))
bad = []
for key in ("isovalue", "area", "volume", "gradient_integral", "components"):
    if len(d[key]) != 33: bad.append("%s has %d entries" % (key, len(d[key])))
if d["lo"] != -2 or d["hi"] != 2: bad.append("range %r:%r" % (d["lo"], d["hi"]))
if len(d["intervals"]) != len(d["suggestions"]) + 1: bad.append("intervals vs suggestions")
# the ball of radius 6 (world units, spacing applied): area and volume at 0 within 15%
# (the noise roughens the surface, which adds area)
k = 16
if abs(d["isovalue"][k]) > 1e-9: bad.append("middle isovalue %r" % d["isovalue"][k])
vol = 4.0 / 3.0 * math.pi * 6 ** 3
if abs(d["volume"][k] - vol) > 0.15 * vol: bad.append("volume %g vs %g" % (d["volume"][k], vol))
print("; ".join(bad)); sys.exit(1 if bad else 0)' "$OUT" 2>&1); then
        pass
    else
        fail "spectrum --json has the arrays and the ball's volume" "$msg"
    fi
else
    echo "note: $PY is absent; skipping the SVG and JSON checks"
fi

# ---- the CT head: skin and bone among the suggestions -------------------------------------
if [ -n "$DATA" ] && [ -f "$DATA/ct_head_quarter.nrrd" ]; then
    run "$CLI" spectrum "$DATA/ct_head_quarter.nrrd" --json
    if [ "$rc" -eq 0 ] && [ -x "$PY" ] && msg=$("$PY" -c '
import json, sys
s = [g["isovalue"] for g in json.load(open(sys.argv[1]))["suggestions"]]
ok = any(abs(v - 500) <= 150 for v in s) and any(abs(v - 1150) <= 250 for v in s)
print("suggestions %r" % s); sys.exit(0 if ok else 1)' "$OUT" 2>&1); then
        pass
    else
        fail "CT head suggestions include skin (~500) and bone (~1150)" "exit $rc" "${msg:-}"
    fi
    run "$CLI" denoise "$DATA/ct_head_quarter.nrrd" -o ct.nrrd --method diffusion
    if [ "$rc" -eq 0 ] && [ -s ct.nrrd ]; then pass; else fail "denoise the CT head" "$(cat "$ERR")"; fi
else
    echo "note: shared data absent; skipping the CT head checks"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
