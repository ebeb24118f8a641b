// Shared fixtures for the FEM tests: box meshes from the voxel mesher, small vector helpers, and
// a dihedral angle written apart from fem/ (the sliver pass is judged by it, not by its own).
#pragma once

#include "blobvk/fem/voxel_mesher.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

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

// Smallest dihedral angle (degrees) over `tets`: at each edge, the angle between the two other
// corners projected onto the plane normal to the edge.
inline double minDihedralDegrees(const std::vector<mesh::Double3>& points,
                                 const std::vector<std::array<std::uint32_t, 4>>& tets) {
  double best = 180;
  static constexpr int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (const auto& t : tets) {
    Eigen::Vector3d p[4];
    for (int k = 0; k < 4; ++k) p[k] = {points[t[std::size_t(k)]].x, points[t[std::size_t(k)]].y, points[t[std::size_t(k)]].z};
    for (const auto& e : kEdges) {
      int o[2], c = 0;
      for (int k = 0; k < 4; ++k)
        if (k != e[0] && k != e[1]) o[c++] = k;
      const Eigen::Vector3d axis = (p[e[1]] - p[e[0]]).normalized();
      Eigen::Vector3d a = p[o[0]] - p[e[0]], b = p[o[1]] - p[e[0]];
      a -= a.dot(axis) * axis;
      b -= b.dot(axis) * axis;
      best = std::min(best, std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI);
    }
  }
  return best;
}

}  // namespace blobvk::fem::test
