// A sliver pass after TetGen: TetGen's -q/<angle> and -o/<angle> leave a few tets below the
// requested minimum dihedral angle (measured on cleaned-up BlobTree surfaces: 7.5-9.9 degrees
// in 85k-215k tets), and which tets they are moves with small input changes. This pass
// moves the free nodes of those tets to raise the smallest dihedral angle of every tet around
// them. It never changes the connectivity and never moves a node off the surface, so the mesh
// stays valid (every tet keeps a positive volume) and conforming to the input surface.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

// Smallest of the six dihedral angles of a tet, in degrees (0 when degenerate).
double minDihedralDegrees(const std::vector<mesh::Double3>& points, const std::array<std::uint32_t, 4>& tet);

struct SliverStats {
  std::size_t tetsBelowBefore = 0, tetsBelowAfter = 0;  // tets with a dihedral angle < bound
  std::size_t nodesMoved = 0;
  double minDihedralBeforeDegrees = 180, minDihedralAfterDegrees = 180;
};

// For each tet with a dihedral angle below boundDegrees, moves its movable nodes by a local
// search (a step away from the opposite face of the worst tet, or towards the centroid of the
// neighbours) that is kept only where it raises the smallest dihedral angle of the node's
// star. Movable: nodes >= fixedNodes (TetGen's Steiner points; the input surface vertices come
// first and stay) that are interior, or on the boundary inside one flat facet (they slide in its
// plane, the boundary faces around them keep their orientation). Moves rest and current
// positions alike (call it before simulating). Deterministic and single-threaded; costs only
// around the slivers.
SliverStats smoothSlivers(mesh::TetMesh& mesh, double boundDegrees, std::size_t fixedNodes);

}  // namespace blobvk::fem
