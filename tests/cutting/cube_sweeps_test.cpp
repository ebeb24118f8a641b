// Many sweeps through a block of ~25k tets: topology stays valid, volume is conserved, the change
// sets replay to the same mesh, quality bounds hold; full and closed cuts separate parts.
#include "blobvk/cutting/blade_run.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/vec.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

namespace blobvk::cutting {
namespace {

Double3 unit(Double3 v) { return v * (1.0 / length(v)); }

TEST(CubeSweeps, HundredRandomSweepsKeepTheMeshValid) {
  const int n = 16;
  Cutter cutter(test::cubeMesh(n));
  const double volume = double(n) * n * n;  // the block's volume, not the topology's own sum
  const double bound = minimumChildVolumeFraction(cutter.options().snapFraction, cutter.options().steinerMargin);
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> inside(2.0, n - 2.0), len(2.0, 6.0), g(-1.0, 1.0), tilt(-0.3, 0.3);
  // A mirror of the mesh kept only through the change sets, as an incremental FEM would.
  std::map<std::uint32_t, Tet> mirror;
  for (std::uint32_t s = 0; s < cutter.topology().slotCount(); ++s) mirror[s] = cutter.topology().tet(s);
  std::vector<Double3> mirrorRest = cutter.topology().mesh().restPositions;
  std::array<std::size_t, 11> cases{};
  std::size_t splitTotal = 0;
  double seconds = 0;
  for (int sweep = 0; sweep < 100; ++sweep) {
    const Double3 c{inside(rng), inside(rng), inside(rng)};
    const Double3 v = unit({g(rng), g(rng), g(rng)});
    const Double3 u = unit(cross(v, unit({g(rng), g(rng), g(rng)})));
    const double half = len(rng), travel = len(rng);
    BladeKeyframe from{0.0, c - v * half, c + v * half};
    // The blade also turns a little while it moves: the swept quad is not planar.
    BladeKeyframe to{1.0, c + u * travel - v * half, c + u * travel + v * half + Double3{tilt(rng), tilt(rng), tilt(rng)}};
    const CutResult r = cutter.cut(sweptTriangles(from, to));
    seconds += r.seconds;
    splitTotal += r.splitTets;
    for (std::size_t k = 0; k < cases.size(); ++k) cases[k] += r.caseCounts[k];
    EXPECT_GE(r.minChildVolumeRatio, bound * (1 - 1e-9)) << "sweep " << sweep;
    ASSERT_EQ(r.removedTets.size(), r.removedTetNodes.size());
    for (std::size_t i = 0; i < r.removedTets.size(); ++i) {
      const auto it = mirror.find(r.removedTets[i]);
      ASSERT_NE(it, mirror.end());
      EXPECT_EQ(it->second, r.removedTetNodes[i]);
      mirror.erase(it);
    }
    for (std::uint32_t s : r.addedTets) mirror[s] = cutter.topology().tet(s);
    // The rest positions kept only through the change sets: new nodes appended from their
    // sources, then the smoothing's moves in order, each from the values before it.
    ASSERT_EQ(mirrorRest.size() + r.newNodes.size(), cutter.topology().mesh().nodeCount());
    for (const NewNode& nn : r.newNodes) {
      ASSERT_EQ(nn.index, mirrorRest.size());
      Double3 at{};
      for (int k = 0; k < 4; ++k)
        if (nn.sources[k] != kNone) at = at + mirrorRest[nn.sources[k]] * nn.weights[k];
      mirrorRest.push_back(at);
    }
    for (const MovedNode& m : r.movedNodes) {
      Double3 at{};
      for (int k = 0; k < 4; ++k) at = at + mirrorRest[m.sources[k]] * m.weights[k];
      mirrorRest[m.index] = at;
    }
    const auto& rest = cutter.topology().mesh().restPositions;
    for (std::size_t v = 0; v < rest.size(); ++v) EXPECT_NEAR(length(mirrorRest[v] - rest[v]), 0.0, 1e-12) << "node " << v;
    if (sweep % 10 == 9) {
      const SelfCheckReport check = cutter.topology().selfCheck();
      ASSERT_TRUE(check.ok()) << "sweep " << sweep << ": " << check.summary();
    }
    ASSERT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-11) << "sweep " << sweep;
  }
  ASSERT_EQ(mirror.size(), cutter.topology().liveTetCount());
  for (const auto& [slot, nodes] : mirror) EXPECT_EQ(cutter.topology().tet(slot), nodes);
  std::printf("100 sweeps: %zu tets now, %zu splits, %.2f ms total cut time (%.0f split tets/ms)\n",
              cutter.topology().liveTetCount(), splitTotal, seconds * 1e3, splitTotal / (seconds * 1e3));
  for (std::size_t k = 0; k < cases.size(); ++k)
    std::printf("  case %s: %zu\n", std::string(cutCaseName(CutCase(k))).c_str(), cases[k]);
  for (CutCase c : {CutCase::A, CutCase::B, CutCase::C, CutCase::D, CutCase::X, CutCase::Y})
    EXPECT_GT(cases[std::size_t(c)], 0u) << cutCaseName(c);
}

double partVolume(const mesh::TetMesh& m, const std::vector<std::uint32_t>& part) {
  double v = 0;
  for (std::uint32_t t : part) {
    const auto& tet = m.tets[t];
    const auto& r = m.restPositions;
    v += tetVolume(r[tet[0]], r[tet[1]], r[tet[2]], r[tet[3]]);
  }
  return v;
}

TEST(CubeSweeps, FullCutThroughTheBlockGivesTwoParts) {
  const int n = 8;
  const double x = 3.47;  // crossings at 0.47 of the unit edges: nothing snaps (default tau 0.42)
  for (int steps : {1, 2, 5}) {
    BladePath path;
    for (int k = 0; k <= steps; ++k) {
      const double y = -1.0 + (n + 2.0) * k / steps;
      path.keyframes.push_back({double(k), {x, y, -1}, {x, y, n + 1.0}});
    }
    BladeRunOptions options;
    options.checkTopologyEachEvent = true;
    const BladeRunResult run = runBladePath(test::cubeMesh(n), path, options);
    for (const auto& check : run.checks) EXPECT_TRUE(check.ok()) << check.summary();
    EXPECT_TRUE(run.finalCheck.ok()) << run.finalCheck.summary();
    ASSERT_EQ(run.parts.size(), 2u) << steps << " steps";
    double v0 = partVolume(run.mesh, run.parts[0]), v1 = partVolume(run.mesh, run.parts[1]);
    if (v0 > v1) std::swap(v0, v1);
    // One step: the crack is exactly the plane. With several steps the blade stops inside tets,
    // whose later splits may snap the crack to nodes within snapFraction of an edge of the plane.
    const double tolerance = steps == 1 ? 1e-9 * n * n * n : options.cut.snapFraction * n * n;
    EXPECT_NEAR(v0, x * n * n, tolerance) << steps << " steps";
    EXPECT_NEAR(v1, (n - x) * n * n, tolerance) << steps << " steps";
    EXPECT_NEAR(run.after.totalVolume, double(n) * n * n, 1e-10 * n * n * n);
  }
}

TEST(CubeSweeps, ClosedPathCutsOutAPart) {
  // A vertical blade taller than the block travels around a circle: a cookie cutter.
  const int n = 10;
  const double cx = 4.9, cy = 5.2, radius = 2.7;
  BladePath path;
  const int steps = 24;
  for (int k = 0; k <= steps; ++k) {
    const double a = 2.0 * M_PI * k / steps;
    const double x = cx + radius * std::cos(a), y = cy + radius * std::sin(a);
    path.keyframes.push_back({double(k), {x, y, -1}, {x, y, n + 1.0}});
  }
  BladeRunOptions options;
  options.checkTopologyEachEvent = true;
  const BladeRunResult run = runBladePath(test::cubeMesh(n), path, options);
  for (const auto& check : run.checks) EXPECT_TRUE(check.ok()) << check.summary();
  ASSERT_EQ(run.parts.size(), 2u);
  EXPECT_TRUE(run.finalCheck.ok()) << run.finalCheck.summary();
  // The cut-out prism: a 24-gon of circumradius 2.7, up to the snap distance (0.2 of an edge).
  const double polygon = 0.5 * steps * radius * radius * std::sin(2.0 * M_PI / steps) * n;
  EXPECT_NEAR(partVolume(run.mesh, run.parts[1]), polygon, 0.2 * 2.0 * M_PI * radius * n);
  EXPECT_NEAR(run.after.totalVolume, double(n) * n * n, 1e-10 * n * n * n);
  std::printf("quality before: %s\nafter: %s\n%s", run.before.summary().c_str(), run.after.summary().c_str(),
              run.after.histogram().c_str());
}

}  // namespace
}  // namespace blobvk::cutting

