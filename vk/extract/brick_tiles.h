// The sparse field pass's tiles: the grid's bricks split into a few boxes of whole bricks, each
// evaluated by a specialised kernel from which the subtrees whose skip boxes miss the box are
// dropped at compile time (CodegenOptions::region, as the dense path's vk/eval/field_tiles.h).
//
// Why: llvmpipe (Mesa 22.3) has no real branches, so the specialised code runs every instruction
// of the program at every point of every active brick; pruning on the host is the only skip it
// gets. On tower at 512 cells eight tiles leave about a sixth of the program's work per point
// (prunedEvaluationCost). Values are bit for bit those of the whole program at every point of a
// tile's bricks (past the grid's end included), so the mesh does not change.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::vk {

struct BrickTile {
  std::array<std::uint32_t, 3> first{}, last{};  // brick coordinates, inclusive
  PointRegion region;                            // world box of all its bricks' points (padded)
};

// Tiles covering every brick of the grid exactly once (at most maxTiles; one when pruning gains
// too little), planned by planFieldTiles over a grid whose points are the bricks; past maxTiles,
// tiles whose code would loop with `loops` split on, up to maxTilesForLoopedCode tiles
// (FieldTilingOptions::maxTilesForLoopedCode; 0: not). Deterministic.
std::vector<BrickTile> planBrickTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                      const BrickGrid& bricks, std::uint32_t maxTiles,
                                      std::uint32_t maxTilesForLoopedCode = 0, const LoopOptions& loops = {});

// Bricks (packed coordinates, BrickGrid::pack, in batch order) grouped by tile: `order`
// holds batch brick numbers, tile t's at order[starts[t] .. starts[t + 1]), ascending.
struct BrickTileOrder {
  std::vector<std::uint32_t> order;
  std::vector<std::uint32_t> starts;  // tiles + 1
};
BrickTileOrder orderBricksByTile(std::span<const BrickTile> tiles, const BrickGrid& bricks,
                                 std::span<const std::uint32_t> packedBricks);

}  // namespace blobvk::vk
