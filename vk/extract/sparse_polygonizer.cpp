#include "blobvk/vk/extract/sparse_polygonizer.h"

#include "blobvk/vk/extract/host_copy.h"

#include "blobvk/vk/device/device_timer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/region_tape.h"
#include "blobvk/vk/eval/uniform_program.h"
#include "blobvk/vk/extract/brick_tapes.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/classify_kernel.h"
#include "blobvk/vk/extract/classify_tiles.h"
#include "blobvk/vk/extract/host_classify.h"
#include "blobvk/vk/extract/loop_limit.h"
#include "blobvk/vk/extract/sparse_batches.h"
#include "blobvk/vk/extract/scan.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <span>
#include <string>
#include <vector>

namespace blobvk::vk {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// 12345678 -> "12,345,678" (the phase notes' counts of bricks run to hundreds of millions).
std::string groupedCount(std::uint64_t n) {
  std::string digits = std::to_string(n), out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

// The Program's records in uniform blocks for brick_classify_uniform.comp (uniform_program.h);
// empty where they do not fit, and brick_classify.comp reads them as storage buffers.
struct ClassifyUniforms {
  std::vector<Buffer> buffers;
};

ClassifyUniforms classifyUniforms(Device& device, const blobtree::Program& program) {
  return {uploadUniformProgram(device, program)};
}

// Where a classification pass writes: flags[i] is brick firstBrick + i (linear index), and
// flags[lastWord] is the word after the last brick (set to 0 by the pass over brick firstBrick).
struct FlagsWindow {
  std::uint64_t firstBrick = 0, lastWord = 0;
};
FlagsWindow wholeFlags(const BrickGrid& bg) { return {0, bg.count()}; }

// One brick_classify dispatch over the bricks of `box` (of `bg`) into their words of `flags`
// (the last word 0 when the box holds the window's first brick; the caller zeroes the flags
// otherwise); with `parents` (flags of bricks twice the size, parents[0] being parent brick
// `parentBase`), bricks in dropped parents are dropped.
void dispatchClassify(Recorder& rec, const Kernel& kernel, const GpuProgram& gpu, const ClassifyUniforms& uniforms,
                      const blobtree::GridSpec& grid, const BrickGrid& bg, const Buffer& flags, FlagsWindow window,
                      const BrickGrid* parentGrid, const Buffer& parents, std::uint64_t parentBase, const BrickBox& box,
                      const ClassifyTile* tile = nullptr) {
  if (box.empty()) return;
  const auto pb = gpu.bindings();
  struct {
    float originCell[4];
    std::uint32_t cells[4], bricks[4], parents[4], first[4], end[4];
    std::uint32_t parentBase;
  } push{{grid.origin.x, grid.origin.y, grid.origin.z, grid.cellSize},
         {std::uint32_t(grid.cells.x), std::uint32_t(grid.cells.y), std::uint32_t(grid.cells.z), bg.log2B},
         {bg.x, bg.y, bg.z, tile ? tile->length : gpu.codeLength},
         {parentGrid ? parentGrid->x : 0, parentGrid ? parentGrid->y : 0, parentGrid ? parentGrid->z : 0,
          parentGrid ? 1u : 0u},
         {box.first[0], box.first[1], box.first[2], std::uint32_t(window.firstBrick)},
         {box.end[0], box.end[1], box.end[2], std::uint32_t(window.lastWord)},
         std::uint32_t(parentBase)};
  const bool uniform = !uniforms.buffers.empty();
  const BufferRange bind[7] = {tile ? BufferRange(tile->code) : uniform ? BufferRange(uniforms.buffers[0]) : pb[0],
                               uniform ? BufferRange(uniforms.buffers[1]) : pb[1],
                               uniform ? BufferRange(uniforms.buffers[2]) : pb[2],
                               uniform ? BufferRange(uniforms.buffers[3]) : pb[3],
                               uniform ? BufferRange(uniforms.buffers[4]) : pb[4],
                               flags,
                               parents};
  rec.dispatch(kernel, bind, &push, sizeof(push), (box.end[0] - box.first[0] + 3) / 4, (box.end[1] - box.first[1] + 3) / 4,
               (box.end[2] - box.first[2] + 3) / 4);
}

// A grid of at least this many bricks gets a pass over bricks twice the size first (and so on:
// at most kMaxParentLevels coarser passes); below it a coarser pass would not pay.
constexpr std::uint64_t kParentPassBricks = 512;
constexpr std::size_t kMaxParentLevels = 3;

// The coarser levels' grids and flags, parent of the classified grid first. Like the finest
// flags, each level's come in windows of its layers: those under the finest layers a pass
// classifies (parentLayers), so that no level outgrows a storage buffer where the finest flags
// need windows (tower_L6P8I4 at 4096³ in bricks of 4³: its bricks of 8³ alone take 324 MB of flags).
struct ClassifyParents {
  std::vector<BrickGrid> grids;
  std::vector<Buffer> flags;
  Buffer none;  // bound where a pass has no parent
};

// Layers [first, end) of coarser level `level` (0: bricks twice the size) that hold the finest
// layers [first, end).
std::array<std::uint32_t, 2> parentLayers(std::uint32_t first, std::uint32_t end, std::size_t level) {
  const unsigned shift = unsigned(level + 1);
  return {first >> shift, ((end - 1) >> shift) + 1};
}

// The grid of bricks twice the size of `g`'s.
BrickGrid parentGrid(const BrickGrid& g) { return {g.log2B + 1, (g.x + 1) / 2, (g.y + 1) / 2, (g.z + 1) / 2}; }

// Whether a grid of `bricks` at coarser level `level` (0: the classified grid) gets a pass over
// bricks twice the size first.
bool takesParentPass(const BrickGrid& bricks, std::size_t level) {
  return bricks.count() >= kParentPassBricks && level < kMaxParentLevels;
}

// The coarsest level the classification of `bg` passes over (bg itself without parent levels).
BrickGrid classifyTopGrid(const BrickGrid& bg) {
  BrickGrid g = bg;
  for (std::size_t level = 0; takesParentPass(g, level); ++level) g = parentGrid(g);
  return g;
}

// Levels of parents for `bg`, their flags sized for the largest of `windows` (finest layers
// [first, end) a pass classifies).
ClassifyParents classifyParents(Device& device, const BrickGrid& bg,
                                std::span<const std::array<std::uint32_t, 2>> windows, std::uint64_t& bytes) {
  ClassifyParents p;
  BrickGrid g = bg;
  while (takesParentPass(g, p.grids.size())) {
    g = parentGrid(g);
    std::uint64_t layers = 0;
    for (const auto& [first, end] : windows) {
      const auto [lo, hi] = parentLayers(first, end, p.grids.size());
      layers = std::max<std::uint64_t>(layers, hi - lo);
    }
    p.grids.push_back(g);
    p.flags.push_back(makeSparseBuffer(device, (layers * g.x * g.y + 1) * 4, "parent brick flags", bytes));
  }
  p.none = makeSparseBuffer(device, 16, "parent brick flags", bytes);
  return p;
}

// The first brick (linear index) of level `level`'s flags for finest layers from `first`.
std::uint64_t parentBase(const ClassifyParents& parents, std::size_t level, std::uint32_t first) {
  const BrickGrid& g = parents.grids[level];
  return std::uint64_t(parentLayers(first, first + 1, level)[0]) * g.x * g.y;
}

// `dispatch(box, tile)` over `box` of a level `shift` levels below the classification's top: once
// with the whole program (tile null) without tiles, else once per tile, over its bricks of the
// level within `box`, with its tape.
template <class Dispatch>
void overTiles(std::span<const ClassifyTile> tiles, const BrickBox& box, unsigned shift, const BrickGrid& level,
               Dispatch&& dispatch) {
  if (tiles.empty()) return dispatch(box, nullptr);
  for (const ClassifyTile& t : tiles) {
    BrickBox b = boxBelow(t.top, shift, level);
    for (int a = 0; a < 3; ++a) b.first[a] = std::max(b.first[a], box.first[a]), b.end[a] = std::min(b.end[a], box.end[a]);
    dispatch(b, &t);
  }
}

// brick_classify over the coarser levels under the finest layers [first, end), coarsest first,
// each skipping the bricks its parents dropped; with `tiles` (classify_tiles.h, boxes of the
// coarsest level) one dispatch per tile and level, each with its tile's tape.
void recordParents(Recorder& rec, const Kernel& kernel, const GpuProgram& gpu, const ClassifyUniforms& uniforms,
                   const blobtree::GridSpec& grid, const ClassifyParents& parents, std::span<const ClassifyTile> tiles,
                   std::uint32_t first, std::uint32_t end) {
  for (std::size_t i = parents.grids.size(); i-- > 0;) {
    const bool top = i + 1 == parents.grids.size();
    const BrickGrid& g = parents.grids[i];
    const auto [lo, hi] = parentLayers(first, end, i);
    const FlagsWindow window{std::uint64_t(lo) * g.x * g.y, std::uint64_t(hi - lo) * g.x * g.y};
    auto dispatch = [&](const BrickBox& box, const ClassifyTile* tile) {
      dispatchClassify(rec, kernel, gpu, uniforms, grid, g, parents.flags[i], window, top ? nullptr : &parents.grids[i + 1],
                       top ? parents.none : parents.flags[i + 1], top ? 0 : parentBase(parents, i + 1, first), box, tile);
    };
    overTiles(tiles, BrickBox{{0, 0, lo}, {g.x, g.y, hi}}, unsigned(parents.grids.size() - 1 - i), g, dispatch);
    rec.computeBarrier();
  }
}

// brick_classify over `box` of the grid's own bricks into `flags` (`window` of the grid's),
// skipping the bricks the finest coarser level (recorded before, for finest layers from
// box.first[2]) dropped; with `tiles`, per tile (its part of `box`) with its tape.
void recordFinest(Recorder& rec, const Kernel& kernel, const GpuProgram& gpu, const ClassifyUniforms& uniforms,
                  const blobtree::GridSpec& grid, const BrickGrid& bg, const Buffer& flags, FlagsWindow window,
                  const ClassifyParents& parents, std::span<const ClassifyTile> tiles, const BrickBox& box) {
  const bool any = !parents.grids.empty();
  auto dispatch = [&](const BrickBox& b, const ClassifyTile* tile) {
    dispatchClassify(rec, kernel, gpu, uniforms, grid, bg, flags, window, any ? &parents.grids[0] : nullptr,
                     any ? parents.flags[0] : parents.none, any ? parentBase(parents, 0, box.first[2]) : 0, b, tile);
  };
  overTiles(tiles, box, unsigned(parents.grids.size()), bg, dispatch);
}

// The windows' layers: own layers [first, end) each, at most `windowLayers` (0: as many as one
// storage buffer of flags holds, with the two layers after them that a batch reads).
std::vector<std::array<std::uint32_t, 2>> planWindows(Device& device, const BrickGrid& bg, std::uint32_t windowLayers) {
  const std::uint64_t layerBricks = std::uint64_t(bg.x) * bg.y;
  const std::uint64_t rangeWords = device.info().limits.maxStorageBufferRange / 4;
  std::uint64_t own = bg.z;
  if (bg.count() + 1 > rangeWords) {
    const std::uint64_t fit = (rangeWords - 1) / layerBricks;
    if (fit < 3) {
      throw VulkanError("GPU polygonizer: a layer of " + std::to_string(layerBricks) +
                        " bricks is too large for the brick flags of three layers to fit one storage buffer "
                        "(maxStorageBufferRange): use larger bricks or a smaller grid");
    }
    own = fit - 2;
  }
  if (windowLayers) own = std::min<std::uint64_t>(own, windowLayers);
  std::vector<std::array<std::uint32_t, 2>> windows;
  for (std::uint32_t z = 0; z < bg.z; z = std::uint32_t(std::min<std::uint64_t>(z + own, bg.z)))
    windows.push_back({z, std::uint32_t(std::min<std::uint64_t>(z + own, bg.z))});
  return windows;
}

}  // namespace

std::uint64_t ClassifiedBricks::peakBytes(std::uint64_t batchBytes) const {
  return bytes + std::max(scratchBytes, batchBytes);
}

std::vector<std::uint32_t> classifyBricks(Device& device, const blobtree::Program& program,
                                          const blobtree::GridSpec& grid, std::uint32_t brickCells,
                                          bool uniformRecords, ClassifyCode code, std::uint32_t forcedTiles,
                                          std::uint32_t* tilesRun) {
  const BrickGrid bg = brickGridFor(grid, brickCells);
  const GpuProgram gpu = uploadProgram(device, program, Traversal::Stackless);
  const ClassifyUniforms uniforms = uniformRecords ? classifyUniforms(device, program) : ClassifyUniforms{};
  const ClassifyKernel kernel =
      classifyKernel(device, program, gpu, !uniforms.buffers.empty(), {code, 1}, grid, 1u << bg.log2B);
  Buffer flags = device.createBuffer((bg.count() + 1) * 4);
  std::uint64_t bytes = 0;
  const std::array<std::uint32_t, 2> all{0, bg.z};
  const ClassifyParents parents = classifyParents(device, bg, {&all, 1}, bytes);
  const std::vector<ClassifyTile> tiles =
      forcedTiles > 1 && !kernel.generated
          ? uploadClassifyTiles(device, planClassifyTiles(program, grid, bg, classifyTopGrid(bg), gpu.emptyBox, forcedTiles),
                                uniforms.buffers.empty() ? 0 : kUniformProgramBlock)
          : std::vector<ClassifyTile>{};
  if (tilesRun) *tilesRun = std::uint32_t(tiles.size());
  device.run([&](Recorder& rec) {
    recordParents(rec, *kernel.kernel, gpu, uniforms, grid, parents, tiles, 0, bg.z);
    recordFinest(rec, *kernel.kernel, gpu, uniforms, grid, bg, flags, wholeFlags(bg), parents, tiles, wholeGrid(bg));
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
  // Limits of the packed brick coordinates (BrickGrid::pack: one word) and of a segment record's
  // counts (brick_layout.glsl, brickSegments: a slice's active bricks in 21 bits, a row's in 11).
  if (b.bitsX() + b.bitsY() + b.bitsZ() > 32 || b.x >= (1u << 11) ||
      std::uint64_t(b.x) * b.y >= (1u << 21)) {
    throw VulkanError("GPU polygonizer: " + std::to_string(b.x) + " x " + std::to_string(b.y) + " x " +
                      std::to_string(b.z) + " bricks (at most 2^32 in all, 2047 along x, 2^21 in a layer): use larger bricks");
  }
  return b;
}

BrickBox wholeGrid(const BrickGrid& bricks) { return {{0, 0, 0}, {bricks.x, bricks.y, bricks.z}}; }

std::uint64_t sparseDeviceBytes(const BrickGrid& bricks, std::uint64_t activeBricks, std::uint64_t vertices,
                                std::uint64_t triangles, bool normals, bool colours, std::uint64_t tapeBytes) {
  const std::uint64_t B = 1ull << bricks.log2B, R = B + 1;
  const std::uint64_t perBrick = sparseBrickBytes(bricks);
  const std::uint64_t scan = (scanScratchWords(bricks.count() + 1) + scanScratchWords(activeBricks * R * R) +
                              scanScratchWords(activeBricks * B * B)) * 4;
  // Outputs, where each vertex and triangle comes from (8 bytes each), and each vertex's entry in
  // its tile's or window's list where the vertex pass runs per field tile or per window of vertex
  // tapes (4 bytes).
  const std::uint64_t outputs =
      vertices * (12 + 8 + 8 + 4 + (normals ? 12 : 0) + (colours ? 12 : 0)) + triangles * (12 + 8);
  const std::uint64_t parentFlags = (bricks.count() / 7 + 8) * 4;  // the classification's coarser passes
  const std::uint64_t rowStarts = (std::uint64_t(bricks.y) * (bricks.z + 2) + 1) * 4;  // each brick row's first active brick
  return (bricks.count() + 1) * 8 + parentFlags + rowStarts + activeBricks * perBrick + scan + outputs + 256 * 4 * 4 +
         tapeBytes;
}

namespace {
// The active bricks' coordinates, read back from the device's compacted list (4 bytes a brick).
EvaluatedBricks activeBricks(Device& device, const ClassifiedBricks& classified) {
  EvaluatedBricks e;
  e.cells = 1u << classified.bricks.log2B;
  const std::uint32_t active = classified.layerStarts.empty() ? 0 : classified.layerStarts.back();
  if (active == 0) return e;
  const std::vector<std::uint32_t> packed = classified.downloadList(device, 0, active);
  e.bricks.reserve(active);
  for (std::uint32_t p : packed) e.bricks.push_back(classified.bricks.unpack(p));
  return e;
}

// What the field tiles' cost model weighs of the kernel pruned to a region, remembered: a
// repeated job asks again every run, and for a program of thousands of instructions the code's
// shape analysis takes milliseconds a region (tower_L6P8I4 at 256 cells: 0.2 s a job for its
// plans of 8 to 48 tiles).
struct RegionKernel {
  double codeSize = 0.0, prunedInstructions = 0.0, prunedCost = 0.0;
  bool loops = false;
};
RegionKernel regionKernel(const blobtree::Program& program, std::uint64_t fingerprint, const PointRegion& region,
                          const LoopOptions& loops) {
  static HostMemo<RegionKernel, 1024> memo;
  MemoKey key;
  key.add(fingerprint).add(region.valid).add(region.lo).add(region.hi);
  addLoopOptions(key, loops);
  return memo.get(key, [&] {
    RegionKernel k;
    k.codeSize = double(specialisedCodeSize(program, region, loops));
    k.prunedInstructions = double(branchedInstructionCount(program, region));
    k.prunedCost = double(prunedEvaluationCost(program, region));
    k.loops = specialisedCodeLoops(program, region, loops);
    return k;
  });
}

// Instructions the per-brick tapes (brick_tapes.h) hold over the active bricks, each brick's tape
// counted once: from up to kSampledBricks bricks at a regular stride through the list (the same
// job gives the same figure), scaled to all. Building them is a host walk of milliseconds.
constexpr std::size_t kSampledBricks = 2048;
std::size_t sampleStride(const EvaluatedBricks& evaluated) {
  return (evaluated.bricks.size() + kSampledBricks - 1) / kSampledBricks;
}
double activeTapeInstructions(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& bricks,
                              const EvaluatedBricks& evaluated) {
  const std::size_t n = evaluated.bricks.size();
  if (n == 0) return 0.0;
  std::vector<std::uint32_t> packed;
  for (std::size_t i = 0; i < n; i += sampleStride(evaluated)) packed.push_back(bricks.pack(evaluated.bricks[i]));
  BrickTapes tapes;
  buildBrickTapes(program, grid, bricks, packed, std::uint32_t(program.boxes.size()), tapes);
  return double(tapes.instructions) * double(n) / double(packed.size());
}
// The same for what a point of each brick runs where the code branches on skips (looped code):
// the program less the subtrees whose boxes miss the brick (branchedInstructionCount).
double activeBranchedInstructions(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                  const EvaluatedBricks& evaluated) {
  const std::size_t n = evaluated.bricks.size();
  if (n == 0) return 0.0;
  const std::uint32_t B = evaluated.cells;
  double sum = 0.0;
  std::size_t sampled = 0;
  for (std::size_t i = 0; i < n; i += sampleStride(evaluated), ++sampled) {
    const auto& b = evaluated.bricks[i];
    sum += double(branchedInstructionCount(
        program, regionOfPoints(grid, {b[0] * B, b[1] * B, b[2] * B}, {b[0] * B + B, b[1] * B + B, b[2] * B + B})));
  }
  return sum * double(n) / double(sampled);
}
}  // namespace

SparseEvaluator resolveSparseEvaluator(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                       const GpuPolygonizeOptions& options, const ClassifiedBricks* classified) {
  SparseEvaluator e;
  e.traversal = options.traversal;
  if (options.codegen) e.codegen = *options.codegen;
  // The model's constants are lavapipe's: elsewhere it only picks Auto's evaluator.
  const bool cpuDevice = device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  const bool choose = e.traversal == Traversal::Auto;
  const bool predict = cpuDevice && (e.traversal == Traversal::Stackless || e.traversal == Traversal::Specialised);
  if (!choose && !predict) return e;
  EvaluatorJob job;
  job.vertexPass = true;
  job.refineSteps = options.refineSteps;
  job.repeats = std::max<std::uint32_t>(options.expectedRuns, 1);
  job.tiling.maxTiles = 1;
  EvaluatedBricks evaluated;
  if (classified && cpuDevice) {
    evaluated = activeBricks(device, *classified);
    job.evaluated = &evaluated;
  }
  CodegenOptions codegen = e.codegen ? *e.codegen : defaultCodegenOptions(device);
  const EvaluatorChoice choice = chooseEvaluator(device, program, grid, job, codegen);
  const EvaluatorEstimate* estimate = &choice.chosen;
  if (!choose) {
    estimate = nullptr;
    for (const EvaluatorEstimate& c : choice.candidates)
      if (c.traversal == e.traversal && !estimate) estimate = &c;
  } else {
    e.traversal = choice.chosen.traversal;
    e.codegen = codegen;
    e.codegen->gradient = choice.chosen.vertexGradient;
    e.interpretVertexPassUntilBuilt = cpuDevice && choice.chosen.interpretVertexPassUntilBuilt;
  }
  if (estimate && cpuDevice) {
    e.modelBuildSeconds = estimate->buildSeconds;
    e.modelRunSeconds = estimate->runSeconds;
  }
  // Field tiles prune the unrolled code per tile of bricks (brick_tiles.h) at the cost of one
  // kernel build per tile instead of one for the whole program: they pay where the active
  // bricks' points times the pruned work outweigh the pruned kernels' builds (tower at 256 cells:
  // field 0.09 s against 0.23 s per run, no slower a first run), not on small jobs (dice at 64
  // cells: +0.1 s of start-up for 2 ms of field).
  // (Auto only: a forced evaluator gets the tiles it is given.)
  if (choose && cpuDevice && job.evaluated && e.traversal == Traversal::Specialised) {
    // The field time a plan of at most `cap` tiles (and `loopedCap` for looped code) saves over
    // the runs against one unrolled kernel, its field time over the runs, and its kernels' builds
    // beyond the whole program's.
    struct TileGain {
      std::size_t tiles = 0;
      double saved = 0.0, run = 0.0, extraBuild = 0.0;
    };
    const double R = double(evaluated.cells) + 1.0, pointsPerBrick = R * R * R;
    const std::uint64_t fingerprint = programFingerprint(program);
    const RegionKernel whole = regionKernel(program, fingerprint, {}, codegen.loops);
    const double wholeBuild = specialisedKernelSeconds(whole.codeSize, 1.0);
    // Seconds per point of a kernel: unrolled code runs all it holds under a mask; looped code
    // branches on its skips, running a share of its instructions.
    auto secondsPerPoint = [](const RegionKernel& k) {
      return k.loops ? costs::kLoopedSecondsPerInstruction * costs::kLoopedTileRunShare * k.prunedInstructions
                     : costs::kSpecialisedSecondsPerCost * k.prunedCost;
    };
    auto tileGain = [&](std::uint32_t cap, std::uint32_t loopedCap) {
      TileGain g;
      const std::vector<BrickTile> tiles = planBrickTiles(program, grid, classified->bricks, cap, loopedCap, codegen.loops);
      g.tiles = tiles.size();
      g.extraBuild = -wholeBuild;
      for (const BrickTile& t : tiles) {
        std::uint64_t bricks = 0;
        for (const auto& b : evaluated.bricks)
          bricks += b[0] >= t.first[0] && b[0] <= t.last[0] && b[1] >= t.first[1] && b[1] <= t.last[1] &&
                    b[2] >= t.first[2] && b[2] <= t.last[2];
        const double points = double(bricks) * pointsPerBrick * double(job.repeats);
        const RegionKernel k = regionKernel(program, fingerprint, t.region, codegen.loops);
        g.extraBuild += specialisedKernelSeconds(k.codeSize, 1.0);
        g.saved += costs::kSpecialisedSecondsPerCost * (whole.prunedCost - k.prunedCost) * points;
        g.run += secondsPerPoint(k) * points;
      }
      return g;
    };
    // The pruned field kernels build in about a third of what the model's constants (fitted to
    // whole mesh kernels) say: tower at 256 cells, predicted +0.67 s for 8 tiles, measured no
    // slower a first run with the field's 0.14-0.2 s saved; dice at 64 cells +0.1-0.15 s.
    constexpr double kTileBuildShare = 0.3;
    // The plan taken so far: the whole program's one kernel.
    const double activePoints = double(evaluated.bricks.size()) * pointsPerBrick * double(job.repeats);
    TileGain taken;
    taken.tiles = 1;
    taken.run = secondsPerPoint(whole) * activePoints;
    const TileGain coarse = options.maxFieldTiles > 1 ? tileGain(options.maxFieldTiles, 0) : taken;
    e.fieldTiles = coarse.tiles > 1 && coarse.saved > kTileBuildShare * coarse.extraBuild;
    // A job that runs again may take more tiles where the finer plan's extra saving pays its
    // extra kernels by the same measure (tower at 512 cells and 6 runs: 16 tiles, field pass
    // 0.16 s against 0.21 s; one run keeps 8: a `mesh` does not wait for 8 more builds).
    TileGain plan = coarse;
    if (e.fieldTiles && job.repeats > 1 && options.repeatedJobFieldTiles > options.maxFieldTiles) {
      const TileGain fine = tileGain(options.repeatedJobFieldTiles, 0);
      if (fine.tiles > coarse.tiles && fine.saved - coarse.saved > kTileBuildShare * (fine.extraBuild - coarse.extraBuild)) {
        e.fieldTileCap = options.repeatedJobFieldTiles;
        plan = fine;
      }
    }
    // Tiles whose code still loops (a program of thousands of instructions) split on until it
    // unrolls, where the field time that saves pays the extra kernels by the same measure
    // (tower_L6P8I4 at 256 cells: 48 tiles, field 0.2-0.25 s against 5-7 s a run, and a first run
    // no slower).
    if (e.fieldTiles && whole.loops && options.maxFieldTilesForLoopedCode > plan.tiles &&
        codegen.loops.minProgramInstructions > 0) {
      const std::uint32_t cap = e.fieldTileCap ? e.fieldTileCap : options.maxFieldTiles;
      const TileGain unrolled = tileGain(cap, options.maxFieldTilesForLoopedCode);
      if (unrolled.tiles > plan.tiles && plan.run - unrolled.run > kTileBuildShare * (unrolled.extraBuild - plan.extraBuild)) {
        e.loopedTileCap = options.maxFieldTilesForLoopedCode;
        plan = unrolled;
      }
    }
    if (e.fieldTiles) taken = plan;
    // A looped program's field over per-brick tapes (brick_tapes.h: the program pruned to each
    // brick on the host, interpreted from uniform blocks) builds no kernel and runs each brick's
    // few instructions, where looped code runs every instance a skip does not jump (a flat blend
    // of 600 points has none to jump: 1,200 instructions a point against 67 on its tapes).
    // Taken where it beats the looped plan above, its kernels' builds included, its loops fit the
    // driver's limit with these bricks (the interpreter's bound), and the tapes go to uniform
    // blocks (the rate's; from a storage buffer they run several times slower). Tiles split until they
    // unroll run several times faster than tapes once built (tower_L6P8I4 at 128 cells: field
    // 0.05 s against 2.2 s a run), so where the split pays the tapes are not considered.
    // How much looped code runs against the bricks' tapes, beyond which the vertex pass takes them.
    constexpr double kVertexTapeShare = 8.0;
    double tapeInstructions = -1.0;  // over the active bricks, once counted
    if (whole.loops && !options.brickTapes && e.loopedTileCap == 0 && options.brickTapeUniforms &&
        device.info().limits.maxUniformBufferRange >= kUniformTapeBlock) {
      const bool fits = brickCellsWithinLoopLimit(evaluated.cells, evaluationLoopBound(program, Traversal::Stackless, nullptr),
                                                  loopIterationLimit(device.info())) == evaluated.cells;
      const double takenTotal = taken.run + kTileBuildShare * (wholeBuild + taken.extraBuild);
      tapeInstructions = activeTapeInstructions(program, grid, classified->bricks, evaluated);
      e.brickTapes = fits && costs::kTapeSecondsPerInstruction * pointsPerBrick * double(job.repeats) * tapeInstructions <
                                 takenTotal;
      if (e.brickTapes) e.fieldTiles = false, e.fieldTileCap = 0;
    }
    // A looped program's vertex pass runs the whole program's looped code unless its tiles unroll
    // (vertex tiles) or it interprets per-brick vertex tapes. From a storage buffer the tapes are
    // taken where a point of a brick would run many times its brick's tape (a flat blend, which
    // looped code cannot skip: 600 points at 256 cells, 72 times, vertex pass 8 s longer looped;
    // towers, whose skips the looped code takes, about once, and their looped pass is as fast or
    // faster: tower L3P8G2 at 256 cells 1.1-1.4 s against 1.8-1.9 s with tapes). From uniform
    // blocks (vertexTapesInWindows) always: towers at 256 cells, looped and from windows, L3P8G2
    // 0.45 -> 0.32 s, L5P8G3 2.4 -> 0.59 s, tower_L6P8I4 3.4 -> 0.67 s.
    if (whole.loops && !e.brickTapes && (options.normals || options.colours)) {
      if (vertexTapesInWindows(device, options)) {
        e.vertexTapes = true;
      } else {
        if (tapeInstructions < 0.0) tapeInstructions = activeTapeInstructions(program, grid, classified->bricks, evaluated);
        e.vertexTapes = activeBranchedInstructions(program, grid, evaluated) > kVertexTapeShare * tapeInstructions;
      }
    }
  }
  return e;
}

void SparseEvaluator::report(GpuStats& stats) const {
  stats.traversal = traversal;
  stats.vertexGradient = codegen && codegen->gradient && traversal == Traversal::Specialised;
  stats.modelBuildSeconds = modelBuildSeconds;
  stats.modelRunSeconds = modelRunSeconds;
}

GpuPolygonizeOptions SparseEvaluator::apply(const GpuPolygonizeOptions& options) const {
  GpuPolygonizeOptions resolved = options;
  resolved.traversal = traversal;
  if (codegen) resolved.codegen = &*codegen;
  if (!fieldTiles) resolved.maxFieldTiles = 1;
  else if (fieldTileCap > 0) resolved.maxFieldTiles = fieldTileCap;
  resolved.maxFieldTilesForLoopedCode = fieldTiles ? loopedTileCap : 0;
  resolved.brickTapes = options.brickTapes || brickTapes;
  resolved.vertexTapes = options.vertexTapes || vertexTapes;
  resolved.interpretVertexPassUntilBuilt = options.interpretVertexPassUntilBuilt || interpretVertexPassUntilBuilt;
  return resolved;
}

const ScanWindow& windowHolding(std::span<const ScanWindow> windows, std::uint32_t firstLayer, std::uint32_t endLayer) {
  for (const ScanWindow& w : windows)
    if (w.firstLayer <= firstLayer && endLayer <= w.endLayer) return w;
  throw VulkanError("GPU polygonizer: no window of the brick tables holds brick layers " + std::to_string(firstLayer) +
                    " to " + std::to_string(endLayer));
}

std::vector<std::uint32_t> ClassifiedBricks::windowEnds() const {
  std::vector<std::uint32_t> ends;
  for (std::size_t i = 0; i + 1 < windows.size(); ++i) ends.push_back(windows[i].endLayer);
  return ends;
}

std::vector<std::uint32_t> ClassifiedBricks::downloadList(Device& device, std::uint32_t first,
                                                          std::uint32_t count) const {
  std::vector<std::uint32_t> packed(count);
  for (const ScanWindow& w : windows) {
    // The bricks of w's own layers (the list's extra layer is the next window's own).
    const std::uint32_t begin = std::max(first, w.activeBase), end = std::min(first + count, layerStarts[w.endLayer]);
    if (begin < end) device.download(w.list, packed.data() + (begin - first), 4ull * (end - begin), 4ull * (begin - w.activeBase));
  }
  return packed;
}

ClassifiedBricks classifyAndCompact(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                    const BrickGrid& bg, GpuStats& s, const BrickBox* only, std::uint32_t windowLayers,
                                    const ClassifyChoice& choice, const ClassifyWatch& watch) {
  ClassifiedBricks c;
  c.bricks = bg;
  // The classification interprets the register code, or runs it generated once that kernel is
  // built (classify_kernel.h), whatever evaluator the batches use.
  UploadBatch uploads(device);  // the program rides in the classification's first submit
  const GpuProgram gpu = uploadProgram(device, program, Traversal::Stackless);
  const ClassifyUniforms uniforms = classifyUniforms(device, program);
  // The interpreter's tiles (classify_tiles.h), planned on the host first: where they pay, the
  // generated code must beat them to be built or taken. An edit's box is small: no tiles.
  const ClassifyTilesPlan plan = only || choice.code == ClassifyCode::Generated
                                     ? ClassifyTilesPlan{}
                                     : planClassifyTiles(program, grid, bg, classifyTopGrid(bg), gpu.emptyBox, choice.maxTiles);
  const bool tiled = !plan.tiles.empty() && (plan.pays || !choice.tilesWhenTheyPay);
  ClassifyChoice chosen = choice;
  chosen.tiledSeconds = tiled ? plan.seconds : -1.0;
  const ClassifyKernel kernel =
      classifyKernel(device, program, gpu, !uniforms.buffers.empty(), chosen, grid, 1u << bg.log2B);
  s.generatedClassification = kernel.generated;
  const std::uint32_t layers = bg.z;
  const std::uint64_t layerBricks = std::uint64_t(bg.x) * bg.y;
  const std::vector<std::array<std::uint32_t, 2>> planned =
      only ? std::vector<std::array<std::uint32_t, 2>>{{0, layers}} : planWindows(device, bg, windowLayers);
  DeviceTimer timer(device, 4 * std::uint32_t(planned.size()));
  const auto t0 = Clock::now();
  std::uint64_t largestWindow = 0;
  std::vector<std::array<std::uint32_t, 2>> classified;  // the layers each window's passes classify
  for (const auto& [first, end] : planned) {
    const std::uint32_t scanEnd = std::min(end + 2, layers);
    largestWindow = std::max<std::uint64_t>(largestWindow, (scanEnd - first) * layerBricks);
    classified.push_back({first, scanEnd});
  }
  Buffer scratch = makeSparseBuffer(device, (scanScratchWords(largestWindow + 1) + 1) * 4, "scan scratch", c.scratchBytes);
  // The flags and their scan, one window at a time: only the row starts and the active bricks'
  // list stay for the batches.
  Buffer scan = makeSparseBuffer(device, (largestWindow + 1) * 4, "brick flags", c.scratchBytes);
  // With several windows each list is sized to its active bricks, counted by a first submit (the
  // flags of a grid that needs windows would add up to more than the device holds, lavapipe's
  // 2 GiB at 4096³); one window takes a list for all its bricks and a single submit.
  const bool countFirst = planned.size() > 1;
  Buffer totals = makeSparseBuffer(device, 16, "totals", c.scratchBytes);
  Buffer layerStarts = device.createBuffer((layers + 1) * 4ull, MemoryUse::Readback);
  const ClassifyParents parents = only ? ClassifyParents{{}, {}, makeSparseBuffer(device, 16, "parent brick flags", c.scratchBytes)}
                                       : classifyParents(device, bg, classified, c.scratchBytes);
  const std::vector<ClassifyTile> tiles = tiled && !kernel.generated
                                              ? uploadClassifyTiles(device, plan, uniforms.buffers.empty() ? 0 : kUniformProgramBlock)
                                              : std::vector<ClassifyTile>{};
  s.classifyTiles = std::uint32_t(tiles.size());
  for (const ClassifyTile& t : tiles) c.scratchBytes += t.code.size();  // freed with the classification
  c.layerStarts.assign(layers + 1, 0);
  std::uint32_t activeBase = 0;
  std::size_t ran = 0;  // windows classified
  for (std::size_t k = 0; k < planned.size(); ++k) {
    const auto [first, end] = planned[k];
    const std::uint32_t scanEnd = std::min(end + 2, layers);
    const std::uint64_t words = (scanEnd - first) * layerBricks;
    const std::uint32_t rows = (scanEnd - first) * bg.y;
    ScanWindow w;
    w.firstLayer = first;
    w.endLayer = end;
    w.activeBase = activeBase;
    w.rowStarts = makeSparseBuffer(device, (rows + 1) * 4ull, "brick row starts", c.bytes);
    const FlagsWindow flags{first * layerBricks, words};
    const BrickBox box = only ? *only : BrickBox{{0, 0, first}, {bg.x, bg.y, scanEnd}};
    // The flags, their scan and the layers' first bricks (counted from the window's first).
    auto classify = [&](Recorder& rec) {
      if (only) {  // the bricks outside the box stay inactive
        rec.fill(scan, 0);
        rec.computeBarrier();
      }
      recordParents(rec, *kernel.kernel, gpu, uniforms, grid, parents, tiles, first, scanEnd);
      recordFinest(rec, *kernel.kernel, gpu, uniforms, grid, bg, scan, flags, parents, tiles, box);
      rec.computeBarrier();
      recordExclusiveScan(rec, scan.handle(), 0, std::uint32_t(words + 1), scratch.handle(), 0, totals.handle(), 0);
      rec.computeBarrier();
      for (std::uint32_t z = first; z <= scanEnd; ++z)
        rec.copy(scan, 4ull * (z - first) * layerBricks, layerStarts, 4ull * z, 4);
    };
    // The list of active bricks and the rows' first numbers, from the scan.
    auto compact = [&](Recorder& rec) {
      {
        const std::uint32_t push[6] = {bg.x, bg.y, bg.z, first, scanEnd, std::uint32_t(first * layerBricks)};
        const BufferRange bind[2] = {scan, w.list};
        rec.dispatch(*device.kernel("brick_compact", {}), bind, push, sizeof(push), (bg.x + 3) / 4, (bg.y + 3) / 4,
                     (scanEnd - first + 3) / 4);
      }
      {
        const std::uint32_t push[2] = {bg.x, rows};
        const BufferRange bind[2] = {scan, w.rowStarts};
        constexpr std::array<std::uint32_t, 1> wg{64};
        const Groups g = groupsFor(rows + 1, wg[0]);
        rec.dispatch(*device.kernel("brick_row_starts", wg), bind, push, sizeof(push), g.x, g.y);
      }
    };
    auto begin = [&](Recorder& rec, std::uint32_t mark) {
      if (k == 0 && mark == 0) timer.reset(rec);
      timer.mark(rec, 4 * std::uint32_t(k) + mark);
    };
    auto finish = [&](Recorder& rec, std::uint32_t mark) {
      timer.mark(rec, 4 * std::uint32_t(k) + mark);
      rec.hostBarrier();
    };
    // The layers' first bricks, counted from the window's first (the last: its active count).
    std::vector<std::uint32_t> starts(scanEnd + 1 - first);
    auto readStarts = [&] { device.download(layerStarts, starts.data(), starts.size() * 4, 4ull * first); };
    if (countFirst) {
      device.run([&](Recorder& rec) {
        begin(rec, 0);
        classify(rec);
        finish(rec, 1);
      });
      readStarts();
      w.list = makeSparseBuffer(device, std::max<std::uint64_t>(starts.back(), 1) * 4, "brick list", c.bytes);
      device.run([&](Recorder& rec) {
        begin(rec, 2);
        compact(rec);
        finish(rec, 3);
      });
      s.submits += 2;
    } else {
      w.list = makeSparseBuffer(device, std::max<std::uint64_t>(words, 1) * 4, "brick list", c.bytes);
      device.run([&](Recorder& rec) {
        begin(rec, 0);
        classify(rec);
        rec.computeBarrier();
        compact(rec);
        finish(rec, 1);
      });
      ++s.submits;
      readStarts();
    }
    for (std::uint32_t z = first; z <= scanEnd; ++z) c.layerStarts[z] = activeBase + starts[z - first];
    activeBase = c.layerStarts[end];
    c.windows.push_back(std::move(w));
    ++ran;
    if (watch.progress && planned.size() > 1) watch.progress(k + 1, planned.size());
    // The window's pairs (from each of its layers; scanEnd reaches two layers past its end).
    for (std::uint32_t z = first; z < end && !c.abandoned; ++z)
      c.abandoned = c.layerStarts[std::min(z + watch.abandonLayers, layers)] - c.layerStarts[z] > watch.abandonPairsOver;
    if (c.abandoned) break;
  }
  s.activeBricks = c.layerStarts[layers];
  s.classifySeconds = since(t0);
  if (timer.enabled()) {
    s.deviceTimed = true;
    s.classifySeconds = 0.0;
    for (std::uint32_t k = 0; k < ran; ++k) {
      s.classifySeconds += timer.seconds(4 * k, 4 * k + 1);
      if (countFirst) s.classifySeconds += timer.seconds(4 * k + 2, 4 * k + 3);
    }
  }
  return c;
}

ClassifiedBricks classifyToFit(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                               std::uint32_t brickCells, const std::function<std::uint64_t(const BrickGrid&)>& rangeBricks,
                               GpuStats& stats, std::uint32_t windowLayers, const ClassifyChoice& choice,
                               const std::function<void(const std::string&)>& phaseNote,
                               const std::function<void(std::size_t done, std::size_t total)>& progress,
                               std::uint32_t layersPerLoad) {
  constexpr std::uint32_t kSmallestFallbackCells = 4;
  double classifySeconds = 0.0;
  bool again = false;
  for (;;) {
    const BrickGrid bricks = brickGridFor(grid, brickCells);
    const bool onHost = choice.hostOptions && classifiesOnHost(device, *choice.hostOptions, bricks);
    if (phaseNote) {
      const std::string size = std::to_string(brickCells);
      phaseNote(std::string(!again                ? ""
                            : layersPerLoad == 1 ? "a brick layer holds more active bricks than one storage buffer; "
                                                 : "two adjacent brick layers hold more active bricks than one storage buffer; ") +
                "classifying " + groupedCount(bricks.count()) + " bricks of " + size + "x" + size + "x" + size +
                (onHost ? " cells on the host" : " cells on the device"));
    }
    again = true;
    // Eight times the bricks (their tables in windows of layers where they outgrow one buffer)
    // where a pair does not fit: the smaller grid must still be valid. Without one, the pairs
    // over the range are the batch planner's to name (planSparseBatches).
    bool canHalve = brickCells > kSmallestFallbackCells;
    if (canHalve) {
      try {
        brickGridFor(grid, brickCells / 2);
      } catch (const VulkanError&) {
        canHalve = false;
      }
    }
    ClassifyWatch watch{progress, canHalve ? rangeBricks(bricks) : ~0ull, std::max<std::uint32_t>(1, layersPerLoad)};
    ClassifiedBricks c = onHost ? classifyOnHost(device, *choice.hostOptions, grid, bricks, stats, watch)
                             : classifyAndCompact(device, program, grid, bricks, stats, nullptr, windowLayers, choice, watch);
    classifySeconds += stats.classifySeconds;
    stats.classifySeconds = classifySeconds;
    if (!c.abandoned) return c;
    brickCells /= 2;
  }
}

namespace {
// A batch with keyed corners (sparse_batches.h): its triangles' corners as edge keys, held until
// the next batch has run. A corner is a vertex of the batch's own bricks or of the next layer's
// (a vertex on the batch's upper face), and each batch's vertices ascend by key, so a corner is
// found by a binary search in the batch's keys, else in the next batch's.
struct KeyedCorners {
  bool pending = false;
  std::vector<std::uint64_t> corners;
  std::size_t firstKey = 0, keyCount = 0;  // the batch's vertices in the mesh that holds them
  std::uint64_t firstVertex = 0;           // the batch's first vertex in the whole mesh
  std::size_t firstTriangle = 0;           // its first triangle in the mesh that holds it

  void hold(std::vector<std::uint64_t> c, std::size_t keyAt, std::size_t keys, std::uint64_t first, std::size_t at) {
    corners = std::move(c);
    firstKey = keyAt;
    keyCount = keys;
    firstVertex = first;
    firstTriangle = at;
    pending = true;
  }
  // Writes the held triangles into `held` (the mesh holding the batch); `next` are the next
  // batch's keys.
  void resolve(mesh::TriMesh& held, std::span<const std::uint64_t> next) {
    const std::span<const std::uint64_t> keys(held.edgeKeys.data() + firstKey, keyCount);
    const std::uint64_t nextFirst = firstVertex + keyCount;
    auto indexOf = [&](std::uint64_t key) -> std::uint32_t {
      if (auto it = std::lower_bound(keys.begin(), keys.end(), key); it != keys.end() && *it == key)
        return std::uint32_t(firstVertex + std::uint64_t(it - keys.begin()));
      if (auto it = std::lower_bound(next.begin(), next.end(), key); it != next.end() && *it == key)
        return std::uint32_t(nextFirst + std::uint64_t(it - next.begin()));
      throw VulkanError("GPU polygonizer: a triangle corner's edge key " + std::to_string(key) +
                        " is no vertex of its brick layer or the next");
    };
    const std::size_t count = corners.size() / 3;
    auto& triangles = held.triangles;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
      for (std::size_t t = r.begin(); t < r.end(); ++t)
        triangles[firstTriangle + t] = {indexOf(corners[3 * t]), indexOf(corners[3 * t + 1]), indexOf(corners[3 * t + 2])};
    });
    pending = false;
  }
};
}  // namespace

void runSparseExtraction(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                         const GpuPolygonizeOptions& options, const SparseBatchSink& sink, GpuStats& s) {
  const auto wallStart = Clock::now();
  // Submits: one classifies and compacts the bricks (again with smaller bricks where a layer
  // pair would not fit one storage buffer); then, per batch of whole brick layers, two
  // (three where the host lists the vertex tiles; sparse_batches.h). The evaluator is chosen once the active bricks are known.
  // llvmpipe ends an invocation's loops after 65,535 iterations (loop_limit.h): bricks whose rows
  // of points fit them for the most the model's evaluator can loop (the same mesh on any bricks);
  // SparseBatchRunner refuses a job none fits.
  const std::uint32_t brickCells = brickCellsForLoopLimit(device.info(), program, options, options.brickCells);
  if (brickCells < options.brickCells && options.phaseNote)
    options.phaseNote("a row of " + std::to_string(options.brickCells + 1) +
                      " points would outrun the driver's loop limit (" + std::to_string(loopIterationLimit(device.info())) +
                      " iterations) with a program of " + std::to_string(program.code.size()) + " instructions");
  ClassifyChoice classifyChoice{options.classifyCode, options.expectedRuns};
  classifyChoice.hostOptions = &options;
  const ClassifiedBricks classified = classifyToFit(
      device, program, grid, brickCells, [&device](const BrickGrid& b) { return sparseRangeBricks(device, b); }, s,
      options.windowLayers, classifyChoice, options.phaseNote, options.classifyProgress,
      1);  // one device matches a lone layer's corners by key (planSparseBatches, KeyedBatches::Allow)
  s.hostSteps.classification = since(wallStart);
  const auto preparationStart = Clock::now();
  const SparseEvaluator evaluator = resolveSparseEvaluator(device, program, grid, options, &classified);
  const BrickGrid& bg = classified.bricks;
  s.brickCells = 1u << bg.log2B;
  s.bricks = std::uint32_t(bg.count());
  evaluator.report(s);
  const GpuPolygonizeOptions resolved = evaluator.apply(options);
  const std::vector<SparseBatch> batches = planSparseBatches(
      classified.layerStarts, sparseBatchLimit(device, bg, options.maxBatchBricks), sparseRangeBricks(device, bg),
      ~0ull, classified.windowEnds(), options.keyedCornerBatches ? KeyedBatches::Force : KeyedBatches::Allow);
  s.batches = std::uint32_t(batches.size());
  if (options.phaseNote)
    options.phaseNote(groupedCount(classified.layerStarts.back()) + " active bricks of " + groupedCount(bg.count()) +
                      " in " + std::to_string(batches.size()) + (batches.size() == 1 ? " batch" : " batches"));
  std::uint64_t batchBytes = 0;
  if (!batches.empty()) {
    std::uint32_t maxLoaded = 0;
    for (const SparseBatch& b : batches) maxLoaded = std::max(maxLoaded, b.loadedActive);
    SparseBatchRunner runner(device, program, grid, resolved, resolved.traversal, bg, classified.windows, maxLoaded,
                             s.batches);
    s.hostSteps.preparation = since(preparationStart);
    std::uint64_t vertexBase = 0;
    KeyedCorners waiting;  // a keyed batch's triangles, until the next batch's vertices are known
    for (std::size_t i = 0; i < batches.size(); ++i) {
      mesh::TriMesh& into = sink.into();
      const std::size_t before = into.positions.size(), trianglesBefore = into.triangles.size();
      const bool keyed = batches[i].keyedCorners;
      std::vector<std::uint64_t> corners;
      // The job's share done after this batch, by active bricks: its mesh grows about as much. At
      // most 4 times: a first batch denser than the rest must not reserve many meshes' worth.
      const double done = double(batches[i].activeBase) + batches[i].ownActive, all = double(classified.layerStarts.back());
      const double reserveRatio = sink.accumulates && done < all ? std::min(4.0, 1.05 * all / done) : 1.0;
      runner.run(batches[i], vertexBase, into, s, keyed ? &corners : nullptr, reserveRatio);
      const std::size_t added = into.positions.size() - before;
      const auto cornersStart = Clock::now();
      if (waiting.pending) waiting.resolve(sink.meshOf(i - 1), {into.edgeKeys.data() + before, added});
      if (keyed) {
        growParallel(into.triangles, corners.size() / 3, roomAhead(trianglesBefore + corners.size() / 3, reserveRatio));
        waiting.hold(std::move(corners), before, added, vertexBase, trianglesBefore);
        if (i + 1 == batches.size()) waiting.resolve(into, {});
      }
      if (keyed || (i > 0 && batches[i - 1].keyedCorners)) s.hostSteps.corners += since(cornersStart);
      vertexBase += added;
      if (sink.done) sink.done(i, batches.size());
    }
    runner.deviceTimes(s);
    batchBytes = runner.sharedBytes() + runner.peakOutputBytes();
  }
  s.deviceBytes = classified.peakBytes(batchBytes);
  s.seconds = since(wallStart);
  s.hostSeconds = std::max(0.0, s.seconds - s.classifySeconds - s.fieldSeconds - s.extractSeconds - s.readbackSeconds);
}

mesh::TriMesh polygonizeSparse(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                               const GpuPolygonizeOptions& options, GpuStats* stats) {
  mesh::TriMesh mesh;
  polygonizeSparseInto(device, program, grid, options, mesh, stats);
  return mesh;
}

void polygonizeSparseInto(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                          const GpuPolygonizeOptions& options, mesh::TriMesh& mesh, GpuStats* stats) {
  mesh.positions.clear();
  mesh.normals.clear();
  mesh.colours.clear();
  mesh.triangles.clear();
  mesh.edgeKeys.clear();
  GpuStats s;
  runSparseExtraction(device, program, grid, options,
                      {[&]() -> mesh::TriMesh& { return mesh; }, {}, [&](std::size_t) -> mesh::TriMesh& { return mesh; }, true},
                      s);
  if (stats) *stats = s;
}

}  // namespace blobvk::vk
