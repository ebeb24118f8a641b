// remeshSurface on marching-cubes surfaces of analytic implicit models (a blended pair of
// spheres, a torus): the input has the near-degenerate triangles of real polygonizations, the
// output must keep the topology and the volume and have no thin triangles.
#include "cube_mesh.h"
#include "grid_mc.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/surface_remesh.h"

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

// Smallest corner angle (degrees) of `m`, from the law of cosines on the side lengths (written
// apart from mesh::minTriangleAngleDegrees, which the remesher's statistics use).
double smallestCornerAngle(const mesh::TriMesh& m) {
  double best = 180;
  for (const auto& t : m.triangles) {
    double side[3];
    for (int k = 0; k < 3; ++k) {
      const mesh::Float3 &a = m.positions[t[std::size_t((k + 1) % 3)]], &b = m.positions[t[std::size_t((k + 2) % 3)]];
      side[k] = std::hypot(double(a.x) - b.x, double(a.y) - b.y, double(a.z) - b.z);  // opposite corner k
    }
    for (int k = 0; k < 3; ++k) {
      const double a = side[k], b = side[(k + 1) % 3], c = side[(k + 2) % 3];
      best = std::min(best, std::acos(std::clamp((b * b + c * c - a * a) / (2 * b * c), -1.0, 1.0)) * 180 / M_PI);
    }
  }
  return best;
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
  EXPECT_GT(smallestCornerAngle(out), 25.0);
  EXPECT_NEAR(stats.minAngleAfterDegrees, smallestCornerAngle(out), 1e-6);
  EXPECT_NEAR(stats.minAngleBeforeDegrees, smallestCornerAngle(input), 1e-6);
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
  EXPECT_GT(smallestCornerAngle(out), 25.0);
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

// A shell between a sphere of radius 0.9 and an off-centre one of radius 0.8 (0.5 + the signed
// distance inside): 0.05 to 0.15 thick (1 to 3 cells at 48 cells), so its two sides come closer
// than a 2-cell target edge on one side, as in the shipped eggshell.
double shell(const mesh::Double3& p) {
  const double outer = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
  const double inner = std::sqrt(p.x * p.x + (p.y - 0.05) * (p.y - 0.05) + p.z * p.z);
  return kIso + std::min(0.9 - outer, inner - 0.8);
}

struct Point {
  double x, y, z;
};
Point operator-(const Point& a, const Point& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(const Point& a, const Point& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Point cross(const Point& a, const Point& b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

// Möller-Trumbore: whether segment p-q passes through triangle abc (written apart from the
// remesher's own test, which this checks).
bool segmentHits(const Point& p, const Point& q, const Point& a, const Point& b, const Point& c) {
  const Point d = q - p, e1 = b - a, e2 = c - a, h = cross(d, e2);
  const double det = dot(e1, h);
  if (std::abs(det) < 1e-300) return false;
  const Point s = p - a;
  const double u = dot(s, h) / det;
  const Point qv = cross(s, e1);
  const double v = dot(d, qv) / det, t = dot(e2, qv) / det;
  return u >= 0 && v >= 0 && u + v <= 1 && t >= 0 && t <= 1;
}

// Pairs of triangles of `m` that cross (a sweep along x over bounding-box overlaps). Triangles
// with one common vertex count when an edge opposite it crosses the other; edge neighbours do not.
std::size_t crossingPairs(const mesh::TriMesh& m) {
  const auto at = [&](std::uint32_t v) { return Point{m.positions[v].x, m.positions[v].y, m.positions[v].z}; };
  const auto xs = [&](std::size_t f, bool high) {
    const auto& t = m.triangles[f];
    const auto x = [&](int k) { return m.positions[t[std::size_t(k)]].x; };
    return high ? std::max({x(0), x(1), x(2)}) : std::min({x(0), x(1), x(2)});
  };
  std::vector<std::size_t> order(m.triangles.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return xs(a, false) < xs(b, false); });
  std::size_t count = 0;
  for (std::size_t oi = 0; oi < order.size(); ++oi)
    for (std::size_t oj = oi + 1; oj < order.size() && xs(order[oj], false) <= xs(order[oi], true); ++oj) {
      const auto &s = m.triangles[order[oi]], &t = m.triangles[order[oj]];
      bool apart = false;
      for (int axis = 1; axis < 3 && !apart; ++axis) {
        const auto c = [&](std::uint32_t v) { const auto& p = m.positions[v]; return axis == 0 ? p.x : axis == 1 ? p.y : p.z; };
        apart = std::max({c(s[0]), c(s[1]), c(s[2])}) < std::min({c(t[0]), c(t[1]), c(t[2])}) ||
                std::max({c(t[0]), c(t[1]), c(t[2])}) < std::min({c(s[0]), c(s[1]), c(s[2])});
      }
      if (apart) continue;
      int shared = 0;
      for (std::uint32_t a : s)
        for (std::uint32_t b : t) shared += a == b;
      if (shared >= 2) continue;
      bool hit = false;
      for (int k = 0; k < 3 && !hit; ++k) {
        const std::uint32_t sa = s[std::size_t(k)], sb = s[std::size_t((k + 1) % 3)];
        const std::uint32_t ta = t[std::size_t(k)], tb = t[std::size_t((k + 1) % 3)];
        const bool sEdgeFree = std::find(t.begin(), t.end(), sa) == t.end() && std::find(t.begin(), t.end(), sb) == t.end();
        const bool tEdgeFree = std::find(s.begin(), s.end(), ta) == s.end() && std::find(s.begin(), s.end(), tb) == s.end();
        hit = (sEdgeFree && segmentHits(at(sa), at(sb), at(t[0]), at(t[1]), at(t[2]))) ||
              (tEdgeFree && segmentHits(at(ta), at(tb), at(s[0]), at(s[1]), at(s[2])));
      }
      count += hit;
    }
  return count;
}



TEST(SurfaceRemesh, ThinShellDoesNotFoldIntoItself) {
  double h = 0;
  const mesh::TriMesh input = polygonize(shell, 48, h);
  ASSERT_TRUE(mesh::checkMesh(input).watertight());
  mesh::SurfaceRemeshOptions o = optionsFor(shell, h, 2.0);
  mesh::SurfaceRemeshStats stats;
  const mesh::TriMesh out = mesh::remeshSurface(input, o, &stats);
  expectSameTopologyAndVolume(input, out, 0.05);
  EXPECT_EQ(crossingPairs(out), 0u);
  EXPECT_GT(stats.undoneMoves, 0u);  // the guard had work to do
  // Without the guard the same clean-up does fold the shell: the check above can fail.
  o.preventSelfIntersections = false;
  EXPECT_GT(crossingPairs(mesh::remeshSurface(input, o)), 0u);
}

TEST(SurfaceRemesh, BatchProjectionGivesTheScalarProjectionsPoints) {
  const mesh::SurfaceProjection one = mesh::isoSurfaceProjection(peanut, kIso, 1e-4);
  const mesh::SurfaceProjectionBatch many = mesh::isoSurfaceProjectionBatch(
      [](const std::vector<mesh::Double3>& points, std::vector<double>& values) {
        values.resize(points.size());
        for (std::size_t i = 0; i < points.size(); ++i) values[i] = peanut(points[i]);
      },
      kIso, 1e-4);
  std::vector<mesh::Double3> points;
  for (int i = 0; i < 50; ++i) points.push_back({-1.0 + 0.04 * i, 0.3 * std::sin(i), 0.2 * std::cos(i)});
  points.push_back({0, 5, 0});  // outside every kernel: zero gradient, the point stays
  std::vector<mesh::Double3> projected = points;
  many(projected);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(projected[i], one(points[i])) << i;
  EXPECT_EQ(projected.back(), points.back());
  EXPECT_NEAR(peanut(projected[25]), kIso, 1e-3);
}

TEST(SurfaceRemesh, BatchProjectionIsUsedWhenGiven) {
  double h = 0;
  const mesh::TriMesh input = polygonize(peanut, 32, h);
  mesh::SurfaceRemeshOptions o;
  o.targetEdgeLength = 1.5 * h;
  std::size_t calls = 0, points = 0;
  o.projectBatch = [&, project = mesh::isoSurfaceProjection(peanut, kIso, 1e-3 * h)](std::vector<mesh::Double3>& p) {
    ++calls;
    points += p.size();
    for (mesh::Double3& q : p) q = project(q);
  };
  const mesh::TriMesh out = mesh::remeshSurface(input, o);
  expectSameTopologyAndVolume(input, out, 0.01);
  EXPECT_GT(calls, 0u);
  EXPECT_GT(points, 5 * out.positions.size());  // every vertex in each of the 5 relaxation rounds
  for (const mesh::Float3& v : out.positions) ASSERT_NEAR(peanut({v.x, v.y, v.z}), kIso, 1e-3);
}

}  // namespace
}  // namespace blobvk
