// A mesh sink for tests of streamed extraction: joins the runs into one mesh and counts every
// triangle corner outside the window it came with, as a file writer or the streamed check would
// read it.
#pragma once

#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/mesh/trimesh.h"
#include "reference_checks.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

namespace blobvk::testing {

class JoiningSink final : public mesh::MeshSink {
 public:
  mesh::TriMesh mesh;
  std::size_t vertexRuns = 0, triangleRuns = 0, largestWindow = 0, outsideWindow = 0, wrongWindowVertex = 0;

  void vertices(std::span<const mesh::Float3> p, std::span<const mesh::Float3> n,
                std::span<const mesh::Float3> c) override {
    ++vertexRuns;
    mesh.positions.insert(mesh.positions.end(), p.begin(), p.end());
    mesh.normals.insert(mesh.normals.end(), n.begin(), n.end());
    mesh.colours.insert(mesh.colours.end(), c.begin(), c.end());
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> t, const mesh::VertexWindow& w) override {
    ++triangleRuns;
    const std::uint64_t size = w.a.size() + w.b.size();
    largestWindow = std::max<std::size_t>(largestWindow, size);
    for (const auto& tri : t) {
      for (std::uint32_t v : tri) {
        if (v < w.first || v >= w.first + size || v >= mesh.positions.size()) {
          ++outsideWindow;
        } else if (!(w[v] == mesh.positions[v])) {
          ++wrongWindowVertex;
        }
      }
    }
    mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  }
};

// What every streamed job's runs must be: one vertex run and one triangle run per batch, every
// corner inside the window it came with, and joined, the bytes of `whole` (the same job in
// memory; a sink gets no edge keys).
inline void expectJoinedRuns(const JoiningSink& sink, std::size_t batches, const mesh::TriMesh& whole, const std::string& what) {
  EXPECT_EQ(sink.vertexRuns, batches) << what;
  EXPECT_EQ(sink.triangleRuns, batches) << what;
  EXPECT_EQ(sink.outsideWindow, 0u) << what;
  EXPECT_EQ(sink.wrongWindowVertex, 0u) << what;
  EXPECT_TRUE(sameBytes(sink.mesh.positions, whole.positions)) << what;
  EXPECT_TRUE(sameBytes(sink.mesh.normals, whole.normals)) << what;
  EXPECT_TRUE(sameBytes(sink.mesh.colours, whole.colours)) << what;
  EXPECT_EQ(sink.mesh.triangles, whole.triangles) << what;
}

}  // namespace blobvk::testing
