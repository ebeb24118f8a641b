// Meshers and input validation: voxel conformity and volume, TetGen quality and rejections.
#include "blobvk/fem/simulation.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/mesh/checks.h"
#include "test_helpers.h"

#include <cstring>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>


namespace blobvk::fem {
namespace {

using mesh::Double3;

TEST(VoxelMesher, BoxIsConformingWithExactVolumeAndClosedBoundary) {
  const mesh::TetMesh m = test::boxMesh(0.4, 0.3, 0.2, 0.1);
  EXPECT_EQ(m.tets.size(), 4u * 3u * 2u * 6u);
  EXPECT_EQ(m.nodeCount(), 5u * 4u * 3u);
  EXPECT_NEAR(totalVolume(m, true), 0.4 * 0.3 * 0.2, 1e-12);
  // Conforming: only outer faces are boundary faces (2 triangles per outer cell face).
  EXPECT_EQ(m.boundaryFaces.size(), 2u * 2u * (4 * 3 + 4 * 2 + 3 * 2));
  mesh::TriMesh surface;
  for (const auto& p : m.positions) surface.positions.push_back({float(p.x), float(p.y), float(p.z)});
  surface.triangles.assign(m.boundaryFaces.begin(), m.boundaryFaces.end());
  const mesh::MeshReport report = mesh::checkMesh(surface);
  EXPECT_TRUE(report.watertight()) << report.summary();
  EXPECT_NEAR(report.volume, 0.4 * 0.3 * 0.2, 1e-6);  // outward orientation
  EXPECT_NO_THROW(validateTetMesh(m));
}

TEST(VoxelMesher, SphereFieldKeepsCellsWithCentreOrCornerInside) {
  VoxelMesherSettings s;
  s.boundsMin = {-1, -1, -1};
  s.boundsMax = {1, 1, 1};
  s.cellSize = 0.1;
  auto field = [](double x, double y, double z) {
    const double d2 = x * x + y * y + z * z;
    return float(d2 < 0.25 ? std::pow(1 - d2 / 0.25, 3) : 0.0);  // iso 0.5 at r = 0.5*sqrt(1-2^-1/3)
  };
  const mesh::TetMesh m = voxelTetrahedralize(field, s);
  const double r = 0.5 * std::sqrt(1 - std::pow(2.0, -1.0 / 3.0));
  // The kept cells cover the ball and stay within one cell diagonal of it.
  const double vol = totalVolume(m, true), ball = 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_GT(vol, ball);
  for (const auto& p : m.positions) EXPECT_LE(test::norm(p), r + 2 * std::sqrt(3.0) * 0.1);
  EXPECT_NO_THROW(validateTetMesh(m));
}

// Too many tets for the settings' limit are refused before they are built, with the count: a
// small cell once ran the process out of memory (std::bad_alloc after 5.5 GB).
TEST(VoxelMesher, RefusesMoreTetsThanItsLimitBeforeBuildingThem) {
  VoxelMesherSettings s;
  s.boundsMin = {0, 0, 0};
  s.boundsMax = {1, 1, 1};
  s.cellSize = 0.1;  // 10^3 cells, all inside: 6,000 tets
  const auto full = [](double, double, double) { return 1.0f; };
  s.maxTets = 6000;
  EXPECT_EQ(voxelTetrahedralize(full, s).tets.size(), 6000u);
  s.maxTets = 5999;
  try {
    (void)voxelTetrahedralize(full, s);
    ADD_FAILURE() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("make 6000 tets, more than the limit of 5999"), std::string::npos) << e.what();
  }
}

TEST(VoxelMesher, RefusesTooManyCellsWhateverTheCellSize) {
  // Every cell size from 1e-3 down gives more than 5e7 cells over a unit box; at 1e-9 the cells
  // per axis (1e9) times two overflow an int, which once read as a small grid with no cell inside.
  VoxelMesherSettings s;
  s.boundsMin = {0, 0, 0};
  s.boundsMax = {1, 1, 1};
  const auto full = [](double, double, double) { return 1.0f; };
  for (const double cell : {1e-3, 1e-6, 1e-9, 1e-12, 1e-300}) {
    s.cellSize = cell;
    try {
      (void)voxelTetrahedralize(full, s);
      FAIL() << "cell size " << cell << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "voxel mesher: more than 5e7 cells; raise cellSize") << cell;
    }
  }
}

TEST(VoxelMesher, SampledGridMatchesCallbackOnSameGrid) {
  SampledGrid g;
  g.origin = {0, 0, 0};
  g.spacing = 0.25;
  g.nx = g.ny = g.nz = 5;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) g.values.push_back(i <= 2 && j <= 2 && k <= 2 ? 1.0f : 0.0f);
  const mesh::TetMesh m = voxelTetrahedralize(g);
  // Cells with any corner in the 3x3x3 inside block: indices 0..2 per axis -> 27 cells.
  EXPECT_EQ(m.tets.size(), 27u * 6u);
}

