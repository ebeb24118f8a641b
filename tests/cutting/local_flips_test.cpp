// LocalFlips (local_flips.h): on hand-made configurations whose best connectivity is known, and on
// a TetGen ball of two regions where every tet below 40 deg is attacked. Oracles: the dihedral
// angles computed independently (tetQuality), the volume of each region and the boundary faces
// (unchanged by any flip), the self-check (conforming, positive), the change set replayed on a
// copy of the tets, and the minimum dihedral angle never falling.
#include "blobvk/cutting/local_flips.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/vec.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <cstdio>
#include <set>
#include <string>

namespace blobvk::cutting {
namespace {

double minAngle(const mesh::TetMesh& m) {
  double worst = 180;
  for (const auto& t : m.tets) {
    const auto& r = m.restPositions;
    worst = std::min(worst, tetQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]).minDihedralDeg);
  }
  return worst;
}

std::set<std::array<std::uint32_t, 3>> boundary(const CutTopology& topology) {
  std::set<std::array<std::uint32_t, 3>> faces;
  for (const auto& f : topology.toTetMesh().boundaryFaces) {
    std::array<std::uint32_t, 3> k{f[0], f[1], f[2]};
    std::sort(k.begin(), k.end());
    faces.insert(k);
  }
  return faces;
}

struct FlipRun {
  FlipStats stats;
  std::vector<std::uint32_t> removed, added;
  std::vector<Tet> removedNodes;
};

FlipRun improveAll(CutTopology& topology, double belowDeg) {
  SpatialGrid grid;
  grid.rebuild(topology);
  std::vector<std::uint32_t> seeds(topology.slotCount());
  for (std::uint32_t s = 0; s < seeds.size(); ++s) seeds[s] = s;
  FlipRun run;
  LocalFlips flips;
  run.stats = flips.improve(topology, grid, seeds, belowDeg, 1u << 20, {run.removed, run.removedNodes, run.added});
  return run;
}

TEST(LocalFlips, MinDihedralMatchesTetQuality) {
  const Double3 a{0, 0, 0}, b{1, 0.1, 0}, c{0.2, 1, 0.05}, d{0.3, 0.2, 0.9};
  EXPECT_NEAR(minDihedralDeg(a, b, c, d), tetQuality(a, b, c, d).minDihedralDeg, 1e-9);
  EXPECT_NEAR(minDihedralDeg({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}), 54.7356103172, 1e-8);
}

// A triangle (a, b, c) with apexes d above and e below, the triangle much larger than the apex
// heights: the two tets are flat, the three tets around the edge d-e are not.
TEST(LocalFlips, FaceRemovalReplacesTwoFlatTetsByThreeAroundTheApexEdge) {
  mesh::TetMesh m;
  m.positions = {{1, 0, 0}, {-0.5, 0.866, 0}, {-0.5, -0.866, 0}, {0, 0, 0.25}, {0, 0, -0.25}};
  m.restPositions = m.positions;
  m.tets = {{0, 1, 2, 3}, {0, 2, 1, 4}};
  for (auto& t : m.tets)
    if (tetVolume(m.positions[t[0]], m.positions[t[1]], m.positions[t[2]], m.positions[t[3]]) < 0) std::swap(t[0], t[1]);
  m.regions = {0, 0};
  const double before = minAngle(m);
  CutTopology topology(m);
  const auto faces = boundary(topology);
  const FlipRun run = improveAll(topology, 30);
  EXPECT_EQ(run.stats.faceRemovals, 1u);
  EXPECT_EQ(topology.liveTetCount(), 3u);
  EXPECT_TRUE(topology.hasEdge(3, 4));
  EXPECT_EQ(topology.tetsOfFace(0, 1, 2)[0], kNone);  // the shared face is gone
  EXPECT_TRUE(topology.selfCheck().ok());
  EXPECT_EQ(boundary(topology), faces);
  EXPECT_GT(minAngle(topology.toTetMesh()), before + 10);
}

