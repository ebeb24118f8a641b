#include "blobvk/vk/eval/evaluator_choice.h"

#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/program_codegen.h"

#include <algorithm>
#include <cmath>

namespace blobvk::vk {

double specialisedKernelSeconds(double instructions, double copies) {
  const double n = instructions * copies;
  return costs::kSpecialisedKernelSeconds + costs::kSpecialisedSecondsPerInstruction * n +
         costs::kSpecialisedSecondsPerInstruction2 * n * n;
}

namespace {
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
  auto tileCodegen = [&](const PointRegion& region) {
    CodegenOptions c = codegen;
    c.region = region;
    return c;
  };
  const double points = double(grid.pointCount());
  const double vertexEvaluations =
      job.vertexPass ? kVerticesPerSurfacePoint * std::pow(points, 2.0 / 3.0) *
                           (kEvaluationsPerVertex + std::max(job.refineSteps, 0))
                     : 0.0;
  const double wholeCost = prunedEvaluationCost(program, {});
  FieldTilingOptions tiling = job.tiling;
  tiling.minPointsForLargePrograms = 0;
  const std::vector<FieldTile> tiles = planFieldTiles(program, grid, tiling);
  double tileWork = 0.0;
  for (const FieldTile& t : tiles) tileWork += double(t.points()) * t.cost;
  const double meanTileCost = points > 0.0 ? tileWork / points : wholeCost;

  EvaluatorEstimate interpreter;
  interpreter.traversal = Traversal::Stackless;
  interpreter.buildSeconds = (isBuilt("field_grid", nullptr) ? 0.0 : kInterpreterKernelSeconds) +
                             (job.vertexPass && !isBuilt("vertices", nullptr) ? kInterpreterKernelSeconds : 0.0);
  interpreter.runSeconds = kInterpreterSecondsPerCost * (tileWork + meanTileCost * vertexEvaluations);
  choice.candidates.push_back(interpreter);

  const bool wholeFits = canSpecialise(program, {}, codegen.loops);
  const double wholeSize = wholeFits ? double(specialisedCodeSize(program, {}, codegen.loops)) : 0.0;
  // The vertex kernel: the whole program specialised, else the interpreter.
  const bool vertexBuilt = job.vertexPass && (wholeFits ? isBuilt("vertices", &codegen) : isBuilt("vertices", nullptr));
  const double vertexBuild = !job.vertexPass || vertexBuilt ? 0.0
                             : wholeFits ? specialisedKernelSeconds(wholeSize, kVertexKernelCopies)
                                         : kInterpreterKernelSeconds;
  const double vertexMegabytes =
      job.vertexPass && wholeFits && !vertexBuilt ? buildMegabytes(wholeSize * kVertexKernelCopies) : 0.0;
  const bool wholeFieldBuilt = wholeFits && isBuilt("field_grid", &codegen);
  const double vertexRun = (wholeFits ? kSpecialisedSecondsPerCost * wholeCost : kInterpreterSecondsPerCost * meanTileCost) *
                           vertexEvaluations;
  if (wholeFits) {
    EvaluatorEstimate whole;
    whole.traversal = Traversal::Specialised;
    whole.fieldKernels = 1;
    whole.buildSeconds = (wholeFieldBuilt ? 0.0 : specialisedKernelSeconds(wholeSize, 1.0)) + vertexBuild;
    whole.buildMegabytes = std::max(wholeFieldBuilt ? 0.0 : buildMegabytes(wholeSize), vertexMegabytes);
    whole.runSeconds = kSpecialisedSecondsPerCost * wholeCost * points + vertexRun;
    choice.candidates.push_back(whole);
  }
  if (tiles.size() > 1) {
    // As FieldPass builds it: a kernel per tile the generator accepts pruned; the others share
    // the whole program's kernel (specialised, or the interpreter when too large).
    EvaluatorEstimate tiled;
    tiled.traversal = Traversal::Specialised;
    tiled.fieldKernels = std::uint32_t(tiles.size());
    bool shared = false, own = false;
    for (const FieldTile& t : tiles) {
      if (specialiseTile(program, t.region, codegen.loops)) {
        own = true;
        const CodegenOptions c = tileCodegen(t.region);
        if (!isBuilt("field_grid", &c)) {
          const double size = double(specialisedCodeSize(program, t.region, codegen.loops));
          tiled.buildSeconds += specialisedKernelSeconds(size, 1.0);
          tiled.buildMegabytes = std::max(tiled.buildMegabytes, buildMegabytes(size));
        }
        tiled.runSeconds += kSpecialisedSecondsPerCost * double(t.points()) * t.cost;
      } else {
        shared = true;
        tiled.runSeconds += double(t.points()) * (wholeFits ? kSpecialisedSecondsPerCost * wholeCost
                                                            : kInterpreterSecondsPerCost * t.cost);
      }
    }
    if (shared && !(wholeFits ? wholeFieldBuilt : isBuilt("field_grid", nullptr)))
      tiled.buildSeconds += wholeFits ? specialisedKernelSeconds(wholeSize, 1.0) : kInterpreterKernelSeconds;
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
  for (const EvaluatorEstimate& e : choice.candidates)
    if (e.buildMegabytes <= kMaxBuildMegabytes && e.total(job.repeats) < choice.chosen.total(job.repeats))
      choice.chosen = e;
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
