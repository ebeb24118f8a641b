// A mesh handed over in pieces, for meshes too large to hold whole: vertices in their final order
// a run at a time, and triangles (with final, global indices) a run at a time, each run of
// triangles coming with the vertices its corners may use. Producers (the streamed polygonizer)
// call a sink; writers (streamed_writer.h) are sinks.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::mesh {

// The vertices a run of triangles may use: global indices [first, first + a.size() + b.size()),
// held in two pieces (a producer keeps two layers of vertices, not one array).
struct VertexWindow {
  std::uint64_t first = 0;
  std::span<const Float3> a, b;

  const Float3& operator[](std::uint64_t v) const {
    const std::uint64_t i = v - first;
    return i < a.size() ? a[i] : b[i - a.size()];
  }
};

class MeshSink {
 public:
  virtual ~MeshSink() = default;
  // The next run of vertices; normals and colours are empty or as long as positions, the same
  // choice on every call.
  virtual void vertices(std::span<const Float3> positions, std::span<const Float3> normals,
                        std::span<const Float3> colours) = 0;
  // The next run of triangles; every corner lies in `window`.
  virtual void triangles(std::span<const std::array<std::uint32_t, 3>> triangles,
                         const VertexWindow& window) = 0;
};

// Hands every run to several sinks in turn (e.g. a file and a streamed check).
class TeeSink final : public MeshSink {
 public:
  explicit TeeSink(std::vector<MeshSink*> sinks) : sinks_(std::move(sinks)) {}
  void vertices(std::span<const Float3> positions, std::span<const Float3> normals,
                std::span<const Float3> colours) override {
    for (MeshSink* s : sinks_) s->vertices(positions, normals, colours);
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> triangles, const VertexWindow& window) override {
    for (MeshSink* s : sinks_) s->triangles(triangles, window);
  }

 private:
  std::vector<MeshSink*> sinks_;
};

}  // namespace blobvk::mesh
