# SPDX-License-Identifier: BSD-3-Clause
"""Builds the volmesh Python package: python/volmesh (the API) and volmesh._volmesh, one
extension module holding the binding and every source file of the C library (the same files
CMake builds into libvolmesh). zlib and libm are linked; OpenMP is used when the compiler
builds a test program with -fopenmp, and left out otherwise (one thread)."""
import glob
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile

from setuptools import Extension, setup

HERE = os.path.dirname(os.path.abspath(__file__))
LIB_DIRS = ["core", "io", "preprocess", "mesher", "labels", "improve", "surface", "quality"]


def rel(p):
    return os.path.relpath(p, HERE)


def version():
    with open(os.path.join(HERE, "include", "volmesh", "volmesh.h")) as fh:
        return re.search(r'#define VOLMESH_VERSION "([^"]+)"', fh.read()).group(1)


def openmp_flags():
    """-fopenmp when the C compiler builds and links a test program with it."""
    cc = (os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc").split()
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "omp.c")
        with open(src, "w") as fh:
            fh.write("#include <omp.h>\nint main(void) { return omp_get_max_threads() < 1; }\n")
        try:
            ok = subprocess.run(cc + ["-fopenmp", src, "-o", os.path.join(tmp, "omp")],
                                capture_output=True).returncode == 0
        except OSError:
            ok = False
    if not ok:
        print("volmesh: OpenMP off (the compiler builds no -fopenmp program): one thread",
              file=sys.stderr)
    return ["-fopenmp"] if ok else []


sources = [rel(os.path.join(HERE, "python", "volmesh", "_volmesh.c"))]
for d in LIB_DIRS:
    sources += sorted(rel(p) for p in glob.glob(os.path.join(HERE, d, "*.c")))
omp = openmp_flags()

ext = Extension(
    "volmesh._volmesh",
    sources=sources,
    include_dirs=[rel(os.path.join(HERE, "include")), "."],
    define_macros=[("VM_HAVE_OPENMP", "1")] if omp else [],
    extra_compile_args=["-std=c11", "-O2"] + omp,
    extra_link_args=omp,
    libraries=["z", "m"],
)

setup(
    version=version(),
    package_dir={"": "python"},
    packages=["volmesh"],
    ext_modules=[ext],
    zip_safe=False,
)
