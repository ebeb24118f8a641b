// One cut event end to end, as the app runs it (surgery/soft_body.cpp, SoftBody::cutEvent):
// the cutter splits the tets the blade swept (cutting::Cutter::cut), the event becomes a
// fem::TopologyChange (surgery::toTopologyChange), and the running simulation takes it
// (fem::Simulation::applyTopologyChange: element data, lumped masses, incidence rows, boundary
// faces). Anchor T3: <= 2 ms per event at ~100k tets with ~500 tets swept.
// Mesh and strokes are bench_cutting's BM_CutEvent: a 26^3 block of unit voxels (105,456 tets),
// tilted 10 x 10 blade strokes on parallel, disjoint slices; cutter and simulation are rebuilt
// (outside the timed region) every 16 strokes. The simulation does not step between events (a
// step costs ~40 ms here and does not change what an event costs).
// Counters per event: wall ms and main-thread CPU ms of each phase (cut, convert, fem) and of the
// sum, split tets, new nodes, tet slots written, and the wall ms of the flips after the opening
// (CutResult::flipSeconds, part of the cut).
#include "blobvk/surgery/cut_to_topology_change.h"
#include "bench/cut_block.h"
#include "bench/cut_settings.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/cutting/quality.h"
#include "tests/cutting/random_strokes.h"
#include "tests/fem/icosphere.h"

#include <benchmark/benchmark.h>

#include <cstdlib>

#include <time.h>

#include <array>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

namespace {

using namespace blobvk;
using bench::cube;
using bench::stroke;


// The cutter's options with the snap fraction given in hundredths (a benchmark argument).
// The snap fraction in %; BLOBVK_SMOOTH_BELOW_DEG, when set, replaces the node smoothing's
// threshold (0: off), for comparing the quality and time with and without it.
cutting::CutOptions snapOptions(std::int64_t percent) {
  cutting::CutOptions options;
  options.snapFraction = double(percent) / 100.0;
  if (const char* text = std::getenv("BLOBVK_SMOOTH_BELOW_DEG"); text && *text)
    options.smoothBelowDeg = std::strtod(text, nullptr);
  return options;
}

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// Wall and main-thread CPU time of one phase, summed over events.
struct PhaseClock {
  double wallMs = 0, cpuMs = 0;
  template <class Body>
  auto time(Body&& body) {
    const auto wall = std::chrono::steady_clock::now();
    const double cpu = threadCpuMs();
    auto result = body();
    cpuMs += threadCpuMs() - cpu;
    wallMs += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - wall).count();
    return result;
  }
};

// Cut events on `body` (FEM settings `settings`) with strokes stroke(0 .. strokesPerMesh-1), the
// cutter and simulation rebuilt every strokesPerMesh events outside the timed region: per event,
// the cut, its conversion to an FEM topology change and the FEM update, wall and CPU time.
template <class Stroke>
void runCutEvents(benchmark::State& state, const mesh::TetMesh& body, const fem::SimulationSettings& settings,
                  const cutting::CutOptions& options, int strokesPerMesh, Stroke&& stroke) {
  std::unique_ptr<cutting::Cutter> cutter;
  std::optional<fem::Simulation> sim;
  int k = strokesPerMesh;
  PhaseClock cut, convert, apply;
  double splits = 0, newNodes = 0, slots = 0, flipMs = 0, flipAttempts = 0, flipsDone = 0;
  std::array<double, 4> phaseMs{};
  for (auto _ : state) {
    if (k == strokesPerMesh) {
      state.PauseTiming();
      cutter.reset();
      sim.reset();
      cutter = std::make_unique<cutting::Cutter>(body, options);
      sim.emplace(body, settings);
      sim->run(1);
      k = 0;
      state.ResumeTiming();
    }
    const std::size_t nodesBefore = sim->mesh().nodeCount(), tetsBefore = sim->mesh().tetCount();
    const cutting::CutResult event = cut.time([&] { return cutter->cut(stroke(k++)); });
    const fem::TopologyChange change =
        convert.time([&] { return surgery::toTopologyChange(event, cutter->topology(), nodesBefore, tetsBefore); });
    apply.time([&] {
      sim->applyTopologyChange(change);
      return 0;
    });
    benchmark::DoNotOptimize(sim->mesh().boundaryFaces.data());
    splits += double(event.splitTets);
    flipMs += event.flipSeconds * 1e3;
    flipAttempts += double(event.flipAttempts);
    flipsDone += double(event.faceRemovals + event.edgeRemovals);
    for (std::size_t p = 0; p < phaseMs.size(); ++p) phaseMs[p] += event.phaseSeconds[p] * 1e3;
    newNodes += double(change.newNodes.size());
    slots += double(change.tetSlots.size());
  }
  const double events = double(state.iterations());
  state.counters["tets"] = double(body.tets.size());
  state.counters["snap_fraction"] = options.snapFraction;
  state.counters["split_per_event"] = splits / events;
  state.counters["new_nodes"] = newNodes / events;
  state.counters["slots_written"] = slots / events;
  state.counters["cut_ms"] = cut.wallMs / events;
  state.counters["flip_ms"] = flipMs / events;  // wall, part of cut_ms
  state.counters["flip_attempts"] = flipAttempts / events;
  state.counters["flips"] = flipsDone / events;
  // The cutter's phases (CutResult::phaseSeconds): candidates, cut edges and nodes, splits and
  // crack faces, crack opening; the flips are the rest of cut_ms.
  state.counters["cut_candidates_ms"] = phaseMs[0] / events;
  state.counters["cut_edges_ms"] = phaseMs[1] / events;
  state.counters["cut_split_ms"] = phaseMs[2] / events;
  state.counters["cut_open_ms"] = phaseMs[3] / events;
  state.counters["convert_ms"] = convert.wallMs / events;
  state.counters["fem_ms"] = apply.wallMs / events;
  state.counters["total_ms"] = (cut.wallMs + convert.wallMs + apply.wallMs) / events;
  state.counters["cut_cpu_ms"] = cut.cpuMs / events;
  state.counters["convert_cpu_ms"] = convert.cpuMs / events;
  state.counters["fem_cpu_ms"] = apply.cpuMs / events;
  state.counters["total_cpu_ms"] = (cut.cpuMs + convert.cpuMs + apply.cpuMs) / events;
}

