// TetGen quality tetrahedralization to ~100k tets (issue #6: <= 3 s with a minimum dihedral angle
// >= 10 degrees), with the switches of fem/tetgen_mesher. Two closed surfaces:
//  - blob: the MPU polygonization of a blended sphere + cylinder (tests/cpu_simd/models.h) at 32
//    cells along its longest axis (3,268 triangles; marching cubes leaves triangles with angles
//    down to 0.3 degrees);
//  - icosphere: a unit sphere subdivided 4 times (5,120 triangles, all angles > 54 degrees).
// The volume bound -a is 3 x enclosed volume / target tets (TetGen's tets come out ~3x smaller
// than the bound on the sphere). Counters: tets, nodes, surface triangles, minimum dihedral
// angle (degrees), tets below 10 degrees; the label is the switch string.
// Then the shipped simulated scenes (craniotomy, eggshell_sim, soft_peanut) polygonized as
// `blobvk simulate` does: sceneTetgen = clean-up + TetGen + sliver pass, with the minimum
// dihedral before and after the sliver pass; sceneRemesh = the clean-up alone (scalar vs SIMD
// projection, self-intersection guard on/off). Counters say which arguments are which.
//   bench_tetgen                                   # all (the raw MC scene rows take ~1 min)
//   bench_tetgen --benchmark_filter='icosphere'
//   bench_tetgen --benchmark_filter='-sceneTetgen/[a-z_]+/[0-9]+/0/'   # all but the raw MC rows
//   bench_tetgen --benchmark_filter='tetgenChildProcess'           # the child process's cost
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/surface_remesh.h"
#include "tests/cpu_simd/models.h"
#include "tests/fem/icosphere.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <glm/geometric.hpp>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace blobvk;

mesh::TriMesh blobSurface() {
  const blobtree::Program program = blobtree::compile(testmodels::op(blobtree::OperatorType::Blend, testmodels::pair()));
  const glm::vec3 extent = program.bounds.hi - program.bounds.lo;
  blobtree::GridSpec g;
  g.cellSize = std::max({extent.x, extent.y, extent.z}) / 30.0f;
  g.origin = program.bounds.lo - g.cellSize;
  g.cells = glm::ivec3(glm::ceil((extent + 2.0f * g.cellSize) / g.cellSize));
  return cpu::polygonizeMpu(program, g, cpu::MpuOptions{});
}

using blobvk::testing::icosphere;  // tests/fem/icosphere.h

// CPU time of the calling thread (the clean-up is single-threaded; wall time moves with the load).
double threadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

// Smallest dihedral angle of the mesh (degrees) and how many tets have one below 10 degrees.
std::pair<double, std::size_t> dihedralStats(const mesh::TetMesh& m) {
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double best = 180;
  std::size_t below10 = 0;
  for (const auto& t : m.tets) {
    double tetBest = 180;
    for (const auto& e : kEdges) {
      int o[2], c = 0;
      for (int k = 0; k < 4; ++k)
        if (k != e[0] && k != e[1]) o[c++] = k;
      const auto& p0 = m.positions[t[std::size_t(e[0])]];
      const auto& p1 = m.positions[t[std::size_t(e[1])]];
      double axis[3] = {p1.x - p0.x, p1.y - p0.y, p1.z - p0.z};
      const double len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
      for (double& v : axis) v /= len;
      double side[2][3];
      for (int s = 0; s < 2; ++s) {
        const auto& q = m.positions[t[std::size_t(o[s])]];
        double v[3] = {q.x - p0.x, q.y - p0.y, q.z - p0.z};
        const double along = v[0] * axis[0] + v[1] * axis[1] + v[2] * axis[2];
        double n = 0;
        for (int k = 0; k < 3; ++k) {
          side[s][k] = v[k] - along * axis[k];
          n += side[s][k] * side[s][k];
        }
        for (int k = 0; k < 3; ++k) side[s][k] /= std::sqrt(n);
      }
      const double cosine = side[0][0] * side[1][0] + side[0][1] * side[1][1] + side[0][2] * side[1][2];
      tetBest = std::min(tetBest, std::acos(std::clamp(cosine, -1.0, 1.0)) * 180 / M_PI);
    }
    best = std::min(best, tetBest);
    below10 += tetBest < 10 ? 1 : 0;
  }
  return {best, below10};
}

