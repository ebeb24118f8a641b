// The interpreted brick classification per tile: the grid's bricks split into boxes of the
// classification's coarsest level, each box classified (every level) with the register code
// pruned on the host to the points of the box (vk/eval/region_tape.h, TapeUse::Field).
//
// Why: the interpreter pays for every instruction of the code it is given, at every brick, and
// llvmpipe skips nothing it is not told to skip (no real branches): random128's 128 primitives
// under one skip box cost the whole program at each of its 36,000 bricks of 16^3 at 512 cells.
// A tile's tape drops the primitives and subtrees that are 0 over it, so each brick runs a few
// tens of instructions. Unlike the field tiles' generated kernels (brick_tiles.h) a tape costs a
// host walk of the code and an upload, no pipeline build, so the tiles can be many.
//
// The flags stay conservative: a tile's tape computes the program's field at every grid point
// of the tile (its points past the grid's end and the coordinates' rounding included, through
// regionOfPoints' margin), so its interval over a brick of the tile bounds the field at that
// brick's samples. They can be tighter than the whole program's (an addition of 0 costs the
// interval a rounding margin); which bricks are active never changes the mesh.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/extract/classify_kernel.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>
#include <vector>

namespace blobvk::vk {

// One tile on the host: its bricks of the coarsest level classified (the finest, without parent
// levels) and its tape.
struct PlannedClassifyTile {
  BrickBox top;
  std::vector<layout::Instruction> tape;
};

// Regular splits of `top` (the coarsest level classified above the `finest` bricks) into 2^3,
// 3^3 ... tiles (at most maxTiles), each with the register code pruned to its points
// (TapeUse::Field; `emptyBox` is the empty skip box the evaluator sees, GpuProgram::emptyBox),
// and lavapipe's predicted seconds for the interpreter (its steps over the finest level,
// classifyWork, plus kClassifyTileDispatchSeconds per tile and level): the fastest split, tried
// while they get faster. `pays` where it comes within kClassifyTilesMargin of the whole
// program's prediction. `tiles` is empty where the top level is one brick.
struct ClassifyTilesPlan {
  std::vector<PlannedClassifyTile> tiles;
  double seconds = 0.0;       // the tiles' prediction
  double wholeSeconds = 0.0;  // the whole program's
  bool pays = false;
};
ClassifyTilesPlan planClassifyTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                    const BrickGrid& finest, const BrickGrid& top, std::uint32_t emptyBox,
                                    std::uint32_t maxTiles = kMaxClassifyTiles);

// A tile on the device: its tape in a storage buffer, or in a uniform block of `uniformBlock`
// bytes (brick_classify_uniform, whose code block holds uniformBlock / 16 instructions: a tape is
// never longer than the program).
struct ClassifyTile {
  BrickBox top;
  Buffer code;
  std::uint32_t length = 0;
};
std::vector<ClassifyTile> uploadClassifyTiles(Device& device, const ClassifyTilesPlan& plan, std::uint64_t uniformBlock);

// The bricks `shift` levels finer than `box`'s (each level halving the brick), within `grid`.
BrickBox boxBelow(const BrickBox& box, unsigned shift, const BrickGrid& grid);

}  // namespace blobvk::vk
