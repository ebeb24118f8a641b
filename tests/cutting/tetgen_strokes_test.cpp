// 100 random blade strokes through a TetGen-meshed ball (the kind of body the shipped scenes
// simulate): each stroke is cut in three blade steps, each step also re-cutting the previous
// one, and finished by a pass over the whole stroke, as surgery::SoftBody does. Oracles: the
// topology self-check (every face shared by at most two tets, node lists consistent), the ball's
// volume at rest (children partition their parents), and the child/parent volume bound the snap
// fraction guarantees (minimumChildVolumeFraction), and the quality target of the cut: no
// dihedral angle below 5 deg at the end, measured by meshQuality (quality.cpp, its own angle
// computation, not the flips' measure). Measured 8.94 deg with the defaults (snap fraction 0.42,
// flips and node smoothing at 15 deg); 0.77 deg with the thesis' 0.2 before node smoothing
// (docs/cutting.md, "Quality after cuts").
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"
#include "random_strokes.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <utility>
#include <vector>

namespace blobvk::cutting {
namespace {

TEST(TetgenStrokes, HundredRandomStrokesKeepTheBallConformingAndItsVolume) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 1.5e-3;
  const mesh::TetMesh ball = fem::tetrahedralize(testing::icosphere(2), options);
  const QualityStats before = meshQuality(ball);
  Cutter cutter(ball);
  const double bound = minimumChildVolumeFraction(cutter.options().snapFraction, cutter.options().steinerMargin);
  const double volume = cutter.topology().totalRestVolume();
  test::RandomStrokes strokes(16);
  std::size_t splits = 0, attached = 0;
  for (int stroke = 0; stroke < 100; ++stroke) {
    const test::StrokeEvents events = strokes.next();
    for (std::size_t step = 0; step < events.size(); ++step) {
      const CutResult r = cutter.cut(events[step]);
      splits += r.splitTets;
      attached += r.attachedSlivers;
      EXPECT_GE(r.minChildVolumeRatio, bound * (1 - 1e-9)) << "stroke " << stroke << ", event " << step;
    }
    if (stroke % 10 == 9) {
      const SelfCheckReport check = cutter.topology().selfCheck();
      ASSERT_TRUE(check.ok()) << "stroke " << stroke << ": " << check.summary();
    }
    ASSERT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12) << "stroke " << stroke;
  }
  const mesh::TetMesh body = cutter.topology().toTetMesh();
  const QualityStats after = meshQuality(body);
  std::size_t below5 = 0, below1 = 0;
  for (const Tet& t : body.tets) {
    const auto& r = body.restPositions;
    const double angle = minDihedralDeg(r[t[0]], r[t[1]], r[t[2]], r[t[3]]);
    below5 += angle < 5.0;
    below1 += angle < 1.0;
  }
  std::printf("tets below 5 deg: %zu, below 1 deg: %zu\n", below5, below1);
  std::printf("ball: %zu -> %zu tets, %zu splits, %zu slivers kept attached\n  before: %s\n  after:  %s\n",
              before.tets, after.tets, splits, attached, before.summary().c_str(), after.summary().c_str());
  EXPECT_GE(after.minDihedralDeg, 5.0);
  EXPECT_EQ(below5, 0u);
  EXPECT_GT(after.tets, before.tets);
}

// 100 strokes of one seed through a TetGen ball: conforming (self-check), rest volume to 1e-12,
// no dihedral angle below 5 deg by meshQuality.
void expectStrokesKeepFiveDegrees(const mesh::TetMesh& ball, unsigned seed) {
  Cutter cutter(ball);
  const double volume = cutter.topology().totalRestVolume();
  test::RandomStrokes strokes(seed);
  for (int stroke = 0; stroke < 100; ++stroke)
    for (const auto& event : strokes.next()) cutter.cut(event);
  const SelfCheckReport check = cutter.topology().selfCheck();
  ASSERT_TRUE(check.ok()) << check.summary();
  EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12);
  const QualityStats after = meshQuality(cutter.topology().toTetMesh());
  std::printf("seed %u: %zu -> %zu tets, %s\n", seed, ball.tets.size(), after.tets, after.summary().c_str());
  EXPECT_GT(after.tets, ball.tets.size());
  EXPECT_GE(after.minDihedralDeg, 5.0);
}

const mesh::TetMesh& ball(double maxVolume, int subdivisions) {
  static std::vector<std::pair<double, mesh::TetMesh>> made;
  for (const auto& [v, m] : made)
    if (v == maxVolume) return m;
  fem::TetgenOptions options;
  options.maxVolume = maxVolume;
  made.emplace_back(maxVolume, fem::tetrahedralize(testing::icosphere(subdivisions), options));
  return made.back().second;
}

// Other seeds on the ~12.7k-tet ball (seed 12 ended at 4.88 deg, a tet with three boundary faces,
// before the 3-2 flip and boundary edge removal of local_flips.h).
class SmallBallStrokes : public ::testing::TestWithParam<unsigned> {};
TEST_P(SmallBallStrokes, KeepTheBallConformingItsVolumeAndFiveDegrees) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  expectStrokesKeepFiveDegrees(ball(1.5e-3, 2), GetParam());
}
INSTANTIATE_TEST_SUITE_P(TetgenStrokes, SmallBallStrokes, ::testing::Values(1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 12u));

// The quality target at full size: 100 strokes through the ~100k-tet ball of bench_cut_event's
// BM_RandomStrokesTetgenBall. Seed 16 is the bench's; seeds 2, 3 and 7 end with a tet below
// 5 deg without node smoothing (4.71, 4.92 and 4.14 deg, CutOptions::smoothBelowDeg = 0), seed 2
// also when crease nodes may not slide; seed 24 ends at 4.13 deg without the 3-2 flip of a ring
// whose slot the event appended, seed 29 at 4.96 deg without boundary edge removal (both
// local_flips.h); seeds 35 and 64 end at 4.73 and 4.28 deg when a node snapped to a cut that has
// not opened may not slide parallel to it (node_smoothing.h); seeds 76 and 88 end at 3.95 and
// 3.96 deg when a quad crack takes the key rule's diagonal whatever its shape (a flat crack
// triangle of three nearly collinear cut points, CutOptions::crackDiagonalBelowDeg = 0), seed 37
// at 4.71 deg when a spike's apex may not slide parallel to its base (a tet hanging off the body
// by one face, node_smoothing.h; docs/cutting.md "Quality after cuts").
class HundredThousandTetBallStrokes : public ::testing::TestWithParam<unsigned> {};
TEST_P(HundredThousandTetBallStrokes, KeepTheBallConformingItsVolumeAndFiveDegrees) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  const mesh::TetMesh& body = ball(130e-6, 4);
  ASSERT_GT(body.tets.size(), 90000u);
  expectStrokesKeepFiveDegrees(body, GetParam());
}
INSTANTIATE_TEST_SUITE_P(TetgenStrokes, HundredThousandTetBallStrokes, ::testing::Values(2u, 3u, 7u, 16u, 24u, 29u, 35u, 37u, 64u, 76u, 88u));

}  // namespace
}  // namespace blobvk::cutting
