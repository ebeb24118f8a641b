#include "blobvk/vk/extract/multi_device.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/extract/host_copy.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/sparse_batches.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "blobvk/vk/extract/streamed_extract.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace blobvk::vk {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The batches' hand-out and join, shared by the device threads and the joining thread.
struct Queue {
  std::mutex mutex;
  std::condition_variable changed;
  std::size_t next = 0, joined = 0, window = 1;
  std::vector<std::optional<mesh::TriMesh>> pieces;  // finished batches not yet joined
  std::exception_ptr error;
};

// What in `program` the CPU and lavapipe do not compute bit for bit (llvmpipe's pow, sin and
// cos are not the C library's: docs/vulkan.md, the floating-point table), or empty.
std::string inexactOnLavapipe(const blobtree::Program& program) {
  for (const auto& in : program.code) {
    const std::uint32_t op = in.code.x & 0xffu;
    if (op == layout::OP_POW) return "a Ricci blend (pow)";
    if (op == layout::OP_WARP && in.code.y < program.warps.size()) {
      const std::uint32_t type = program.warps[in.code.y].meta.x;
      if (type == layout::WARP_TWIST) return "a twist warp (sin, cos)";
      if (type == layout::WARP_BEND) return "a bend warp (sin, cos)";
    }
  }
  return {};
}

template <class T, class A>
void appendAll(std::vector<T, A>& to, const std::vector<T, A>& from) {
  appendParallel(to, from.data(), from.size());
}

