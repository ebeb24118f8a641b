// Per-element data of the corotational linear tet model and the two per-step passes over it:
// rotations (embarrassingly parallel) and forces + warped stiffness (parallel per colour: no two
// tets of one colour share a node, so scatters need no locks and stay deterministic).
#pragma once

#include "fem/block_matrix.h"
#include "fem/material.h"
#include "mesh/tetmesh.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

struct ElementSet {
  std::vector<std::array<std::uint32_t, 4>> tets;
  std::vector<std::array<double, 9>> restInverse;  // Dm^-1, row-major; rows are grad N1..N3
  std::vector<double> volume, lambda, mu, density;
  std::vector<std::array<double, 4>> quaternion;   // warm start of the rotation extraction
  std::vector<std::array<double, 9>> rotation;     // R of the last rotation pass, row-major
  std::vector<std::vector<std::uint32_t>> colours;

  // Expects a validated mesh and one material per region index used.
  void build(const mesh::TetMesh& mesh, const std::vector<Material>& materials);
  std::size_t size() const { return tets.size(); }
  // rho V / 4 to each node of each tet.
  std::vector<double> lumpedMass(std::size_t nodeCount) const;
  // Extracts every element's rotation at positions x; returns the total iterations.
  long long updateRotations(const std::vector<mesh::Double3>& x, int maxIterations);
  // Adds the elastic forces -R sigma(eps) grad N V into force (3 per node) and, when matrix is
  // not null, stiffnessScale * R K_e R^T into its blocks. Returns the elastic energy
  // sum V (mu eps:eps + lambda/2 tr(eps)^2), eps = sym(R^T F) - I.
  double addForcesAndStiffness(const std::vector<mesh::Double3>& x, std::vector<double>& force, BlockMatrix3* matrix,
                               double stiffnessScale) const;
};

}  // namespace blobvk::fem
