// The Vulkan backend on the machine's default device (lavapipe here), validation off: field
// evaluations per second for both traversals (the thesis' Table 4.2 comparison) and the whole
// GPU polygonization, on the shipped tower and random128 scenes. Arguments: {resolution}. The CPU
// column is the CPU time of the whole process (lavapipe runs on its own threads): less sensitive
// to other load on the machine than the wall time.
// CPU baselines over the same grid points: scalar (blobtree::evaluate, one thread) and the AVX
// evaluator on all threads (cpu_simd::evaluateFieldBatch on rows of points, TBB), the issue's
// "lavapipe against the AVX path on the same cores" comparison (the full Program at every point,
// no MPU discard or tape pruning, like the GPU field pass).
//   LP_NUM_THREADS=2 bench_vk --benchmark_filter='field'      # evals/s, both traversals
//   LP_NUM_THREADS=2 bench_vk --benchmark_filter='polygonize/.*/128'
//   LP_NUM_THREADS=2 bench_vk --benchmark_filter='field/specialised|cpu_avx'  # the ratio
//   LP_NUM_THREADS=2 bench_vk --benchmark_filter='classify/'  # the sparse path's classification
// Run from the repository root (scenes/ is read relative to it) or set BLOBVK_SCENES.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/extract/brick_tapes.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/runtime_compiler.h"
#include "blobvk/vk/extract/scan.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "blobvk/vk/device/standalone.h"

#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace blobvk;

vk::StandaloneContext& context() {
  static std::unique_ptr<vk::StandaloneContext> ctx = [] {
    vk::StandaloneOptions o;
    if (const char* d = std::getenv("BLOBVK_BENCH_DEVICE")) o.device = d;
    return std::make_unique<vk::StandaloneContext>(o);
  }();
  return *ctx;
}

struct Model {
  blobtree::Program program;
  blobtree::GridSettings bounds;
};

const Model& model(const std::string& name) {
  static std::map<std::string, Model> cache;
  auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const char* dir = std::getenv("BLOBVK_SCENES");
  const blobtree::Scene scene = blobtree::loadScene(std::string(dir ? dir : "scenes") + "/" + name + ".json");
  return cache.emplace(name, Model{blobtree::compile(scene.root), scene.grid}).first->second;
}

blobtree::GridSpec gridFor(const Model& m, int resolution) {
  blobtree::GridRequest r;
  r.resolution = resolution;
  return blobtree::chooseGrid(m.program, m.bounds, r);
}

void field(benchmark::State& state, const std::string& scene, vk::Traversal traversal) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  vk::FieldOptions o;
  o.traversal = traversal;
  if (const char* wg = std::getenv("BLOBVK_BENCH_WORKGROUP")) o.workgroupSize = std::uint32_t(std::atoi(wg));
  vk::CodegenOptions codegen;
  if (const char* b = std::getenv("BLOBVK_BENCH_BRANCH_MIN")) {  // skips as branches, from this size
    codegen.branchOnSkips = true;
    codegen.minBranchInstructions = std::uint32_t(std::atoi(b));
    o.codegen = &codegen;
  }

  if (const char* t = std::getenv("BLOBVK_BENCH_TILES")) o.tiling.maxTiles = std::uint32_t(std::atoi(t));
  if (const char* g = std::getenv("BLOBVK_BENCH_TILE_GAIN")) o.tiling.minGain = std::atof(g);
  vk::evaluateFieldOnGrid(context().device(), m.program, grid, o);  // JIT at first dispatch
  double seconds = 0.0, evals = 0.0, tiles = 0.0;
  for (auto _ : state) {
    vk::FieldStats s;
    auto f = vk::evaluateFieldOnGrid(context().device(), m.program, grid, o, &s);
    benchmark::DoNotOptimize(f.data());
    seconds += s.seconds;
    evals += double(s.evaluations);
    tiles = s.tiles;
  }
  state.counters["tiles"] = tiles;
  state.counters["Mevals_per_s_gpu"] = evals / seconds * 1e-6;
  state.counters["instructions"] = double(m.program.code.size());
  state.counters["registers"] = double(m.program.fieldRegisters);
}

