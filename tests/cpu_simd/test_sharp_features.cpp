// Sharp features (cpu_simd/sharp_features.h) on CSG models whose creases plain marching cubes
// chamfers: the mesh stays watertight and deterministic, and lies closer to the surface than
// marching cubes at the same grid, measured against a far finer mesh of the same model
// (cpu_simd/surface_error.h); smooth models get no feature vertex.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/sharp_features.h"
#include "blobvk/cpu_simd/surface_error.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/surface_remesh_intersections.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <map>
#include <stdexcept>
#include <vector>
#include <string>

namespace blobvk::testing {
namespace {

// A box with a hole drilled through it: a circle of crease all round each end of the hole.
constexpr const char* kBoxMinusCylinder = R"({"blobvk": 1, "name": "box_minus_cylinder", "root": {"type": "difference",
  "children": [{"type": "cube", "centre": [0, 0, 0], "halfExtents": 0.8, "support": 0.2},
               {"type": "cylinder", "base": [0, -2, 0], "axis": "y", "radius": 0.35, "height": 4, "support": 0.2}]}})";

// Two blended points: smooth everywhere.
constexpr const char* kBlend = R"({"blobvk": 1, "name": "blend", "root": {"type": "blend", "children": [
  {"type": "point", "centre": [-0.4, 0, 0]}, {"type": "point", "centre": [0.4, 0.1, 0]}]}})";

struct Model {
  blobtree::Program program;
  blobtree::GridSpec grid(int resolution) const {
    blobtree::GridRequest r;
    r.resolution = resolution;
    return blobtree::chooseGrid(program, {}, r);
  }
};

Model model(const char* json) {
  const blobtree::Scene scene = blobtree::parseSceneJson(json, "test");
  return {blobtree::compile(scene.root)};
}

mesh::TriMesh meshOf(const Model& m, int resolution, int threads = 0, int refine = 0) {
  cpu::MpuOptions o;
  o.threads = threads;
  o.refineSteps = refine;
  return cpu::polygonizeMpu(m.program, m.grid(resolution), o);
}

TEST(SharpFeatures, BoxMinusCylinderStaysWatertightAndComesCloserToTheSurface) {
  const Model m = model(kBoxMinusCylinder);
  const int resolution = 48;
  const mesh::TriMesh plain = meshOf(m, resolution);
  mesh::TriMesh sharp = plain;
  cpu::FeatureReport report;
  cpu::placeSharpFeatures(sharp, m.grid(resolution), {}, &report);

  EXPECT_GT(report.featureVertices, 50u);  // two rings of crease across the grid
  EXPECT_GT(report.flips, 0u);
  EXPECT_EQ(sharp.positions.size(), plain.positions.size() + report.featureVertices);
  EXPECT_EQ(sharp.normals.size(), sharp.positions.size());
  EXPECT_EQ(sharp.edgeKeys.size(), sharp.positions.size());
  const mesh::MeshReport check = mesh::checkMesh(sharp);
  EXPECT_TRUE(check.watertight()) << check.summary();
  EXPECT_EQ(check.eulerCharacteristic, mesh::checkMesh(plain).eulerCharacteristic);  // a torus either way
  EXPECT_GT(check.volume, 0.0);

  // Against a mesh of the same model at 6x the resolution, refined onto the surface.
  const mesh::TriMesh reference = meshOf(m, 6 * resolution, 0, 4);
  const double h = double(m.grid(resolution).cellSize);
  const cpu::SurfaceError before = cpu::surfaceError(plain, reference, h);
  const cpu::SurfaceError after = cpu::surfaceError(sharp, reference, h);
  // Marching cubes cuts the crease by a fraction of a cell; the feature vertices restore it.
  EXPECT_GT(before.hausdorff(), 0.15 * h);
  EXPECT_LT(after.hausdorff(), 0.7 * before.hausdorff()) << "before " << before.hausdorff() / h << " cells, after "
                                                        << after.hausdorff() / h << " cells";
  EXPECT_LE(after.meanToReference, before.meanToReference);
}

