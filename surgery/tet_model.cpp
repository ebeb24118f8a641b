#include "blobvk/surgery/tet_model.h"

#include "blobvk/surgery/cavity_holes.h"
#include "blobvk/surgery/tissue_regions.h"

#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/fem/surface_embedding.h"
#include "blobvk/fem/tet_utils.h"
#include "blobvk/fem/tetgen_mesher.h"
#include "blobvk/fem/voxel_mesher.h"
#include "blobvk/mesh/checks.h"
#include "blobvk/mesh/surface_remesh.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>

namespace blobvk::surgery {
namespace {

double since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The BlobTree field over many points through the SIMD evaluator: the remesher's Newton
// projection evaluates 7 points per vertex (craniotomy: 80 ms of a 250 ms clean-up with the
// scalar evaluator, 30 ms in batches). Equal to blobtree::evaluate bit for bit (cpu_simd's
// contract), so the result does not depend on the SIMD level.
mesh::FieldBatch simdField(const blobtree::Program& program) {
  return [&program, level = cpu::bestSimdLevel()](const std::vector<mesh::Double3>& points, std::vector<double>& values) {
    const std::size_t n = points.size();
    std::vector<float> x(n), y(n), z(n), f(n);
    for (std::size_t i = 0; i < n; ++i) x[i] = float(points[i].x), y[i] = float(points[i].y), z[i] = float(points[i].z);
    cpu::evaluateFieldBatch(program, x.data(), y.data(), z.data(), f.data(), n, level);
    values.assign(f.begin(), f.end());
  };
}

// TetGen's options for one surface: the scene's, plus a hole point in each of its cavities,
// found from the field half a polygonizer cell inside the hollow.
fem::TetgenOptions withCavities(fem::TetgenOptions options, const mesh::TriMesh& surface, const blobtree::Program& program,
                                double cellSize) {
  options.holes = cavityHolePoints(
      surface,
      [&program](const mesh::Double3& p) { return double(blobtree::evaluate(program, glm::vec3(float(p.x), float(p.y), float(p.z)))); },
      0.5, 0.5 * cellSize);
  return options;
}

}  // namespace

SceneModel loadSceneModel(const std::string& path) {
  SceneModel model;
  model.name = path;
  model.scene = blobtree::loadScene(path);  // SceneError already names the file and place
  try {
    model.program = blobtree::compile(model.scene.root);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": cannot compile the model: " + e.what());
  }
  return model;
}

SimulationConfig simulationConfigOf(const SceneModel& model) {
  if (model.scene.simulationJson.empty()) {
    throw std::runtime_error(model.name + ": the scene has no \"simulation\" section (see docs/fem.md)");
  }
  return parseSimulationConfig(model.scene.simulationJson, model.name);
}

namespace {

// Settings that would have TetGen or the surface clean-up grow without bound are refused before
// either runs, naming the scene key: the clean-up's triangles follow the surface's area over the
// target edge squared, TetGen's tets the body's volume over maxVolume.
void checkTetgenBudget(const std::string& scene, const SimulationConfig& config, const mesh::MeshReport& surface,
                       double cellSize) {
  constexpr double kMaxCleanedTriangles = 4e6;
  if (config.tetgenRemeshEdgeCells > 0) {
    const double edge = config.tetgenRemeshEdgeCells * cellSize;
    const double triangles = surface.area / (0.25 * std::sqrt(3.0) * edge * edge);
    if (triangles > kMaxCleanedTriangles) {
      char buf[256];
      std::snprintf(buf, sizeof buf,
                    "a target edge of %.3g cells makes about %.3g triangles, over %.0g; raise it (or 0: no clean-up)",
                    config.tetgenRemeshEdgeCells, triangles, kMaxCleanedTriangles);
      throw std::runtime_error(scene + ": /simulation/tetgen/remeshEdge: " + buf);
    }
  }
  try {
    fem::checkTetBudget(config.tetgen, surface.volume);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(scene + ": /simulation/tetgen/maxVolume: " + e.what() +
                             "; raise maxVolume or /simulation/tetgen/maxAddedPoints");
  }
}

}  // namespace

