// The CPU oracles of the Vulkan tests: the scalar reference evaluator on every grid point and the
// reference polygonizer's mesh, compared index by index. A GPU result is checked against these,
// never only against another GPU result.
#pragma once

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "shipped_scenes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace blobvk::testing {

// blobtree::evaluate at every grid point, in the GPU's point order.
inline std::vector<float> referenceField(const blobtree::Program& program, const blobtree::GridSpec& grid) {
  std::vector<float> f(grid.pointCount());
  const auto pts = grid.points();
  for (int k = 0; k < pts.z; ++k)
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i) f[grid.pointIndex(i, j, k)] = blobtree::evaluate(program, grid.point(i, j, k));
  return f;
}

inline float maxFieldDifference(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return INFINITY;
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

// Same vertices (edge keys), same triangles, positions within `tolerance`.
inline void expectSameMeshAsReference(const mesh::TriMesh& gpu, const mesh::TriMesh& ref, float tolerance,
                                      const std::string& what) {
  ASSERT_GT(ref.triangleCount(), 0u) << what;
  EXPECT_EQ(gpu.edgeKeys, ref.edgeKeys) << what;
  EXPECT_EQ(gpu.triangles, ref.triangles) << what;
  ASSERT_EQ(gpu.positions.size(), ref.positions.size()) << what;
  float worst = 0.0f;
  for (std::size_t i = 0; i < ref.positions.size(); ++i)
    worst = std::max({worst, std::abs(gpu.positions[i].x - ref.positions[i].x),
                      std::abs(gpu.positions[i].y - ref.positions[i].y), std::abs(gpu.positions[i].z - ref.positions[i].z)});
  EXPECT_LE(worst, tolerance) << what;
}

// Two GPU meshes of one grid made by different code (interpreter and specialised, tiled and
// untiled): the same vertices and triangles, attributes within the given bounds (0: bit for bit).
inline void expectSameMeshWithin(const mesh::TriMesh& a, const mesh::TriMesh& b, float positionTolerance,
                                 float normalTolerance, float colourTolerance, const std::string& what) {
  EXPECT_EQ(a.edgeKeys, b.edgeKeys) << what;
  EXPECT_EQ(a.triangles, b.triangles) << what;
  auto worst = [&](const auto& x, const auto& y, const char* name) {
    if (x.size() != y.size()) {
      ADD_FAILURE() << what << ": " << name << " counts differ";
      return 0.0f;
    }
    float w = 0.0f;
    for (std::size_t i = 0; i < x.size(); ++i) {
      w = std::max({w, std::abs(x[i].x - y[i].x), std::abs(x[i].y - y[i].y), std::abs(x[i].z - y[i].z)});
      if (std::isnan(x[i].x) != std::isnan(y[i].x)) w = INFINITY;
    }
    return w;
  };
  EXPECT_LE(worst(a.positions, b.positions, "positions"), positionTolerance) << what << ": positions";
  EXPECT_LE(worst(a.normals, b.normals, "normals"), normalTolerance) << what << ": normals";
  EXPECT_LE(worst(a.colours, b.colours, "colours"), colourTolerance) << what << ": colours";
}

// Vertex tolerance of a GPU mesh against the CPU reference, in cells: lavapipe's division and
// sqrt are IEEE; other drivers' sqrt, division, sin/cos and pow are not (docs/vulkan.md).
inline float referenceToleranceCells(bool cpuDevice) { return cpuDevice ? 1e-4f : 1e-2f; }

// Every array of `m` byte for byte that of `one` (another split of the same job: batches, windows,
// devices), naming `what` on a difference.
inline void expectSameBytes(const mesh::TriMesh& m, const mesh::TriMesh& one, const std::string& what) {
  EXPECT_TRUE(sameBytes(m.positions, one.positions)) << what;
  EXPECT_TRUE(sameBytes(m.normals, one.normals)) << what;
  EXPECT_TRUE(sameBytes(m.colours, one.colours)) << what;
  EXPECT_TRUE(sameBytes(m.edgeKeys, one.edgeKeys)) << what;
  EXPECT_TRUE(sameBytes(m.triangles, one.triangles)) << what;
}

}  // namespace blobvk::testing
