#!/usr/bin/env bash
# Sets everything up on a fresh Debian 12 machine and runs the main job on the embedded default:
# the shipped tower scene polygonized on the default Vulkan device (lavapipe on a machine without
# a GPU) and on the CPU, compared, and written to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)" --target blobvk
mkdir -p out
blobvk=build/release/apps/blobvk
"$blobvk" info scenes/tower.json
"$blobvk" mesh scenes/tower.json -o out/tower.ply --resolution 128
