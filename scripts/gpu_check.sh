#!/usr/bin/env bash
# The Vulkan path on the first non-CPU Vulkan device of this machine (lavapipe when there is
# none, said so in the summary): builds the release preset, runs the Vulkan test suites (every
# test under the validation layer with synchronisation validation), `blobvk compare
# --validation` on every shipped scene, and `blobvk bench` of tower and random128 (default field
# pass and per-brick tapes); prints one summary
# table and exits non-zero when anything failed. On a GPU it also benches the tower at 512^3 and
# 2048^3 against the CPU backend.
#   scripts/gpu_check.sh [--resolution N] [--bench-resolution N] [--no-build] [--log-dir DIR]
# Defaults: compare at 64 cells, bench at 128, logs in a new temporary directory (--log-dir: a
# CI job's artifact folder). BLOBVK_BUILD_JOBS sets the build's -j.
set -uo pipefail
cd "$(dirname "$0")/.."

resolution=64
bench_resolution=128
build=1
log_dir=""
while [ $# -gt 0 ]; do
  case "$1" in
    --resolution) resolution="$2"; shift 2 ;;
    --bench-resolution) bench_resolution="$2"; shift 2 ;;
    --no-build) build=0; shift ;;
    --log-dir) log_dir="$2"; shift 2 ;;
    *) echo "usage: scripts/gpu_check.sh [--resolution N] [--bench-resolution N] [--no-build] [--log-dir DIR]" >&2; exit 2 ;;
  esac
done

bin=build/release
blobvk="$bin/apps/blobvk"
if [ -n "$log_dir" ]; then mkdir -p "$log_dir"; else log_dir="$(mktemp -d -t blobvk-gpu-check.XXXXXX)"; fi
rows=()
failed=0
# row STEP RESULT DETAIL
row() { rows+=("$(printf '%-34s | %-4s | %s' "$1" "$2" "$3")"); [ "$2" = "FAIL" ] && failed=1; return 0; }

# Every installed ICD visible, so a GPU is found even where a test default would pin lavapipe.
icds=$(ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json 2>/dev/null | paste -sd: -)
[ -n "$icds" ] && export VK_ICD_FILENAMES="$icds"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"

if [ "$build" = 1 ]; then
  jobs="${BLOBVK_BUILD_JOBS:-$(nproc)}"
  if { [ -f "$bin/CMakeCache.txt" ] || cmake --preset release >"$log_dir/configure.log" 2>&1; } &&
     cmake --build --preset release -j "$jobs" --target blobvk vk_tests render_tests >"$log_dir/build.log" 2>&1; then
    row "build (release preset)" PASS "$bin"
  else
    row "build (release preset)" FAIL "see $log_dir/build.log"
    printf '%s\n' "${rows[@]}"
    exit 1
  fi
fi

# The first device whose type is not CPU, from `blobvk devices` ("[i] name (type), Vulkan x").
device_line=$("$blobvk" devices 2>/dev/null | grep -E '^\[[0-9]+\]' | grep -v '(CPU)' | head -n 1)
if [ -n "$device_line" ]; then
  device_index=$(sed -E 's/^\[([0-9]+)\].*/\1/' <<<"$device_line")
  device_name=$(sed -E 's/^\[[0-9]+\] (.*) \(.*/\1/' <<<"$device_line")
  row "device" PASS "$device_name (index $device_index)"
  gpu=1
else
  gpu=0
  device_line=$("$blobvk" devices 2>/dev/null | grep -E '^\[[0-9]+\]' | head -n 1)
  if [ -z "$device_line" ]; then
    row "device" FAIL "no Vulkan device at all (install mesa-vulkan-drivers)"
    printf '%s\n' "${rows[@]}"
    exit 1
  fi
  device_index=$(sed -E 's/^\[([0-9]+)\].*/\1/' <<<"$device_line")
  device_name=$(sed -E 's/^\[[0-9]+\] (.*) \(.*/\1/' <<<"$device_line")
  row "device" PASS "NO GPU FOUND: falling back to $device_name (index $device_index)"
fi
export BLOBVK_TEST_DEVICE="$device_index"

