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

// Collapses through the die's pips open it at some error bounds (2 %: 230 triangles, 99 %: none
// at all), and the guard backs off. The oracle is the request's order: a looser bound may not keep
// more triangles (backing off once jumped to half the mesh), every result is closed with the
// input's topology, within the bound asked for, and the report says when it backed off.
TEST(Simplify, ALooserErrorBoundNeverKeepsMoreTriangles) {
  const TriMesh mesh = shippedMesh("dice", 48);
  const MeshReport before = checkMesh(mesh);
  ASSERT_TRUE(before.watertight()) << before.summary();
  std::size_t previous = mesh.triangles.size();
  int backedOff = 0;
  for (const char* bound : {"0.5%", "1%", "2%", "5%", "10%", "50%", "99%", "100%"}) {
    const SimplifyTarget target = parseSimplifyTarget(bound);
    SimplifyReport report;
    const TriMesh out = simplifyMesh(mesh, target, &report);
    const MeshReport after = checkMesh(out);
    EXPECT_TRUE(after.watertight()) << bound << ": " << after.summary();
    EXPECT_EQ(after.eulerCharacteristic, before.eulerCharacteristic) << bound;
    EXPECT_EQ(after.components, before.components) << bound;
    EXPECT_FALSE(report.keptInput) << bound;
    EXPECT_LE(report.error, target.value * 1.0001f) << bound << ": " << report.summary();
    EXPECT_LE(out.triangles.size(), previous) << bound << ": " << report.summary();
    EXPECT_LT(out.triangles.size(), mesh.triangles.size() / 20) << bound << ": " << report.summary();
    if (report.backedOff) {
      ++backedOff;
      EXPECT_GT(out.triangles.size(), report.trianglesFirstTry) << bound;
      EXPECT_NE(report.summary().find("backed off"), std::string::npos) << report.summary();
    } else {
      EXPECT_EQ(report.attempts, 1) << bound;
      EXPECT_EQ(report.summary().find("backed off"), std::string::npos) << report.summary();
    }
    previous = out.triangles.size();
  }
  EXPECT_GT(backedOff, 0) << "the sweep no longer exercises backing off: pick bounds that open the die";
}

// The same order for ratios: a tiny ratio that opens the die backs off to a handful of triangles,
// not to half of them.
TEST(Simplify, ALargerRatioNeverKeepsFewerTriangles) {
  const TriMesh mesh = shippedMesh("dice", 48);
  std::size_t previous = 0;
  for (const float ratio : {0.0001f, 0.0002f, 0.001f, 0.005f, 0.01f, 0.05f, 0.25f}) {
    SimplifyReport report;
    const TriMesh out = simplifyMesh(mesh, {SimplifyTarget::Kind::Ratio, ratio}, &report);
    EXPECT_TRUE(checkMesh(out).watertight()) << ratio;
    EXPECT_GE(out.triangles.size(), previous) << ratio << ": " << report.summary();
    EXPECT_LT(out.triangles.size(), std::max<std::size_t>(100, std::size_t(2.0 * ratio * double(mesh.triangles.size()))))
        << ratio << ": " << report.summary();
    previous = out.triangles.size();
  }
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
