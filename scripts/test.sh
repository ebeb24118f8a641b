#!/usr/bin/env bash
# Sets everything up on a fresh Debian 12 machine and passes the whole test suite:
# installs the packages, builds the release preset and runs all of CTest (Vulkan tests on
# lavapipe under the validation layer), then builds the asan preset (AddressSanitizer + UBSan)
# for the CPU-side test binaries and runs them. BLOBVK_SKIP_ASAN=1 skips the second part.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
jobs="$(nproc)"
# Repeated runs on one machine (CI, a developer) reuse unchanged objects; a fresh machine has an
# empty cache and builds everything once. BLOBVK_NO_CCACHE=1 measures a cold build.
if [ "${BLOBVK_NO_CCACHE:-0}" != "1" ] && command -v ccache >/dev/null; then
  export CMAKE_CXX_COMPILER_LAUNCHER=ccache CMAKE_C_COMPILER_LAUNCHER=ccache
  # Paths relative to the checkout, so two clones in different folders share objects.
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
fi
cmake --preset release
cmake --build --preset release -j "$jobs"
# lavapipe on a CPU: pin its worker threads so timings and memory stay predictable.
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
# `slow` tests (install.cpu_only_build: a second, Vulkan-off build of the libraries installed
# component by component) run with BLOBVK_SLOW_TESTS=1; the asan build below also builds without
# Vulkan, so the Vulkan-off configuration is compiled here either way.
if [ "${BLOBVK_SLOW_TESTS:-0}" = "1" ]; then
  ctest --preset release -j "$jobs"
else
  ctest --preset release -j "$jobs" -LE slow
fi

if [ "${BLOBVK_SKIP_ASAN:-0}" != "1" ]; then
  # The sanitized subset: everything without Vulkan (lavapipe under ASan is slow and its own
  # allocations are not ours to check); see docs/reliability.md.
  asan_targets=(blobtree_tests mesh_tests cpu_reference_tests cpu_simd_tests cutting_tests
                fem_tests surgery_tests cli_tests blobvk reliability_tests fuzz_scene_json_replay
                fuzz_scene_blob_replay fuzz_compile_eval_replay fuzz_mesh_readers_replay
                drag_edit cut_host)
  cmake --preset asan -DBLOBVK_WITH_VULKAN=OFF
  cmake --build --preset asan -j "$jobs" --target "${asan_targets[@]}"
  # ASan triples stack frames; the 4096-level nesting tests need more than the default 8 MB.
  ulimit -Ss 65536 || true
  # The install tests build consumers against the installed libraries: a packaging check that the
  # release run makes; here the sanitized libraries would need sanitized consumers.
  ctest --preset asan -j "$jobs" -E NOT_BUILT -LE "install|mpi"
fi
