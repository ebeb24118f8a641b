// FEM step cost (corotational linear tets, implicit Euler, CG to the default relative residual
// 1e-3) on voxel box meshes of ~1k, 10k and 100k tets pressed by a moving sphere, with a
// per-phase breakdown as counters (ms per step): rotations, assembly, contact, solve.
#include "bench/cut_settings.h"
#include "blobvk/fem/elements.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/system_matrix.h"
#include "blobvk/fem/voxel_mesher.h"
#include "tests/fem/cut_changes.h"  // the same cut-like change builder the topology tests use

#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <optional>

namespace {

using namespace blobvk;

mesh::TetMesh box(int cx, int cy, int cz) {
  fem::VoxelMesherSettings s;
  s.boundsMin = {0, 0, 0};
  s.boundsMax = {0.01 * cx, 0.01 * cy, 0.01 * cz};
  s.cellSize = 0.01;
  return fem::voxelTetrahedralize([](double, double, double) { return 1.0f; }, s);
}

// The block fixed at its base and pressed by a sphere that keeps moving (so the warm start is
// never already the answer): down into the top face, then sideways, about 2 mm per step at 60 Hz.
// CG runs to the default tolerance (relative residual 1e-3, cap 500).
fem::SimulationSettings pressedBlock(int cx, int cy, int cz) {
  fem::SimulationSettings settings;
  settings.materials = {fem::Material{1e5, 0.45, 1000}};
  settings.fixed = [](const mesh::Double3& p) { return p.y < 1e-9; };
  settings.cgMaxIterations = 500;
  settings.cgTolerance = 1e-3;
  fem::Tool probe;
  probe.radius = 0.02;
  probe.stiffness = 2e3;
  const double top = 0.01 * cy, midX = 0.005 * cx, midZ = 0.005 * cz;
  probe.path = {{0.0, {midX, top + 0.02, midZ}}, {1.0, {midX, top - 0.01, midZ}}, {3.0, {midX + 0.1, top - 0.01, midZ + 0.1}}};
  settings.tools = {probe};
  return settings;
}

// The default solver (block-Jacobi) on the pressed block, 30 steps after 30 warm-up steps (the
// probe touches the body from there on). Counters: ms per step of each phase, CG iterations per
// step and the largest relative residual (all steps meet the tolerance: cap_hits 0).
// (A fixed 10 CG iterations per step, as SOFA's benchmark protocol runs, is not a stable
// implicit step: this block blew up within ~100 steps, and the figures measured a garbage state.)
void BM_FemStep(benchmark::State& state) {
  const int cx = int(state.range(0)), cy = int(state.range(1)), cz = int(state.range(2));
  fem::Simulation sim(box(cx, cy, cz), pressedBlock(cx, cy, cz));
  sim.run(30);
  double rotations = 0, assembly = 0, contact = 0, solve = 0, iterations = 0, rotationIterations = 0, worst = 0;
  for (auto _ : state) {
    sim.step();
    const auto& s = sim.lastStats();
    rotations += s.rotationsMs;
    assembly += s.assemblyMs;
    contact += s.contactMs;
    solve += s.solveMs + s.preconditionerMs;
    iterations += s.cgIterations;
    rotationIterations += s.rotationIterationsPerTet;
    worst = std::max(worst, s.cgRelativeResidual);
  }
  const double n = double(state.iterations());
  state.counters["tets"] = double(sim.mesh().tetCount());
  state.counters["nodes"] = double(sim.mesh().nodeCount());
  state.counters["rotations_ms"] = rotations / n;
  state.counters["assembly_ms"] = assembly / n;
  state.counters["contact_ms"] = contact / n;
  state.counters["solve_ms"] = solve / n;
  state.counters["cg_iterations"] = iterations / n;
  state.counters["max_rel_residual"] = worst;
  state.counters["cap_hits"] = double(sim.solverSummary().capHits);
  state.counters["rot_iters_per_tet"] = rotationIterations / n;
}

// A step solved to a stated tolerance (relative residual 1e-3, cap 500) with each
// preconditioner (arg 3: 0 Jacobi, 1 block-Jacobi, 2 incomplete Cholesky), on the pressed block.
// Counters: CG iterations per step, the largest relative residual, preconditioner set-up and
// solve ms.
void BM_FemStepConverged(benchmark::State& state) {
  const int cx = int(state.range(0)), cy = int(state.range(1)), cz = int(state.range(2));
  fem::SimulationSettings settings = pressedBlock(cx, cy, cz);
  settings.preconditioner = fem::PreconditionerKind(state.range(3));
  fem::Simulation sim(box(cx, cy, cz), settings);
  sim.run(30);  // the probe touches the body from here on
  double setup = 0, solve = 0, iterations = 0, worst = 0, steps = 0;
  for (auto _ : state) {
    sim.step();
    const auto& s = sim.lastStats();
    setup += s.preconditionerMs;
    solve += s.solveMs;
    iterations += s.cgIterations;
    worst = std::max(worst, s.cgRelativeResidual);
    ++steps;
  }
  state.counters["tets"] = double(sim.mesh().tetCount());
  state.counters["cg_iterations"] = iterations / steps;
  state.counters["max_rel_residual"] = worst;
  state.counters["cap_hits"] = double(sim.solverSummary().capHits);
  state.counters["precond_ms"] = setup / steps;
  state.counters["solve_ms"] = solve / steps;
}
BENCHMARK(BM_FemStepConverged)
    ->ArgsProduct({{12}, {12}, {12}, {0, 1, 2}})
    ->Args({19, 20, 45, 0})
    ->Args({19, 20, 45, 1})
    ->Args({19, 20, 45, 2})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(30);

// One product with the implicit system, the core of a CG iteration, on a bent block (arg 3: 0
// matrix-free, per tet then a per-node gather, double; 1 the assembled matrix of
// system_matrix.h, float off-diagonal blocks; 2 assembling that matrix, once per step).
void BM_FemSystemProduct(benchmark::State& state) {
  const mesh::TetMesh m = box(int(state.range(0)), int(state.range(1)), int(state.range(2)));
  fem::ElementSet elements;
  elements.build(m, {fem::Material{1e5, 0.45, 1000}});
  std::vector<mesh::Double3> x = m.restPositions;
  for (auto& p : x) {
    const double a = 0.5 * p.y, c = std::cos(a), s = std::sin(a);
    p = {c * p.x - s * p.y, s * p.x + c * p.y, 1.01 * p.z};
  }
  const std::size_t n = m.nodeCount();
  std::vector<double> force(3 * n), nodeScale(n, 1e-3), p(3 * n), y(3 * n);
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = std::sin(0.37 * double(i));
  elements.computeForces(x, 30, force.data(), nullptr);
  fem::SystemMatrix matrix;
  matrix.buildPattern(elements.incidence(), m.tets);
  elements.assembleMatrix(matrix, nodeScale.data(), 2.8e-4);
  const long mode = state.range(3);
  for (auto _ : state) {
    if (mode == 0) elements.applySystem(p.data(), y.data(), nodeScale.data(), 2.8e-4);
    if (mode == 1) matrix.multiply(p.data(), y.data());
    if (mode == 2) elements.assembleMatrix(matrix, nodeScale.data(), 2.8e-4);
    benchmark::DoNotOptimize(y.data());
  }
  state.counters["tets"] = double(m.tetCount());
}
BENCHMARK(BM_FemSystemProduct)->ArgsProduct({{12}, {12}, {12}, {0, 1, 2}})->ArgsProduct({{19}, {20}, {45}, {0, 1, 2}})->Unit(benchmark::kMillisecond);

// A cut-like change on the 100k-tet block: every edge crossing the plane y = 0.155 inside a
// 9 x 9-cell window is split at the plane (as a scalpel sweep's intersection points would be),
// which rewrites the tets crossing it in place and appends their other pieces.
fem::TopologyChange cutChange(const mesh::TetMesh& m) {
  fem::test::ChangeBuilder b(m);
  const double plane = 0.155;
  auto inWindow = [](const mesh::Double3& p) { return p.x > 0.045 && p.x < 0.145 && p.z > 0.145 && p.z < 0.245; };
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  for (const auto& t : m.tets)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const auto &a = m.restPositions[t[std::size_t(i)]], &c = m.restPositions[t[std::size_t(j)]];
        if (a.y < plane && c.y > plane && inWindow(a) && inWindow(c)) edges.emplace_back(t[std::size_t(i)], t[std::size_t(j)]);
      }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  for (const auto& [a, c] : edges) {
    const double ya = m.restPositions[a].y, yc = m.restPositions[c].y;
    b.splitEdge(a, c, (plane - ya) / (yc - ya));
  }
  return b.build();
}

