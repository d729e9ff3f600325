#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# The Python package (issue 28), as a user installs it: a fresh venv that sees Debian's
# python3-numpy, python3-meshio and python3-pytest, `pip install --no-build-isolation
# --no-index` of the source tree (offline), then the pytest cases of tests/python/pytest,
# run from outside the source tree so that they import the installed package.
set -u
src=${VM_SOURCE_DIR:?}
if [ -n "${VM_SANITIZED:-}" ]; then
    echo "skipped under the sanitizers: the package is built by setuptools, without them, and the release suite runs these tests"
    exit 77
fi
for m in numpy pytest meshio; do
    /usr/bin/python3 -c "import $m" 2>/dev/null ||
        { echo "Debian's python3-$m is missing (scripts/deps.sh --tests installs it)"; exit 1; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 -m venv --system-site-packages "$work/V" || { echo "venv failed"; exit 1; }
if ! "$work/V/bin/pip" install --no-build-isolation --no-index "$src" >"$work/pip.log" 2>&1; then
    echo "pip install failed:"; tail -30 "$work/pip.log"; exit 1
fi
if grep -E "warning:" "$work/pip.log"; then echo "the C sources warn when setuptools builds them"; exit 1; fi
cd "$work" && "$work/V/bin/python" -m pytest -q -p no:cacheprovider "$src/tests/python/pytest"
