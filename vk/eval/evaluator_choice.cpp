#include "blobvk/vk/eval/evaluator_choice.h"

#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/uniform_program.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace blobvk::vk {

double specialisedKernelSeconds(double instructions, double copies) {
  const double n = instructions * copies;
  return costs::kSpecialisedKernelSeconds + costs::kSpecialisedSecondsPerInstruction * n +
         costs::kSpecialisedSecondsPerInstruction2 * n * n;
}

namespace {
// Work (points x instructions run) of an evaluator that branches on its skips, as the interpreter
// and looped code do: the grid in blocks of 16^3 points or more (the sparse extraction's bricks),
// each point running the program pruned to its block. A subgroup skips more finely than a block,
// but blocks already drop what lies away from the points, which the whole program does not. Counted
// in instructions, not prunedEvaluationCost: on llvmpipe the interpreter pays every opcode's and
// primitive type's code under a mask at each instruction, so an operator costs about a primitive.
//
// With `evaluated` bricks only their points count: each block (whole bricks) weighs its pruned
// program by the points of the bricks whose first point lies in it (its region reaches one point
// further, where the last of those bricks ends). Blocks stay at most 8 per axis, so the cost stays a few hundred pruned counts
// however many bricks are active.
struct EvaluatedWork {
  double points = 0.0, work = 0.0;
};
EvaluatedWork branchingWork(const blobtree::Program& program, const blobtree::GridSpec& grid,
                            const EvaluatedBricks* evaluated) {
  constexpr std::uint32_t kBlockPoints = 16, kMaxBlocksPerAxis = 8;
  EvaluatedWork w;
  const auto pts = grid.points();
  if (pts.x < 1 || pts.y < 1 || pts.z < 1) return w;
  const std::uint32_t n[3] = {std::uint32_t(pts.x), std::uint32_t(pts.y), std::uint32_t(pts.z)};
  // Blocks of whole bricks, so that a brick starting in a block ends at most one point past it.
  const std::uint32_t brick = evaluated ? std::max<std::uint32_t>(evaluated->cells, 1) : 1;
  std::uint32_t step[3], blocks[3];
  for (int a = 0; a < 3; ++a) {
    step[a] = std::max(kBlockPoints, (n[a] + kMaxBlocksPerAxis - 1) / kMaxBlocksPerAxis);
    step[a] = (step[a] + brick - 1) / brick * brick;
    blocks[a] = (n[a] + step[a] - 1) / step[a];
  }
  // Points evaluated per block: all of its own, or those of the bricks starting in it.
  std::vector<double> blockPoints(std::size_t(blocks[0]) * blocks[1] * blocks[2], 0.0);
  auto blockIndex = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
    return (std::size_t(z / step[2]) * blocks[1] + y / step[1]) * blocks[0] + x / step[0];
  };
  if (evaluated) {
    const std::uint32_t B = std::max<std::uint32_t>(evaluated->cells, 1);
    for (const auto& b : evaluated->bricks) {
      const std::uint32_t first[3] = {b[0] * B, b[1] * B, b[2] * B};
      if (first[0] >= n[0] || first[1] >= n[1] || first[2] >= n[2]) continue;
      double p = 1.0;
      for (int a = 0; a < 3; ++a) p *= double(std::min(first[a] + B, n[a] - 1) - first[a] + 1);
      blockPoints[blockIndex(first[0], first[1], first[2])] += p;
    }
  }
  const std::uint32_t reach = evaluated ? 1 : 0;
  for (std::uint32_t z = 0; z < n[2]; z += step[2])
    for (std::uint32_t y = 0; y < n[1]; y += step[1])
      for (std::uint32_t x = 0; x < n[0]; x += step[0]) {
        const std::array<std::uint32_t, 3> first{x, y, z};
        const std::array<std::uint32_t, 3> last{std::min(x + step[0] + reach, n[0]) - 1,
                                                std::min(y + step[1] + reach, n[1]) - 1,
                                                std::min(z + step[2] + reach, n[2]) - 1};
        double points = blockPoints[blockIndex(x, y, z)];
        if (!evaluated) {
          const std::array<std::uint32_t, 3> own{std::min(x + step[0], n[0]) - 1, std::min(y + step[1], n[1]) - 1,
                                                 std::min(z + step[2], n[2]) - 1};
          points = double(own[0] - first[0] + 1) * (own[1] - first[1] + 1) * (own[2] - first[2] + 1);
        }
        if (points <= 0.0) continue;
        w.points += points;
        w.work += points * double(branchedInstructionCount(program, regionOfPoints(grid, first, last)));
      }
  return w;
}