for suite in vk/vk_tests render/render_tests; do
  name=$(basename "$suite")
  if "$bin/tests/$suite" --gtest_brief=1 >"$log_dir/$name.log" 2>&1; then
    row "$name" PASS "$(grep -Eo '[0-9]+ tests? from [0-9]+ test suites? ran' "$log_dir/$name.log" | tail -n 1)"
  else
    row "$name" FAIL "$(grep -c '^\[  FAILED  \]' "$log_dir/$name.log") failed line(s), see $log_dir/$name.log"
  fi
done

for scene in scenes/*.json scenes/legacy/*.blob; do
  out="$log_dir/compare_$(basename "$scene").log"
  if "$blobvk" compare "$scene" --resolution "$resolution" --device "$device_index" --validation >"$out" 2>&1; then
    row "compare $(basename "$scene")" PASS "$(grep -E '^mesh' "$out" | sed -E 's/^mesh +//')"
  else
    row "compare $(basename "$scene")" FAIL "$(tail -n 1 "$out")"
  fi
done

# The default field pass, then per-brick tapes (--brick-tapes: the interpreter over each brick's
# pruned program; opt-in because lavapipe runs generated code faster, docs/performance.md).
for scene in tower random128; do
  for tapes in "" --brick-tapes; do
    what="bench $scene.json vk${tapes:+ tapes} @$bench_resolution"
    out="$log_dir/bench_${scene}${tapes:+_tapes}.log"
    # shellcheck disable=SC2086  # $tapes is one flag or nothing
    if "$blobvk" bench "scenes/$scene.json" --backend vk --device "$device_index" --resolution "$bench_resolution" \
         --repeats 3 --warmup 1 --json $tapes >"$out" 2>"$out.err"; then
      row "$what" PASS "$(python3 -c '
import json, sys
r = json.load(open(sys.argv[1]))[0]
print("median %.4f s (min %.4f), field %.4f s, %d triangles, %.3g field evaluations/s" %
      (r["median_s"], r["min_s"], r["vk_phases"]["field_s"], r["triangles"], r["evaluations_per_s"]))' "$out")"
    else
      row "$what" FAIL "$(tail -n 1 "$out.err")"
    fi
  done
done

# On a GPU: the tower at 512^3 and 2048^3 against the CPU backend on this host's cores (the
# steady state and the device's own time per phase, docs/performance.md "Vulkan on a discrete GPU").
if [ "$gpu" = 1 ]; then
  out="$log_dir/bench_tower_large.log"
  if "$blobvk" bench scenes/tower.json --backend vk cpu --device "$device_index" --resolution 512 2048 \
       --repeats 3 --warmup 1 --json >"$out" 2>"$out.err"; then
    if summary=$(python3 -c '
import json, sys
rows = json.load(open(sys.argv[1]))
cpu = {r["resolution"]: r["min_s"] for r in rows if r["backend"] == "cpu"}
for r in rows:
    if not r["backend"].startswith("vk"): continue
    p = r["vk_phases"]
    device = p["classification_s"] + p["field_s"] + p["extraction_s"]
    print("bench tower.json vk/cpu @%d|vk min %.4f s, cpu min %.4f s (vk/cpu %.2f), device work %.4f s, read-back %.4f s" %
          (r["resolution"], r["min_s"], cpu[r["resolution"]], r["min_s"] / cpu[r["resolution"]], device, p["readback_s"]))' "$out"); then
      while IFS= read -r line; do row "${line%%|*}" PASS "${line#*|}"; done <<<"$summary"
    else
      row "bench tower.json vk/cpu @512,2048" FAIL "its JSON did not read back, see $out"
    fi
  else
    row "bench tower.json vk/cpu @512,2048" FAIL "$(tail -n 1 "$out.err")"
  fi
fi

echo
echo "blobvk gpu_check on $device_name (compare at $resolution cells; logs in $log_dir)"
printf '%-34s | %-4s | %s\n' "step" "ok" "detail"
printf '%s\n' "-----------------------------------+------+-----------------------------------------------"
printf '%s\n' "${rows[@]}"
if [ "$failed" = 0 ]; then echo "ALL PASSED"; else echo "FAILURES (see the logs)"; fi
exit "$failed"
