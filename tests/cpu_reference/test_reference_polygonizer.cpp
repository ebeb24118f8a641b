// The reference polygonizer is checked against geometry it must reproduce (the analytic sphere of
// a point primitive), against its own documented rules recomputed independently here (edge keys,
// linear interpolation, cell locality), and for watertightness on blends.
#include "blobvk/cpu_simd/reference_polygonizer.h"

#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/mesh/checks.h"

#include <gtest/gtest.h>
#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <numbers>
#include <stdexcept>

namespace blobvk {
namespace {

// Radius where (1 - d^2)^3 = 0.5 for unit support: d = sqrt(1 - 0.5^(1/3)).
const double kUnitIsoRadius = std::sqrt(1.0 - std::cbrt(0.5));

blobtree::Node pointNode(glm::dvec3 centre, double support, glm::dvec3 colour = {0.8, 0.8, 0.8}) {
  blobtree::Primitive p;
  p.type = blobtree::PrimitiveType::Point;
  p.a = centre;
  p.support = support;
  p.colour = colour;
  return blobtree::Node{p, "", {}, {}};
}

blobtree::Node blend(std::vector<blobtree::Node> children) {
  blobtree::Operator o;
  o.type = blobtree::OperatorType::Blend;
  return blobtree::Node{o, "", {}, std::move(children)};
}

// Grid covering [-half, half]^3 (plus the centre offset) with the given cell size.
blobtree::GridSpec cubeGrid(glm::vec3 centre, float half, float cellSize) {
  blobtree::GridSpec g;
  const int cells = int(std::ceil(2.0f * half / cellSize));
  g.origin = centre - glm::vec3(0.5f * float(cells) * cellSize);
  g.cellSize = cellSize;
  g.cells = glm::ivec3(cells);
  return g;
}

struct DecodedKey {
  int i, j, k, axis;
};
DecodedKey decode(const blobtree::GridSpec& g, std::uint64_t key) {
  const glm::ivec3 p = g.points();
  const int axis = int(key % 3);
  std::uint64_t point = key / 3;
  const int i = int(point % std::uint64_t(p.x));
  point /= std::uint64_t(p.x);
  const int j = int(point % std::uint64_t(p.y));
  const int k = int(point / std::uint64_t(p.y));
  return {i, j, k, axis};
}

TEST(ReferencePolygonizer, IsoRadiusConstant) { EXPECT_NEAR(kUnitIsoRadius, 0.45420206, 1e-7); }

class SphereVolume : public ::testing::TestWithParam<double> {};

TEST_P(SphereVolume, PointPrimitiveEnclosesTheAnalyticSphere) {
  const double support = GetParam();
  const glm::vec3 centre(0.3f, -0.2f, 0.1f);
  const blobtree::Program program = blobtree::compile(pointNode(glm::dvec3(centre), support));
  const blobtree::GridSpec grid = cubeGrid(centre, float(0.6 * support), float(0.02 * support));
  const mesh::TriMesh m = cpu::polygonizeReference(program, grid);
  const mesh::MeshReport r = mesh::checkMesh(m);
  ASSERT_TRUE(r.watertight()) << r.summary();
  EXPECT_EQ(r.eulerCharacteristic, 2);
  EXPECT_EQ(r.components, 1u);
  const double radius = kUnitIsoRadius * support;
  const double expected = 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
  EXPECT_NEAR(r.volume / expected, 1.0, 0.01) << r.summary();
  // Every vertex lies on the sphere to well within a cell.
  for (const auto& p : m.positions) {
    const double d = glm::length(glm::dvec3(p.x, p.y, p.z) - glm::dvec3(centre));
    EXPECT_NEAR(d, radius, 0.2 * grid.cellSize);
  }
}

INSTANTIATE_TEST_SUITE_P(Supports, SphereVolume, ::testing::Values(1.0, 2.5));

TEST(ReferencePolygonizer, VerticesFollowTheDocumentedEdgeRule) {
  const blobtree::Program program = blobtree::compile(pointNode({0.05, 0.0, -0.03}, 1.0));
  const blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 0.6f, 0.07f);
  cpu::ReferenceOptions options;
  options.normals = false;
  options.colours = false;
  const mesh::TriMesh m = cpu::polygonizeReference(program, grid, options);
  ASSERT_GT(m.vertexCount(), 100u);
  ASSERT_EQ(m.edgeKeys.size(), m.vertexCount());
  EXPECT_TRUE(m.normals.empty());
  EXPECT_TRUE(m.colours.empty());
  for (std::size_t v = 0; v < m.vertexCount(); ++v) {
    if (v > 0) {
      ASSERT_LT(m.edgeKeys[v - 1], m.edgeKeys[v]) << "keys not strictly increasing at " << v;
    }
    const DecodedKey e = decode(grid, m.edgeKeys[v]);
    ASSERT_EQ(grid.edgeKey(e.i, e.j, e.k, e.axis), m.edgeKeys[v]);
    glm::ivec3 end(e.i, e.j, e.k);
    end[e.axis] += 1;
    const glm::vec3 a = grid.point(e.i, e.j, e.k), b = grid.point(end.x, end.y, end.z);
    const float fa = blobtree::evaluate(program, a), fb = blobtree::evaluate(program, b);
    ASSERT_NE(fa >= layout::ISO_VALUE, fb >= layout::ISO_VALUE) << "vertex on a non-crossing edge";
    // Kept 2^-12 of the edge from either end (rule 2): no two vertices on one grid point.
    const float t = std::min(std::max((layout::ISO_VALUE - fa) / (fb - fa), 0.000244140625f), 0.999755859375f);
    glm::vec3 expected = a;
    expected[e.axis] = a[e.axis] + t * (b[e.axis] - a[e.axis]);
    EXPECT_EQ(m.positions[v], (mesh::Float3{expected.x, expected.y, expected.z})) << "vertex " << v;
  }
  // Every crossing edge has its vertex: count the crossing edges independently.
  std::size_t crossings = 0;
  const glm::ivec3 pts = grid.points();
  for (int k = 0; k < pts.z; ++k)
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i)
        for (int axis = 0; axis < 3; ++axis) {
          glm::ivec3 end(i, j, k);
          end[axis] += 1;
          if (end[axis] >= pts[axis]) continue;
          const bool ia = blobtree::evaluate(program, grid.point(i, j, k)) >= layout::ISO_VALUE;
          const bool ib = blobtree::evaluate(program, grid.point(end.x, end.y, end.z)) >= layout::ISO_VALUE;
          crossings += ia != ib;
        }
  EXPECT_EQ(crossings, m.vertexCount());
}

