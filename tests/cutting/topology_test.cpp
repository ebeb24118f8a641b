#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/topology.h"
#include "blobvk/cutting/vec.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

namespace blobvk::cutting {
namespace {

TEST(Topology, CubeMeshIsValidWithExpectedCounts) {
  const int n = 3;
  CutTopology topo(test::cubeMesh(n));
  const SelfCheckReport r = topo.selfCheck();
  EXPECT_TRUE(r.ok()) << r.summary();
  EXPECT_EQ(r.tets, std::size_t(6 * n * n * n));
  // Each of the 6 cube sides: n*n squares, 2 triangles each.
  EXPECT_EQ(r.boundaryFaces, std::size_t(6 * n * n * 2));
  EXPECT_NEAR(topo.totalRestVolume(), n * n * n, 1e-12);
  EXPECT_TRUE(topo.hasEdge(0, 1));
  EXPECT_FALSE(topo.hasEdge(0, 63));  // opposite corners of the cube
  EXPECT_EQ(disjointParts(topo).size(), 1u);
}

TEST(Topology, SelfCheckCatchesBrokenMeshes) {
  mesh::TetMesh m = test::cubeMesh(2);
  m.tets.push_back(m.tets[0]);
  EXPECT_GT(CutTopology(m).selfCheck().duplicateTets, 0u);
  EXPECT_GT(CutTopology(m).selfCheck().overSharedFaces, 0u);
  m = test::cubeMesh(2);
  std::swap(m.tets[3][0], m.tets[3][1]);
  const SelfCheckReport flipped = CutTopology(m).selfCheck();
  EXPECT_GT(flipped.nonPositiveTets, 0u);
  EXPECT_GT(flipped.misorientedFaces, 0u);
  EXPECT_FALSE(flipped.ok());
}

TEST(Topology, DeferredDeletionAndCompaction) {
  CutTopology topo(test::cubeMesh(2));
  const std::size_t before = topo.liveTetCount();
  const Tet last = topo.tet(std::uint32_t(topo.slotCount() - 1));
  topo.removeTet(0);
  topo.removeTet(5);
  EXPECT_EQ(topo.liveTetCount(), before - 2);
  EXPECT_EQ(topo.slotCount(), before);  // holes stay until compaction
  EXPECT_TRUE(topo.selfCheck().ok());
  const auto moves = topo.compact();
  EXPECT_EQ(topo.slotCount(), before - 2);
  ASSERT_EQ(moves.size(), 2u);
  EXPECT_EQ(moves[0].second, 0u);
  EXPECT_EQ(topo.tet(0), last);  // the last tet filled the first hole
  const SelfCheckReport r = topo.selfCheck();
  EXPECT_TRUE(r.ok()) << r.summary();
  EXPECT_EQ(r.tets, before - 2);
}

TEST(Topology, BoundarySurfaceOfCubeIsWatertight) {
  CutTopology topo(test::cubeMesh(3));
  const mesh::TriMesh surface = boundarySurface(topo);
  EXPECT_EQ(surface.triangleCount(), 6u * 9u * 2u);
  // Closed: the signed volume of the surface equals the cube's.
  double volume = 0;
  for (const auto& t : surface.triangles) {
    const auto& a = surface.positions[t[0]];
    const auto& b = surface.positions[t[1]];
    const auto& c = surface.positions[t[2]];
    volume += dot(Double3{a.x, a.y, a.z}, cross(Double3{b.x, b.y, b.z}, Double3{c.x, c.y, c.z})) / 6.0;
  }
  EXPECT_NEAR(volume, 27.0, 1e-9);
}

}  // namespace
}  // namespace blobvk::cutting
