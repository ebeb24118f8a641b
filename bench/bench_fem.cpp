// FEM step cost (corotational linear tets, implicit Euler, Jacobi PCG with 10 iterations as in
// the SOFA benchmark protocol) on voxel box meshes of ~1k, 10k and 100k tets, with a per-phase
// breakdown as counters (ms per step): rotations, assembly (forces + warped stiffness refill),
// contact, solve (CG + update).
#include "fem/simulation.h"
#include "fem/voxel_mesher.h"

#include <benchmark/benchmark.h>

namespace {

using namespace blobvk;

mesh::TetMesh box(int cx, int cy, int cz) {
  fem::VoxelMesherSettings s;
  s.boundsMin = {0, 0, 0};
  s.boundsMax = {0.01 * cx, 0.01 * cy, 0.01 * cz};
  s.cellSize = 0.01;
  return fem::voxelTetrahedralize([](double, double, double) { return 1.0f; }, s);
}

void BM_FemStep(benchmark::State& state) {
  const int cx = int(state.range(0)), cy = int(state.range(1)), cz = int(state.range(2));
  fem::SimulationSettings settings;
  settings.materials = {fem::Material{1e5, 0.45, 1000}};
  settings.fixed = [](const mesh::Double3& p) { return p.y < 1e-9; };
  settings.cgMaxIterations = 10;
  settings.cgTolerance = 0;  // fixed work per step, like SOFA's CG with 10 iterations
  fem::Simulation sim(box(cx, cy, cz), settings);
  sim.run(3);  // warm the rotations and the velocity guess
  double rotations = 0, assembly = 0, contact = 0, solve = 0;
  for (auto _ : state) {
    sim.step();
    const auto& s = sim.lastStats();
    rotations += s.rotationsMs;
    assembly += s.assemblyMs;
    contact += s.contactMs;
    solve += s.solveMs;
  }
  const double n = double(state.iterations());
  state.counters["tets"] = double(sim.mesh().tetCount());
  state.counters["nodes"] = double(sim.mesh().nodeCount());
  state.counters["rotations_ms"] = rotations / n;
  state.counters["assembly_ms"] = assembly / n;
  state.counters["contact_ms"] = contact / n;
  state.counters["solve_ms"] = solve / n;
}
// 960, 10,368 and 102,600 tets (the last two match the anchors' baseline meshes).
BENCHMARK(BM_FemStep)->Args({8, 5, 4})->Args({12, 12, 12})->Args({19, 20, 45})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