TetModel buildTetModel(const SceneModel& model, const blobtree::GridSpec& grid, const TetModelOptions& options) {
  TetModel body;
  body.config = simulationConfigOf(model);
  SimulationConfig& config = body.config;
  if (options.voxelCell) config.voxelCellSize = *options.voxelCell;

  auto start = std::chrono::steady_clock::now();
  cpu::MpuOptions poly;
  poly.threads = options.threads;
  body.surface = cpu::polygonizeMpu(model.program, grid, poly);
  body.meshSeconds = since(start);

  start = std::chrono::steady_clock::now();
  mesh::TetMesh tets;
  fem::SurfaceEmbedding embedding;
  const blobtree::Program& program = model.program;
  if (config.mesher == "tetgen") {
    if (!fem::tetgenAvailable()) {
      throw std::runtime_error(model.name + ": /simulation/mesher: this build has no TetGen (BLOBVK_WITH_TETGEN=OFF); use \"voxel\"");
    }
    checkTetgenBudget(model.name, config, mesh::checkMesh(body.surface), grid.cellSize);
    std::size_t inputPoints = 0;  // the surface TetGen meshed: its points are the first nodes
    if (config.tetgenRemeshEdgeCells > 0) {
      // Marching-cubes slivers would pass into the tets (docs/fem.md): TetGen meshes a cleaned-up
      // copy, and the render surface (with its colours) is embedded in the result.
      mesh::SurfaceRemeshOptions remesh;
      remesh.targetEdgeLength = config.tetgenRemeshEdgeCells * grid.cellSize;
      remesh.projectBatch = mesh::isoSurfaceProjectionBatch(simdField(program), 0.5, 1e-3 * grid.cellSize);
      try {
        const mesh::TriMesh cleaned = mesh::remeshSurface(body.surface, remesh);
        // No embedding of the marching-cubes surface: the tet boundary (the cleaned surface) is
        // what gets rendered (renderTetBoundary), and embedding ~20k points, many of them just
        // outside the cleaned surface, took half of the craniotomy's meshing time.
        tets = fem::tetrahedralize(cleaned, withCavities(config.tetgen, cleaned, program, grid.cellSize));
        inputPoints = cleaned.vertexCount();
      } catch (const std::exception& e) {
        // The clean-up refuses edits that make triangles cross, so TetGen should accept its
        // output; should it not (an intersection, or TetGen's "very close facets" error), the
        // raw surface still meshes.
        std::cerr << model.name << ": warning: the surface clean-up before TetGen failed (" << e.what()
                  << "); meshing the raw surface (expect slivers; lower /simulation/tetgen/remeshEdge)\n";
        tets = {};
      }
    }
    if (tets.tets.empty()) {
      tets = fem::tetrahedralize(body.surface, withCavities(config.tetgen, body.surface, program, grid.cellSize));
      embedding = fem::identityEmbedding(body.surface.vertexCount());
      inputPoints = body.surface.vertexCount();
    }
    const std::uint32_t cap = config.tetgen.maxAddedPoints;
    if (cap > 0 && tets.nodeCount() >= inputPoints + cap)
      std::cerr << model.name << ": warning: TetGen stopped at its limit of " << cap
                << " added points (/simulation/tetgen/maxAddedPoints): its tets may not meet radiusEdge and minDihedral\n";
  } else {
    fem::VoxelMesherSettings voxel;
    // The scene's grid box when it gives one (it is where the surface is), else the Program's.
    const auto& b = program.bounds;
    const auto& g = model.scene.grid;
    voxel.boundsMin = g.boundsLo ? mesh::Double3{g.boundsLo->x, g.boundsLo->y, g.boundsLo->z}
                                 : mesh::Double3{b.lo.x, b.lo.y, b.lo.z};
    voxel.boundsMax = g.boundsHi ? mesh::Double3{g.boundsHi->x, g.boundsHi->y, g.boundsHi->z}
                                 : mesh::Double3{b.hi.x, b.hi.y, b.hi.z};
    voxel.cellSize = config.voxelCellSize > 0 ? config.voxelCellSize : 2.0 * grid.cellSize;
    try {
      tets = fem::voxelTetrahedralize(
          [&program](double x, double y, double z) {
            return blobtree::evaluate(program, glm::vec3(float(x), float(y), float(z)));
          },
          voxel);
    } catch (const std::invalid_argument& e) {  // the mesher's problem, at the setting that made it
      const bool fromOption = options.voxelCell.has_value();
      throw std::runtime_error(model.name + ": " + (fromOption ? "--voxel-cell" : "/simulation/voxel/cellSize") + ": " +
                               e.what());
    }
    embedding = fem::embedPoints(tets, body.surface.positions);
  }
  if (tets.tets.empty()) throw std::runtime_error(model.name + ": the tetrahedral mesh is empty (model too thin for the voxel cell size?)");
  if (config.materialFromPrimitive) {
    if (config.settings.materials.size() < program.primitives.size()) {
      throw std::runtime_error(model.name + ": /simulation/materials: materialFromPrimitive needs one material per primitive (" +
                               std::to_string(program.primitives.size()) + "), got " +
                               std::to_string(config.settings.materials.size()));
    }
    assignTissueRegions(program, tets);
  }
  if (config.fixedSelector) {
    // The lambda owns its copy: the config (and its optional Program) is moved around later.
    auto selector = std::make_shared<const blobtree::Program>(*config.fixedSelector);
    config.settings.fixed = [selector](const mesh::Double3& p) {
      return blobtree::evaluate(*selector, glm::vec3(float(p.x), float(p.y), float(p.z))) >= 0.5f;
    };
  }
  body.renderTetBoundary = config.mesher == "tetgen";
  body.tetSeconds = since(start);
  body.tets = std::move(tets);
  body.embedding = std::move(embedding);
  return body;
}

}  // namespace blobvk::surgery