void cpuScalarField(benchmark::State& state, const std::string& scene) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  const auto pts = grid.points();
  double evals = 0.0;
  for (auto _ : state) {
    float sum = 0.0f;
    for (int k = 0; k < pts.z; ++k)
      for (int j = 0; j < pts.y; ++j)
        for (int i = 0; i < pts.x; ++i) sum += blobtree::evaluate(m.program, grid.point(i, j, k));
    benchmark::DoNotOptimize(sum);
    evals += double(grid.pointCount());
  }
  state.counters["Mevals_per_s"] = benchmark::Counter(evals * 1e-6, benchmark::Counter::kIsRate);
}

void cpuSimdField(benchmark::State& state, const std::string& scene) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  const auto pts = grid.points();
  std::vector<float> field(grid.pointCount());
  const cpu::SimdLevel level = cpu::bestSimdLevel();
  double evals = 0.0;
  for (auto _ : state) {
    // One task per (j, k) row of points: x varies, y and z are constant.
    tbb::parallel_for(tbb::blocked_range<int>(0, pts.y * pts.z), [&](const tbb::blocked_range<int>& r) {
      std::vector<float> x(std::size_t(pts.x)), y(std::size_t(pts.x)), z(std::size_t(pts.x));
      for (int row = r.begin(); row != r.end(); ++row) {
        const int j = row % pts.y, k = row / pts.y;
        for (int i = 0; i < pts.x; ++i) {
          const auto p = grid.point(i, j, k);
          x[std::size_t(i)] = p.x;
          y[std::size_t(i)] = p.y;
          z[std::size_t(i)] = p.z;
        }
        cpu::evaluateFieldBatch(m.program, x.data(), y.data(), z.data(),
                                field.data() + std::size_t(row) * std::size_t(pts.x), std::size_t(pts.x), level);
      }
    });
    benchmark::DoNotOptimize(field.data());
    evals += double(grid.pointCount());
  }
  state.counters["Mevals_per_s"] = benchmark::Counter(evals * 1e-6, benchmark::Counter::kIsRate);
  state.SetLabel(cpu::toString(level));
}

void polygonize(benchmark::State& state, const std::string& scene, vk::Traversal traversal) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  vk::GpuPolygonizeOptions o;
  o.traversal = traversal;
  if (const char* t = std::getenv("BLOBVK_BENCH_TILES")) o.maxFieldTiles = std::uint32_t(std::atoi(t));
  o.tiledVertexPass = std::getenv("BLOBVK_BENCH_TILED_VERTICES") != nullptr;
  vk::polygonize(context().device(), m.program, grid, o);  // JIT at first dispatch
  vk::GpuStats s;
  std::size_t triangles = 0;
  for (auto _ : state) {
    auto mesh = vk::polygonize(context().device(), m.program, grid, o, &s);
    triangles = mesh.triangleCount();
  }
  state.counters["triangles"] = double(triangles);
  state.counters["classify_s"] = s.classifySeconds;
  state.counters["emit_s"] = s.emitSeconds;
  state.counters["tiles"] = s.fieldTiles;
}

