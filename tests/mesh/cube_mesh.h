// A unit cube [0,1]^3 as 8 vertices and 12 outward triangles, built by hand for the tests.
#pragma once

#include "blobvk/mesh/trimesh.h"

namespace blobvk::testing {

inline mesh::TriMesh unitCube(float offsetX = 0.0f) {
  mesh::TriMesh m;
  for (int c = 0; c < 8; ++c)
    m.positions.push_back({float(c & 1) + offsetX, float((c >> 1) & 1), float((c >> 2) & 1)});
  // Two triangles per face, counter-clockwise seen from outside.
  const std::uint32_t faces[6][4] = {
      {0, 2, 3, 1},  // z = 0, normal -z
      {4, 5, 7, 6},  // z = 1, normal +z
      {0, 1, 5, 4},  // y = 0, normal -y
      {2, 6, 7, 3},  // y = 1, normal +y
      {0, 4, 6, 2},  // x = 0, normal -x
      {1, 3, 7, 5},  // x = 1, normal +x
  };
  for (const auto& f : faces) {
    m.triangles.push_back({f[0], f[1], f[2]});
    m.triangles.push_back({f[0], f[2], f[3]});
  }
  return m;
}

}  // namespace blobvk::testing
