// llvmpipe, the CPU driver under lavapipe, ends the loops of a shader invocation without any
// error once they have run 65,535 iterations in all (gallivm's LP_MAX_TGSI_LOOP_ITERATIONS: one
// counter shared by every loop of the invocation, whatever the nesting). blobvk's interpreters
// loop once per instruction, and looped generated code once per skip and instance, so the sparse
// field pass, which evaluates a row of B + 1 points per invocation, would see the field of a
// program of a few thousand instructions cut short (a blend of 2,500 points gave 17 % fewer
// triangles, silently). These bounds let the extraction pick bricks whose rows fit the limit, and
// every pass refuse, with an error naming the limit, a job that cannot fit it.
#pragma once

#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/extract/polygonize.h"

#include <cstdint>

namespace blobvk::vk {

inline constexpr std::uint64_t kLlvmpipeLoopIterations = 65535;

// The loop iterations one shader invocation may run on this device: kLlvmpipeLoopIterations on
// llvmpipe, no limit (~0) elsewhere.
std::uint64_t loopIterationLimit(const DeviceInfo& info);

// At most how many loop iterations one evaluation of `program`'s field runs with `traversal`
// (codegen: Specialised's options, null for the CPU drivers' default): an interpreter one per
// instruction (the stack-based walk two), the generated code in its looped form one per skip and
// instance (fewer than its instructions), straight-line generated code without branching skips
// none. Traversal::Auto counts as the interpreter (the most an unresolved job can run).
std::uint64_t evaluationLoopBound(const blobtree::Program& program, Traversal traversal, const CodegenOptions* codegen);
// The same for the sparse field pass of `options` (per-brick tapes are interpreted).
std::uint64_t evaluationLoopBound(const blobtree::Program& program, const GpuPolygonizeOptions& options);

// Loop iterations of one invocation of the sparse field pass (a row of brickCells + 1 points,
// each one evaluation, and the row's own loops), with `perEvaluation` from evaluationLoopBound.
std::uint64_t brickFieldLoopIterations(std::uint32_t brickCells, std::uint64_t perEvaluation);

// Loop iterations of one invocation of the vertex pass: the refinement's evaluations, the
// stack-based traversal's six normal samples and colour, the gradient pass.
std::uint64_t vertexLoopIterations(int refineSteps, bool stackBased, std::uint64_t perEvaluation);

// The largest power of two from 2 to `brickCells` whose field pass fits `limit`; 0 when none does.
std::uint32_t brickCellsWithinLoopLimit(std::uint32_t brickCells, std::uint64_t perEvaluation, std::uint64_t limit);
// The bricks a sparse job on `info`'s device takes for the evaluator `options` describes
// (Traversal::Auto: the interpreter's bound, the most the model's choice can loop):
// brickCellsWithinLoopLimit, or `brickCells` itself where the device has no limit or no size fits
// (SparseBatchRunner then refuses the job, checkSparseLoopLimit).
std::uint32_t brickCellsForLoopLimit(const DeviceInfo& info, const blobtree::Program& program,
                                     const GpuPolygonizeOptions& options, std::uint32_t brickCells);

// Throws VulkanError naming the limit, the program's size and what to do when the sparse passes
// of a job with bricks of `brickCells` would exceed `limit`.
void checkSparseLoopLimit(const blobtree::Program& program, const GpuPolygonizeOptions& options,
                          std::uint32_t brickCells, std::uint64_t limit);
// The same for the dense pipeline, whose field kernel evaluates one point per invocation.
void checkDenseLoopLimit(const blobtree::Program& program, const GpuPolygonizeOptions& options, std::uint64_t limit);

}  // namespace blobvk::vk
