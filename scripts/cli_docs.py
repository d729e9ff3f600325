#!/usr/bin/python3
# SPDX-License-Identifier: BSD-3-Clause
"""Keeps docs/CLI.md in step with the program: every fenced block that starts with
"usage: volmesh [COMMAND]" is the --help text of that command.

  scripts/cli_docs.py VOLMESH           rewrite those blocks from the program's --help
  scripts/cli_docs.py VOLMESH --check   exit 1 (listing them) when a block differs
"""
import re
import subprocess
import sys
from pathlib import Path

doc = Path(__file__).resolve().parent.parent / "docs" / "CLI.md"
program, check = sys.argv[1], "--check" in sys.argv
text = doc.read_text()
block = re.compile(r"```\n(usage: volmesh( [a-z]+)?[^\n]*\n.*?)```", re.S)
stale = []


def current(match):
    words = match.group(1).split()
    command = words[2] if len(words) > 2 and words[2] not in ("COMMAND", "[options]") else None
    args = [program] + ([command] if command else []) + ["--help"]
    help_text = subprocess.run(args, capture_output=True, text=True).stdout
    if help_text != match.group(1):
        stale.append(command or "(top level)")
    return "```\n" + help_text + "```"


new = block.sub(current, text)
if check:
    if stale:
        print("docs/CLI.md differs from --help for: " + ", ".join(stale))
        print("run: scripts/cli_docs.py build/volmesh")
        sys.exit(1)
    print("1 passed, 0 failed")
else:
    doc.write_text(new)
    print("updated: " + (", ".join(stale) if stale else "nothing"))
