// A mesh sink for tests of streamed extraction: joins the runs into one mesh and counts every
// triangle corner outside the window it came with, as a file writer or the streamed check would
// read it.
#pragma once

#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/mesh/trimesh.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

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

}  // namespace blobvk::testing
