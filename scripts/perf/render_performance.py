#!/usr/bin/env python3
"""Writes docs/performance.md (and its charts) from benchmark results.

Usage: render_performance.py RESULTS_DIR DOCS_DIR

RESULTS_DIR holds what scripts/performance.sh measured:
  machine.json                   cores, CPU model, lavapipe/LLVM version, blobvk version
  commands.json                  {section: command line} as run
  bench_cpu.json, bench_vk.json  `blobvk bench --json` (whole-scene polygonization)
  bench_phases.json              `blobvk bench --json` at 384 (the per-phase breakdown)
  bench_sparse_M_L.json          `blobvk bench --json --mpu M --sub-block L` (the sparse field cache)
  gb_<binary>.json               Google Benchmark JSON (--benchmark_format=json)
Every figure above the page's hand-measured marker comes from those files; the sections below
the marker (jobs too long or too machine-specific for the script: out-of-core, MPI ranks, a
discrete GPU, start-up) are kept from the existing page as they are.
"""
import json
import os
import subprocess
import sys
from collections import OrderedDict, defaultdict


def load(path, default=None):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return default


def fmt_time(seconds):
    if seconds is None:
        return "–"
    if seconds >= 1.0:
        return f"{seconds:.2f} s"
    if seconds >= 1e-3:
        return f"{seconds * 1e3:.1f} ms" if seconds < 0.1 else f"{seconds * 1e3:.0f} ms"
    return f"{seconds * 1e6:.0f} µs"


def fmt_num(x):
    if x is None:
        return "–"
    if isinstance(x, int) or float(x).is_integer() and abs(x) >= 1:
        return f"{int(x):,}"
    if abs(x) >= 100:
        return f"{x:,.0f}"
    if abs(x) >= 10:
        return f"{x:.1f}"
    return f"{x:.3g}"


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------
# Google Benchmark results: minimum over repetitions, and the counters of that repetition.
def gb_runs(path):
    data = load(path)
    if not data:
        return OrderedDict()
    scale = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
    runs = OrderedDict()
    for b in data.get("benchmarks", []):
        if b.get("run_type") == "aggregate" or "error_occurred" in b and b["error_occurred"]:
            continue
        name = b.get("run_name", b["name"])
        t = b["real_time"] * scale[b.get("time_unit", "ns")]
        cpu = b["cpu_time"] * scale[b.get("time_unit", "ns")]
        std = {"name", "run_name", "run_type", "repetitions", "repetition_index", "threads",
               "iterations", "real_time", "cpu_time", "time_unit", "family_index",
               "per_family_instance_index", "aggregate_name", "aggregate_unit", "label"}
        counters = {k: v for k, v in b.items() if k not in std and isinstance(v, (int, float))}
        prev = runs.get(name)
        if prev is None or t < prev["time"]:
            runs[name] = {"time": t, "cpu": cpu, "counters": counters, "reps": (prev or {}).get("reps", 0) + 1}
        else:
            prev["reps"] += 1
    return runs


def gb_context(results):
    for f in sorted(os.listdir(results)):
        if f.startswith("gb_"):
            ctx = (load(os.path.join(results, f)) or {}).get("context")
            if ctx:
                return ctx
    return {}


def gb_table(runs, counters=None, rename=None, time_label="min time"):
    if not runs:
        return "_(not measured: the benchmark binary was not built)_"
    keys = counters or sorted({k for r in runs.values() for k in r["counters"]})
    header = ["benchmark", time_label, "repeats"] + keys
    rows = []
    for name, r in runs.items():
        # Google Benchmark's own suffixes say how it timed, which the page states once above.
        for suffix in ("/process_time", "/real_time", "/iterations:5", "/iterations:64"):
            name = name.replace(suffix, "")
        label = rename(name) if rename else name
        if label is None:
            continue
        rows.append([f"`{label}`", fmt_time(r["time"]), r["reps"]] +
                    [fmt_num(r["counters"].get(k)) for k in keys])
    return table(header, rows)


