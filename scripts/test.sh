#!/usr/bin/env bash
# Sets everything up on a fresh Debian 12 machine and passes the whole test suite:
# installs the packages, configures the release preset, builds, runs CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cmake --preset release
cmake --build --preset release -j "$(nproc)"
# lavapipe on a CPU: pin its worker threads so timings and memory stay predictable.
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
ctest --preset release -j "$(nproc)"
