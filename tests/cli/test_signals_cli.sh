# SPDX-License-Identifier: BSD-3-Clause
# tests/cli/test_signals_cli.sh — temporary files never outlive a run (issue 31, item 7):
# SIGTERM and SIGINT while the outputs are being written or held remove them, with exit 143
# and 130, and an older output survives; output names of 250 bytes (at NAME_MAX with the
# temporary suffix) are written.
#
# Run by ctest as `bash test_signals_cli.sh` with VM_CLI and VM_TEST_TMP set. Exit 0 pass,
# 1 fail, 77 skip (no program to test).
set -u
set -m # job control: a background job keeps SIGINT (not ignored), as in a terminal

CLI=${VM_CLI:-}
if [ -z "$CLI" ] || [ ! -x "$CLI" ]; then
    echo "skipped: no volmesh program (set VM_CLI to its path)"
    exit 77
fi
WORK=$(mktemp -d "${VM_TEST_TMP:-${TMPDIR:-/tmp}}/test_signals_cli.XXXXXX") || exit 1
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
temporaries() { ls -A | grep -e '\.tmp-' -e '^\.vm-' -e '\.svg-'; }

# A phantom big enough that writing and checking its mesh take a good part of a second.
run "$CLI" demo --size 96 --quiet
if [ "$rc" -eq 0 ] && [ -s phantom.nrrd ]; then pass; else fail "demo" "exit $rc"; fi
rm -f demo.vtu demo-surface.vtu demo-report.html

# kill_while_writing SIG WANT: a mesh run is sent SIG once its temporary output appears.
kill_while_writing() {
    local sig=$1 want=$2
    echo old >big.vtu
    "$CLI" mesh phantom.nrrd --iso 0 --no-improve --quiet -o big.vtu --surface big-s.vtu \
        >"$OUT" 2>"$ERR" &
    local pid=$! seen=0
    for _ in $(seq 1 2000); do
        if temporaries >/dev/null; then
            seen=1
            break
        fi
        sleep 0.01
    done
    kill -s "$sig" "$pid" 2>/dev/null
    wait "$pid"
    local rc=$?
    if [ "$seen" -eq 1 ] && [ "$rc" -eq "$want" ]; then pass; else
        fail "SIG$sig while writing" "saw a temporary file: $seen, exit $rc (want $want)" \
            "stderr: $(cat "$ERR")"
    fi
    if [ -z "$(temporaries)" ] && [ ! -e big-s.vtu ]; then pass; else
        fail "SIG$sig leaves no file" "$(ls -A)"
    fi
    if [ "$(head -c 3 big.vtu)" = old ]; then pass; else
        fail "SIG$sig: the older output survives"
    fi
}
kill_while_writing TERM 143
kill_while_writing INT 130

# Names at the limit: 246 + ".vtu" = 250 bytes, which ".tmp-PID" would take past NAME_MAX.
long=$(printf 'a%.0s' $(seq 1 246))
run "$CLI" mesh phantom.nrrd --iso 0 --no-improve --quiet -o "$long.vtu" \
    --report "${long}.html"
if [ "$rc" -eq 0 ] && [ -s "$long.vtu" ] && [ -s "$long.html" ]; then pass; else
    fail "250-byte output names" "exit $rc" "stderr: $(cat "$ERR")"
fi
if [ -z "$(temporaries)" ]; then pass; else fail "250-byte names leave no file" "$(ls -A)"; fi
run "$CLI" convert "$long.vtu" "${long:0:247}.obj"
if [ "$rc" -eq 0 ] && [ -s "${long:0:247}.obj" ]; then pass; else
    fail "convert to a 251-byte name" "exit $rc" "stderr: $(cat "$ERR")"
fi

echo "$passed passed, $failed failed"
[ "$failed" -eq 0 ]
