#include "blobvk/vk/extract/brick_tiles.h"

#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/host_memo.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <algorithm>
#include <stdexcept>

namespace blobvk::vk {

namespace {
std::vector<BrickTile> planTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                 const BrickGrid& bricks, std::uint32_t maxTiles, std::uint32_t maxTilesForLoopedCode,
                                 const LoopOptions& loops) {
  const std::uint32_t B = 1u << bricks.log2B;
  const std::array<std::uint32_t, 3> count{bricks.x, bricks.y, bricks.z};
  // A grid whose point i is brick i's first point: its tiles of points are tiles of bricks (the
  // last point layer of each axis holds no brick). Bricks are few, so any extent may be split.
  blobtree::GridSpec coarse = grid;
  coarse.cellSize = grid.cellSize * float(B);
  coarse.cells = {int(bricks.x), int(bricks.y), int(bricks.z)};
  FieldTilingOptions options;
  options.maxTiles = std::max<std::uint32_t>(maxTiles, 1);
  options.minExtent = 1;
  options.maxTilesForLoopedCode = maxTilesForLoopedCode;
  options.loops = loops;
  options.kernelReach = 1;
  std::vector<BrickTile> tiles;
  for (const FieldTile& f : planFieldTiles(program, coarse, options)) {
    BrickTile t;
    bool empty = false;
    std::array<std::uint32_t, 3> lo{}, hi{};
    for (int i = 0; i < 3; ++i) {
      empty = empty || f.first[i] >= count[i];
      t.first[i] = f.first[i];
      t.last[i] = std::min(f.last[i], count[i] - 1);
      lo[i] = t.first[i] * B;
      hi[i] = (t.last[i] + 1) * B;  // every point the field kernel evaluates, past the grid's end too
    }
    if (empty) continue;
    t.region = regionOfPoints(grid, lo, hi);
    tiles.push_back(t);
  }
  return tiles;
}
}  // namespace

std::vector<BrickTile> planBrickTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                      const BrickGrid& bricks, std::uint32_t maxTiles,
                                      std::uint32_t maxTilesForLoopedCode, const LoopOptions& loops) {
  static HostMemo<std::vector<BrickTile>> memo;
  MemoKey key;
  key.add(programFingerprint(program)).add(grid.origin).add(grid.cellSize).add(grid.cells);
  key.add(bricks.log2B).add(bricks.x).add(bricks.y).add(bricks.z).add(maxTiles);
  addLoopOptions(key.add(maxTilesForLoopedCode), loops);
  return memo.get(key, [&] { return planTiles(program, grid, bricks, maxTiles, maxTilesForLoopedCode, loops); });
}

BrickTileOrder orderBricksByTile(std::span<const BrickTile> tiles, const BrickGrid& bricks,
                                 std::span<const std::uint32_t> packedBricks) {
  BrickTileOrder o;
  std::vector<std::uint32_t> tileOf(packedBricks.size(), 0);
  std::vector<std::uint32_t> sizes(tiles.size(), 0);
  for (std::size_t a = 0; a < packedBricks.size(); ++a) {
    const std::uint32_t p = packedBricks[a];
    const std::array<std::uint32_t, 3> b = bricks.unpack(p);
    std::uint32_t t = 0;
    auto holds = [&](const BrickTile& tile) {
      for (int i = 0; i < 3; ++i)
        if (b[i] < tile.first[i] || b[i] > tile.last[i]) return false;
      return true;
    };
    while (t < tiles.size() && !holds(tiles[t])) ++t;
    // A brick outside every tile would be evaluated with a kernel pruned for somewhere else.
    if (t == tiles.size()) throw std::logic_error("GPU polygonizer: a brick lies in no field tile");
    tileOf[a] = t;
    ++sizes[t];
  }
  o.starts.assign(tiles.size() + 1, 0);
  for (std::size_t t = 0; t < tiles.size(); ++t) o.starts[t + 1] = o.starts[t] + sizes[t];
  o.order.resize(packedBricks.size());
  std::vector<std::uint32_t> next(o.starts.begin(), o.starts.end() - 1);
  for (std::size_t a = 0; a < packedBricks.size(); ++a) o.order[next[tileOf[a]]++] = std::uint32_t(a);
  return o;
}

}  // namespace blobvk::vk
