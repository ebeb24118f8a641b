// What building an evaluator costs against program size: the kernels of one mesh (the field and
// vertex kernels with the evaluator, and the fixed extraction kernels) built and run once on a
// small grid, in a fresh process each (lavapipe builds LLVM code at a kernel's first dispatch,
// and peak memory is per process). Evaluators: the stackless interpreter, the specialised code
// unrolled, the specialised code with shared functions and loops. Programs: generated towers
// (blobtree::generateTower) of 100 to 60,000 instructions. Counters: build_s (wall seconds of
// the mesh), peak_MB (the child's peak resident memory), instructions, emitted (instructions the
// generated code spells out), default (1 on the row the cost model picks for a mesh of this
// program at 64 cells with lavapipe's default options: unrolled up to
// costs::kLoopedAboveInstructionsOnCpu instructions, looped beyond). A specialised build the model
// predicts above 60 s is not run (skipped, with the prediction).
//   LP_NUM_THREADS=2 MESA_SHADER_CACHE_DISABLE=true bench_compile_cost --benchmark_counters_tabular=true
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/device/standalone.h"

#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace {

using namespace blobvk;

enum class Evaluator { Interpreter, Unrolled, Looped };

const char* name(Evaluator e) {
  switch (e) {
    case Evaluator::Interpreter: return "interpreter";
    case Evaluator::Unrolled: return "specialised_unrolled";
    case Evaluator::Looped: return "specialised_looped";
  }
  return "?";
}

// Towers of `levels` storeys of 8 pillars on a grid x grid plan.
struct Size {
  int levels, pillars, grid;
};

blobtree::Program tower(const Size& s) {
  return blobtree::compile(blobtree::generateTower(s.levels, s.pillars, 6.0, 6.0, s.grid));
}

blobtree::GridSpec gridAt(const blobtree::Program& p, int resolution) {
  blobtree::GridRequest r;
  r.resolution = resolution;
  return blobtree::chooseGrid(p, {}, r);
}

// Lavapipe's options (defaultCodegenOptions on a CPU device: masked skips in unrolled code, loops
// that branch), with the form forced: every size unrolled, or every size looped.
vk::CodegenOptions codegenFor(Evaluator e) {
  vk::CodegenOptions c = vk::defaultCodegenOptions(true);
  c.loops.enabled = e == Evaluator::Looped;
  c.loops.minProgramInstructions = 0;
  return c;
}

struct Result {
  double seconds = 0.0;
  double peakMB = 0.0;
  int ok = 0;
  char why[240] = "the child process ended without a result";  // when !ok: the reason, as the run gave it
};

// In a child process: a device, then one mesh at 8 cells (every kernel built and dispatched).
Result measureInChild(const blobtree::Program& program, Evaluator e) {
  int fds[2];
  if (pipe(fds) != 0) return {};
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    Result r;
    try {
      vk::StandaloneOptions options;
      options.pipelineCache = "off";  // a cold build: no SPIR-V read back from an earlier run
      vk::StandaloneContext context{options};
      const vk::CodegenOptions codegen = codegenFor(e);
      vk::GpuPolygonizeOptions o;
      o.traversal = e == Evaluator::Interpreter ? vk::Traversal::Stackless : vk::Traversal::Specialised;
      o.codegen = &codegen;
      o.maxFieldTiles = 1;
      const auto t0 = std::chrono::steady_clock::now();
      const auto mesh = vk::polygonize(context.device(), program, gridAt(program, 8), o);
      r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      rusage u{};
      getrusage(RUSAGE_SELF, &u);
      r.peakMB = double(u.ru_maxrss) / 1024.0;
      r.ok = mesh.triangles.empty() ? 0 : 1;
      if (!r.ok) std::snprintf(r.why, sizeof r.why, "the mesh at 8 cells is empty");
    } catch (const std::exception& e) {
      r.ok = 0;  // e.g. lavapipe's loop limit, which an interpreted program this long exceeds
      std::snprintf(r.why, sizeof r.why, "%s", e.what());
    }
    if (write(fds[1], &r, sizeof r) != ssize_t(sizeof r)) _exit(1);
    _exit(0);
  }
  close(fds[1]);
  Result r;
  if (read(fds[0], &r, sizeof r) != ssize_t(sizeof r)) r.ok = 0;
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return r;
}

void buildCost(benchmark::State& state, Size size, Evaluator e) {
  const blobtree::Program program = tower(size);
  const vk::CodegenOptions codegen = codegenFor(e);
  std::uint32_t emitted = 0;
  if (e != Evaluator::Interpreter) {
    if (!vk::canSpecialise(program, {}, codegen.loops)) {
      state.SkipWithError("the generator refuses it (over kMaxSpecialisedInstructions)");
      return;
    }
    emitted = vk::specialisedCodeSize(program, {}, codegen.loops);
    const double predicted = vk::specialisedKernelSeconds(emitted, 1.0) +
                             vk::specialisedKernelSeconds(emitted, vk::costs::kGradientVertexKernelCopies);
    if (predicted > 60.0) {
      std::string why("predicted ");
      why.append(std::to_string(int(predicted))).append(" s to build");
      state.SkipWithError(why.c_str());
      return;
    }
  }
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.tiling.maxTiles = 1;  // as the sparse extraction (the default) asks
  const vk::CodegenOptions lavapipe = vk::defaultCodegenOptions(true);
  const auto choice = vk::chooseEvaluator(true, program, gridAt(program, 64), job, lavapipe);
  const Evaluator picked = choice.chosen.traversal == vk::Traversal::Stackless ? Evaluator::Interpreter
                           : vk::specialisedCodeLoops(program, {}, lavapipe.loops) ? Evaluator::Looped
                                                                                  : Evaluator::Unrolled;
  const bool chosen = picked == e;
  Result r;
  for (auto _ : state) {
    r = measureInChild(program, e);
    state.SetIterationTime(r.seconds);
  }
  if (!r.ok) state.SkipWithError(r.why);
  state.counters["instructions"] = double(program.code.size());
  state.counters["emitted"] = double(emitted);
  state.counters["build_s"] = r.seconds;
  state.counters["peak_MB"] = r.peakMB;
  state.counters["default"] = chosen ? 1.0 : 0.0;
}

const int registered = [] {
  const Size sizes[] = {{1, 8, 1}, {2, 8, 1}, {3, 8, 1}, {3, 8, 2}, {5, 8, 3}, {5, 8, 6}, {5, 8, 10}, {5, 8, 13}};
  for (const Size& s : sizes) {
    // Built by append: gcc 12's -Wrestrict misfires on `"x" + std::to_string(n)`.
    std::string label("L");
    label.append(std::to_string(s.levels)).append("P").append(std::to_string(s.pillars));
    label.append("G").append(std::to_string(s.grid));
    for (Evaluator e : {Evaluator::Interpreter, Evaluator::Unrolled, Evaluator::Looped}) {
      std::string title("build/");
      title.append(name(e)).append("/").append(label);
      benchmark::RegisterBenchmark(title.c_str(), buildCost, s, e)
          ->Iterations(1)
          ->UseManualTime()
          ->Unit(benchmark::kSecond);
    }
  }
  return 0;
}();

}  // namespace

BENCHMARK_MAIN();
