#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# build_cgal.sh OUTDIR — compiles tests/reference/cgal_mesh3.cpp into OUTDIR/cgal_mesh3 when
# CGAL's headers (Debian libcgal-dev) and g++ are installed, and prints the program's path.
# Rebuilds only when the source changed (its checksum is kept beside the program); the first
# build takes about a minute. Prints nothing and exits 77 when CGAL or g++ is missing, 1 when
# the compile fails. Never links TetGen or anything beyond CGAL's header-only library, GMP
# and MPFR.
set -u
out=${1:?usage: build_cgal.sh OUTDIR}
here=$(cd "$(dirname "$0")" && pwd)
src=$here/cgal_mesh3.cpp
cxx=${CXX:-g++}
if [ ! -f /usr/include/CGAL/make_mesh_3.h ] || ! command -v "$cxx" >/dev/null 2>&1; then
    echo "build_cgal.sh: CGAL (libcgal-dev) or $cxx missing" >&2
    exit 77
fi
mkdir -p "$out" || exit 1
sum=$(sha256sum "$src" | cut -d' ' -f1)
if [ -x "$out/cgal_mesh3" ] && [ "$(cat "$out/cgal_mesh3.sha256" 2>/dev/null)" = "$sum" ]; then
    echo "$out/cgal_mesh3"
    exit 0
fi
echo "build_cgal.sh: compiling cgal_mesh3 (about a minute)" >&2
if ! "$cxx" -O2 -DNDEBUG -std=c++17 -o "$out/cgal_mesh3.new" "$src" -lgmp -lmpfr >"$out/build.log" 2>&1; then
    echo "build_cgal.sh: compile failed, see $out/build.log" >&2
    tail -20 "$out/build.log" >&2
    exit 1
fi
mv "$out/cgal_mesh3.new" "$out/cgal_mesh3" && echo "$sum" >"$out/cgal_mesh3.sha256"
echo "$out/cgal_mesh3"
