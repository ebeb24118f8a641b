#include "cube_mesh.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/unreferenced.h"

#include <gtest/gtest.h>

#include <array>
#include <stdexcept>
#include <vector>

namespace blobvk {
namespace {

using Corners = std::vector<std::array<mesh::Float3, 3>>;

// Each triangle by the positions of its corners: what dropping vertices must not change.
Corners cornersOf(const mesh::TriMesh& m) {
  Corners c;
  for (const auto& t : m.triangles) c.push_back({m.positions[t[0]], m.positions[t[1]], m.positions[t[2]]});
  return c;
}

// The unit cube's 8 corners interleaved with 5 points no triangle uses (as the interior nodes
// of a tet mesh), each vertex with a normal, colour and edge key of its own.
mesh::TriMesh cubeWithLooseVertices() {
  const mesh::TriMesh cube = testing::unitCube();
  mesh::TriMesh m;
  std::vector<std::uint32_t> at(8);
  const std::vector<bool> loose = {true, false, false, true, false, true, false, false, false, true, false, true, false};
  std::uint32_t corner = 0;
  for (std::size_t i = 0; i < loose.size(); ++i) {
    const float f = float(i);
    m.positions.push_back(loose[i] ? mesh::Float3{0.5f, 0.5f, f} : cube.positions[corner]);
    m.normals.push_back({f, 0, 0});
    m.colours.push_back({0, f, 0});
    m.edgeKeys.push_back(100 + i);
    if (!loose[i]) at[corner++] = std::uint32_t(i);
  }
  for (const auto& t : cube.triangles) m.triangles.push_back({at[t[0]], at[t[1]], at[t[2]]});
  return m;
}

TEST(DropUnreferencedVertices, KeepsEveryTriangleAndTheOrderOfTheUsedVertices) {
  mesh::TriMesh m = cubeWithLooseVertices();
  const Corners before = cornersOf(m);
  ASSERT_EQ(mesh::checkMesh(m).unreferencedVertices, 5u);
  EXPECT_EQ(mesh::dropUnreferencedVertices(m), 5u);
  EXPECT_EQ(cornersOf(m), before);
  const mesh::MeshReport r = mesh::checkMesh(m);
  EXPECT_EQ(r.unreferencedVertices, 0u);
  EXPECT_TRUE(r.watertight()) << r.summary();
  EXPECT_NEAR(r.volume, 1.0, 1e-12);
  // The attributes travel with their vertex: the kept ones were 1, 2, 4, 6, 7, 8, 10, 12.
  const std::vector<std::uint64_t> keys = {101, 102, 104, 106, 107, 108, 110, 112};
  ASSERT_EQ(m.edgeKeys.size(), keys.size());
  for (std::size_t i = 0; i < keys.size(); ++i) {
    EXPECT_EQ(m.edgeKeys[i], keys[i]);
    EXPECT_EQ(m.normals[i].x, float(keys[i] - 100));
    EXPECT_EQ(m.colours[i].y, float(keys[i] - 100));
  }
  EXPECT_EQ(mesh::dropUnreferencedVertices(m), 0u);  // nothing left to drop
  EXPECT_EQ(cornersOf(m), before);
}

TEST(DropUnreferencedVertices, LeavesAMeshWithoutLooseVerticesUnchanged) {
  mesh::TriMesh m = testing::unitCube();
  const mesh::TriMesh before = m;
  EXPECT_EQ(mesh::dropUnreferencedVertices(m), 0u);
  EXPECT_EQ(m, before);
  mesh::TriMesh points;  // no triangle: every vertex goes
  points.positions.resize(3, {});
  EXPECT_EQ(mesh::dropUnreferencedVertices(points), 3u);
  EXPECT_EQ(points.vertexCount(), 0u);
}

TEST(DropUnreferencedVertices, RefusesAnIndexPastTheLastVertex) {
  mesh::TriMesh m = testing::unitCube();
  m.triangles.push_back({0, 1, 8});
  const mesh::TriMesh before = m;
  EXPECT_THROW(mesh::dropUnreferencedVertices(m), std::out_of_range);
  EXPECT_EQ(m, before);
}

}  // namespace
}  // namespace blobvk