def compile_cost_table(path):
    """bench_compile_cost as one row per generated tower and one column per evaluator: the fastest
    build of the repetitions, the largest peak memory, bold where the cost model picks it, and why
    a build was not run (the benchmark's error message)."""
    data = load(path)
    if not data:
        return "_(not measured: the benchmark binary was not built)_"
    columns = [("interpreter", "interpreter"), ("specialised_unrolled", "specialised, unrolled"),
               ("specialised_looped", "specialised, looped (emitted)")]
    towers = OrderedDict()
    for b in data.get("benchmarks", []):
        if b.get("run_type") == "aggregate":
            continue
        parts = b.get("run_name", b["name"]).split("/")
        if len(parts) < 3 or parts[0] != "build":
            continue
        evaluator, tower = parts[1], parts[2]
        cell = towers.setdefault(tower, {"instructions": None}).setdefault(evaluator, {})
        if b.get("error_occurred"):
            cell["error"] = b.get("error_message", "not run")
            continue
        towers[tower]["instructions"] = int(b.get("instructions", 0))
        cell["build"] = min(cell.get("build", float("inf")), b["build_s"])
        cell["peak"] = max(cell.get("peak", 0.0), b["peak_MB"])
        cell["emitted"] = int(b.get("emitted", 0))
        cell["default"] = b.get("default", 0.0) >= 1.0
    rows = []
    for tower, t in towers.items():
        row = [tower, fmt_num(t["instructions"]) if t["instructions"] is not None else "?"]
        for key, _ in columns:
            c = t.get(key, {})
            if "build" not in c:
                row.append(c.get("error", "not run"))
                continue
            text = f"{fmt_time(c['build'])}, {c['peak']:.0f} MB"
            if key == "specialised_looped":
                text += f" ({c['emitted']})"
            row.append(f"**{text}**" if c["default"] else text)
        rows.append(row)
    return table(["tower", "instructions"] + [label for _, label in columns], rows)


# ---------------------------------------------------------------------------------------------
# `blobvk bench --json` results.
def bench_rows(path):
    return load(path, []) or []


def scene_name(path):
    return os.path.splitext(os.path.basename(path))[0]


def cpu_table(rows):
    by = OrderedDict()
    for r in rows:
        by.setdefault((scene_name(r["scene"]), r["resolution"]), {})[r["threads"]] = r
    header = ["scene", "res", "triangles", "1 thread (min)", "ns/tri 1t", "2 threads (min)",
              "ns/tri 2t", "speed-up", "FVEPT"]
    out = []
    for (scene, res), t in by.items():
        one, two = t.get(1), t.get(2) or t.get(0)
        tri = (two or one)["triangles"]
        ns = lambda r: f"{r['min_s'] * 1e9 / r['triangles']:.0f}" if r and r["triangles"] else "–"
        speed = f"{one['min_s'] / two['min_s']:.2f}x" if one and two and two["min_s"] > 0 else "–"
        out.append([f"`{scene}`", res, f"{tri:,}", fmt_time(one and one["min_s"]), ns(one),
                    fmt_time(two and two["min_s"]), ns(two), speed, f"{(two or one)['fvept']:.1f}"])
    return table(header, out)


PHASES = [("classification", "classification"), ("field", "field"), ("vertices", "vertices"),
          ("normals_colours", "normals + colours"), ("triangles", "triangles"), ("welding", "welding"),
          ("setup", "setup")]


def phase_table(rows, resolution):
    """ns per output triangle in each phase of the fastest run (`phases_s` of `blobvk bench
    --json`), and the binary-PLY output after it, at one resolution."""
    header = ["scene", "threads", "ns/tri (min)"] + [label for _, label in PHASES] + ["output (PLY)", "FVEPT"]
    out = []
    for r in rows:
        if r["resolution"] != resolution or not r.get("phases_s") or not r["triangles"]:
            continue
        ns = lambda s: f"{s * 1e9 / r['triangles']:.0f}"
        out.append([f"`{scene_name(r['scene'])}`", r["threads"] or "all", ns(r["min_s"])] +
                   [ns(r["phases_s"].get(k, 0.0)) for k, _ in PHASES] +
                   [ns(r.get("output_s", 0.0)), f"{r['fvept']:.1f}"])
    return table(header, out) if out else ""


