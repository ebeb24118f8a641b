#include "blobvk/vk/extract/sparse_batches.h"

#include "blobvk/vk/device/concurrent_builds.h"
#include "blobvk/vk/device/device_timer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/uniform_program.h"
#include "blobvk/vk/extract/brick_tapes.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/case_table.h"
#include "blobvk/vk/extract/host_copy.h"
#include "blobvk/vk/extract/host_row_passes.h"
#include "blobvk/vk/extract/host_scan.h"
#include "blobvk/vk/extract/host_triangles.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/row_culling.h"
#include "blobvk/vk/extract/scan.h"
#include "blobvk/vk/extract/vertex_tile_lists.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstring>
#include <functional>
#include <future>
#include <string>
#include <type_traits>

namespace blobvk::vk {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Work groups in y and z for one index per active brick (y <= 65535).
struct BrickGroups {
  std::uint32_t y = 1, z = 1;
};
BrickGroups brickGroups(std::uint32_t bricks) {
  BrickGroups g;
  g.y = std::max<std::uint32_t>(1, std::min<std::uint32_t>(bricks, 65535));
  g.z = (bricks + g.y - 1) / g.y;
  return g;
}

}  // namespace

std::uint64_t sparseBrickBytes(const BrickGrid& bricks) {
  const std::uint64_t B = 1ull << bricks.log2B, R = B + 1;
  const std::uint64_t S = std::max<std::uint64_t>(B, 4);  // floats a row of samples takes (brick_field.comp)
  return R * R * (S + 1) * 4  // field samples
         + R * R * R * 4      // point words
         + R * R * 8       // inside masks, vertex segments
         + R * R * 12      // row culling's lists (llvmpipe): field pass entries (8 bytes), one-sided rows
         + B * B * 4       // triangle segments
         + 32 + 16         // the brick's neighbours and its segment record
         + 4;              // its place in the field tiles' order
}

namespace {

// Device memory a batch of bricks may take: a quarter of the largest device-local heap.
std::uint64_t sparseBatchBudget(Device& device) {
  const auto& mp = device.memory().properties();
  std::uint64_t largest = 0;
  for (std::uint32_t h = 0; h < mp.memoryHeapCount; ++h) {
    if (mp.memoryHeaps[h].flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) largest = std::max(largest, mp.memoryHeaps[h].size);
  }
  return std::max<std::uint64_t>(largest / 4, 64ull << 20);
}

}  // namespace

Buffer makeSparseBuffer(Device& device, std::uint64_t size, const char* what, std::uint64_t& bytes) {
  const std::uint64_t range = device.info().limits.maxStorageBufferRange;
  if (size > range) {
    throw VulkanError(std::string("GPU polygonizer: the sparse extraction's ") + what + " need " +
                      std::to_string(size >> 20) + " MiB, over the device's maxStorageBufferRange (" +
                      std::to_string(range >> 20) + " MiB): use a smaller grid");
  }
  bytes += std::max<std::uint64_t>(size, 16);
  return device.createBuffer(std::max<std::uint64_t>(size, 16));
}

std::uint64_t sparseRangeBricks(Device& device, const BrickGrid& bricks) {
  const std::uint64_t R = (1ull << bricks.log2B) + 1;
  const std::uint64_t range = device.info().limits.maxStorageBufferRange;
  const std::uint64_t S = std::max<std::uint64_t>(R - 1, 4);  // floats a row of samples takes
  // The field samples (R^3 floats from B = 4 on) and point words: the largest per-brick arrays.
  return range / (std::max(R * R * (S + 1), R * R * R) * 4);
}

std::uint64_t sparseBatchLimit(Device& device, const BrickGrid& bricks, std::uint32_t maxBatchBricks) {
  return std::min<std::uint64_t>(sparseRangeBricks(device, bricks),
                                 maxBatchBricks ? maxBatchBricks
                                                : std::max<std::uint64_t>(1, sparseBatchBudget(device) / sparseBrickBytes(bricks)));
}

std::vector<SparseBatch> planSparseBatches(std::span<const std::uint32_t> starts, std::uint64_t limit,
                                           std::uint64_t rangeBricks, std::uint64_t ownTarget,
                                           std::span<const std::uint32_t> ends, KeyedBatches keyed) {
  std::vector<SparseBatch> batches;
  const std::uint32_t layers = std::uint32_t(starts.size()) - 1;
  for (std::uint32_t z = 0; z < layers;) {
    if (starts[z + 1] == starts[z]) {
      ++z;
      continue;
    }
    auto loaded = [&](std::uint32_t end) { return starts[std::min(end + 1, layers)] - starts[z]; };
    auto own = [&](std::uint32_t end) -> std::uint64_t { return starts[end] - starts[z]; };
    // One more layer when it brings the batch's own bricks nearer the target.
    auto nearer = [&](std::uint32_t end) {
      if (own(end + 1) <= ownTarget) return true;
      return own(end) < ownTarget && own(end + 1) - ownTarget < ownTarget - own(end);
    };
    auto mustEnd = [&](std::uint32_t end) { return std::binary_search(ends.begin(), ends.end(), end); };
    std::uint32_t end = z + 1;
    const bool alone = keyed == KeyedBatches::Force || (keyed == KeyedBatches::Allow && loaded(end) > rangeBricks);
    if (alone && own(end) <= rangeBricks) {
      batches.push_back({starts[z], starts[end] - starts[z], starts[end] - starts[z], z, end, true});
      z = end;
      continue;
    }
    while (end < layers && !mustEnd(end) && loaded(end + 1) <= limit && nearer(end)) ++end;
    if (loaded(end) > rangeBricks) {
      throw VulkanError(std::string("GPU polygonizer: ") + (alone ? "a brick layer holds " : "two brick layers hold ") +
                        std::to_string(alone ? own(end) : loaded(end)) +
                        " active bricks, over the " + std::to_string(rangeBricks) +
                        " one storage buffer can hold (maxStorageBufferRange): use a smaller grid or bricks");
    }
    batches.push_back({starts[z], starts[end] - starts[z], loaded(end), z, end});
    z = end;
  }
  return batches;
}

// Device timestamps per batch: field, masks and edges, scans | (second submit) sources,
// vertices, triangles, read-back copies; mark 9 opens the vertex pass, which starts a submit of
// its own where the host lists the vertex tiles (so the host's work between is not timed).
constexpr std::uint32_t kMarks = 10;

