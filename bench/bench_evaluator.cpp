// Evaluator throughput: scalar reference vs AVX2 vs AVX-512, per node type and for whole scenes,
// one thread. Points are random in the model's bounds; items/s is points per second.
//   bench_evaluator --benchmark_filter=scene
#include "blobtree/evaluate.h"
#include "cpu_simd/simd_evaluator.h"
#include "tests/cpu_simd/models.h"

#include <benchmark/benchmark.h>

#include <random>
#include <vector>

namespace {

using namespace blobvk;

struct Batch {
  blobtree::Program program;
  std::vector<float> x, y, z, f;
};

Batch makeBatch(const blobtree::Node& node, std::size_t n = 4096) {
  Batch b{blobtree::compile(node), {}, {}, {}, std::vector<float>(n)};
  std::mt19937 rng(42);
  const glm::vec3 lo = b.program.bounds.lo, hi = b.program.bounds.hi;
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    b.x.push_back(lo.x + (hi.x - lo.x) * u(rng));
    b.y.push_back(lo.y + (hi.y - lo.y) * u(rng));
    b.z.push_back(lo.z + (hi.z - lo.z) * u(rng));
  }
  return b;
}

void run(benchmark::State& state, const blobtree::Node& node, cpu::SimdLevel level) {
  if (!cpu::simdLevelSupported(level)) {
    state.SkipWithError("not supported by this CPU");
    return;
  }
  Batch b = makeBatch(node);
  for (auto _ : state) {
    if (level == cpu::SimdLevel::Scalar) {
      // The reference itself, called point by point.
      for (std::size_t i = 0; i < b.f.size(); ++i)
        b.f[i] = blobtree::evaluate(b.program, glm::vec3(b.x[i], b.y[i], b.z[i]));
    } else {
      cpu::evaluateFieldBatch(b.program, b.x.data(), b.y.data(), b.z.data(), b.f.data(),
                              b.f.size(), level);
    }
    benchmark::DoNotOptimize(b.f.data());
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(b.f.size()));
}

void registerAll() {
  using cpu::SimdLevel;
  std::vector<std::pair<std::string, blobtree::Node>> models;
  for (auto& m : testmodels::primitiveModels()) models.emplace_back("prim/" + m.first, m.second);
  for (auto& m : testmodels::operatorModels()) models.emplace_back("op/" + m.first, m.second);
  for (auto& m : testmodels::warpModels()) models.emplace_back("warp/" + m.first, m.second);
  models.emplace_back("scene/tower", testmodels::tower());
  models.emplace_back("scene/random_blobs_128", testmodels::randomBlobs(128));
  for (const auto& [name, node] : models)
    for (SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512})
      benchmark::RegisterBenchmark((name + "/" + cpu::toString(l)).c_str(),
                                   [node = node, l](benchmark::State& s) { run(s, node, l); });
}

}  // namespace

int main(int argc, char** argv) {
  registerAll();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
