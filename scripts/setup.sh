#!/usr/bin/env bash
# Installs the Debian 12 packages blobvk needs to build, test and run on lavapipe.
# Idempotent: packages already present are skipped by apt-get. Works as root; uses sudo otherwise.
set -euo pipefail

packages=(
  build-essential cmake ninja-build ccache pkg-config
  libtbb-dev libeigen3-dev libglm-dev nlohmann-json3-dev libcli11-dev libpng-dev
  libgtest-dev libgmock-dev libbenchmark-dev libtet1.5-dev
  libtinygltf-dev libmeshoptimizer-dev  # glTF export and simplification (mesh/engine)
  libvulkan-dev glslang-dev glslang-tools spirv-tools spirv-cross mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  clang libclang-rt-14-dev
  gnuplot-nox  # charts of scripts/evaluation.sh
  libopenmpi-dev openmpi-bin  # mpirun -n N blobvk mesh (built when CMake finds MPI)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y --no-install-recommends "${missing[@]}"
