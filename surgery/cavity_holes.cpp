#include "blobvk/surgery/cavity_holes.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>

namespace blobvk::surgery {
namespace {

struct Vec {
  double x, y, z;
};
Vec toVec(const mesh::Float3 &p) { return {p.x, p.y, p.z}; }
Vec sub(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
Vec cross(Vec a, Vec b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

std::uint32_t findRoot(std::vector<std::uint32_t> &parent, std::uint32_t v) {
  while (parent[v] != v)
    v = parent[v] = parent[parent[v]];
  return v;
}

} // namespace

std::vector<mesh::Double3> cavityHolePoints(const mesh::TriMesh &surface,
                                            const FieldAt &field, double iso,
                                            double step) {
  // Components by shared vertices (union-find over the triangles' corners).
  std::vector<std::uint32_t> parent(surface.positions.size());
  std::iota(parent.begin(), parent.end(), 0u);
  for (const auto &t : surface.triangles) {
    const std::uint32_t a = findRoot(parent, t[0]);
    for (int k = 1; k < 3; ++k) {
      const std::uint32_t b = findRoot(parent, t[k]);
      if (a != b)
        parent[std::max(a, b)] =
            std::min(a, b); // the root is the lowest vertex
    }
  }
  // Per component: signed volume (divergence theorem) and its triangles,
  // largest first.
  std::vector<double> volume(surface.positions.size(), 0.0);
  std::vector<std::vector<std::pair<double, std::size_t>>> triangles(
      surface.positions.size());
  for (std::size_t f = 0; f < surface.triangles.size(); ++f) {
    const auto &t = surface.triangles[f];
    const Vec a = toVec(surface.positions[t[0]]),
              b = toVec(surface.positions[t[1]]),
              c = toVec(surface.positions[t[2]]);
    const std::uint32_t root = findRoot(parent, t[0]);
    volume[root] += dot(a, cross(b, c)) / 6.0;
    const Vec n = cross(sub(b, a), sub(c, a));
    triangles[root].push_back({std::sqrt(dot(n, n)), f});
  }
  std::vector<mesh::Double3> holes;
  for (std::uint32_t root = 0; root < parent.size(); ++root) {
    if (findRoot(parent, root) != root || !(volume[root] < 0))
      continue;
    auto &list = triangles[root];
    // Larger triangles first (their normals are the most reliable); ties by
    // index.
    std::sort(list.begin(), list.end(), [](const auto &l, const auto &r) {
      return l.first != r.first ? l.first > r.first : l.second < r.second;
    });
    for (const auto &[area2, f] : list) {
      if (!(area2 > 0))
        break;
      const auto &t = surface.triangles[f];
      const Vec a = toVec(surface.positions[t[0]]),
                b = toVec(surface.positions[t[1]]),
                c = toVec(surface.positions[t[2]]);
      const Vec n = cross(sub(b, a), sub(c, a));
      const double s =
          step /
          area2; // |n| = area2: step along the unit normal, into the hollow
      const mesh::Double3 p{(a.x + b.x + c.x) / 3 + s * n.x,
                            (a.y + b.y + c.y) / 3 + s * n.y,
                            (a.z + b.z + c.z) / 3 + s * n.z};
      if (field(p) < iso) {
        holes.push_back(p);
        break;
      }
    }
  }
  return holes;
}

} // namespace blobvk::surgery
