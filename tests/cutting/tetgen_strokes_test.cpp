// 100 random blade strokes through a TetGen-meshed ball (the kind of body the shipped scenes
// simulate): each stroke is cut in three blade steps, each step also re-cutting the previous
// one, and finished by a pass over the whole stroke, as surgery::SoftBody does. Oracles: the
// topology self-check (every face shared by at most two tets, node lists consistent), the ball's
// volume at rest (children partition their parents), and the child/parent volume bound the snap
// fraction guarantees (minimumChildVolumeFraction), and the quality target of the cut: no
// dihedral angle below 5 deg at the end, measured by meshQuality (quality.cpp, its own angle
// computation, not the flips' measure). Measured 6.82 deg with the default snap fraction 0.42;
// 0.77 deg with the thesis' 0.2 (docs/cutting.md, "Quality after cuts").
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"
#include "random_strokes.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cstdio>

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

}  // namespace
}  // namespace blobvk::cutting