// Appends a batch's piece (triangle indices counted from its own first vertex) to the mesh.
void join(mesh::TriMesh& mesh, const mesh::TriMesh& piece) {
  const std::uint64_t base = mesh.positions.size();
  if (base + piece.positions.size() > 0xffffffffull) {
    throw VulkanError("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
  }
  appendAll(mesh.positions, piece.positions);
  appendAll(mesh.normals, piece.normals);
  appendAll(mesh.colours, piece.colours);
  appendAll(mesh.edgeKeys, piece.edgeKeys);
  const std::size_t t0 = mesh.triangles.size();
  appendAll(mesh.triangles, piece.triangles);
  const std::uint32_t offset = std::uint32_t(base);
  for (std::size_t t = t0; t < mesh.triangles.size(); ++t)
    for (std::uint32_t& v : mesh.triangles[t]) v += offset;
}

// The workers checked: distinct devices, and a host worker only beside CPU-type devices and for
// programs they compute as the CPU does. Returns the host worker to use (null: none).
const HostBatchWorker* checkWorkers(std::span<Device* const> devices, const blobtree::Program& program,
                                    const HostBatchWorker* host) {
  if (devices.empty()) throw VulkanError("GPU polygonizer: no device to run on");
  for (std::size_t i = 0; i < devices.size(); ++i) {
    if (!devices[i]) throw VulkanError("GPU polygonizer: device " + std::to_string(i) + " is null");
    for (std::size_t j = 0; j < i; ++j) {
      if (devices[j] == devices[i]) {
        throw VulkanError("GPU polygonizer: devices " + std::to_string(j) + " and " + std::to_string(i) +
                          " are the same Device object (open the physical device twice instead)");
      }
    }
  }
  if (host && !host->run) host = nullptr;
  // The host's pieces resolve their last layer's corners from its own run of the next layer, a
  // device's from its own: the indices agree only where both compute the same floats, which the
  // CPU and lavapipe do (docs/vulkan.md) and a GPU does not promise.
  if (host) {
    for (Device* d : devices)
      if (d && d->info().type != VK_PHYSICAL_DEVICE_TYPE_CPU)
        throw VulkanError("GPU polygonizer: the CPU worker joins CPU-type devices only (lavapipe), not " +
                          std::string(d->info().name));
    // Which batches the CPU takes depends on timing, so its pieces must be the devices' bytes.
    if (const std::string what = inexactOnLavapipe(program); !what.empty())
      throw VulkanError("GPU polygonizer: the CPU worker's batches equal lavapipe's only for programs without Ricci "
                        "blends and twist or bend warps, and this one has " + what +
                        ": the mesh would depend on which worker took which batch (run without the CPU worker)");
  }
  return host;
}

// Whether one worker runs the whole job (no batches to share).
bool oneWorker(std::span<Device* const> devices, const HostBatchWorker* host, const blobtree::GridSpec& grid) {
  return devices.size() + (host ? 1 : 0) == 1 || grid.cells.x < 1 || grid.cells.y < 1 || grid.cells.z < 1;
}

// A finished batch's piece, handed over in batch order: its vertices, and its triangles with
// indices counted from its first vertex (corners on the next batch's vertices numbered past its own).
using PieceTaker = std::function<void(mesh::TriMesh& piece, std::size_t batch, std::size_t batches)>;

// The job on several workers (checked by checkWorkers), each piece given to `take` in batch order.
void runOnDevices(std::span<Device* const> devices, const blobtree::Program& program, const blobtree::GridSpec& grid,
                  const GpuPolygonizeOptions& options, GpuStats* stats, std::vector<GpuStats>* perDevice,
                  const HostBatchWorker* host, const PieceTaker& takePiece) {
  const std::size_t n = devices.size();
  const std::size_t workers = n + (host ? 1 : 0);
  if (!options.sparse || options.tiledVertexPass) {
    throw VulkanError("GPU polygonizer: several devices need the sparse extraction (not the dense one, nor tiled vertices)");
  }

  const auto wallStart = Clock::now();
  GpuStats s;
  std::vector<GpuStats> shares(workers);
  s.devices = std::uint32_t(n);
  Device& first = *devices[0];
  // Bricks whose layer pairs fit every device's storage-buffer range.
  const auto rangeBricks = [&devices](const BrickGrid& b) {
    std::uint64_t range = ~0ull;
    for (Device* d : devices) range = std::min(range, sparseRangeBricks(*d, b));
    return range;
  };
  // Bricks whose rows fit the loop limit of every llvmpipe among the devices (loop_limit.h), for
  // whichever evaluator the model picks (the interpreter's bound where it may pick it).
  std::uint32_t brickCells = options.brickCells;
  for (Device* d : devices) brickCells = brickCellsForLoopLimit(d->info(), program, options, brickCells);
  // One evaluator for every device: the bytes must not depend on which device ran a batch.
  const ClassifiedBricks classified = classifyToFit(first, program, grid, brickCells, rangeBricks, shares[0],
                                                    options.windowLayers, {}, options.phaseNote,
                                                    options.classifyProgress);
  const BrickGrid& bg = classified.bricks;
  s.brickCells = 1u << bg.log2B;
  s.bricks = std::uint32_t(bg.count());
  const SparseEvaluator evaluator = resolveSparseEvaluator(first, program, grid, options, &classified);
  evaluator.report(s);
  const GpuPolygonizeOptions resolved = evaluator.apply(options);
  const std::uint32_t active = classified.layerStarts.back();
  s.activeBricks = active;
  s.classifySeconds = shares[0].classifySeconds;
  s.deviceTimed = shares[0].deviceTimed;

  const std::uint64_t range = rangeBricks(bg);
  std::uint64_t limit = ~0ull;
  for (Device* d : devices) limit = std::min(limit, sparseBatchLimit(*d, bg, options.maxBatchBricks));
  std::uint64_t ownTarget = ~0ull;
  if (!options.maxBatchBricks) {
    // With the CPU beside the devices the workers' speeds differ: at least 4 batches each, so that
    // the faster ones take more.
    const std::uint32_t perWorker = std::max<std::uint32_t>(options.batchesPerDevice, host ? 4 : 1);
    const std::uint64_t pieces = workers * perWorker;
    ownTarget = std::max<std::uint64_t>(1, (active + pieces - 1) / pieces);
  }
  const std::vector<SparseBatch> batches =
      planSparseBatches(classified.layerStarts, limit, range, ownTarget, classified.windowEnds());
  s.batches = std::uint32_t(batches.size());
  std::uint32_t maxLoaded = 0;
  for (const SparseBatch& b : batches) maxLoaded = std::max(maxLoaded, b.loadedActive);

  // The other devices get the classification's tables from the host (the first device's copy).
  std::vector<std::vector<std::uint32_t>> rowWords, listWords;
  if (!batches.empty() && n > 1) {
    const std::uint32_t layers = std::uint32_t(classified.layerStarts.size() - 1);
    for (const ScanWindow& w : classified.windows) {
      // The list's bricks, not its room (a single window's has room for every brick).
      const std::uint32_t listed = classified.layerStarts[std::min(w.endLayer + 2, layers)] - w.activeBase;
      rowWords.emplace_back(w.rowStarts.size() / 4);
      listWords.emplace_back(std::max<std::uint32_t>(listed, 1));
      first.download(w.rowStarts, rowWords.back().data(), w.rowStarts.size());
      if (listed) first.download(w.list, listWords.back().data(), 4ull * listed);
    }
  }

  Queue q;
  q.pieces.resize(batches.size());
  q.window = 2 * workers;
  // Hands out the next batch (or none: all taken, or an error) and stores finished pieces.
  auto take = [&q, &batches](std::size_t& b) {
    std::unique_lock lock(q.mutex);
    q.changed.wait(lock, [&] { return q.error || q.next >= batches.size() || q.next < q.joined + q.window; });
    if (q.error || q.next >= batches.size()) return false;
    b = q.next++;
    return true;
  };
  auto give = [&q](std::size_t b, mesh::TriMesh piece) {
    {
      std::lock_guard lock(q.mutex);
      q.pieces[b] = std::move(piece);
    }
    q.changed.notify_all();
  };
  auto fail = [&q] {
    std::lock_guard lock(q.mutex);
    if (!q.error) q.error = std::current_exception();
    q.changed.notify_all();
  };
  auto work = [&](std::size_t d) {
    GpuStats& share = shares[d];
    const auto busyStart = Clock::now();
    try {
      Device& device = *devices[d];
      std::uint64_t tableBytes = 0;
      std::vector<ScanWindow> copies;
      if (d > 0) {
        for (std::size_t k = 0; k < classified.windows.size(); ++k) {
          ScanWindow w = {classified.windows[k].firstLayer, classified.windows[k].endLayer,
                          classified.windows[k].activeBase, {}, {}};
          w.rowStarts = makeSparseBuffer(device, rowWords[k].size() * 4, "brick row starts", tableBytes);
          w.list = makeSparseBuffer(device, listWords[k].size() * 4, "brick list", tableBytes);
          device.upload(w.rowStarts, rowWords[k].data(), rowWords[k].size() * 4);
          device.upload(w.list, listWords[k].data(), listWords[k].size() * 4);
          copies.push_back(std::move(w));
        }
      }
      SparseBatchRunner runner(device, program, grid, resolved, resolved.traversal, bg,
                               d ? std::span<const ScanWindow>(copies) : std::span<const ScanWindow>(classified.windows),
                               maxLoaded, s.batches);
      for (std::size_t b = 0; take(b);) {
        mesh::TriMesh piece;
        runner.run(batches[b], 0, piece, share);
        ++share.batches;
        give(b, std::move(piece));
      }
      runner.deviceTimes(share);
      // Device 0 also classified: its peak is the classification's or the batches', whichever is larger.
      const std::uint64_t batchBytes = runner.sharedBytes() + runner.peakOutputBytes();
      share.deviceBytes = d ? tableBytes + batchBytes : classified.peakBytes(batchBytes);
    } catch (...) {
      fail();
    }
    share.seconds = since(busyStart);
  };
  auto hostWork = [&] {
    GpuStats& share = shares[n];
    const auto busyStart = Clock::now();
    try {
      for (std::size_t b = 0; take(b);) {
        const SparseBatch& batch = batches[b];
        mesh::TriMesh piece = host->run(batch.firstLayer, batch.endLayer, 1u << bg.log2B);
        ++share.batches;
        give(b, std::move(piece));
      }
    } catch (...) {
      fail();
    }
    share.seconds = since(busyStart);
  };

  {
    std::vector<std::jthread> threads;
    try {
      // A thread that cannot start fails the job (inside the try): the ones started see the
      // error in take() and end, so their joins below cannot wait for ever.
      if (!batches.empty()) {
        for (std::size_t d = 0; d < n; ++d) threads.emplace_back(work, d);
        if (host) threads.emplace_back(hostWork);
      }
      for (std::size_t b = 0; b < batches.size(); ++b) {
        mesh::TriMesh piece;
        {
          std::unique_lock lock(q.mutex);
          q.changed.wait(lock, [&] { return q.error || q.pieces[b].has_value(); });
          if (q.error) break;
          piece = std::move(*q.pieces[b]);
          q.pieces[b].reset();
        }
        takePiece(piece, b, batches.size());
        {
          std::lock_guard lock(q.mutex);
          q.joined = b + 1;
        }
        q.changed.notify_all();
      }
    } catch (...) {
      fail();
    }
  }  // the device threads end here
  if (q.error) std::rethrow_exception(q.error);

  for (const GpuStats& share : shares) {
    s.submits += share.submits;
    s.fieldEvaluations += share.fieldEvaluations;
    s.fieldSeconds += share.fieldSeconds;
    s.extractSeconds += share.extractSeconds;
    s.edgesSeconds += share.edgesSeconds;
    s.scansSeconds += share.scansSeconds;
    s.sourcesSeconds += share.sourcesSeconds;
    s.trianglesSeconds += share.trianglesSeconds;
    s.verticesSeconds += share.verticesSeconds;
    s.readbackSeconds += share.readbackSeconds;
    s.readbackDeviceSeconds += share.readbackDeviceSeconds;
    s.tapeInstructions += share.tapeInstructions;
    s.tapeWords += share.tapeWords;
    s.tapeSeconds += share.tapeSeconds;
    s.deviceBytes = std::max(s.deviceBytes, share.deviceBytes);
  }
  s.seconds = since(wallStart);
  s.hostSeconds = std::max(0.0, s.seconds - s.classifySeconds - s.fieldSeconds - s.extractSeconds - s.readbackSeconds);
  if (stats) *stats = s;
  if (perDevice) *perDevice = std::move(shares);
}

}  // namespace

