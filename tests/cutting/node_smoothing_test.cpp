// NodeSmoothing (node_smoothing.h) on a voxel block with one interior node pushed almost onto a
// face of its star, which makes slivers no flip is asked to fix. Oracles: the smallest dihedral
// angle (computed independently by tetQuality), the block's volume, the boundary nodes (never
// moved), the topology self-check, and each move's weights reproducing the new rest position
// from the positions before it.
#include "blobvk/cutting/node_smoothing.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/spatial_grid.h"
#include "blobvk/cutting/topology.h"
#include "blobvk/cutting/vec.h"

#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

Smoothed smooth(CutTopology& topology, const std::vector<double>& onCut, double belowDeg = 15.0,
                const std::vector<mesh::Double3>& snapPlane = {}) {
  SpatialGrid grid;
  grid.rebuild(topology);
  std::vector<std::uint32_t> seeds(topology.slotCount());
  std::iota(seeds.begin(), seeds.end(), 0u);
  Smoothed run;
  NodeSmoothing smoothing;
  smoothing.improve(topology, grid, seeds, belowDeg, onCut, snapPlane, {run.removed, run.removedNodes, run.added}, run.moved);
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
  // No node of the block's boundary moves (none is in a bad tet); a move's weights give its new
  // place from the values before it.
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

// The pushed node snapped to a planar cut x = 1.98 that has not opened (a crack's front, a
// partial split): it may slide parallel to that plane only, so its x (its distance to the cut,
// which the cutter's later snap decisions read) is kept while the star's smallest angle rises;
// snapped to two planes (NaN) it stays.
TEST(NodeSmoothing, ANodeSnappedToOnePlanarCutSlidesParallelToIt) {
  std::uint32_t pushed = 0;
  const mesh::TetMesh before = pushedBlock(pushed);
  const double angleBefore = minAngle(before);
  CutTopology topology(before);
  const double volume = topology.totalRestVolume();
  std::vector<double> onCut(before.nodeCount(), 0.0);
  onCut[pushed] = 1e-3;
  std::vector<mesh::Double3> plane(before.nodeCount(), mesh::Double3{0, 0, 0});
  plane[pushed] = {1, 0, 0};
  const Smoothed run = smooth(topology, onCut, 15.0, plane);
  ASSERT_FALSE(run.moved.empty());
  const auto& rest = topology.mesh().restPositions;
  std::printf("min dihedral %.2f -> %.2f deg, node at (%.4f, %.4f, %.4f)\n", angleBefore, minAngle(topology.mesh()),
              rest[pushed].x, rest[pushed].y, rest[pushed].z);
  EXPECT_NE(rest[pushed].z, 1.15);
  EXPECT_NEAR(rest[pushed].x, 1.98, 1e-12);
  EXPECT_GT(minAngle(topology.mesh()), angleBefore + 1.0);
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-12 * volume);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();

  CutTopology twoPlanes(before);
  plane[pushed] = {std::nan(""), 0, 0};
  const Smoothed stays = smooth(twoPlanes, onCut, 15.0, plane);
  for (const MovedNode& m : stays.moved) EXPECT_NE(m.index, pushed);
  EXPECT_EQ(twoPlanes.mesh().restPositions[pushed].z, 1.15);
}

// A node of the block's face z = 0 (flat: every boundary face around it lies in that plane)
// pushed within the face towards a neighbour, which flattens the tets of its star. Interior
// smoothing cannot reach it; sliding within the face can, and keeps the face (the node stays on
// z = 0 to rounding, every other node where it was) and the volume.
mesh::TetMesh pushedFaceNode(std::uint32_t& pushed, mesh::Double3 at) {
  mesh::TetMesh m = test::cubeMesh(4);
  for (std::uint32_t i = 0; i < m.nodeCount(); ++i)
    if (m.restPositions[i].x == 2 && m.restPositions[i].y == 2 && m.restPositions[i].z == 0) pushed = i;
  m.restPositions[pushed] = m.positions[pushed] = at;
  return m;
}

// Every node that was on a face of the n^3 block is still on it (to rounding).
void expectOnTheBlocksFaces(const std::vector<mesh::Double3>& before, const std::vector<mesh::Double3>& after,
                            double n = 4) {
  for (std::uint32_t v = 0; v < before.size(); ++v)
    for (int axis = 0; axis < 3; ++axis) {
      const double p = axis == 0 ? before[v].x : axis == 1 ? before[v].y : before[v].z;
      const double q = axis == 0 ? after[v].x : axis == 1 ? after[v].y : after[v].z;
      if (p == 0 || p == n) {
        EXPECT_NEAR(q, p, 1e-12) << "node " << v << ", axis " << axis;
      }
    }
}

