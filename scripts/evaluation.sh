#!/usr/bin/env bash
# Regenerates docs/evaluation.md and its charts (docs/evaluation/*.png): the thesis' chapter 7
# evaluation (eggshell, craniotomy) run through the blobvk CLI. One command:
#
#   scripts/evaluation.sh            # builds build/evaluation/apps/blobvk if needed
#   BLOBVK=path/to/blobvk scripts/evaluation.sh
#   QUICK=1 scripts/evaluation.sh    # fewer steps and resolutions (smoke run, ~2 minutes)
#
# Needs python3; charts need gnuplot (scripts/setup.sh installs gnuplot-nox), else skipped.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
blobvk="${BLOBVK:-$root/build/evaluation/apps/blobvk}"
if [ ! -x "$blobvk" ]; then
  cmake -S "$root" -B "$root/build/evaluation" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$root/build/evaluation" -j2 --target blobvk
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
out="$root/docs/evaluation"
mkdir -p "$out"

# `cut` runs each scene's whole procedure (its own step count: cut, lift, tools); `simulate` times
# the FEM on the uncut body.
if [ -n "${QUICK:-}" ]; then
  resolutions="32 64"; sim_steps=10; egg_cut_extra=""
else
  resolutions="32 64 96 128"; sim_steps=40; egg_cut_extra=""
fi
scenes="scenes/eggshell_sim.json scenes/craniotomy.json"

echo "evaluation: model statistics" >&2
for s in $scenes; do "$blobvk" info "$s" >"$work/info_$(basename "$s" .json).txt"; done

# Triangles per tissue: every named child of the craniotomy, meshed alone at the scene's grid.
python3 - "$work" <<'EOF'
import json, sys
work = sys.argv[1]
scene = json.load(open("scenes/craniotomy.json"))
shell, intra = scene["root"]["children"]
tissues = {"scalp and skull": shell, "CSF and brain": intra, "brain": intra["children"][1]}
for name, node in tissues.items():
    sub = {"blobvk": 1, "name": name, "grid": scene["grid"], "root": node}
    json.dump(sub, open(f"{work}/tissue_{name.replace(' ', '_')}.json", "w"))
EOF
for t in "$work"/tissue_*.json scenes/eggshell_sim.json scenes/craniotomy.json; do
  "$blobvk" mesh "$t" -o "$work/mesh.ply" >"$work/mesh_$(basename "$t" .json).txt" 2>&1
done

echo "evaluation: cut (whole procedures) and simulate ($sim_steps steps, uncut)" >&2
run_timed() {  # name, then the command; stderr+stdout to $work/name.txt, wall seconds to name.wall
  local name="$1"; shift
  local start end
  start=$(date +%s.%N)
  "$@" >"$work/$name.txt" 2>&1
  end=$(date +%s.%N)
  python3 -c "print($end - $start)" >"$work/$name.wall"
}
# shellcheck disable=SC2086
run_timed egg_cut "$blobvk" cut scenes/eggshell_sim.json -o "$work/egg_cut" --image-size 256 $egg_cut_extra
run_timed egg_sim "$blobvk" simulate scenes/eggshell_sim.json -o "$work/egg_sim" --steps "$sim_steps" --no-png
run_timed cran_cut "$blobvk" cut scenes/craniotomy.json -o "$work/cran_cut" --image-size 256
run_timed cran_sim "$blobvk" simulate scenes/craniotomy.json -o "$work/cran_sim" --steps "$sim_steps" --no-png
cp "$work/egg_cut/stats.csv" "$work/egg_stats.csv"
cp "$work/cran_cut/stats.csv" "$work/cran_stats.csv"
# A few small PNG frames of each procedure (the CLI renders them when a Vulkan device exists).
rm -f "$out"/*_frame_*.png
for pair in "egg_cut eggshell" "cran_cut craniotomy"; do
  set -- $pair
  pngs=("$work/$1"/frame_*.png)
  [ -e "${pngs[0]}" ] || continue
  n=${#pngs[@]}
  for i in 0 $((n / 4)) $((n / 2)) $((3 * n / 4)) $((n - 1)); do
    cp "${pngs[$i]}" "$out/$2_frame_$(printf %02d "$i").png"
  done
done

echo "evaluation: polygonization benchmarks (cpu and vk)" >&2
# shellcheck disable=SC2086
"$blobvk" bench $scenes --resolution $resolutions --backend cpu --threads 1 2 --repeats 3 --warmup 1 --json \
  >"$work/bench_cpu.json" 2>"$work/bench_cpu.err"
# shellcheck disable=SC2086
if ! "$blobvk" bench $scenes --resolution $resolutions --backend vk --repeats 3 --warmup 1 --json \
  >"$work/bench_vk.json" 2>"$work/bench_vk.err"; then
  echo "[]" >"$work/bench_vk.json"
fi

# The thesis' Table 4.2: the stackless register code against the stack-based traversal, on the
# GPU backend (small grids: the stack-based kernel is slow on lavapipe).
# shellcheck disable=SC2086
if ! "$blobvk" bench $scenes --resolution 32 48 64 --backend vk --traversal specialised stackless stack --repeats 1 --warmup 1 \
  --json >"$work/bench_traversal.json" 2>"$work/bench_traversal.err"; then
  echo "[]" >"$work/bench_traversal.json"
fi

python3 "$root/tests/evaluation/write_report.py" "$work" "$out" "$root/docs/evaluation.md"

if command -v gnuplot >/dev/null; then
  for g in "$work"/*.gp; do gnuplot "$g" || echo "evaluation: gnuplot failed on $g" >&2; done
else
  echo "evaluation: gnuplot not found, charts skipped (scripts/setup.sh installs gnuplot-nox)" >&2
fi
echo "evaluation: wrote docs/evaluation.md" >&2
