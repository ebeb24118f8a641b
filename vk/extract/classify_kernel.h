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

namespace blobvk::vk {


struct ClassifyChoice {
  ClassifyCode code = ClassifyCode::Auto;
  std::uint32_t expectedRuns = 1;  // Auto: jobs with this program the caller expects (its own included)
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

// Whether the generated kernel pays for its build over `runs` jobs classifying bricks of
// `brickCells` on `grid`: predicted faster than the interpreter by a margin, and the time saved
// over the runs beyond its build (lavapipe's constants, vk/eval/evaluator_costs.h).
bool classifyCodePays(const blobtree::Program& program, const blobtree::GridSpec& grid, std::uint32_t brickCells,
                      std::uint32_t runs);

}  // namespace blobvk::vk
