// Whole polygonization with the MPU polygonizer: tower (4 levels, 8 pillars, one instance) and a
// blend of 128 random points, at several resolutions, thread counts and MPU sizes. Counters:
// triangles, FVEPT (point evaluations per triangle), FVEPT_simd (SIMD calls per triangle),
// discarded/crossed MPUs. Arguments: {resolution, threads, mpuCells}.
//   bench_polygonizer --benchmark_filter='/256/2/'      # the 256^3, 2-core target
//   bench_polygonizer --benchmark_filter='mpu_sweep'     # time against MPU size
#include "cpu_simd/mpu_polygonizer.h"
#include "tests/cpu_simd/models.h"

#include <benchmark/benchmark.h>

#include <algorithm>

namespace {

using namespace blobvk;

// `resolution` cells along the longest side of the program's bounds, one cell of margin.
blobtree::GridSpec gridFor(const blobtree::Program& program, int resolution) {
  const glm::vec3 extent = program.bounds.hi - program.bounds.lo;
  const float longest = std::max({extent.x, extent.y, extent.z});
  blobtree::GridSpec g;
  g.cellSize = longest / float(resolution - 2);
  g.origin = program.bounds.lo - g.cellSize;
  g.cells = glm::ivec3(glm::ceil((extent + 2.0f * g.cellSize) / g.cellSize));
  return g;
}

void polygonize(benchmark::State& state, const blobtree::Node& node) {
  const blobtree::Program program = blobtree::compile(node);
  const blobtree::GridSpec grid = gridFor(program, int(state.range(0)));
  cpu::MpuOptions o;
  o.threads = int(state.range(1));
  o.mpuCells = int(state.range(2));
  cpu::MpuStats st;
  for (auto _ : state) {
    mesh::TriMesh m = cpu::polygonizeMpu(program, grid, o, &st);
    benchmark::DoNotOptimize(m.positions.data());
  }
  state.counters["triangles"] = double(st.triangles);
  state.counters["FVEPT"] = st.fvept;
  state.counters["FVEPT_simd"] = st.fveptSimd;
  state.counters["grid_evals"] = double(st.gridEvaluations);
  state.counters["discarded"] = double(st.discardedEmpty + st.discardedFull);
  state.counters["crossed"] = double(st.crossed);
  state.counters["mpus"] = double(st.mpus);
  state.counters["ms_mpus"] = st.msMpus;
  state.counters["ms_scatter"] = st.msScatter;
  state.counters["ms_prefix"] = st.msPrefix;
  state.counters["cpu_field"] = st.cpuField;
  state.counters["cpu_attr"] = st.cpuAttributes;
  state.counters["cpu_cells"] = st.cpuCells;
  state.counters["cpu_vertices"] = st.cpuVertices;
  state.counters["cpu_discard"] = st.cpuDiscard;
}

void registerAll() {
  const std::pair<const char*, blobtree::Node> scenes[] = {
      {"tower", testmodels::tower()}, {"random_blobs_128", testmodels::randomBlobs(128)}};
  for (const auto& [name, node] : scenes) {
    auto* b = benchmark::RegisterBenchmark(
        (std::string("polygonize/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node); });
    for (int res : {64, 128, 256})
      for (int threads : {1, 2}) b->Args({res, threads, cpu::kDefaultMpuCells});
    b->Unit(benchmark::kMillisecond)->UseRealTime();
    auto* sweep = benchmark::RegisterBenchmark(
        (std::string("mpu_sweep/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node); });
    for (int d : {4, 6, 8, 12, 16, 24, 32}) sweep->Args({256, 2, d});
    sweep->Unit(benchmark::kMillisecond)->UseRealTime();
  }
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
