#!/usr/bin/env bash
# Runs every libFuzzer target for N minutes each (default 2), seeded from its checked-in corpus
# (tests/fuzz/corpus/<target>/), the shipped scenes and the bad-input catalogue. Crashes land in
# the checked-in corpus folder, so CTest replays them; new interesting inputs stay in
# build/fuzz/corpus/<target>/ (merge them with -merge=1 when they add coverage worth keeping).
# Usage: scripts/fuzz.sh [minutes] [target...]
set -euo pipefail
cd "$(dirname "$0")/.."
minutes="${1:-2}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_scene_json fuzz_scene_blob fuzz_compile_eval fuzz_mesh_readers)
bash scripts/setup.sh
cmake --preset fuzz >/dev/null
cmake --build --preset fuzz --target "${targets[@]}"
for t in "${targets[@]}"; do
  corpus="build/fuzz/corpus/$t"
  crashes="tests/fuzz/corpus/$t"
  mkdir -p "$corpus" "$crashes"
  case "$t" in
    fuzz_scene_json) seeds=("$crashes" scenes tests/data/bad) ;;
    fuzz_scene_blob) seeds=("$crashes" scenes/legacy tests/data/bad) ;;
    *) seeds=("$crashes") ;;  # fuzz_mesh_readers: first byte 0 .ply, 1 .obj, 2 .stl
  esac
  log="build/fuzz/logs/$t.log"
  mkdir -p build/fuzz/logs
  echo "== $t for $minutes min (full log: $log)"
  # -timeout: an input that runs 10 s counts as a hang; -rss_limit_mb: 2 GB is a leak/blow-up.
  "build/fuzz/tests/fuzz/$t" "$corpus" "${seeds[@]}" -max_total_time=$((minutes * 60)) \
    -timeout=10 -rss_limit_mb=2048 -artifact_prefix="$crashes/" -print_final_stats=1 >"$log" 2>&1 || true
  grep -E "INITED|DONE|stat::number_of_executed_units|stat::peak_rss|SUMMARY|Done|artifact" "$log" || true
done
