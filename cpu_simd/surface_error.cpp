#include "blobvk/cpu_simd/surface_error.h"

#include "blobvk/blobtree/triangle_closest.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

namespace blobvk::cpu {
namespace {

using glm::dvec3;
dvec3 toD(const mesh::Float3& f) { return {f.x, f.y, f.z}; }

// Triangles listed in every bucket their bounding box covers; a query searches rings of buckets
// outwards until the nearest triangle found is closer than the next ring can be.
class TriangleHash {
 public:
  TriangleHash(const mesh::TriMesh& m, double bucket) : mesh_(m), h_(bucket) {
    for (std::uint32_t t = 0; t < m.triangles.size(); ++t) {
      dvec3 lo(std::numeric_limits<double>::infinity()), hi(-lo);
      for (std::uint32_t v : m.triangles[t]) lo = glm::min(lo, toD(m.positions[v])), hi = glm::max(hi, toD(m.positions[v]));
      const auto a = cell(lo), b = cell(hi);
      for (std::int64_t z = a[2]; z <= b[2]; ++z)
        for (std::int64_t y = a[1]; y <= b[1]; ++y)
          for (std::int64_t x = a[0]; x <= b[0]; ++x) buckets_[key(x, y, z)].push_back(t);
    }
  }

  double distance(const dvec3& p) const {
    const auto c = cell(p);
    double best = std::numeric_limits<double>::infinity();
    for (std::int64_t ring = 0; ring < 64; ++ring) {
      for (std::int64_t z = c[2] - ring; z <= c[2] + ring; ++z)
        for (std::int64_t y = c[1] - ring; y <= c[1] + ring; ++y)
          for (std::int64_t x = c[0] - ring; x <= c[0] + ring; ++x) {
            if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != ring) continue;
            const auto it = buckets_.find(key(x, y, z));
            if (it == buckets_.end()) continue;
            for (std::uint32_t t : it->second) {
              const auto& tri = mesh_.triangles[t];
              const dvec3 q = blobtree::detail::triangleClosest<double>(p, toD(mesh_.positions[tri[0]]),
                                                                         toD(mesh_.positions[tri[1]]),
                                                                         toD(mesh_.positions[tri[2]]));
              best = std::min(best, glm::length(p - q));
            }
          }
      // Everything within `ring` buckets of p's bucket has been seen.
      if (best <= double(ring) * h_) break;
    }
    return best;
  }

 private:
  std::array<std::int64_t, 3> cell(const dvec3& p) const {
    return {std::int64_t(std::floor(p.x / h_)), std::int64_t(std::floor(p.y / h_)), std::int64_t(std::floor(p.z / h_))};
  }
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    return (std::uint64_t(x & 0x1fffff) << 42) | (std::uint64_t(y & 0x1fffff) << 21) | std::uint64_t(z & 0x1fffff);
  }
  const mesh::TriMesh& mesh_;
  double h_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> buckets_;
};

struct MaxSum {
  double max = 0.0, sum = 0.0;
  dvec3 at{0.0};
};

template <typename Point>
MaxSum distances(const TriangleHash& to, std::size_t n, Point&& point) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n), MaxSum{},
      [&](const tbb::blocked_range<std::size_t>& r, MaxSum acc) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) {
          const dvec3 p = point(i);
          const double d = to.distance(p);
          if (d > acc.max) acc.max = d, acc.at = p;
          acc.sum += d;
        }
        return acc;
      },
      [](MaxSum a, const MaxSum& b) {
        // Ties keep the left range's point, so the answer does not depend on the split.
        return b.max > a.max ? MaxSum{b.max, a.sum + b.sum, b.at} : MaxSum{a.max, a.sum + b.sum, a.at};
      });
}

}  // namespace

SurfaceError surfaceError(const mesh::TriMesh& m, const mesh::TriMesh& reference, double bucket) {
  SurfaceError e;
  const TriangleHash refHash(reference, bucket), meshHash(m, bucket);
  // The mesh's vertices and its triangles' centroids (a flat triangle strays most inside).
  const std::size_t nv = m.positions.size();
  const MaxSum to = distances(refHash, nv + m.triangles.size(), [&](std::size_t i) {
    if (i < nv) return toD(m.positions[i]);
    const auto& t = m.triangles[i - nv];
    return (toD(m.positions[t[0]]) + toD(m.positions[t[1]]) + toD(m.positions[t[2]])) / 3.0;
  });
  const MaxSum from = distances(meshHash, reference.positions.size(), [&](std::size_t i) { return toD(reference.positions[i]); });
  e.toReference = to.max;
  e.fromReference = from.max;
  e.worstTo = {float(to.at.x), float(to.at.y), float(to.at.z)};
  e.worstFrom = {float(from.at.x), float(from.at.y), float(from.at.z)};
  e.meanToReference = to.sum / double(std::max<std::size_t>(1, nv + m.triangles.size()));
  return e;
}

}  // namespace blobvk::cpu