mesh::TriMesh cubeSurface(double h, double ox = 0) {
  mesh::TriMesh m;
  for (int c = 0; c < 8; ++c)
    m.positions.push_back({float(ox + (c & 1 ? h : -h)), float(c & 2 ? h : -h), float(c & 4 ? h : -h)});
  // Counter-clockwise seen from outside.
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

TEST(TetgenMesher, SwitchesReflectOptions) {
  TetgenOptions o;
  o.maxRadiusEdgeRatio = 1.5;
  o.minDihedralDegrees = 12;
  o.maxVolume = 0.001;
  EXPECT_EQ(tetgenSwitches(o), "pzQq1.5/12a0.001S200000");
  o.quality = false;
  o.maxVolume = 0;
  o.keepSurface = true;
  o.maxAddedPoints = 0;
  EXPECT_EQ(tetgenSwitches(o), "pzQY");
  o.optimizeMaxDihedralDegrees = 150;
  EXPECT_EQ(tetgenSwitches(o), "pzQYo/150");
  o.optimizeMaxDihedralDegrees = 180;
  EXPECT_THROW(tetgenSwitches(o), std::invalid_argument);
  o.optimizeMaxDihedralDegrees = 150;
  o.maxAddedPoints = 3000000000u;  // past TetGen's int: it would wrap to "no limit"
  EXPECT_THROW(tetgenSwitches(o), std::invalid_argument);
  o.maxAddedPoints = 0;
  o.optimizeMaxDihedralDegrees = 0;
  o.quality = true;
  o.maxRadiusEdgeRatio = 0.9;
  EXPECT_THROW(tetgenSwitches(o), std::invalid_argument);
}

TEST(TetgenMesher, CubeGivesQualityTetsWithExactVolume) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  TetgenOptions o;
  o.maxVolume = 0.01;
  const mesh::TetMesh m = tetrahedralize(cubeSurface(0.5), o);
  EXPECT_GT(m.tets.size(), 100u);
  EXPECT_NEAR(totalVolume(m, true), 1.0, 1e-9);
  EXPECT_NO_THROW(validateTetMesh(m));
  EXPECT_GE(test::minDihedralDegrees(m.positions, m.tets), 10.0 - 1e-6);
  for (const auto& t : m.tets) EXPECT_LE(std::abs(tetVolume(m.restPositions, t)), 0.01 * (1 + 1e-9));
  // Input points stay the first nodes (the identity surface mapping relies on it).
  const auto cube = cubeSurface(0.5);
  for (std::size_t i = 0; i < cube.positions.size(); ++i) EXPECT_EQ(m.positions[i].x, double(cube.positions[i].x));
  // Boundary = the cube's surface.
  mesh::TriMesh surface;
  for (const auto& p : m.positions) surface.positions.push_back({float(p.x), float(p.y), float(p.z)});
  surface.triangles.assign(m.boundaryFaces.begin(), m.boundaryFaces.end());
  EXPECT_NEAR(mesh::checkMesh(surface).volume, 1.0, 1e-5);
}

// The child process changes nothing but where TetGen runs: the same nodes and tets, bit for bit,
// and the same errors (a TetGen failure's message crosses the pipe).
TEST(TetgenMesher, InTheCallingThreadGivesTheIsolatedMeshBitForBit) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  TetgenOptions isolated;
  isolated.maxVolume = 0.01;
  TetgenOptions inThread = isolated;
  inThread.isolateInChildProcess = false;
  const mesh::TetMesh a = tetrahedralize(cubeSurface(0.5), isolated), b = tetrahedralize(cubeSurface(0.5), inThread);
  ASSERT_EQ(a.positions.size(), b.positions.size());
  ASSERT_EQ(a.tets.size(), b.tets.size());
  EXPECT_EQ(0, std::memcmp(a.positions.data(), b.positions.data(), a.positions.size() * sizeof(a.positions[0])));
  EXPECT_EQ(0, std::memcmp(a.tets.data(), b.tets.data(), a.tets.size() * sizeof(a.tets[0])));
  EXPECT_EQ(a.boundaryFaces, b.boundaryFaces);
  auto open = cubeSurface(0.5);
  open.triangles.pop_back();
  EXPECT_THROW(tetrahedralize(open, inThread), std::invalid_argument);
}

