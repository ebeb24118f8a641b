#include "blobvk/cutting/predicates.h"

#include <gtest/gtest.h>

#include <random>

namespace blobvk::cutting {
namespace {

TEST(Predicates, OrientationSignOfSimpleConfigurations) {
  const Double3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_EQ(orient3dSign(a, b, c, {0, 0, -1}), 1);   // below the counter-clockwise triangle
  EXPECT_EQ(orient3dSign(a, b, c, {0, 0, 1}), -1);
  EXPECT_EQ(orient3dSign(a, b, c, {0.25, 0.5, 0}), 0);  // exactly coplanar
}

TEST(Predicates, CoplanarPointsOnATiltedPlaneAreNeverMisclassifiedAsOpposite) {
  // Points exactly on the plane x + y + z = 1 with dyadic coordinates: the sign must be 0.
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> k(-64, 64);
  for (int i = 0; i < 1000; ++i) {
    auto on = [&] {
      const double x = k(rng) / 64.0, y = k(rng) / 64.0;
      return Double3{x, y, 1.0 - x - y};
    };
    EXPECT_EQ(orient3dSign(on(), on(), on(), on()), 0);
  }
}

TEST(Predicates, TinyOffsetsKeepTheirSign) {
  const Double3 a{0, 0, 0}, b{1e3, 0, 0}, c{0, 1e3, 0};
  EXPECT_EQ(orient3dSign(a, b, c, {1, 1, -1e-12}), 1);
  EXPECT_EQ(orient3dSign(a, b, c, {1, 1, 1e-12}), -1);
}

TEST(Predicates, SegmentTriangleCrossing) {
  const Double3 a{0, 0, 0}, b{2, 0, 0}, c{0, 2, 0};
  auto hit = segmentCrossesTriangle({0.5, 0.5, -1}, {0.5, 0.5, 3}, a, b, c);
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(hit.t, 0.25, 1e-15);
  EXPECT_FALSE(segmentCrossesTriangle({3, 3, -1}, {3, 3, 1}, a, b, c).hit);     // misses
  EXPECT_FALSE(segmentCrossesTriangle({0.5, 0.5, 0}, {0.5, 0.5, 1}, a, b, c).hit);  // touches: a cut node
  EXPECT_FALSE(segmentCrossesTriangle({0.5, 0.5, 1}, {0.5, 0.5, 2}, a, b, c).hit);  // same side
  EXPECT_TRUE(segmentCrossesTriangle({1, 1, -1}, {1, 1, 1}, a, b, c).hit);      // on the hypotenuse: closed
}

TEST(Predicates, ClosestPointOnTriangleRegions) {
  const Double3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
  EXPECT_EQ(closestPointOnTriangle({-1, -1, 5}, a, b, c), a);
  const Double3 inside = closestPointOnTriangle({0.2, 0.3, 5}, a, b, c);
  EXPECT_NEAR(length(inside - Double3{0.2, 0.3, 0}), 0.0, 1e-15);
  const Double3 onEdge = closestPointOnTriangle({1, 1, 0}, a, b, c);
  EXPECT_NEAR(onEdge.x, 0.5, 1e-15);
  EXPECT_NEAR(onEdge.y, 0.5, 1e-15);
}

}  // namespace
}  // namespace blobvk::cutting
