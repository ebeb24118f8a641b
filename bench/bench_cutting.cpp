// Cost of one cut event (cutting::Cutter::cut) on a voxel block of ~100k tets: a planar blade
// stroke 10 units wide sweeping 10 units (about 100 unit^2, ~500 split tets), tilted so that every
// cut case occurs. The mesh is rebuilt (outside the timed region) every `kStrokesPerMesh` strokes,
// which cut parallel, disjoint slices, so each stroke meets fresh tets.
// Counters: split tets per event, split tets per ms (from CutResult::seconds), split tets per ms
// of the splits phase (anchor T3's throughput; wall time, and scaled to CPU time), slots added
// per event, live tets, minor page faults per event, the mean time of the event's four phases
// (CutResult::phaseSeconds, us), and the minimum dihedral angle of the tets an event removes
// (before) and of those it adds (after), at rest; the dihedral scan runs with the timer paused.
// Arg 26: 105k tets; Arg 41: 414k tets (4x): the per-event cost must not grow with the mesh.
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/vec.h"
#include "bench/cut_block.h"

#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace {

using namespace blobvk;
using namespace blobvk::cutting;

using bench::cube;    // bench/cut_block.h: the block and strokes bench_cut_event shares
using bench::stroke;

// Minor page faults of the calling thread so far (first touches of fresh memory: a cost of the
// event that instruction counts do not show).
double minorFaults() {
  rusage usage{};
  getrusage(RUSAGE_THREAD, &usage);
  return double(usage.ru_minflt);
}

// CPU time of the calling thread (s).
double threadSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double minDihedralDeg(const mesh::TetMesh& m, const cutting::Tet& t) {
  const auto& r = m.restPositions;
  return cutting::tetQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]).minDihedralDeg;
}

void BM_CutEvent(benchmark::State& state) {
  const int n = int(state.range(0));
  const mesh::TetMesh block = cube(n);
  constexpr int kStrokesPerMesh = 16;  // slices z = 3.5 .. 18.5 of a block at least 26 cells high
  std::unique_ptr<cutting::Cutter> cutter;
  int k = kStrokesPerMesh;
  double splits = 0, added = 0, seconds = 0, cpuSeconds = 0, faults = 0, dihedralBefore = 180, dihedralAfter = 180;
  std::array<double, 4> phases{};
  for (auto _ : state) {
    state.PauseTiming();
    if (k == kStrokesPerMesh) {
      cutter = std::make_unique<cutting::Cutter>(block);
      k = 0;
    }
    const double faultsBefore = minorFaults();
    state.ResumeTiming();
    const double cpuBefore = threadSeconds();
    const cutting::CutResult r = cutter->cut(stroke(k++));
    cpuSeconds += threadSeconds() - cpuBefore;
    splits += double(r.splitTets);
    added += double(r.addedTets.size());
    seconds += r.seconds;
    for (std::size_t i = 0; i < 4; ++i) phases[i] += r.phaseSeconds[i];
    benchmark::DoNotOptimize(r.addedTets.data());
    state.PauseTiming();
    faults += minorFaults() - faultsBefore;
    const mesh::TetMesh& m = cutter->topology().mesh();
    for (const cutting::Tet& t : r.removedTetNodes) dihedralBefore = std::min(dihedralBefore, minDihedralDeg(m, t));
    for (std::uint32_t slot : r.addedTets) dihedralAfter = std::min(dihedralAfter, minDihedralDeg(m, m.tets[slot]));
    state.ResumeTiming();
  }
  const double events = double(state.iterations());
  state.counters["tets"] = double(block.tets.size());
  state.counters["split_per_event"] = splits / events;
  state.counters["split_per_ms"] = splits / (seconds * 1e3);
  // Anchor T3's throughput (classification + table lookup + split, new nodes and adjacency
  // included): split tets per ms of the codes-and-splits phase alone.
  state.counters["split_phase_per_ms"] = splits / (phases[2] * 1e3);
  // The phases are timed in wall time (CutResult::phaseSeconds), which other processes inflate
  // on a loaded machine: the same throughput with the phase's time scaled by the whole event's
  // CPU / wall ratio (an estimate: it assumes the preemption spread evenly over the event).
  state.counters["split_phase_per_cpu_ms"] = splits / (phases[2] * (cpuSeconds / seconds) * 1e3);
  state.counters["added_per_event"] = added / events;
  state.counters["page_faults_per_event"] = faults / events;
  const char* names[4] = {"us_candidates", "us_cut_edges_nodes", "us_splits", "us_opening"};
  for (std::size_t i = 0; i < 4; ++i) state.counters[names[i]] = phases[i] * 1e6 / events;
  state.counters["min_dihedral_before"] = dihedralBefore;
  state.counters["min_dihedral_after"] = dihedralAfter;
}
// 26^3 * 6 = 105,456 tets; 41^3 * 6 = 413,526 tets.
BENCHMARK(BM_CutEvent)->Arg(26)->Arg(41)->Unit(benchmark::kMillisecond)->Iterations(64);

}  // namespace

BENCHMARK_MAIN();