TEST(ReferencePolygonizer, TrianglesStayInOneCellInCellOrder) {
  const blobtree::Program program = blobtree::compile(
      blend({pointNode({-0.3, 0, 0}, 1.0), pointNode({0.35, 0.1, 0}, 0.8)}));
  const blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 1.1f, 0.09f);
  const mesh::TriMesh m = cpu::polygonizeReference(program, grid, {false, false, 0});
  ASSERT_GT(m.triangleCount(), 0u);
  // The cells that own an edge: the 4 cells around it. A triangle's cell is in the intersection
  // of its three edges' cells; cell order means those indices never go back.
  const auto cellsOfEdge = [&](const DecodedKey& e) {
    std::set<std::uint64_t> cells;
    for (int du = 0; du < 2; ++du)
      for (int dv = 0; dv < 2; ++dv) {
        glm::ivec3 c(e.i, e.j, e.k);
        c[(e.axis + 1) % 3] -= du;
        c[(e.axis + 2) % 3] -= dv;
        if (glm::any(glm::lessThan(c, glm::ivec3(0))) || glm::any(glm::greaterThanEqual(c, grid.cells))) continue;
        cells.insert(grid.pointIndex(c.x, c.y, c.z));
      }
    return cells;
  };
  std::uint64_t lastCell = 0;
  for (const auto& tri : m.triangles) {
    std::set<std::uint64_t> common = cellsOfEdge(decode(grid, m.edgeKeys[tri[0]]));
    for (int v = 1; v < 3; ++v) {
      const std::set<std::uint64_t> cells = cellsOfEdge(decode(grid, m.edgeKeys[tri[std::size_t(v)]]));
      std::set<std::uint64_t> both;
      std::set_intersection(common.begin(), common.end(), cells.begin(), cells.end(),
                            std::inserter(both, both.begin()));
      common = both;
    }
    ASSERT_FALSE(common.empty()) << "triangle spans more than one cell";
    ASSERT_LE(lastCell, *common.rbegin()) << "triangles out of cell order";
    lastCell = std::max(lastCell, *common.begin());
  }
}

TEST(ReferencePolygonizer, BlendIsWatertightAndTwoSpheresApartAreTwoComponents) {
  const blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 1.3f, 0.05f);
  const mesh::MeshReport joined = mesh::checkMesh(cpu::polygonizeReference(
      blobtree::compile(blend({pointNode({-0.3, 0, 0}, 1.0), pointNode({0.3, 0, 0}, 1.0)})), grid));
  EXPECT_TRUE(joined.watertight()) << joined.summary();
  EXPECT_EQ(joined.components, 1u);
  EXPECT_EQ(joined.eulerCharacteristic, 2);
  const mesh::MeshReport apart = mesh::checkMesh(cpu::polygonizeReference(
      blobtree::compile(blend({pointNode({-0.7, 0, 0}, 0.5), pointNode({0.7, 0, 0}, 0.5)})), grid));
  EXPECT_TRUE(apart.watertight()) << apart.summary();
  EXPECT_EQ(apart.components, 2u);
  EXPECT_EQ(apart.eulerCharacteristic, 4);
}