def phase_section(rows, command):
    """The "where the time goes" section, from the rows of its own bench run."""
    res = max((r["resolution"] for r in rows if r.get("phases_s")), default=None)
    if res is None:
        return ""
    return ("\n## Where the CPU polygonizer's time goes (`blobvk bench --json`, `phases_s`)\n\n"
            f"Per phase, in ns per output triangle, of the fastest of the repeats at {res}. The MPU phase\n"
            "runs on the worker threads: its wall time is split by the CPU time the workers spent in\n"
            "each part — *classification* (interval bound of each MPU group, tape pruning), *field*\n"
            "(the octree of sub-block bounds and the SIMD evaluation of the points it keeps),\n"
            "*vertices* (crossing edges, positions, edge keys), *normals + colours* (one analytic-gradient\n"
            "pass per vertex), *triangles* (case index and the case table per cell).\n"
            "*welding* is the scan over (row, MPU column), MPU layers in parallel, beside the sizing of\n"
            "the output arrays, then the parallel copy of every MPU's rows of vertices and triangles into\n"
            "the welded arrays (memory bound: the copy's stores miss the cache). *output* encodes the\n"
            "mesh as binary PLY, once, after the timed runs (not in ns/tri; its fresh string's page faults\n"
            "included).\n\n"
            "The field dominates where the model is large (`tower`: the interval bounds of the octree\n"
            "blocks and the SIMD evaluation of the points they keep). `random128`'s colour tapes keep\n"
            "every add of its 128-way blend (three divisions per add, for the reference's colour bits),\n"
            "but an MPU's tape adds about 93 null twins into the accumulator in about 4 chains, and the\n"
            "gradient pass stops a chain at the first add that changes no bit (one or two adds per\n"
            "chain), so *normals + colours* is not its largest phase. On `eggshell`\n"
            "(two primitives) the field is cheap and the extraction phases and welding are most of the\n"
            "time, spread over many small loops: by source line (one thread) the welding's copy is about\n"
            "a fifth, the triangle loop about a seventh, the vertex loop and the SIMD field and gradient\n"
            "kernels about a ninth each. A phase profile of one thread: `perf record -g\n"
            "build/release/apps/blobvk bench scenes/eggshell.json --resolution 384 --backend cpu\n"
            "--threads 1` (`perf report --sort srcline` with `-g` objects for the lines).\n"
            + (f"\n```sh\n{command}\n```\n" if command else "") + "\n" + phase_table(rows, res) + "\n")


