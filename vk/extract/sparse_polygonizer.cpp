#include "blobvk/vk/extract/sparse_polygonizer.h"

#include "blobvk/vk/device/device_timer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/extract/case_table.h"
#include "blobvk/vk/extract/host_copy.h"
#include "blobvk/vk/extract/scan.h"

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cstring>
#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

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

// The per-pass buffers, allocated once the counts they depend on are known.
struct Buffers {
  Device& device;
  std::uint64_t bytes = 0;
  Buffer make(std::uint64_t size, const char* what) {
    const std::uint64_t range = device.info().limits.maxStorageBufferRange;
    if (size > range) {
      throw VulkanError(std::string("GPU polygonizer: the sparse extraction's ") + what + " need " +
                        std::to_string(size >> 20) + " MiB, over the device's maxStorageBufferRange (" +
                        std::to_string(range >> 20) + " MiB): use a smaller grid");
    }
    bytes += std::max<std::uint64_t>(size, 16);
    return device.createBuffer(std::max<std::uint64_t>(size, 16));
  }
};

// brick_classify over every brick of the grid, into flags[0 .. bricks] (the last word 0).
void recordClassify(Recorder& rec, const GpuProgram& gpu, const blobtree::GridSpec& grid, const BrickGrid& bg,
                    const Buffer& flags) {
  const auto pb = gpu.bindings();
  struct {
    float originCell[4];
    std::uint32_t cells[4], bricks[4];
  } push{{grid.origin.x, grid.origin.y, grid.origin.z, grid.cellSize},
         {std::uint32_t(grid.cells.x), std::uint32_t(grid.cells.y), std::uint32_t(grid.cells.z), bg.log2B},
         {bg.x, bg.y, bg.z, gpu.codeLength}};
  const BufferRange bind[6] = {pb[0], pb[1], pb[2], pb[3], pb[4], flags};
  // Constants 3-5: the program's opcode, primitive and warp masks (the others are not used).
  const auto specs = gpu.specs(64, Traversal::Stackless);
  rec.dispatch(*rec.device().kernel("brick_classify", specs), bind, &push, sizeof(push), (bg.x + 3) / 4,
               (bg.y + 3) / 4, (bg.z + 3) / 4);
}

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

std::vector<std::uint32_t> classifyBricks(Device& device, const blobtree::Program& program,
                                          const blobtree::GridSpec& grid, std::uint32_t brickCells) {
  const BrickGrid bg = brickGridFor(grid, brickCells);
  const GpuProgram gpu = uploadProgram(device, program, Traversal::Stackless);
  Buffer flags = device.createBuffer((bg.count() + 1) * 4);
  device.run([&](Recorder& rec) {
    recordClassify(rec, gpu, grid, bg, flags);
    rec.hostBarrier();
  });
  std::vector<std::uint32_t> out(bg.count());
  device.download(flags, out.data(), out.size() * 4);
  return out;
}

BrickGrid brickGridFor(const blobtree::GridSpec& grid, std::uint32_t brickCells) {
  if (brickCells < 2 || brickCells > 16 || !std::has_single_bit(brickCells)) {
    throw VulkanError("GPU polygonizer: the brick size must be a power of two from 2 to 16 cells, not " +
                      std::to_string(brickCells));
  }
  BrickGrid b;
  b.log2B = std::uint32_t(std::countr_zero(brickCells));
  b.x = (std::uint32_t(grid.cells.x) + brickCells - 1) / brickCells;
  b.y = (std::uint32_t(grid.cells.y) + brickCells - 1) / brickCells;
  b.z = (std::uint32_t(grid.cells.z) + brickCells - 1) / brickCells;
  if (std::max({b.x, b.y, b.z}) > 1024) {
    throw VulkanError("GPU polygonizer: " + std::to_string(std::max({b.x, b.y, b.z})) +
                      " bricks along an axis (at most 1024): use larger bricks");
  }
  return b;
}

