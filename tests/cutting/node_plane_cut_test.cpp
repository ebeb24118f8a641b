// Issue 7 follow-up: a blade whose swept surface passes exactly (or within rounding) through a
// plane of mesh nodes, so the crack must run along existing faces (case Z everywhere, every
// touched node a cut node). It used to produce no cut at all.
#include "blobvk/cutting/blade_run.h"
#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/parts.h"
#include "blobvk/cutting/vec.h"
#include "test_helpers.h"

#include <gtest/gtest.h>

#include <cmath>

namespace blobvk::cutting {
namespace {

// The reported setup: nodes at x = origin + h * k with origin and h not exactly representable
// (-0.35 + 0.1 k), so the node plane at x = 0.05 only holds "up to float rounding".
constexpr int kCells = 8;
constexpr double kCell = 0.1;
constexpr double kOrigin = -0.35;

mesh::TetMesh shiftedCube() {
  mesh::TetMesh m = test::cubeMesh(kCells, kCell);
  for (auto& p : m.positions) p = p + Double3{kOrigin, kOrigin, kOrigin};
  m.restPositions = m.positions;
  return m;
}

double partVolume(const mesh::TetMesh& m, const std::vector<std::uint32_t>& part) {
  double v = 0;
  for (std::uint32_t t : part) {
    const auto& tet = m.tets[t];
    const auto& r = m.restPositions;
    v += tetVolume(r[tet[0]], r[tet[1]], r[tet[2]], r[tet[3]]);
  }
  return v;
}

struct PlaneCase {
  double offsetInCells;  // blade plane = node plane + offset * cell size
  int steps;             // keyframe steps of the stroke
};

class NodePlaneCut : public ::testing::TestWithParam<PlaneCase> {};

TEST_P(NodePlaneCut, SeparatesTheBlockAlongTheNodePlane) {
  const PlaneCase pc = GetParam();
  const double x = kOrigin + 4 * kCell + pc.offsetInCells * kCell;  // node plane k = 4 (x ~ 0.05)
  const double lo = kOrigin - 0.1, hi = kOrigin + kCells * kCell + 0.1;
  BladePath path;
  for (int k = 0; k <= pc.steps; ++k) {
    const double y = lo + (hi - lo) * k / pc.steps;
    path.keyframes.push_back({double(k), {x, y, lo}, {x, y, hi}});
  }
  BladeRunOptions options;
  options.checkTopologyEachEvent = true;
  const mesh::TetMesh input = shiftedCube();
  const BladeRunResult run = runBladePath(input, path, options);
  for (const auto& check : run.checks) EXPECT_TRUE(check.ok()) << check.summary();
  EXPECT_TRUE(run.finalCheck.ok()) << run.finalCheck.summary();
  ASSERT_EQ(run.parts.size(), 2u) << "offset " << pc.offsetInCells << ", steps " << pc.steps;
  const double total = kCells * kCell * kCells * kCell * kCells * kCell;
  EXPECT_NEAR(run.after.totalVolume, total, 1e-12 * total);
  // The crack runs along the node plane (the nodes snap): 4 cells on each side.
  double v0 = partVolume(run.mesh, run.parts[0]), v1 = partVolume(run.mesh, run.parts[1]);
  EXPECT_NEAR(v0, total / 2, 1e-9 * total);
  EXPECT_NEAR(v1, total / 2, 1e-9 * total);
  // Every tet lies on one side of the plane (up to the snap distance): the parts do not mix.
  for (int p = 0; p < 2; ++p) {
    int left = 0, right = 0;
    for (std::uint32_t t : run.parts[std::size_t(p)]) {
      const auto& tet = run.mesh.tets[t];
      const auto& r = run.mesh.restPositions;
      const double cx = (r[tet[0]].x + r[tet[1]].x + r[tet[2]].x + r[tet[3]].x) / 4;
      (cx < x ? left : right) += 1;
    }
    EXPECT_TRUE(left == 0 || right == 0) << "part " << p << ": " << left << " left, " << right << " right";
  }
}

INSTANTIATE_TEST_SUITE_P(Offsets, NodePlaneCut,
                         ::testing::Values(PlaneCase{0.0, 1}, PlaneCase{1e-12, 1}, PlaneCase{1e-9, 1},
                                           PlaneCase{1e-6, 1}, PlaneCase{-1e-12, 1}, PlaneCase{-1e-6, 1},
                                           PlaneCase{1e-10, 1}, PlaneCase{-1e-10, 1}, PlaneCase{1e-8, 1}, PlaneCase{1e-4, 1},
                                           PlaneCase{0.0, 3}, PlaneCase{1e-9, 3}, PlaneCase{1e-6, 3}));

// Planes through the block's central node along other families of mesh faces and edges (the face
// diagonals of the voxel split, the body diagonal): any plane through the centre halves the
// block, and since the plane contains nodes and crosses edges only at parameters >= 1/3, the
// crack lies exactly on it.
class DiagonalNodePlaneCut : public ::testing::TestWithParam<Double3> {};

TEST_P(DiagonalNodePlaneCut, HalvesTheBlock) {
  const Double3 n = GetParam() * (1.0 / length(GetParam()));
  const Double3 centre{kOrigin + 4 * kCell, kOrigin + 4 * kCell, kOrigin + 4 * kCell};
  const Double3 seed = std::fabs(n.x) < 0.9 ? Double3{1, 0, 0} : Double3{0, 1, 0};
  Double3 u = cross(n, seed);
  u = u * (1.0 / length(u));
  const Double3 v = cross(n, u);
  BladeRunOptions options;
  options.checkTopologyEachEvent = true;
  const mesh::TetMesh input = shiftedCube();
  const BladeRunResult run = runBladePath(input, test::squareSweep(centre, u, v, 1.0), options);
  for (const auto& check : run.checks) EXPECT_TRUE(check.ok()) << check.summary();
  ASSERT_EQ(run.parts.size(), 2u);
  const double total = kCells * kCell * kCells * kCell * kCells * kCell;
  EXPECT_NEAR(run.after.totalVolume, total, 1e-12 * total);
  EXPECT_NEAR(partVolume(run.mesh, run.parts[0]), total / 2, 1e-9 * total);
  EXPECT_NEAR(partVolume(run.mesh, run.parts[1]), total / 2, 1e-9 * total);
}

INSTANTIATE_TEST_SUITE_P(Normals, DiagonalNodePlaneCut,
                         ::testing::Values(Double3{1, 0, 0}, Double3{0, 1, 0}, Double3{0, 0, 1}, Double3{1, 1, 0},
                                           Double3{1, -1, 0}, Double3{0, 1, 1}, Double3{0, 1, -1},
                                           Double3{1, 0, 1}, Double3{1, 0, -1}, Double3{1, 1, 1},
                                           Double3{1, -1, 1}, Double3{1, 1, -1}, Double3{-1, 1, 1}));

// The blade stopping halfway along a node plane: the crack opens only where the blade passed, the
// block stays one part, and a second stroke finishing the cut separates it.
TEST(NodePlaneCutProgressive, HalfThenFull) {
  const double x = kOrigin + 4 * kCell;
  const double lo = kOrigin - 0.1, hi = kOrigin + kCells * kCell + 0.1, mid = kOrigin + 0.5 * kCells * kCell;
  Cutter cutter(shiftedCube());
  const double volume = kCells * kCell * kCells * kCell * kCells * kCell;
  const CutResult first = cutter.cut(sweptTriangles({0, {x, lo, lo}, {x, lo, hi}}, {1, {x, mid, lo}, {x, mid, hi}}));
  EXPECT_GT(first.crackFaces, 0u);
  EXPECT_GT(first.duplicatedNodes, 0u);
  ASSERT_TRUE(cutter.topology().selfCheck().ok()) << cutter.topology().selfCheck().summary();
  EXPECT_EQ(disjointParts(cutter.topology()).size(), 1u);
  cutter.cut(sweptTriangles({1, {x, mid, lo}, {x, mid, hi}}, {2, {x, hi, lo}, {x, hi, hi}}));
  ASSERT_TRUE(cutter.topology().selfCheck().ok()) << cutter.topology().selfCheck().summary();
  EXPECT_EQ(disjointParts(cutter.topology()).size(), 2u);
  EXPECT_NEAR(cutter.topology().totalRestVolume(), volume, 1e-12 * volume);
}

}  // namespace
}  // namespace blobvk::cutting