mesh::TriMesh polygonizeOnDevices(std::span<Device* const> devices, const blobtree::Program& program,
                                  const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options,
                                  GpuStats* stats, std::vector<GpuStats>* perDevice,
                                  const HostBatchWorker* host) {
  host = checkWorkers(devices, program, host);
  if (oneWorker(devices, host, grid)) {
    GpuStats one;
    mesh::TriMesh mesh = polygonize(*devices[0], program, grid, options, &one);
    if (stats) *stats = one;
    if (perDevice) perDevice->assign(1, one);
    return mesh;
  }
  mesh::TriMesh mesh;
  runOnDevices(devices, program, grid, options, stats, perDevice, host,
               [&mesh](mesh::TriMesh& piece, std::size_t, std::size_t) { join(mesh, piece); });
  return mesh;
}

void polygonizeOnDevicesStreamed(std::span<Device* const> devices, const blobtree::Program& program,
                                 const blobtree::GridSpec& grid, const GpuPolygonizeOptions& options,
                                 mesh::MeshSink& sink, GpuStats* stats, std::vector<GpuStats>* perDevice,
                                 const HostBatchWorker* host,
                                 const std::function<void(std::size_t done, std::size_t total)>& progress) {
  host = checkWorkers(devices, program, host);
  if (oneWorker(devices, host, grid)) {
    GpuStats one;
    polygonizeStreamed(*devices[0], program, grid, options, sink, &one, progress);
    if (stats) *stats = one;
    if (perDevice) perDevice->assign(1, one);
    return;
  }
  // Batches as small as one device's streamed job takes (streamed_extract.h), so the pieces
  // waiting for the join (at most 2 x workers) and the one held back stay small.
  GpuPolygonizeOptions streamed = options;
  if (streamed.maxBatchBricks == 0) streamed.maxBatchBricks = kStreamedBatchBricks;
  // The piece before holds back its triangles until the next piece's vertices are in the sink
  // (its corners on the next layer are numbered past its own vertices), as on one device.
  mesh::TriMesh previous;
  std::uint64_t previousFirst = 0;
  bool pending = false;
  const auto globalise = [](mesh::TriMesh& piece, std::uint64_t first) {
    for (auto& t : piece.triangles)
      for (std::uint32_t& v : t) v += std::uint32_t(first);
  };
  runOnDevices(devices, program, grid, streamed, stats, perDevice, host,
               [&](mesh::TriMesh& piece, std::size_t b, std::size_t count) {
                 const std::uint64_t first = pending ? previousFirst + previous.positions.size() : 0;
                 if (first + piece.positions.size() > 0xffffffffull)
                   throw VulkanError("GPU polygonizer: the mesh has more than 2^32 vertices (32-bit indices): use a smaller grid");
                 sink.vertices(piece.positions, piece.normals, piece.colours);
                 if (pending) sink.triangles(previous.triangles, mesh::VertexWindow{previousFirst, previous.positions, piece.positions});
                 globalise(piece, first);
                 previous = std::move(piece);
                 previousFirst = first;
                 pending = true;
                 if (progress) progress(b + 1, count);
               });
  if (pending) sink.triangles(previous.triangles, mesh::VertexWindow{previousFirst, previous.positions, {}});
}

}  // namespace blobvk::vk
