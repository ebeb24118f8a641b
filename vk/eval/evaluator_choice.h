// Which evaluator runs a job (Traversal::Auto): the interpreter, or the specialised code as one
// kernel or per field tile, whichever the measured costs (vk/eval/evaluator_costs.h) say finishes
// first, counting the kernels' build time once and the evaluation once per repeat.
//
// Why: the specialised code evaluates faster than the interpreter, but lavapipe builds it slowly
// and the build grows faster than the code; a mesh of a few thousand instructions took minutes to
// build for a second's work. The answer depends on the program, the grid and how often the
// kernels are reused, so it is computed, not capped.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/device/context.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/gpu_program.h"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace blobvk::vk {

// The points a job evaluates when that is not the whole grid: the sparse extraction's active
// bricks, known once they are classified. Each brick evaluates the (cells + 1)^3 grid points of
// its cells (clipped to the grid).
struct EvaluatedBricks {
  std::uint32_t cells = 16;  // per brick edge
  std::vector<std::array<std::uint32_t, 3>> bricks;  // brick coordinates (grid point = brick * cells)
};

struct EvaluatorJob {
  bool vertexPass = false;      // polygonization: a vertex kernel evaluates too
  int refineSteps = 0;          // per vertex (vertex pass)
  std::uint32_t repeats = 1;    // runs of the job with the same kernels
  FieldTilingOptions tiling;    // the field pass's tiles when specialised
  std::uint32_t workgroupSize = 64;  // the kernels' (to find those already built)
  // Null: the whole grid is evaluated (dense paths, or before classification). Otherwise only
  // these bricks' points are, and the field is one kernel (no tiles).
  const EvaluatedBricks* evaluated = nullptr;
};

struct EvaluatorEstimate {
  Traversal traversal = Traversal::Stackless;
  std::uint32_t fieldKernels = 1;  // specialised: 1 = one kernel for the grid; more = per tile
  // Specialised unrolled code: the vertex kernel runs the generated gradient (CodegenOptions::
  // gradient), or interprets it where that kernel's build would cost more than it saves.
  bool vertexGradient = true;
  // With the generated gradient not built yet: a job that cannot reuse the kernel pays its whole
  // build before its vertex pass, though interpreting that pass would cost less (tower at 256
  // cells on lavapipe: about 0.8 s to create the pipeline, even with warm caches, against 0.1-0.3 s
  // more vertex pass). Then the first job interprets the vertex pass (the meshes are the same
  // bytes) while the generated kernel builds in the background for the jobs after it.
  bool interpretVertexPassUntilBuilt = false;
  bool looped = false;  // specialised: the code loops over instances (vk/eval/program_shape.h)
  double buildSeconds = 0.0, runSeconds = 0.0;
  double buildMegabytes = 0.0;  // peak memory of its largest kernel build, beyond the process's
  double total(std::uint32_t repeats) const { return buildSeconds + repeats * runSeconds; }
};

struct EvaluatorChoice {
  EvaluatorEstimate chosen;
  std::vector<EvaluatorEstimate> candidates;  // what was compared, chosen among them
};

// Whether a kernel is already built: embedded `shader` ("field_grid", "vertices") with the
// interpreter (codegen null) or with the evaluator generated for `*codegen` (its region set for a
// field tile). A built kernel's build cost is sunk: a second job of the same program in a process
// (a viewer re-meshing, `bench` repeats, a mesh after a compare) weighs run time only.
using KernelBuiltQuery = std::function<bool(const std::string& shader, const CodegenOptions* codegen)>;

// The evaluator for `job` on `grid`. Devices other than CPU drivers keep the specialised code
// (their kernels build fast and the model's constants are lavapipe's). Kernels the device
// already holds count as built.
EvaluatorChoice chooseEvaluator(Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const EvaluatorJob& job, const CodegenOptions& codegen);

// The same from the device type alone (tests and benchmarks); `built` null: nothing is built.
EvaluatorChoice chooseEvaluator(bool cpuDevice, const blobtree::Program& program, const blobtree::GridSpec& grid,
                                const EvaluatorJob& job, const CodegenOptions& codegen,
                                const KernelBuiltQuery& built = {});

// Build seconds of one specialised kernel spelling out `instructions` per evaluator copy.
double specialisedKernelSeconds(double instructions, double copies);

}  // namespace blobvk::vk
