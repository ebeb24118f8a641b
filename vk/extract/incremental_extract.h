// Re-meshing on Vulkan after an edit (blobtree/edit.h): the sparse extraction's output is laid
// out by brick layers (docs/vulkan.md, "Sparse extraction"): the vertices of a run of brick
// layers are one contiguous run of the mesh (global edge-key order) and so are their triangles
// (cell order). An update re-classifies the bricks, re-runs only the brick layers the edit's
// region can reach through the sparse batch runner (sparse_batches.h) and splices their piece
// into the previous mesh: the vertices and triangles after it move by the change in count, and
// the triangles after it shift their corners by the change in vertex count. The mesh after
// every update is byte-identical to vk::polygonize of the edited Program on the same grid with
// the same evaluator (tests/vk/test_incremental_extract.cpp).
//
// The grid is fixed for the session, as for cpu::IncrementalPolygonizer.
#pragma once

#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/extract/polygonize.h"

#include <cstdint>
#include <memory>

namespace blobvk::vk {

struct IncrementalGpuStats {
  std::uint32_t layers = 0;       // brick layers (z) of the grid
  std::uint32_t layersRerun = 0;  // brick layers extracted again
  std::uint32_t firstLayer = 0;   // the first of them
  bool full = false;              // the region reached every layer: the whole grid was re-meshed
  std::uint64_t verticesMoved = 0, trianglesMoved = 0;  // kept elements moved by the splice
  // Wall-clock per phase (ms): the bricks' classification (whole grid, one submit), the re-run
  // layers' batches (program upload, field, extraction, read-back), the splice.
  double msClassify = 0, msExtract = 0, msSplice = 0, msTotal = 0;
  GpuStats gpu;  // the re-run's own counters (batches, submits, active bricks, device times)
};

class IncrementalExtractor {
 public:
  // `options` must ask for the sparse extraction (throws VulkanError otherwise). With
  // Traversal::Auto each run takes the cost model's evaluator (vk/eval/evaluator_choice.h) for
  // the bricks it re-runs, counting the build of a specialised kernel, which every edit's
  // Program needs anew: a small edit interprets, a large one of a long program may build. The
  // bytes stay a full run's: on lavapipe the interpreter and the generated code agree bit for bit
  // (docs/vulkan.md), and off CPU drivers the model keeps the specialised code for every run. An
  // explicit traversal is used for every run. The device must outlive the extractor.
  IncrementalExtractor(Device& device, const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options = {});
  ~IncrementalExtractor();
  IncrementalExtractor(const IncrementalExtractor&) = delete;
  IncrementalExtractor& operator=(const IncrementalExtractor&) = delete;

  // Extracts the whole grid and keeps the mesh and its per-layer offsets.
  const mesh::TriMesh& reset(const blobtree::Program& program, IncrementalGpuStats* stats = nullptr);

  // `program` differs from the previous one only inside `region` (EditableTree::apply's
  // answer). Re-runs the brick layers whose points, edges, normal samples or cells the region
  // can reach, and splices. Throws std::logic_error before the first reset.
  const mesh::TriMesh& update(const blobtree::Program& program, const blobtree::Region& region,
                              IncrementalGpuStats* stats = nullptr);

  const mesh::TriMesh& mesh() const;
  const blobtree::GridSpec& grid() const;
  // The options every run of the session uses: a full vk::polygonize with them gives the same bytes.
  const GpuPolygonizeOptions& options() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The brick layers [first, end) an edit's region forces to be extracted again on a grid of
// `layers` layers of `brickCells` cells: every layer holding a grid point, an edge (its vertex,
// refinement and normal samples, `normalStep` away) or a cell the region reaches, and the layer
// below, whose first point layer's vertex numbers the previous layer's triangles use. Empty
// (first == end) when the region misses the grid.
struct LayerRange {
  std::uint32_t first = 0, end = 0;
};
LayerRange layersReached(const blobtree::GridSpec& grid, std::uint32_t brickCells, std::uint32_t layers,
                         const blobtree::Region& region, float normalStep);

}  // namespace blobvk::vk
