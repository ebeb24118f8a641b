// Edit latency: one edit of a tower (EditableTree::apply: recompile and region) and the
// incremental re-mesh (IncrementalPolygonizer::update) at 256 cells, against edit size (a
// capital point, a pillar's cylinder, its colour, a whole pillar, a whole storey) and scene size
// (towers of 2, 4 and 6 storeys on a 4 x 4 layout; L6 is scenes/tower_L6P8I4.json). Each
// iteration moves the node by +-0.3 (about one cell) and re-meshes. Counters: ms_apply,
// ms_polygonize, ms_splice (per edit), mpus_rerun, full_ms (polygonizeMpu of the same scene and
// grid, best of 3, measured in the same process), fraction_of_full (edit latency / full_ms).
// The output after every edit equals the full re-mesh byte for byte (tests/cpu_simd).
//   bench_edit --benchmark_counters_tabular=true
//   bench_edit --benchmark_filter='L6/cylinder' --benchmark_format=json
#include "blobvk/blobtree/edit.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/cpu_simd/incremental_polygonizer.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>

namespace {

using namespace blobvk;
using Clock = std::chrono::steady_clock;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

enum class EditKind { Capital, Cylinder, CylinderColour, Pillar, Storey };

// In generateTower(L, 8, 6, 6, 4): root union -> tower (of 16) -> storey -> pillar (union of
// {union of disc and cylinder} and the capital point). Tower 5, storey 1, pillar 3.
blobtree::NodePath pathOf(EditKind kind) {
  switch (kind) {
    case EditKind::Capital: return {5, 1, 3, 1};
    case EditKind::Cylinder:
    case EditKind::CylinderColour: return {5, 1, 3, 0, 1};
    case EditKind::Pillar: return {5, 1, 3};
    case EditKind::Storey: return {5, 1};
  }
  return {};
}

void edit(benchmark::State& state, int levels, EditKind kind) {
  blobtree::EditableTree tree(blobtree::generateTower(levels, 8, 6.0, 6.0, 4));
  blobtree::GridRequest request;
  request.resolution = 256;
  const blobtree::GridSpec grid = blobtree::chooseGrid(tree.program(), {}, request);
  cpu::MpuOptions options;
  options.threads = int(state.range(0));
  double fullMs = 1e30;
  for (int i = 0; i < 3; ++i) {
    const auto t0 = Clock::now();
    const mesh::TriMesh m = cpu::polygonizeMpu(tree.program(), grid, options);
    fullMs = std::min(fullMs, msSince(t0));
    benchmark::DoNotOptimize(m.positions.data());
  }
  cpu::IncrementalPolygonizer inc(grid, options);
  inc.reset(tree.program());

  const blobtree::NodePath path = pathOf(kind);
  const blobtree::Node& node = tree.node(path);
  const blobtree::Transform home = node.transform;
  blobtree::Primitive prim;
  if (node.isPrimitive()) prim = std::get<blobtree::Primitive>(node.kind);
  double apply = 0, polygonize = 0, splice = 0, total = 0, rerun = 0, plan = 0, move = 0, shift = 0, write = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const auto t0 = Clock::now();
    blobtree::Region region;
    if (kind == EditKind::CylinderColour) {
      prim.colour = n % 2 ? glm::dvec3(0.8) : glm::dvec3(0.9, 0.2, 0.1);
      region = tree.apply({path, blobtree::SetPrimitive{prim}});
    } else {
      blobtree::Transform t = home;
      t.translate.x += n % 2 ? 0.0 : 0.3;
      region = tree.apply({path, blobtree::SetTransform{t}});
    }
    apply += msSince(t0);
    cpu::IncrementalStats st;
    const mesh::TriMesh& m = inc.update(tree.program(), region, &st);
    benchmark::DoNotOptimize(m.positions.data());
    total += msSince(t0);
    polygonize += st.msPolygonize, splice += st.msSplice, rerun += double(st.mpusRerun);
    plan += st.msPlan, move += st.msMove, shift += st.msShift, write += st.msWrite;
    ++n;
  }
  const double k = n ? 1.0 / double(n) : 0.0;
  state.counters["ms_apply"] = apply * k;
  state.counters["ms_polygonize"] = polygonize * k;
  state.counters["ms_splice"] = splice * k;
  state.counters["ms_plan"] = plan * k;
  state.counters["ms_move"] = move * k;
  state.counters["ms_shift"] = shift * k;
  state.counters["ms_write"] = write * k;
  state.counters["mpus_rerun"] = rerun * k;
  state.counters["mpus"] = double(((grid.cells + options.mpuCells - 1) / options.mpuCells).x) *
                           double(((grid.cells + options.mpuCells - 1) / options.mpuCells).y) *
                           double(((grid.cells + options.mpuCells - 1) / options.mpuCells).z);
  state.counters["triangles"] = double(inc.mesh().triangleCount());
  state.counters["instructions"] = double(tree.program().code.size());
  state.counters["full_ms"] = fullMs;
  state.counters["fraction_of_full"] = total * k / fullMs;
}

void registerAll() {
  const std::pair<EditKind, const char*> kinds[] = {{EditKind::Capital, "capital"},
                                                    {EditKind::Cylinder, "cylinder"},
                                                    {EditKind::CylinderColour, "colour"},
                                                    {EditKind::Pillar, "pillar"},
                                                    {EditKind::Storey, "storey"}};
  for (int levels : {2, 4, 6})
    for (const auto& [kind, name] : kinds) {
      const std::string label = "edit/L" + std::to_string(levels) + "/" + name;
      benchmark::RegisterBenchmark(label.c_str(), [levels, kind = kind](benchmark::State& s) { edit(s, levels, kind); })
          ->Arg(2)
          ->ArgName("threads")
          ->Unit(benchmark::kMillisecond)
          ->MinTime(1.0);
    }
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
