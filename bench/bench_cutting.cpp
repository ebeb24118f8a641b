// Cost of one cut event (cutting::Cutter::cut) on a voxel block of ~100k tets: a planar blade
// stroke 10 units wide sweeping 10 units (about 100 unit^2, ~500 split tets), tilted so that every
// cut case occurs. The mesh is rebuilt (outside the timed region) every `kStrokesPerMesh` strokes,
// which cut parallel, disjoint slices, so each stroke meets fresh tets.
// Counters: split tets per event, split tets per ms (from CutResult::seconds), split tets per ms
// of the splits phase (anchor T3's throughput), slots added per event, live tets, the
// mean time of the event's four phases (CutResult::phaseSeconds, us), and the minimum dihedral
// angle of the tets an event removes (before) and of those it adds (after), at rest; the
// dihedral scan runs with the timer paused.
// Arg 26: 105k tets; Arg 41: 414k tets (4x): the per-event cost must not grow with the mesh.
#include "cutting/cutter.h"
#include "cutting/quality.h"
#include "cutting/vec.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace {

using namespace blobvk;
using namespace blobvk::cutting;


// n^3 unit voxels, 6 tets each (the thesis split, as fem::voxelTetrahedralize), positive.
mesh::TetMesh cube(int n) {
  mesh::TetMesh m;
  auto id = [n](int x, int y, int z) { return std::uint32_t((z * (n + 1) + y) * (n + 1) + x); };
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) m.positions.push_back({double(x), double(y), double(z)});
  m.restPositions = m.positions;
  constexpr int kSix[6][4] = {{0, 2, 1, 4}, {3, 2, 4, 1}, {3, 2, 6, 4}, {3, 1, 4, 5}, {3, 4, 6, 5}, {3, 6, 7, 5}};
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        std::array<std::uint32_t, 8> c{};
        for (int b = 0; b < 8; ++b) c[b] = id(x + (b & 1), y + (b >> 1 & 1), z + (b >> 2 & 1));
        for (const auto& s : kSix) {
          cutting::Tet t{c[s[0]], c[s[1]], c[s[2]], c[s[3]]};
          const auto& p = m.positions;
          if (cutting::tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
        }
      }
  return m;
}

Double3 unit(Double3 v) { return v * (1.0 / cutting::length(v)); }

// Stroke k: a square blade patch of half-size 5 centred at z = 3.5 + k, slightly tilted.
std::vector<cutting::Triangle> stroke(int k) {
  const Double3 c{8.3 + 0.37 * (k % 3), 8.6 - 0.21 * (k % 5), 3.5 + k + 0.13 * (k % 2)};
  const Double3 u = unit({1, 0.2, 0.1}), v = unit(cutting::cross(u, {0.1, -0.3, 1}));
  const cutting::BladeKeyframe from{0.0, c - u * 5.0 - v * 5.0, c - u * 5.0 + v * 5.0};
  const cutting::BladeKeyframe to{1.0, c + u * 5.0 - v * 5.0, c + u * 5.0 + v * 5.0};
  return cutting::sweptTriangles(from, to);
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
  double splits = 0, added = 0, seconds = 0, dihedralBefore = 180, dihedralAfter = 180;
  std::array<double, 4> phases{};
  for (auto _ : state) {
    if (k == kStrokesPerMesh) {
      state.PauseTiming();
      cutter = std::make_unique<cutting::Cutter>(block);
      k = 0;
      state.ResumeTiming();
    }
    const cutting::CutResult r = cutter->cut(stroke(k++));
    splits += double(r.splitTets);
    added += double(r.addedTets.size());
    seconds += r.seconds;
    for (std::size_t i = 0; i < 4; ++i) phases[i] += r.phaseSeconds[i];
    benchmark::DoNotOptimize(r.addedTets.data());
    state.PauseTiming();
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
  state.counters["added_per_event"] = added / events;
  const char* names[4] = {"us_candidates", "us_cut_edges_nodes", "us_splits", "us_opening"};
  for (std::size_t i = 0; i < 4; ++i) state.counters[names[i]] = phases[i] * 1e6 / events;
  state.counters["min_dihedral_before"] = dihedralBefore;
  state.counters["min_dihedral_after"] = dihedralAfter;
}
// 26^3 * 6 = 105,456 tets; 41^3 * 6 = 413,526 tets.
BENCHMARK(BM_CutEvent)->Arg(26)->Arg(41)->Unit(benchmark::kMillisecond)->Iterations(64);

}  // namespace

BENCHMARK_MAIN();
