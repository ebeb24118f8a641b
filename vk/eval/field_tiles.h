// Spatial tape pruning for the field pass: the grid's points split into a few boxes (tiles), each
// evaluated by its own specialised kernel from which the subtrees whose skip boxes miss the tile
// are dropped at compile time (CodegenOptions::region).
//
// Why: a box skip is the CPU's biggest saving on coherent points (a 64-point chunk outside a
// subtree's box skips it whole), but llvmpipe (Mesa 22.3) has no real branches — every `if` runs
// both sides under a lane mask, loops run their body at least once — so the specialised code
// runs every instruction at every point. Pruning on the host gives lavapipe the same saving: for
// the tower, a tile at one storey runs a fraction of the code. GPUs benefit too (less code, no
// divergent skips), so the plan does not depend on the device.
//
// Results are bit for bit those of the unpruned program (the pruned subtrees give exactly 0
// at points outside their box, which every point of the tile is).
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/host_memo.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::vk {

struct FieldTile {
  std::array<std::uint32_t, 3> first{}, last{};  // grid point indices, inclusive
  PointRegion region;                            // world box holding the tile's points (padded)
  std::uint32_t cost = 0;                        // per point, pruned (prunedEvaluationCost)
  std::uint64_t points() const {
    return std::uint64_t(last[0] - first[0] + 1) * (last[1] - first[1] + 1) * (last[2] - first[2] + 1);
  }
};

struct FieldTilingOptions {
  // At most this many tiles (each may be its own pipeline, compiled at first use); 1 = no tiling.
  std::uint32_t maxTiles = 8;
  // A split is taken only when it cuts the total work (points x cost) by this fraction.
  double minGain = 0.05;
  // Tiles are not split below this many points along an axis.
  std::uint32_t minExtent = 8;
  // A program too large to specialise whole is tiled only on grids of at least this many points:
  // its tile kernels (up to kMaxTileInstructions) take ~0.3 s each to build on lavapipe
  // (tower_L6P8I4 at 128 cells, 1.4 M points: 11.3 s -> 6.6 s a polygonization; at 24 cells the
  // builds were all the time).
  std::uint64_t minPointsForLargePrograms = 1'000'000;
  // Past maxTiles (and minGain), a tile whose pruned code takes the looped form with `loops`
  // (specialisedCodeLoops) is split further, the one with the most work first, up to this many
  // tiles in all (0: no such splits). On a CPU driver each buffer load in a loop is a loop over
  // the lanes, so looped code runs tens of times slower than the unrolled code of smaller tiles,
  // which builds in about the time (tower_L6P8I4 at 256 cells on lavapipe: field 5-7 s in 8 or 16
  // looped tiles, 0.2-0.25 s in 48 unrolled ones; a first run no slower). A split must take code
  // off both halves (splitLoopedTiles). Only where `loops` unrolls short code
  // (minProgramInstructions > 0, CPU drivers): elsewhere any repeated shape loops.
  std::uint32_t maxTilesForLoopedCode = 0;
  LoopOptions loops;
  // Points past a tile's last along each axis (within the grid) that its kernel evaluates too,
  // which the test for looped code covers (a grid whose points are bricks: 1, each brick's far side).
  std::uint32_t kernelReach = 0;
};

// A program too large to specialise whole gets its own kernel for a tile only when the pruned
// code has at most this many instructions: LLVM's time grows faster than the code (measured on
// tower_L6P8I4: 16 tile kernels of ~2,900 instructions took 80 s to build on lavapipe).
inline constexpr std::uint32_t kMaxTileInstructions = 1024;

// True when a tile of `program` gets its own specialised kernel (generated with `loops`).
bool specialiseTile(const blobtree::Program& program, const PointRegion& region, const LoopOptions& loops = {});
// specialiseTile for each region (1 or 0), remembered for the programs and plans asked about
// last (host_memo.h): a repeated job asks each run, and a program of thousands of instructions
// takes milliseconds a tile. `fingerprint` is programFingerprint(program) (0: computed here).
std::vector<char> specialiseTiles(const blobtree::Program& program, std::uint64_t fingerprint,
                                  std::span<const PointRegion> regions, const LoopOptions& loops);

// Tiles covering every grid point exactly once, chosen greedily (k-d splits at an eighth of a
// tile's extent along any axis, the one removing the most work first).
// Deterministic: the same program and grid give the same tiles.
std::vector<FieldTile> planFieldTiles(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                      const FieldTilingOptions& options = {});

// The padded world box of grid points first..last (inclusive): a hundredth of a cell of margin,
// so that the shader's own arithmetic for a point can never land outside it.
PointRegion regionOfPoints(const blobtree::GridSpec& grid, const std::array<std::uint32_t, 3>& first,
                           const std::array<std::uint32_t, 3>& last);

}  // namespace blobvk::vk
