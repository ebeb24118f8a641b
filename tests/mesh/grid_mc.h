// Test helper: marching cubes over a boolean grid with midpoint vertices, written independently
// of the library's polygonizers so the case table can be tested on its own.
#pragma once

#include "blobvk/mesh/trimesh.h"

#include <vector>

namespace blobvk::testing {

struct SignGrid {
  int n = 0;  // points per axis
  std::vector<bool> inside;  // n^3, x fastest
  bool at(int i, int j, int k) const { return inside[std::size_t((k * n + j) * n + i)]; }
};

// One vertex per crossing edge at the edge midpoint, welded; triangles from the case table.
mesh::TriMesh polygonizeSigns(const SignGrid& grid);

}  // namespace blobvk::testing
