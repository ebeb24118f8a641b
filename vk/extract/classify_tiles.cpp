#include "blobvk/vk/extract/classify_tiles.h"

#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/field_tiles.h"  // regionOfPoints
#include "blobvk/vk/eval/host_memo.h"
#include "blobvk/vk/eval/program_codegen.h"  // programFingerprint
#include "blobvk/vk/eval/region_tape.h"
#include "blobvk/vk/extract/classify_kernel.h"

#include <algorithm>

namespace blobvk::vk {

namespace {

// The top grid split into n parts along each axis (as even as the bricks allow; an axis of fewer
// bricks into as many parts), each part's tape pruned to its points, and the interpreter's
// predicted steps over the finest level for all of them (classifyWork on each part of the grid).
struct Split {
  std::vector<PlannedClassifyTile> tiles;
  double steps = 0.0;
};
Split splitTop(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& finest,
               const BrickGrid& top, std::uint32_t emptyBox, std::uint32_t n) {
  Split split;
  const std::uint32_t B = 1u << top.log2B, finestCells = 1u << finest.log2B;
  const std::array<std::uint32_t, 3> count{top.x, top.y, top.z};
  std::array<std::uint32_t, 3> parts{};
  for (int a = 0; a < 3; ++a) parts[a] = std::min(n, count[a]);
  const std::uint32_t vectors = std::max<std::uint32_t>(4, 256 / (parts[0] * parts[1] * parts[2]));
  for (std::uint32_t k = 0; k < parts[2]; ++k)
    for (std::uint32_t j = 0; j < parts[1]; ++j)
      for (std::uint32_t i = 0; i < parts[0]; ++i) {
        PlannedClassifyTile t;
        const std::uint32_t at[3] = {i, j, k};
        std::array<std::uint32_t, 3> lo{}, hi{};
        blobtree::GridSpec part = grid;
        for (int a = 0; a < 3; ++a) {
          t.top.first[a] = count[a] * at[a] / parts[a];
          t.top.end[a] = count[a] * (at[a] + 1) / parts[a];
          lo[a] = t.top.first[a] * B;
          hi[a] = t.top.end[a] * B;  // the bricks' last points, past the grid's end too
          const int from = int(lo[a]), to = std::min(int(hi[a]), grid.cells[a]);
          part.origin[a] = grid.origin[a] + grid.cellSize * float(from);
          part.cells[a] = std::max(to - from, 1);
        }
        appendRegionTape(program.code, program, regionOfPoints(grid, lo, hi), emptyBox, TapeUse::Field, t.tape);
        split.steps += classifyWork(program, t.tape, part, finestCells, vectors).interpreted;
        split.tiles.push_back(std::move(t));
      }
  return split;
}

}  // namespace

namespace {
ClassifyTilesPlan planTiles(const blobtree::Program& program, const blobtree::GridSpec& grid, const BrickGrid& finest,
                            const BrickGrid& top, std::uint32_t emptyBox, std::uint32_t maxTiles) {
  ClassifyTilesPlan plan;
  if (maxTiles < 8 || program.code.empty() || top.count() < 2) return plan;
  // A tape costs a host walk of the code, so trying regular splits is cheaper than planning
  // (planFieldTiles' greedy splits cost tower 1-2 ms a job).
  const std::uint32_t levels = top.log2B - finest.log2B + 1;
  plan.wholeSeconds = costs::kClassifyInterpretedSecondsPerStep *
                      classifyWork(program, grid, 1u << finest.log2B, 256).interpreted;
  for (std::uint32_t n = 2; n * n * n <= maxTiles; ++n) {
    Split split = splitTop(program, grid, finest, top, emptyBox, n);
    const double seconds = costs::kClassifyInterpretedSecondsPerStep * split.steps +
                           costs::kClassifyTileDispatchSeconds * double(split.tiles.size() * levels);
    if (!plan.tiles.empty() && seconds >= plan.seconds) break;
    plan.tiles = std::move(split.tiles);
    plan.seconds = seconds;
  }
  if (plan.tiles.size() < 2) plan.tiles.clear();
  plan.pays = !plan.tiles.empty() && plan.seconds < costs::kClassifyTilesMargin * plan.wholeSeconds;
  return plan;
}
}  // namespace

ClassifyTilesPlan planClassifyTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                    const BrickGrid& finest, const BrickGrid& top, std::uint32_t emptyBox,
                                    std::uint32_t maxTiles) {
  // The tapes are host walks of the code per tile and split tried (random128 at 512 cells: 4 ms
  // of a 18 ms job on an H100), the same each run of a repeated job.
  static HostMemo<ClassifyTilesPlan, 16> memo;
  MemoKey key;
  key.add(programFingerprint(program)).add(grid.origin).add(grid.cellSize).add(grid.cells);
  for (const BrickGrid& b : {finest, top}) key.add(b.log2B).add(b.x).add(b.y).add(b.z);
  key.add(emptyBox).add(maxTiles);
  return memo.get(key, [&] { return planTiles(program, grid, finest, top, emptyBox, maxTiles); });
}

std::vector<ClassifyTile> uploadClassifyTiles(Device& device, const ClassifyTilesPlan& plan, std::uint64_t uniformBlock) {
  std::vector<ClassifyTile> tiles;
  for (const PlannedClassifyTile& p : plan.tiles) {
    ClassifyTile t;
    t.top = p.top;
    t.length = std::uint32_t(p.tape.size());
    const std::uint64_t bytes = std::max<std::uint64_t>(p.tape.size() * sizeof(p.tape[0]), 16);
    t.code = uniformBlock ? device.createBuffer(uniformBlock, MemoryUse::DeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT)
                          : device.createBuffer(bytes);
    if (!p.tape.empty()) device.upload(t.code, p.tape.data(), p.tape.size() * sizeof(p.tape[0]));
    tiles.push_back(std::move(t));
  }
  return tiles;
}

BrickBox boxBelow(const BrickBox& box, unsigned shift, const BrickGrid& grid) {
  const std::array<std::uint32_t, 3> count{grid.x, grid.y, grid.z};
  BrickBox b;
  for (int a = 0; a < 3; ++a) {
    b.first[a] = std::min(box.first[a] << shift, count[a]);
    b.end[a] = std::min(box.end[a] << shift, count[a]);
  }
  return b;
}

}  // namespace blobvk::vk
