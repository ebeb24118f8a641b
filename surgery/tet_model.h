// From a scene to a tetrahedral body ready to simulate: polygonize (CPU), tetrahedralize (TetGen
// or voxels), assign tissue materials, build the fixed-node selector, embed the render surface.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/tree.h"
#include "blobvk/fem/surface_embedding.h"
#include "blobvk/mesh/tetmesh.h"
#include "blobvk/mesh/trimesh.h"
#include "blobvk/surgery/scene_config.h"

#include <optional>
#include <string>

namespace blobvk::surgery {

// A scene loaded and compiled, with the name its errors use (usually the file path).
struct SceneModel {
  std::string name;
  blobtree::Scene scene;
  blobtree::Program program;
};
// Loads and compiles a scene file; errors name the file.
SceneModel loadSceneModel(const std::string& path);
// The scene's "simulation" section, parsed and checked (errors name the file and the place; a
// scene without one is an error): what buildTetModel uses, for callers that check a scene
// before the long polygonization and tetrahedralization.
SimulationConfig simulationConfigOf(const SceneModel& model);

struct TetModelOptions {
  int threads = 0;                          // polygonizer threads (0: all cores)
  std::optional<double> voxelCell;          // overrides simulation.voxel.cellSize
};

struct TetModel {
  SimulationConfig config;
  mesh::TriMesh surface;          // the polygonized model (rest state)
  mesh::TetMesh tets;
  fem::SurfaceEmbedding embedding;  // surface vertices in the tets (empty when renderTetBoundary)
  // True for TetGen bodies: TetGen meshes the (cleaned) polygonized surface and keeps its
  // vertices as nodes, so the tet boundary is that surface; rendering the boundary keeps it
  // through cuts (split along the crack, crack faces added) with no switch at the first cut.
  // False for voxel bodies: their boundary is a staircase, `surface` is rendered through
  // `embedding` until the first cut. (TetGen on the raw surface, when the clean-up fails, sets
  // the identity embedding too.)
  bool renderTetBoundary = false;
  double meshSeconds = 0, tetSeconds = 0;
};

// Throws std::runtime_error naming the scene when it has no "simulation" section, when the
// mesher is unavailable or the mesh comes out empty; blobtree::SceneError for a malformed section.
TetModel buildTetModel(const SceneModel& model, const blobtree::GridSpec& grid, const TetModelOptions& options = {});

}  // namespace blobvk::surgery
