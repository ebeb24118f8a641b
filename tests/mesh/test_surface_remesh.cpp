// remeshSurface on marching-cubes surfaces of analytic implicit models (a blended pair of
// spheres, a torus): the input has the near-degenerate triangles of real polygonizations, the
// output must keep the topology and the volume and have no thin triangles.
#include "cube_mesh.h"
#include "grid_mc.h"

#include "mesh/checks.h"
#include "mesh/surface_remesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>

namespace blobvk {
namespace {

using Field = std::function<double(const mesh::Double3&)>;
constexpr double kIso = 0.5;

// Two Wyvill-kernel spheres, blended (summed): inside where the field >= 0.5.
double peanut(const mesh::Double3& p) {
  const auto kernel = [](double d2) { return d2 < 1 ? (1 - d2) * (1 - d2) * (1 - d2) : 0.0; };
  const auto sphere = [&](double cx) { return kernel(((p.x - cx) * (p.x - cx) + p.y * p.y + p.z * p.z) / 0.81); };
  return sphere(-0.45) + sphere(0.45);
}

// A torus (radii 0.6 and 0.25) as 0.5 + signed distance inside.
double torus(const mesh::Double3& p) {
  const double ring = std::sqrt(p.x * p.x + p.y * p.y) - 0.6;
  return kIso + 0.25 - std::sqrt(ring * ring + p.z * p.z);
}

// Marching cubes over [-1.2, 1.2]^3 with `cells` cells per axis: the case table of
// testing::polygonizeSigns, then each vertex slid from its edge midpoint to the linearly
// interpolated crossing, as a real polygonizer places it (this is what makes slivers).
mesh::TriMesh polygonize(const Field& field, int cells, double& cellSize) {
  const double lo = -1.2;
  cellSize = 2.4 / cells;
  const double h = cellSize;
  testing::SignGrid grid;
  grid.n = cells + 1;
  grid.inside.resize(std::size_t(grid.n) * std::size_t(grid.n) * std::size_t(grid.n));
  const auto world = [&](double i, double j, double k) { return mesh::Double3{lo + h * i, lo + h * j, lo + h * k}; };
  for (int k = 0; k < grid.n; ++k)
    for (int j = 0; j < grid.n; ++j)
      for (int i = 0; i < grid.n; ++i)
        grid.inside[std::size_t((k * grid.n + j) * grid.n + i)] = field(world(i, j, k)) >= kIso;
  mesh::TriMesh m = testing::polygonizeSigns(grid);
  for (mesh::Float3& v : m.positions) {
    double c[3] = {v.x, v.y, v.z}, a[3], b[3];
    for (int axis = 0; axis < 3; ++axis) {
      a[axis] = std::floor(c[axis]);
      b[axis] = c[axis] == a[axis] ? a[axis] : a[axis] + 1;  // the midpoint's axis gets +1
    }
    const double fa = field(world(a[0], a[1], a[2])), fb = field(world(b[0], b[1], b[2]));
    const double t = (kIso - fa) / (fb - fa);
    const mesh::Double3 pa = world(a[0], a[1], a[2]), pb = world(b[0], b[1], b[2]);
    v = {float(pa.x + t * (pb.x - pa.x)), float(pa.y + t * (pb.y - pa.y)), float(pa.z + t * (pb.z - pa.z))};
  }
  return m;
}

mesh::SurfaceRemeshOptions optionsFor(const Field& field, double cellSize, double edgeCells = 1.5) {
  mesh::SurfaceRemeshOptions o;
  o.targetEdgeLength = edgeCells * cellSize;
  o.project = mesh::isoSurfaceProjection(field, kIso, 1e-3 * cellSize);
  return o;
}

void expectSameTopologyAndVolume(const mesh::TriMesh& before, const mesh::TriMesh& after, double volumeTolerance) {
  const mesh::MeshReport a = mesh::checkMesh(before), b = mesh::checkMesh(after);
  EXPECT_TRUE(b.watertight()) << b.summary();
  EXPECT_EQ(b.unreferencedVertices, 0u);
  EXPECT_EQ(b.eulerCharacteristic, a.eulerCharacteristic);
  EXPECT_EQ(b.components, a.components);
  EXPECT_NEAR(b.volume / a.volume, 1.0, volumeTolerance);
}

TEST(SurfaceRemesh, PeanutKeepsTopologyAndVolumeAndLosesItsSlivers) {
  double h = 0;
  const mesh::TriMesh input = polygonize(peanut, 40, h);
  ASSERT_TRUE(mesh::checkMesh(input).watertight());
  mesh::SurfaceRemeshStats stats;
  const mesh::TriMesh out = mesh::remeshSurface(input, optionsFor(peanut, h), &stats);
  expectSameTopologyAndVolume(input, out, 0.01);
  EXPECT_LT(stats.minAngleBeforeDegrees, 5.0);  // the input really has marching-cubes slivers
  EXPECT_GT(stats.minAngleAfterDegrees, 25.0);
  EXPECT_DOUBLE_EQ(stats.minAngleAfterDegrees, mesh::minTriangleAngleDegrees(out));
  EXPECT_GT(stats.splits + stats.collapses, 0u);
  EXPECT_GT(stats.flips, 0u);
}

TEST(SurfaceRemesh, VerticesEndOnTheImplicitSurfaceWithEdgesNearTheTarget) {
  double h = 0;
  const mesh::TriMesh input = polygonize(peanut, 40, h);
  const mesh::SurfaceRemeshOptions o = optionsFor(peanut, h);
  const mesh::TriMesh out = mesh::remeshSurface(input, o);
  for (const mesh::Float3& v : out.positions) ASSERT_NEAR(peanut({v.x, v.y, v.z}), kIso, 1e-3);
  double longest = 0;
  for (const auto& t : out.triangles)
    for (int k = 0; k < 3; ++k) {
      const mesh::Float3 &a = out.positions[t[std::size_t(k)]], &b = out.positions[t[std::size_t((k + 1) % 3)]];
      longest = std::max(longest, std::hypot(double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z));
    }
  EXPECT_LT(longest, 2.0 * o.targetEdgeLength);
}

TEST(SurfaceRemesh, TorusKeepsGenusOne) {
  double h = 0;
  const mesh::TriMesh input = polygonize(torus, 48, h);
  ASSERT_EQ(mesh::checkMesh(input).eulerCharacteristic, 0);
  mesh::SurfaceRemeshStats stats;
  const mesh::TriMesh out = mesh::remeshSurface(input, optionsFor(torus, h), &stats);
  expectSameTopologyAndVolume(input, out, 0.01);
  EXPECT_GT(stats.minAngleAfterDegrees, 25.0);
}

TEST(SurfaceRemesh, CoarseTargetWithoutProjectionStaysClosed) {
  double h = 0;
  const mesh::TriMesh input = polygonize(peanut, 32, h);
  mesh::SurfaceRemeshOptions o;
  o.targetEdgeLength = 2.0 * h;  // no projection: tangential moves only
  const mesh::TriMesh out = mesh::remeshSurface(input, o);
  // Without a projection the chords cut corners round by round: the topology holds, the volume
  // shrinks by a few percent (which is why the callers pass the implicit surface).
  expectSameTopologyAndVolume(input, out, 0.1);
  EXPECT_LT(out.triangles.size(), input.triangles.size());
}

TEST(SurfaceRemesh, SameInputGivesTheSameOutput) {
  double h = 0;
  const mesh::TriMesh input = polygonize(torus, 32, h);
  EXPECT_EQ(mesh::remeshSurface(input, optionsFor(torus, h)), mesh::remeshSurface(input, optionsFor(torus, h)));
}

TEST(SurfaceRemesh, RejectsOpenSurfacesAndBadTargets) {
  mesh::TriMesh open = testing::unitCube();
  open.triangles.pop_back();
  mesh::SurfaceRemeshOptions o;
  o.targetEdgeLength = 0.5;
  EXPECT_THROW(mesh::remeshSurface(open, o), std::invalid_argument);
  o.targetEdgeLength = 0;
  EXPECT_THROW(mesh::remeshSurface(testing::unitCube(), o), std::invalid_argument);
  EXPECT_THROW(mesh::isoSurfaceProjection(peanut, kIso, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace blobvk
