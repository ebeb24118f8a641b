// Edit latency on Vulkan: one edit of scenes/tower_L6P8I4.json's generator (generateTower(6, 8,
// 6, 6, 4), as bench_edit) and the incremental re-extraction (vk::IncrementalExtractor::update)
// at 256 cells, against edit size (a capital point, a pillar's cylinder, a whole pillar, a
// storey) and brick size (the argument: 16, the default, or 8: thinner layers, more bricks to
// classify). Each iteration moves the node by +-0.3 (about one cell) and re-meshes. Counters per
// edit: ms_apply (recompile, region), ms_classify (the re-run box's bricks, one submit),
// ms_extract (the box's active bricks: program upload, field, extraction, read-back), ms_splice
// (row by row), bricks_rerun of bricks (the box), active_bricks_rerun; full_ms: a full
// vk::polygonize of the same scene with the same (default) options, its
// kernels already built, in the same process; fraction_of_full: edit latency / full_ms. Each
// run's evaluator is the cost model's choice for its bricks (IncrementalExtractor). Bytes: tests/vk/test_incremental_extract.cpp.
//   LP_NUM_THREADS=2 bench_edit_vk --benchmark_counters_tabular=true
//   LP_NUM_THREADS=2 bench_edit_vk --benchmark_filter='brick:16' --benchmark_repetitions=3 --benchmark_format=json
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/vk/device/standalone.h"
#include "blobvk/vk/extract/incremental_extract.h"
#include "blobvk/vk/extract/polygonize.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace blobvk;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

std::unique_ptr<vk::StandaloneContext>& contextSlot() {
  static std::unique_ptr<vk::StandaloneContext> ctx;
  return ctx;
}
vk::Device& device() {
  auto& ctx = contextSlot();
  if (!ctx) {
    vk::StandaloneOptions o;
    if (const char* d = std::getenv("BLOBVK_BENCH_DEVICE")) o.device = d;
    ctx = std::make_unique<vk::StandaloneContext>(o);
  }
  return ctx->device();
}

enum class EditKind { Capital, Cylinder, Pillar, Storey };

// As bench_edit: root union -> tower (of 16) -> storey -> pillar (union of {union of disc and
// cylinder} and the capital point). Tower 5, storey 1, pillar 3.
blobtree::NodePath pathOf(EditKind kind) {
  switch (kind) {
    case EditKind::Capital: return {5, 1, 3, 1};
    case EditKind::Cylinder: return {5, 1, 3, 0, 1};
    case EditKind::Pillar: return {5, 1, 3};
    case EditKind::Storey: return {5, 1};
  }
  return {};
}

// One editing session per brick size, shared by the edit kinds and repetitions (each run ends
// with every node back home, after an even number of moves): the tree, the extractor after its
// reset, and a full re-mesh's time (ms on lavapipe, measured once): vk::polygonize with the
// session's options, the program's kernels already built by the reset, so it is the full path's
// run alone (a full re-mesh after an edit would build its kernels too).
struct Session {
  blobtree::EditableTree tree{blobtree::generateTower(6, 8, 6.0, 6.0, 4)};
  blobtree::GridSpec grid;
  std::unique_ptr<vk::IncrementalExtractor> inc;
  double fullMs = 0;
};

std::map<std::uint32_t, std::unique_ptr<Session>>& sessions() {
  static std::map<std::uint32_t, std::unique_ptr<Session>> all;
  return all;
}

Session& session(std::uint32_t brickCells) {
  std::unique_ptr<Session>& s = sessions()[brickCells];
  if (!s) {
    s = std::make_unique<Session>();
    blobtree::GridRequest request;
    request.resolution = 256;
    s->grid = blobtree::chooseGrid(s->tree.program(), {}, request);
    vk::GpuPolygonizeOptions options;
    options.brickCells = brickCells;
    s->inc = std::make_unique<vk::IncrementalExtractor>(device(), s->grid, options);
    s->inc->reset(s->tree.program());
    const auto t0 = Clock::now();
    const mesh::TriMesh m = vk::polygonize(device(), s->tree.program(), s->grid, s->inc->options());
    s->fullMs = msSince(t0);
    benchmark::DoNotOptimize(m.positions.data());
  }
  return *s;
}

