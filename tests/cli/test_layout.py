# SPDX-License-Identifier: BSD-3-Clause
"""tests/cli/test_layout.py — the source tree keeps the layout of docs/ARCHITECTURE.md (issue 27):
no folder of library code holds more than 35 % of its C lines; no two library files (nor two
files of the volmesh program) call each other, read off the built objects' symbol tables with
nm; at most 5 functions run over 150 lines; every library source file opens with a comment
naming itself; every source file carries the licence's SPDX line."""
import collections
import glob
import os
import re
import subprocess
import sys

SRC = os.environ["VM_SOURCE_DIR"]
BUILD = os.path.dirname(os.environ["VM_CLI"])
LIB_DIRS = ["core", "io", "preprocess", "mesher", "labels", "improve", "surface", "quality"]
ALL_DIRS = LIB_DIRS + ["cli", "mpi", "include"]
failures = []


def sources(dirs, exts=(".c", ".h")):
    for d in dirs:
        for root, _, files in os.walk(os.path.join(SRC, d)):
            for f in sorted(files):
                if f.endswith(exts):
                    yield os.path.join(root, f)


def lines_of(path):
    with open(path, encoding="utf-8", errors="replace") as fh:
        return fh.read().split("\n")


def folder_shares():
    """C lines per folder, at any depth, against the library's (with cli, mpi, include)."""
    per = collections.Counter()
    total = 0
    for p in sources(ALL_DIRS):
        n = len(lines_of(p))
        total += n
        rel = os.path.relpath(os.path.dirname(p), SRC).split(os.sep)
        for k in range(1, len(rel) + 1):
            per["/".join(rel[:k])] += n
    for d, n in sorted(per.items()):
        share = n / total
        if share > 0.35:
            failures.append(f"{d}/ holds {share:.0%} of the {total} C lines (limit 35 %)")
    top = max(per.items(), key=lambda kv: kv[1])
    print(f"largest folder: {top[0]}/ with {top[1] / total:.0%} of {total} lines")


def function_lengths():
    """Lengths of function definitions: a line at column 0 with '(' whose signature ends with
    '{', up to the '}' at column 0."""
    out = []
    for p in sources(LIB_DIRS + ["cli", "mpi"], (".c",)):
        L = lines_of(p)
        i = 0
        while i < len(L):
            line = L[i]
            if (re.match(r"[A-Za-z_]", line) and "(" in line and not line.startswith("typedef")
                    and "=" not in line.split("(")[0]):
                j = i
                while j < len(L) and j < i + 8 and not L[j].rstrip().endswith(("{", ";")):
                    j += 1
                if j < len(L) and L[j].rstrip().endswith("{"):
                    k = j + 1
                    while k < len(L) and not L[k].startswith("}"):
                        k += 1
                    name = re.findall(r"(\w+)\s*\(", line)
                    out.append((k - i + 1, os.path.relpath(p, SRC), name[0] if name else "?"))
                    i = k
            i += 1
    long_ones = sorted((f for f in out if f[0] > 150), reverse=True)
    for n, p, name in long_ones:
        print(f"  {n} lines: {p} {name}")
    if len(long_ones) > 5:
        failures.append(f"{len(long_ones)} functions run over 150 lines (at most 5)")
    print(f"{len(out)} functions, {len(long_ones)} over 150 lines")


def call_cycles(objdir, label):
    """Pairs of object files that each use a symbol the other defines."""
    objs = glob.glob(os.path.join(objdir, "**", "*.o"), recursive=True)
    if not objs:
        failures.append(f"no object files under {objdir}")
        return
    defs, uses = {}, {}
    for o in objs:
        name = o.split(".dir" + os.sep, 1)[-1][:-2]
        nm = subprocess.run(["nm", o], capture_output=True, text=True, check=True).stdout
        d, u = set(), set()
        for row in nm.splitlines():
            f = row.split()
            if len(f) == 3 and f[1] in "TDBR":
                d.add(f[2])
            elif len(f) == 2 and f[0] == "U":
                u.add(f[1])
        defs[name], uses[name] = d, u
    owner = {s: f for f, d in defs.items() for s in d}
    calls = collections.defaultdict(set)
    for f, u in uses.items():
        for s in u:
            if owner.get(s, f) != f:
                calls[f].add(owner[s])
    pairs = sorted({tuple(sorted((a, b))) for a in list(calls) for b in calls[a]
                    if a in calls.get(b, ())})
    for a, b in pairs:
        failures.append(f"{label}: {a} and {b} call each other")
    print(f"{label}: {len(defs)} files, {len(pairs)} pairs calling each other")


def file_headers():
    """Library and program files open with a comment naming themselves; every source file
    of the project (C, headers, Python, shell, CMake) carries the licence's SPDX line."""
    for p in sources(LIB_DIRS + ["cli", "mpi"]):
        rel = os.path.relpath(p, SRC)
        head = "\n".join(lines_of(p)[:3])
        if rel not in head:
            failures.append(f"{rel} does not open with a comment naming itself")
    tracked = subprocess.run(["git", "-C", SRC, "ls-files"], capture_output=True, text=True)
    if tracked.returncode != 0:
        print("not a git checkout: the SPDX lines are not checked")
        return
    missing = []
    for rel in tracked.stdout.split():
        if "/corpus/" in rel or not (rel.endswith((".c", ".h", ".cpp", ".py", ".sh", ".cmake"))
                                     or os.path.basename(rel) == "CMakeLists.txt"):
            continue
        if "SPDX-License-Identifier: BSD-3-Clause" not in "\n".join(lines_of(
                os.path.join(SRC, rel))[:3]):
            missing.append(rel)
    for rel in missing:
        failures.append(f"{rel} has no SPDX-License-Identifier line in its first 3 lines")
    print(f"SPDX lines: {len(missing)} files without one")


folder_shares()
function_lengths()
call_cycles(os.path.join(BUILD, "CMakeFiles", "volmesh_objects.dir"), "library")
call_cycles(os.path.join(BUILD, "CMakeFiles", "volmesh.dir"), "volmesh program")
file_headers()
for f in failures:
    print("FAIL:", f)
print(f"{1 if not failures else 0} passed, {1 if failures else 0} failed")
sys.exit(1 if failures else 0)