// range(0): target tets; ratio, angle: the -q bounds; optimize: the -o/<angle> bound (0: none).
void tetrahedralize(benchmark::State& state, const mesh::TriMesh& (*surface)(), double ratio, double angle, double optimize) {
  if (!fem::tetgenAvailable()) {
    state.SkipWithError("built without TetGen");
    return;
  }
  const mesh::TriMesh& s = surface();
  fem::TetgenOptions o;
  o.maxRadiusEdgeRatio = ratio;
  o.minDihedralDegrees = angle;
  o.optimizeMaxDihedralDegrees = optimize;
  o.maxVolume = 3.0 * mesh::checkMesh(s).volume / double(state.range(0));
  mesh::TetMesh m;
  for (auto _ : state) {
    m = fem::tetrahedralize(s, o);
    benchmark::DoNotOptimize(m.tets.data());
  }
  const auto [minimum, below10] = dihedralStats(m);
  state.counters["tets"] = double(m.tetCount());
  state.counters["nodes"] = double(m.nodeCount());
  state.counters["surface_tris"] = double(s.triangles.size());
  state.counters["min_dihedral_deg"] = minimum;
  state.counters["tets_below_10deg"] = double(below10);
  state.SetLabel(fem::tetgenSwitches(o));
}

const mesh::TriMesh& blob() {
  static const mesh::TriMesh s = blobSurface();
  return s;
}
const mesh::TriMesh& sphere() {
  static const mesh::TriMesh s = icosphere(4);
  return s;
}

// A shipped scene polygonized as `blobvk simulate` does (the scene's grid, MPU polygonizer), with
// the Program kept for the remesher's projection onto the implicit surface.
struct SceneSurface {
  blobtree::Program program;
  mesh::TriMesh surface;
  double cellSize = 0;
};

const SceneSurface& sceneSurface(const std::string& name) {
  static std::map<std::string, SceneSurface> cache;
  const auto it = cache.find(name);
  if (it != cache.end()) return it->second;
  const char* dir = std::getenv("BLOBVK_SCENES");
  const blobtree::Scene scene = blobtree::loadScene(std::string(dir ? dir : "scenes") + "/" + name + ".json");
  SceneSurface s;
  s.program = blobtree::compile(scene.root);
  const blobtree::GridSpec grid = blobtree::chooseGrid(s.program, scene.grid, {});
  s.surface = cpu::polygonizeMpu(s.program, grid, cpu::MpuOptions{});
  s.cellSize = grid.cellSize;
  return cache.emplace(name, std::move(s)).first->second;
}

// Smallest angle between two adjacent surface triangles measured inside the solid (degrees):
// tets at that edge cannot have a larger dihedral angle there, whatever TetGen does.
double minSurfaceInteriorAngle(const mesh::TriMesh& s) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> faceOfEdge;
  for (std::size_t f = 0; f < s.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) faceOfEdge[{s.triangles[f][std::size_t(k)], s.triangles[f][std::size_t((k + 1) % 3)]}] = f;
  const auto at = [&](std::uint32_t v) { return glm::dvec3(s.positions[v].x, s.positions[v].y, s.positions[v].z); };
  const auto normal = [&](std::size_t f) {
    const auto& t = s.triangles[f];
    return glm::normalize(glm::cross(at(t[1]) - at(t[0]), at(t[2]) - at(t[0])));
  };
  double best = 360;
  for (const auto& [edge, f] : faceOfEdge) {
    const std::size_t e = faceOfEdge.at({edge.second, edge.first});
    std::uint32_t d = 0;
    for (std::uint32_t v : s.triangles[e])
      if (v != edge.first && v != edge.second) d = v;
    const double turn = std::acos(std::clamp(glm::dot(normal(f), normal(e)), -1.0, 1.0));
    const bool convex = glm::dot(normal(f), at(d) - at(edge.first)) < 0;
    best = std::min(best, (convex ? M_PI - turn : M_PI + turn) * 180 / M_PI);
  }
  return best;
}

