// The diagonal of a quad crack (CutOptions::crackDiagonalBelowDeg): a tet cut by the plane z = 0
// through four edges whose crossing points P (on ac), Q (on ad), R (on bd), S (on bc) make a quad
// with an angle of 161 deg at Q. Split along P-R, the crack triangle P, Q, R is almost flat, and
// so are the children coned over it; along Q-S both crack triangles are well shaped. The key rule
// picks P-R or Q-S by the order of the nodes' indices, so every order of the four corners is cut.
// Oracles: the crack's two triangles (faces of the children with all three nodes on z = 0), whose
// shared edge is the diagonal; the crossing points computed here from the corners; the tet's
// volume; the children's smallest dihedral angle by tetQuality.
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/vec.h"

#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

namespace blobvk::cutting {
namespace {

// The corners: a, b above the plane (z = 1, 1.3), c, d below (z = -1.3, -1): every crossing lies
// at 0.43-0.57 of its edge, so nothing snaps with the default fraction 0.42. Smallest dihedral
// angle 20.8 deg.
constexpr std::array<Double3, 4> kCorners{Double3{0.4, -1.0, 1.0}, Double3{-0.9, 0.9, 1.3}, Double3{1.0, -0.8, -1.3},
                                          Double3{-0.9, 0.5, -1.0}};

Double3 crossing(Double3 p, Double3 q) { return lerp(p, q, p.z / (p.z - q.z)); }

double angleAt(Double3 a, Double3 b, Double3 c) {
  const Double3 u = a - b, v = c - b;
  return std::acos(dot(u, v) / (length(u) * length(v))) * 180.0 / 3.14159265358979323846;
}

struct Outcome {
  bool alongQS = false, alongPR = false;
  double minDihedralDeg = 0;
};

// Cuts the tet with its corners stored in `order`, flips and smoothing off (the split alone).
Outcome cutInOrder(const std::array<int, 4>& order, double diagonalBelowDeg) {
  const mesh::TetMesh tet =
      test::singleTet(kCorners[order[0]], kCorners[order[1]], kCorners[order[2]], kCorners[order[3]]);
  CutOptions options;
  options.improveBelowDeg = 0;
  options.smoothBelowDeg = 0;
  options.crackDiagonalBelowDeg = diagonalBelowDeg;
  Cutter cutter(tet, options);
  const double volume = cutter.topology().totalRestVolume();
  const CutResult r = cutter.cut(test::squareTriangles({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 5.0));
  EXPECT_EQ(r.count(CutCase::B), 1u);
  EXPECT_EQ(disjointParts(cutter.topology()).size(), 2u);
  EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12);
  const auto& [a, b, c, d] = kCorners;
  const Double3 p = crossing(a, c), q = crossing(a, d), rr = crossing(b, d), s = crossing(b, c);
  auto near = [](Double3 x, Double3 y) { return length(x - y) < 1e-12; };
  Outcome out;
  out.minDihedralDeg = 180;
  const mesh::TetMesh after = cutter.topology().toTetMesh();
  const auto& x = after.restPositions;
  for (const Tet& t : after.tets) {
    out.minDihedralDeg = std::min(out.minDihedralDeg, tetQuality(x[t[0]], x[t[1]], x[t[2]], x[t[3]]).minDihedralDeg);
    for (const auto& f : kTetFaces) {
      const std::array<Double3, 3> v{x[t[f[0]]], x[t[f[1]]], x[t[f[2]]]};
      if (std::any_of(v.begin(), v.end(), [](Double3 y) { return std::fabs(y.z) > 1e-12; })) continue;
      auto has = [&](Double3 y) { return std::any_of(v.begin(), v.end(), [&](Double3 z) { return near(y, z); }); };
      out.alongQS |= has(q) && has(s);
      out.alongPR |= has(p) && has(rr);
    }
  }
  EXPECT_NE(out.alongQS, out.alongPR);  // one diagonal, on both sides of the crack
  return out;
}

TEST(CrackDiagonal, AQuadCrackIsSplitAlongTheDiagonalThatKeepsItsTrianglesOpen) {
  const auto& [a, b, c, d] = kCorners;
  const Double3 p = crossing(a, c), q = crossing(a, d), r = crossing(b, d), s = crossing(b, c);
  ASSERT_GT(angleAt(p, q, r), 160.0);  // the flat triangle of diagonal P-R
  ASSERT_LT(std::max({angleAt(p, q, s), angleAt(q, s, p), angleAt(s, p, q), angleAt(q, r, s), angleAt(r, s, q),
                      angleAt(s, q, r)}),
            120.0);  // the triangles of diagonal Q-S
  std::array<int, 4> order{0, 1, 2, 3};
  int keyRuleFlat = 0;
  double worstChosen = 180, worstKeyRule = 180;
  do {
    const Outcome keyRule = cutInOrder(order, 0.0);
    const Outcome chosen = cutInOrder(order, 15.0);
    keyRuleFlat += keyRule.alongPR;
    EXPECT_TRUE(chosen.alongQS);
    EXPECT_GE(chosen.minDihedralDeg, keyRule.minDihedralDeg - 1e-9);
    worstChosen = std::min(worstChosen, chosen.minDihedralDeg);
    worstKeyRule = std::min(worstKeyRule, keyRule.minDihedralDeg);
  } while (std::next_permutation(order.begin(), order.end()));
  std::printf("smallest child dihedral over the 24 orders: %.2f deg (key rule: %.2f deg, P-R in %d orders)\n",
              worstChosen, worstKeyRule, keyRuleFlat);
  EXPECT_GT(keyRuleFlat, 0);  // the case arises: some orders fan the crack from P or R
  EXPECT_GT(worstChosen, worstKeyRule);
}

}  // namespace
}  // namespace blobvk::cutting