void expectSlidesWithinTheFace(const std::vector<double>& onCut) {
  std::uint32_t pushed = 0;
  const mesh::TetMesh before = pushedFaceNode(pushed, {1.12, 1.97, 0});
  const double angleBefore = minAngle(before);
  ASSERT_LT(angleBefore, 15.0);
  CutTopology topology(before);
  ASSERT_TRUE(topology.selfCheck().ok());  // still positive
  const double volume = topology.totalRestVolume();
  const Smoothed run = smooth(topology, onCut);
  ASSERT_FALSE(run.moved.empty());
  const double angleAfter = minAngle(topology.mesh());
  std::printf("min dihedral %.2f -> %.2f deg, %zu moves\n", angleBefore, angleAfter, run.moved.size());
  EXPECT_GT(angleAfter, angleBefore + 1.0);
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-12 * volume);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  const auto& rest = topology.mesh().restPositions;
  EXPECT_NE(rest[pushed].x, 1.12);
  EXPECT_LE(std::fabs(rest[pushed].z), 1e-12);
  // Whatever else moved stayed on its face of the block: the box is unchanged.
  expectOnTheBlocksFaces(before.restPositions, rest);
}

TEST(NodeSmoothing, ABoundaryNodeSlidesWithinItsFlatFace) {
  expectSlidesWithinTheFace(std::vector<double>(test::cubeMesh(4).nodeCount(), 0.0));
}

// The same node marked as lying on a cut surface: an open crack is a flat boundary like the
// face, so the node slides within it (the crack's faces keep their plane).
TEST(NodeSmoothing, ANodeOnAFlatCrackSlidesWithinIt) {
  std::uint32_t pushed = 0;
  const mesh::TetMesh m = pushedFaceNode(pushed, {1.12, 1.97, 0});
  std::vector<double> onCut(m.nodeCount(), 0.0);
  onCut[pushed] = 1e-3;
  expectSlidesWithinTheFace(onCut);
}

// A real open crack: a half stroke along the node plane x = 2 of the block opens a planar crack
// (its nodes duplicated, one copy per side). One copy of the crack node (2, 1, 2) is pushed within
// the crack plane, which flattens tets on its side; it slides back within the plane (the crack's
// faces keep their plane), the other copy stays, the block stays one part with its volume.
TEST(NodeSmoothing, ANodeOfAnOpenPlanarCrackSlidesWithinIt) {
  CutOptions options;
  options.improveBelowDeg = 0;
  options.smoothBelowDeg = 0;
  Cutter cutter(test::cubeMesh(4), options);
  const CutResult cut = cutter.cut(sweptTriangles({0, {2, -0.5, -0.5}, {2, -0.5, 4.5}}, {1, {2, 2.5, -0.5}, {2, 2.5, 4.5}}));
  ASSERT_GT(cut.duplicatedNodes, 0u);
  CutTopology& topology = cutter.topology();
  ASSERT_EQ(disjointParts(topology).size(), 1u);
  std::vector<std::uint32_t> copies;
  for (std::uint32_t v = 0; v < topology.mesh().nodeCount(); ++v)
    if (topology.mesh().restPositions[v] == mesh::Double3{2, 1, 2}) copies.push_back(v);
  ASSERT_EQ(copies.size(), 2u);
  const std::uint32_t pushed = copies[1];
  const mesh::Double3 at{2, 1.9, 2};
  topology.moveNode(pushed, at, at);
  ASSERT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();  // still positive
  const double angleBefore = minAngle(topology.toTetMesh());
  ASSERT_LT(angleBefore, 15.0);
  const double volume = topology.totalRestVolume();
  // The crack's nodes, as the cutter marks them (its snap reach: on a cut surface).
  std::vector<double> onCut(topology.mesh().nodeCount(), 0.0);
  for (std::uint32_t v = 0; v < onCut.size(); ++v)
    if (topology.mesh().restPositions[v].x == 2) onCut[v] = 1e-9;
  const Smoothed run = smooth(topology, onCut);
  ASSERT_FALSE(run.moved.empty());
  const double angleAfter = minAngle(topology.toTetMesh());
  std::printf("min dihedral %.2f -> %.2f deg, %zu moves\n", angleBefore, angleAfter, run.moved.size());
  EXPECT_GT(angleAfter, angleBefore + 1.0);
  const auto& rest = topology.mesh().restPositions;
  EXPECT_NE(rest[pushed].y, at.y);
  EXPECT_NEAR(rest[pushed].x, 2.0, 1e-12);
  EXPECT_EQ(rest[copies[0]], (mesh::Double3{2, 1, 2}));
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-12 * volume);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  EXPECT_EQ(disjointParts(topology).size(), 1u);
}

