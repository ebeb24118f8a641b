// Fast voxel tetrahedralization: every grid cell that is (partly) inside the implicit surface
// becomes 6 tets with the thesis split (thesis.md §6.6). The split uses the same face diagonals on
// opposite cell faces, so neighbouring cells conform. fem does not depend on blobtree: the field
// comes as a callback or a sampled grid.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <cstddef>
#include <functional>
#include <vector>

namespace blobvk::fem {

// Field value at a point; inside where value >= iso (BlobTree convention: iso 0.5).
using ScalarField = std::function<float(double x, double y, double z)>;

struct VoxelMesherSettings {
  mesh::Double3 boundsMin, boundsMax;  // region to voxelize
  double cellSize = 0.05;              // edge length of the cubic cells (> 0)
  float iso = 0.5f;
  // Refused above this many tets (6 per kept cell), before they are built: a simulated tet takes
  // about 1.7 KB across the FEM, the cutter and the render surface, so 4 M is about 7 GB.
  std::size_t maxTets = 4'000'000;
};

// Samples `field` at cell corners and centres; keeps a cell when its centre or any corner is
// inside. Nodes are welded; the result is positively oriented, with boundary faces.
mesh::TetMesh voxelTetrahedralize(const ScalarField& field, const VoxelMesherSettings& settings);

// Same, over values already sampled at grid points (x fastest, then y, then z); a cell's centre
// value is the mean of its 8 corners (trilinear interpolation at the centre).
struct SampledGrid {
  mesh::Double3 origin;
  double spacing = 1.0;
  int nx = 0, ny = 0, nz = 0;  // points per axis (cells = n - 1)
  std::vector<float> values;   // nx * ny * nz
};
mesh::TetMesh voxelTetrahedralize(const SampledGrid& grid, float iso = 0.5f);

}  // namespace blobvk::fem
