#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# docs/CLI.md quotes each command's --help verbatim; this fails when they drift apart.
exec /usr/bin/python3 "${VM_SOURCE_DIR:?}/scripts/cli_docs.py" "${VM_CLI:?}" --check