// The clean-up's options: target edge in cells; projection 0: scalar blobtree::evaluate per point,
// 1: the SIMD evaluator over batches (as apps/soft_body.cpp), 2: none (tangent-plane moves only).
mesh::SurfaceRemeshOptions remeshOptions(const SceneSurface& scene, double edgeCells, int projection) {
  mesh::SurfaceRemeshOptions r;
  r.targetEdgeLength = scene.cellSize * edgeCells;
  const blobtree::Program& program = scene.program;
  if (projection == 0) {
    r.project = mesh::isoSurfaceProjection(
        [&program](const mesh::Double3& p) { return double(blobtree::evaluate(program, glm::vec3(float(p.x), float(p.y), float(p.z)))); },
        0.5, 1e-3 * scene.cellSize);
  } else if (projection == 1) {
    r.projectBatch = mesh::isoSurfaceProjectionBatch(
        [&program, level = cpu::bestSimdLevel()](const std::vector<mesh::Double3>& points, std::vector<double>& values) {
          const std::size_t n = points.size();
          std::vector<float> x(n), y(n), z(n), f(n);
          for (std::size_t i = 0; i < n; ++i) x[i] = float(points[i].x), y[i] = float(points[i].y), z[i] = float(points[i].z);
          cpu::evaluateFieldBatch(program, x.data(), y.data(), z.data(), f.data(), n, level);
          values.assign(f.begin(), f.end());
        },
        0.5, 1e-3 * scene.cellSize);
  }
  return r;
}

// The clean-up alone: range(0) target edge in % of a cell, range(1) projection (remeshOptions),
// range(2) 1 = with the self-intersection guard. CPU time = the main thread's (single-threaded).
void sceneRemesh(benchmark::State& state, const std::string& name) {
  const SceneSurface& scene = sceneSurface(name);
  mesh::SurfaceRemeshOptions r = remeshOptions(scene, double(state.range(0)) / 100.0, int(state.range(1)));
  r.preventSelfIntersections = state.range(2) != 0;
  mesh::SurfaceRemeshStats stats;
  mesh::TriMesh out;
  for (auto _ : state) {
    out = mesh::remeshSurface(scene.surface, r, &stats);
    benchmark::DoNotOptimize(out.triangles.data());
  }
  state.counters["tris"] = double(out.triangles.size());
  state.counters["min_tri_angle_deg"] = stats.minAngleAfterDegrees;
  state.counters["undone_moves"] = double(stats.undoneMoves);
}

// The TetGen path of a shipped simulated scene, timed with the surface clean-up before it.
// range(0): target tets (0: no volume bound, as `blobvk simulate` by default); range(1): remesh target edge length in percent of the polygonizer's
// cell size (0: TetGen on the raw marching-cubes surface); range(2): the clean-up's projection
// evaluates the field with the scalar blobtree::evaluate (0) or the SIMD batch evaluator (1). Switches q1.414/10 o/150 a<3V/target>.
void sceneTetgen(benchmark::State& state, const std::string& name) {
  if (!fem::tetgenAvailable()) {
    state.SkipWithError("built without TetGen");
    return;
  }
  const SceneSurface& scene = sceneSurface(name);
  fem::TetgenOptions o;
  o.optimizeMaxDihedralDegrees = 150;
  o.maxVolume = state.range(0) > 0 ? 3.0 * mesh::checkMesh(scene.surface).volume / double(state.range(0)) : 0.0;
  const mesh::SurfaceRemeshOptions r = remeshOptions(scene, double(state.range(1)) / 100.0, int(state.range(2)));
  mesh::TetMesh m;
  mesh::TriMesh input;
  mesh::SurfaceRemeshStats stats;
  fem::SliverStats slivers;
  double remeshSeconds = 0, remeshCpuSeconds = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const double cpuStart = threadCpuSeconds();
    input = state.range(1) > 0 ? mesh::remeshSurface(scene.surface, r, &stats) : scene.surface;
    remeshSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    remeshCpuSeconds = threadCpuSeconds() - cpuStart;
    try {
      m = fem::tetrahedralize(input, o, &slivers);
    } catch (const std::exception& e) {
      state.SkipWithError(e.what());  // e.g. a thin shell whose clean-up intersects itself
      return;
    }
    benchmark::DoNotOptimize(m.tets.data());
  }
  const auto [minimum, below10] = dihedralStats(m);
  const mesh::MeshReport before = mesh::checkMesh(scene.surface), after = mesh::checkMesh(input);
  state.counters["tets"] = double(m.tetCount());
  state.counters["surface_tris"] = double(input.triangles.size());
  state.counters["min_tri_angle_deg"] = mesh::minTriangleAngleDegrees(input);
  state.counters["min_dihedral_deg"] = minimum;
  state.counters["tets_below_10deg"] = double(below10);
  state.counters["min_surface_angle_deg"] = minSurfaceInteriorAngle(input);
  state.counters["remesh_s"] = remeshSeconds;
  state.counters["remesh_cpu_s"] = remeshCpuSeconds;
  state.counters["tetgen_min_dihedral_deg"] = slivers.minDihedralBeforeDegrees;
  state.counters["slivers_moved"] = double(slivers.nodesMoved);
  state.counters["volume_change_pct"] = 100.0 * (after.volume - before.volume) / before.volume;
  state.SetLabel(fem::tetgenSwitches(o));
}

BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10, sphere, 1.414, 10.0, 0.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10_o150, sphere, 1.414, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10_o140, sphere, 1.414, 10.0, 140.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q2_10_o150, sphere, 2.0, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, blob_q1.414_10, blob, 1.414, 10.0, 0.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, blob_q1.414_10_o150, blob, 1.414, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);

// TetGen runs in a child process (fem/tetgen_mesher.cpp: a crash must not take the host down).
// Its cost grows with the host's memory, not the surface: fork copies the page tables, and every
// page the host writes while the child lives, and once more after, takes a fault. Args: MiB the
// host holds, written before each call (a simulation's or an engine's state); 1 isolated (the
// default), 0 in the calling thread (TetgenOptions::isolateInChildProcess). A small closed
// surface (an icosphere of 320 triangles, a few ms of TetGen), so what grows is the isolation.
// Counters: call_ms (tetrahedralize, wall), rewrite_ms (the host writing a byte per page of its
// memory after the call: the copy-on-write faults the child leaves behind).
void tetgenChildProcess(benchmark::State& state) {
  const mesh::TriMesh surface = icosphere(2);
  fem::TetgenOptions o;
  o.smoothSlivers = false;
  o.isolateInChildProcess = state.range(1) != 0;
  std::vector<char> host(std::size_t(state.range(0)) << 20, 1);
  const std::size_t page = 4096;
  double callSeconds = 0.0, rewriteSeconds = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(fem::tetrahedralize(surface, o));
    const auto t1 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < host.size(); i += page) host[i] = char(host[i] + 1);
    benchmark::ClobberMemory();
    const auto t2 = std::chrono::steady_clock::now();
    callSeconds += std::chrono::duration<double>(t1 - t0).count();
    rewriteSeconds += std::chrono::duration<double>(t2 - t1).count();
  }
  state.counters["call_ms"] = 1e3 * callSeconds / double(state.iterations());
  state.counters["rewrite_ms"] = 1e3 * rewriteSeconds / double(state.iterations());
}
BENCHMARK(tetgenChildProcess)->ArgsProduct({{0, 256, 2048}, {0, 1}})->Unit(benchmark::kMillisecond);

// Shipped simulated scenes. Args: {target tets (0: no -a, as `blobvk simulate`), clean-up edge
// in % of a cell (0: raw marching-cubes surface), projection (0 scalar, 1 SIMD batch)}. The
// defaults of `blobvk simulate` are {0, 200, 1}; soft_peanut is small, so it also runs with an
// -a bound that gives ~100k tets.
BENCHMARK_CAPTURE(sceneRemesh, craniotomy, std::string("craniotomy"))
    ->ArgsProduct({{200}, {0, 1, 2}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(sceneRemesh, eggshell_sim, std::string("eggshell_sim"))
    ->ArgsProduct({{200}, {0, 1, 2}, {1}})->Unit(benchmark::kMillisecond);

BENCHMARK_CAPTURE(sceneTetgen, craniotomy, std::string("craniotomy"))
    ->Args({0, 0, 1})->Args({0, 150, 0})->Args({0, 150, 1})->Args({0, 200, 0})->Args({0, 200, 1})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(sceneTetgen, eggshell_sim, std::string("eggshell_sim"))
    ->Args({0, 0, 1})->Args({0, 100, 1})->Args({0, 150, 1})->Args({0, 200, 1})->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(sceneTetgen, soft_peanut, std::string("soft_peanut"))
    ->Args({100000, 0, 1})->Args({100000, 150, 1})->Args({100000, 200, 1})->Args({0, 200, 1})->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
