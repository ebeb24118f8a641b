// Tetrahedral mesh value type shared by the FEM and cutting modules. Plain arrays, owned by
// value; double precision because the simulation integrates in double.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::mesh {

struct Double3 {
  double x = 0, y = 0, z = 0;
  friend bool operator==(const Double3&, const Double3&) = default;
};

struct TetMesh {
  std::vector<Double3> positions;      // current (deformed) positions
  std::vector<Double3> restPositions;  // rest state; same size as positions
  // Nodes of each tet, ordered so that dot(p1 - p0, cross(p2 - p0, p3 - p0)) > 0 at rest.
  std::vector<std::array<std::uint32_t, 4>> tets;
  // Boundary faces (counter-clockwise seen from outside), as node triples.
  std::vector<std::array<std::uint32_t, 3>> boundaryFaces;
  std::vector<std::uint32_t> regions;  // material region per tet (empty: all region 0)

  std::size_t nodeCount() const { return positions.size(); }
  std::size_t tetCount() const { return tets.size(); }
};

}  // namespace blobvk::mesh
