#include "blobvk/cutting/parts.h"

#include <algorithm>
#include <numeric>
#include <unordered_map>

namespace blobvk::cutting {

std::vector<std::vector<std::uint32_t>> disjointParts(const CutTopology& topology) {
  const std::size_t n = topology.slotCount();
  std::vector<std::uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (std::uint32_t s = 0; s < n; ++s) {
    if (!topology.alive(s)) continue;
    const Tet& t = topology.tet(s);
    for (const auto& f : kTetFaces) {
      const auto pair = topology.tetsOfFace(t[f[0]], t[f[1]], t[f[2]]);
      const std::uint32_t other = pair[0] == s ? pair[1] : pair[0];
      if (other != kNone) parent[find(s)] = find(other);
    }
  }
  std::unordered_map<std::uint32_t, std::size_t> index;
  std::vector<std::vector<std::uint32_t>> parts;
  for (std::uint32_t s = 0; s < n; ++s) {
    if (!topology.alive(s)) continue;
    const auto [it, inserted] = index.emplace(find(s), parts.size());
    if (inserted) parts.emplace_back();
    parts[it->second].push_back(s);
  }
  std::stable_sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return parts;
}

mesh::TriMesh boundarySurface(const CutTopology& topology) {
  mesh::TriMesh out;
  std::unordered_map<std::uint32_t, std::uint32_t> vertexOf;
  const auto& p = topology.mesh().positions;
  for (std::uint32_t s = 0; s < topology.slotCount(); ++s) {
    if (!topology.alive(s)) continue;
    const Tet& t = topology.tet(s);
    for (const auto& f : kTetFaces) {
      const auto pair = topology.tetsOfFace(t[f[0]], t[f[1]], t[f[2]]);
      if (pair[1] != kNone) continue;
      std::array<std::uint32_t, 3> tri;
      for (int i = 0; i < 3; ++i) {
        const std::uint32_t node = t[f[i]];
        const auto [it, inserted] = vertexOf.emplace(node, std::uint32_t(out.positions.size()));
        if (inserted) out.positions.push_back({float(p[node].x), float(p[node].y), float(p[node].z)});
        tri[i] = it->second;
      }
      out.triangles.push_back(tri);
    }
  }
  return out;
}

}  // namespace blobvk::cutting
