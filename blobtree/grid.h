// The sampling grid every polygonizer uses: points origin + cellSize * (i, j, k) for
// 0 <= i <= cells.x etc. Global edge keys (point index * 3 + axis) order mesh vertices.
#pragma once

#include "blobvk/blobtree/program.h"

#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>

namespace blobvk::blobtree {

struct GridSettings;

struct GridSpec {
  glm::vec3 origin{0.0f};
  float cellSize = 0.1f;
  glm::ivec3 cells{0};  // cells per axis; points per axis are cells + 1

  glm::ivec3 points() const { return cells + 1; }
  std::uint64_t pointCount() const;
  glm::vec3 point(int i, int j, int k) const {
    return origin + cellSize * glm::vec3(float(i), float(j), float(k));
  }
  std::uint64_t pointIndex(int i, int j, int k) const {
    const glm::ivec3 p = points();
    return (std::uint64_t(k) * std::uint64_t(p.y) + std::uint64_t(j)) * std::uint64_t(p.x) +
           std::uint64_t(i);
  }
  // Key of the grid edge that starts at point (i, j, k) and runs along axis (0 x, 1 y, 2 z).
  std::uint64_t edgeKey(int i, int j, int k, int axis) const {
    return pointIndex(i, j, k) * 3u + std::uint64_t(axis);
  }
};

struct GridRequest {
  std::optional<float> cellSize;   // wins over resolution
  std::optional<int> resolution;   // cells along the longest side of the bounds
};

// Chooses the grid for a program: the box is the scene's grid bounds when given, else the
// program's bounds; command-line requests win over the scene's settings; the default is 128
// cells along the longest side. The grid gets one cell of margin so a closed surface never
// touches its border. Throws std::invalid_argument when the bounds are unbounded or the
// request is not positive.
GridSpec chooseGrid(const Program& program, const GridSettings& scene, const GridRequest& request);

}  // namespace blobvk::blobtree
