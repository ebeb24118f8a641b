// Indexed triangle mesh, the common output of every polygonizer. Plain arrays, owned by value.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "blobvk/mesh/mesh_array.h"

namespace blobvk::mesh {

struct Float3 {
  float x = 0, y = 0, z = 0;
  friend bool operator==(const Float3&, const Float3&) = default;
};

// The arrays are MeshArrays (mesh_array.h): std::vectors whose resize(n) leaves new elements
// unwritten, to be written by the caller; resize(n, {}) fills them.
struct TriMesh {
  MeshArray<Float3> positions;
  MeshArray<Float3> normals;  // empty or one per position
  MeshArray<Float3> colours;  // empty or one per position, linear RGB in [0, 1]
  MeshArray<std::array<std::uint32_t, 3>> triangles;  // counter-clockwise seen from outside
  // Global grid-edge index of each vertex when it came from a polygonizer (empty otherwise):
  // the key that orders vertices and makes CPU and GPU meshes comparable index by index.
  MeshArray<std::uint64_t> edgeKeys;

  std::size_t vertexCount() const { return positions.size(); }
  std::size_t triangleCount() const { return triangles.size(); }
  friend bool operator==(const TriMesh&, const TriMesh&) = default;
};

}  // namespace blobvk::mesh