namespace blobvk::cutting {
namespace {

// Timing of single cut events on a ~105k-tet block (printed, not asserted: the machine is shared).
TEST(CutPerformance, EventOnHundredThousandTets) {
  const int n = 26;
  Cutter cutter(test::cubeMesh(n));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> offset(-0.45, 0.45);
  double worst = 0, total = 0;
  std::size_t splits = 0;
  const int events = 20;
  for (int k = 0; k < events; ++k) {
    // A blade 10 units long moving 10 units: a ~100 unit^2 planar patch, about 500 tets.
    const double z = 3.5 + k + offset(rng);
    const Double3 c{8.3 + offset(rng), 8.6 + offset(rng), z};
    const Double3 u = unit({1, 0.2, 0.1}), v = unit(cross(u, {0.1, -0.3, 1}));
    const auto swept = test::squareTriangles(c, u, v, 5.0);
    const CutResult r = cutter.cut(swept);
    worst = std::max(worst, r.seconds);
    total += r.seconds;
    splits += r.splitTets;
  }
  EXPECT_TRUE(cutter.topology().selfCheck().ok());
  std::printf("%d events on %zu tets: mean %.3f ms, worst %.3f ms, %.1f split tets per event, %.0f split tets/ms\n",
              events, cutter.topology().liveTetCount(), total / events * 1e3, worst * 1e3,
              double(splits) / events, splits / (total * 1e3));
}

}  // namespace
}  // namespace blobvk::cutting
