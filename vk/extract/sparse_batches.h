// The sparse extraction's batches of brick layers (docs/vulkan.md, "Sparse extraction"): how the
// classified active bricks are cut into batches, and the per-device machinery that runs one
// batch (field, masks, rows, scans, vertices, triangles, read-back). A batch is an independent
// unit of work: given the classification (the scanned brick flags and the active-brick list) it
// produces its vertices and its triangles with indices counted from its own first vertex, so
// batches can run on any device in any order and be joined in batch order (multi_device.h).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace blobvk::vk {

// Whole brick layers run together, holding one layer more than they emit: a triangle of the last
// layer may use a vertex that the next layer's bricks own, whose index comes from that layer's
// scanned segments.
//
// Where two layers hold more active bricks than one storage buffer, a batch is one layer alone
// with *keyed corners*: it does not load the next layer, its triangles come back as their
// corners' edge keys (shaders/brick_triangle_keys.comp), and the host finds each corner among
// its own and the next batch's vertices by key (runSparseExtraction).
struct SparseBatch {
  std::uint32_t activeBase = 0;    // the batch's first active brick (in (bz, by, bx) order)
  std::uint32_t ownActive = 0;     // active bricks whose vertices and triangles it emits
  std::uint32_t loadedActive = 0;  // ... plus the next layer's, whose segments it scans
  std::uint32_t firstLayer = 0, endLayer = 0;  // the brick layers [first, end) it emits
  bool keyedCorners = false;       // one layer, the next not loaded: triangles as corner keys
};

// What planSparseBatches does with a layer whose pair with the next is over one storage buffer.
enum class KeyedBatches {
  Refuse,  // throw (the callers that cannot match keys: several devices, edits)
  Allow,   // that layer alone, with keyed corners
  Force,   // every batch one layer with keyed corners (tests)
};

// Active bricks per batch that fit `device`: its storage-buffer range and a quarter of its
// largest device-local heap (or `maxBatchBricks` when that is smaller and not 0).
std::uint64_t sparseBatchLimit(Device& device, const BrickGrid& bricks, std::uint32_t maxBatchBricks);
// Device bytes a batch brick takes (its samples, masks, point words, segments, lists).
std::uint64_t sparseBrickBytes(const BrickGrid& bricks);

// Cuts the active bricks into batches of whole layers of at most `limit` loaded bricks (a batch
// of one layer may load more: it throws when that is over `rangeBricks`, what one storage buffer
// holds, or with `keyed` Allow is that layer alone with keyed corners). `layerStarts[z]` is the
// first active brick of layer z, `layerStarts[layers]` the count.
// `ownTarget` (several devices): a batch also ends at the layer boundary nearest to that many
// bricks of its own, so the batches carry about equal work. A batch ends at each layer of
// `ends` (ascending; the classification's windows, ClassifiedBricks::windowEnds).
std::vector<SparseBatch> planSparseBatches(std::span<const std::uint32_t> layerStarts, std::uint64_t limit,
                                           std::uint64_t rangeBricks, std::uint64_t ownTarget = ~0ull,
                                           std::span<const std::uint32_t> ends = {},
                                           KeyedBatches keyed = KeyedBatches::Refuse);
// What one storage buffer can hold, in active bricks of `bricks`' size, on `device`.
std::uint64_t sparseRangeBricks(Device& device, const BrickGrid& bricks);

// Whether per-brick vertex tapes go to uniform blocks by windows of bricks on `device`
// (GpuPolygonizeOptions::brickTapeUniforms, a CPU device whose uniform range holds a block): from
// there llvmpipe interprets them 2.4-5x faster than from a storage buffer.
bool vertexTapesInWindows(const Device& device, const GpuPolygonizeOptions& options);

// A device buffer of `size` bytes (at least 16) for the sparse extraction's `what`, added to
// `bytes`; throws naming `what` when it is over the device's maxStorageBufferRange.
Buffer makeSparseBuffer(Device& device, std::uint64_t size, const char* what, std::uint64_t& bytes);

// Runs batches on one device. The brick tables are the classification's windows (scanned flags
// and active-brick list; ClassifiedBricks::windows) on this device, each batch within one; they
// and the device must outlive the runner.
// `traversal` must be resolved (not Auto) and the same on every device of a job.
class SparseBatchRunner {
 public:
  SparseBatchRunner(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                    const GpuPolygonizeOptions& options, Traversal traversal, const BrickGrid& bricks,
                    std::span<const ScanWindow> windows, std::uint32_t maxLoaded, std::uint32_t maxBatches);
  ~SparseBatchRunner();
  SparseBatchRunner(const SparseBatchRunner&) = delete;
  SparseBatchRunner& operator=(const SparseBatchRunner&) = delete;

  // Two submits (three where the device writes the sources and the host lists the vertex tiles): appends the batch's vertices (positions, normals, colours, edge keys) and its
  // triangles, indices offset by `vertexBase`, to `out`. Adds to the stats' field evaluations,
  // submits and wall-time phases. At most `maxBatches` calls. With `cornerKeys`, the triangles'
  // corners are appended there as edge keys (three per triangle, out.triangles untouched): for a
  // run whose bricks' upper neighbours are not loaded (an edit's box of bricks). `reserveRatio`
  // > 1: where an array of `out` must move to grow, it is given that many times the size it
  // grows to (later batches will append to it: no second move and copy of what it holds).
  void run(const SparseBatch& batch, std::uint64_t vertexBase, mesh::TriMesh& out, GpuStats& stats,
           std::vector<std::uint64_t>* cornerKeys = nullptr, double reserveRatio = 1.0);
  // Device time of the batches run (when the queue has timestamps): replaces the stats' field
  // and extract seconds with it and adds the read-back copies; returns false without timestamps.
  bool deviceTimes(GpuStats& stats);
  // Device bytes: the per-brick buffers, and the largest batch's outputs.
  std::uint64_t sharedBytes() const;
  std::uint64_t peakOutputBytes() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace blobvk::vk