struct SparseBatchRunner::State {
  Device& device;
  const blobtree::GridSpec grid;
  const GpuPolygonizeOptions options;
  const BrickGrid bg;
  std::span<const ScanWindow> windows;
  UploadBatch uploads;  // the program and case table ride in the first batch's submit
  GpuProgram gpu;
  std::uint64_t bytes = 0, peakOutputBytes = 0;
  Buffer batchBricks, field, pointWords, cases, masks, vertexSegments, triangleSegments, neighbours, segments, segmentScratch,
      counts, fieldOrder;
  std::uint64_t vertexScratch = 0;
  std::uint64_t fieldTailBase = 0;   // floats before the samples' tail
  std::uint32_t fieldGroupSize = 0;  // brick_field's work group: one brick's rows of points
  // The field pass per tile of bricks, each kernel pruned to its tile (brick_tiles.h); one tile
  // with the program's kernel when the evaluator is not specialised or pruning gains too little.
  // The vertex pass may run per tile too (vertexTileKernels below).
  std::vector<BrickTile> tiles;
  std::vector<KernelPtr> fieldKernels;
  // The vertex kernel, built on a thread of its own while the field kernels are built and the
  // first batch's field pass runs: with specialised code it is the slowest kernel to build by far
  // (tower: the whole program's field, gradient and colour spelled out; lavapipe translates and
  // optimises it in vkCreateComputePipelines, 1-1.5 s), and nothing needs it before the batch's
  // second submit. Declared after everything the build reads, so that it is joined first.
  KernelPtr vertexKernel;
  std::future<KernelPtr> vertexKernelBuild;
  bool interpretedVertexPass = false;  // the embedded interpreter while the generated kernel builds
  bool loopedVertexPass = false;       // the whole program's looped code, its gradient interpreted
  // An interpreting vertex kernel without samples reads the program from uniform blocks where it
  // fits them (uniform_program.h): these, else empty.
  std::vector<Buffer> vertexUniforms;
  bool vertexReadsUniforms = false;  // vertexKernel is brick_vertices_direct_uniform
  // Started when the job is done: the background build of the tiles' vertex kernels for the runs
  // after it (GpuPolygonizeOptions::expectedRuns).
  std::function<void()> tileBuildAfterJobDone;
  double tileBuildSeconds = 0.0;       // its predicted build time (specialisedKernelSeconds)
  double measuredVertexSeconds = 0.0;  // the job's vertex pass so far, batches completed (device time)
  ~State() {
    if (tileBuildAfterJobDone && tileBuildAfterJobPays()) tileBuildAfterJobDone();
  }
  // A quick build starts unbidden (GpuPolygonizeOptions::unbiddenBuildSeconds); a long one only
  // where the runs the caller expects after this one repay it, each saving a share of this job's
  // vertex pass (evaluator_costs.h).
  // Without the rule a random blend of 2048 points at 256 cells built 46 tiles' kernels for 136 s
  // and 2.9 GB behind a `bench --repeats 3` whose runs take 7.5 s.
  bool tileBuildAfterJobPays() noexcept {
    if (tileBuildSeconds <= options.unbiddenBuildSeconds) return true;
    // Unmeasured (no timestamps, or the job failed): 0, so no long build on a guess.
    const bool interpreted = interpretedVertexPass || loopedVertexPass || vertexTapes;
    const double saving = interpreted ? costs::kTiledVertexSavingInterpreted : costs::kTiledVertexSavingGenerated;
    return measuredVertexSeconds * saving * double(options.expectedRuns - 1) >= tileBuildSeconds;
  }
  // The vertex pass per field tile (GpuPolygonizeOptions::sparseVertexTiles): tile t's vertices
  // by vertexTileKernels[t], pruned to its box; empty: one kernel for every vertex. Built on a
  // thread of their own as the one kernel is, joined first for the same reason.
  std::vector<KernelPtr> vertexTileKernels;
  std::future<std::vector<KernelPtr>> vertexTileBuild;
  Buffer brickTiles, tileCounters, tileArgs;  // per batch brick its tile; counts and cursors; dispatches
  std::vector<std::uint32_t> batchTiles;
  const KernelPtr& vertices() {
    if (vertexKernelBuild.valid()) vertexKernel = vertexKernelBuild.get();  // rethrows a failed build
    return vertexKernel;
  }
  const std::vector<KernelPtr>& vertexTiles() {
    if (vertexTileBuild.valid()) vertexTileKernels = vertexTileBuild.get();
    return vertexTileKernels;
  }
  std::vector<std::uint32_t> batchPacked;  // host copy of a batch's brick list (tiles, tapes, row culling)
  // Row culling (row_culling.h): the field kernels take a list of rows, brick_row_fill the rest.
  bool cullRows = false;
  Buffer rowList, fillList;
  // On a CPU device whose segment buffers the host reads and writes in place, the host scans them
  // (host_scan.h) between the two submits; elsewhere the device does (scan.h).
  bool hostScans = false;
  // ... and, with the scans, the row passes (host_row_passes.h: counts, then point words and
  // sources) and the triangles (host_triangles.h), in the buffers the field pass left mapped.
  bool hostRowPasses = false;
  // Per-brick tapes (GpuPolygonizeOptions::brickTapes): the program the tapes are pruned from, the
  // batch's tapes on the host and on the device (grown as batches need), each brick's range.
  const blobtree::Program* tapeProgram = nullptr;
  BrickTapes tapes;
  Buffer tapeCode, tapeRanges;
  // The same packed for uniform blocks (brick_tapes.h, UniformTapes), where the device's uniform
  // range allows: five buffers of a 64 KB block per window, grown as batches need.
  bool uniformTapes = false;
  UniformTapes windowTapes;
  std::array<Buffer, 5> tapeBlocks;
  // Device bytes of the tape buffers (code, ranges and the uniform blocks), as grown so far.
  std::uint64_t tapeBytes() const {
    std::uint64_t b = tapeCode.size() + tapeRanges.size() + vertexTapeCode.size() + vertexTapeRanges.size() +
                      vertexWindowArgs.size();
    for (const Buffer& block : tapeBlocks) b += block.size();
    for (const Buffer& block : vertexTapeBlocks) b += block.size();
    return b;
  }
  std::vector<std::uint8_t> blockBytes;
  // With the field's tapes, the vertex pass interprets per-brick vertex tapes (TapeUse::Vertex,
  // brick_vertices_direct_tapes) where it would interpret the whole program: the batch's tapes
  // on the host and on the device (grown as batches need), each brick's range.
  bool vertexTapes = false;
  const blobtree::Program* vertexTapeProgram = nullptr;
  BrickTapes vertexTapeSet;
  Buffer vertexTapeCode, vertexTapeRanges;
  // On a CPU device the vertex tapes go to uniform blocks by windows of bricks as the field's do
  // (GpuPolygonizeOptions::brickTapeUniforms): the host lists each window's vertices
  // (vertex_tile_lists.h, a window for a tile) and brick_vertices_direct_tapes_uniform runs a
  // dispatch per window. From a storage buffer llvmpipe loops over the lanes at every load (at
  // 256 cells, vertex pass from the storage buffer and from windows: a union of 200 instances
  // 0.30 -> 0.08-0.13 s, a random blend of 1024 points 4.2 -> 1.8 s). Where a batch's tapes do
  // not fit the blocks, its vertex tapes go to the storage buffer.
  bool vertexTapeWindows = false;   // chosen for the job
  bool batchVertexWindows = false;  // this batch's vertex tapes are in windows
  UniformTapes vertexWindowTapes;
  std::array<Buffer, 5> vertexTapeBlocks;
  std::vector<std::uint32_t> vertexWindowOfBrick;  // per batch brick, its window
  Buffer vertexWindowArgs;                         // per window, its dispatch (vertex_tile_lists.h)
  KernelPtr vertexWindowKernel;
  // The storage-buffer tape kernel, for a batch whose tapes do not fit uniform blocks.
  KernelPtr storageTapes;
  const KernelPtr& storageTapeKernel() {
    if (!uniformTapes) return fieldKernels.front();
    if (!storageTapes) storageTapes = device.kernel("brick_field_tapes", tapeSpecs());
    return storageTapes;
  }

  // `buffer` holds at least `bytes` (its contents dropped), counted in the device bytes. Called
  // between batches: the last batch's submits have completed (Device::run waits).
  void reserve(Buffer& buffer, std::uint64_t bytes, VkBufferUsageFlags usage, const char* what) {
    if (buffer.size() >= bytes) return;
    const std::uint64_t size = std::max(bytes, buffer.size() * 3 / 2);
    this->bytes -= buffer.size();
    buffer = Buffer();
    if (usage == VK_BUFFER_USAGE_STORAGE_BUFFER_BIT) {
      buffer = makeSparseBuffer(device, size, what, this->bytes);
    } else {
      buffer = device.createBuffer(size, MemoryUse::DeviceLocal, usage);
      this->bytes += size;
    }
  }

  // Each window's code and records at the start of its 64 KB block (any uniform offset alignment).
  void uploadWindowBlocks(const UniformTapes& u, std::array<Buffer, 5>& blocks) {
    const std::uint64_t windows = u.windows.size();
    auto uploadBlocks = [&](Buffer& dst, const void* records, std::size_t recordBytes, std::size_t perWindow) {
      reserve(dst, windows * kUniformTapeBlock, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, "brick tape blocks");
      blockBytes.assign(windows * kUniformTapeBlock, 0);
      for (std::uint64_t w = 0; w < windows; ++w)
        std::memcpy(blockBytes.data() + w * kUniformTapeBlock,
                    static_cast<const std::uint8_t*>(records) + w * perWindow * recordBytes, perWindow * recordBytes);
      device.upload(dst, blockBytes.data(), blockBytes.size());
    };
    uploadBlocks(blocks[0], u.code.data(), sizeof(layout::Instruction), kUniformTapeCode);
    uploadBlocks(blocks[1], u.primitives.data(), sizeof(layout::PrimitiveRecord), kUniformTapePrims);
    uploadBlocks(blocks[2], u.matrices.data(), sizeof(layout::MatrixRecord), kUniformTapeMatrices);
    uploadBlocks(blocks[3], u.boxes.data(), sizeof(layout::BoxRecord), kUniformTapeBoxes);
    uploadBlocks(blocks[4], u.warps.data(), sizeof(layout::WarpRecord), kUniformTapeWarps);
  }
  // Builds and uploads the tapes of the batch's bricks (`packed`): in uniform blocks by windows
  // where they fit, else in one storage buffer. Returns whether they went to uniform blocks.
  bool uploadTapes(std::span<const std::uint32_t> packed, const GpuProgram& gpu, GpuStats& s) {
    const auto start = Clock::now();
    const bool uniform = uniformTapes && buildUniformTapes(*tapeProgram, grid, bg, packed, windowTapes);
    if (uniform) {
      const UniformTapes& u = windowTapes;
      uploadWindowBlocks(u, tapeBlocks);
      device.upload(tapeRanges, u.ranges.data(), 4ull * u.ranges.size());
      s.tapeInstructions += u.instructions;
      s.tapeWords += u.windows.size() * kUniformTapeCode;
    } else {
      buildBrickTapes(*tapeProgram, grid, bg, packed, gpu.emptyBox, tapes);
      const std::uint64_t codeBytes = tapes.code.size() * sizeof(layout::Instruction);
      reserve(tapeCode, std::max<std::uint64_t>(codeBytes, 16), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "brick tapes");
      device.upload(tapeCode, tapes.code.data(), codeBytes);
      device.upload(tapeRanges, tapes.ranges.data(), 4ull * tapes.ranges.size());
      s.tapeInstructions += tapes.instructions;
      s.tapeWords += tapes.code.size();
    }
    s.tapeSeconds += std::chrono::duration<double>(Clock::now() - start).count();
    return uniform;
  }
  // Builds and uploads the vertex tapes of the batch's bricks (`packed`): in windows of uniform
  // blocks where the job takes them and they fit, else in the storage buffer.
  void uploadVertexTapes(std::span<const std::uint32_t> packed, const GpuProgram& gpu, GpuStats& s, bool windows) {
    const auto start = Clock::now();
    batchVertexWindows =
        windows && buildUniformTapes(*vertexTapeProgram, grid, bg, packed, vertexWindowTapes, TapeUse::Vertex);
    if (batchVertexWindows) {
      const UniformTapes& u = vertexWindowTapes;
      uploadWindowBlocks(u, vertexTapeBlocks);
      device.upload(vertexTapeRanges, u.ranges.data(), 4ull * u.ranges.size());
      vertexWindowOfBrick.resize(packed.size());
      for (std::size_t w = 0; w < u.windows.size(); ++w)
        std::fill(vertexWindowOfBrick.begin() + u.windows[w].firstBrick, vertexWindowOfBrick.begin() + u.windows[w].endBrick,
                  std::uint32_t(w));
      reserve(vertexWindowArgs, u.windows.size() * 32, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, "vertex window dispatches");
      s.tapeSeconds += std::chrono::duration<double>(Clock::now() - start).count();
      return;
    }
    buildBrickTapes(*vertexTapeProgram, grid, bg, packed, gpu.emptyBox, vertexTapeSet, TapeUse::Vertex);
    const std::uint64_t codeBytes = vertexTapeSet.code.size() * sizeof(layout::Instruction);
    reserve(vertexTapeCode, std::max<std::uint64_t>(codeBytes, 16), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "vertex tapes");
    device.upload(vertexTapeCode, vertexTapeSet.code.data(), codeBytes);
    device.upload(vertexTapeRanges, vertexTapeSet.ranges.data(), 4ull * vertexTapeSet.ranges.size());
    s.tapeSeconds += std::chrono::duration<double>(Clock::now() - start).count();
  }
  DeviceTimer timer;
  std::uint32_t runs = 0, maxBatches = 0;

