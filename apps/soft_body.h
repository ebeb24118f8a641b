// From a scene to a running soft body: polygonize, tetrahedralize (TetGen or voxels), assign
// materials, fix nodes, embed the render surface. Shared by `simulate` and `cut`.
#pragma once

#include "blobvk/fem/simulation.h"
#include "model.h"
#include "simulation_config.h"

#include "blobvk/fem/surface_embedding.h"

#include <memory>
#include <optional>

namespace blobvk::app {

struct SoftBody {
  SimulationConfig config;
  mesh::TriMesh surface;                     // the polygonized model (rest state)
  std::unique_ptr<fem::Simulation> simulation;
  double meshSeconds = 0, tetSeconds = 0;
};

// The tetrahedral mesh alone (for cutting before the FEM is built).
struct TetModel {
  SimulationConfig config;
  mesh::TriMesh surface;
  mesh::TetMesh tets;
  fem::SurfaceEmbedding embedding;
  double meshSeconds = 0, tetSeconds = 0;
};
// `voxelCell` overrides the scene's simulation.voxel.cellSize (a coarser body for quick runs).
TetModel buildTetModel(const Model& model, const blobtree::GridSpec& grid, int threads,
                       std::optional<double> voxelCell = std::nullopt);

SoftBody buildSoftBody(const Model& model, const blobtree::GridSpec& grid, int threads);

}  // namespace blobvk::app
