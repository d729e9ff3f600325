#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# volmesh_mpi leaves no file behind (issue 31, item 7): SIGTERM or SIGINT to the ranks (as a
# batch system's cancel sends; Open MPI's mpiexec, signalled itself, exits and leaves its ranks
# running) while they write their pieces removes every temporary file, writes no piece and no
# .pvtu, and an older OUT.pvtu survives; a run that succeeds leaves the pieces and the .pvtu
# and nothing else.
set -u
set -m # job control: the background mpiexec keeps SIGINT, as in a terminal
. "${VM_SOURCE_DIR}/tests/mpi/common.sh"

# A sphere big enough that writing its pieces takes a good part of a second.
big=128
[ -n "${VM_SANITIZED:-}" ] && big=64
"$VM_CLI" demo --shape sphere --size $big --quiet >/dev/null && mv phantom.nrrd big.nrrd ||
    bad "demo $big"
rm -f demo.vtu demo-surface.vtu demo-report.html
temporaries() { ls -A | grep -e '\.tmp-' -e '^\.vm-'; }

# kill_while_writing SIG: the ranks (mpiexec's children) are sent SIG once a rank's temporary
# piece appears.
kill_while_writing() {
    local sig=$1
    echo old >out.pvtu
    # mpiexec itself in the background (run, a function, would put a subshell there)
    ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}fast_unwind_on_malloc=0" \
        LSAN_OPTIONS="${LSAN_OPTIONS:+$LSAN_OPTIONS:}suppressions=$supp:fast_unwind_on_malloc=0" \
        "$mpiexec" --allow-run-as-root --oversubscribe -np 2 "$VM_MPI" big.nrrd --iso 0 \
        -o out.pvtu --quiet >out.log 2>&1 &
    local pid=$! seen=0
    for _ in $(seq 1 3000); do
        if temporaries >/dev/null; then
            seen=1
            break
        fi
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.01
    done
    local ranks
    ranks=$(pgrep -P "$pid")
    [ -n "$ranks" ] && kill -s "$sig" $ranks 2>/dev/null
    wait "$pid"
    local rc=$?
    # the ranks may outlive mpiexec by a moment
    for _ in $(seq 1 200); do
        [ -z "$(temporaries)" ] && break
        sleep 0.05
    done
    [ $seen = 1 ] && [ $rc -ne 0 ] && ok ||
        bad "SIG$sig while writing: saw a temporary file: $seen, exit $rc: $(cat out.log)"
    [ -z "$(temporaries)" ] && ! ls out_*.vtu >/dev/null 2>&1 && ok ||
        bad "SIG$sig leaves files: $(ls -A)"
    [ "$(head -c 3 out.pvtu)" = old ] && ok || bad "SIG$sig: the older out.pvtu is lost"
}
kill_while_writing TERM
kill_while_writing INT

# A run that succeeds: the pieces and the .pvtu, no temporary file.
rm -f out.pvtu
res=$(run 2 "$VM_MPI" big.nrrd --iso 0 -o out.pvtu --quiet 2>&1) || bad "a run: $res"
[ -s out.pvtu ] && [ -s out_0.vtu ] && [ -s out_1.vtu ] && [ -z "$(temporaries)" ] && ok ||
    bad "a run that succeeds: $(ls -A)"
grep -q 'Piece Source="out_1.vtu"' out.pvtu && ok || bad "out.pvtu lists its pieces"
finish "$(basename "$0")"
