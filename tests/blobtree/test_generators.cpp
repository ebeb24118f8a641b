// Procedural models: node counts from their definitions, determinism, and the PRNG against
// the published SplitMix64 test vector.
#include "blobvk/blobtree/generators.h"
#include "test_scene_compare.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace blobvk::blobtree;
using blobvk::testing::countNodes;
using blobvk::testing::expectSameTree;

TEST(Generators, SplitMix64MatchesTheReferenceSequence) {
  // Vigna's splitmix64.c seeded with 1234567 (the sequence quoted by Rosetta Code).
  SplitMix64 rng(1234567);
  EXPECT_EQ(rng.next(), 6457827717110365317ull);
  EXPECT_EQ(rng.next(), 3203168211198807973ull);
  EXPECT_EQ(rng.next(), 9817491932198370423ull);
  EXPECT_EQ(rng.next(), 4593380528125082431ull);
  EXPECT_EQ(rng.next(), 16408922859458223821ull);
  SplitMix64 u(42);
  for (int i = 0; i < 1000; ++i) {
    const double x = u.uniform();
    ASSERT_GE(x, 0.0);
    ASSERT_LT(x, 1.0);
  }
}

TEST(Generators, TowerCountsFollowTheConstruction) {
  // Per level: P pillars of (union(union(disc, cylinder), point)) plus one ceiling disc.
  for (int levels : {1, 4, 6}) {
    for (int pillars : {3, 8}) {
      const auto c = countNodes(generateTower(levels, pillars, 6.0, 6.0, 1));
      EXPECT_EQ(c.primitives, std::size_t(levels * (3 * pillars + 1)));
      EXPECT_EQ(c.operators, std::size_t(1 + levels * (1 + 2 * pillars)));
      EXPECT_EQ(c.warps, 0u);
    }
  }
  const auto grid = countNodes(generateTower(6, 8, 6.0, 6.0, 4));
  EXPECT_EQ(grid.primitives, 16u * 6u * 25u);
  EXPECT_EQ(grid.operators, 1u + 16u * (1u + 6u * 17u));
}

TEST(Generators, TowerGeometry) {
  const double r = 5.0, h = 4.0;
  const Node t = generateTower(3, 6, r, h, 2);
  ASSERT_EQ(t.children.size(), 4u);
  EXPECT_EQ(t.children[3].transform.translate, Vec3(3.0 * r, 0.0, 3.0 * r));  // spaced 3r
  const Node& tower = t.children[0];
  EXPECT_EQ(tower.id, "tower");
  const Node& level2 = tower.children[2];
  EXPECT_EQ(level2.id, "level2");
  EXPECT_DOUBLE_EQ(level2.transform.translate.y, 2.0 * 1.1 * h);  // stacked every 1.1H
  ASSERT_EQ(level2.children.size(), 7u);
  for (int i = 0; i < 6; ++i) {  // pillars on the circle of radius r
    const Vec3 at = level2.children[std::size_t(i)].transform.translate;
    EXPECT_NEAR(std::hypot(at.x, at.z), r, 1e-12);
    EXPECT_EQ(at.y, 0.0);
  }
  const Primitive& ceiling = std::get<Primitive>(level2.children[6].kind);
  EXPECT_EQ(ceiling.type, PrimitiveType::Disc);
  EXPECT_DOUBLE_EQ(ceiling.radius, 1.2 * r);
  const Node& pillar = level2.children[0];
  const Primitive& base = std::get<Primitive>(pillar.children[0].children[0].kind);
  const Primitive& column = std::get<Primitive>(pillar.children[0].children[1].kind);
  EXPECT_EQ(base.type, PrimitiveType::Disc);
  EXPECT_EQ(base.radius, 1.0);
  EXPECT_EQ(column.type, PrimitiveType::Cylinder);
  EXPECT_EQ(column.radius, 0.25);
  EXPECT_DOUBLE_EQ(column.height, 0.7 * h);
  EXPECT_EQ(std::get<Primitive>(pillar.children[1].kind).type, PrimitiveType::Point);
  EXPECT_THROW(generateTower(0, 8, 6.0, 6.0, 1), std::invalid_argument);
  EXPECT_THROW(generateTower(2, 8, -1.0, 6.0, 1), std::invalid_argument);
}

TEST(Generators, EggshellIsADifferenceOfTheThesisEllipsoids) {
  const Node e = generateEggshell();
  EXPECT_EQ(std::get<Operator>(e.kind).type, OperatorType::Difference);
  ASSERT_EQ(e.children.size(), 2u);
  EXPECT_EQ(e.children[0].transform.scale, Vec3(3.45, 2.18, 3.11));
  EXPECT_EQ(e.children[1].transform.scale, Vec3(3.14, 1.76, 2.83));
  EXPECT_EQ(std::get<Primitive>(e.children[0].kind).type, PrimitiveType::Point);
}

TEST(Generators, RandomBlobsAreDeterministicAndSeedDependent) {
  const Node a = generateRandomBlobs(128, 1);
  const Node b = generateRandomBlobs(128, 1);
  const Node c = generateRandomBlobs(128, 2);
  EXPECT_EQ(countNodes(a).primitives, 128u);
  EXPECT_EQ(std::get<Operator>(a.kind).type, OperatorType::Blend);
  expectSameTree(a, b, 0.0);
  EXPECT_NE(std::get<Primitive>(a.children[0].kind).a, std::get<Primitive>(c.children[0].kind).a);
  // The first point is drawn from the first three SplitMix64 outputs, independently computed.
  SplitMix64 rng(1);
  const double half = 0.75 * std::cbrt(128.0);
  const double x = -half + 2.0 * half * (double(rng.next() >> 11) * 0x1.0p-53);
  EXPECT_EQ(std::get<Primitive>(a.children[0].kind).a.x, x);
  for (const Node& n : a.children) {
    const Primitive& p = std::get<Primitive>(n.kind);
    EXPECT_LE(std::abs(p.a.x), half);
    EXPECT_LE(std::abs(p.a.y), half);
    EXPECT_LE(std::abs(p.a.z), half);
    EXPECT_GT(p.support, 0.0);
  }
  EXPECT_THROW(generateRandomBlobs(0, 1), std::invalid_argument);
}
