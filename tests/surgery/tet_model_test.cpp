// surgery::buildTetModel with TetGen on the shipped scenes, and
// surgery::cavityHolePoints: a hollow body comes out hollow (TetGen fills every
// enclosed region unless given a point in it). Oracles: the polygonized
// surface's own volume (divergence theorem, mesh::checkMesh) and the field at
// the tet centroids, both independent of TetGen.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/surgery/cavity_holes.h"
#include "blobvk/surgery/tet_model.h"

#include <glm/vec3.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>
#include <string>

namespace {

using namespace blobvk;

std::string source(const std::string &rel) {
  return std::string(BLOBVK_SOURCE_DIR) + "/" + rel;
}

// A UV sphere of radius r (outward, or inward when flipped), welded at the
// poles.
mesh::TriMesh sphere(double r, bool inward, int slices = 24, int stacks = 12) {
  mesh::TriMesh s;
  s.positions.push_back({0, 0, float(r)});
  for (int i = 1; i < stacks; ++i)
    for (int j = 0; j < slices; ++j) {
      const double th = M_PI * i / stacks, ph = 2 * M_PI * j / slices;
      s.positions.push_back({float(r * std::sin(th) * std::cos(ph)),
                             float(r * std::sin(th) * std::sin(ph)),
                             float(r * std::cos(th))});
    }
  s.positions.push_back({0, 0, float(-r)});
  const auto ring = [&](int i, int j) {
    return std::uint32_t(1 + (i - 1) * slices + (j % slices));
  };
  const std::uint32_t south = std::uint32_t(s.positions.size() - 1);
  auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    s.triangles.push_back(inward ? std::array{a, c, b} : std::array{a, b, c});
  };
  for (int j = 0; j < slices; ++j)
    add(0, ring(1, j), ring(1, j + 1));
  for (int i = 1; i < stacks - 1; ++i)
    for (int j = 0; j < slices; ++j) {
      add(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1));
      add(ring(i, j), ring(i + 1, j + 1), ring(i, j + 1));
    }
  for (int j = 0; j < slices; ++j)
    add(south, ring(stacks - 1, j + 1), ring(stacks - 1, j));
  return s;
}

mesh::TriMesh append(mesh::TriMesh a, const mesh::TriMesh &b) {
  const auto offset = std::uint32_t(a.positions.size());
  a.positions.insert(a.positions.end(), b.positions.begin(), b.positions.end());
  for (auto t : b.triangles)
    a.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  return a;
}

// A shell 0.6 < |p| < 1 (field 1 inside the material): one hole point, in the
// hollow, for the inner (inward-facing) sphere; none for a solid ball.
TEST(CavityHoles, OnePointInsideEachHollowNoneForASolid) {
  const auto shellField = [](const mesh::Double3 &p) {
    const double r = std::sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
    return r > 0.6 && r < 1.0 ? 1.0 : 0.0;
  };
  const mesh::TriMesh shell = append(sphere(1.0, false), sphere(0.6, true));
  const auto holes = surgery::cavityHolePoints(shell, shellField, 0.5, 0.05);
  ASSERT_EQ(holes.size(), 1u);
  const double r = std::sqrt(holes[0].x * holes[0].x + holes[0].y * holes[0].y +
                             holes[0].z * holes[0].z);
  EXPECT_LT(r, 0.6);
  EXPECT_GT(r, 0.5);
  EXPECT_TRUE(surgery::cavityHolePoints(
                  sphere(1.0, false), [](const mesh::Double3 &) { return 1.0; },
                  0.5, 0.05)
                  .empty());
  // Where the field says the side the normals face is material, no point is
  // made.
  EXPECT_TRUE(surgery::cavityHolePoints(
                  shell, [](const mesh::Double3 &) { return 1.0; }, 0.5, 0.05)
                  .empty());
  if (!fem::tetgenAvailable())
    return;
  // TetGen with the point meshes the shell only: the volume between the two
  // polyhedra.
  fem::TetgenOptions options;
  const double shellVolume = mesh::checkMesh(shell).volume;
  options.holes = holes;
  EXPECT_NEAR(fem::totalVolume(fem::tetrahedralize(shell, options), true),
              shellVolume, 1e-6 * shellVolume); // float input positions
  options.holes.clear();
  EXPECT_GT(fem::totalVolume(fem::tetrahedralize(shell, options), true),
            1.2 * shellVolume);
}

