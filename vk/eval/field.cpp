#include "blobvk/vk/eval/field.h"

#include "blobvk/vk/device/concurrent_builds.h"
#include "blobvk/vk/eval/evaluator_choice.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <tuple>

namespace blobvk::vk {

std::uint32_t layersPerBrick(const Device& device, const blobtree::GridSpec& grid,
                             std::uint64_t maxBytes, std::uint64_t bytesPerPoint) {
  const auto pts = grid.points();
  const std::uint64_t layerBytes = std::uint64_t(pts.x) * std::uint64_t(pts.y) * bytesPerPoint;
  const std::uint64_t budget =
      std::min<std::uint64_t>(maxBytes, device.info().limits.maxStorageBufferRange);
  return std::uint32_t(std::max<std::uint64_t>(1, budget / std::max<std::uint64_t>(layerBytes, 1)));
}

namespace {

// The tile plans of recent (program, grid, options), per Device (no global state: two Devices
// share nothing): planning costs 0.5-2 ms of host time (the pruned cost of every candidate
// split), as much as a small grid's whole field on lavapipe, and a renderer or benchmark asks
// for the same plan again and again. Keyed by the program's fingerprint; a few dozen entries,
// cleared when full.
using PlanKey = std::tuple<std::uint64_t, float, float, float, float, int, int, int, std::uint32_t, double,
                           std::uint32_t, std::uint64_t>;
struct TilePlanCache {
  std::mutex mutex;  // a Device is externally synchronised; this keeps the cache safe regardless
  std::map<PlanKey, std::vector<FieldTile>> plans;
};

std::vector<FieldTile> cachedPlan(Device& device, const blobtree::Program& program, std::uint64_t fingerprint,
                                  const blobtree::GridSpec& grid, const FieldTilingOptions& options) {
  std::shared_ptr<void>& slot = device.tilePlanCache();
  if (!slot) slot = std::make_shared<TilePlanCache>();
  auto& cache = *static_cast<TilePlanCache*>(slot.get());
  const PlanKey key{fingerprint, grid.origin.x, grid.origin.y, grid.origin.z, grid.cellSize, grid.cells.x,
                    grid.cells.y, grid.cells.z, options.maxTiles, options.minGain, options.minExtent,
                    options.minPointsForLargePrograms};
  {
    std::lock_guard<std::mutex> lock(cache.mutex);
    if (auto it = cache.plans.find(key); it != cache.plans.end()) return it->second;
  }
  std::vector<FieldTile> tiles = planFieldTiles(program, grid, options);
  std::lock_guard<std::mutex> lock(cache.mutex);
  if (cache.plans.size() >= 64) cache.plans.clear();
  cache.plans.emplace(key, tiles);
  return tiles;
}

}  // namespace

FieldPass::FieldPass(Device& device, const blobtree::Program& program, const GpuProgram& gpu,
                     Traversal traversal, std::uint32_t workgroupSize, const blobtree::GridSpec& grid,
                     const FieldTilingOptions& tiling)
    : programBindings_(gpu.bindings()), codeLength_(gpu.codeLength), grid_(grid), workgroupSize_(workgroupSize) {
  const bool specialised = traversal == Traversal::Specialised;
  FieldTilingOptions o = tiling;
  if (!specialised) o.maxTiles = 1;  // the interpreters read the whole program anyway
  if (!gpu.specialised && grid.pointCount() < o.minPointsForLargePrograms) o.maxTiles = 1;
  const std::uint64_t programPrint = gpu.fingerprint ? gpu.fingerprint : programFingerprint(program);
  tiles_ = cachedPlan(device, program, programPrint, grid, o);
  // Tiles only pay with kernels of their own: when none can have one (a program too large to
  // specialise, pruning too little), one dispatch over the whole grid.
  if (tiles_.size() > 1 &&
      std::none_of(tiles_.begin(), tiles_.end(), [&](const FieldTile& t) { return specialiseTile(program, t.region, gpu.codegen.loops); })) {
    o.maxTiles = 1;
    tiles_ = planFieldTiles(program, grid, o);
  }
  // Specialization constant 0 of field_grid is the work group's rows, not its size.
  const std::uint32_t rows = gridGroupRows(workgroupSize);
  // Each tile's kernel (code generation, SPIR-V, pipeline) on every core: they are independent.
  std::vector<std::function<KernelPtr()>> builds;
  for (const FieldTile& t : tiles_) {
    builds.push_back([&, region = t.region]() -> KernelPtr {
      // A whole-grid tile uses the program's own kernel (the one other passes share); a program
      // too large to specialise whole may still fit once pruned to a tile.
      const bool ownKernel =
          specialised && !(tiles_.size() == 1 && gpu.specialised) && specialiseTile(program, region, gpu.codegen.loops);
      if (!ownKernel) return evaluatorKernel(device, gpu, "field_grid", rows, traversal);
      CodegenOptions c = gpu.codegen;
      c.region = region;
      return specialisedKernel(device, program, programPrint, c, "field_grid", rows);
    });
  }
  kernels_ = buildConcurrently(builds);
}

void FieldPass::record(Recorder& rec, std::uint32_t k0, std::uint32_t layers, const Buffer& out) const {
  const auto pts = grid_.points();
  const auto& pb = programBindings_;
  const BufferRange bind[6] = {pb[0], pb[1], pb[2], pb[3], pb[4], BufferRange(out)};
  for (std::size_t ti = 0; ti < tiles_.size(); ++ti) {
    const FieldTile& t = tiles_[ti];
    const std::uint32_t kLo = std::max(k0, t.first[2]), kHi = std::min(k0 + layers - 1, t.last[2]);
    if (layers == 0 || kLo > kHi) continue;
    const std::uint32_t tnx = t.last[0] - t.first[0] + 1, tny = t.last[1] - t.first[1] + 1;
    struct {
      float origin[3], cell;
      std::uint32_t nx, ny, tileNx, tileNy, i0, j0, k0, outK0, codeLength;
    } push{{grid_.origin.x, grid_.origin.y, grid_.origin.z}, grid_.cellSize, std::uint32_t(pts.x),
           std::uint32_t(pts.y), tnx, tny, t.first[0], t.first[1], kLo, k0, codeLength_};
    const Groups3 g = gridGroups(tnx, tny, kHi - kLo + 1, workgroupSize_);
    rec.dispatch(*kernels_[ti], bind, &push, sizeof(push), g.x, g.y, g.z);
  }
}

std::vector<float> evaluateFieldOnGrid(Device& device, const blobtree::Program& program,
                                       const blobtree::GridSpec& grid, const FieldOptions& options,
                                       FieldStats* stats) {
  const auto pts = grid.points();
  std::vector<float> field(grid.pointCount());
  if (field.empty()) return field;
  FieldOptions o = options;
  CodegenOptions codegen = o.codegen ? *o.codegen : defaultCodegenOptions(device);
  o.codegen = &codegen;
  if (o.traversal == Traversal::Auto) {
    EvaluatorJob job;
    job.tiling = o.tiling;
    job.workgroupSize = o.workgroupSize;
    const EvaluatorEstimate e = chooseEvaluator(device, program, grid, job, codegen).chosen;
    o.traversal = e.traversal;
    o.tiling.maxTiles = e.fieldKernels;
    o.tiling.minPointsForLargePrograms = 0;  // the model weighed the tiles' build time
  }
  const GpuProgram gpu = uploadProgram(device, program, o.traversal, o.codegen);
  const FieldPass pass(device, program, gpu, o.traversal, o.workgroupSize, grid, o.tiling);
  const std::uint32_t brickLayers = layersPerBrick(device, grid, options.maxBrickBytes, 4);
  const std::uint64_t layerPoints = std::uint64_t(pts.x) * std::uint64_t(pts.y);
  Buffer out = device.createBuffer(layerPoints * std::min<std::uint32_t>(brickLayers, pts.z) * 4);
  FieldStats s;
  s.tiles = std::uint32_t(pass.tileCount());
  for (std::uint32_t k0 = 0; k0 < std::uint32_t(pts.z); k0 += brickLayers) {
    const std::uint32_t layers = std::min<std::uint32_t>(brickLayers, std::uint32_t(pts.z) - k0);
    const auto t0 = std::chrono::steady_clock::now();
    device.run([&](Recorder& rec) {
      pass.record(rec, k0, layers, out);
      rec.hostBarrier();
    });
    s.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    device.download(out, field.data() + k0 * layerPoints, layerPoints * layers * 4);
    ++s.bricks;
  }
  s.evaluations = field.size();
  if (stats) *stats = s;
  return field;
}

}  // namespace blobvk::vk
