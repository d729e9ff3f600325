# SPDX-License-Identifier: BSD-3-Clause
"""Builds the volmesh Python package: python/volmesh (the API) and volmesh._volmesh, one
extension module holding the binding and every source file of the C library (the same files
CMake builds into libvolmesh). zlib and libm are linked; OpenMP is used when the compiler
builds a test program with -fopenmp, and left out otherwise (one thread). The optional
readers and writers are built as CMake builds them: each library is used when a test program
calling it compiles and links (libtiff 4.5 for TIFF, libjpeg, CharLS and OpenJPEG for
compressed DICOM, serial HDF5 for XDMF), and left out otherwise with one line saying so
(those inputs and outputs are then refused by name)."""
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


def builds(code, libs, incs):
    """Whether a C program using the given libraries compiles and links."""
    cc = (os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc").split()
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "probe.c")
        with open(src, "w") as fh:
            fh.write(code)
        cmd = cc + [src, "-o", os.path.join(tmp, "probe")] + ["-I" + i for i in incs]
        try:
            return subprocess.run(cmd + ["-l" + l for l in libs],
                                  capture_output=True).returncode == 0
        except OSError:
            return False


# (what, macros, libraries, include folders, test program): the optional parts.
OPTIONAL = [
    ("TIFF reader", ["VM_HAVE_TIFF"], ["tiff"], [],
     "#include <tiffio.h>\nint main(void) { TIFFOpenOptions *o = TIFFOpenOptionsAlloc();"
     " TIFFOpenOptionsFree(o); return 0; }\n"),
    ("DICOM JPEG", ["VM_HAVE_DICOM_JPEG"], ["jpeg"], [],
     "#include <stdio.h>\n#include <jpeglib.h>\nint main(void) { struct jpeg_decompress_struct d;"
     " struct jpeg_error_mgr e; d.err = jpeg_std_error(&e); jpeg_create_decompress(&d);"
     " jpeg_destroy_decompress(&d); return 0; }\n"),
    ("DICOM JPEG-LS", ["VM_HAVE_DICOM_JPEGLS"], ["charls"], [],
     "#include <charls/charls.h>\nint main(void) { charls_jpegls_decoder *d ="
     " charls_jpegls_decoder_create(); charls_jpegls_decoder_destroy(d); return 0; }\n"),
    ("DICOM JPEG 2000", ["VM_HAVE_DICOM_J2K", "VM_HAVE_OPJ_STRICT"], ["openjp2"],
     sorted(glob.glob("/usr/include/openjpeg-2*")),
     "#include <openjpeg.h>\nint main(void) { opj_codec_t *c = opj_create_decompress(OPJ_CODEC_J2K);"
     " int bad = !opj_decoder_set_strict_mode(c, OPJ_TRUE); opj_destroy_codec(c); return bad; }\n"),
    ("XDMF", ["VM_HAVE_HDF5"], ["hdf5_serial"], ["/usr/include/hdf5/serial"],
     "#include <hdf5.h>\nint main(void) { return H5open() < 0; }\n"),
]

macros, libs, incs = [], [], []
for what, defs, lib, inc, code in OPTIONAL:
    if builds(code, lib, inc):
        macros += [(d, "1") for d in defs]
        libs += lib
        incs += inc
    else:
        print("volmesh: %s off (a test program using %s does not build)" % (what, lib[0]),
              file=sys.stderr)

sources = [rel(os.path.join(HERE, "python", "volmesh", "_volmesh.c"))]
for d in LIB_DIRS:
    sources += sorted(rel(p) for p in glob.glob(os.path.join(HERE, d, "*.c")))
omp = openmp_flags()

ext = Extension(
    "volmesh._volmesh",
    sources=sources,
    include_dirs=[rel(os.path.join(HERE, "include")), "."] + incs,
    define_macros=([("VM_HAVE_OPENMP", "1")] if omp else []) + macros,
    extra_compile_args=["-std=c11", "-O2"] + omp,
    extra_link_args=omp,
    libraries=libs + ["z", "m"],
)

setup(
    version=version(),
    package_dir={"": "python"},
    packages=["volmesh"],
    ext_modules=[ext],
    zip_safe=False,
)
