// Whole polygonization with the MPU polygonizer: tower (4 levels, 8 pillars, one instance) and a
// blend of 128 random points, at several resolutions, thread counts and MPU sizes. Counters:
// triangles, FVEPT (point evaluations per triangle), FVEPT_simd (SIMD calls per triangle),
// discarded/crossed MPUs. Arguments: {resolution, threads, mpuCells, subBlockCells (-1: default)}.
//   bench_polygonizer --benchmark_filter='/256/2/'      # the 256^3, 2-core target
//   bench_polygonizer --benchmark_filter='mpu_sweep'     # time against MPU size
//   bench_polygonizer --benchmark_filter='subblock_sweep' # sparse field cache block size
//   bench_polygonizer --benchmark_filter='remesh'         # one MpuPolygonizer meshing again into
//                                                        # one TriMesh (polygonize/: fresh each time)
#include "blobvk/cpu_simd/mpu_polygonizer.h"
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

// `again`: one MpuPolygonizer meshing into one TriMesh every iteration (its scratch, MPU results
// and output arrays reused), as a host re-meshing does; otherwise polygonizeMpu into a fresh mesh.
void polygonize(benchmark::State& state, const blobtree::Node& node, bool again = false) {
  const blobtree::Program program = blobtree::compile(node);
  const blobtree::GridSpec grid = gridFor(program, int(state.range(0)));
  cpu::MpuOptions o;
  o.threads = int(state.range(1));
  o.mpuCells = int(state.range(2));
  if (state.range(3) >= 0) o.subBlockCells = int(state.range(3));
  cpu::MpuStats st;
  cpu::MpuPolygonizer polygonizer;
  mesh::TriMesh kept;
  for (auto _ : state) {
    if (again) {
      polygonizer.polygonize(program, grid, o, kept, &st);
      benchmark::DoNotOptimize(kept.positions.data());
    } else {
      mesh::TriMesh m = cpu::polygonizeMpu(program, grid, o, &st);
      benchmark::DoNotOptimize(m.positions.data());
    }
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
  state.counters["cpu_prune"] = st.cpuPrune;
  state.counters["tape_avg"] =
      double(st.tapeInstructions) / double(std::max<std::uint64_t>(1, st.empty + st.full + st.crossed));
  state.counters["code"] = double(program.code.size());
  state.counters["subblocks_classified"] =
      double(st.subBlocksClassified) / double(std::max<std::uint64_t>(1, st.subBlocks));
}

void registerAll() {
  const std::pair<const char*, blobtree::Node> scenes[] = {
      {"tower", testmodels::tower()}, {"random_blobs_128", testmodels::randomBlobs(128)}};
  for (const auto& [name, node] : scenes) {
    auto* b = benchmark::RegisterBenchmark(
        (std::string("polygonize/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node); });
    for (int res : {64, 128, 256})
      for (int threads : {1, 2}) b->Args({res, threads, cpu::kDefaultMpuCells, -1});
    b->Unit(benchmark::kMillisecond)->UseRealTime();
    auto* remesh = benchmark::RegisterBenchmark(
        (std::string("remesh/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node, true); });
    for (int threads : {1, 2}) remesh->Args({256, threads, cpu::kDefaultMpuCells, -1});
    remesh->Unit(benchmark::kMillisecond)->UseRealTime();
    auto* sweep = benchmark::RegisterBenchmark(
        (std::string("mpu_sweep/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node); });
    for (int d : {4, 6, 8, 12, 16, 24, 32})
      for (int threads : {1, 2}) sweep->Args({256, threads, d, -1});
    sweep->Unit(benchmark::kMillisecond)->UseRealTime();
    // Sparse field cache: sub-block size B (0: every point evaluated) for a few MPU sizes.
    auto* sparse = benchmark::RegisterBenchmark(
        (std::string("subblock_sweep/") + name).c_str(),
        [node = node](benchmark::State& s) { polygonize(s, node); });
    for (int d : {8, 16, 32})
      for (int sb : {0, 2, 4, 8}) sparse->Args({256, 1, d, sb});
    sparse->Unit(benchmark::kMillisecond)->UseRealTime();
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
