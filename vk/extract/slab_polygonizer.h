// The recording layer of the GPU polygonizer, for engines that embed it: per z-slab, record the
// classify pass (field, flags, cell counts, both scans, draw arguments) and, once the counts are
// known (read back, or an upper bound), the emit pass into caller buffers.
//
// Barriers: each record* call expects nothing pending on the buffers it uses (the caller's
// earlier writes to them finished: a compute->compute or transfer->compute barrier) and ends
// with its own writes made visible to compute, transfer and indirect reads (computeBarrier).
// drawArgs() then holds a VkDrawIndexedIndirectCommand for the triangles up to this slab, then
// the running vertex and triangle counts (words 5 and 6), then the vertex pass's dispatch (words
// 7-9), the slab's own counts (words 11, 12); after recordEmit, word 10 holds its overflow bits
// (kOverflowWord, EmitOverflow).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/polygonize.h"

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
// The capacities say how many of this slab's vertices (in positions, keys, and normals/colours
// when requested) and triangles (3 indices each) the buffers hold from their start: the emit
// pass never writes past them, and reports a slab that does not fit (EmitOverflow).
struct SlabOutputs {
  BufferRange positions, normals, colours, keys, indices;
  std::uint32_t vertexCapacity = 0, triangleCapacity = 0;
};

// drawArgs() word 10 after recordEmit: which of the slab's outputs did not fit the capacities.
// Only what fits is written; an overflowing slab's triangles are left out of the indexed draw.
// Words 11 and 12: the slab's own vertex and triangle counts (after recordClassify).
inline constexpr std::uint32_t kOverflowWord = 10;
inline constexpr std::uint32_t kDrawArgsWords = 16;
struct EmitOverflow {
  bool vertices = false, triangles = false;
  explicit operator bool() const { return vertices || triangles; }
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
  // The overflow bits of the last emit pass, read back (its command buffer must have completed,
  // with Recorder::hostBarrier after recordEmit).
  EmitOverflow readOverflow() const;

 private:
  Device& device_;
  blobtree::GridSpec grid_;
  GpuPolygonizeOptions options_;
  GpuProgram program_;
  std::unique_ptr<FieldPass> fieldPass_;  // reads program_'s buffers
  // With field tiles, the vertex pass runs per tile too, each with the evaluator pruned to the
  // points its vertices need (tile_rows, a scan, tile_args, vertices_tiled); empty: one pass.
  std::vector<KernelPtr> vertexTileKernels_;
  Buffer rowScan_, tileArgs_;

  struct VertexPush;
  VertexPush vertexPush(const SlabPlan& p, std::uint32_t vertexBase, std::uint32_t vertexCapacity) const;
  void recordTiledVertices(Recorder& rec, const SlabPlan& p, std::uint32_t vertexBase, const SlabOutputs& out);
  void recordEmitLimits(Recorder& rec, const SlabOutputs& out);
  Buffer cases_, field_, flags_, vertexOffsets_, triOffsets_, scratch_, totals_, args_;
  std::uint32_t slabCells_ = 0, slabs_ = 0;
  std::uint32_t pointScratch_ = 0;  // scratch words used by the vertex scan
};

}  // namespace blobvk::vk
