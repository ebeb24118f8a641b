// Small voxel bodies for the surgery tests: boxes meshed by the voxel mesher (5 tets per cube).
#pragma once

#include "blobvk/fem/voxel_mesher.h"
#include "blobvk/mesh/tetmesh.h"

#include <cmath>

namespace blobvk::testing {

// The box [-h, h]^3 in cubes of side `cell`.
inline mesh::TetMesh voxelBox(double h, double cell) {
  fem::VoxelMesherSettings voxel;
  voxel.boundsMin = {-h - 0.5 * cell, -h - 0.5 * cell, -h - 0.5 * cell};
  voxel.boundsMax = {h + 0.5 * cell, h + 0.5 * cell, h + 0.5 * cell};
  voxel.cellSize = cell;
  return fem::voxelTetrahedralize(
      [h](double x, double y, double z) { return std::fabs(x) <= h && std::fabs(y) <= h && std::fabs(z) <= h ? 1.0f : 0.0f; },
      voxel);
}

inline double restVolume(const mesh::TetMesh& m, std::uint32_t t) {
  const auto& p = m.restPositions;
  const auto& n = m.tets[t];
  const mesh::Double3 a = p[n[0]], b = p[n[1]], c = p[n[2]], d = p[n[3]];
  const double ux = b.x - a.x, uy = b.y - a.y, uz = b.z - a.z, vx = c.x - a.x, vy = c.y - a.y, vz = c.z - a.z,
               wx = d.x - a.x, wy = d.y - a.y, wz = d.z - a.z;
  return (ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)) / 6.0;
}

inline mesh::Double3 restCentroid(const mesh::TetMesh& m, std::uint32_t t) {
  mesh::Double3 c;
  for (std::uint32_t v : m.tets[t]) c = {c.x + 0.25 * m.restPositions[v].x, c.y + 0.25 * m.restPositions[v].y, c.z + 0.25 * m.restPositions[v].z};
  return c;
}

}  // namespace blobvk::testing
