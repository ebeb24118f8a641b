#include "blobvk/cutting/quality.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cmath>

namespace blobvk::cutting {
namespace {

TEST(Quality, RegularTetMatchesClosedForms) {
  // Regular tet with edge 2*sqrt(2): inradius a/sqrt(24), circumradius a*sqrt(6)/4.
  const double a = 2.0 * std::sqrt(2.0);
  const TetQuality q = tetQuality({1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1});
  EXPECT_NEAR(std::fabs(q.volume), a * a * a / (6 * std::sqrt(2.0)), 1e-12);
  EXPECT_NEAR(q.inradius, a / std::sqrt(24.0), 1e-12);
  EXPECT_NEAR(q.circumradius, a * std::sqrt(6.0) / 4.0, 1e-12);
  EXPECT_NEAR(q.radiusRatio, 1.0, 1e-12);
  EXPECT_NEAR(q.aspectRatio, 1.0, 1e-12);  // the thesis code printed 3 here (r off by 3)
  const double dihedral = std::acos(1.0 / 3.0) * 180.0 / M_PI;  // 70.53 degrees
  EXPECT_NEAR(q.minDihedralDeg, dihedral, 1e-9);
  EXPECT_NEAR(q.maxDihedralDeg, dihedral, 1e-9);
}

TEST(Quality, CornerTetAnglesAndRatios) {
  // The right-corner tet: dihedral 90 degrees at the three axis edges, acos(1/sqrt(3)) at the others.
  const TetQuality q = tetQuality({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1});
  EXPECT_NEAR(q.maxDihedralDeg, 90.0, 1e-9);
  EXPECT_NEAR(q.minDihedralDeg, std::acos(1.0 / std::sqrt(3.0)) * 180.0 / M_PI, 1e-9);
  // r = 3V / sum(A) = 0.5 / (1.5 + sqrt(3)/2); R = sqrt(3)/2.
  const double r = 0.5 / (1.5 + std::sqrt(3.0) / 2.0);
  EXPECT_NEAR(q.inradius, r, 1e-12);
  EXPECT_NEAR(q.circumradius, std::sqrt(3.0) / 2.0, 1e-12);
  EXPECT_NEAR(q.radiusRatio, 3 * r / (std::sqrt(3.0) / 2.0), 1e-12);
}

TEST(Quality, SliverIsFlagged) {
  const TetQuality q = tetQuality({0, 0, 0}, {1, 0, 0}, {0, 1, 1e-3}, {1, 1, 0});
  EXPECT_LT(q.radiusRatio, 0.01);
  EXPECT_LT(q.minDihedralDeg, 1.0);
  EXPECT_GT(q.maxDihedralDeg, 179.0);
}

TEST(Quality, MeshStatisticsAndHistogram) {
  const QualityStats s = meshQuality(test::cubeMesh(2));
  EXPECT_EQ(s.tets, 48u);
  EXPECT_NEAR(s.totalVolume, 8.0, 1e-12);
  EXPECT_NEAR(s.volumeRatio, 1.0, 1e-12);  // all six voxel tets have volume 1/6
  std::size_t angles = 0;
  for (std::size_t c : s.dihedralHistogram) angles += c;
  EXPECT_EQ(angles, 48u * 6u);
  EXPECT_FALSE(s.histogram().empty());
}

}  // namespace
}  // namespace blobvk::cutting