// eggshell_sim meshes as a shell: its tets fill what the polygonized surface
// encloses (the shell between the two iso surfaces), not the egg's inside. The
// surface TetGen meshes is a clean-up of the polygonized one
// (mesh::remeshSurface), so the volumes agree to a few per mille; both are
// within 1 % of the analytic shell, 4/3 pi r^3 (3.45 * 2.18 * 3.11 - 3.14
// * 1.76 * 2.83) with r = sqrt(1 - 0.5^(1/3)) the iso radius of the Wyvill
// kernel in the primitives' unit frame.
TEST(TetModel, EggshellMeshesAsAShell) {
  if (!fem::tetgenAvailable())
    GTEST_SKIP() << "built without TetGen";
  const surgery::SceneModel model =
      surgery::loadSceneModel(source("scenes/eggshell_sim.json"));
  const surgery::TetModel body = surgery::buildTetModel(
      model, blobtree::chooseGrid(model.program, model.scene.grid,
                                  {})); // the scene's grid
  EXPECT_EQ(body.config.mesher, "tetgen");
  const double surfaceVolume = mesh::checkMesh(body.surface).volume;
  const double tetVolume = fem::totalVolume(body.tets, true);
  EXPECT_NEAR(tetVolume, surfaceVolume, 0.01 * surfaceVolume);
  const double r = std::sqrt(1 - std::cbrt(0.5));
  const double analytic =
      4.0 / 3.0 * M_PI * r * r * r * (3.45 * 2.18 * 3.11 - 3.14 * 1.76 * 2.83);
  EXPECT_NEAR(tetVolume, analytic, 0.01 * analytic);
  EXPECT_NEAR(surfaceVolume, analytic, 0.01 * analytic);
  // No tet in the hollow: every centroid is in the material by the field (a tet
  // of the clean-up may poke a little past the iso surface, so the bound is
  // below 0.5).
  std::size_t hollow = 0;
  for (const auto &t : body.tets.tets) {
    mesh::Double3 c{0, 0, 0};
    for (auto n : t)
      c = {c.x + body.tets.restPositions[n].x / 4,
           c.y + body.tets.restPositions[n].y / 4,
           c.z + body.tets.restPositions[n].z / 4};
    if (blobtree::evaluate(model.program, glm::vec3(float(c.x), float(c.y),
                                                    float(c.z))) < 0.25f)
      ++hollow;
  }
  EXPECT_EQ(hollow, 0u) << "of " << body.tets.tetCount() << " tets";
}

// Settings whose work has no bound (a clean-up edge of a thousandth of a cell: hundreds of
// millions of triangles; a largest tet volume of 1e-12: 10^12 tets) are refused before any
// meshing, with the scene key to change; the shipped setting of the same scene meshes.
TEST(TetModel, RefusesSettingsThatWouldGrowWithoutBound) {
  if (!fem::tetgenAvailable())
    GTEST_SKIP() << "built without TetGen";
  const std::pair<const char *, double> cases[] = {{"remeshEdge", 0.001},
                                                   {"maxVolume", 1e-12}};
  for (const auto &[key, value] : cases) {
    surgery::SceneModel model =
        surgery::loadSceneModel(source("scenes/soft_peanut.json"));
    nlohmann::json simulation =
        nlohmann::json::parse(model.scene.simulationJson);
    simulation["tetgen"][key] = value;
    model.scene.simulationJson = simulation.dump();
    const blobtree::GridSpec grid =
        blobtree::chooseGrid(model.program, model.scene.grid, {});
    try {
      (void)surgery::buildTetModel(model, grid);
      ADD_FAILURE() << key << " " << value << " was accepted";
    } catch (const std::runtime_error &e) {
      EXPECT_NE(std::string(e.what()).find(
                    std::string("/simulation/tetgen/") + key + ": "),
                std::string::npos)
          << e.what();
    }
  }
}

} // namespace