void BM_CutEventEndToEnd(benchmark::State& state) {
  const int n = int(state.range(0));
  const mesh::TetMesh block = cube(n);
  constexpr int kStrokesPerMesh = 16;  // slices z = 3.5 .. 18.5 of a block at least 26 cells high
  runCutEvents(state, block, bench::cutBlockSettings(), snapOptions(state.range(1)), kStrokesPerMesh,
               [](int k) { return stroke(k); });
}
// 26^3 * 6 = 105,456 tets; the default snap fraction (0.42), then the thesis' 0.2.
BENCHMARK(BM_CutEventEndToEnd)->Args({26, 42})->Args({26, 20})->Unit(benchmark::kMillisecond)->Iterations(64);

// The same event on the kind of body the shipped scenes simulate: a TetGen ball of radius 1
// (icosphere surface, -a maxVolume), ~100k tets, cut by 16 parallel tilted square strokes of
// half-size 0.35 (about as many tets split per event as the block's strokes), centred at
// z = -0.75 .. 0.75; cutter and simulation rebuilt every 16 strokes (outside the timed region).
std::vector<cutting::Triangle> ballStroke(int k) {
  using cutting::operator*;
  using cutting::operator+;
  using cutting::operator-;
  const auto unit = [](mesh::Double3 v) { return v * (1.0 / cutting::length(v)); };
  const mesh::Double3 c{0.03 * (k % 3), -0.02 * (k % 5), -0.75 + 0.1 * k + 0.013 * (k % 2)};
  const mesh::Double3 u = unit({1, 0.2, 0.1}), v = unit(cutting::cross(u, {0.1, -0.3, 1}));
  const cutting::BladeKeyframe from{0.0, c - u * 0.35 - v * 0.35, c - u * 0.35 + v * 0.35};
  const cutting::BladeKeyframe to{1.0, c + u * 0.35 - v * 0.35, c + u * 0.35 + v * 0.35};
  return cutting::sweptTriangles(from, to);
}

void BM_CutEventTetgenBall(benchmark::State& state) {
  if (!fem::tetgenAvailable()) {
    state.SkipWithError("built without TetGen");
    return;
  }
  fem::TetgenOptions options;
  options.maxVolume = double(state.range(0)) * 1e-6;
  const mesh::TetMesh ball = fem::tetrahedralize(testing::icosphere(4), options);
  fem::SimulationSettings settings = bench::cutBlockSettings();
  settings.fixed = [](const mesh::Double3& p) { return p.y < -0.9; };
  constexpr int kStrokesPerMesh = 16;
  runCutEvents(state, ball, settings, snapOptions(state.range(1)), kStrokesPerMesh, ballStroke);
}
// Arguments: TetGen's -a bound in 1e-6 units (130 gives ~100k tets), the snap fraction in %.
BENCHMARK(BM_CutEventTetgenBall)->Args({130, 42})->Args({130, 20})->Unit(benchmark::kMillisecond)->Iterations(64);