// A node on an edge of the block (its boundary faces in the two planes y = 0 and z = 0) pushed
// along the edge: a node of the edge slides along the line of both planes (y and z stay 0 to
// rounding), so both faces and the volume are kept.
TEST(NodeSmoothing, ANodeOnABoundaryCreaseSlidesAlongIt) {
  mesh::TetMesh m = test::cubeMesh(4);
  std::uint32_t pushed = 0;
  for (std::uint32_t i = 0; i < m.nodeCount(); ++i)
    if (m.restPositions[i].x == 2 && m.restPositions[i].y == 0 && m.restPositions[i].z == 0) pushed = i;
  m.restPositions[pushed] = m.positions[pushed] = {1.12, 0, 0};
  const double angleBefore = minAngle(m);
  ASSERT_LT(angleBefore, 15.0);
  CutTopology topology(m);
  ASSERT_TRUE(topology.selfCheck().ok());
  const double volume = topology.totalRestVolume();
  const Smoothed run = smooth(topology, std::vector<double>(m.nodeCount(), 0.0));
  ASSERT_FALSE(run.moved.empty());
  const double angleAfter = minAngle(topology.mesh());
  std::printf("min dihedral %.2f -> %.2f deg, %zu moves\n", angleBefore, angleAfter, run.moved.size());
  EXPECT_GT(angleAfter, angleBefore + 1.0);
  // A node of the edge moved (the pushed one or its neighbour on the edge), along the edge.
  const auto& rest = topology.mesh().restPositions;
  bool alongTheEdge = false;
  for (const MovedNode& mv : run.moved) {
    const mesh::Double3 p = m.restPositions[mv.index];
    if (p.y != 0 || p.z != 0) continue;
    alongTheEdge = true;
    EXPECT_NE(rest[mv.index].x, p.x);
    EXPECT_LE(std::fabs(rest[mv.index].y), 1e-12);
    EXPECT_LE(std::fabs(rest[mv.index].z), 1e-12);
  }
  EXPECT_TRUE(alongTheEdge);
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-12 * volume);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
  expectOnTheBlocksFaces(m.restPositions, rest);
}

// A corner of the block (three planes) never moves, whatever its tets: here every tet is below
// the threshold, so every node is tried.
TEST(NodeSmoothing, ACornerOfTheBlockStays) {
  const mesh::TetMesh m = test::cubeMesh(2);
  CutTopology topology(m);
  smooth(topology, std::vector<double>(m.nodeCount(), 0.0), 90.0);
  for (std::uint32_t v = 0; v < m.nodeCount(); ++v) {
    const mesh::Double3 p = m.restPositions[v];
    const bool corner = (p.x == 0 || p.x == 2) && (p.y == 0 || p.y == 2) && (p.z == 0 || p.z == 2);
    if (corner) {
      EXPECT_EQ(topology.mesh().restPositions[v], p) << "node " << v;
    }
  }
  expectOnTheBlocksFaces(m.restPositions, topology.mesh().restPositions, 2);
  EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
}

