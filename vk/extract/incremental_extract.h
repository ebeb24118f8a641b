// Re-meshing on Vulkan after an edit (blobtree/edit.h): an update classifies and re-runs only the
// box of bricks whose grid points, edges (their vertices, refinement and normal samples) or
// cells the edit's region can reach, through the sparse batch runner (sparse_batches.h) with every
// brick outside the box inactive, and splices the box's rows into the previous mesh
// (row_splice.h): in global order the vertices of the box's points on one point row are one
// contiguous run of the mesh, and so are the triangles of its cells on one cell row. The mesh
// after every update is byte-identical to vk::polygonize of the edited Program on the same grid
// with the same evaluator (tests/vk/test_incremental_extract.cpp).
//
// The grid is fixed for the session, as for cpu::IncrementalPolygonizer.
#pragma once

#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/row_splice.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>
#include <memory>

namespace blobvk::vk {

struct IncrementalGpuStats {
  std::uint32_t layers = 0;       // brick layers (z) of the grid
  std::uint32_t layersRerun = 0;  // brick layers the re-run box spans
  std::uint32_t firstLayer = 0;   // the first of them
  std::uint32_t bricks = 0;       // bricks of the grid
  std::uint32_t bricksRerun = 0;  // bricks of the re-run box (classified again; the active ones re-run)
  BrickBox box;                   // the re-run box
  bool full = false;              // the region reached every brick: the whole grid was re-meshed
  std::uint64_t verticesMoved = 0, trianglesMoved = 0;  // kept elements moved by the splice
  std::uint64_t cornersByKey = 0;  // kept triangles' corners on the box's rows, found again by key
  // The vertices and triangles whose bytes may differ from the mesh before (all after a reset):
  // what a copy of the mesh elsewhere must rewrite (vk/render/incremental_draw.h).
  ChangedRange verticesChanged, trianglesChanged;
  // Wall-clock per phase (ms): the box's classification (one submit), its batches (program
  // upload, field, extraction, read-back), the splice.
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
  // answer). Re-runs the bricks whose points, edges, normal samples or cells the region can
  // reach (bricksReached), and splices. Throws std::logic_error before the first reset.
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

// The box of bricks an edit's region forces to be extracted again: per axis, every brick owning
// a grid point whose edges (their vertices, refinement and normal samples, `normalStep` away)
// the region reaches, or holding a cell one of whose corners it reaches. Every other brick keeps
// its cells' configurations and its points' vertices bit for bit (row_splice.h says why that
// is enough). Empty when the region misses the grid; the whole grid for a region of everything.
BrickBox bricksReached(const blobtree::GridSpec& grid, const BrickGrid& bricks, const blobtree::Region& region,
                       float normalStep);

}  // namespace blobvk::vk
