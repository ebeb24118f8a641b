// surgery::MaterialMap inverts the deformation: for an affine motion of the body (the FEM's
// piecewise-affine map is then one affine map) every point inside maps back to its material
// point, and a point outside a translated body moves back by the translation.
#include "test_bodies.h"

#include "blobvk/surgery/material_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

using namespace blobvk;

mesh::Double3 affine(const mesh::Double3& p) {
  // A rotation about z by 0.3 rad, a stretch along x by 1.2 and a translation.
  const double c = std::cos(0.3), s = std::sin(0.3);
  const double x = 1.2 * p.x;
  return {c * x - s * p.y + 0.4, s * x + c * p.y - 0.1, p.z + 0.25};
}

TEST(MaterialMap, InvertsAnAffineMotionInsideTheBody) {
  const mesh::TetMesh box = blobvk::testing::voxelBox(0.5, 0.1);
  std::vector<mesh::Double3> deformed;
  for (const auto& p : box.restPositions) deformed.push_back(affine(p));
  const surgery::MaterialMap map(box, deformed, {{-2, -2, -2}, {2, 2, 2}}, 0.1);
  EXPECT_EQ(map.indexedTets(), box.tets.size());
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.54, 0.54);
  for (int i = 0; i < 500; ++i) {
    const mesh::Double3 X{u(rng), u(rng), u(rng)};
    const mesh::Double3 back = map.toMaterial(affine(X));
    ASSERT_NEAR(back.x, X.x, 1e-12);
    ASSERT_NEAR(back.y, X.y, 1e-12);
    ASSERT_NEAR(back.z, X.z, 1e-12);
  }
}

TEST(MaterialMap, PointsOutsideATranslatedBodyMoveBackByTheTranslation) {
  const mesh::TetMesh box = blobvk::testing::voxelBox(0.5, 0.1);
  const mesh::Double3 t{0.3, -0.2, 0.1};
  std::vector<mesh::Double3> moved;
  for (const auto& p : box.restPositions) moved.push_back({p.x + t.x, p.y + t.y, p.z + t.z});
  const surgery::MaterialMap map(box, moved, {{-3, -3, -3}, {3, 3, 3}}, 0.1);
  // Near the surface (found through a tet) and far from it (no tet within two cells).
  for (const mesh::Double3 X : {mesh::Double3{0.62, 0.1, 0}, mesh::Double3{0, -0.6, 0.3}, mesh::Double3{2.5, 2.5, 2.5}}) {
    const mesh::Double3 back = map.toMaterial({X.x + t.x, X.y + t.y, X.z + t.z});
    EXPECT_NEAR(back.x, X.x, 1e-12);
    EXPECT_NEAR(back.y, X.y, 1e-12);
    EXPECT_NEAR(back.z, X.z, 1e-12);
  }
  // Only the tets whose moved box meets the region are indexed.
  const surgery::MaterialMap corner(box, moved, {{0.7, 0.2, 0.5}, {1.0, 1.0, 1.0}}, 0.1);
  EXPECT_GT(corner.indexedTets(), 0u);
  EXPECT_LT(corner.indexedTets(), box.tets.size() / 10);
}

}  // namespace