void edit(benchmark::State& state, EditKind kind) {
  Session& current = session(std::uint32_t(state.range(0)));
  blobtree::EditableTree& tree = current.tree;
  vk::IncrementalExtractor& inc = *current.inc;
  const double full = current.fullMs;

  const blobtree::NodePath path = pathOf(kind);
  const blobtree::Transform home = tree.node(path).transform;
  double apply = 0, classify = 0, extract = 0, splice = 0, total = 0, boxBricks = 0, bricks = 0, gridBricks = 0;
  double field = 0, passes = 0, vertices = 0, brickCells = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    blobtree::Transform t = home;
    t.translate.x += n % 2 ? 0.0 : 0.3;
    const blobtree::Region region = tree.apply({path, blobtree::SetTransform{t}});
    apply += msSince(t0);
    vk::IncrementalGpuStats st;
    const mesh::TriMesh& m = inc.update(tree.program(), region, &st);
    benchmark::DoNotOptimize(m.positions.data());
    total += msSince(t0);
    classify += st.msClassify, extract += st.msExtract, splice += st.msSplice;
    boxBricks += double(st.bricksRerun), bricks += double(st.gpu.activeBricks), gridBricks = double(st.bricks);
    field += st.gpu.fieldSeconds * 1e3, passes += st.gpu.extractSeconds * 1e3, vertices += st.gpu.verticesSeconds * 1e3;
    brickCells = double(st.gpu.brickCells);  // the session's: the argument, or fewer for the driver's loop limit
    ++n;
  }
  const double k = n ? 1.0 / double(n) : 0.0;
  state.counters["ms_apply"] = apply * k;
  state.counters["ms_classify"] = classify * k;
  state.counters["ms_extract"] = extract * k;
  state.counters["ms_splice"] = splice * k;
  // Device time of the re-run (timestamps): the field at the active bricks' points, the extraction
  // passes, of which the vertices (refinement, normals).
  state.counters["ms_field_device"] = field * k;
  state.counters["ms_passes_device"] = passes * k;
  state.counters["ms_vertices_device"] = vertices * k;
  state.counters["bricks_rerun"] = boxBricks * k;
  state.counters["bricks"] = gridBricks;
  state.counters["brick_cells"] = brickCells;
  state.counters["active_bricks_rerun"] = bricks * k;
  state.counters["triangles"] = double(inc.mesh().triangleCount());
  state.counters["full_ms"] = full;
  state.counters["fraction_of_full"] = total * k / full;
}

void registerAll() {
  const std::pair<EditKind, const char*> kinds[] = {
      {EditKind::Capital, "capital"}, {EditKind::Cylinder, "cylinder"}, {EditKind::Pillar, "pillar"},
      {EditKind::Storey, "storey"}};
  for (const auto& [kind, name] : kinds) {
    const std::string label = std::string("edit_vk/L6/") + name;
    benchmark::RegisterBenchmark(label.c_str(), [kind = kind](benchmark::State& s) { edit(s, kind); })
        ->Arg(16)
        ->Arg(8)
        ->ArgName("brick")
        ->Unit(benchmark::kMillisecond)
        ->Iterations(4)  // even: the node ends at home for the next benchmark of the session
        ->UseRealTime()
        ->ComputeStatistics("min", [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  setenv("LP_NUM_THREADS", "2", 0);
  setenv("LP_NATIVE_VECTOR_WIDTH", "256", 0);  // as the CLI does (apps/main.cpp)
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  sessions().clear();
  contextSlot().reset();  // before the driver's exit handlers (docs/vulkan.md)
  return 0;
}
