#include "blobvk/vk/extract/loop_limit.h"

#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <algorithm>
#include <string>

namespace blobvk::vk {

std::uint64_t loopIterationLimit(const DeviceInfo& info) {
  return info.isLlvmpipe() ? kLlvmpipeLoopIterations : ~0ull;
}

std::uint64_t evaluationLoopBound(const blobtree::Program& program, const GpuPolygonizeOptions& options) {
  return evaluationLoopBound(program, options.brickTapes ? Traversal::Stackless : options.traversal, options.codegen);
}

std::uint64_t evaluationLoopBound(const blobtree::Program& program, Traversal traversal, const CodegenOptions* options) {
  const std::uint64_t instructions = program.code.size();
  const std::uint64_t interpreted = instructions + 1;  // the loop's last test counts too
  switch (traversal) {
    case Traversal::StackBased:
      return 2 * instructions + 2;  // each node entered and left
    case Traversal::Specialised: {
      // The limit is llvmpipe's, so without options the code is the CPU drivers' default.
      const CodegenOptions codegen = options ? *options : defaultCodegenOptions(true);
      if (!canSpecialise(program, {}, codegen.loops)) return interpreted;  // too large: interpreted
      const bool looped = specialisedCodeLoops(program, {}, codegen.loops);
      return looped || codegen.branchOnSkips ? interpreted : 0;  // a loop per skip and instance at most
    }
    case Traversal::Stackless:
    case Traversal::Auto:
      break;
  }
  return interpreted;
}

std::uint64_t brickFieldLoopIterations(std::uint32_t brickCells, std::uint64_t perEvaluation) {
  const std::uint64_t points = std::uint64_t(brickCells) + 1;
  // brick_field_body.glsl: a loop over the row's runs of four points, one over each run's points.
  return points * perEvaluation + 2 * points + 8;
}

std::uint64_t vertexLoopIterations(int refineSteps, bool stackBased, std::uint64_t perEvaluation) {
  // edge_vertex.glsl: the sample loop (the refinement steps, six normal samples for the
  // stack-based walk, and a last pass that leaves), each sample one evaluation; then the gradient
  // pass (or the stack-based walk's colour), one more evaluation's worth.
  const std::uint64_t samples = std::uint64_t(std::max(refineSteps, 0)) + (stackBased ? 6 : 0);
  return (samples + 1) * perEvaluation + samples + 8;
}

std::uint32_t brickCellsWithinLoopLimit(std::uint32_t brickCells, std::uint64_t perEvaluation, std::uint64_t limit) {
  for (std::uint32_t b = brickCells; b >= 2; b /= 2)
    if (brickFieldLoopIterations(b, perEvaluation) <= limit) return b;
  return 0;
}

std::uint32_t brickCellsForLoopLimit(const DeviceInfo& info, const blobtree::Program& program,
                                     const GpuPolygonizeOptions& options, std::uint32_t brickCells) {
  const std::uint64_t limit = loopIterationLimit(info);
  if (limit == ~0ull) return brickCells;
  const std::uint32_t fits = brickCellsWithinLoopLimit(brickCells, evaluationLoopBound(program, options), limit);
  return fits != 0 ? fits : brickCells;
}

namespace {

// The vertex pass runs the traversal's kernel, interpreting the gradient where the generated one
// is off or not built yet, or (with brick tapes) over the bricks' vertex tapes, whose runs of
// null additions loop over their colour blends: under llvmpipe's masks at most one iteration per
// instruction more (a tape and its runs are at most the program).
std::uint64_t vertexPassLoopIterations(const blobtree::Program& program, const GpuPolygonizeOptions& options) {
  GpuPolygonizeOptions vertexEvaluator = options;
  vertexEvaluator.brickTapes = false;
  const bool generatedGradient = !options.codegen || options.codegen->gradient;
  if (options.traversal == Traversal::Specialised && (!generatedGradient || options.interpretVertexPassUntilBuilt))
    vertexEvaluator.traversal = Traversal::Stackless;
  const std::uint64_t evaluations = vertexLoopIterations(options.refineSteps, options.traversal == Traversal::StackBased,
                                                         evaluationLoopBound(program, vertexEvaluator));
  // The generated gradient's loops over runs of pruned primitives' colour blends
  // (vk/eval/gradient_codegen.cpp, nullAdds): at most one iteration per instruction.
  const bool generated = vertexEvaluator.traversal == Traversal::Specialised && generatedGradient;
  return evaluations + (generated || options.brickTapes || options.vertexTapes ? program.code.size() : 0);
}

// Whether a job with `options` fits `limit`: its vertex pass, and its field pass with bricks of
// `brickCells` (sparse) or one point per invocation (dense, brickCells 0).
bool fitsLoopLimit(const blobtree::Program& program, const GpuPolygonizeOptions& options, std::uint32_t brickCells,
                   std::uint64_t limit) {
  if (vertexPassLoopIterations(program, options) > limit) return false;
  const std::uint64_t perEvaluation = evaluationLoopBound(program, options);
  return (brickCells ? brickFieldLoopIterations(brickCells, perEvaluation) : perEvaluation + 8) <= limit;
}

// A refusal's advice: only what would run the job within the limit (a program too large to
// specialise is interpreted whatever --traversal says, and then no brick may fit), always ending
// with the cpu backend.
std::string adviceWithin(const blobtree::Program& program, const GpuPolygonizeOptions& options, std::uint32_t brickCells,
                         std::uint64_t limit) {
  std::string advice;
  for (std::uint32_t b = brickCells / 2; b >= 2; b /= 2) {
    if (fitsLoopLimit(program, options, b, limit)) {
      advice += "bricks of " + std::to_string(b) + " cells (--brick-cells " + std::to_string(b) + "), ";
      break;
    }
  }
  if (options.traversal != Traversal::Specialised) {
    GpuPolygonizeOptions specialised = options;
    specialised.traversal = Traversal::Specialised;
    specialised.brickTapes = false;
    specialised.interpretVertexPassUntilBuilt = false;
    bool fits = fitsLoopLimit(program, specialised, brickCells, limit);
    for (std::uint32_t b = brickCells / 2; b >= 2 && !fits; b /= 2) fits = fitsLoopLimit(program, specialised, b, limit);
    if (fits) advice += "a specialised evaluator (--traversal specialised), ";
  }
  return advice + (advice.empty() ? "the cpu backend (--backend cpu)" : "or the cpu backend");
}

[[noreturn]] void refuse(const blobtree::Program& program, std::uint64_t iterations, const std::string& pass,
                         std::uint64_t limit, const std::string& advice) {
  throw VulkanError("GPU polygonizer: the program's " + std::to_string(program.code.size()) + " instructions take up to " +
                    std::to_string(iterations) + " loop iterations per invocation of the " + pass +
                    ", over this driver's limit of " + std::to_string(limit) +
                    " (llvmpipe ends longer loops early and silently); use " + advice);
}

}  // namespace

void checkSparseLoopLimit(const blobtree::Program& program, const GpuPolygonizeOptions& options,
                          std::uint32_t brickCells, std::uint64_t limit) {
  const std::uint64_t field = brickFieldLoopIterations(brickCells, evaluationLoopBound(program, options));
  if (field > limit)
    refuse(program, field, "field pass with bricks of " + std::to_string(brickCells) + " cells", limit,
           adviceWithin(program, options, brickCells, limit));
  const std::uint64_t vertex = vertexPassLoopIterations(program, options);
  if (vertex > limit) refuse(program, vertex, "vertex pass", limit, adviceWithin(program, options, brickCells, limit));
}

void checkDenseLoopLimit(const blobtree::Program& program, const GpuPolygonizeOptions& options, std::uint64_t limit) {
  const std::uint64_t field = evaluationLoopBound(program, options) + 8;  // field_grid.comp: one point
  if (field > limit) refuse(program, field, "field pass", limit, adviceWithin(program, options, 0, limit));
  const std::uint64_t vertex = vertexPassLoopIterations(program, options);
  if (vertex > limit) refuse(program, vertex, "vertex pass", limit, adviceWithin(program, options, 0, limit));
}

}  // namespace blobvk::vk
