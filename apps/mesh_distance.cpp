#include "mesh_distance.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <unordered_map>
#include <vector>

namespace blobvk::app {
namespace {

class VertexHash {
 public:
  VertexHash(std::span<const mesh::Float3> points, float cell) : points_(points), cell_(cell) {
    for (std::uint32_t i = 0; i < points.size(); ++i) buckets_[key(cellOf(points[i]))].push_back(i);
  }

  // Distance to the nearest point, searching rings of cells outwards until a hit is certain.
  double nearest(const mesh::Float3& p) const {
    if (points_.empty()) return std::numeric_limits<double>::infinity();
    const auto c = cellOf(p);
    double best = std::numeric_limits<double>::infinity();
    for (int ring = 0; ring < 64; ++ring) {
      for (int dz = -ring; dz <= ring; ++dz)
        for (int dy = -ring; dy <= ring; ++dy)
          for (int dx = -ring; dx <= ring; ++dx) {
            if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) != ring) continue;
            auto it = buckets_.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
            if (it == buckets_.end()) continue;
            for (std::uint32_t i : it->second) {
              const double x = double(points_[i].x) - p.x, y = double(points_[i].y) - p.y, z = double(points_[i].z) - p.z;
              best = std::min(best, std::sqrt(x * x + y * y + z * z));
            }
          }
      // Everything outside ring r is at least r cells away.
      if (best <= double(ring) * cell_) return best;
    }
    if (std::isfinite(best)) return best;
    for (const auto& q : points_) {  // far outlier: brute force
      const double x = double(q.x) - p.x, y = double(q.y) - p.y, z = double(q.z) - p.z;
      best = std::min(best, std::sqrt(x * x + y * y + z * z));
    }
    return best;
  }

 private:
  std::array<int, 3> cellOf(const mesh::Float3& p) const {
    return {int(std::floor(p.x / cell_)), int(std::floor(p.y / cell_)), int(std::floor(p.z / cell_))};
  }
  static std::uint64_t key(const std::array<int, 3>& c) {
    return (std::uint64_t(std::uint32_t(c[0]) & 0x1fffff) << 42) | (std::uint64_t(std::uint32_t(c[1]) & 0x1fffff) << 21) |
           std::uint64_t(std::uint32_t(c[2]) & 0x1fffff);
  }
  std::span<const mesh::Float3> points_;
  float cell_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> buckets_;
};

double directed(const mesh::TriMesh& from, const VertexHash& to) {
  double worst = 0;
  for (const auto& p : from.positions) worst = std::max(worst, to.nearest(p));
  return worst;
}

}  // namespace

double vertexHausdorff(const mesh::TriMesh& a, const mesh::TriMesh& b, float cellSize) {
  if (a.positions.empty() && b.positions.empty()) return 0.0;
  const VertexHash ha(a.positions, cellSize), hb(b.positions, cellSize);
  return std::max(directed(a, hb), directed(b, ha));
}

}  // namespace blobvk::app