TEST(ReferencePolygonizer, RefinementLandsOnTheIsoSurface) {
  const glm::dvec3 centre(0.013, -0.021, 0.007);
  const blobtree::Program program = blobtree::compile(pointNode(centre, 1.0));
  const blobtree::GridSpec grid = cubeGrid(glm::vec3(centre), 0.6f, 0.1f);
  const mesh::TriMesh linear = cpu::polygonizeReference(program, grid, {false, false, 0});
  const mesh::TriMesh refined = cpu::polygonizeReference(program, grid, {false, false, 8});
  ASSERT_EQ(linear.edgeKeys, refined.edgeKeys);  // same topology, only positions move
  ASSERT_EQ(linear.triangles, refined.triangles);
  double linearError = 0.0;
  for (std::size_t v = 0; v < refined.vertexCount(); ++v) {
    const auto dist = [&](const mesh::Float3& p) {
      return std::abs(glm::length(glm::dvec3(p.x, p.y, p.z) - centre) - kUnitIsoRadius);
    };
    // Along a grid edge the crossing is where the sphere meets it; the distance to the sphere
    // bounds the distance to that crossing from below, so check the field value instead too.
    EXPECT_LT(dist(refined.positions[v]), 1e-3 * grid.cellSize) << "vertex " << v;
    const auto& p = refined.positions[v];
    EXPECT_NEAR(blobtree::evaluate(program, {p.x, p.y, p.z}), layout::ISO_VALUE, 1e-4);
    linearError = std::max(linearError, dist(linear.positions[v]));
  }
  EXPECT_GT(linearError, 1e-3 * grid.cellSize);  // refinement had something to fix
}

TEST(ReferencePolygonizer, NormalsPointOutAndColoursComeFromThePrimitive) {
  const glm::dvec3 centre(0.0, 0.1, 0.0);
  const blobtree::Program program = blobtree::compile(pointNode(centre, 1.0, {0.2, 0.4, 0.6}));
  const mesh::TriMesh m = cpu::polygonizeReference(program, cubeGrid(glm::vec3(centre), 0.6f, 0.05f));
  ASSERT_EQ(m.normals.size(), m.vertexCount());
  ASSERT_EQ(m.colours.size(), m.vertexCount());
  for (std::size_t v = 0; v < m.vertexCount(); ++v) {
    const glm::dvec3 n(m.normals[v].x, m.normals[v].y, m.normals[v].z);
    const glm::dvec3 radial =
        glm::normalize(glm::dvec3(m.positions[v].x, m.positions[v].y, m.positions[v].z) - centre);
    EXPECT_NEAR(glm::length(n), 1.0, 1e-4);
    EXPECT_GT(glm::dot(n, radial), 0.999);
    EXPECT_NEAR(m.colours[v].x, 0.2f, 1e-6);
    EXPECT_NEAR(m.colours[v].y, 0.4f, 1e-6);
    EXPECT_NEAR(m.colours[v].z, 0.6f, 1e-6);
  }
  // Triangle winding agrees with the normals: outward.
  for (const auto& t : m.triangles) {
    const auto P = [&](std::uint32_t i) { return glm::dvec3(m.positions[i].x, m.positions[i].y, m.positions[i].z); };
    const glm::dvec3 face = glm::cross(P(t[1]) - P(t[0]), P(t[2]) - P(t[0]));
    const glm::dvec3 n(m.normals[t[0]].x, m.normals[t[0]].y, m.normals[t[0]].z);
    EXPECT_GE(glm::dot(face, n), 0.0);
  }
}

TEST(ReferencePolygonizer, DeterministicAcrossRuns) {
  const blobtree::Program program = blobtree::compile(
      blend({pointNode({-0.2, 0, 0}, 1.0), pointNode({0.25, 0.1, 0}, 0.7)}));
  const blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 1.0f, 0.08f);
  EXPECT_EQ(cpu::polygonizeReference(program, grid), cpu::polygonizeReference(program, grid));
}

TEST(ReferencePolygonizer, EmptyGridsAndBadOptions) {
  const blobtree::Program program = blobtree::compile(pointNode({0, 0, 0}, 1.0));
  blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 0.6f, 0.1f);
  grid.cells.y = 0;
  EXPECT_EQ(cpu::polygonizeReference(program, grid).vertexCount(), 0u);
  grid = cubeGrid({5, 5, 5}, 0.6f, 0.1f);  // far from the primitive: nothing crosses
  EXPECT_EQ(cpu::polygonizeReference(program, grid).triangleCount(), 0u);
  grid.cellSize = 0.0f;
  EXPECT_THROW(cpu::polygonizeReference(program, grid), std::invalid_argument);
  grid = cubeGrid({0, 0, 0}, 0.6f, 0.1f);
  EXPECT_THROW(cpu::polygonizeReference(program, grid, {true, true, -1}), std::invalid_argument);
}

TEST(ReferencePolygonizer, SurfaceCutByTheGridBorderIsOpenButManifold) {
  const blobtree::Program program = blobtree::compile(pointNode({0, 0, 0}, 1.0));
  blobtree::GridSpec grid = cubeGrid({0, 0, 0}, 0.6f, 0.05f);
  grid.cells.x /= 2;  // the grid ends at the sphere's middle
  const mesh::MeshReport r = mesh::checkMesh(cpu::polygonizeReference(program, grid));
  EXPECT_GT(r.boundaryEdges, 0u);
  EXPECT_TRUE(r.manifold() && r.oriented()) << r.summary();
}

}  // namespace
}  // namespace blobvk