def sparse_section(results, commands):
    """The sparse field cache against MPU and leaf size: evaluations and time, a run for each."""
    configs = [(16, 0), (16, 4), (16, 2), (24, 3)]
    runs = [(mpu, leaf, bench_rows(os.path.join(results, f"bench_sparse_{mpu}_{leaf}.json")))
            for mpu, leaf in configs]
    runs = [run for run in runs if run[2]]
    if not runs:
        return ""
    header = ["scene", "res", "MPU cells", "leaf cells", "FVEPT", "grid points / tri", "ns/tri (min, 2 threads)",
              "field ns/tri"]
    out = []
    for mpu, leaf, rows in runs:
        for r in rows:
            if not r["triangles"]:
                continue
            tri = r["triangles"]
            grid = (r["point_evaluations"] - r["vertices"]) / tri
            out.append([f"`{scene_name(r['scene'])}`", r["resolution"], mpu, leaf or "off (every point)",
                        f"{r['fvept']:.2f}", f"{grid:.2f}", f"{r['min_s'] * 1e9 / tri:.0f}",
                        f"{r['phases_s'].get('field', 0.0) * 1e9 / tri:.0f}"])
    out.sort(key=lambda row: (row[0], row[1]))
    keys = [f"bench_sparse_{mpu}_{leaf}" for mpu, leaf, _ in runs]
    cmds = "\n".join(commands[k] for k in keys if k in commands)
    return ("\n## Sparse field cache: evaluations against MPU and leaf size (`blobvk bench --mpu --sub-block`)\n\n"
            "Each MPU that the early discard keeps is halved recursively (an octree) down to leaves of\n"
            "`--sub-block` cells, one level at a time with the interval bounds of a level's blocks in one\n"
            "batch; a block whose bound is all outside or all inside is not evaluated, so only the points\n"
            "of leaves near the surface are. The mesh is the same bytes for every setting. *FVEPT* counts\n"
            "every point evaluation (grid points, then one analytic-gradient pass per vertex); *field*\n"
            "is the field phase, bounds included. `blobvk mesh`, `bench` and `compare` use MPUs of 24\n"
            "cells with leaves of 3 (24, 12, 6, 3); the library default for edits and streaming is 16\n"
            "with leaves of 4. Leaves of 2 cells evaluate fewer points still, but their bounds cost more\n"
            "than the points they save.\n"
            + (f"\n```sh\n{cmds}\n```\n" if cmds else "") + "\n" + table(header, out) + "\n")


# ---------------------------------------------------------------------------------------------
# Charts (gnuplot, when present).
def gnuplot(script, data_files):
    try:
        subprocess.run(["gnuplot"], input=script, text=True, check=True, capture_output=True)
        return True
    except (OSError, subprocess.CalledProcessError) as e:
        sys.stderr.write(f"performance: chart skipped ({e})\n")
        return False
    finally:
        for f in data_files:
            try:
                os.remove(f)
            except OSError:
                pass


def chart_ns_per_triangle(cpu_rows, vk_rows, out_png):
    series = defaultdict(list)  # (scene, label) -> [(res, ns)]
    for r in cpu_rows:
        if r["triangles"]:
            label = f"cpu {r['threads']}t"
            series[(scene_name(r["scene"]), label)].append((r["resolution"], r["min_s"] * 1e9 / r["triangles"]))
    for r in vk_rows:
        if r["triangles"]:
            series[(scene_name(r["scene"]), "vk")].append((r["resolution"], r["min_s"] * 1e9 / r["triangles"]))
    if not series:
        return False
    files, plots = [], []
    for i, ((scene, label), pts) in enumerate(sorted(series.items())):
        f = f"{out_png}.{i}.dat"
        with open(f, "w") as d:
            for res, ns in sorted(pts):
                d.write(f"{res} {ns}\n")
        files.append(f)
        plots.append(f"'{f}' using 1:2 with linespoints title '{scene}, {label}'")
    script = f"""set terminal pngcairo noenhanced size 900,520 font ',10'
set output '{out_png}'
set logscale y
set xlabel 'grid resolution (cells along the longest side)'
set ylabel 'ns per output triangle (min of repeats)'
set key outside right
set grid
plot {', '.join(plots)}
"""
    return gnuplot(script, files)


def chart_fem(runs, out_png):
    pts = []
    for name, r in runs.items():
        if name.startswith("BM_FemStep") and "tets" in r["counters"]:
            pts.append((r["counters"]["tets"], r["time"] * 1e3))
    if not pts:
        return False
    f = out_png + ".dat"
    with open(f, "w") as d:
        for t, ms in sorted(pts):
            d.write(f"{t} {ms}\n")
    script = f"""set terminal pngcairo noenhanced size 700,420 font ',10'
set output '{out_png}'
set logscale xy
set xlabel 'tetrahedra'
set ylabel 'ms per step (min of repeats)'
set grid
plot '{f}' using 1:2 with linespoints title 'FEM step (corotational, implicit Euler, CG)'
"""
    return gnuplot(script, [f])


# ---------------------------------------------------------------------------------------------
HAND_MEASURED_MARKER = "<!-- Hand-measured sections:"