// One applyTopologyChange of the cut above on a running 100k-tet simulation. The simulation is
// rebuilt, and the previous one destroyed, outside the timed region for every iteration (the
// destructor frees ~100 MB: timing it once made this benchmark read 5 ms instead of ~1).
// Counter `page_faults`: minor page faults per change (first touches of the reserved room);
// `next_step_rows_ms`: the step after the change rebuilding the solver matrix's rows it touched
// (untimed here, part of that step's assembly).
void BM_FemTopologyChange(benchmark::State& state) {
  const mesh::TetMesh m = box(19, 20, 45);
  const fem::TopologyChange change = cutChange(m);
  std::size_t rewritten = 0;
  for (auto slot : change.tetSlots) rewritten += slot < m.tetCount() ? 1 : 0;
  std::optional<fem::Simulation> sim;
  double faults = 0, nextStepRows = 0;
  for (auto _ : state) {
    state.PauseTiming();
    sim.reset();
    sim.emplace(m, bench::cutBlockSettings());
    sim->run(1);
    rusage before{}, after{};
    getrusage(RUSAGE_THREAD, &before);
    state.ResumeTiming();
    sim->applyTopologyChange(change);
    benchmark::DoNotOptimize(sim->mesh().tetCount());
    state.PauseTiming();
    getrusage(RUSAGE_THREAD, &after);
    faults += double(after.ru_minflt - before.ru_minflt);
    sim->step();  // rebuilds the solver matrix's rows the change touched
    nextStepRows += sim->lastStats().matrixPatternMs;
    state.ResumeTiming();
  }
  sim.reset();  // the loop is over: no longer timed
  state.counters["page_faults"] = faults / double(state.iterations());
  state.counters["next_step_rows_ms"] = nextStepRows / double(state.iterations());
  state.counters["new_nodes"] = double(change.newNodes.size());
  state.counters["tets_rewritten"] = double(rewritten);
  state.counters["tets_appended"] = double(change.tetSlots.size() - rewritten);
}
BENCHMARK(BM_FemTopologyChange)->Iterations(5)->Unit(benchmark::kMillisecond);

// For comparison: what a full rebuild costs, a fresh Simulation on the 100k-tet block.
void BM_FemRebuild(benchmark::State& state) {
  const mesh::TetMesh m = box(19, 20, 45);
  for (auto _ : state) {
    fem::Simulation sim(m, bench::cutBlockSettings());
    benchmark::DoNotOptimize(sim.mesh().tetCount());
  }
}
BENCHMARK(BM_FemRebuild)->Iterations(5)->Unit(benchmark::kMillisecond);
// 960, 10,368 and 102,600 tets (the last two match the anchors' baseline meshes).
BENCHMARK(BM_FemStep)->Args({8, 5, 4})->Args({12, 12, 12})->Args({19, 20, 45})->Unit(benchmark::kMillisecond)->Iterations(30);

}  // namespace

BENCHMARK_MAIN();
