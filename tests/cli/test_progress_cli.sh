#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Progress bars as a user sees them on a terminal (run under `script`, which gives the
# program a pseudo-terminal): every stage of `mesh --report --surface`, `quality`, `report`
# and `convert` draws a bar that only moves forward and ends at 100 %; nothing is drawn with
# --quiet or when stderr is not a terminal.
set -u
command -v script >/dev/null || { echo "SKIP: no 'script' program (util-linux)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
pass=0 fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
"$VM_CLI" demo --shape genus3 --size 40 >/dev/null || bad "demo"

# Runs "$@" on a pseudo-terminal; prints its terminal output with each bar redraw on a line.
on_tty() {
    local cmd
    printf -v cmd '%q ' "$@"
    script -qec "$cmd" tty.log >/dev/null 2>&1
    local rc=$?
    tr '\r' '\n' <tty.log | tr -d '\033'
    return $rc
}

# Checks the bars in the terminal output on stdin: every stage in $1 (space-separated) drew
# a bar, each stage's percentages never go back within one bar, and each bar reaches 100.
check_bars() {
    cat >bars.txt
    /usr/bin/python3 - "$1" <<'PY'
import re, sys
want = sys.argv[1].split()
text = open("bars.txt", errors="replace").read()
runs = []  # (stage, [percent, ...]) in order of appearance
for line in text.split("\n"):
    m = re.match(r"^(\S+)\s+\[[# ]*\]\s+(\d+)%", line)
    if not m:
        continue
    stage, pct = m.group(1), int(m.group(2))
    if runs and runs[-1][0] == stage and pct >= runs[-1][1][-1] and runs[-1][1][-1] < 100:
        runs[-1][1].append(pct)
    else:
        runs.append((stage, [pct]))
errors = []
for stage, pcts in runs:
    if pcts[-1] != 100:
        errors.append("%s ends at %d%%: %s" % (stage, pcts[-1], pcts))
seen = [s for s, _ in runs]
for s in want:
    if s not in seen:
        errors.append("no bar for %s (saw %s)" % (s, " ".join(seen)))
print("; ".join(errors))
sys.exit(1 if errors else 0)
PY
}

out=$(on_tty "$VM_CLI" mesh phantom.nrrd --iso 0 -o m.vtu --report m.html --surface m-surf.stl) ||
    bad "mesh on a terminal"
msg=$(printf '%s\n' "$out" | check_bars "contour improve write check quality") && ok ||
    bad "mesh bars: $msg"
# two write bars: the mesh and its surface
[ "$(printf '%s\n' "$out" | grep -c '^write .*100%')" -ge 2 ] && ok || bad "mesh: not two write bars"
[ -s m.vtu ] && [ -s m.html ] && [ -s m-surf.stl ] && ok || bad "mesh outputs missing"

out=$(on_tty "$VM_CLI" quality m.vtu) || bad "quality on a terminal"
msg=$(printf '%s\n' "$out" | check_bars "check quality") && ok || bad "quality bars: $msg"
out=$(on_tty "$VM_CLI" report m.vtu -o r.html) || bad "report on a terminal"
msg=$(printf '%s\n' "$out" | check_bars "check quality") && ok || bad "report bars: $msg"
for f in inp msh mesh vtk ply obj off stl vtu; do
    out=$(on_tty "$VM_CLI" convert m.vtu "c.$f") || bad "convert to $f"
    msg=$(printf '%s\n' "$out" | check_bars "write") && ok || bad "convert $f bars: $msg"
done

# --quiet, and stderr not a terminal: no bar at all
out=$(on_tty "$VM_CLI" mesh phantom.nrrd --iso 0 -o q.vtu --report q.html --quiet)
printf '%s\n' "$out" | grep -q '%' && bad "mesh --quiet drew a bar" || ok
out=$(on_tty "$VM_CLI" quality m.vtu --quiet)
printf '%s\n' "$out" | grep -q '\] *[0-9]*%' && bad "quality --quiet drew a bar" || ok
out=$(on_tty "$VM_CLI" report m.vtu -o r2.html -q)
printf '%s\n' "$out" | grep -q '%' && bad "report -q drew a bar" || ok
err=$("$VM_CLI" mesh phantom.nrrd --iso 0 -o n.vtu --report n.html 2>&1 >/dev/null)
[ -z "$err" ] && ok || bad "stderr not a terminal but got: $err"
echo "$pass passed, $fail failed"
[ $fail = 0 ]
