// NodeSmoothing (node_smoothing.h) on a voxel block with one interior node pushed almost onto a
// face of its star, which makes slivers no flip is asked to fix. Oracles: the smallest dihedral
// angle (computed independently by tetQuality), the block's volume, the boundary nodes (never
// moved), the topology self-check, and each move's weights reproducing the new rest position
// from the positions before it.
#include "blobvk/cutting/node_smoothing.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/topology.h"

#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>

namespace blobvk::cutting {
namespace {

double minAngle(const mesh::TetMesh& m) {
  double worst = 180;
  for (const Tet& t : m.tets) {
    const auto& r = m.restPositions;
    worst = std::min(worst, tetQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]).minDihedralDeg);
  }
  return worst;
}

// A 4^3 block with node (2, 2, 2) moved to (1.98, 1.97, 1.15): still positive, but several of its
// tets are slivers.
mesh::TetMesh pushedBlock(std::uint32_t& pushed) {
  mesh::TetMesh m = test::cubeMesh(4);
  for (std::uint32_t i = 0; i < m.nodeCount(); ++i)
    if (m.restPositions[i].x == 2 && m.restPositions[i].y == 2 && m.restPositions[i].z == 2) pushed = i;
  m.restPositions[pushed] = m.positions[pushed] = {1.98, 1.97, 1.15};
  return m;
}

struct Smoothed {
  std::vector<MovedNode> moved;
  std::vector<std::uint32_t> removed, added;
  std::vector<Tet> removedNodes;
};

Smoothed smooth(CutTopology& topology, const std::vector<double>& onCut) {
  SpatialGrid grid;
  grid.rebuild(topology);
  std::vector<std::uint32_t> seeds(topology.slotCount());
  std::iota(seeds.begin(), seeds.end(), 0u);
  Smoothed run;
  NodeSmoothing smoothing;
  smoothing.improve(topology, grid, seeds, 15.0, onCut, {run.removed, run.removedNodes, run.added}, run.moved);
  return run;
}

TEST(NodeSmoothing, AFreeInteriorNodeMovesAndRaisesTheSmallestAngle) {
  std::uint32_t pushed = 0;
  const mesh::TetMesh before = pushedBlock(pushed);
  const double angleBefore = minAngle(before);
  ASSERT_LT(angleBefore, 15.0);
  ASSERT_TRUE(CutTopology(before).selfCheck().ok());  // still positive
  CutTopology topology(before);
  const double volume = topology.totalRestVolume();
  const Smoothed run = smooth(topology, std::vector<double>(before.nodeCount(), 0.0));
  ASSERT_FALSE(run.moved.empty());
  std::printf("min dihedral %.2f -> %.2f deg, %zu moves\n", angleBefore, minAngle(topology.mesh()), run.moved.size());
  EXPECT_GT(minAngle(topology.mesh()), angleBefore + 1.0);
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-12 * volume);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  // Boundary nodes never move; a move's weights give its new place from the values before it.
  std::vector<mesh::Double3> rest = before.restPositions;
  for (const MovedNode& m : run.moved) {
    const mesh::Double3 p = rest[m.index];
    EXPECT_FALSE(p.x == 0 || p.x == 4 || p.y == 0 || p.y == 4 || p.z == 0 || p.z == 4) << "node " << m.index;
    mesh::Double3 sum{0, 0, 0};
    for (std::size_t i = 0; i < 4; ++i) {
      const mesh::Double3 s = rest[m.sources[i]];
      sum = {sum.x + m.weights[i] * s.x, sum.y + m.weights[i] * s.y, sum.z + m.weights[i] * s.z};
    }
    rest[m.index] = sum;
  }
  for (std::uint32_t v = 0; v < rest.size(); ++v) {
    EXPECT_EQ(rest[v].x, topology.mesh().restPositions[v].x) << "node " << v;
    EXPECT_EQ(rest[v].z, topology.mesh().restPositions[v].z) << "node " << v;
  }
  // Every tet around a moved node is in the change set, listed as removed with its (same) nodes.
  for (const MovedNode& m : run.moved)
    for (std::uint32_t s : topology.tetsOfNode(m.index)) {
      EXPECT_NE(std::find(run.added.begin(), run.added.end(), s), run.added.end()) << "slot " << s;
      const auto it = std::find(run.removed.begin(), run.removed.end(), s);
      ASSERT_NE(it, run.removed.end()) << "slot " << s;
      EXPECT_EQ(run.removedNodes[std::size_t(it - run.removed.begin())], topology.tet(s));
    }
}

TEST(NodeSmoothing, ANodeOnACutSurfaceStays) {
  std::uint32_t pushed = 0;
  const mesh::TetMesh before = pushedBlock(pushed);
  CutTopology topology(before);
  std::vector<double> onCut(before.nodeCount(), 0.0);
  onCut[pushed] = 1e-3;
  const Smoothed run = smooth(topology, onCut);
  for (const MovedNode& m : run.moved) EXPECT_NE(m.index, pushed);
  EXPECT_EQ(topology.mesh().restPositions[pushed].x, 1.98);
}

}  // namespace
}  // namespace blobvk::cutting
