// The block and blade strokes of the cut-event benchmarks (bench_cutting's BM_CutEvent and
// bench_cut_event): n^3 unit voxels, 6 positive tets each (the thesis split, as
// fem::voxelTetrahedralize), and stroke k, a square blade patch of half-size 5 centred at
// z = 3.5 + k, slightly tilted so that every cut case occurs; strokes k = 0..15 cut parallel,
// disjoint slices of a block at least 26 cells high.
#pragma once

#include "blobvk/cutting/cutter.h"
#include "blobvk/cutting/vec.h"

#include <array>
#include <utility>
#include <vector>

namespace blobvk::bench {

inline mesh::TetMesh cube(int n) {
  mesh::TetMesh m;
  auto id = [n](int x, int y, int z) { return std::uint32_t((z * (n + 1) + y) * (n + 1) + x); };
  for (int z = 0; z <= n; ++z)
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x) m.positions.push_back({double(x), double(y), double(z)});
  m.restPositions = m.positions;
  constexpr int kSix[6][4] = {{0, 2, 1, 4}, {3, 2, 4, 1}, {3, 2, 6, 4}, {3, 1, 4, 5}, {3, 4, 6, 5}, {3, 6, 7, 5}};
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        std::array<std::uint32_t, 8> c{};
        for (int b = 0; b < 8; ++b) c[std::size_t(b)] = id(x + (b & 1), y + (b >> 1 & 1), z + (b >> 2 & 1));
        for (const auto& s : kSix) {
          cutting::Tet t{c[std::size_t(s[0])], c[std::size_t(s[1])], c[std::size_t(s[2])], c[std::size_t(s[3])]};
          const auto& p = m.positions;
          if (cutting::tetVolume(p[t[0]], p[t[1]], p[t[2]], p[t[3]]) < 0) std::swap(t[2], t[3]);
          m.tets.push_back(t);
        }
      }
  return m;
}

inline std::vector<cutting::Triangle> stroke(int k) {
  using cutting::operator*;
  using cutting::operator+;
  using cutting::operator-;
  const auto unit = [](mesh::Double3 v) { return v * (1.0 / cutting::length(v)); };
  const mesh::Double3 c{8.3 + 0.37 * (k % 3), 8.6 - 0.21 * (k % 5), 3.5 + k + 0.13 * (k % 2)};
  const mesh::Double3 u = unit({1, 0.2, 0.1}), v = unit(cutting::cross(u, {0.1, -0.3, 1}));
  const cutting::BladeKeyframe from{0.0, c - u * 5.0 - v * 5.0, c - u * 5.0 + v * 5.0};
  const cutting::BladeKeyframe to{1.0, c + u * 5.0 - v * 5.0, c + u * 5.0 + v * 5.0};
  return cutting::sweptTriangles(from, to);
}

}  // namespace blobvk::bench