// TetGen need not end for a radius-edge bound of 1 (it grew by 50 MB/s on a scene's body): the
// added-point limit ends it with a valid mesh, and a largest tet volume asking for more tets than
// the limit allows is refused before TetGen runs.
TEST(TetgenMesher, TheAddedPointLimitBoundsItsWork) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  TetgenOptions o;
  o.maxRadiusEdgeRatio = 1.0;
  o.minDihedralDegrees = 25;
  o.maxAddedPoints = 2000;
  // A slab 8 x 1 x 0.125: its long thin faces need refining, which these bounds never finish
  // (a unit cube meets them with no point added).
  auto slab = cubeSurface(0.5);
  for (auto& p : slab.positions) p = {8.0f * p.x, p.y, 0.125f * p.z};
  const mesh::TetMesh m = tetrahedralize(slab, o);
  EXPECT_EQ(m.nodeCount(), slab.positions.size() + o.maxAddedPoints);  // stopped at the limit
  EXPECT_NEAR(totalVolume(m, true), 1.0, 1e-9);
  EXPECT_NO_THROW(validateTetMesh(m));
  const auto cube = cubeSurface(0.5);
  o.maxVolume = 1.0 / (6.0 * 2000) * 0.99;  // the unit cube asks for just over 6 x 2000 tets
  EXPECT_THROW(checkTetBudget(o, 1.0), std::invalid_argument);
  EXPECT_THROW(tetrahedralize(cube, o), std::invalid_argument);
  o.maxVolume = 1.0 / (6.0 * 2000) * 1.01;
  EXPECT_NO_THROW(checkTetBudget(o, 1.0));
  o.maxAddedPoints = 0;  // no limit: nothing is refused
  o.maxVolume = 1e-12;
  EXPECT_NO_THROW(checkTetBudget(o, 1.0));
}

TEST(TetgenMesher, RejectsOpenSurface) {
  auto open = cubeSurface(0.5);
  open.triangles.pop_back();
  try {
    tetrahedralize(open);
    FAIL() << "open surface accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("closed"), std::string::npos) << e.what();
  } catch (const std::runtime_error& e) {
    EXPECT_FALSE(tetgenAvailable()) << e.what();
  }
}

TEST(TetgenMesher, RejectsSelfIntersectingSurface) {
  if (!tetgenAvailable()) GTEST_SKIP() << "built without TetGen";
  auto a = cubeSurface(0.5), b = cubeSurface(0.5, 0.3);  // two overlapping closed cubes
  const auto offset = std::uint32_t(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (auto t : b.triangles) a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  try {
    tetrahedralize(a);
    FAIL() << "self-intersecting surface accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("intersects itself"), std::string::npos) << e.what();
  }
}

TEST(Validation, BadMaterialsAndDegenerateTetsGiveClearErrors) {
  const mesh::TetMesh m = test::boxMesh(0.2, 0.2, 0.2, 0.1);
  auto expectThrowContaining = [&](SimulationSettings s, const mesh::TetMesh& mesh, const std::string& text) {
    try {
      Simulation sim(mesh, s);
      FAIL() << "accepted: " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(text), std::string::npos) << e.what();
    }
  };
  SimulationSettings s;
  s.materials[0].youngModulus = 0;
  expectThrowContaining(s, m, "Young");
  s = {};
  s.materials[0].poissonRatio = 0.5;
  expectThrowContaining(s, m, "Poisson");
  s = {};
  s.materials[0].density = -1;
  expectThrowContaining(s, m, "density");
  s = {};
  s.timeStep = 0;
  expectThrowContaining(s, m, "time step");
  mesh::TetMesh flat = m;
  flat.restPositions[flat.tets[3][3]] = flat.restPositions[flat.tets[3][0]];  // collapse a tet
  expectThrowContaining({}, flat, "degenerate");
  mesh::TetMesh regions = m;
  regions.regions.assign(m.tets.size(), 2);
  expectThrowContaining({}, regions, "region");
  SimulationSettings toolless;
  toolless.tools.push_back(Tool{});
  expectThrowContaining(toolless, m, "keyframe");
}

TEST(Regions, SelectorAssignsPerTetMaterials) {
  mesh::TetMesh m = test::boxMesh(0.4, 0.1, 0.1, 0.05);
  assignRegions(m, [](const Double3& c) { return c.x < 0.2 ? 0u : 1u; });
  ASSERT_EQ(m.regions.size(), m.tets.size());
  SimulationSettings s;
  s.materials = {Material{1e5, 0.3, 1000}, Material{1e5, 0.3, 3000}};
  Simulation sim(m, s);
  // Mass: 0.2*0.1*0.1*(1000 + 3000) = 8 kg.
  double total = 0;
  for (double mi : sim.nodeMasses()) total += mi;
  EXPECT_NEAR(total, 8.0, 1e-9);
}

}  // namespace
}  // namespace blobvk::fem
