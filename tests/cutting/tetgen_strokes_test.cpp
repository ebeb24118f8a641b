// 100 random blade strokes through a TetGen-meshed ball (the kind of body the shipped scenes
// simulate): each stroke is cut in three blade steps, each step also re-cutting the previous
// one, and finished by a pass over the whole stroke, as surgery::SoftBody does. Oracles: the
// topology self-check (every face shared by at most two tets, node lists consistent), the ball's
// volume at rest (children partition their parents), and the child/parent volume bound the snap
// fraction guarantees (minimumChildVolumeFraction). Dihedral angles are printed, not bounded:
// cuts through the children of earlier cuts compound (no local remeshing yet; docs/cutting.md).
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

namespace blobvk::cutting {
namespace {

using mesh::Double3;

Double3 unit(Double3 v) {
  const double l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
  return {v.x / l, v.y / l, v.z / l};
}
Double3 cross3(Double3 a, Double3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
Double3 along(Double3 p, Double3 d, double s) { return {p.x + s * d.x, p.y + s * d.y, p.z + s * d.z}; }

TEST(TetgenStrokes, HundredRandomStrokesKeepTheBallConformingAndItsVolume) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 1.5e-3;
  const mesh::TetMesh ball = fem::tetrahedralize(testing::icosphere(2), options);
  const QualityStats before = meshQuality(ball);
  Cutter cutter(ball);
  const double bound = minimumChildVolumeFraction(cutter.options().snapFraction, cutter.options().steinerMargin);
  const double volume = cutter.topology().totalRestVolume();
  std::mt19937 rng(16);
  std::uniform_real_distribution<double> g(-1.0, 1.0), centre(-0.5, 0.5), half(0.25, 0.6), travel(0.3, 0.8);
  std::size_t splits = 0, attached = 0;
  for (int stroke = 0; stroke < 100; ++stroke) {
    const Double3 c{centre(rng), centre(rng), centre(rng)};
    const Double3 v = unit({g(rng), g(rng), g(rng)});
    const Double3 u = unit(cross3(v, unit({g(rng), g(rng), g(rng)})));
    const Double3 turn = unit({g(rng), g(rng), g(rng)});
    const double h = half(rng), length = travel(rng);
    std::vector<Triangle> all, previous;
    BladeKeyframe last{0.0, along(c, v, -h), along(c, v, h)};
    for (int step = 1; step <= 3; ++step) {
      // The blade turns a little while it moves: the stroke's surface is not planar.
      const Double3 at = along(c, u, length * step / 3.0);
      const Double3 tip = along(along(at, v, h), turn, 0.1 * step);
      BladeKeyframe now{double(step), along(at, v, -h), tip};
      std::vector<Triangle> swept = sweptTriangles(last, now);
      last = now;
      std::vector<Triangle> event = swept;
      event.insert(event.end(), previous.begin(), previous.end());
      all.insert(all.end(), swept.begin(), swept.end());
      previous = swept;
      const CutResult r = cutter.cut(event);
      splits += r.splitTets;
      attached += r.attachedSlivers;
      EXPECT_GE(r.minChildVolumeRatio, bound * (1 - 1e-9)) << "stroke " << stroke << ", step " << step;
    }
    const CutResult r = cutter.cut(all);
    splits += r.splitTets;
    attached += r.attachedSlivers;
    if (stroke % 10 == 9) {
      const SelfCheckReport check = cutter.topology().selfCheck();
      ASSERT_TRUE(check.ok()) << "stroke " << stroke << ": " << check.summary();
    }
    ASSERT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12) << "stroke " << stroke;
  }
  const QualityStats after = meshQuality(cutter.topology().toTetMesh());
  std::printf("ball: %zu -> %zu tets, %zu splits, %zu slivers kept attached\n  before: %s\n  after:  %s\n",
              before.tets, after.tets, splits, attached, before.summary().c_str(), after.summary().c_str());
  EXPECT_GT(after.minDihedralDeg, 0.0);  // no flat tet
  EXPECT_GT(after.tets, before.tets);
}

}  // namespace
}  // namespace blobvk::cutting