// The sparse path's brick classification and compaction alone (bricks of 16 cells, the default),
// interpreted (tile by tile where the cost model says it pays, vk/extract/classify_tiles.h, or
// with `maxTiles` 1 the whole program) or generated (vk/extract/classify_kernel.h): device time
// per job (the timer's figure, GpuStats::classifySeconds), the kernel built before timing;
// `wall_ms` adds the host's part (the tiles' plan and tapes, submits, waits).
void classify(benchmark::State& state, const std::string& scene, vk::ClassifyCode code, std::uint32_t maxTiles) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  vk::Device& device = context().device();
  const vk::BrickGrid bricks = vk::brickGridFor(grid, 16);
  vk::GpuStats s;
  vk::ClassifyChoice choice{code, 1};
  choice.maxTiles = maxTiles;
  vk::classifyAndCompact(device, m.program, grid, bricks, s, nullptr, 0, choice);  // build, JIT
  double wall = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    vk::classifyAndCompact(device, m.program, grid, bricks, s, nullptr, 0, choice);
    wall += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    state.SetIterationTime(s.classifySeconds);
  }
  state.counters["wall_ms"] = 1e3 * wall / double(std::max<benchmark::IterationCount>(state.iterations(), 1));
  state.counters["active_bricks"] = s.activeBricks;
  state.counters["generated"] = s.generatedClassification;
  state.counters["tiles"] = s.classifyTiles;
  // The cost model's walk (classify_kernel.h): steps of the finest level, in thousands.
  const vk::ClassifyWork work = vk::classifyWork(m.program, grid, 16);
  state.counters["ksteps_interpreted"] = work.interpreted * 1e-3;
  state.counters["ksteps_generated"] = work.generated * 1e-3;
}

// Host side of the specialised path's first use: GLSL generation and glslang to SPIR-V for the
// field kernel (the driver's own JIT at the first dispatch comes on top; see `first_s` of
// `blobvk bench --backend vk`).
void specialiseAndCompile(benchmark::State& state, const std::string& scene) {
  const Model& m = model(scene);
  std::size_t words = 0, chars = 0;
  for (auto _ : state) {
    const std::string glsl = vk::generateSpecialisedEvaluator(m.program);
    const auto spirv = vk::compileComputeShader("field_grid.comp", {{"eval_program.glsl", glsl}});
    words = spirv.size();
    chars = glsl.size();
  }
  state.counters["spirv_words"] = double(words);
  state.counters["glsl_chars"] = double(chars);
}

// Host side of per-brick tapes (vk/extract/brick_tapes.h): the tapes of every brick of 16 cells
// of the grid (an upper bound of a job's active bricks), packed for a storage buffer or for
// uniform blocks; counters give the instructions per brick and the windows.
void brickTapes(benchmark::State& state, const std::string& scene, bool uniform) {
  const Model& m = model(scene);
  const auto grid = gridFor(m, int(state.range(0)));
  const vk::BrickGrid bricks = vk::brickGridFor(grid, 16);
  std::vector<std::uint32_t> packed;
  for (std::uint32_t z = 0; z < bricks.z; ++z)
    for (std::uint32_t y = 0; y < bricks.y; ++y)
      for (std::uint32_t x = 0; x < bricks.x; ++x) packed.push_back(bricks.pack({x, y, z}));
  vk::BrickTapes tapes;
  vk::UniformTapes windows;
  for (auto _ : state) {
    if (uniform) {
      if (!vk::buildUniformTapes(m.program, grid, bricks, packed, windows)) state.SkipWithError("a tape over a block");
    } else {
      vk::buildBrickTapes(m.program, grid, bricks, packed, std::uint32_t(m.program.boxes.size()), tapes);
    }
  }
  const std::uint64_t instructions = uniform ? windows.instructions : tapes.instructions;
  state.counters["bricks"] = double(packed.size());
  state.counters["instructions_per_brick"] = double(instructions) / double(packed.size());
  state.counters["windows"] = double(windows.windows.size());
}

