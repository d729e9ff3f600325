# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_anisotropic_cli.sh — anisotropic voxels through dual contouring and the
# quality pass (issue 31, item 5): a ball at spacing 1:1:10 keeps its volume within 2% of the
# mesh before the pass, with a min dihedral >= 15 degrees and exit 0; at 1:1:50, where the pass
# loses a third of it, the run is never silent: exit 1 and one warning line that gives the
# change and names the anisotropic voxels as its cause.
#
# Run by ctest as `bash test_anisotropic_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_anisotropic_cli.XXXXXX") || exit 1
trap 'rm -rf "$WORK"' EXIT
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
# field NAME FILE: a number of a one-line JSON summary
field() { sed -n "s/.*\"$1\": \([-0-9.e+]*\).*/\1/p" "$2"; }

"$CLI" demo --shape sphere --size 40 --quiet >/dev/null || fail "demo"

# 1:1:10: the pass keeps the volume (within 2%) and meets 15 degrees
"$CLI" mesh phantom.nrrd --iso 0 --spacing 1,1,10 --no-improve --json -o before.vtu \
    >before.json 2>before.err
"$CLI" mesh phantom.nrrd --iso 0 --spacing 1,1,10 --json -o after.vtu >after.json 2>after.err
rc=$?
v0=$(field volume before.json)
v1=$(field volume after.json)
dmin=$(field min_dihedral after.json)
inv=$(field inverted after.json)
if [ "$rc" -eq 0 ] && [ -n "$v0" ] && [ -n "$v1" ] && [ "$inv" = 0 ] &&
    awk -v a="$v0" -v b="$v1" -v d="$dmin" \
        'BEGIN { e = (b - a) / a; exit !(e <= 0.02 && e >= -0.02 && d >= 15) }'; then
    pass
else
    fail "1:1:10 keeps its volume and 15 degrees" "exit $rc, volume $v0 -> $v1, min dihedral $dmin" \
        "stderr: $(cat after.err)"
fi

# 1:1:50: not silent
"$CLI" mesh phantom.nrrd --iso 0 --spacing 1,1,50 --quiet -o long.vtu >long.out 2>long.err
rc=$?
if [ "$rc" -eq 1 ] && [ "$(wc -l <long.err)" -eq 1 ] &&
    grep -q 'long.vtu: warning: the quality pass changed the volume by -' long.err &&
    grep -q 'voxels 50 times longer than wide' long.err; then
    pass
else
    fail "1:1:50 is a failed check with its cause" "exit $rc (want 1)" "stderr: $(cat long.err)"
fi
# isotropic voxels: no note at all
"$CLI" mesh phantom.nrrd --iso 0 --quiet -o iso.vtu >iso.out 2>iso.err
rc=$?
if [ "$rc" -eq 0 ] && [ ! -s iso.err ] && ! grep -q 'quality pass: volume' iso.out; then pass; else
    fail "isotropic voxels: exit 0, no volume note" "exit $rc" "$(cat iso.out iso.err)"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
