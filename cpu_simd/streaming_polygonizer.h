// Out-of-core polygonization: polygonizeMpu's mesh produced one layer of MPUs at a time (the
// MPUs with one z index) and handed to a mesh::MeshSink, so memory holds two layers, not the
// mesh. Global vertex order is z-major edge-key order and triangles are in cell order, so a
// layer's vertices and its triangles are each one contiguous run of the output; a layer's top
// cells use vertices of the layer above, so its triangles are emitted once that layer exists.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/mesh/mesh_sink.h"
#include "blobvk/mesh/trimesh.h"

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

namespace blobvk::cpu {

// One MPU layer's share of the mesh, in plain arrays (it can be computed anywhere, e.g. on
// another MPI rank, and joined in order): the vertices it owns in global order, the triangles of
// its cells in cell order with corner indices relative to the layer's first vertex. Corners on
// vertices of the layer above are listed in `above` and hold 0 until the join resolves them.
struct MeshLayer {
  struct AboveCorner {
    std::uint64_t slot;  // triangle * 3 + corner
    std::uint64_t key;   // the grid edge (blobtree::GridSpec::edgeKey) the vertex lies on
  };
  int z = 0;
  std::vector<mesh::Float3> positions, normals, colours;
  std::vector<std::uint64_t> keys;  // edge keys, ascending
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<AboveCorner> above;

  std::size_t bytes() const;  // heap bytes held
};

// Computes the layers of a grid one at a time, each in parallel over its MPUs on
// MpuOptions::threads; the MPUs' results are polygonizeMpu's bit for bit.
class LayerPolygonizer {
 public:
  LayerPolygonizer(const blobtree::Program& program, const blobtree::GridSpec& grid, const MpuOptions& options);
  ~LayerPolygonizer();
  LayerPolygonizer(const LayerPolygonizer&) = delete;
  LayerPolygonizer& operator=(const LayerPolygonizer&) = delete;

  int layerCount() const;  // MPUs along z (0 for an empty grid)
  MeshLayer layer(int z);  // 0 <= z < layerCount(), in any order
  // How many of `layer`'s first vertices lie on its bottom plane of grid points: the only ones
  // the layer below refers to (its `above` corners), so whoever joins that layer needs these
  // keys and positions, not the whole layer (keys are z-major, so the plane is a prefix).
  std::size_t bottomVertices(const MeshLayer& layer) const;
  // Evaluation and MPU counts summed over the layers computed so far (no phase times).
  const MpuStats& stats() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Joins layers pushed in order 0, 1, 2, ... into a sink: a layer's vertices go out when it is
// pushed, its triangles when the next layer is (their `above` corners found by edge key among
// that layer's vertices) or at finish(). Throws std::length_error past 2^31 vertices (the int
// indices of PLY and the in-memory mesh's limit).
class LayerJoiner {
 public:
  explicit LayerJoiner(mesh::MeshSink& sink);
  ~LayerJoiner();
  void push(MeshLayer layer);
  void finish();
  std::uint64_t vertices() const { return nextVertex_; }
  std::uint64_t triangles() const { return triangles_; }
  std::size_t peakBytes() const { return peakBytes_; }  // most bytes held in layers at once

 private:
  void emitPending(const MeshLayer* above, std::uint64_t aboveFirst);

  mesh::MeshSink& sink_;
  std::optional<MeshLayer> pending_;
  std::uint64_t pendingFirst_ = 0, nextVertex_ = 0, triangles_ = 0;
  std::size_t peakBytes_ = 0;
};

// The piece of polygonizeMpu's mesh that layers [first, end) own, as one array (a batch of the
// Vulkan sparse extraction computed on the host, vk/extract/multi_device.h): their vertices in
// global order, their triangles in cell order with indices counted from the piece's first
// vertex; corners on the next layer's vertices continue the count past the piece's own (the
// next piece's first vertices). Computes layer `end` as well when a triangle needs it.
mesh::TriMesh polygonizeLayerRange(LayerPolygonizer& layers, int first, int end);

// polygonizeMpu's mesh for `grid`, streamed into `sink` layer by layer: concatenated, the vertex
// runs are its vertices and the triangle runs its triangles. MpuOptions::progress reports
// finished layers. Peak memory: about three layers' results plus per-layer row tables.
MpuStats polygonizeMpuStreamed(const blobtree::Program& program, const blobtree::GridSpec& grid,
                               const MpuOptions& options, mesh::MeshSink& sink);

}  // namespace blobvk::cpu