  // The tape kernels' specialization constants: the interpreter's, with the skip case kept (a
  // tape's "write 0" is a skip on the empty box even where the program has none).
  std::array<std::uint32_t, 6> tapeSpecs() const {
    std::array<std::uint32_t, 6> specs = gpu.specs(fieldGroupSize, Traversal::Stackless);
    specs[3] |= 1u << layout::OP_SKIP;
    return specs;
  }
  // ... and the vertex tapes' kernel, which also meets runs of null additions.
  std::array<std::uint32_t, 6> vertexTapeSpecs(std::uint32_t wg) const {
    std::array<std::uint32_t, 6> specs = gpu.specs(wg, Traversal::Stackless);
    specs[3] |= 1u << layout::OP_SKIP | 1u << layout::OP_NULL_ADDS;
    return specs;
  }

  State(Device& d, const blobtree::Program& program, const blobtree::GridSpec& g, const GpuPolygonizeOptions& o,
        Traversal traversal, const BrickGrid& b, std::span<const ScanWindow> w, std::uint32_t maxLoaded,
        std::uint32_t batches)
      : device(d), grid(g), options(o), bg(b), windows(w), uploads(d),
        gpu(uploadProgram(d, program, traversal, o.codegen)), timer(d, kMarks * batches), maxBatches(batches) {
    const std::uint64_t B = 1ull << bg.log2B, R = B + 1, P = R * R * R;
    const std::uint64_t maxRows = std::uint64_t(maxLoaded) * R * R, maxCellRows = std::uint64_t(maxLoaded) * B * B;
    auto make = [&](std::uint64_t size, const char* what) { return makeSparseBuffer(device, size, what, bytes); };
    batchBricks = make(std::uint64_t(maxLoaded) * 4, "batch brick list");
    // A row's samples: S = max(B, 4) floats from a 16-byte boundary, then (B >= 4) its last
    // point in the tail after every row's run (brick_layout.glsl, fieldIndex).
    const std::uint64_t S = std::max<std::uint64_t>(B, 4);
    fieldTailBase = maxRows * S;
    field = make(maxRows * (S + 1) * 4, "field samples");
    pointWords = make(std::uint64_t(maxLoaded) * P * 4, "point words");
    const std::vector<std::uint32_t>& words = caseTableUniform();
    bytes += words.size() * 4;
    cases = device.createBuffer(words.size() * 4, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    device.upload(cases, words.data(), words.size() * 4);
    masks = make(maxRows * 4, "inside masks");
    vertexSegments = make(maxRows * 4, "vertex segments");
    triangleSegments = make(maxCellRows * 4, "triangle segments");
    neighbours = make(std::uint64_t(maxLoaded) * 32, "brick neighbours");
    segments = make(std::uint64_t(maxLoaded) * 16, "brick segment records");
    vertexScratch = scanScratchWords(maxRows);
    segmentScratch = make((vertexScratch + scanScratchWords(maxCellRows) + 1) * 4, "segment scan scratch");
    hostScans = device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU && vertexSegments.hostReadable() &&
                triangleSegments.hostReadable() && o.hostPassesOnCpuDevices;
    hostRowPasses = hostScans && masks.hostReadable() && segments.hostReadable() && pointWords.hostReadable() &&
                    neighbours.hostReadable();

    // One lane per row of points: a work group holds a brick's R^2 rows rounded up to a vector of 8
    // (llvmpipe runs an idle vector through the whole evaluator), within the device's limits.
    const auto& limits = device.info().limits;
    fieldGroupSize = std::min<std::uint32_t>({std::uint32_t(R * R + 7) / 8 * 8, limits.maxComputeWorkGroupSize[0],
                                              limits.maxComputeWorkGroupInvocations});
    fieldOrder = make(std::uint64_t(maxLoaded) * 4, "field tile order");
    // Row culling packs a batch brick in 23 bits and a batch row in 31.
    cullRows = cullsRows(o, device.info().isLlvmpipe(), std::uint32_t(B)) &&
               maxRows < (1ull << 30) && maxLoaded < (1u << 22);
    if (cullRows) {
      rowList = make(maxRows * 8, "field rows");
      fillList = make(maxRows * 4, "one-sided rows");
    }
    const char* fieldShader = cullRows ? "brick_field_rows" : "brick_field";
    const std::uint32_t fieldKernelGroup = cullRows ? std::uint32_t(o.workgroupSize) : fieldGroupSize;
    // Without samples to take (no refinement; normals from the gradient), the kernel without the
    // sample loop, whose field evaluator llvmpipe would run once per vertex anyway.
    const bool samples = o.refineSteps > 0 || traversal == Traversal::StackBased;
    const char* vertexShader = samples ? "brick_vertices" : "brick_vertices_direct";
    const char* tiledVertexShader = samples ? "brick_vertices_tiled" : "brick_vertices_direct_tiled";
    const bool generated = traversal == Traversal::Specialised && gpu.specialised && gpu.codegen.gradient;
    if (traversal == Traversal::Specialised && o.maxFieldTiles > 1 && !o.brickTapes)
      tiles = planBrickTiles(program, g, bg, o.maxFieldTiles, o.maxFieldTilesForLoopedCode, gpu.codegen.loops);
    // The vertex pass per field tile: only with the generated gradient (an interpreted one gains
    // nothing from a pruned field) and more than one tile.
    bool tileable = generated && tiles.size() > 1;
    const std::uint64_t print = tiles.size() > 1 ? (gpu.fingerprint ? gpu.fingerprint : programFingerprint(program)) : 0;
    const std::uint32_t wg = o.workgroupSize;
    // Tile t's vertex kernel: pruned to its box where the generator takes the pruned program,
    // else the whole program's code with the tiled shader.
    auto tileCodegen = [this](std::size_t t) {
      CodegenOptions c = gpu.codegen;
      c.region = tiles[t].region;
      return c;
    };
    std::vector<PointRegion> regions;
    for (const BrickTile& t : tiles) regions.push_back(t.region);
    // Which tiles get a kernel of their own: a program too large to specialise whole may still
    // fit once pruned to a tile.
    const std::vector<char> ownTile =
        specialiseTiles(program, print ? print : gpu.fingerprint, regions, gpu.codegen.loops);
    auto ownTileKernel = [ownTile](std::size_t t) { return ownTile[t] != 0; };
    // ... and only where every tile's code unrolls: looped code generates no gradient, and a
    // looped tile's vertex kernel would interpret it from the storage buffers (a flat blend of 600
    // points at 256 cells: 69 s against 2.7 s for the vertex tapes).
    for (std::size_t t = 0; tileable && t < tiles.size(); ++t)
      tileable = ownTileKernel(t) && !specialisedCodeLoops(program, tiles[t].region, gpu.codegen.loops);
    bool tiledVertices = tileable && o.sparseVertexTiles;
    // Runs on the vertex kernels' thread, after this constructor: the program is gpu's copy.
    auto buildVertexTile = [this, print, tiledVertexShader, wg, traversal, ownTileKernel,
                            tileCodegen](std::size_t t) -> KernelPtr {
      if (!ownTileKernel(t)) return evaluatorKernel(device, gpu, tiledVertexShader, wg, traversal);
      return specialisedKernel(device, *gpu.specialised, print, tileCodegen(t), tiledVertexShader, wg);
    };
    // The vertex kernels this job runs when they are generated: the whole program's, or every tile's.
    auto tileKernelsBuilt = [&] {
      for (std::size_t t = 0; t < tiles.size(); ++t) {
        const bool own = ownTileKernel(t);
        if (!specialisedKernelBuilt(device, own ? print : gpu.fingerprint, own ? tileCodegen(t) : gpu.codegen,
                                    tiledVertexShader, wg))
          return false;
      }
      return true;
    };
    auto vertexKernelsBuilt = [&] {
      return tiledVertices ? tileKernelsBuilt()
                           : specialisedKernelBuilt(device, gpu.fingerprint, gpu.codegen, vertexShader, wg);
    };
    // A job that runs again (expectedRuns > 1) takes the tiles' vertex kernels once they are
    // built; until then it runs the one kernel, and the tiles' kernels build in the background
    // once the job is done (~State), so that they slow neither it nor its first run. The pass
    // then takes 0.6-0.7 of the time (tower and random128 at 512 cells on lavapipe: 67 -> 45 and
    // 210 -> 130 ms) for 1-2.5 s of builds.
    bool tileBuildAfterJob = false;
    if (tileable && !tiledVertices && o.expectedRuns > 1) {
      tiledVertices = tileKernelsBuilt();
      tileBuildAfterJob = !tiledVertices;
    }
    // Looped code (a long program on a CPU driver) brings no gradient of its own: its vertex kernel
    // interprets the gradient from the storage buffers, so where the pass runs the whole
    // program's one kernel it interprets the gradient from uniform blocks instead (the same bits;
    // llvmpipe gathers from a uniform block and loops over the lanes for a storage buffer: a
    // flat blend of 600 points at 64 cells, vertex pass 4.4 s -> 0.6 s).
    loopedVertexPass = generated && !tiledVertices && specialisedCodeLoops(*gpu.specialised, {}, gpu.codegen.loops);
    const bool vertexGenerated = generated && !loopedVertexPass;
    // Background builds of the generated vertex kernels are known by a key: the one kernel's, or
    // with every tile's code, the tiles'.
    auto vertexKey = [&](bool tiled) {
      std::string key = std::string(tiled ? tiledVertexShader : vertexShader) + ":" +
                        std::to_string(evaluatorFingerprint(gpu.fingerprint, gpu.codegen)) + ":" +
                        std::to_string(o.workgroupSize);
      for (std::size_t t = 0; tiled && t < tiles.size(); ++t)
        key.append(":").append(std::to_string(evaluatorFingerprint(print, tileCodegen(t))));
      return key;
    };
    const std::string backgroundKey = vertexKey(tiledVertices);
    if (tileBuildAfterJob) {
      std::vector<std::pair<std::uint64_t, CodegenOptions>> kernels;  // per tile: fingerprint, code
      for (std::size_t t = 0; t < tiles.size(); ++t) {
        kernels.emplace_back(ownTileKernel(t) ? print : gpu.fingerprint, ownTileKernel(t) ? tileCodegen(t) : gpu.codegen);
        const PointRegion region = ownTileKernel(t) ? tiles[t].region : PointRegion{};
        tileBuildSeconds += specialisedKernelSeconds(specialisedCodeSize(program, region, gpu.codegen.loops),
                                                     costs::kGradientVertexKernelCopies);
      }
      tileBuildAfterJobDone = [&d = device, key = vertexKey(true), program = gpu.specialised, kernels,
                               shader = std::string(tiledVertexShader), wg] {
        d.buildInBackground(key, [&d, program, kernels, shader, wg] {
          for (const auto& [print, codegen] : kernels) specialisedKernel(d, *program, print, codegen, shader, wg);
        });
      };
    }
    // The kernels this job builds before its first submit, on every core at once
    // (concurrent_builds.h): the vertex kernel, unless it builds on a thread of its own, the
    // field kernel of each tile, and the batches' fixed kernels.
    std::vector<std::function<KernelPtr()>> builds;
    // The vertex kernel that interprets the gradient (as the generated code's, bit for bit): the
    // embedded one, without samples from uniform blocks where the program fits them.
    const bool interpretUntilBuilt = vertexGenerated && o.interpretVertexPassUntilBuilt && !vertexKernelsBuilt() &&
                                     !device.backgroundBuildDone(backgroundKey);
    // With the field's tapes, or where asked for a looped program (GpuPolygonizeOptions::
    // vertexTapes), a vertex pass that would interpret the whole program interprets each brick's
    // vertex tape instead (a flat blend of 600 points: a few tens of instructions a vertex instead
    // of 1,200; the same bits).
    vertexTapes = (o.brickTapes || (loopedVertexPass && o.vertexTapes)) && !samples && traversal != Traversal::StackBased &&
                  !vertexGenerated && !tiledVertices && (o.normals || o.colours);
    if (vertexTapes) {
      vertexTapeProgram = &program;
      vertexTapeRanges = make(std::uint64_t(maxLoaded) * 8, "vertex tape ranges");
      vertexTapeWindows = hostScans && vertexTapesInWindows(device, o);
    }
    if (!vertexTapes && !samples && traversal != Traversal::StackBased && o.uniformVertexProgram &&
        (!vertexGenerated || interpretUntilBuilt))
      vertexUniforms = uploadUniformProgram(device, program);
    auto interpretingVertexKernel = [&, vertexShader, wg]() -> KernelPtr {
      vertexReadsUniforms = !vertexUniforms.empty();
      if (vertexReadsUniforms)
        return device.kernel("brick_vertices_direct_uniform", gpu.specs(wg, Traversal::Stackless));
      return evaluatorKernel(device, gpu, vertexShader, wg,
                             traversal == Traversal::StackBased ? traversal : Traversal::Stackless);
    };
    if (vertexTapes) {
      // Both kernels where the tapes may go to windows: a batch whose tapes do not fit takes the
      // storage buffer's.
      builds.push_back([this, wg] { return device.kernel("brick_vertices_direct_tapes", vertexTapeSpecs(wg)); });
      if (vertexTapeWindows)
        builds.push_back([this, wg] { return device.kernel("brick_vertices_direct_tapes_uniform", vertexTapeSpecs(wg)); });
    } else if (interpretUntilBuilt) {
      // Not built: this job interprets its vertex pass (quick to create, the same bytes) and, if
      // more jobs are expected, the generated kernel builds in the background for them (once: a
      // build an earlier job started goes on). A job that comes while the build still runs
      // interprets again rather than waiting for it: waiting stalled a re-meshing loop's second
      // job for most of the build (tower at 128 cells on lavapipe: 0.5-0.7 s against 0.02 s
      // steady), and left the cores the job would have used idle beside a one-thread build. A
      // build that failed counts as done: the job then builds in the foreground and reports it.
      builds.push_back(interpretingVertexKernel);
      interpretedVertexPass = true;
      if (o.expectedRuns > 1) {
        std::vector<CodegenOptions> codegens;  // one kernel, or one per tile with a kernel of its own
        if (!tiledVertices) codegens.push_back(gpu.codegen);
        for (std::size_t t = 0; tiledVertices && t < tiles.size(); ++t)
          if (ownTileKernel(t)) codegens.push_back(tileCodegen(t));
        device.buildInBackground(backgroundKey, [&d = device, program = gpu.specialised,
                                                 print = tiledVertices ? print : gpu.fingerprint, codegens,
                                                 shader = std::string(tiledVertices ? tiledVertexShader : vertexShader), wg] {
          for (const CodegenOptions& c : codegens) specialisedKernel(d, *program, print, c, shader, wg);
        });
      }
    } else if (tiledVertices) {
      // The tiles' vertex kernels on a thread of their own as the one kernel below, each tile's
      // build on every core at once (they are independent).
      vertexTileBuild = std::async(std::launch::async, [this, buildVertexTile, backgroundKey] {
        device.waitForBackgroundBuild(backgroundKey);  // an earlier job's: then cache hits here
        std::vector<std::function<KernelPtr()>> tileBuilds;
        for (std::size_t t = 0; t < tiles.size(); ++t) tileBuilds.push_back([&buildVertexTile, t] { return buildVertexTile(t); });
        return buildConcurrently(tileBuilds);
      });
    } else if (traversal == Traversal::Specialised && (vertexGenerated || vertexUniforms.empty())) {
      vertexKernelBuild = std::async(std::launch::async, [this, vertexShader, wg, traversal, backgroundKey] {
        device.waitForBackgroundBuild(backgroundKey);  // an earlier job's: then a cache hit here
        return evaluatorKernel(device, gpu, vertexShader, wg, traversal);
      });
    } else {  // the embedded interpreter: its pipeline is quick to create
      builds.push_back(interpretingVertexKernel);
    }
    const std::size_t vertexBuilds = builds.size();
    if (o.brickTapes) {
      // The interpreter over tapes, whatever the traversal: a tape's "write 0" is a skip on the
      // empty box, so the kernel keeps the skip case even where the program has none.
      tiles.assign(1, BrickTile{{0, 0, 0}, {bg.x - 1, bg.y - 1, bg.z - 1}, {}});
      tapeProgram = &program;
      tapeRanges = make(std::uint64_t(maxLoaded) * 8, "brick tape ranges");
      uniformTapes = o.brickTapeUniforms && limits.maxUniformBufferRange >= kUniformTapeBlock;
      builds.push_back([&] { return device.kernel(uniformTapes ? "brick_field_tapes_uniform" : "brick_field_tapes", tapeSpecs()); });
    } else if (tiles.size() <= 1) {
      tiles.assign(1, BrickTile{{0, 0, 0}, {bg.x - 1, bg.y - 1, bg.z - 1}, {}});
      builds.push_back([&] { return evaluatorKernel(device, gpu, fieldShader, fieldKernelGroup, traversal); });
    } else {
      for (std::size_t t = 0; t < tiles.size(); ++t) {
        builds.push_back([&, region = tiles[t].region, own = ownTileKernel(t)]() -> KernelPtr {
          if (!own) return evaluatorKernel(device, gpu, fieldShader, fieldKernelGroup, traversal);
          CodegenOptions c = gpu.codegen;
          c.region = region;
          return specialisedKernel(device, program, print, c, fieldShader, fieldKernelGroup);
        });
      }
    }
    // The program's kernels first (the field's is the slowest to create), then the fixed kernels
    // of the batches' passes, which the threads done early create rather than the first submits
    // one after the other (their pipelines are then found by name and specialization).
    const std::size_t evaluatorBuilds = builds.size();
    const std::array<std::uint32_t, 1> wgSpec{wg};
    builds.push_back([this, wgSpec] { return device.kernel("brick_neighbours", wgSpec); });
    if (!hostRowPasses) {
      for (const char* fixed : {"brick_rows", "brick_sources", "brick_triangles"})
        builds.push_back([this, fixed, wgSpec] { return device.kernel(fixed, wgSpec); });
    }
    if (cullRows) builds.push_back([this, wgSpec] { return device.kernel("brick_row_fill", wgSpec); });
    std::vector<KernelPtr> built = buildConcurrently(builds);
    if (vertexBuilds) vertexKernel = built.front();
    if (vertexTapes && vertexTapeWindows) vertexWindowKernel = built[1];
    fieldKernels.assign(built.begin() + std::ptrdiff_t(vertexBuilds), built.begin() + std::ptrdiff_t(evaluatorBuilds));
    if (tiledVertices && !interpretedVertexPass) {
      brickTiles = make(std::uint64_t(maxLoaded) * 4, "brick tiles");
      tileCounters = make(tiles.size() * 8, "vertex tile counters");
      tileArgs = device.createBuffer(tiles.size() * 32, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT);
      bytes += tiles.size() * 32;
    }
    counts = device.createBuffer(16, MemoryUse::Readback);
  }
};

namespace {
// Every caller (one device or several, streamed, incremental) runs its batches here: a job whose
// rows of points would outrun llvmpipe's loop limit fails with an error instead of a wrong mesh
// (runSparseExtraction first picks bricks that fit, loop_limit.h).
void checkLoopLimit(Device& device, const blobtree::Program& program, const GpuPolygonizeOptions& options,
                    Traversal traversal, const BrickGrid& bricks) {
  const std::uint64_t limit = loopIterationLimit(device.info());
  if (limit == ~0ull) return;
  GpuPolygonizeOptions resolved = options;
  resolved.traversal = traversal;
  checkSparseLoopLimit(program, resolved, 1u << bricks.log2B, limit);
}
}  // namespace

SparseBatchRunner::SparseBatchRunner(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                     const GpuPolygonizeOptions& options, Traversal traversal, const BrickGrid& bricks,
                                     std::span<const ScanWindow> windows, std::uint32_t maxLoaded,
                                     std::uint32_t maxBatches)
    : state_((checkLoopLimit(device, program, options, traversal, bricks),
              std::make_unique<State>(device, program, grid, options, traversal, bricks, windows, maxLoaded,
                                      maxBatches))) {}

bool vertexTapesInWindows(const Device& device, const GpuPolygonizeOptions& options) {
  return device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU && options.brickTapeUniforms &&
         device.info().limits.maxUniformBufferRange >= kUniformTapeBlock;
}

SparseBatchRunner::~SparseBatchRunner() = default;

std::uint64_t SparseBatchRunner::sharedBytes() const { return state_->bytes; }
std::uint64_t SparseBatchRunner::peakOutputBytes() const { return state_->peakOutputBytes; }

bool SparseBatchRunner::deviceTimes(GpuStats& s) {
  State& st = *state_;
  if (!st.timer.enabled()) return false;
  s.fieldSeconds = s.extractSeconds = 0.0;
  s.edgesSeconds = s.scansSeconds = s.sourcesSeconds = s.trianglesSeconds = s.verticesSeconds = 0.0;
  for (std::uint32_t b = 0; b < st.runs; ++b) {
    const std::uint32_t m = kMarks * b;
    s.fieldSeconds += st.timer.seconds(m, m + 1);
    s.edgesSeconds += st.timer.seconds(m + 1, m + 2);
    s.scansSeconds += st.timer.seconds(m + 2, m + 3);
    s.sourcesSeconds += st.timer.seconds(m + 4, m + 5);
    s.verticesSeconds += st.timer.seconds(m + 9, m + 6);
    s.trianglesSeconds += st.timer.seconds(m + 6, m + 7);
    const double copy = st.timer.seconds(m + 7, m + 8);
    s.readbackSeconds += copy;
    s.readbackDeviceSeconds += copy;
  }
  s.extractSeconds = s.edgesSeconds + s.scansSeconds + s.sourcesSeconds + s.verticesSeconds + s.trianglesSeconds;
  return true;
}

void SparseBatchRunner::run(const SparseBatch& batch, std::uint64_t vertexBase, mesh::TriMesh& mesh, GpuStats& s,
                            std::vector<std::uint64_t>* cornerKeys, double reserveRatio) {
  State& st = *state_;
  if (st.runs >= st.maxBatches) throw VulkanError("GPU polygonizer: more batches run than the runner was made for");
  Device& device = st.device;
  const GpuPolygonizeOptions& options = st.options;
  const BrickGrid& bg = st.bg;
  const GpuProgram& gpu = st.gpu;
  const auto pb = gpu.bindings();
  const std::uint32_t B = 1u << bg.log2B, R = B + 1, P = R * R * R, wg = options.workgroupSize;
  const std::array<std::uint32_t, 1> wgSpec{wg};
  const float originCell[4] = {st.grid.origin.x, st.grid.origin.y, st.grid.origin.z, st.grid.cellSize};
  const std::uint32_t cells[4] = {std::uint32_t(st.grid.cells.x), std::uint32_t(st.grid.cells.y),
                                  std::uint32_t(st.grid.cells.z), bg.log2B};
  const std::uint32_t run = st.runs++, mark = kMarks * run, loaded = batch.loadedActive;
  // The window of the brick tables holding the batch's layers, and the batch's first active brick
  // counted from the window's.
  const ScanWindow* window = &windowHolding(st.windows, batch.firstLayer, batch.endLayer);
  const std::uint32_t windowActive = batch.activeBase - window->activeBase;
  const std::uint64_t rowCount = std::uint64_t(loaded) * R * R;
  const std::uint64_t triangleSegmentCount = std::uint64_t(loaded) * B * B;
  const Groups columnGroups = groupsFor(std::uint64_t(loaded) * R, wg);  // the row passes: a lane per column of rows
  s.fieldTiles = std::uint32_t(st.tiles.size());
  // The batch's brick list on the host, for the tiles' order, the tapes and row culling.
  if (st.tiles.size() > 1 || st.tapeProgram || st.vertexTapes || st.cullRows) {
    st.batchPacked.resize(loaded);
    device.download(window->list, st.batchPacked.data(), 4ull * loaded, 4ull * windowActive);
  }
  // The batch's bricks grouped by field tile (the identity with one tile), uploaded for brick_field.
  BrickTileOrder tileOrder;
  if (st.tiles.size() > 1) {
    tileOrder = orderBricksByTile(st.tiles, bg, st.batchPacked);
  } else {
    tileOrder.order.resize(loaded);
    for (std::uint32_t a = 0; a < loaded; ++a) tileOrder.order[a] = a;
    tileOrder.starts = {0, loaded};
  }
  device.upload(st.fieldOrder, tileOrder.order.data(), 4ull * loaded);
  RowPlan rows;
  if (st.cullRows) {
    const auto planStart = Clock::now();
    rows = planRows(options, st.grid, bg, st.batchPacked, tileOrder);
    if (!rows.rows.empty()) device.upload(st.rowList, rows.rows.data(), 4ull * rows.rows.size());
    if (!rows.fills.empty()) device.upload(st.fillList, rows.fills.data(), 4ull * rows.fills.size());
    s.hostSteps.rowCulling += since(planStart);
    s.fieldEvaluations += rows.evaluations;
  } else {
    s.fieldEvaluations += std::uint64_t(loaded) * P;
  }
  const bool uniformTapes = st.tapeProgram && st.uploadTapes(st.batchPacked, gpu, s);
  if (st.vertexTapes) st.uploadVertexTapes(st.batchPacked, gpu, s, st.vertexTapeWindows);
  // The vertex pass per tile: each batch brick's tile, for brick_vertex_tile_counts and _lists.
  const std::vector<KernelPtr>& vertexTiles = st.vertexTiles();
  s.vertexTiles = std::uint32_t(vertexTiles.size());
  if (!vertexTiles.empty()) {
    st.batchTiles.resize(loaded);
    for (std::uint32_t t = 0; t + 1 < tileOrder.starts.size(); ++t)
      for (std::uint32_t i = tileOrder.starts[t]; i < tileOrder.starts[t + 1]; ++i) st.batchTiles[tileOrder.order[i]] = t;
    device.upload(st.brickTiles, st.batchTiles.data(), 4ull * loaded);
  }
  auto submit = [&](const std::function<void(Recorder&)>& record, const std::function<void()>& whileRunning = {}) {
    device.run(record, whileRunning);
    ++s.submits;
  };

  // 3-5: the field at the batch's points and the inside masks per row of points; each brick's
  // neighbours and segment record; crossing edges and counts per row; the two scans; the counts
  // of the layers the batch emits.
  auto t0 = Clock::now();
  const auto fieldStart = t0;
  submit([&](Recorder& rec) {
    if (run == 0) st.timer.reset(rec);
    rec.computeBarrier();  // the last batch's reads and writes of the shared buffers come first
    st.timer.mark(rec, mark);
    rec.copy(window->list, 4ull * windowActive, st.batchBricks, 0, 4ull * loaded);
    rec.computeBarrier();
    for (std::size_t t = 0; t < st.tiles.size(); ++t) {
      const std::uint32_t first = tileOrder.starts[t], count = tileOrder.starts[t + 1] - first;
      if (count == 0) continue;
      struct {
        float originCell[4];
        std::uint32_t log2B, activeBricks, codeLength, orderBase, tailBase, bricksX, bricksY;
      } push{{originCell[0], originCell[1], originCell[2], originCell[3]},
             bg.log2B,
             count,
             gpu.codeLength,
             first,
             std::uint32_t(st.fieldTailBase),
             bg.x,
             bg.y};
      // Bindings 6 and 9: the samples' runs (vec4) and their tail (float), one buffer.
      const std::uint32_t groups = (R * R + st.fieldGroupSize - 1) / st.fieldGroupSize;
      const BrickGroups tg = brickGroups(count);
      if (uniformTapes) {  // a dispatch per window of bricks, its blocks in place of the program
        for (std::size_t w = 0; w < st.windowTapes.windows.size(); ++w) {
          const UniformTapes::Window& win = st.windowTapes.windows[w];
          auto block = [&](const Buffer& b) { return BufferRange(b.handle(), w * kUniformTapeBlock, kUniformTapeBlock); };
          auto wpush = push;
          wpush.orderBase = first + win.firstBrick;
          wpush.activeBricks = win.endBrick - win.firstBrick;
          const BrickGroups wg = brickGroups(wpush.activeBricks);
          const BufferRange bind[11] = {block(st.tapeBlocks[0]), block(st.tapeBlocks[1]), block(st.tapeBlocks[2]),
                                        block(st.tapeBlocks[3]), block(st.tapeBlocks[4]), st.batchBricks,
                                        st.field, st.masks, st.fieldOrder, st.field, st.tapeRanges};
          rec.dispatch(*st.fieldKernels[t], bind, &wpush, sizeof(wpush), groups, wg.y, wg.z);
        }
        continue;
      }
      if (st.tapeProgram) {  // binding 0: the tapes in place of the program's code
        const BufferRange bind[11] = {st.tapeCode,    pb[1],    pb[2],    pb[3],         pb[4],   st.batchBricks,
                                      st.field,       st.masks, st.fieldOrder, st.field, st.tapeRanges};
        rec.dispatch(*st.storageTapeKernel(), bind, &push, sizeof(push), groups, tg.y, tg.z);
        continue;
      }
      if (st.cullRows) {  // the tile's listed rows, a lane each
        push.orderBase = rows.starts[t];
        push.activeBricks = rows.starts[t + 1] - rows.starts[t];
        if (push.activeBricks == 0) continue;
        const BufferRange bind[10] = {pb[0], pb[1], pb[2], pb[3], pb[4], st.batchBricks, st.field, st.masks, st.rowList, st.field};
        const Groups rg = groupsFor(push.activeBricks, wg);
        rec.dispatch(*st.fieldKernels[t], bind, &push, sizeof(push), rg.x, rg.y);
        continue;
      }
      const BufferRange bind[10] = {pb[0],    pb[1],          pb[2], pb[3], pb[4], st.batchBricks, st.field, st.masks,
                                    st.fieldOrder, st.field};
      rec.dispatch(*st.fieldKernels[t], bind, &push, sizeof(push), groups, tg.y, tg.z);
    }
    if (!rows.fills.empty()) {
      const std::uint32_t push[2] = {std::uint32_t(rows.fills.size()), R};
      const BufferRange bind[2] = {st.fillList, st.masks};
      const Groups g = groupsFor(rows.fills.size(), wg);
      rec.dispatch(*device.kernel("brick_row_fill", wgSpec), bind, push, sizeof(push), g.x, g.y);
    }
    {
      const std::uint32_t push[7] = {bg.x, bg.y, bg.z, loaded, windowActive, bg.log2B, window->firstLayer};
      const BufferRange bind[5] = {st.batchBricks, st.neighbours, st.segments, window->rowStarts, window->list};
      const Groups g = groupsFor(loaded, wg);
      rec.dispatch(*device.kernel("brick_neighbours", wgSpec), bind, push, sizeof(push), g.x, g.y);
    }
    rec.computeBarrier();
    st.timer.mark(rec, mark + 1);
    if (!st.hostRowPasses) {
      const std::uint32_t push[8] = {cells[0], cells[1], cells[2], cells[3], bg.x, bg.y, bg.z, loaded};
      const BufferRange bind[5] = {st.masks, st.segments, st.cases, st.vertexSegments, st.triangleSegments};
      rec.dispatch(*device.kernel("brick_rows", wgSpec), bind, push, sizeof(push), columnGroups.x, columnGroups.y);
    }
    rec.computeBarrier();
    st.timer.mark(rec, mark + 2);
    if (!st.hostScans) {
      recordExclusiveScan(rec, st.vertexSegments.handle(), 0, std::uint32_t(rowCount), st.segmentScratch.handle(), 0,
                          st.counts.handle(), 0);
      rec.computeBarrier();  // the scans share the scratch and totals buffers (see slab_polygonizer.cpp)
      recordExclusiveScan(rec, st.triangleSegments.handle(), 0, std::uint32_t(triangleSegmentCount),
                          st.segmentScratch.handle(), std::uint32_t(st.vertexScratch), st.counts.handle(), 1);
      rec.computeBarrier();
      if (batch.ownActive < loaded) {  // where the next layer's segments start
        rec.copy(st.vertexSegments, 4ull * batch.ownActive * R * R, st.counts, 8, 4);
        rec.copy(st.triangleSegments, 4ull * batch.ownActive * B * B, st.counts, 12, 4);
      }
    }
    st.timer.mark(rec, mark + 3);
    rec.hostBarrier();
  });
  // The totals and where the next layer's segments start: c[0], c[1] the batch's vertices and
  // triangles, c[2], c[3] those of the bricks it emits.
  std::uint32_t c[4] = {0, 0, 0, 0};
  const HostRowLayout rowLayout{{cells[0], cells[1], cells[2]},
                                {bg.x, bg.y, bg.z},
                                bg.log2B,
                                loaded,
                                batch.ownActive,
                                static_cast<const std::uint32_t*>(st.masks.mapped()),
                                static_cast<const std::uint32_t*>(st.segments.mapped())};
  if (st.hostScans) {
    auto* vertexCounts = static_cast<std::uint32_t*>(st.vertexSegments.mapped());
    auto* triangleCounts = static_cast<std::uint32_t*>(st.triangleSegments.mapped());
    if (st.hostRowPasses) {
      const auto rowsStart = Clock::now();
      countRowsOnHost(rowLayout, vertexCounts, triangleCounts);
      s.hostSteps.rows += since(rowsStart);
    }
    const auto scanStart = Clock::now();
    c[0] = exclusiveScanInPlace(vertexCounts, rowCount);
    c[1] = exclusiveScanInPlace(triangleCounts, triangleSegmentCount);
    if (batch.ownActive < loaded) {
      c[2] = vertexCounts[std::uint64_t(batch.ownActive) * R * R];
      c[3] = triangleCounts[std::uint64_t(batch.ownActive) * B * B];
    }
    s.hostSteps.scans += since(scanStart);
  } else {
    device.download(st.counts, c, 16);
  }
  // A point word holds a vertex counted from the batch's first segment in 29 bits
  // (brick_sources.comp), the loaded bricks' vertices included.
  if (c[0] >= (1u << 29)) {
    throw VulkanError("GPU polygonizer: a batch of brick layers holds " + std::to_string(c[0]) +
                      " vertices, over 2^29: use smaller batches (maxBatchBricks)");
  }
  const std::uint32_t vertices = batch.ownActive < loaded ? c[2] : c[0];
  const std::uint32_t triangles = batch.ownActive < loaded ? c[3] : c[1];
  if (vertexBase + vertices > 0xffffffffull) {
    throw VulkanError("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
  }
  s.extractSeconds += since(t0);
  s.hostSteps.fieldSubmits += since(fieldStart);

  // 6-7: the batch's vertices and triangles, copied in the same submit into one read-back
  // buffer (skipped where the device buffers are host-readable, as on lavapipe).
  t0 = Clock::now();
  std::uint64_t outBytes = 0;
  auto make = [&](std::uint64_t size, const char* what) { return makeSparseBuffer(device, size, what, outBytes); };
  Buffer positions = make(std::uint64_t(vertices) * 12, "vertex positions");
  Buffer normals = make(options.normals ? std::uint64_t(vertices) * 12 : 16, "vertex normals");
  Buffer colours = make(options.colours ? std::uint64_t(vertices) * 12 : 16, "vertex colours");
  Buffer keys = make(std::uint64_t(vertices) * 8, "edge keys");
  const std::uint64_t cornerBytes = cornerKeys ? 24 : 12;  // per triangle: three indices or three edge keys
  // brick_triangles.comp runs a lane per four triangles: its buffers hold whole groups of four.
  const std::uint64_t triangleQuads = (std::uint64_t(triangles) + 3) / 4;
  Buffer vertexSources = make(std::uint64_t(vertices) * 8, "vertex sources");
  Buffer triangleSources = make(triangleQuads * 4 * 8, "triangle sources");
  // On a CPU device the host assembles the triangles (host_triangles.h) from the sources pass's
  // buffers, straight into the mesh; elsewhere brick_triangles.comp does, into `indices`. (Where
  // the host cannot map these two, brick_sources and brick_triangles run on the device, built at
  // their first dispatch: the runner built no pipeline for them.)
  const bool hostSources = st.hostRowPasses && vertexSources.hostReadable() && triangleSources.hostReadable();
  const bool hostTriangles = !cornerKeys && hostSources;
  Buffer indices = make(hostTriangles ? 16 : triangleQuads * 4 * cornerBytes, "triangle indices");
  const bool vertexWindows = vertices && st.vertexTapes && st.batchVertexWindows;
  Buffer tileVertices =
      vertexTiles.empty() && !vertexWindows ? Buffer{} : make(std::uint64_t(vertices) * 4, "vertex tile lists");
  // Edge keys are 64-bit, low word first on the device (x86 and ARM hosts are little-endian).
  static_assert(sizeof(mesh.edgeKeys[0]) == 8 && std::endian::native == std::endian::little);
  // Each output's room at the end of its mesh array, made before the copies: grow(false) makes
  // room (roomFor), grow(true) appends the elements and returns where they start.
  auto grow = [](auto& vec, std::uint64_t count, double ratio) {
    return std::function<void*(bool)>([&vec, count, ratio](bool fill) -> void* {
      if (fill) return appendElements(vec, count);
      roomFor(vec, count, roomAhead(vec.size() + count, ratio));
      return nullptr;
    });
  };
  struct Output {
    const Buffer* buffer;
    std::uint64_t bytes;
    std::function<void*(bool)> grow;
    std::uint64_t offset = 0;  // in the read-back buffer
    void* to = nullptr;        // where grow made room
    bool madeByHost = false;   // written into `to` by the host, not copied from `buffer`
  };
  std::vector<Output> outputs{{&positions, vertices * 12ull, grow(mesh.positions, vertices, reserveRatio)},
                              {&keys, vertices * 8ull, grow(mesh.edgeKeys, vertices, reserveRatio)},
                              {&indices, triangles * cornerBytes,
                               cornerKeys ? grow(*cornerKeys, 3ull * triangles, 1.0)  // the batch's own
                                          : grow(mesh.triangles, triangles, reserveRatio)}};
  const std::size_t indexOutput = outputs.size() - 1;  // an index: the vector grows below
  outputs[indexOutput].madeByHost = hostTriangles;
  if (options.normals) outputs.push_back({&normals, vertices * 12ull, grow(mesh.normals, vertices, reserveRatio)});
  if (options.colours) outputs.push_back({&colours, vertices * 12ull, grow(mesh.colours, vertices, reserveRatio)});
  // The arrays grow side by side: each one's value-initialising fill is a single thread's, and
  // at 512^3 on a discrete GPU those fills took longer than the device's whole job. Their
  // memory comes from this thread (roomFor).
  auto growOutputs = [&outputs, &s] {
    const auto growStart = Clock::now();
    for (Output& o : outputs)
      if (o.bytes) o.grow(false);
    tbb::parallel_for(std::size_t(0), outputs.size(), [&outputs](std::size_t i) {
      if (outputs[i].bytes) outputs[i].to = outputs[i].grow(true);
    });
    s.hostSteps.grow += since(growStart);
  };
  std::uint64_t stagingBytes = 0;
  for (Output& o : outputs) {
    if (o.buffer->hostReadable() || o.bytes == 0 || o.madeByHost) continue;
    o.offset = stagingBytes;
    stagingBytes += (o.bytes + 15) / 16 * 16;
  }
  Buffer staging = stagingBytes ? device.createBuffer(stagingBytes, MemoryUse::Readback) : Buffer{};
  // With a read-back copy, each output is copied into the mesh as soon as the device has copied
  // it out, while the device copies out the next (one event per output): of the two copies of a
  // 62 MB mesh, only the last output's waits for the fence.
  std::vector<std::size_t> staged;  // outputs with a read-back copy, in copy order
  for (std::size_t i = 0; i < outputs.size(); ++i)
    if (!outputs[i].buffer->hostReadable() && outputs[i].bytes && !outputs[i].madeByHost) staged.push_back(i);
  const std::span<const VkEvent> events = device.hostEvents(std::uint32_t(staged.size()));
  auto copyOut = [&outputs, &staging](std::size_t i) {
    const Output& o = outputs[i];
    copyParallel(o.to, o.buffer->hostReadable() ? o.buffer->mapped() : static_cast<const char*>(staging.mapped()) + o.offset,
                 o.bytes);
  };
  // Grows the arrays, then copies every staged output but the last as the device sets its event.
  auto whileDeviceCopies = [&] {
    growOutputs();
    const auto copyStart = Clock::now();
    for (std::size_t k = 0; k + 1 < staged.size(); ++k) {
      device.waitForHostEvent(events[k]);
      copyOut(staged[k]);
    }
    s.hostSteps.copy += since(copyStart);
  };
  st.peakOutputBytes = std::max(st.peakOutputBytes, outBytes);
  const KernelPtr& vertexKernel = st.vertices();
  if (st.interpretedVertexPass || st.loopedVertexPass) s.vertexGradient = false;
  if (vertices && st.vertexReadsUniforms) s.vertexUniforms = true;
  if (vertices && st.vertexTapes) s.vertexTapes = true;
  s.tapeBytes = std::max(s.tapeBytes, st.tapeBytes());
  // With a read-back copy to wait for (a discrete GPU), the arrays grow while the device works;
  // where the host reads the device's buffers (lavapipe, whose device work is these cores) after.
  // On a CPU device the host lists each tile's vertices (vertex_tile_lists.h) after the sources
  // pass (its own, or the device's in a submit of its own) and before the vertex pass's submit;
  // elsewhere the device does, in one submit.
  const bool hostTileLists = vertices && !vertexTiles.empty() && st.hostScans && vertexSources.hostReadable() &&
                             tileVertices.hostReadable() && st.tileArgs.hostReadable();
  // The vertex tapes' windows are listed on the host alone; where it cannot, the batch's vertex
  // tapes go to the storage buffer after all.
  const bool hostWindowLists = vertexWindows && vertexSources.hostReadable() && tileVertices.hostReadable() &&
                               st.vertexWindowArgs.hostReadable();
  if (vertexWindows && !hostWindowLists) st.uploadVertexTapes(st.batchPacked, gpu, s, false);
  if (hostWindowLists) s.vertexTapeWindows += std::uint32_t(st.vertexWindowTapes.windows.size());
  auto recordSources = [&](Recorder& rec) {
    rec.computeBarrier();
    st.timer.mark(rec, mark + 4);
    if ((vertices || triangles) && !hostSources) {
      const std::uint32_t push[9] = {cells[0], cells[1], cells[2], cells[3], bg.x, bg.y, bg.z, loaded, batch.ownActive};
      const BufferRange bind[8] = {st.masks,           st.segments,   st.cases,        st.vertexSegments,
                                   st.triangleSegments, vertexSources, triangleSources, st.pointWords};
      rec.dispatch(*device.kernel("brick_sources", wgSpec), bind, push, sizeof(push), columnGroups.x, columnGroups.y);
    }
    rec.computeBarrier();
    st.timer.mark(rec, mark + 5);
  };
  auto recordTheRest = [&](Recorder& rec) {
    st.timer.mark(rec, mark + 9);
    if (vertices) {
      struct {
        float originCell[4];
        std::uint32_t codeLength, refineSteps, attributes;
        float normalStep;
        std::uint32_t log2B, vertices, nx, ny, tailBase;
      } push{{originCell[0], originCell[1], originCell[2], originCell[3]},
             gpu.codeLength,
             std::uint32_t(std::max(options.refineSteps, 0)),
             (options.normals ? 1u : 0u) | (options.colours ? 2u : 0u),
             options.normalStep,
             bg.log2B,
             vertices,
             std::uint32_t(st.grid.cells.x + 1),
             std::uint32_t(st.grid.cells.y + 1),
             std::uint32_t(st.fieldTailBase)};
      // The program's buffers, or its uniform blocks for the kernel that reads them there (an
      // interpreting kernel: never the tiles' generated ones).
      auto program = [&](std::size_t i) { return st.vertexReadsUniforms ? BufferRange(st.vertexUniforms[i]) : pb[i]; };
      const BufferRange bind[14] = {program(0),    program(1), program(2), program(3), program(4), st.field,     st.batchBricks,
                                    vertexSources, positions,  normals,    colours,    keys,       tileVertices, st.tileArgs};
      const Groups g = groupsFor(vertices, wg);
      if (hostWindowLists) {
        // A dispatch per window of bricks over its vertex list: its blocks in place of the
        // program (0-4), the list and dispatches (12, 13), the tapes' ranges in their windows (14).
        BufferRange windowBind[15];
        std::copy(bind, bind + 12, windowBind);
        windowBind[12] = tileVertices;
        windowBind[13] = st.vertexWindowArgs;
        windowBind[14] = st.vertexTapeRanges;
        struct {
          decltype(push) vertex;
          std::uint32_t window;
        } windowPush{push, 0};
        for (std::uint32_t w = 0; w < std::uint32_t(st.vertexWindowTapes.windows.size()); ++w) {
          for (std::size_t i = 0; i < 5; ++i)
            windowBind[i] = BufferRange(st.vertexTapeBlocks[i].handle(), w * kUniformTapeBlock, kUniformTapeBlock);
          windowPush.window = w;
          rec.dispatchIndirect(*st.vertexWindowKernel, windowBind, &windowPush, sizeof(windowPush), st.vertexWindowArgs,
                               32ull * w);
        }
      } else if (st.vertexTapes) {  // binding 0: the vertex tapes in place of the program's code; 12: their ranges
        BufferRange tapeBind[13];
        std::copy(bind, bind + 12, tapeBind);
        tapeBind[0] = st.vertexTapeCode;
        tapeBind[12] = st.vertexTapeRanges;
        rec.dispatch(*vertexKernel, tapeBind, &push, sizeof(push), g.x, g.y);
      } else if (vertexTiles.empty()) {
        rec.dispatch(*vertexKernel, std::span(bind, 12), &push, sizeof(push), g.x, g.y);
      } else {
        // Each vertex listed under its brick's tile (counts, runs, lists; made by the host before
        // this submit on a CPU device), then each tile's vertices by its pruned kernel,
        // dispatched indirectly.
        const std::uint32_t tileCount = std::uint32_t(st.tiles.size());
        if (!hostTileLists) {
          const std::uint32_t listPush[2] = {vertices, tileCount};
          const BufferRange listBind[4] = {vertexSources, st.brickTiles, st.tileCounters, tileVertices};
          rec.fill(st.tileCounters, 0);
          rec.computeBarrier();
          rec.dispatch(*device.kernel("brick_vertex_tile_counts", wgSpec), std::span(listBind, 3), listPush, 4, g.x, g.y);
          rec.computeBarrier();
          const std::uint32_t argsPush[2] = {tileCount, wg};
          const BufferRange argsBind[2] = {st.tileCounters, st.tileArgs};
          rec.dispatch(*device.kernel("brick_vertex_tile_args", {}), argsBind, argsPush, sizeof(argsPush), 1);
          rec.computeBarrier();
          rec.dispatch(*device.kernel("brick_vertex_tile_lists", wgSpec), listBind, listPush, sizeof(listPush), g.x, g.y);
          rec.computeBarrier();
        }
        struct {
          decltype(push) vertex;
          std::uint32_t tile;
        } tilePush{push, 0};
        for (std::uint32_t t = 0; t < tileCount; ++t) {
          tilePush.tile = t;
          rec.dispatchIndirect(*vertexTiles[t], bind, &tilePush, sizeof(tilePush), st.tileArgs, 32ull * t);
        }
      }
    }
    st.timer.mark(rec, mark + 6);
    if (triangles && cornerKeys) {
      const std::uint32_t push[4] = {bg.log2B, triangles, std::uint32_t(st.grid.cells.x + 1),
                                     std::uint32_t(st.grid.cells.y + 1)};
      const BufferRange bind[4] = {st.cases, st.batchBricks, triangleSources, indices};
      const Groups g = groupsFor(triangles, wg);
      rec.dispatch(*device.kernel("brick_triangle_keys", wgSpec), bind, &push, sizeof(push), g.x, g.y);
    } else if (triangles && !hostTriangles) {
      const std::uint32_t push[3] = {bg.log2B, triangles, std::uint32_t(vertexBase)};
      const BufferRange bind[5] = {st.cases, st.pointWords, st.neighbours, triangleSources, indices};
      const Groups g = groupsFor(triangleQuads, wg);
      rec.dispatch(*device.kernel("brick_triangles", wgSpec), bind, &push, sizeof(push), g.x, g.y);
    }
    rec.computeBarrier();
    st.timer.mark(rec, mark + 7);
    for (std::size_t k = 0; k < staged.size(); ++k) {
      const Output& o = outputs[staged[k]];
      rec.copy(*o.buffer, 0, staging, o.offset, o.bytes);
      if (k + 1 < staged.size()) rec.signalHost(events[k]);
    }
    st.timer.mark(rec, mark + 8);
    rec.hostBarrier();
  };
  const std::function<void()> whileRunning = stagingBytes ? std::function<void()>(whileDeviceCopies) : nullptr;
  // The sources: the host's, or the device's pass (in a submit of its own where the host lists
  // the tiles' vertices from them: a CPU device whose row buffers the host cannot map).
  const bool sourcesSubmit = !hostSources && (hostTileLists || hostWindowLists);
  if (hostSources) {
    const auto sourcesStart = Clock::now();
    if (vertices || triangles) {
      writeSourcesOnHost(rowLayout, static_cast<const std::uint32_t*>(st.vertexSegments.mapped()),
                         static_cast<const std::uint32_t*>(st.triangleSegments.mapped()),
                         static_cast<std::uint32_t*>(st.pointWords.mapped()),
                         static_cast<std::uint32_t*>(vertexSources.mapped()),
                         static_cast<std::uint32_t*>(triangleSources.mapped()));
    }
    s.hostSteps.sources += since(sourcesStart);
  } else if (sourcesSubmit) {
    submit([&](Recorder& rec) {
      recordSources(rec);
      rec.hostBarrier();
    });
  }
  if (hostWindowLists) {
    const auto listStart = Clock::now();
    listVerticesByTile(static_cast<const std::uint32_t*>(vertexSources.mapped()), vertices, st.vertexWindowOfBrick.data(),
                       std::uint32_t(st.vertexWindowTapes.windows.size()), wg,
                       static_cast<std::uint32_t*>(tileVertices.mapped()),
                       static_cast<std::uint32_t*>(st.vertexWindowArgs.mapped()));
    s.hostSteps.vertexTileLists += since(listStart);
  }
  if (hostTileLists) {
    const auto listStart = Clock::now();
    listVerticesByTile(static_cast<const std::uint32_t*>(vertexSources.mapped()), vertices, st.batchTiles.data(),
                       std::uint32_t(st.tiles.size()), wg, static_cast<std::uint32_t*>(tileVertices.mapped()),
                       static_cast<std::uint32_t*>(st.tileArgs.mapped()));
    s.hostSteps.vertexTileLists += since(listStart);
  }
  submit(
      [&](Recorder& rec) {
        if (sourcesSubmit) {
          rec.computeBarrier();  // the sources pass's writes, made in the last submit
        } else {
          recordSources(rec);  // its dispatch, or only its timestamps where the host wrote them
        }
        recordTheRest(rec);
      },
      whileRunning);
  s.extractSeconds += since(t0);
  s.hostSteps.emitSubmits += since(t0);
  // The batch's vertex pass, for the after-job build's payback (State::tileBuildAfterJobPays):
  // read once the batch has completed, never in the destructor of a job that failed (a query
  // never written would be waited for).
  if (st.tileBuildAfterJobDone && st.timer.enabled()) st.measuredVertexSeconds += st.timer.seconds(mark + 9, mark + 6);

  // What is left after the fence: every output where the host reads the device's buffers
  // (lavapipe), else the last staged one.
  t0 = Clock::now();
  if (!stagingBytes) growOutputs();
  const auto copyStart = Clock::now();
  for (std::size_t i = 0; i < outputs.size(); ++i)
    if (outputs[i].bytes && outputs[i].buffer->hostReadable() && !outputs[i].madeByHost) copyOut(i);
  if (!staged.empty()) copyOut(staged.back());
  s.readbackSeconds += since(t0);
  s.hostSteps.copy += since(copyStart);
  if (hostTriangles && triangles) {
    const auto trianglesStart = Clock::now();
    const HostTriangleInputs in{static_cast<const std::uint32_t*>(triangleSources.mapped()),
                                static_cast<const std::uint32_t*>(st.pointWords.mapped()),
                                static_cast<const std::uint32_t*>(st.neighbours.mapped()), bg.log2B,
                                std::uint32_t(vertexBase)};
    assembleTrianglesOnHost(in, triangles, static_cast<std::array<std::uint32_t, 3>*>(outputs[indexOutput].to));
    s.hostSteps.triangles += since(trianglesStart);
    s.extractSeconds += since(trianglesStart);
  }
}

}  // namespace blobvk::vk