// Memory a specialised kernel's build takes beyond the process's own (kernels are built one at a
// time, so the largest counts).
double buildMegabytes(double instructions) { return costs::kBuildMegabytesPerInstruction * instructions; }
}  // namespace

EvaluatorChoice chooseEvaluator(bool cpuDevice, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const EvaluatorJob& job, const CodegenOptions& codegen,
                                const KernelBuiltQuery& built) {
  using namespace costs;
  EvaluatorChoice choice;
  // Build seconds of a kernel unless the device holds it already (sunk).
  auto isBuilt = [&](const char* shader, const CodegenOptions* c) { return built && built(shader, c); };
  // The generator options of the kernels the specialised candidates build (set below, once the
  // vertex kernel's gradient is decided: it is part of every kernel's fingerprint).
  CodegenOptions chosenCodegen = codegen;
  auto tileCodegen = [&](const PointRegion& region) {
    CodegenOptions c = chosenCodegen;
    c.region = region;
    return c;
  };
  // The surface, and so the vertex pass, scales with the grid; the field with the points evaluated.
  const double gridPoints = double(grid.pointCount());
  // Vertices: from the active bricks where the job knows them (a sparse surface in a large grid
  // has far fewer than the grid's surface-sized estimate), else from the grid.
  const double brickFace = job.evaluated ? double(job.evaluated->cells) * double(job.evaluated->cells) : 0.0;
  const double vertices = !job.vertexPass ? 0.0
                          : job.evaluated ? kVerticesPerBrickFaceCell * brickFace * double(job.evaluated->bricks.size())
                                          : kVerticesPerSurfacePoint * std::pow(gridPoints, 2.0 / 3.0);
  const double vertexEvaluations = vertices * (kEvaluationsPerVertex + std::max(job.refineSteps, 0));
  const double wholeCost = prunedEvaluationCost(program, {});
  FieldTilingOptions tiling = job.tiling;
  tiling.minPointsForLargePrograms = 0;
  if (job.evaluated) tiling.maxTiles = 1;
  const std::vector<FieldTile> tiles = planFieldTiles(program, grid, tiling);
  // What evaluators that branch on skips run (the interpreter, looped code), in instructions;
  // branchScale turns a tile's pruned cost into those.
  const EvaluatedWork evaluatedWork = branchingWork(program, grid, job.evaluated);
  const double points = evaluatedWork.points, branchWork = evaluatedWork.work;
  double tileWork = 0.0;
  for (const FieldTile& t : tiles) tileWork += (tiles.size() == 1 ? points : double(t.points())) * t.cost;
  const double meanBranchCost = points > 0.0 ? branchWork / points : double(program.code.size());
  const double branchScale = tileWork > 0.0 ? branchWork / tileWork : 1.0;

  EvaluatorEstimate interpreter;
  interpreter.traversal = Traversal::Stackless;
  interpreter.buildSeconds = (isBuilt("field_grid", nullptr) ? 0.0 : kInterpreterKernelSeconds) +
                             (job.vertexPass && !isBuilt("vertices", nullptr) ? kInterpreterKernelSeconds : 0.0);
  interpreter.runSeconds = kInterpreterSecondsPerInstruction * (branchWork + meanBranchCost * vertexEvaluations);
  choice.candidates.push_back(interpreter);

  // A specialised kernel for `region`: its build, and its seconds per point and unit of the
  // region's pruned cost. Unrolled code on a CPU driver runs every line under a mask, so it pays
  // for all the code it holds (`cost`); looped code branches on its skips like the interpreter,
  // so it pays for what the points need, approximated by the region's pruned cost as for the
  // interpreter.
  struct Kernel {
    double size = 0.0;
    bool looped = false;
  };
  auto kernelFor = [&](const PointRegion& region) {
    Kernel k;
    k.looped = specialisedCodeLoops(program, region, codegen.loops);
    k.size = double(specialisedCodeSize(program, region, codegen.loops));
    return k;
  };
  auto kernelSeconds = [&](const Kernel& k, double copies) {
    return specialisedKernelSeconds(k.size, copies) + (k.looped ? kLoopedKernelSeconds : 0.0);
  };
  // Seconds per evaluation by kernel `k` holding code of cost `held` (prunedEvaluationCost), at
  // points that run `pruned` instructions when branching.
  auto evaluationSeconds = [&](const Kernel& k, double pruned, double held) {
    return k.looped ? kLoopedSecondsPerInstruction * pruned : kSpecialisedSecondsPerCost * held;
  };

  const bool wholeFits = canSpecialise(program, {}, codegen.loops);
  // The gradient interpreted at every vertex, from storage buffers. Where the vertex kernel takes
  // no samples and the program fits uniform blocks a first job reads them there
  // (SparseBatchRunner), in a fraction of the time: that weighs one interpreted pass against
  // waiting for the generated kernel (interpretFirst below). The choice of the generated gradient
  // for the job's runs keeps the storage buffers' rate: it does not count that the generated
  // kernel then builds while the first job interprets, and errs towards the kernel the runs after
  // the first one want (tower at 256 cells: a 27 ms generated vertex pass per run, tiled,
  // against about 0.17 s interpreted from uniform blocks).
  const double interpretedGradientSeconds =
      kInterpreterSecondsPerInstruction * meanBranchCost * kInterpretedGradientEvaluations * vertices;
  const double firstPassGradientSeconds =
      interpretedGradientSeconds *
      (job.refineSteps <= 0 && fitsUniformBlocks(program) ? kUniformInterpretedGradientFraction : 1.0);
  const Kernel whole = wholeFits ? kernelFor({}) : Kernel{};
  // The vertex kernel: the whole program specialised, else the interpreter. Unrolled code
  // either generates the gradient (a larger kernel, a faster vertex pass) or interprets it; the
  // variant that fits the memory bound and costs less over the job's repeats is taken.
  struct VertexKernel {
    bool gradient = false;
    double build = 0.0, megabytes = 0.0, run = 0.0;
  };
  // `gradient` is the generator option (part of the kernel's name); looped code generates no
  // gradient whatever the option, so it costs as interpreting it.
  auto vertexKernel = [&](bool gradient) {
    VertexKernel v;
    v.gradient = gradient;
    if (!job.vertexPass) return v;
    CodegenOptions c = codegen;
    c.gradient = gradient;
    const bool built = wholeFits ? isBuilt("vertices", &c) : isBuilt("vertices", nullptr);
    const bool generated = gradient && wholeFits && !whole.looped;
    const double copies = generated ? kGradientVertexKernelCopies : kVertexKernelCopies;
    const double memoryCopies = generated ? kGradientVertexKernelMemoryCopies : kVertexKernelMemoryCopies;
    v.build = built ? 0.0 : wholeFits ? kernelSeconds(whole, copies) : kInterpreterKernelSeconds;
    v.megabytes = wholeFits && !built ? buildMegabytes(whole.size * memoryCopies) : 0.0;
    v.run = (wholeFits ? evaluationSeconds(whole, meanBranchCost, wholeCost)
                       : kInterpreterSecondsPerInstruction * meanBranchCost) *
            vertexEvaluations;
    if (!generated) v.run += interpretedGradientSeconds;
    return v;
  };
  // No vertex kernel, or none that could generate the gradient (looped code, the interpreter):
  // the option stays as the caller set it, so the kernels keep the names a job with these
  // options builds.
  const bool keepOption = !job.vertexPass || !wholeFits || whole.looped;
  VertexKernel vertex = vertexKernel(keepOption ? codegen.gradient : false);
  if (job.vertexPass && codegen.gradient && wholeFits && !whole.looped) {  // looped code generates none
    const VertexKernel generated = vertexKernel(true);
    if (generated.megabytes <= kMaxBuildMegabytes &&
        generated.build + job.repeats * generated.run < vertex.build + job.repeats * vertex.run)
      vertex = generated;
  }
  const double vertexBuild = vertex.build, vertexMegabytes = vertex.megabytes, vertexRun = vertex.run;
  // One vertex pass with the embedded interpreter (no code generated: its kernel builds in
  // kInterpreterKernelSeconds) against waiting for the generated kernel's build. Only without
  // refinement: the vertex kernel then samples no field (brick_vertices_direct), the interpreter
  // runs the gradient alone.
  const bool generatedToBuild =
      job.refineSteps <= 0 && vertex.gradient && wholeFits && !whole.looped && vertex.build > 0.0;
  const double interpretedVertexPass =
      (isBuilt("vertices", nullptr) ? 0.0 : kInterpreterKernelSeconds) + firstPassGradientSeconds;
  const bool interpretFirst = generatedToBuild && interpretedVertexPass < vertex.build + vertex.run;
  chosenCodegen.gradient = vertex.gradient;
  const bool wholeFieldBuilt = wholeFits && isBuilt("field_grid", &chosenCodegen);
  if (wholeFits) {
    EvaluatorEstimate e;
    e.traversal = Traversal::Specialised;
    e.fieldKernels = 1;
    e.vertexGradient = vertex.gradient;
    e.interpretVertexPassUntilBuilt = interpretFirst;
    e.looped = whole.looped;
    e.buildSeconds = (wholeFieldBuilt ? 0.0 : kernelSeconds(whole, 1.0)) + vertexBuild;
    e.buildMegabytes = std::max(wholeFieldBuilt ? 0.0 : buildMegabytes(whole.size), vertexMegabytes);
    e.runSeconds = (whole.looped ? kLoopedSecondsPerInstruction * branchWork : kSpecialisedSecondsPerCost * wholeCost * points) +
                   vertexRun;
    choice.candidates.push_back(e);
  }
  if (tiles.size() > 1) {
    // As FieldPass builds it: a kernel per tile the generator accepts pruned; the others share
    // the whole program's kernel (specialised, or the interpreter when too large).
    EvaluatorEstimate tiled;
    tiled.traversal = Traversal::Specialised;
    tiled.fieldKernels = std::uint32_t(tiles.size());
    tiled.vertexGradient = vertex.gradient;
    tiled.interpretVertexPassUntilBuilt = interpretFirst;
    bool shared = false, own = false;
    for (const FieldTile& t : tiles) {
      if (specialiseTile(program, t.region, codegen.loops)) {
        own = true;
        const CodegenOptions c = tileCodegen(t.region);
        const Kernel k = kernelFor(t.region);
        if (!isBuilt("field_grid", &c)) {
          tiled.buildSeconds += kernelSeconds(k, 1.0);
          tiled.buildMegabytes = std::max(tiled.buildMegabytes, buildMegabytes(k.size));
        }
        tiled.runSeconds += double(t.points()) * evaluationSeconds(k, t.cost * branchScale, t.cost);
      } else {
        shared = true;
        tiled.runSeconds += double(t.points()) * (wholeFits ? evaluationSeconds(whole, t.cost * branchScale, wholeCost)
                                                            : kInterpreterSecondsPerInstruction * t.cost * branchScale);
      }
    }
    if (shared && !(wholeFits ? wholeFieldBuilt : isBuilt("field_grid", nullptr)))
      tiled.buildSeconds += wholeFits ? kernelSeconds(whole, 1.0) : kInterpreterKernelSeconds;
    tiled.buildSeconds += vertexBuild;
    tiled.buildMegabytes = std::max(tiled.buildMegabytes, vertexMegabytes);
    tiled.runSeconds += vertexRun;
    // With no tile of its own FieldPass runs one kernel: the candidates above.
    if (own) choice.candidates.push_back(tiled);
  }

  choice.chosen = interpreter;
  if (!cpuDevice) {
    // Uncalibrated off lavapipe: GPU drivers build kernels in milliseconds, so the specialised
    // code (tiled where it tiles) is the earlier default there.
    for (const EvaluatorEstimate& e : choice.candidates)
      if (e.traversal == Traversal::Specialised) choice.chosen = e;
    return choice;
  }
  // Unrolled code must beat the interpreter by a margin (its run and the interpreter's are
  // predicted by different measures); looped code runs as a fraction of the interpreter's time
  // by the same measure, so the plain comparison holds for it.
  const double interpreterTotal = interpreter.total(job.repeats);
  double best = interpreterTotal;
  for (const EvaluatorEstimate& e : choice.candidates) {
    if (e.traversal != Traversal::Specialised || e.buildMegabytes > kMaxBuildMegabytes) continue;
    const double total = e.total(job.repeats);
    if (total < best && (e.looped || total < kSpecialisedPaybackFraction * interpreterTotal)) {
      choice.chosen = e;
      best = total;
    }
  }
  return choice;
}

EvaluatorChoice chooseEvaluator(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const EvaluatorJob& job, const CodegenOptions& codegen) {
  const std::uint64_t fingerprint = programFingerprint(program);
  const KernelBuiltQuery built = [&](const std::string& shader, const CodegenOptions* c) {
    // field_grid's constant 0 is its work group's rows (vk/eval/field.cpp).
    const std::uint32_t wg = shader == "field_grid" ? gridGroupRows(job.workgroupSize) : job.workgroupSize;
    return c ? specialisedKernelBuilt(device, fingerprint, *c, shader, wg)
             : interpreterKernelBuilt(device, program, shader, wg);
  };
  return chooseEvaluator(device.info().type == VK_PHYSICAL_DEVICE_TYPE_CPU, program, grid, job, codegen, built);
}

}  // namespace blobvk::vk