// The exclusive scan the polygonizer runs twice per slab (points, cells), on `range(0)` values.
void scan(benchmark::State& state) {
  vk::Device& device = context().device();
  const std::uint32_t n = std::uint32_t(state.range(0));
  vk::Buffer values = device.createBuffer(std::uint64_t(n) * 4);
  vk::Buffer scratch = device.createBuffer(std::max<std::uint64_t>(vk::scanScratchWords(n), 1) * 4);
  vk::Buffer totals = device.createBuffer(16);
  std::vector<std::uint32_t> ones(n, 1);
  double seconds = 0;
  for (auto _ : state) {
    device.upload(values, ones.data(), std::uint64_t(n) * 4);
    const auto t0 = std::chrono::steady_clock::now();
    device.run([&](vk::Recorder& rec) {
      vk::recordExclusiveScan(rec, values.handle(), 0, n, scratch.handle(), 0, totals.handle(), 0);
      rec.hostBarrier();
    });
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  state.counters["Mvalues_per_s"] = double(n) * double(state.iterations()) / seconds * 1e-6;
}

void registerAll() {
  benchmark::RegisterBenchmark("scan", scan)->Arg(1 << 21)->Unit(benchmark::kMillisecond)->UseRealTime();
  for (const char* scene : {"tower", "random128", "tower_L6P8I4"}) {
    for (bool uniform : {false, true})
      benchmark::RegisterBenchmark((std::string("brick_tapes/") + (uniform ? "uniform/" : "storage/") + scene).c_str(),
                                   brickTapes, std::string(scene), uniform)
          ->Arg(256)->Arg(1024)->Unit(benchmark::kMillisecond);
  }
  for (const char* scene : {"tower", "random128", "eggshell", "dice", "creature", "craniotomy", "twisted_column"}) {
    const struct {
      const char* name;
      vk::ClassifyCode code;
      std::uint32_t maxTiles;
    } kinds[] = {{"interpreter/", vk::ClassifyCode::Interpreter, vk::kMaxClassifyTiles},
                 {"interpreter_whole/", vk::ClassifyCode::Interpreter, 1},
                 {"generated/", vk::ClassifyCode::Generated, 1}};
    for (const auto& k : kinds) {
      const std::string name = std::string("classify/") + k.name + scene;
      benchmark::RegisterBenchmark(name.c_str(), classify, std::string(scene), k.code, k.maxTiles)
          ->Arg(256)->Arg(512)->Unit(benchmark::kMillisecond)->UseManualTime();
    }
  }
  for (const char* scene : {"tower", "random128"}) {
    const std::string s = scene;
    benchmark::RegisterBenchmark(("specialise_compile/" + s).c_str(), specialiseAndCompile, s)
        ->Unit(benchmark::kMillisecond);
    for (int res : {64, 128, 256}) {
      benchmark::RegisterBenchmark(("field/specialised/" + s).c_str(), field, s,
                                   vk::Traversal::Specialised)
          ->Arg(res)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
      benchmark::RegisterBenchmark(("cpu_avx_field/" + s).c_str(), cpuSimdField, s)
          ->Arg(res)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
    }
    for (int res : {64, 128}) {  // the interpreters are too slow for 256
      benchmark::RegisterBenchmark(("field/stackless/" + s).c_str(), field, s,
                                   vk::Traversal::Stackless)
          ->Arg(res)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
      benchmark::RegisterBenchmark(("field/stack_based/" + s).c_str(), field, s,
                                   vk::Traversal::StackBased)
          ->Arg(res)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
      benchmark::RegisterBenchmark(("cpu_scalar_field/" + s).c_str(), cpuScalarField, s)
          ->Arg(res)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
    }
    for (auto traversal : {vk::Traversal::Specialised, vk::Traversal::Stackless})
      benchmark::RegisterBenchmark(("polygonize/" + std::string(vk::traversalName(traversal)) + "/" + s).c_str(),
                                   polygonize, s, traversal)
          ->Arg(64)->Arg(128)->Unit(benchmark::kMillisecond)->UseRealTime()->MeasureProcessCPUTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  setenv("LP_NUM_THREADS", "2", 0);
  setenv("LP_NATIVE_VECTOR_WIDTH", "256", 0);  // as the CLI does (apps/main.cpp)
  registerAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
