// The recording layer of the GPU polygonizer, for engines that embed it: per z-slab, record the
// classify pass (field, flags, cell counts, both scans, draw arguments) and, once the counts are
// known (read back, or an upper bound), the emit pass into caller buffers.
//
// Barriers: each record* call expects nothing pending on the buffers it uses (the caller's
// earlier writes to them finished: a compute->compute or transfer->compute barrier) and ends
// with its own writes made visible to compute, transfer and indirect reads (computeBarrier).
// drawArgs() then holds a VkDrawIndexedIndirectCommand for the triangles up to this slab, then
// the running vertex and triangle counts (words 5 and 6), then the vertex pass's dispatch (words 7-9).
#pragma once

#include "blobtree/grid.h"
#include "vk/field.h"
#include "vk/gpu_program.h"
#include "vk/polygonize.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace blobvk::vk {

struct SlabPlan {
  std::uint32_t k0 = 0;          // first cell layer (= first point layer)
  std::uint32_t cellLayers = 0;  // cells k0 .. k0 + cellLayers - 1
  bool last = false;             // owns the top point layer too
  std::uint64_t ownedPoints = 0;
  std::uint64_t cells = 0;
};

// Where the emit pass writes: float3 arrays (tightly packed), per-vertex slab-local edge keys
// (local point index * 3 + axis) and uint32 triangle indices (global: vertexBase added).
struct SlabOutputs {
  BufferRange positions, normals, colours, keys, indices;
};

class SlabPolygonizer {
 public:
  SlabPolygonizer(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                  const GpuPolygonizeOptions& options);

  std::uint32_t slabCount() const { return slabs_; }
  std::uint32_t fieldTileCount() const { return std::uint32_t(fieldPass_->tileCount()); }
  SlabPlan plan(std::uint32_t slab) const;
  const Buffer& drawArgs() const { return args_; }

  void recordClassify(Recorder& rec, std::uint32_t slab, std::uint32_t vertexBase,
                      std::uint32_t triangleBase);
  void recordEmit(Recorder& rec, std::uint32_t slab, std::uint32_t vertexBase,
                  const SlabOutputs& out);

 private:
  Device& device_;
  blobtree::GridSpec grid_;
  GpuPolygonizeOptions options_;
  GpuProgram program_;
  std::unique_ptr<FieldPass> fieldPass_;  // reads program_'s buffers
  // With field tiles, the vertex pass runs per tile too, each with the evaluator pruned to the
  // points its vertices need (tile_rows, a scan, tile_args, vertices_tiled); empty: one pass.
  std::vector<const Kernel*> vertexTileKernels_;
  Buffer rowScan_, tileArgs_;

  struct VertexPush;
  VertexPush vertexPush(const SlabPlan& p, std::uint32_t vertexBase) const;
  void recordTiledVertices(Recorder& rec, const SlabPlan& p, std::uint32_t vertexBase, const SlabOutputs& out);
  Buffer cases_, field_, flags_, vertexOffsets_, triOffsets_, scratch_, totals_, args_;
  std::uint32_t slabCells_ = 0, slabs_ = 0;
  std::uint32_t pointScratch_ = 0;  // scratch words used by the vertex scan
};

}  // namespace blobvk::vk
