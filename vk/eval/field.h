// The field of a Program at every point of a grid, computed on the GPU in z-slab bricks (a
// grid never has to fit one storage buffer). Used by `blobvk compare` and the benchmarks.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/gpu_program.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::vk {

struct FieldOptions {
  Traversal traversal = Traversal::Auto;
  std::uint32_t workgroupSize = 64;
  std::uint64_t maxBrickBytes = 64ull << 20;  // field floats per brick (also capped by the device)
  // Traversal::Specialised: code generation options (default: chosen for the device).
  const CodegenOptions* codegen = nullptr;
  // Traversal::Specialised: the grid is split into tiles with pruned kernels (vk/eval/field_tiles.h);
  // maxTiles = 1 turns it off.
  FieldTilingOptions tiling;
};

struct FieldStats {
  double seconds = 0.0;      // wall time of the GPU submits (upload excluded)
  std::uint32_t bricks = 0;
  std::uint32_t tiles = 0;   // kernels the grid was split into (vk/eval/field_tiles.h)
  std::uint64_t evaluations = 0;
};

// Field at grid.point(i, j, k), stored at grid.pointIndex(i, j, k).
std::vector<float> evaluateFieldOnGrid(Device& device, const blobtree::Program& program,
                                       const blobtree::GridSpec& grid,
                                       const FieldOptions& options = {},
                                       FieldStats* stats = nullptr);

// z layers of points per brick so that `bytesPerPoint * points` stays within the budget and the
// device's maxStorageBufferRange (at least 1).
std::uint32_t layersPerBrick(const Device& device, const blobtree::GridSpec& grid,
                             std::uint64_t maxBytes, std::uint64_t bytesPerPoint);

// The field pass of one program over one grid: its tiles and their kernels (built here, so a
// pipeline is compiled once, not at the first slab).
class FieldPass {
 public:
  // `program` must be the one `gpu` was uploaded from (its tiles' evaluators are generated with
  // gpu.codegen); `gpu`'s buffers must outlive the pass.
  FieldPass(Device& device, const blobtree::Program& program, const GpuProgram& gpu, Traversal traversal,
            std::uint32_t workgroupSize, const blobtree::GridSpec& grid, const FieldTilingOptions& tiling = {});

  // Records the field of points (i, j, k0 + l), l < layers, into `out` (slab-linear floats).
  void record(Recorder& rec, std::uint32_t k0, std::uint32_t layers, const Buffer& out) const;

  std::size_t tileCount() const { return tiles_.size(); }
  const std::vector<FieldTile>& tiles() const { return tiles_; }

 private:
  std::array<BufferRange, 5> programBindings_;
  std::uint32_t codeLength_ = 0;
  blobtree::GridSpec grid_;
  std::uint32_t workgroupSize_;
  std::vector<FieldTile> tiles_;
  std::vector<KernelPtr> kernels_;  // per tile
};

}  // namespace blobvk::vk
