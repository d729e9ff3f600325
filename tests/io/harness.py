# SPDX-License-Identifier: BSD-3-Clause
"""tests/io/harness.py — what the Python tests of the writers share: the program under test
($VM_CLI; the test skips with 77 without it), the list of failures, check() and run()."""
import os
import subprocess
import sys

failures = []


def need_cli():
    """The program under test; exits 77 (skip) when VM_CLI is not set."""
    cli = os.environ.get("VM_CLI")
    if not cli:
        print("skipped: VM_CLI is not set")
        sys.exit(77)
    return cli


def check(cond, what):
    if not cond:
        failures.append(what)
        print(f"  FAILED: {what}")


def run(*args, expect=0):
    """Runs the program with args; a failure when its exit status is not expect."""
    r = subprocess.run([need_cli(), *args], capture_output=True, text=True)
    check(r.returncode == expect,
          f"volmesh {' '.join(args)}: exit {r.returncode} (want {expect}) {r.stderr.strip()}")
    return r
