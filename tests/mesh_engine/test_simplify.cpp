// meshoptimizer simplification behind the closedness guard: on shipped scenes the result keeps
// the requested share of triangles (or stays within the error bound), and stays watertight with
// the input's topology; an open mesh keeps its border where it was.
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/engine/simplify.h"
#include "shipped_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

namespace {

using namespace blobvk::mesh;

TEST(Simplify, ParsesARatioOrAPercentError) {
  SimplifyTarget t = parseSimplifyTarget("0.25");
  EXPECT_EQ(t.kind, SimplifyTarget::Kind::Ratio);
  EXPECT_FLOAT_EQ(t.value, 0.25f);
  t = parseSimplifyTarget("0.5%");
  EXPECT_EQ(t.kind, SimplifyTarget::Kind::Error);
  EXPECT_FLOAT_EQ(t.value, 0.005f);
  for (const char* bad : {"", "%", "0", "1.5", "-0.1", "abc", "0.2x", "0%", "101%", "nan", "inf"})
    EXPECT_THROW(parseSimplifyTarget(bad), std::invalid_argument) << bad;
}

// The tower has 21 windows (Euler characteristic -40): edge collapses through their thin frames
// are exactly what breaks manifoldness, so it is the hard case.
class SimplifyShipped : public ::testing::TestWithParam<std::tuple<const char*, float>> {};

TEST_P(SimplifyShipped, ReachesTheRatioAndStaysClosedWithTheSameTopology) {
  const auto [scene, ratio] = GetParam();
  const TriMesh mesh = shippedMesh(scene, 96);
  const MeshReport before = checkMesh(mesh);
  ASSERT_TRUE(before.watertight()) << before.summary();
  SimplifyReport report;
  const TriMesh out = simplifyMesh(mesh, {SimplifyTarget::Kind::Ratio, ratio}, &report);
  const MeshReport after = checkMesh(out);
  EXPECT_TRUE(after.watertight()) << after.summary();
  EXPECT_EQ(after.eulerCharacteristic, before.eulerCharacteristic);
  EXPECT_EQ(after.components, before.components);
  EXPECT_EQ(after.unreferencedVertices, 0u);
  EXPECT_FALSE(report.keptInput);
  // The ratio is reached to within the few back-to-back pairs the guard removes.
  const double kept = double(out.triangles.size()) / double(mesh.triangles.size());
  EXPECT_NEAR(kept, ratio, 0.01) << report.summary();
  EXPECT_EQ(report.trianglesAfter, out.triangles.size());
  EXPECT_TRUE(report.watertightAfter);
  // Collapses move the surface by a fraction of a cell: the volume barely changes.
  EXPECT_NEAR(after.volume, before.volume, 0.01 * before.volume);
  EXPECT_EQ(out.normals.size(), out.positions.size());
  EXPECT_EQ(out.colours.size(), out.positions.size());
  EXPECT_TRUE(out.edgeKeys.empty());
}

INSTANTIATE_TEST_SUITE_P(Scenes, SimplifyShipped,
                         ::testing::Values(std::make_tuple("tower", 0.25f), std::make_tuple("tower", 0.1f),
                                           std::make_tuple("dice", 0.25f), std::make_tuple("creature", 0.5f)));

TEST(Simplify, AnErrorBoundLimitsTheDeviation) {
  const TriMesh mesh = shippedMesh("twisted_column", 96);
  SimplifyReport tight, loose;
  const TriMesh a = simplifyMesh(mesh, parseSimplifyTarget("0.01%"), &tight);
  const TriMesh b = simplifyMesh(mesh, parseSimplifyTarget("0.5%"), &loose);
  EXPECT_LE(tight.error, 1e-4f);
  EXPECT_LE(loose.error, 5e-3f);
  EXPECT_LT(b.triangles.size(), a.triangles.size()) << "a looser bound removes more";
  EXPECT_LT(a.triangles.size(), mesh.triangles.size());
  EXPECT_TRUE(checkMesh(a).watertight());
  EXPECT_TRUE(checkMesh(b).watertight());
}

// A bumpy open square: its 4 * n border vertices must all survive, at their places.
TEST(Simplify, AnOpenMeshKeepsItsBorder) {
  const int n = 40;
  TriMesh mesh;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      mesh.positions.push_back({float(i), float(j), 0.3f * std::sin(0.4f * float(i)) * std::cos(0.3f * float(j))});
  auto at = [&](int i, int j) { return std::uint32_t(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  SimplifyReport report;
  const TriMesh out = simplifyMesh(mesh, {SimplifyTarget::Kind::Ratio, 0.2f}, &report);
  EXPECT_LT(out.triangles.size(), mesh.triangles.size() / 2);
  EXPECT_FALSE(report.watertightBefore);
  std::set<std::tuple<float, float, float>> kept;
  for (const Float3& p : out.positions) kept.insert({p.x, p.y, p.z});
  int border = 0;
  for (const Float3& p : mesh.positions)
    if (p.x == 0 || p.y == 0 || p.x == float(n) || p.y == float(n)) {
      ++border;
      EXPECT_TRUE(kept.count({p.x, p.y, p.z})) << p.x << " " << p.y;
    }
  EXPECT_EQ(border, 4 * n);
  EXPECT_EQ(checkMesh(out).boundaryEdges, std::size_t(4 * n)) << "the border is neither moved nor coarsened";
}

}  // namespace