def main():
    results, docs = sys.argv[1], sys.argv[2]
    machine = load(os.path.join(results, "machine.json"), {})
    commands = load(os.path.join(results, "commands.json"), {})
    cpu_rows = bench_rows(os.path.join(results, "bench_cpu.json"))
    vk_rows = bench_rows(os.path.join(results, "bench_vk.json"))
    gb = {f[3:-5]: gb_runs(os.path.join(results, f)) for f in sorted(os.listdir(results))
          if f.startswith("gb_") and f.endswith(".json")}
    charts = os.path.join(docs, "performance")
    os.makedirs(charts, exist_ok=True)

    def cmd(key):
        c = commands.get(key)
        return f"\n```sh\n{c}\n```\n" if c else ""

    md = []
    w = md.append
    w("# Performance\n")
    w("Current figures for every hot path, each table with the command that produced it. The page\n"
      "down to the hand-measured sections is generated by `scripts/performance.sh` (it runs the\n"
      "commands below and renders this file with `scripts/perf/render_performance.py`); rerun it to\n"
      "check a figure on your machine. The sections after it (lavapipe against the CPU by pass,\n"
      "out-of-core and MPI jobs, a discrete GPU, start-up) are measured by hand with the commands they\n"
      "give, and kept by the script.\n"
      "Times are the **minimum of several repeats** (the run least disturbed by other work on the\n"
      "cores) and every ratio compares two figures of the same run.\n")
    w("## Machine\n")
    w(table(["", ""], [
        ["CPU", machine.get("cpu", "?")],
        ["cores used", machine.get("cores", "?")],
        ["Vulkan device", machine.get("vulkan_device", "none")],
        ["blobvk", machine.get("blobvk_version", "?")],
        ["compiler", machine.get("compiler", "?")],
    ]))
    w("\nNo GPU is attached to this machine: the Vulkan figures are Mesa's lavapipe (llvmpipe) running\n"
      "the SPIR-V kernels on the same 2 cores. `scripts/gpu_check.sh` measures a real GPU where one exists.\n")

    w("## CPU polygonization (`blobvk bench`)\n")
    w("The MPU polygonizer on TBB with the AVX evaluator (`--backend cpu`), welded, indexed output.\n"
      "*ns/tri* is the minimum wall time divided by the output triangles; *FVEPT* is field\n"
      "evaluations per output triangle (point evaluations, normals included). The repeats mesh\n"
      "again with one `cpu::MpuPolygonizer` into the previous mesh's arrays, as a host re-meshing\n"
      "does, so they pay no allocation or page faults; the first, cold run is `first_s` in the JSON.\n")
    w(cmd("bench_cpu"))
    w(cpu_table(cpu_rows) if cpu_rows else "_(not measured)_")
    if chart_ns_per_triangle(cpu_rows, vk_rows, os.path.join(charts, "ns_per_triangle.png")):
        w("\n![ns per triangle against resolution](performance/ns_per_triangle.png)\n")
    phase_rows = bench_rows(os.path.join(results, "bench_phases.json"))
    w(phase_section(phase_rows, commands.get("bench_phases")))
    w(sparse_section(results, commands))

    w("\n## Field evaluation (`bench_evaluator`)\n")
    w("Points per second for whole scenes, one thread, by instruction set (random points in the\n"
      "model's bounds, and coherent grid rows).\n")
    w(cmd("gb_bench_evaluator"))
    w(gb_table(gb.get("bench_evaluator", {})))

    w("\n## Vulkan kernels (`bench_vk`)\n")
    w("The field on a grid: lavapipe kernels (specialised, stackless interpreter) against the AVX\n"
      "evaluator on the same grid, and the time to specialise and compile a kernel.\n")
    w(cmd("gb_bench_vk"))
    w(gb_table(gb.get("bench_vk", {})))

    if gb.get("bench_compile_cost"):
        w("\n## Kernel compile cost against program size (`bench_compile_cost`)\n")
        w("The kernels of one mesh (field and vertex kernels with the evaluator, and the fixed extraction\n"
          "kernels) built and run once on a small grid, each in a fresh process with Mesa's shader cache\n"
          "off; generated towers of growing size. Each cell: the fastest build's wall seconds and the\n"
          "process's peak memory; for looped specialised code, the instructions it spells out.\n"
          "**Bold**: the evaluator `Traversal::Auto` picks for a mesh of that program at 64 cells\n"
          "(vk/eval/evaluator_choice.h). Specialised builds predicted above 60 s are not run.\n")
        w(cmd("gb_bench_compile_cost"))
        w(compile_cost_table(os.path.join(results, "gb_bench_compile_cost.json")))

    w("\n## FEM (`bench_fem`)\n")
    w("A corotational implicit step on a voxel block fixed at its base and pressed by a moving sphere,\n"
      "CG to the default relative residual 1e-3 with block-Jacobi (counters in ms per step, CG\n"
      "iterations per step, the worst residual, cap hits); one product with the implicit system\n"
      "(matrix-free against the assembled matrix, and the assembly); a topology change after a cut\n"
      "against a full rebuild.\n")
    w(cmd("gb_bench_fem"))
    w(gb_table(gb.get("bench_fem", {})))
    if chart_fem(gb.get("bench_fem", {}), os.path.join(charts, "fem_step.png")):
        w("\n![FEM step time against tet count](performance/fem_step.png)\n")

    w("\n## Cutting (`bench_cutting`, `bench_cut_event`)\n")
    w("A cut event on a block of ~100k and ~400k tets (64 blade steps): the cutter alone, then the whole\n"
      "event as an application runs it (cut, conversion to a topology change, FEM update).\n")
    w(cmd("gb_bench_cutting"))
    w(gb_table(gb.get("bench_cutting", {})))
    w(cmd("gb_bench_cut_event"))
    w(gb_table(gb.get("bench_cut_event", {})))

    w("\n## Editing (`bench_edit`)\n")
    w("One edit of a tower and the incremental re-mesh at 256 cells (docs/editing.md): moving a capital\n"
      "point, a pillar's cylinder, a whole pillar or a storey by about one cell, or changing the\n"
      "cylinder's colour, on towers of 2, 4 and 6 storeys (`L6` is `scenes/tower_L6P8I4.json`), 2\n"
      "threads. Per edit: *ms_apply* (recompile and region), *ms_polygonize* (the MPUs re-run),\n"
      "*ms_splice*; *full_ms* is a full re-mesh of the same scene and grid in the same process, and\n"
      "*fraction_of_full* the whole edit (apply + re-mesh) over it. Every edited mesh equals the\n"
      "full re-mesh byte for byte (`tests/cpu_simd/test_incremental_polygonizer.cpp`).\n")
    w(cmd("gb_bench_edit"))
    w(gb_table(gb.get("bench_edit", {}),
               counters=["ms_apply", "ms_polygonize", "ms_splice", "mpus_rerun", "mpus", "triangles",
                         "full_ms", "fraction_of_full"],
               rename=lambda n: n.replace("/threads:2/min_time:1.000", ""), time_label="time per edit"))

    w("\n## Tetrahedral meshing (`bench_tetgen`)\n")
    w("TetGen on the shipped simulated scenes after the surface clean-up, to about 100k tets, with the\n"
      "minimum dihedral angle reached.\n")
    w(cmd("gb_bench_tetgen"))
    w(gb_table(gb.get("bench_tetgen", {})))

    page = os.path.join(docs, "performance.md")
    text = "\n".join(md).replace("\n\n\n", "\n\n")
    # The hand-measured sections (from the marker on) stay as the page has them.
    if os.path.exists(page):
        old = open(page).read()
        at = old.find(HAND_MEASURED_MARKER)
        if at >= 0:
            text = text.rstrip("\n") + "\n\n" + old[at:].rstrip("\n")
    with open(page, "w") as f:
        f.write(text + "\n")


if __name__ == "__main__":
    main()
