// Which kernel classifies the sparse path's bricks (sparse_polygonizer.h): the embedded
// interpreter of the register code (shaders/brick_classify*.comp), or the kernel generated for
// the program (vk/eval/interval_codegen.h), which gives the same flags bit for bit, several
// times faster on lavapipe, after a build (glslang and llvmpipe) of its own.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/polygonize.h"

#include <cstdint>
#include <span>

namespace blobvk::vk {


// Most tiles the interpreted classification takes (classify_tiles.h): each is a tape upload and
// one dispatch per level.
inline constexpr std::uint32_t kMaxClassifyTiles = 64;

struct ClassifyChoice {
  ClassifyCode code = ClassifyCode::Auto;
  std::uint32_t expectedRuns = 1;  // Auto: jobs with this program the caller expects (its own included)
  // The interpreter per tile with pruned tapes (classify_tiles.h): at most this many tiles (1: the
  // whole program), where the cost model says they pay, or (tilesWhenTheyPay false, for tests)
  // wherever the plan has several.
  std::uint32_t maxTiles = kMaxClassifyTiles;
  bool tilesWhenTheyPay = true;
  // Auto: the interpreter's predicted seconds tile by tile where the tiles pay (< 0: they do not,
  // or were not planned), which the generated code must beat to be built or taken.
  double tiledSeconds = -1.0;
  // classifyToFit: the job's options, where its small grids may classify on the host
  // (host_classify.h); null: always on the device.
  const GpuPolygonizeOptions* hostOptions = nullptr;
};

struct ClassifyKernel {
  KernelPtr kernel;
  bool generated = false;
};

// The kernel for `program` (uploaded as `gpu`, Traversal::Stackless) with its records in uniform
// buffers (`uniformRecords`, brick_classify_uniform's layout) or storage buffers (brick_classify:
// always the interpreter), classifying bricks of `brickCells` on `grid` (the cost model's job).
ClassifyKernel classifyKernel(Device& device, const blobtree::Program& program, const GpuProgram& gpu,
                              bool uniformRecords, const ClassifyChoice& choice, const blobtree::GridSpec& grid,
                              std::uint32_t brickCells);

// Steps of the classification's finest level, summed over its lanes' vectors (8 bricks: 4 along
// x, 2 along y, as llvmpipe packs the 4 x 4 x 4 work groups), walked on the host with the
// program's skip boxes on the world point: the interpreter's (a vector runs until its longest
// lane is done, each lane jumping over the skips its brick misses) and the generated code's (all
// its instructions, but the regions of branching skips that every lane misses). Sampled evenly
// over at most `maxVectors` vectors, scaled to all of them.
struct ClassifyWork {
  double interpreted = 0.0, generated = 0.0;
};
ClassifyWork classifyWork(const blobtree::Program& program, const blobtree::GridSpec& grid, std::uint32_t brickCells,
                          std::uint32_t maxVectors = 1024);
// The same for `code` in place of program.code (a tape of it, vk/eval/region_tape.h: skips on
// boxes past program.boxes, the empty box, count as entered).
ClassifyWork classifyWork(const blobtree::Program& program, std::span<const layout::Instruction> code,
                          const blobtree::GridSpec& grid, std::uint32_t brickCells, std::uint32_t maxVectors = 1024);

// Whether the generated kernel pays for its build over `runs` jobs classifying bricks of
// `brickCells` on `grid`: predicted faster than the interpreter by a margin, and the time saved
// over the runs beyond its build (lavapipe's constants, vk/eval/evaluator_costs.h). With
// `interpretedSeconds` >= 0 the interpreter is predicted to take no more than that (its tiles).
bool classifyCodePays(const blobtree::Program& program, const blobtree::GridSpec& grid, std::uint32_t brickCells,
                      std::uint32_t runs, double interpretedSeconds = -1.0);

}  // namespace blobvk::vk
