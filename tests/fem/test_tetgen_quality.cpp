// The sliver pass after TetGen (fem/tetgen_slivers.h) and the minimum dihedral angle that
// tetrahedralize() delivers with it: slivers are raised above the bound while the mesh stays
// valid, keeps its volume, and keeps its surface (input vertices and boundary planes).
#include "blobvk/fem/tet_utils.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/fem/tetgen_slivers.h"
#include "blobvk/mesh/checks.h"
#include "icosphere.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace blobvk::fem {
namespace {

using mesh::Double3;
using testing::icosphere;  // icosphere.h

// Judged with the test's own dihedral (test_helpers.h), not with the pass's minDihedralDegrees.
double meshMinDihedral(const mesh::TetMesh& m) { return test::minDihedralDegrees(m.restPositions, m.tets); }

bool allPositive(const mesh::TetMesh& m) {
  return std::all_of(m.tets.begin(), m.tets.end(), [&](const auto& t) { return tetVolume(m.restPositions, t) > 0; });
}

// Index of the box-mesh node at (i, j, k) cells (nodes are the grid points, x fastest).
std::uint32_t nodeNear(const mesh::TetMesh& m, const Double3& p) {
  std::uint32_t best = 0;
  double bestDistance = 1e30;
  for (std::uint32_t v = 0; v < m.nodeCount(); ++v) {
    const Double3& q = m.restPositions[v];
    const double d = (q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) + (q.z - p.z) * (q.z - p.z);
    if (d < bestDistance) bestDistance = d, best = v;
  }
  return best;
}

void moveNode(mesh::TetMesh& m, std::uint32_t v, const Double3& to) {
  m.restPositions[v] = to;
  m.positions[v] = to;
}

TEST(SliverPass, DihedralOfARegularAndAFlatTet) {
  const std::vector<Double3> p = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}, {0, 0, 1e-9}};
  EXPECT_NEAR(minDihedralDegrees(p, {0, 1, 2, 3}), std::acos(1.0 / 3.0) * 180 / M_PI, 1e-9);
  // The right-corner tet: 90 degrees at the three axis edges, acos(1/sqrt(3)) at the others.
  EXPECT_NEAR(minDihedralDegrees({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {0, 1, 2, 3}),
              std::acos(1.0 / std::sqrt(3.0)) * 180 / M_PI, 1e-9);
  EXPECT_LT(minDihedralDegrees({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.3, 0.3, 1e-4}}, {0, 1, 2, 3}), 0.1);
}

TEST(SliverPass, RaisesSliversAroundAnInteriorNodeAndKeepsTheMesh) {
  mesh::TetMesh m = test::boxMesh(0.3, 0.3, 0.3, 0.1);
  const mesh::TetMesh original = m;
  const std::uint32_t v = nodeNear(m, {0.1, 0.1, 0.1});  // interior
  moveNode(m, v, {0.1 - 0.09, 0.1 - 0.08, 0.1 + 0.09});  // near a face of its star: 5.6 degrees
  ASSERT_TRUE(allPositive(m));
  ASSERT_LT(meshMinDihedral(m), 10.0);  // the precondition: the move made slivers

  const SliverStats stats = smoothSlivers(m, 10.0, 0);
  EXPECT_GT(stats.tetsBelowBefore, 0u);
  EXPECT_EQ(stats.tetsBelowAfter, 0u);
  EXPECT_GE(meshMinDihedral(m), 10.0 - 1e-9);
  EXPECT_NEAR(stats.minDihedralAfterDegrees, meshMinDihedral(m), 1e-9);
  EXPECT_TRUE(allPositive(m));
  EXPECT_NEAR(totalVolume(m, true), 0.027, 1e-12);
  EXPECT_EQ(m.positions, m.restPositions);
  // The surface stays: corner and edge nodes of the box do not move, face nodes stay in their
  // face's plane (they may slide in it), only interior nodes move freely.
  for (std::uint32_t w = 0; w < m.nodeCount(); ++w) {
    const Double3& q = original.restPositions[w];
    const Double3& now = m.restPositions[w];
    const double before[3] = {q.x, q.y, q.z}, after[3] = {now.x, now.y, now.z};
    int onBoundary = 0;
    for (int a = 0; a < 3; ++a) {
      if (before[a] > 1e-9 && before[a] < 0.3 - 1e-9) continue;
      ++onBoundary;
      EXPECT_NEAR(after[a], before[a], 1e-15) << "node " << w << " left the boundary plane";
    }
    if (onBoundary >= 2) {
      EXPECT_EQ(now, q) << "corner or edge node " << w << " moved";
    }
  }
  EXPECT_EQ(m.tets, original.tets);
}