// Edge removal on an octahedron: an axis (0, 0, +-h) through a ring of four nodes, the first at
// (s, 0, 0), the others at radius 1. The four tets around the axis or the four around either ring
// diagonal (the ring's two triangulations, valid when the tets do not overlap: their volumes sum
// to the octahedron's): the best of these, computed here with tetQuality, is what the flips must
// end with, and the axis must be gone exactly when a diagonal is better.
TEST(LocalFlips, EdgeRemovalEndsWithTheBestOfTheOctahedronsSplits) {
  int removed = 0;
  for (const double h : {0.3, 1.0, 2.0})
    for (const double s : {0.3, 0.6, 1.5, 2.5}) {
      mesh::TetMesh m;
      m.positions = {{0, 0, h}, {0, 0, -h}, {s, 0, 0}, {0, 1, 0}, {-1, 0, 0.01}, {0, -1, 0}};
      m.restPositions = m.positions;
      const auto& p = m.positions;
      std::vector<Tet> aroundAxis, aroundDiagonal02, aroundDiagonal13;
      for (std::uint32_t k = 0; k < 4; ++k) aroundAxis.push_back({0, 1, 2 + k, 2 + (k + 1) % 4});
      for (std::uint32_t apex : {0u, 1u}) {
        aroundDiagonal02.push_back({2, 3, 4, apex});
        aroundDiagonal02.push_back({2, 4, 5, apex});
        aroundDiagonal13.push_back({3, 4, 5, apex});
        aroundDiagonal13.push_back({3, 5, 2, apex});
      }
      auto volumeOf = [&](const std::vector<Tet>& tets) {
        double v = 0;
        for (const Tet& t : tets) v += std::fabs(tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]));
        return v;
      };
      const double volume = volumeOf(aroundAxis);
      auto worstOf = [&](const std::vector<Tet>& tets) {
        if (std::fabs(volumeOf(tets) - volume) > 1e-12 * volume) return -1.0;  // overlapping: not a split
        double worst = 180;
        for (const Tet& t : tets) worst = std::min(worst, tetQuality(p[t[0]], p[t[1]], p[t[2]], p[t[3]]).minDihedralDeg);
        return worst;
      };
      const double axis = worstOf(aroundAxis);
      const double best = std::max({axis, worstOf(aroundDiagonal02), worstOf(aroundDiagonal13)});
      for (Tet& t : aroundAxis)
        if (tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
      m.tets = aroundAxis;
      m.regions.assign(4, 0);
      CutTopology topology(m);
      const auto faces = boundary(topology);
      const FlipRun run = improveAll(topology, 90);
      const std::string at = "h = " + std::to_string(h) + ", s = " + std::to_string(s);
      EXPECT_NEAR(minAngle(topology.toTetMesh()), best, 1e-9) << at;
      EXPECT_EQ(topology.hasEdge(0, 1), best == axis) << at;
      EXPECT_EQ(run.stats.edgeRemovals, best == axis ? 0u : 1u) << at;
      removed += best != axis;
      EXPECT_EQ(topology.liveTetCount(), 4u);
      EXPECT_TRUE(topology.selfCheck().ok()) << at;
      EXPECT_EQ(boundary(topology), faces) << at;
      EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-14 * volume) << at;
    }
  EXPECT_GT(removed, 0);  // some of these octahedra are better split along a ring diagonal
}

// Every tet of a TetGen ball below 40 deg attacked, with two regions (x < 0 and x >= 0 by
// centroid): no flip mixes them, so each region keeps its volume; the boundary (the ball's
// surface and the region interface are different things: only the surface is a boundary) is
// unchanged; the change set replays; the minimum angle does not fall.
TEST(LocalFlips, ManyFlipsKeepRegionsBoundaryVolumeAndReplay) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 4e-3;
  mesh::TetMesh m = fem::tetrahedralize(testing::icosphere(2), options);
  m.regions.assign(m.tets.size(), 0);
  for (std::size_t i = 0; i < m.tets.size(); ++i) {
    const auto& t = m.tets[i];
    const auto& p = m.restPositions;
    m.regions[i] = p[t[0]].x + p[t[1]].x + p[t[2]].x + p[t[3]].x < 0 ? 0u : 1u;
  }
  auto regionVolumes = [](const CutTopology& topology) {
    std::array<double, 2> v{};
    const auto& r = topology.mesh().restPositions;
    for (std::uint32_t s = 0; s < topology.slotCount(); ++s) {
      const Tet& t = topology.tet(s);
      v[topology.mesh().regions[s]] += tetVolume(r[t[0]], r[t[1]], r[t[2]], r[t[3]]);
    }
    return v;
  };
  const double before = minAngle(m);
  CutTopology topology(m);
  const auto faces = boundary(topology);
  const auto volumes = regionVolumes(topology);
  std::map<std::uint32_t, Tet> mirror;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s) mirror[s] = topology.tet(s);
  const FlipRun run = improveAll(topology, 40);
  EXPECT_GT(run.stats.edgeRemovals, 10u);
  EXPECT_GT(run.stats.threeTwo, 0u);  // after edge removals that appended slots
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  EXPECT_EQ(boundary(topology), faces);
  const auto after = regionVolumes(topology);
  for (int r = 0; r < 2; ++r) EXPECT_NEAR(after[r], volumes[r], 1e-13 * volumes[r]) << "region " << r;
  ASSERT_EQ(run.removed.size(), run.removedNodes.size());
  for (std::size_t i = 0; i < run.removed.size(); ++i) {
    ASSERT_EQ(mirror.at(run.removed[i]), run.removedNodes[i]);
    mirror.erase(run.removed[i]);
  }
  for (std::uint32_t s : run.added) mirror[s] = topology.tet(s);
  ASSERT_EQ(mirror.size(), topology.liveTetCount());
  for (const auto& [slot, nodes] : mirror) EXPECT_EQ(topology.tet(slot), nodes);
  const double improved = minAngle(topology.toTetMesh());
  EXPECT_GE(improved, before);
  std::printf("ball of %zu tets: %zu face removals, %zu edge removals (%zu 3-2), min dihedral %.2f -> %.2f deg\n",
              m.tets.size(), run.stats.faceRemovals, run.stats.edgeRemovals, run.stats.threeTwo, before, improved);
}

}  // namespace
}  // namespace blobvk::cutting
