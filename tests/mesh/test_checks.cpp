#include "cube_mesh.h"

#include "blobvk/mesh/checks.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace blobvk {
namespace {

TEST(CheckMesh, UnitCubeIsClosedWithEulerTwoAndVolumeOne) {
  const mesh::MeshReport r = mesh::checkMesh(testing::unitCube());
  EXPECT_TRUE(r.watertight()) << r.summary();
  EXPECT_EQ(r.vertices, 8u);
  EXPECT_EQ(r.triangles, 12u);
  EXPECT_EQ(r.edges, 18u);
  EXPECT_EQ(r.eulerCharacteristic, 2);
  EXPECT_EQ(r.components, 1u);
  EXPECT_NEAR(r.volume, 1.0, 1e-12);
  EXPECT_NEAR(r.area, 6.0, 1e-12);
}

TEST(CheckMesh, InvertedCubeHasNegativeVolume) {
  mesh::TriMesh m = testing::unitCube(5.0f);  // away from the origin: the sign must not depend on it
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_TRUE(r.watertight());
  EXPECT_NEAR(r.volume, -1.0, 1e-9);
}

TEST(CheckMesh, MissingFaceLeavesFourBoundaryEdges) {
  mesh::TriMesh m = testing::unitCube();
  m.triangles.resize(10);  // drop the x = 1 face
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_EQ(r.boundaryEdges, 4u);
  EXPECT_FALSE(r.closed());
  EXPECT_TRUE(r.manifold());
  EXPECT_TRUE(r.oriented());
  EXPECT_EQ(r.eulerCharacteristic, 1);  // a disc
}

TEST(CheckMesh, FlippedTriangleIsMisorientedOnAllItsEdges) {
  mesh::TriMesh m = testing::unitCube();
  std::swap(m.triangles[3][1], m.triangles[3][2]);
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_EQ(r.misorientedEdges, 3u);
  EXPECT_TRUE(r.closed());
  EXPECT_FALSE(r.watertight());
}

TEST(CheckMesh, FinMakesANonManifoldEdge) {
  mesh::TriMesh m = testing::unitCube();
  m.positions.push_back({0.5f, -1.0f, -1.0f});
  m.triangles.push_back({0, 1, 8});  // shares the cube edge 0-1
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_EQ(r.nonManifoldEdges, 1u);
  EXPECT_EQ(r.boundaryEdges, 2u);
  EXPECT_FALSE(r.manifold());
  EXPECT_EQ(r.components, 1u);
}

TEST(CheckMesh, TwoCubesAreTwoComponents) {
  mesh::TriMesh a = testing::unitCube(), b = testing::unitCube(3.0f);
  for (auto t : b.triangles) a.triangles.push_back({t[0] + 8, t[1] + 8, t[2] + 8});
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  const mesh::MeshReport r = mesh::checkMesh(a);
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.eulerCharacteristic, 4);
  EXPECT_NEAR(r.volume, 2.0, 1e-9);
}

TEST(CheckMesh, CountsDegenerateTrianglesAndUnreferencedVertices) {
  mesh::TriMesh m = testing::unitCube();
  m.positions.push_back({9, 9, 9});
  m.triangles.push_back({0, 0, 1});
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_EQ(r.degenerateTriangles, 1u);
  EXPECT_EQ(r.unreferencedVertices, 1u);
  EXPECT_TRUE(r.closed());  // the degenerate triangle is kept out of the edge analysis
  EXPECT_FALSE(r.watertight());
}

TEST(CheckMesh, OutOfRangeIndexThrows) {
  mesh::TriMesh m = testing::unitCube();
  m.triangles.push_back({0, 1, 99});
  EXPECT_THROW(mesh::checkMesh(m), std::out_of_range);
}

TEST(CheckMesh, EmptyMeshIsTriviallyClosed) {
  const mesh::MeshReport r = mesh::checkMesh({});
  EXPECT_EQ(r.triangles, 0u);
  EXPECT_EQ(r.components, 0u);
  EXPECT_EQ(r.volume, 0.0);
}

TEST(CheckMesh, SummaryIsOneLine) {
  const std::string s = mesh::checkMesh(testing::unitCube()).summary();
  EXPECT_EQ(s.find('\n'), std::string::npos);
  EXPECT_NE(s.find("watertight"), std::string::npos);
  EXPECT_NE(s.find("12 triangles"), std::string::npos);
}

}  // namespace
}  // namespace blobvk
