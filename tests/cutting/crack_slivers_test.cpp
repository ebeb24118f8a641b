// Slivers between two crack sheets (crack_slivers.h) and snapped nodes remembered across events
// (Cutter's snap reach): a stroke whose blade intervals meet at an angle near a plane of nodes cut
// the block in exactly two parts, with no chip between the sheets. Oracles: part counts, the
// block's volume, the topology self-check, and CrackSlivers on hand-made cracks.
#include "blobvk/cutting/blade.h"
#include "blobvk/cutting/crack_slivers.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/quality.h"
#include "blobvk/cutting/vec.h"
#include "blobvk/fem/tetgen_mesher.h"

#include "../fem/icosphere.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace blobvk::cutting {
namespace {

std::vector<FaceKey> interiorFacesOf(const CutTopology& topology, std::uint32_t slot) {
  std::vector<FaceKey> faces;
  const Tet& t = topology.tet(slot);
  for (const auto& f : kTetFaces) {
    const auto pair = topology.tetsOfFace(t[f[0]], t[f[1]], t[f[2]]);
    if (pair[0] != kNone && pair[1] != kNone) faces.push_back(makeFaceKey(t[f[0]], t[f[1]], t[f[2]]));
  }
  std::sort(faces.begin(), faces.end(), [](const FaceKey& x, const FaceKey& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.c < y.c);
  });
  return faces;
}

// The tet of a 2x2x2 block with the most neighbours: a crack around all of its shared faces
// would cut it out alone.
std::uint32_t innermostTet(const CutTopology& topology) {
  std::uint32_t best = 0;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s)
    if (interiorFacesOf(topology, s).size() > interiorFacesOf(topology, best).size()) best = s;
  return best;
}

TEST(CrackSlivers, APieceWhollyOnCutSurfacesStaysAttachedByItsLargestFace) {
  const CutTopology topology(test::cubeMesh(2));
  const std::uint32_t slot = innermostTet(topology);
  std::vector<FaceKey> crack = interiorFacesOf(topology, slot);
  ASSERT_GE(crack.size(), 3u);
  const std::vector<FaceKey> before = crack;
  const std::vector<double> onCut(topology.mesh().nodeCount(), 1.0);
  CrackSlivers slivers;
  EXPECT_EQ(slivers.attach(topology, crack, onCut), 1u);
  ASSERT_EQ(crack.size(), before.size() - 1);
  // The face taken off the crack is one of largest area.
  const auto& p = topology.mesh().restPositions;
  auto area = [&](const FaceKey& f) {
    const mesh::Double3 u{p[f.b].x - p[f.a].x, p[f.b].y - p[f.a].y, p[f.b].z - p[f.a].z};
    const mesh::Double3 v{p[f.c].x - p[f.a].x, p[f.c].y - p[f.a].y, p[f.c].z - p[f.a].z};
    const double x = u.y * v.z - u.z * v.y, y = u.z * v.x - u.x * v.z, z = u.x * v.y - u.y * v.x;
    return std::sqrt(x * x + y * y + z * z);
  };
  double largest = 0, removed = -1;
  for (const FaceKey& f : before) {
    largest = std::max(largest, area(f));
    if (std::find(crack.begin(), crack.end(), f) == crack.end()) removed = area(f);
  }
  EXPECT_DOUBLE_EQ(removed, largest);
}

TEST(CrackSlivers, APieceWithANodeOffTheCutSurfacesIsCutOff) {
  const CutTopology topology(test::cubeMesh(2));
  const std::uint32_t slot = innermostTet(topology);
  std::vector<FaceKey> crack = interiorFacesOf(topology, slot);
  const std::vector<FaceKey> before = crack;
  std::vector<double> onCut(topology.mesh().nodeCount(), 1.0);
  onCut[topology.tet(slot)[2]] = 0.0;  // material beyond the snap zone: a real piece
  CrackSlivers slivers;
  EXPECT_EQ(slivers.attach(topology, crack, onCut), 0u);
  EXPECT_EQ(crack, before);
}

TEST(CrackSlivers, LargePiecesAreLeftAlone) {
  // A crack along the plane x = 4 of an 8^3 block: both sides hold far more than 64 tets.
  const CutTopology topology(test::cubeMesh(8));
  std::vector<FaceKey> crack;
  const auto& p = topology.mesh().restPositions;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s)
    for (const FaceKey& f : interiorFacesOf(topology, s))
      if (p[f.a].x == 4.0 && p[f.b].x == 4.0 && p[f.c].x == 4.0) crack.push_back(f);
  std::sort(crack.begin(), crack.end(), [](const FaceKey& x, const FaceKey& y) {
    return x.a != y.a ? x.a < y.a : (x.b != y.b ? x.b < y.b : x.c < y.c);
  });
  crack.erase(std::unique(crack.begin(), crack.end()), crack.end());
  ASSERT_EQ(crack.size(), 2u * 8 * 8);
  const std::vector<FaceKey> before = crack;
  const std::vector<double> onCut(topology.mesh().nodeCount(), 1.0);
  CrackSlivers slivers;
  EXPECT_EQ(slivers.attach(topology, crack, onCut), 0u);
  EXPECT_EQ(crack, before);
}

