#!/usr/bin/env bash
# Measures every hot path and regenerates docs/performance.md (+ docs/performance/*.png) from the
# results: `blobvk bench --json` for whole scenes on the CPU and on Vulkan, and the Google Benchmark
# binaries under bench/ with --benchmark_format=json. Every table above the page's hand-measured
# marker comes from these runs; scripts/perf/render_performance.py keeps the page's prose (filling
# in the figures it quotes) and everything from the marker on.
#
#   scripts/performance.sh                 # release build in build/release (built if missing)
#   QUICK=1 scripts/performance.sh         # fewer repeats and sizes (a smoke run, ~3 minutes)
#   RESULTS=dir scripts/performance.sh     # keep the raw JSON in dir (default: a temporary folder)
#
# About 15 minutes on 2 cores. Charts need gnuplot (scripts/setup.sh installs gnuplot-nox).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
build="${BUILD:-build/release}"
if [ ! -x "$build/apps/blobvk" ] || [ ! -x "$build/bench/bench_fem" ]; then
  cmake --preset release >/dev/null
  cmake --build --preset release -j "$(nproc)"
fi
results="${RESULTS:-$(mktemp -d)}"
mkdir -p "$results"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
blobvk="$build/apps/blobvk"

if [ -n "${QUICK:-}" ]; then
  res_cpu="128 256"; res_vk="128"; rep_cpu=2; rep_vk=1; gb_reps=1
else
  res_cpu="128 256 384"; res_vk="128 256"; rep_cpu=7; rep_vk=3; gb_reps=3
fi
scenes="scenes/tower.json scenes/random128.json scenes/eggshell.json scenes/twisted_column.json"

declare -A commands
run() {  # key, then the command line (as shown in the page); stdout to $results/key.json
  local key="$1"; shift
  commands[$key]="$*"
  echo "performance: $key" >&2
  if ! "$@" >"$results/$key.json" 2>"$results/$key.err"; then
    echo "performance: $key failed (see $results/$key.err)" >&2
    rm -f "$results/$key.json"
  fi
}

run bench_cpu "$blobvk" bench $scenes --resolution $res_cpu --backend cpu --threads 1 2 \
  --repeats $rep_cpu --warmup 1 --json
# Where the time goes: the CPU targets' scenes at 384, per phase (phases_s).
run bench_phases "$blobvk" bench scenes/tower.json scenes/random128.json scenes/eggshell.json --resolution 384 \
  --backend cpu --threads 1 2 --repeats $rep_cpu --warmup 1 --json
# The sparse field cache against MPU and leaf size (leaf 0: every grid point of the kept MPUs).
for cfg in 16_0 16_4 16_2 24_3; do
  run bench_sparse_$cfg "$blobvk" bench scenes/tower.json scenes/random128.json --resolution 256 \
    --backend cpu --threads 2 --mpu "${cfg%_*}" --sub-block "${cfg#*_}" --repeats $rep_cpu --warmup 1 --json
done
run bench_vk "$blobvk" bench $scenes --resolution $res_vk --backend vk --repeats $rep_vk --json

gb() {  # binary, filter
  local bin="$1" filter="$2"
  [ -x "$build/bench/$bin" ] || { echo "performance: $bin not built, skipped" >&2; return; }
  run "gb_$bin" "$build/bench/$bin" "--benchmark_filter=$filter" --benchmark_repetitions=$gb_reps \
    --benchmark_format=json
}
gb bench_evaluator '^(grid/)?scene/'
gb bench_vk '^(scan/.*|specialise_compile/.*|(field/specialised|cpu_avx_field)/.*/(128|256)/.*|field/stackless/tower/128/.*|polygonize/specialised/.*/128/.*)$'
# A build's cost without Mesa's shader cache: with it, every repetition after the first would
# reuse the first one's machine code.
if [ -x "$build/bench/bench_compile_cost" ]; then
  run gb_bench_compile_cost env LP_NUM_THREADS="$LP_NUM_THREADS" MESA_SHADER_CACHE_DISABLE=true "$build/bench/bench_compile_cost" \
    --benchmark_repetitions=$gb_reps --benchmark_format=json
fi
# The step, the system product and the topology change (the page's three tables), not the
# convergence study BM_FemStepConverged.
gb bench_fem 'BM_FemStep/|BM_FemTopologyChange|BM_FemSystemProduct|BM_FemRebuild'
gb bench_cutting '.'
gb bench_cut_event '.'
gb bench_edit '.'
gb bench_tetgen '^sceneTetgen/(craniotomy/0/200/1|eggshell_sim/0/200/1|soft_peanut/100000/200/1)$'

# The commands as the page shows them: paths relative to the repository root.
for k in "${!commands[@]}"; do
  printf '%s\t%s\n' "$k" "${commands[$k]//$build\//build/release/}"
done | python3 -c '
import json, sys
rows = dict(line.rstrip("\n").split("\t", 1) for line in sys.stdin if line.strip())
json.dump(rows, open(sys.argv[1], "w"), indent=2, sort_keys=True)' "$results/commands.json"

device="$("$blobvk" devices 2>/dev/null | sed -n 's/^ *\[0\] *//p' | head -1 || true)"
python3 - "$results/machine.json" "$device" "$("$blobvk" --version 2>/dev/null || git describe --always)" <<'PY'
import json, os, platform, subprocess, sys
cpu = "?"
for line in open("/proc/cpuinfo"):
    if line.startswith("model name"):
        cpu = line.split(":", 1)[1].strip(); break
cc = subprocess.run(["c++", "--version"], capture_output=True, text=True).stdout.splitlines()[0]
json.dump({"cpu": cpu, "cores": os.cpu_count(), "vulkan_device": sys.argv[2] or "none",
           "blobvk_version": sys.argv[3], "compiler": cc}, open(sys.argv[1], "w"), indent=2)
PY
python3 scripts/perf/render_performance.py "$results" docs
echo "performance: wrote docs/performance.md (raw results in $results)" >&2
