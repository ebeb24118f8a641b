// The case table is tested against properties of the rule, not against a typed-in table:
// every case is a set of closed, consistently directed loops over exactly the crossing edges,
// the table commutes with cube rotations, and polygonized sign grids are watertight and outward.
#include "grid_mc.h"

#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/marching_cubes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

namespace blobvk {
namespace {

using mesh::marchingCubesCases;

bool crosses(int config, int e) {
  return (((config >> mesh::mcEdgeStartCorner(e)) ^ (config >> mesh::mcEdgeEndCorner(e))) & 1) != 0;
}

// The two cube faces (axis, side) an edge lies on.
std::set<std::pair<int, int>> facesOfEdge(int e) {
  const auto s = mesh::mcEdgeStart(e);
  std::set<std::pair<int, int>> faces;
  for (int d = 0; d < 3; ++d)
    if (d != mesh::mcEdgeAxis(e)) faces.insert({d, s[std::size_t(d)]});
  return faces;
}

TEST(MarchingCubes, EdgeHelpersMatchTheHeaderNumbering) {
  // Edge e runs along axis e / 4; the x edges start at (0, e & 1, (e >> 1) & 1).
  EXPECT_EQ(mesh::mcEdgeStartCorner(0), 0);
  EXPECT_EQ(mesh::mcEdgeEndCorner(0), 1);
  EXPECT_EQ(mesh::mcEdgeStartCorner(3), 6);   // x edge at y = 1, z = 1
  EXPECT_EQ(mesh::mcEdgeStartCorner(5), 1);   // y edge at x = 1, z = 0
  EXPECT_EQ(mesh::mcEdgeEndCorner(5), 3);
  EXPECT_EQ(mesh::mcEdgeStartCorner(10), 2);  // z edge at x = 0, y = 1
  EXPECT_EQ(mesh::mcEdgeEndCorner(10), 6);
}

TEST(MarchingCubes, EmptyAndFullCasesHaveNoTriangles) {
  EXPECT_EQ(marchingCubesCases()[0].triangleCount, 0);
  EXPECT_EQ(marchingCubesCases()[255].triangleCount, 0);
}

TEST(MarchingCubes, EveryCaseUsesExactlyTheCrossingEdges) {
  for (int config = 0; config < 256; ++config) {
    const mesh::McCase& mc = marchingCubesCases()[std::size_t(config)];
    ASSERT_LE(mc.triangleCount, 5);
    std::set<int> used;
    for (int i = 0; i < 3 * mc.triangleCount; ++i) used.insert(mc.edges[std::size_t(i)]);
    for (int e = 0; e < 12; ++e)
      EXPECT_EQ(used.count(e) == 1, crosses(config, e)) << "config " << config << " edge " << e;
  }
}

TEST(MarchingCubes, EveryCaseBoundaryIsClosedLoopsOfFaceSegments) {
  for (int config = 1; config < 255; ++config) {
    const mesh::McCase& mc = marchingCubesCases()[std::size_t(config)];
    // Directed triangle sides; interior (fan) sides cancel with their reverse.
    std::map<std::pair<int, int>, int> sides;
    for (int t = 0; t < mc.triangleCount; ++t)
      for (int k = 0; k < 3; ++k) {
        const int a = mc.edges[std::size_t(3 * t + k)], b = mc.edges[std::size_t(3 * t + (k + 1) % 3)];
        ASSERT_NE(a, b) << "degenerate triangle in config " << config;
        const auto reverse = sides.find({b, a});
        if (reverse != sides.end() && reverse->second > 0) --reverse->second;
        else ++sides[{a, b}];
      }
    std::map<int, int> out, in;
    for (const auto& [side, count] : sides) {
      if (count == 0) {
        // An interior diagonal must not join two crossings of one face: the neighbour across it
        // could use the same diagonal, and the mesh edge would carry four triangles.
        const auto fa = facesOfEdge(side.first), fb = facesOfEdge(side.second);
        std::vector<std::pair<int, int>> common;
        std::set_intersection(fa.begin(), fa.end(), fb.begin(), fb.end(), std::back_inserter(common));
        EXPECT_TRUE(common.empty()) << "config " << config << " diagonal " << side.first << "-" << side.second;
        continue;
      }
      EXPECT_EQ(count, 1) << "config " << config;
      ++out[side.first];
      ++in[side.second];
      // A boundary segment of the cell's polygon lies on one cube face.
      std::set<std::pair<int, int>> common;
      const auto fa = facesOfEdge(side.first), fb = facesOfEdge(side.second);
      std::set_intersection(fa.begin(), fa.end(), fb.begin(), fb.end(),
                            std::inserter(common, common.begin()));
      EXPECT_EQ(common.size(), 1u) << "config " << config << " segment " << side.first << "->" << side.second;
    }
    for (int e = 0; e < 12; ++e) {
      const int expected = crosses(config, e) ? 1 : 0;
      EXPECT_EQ(out[e], expected) << "config " << config << " edge " << e;
      EXPECT_EQ(in[e], expected) << "config " << config << " edge " << e;
    }
  }
}

TEST(MarchingCubes, ComplementUsesTheSameEdges) {
  for (int config = 0; config < 256; ++config) {
    const auto& a = marchingCubesCases()[std::size_t(config)];
    const auto& b = marchingCubesCases()[std::size_t(255 - config)];
    std::set<int> ea(a.edges.begin(), a.edges.begin() + 3 * a.triangleCount);
    std::set<int> eb(b.edges.begin(), b.edges.begin() + 3 * b.triangleCount);
    EXPECT_EQ(ea, eb) << "config " << config;
  }
}

// The 24 rotations of the cube as corner permutations.
std::vector<std::array<int, 8>> cubeRotations() {
  const auto corner = [](int x, int y, int z) { return x | (y << 1) | (z << 2); };
  std::array<int, 8> aboutX{}, aboutZ{};
  for (int c = 0; c < 8; ++c) {
    const int x = c & 1, y = (c >> 1) & 1, z = (c >> 2) & 1;
    aboutX[std::size_t(c)] = corner(x, 1 - z, y);
    aboutZ[std::size_t(c)] = corner(1 - y, x, z);
  }
  std::set<std::array<int, 8>> group{{0, 1, 2, 3, 4, 5, 6, 7}};
  for (bool grew = true; grew;) {
    grew = false;
    for (const auto& g : std::vector<std::array<int, 8>>(group.begin(), group.end()))
      for (const auto& r : {aboutX, aboutZ}) {
        std::array<int, 8> composed{};
        for (int c = 0; c < 8; ++c) composed[std::size_t(c)] = r[std::size_t(g[std::size_t(c)])];
        grew |= group.insert(composed).second;
      }
  }
  return {group.begin(), group.end()};
}

TEST(MarchingCubes, TriangleCountIsInvariantUnderRotation) {
  const auto rotations = cubeRotations();
  ASSERT_EQ(rotations.size(), 24u);
  for (int config = 0; config < 256; ++config)
    for (const auto& r : rotations) {
      int rotated = 0;
      for (int c = 0; c < 8; ++c)
        if ((config >> c) & 1) rotated |= 1 << r[std::size_t(c)];
      EXPECT_EQ(marchingCubesCases()[std::size_t(config)].triangleCount,
                marchingCubesCases()[std::size_t(rotated)].triangleCount)
          << config << " -> " << rotated;
    }
}

TEST(MarchingCubes, SingleInsideCornerAtOriginFacesAwayFromIt) {
  const mesh::McCase& mc = marchingCubesCases()[1];
  ASSERT_EQ(mc.triangleCount, 1);
  const auto midpoint = [](int e) {
    const auto s = mesh::mcEdgeStart(e);
    std::array<double, 3> p = {double(s[0]), double(s[1]), double(s[2])};
    p[std::size_t(mesh::mcEdgeAxis(e))] += 0.5;
    return p;
  };
  const auto a = midpoint(mc.edges[0]), b = midpoint(mc.edges[1]), c = midpoint(mc.edges[2]);
  const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
  const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
  const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  EXPECT_GT(nx, 0.0);
  EXPECT_GT(ny, 0.0);
  EXPECT_GT(nz, 0.0);
}

testing::SignGrid emptyGrid(int n) {
  testing::SignGrid g;
  g.n = n;
  g.inside.assign(std::size_t(n * n * n), false);
  return g;
}

TEST(MarchingCubes, IsolatedInsidePointGivesTheUnitOctahedron) {
  testing::SignGrid g = emptyGrid(3);
  g.inside[std::size_t((1 * 3 + 1) * 3 + 1)] = true;
  const mesh::MeshReport r = mesh::checkMesh(testing::polygonizeSigns(g));
  EXPECT_TRUE(r.watertight()) << r.summary();
  EXPECT_EQ(r.vertices, 6u);
  EXPECT_EQ(r.triangles, 8u);
  EXPECT_EQ(r.eulerCharacteristic, 2);
  EXPECT_NEAR(r.volume, 4.0 / 3.0 * 0.125, 1e-12);  // octahedron with half-diagonal 0.5
}

TEST(MarchingCubes, EveryCaseEmbeddedInAnOutsideGridIsWatertightAndOutward) {
  for (int config = 1; config < 256; ++config) {
    testing::SignGrid g = emptyGrid(4);
    for (int c = 0; c < 8; ++c)
      if ((config >> c) & 1)
        g.inside[std::size_t(((1 + ((c >> 2) & 1)) * 4 + 1 + ((c >> 1) & 1)) * 4 + 1 + (c & 1))] = true;
    const mesh::MeshReport r = mesh::checkMesh(testing::polygonizeSigns(g));
    EXPECT_TRUE(r.watertight()) << "config " << config << ": " << r.summary();
    EXPECT_GT(r.volume, 0.0) << "config " << config;
    EXPECT_EQ(r.eulerCharacteristic % 2, 0) << "config " << config;
  }
}

TEST(MarchingCubes, RandomSignGridsAreWatertightManifoldAndOutward) {
  std::mt19937 rng(12345);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 6;
    testing::SignGrid g = emptyGrid(n);
    const double density = 0.2 + 0.6 * double(trial % 7) / 6.0;
    std::bernoulli_distribution inside(density);
    for (int k = 1; k + 1 < n; ++k)
      for (int j = 1; j + 1 < n; ++j)
        for (int i = 1; i + 1 < n; ++i) g.inside[std::size_t((k * n + j) * n + i)] = inside(rng);
    const mesh::TriMesh m = testing::polygonizeSigns(g);
    const mesh::MeshReport r = mesh::checkMesh(m);
    ASSERT_TRUE(r.watertight()) << "trial " << trial << ": " << r.summary();
    EXPECT_EQ(r.eulerCharacteristic % 2, 0) << "trial " << trial;
    if (r.triangles > 0) {
      EXPECT_GT(r.volume, 0.0) << "trial " << trial;
    }
  }
}

TEST(MarchingCubes, RandomSignGridsTouchingTheBorderStayManifoldAndOriented) {
  std::mt19937 rng(777);
  for (int trial = 0; trial < 100; ++trial) {
    const int n = 6;
    testing::SignGrid g = emptyGrid(n);
    std::bernoulli_distribution inside(0.5);
    for (std::size_t i = 0; i < g.inside.size(); ++i) g.inside[i] = inside(rng);
    const mesh::MeshReport r = mesh::checkMesh(testing::polygonizeSigns(g));
    EXPECT_TRUE(r.manifold() && r.oriented()) << r.summary();
    EXPECT_EQ(r.degenerateTriangles, 0u);
  }
}

}  // namespace
}  // namespace blobvk
