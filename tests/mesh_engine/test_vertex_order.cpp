// Vertex-cache / fetch ordering keeps the surface: the same triangles (as position triples, up to
// rotation, which keeps the winding), watertight, the same volume; and improves the cache figure.
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/engine/vertex_order.h"
#include "shipped_mesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <tuple>
#include <vector>

namespace {

using namespace blobvk::mesh;

// Each triangle as its corner positions rotated so the smallest comes first (winding kept).
std::vector<std::array<std::tuple<float, float, float>, 3>> canonicalTriangles(const TriMesh& m) {
  std::vector<std::array<std::tuple<float, float, float>, 3>> out;
  for (const auto& t : m.triangles) {
    std::array<std::tuple<float, float, float>, 3> c;
    for (int k = 0; k < 3; ++k) {
      const Float3& p = m.positions[t[std::size_t(k)]];
      c[std::size_t(k)] = {p.x, p.y, p.z};
    }
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(VertexOrder, KeepsTheSurfaceAndImprovesTheCache) {
  const TriMesh mesh = shippedMesh("random128", 48);
  TriMesh ordered = mesh;
  const VertexOrderReport report = optimizeVertexOrder(ordered);
  EXPECT_EQ(ordered.positions.size(), mesh.positions.size());
  EXPECT_EQ(canonicalTriangles(ordered), canonicalTriangles(mesh));
  const MeshReport a = checkMesh(mesh), b = checkMesh(ordered);
  EXPECT_TRUE(b.watertight()) << b.summary();
  EXPECT_NEAR(b.volume, a.volume, 1e-9 * a.volume);
  EXPECT_LT(report.acmrAfter, report.acmrBefore);
  EXPECT_LT(report.acmrAfter, 0.8f);  // meshoptimizer reaches ~0.65-0.7 on grid-like meshes
  // Normals and colours followed their vertices.
  for (std::size_t v = 0; v < ordered.positions.size(); v += 97) {
    const auto it = std::find(mesh.positions.begin(), mesh.positions.end(), ordered.positions[v]);
    ASSERT_NE(it, mesh.positions.end());
    const std::size_t was = std::size_t(it - mesh.positions.begin());
    EXPECT_EQ(ordered.normals[v], mesh.normals[was]);
    EXPECT_EQ(ordered.colours[v], mesh.colours[was]);
  }
  // The first vertex used is vertex 0, the next new one vertex 1, ...: first-use (fetch) order.
  std::uint32_t next = 0;
  for (const auto& t : ordered.triangles)
    for (std::uint32_t v : t) {
      ASSERT_LE(v, next);
      if (v == next) ++next;
    }
}

}  // namespace
