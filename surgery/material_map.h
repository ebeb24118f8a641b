// World -> material coordinates through a deformed tet mesh: the inverse of the piecewise-affine
// deformation. A blade cuts the material it passes through; mapping its positions back into the
// rest configuration lets every cut event of a moving body be made in one fixed frame, where
// consecutive blade steps join exactly and a stroke can be swept again without drifting.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::surgery {

struct Box {
  mesh::Double3 lo, hi;
};

class MaterialMap {
 public:
  // Indexes the tets of `mesh` (rest positions and tets) at `positions` (the deformed state)
  // whose deformed box meets `region`; `cell` is the index's cell size (about an edge length).
  MaterialMap(const mesh::TetMesh& mesh, const std::vector<mesh::Double3>& positions, const Box& region, double cell);

  // The material (rest) point at world point p: inside a deformed tet, the same barycentric
  // combination of its rest nodes; outside the body, the nearest indexed tet's closest point
  // mapped to rest plus the offset from it (continuous across the surface, exact for
  // translations); with no tet within two cells, p minus the mean displacement of the region.
  mesh::Double3 toMaterial(const mesh::Double3& p) const;
  // How many tets the region holds (for tests and statistics).
  std::size_t indexedTets() const { return tets_.size(); }

 private:
  struct Entry {
    std::uint32_t tet;
    std::array<double, 12> inverse;  // rows of the inverse edge matrix, then the origin node
  };
  std::int64_t key(int x, int y, int z) const { return (std::int64_t(z) * dims_[1] + y) * dims_[0] + x; }

  const mesh::TetMesh& mesh_;
  const std::vector<mesh::Double3>& positions_;
  mesh::Double3 lo_;
  double cell_;
  std::array<int, 3> dims_{};
  std::vector<Entry> tets_;
  std::vector<std::uint32_t> cellStart_, cellTets_;  // cell c's tets: cellTets_[cellStart_[c] .. cellStart_[c + 1])
  mesh::Double3 meanDisplacement_;
};

}  // namespace blobvk::surgery
