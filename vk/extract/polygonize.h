// GPU marching cubes: the field in z-slab bricks, edge-crossing flags, two prefix sums (vertex
// and triangle offsets), vertices on crossing edges in global edge-key order (welded), and
// triangles in cell order then case-table order: the same mesh as cpu::polygonizeReference,
// index by index, wherever the two classify the grid points alike.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/eval/gpu_program.h"

#include <cstdint>

namespace blobvk::vk {

struct GpuPolygonizeOptions {
  bool normals = true;
  bool colours = true;
  int refineSteps = 0;         // regula-falsi steps after the linear interpolation
  float normalStep = 1e-4f;    // central-difference step (blobtree::normal's default)
  Traversal traversal = Traversal::Auto;  // Auto: the cost model's choice (vk/eval/evaluator_choice.h)
  // Traversal::Specialised: code generation options (default: chosen for the device).
  const CodegenOptions* codegen = nullptr;
  std::uint32_t workgroupSize = 64;
  std::uint64_t maxBrickBytes = 32ull << 20;  // per-slab field bytes; smaller means more slabs
  // Traversal::Specialised: the field pass's tiles with pruned kernels (vk/eval/field_tiles.h); 1 = off.
  std::uint32_t maxFieldTiles = 8;
  // With field tiles, run the vertex pass per tile too, with the evaluator pruned to each tile.
  // Off by default: a vertex kernel inlines the evaluator 8 times and takes 0.1-0.16 s to build
  // on lavapipe (a field tile kernel ~0.035 s), while it saves ~30 % of the emit pass (tower at
  // 128 cells: 57 -> 40 ms) — worth it only when a polygonizer is used many times (an engine
  // re-extracting every frame), not for one mesh.
  bool tiledVertexPass = false;
};

struct GpuStats {
  double seconds = 0.0;          // wall time of all submits and readbacks
  double classifySeconds = 0.0;  // field, flags, cell counts, scans
  double emitSeconds = 0.0;      // vertices (with normals/colours) and triangles
  std::uint32_t bricks = 0;
  std::uint32_t fieldTiles = 0;        // field and vertex passes run per tile (vk/eval/field_tiles.h)
  std::uint64_t fieldEvaluations = 0;  // grid samples (normals/colours/refinement excluded)
};

mesh::TriMesh polygonize(Device& device, const blobtree::Program& program,
                         const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options = {},
                         GpuStats* stats = nullptr);

}  // namespace blobvk::vk
