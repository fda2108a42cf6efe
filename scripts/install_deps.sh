#!/usr/bin/env bash
# Install the Debian packages implicit needs to build, test and run its viewer.
# Idempotent: packages already present are skipped by apt-get. Uses sudo when not root.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git clang-format
  nlohmann-json3-dev libstb-dev libopenexr-dev libtbb-dev
  libembree-dev libopenvdb-dev libpng-dev libjpeg-dev libnanovdb-dev libboost-iostreams-dev libcli11-dev
  libglfw3-dev libimgui-dev libgl-dev libgl1-mesa-dri libglx-mesa0 xvfb xauth
  doctest-dev libbenchmark-dev clang libclang-rt-14-dev libopenmpi-dev openmpi-bin
  pybind11-dev python3-dev python3-numpy python3-pytest
)

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all packages present"
  exit 0
fi

echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