std::uint64_t sparseDeviceBytes(const BrickGrid& bricks, std::uint64_t activeBricks, std::uint64_t vertices,
                                std::uint64_t triangles, bool normals, bool colours) {
  const std::uint64_t B = 1ull << bricks.log2B, R = B + 1;
  const std::uint64_t perBrick = R * R * R * 4   // field
                                 + R * R * 32    // inside and edge masks, vertex segments, their rows
                                 + B * B * 12;   // triangle segments, their rows
  const std::uint64_t scan = (scanScratchWords(bricks.count() + 1) + scanScratchWords(activeBricks * R * R) +
                              scanScratchWords(activeBricks * B * B)) * 4;
  const std::uint64_t outputs = vertices * (12 + 8 + (normals ? 12 : 0) + (colours ? 12 : 0)) + triangles * 12;
  return (bricks.count() + 1) * 8 + activeBricks * perBrick + scan + outputs + 256 * 20 * 4;
}

mesh::TriMesh polygonizeSparse(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                               const GpuPolygonizeOptions& options, GpuStats* stats) {
  mesh::TriMesh mesh;
  GpuStats s;
  const BrickGrid bg = brickGridFor(grid, options.brickCells);
  const std::uint32_t B = 1u << bg.log2B, R = B + 1, P = R * R * R, wg = options.workgroupSize;
  s.brickCells = B;
  s.bricks = std::uint32_t(bg.count());

  Traversal traversal = options.traversal;
  std::optional<CodegenOptions> codegen;
  if (options.codegen) codegen = *options.codegen;
  if (traversal == Traversal::Auto) {
    EvaluatorJob job;
    job.vertexPass = true;
    job.refineSteps = options.refineSteps;
    job.repeats = std::max<std::uint32_t>(options.expectedRuns, 1);
    job.tiling.maxTiles = 1;
    if (!codegen) codegen = defaultCodegenOptions(device);
    const EvaluatorEstimate chosen = chooseEvaluator(device, program, grid, job, *codegen).chosen;
    traversal = chosen.traversal;
    codegen->gradient = chosen.vertexGradient;
  }
  // Uploads (the program, the case table) ride in the next submit instead of their own.
  UploadBatch uploads(device);
  const GpuProgram gpu = uploadProgram(device, program, traversal, codegen ? &*codegen : nullptr);
  const auto pb = gpu.bindings();
  // The classification interprets the register code; the stack-based traversal uploads a tree
  // encoding instead, so the classification gets the register code of its own.
  std::optional<GpuProgram> registerCode;
  if (traversal == Traversal::StackBased) registerCode.emplace(uploadProgram(device, program, Traversal::Stackless));
  const GpuProgram& classifyProgram = registerCode ? *registerCode : gpu;
  Buffers buf{device};
  const std::array<std::uint32_t, 1> wgSpec{wg};
  const float originCell[4] = {grid.origin.x, grid.origin.y, grid.origin.z, grid.cellSize};
  const std::uint32_t cells[4] = {std::uint32_t(grid.cells.x), std::uint32_t(grid.cells.y),
                                  std::uint32_t(grid.cells.z), bg.log2B};

  // Submits: one classifies and compacts the bricks; then, per batch of whole brick layers, one
  // runs field, masks, rows and scans (-> the batch's counts) and one vertices, triangles and
  // the copies into one read-back buffer. Counts land in host-readable memory, uploads ride in
  // the next submit.
  const auto wallStart = Clock::now();
  auto submit = [&](const std::function<void(Recorder&)>& record) {
    device.run(record);
    ++s.submits;
  };

  // 1-2: classify every brick, scan the flags, list the active ones; read back where each brick
  // layer's active bricks start.
  DeviceTimer classifyTimer(device, 2);
  auto t0 = Clock::now();
  const std::uint64_t brickCount = bg.count();
  const std::uint32_t layers = bg.z, layerBricks = bg.x * bg.y;
  Buffer brickScan = buf.make((brickCount + 1) * 4, "brick flags");
  Buffer brickList = buf.make(brickCount * 4, "brick list");
  Buffer scratch = buf.make((scanScratchWords(brickCount + 1) + 1) * 4, "scan scratch");
  Buffer totals = buf.make(16, "totals");
  Buffer layerStarts = device.createBuffer((layers + 1) * 4ull, MemoryUse::Readback);
  submit([&](Recorder& rec) {
    classifyTimer.reset(rec);
    classifyTimer.mark(rec, 0);
    recordClassify(rec, classifyProgram, grid, bg, brickScan);
    rec.computeBarrier();
    recordExclusiveScan(rec, brickScan.handle(), 0, std::uint32_t(brickCount + 1), scratch.handle(), 0,
                        totals.handle(), 0);
    rec.computeBarrier();
    {
      const std::uint32_t push[4] = {bg.x, bg.y, bg.z, 0};
      const BufferRange bind[2] = {brickScan, brickList};
      rec.dispatch(*device.kernel("brick_compact", {}), bind, push, sizeof(push), (bg.x + 3) / 4, (bg.y + 3) / 4,
                   (bg.z + 3) / 4);
    }
    for (std::uint32_t z = 0; z <= layers; ++z) rec.copy(brickScan, 4ull * z * layerBricks, layerStarts, 4ull * z, 4);
    classifyTimer.mark(rec, 1);
    rec.hostBarrier();
  });
  std::vector<std::uint32_t> starts(layers + 1);
  device.download(layerStarts, starts.data(), starts.size() * 4);
  const std::uint32_t active = starts[layers];
  s.activeBricks = active;
  s.classifySeconds = since(t0);

  // Batches of whole brick layers, each holding one layer more than it emits: a triangle of its
  // last layer may use a vertex that the next layer's bricks own (their lower face), whose index
  // comes from that layer's scanned segments. Bricks per batch are bounded by the device's
  // storage-buffer range and the batch memory budget; the per-brick buffers are sized once.
  const std::uint64_t perBrickBytes = std::uint64_t(P) * 4 + std::uint64_t(R) * R * 32 + std::uint64_t(B) * B * 12;
  const std::uint64_t range = device.info().limits.maxStorageBufferRange;
  const std::uint64_t rangeBricks = std::min(range / (std::uint64_t(P) * 4), range / (std::uint64_t(R) * R * 16));
  const std::uint64_t limit = std::min<std::uint64_t>(
      rangeBricks, options.maxBatchBricks ? options.maxBatchBricks
                                          : std::max<std::uint64_t>(1, sparseBatchBudget(device) / perBrickBytes));
  struct Batch {
    std::uint32_t activeBase, ownActive, loadedActive;
  };
  std::vector<Batch> batches;
  std::uint32_t maxLoaded = 0;
  for (std::uint32_t z = 0; z < layers;) {
    if (starts[z + 1] == starts[z]) {
      ++z;
      continue;
    }
    auto loaded = [&](std::uint32_t end) { return starts[std::min(end + 1, layers)] - starts[z]; };
    std::uint32_t end = z + 1;
    while (end < layers && loaded(end + 1) <= limit) ++end;
    if (loaded(end) > rangeBricks) {
      throw VulkanError("GPU polygonizer: two brick layers hold " + std::to_string(loaded(end)) +
                        " active bricks, over the " + std::to_string(rangeBricks) +
                        " one storage buffer can hold (maxStorageBufferRange): use a smaller grid or bricks");
    }
    batches.push_back({starts[z], starts[end] - starts[z], loaded(end)});
    maxLoaded = std::max(maxLoaded, loaded(end));
    z = end;
  }
  s.batches = std::uint32_t(batches.size());
  DeviceTimer batchTimer(device, 6 * s.batches);
  auto finish = [&] {
    s.seconds = since(wallStart);
    if (classifyTimer.enabled()) {
      s.deviceTimed = true;
      s.classifySeconds = classifyTimer.seconds(0, 1);
      s.fieldSeconds = s.extractSeconds = 0.0;
      double copies = 0.0;
      for (std::uint32_t b = 0; b < s.batches; ++b) {
        const std::uint32_t m = 6 * b;
        s.fieldSeconds += batchTimer.seconds(m, m + 1);
        s.extractSeconds += batchTimer.seconds(m + 1, m + 2) + batchTimer.seconds(m + 3, m + 4);
        copies += batchTimer.seconds(m + 4, m + 5);
      }
      s.readbackSeconds += copies;
    }
    s.hostSeconds = std::max(0.0, s.seconds - s.classifySeconds - s.fieldSeconds - s.extractSeconds -
                                      s.readbackSeconds);
    if (stats) *stats = s;
  };
  if (active == 0) {
    s.deviceBytes = buf.bytes;
    finish();
    return mesh;
  }

  // The per-brick buffers, for the largest batch.
  const std::uint64_t maxRows = std::uint64_t(maxLoaded) * R * R, maxCellRows = std::uint64_t(maxLoaded) * B * B;
  Buffer batchBricks = buf.make(std::uint64_t(maxLoaded) * 4, "batch brick list");
  Buffer field = buf.make(std::uint64_t(maxLoaded) * P * 4, "field samples");
  const std::vector<std::uint32_t>& words = packedCaseTable();
  Buffer cases = buf.make(words.size() * 4, "case table");
  device.upload(cases, words.data(), words.size() * 4);
  Buffer masks = buf.make(maxRows * 4, "inside masks");
  Buffer edges = buf.make(maxRows * 16, "edge masks");
  Buffer vertexSegments = buf.make(maxRows * 4, "vertex segments");
  Buffer vertexRows = buf.make(maxRows * 8, "vertex segment rows");
  Buffer triangleSegments = buf.make(maxCellRows * 4, "triangle segments");
  Buffer triangleRows = buf.make(maxCellRows * 8, "triangle segment rows");
  const std::uint64_t vertexScratch = scanScratchWords(maxRows);
  Buffer segmentScratch = buf.make((vertexScratch + scanScratchWords(maxCellRows) + 1) * 4, "segment scan scratch");
  Buffer counts = device.createBuffer(16, MemoryUse::Readback);
  const KernelPtr fieldKernel = evaluatorKernel(device, gpu, "brick_field", wg, traversal);
  const KernelPtr vertexKernel = evaluatorKernel(device, gpu, "brick_vertices", wg, traversal);
  const std::uint64_t sharedBytes = buf.bytes;
  std::uint64_t peakOutputBytes = 0;
  std::uint64_t vertexBase = 0;
  // Edge keys are 64-bit, low word first on the device (x86 and ARM hosts are little-endian).
  static_assert(sizeof(mesh.edgeKeys[0]) == 8 && std::endian::native == std::endian::little);
  auto append = [](auto& vec, std::uint64_t count) {
    return [&vec, count](const void* from) {
      using T = typename std::remove_reference_t<decltype(vec)>::value_type;
      static_assert(std::is_trivially_copyable_v<T>);
      appendParallel(vec, static_cast<const T*>(from), count);
    };
  };

  for (std::uint32_t bi = 0; bi < s.batches; ++bi) {
    const Batch& batch = batches[bi];
    const std::uint32_t mark = 6 * bi, loaded = batch.loadedActive;
    const BrickGroups bgroups = brickGroups(loaded);
    const std::uint64_t rowCount = std::uint64_t(loaded) * R * R;
    const std::uint64_t triangleSegmentCount = std::uint64_t(loaded) * B * B;
    const std::uint32_t rowGroups = (R * R + wg - 1) / wg;
    s.fieldEvaluations += std::uint64_t(loaded) * P;

    // 3-5: the field at the batch's points; inside masks per row of points, crossing edges and
    // counts per row; the two scans; the counts of the layers the batch emits.
    t0 = Clock::now();
    submit([&](Recorder& rec) {
      if (bi == 0) batchTimer.reset(rec);
      rec.computeBarrier();  // the last batch's reads and writes of the shared buffers come first
      batchTimer.mark(rec, mark);
      rec.copy(brickList, 4ull * batch.activeBase, batchBricks, 0, 4ull * loaded);
      rec.computeBarrier();
      {
        struct {
          float originCell[4];
          std::uint32_t log2B, activeBricks, codeLength;
        } push{{originCell[0], originCell[1], originCell[2], originCell[3]}, bg.log2B, loaded, gpu.codeLength};
        const BufferRange bind[7] = {pb[0], pb[1], pb[2], pb[3], pb[4], batchBricks, field};
        rec.dispatch(*fieldKernel, bind, &push, sizeof(push), (P + wg - 1) / wg, bgroups.y, bgroups.z);
      }
      rec.computeBarrier();
      batchTimer.mark(rec, mark + 1);
      {
        const std::uint32_t push[2] = {bg.log2B, loaded};
        const BufferRange bind[2] = {field, masks};
        rec.dispatch(*device.kernel("brick_masks", wgSpec), bind, push, sizeof(push), rowGroups, bgroups.y,
                     bgroups.z);
      }
      rec.computeBarrier();
      {
        const std::uint32_t push[9] = {cells[0], cells[1], cells[2], cells[3], bg.x, bg.y, bg.z, loaded,
                                       batch.activeBase};
        const BufferRange bind[9] = {masks, batchBricks, cases, edges, vertexSegments, vertexRows, triangleSegments,
                                     triangleRows, brickScan};
        rec.dispatch(*device.kernel("brick_rows", wgSpec), bind, push, sizeof(push), rowGroups, bgroups.y,
                     bgroups.z);
      }
      rec.computeBarrier();
      recordExclusiveScan(rec, vertexSegments.handle(), 0, std::uint32_t(rowCount), segmentScratch.handle(), 0,
                          counts.handle(), 0);
      rec.computeBarrier();  // the scans share the scratch and totals buffers (see slab_polygonizer.cpp)
      recordExclusiveScan(rec, triangleSegments.handle(), 0, std::uint32_t(triangleSegmentCount),
                          segmentScratch.handle(), std::uint32_t(vertexScratch), counts.handle(), 1);
      rec.computeBarrier();
      if (batch.ownActive < loaded) {  // where the next layer's segments start
        rec.copy(vertexSegments, 4ull * batch.ownActive * R * R, counts, 8, 4);
        rec.copy(triangleSegments, 4ull * batch.ownActive * B * B, counts, 12, 4);
      }
      batchTimer.mark(rec, mark + 2);
      rec.hostBarrier();
    });
    std::uint32_t c[4] = {0, 0, 0, 0};
    device.download(counts, c, 16);
    const std::uint32_t vertices = batch.ownActive < loaded ? c[2] : c[0];
    const std::uint32_t triangles = batch.ownActive < loaded ? c[3] : c[1];
    if (vertexBase + vertices > 0xffffffffull) {
      throw VulkanError("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
    }
    s.extractSeconds += since(t0);

    // 6-7: the batch's vertices and triangles, copied in the same submit into one read-back
    // buffer (skipped where the device buffers are host-readable, as on lavapipe).
    t0 = Clock::now();
    Buffers out{device};
    Buffer positions = out.make(std::uint64_t(vertices) * 12, "vertex positions");
    Buffer normals = out.make(options.normals ? std::uint64_t(vertices) * 12 : 16, "vertex normals");
    Buffer colours = out.make(options.colours ? std::uint64_t(vertices) * 12 : 16, "vertex colours");
    Buffer keys = out.make(std::uint64_t(vertices) * 8, "edge keys");
    Buffer indices = out.make(std::uint64_t(triangles) * 12, "triangle indices");
    struct Output {
      const Buffer* buffer;
      std::uint64_t bytes;
      std::function<void(const void*)> fill;
      std::uint64_t offset = 0;  // in the read-back buffer
    };
    std::vector<Output> outputs{{&positions, vertices * 12ull, append(mesh.positions, vertices)},
                                {&keys, vertices * 8ull, append(mesh.edgeKeys, vertices)},
                                {&indices, triangles * 12ull, append(mesh.triangles, triangles)}};
    if (options.normals) outputs.push_back({&normals, vertices * 12ull, append(mesh.normals, vertices)});
    if (options.colours) outputs.push_back({&colours, vertices * 12ull, append(mesh.colours, vertices)});
    std::uint64_t stagingBytes = 0;
    for (Output& o : outputs) {
      if (o.buffer->hostReadable() || o.bytes == 0) continue;
      o.offset = stagingBytes;
      stagingBytes += (o.bytes + 15) / 16 * 16;
    }
    Buffer staging = stagingBytes ? device.createBuffer(stagingBytes, MemoryUse::Readback) : Buffer{};
    peakOutputBytes = std::max(peakOutputBytes, out.bytes);
    submit([&](Recorder& rec) {
      rec.computeBarrier();
      batchTimer.mark(rec, mark + 3);
      if (vertices) {
        struct {
          float originCell[4];
          std::uint32_t codeLength, refineSteps, attributes;
          float normalStep;
          std::uint32_t log2B, segments, vertices, nx, ny;
        } push{{originCell[0], originCell[1], originCell[2], originCell[3]},
               gpu.codeLength,
               std::uint32_t(std::max(options.refineSteps, 0)),
               (options.normals ? 1u : 0u) | (options.colours ? 2u : 0u),
               options.normalStep,
               bg.log2B,
               std::uint32_t(rowCount),
               vertices,
               std::uint32_t(grid.cells.x + 1),
               std::uint32_t(grid.cells.y + 1)};
        const BufferRange bind[14] = {pb[0], pb[1], pb[2], pb[3], pb[4], field, edges, batchBricks, vertexSegments,
                                      vertexRows, positions, normals, colours, keys};
        const Groups g = groupsFor(vertices, wg);
        rec.dispatch(*vertexKernel, bind, &push, sizeof(push), g.x, g.y);
      }
      if (triangles) {
        struct {
          std::uint32_t cells[4], bricks[4];
          std::uint32_t segments, triangles, activeBase, vertexBase;
        } push{{cells[0], cells[1], cells[2], cells[3]}, {bg.x, bg.y, bg.z, loaded},
               std::uint32_t(triangleSegmentCount), triangles, batch.activeBase, std::uint32_t(vertexBase)};
        const BufferRange bind[9] = {masks, cases, edges, vertexSegments, triangleSegments, triangleRows, batchBricks,
                                     indices, brickScan};
        const Groups g = groupsFor(triangles, wg);
        rec.dispatch(*device.kernel("brick_triangles", wgSpec), bind, &push, sizeof(push), g.x, g.y);
      }
      rec.computeBarrier();
      batchTimer.mark(rec, mark + 4);
      for (const Output& o : outputs) {
        if (!o.buffer->hostReadable()) rec.copy(*o.buffer, 0, staging, o.offset, o.bytes);
      }
      batchTimer.mark(rec, mark + 5);
      rec.hostBarrier();
    });
    s.extractSeconds += since(t0);

    t0 = Clock::now();
    for (const Output& o : outputs) {
      if (o.bytes == 0) continue;
      o.fill(o.buffer->hostReadable() ? o.buffer->mapped() : static_cast<const char*>(staging.mapped()) + o.offset);
    }
    s.readbackSeconds += since(t0);
    vertexBase += vertices;
  }
  s.deviceBytes = sharedBytes + peakOutputBytes;
  finish();
  return mesh;
}

}  // namespace blobvk::vk
