#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Installs what building and testing volmesh needs on Debian, when it is missing:
# the compiler and CMake, zlib, and (for the tests' independent judges) Debian's python3 with
# VTK, meshio, numpy, pydicom and pytest, the Python package's build (python3-dev, -setuptools, -venv), CalculiX (ccx), gmsh, libexodusii-dev, libtiff-dev, the DICOM codecs (libjpeg62-turbo-dev,
# libcharls-dev, libopenjp2-7-dev), libhdf5-dev, FEniCSx (python3-dolfinx-real) and Open MPI (libopenmpi-dev, openmpi-bin). Usage: scripts/deps.sh [--tests]
set -eu
want_tests=0
[ "${1:-}" = "--tests" ] && want_tests=1
pkgs=()
command -v cmake >/dev/null 2>&1 || pkgs+=(cmake)
command -v cc >/dev/null 2>&1 || pkgs+=(gcc)
command -v make >/dev/null 2>&1 || pkgs+=(make)
dpkg -s zlib1g-dev >/dev/null 2>&1 || pkgs+=(zlib1g-dev)
if [ "$want_tests" = 1 ]; then
    /usr/bin/python3 -c 'import vtk' >/dev/null 2>&1 || pkgs+=(python3-vtk9)
    /usr/bin/python3 -c 'import meshio' >/dev/null 2>&1 || pkgs+=(python3-meshio)
    /usr/bin/python3 -c 'import numpy' >/dev/null 2>&1 || pkgs+=(python3-numpy)
    # tests/io/test_dicom_pydicom.py: pydicom judges the DICOM reader on its own test files
    /usr/bin/python3 -c 'import pydicom' >/dev/null 2>&1 || pkgs+=(python3-pydicom)
    # tests/python: the package built offline into a fresh venv, then pytest
    /usr/bin/python3 -c 'import pytest' >/dev/null 2>&1 || pkgs+=(python3-pytest)
    /usr/bin/python3 -c 'import setuptools' >/dev/null 2>&1 || pkgs+=(python3-setuptools)
    /usr/bin/python3 -c 'import ensurepip, venv' >/dev/null 2>&1 || pkgs+=(python3-venv)
    dpkg -s python3-dev >/dev/null 2>&1 || pkgs+=(python3-dev)
    # tests/reference: the reference meshers (TetGen run as a program; CGAL headers + g++)
    command -v tetgen >/dev/null 2>&1 || pkgs+=(tetgen)
    dpkg -s libcgal-dev >/dev/null 2>&1 || pkgs+=(libcgal-dev)
    command -v g++ >/dev/null 2>&1 || pkgs+=(g++)
    # bench/run and bench/big.py: wall time and peak memory by GNU time -v
    [ -x /usr/bin/time ] || pkgs+=(time)
    # FE interop judges: CalculiX solves our .inp decks, gmsh reads our .msh files; the
    # optional Exodus II writer is built when libexodusii-dev is present at configure time.
    command -v ccx >/dev/null 2>&1 || pkgs+=(calculix-ccx)
    command -v gmsh >/dev/null 2>&1 || pkgs+=(gmsh)
    dpkg -s libexodusii-dev >/dev/null 2>&1 || pkgs+=(libexodusii-dev)
    # the optional TIFF reader (io/tiff.c) is built when libtiff-dev is present; its tests
    # write their TIFF files with libtiff
    dpkg -s libtiff-dev >/dev/null 2>&1 || pkgs+=(libtiff-dev)
    # the optional decoders of compressed DICOM (io/dicom_codecs.c: JPEG, JPEG-LS, JPEG 2000)
    # are built when their -dev packages are present; tests/io/test_dicom_codecs.c encodes
    # its frames with the same libraries
    dpkg -s libjpeg62-turbo-dev >/dev/null 2>&1 || dpkg -s libjpeg-turbo8-dev >/dev/null 2>&1 ||
        pkgs+=(libjpeg62-turbo-dev)
    dpkg -s libcharls-dev >/dev/null 2>&1 || pkgs+=(libcharls-dev)
    dpkg -s libopenjp2-7-dev >/dev/null 2>&1 || pkgs+=(libopenjp2-7-dev)
    # the optional XDMF writer links the serial HDF5 library; dolfinx (FEniCSx) solves on
    # its meshes in tests/io/test_xdmf_dolfinx.py
    dpkg -s libhdf5-dev >/dev/null 2>&1 || pkgs+=(libhdf5-dev)
    /usr/bin/python3 -c 'import dolfinx' >/dev/null 2>&1 || pkgs+=(python3-dolfinx-real)
    # volmesh_mpi (docs/MPI.md) is built against Open MPI and run by tests/mpi under mpirun
    dpkg -s libopenmpi-dev >/dev/null 2>&1 || pkgs+=(libopenmpi-dev)
    command -v mpirun >/dev/null 2>&1 || pkgs+=(openmpi-bin)
    # the HTML report is checked in a real browser
    command -v chromium >/dev/null 2>&1 || pkgs+=(chromium)
    # tests/cli/test_configure.sh builds with clang as well as gcc
    command -v clang >/dev/null 2>&1 || pkgs+=(clang)
fi
[ ${#pkgs[@]} -eq 0 ] && exit 0
echo "volmesh: installing ${pkgs[*]}" >&2
sudo=""
[ "$(id -u)" = 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq "${pkgs[@]}" >/dev/null