// Item 3 of the quality target: 100 random kinked strokes (tests/cutting/random_strokes.h, seed 16,
// as the TetgenStrokes test: three blade steps, each re-cutting the previous one, and a pass over
// the whole stroke, as surgery::SoftBody cuts) through a ~100k-tet TetGen ball, every event
// applied to the running simulation. One iteration is the 100 strokes on a fresh body.
// Counters: per event, the mean and largest wall ms (cut + convert + FEM) and the mean of each
// phase; at the end, the smallest dihedral angle at rest, how many tets are below 5 deg, the
// rest volume's relative change and whether the topology self-check passes.
// The strokes' seed: 16 (the TetgenStrokes test's), or BLOBVK_STROKES_SEED to see how the
// quality holds for other stroke sequences (docs/cutting.md, "Quality after cuts").
unsigned strokeSeed() {
  const char* text = std::getenv("BLOBVK_STROKES_SEED");
  return text && *text ? unsigned(std::strtoul(text, nullptr, 10)) : 16u;
}

void BM_RandomStrokesTetgenBall(benchmark::State& state) {
  if (!fem::tetgenAvailable()) {
    state.SkipWithError("built without TetGen");
    return;
  }
  fem::TetgenOptions options;
  options.maxVolume = double(state.range(0)) * 1e-6;
  const mesh::TetMesh ball = fem::tetrahedralize(testing::icosphere(4), options);
  fem::SimulationSettings settings = bench::cutBlockSettings();
  settings.fixed = [](const mesh::Double3& p) { return p.y < -0.9; };
  std::array<double, 5> phaseMs{};  // CutResult::phaseSeconds, then the flips
  double events = 0, worstMs = 0, minDihedral = 0, volumeChange = 0, selfCheckOk = 0, tetsAfter = 0, below5 = 0;
  PhaseClock cut, convert, apply;
  for (auto _ : state) {
    state.PauseTiming();
    cutting::Cutter cutter(ball, snapOptions(state.range(1)));
    fem::Simulation sim(ball, settings);
    const double volume = cutter.topology().totalRestVolume();
    cutting::test::RandomStrokes strokes(strokeSeed());
    state.ResumeTiming();
    for (int s = 0; s < 100; ++s)
      for (const auto& swept : strokes.next()) {
        const double before = cut.wallMs + convert.wallMs + apply.wallMs;
        const std::size_t nodesBefore = sim.mesh().nodeCount(), tetsBefore = sim.mesh().tetCount();
        const cutting::CutResult event = cut.time([&] { return cutter.cut(swept); });
        const fem::TopologyChange change = convert.time(
            [&] { return surgery::toTopologyChange(event, cutter.topology(), nodesBefore, tetsBefore); });
        apply.time([&] {
          sim.applyTopologyChange(change);
          return 0;
        });
        for (std::size_t p = 0; p < 4; ++p) phaseMs[p] += event.phaseSeconds[p] * 1e3;
        phaseMs[4] += event.flipSeconds * 1e3;
        worstMs = std::max(worstMs, cut.wallMs + convert.wallMs + apply.wallMs - before);
        ++events;
      }
    state.PauseTiming();
    const mesh::TetMesh after = cutter.topology().toTetMesh();
    const cutting::QualityStats quality = cutting::meshQuality(after);
    minDihedral = quality.minDihedralDeg;
    below5 = 0;
    for (const auto& t : after.tets) {
      const auto& r = after.restPositions;
      below5 += cutting::minDihedralDeg(r[t[0]], r[t[1]], r[t[2]], r[t[3]]) < 5.0;
    }
    tetsAfter = double(after.tets.size());
    volumeChange = std::fabs(cutter.topology().totalRestVolume() - volume) / volume;
    selfCheckOk = cutter.topology().selfCheck().ok() ? 1 : 0;
    state.ResumeTiming();
  }
  state.counters["tets"] = double(ball.tets.size());
  state.counters["snap_fraction"] = double(state.range(1)) / 100.0;
  state.counters["tets_after"] = tetsAfter;
  state.counters["events"] = events / double(state.iterations());
  state.counters["event_ms"] = (cut.wallMs + convert.wallMs + apply.wallMs) / events;
  state.counters["worst_event_ms"] = worstMs;
  state.counters["cut_ms"] = cut.wallMs / events;
  state.counters["cut_candidates_ms"] = phaseMs[0] / events;
  state.counters["cut_edges_ms"] = phaseMs[1] / events;
  state.counters["cut_split_ms"] = phaseMs[2] / events;
  state.counters["cut_open_ms"] = phaseMs[3] / events;
  state.counters["flip_ms"] = phaseMs[4] / events;
  state.counters["convert_ms"] = convert.wallMs / events;
  state.counters["fem_ms"] = apply.wallMs / events;
  state.counters["min_dihedral_deg"] = minDihedral;
  state.counters["tets_below_5deg"] = below5;
  state.counters["volume_rel_change"] = volumeChange;
  state.counters["self_check_ok"] = selfCheckOk;
}
BENCHMARK(BM_RandomStrokesTetgenBall)->Args({130, 42})->Args({130, 20})->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
