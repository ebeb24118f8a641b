// The remesher's triangle crossing tests and its face grid (mesh/surface_remesh_intersections.h).
#include "cube_mesh.h"

#include "blobvk/mesh/surface_remesh_intersections.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace blobvk::mesh::remesh {
namespace {

const Triangle kFloor = {Vec3{0, 0, 0}, Vec3{1, 0, 0}, Vec3{0, 1, 0}};

TEST(RemeshIntersections, CrossingSeparatedAndTouchingTriangles) {
  // A triangle standing through the floor, one hovering above it, one lying beside it.
  EXPECT_TRUE(trianglesIntersect(kFloor, {Vec3{0.2, 0.2, -0.5}, Vec3{0.3, 0.2, 0.5}, Vec3{0.2, 0.3, 0.5}}));
  EXPECT_FALSE(trianglesIntersect(kFloor, {Vec3{0.2, 0.2, 0.1}, Vec3{0.3, 0.2, 0.5}, Vec3{0.2, 0.3, 0.5}}));
  EXPECT_FALSE(trianglesIntersect(kFloor, {Vec3{2, 0, -1}, Vec3{3, 0, 1}, Vec3{2, 1, 1}}));
  // A corner resting on the floor counts: the remesher keeps surfaces apart, not just uncrossed.
  EXPECT_TRUE(trianglesIntersect(kFloor, {Vec3{0.2, 0.2, 0}, Vec3{0.3, 0.2, 0.5}, Vec3{0.2, 0.3, 0.5}}));
  // A triangle crossing the floor's interior with its edge passing under a floor edge.
  EXPECT_TRUE(trianglesIntersect(kFloor, {Vec3{-0.5, 0.25, -0.1}, Vec3{1.5, 0.25, -0.1}, Vec3{0.25, 0.25, 1}}));
}

TEST(RemeshIntersections, TrianglesWithACommonCorner) {
  // Both through the origin (corner 0 of the floor): folded back through the floor, or apart.
  const Triangle through = {Vec3{0, 0, 0}, Vec3{0.5, 0.4, -0.3}, Vec3{0.4, 0.5, 0.3}};
  const Triangle above = {Vec3{0, 0, 0}, Vec3{0.5, 0.4, 0.3}, Vec3{0.4, 0.5, 0.6}};
  EXPECT_TRUE(trianglesMeetBeyondCorner(kFloor, 0, through, 0));
  EXPECT_FALSE(trianglesMeetBeyondCorner(kFloor, 0, above, 0));
  EXPECT_TRUE(trianglesMeetBeyondCorner(through, 0, kFloor, 0));
}

TEST(RemeshIntersections, GridFindsACrossingFaceAndIgnoresNeighbours) {
  const EditableMesh cube(testing::unitCube());
  FaceGrid grid(0.25);
  grid.rebuild(cube);
  // The cube's own faces cross nothing (neighbours share vertices).
  for (std::uint32_t f = 0; f < cube.faceSlots(); ++f) {
    const Face& t = cube.face(f);
    const std::uint32_t self[1] = {f};
    EXPECT_EQ(grid.crossedFace(cube, t, {cube.positions[t[0]], cube.positions[t[1]], cube.positions[t[2]]}, self), kNone) << f;
  }
  // A new triangle piercing the cube's x = max face is reported; ignoring that face's triangles
  // (as an edit that replaces them does) hides it.
  double maxX = -1e30;
  for (const Vec3& p : cube.positions) maxX = std::max(maxX, p.x);
  Vec3 mid;
  for (const Vec3& p : cube.positions) mid = mid + p * (1.0 / double(cube.positions.size()));
  const Triangle pierce = {Vec3{mid.x, mid.y, mid.z}, Vec3{maxX + 1, mid.y + 0.01, mid.z}, Vec3{maxX + 1, mid.y, mid.z + 0.01}};
  const Face fresh = {kNone - 1, kNone - 2, kNone - 3};  // shares no vertex with the cube
  const std::uint32_t hit = grid.crossedFace(cube, fresh, pierce, {});
  ASSERT_NE(hit, kNone);
  for (std::uint32_t v : cube.face(hit)) EXPECT_NEAR(cube.positions[v].x, maxX, 1e-12);
  std::vector<std::uint32_t> sideFaces;
  for (std::uint32_t f = 0; f < cube.faceSlots(); ++f) {
    bool onSide = true;
    for (std::uint32_t v : cube.face(f)) onSide = onSide && std::abs(cube.positions[v].x - maxX) < 1e-12;
    if (onSide) sideFaces.push_back(f);
  }
  EXPECT_EQ(grid.crossedFace(cube, fresh, pierce, sideFaces), kNone);
}

}  // namespace
}  // namespace blobvk::mesh::remesh
