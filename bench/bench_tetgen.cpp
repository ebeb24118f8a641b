// TetGen quality tetrahedralization to ~100k tets (issue #6: <= 3 s with a minimum dihedral angle
// >= 10 degrees), with the switches of fem/tetgen_mesher. Two closed surfaces:
//  - blob: the MPU polygonization of a blended sphere + cylinder (tests/cpu_simd/models.h) at 32
//    cells along its longest axis (3,268 triangles; marching cubes leaves triangles with angles
//    down to 0.3 degrees);
//  - icosphere: a unit sphere subdivided 4 times (5,120 triangles, all angles > 54 degrees).
// The volume bound -a is 3 x enclosed volume / target tets (TetGen's tets come out ~3x smaller
// than the bound on the sphere). Counters: tets, nodes, surface triangles, minimum dihedral
// angle (degrees), tets below 10 degrees; the label is the switch string.
//   bench_tetgen                                   # all
//   bench_tetgen --benchmark_filter='icosphere'
#include "cpu_simd/mpu_polygonizer.h"
#include "fem/tetgen_mesher.h"
#include "mesh/checks.h"
#include "tests/cpu_simd/models.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

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

mesh::TriMesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<mesh::Double3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                  {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<std::uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> middle;
    auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = middle.find(key);
      if (it != middle.end()) return it->second;
      p.push_back({(p[a].x + p[b].x) / 2, (p[a].y + p[b].y) / 2, (p[a].z + p[b].z) / 2});
      return middle[key] = std::uint32_t(p.size() - 1);
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    for (const auto& t3 : f) {
      const std::uint32_t ab = mid(t3[0], t3[1]), bc = mid(t3[1], t3[2]), ca = mid(t3[2], t3[0]);
      next.insert(next.end(), {{t3[0], ab, ca}, {t3[1], bc, ab}, {t3[2], ca, bc}, {ab, bc, ca}});
    }
    f = std::move(next);
  }
  mesh::TriMesh s;
  for (const auto& q : p) {
    const double l = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    s.positions.push_back({float(q.x / l), float(q.y / l), float(q.z / l)});
  }
  s.triangles = f;
  return s;
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

BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10, sphere, 1.414, 10.0, 0.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10_o150, sphere, 1.414, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q1.414_10_o140, sphere, 1.414, 10.0, 140.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, icosphere_q2_10_o150, sphere, 2.0, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, blob_q1.414_10, blob, 1.414, 10.0, 0.0)->Arg(100000)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(tetrahedralize, blob_q1.414_10_o150, blob, 1.414, 10.0, 150.0)->Arg(100000)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