TEST(SliverPass, SlidesABoundaryNodeInItsFacetPlaneOnly) {
  mesh::TetMesh m = test::boxMesh(0.3, 0.3, 0.3, 0.1);
  const std::uint32_t v = nodeNear(m, {0.1, 0.1, 0});  // inside the z = 0 face
  moveNode(m, v, {0.1 - 0.09, 0.1 + 0.02, 0});  // 5.7 degrees
  ASSERT_TRUE(allPositive(m));
  ASSERT_LT(meshMinDihedral(m), 10.0);

  const SliverStats stats = smoothSlivers(m, 10.0, 0);
  EXPECT_EQ(stats.tetsBelowAfter, 0u);
  EXPECT_GE(stats.nodesMoved, 1u);
  EXPECT_TRUE(allPositive(m));
  EXPECT_NEAR(m.restPositions[v].z, 0.0, 1e-15);  // still on the boundary plane
  EXPECT_NEAR(totalVolume(m, true), 0.027, 1e-12);
}

TEST(SliverPass, FixedNodesNeverMove) {
  mesh::TetMesh m = test::boxMesh(0.3, 0.3, 0.3, 0.1);
  const std::uint32_t v = nodeNear(m, {0.1, 0.1, 0.1});
  moveNode(m, v, {0.1 - 0.09, 0.1 - 0.08, 0.1 + 0.09});
  ASSERT_LT(meshMinDihedral(m), 10.0);
  const mesh::TetMesh before = m;
  const SliverStats stats = smoothSlivers(m, 10.0, m.nodeCount());  // every node is an input node
  EXPECT_EQ(stats.nodesMoved, 0u);
  EXPECT_EQ(stats.tetsBelowAfter, stats.tetsBelowBefore);
  EXPECT_EQ(m.restPositions, before.restPositions);
}


// TetGen's -q/10 alone leaves slivers here (checked: the test needs them); the pass after it
// brings every tet to >= 10 degrees without touching the input surface.
TEST(TetgenQuality, MinimumDihedralIsMetAfterTheSliverPass) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  const mesh::TriMesh sphere = icosphere(2);
  TetgenOptions o;
  o.maxVolume = 3.0 * mesh::checkMesh(sphere).volume / 20000;
  o.smoothSlivers = false;
  const mesh::TetMesh raw = tetrahedralize(sphere, o);
  o.smoothSlivers = true;
  SliverStats stats;
  const mesh::TetMesh m = tetrahedralize(sphere, o, &stats);
  ASSERT_LT(meshMinDihedral(raw), 10.0) << "TetGen alone met the bound: the test checks nothing";
  EXPECT_GT(stats.tetsBelowBefore, 0u);
  EXPECT_EQ(stats.tetsBelowAfter, 0u);
  EXPECT_GE(meshMinDihedral(m), 10.0 - 1e-9);
  EXPECT_NO_THROW(validateTetMesh(m));
  EXPECT_EQ(m.tets, raw.tets);
  EXPECT_NEAR(totalVolume(m, true), totalVolume(raw, true), 1e-9);
  // And that volume is the input surface's (divergence theorem over the triangles, not the tets).
  EXPECT_NEAR(totalVolume(m, true), mesh::checkMesh(sphere).volume, 1e-9);
  for (std::size_t i = 0; i < sphere.positions.size(); ++i) EXPECT_EQ(m.restPositions[i], raw.restPositions[i]);
}

}  // namespace
}  // namespace blobvk::fem
