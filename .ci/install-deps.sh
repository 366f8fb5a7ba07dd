#!/usr/bin/env bash
# Installs the Debian packages trilevel needs to build, test and run (as root, or with sudo).
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  g++ cmake make pocl-opencl-icd ocl-icd-opencl-dev opencl-headers opencl-clhpp-headers \
  libglm-dev catch2 libcli11-dev nlohmann-json3-dev zlib1g-dev libdeflate-dev pkg-config libtbb-dev \
  python3-numpy python3-scipy python3-dev pybind11-dev python3-venv python3-pytest python3-distributed python3-meshio >/dev/null
# Blender 3.4 (641 MB with its libraries) for the add-on's headless test (ctest -R blender_addon).
$SUDO apt-get install -y -qq --no-install-recommends blender >/dev/null
# VTK's own Python readers (libvtk9.1 and python3-vtk9, about 150 MB, with Open MPI): the .vtp and
# .vtu check of ctest -R mesh_formats (skipped with a message without them).
$SUDO apt-get install -y -qq --no-install-recommends python3-vtk9 >/dev/null