// A stroke of three blade intervals meeting at angles, through a TetGen ball (irregular tets:
// some nodes lie within tau of the first interval's surface while the next interval crosses their
// split tets beside them), cut as surgery::SoftBody does (each interval, then the previous one
// again, then the whole stroke twice): the ball falls into exactly two parts, no chip between
// the crack sheets, whatever the stroke's position and kinks.
TEST(SnappedNodes, KinkedStrokesCutATetgenBallInTwoWithoutChips) {
  if (!fem::tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  fem::TetgenOptions options;
  options.maxVolume = 2e-3;
  const mesh::TetMesh ball = fem::tetrahedralize(testing::icosphere(2), options);
  int strokes = 0;
  for (double x0 : {-0.31, -0.12, 0.0, 0.07, 0.23})
    for (double kink : {-0.35, -0.2, 0.2, 0.35}) {
      Cutter cutter(ball);
      const double volume = cutter.topology().totalRestVolume();
      // A vertical blade (along y) moving along z; its x turns by `kink` per unit of z at each stop.
      const std::vector<double> stops{-1.2, -0.3, 0.35, 1.2};
      std::vector<double> xs{x0};
      for (std::size_t k = 1; k < stops.size(); ++k)
        xs.push_back(xs.back() + (k == 1 ? 0.0 : kink * (k == 2 ? 1.0 : -1.0)) * (stops[k] - stops[k - 1]));
      auto blade = [&](std::size_t k) { return BladeKeyframe{stops[k], {xs[k], -1.2, stops[k]}, {xs[k], 1.2, stops[k]}}; };
      std::vector<Triangle> all, previous;
      for (std::size_t k = 1; k < stops.size(); ++k) {
        const std::vector<Triangle> swept = sweptTriangles(blade(k - 1), blade(k));
        std::vector<Triangle> event = swept;
        event.insert(event.end(), previous.begin(), previous.end());
        previous = swept;
        all.insert(all.end(), swept.begin(), swept.end());
        cutter.cut(event);
      }
      for (int pass = 0; pass < 2; ++pass) cutter.cut(all);
      const SelfCheckReport check = cutter.topology().selfCheck();
      ASSERT_TRUE(check.ok()) << check.summary();
      const auto parts = disjointParts(cutter.topology());
      std::vector<std::size_t> sizes;
      for (const auto& part : parts) sizes.push_back(part.size());
      EXPECT_EQ(parts.size(), 2u) << "x0 " << x0 << ", kink " << kink << ": " << ::testing::PrintToString(sizes);
      EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12);
      ++strokes;
    }
  EXPECT_EQ(strokes, 20);
}

}  // namespace
}  // namespace blobvk::cutting

namespace blobvk::cutting {
namespace {

double minDihedral(const CutTopology& topology) { return meshQuality(topology.toTetMesh()).minDihedralDeg; }
Double3 unit(Double3 v) { return v * (1.0 / length(v)); }

// A blade passing 1e-4 edge lengths from a node snaps the crack onto that node: every child keeps
// at least minimumChildVolumeFraction of its parent and no dihedral angle drops below 5 deg,
// where the same cut without snapping (snapFraction 0) makes slivers below 0.1 deg. Planes in
// 12 directions through a point 1e-4 from the centre node of a 6^3 block; the block's volume is
// kept to 1e-12 and the topology stays conforming. Node smoothing is off in both runs: this is
// what the snapping does by itself.
TEST(SnappedNodes, ABladeGrazingANodeLeavesNoSliver) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> g(-1.0, 1.0);
  for (int k = 0; k < 12; ++k) {
    const Double3 normal = unit({g(rng), g(rng), g(rng)});
    Double3 u = unit(cross(normal, {0.3, 0.5, 0.7}));
    const Double3 v = cross(normal, u);
    const Double3 centre = Double3{3, 3, 3} + normal * 1e-4;
    const std::vector<Triangle> swept = test::squareTriangles(centre, u, v, 10.0);
    double snapped = 0, unsnapped = 0;
    for (double tau : {0.2, 0.0}) {
      CutOptions options;
      options.snapFraction = tau;
      options.smoothBelowDeg = 0;  // snapping alone (node smoothing repairs some unsnapped slivers)
      Cutter cutter(test::cubeMesh(6), options);
      const double volume = cutter.topology().totalRestVolume();
      const CutResult r = cutter.cut(swept);
      EXPECT_GT(r.splitTets, 0u);
      ASSERT_TRUE(cutter.topology().selfCheck().ok());
      EXPECT_LE(test::relativeDifference(cutter.topology().totalRestVolume(), volume), 1e-12);
      if (tau > 0) {
        EXPECT_EQ(disjointParts(cutter.topology()).size(), 2u) << "direction " << k;
        EXPECT_GE(r.minChildVolumeRatio, minimumChildVolumeFraction(tau, options.steinerMargin) * (1 - 1e-9));
        snapped = minDihedral(cutter.topology());
      } else {
        unsnapped = minDihedral(cutter.topology());
      }
    }
    EXPECT_GE(snapped, 5.0) << "direction " << k;
    EXPECT_LT(unsnapped, 0.1) << "direction " << k << ": the oracle's sliver did not appear";
  }
}

}  // namespace
}  // namespace blobvk::cutting
