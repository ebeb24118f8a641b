#include "grid_mc.h"

#include "blobvk/mesh/marching_cubes.h"

#include <unordered_map>

namespace blobvk::testing {

mesh::TriMesh polygonizeSigns(const SignGrid& grid) {
  mesh::TriMesh out;
  std::unordered_map<long long, std::uint32_t> vertexOfEdge;
  const int n = grid.n;
  const auto vertex = [&](int i, int j, int k, int axis) {
    const long long key = ((long long)(k * n + j) * n + i) * 3 + axis;
    const auto [it, inserted] = vertexOfEdge.try_emplace(key, std::uint32_t(out.positions.size()));
    if (inserted) {
      float p[3] = {float(i), float(j), float(k)};
      p[axis] += 0.5f;
      out.positions.push_back({p[0], p[1], p[2]});
    }
    return it->second;
  };
  const auto& cases = mesh::marchingCubesCases();
  for (int k = 0; k + 1 < n; ++k)
    for (int j = 0; j + 1 < n; ++j)
      for (int i = 0; i + 1 < n; ++i) {
        int config = 0;
        for (int c = 0; c < 8; ++c)
          if (grid.at(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))) config |= 1 << c;
        const mesh::McCase& mc = cases[std::size_t(config)];
        for (int t = 0; t < mc.triangleCount; ++t) {
          std::array<std::uint32_t, 3> tri{};
          for (int v = 0; v < 3; ++v) {
            const int e = mc.edges[std::size_t(3 * t + v)];
            const auto s = mesh::mcEdgeStart(e);
            tri[std::size_t(v)] = vertex(i + s[0], j + s[1], k + s[2], mesh::mcEdgeAxis(e));
          }
          out.triangles.push_back(tri);
        }
      }
  return out;
}

}  // namespace blobvk::testing
