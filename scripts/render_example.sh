#!/usr/bin/env bash
# Install the dependencies, build, and render the example scene to out/sdfunction.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake --preset release
cmake --build --preset release -j "$(nproc 2>/dev/null || echo 2)"
mkdir -p out
./build/release/ypathtrace --scene examples/sdfunction/sdfunction.json \
  --output out/sdfunction.png --shader implicit --samples 64 --resolution 720
echo "rendered out/sdfunction.png"
