#!/usr/bin/env bash
# Sets everything up on a fresh Debian 12 machine and runs the main job on the embedded default:
# the shipped tower scene polygonized on the default Vulkan device (lavapipe on a machine without
# a GPU), checked against the CPU backend, and rendered headless to a PNG. Results in out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)" --target blobvk
export LP_NUM_THREADS="${LP_NUM_THREADS:-$(nproc)}"
mkdir -p out
blobvk=build/release/apps/blobvk
"$blobvk" devices
"$blobvk" info scenes/tower.json
"$blobvk" mesh scenes/tower.json -o out/tower_vk.ply --backend vk --resolution 96
"$blobvk" mesh scenes/tower.json -o out/tower_cpu.ply --backend cpu --resolution 96
"$blobvk" compare scenes/tower.json --resolution 96
"$blobvk" render scenes/tower.json -o out/tower.png --size 768x768 --backend vk --resolution 96
echo "main job done: out/tower_vk.ply, out/tower_cpu.ply, out/tower.png"
