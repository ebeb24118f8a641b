// A unit sphere for TetGen tests and benchmarks: an icosahedron subdivided `levels` times,
// vertices pushed onto the sphere (every triangle angle > 54 degrees, closed, outward).
#pragma once

#include "blobvk/mesh/tetmesh.h"  // Double3
#include "blobvk/mesh/trimesh.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

namespace blobvk::testing {

inline mesh::TriMesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<mesh::Double3> p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<std::uint32_t, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> middle;
    const auto mid = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto it = middle.find(key);
      if (it != middle.end()) return it->second;
      p.push_back({(p[a].x + p[b].x) / 2, (p[a].y + p[b].y) / 2, (p[a].z + p[b].z) / 2});
      return middle[key] = std::uint32_t(p.size() - 1);
    };
    std::vector<std::array<std::uint32_t, 3>> next;
    for (const auto& t3 : f) {
      const std::uint32_t ab = mid(t3[0], t3[1]), bc = mid(t3[1], t3[2]), ca = mid(t3[2], t3[0]);
      next.insert(next.end(), {{t3[0], ab, ca}, {t3[1], bc, ab}, {t3[2], ca, bc}, {ab, bc, ca}});
    }
    f = std::move(next);
  }
  mesh::TriMesh s;
  for (const auto& q : p) {
    const double l = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    s.positions.push_back({float(q.x / l), float(q.y / l), float(q.z / l)});
  }
  s.triangles.assign(f.begin(), f.end());
  return s;
}

}  // namespace blobvk::testing
