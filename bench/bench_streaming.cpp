// In-memory against streamed polygonization (the layer loop and join, into a sink that only
// counts), on the tower of the tests at several resolutions: what streaming costs over
// polygonizeMpu before any file is written. Arguments: {resolution, threads}.
//   bench_streaming --benchmark_filter='/256/'
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/streaming_polygonizer.h"
#include "tests/cpu_simd/models.h"

#include <benchmark/benchmark.h>

#include <algorithm>

namespace {

using namespace blobvk;

blobtree::GridSpec gridFor(const blobtree::Program& program, int resolution) {
  const glm::vec3 extent = program.bounds.hi - program.bounds.lo;
  const float longest = std::max({extent.x, extent.y, extent.z});
  blobtree::GridSpec g;
  g.cellSize = longest / float(resolution - 2);
  g.origin = program.bounds.lo - g.cellSize;
  g.cells = glm::ivec3(glm::ceil((extent + 2.0f * g.cellSize) / g.cellSize));
  return g;
}

class CountingSink final : public mesh::MeshSink {
 public:
  std::uint64_t vertexCount = 0, triangleCount = 0;
  void vertices(std::span<const mesh::Float3> p, std::span<const mesh::Float3>, std::span<const mesh::Float3>) override {
    vertexCount += p.size();
  }
  void triangles(std::span<const std::array<std::uint32_t, 3>> t, const mesh::VertexWindow&) override {
    triangleCount += t.size();
  }
};

void inMemory(benchmark::State& state) {
  const blobtree::Program program = blobtree::compile(testmodels::tower());
  const blobtree::GridSpec grid = gridFor(program, int(state.range(0)));
  cpu::MpuOptions o;
  o.threads = int(state.range(1));
  std::size_t triangles = 0;
  for (auto _ : state) {
    mesh::TriMesh m = cpu::polygonizeMpu(program, grid, o);
    triangles = m.triangleCount();
    benchmark::DoNotOptimize(m.positions.data());
  }
  state.counters["triangles"] = double(triangles);
}

void streamed(benchmark::State& state) {
  const blobtree::Program program = blobtree::compile(testmodels::tower());
  const blobtree::GridSpec grid = gridFor(program, int(state.range(0)));
  cpu::MpuOptions o;
  o.threads = int(state.range(1));
  std::uint64_t triangles = 0;
  for (auto _ : state) {
    CountingSink sink;
    cpu::polygonizeMpuStreamed(program, grid, o, sink);
    triangles = sink.triangleCount;
  }
  state.counters["triangles"] = double(triangles);
}

void args(benchmark::internal::Benchmark* b) {
  for (int res : {128, 256, 384})
    for (int threads : {1, 2}) b->Args({res, threads});
  b->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(inMemory)->Apply(args);
BENCHMARK(streamed)->Apply(args);

}  // namespace
BENCHMARK_MAIN();
