// Shared fixtures for the FEM tests: box meshes from the voxel mesher and small vector helpers.
#pragma once

#include "fem/voxel_mesher.h"

#include <cmath>

namespace blobvk::fem::test {

// A box [0,lx] x [0,ly] x [0,lz] of cubic cells of edge `cell`, 6 tets per cell.
inline mesh::TetMesh boxMesh(double lx, double ly, double lz, double cell) {
  VoxelMesherSettings s;
  s.boundsMin = {0, 0, 0};
  s.boundsMax = {lx, ly, lz};
  s.cellSize = cell;
  return voxelTetrahedralize([](double, double, double) { return 1.0f; }, s);
}

inline double norm(const mesh::Double3& v) { return std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z); }

}  // namespace blobvk::fem::test
