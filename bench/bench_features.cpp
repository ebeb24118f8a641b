// Sharp features against plain marching cubes (issue: CSG creases), as geometric error and as
// time: each case polygonizes a model at a resolution, with or without the feature pass, and
// reports its distance to a mesh of the same model at 512 cells refined onto the surface
// (cpu_simd/surface_error.h), in cells of the case's grid.
//
//   build/release/bench/bench_features --benchmark_counters_tabular=true --benchmark_format=json
//
// Cases: box_minus_cylinder and scenes/dice.json at 64 and 128; mode 0 plain marching cubes,
// 1 with --features, 2 plain at 4x the resolution, 3 --features --feature-angle 15; 0 or 2 refinement steps per vertex (--refine).
// Time is polygonization plus the pass.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/sharp_features.h"
#include "blobvk/cpu_simd/surface_error.h"

#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>

namespace {

using namespace blobvk;

constexpr const char* kBoxMinusCylinder = R"({"blobvk": 1, "name": "box_minus_cylinder", "root": {"type": "difference",
  "children": [{"type": "cube", "centre": [0, 0, 0], "halfExtents": 0.8, "support": 0.2},
               {"type": "cylinder", "base": [0, -2, 0], "axis": "y", "radius": 0.35, "height": 4, "support": 0.2}]}})";

blobtree::Program programOf(int scene) {
  if (scene == 0) return blobtree::compile(blobtree::parseSceneJson(kBoxMinusCylinder, "box_minus_cylinder").root);
  return blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/dice.json").root);
}

blobtree::GridSpec gridOf(const blobtree::Program& p, int resolution) {
  blobtree::GridRequest r;
  r.resolution = resolution;
  return blobtree::chooseGrid(p, {}, r);
}

const mesh::TriMesh& referenceOf(int scene) {
  static std::map<int, std::unique_ptr<mesh::TriMesh>> cache;
  auto& m = cache[scene];
  if (!m) {
    const blobtree::Program p = programOf(scene);
    cpu::MpuOptions o;
    o.refineSteps = 4;
    m = std::make_unique<mesh::TriMesh>(cpu::polygonizeMpu(p, gridOf(p, 512), o));
  }
  return *m;
}

void featureError(benchmark::State& state) {
  const int scene = int(state.range(0)), resolution = int(state.range(1)), mode = int(state.range(2));
  cpu::MpuOptions options;
  options.refineSteps = int(state.range(3));
  const blobtree::Program program = programOf(scene);
  const int res = mode == 2 ? 4 * resolution : resolution;
  const blobtree::GridSpec grid = gridOf(program, res);
  mesh::TriMesh mesh;
  cpu::FeatureReport report;
  for (auto _ : state) {
    mesh = cpu::polygonizeMpu(program, grid, options);
    report = {};
    cpu::FeatureOptions features;
    if (mode == 3) features.creaseDegrees = 15.0f;
    if (mode == 1 || mode == 3) cpu::placeSharpFeatures(mesh, grid, features, &report);
    benchmark::DoNotOptimize(mesh.triangles.data());
  }
  const double h = double(gridOf(program, resolution).cellSize);
  const cpu::SurfaceError e = cpu::surfaceError(mesh, referenceOf(scene), double(grid.cellSize));
  state.SetLabel(std::string(scene == 0 ? "box_minus_cylinder" : "dice") + (mode == 0 ? " mc" : mode == 1 ? " features" : mode == 3 ? " features 15 deg" : " mc 4x"));
  state.counters["hausdorff_cells"] = e.hausdorff() / h;
  state.counters["mean_cells"] = e.meanToReference / h;
  if (std::getenv("BLOBVK_BENCH_WHERE"))
    std::fprintf(stderr, "%s: to %.3f at (%.3f %.3f %.3f), from %.3f at (%.3f %.3f %.3f)\n", (std::to_string(scene) + "/" + std::to_string(resolution) + "/" + std::to_string(mode)).c_str(),
                 e.toReference / h, e.worstTo.x, e.worstTo.y, e.worstTo.z, e.fromReference / h, e.worstFrom.x,
                 e.worstFrom.y, e.worstFrom.z);
  state.counters["triangles"] = double(mesh.triangles.size());
  state.counters["feature_vertices"] = double(report.featureVertices);
}

BENCHMARK(featureError)
    ->ArgsProduct({{0, 1}, {64, 128}, {0, 1, 2, 3}, {0, 2}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
