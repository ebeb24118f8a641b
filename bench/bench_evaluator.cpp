// Evaluator throughput: scalar reference vs AVX2 vs AVX-512, per node type and for whole scenes,
// one thread; items/s is points per second. Two point sets:
// - random points in the model's bounds (incoherent: a SIMD chunk rarely takes a box skip whole);
// - grid/: every point of a 64^3 grid over the bounds, one row of 64 points per batch call, which
//   is what the polygonizer's field cache evaluates (coherent points; the full Program, without
//   the polygonizer's per-MPU pruning or discard).
//   bench_evaluator --benchmark_filter=scene
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "tests/cpu_simd/models.h"

#include <benchmark/benchmark.h>

#include <algorithm>
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

// Every point of a res^3 grid over the model's bounds, as rows of res points along x.
void runGrid(benchmark::State& state, const blobtree::Node& node, cpu::SimdLevel level, int res = 64) {
  if (!cpu::simdLevelSupported(level)) {
    state.SkipWithError("not supported by this CPU");
    return;
  }
  const blobtree::Program program = blobtree::compile(node);
  const glm::vec3 lo = program.bounds.lo, size = program.bounds.hi - program.bounds.lo;
  const std::size_t n = std::size_t(res);
  std::vector<float> x(n), y(n), z(n), f(n);
  for (std::size_t i = 0; i < n; ++i) x[i] = lo.x + size.x * (float(i) + 0.5f) / float(res);
  for (auto _ : state) {
    for (int k = 0; k < res; ++k) {
      for (int j = 0; j < res; ++j) {
        std::fill(y.begin(), y.end(), lo.y + size.y * (float(j) + 0.5f) / float(res));
        std::fill(z.begin(), z.end(), lo.z + size.z * (float(k) + 0.5f) / float(res));
        if (level == cpu::SimdLevel::Scalar) {
          for (std::size_t i = 0; i < n; ++i) f[i] = blobtree::evaluate(program, glm::vec3(x[i], y[i], z[i]));
        } else {
          cpu::evaluateFieldBatch(program, x.data(), y.data(), z.data(), f.data(), n, level);
        }
        benchmark::DoNotOptimize(f.data());
      }
    }
  }
  state.SetItemsProcessed(std::int64_t(state.iterations()) * std::int64_t(n * n * n));
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
  for (const auto& [name, node] : models) {
    if (name.rfind("scene/", 0) != 0) continue;
    for (SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512})
      benchmark::RegisterBenchmark(("grid/" + name + "/" + cpu::toString(l)).c_str(),
                                   [node = node, l](benchmark::State& s) { runGrid(s, node, l); })
          ->Unit(benchmark::kMillisecond);
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
