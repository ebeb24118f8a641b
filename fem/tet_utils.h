// Small whole-mesh helpers on mesh::TetMesh: volumes, orientation, boundary extraction,
// validation and region assignment. Used by both meshers and by the simulation.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

namespace blobvk::fem {

using mesh::Double3;
using mesh::TetMesh;

// Signed volume of tet t (positive when its nodes follow the TetMesh orientation rule).
double tetVolume(const std::vector<Double3>& points, const std::array<std::uint32_t, 4>& tet);
// Sum of tet volumes over the rest (rest = true) or current positions.
double totalVolume(const TetMesh& mesh, bool rest);
// Swaps two nodes of every tet whose rest volume is negative.
void orientTets(TetMesh& mesh);
// Faces used by exactly one tet, oriented counter-clockwise seen from outside. Sorted, so the
// result does not depend on thread count or hash order.
std::vector<std::array<std::uint32_t, 3>> findBoundaryFaces(const TetMesh& mesh);
// Throws std::invalid_argument for: size mismatch between positions and rest positions, node
// index out of range, a repeated node in a tet, or a rest volume <= 1e-12 x the mean |volume|
// (degenerate or inverted tet), naming the first offending tet.
void validateTetMesh(const TetMesh& mesh);

// Region of the tet whose rest centroid is the argument (e.g. "the primitive that dominates the
// field here"). Fills mesh.regions, one entry per tet.
using RegionSelector = std::function<std::uint32_t(const Double3& centroid)>;
void assignRegions(TetMesh& mesh, const RegionSelector& selector);

}  // namespace blobvk::fem