// A spike: a flat tet (height 0.05) on an equilateral face of a body tet, its apex in no other
// tet, all three faces through it on the boundary, the apex's foot near a base corner (a bad
// angle at a base edge). With all its nodes on cut surfaces (a piece between crack sheets) the
// apex slides parallel to the base: its height, so the spike's and the body's volume, is kept,
// and the foot goes to the incentre, where the smallest angle is the largest a foot in the plane
// allows, atan(height / inradius) at every base edge. With a base node on the body's own surface
// (not on a cut), or the apex not on a cut, it stays.
TEST(NodeSmoothing, ASpikeApexOnACutSlidesParallelToItsBase) {
  const double h = 0.05, root3 = std::sqrt(3.0);
  mesh::TetMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, root3 / 2, 0}, {0.5, root3 / 6, -0.8}, {0.1, 0.05, h}};
  m.restPositions = m.positions;
  m.tets = {{0, 2, 1, 3}, {0, 1, 2, 4}};  // the body below the base, the spike above
  const std::uint32_t apex = 4;
  auto spikeAngle = [](const std::vector<mesh::Double3>& r, const Tet& t) {
    return tetQuality(r[t[0]], r[t[1]], r[t[2]], r[t[3]]).minDihedralDeg;
  };
  const double spikeBefore = spikeAngle(m.restPositions, m.tets[1]);
  ASSERT_LT(spikeBefore, 5.0);
  // Nodes on a cut: none, the apex alone, the apex and two base nodes, the whole spike.
  const std::array<std::vector<std::uint32_t>, 4> cases{{{}, {apex}, {1, 2, apex}, {0, 1, 2, apex}}};
  for (const auto& cutNodes : cases) {
    const bool onCutSurface = cutNodes.size() == 4;
    CutTopology topology(m);
    ASSERT_TRUE(topology.selfCheck().ok());
    const double volume = topology.totalRestVolume();
    std::vector<double> onCut(m.nodeCount(), 0.0);
    for (std::uint32_t v : cutNodes) onCut[v] = 1e-3;
    const Smoothed run = smooth(topology, onCut);
    const mesh::Double3 to = topology.mesh().restPositions[apex];
    if (!onCutSurface) {
      EXPECT_TRUE(run.moved.empty()) << cutNodes.size() << " nodes on a cut";
      EXPECT_EQ(to.x, 0.1);
      continue;
    }
    ASSERT_EQ(run.moved.size(), 1u);
    EXPECT_EQ(run.moved[0].index, apex);
    EXPECT_NEAR(to.z, h, 1e-15);
    EXPECT_NEAR(to.x, 0.5, 1e-12);  // the incentre of the equilateral base
    EXPECT_NEAR(to.y, root3 / 6, 1e-12);
    EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-15 * volume);
    EXPECT_TRUE(topology.selfCheck().ok()) << topology.selfCheck().summary();
    const double spikeAfter = spikeAngle(topology.mesh().restPositions, topology.tet(1));
    const double expected = std::atan(h / (1.0 / (2.0 * root3))) * 180.0 / 3.14159265358979323846;
    std::printf("spike: smallest dihedral %.2f -> %.2f deg (atan(h / r) = %.2f deg)\n", spikeBefore, spikeAfter,
                expected);
    EXPECT_NEAR(spikeAfter, expected, 1e-9);
    // The move's weights (over the spike's nodes) give the new place from the old ones.
    mesh::Double3 sum{0, 0, 0};
    for (std::size_t i = 0; i < 4; ++i) sum = sum + m.restPositions[run.moved[0].sources[i]] * run.moved[0].weights[i];
    EXPECT_NEAR(length(sum - to), 0.0, 1e-15);
  }
}

// The same spike at height 0.15 (11.2 deg): over the incentre it would reach 27.5 deg, but the
// apex stops at the first of its shorter steps that reaches the 15 deg asked for, so the surface
// moves less than the full slide.
TEST(NodeSmoothing, ASpikeApexStopsWhereItsTetReachesTheThreshold) {
  const double h = 0.15, root3 = std::sqrt(3.0);
  mesh::TetMesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0.5, root3 / 2, 0}, {0.5, root3 / 6, -0.8}, {0.1, 0.05, h}};
  m.restPositions = m.positions;
  m.tets = {{0, 2, 1, 3}, {0, 1, 2, 4}};
  const std::uint32_t apex = 4;
  const auto& r0 = m.restPositions;
  ASSERT_LT(tetQuality(r0[0], r0[1], r0[2], r0[4]).minDihedralDeg, 15.0);
  CutTopology topology(m);
  const double volume = topology.totalRestVolume();
  std::vector<double> onCut(m.nodeCount(), 1e-3);
  onCut[3] = 0;  // the body's own apex
  const Smoothed run = smooth(topology, onCut);
  ASSERT_EQ(run.moved.size(), 1u);
  const auto& r = topology.mesh().restPositions;
  const mesh::Double3 incentre{0.5, root3 / 6, h};
  EXPECT_NEAR(r[apex].z, h, 1e-15);
  EXPECT_LT(length(r[apex] - r0[apex]), 0.9 * length(incentre - r0[apex]));
  EXPECT_GE(tetQuality(r[0], r[1], r[2], r[apex]).minDihedralDeg, 15.0);
  EXPECT_NEAR(topology.totalRestVolume(), volume, 1e-15 * volume);
}

}  // namespace
}  // namespace blobvk::cutting
