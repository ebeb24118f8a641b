// checkMesh (checks.h) for a mesh that arrives in runs (a MeshSink), holding only the edges
// still open: an edge is judged once no later run can use it, i.e. once one of its vertices lies
// before the next run's window. For the streamed polygonizer that is one plane of edges, so
// meshes far larger than memory are checked as they are written.
#pragma once

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/mesh_sink.h"

#include <cstdint>
#include <vector>

namespace blobvk::mesh {

class StreamedMeshCheck final : public MeshSink {
 public:
  void vertices(std::span<const Float3> positions, std::span<const Float3> normals,
                std::span<const Float3> colours) override;
  // Runs must come in order: a run's corners never precede the previous run's window.
  void triangles(std::span<const std::array<std::uint32_t, 3>> triangles, const VertexWindow& window) override;
  // checkMesh's report for all runs so far. `components` counts sets of vertices joined by the
  // triangles' edges, which equals checkMesh's count of edge-connected triangle sets unless two
  // sets touch at a vertex only (a non-manifold vertex).
  MeshReport finish();

 private:
  struct HalfEdge {
    std::uint64_t key;  // (min vertex << 32) | max vertex
    bool forward;
    bool operator<(const HalfEdge& o) const { return key != o.key ? key < o.key : forward < o.forward; }
  };
  void settle(std::uint64_t limit);  // judges the edges whose lower vertex is below limit
  void judge(std::size_t uses, bool sameDirection);
  std::uint32_t find(std::uint32_t x);

  MeshReport report_;
  std::vector<HalfEdge> open_;
  std::vector<std::uint32_t> bucketEnd_;  // settle's counting sort by lower vertex ...
  std::vector<std::uint64_t> byLower_;    // ... of (higher vertex << 1 | forward) words
  std::vector<std::uint32_t> parent_;  // union-find over vertices
  std::vector<bool> referenced_;
};

}  // namespace blobvk::mesh