// Pairs of triangles that cross: no shared corner and touching, or one shared corner and
// meeting beyond it (mesh/surface_remesh_intersections.h), among triangles whose boxes share a
// bucket of a spatial hash.
std::size_t crossingPairs(const mesh::TriMesh& m, double bucket) {
  using mesh::remesh::Vec3;
  auto at = [&](std::uint32_t v) { return Vec3{m.positions[v].x, m.positions[v].y, m.positions[v].z}; };
  std::map<std::array<long, 3>, std::vector<std::uint32_t>> buckets;
  for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
    std::array<long, 3> lo{LONG_MAX, LONG_MAX, LONG_MAX}, hi{LONG_MIN, LONG_MIN, LONG_MIN};
    for (std::uint32_t v : m.triangles[t]) {
      const double c[3] = {m.positions[v].x, m.positions[v].y, m.positions[v].z};
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], long(std::floor(c[a] / bucket)));
        hi[a] = std::max(hi[a], long(std::floor(c[a] / bucket)));
      }
    }
    for (long z = lo[2]; z <= hi[2]; ++z)
      for (long y = lo[1]; y <= hi[1]; ++y)
        for (long x = lo[0]; x <= hi[0]; ++x) buckets[{x, y, z}].push_back(t);
  }
  std::size_t crossings = 0;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seen;
  for (const auto& [cell, list] : buckets)
    for (std::size_t i = 0; i < list.size(); ++i)
      for (std::size_t j = i + 1; j < list.size(); ++j) {
        const auto& s = m.triangles[list[i]];
        const auto& t = m.triangles[list[j]];
        int shared = 0, cs = -1, ct = -1;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            if (s[a] == t[b]) ++shared, cs = a, ct = b;
        if (shared >= 2) continue;
        const mesh::remesh::Triangle ts{at(s[0]), at(s[1]), at(s[2])}, tt{at(t[0]), at(t[1]), at(t[2])};
        const bool cross = shared == 0 ? mesh::remesh::trianglesIntersect(ts, tt)
                                       : mesh::remesh::trianglesMeetBeyondCorner(ts, cs, tt, ct);
        if (cross) seen.emplace_back(std::min(list[i], list[j]), std::max(list[i], list[j]));
      }
  std::sort(seen.begin(), seen.end());
  crossings = std::size_t(std::unique(seen.begin(), seen.end()) - seen.begin());
  return crossings;
}

TEST(SharpFeatures, NoTrianglesCross) {
  const Model dice{blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/dice.json").root)};
  for (const Model& m : {model(kBoxMinusCylinder), dice}) {
    for (int resolution : {32, 48}) {
      mesh::TriMesh mesh = meshOf(m, resolution);
      ASSERT_EQ(crossingPairs(mesh, m.grid(resolution).cellSize), 0u) << "marching cubes itself at " << resolution;
      cpu::placeSharpFeatures(mesh, m.grid(resolution));
      EXPECT_EQ(crossingPairs(mesh, m.grid(resolution).cellSize), 0u) << "at " << resolution;
    }
  }
}

TEST(SharpFeatures, SameBytesWhateverTheThreads) {
  const Model m = model(kBoxMinusCylinder);
  mesh::TriMesh one = meshOf(m, 40, 1), two = meshOf(m, 40, 2);
  cpu::placeSharpFeatures(one, m.grid(40));
  cpu::placeSharpFeatures(two, m.grid(40));
  EXPECT_TRUE(one == two);
}

TEST(SharpFeatures, SmoothModelsGetNoFeatureVertex) {
  const Model m = model(kBlend);
  mesh::TriMesh mesh = meshOf(m, 48);
  const mesh::TriMesh before = mesh;
  cpu::FeatureReport report;
  cpu::placeSharpFeatures(mesh, m.grid(48), {}, &report);
  EXPECT_EQ(report.featureCells, 0u);
  EXPECT_TRUE(mesh == before);
}

TEST(SharpFeatures, RefusesMeshesItCannotPlaceInTheGrid) {
  const Model m = model(kBoxMinusCylinder);
  mesh::TriMesh noKeys = meshOf(m, 24);
  noKeys.edgeKeys.clear();
  EXPECT_THROW(cpu::placeSharpFeatures(noKeys, m.grid(24)), std::invalid_argument);
  mesh::TriMesh noNormals = meshOf(m, 24);
  noNormals.normals.clear();
  EXPECT_THROW(cpu::placeSharpFeatures(noNormals, m.grid(24)), std::invalid_argument);
  mesh::TriMesh reordered = meshOf(m, 24);
  std::swap(reordered.triangles.front(), reordered.triangles.back());
  EXPECT_THROW(cpu::placeSharpFeatures(reordered, m.grid(24)), std::invalid_argument);
}

}  // namespace
}  // namespace blobvk::testing
