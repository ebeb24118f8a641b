// Per-element data of the corotational linear tet model and the per-step passes over it, all
// matrix-free and without colouring: one fused per-tet pass (rotation, stress, rotated shape
// gradients) writes per-tet results, and a per-node gather over the NodeIncidence rows sums
// them. No two threads write the same value and every sum runs in one fixed order, so results
// do not depend on the thread count. The stiffness matrix is never assembled:
// K p is applied element by element, (K p)_i = V [mu (X + X^T) + lambda tr(X) I] h_i with
// X = sum_j p_j h_j^T and h = R g the rotated shape-function gradients (warped stiffness).
// Per-tet passes write one 3-vector per corner; the node gather then only adds.
#pragma once

#include "blobvk/fem/material.h"
#include "blobvk/fem/node_incidence.h"
#include "blobvk/mesh/tetmesh.h"

#include <array>
#include <cstdint>
#include <vector>

namespace blobvk::fem {

struct BlockSystem;
class SystemMatrix;

struct ElasticPassResult {
  double energy = 0;                 // sum V (mu eps:eps + lambda/2 tr(eps)^2), eps = sym(R^T F) - I
  long long rotationIterations = 0;  // over all tets
};

class ElementSet {
 public:
  // Expects a validated mesh and one material per region index used.
  // cutRoom: SimulationSettings::cutRoom.
  void build(const mesh::TetMesh& mesh, const std::vector<Material>& materials, double cutRoom = 0.0);
  std::size_t size() const { return tets_.size(); }
  std::size_t nodeCount() const { return incidence_.nodeCount(); }
  const NodeIncidence& incidence() const { return incidence_; }

  // Incremental edits (a topology change): new nodes have no tets yet; `appendSlots` adds
  // `count` slots past the end (all arrays grow once), which setTet must then fill in order
  // before any pass runs; `setTet` rewrites slot `tet` (or fills the next appended slot, or
  // appends it when tet == size()) from rest positions and a material, resets its rotation warm
  // start and updates the incidence rows of the old and new nodes only.
  void addNodes(std::size_t count) { incidence_.addNodes(count); }
  void appendSlots(std::size_t count);
  void setTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes, const std::vector<mesh::Double3>& rest,
              const Material& material);

  // rho V / 4 from each incident tet, summed in incidence order.
  double lumpedMass(std::size_t node) const;
  std::vector<double> lumpedMass() const;

  // Pass 1 (per tet): rotations at positions x (warm-started), stresses, rotated gradients.
  // Pass 2 (per node): elastic forces -R sigma grad N V into force (3 per node, overwritten) and,
  // when diagonalBlocks is not null, K's 3x3 diagonal blocks (6 per node: xx, yy, zz, xy, xz,
  // yz; overwritten).
  ElasticPassResult computeForces(const std::vector<mesh::Double3>& x, int maxRotationIterations, double* force,
                                  double* diagonalBlocks);
  // y = nodeScale[node] * p + stiffnessScale * K p, with K at the rotations of the last
  // computeForces; p and y hold 3 values per node. nodeScale may be null (treated as 0).
  void applySystem(const double* p, double* y, const double* nodeScale, double stiffnessScale);
  double lastTetPassMs() const { return lastTetPassMs_; }  // pass 1 of the last computeForces
  // The same system as applySystem, as 3x3 blocks into `system` (its pattern built by
  // buildBlockPattern for the current tets): values overwritten.
  void assembleSystem(BlockSystem& system, const double* nodeScale, double stiffnessScale) const;

  // The same system into the solver's block-sparse matrix (its pattern built for the current
  // tets): off-diagonal blocks in float, diagonal blocks derived from them (system_matrix.h).
  void assembleMatrix(SystemMatrix& matrix, const double* nodeScale, double stiffnessScale) const;

 private:
  void assembleMatrixRows(std::size_t begin, std::size_t end, SystemMatrix& matrix, const double* nodeScale,
                          double stiffnessScale) const;
  void reserve(std::size_t tets);
  // The per-tet halves of computeForces and applySystem over tets [begin, end).
  void tetPass(std::size_t begin, std::size_t end, const std::vector<mesh::Double3>& x, int maxIterations,
               bool withDiagonal);
  void stiffnessPass(std::size_t begin, std::size_t end, const double* p, double scale);
  // y_node = nodeScale[node] p_node + sum of tetVectors_ over the node's incidence row.
  void gather(double* y, const double* nodeScale, const double* p) const;
  // out = (x0, x1, x2) + the per-corner 3-vectors of node r's incidence row, in the row's order.
  void sumCorners(const std::vector<std::array<double, 12>>& perCorner, std::size_t r, double x0, double x1, double x2,
                  double* out) const;
  void writeTet(std::uint32_t tet, const std::array<std::uint32_t, 4>& nodes, const std::vector<mesh::Double3>& rest,
                const Material& material);  // element data only, of an existing slot

  std::vector<std::array<std::uint32_t, 4>> tets_;
  std::vector<std::array<double, 9>> restInverse_;  // Dm^-1, row-major; rows are grad N1..N3
  std::vector<double> volume_, lambda_, mu_, density_;
  std::vector<double> stepLambda_;  // lambda stiffened under compression, set by the tet pass (rotation.h)
  std::vector<std::array<double, 4>> quaternion_;         // warm start of the rotation extraction
  std::vector<std::array<double, 9>> rotatedGradients_;   // h_i = R grad N_i, i = 1..3 (h_0 = -sum)
  // The four corners' rotated gradients of tet e: h_1..h_3 as stored, h_0 = -(h_1 + h_2 + h_3).
  void cornerGradients(std::size_t e, double h[4][3]) const {
    const double* g = rotatedGradients_[e].data();
    for (int c = 0; c < 3; ++c) {
      h[1][c] = g[c];
      h[2][c] = g[3 + c];
      h[3][c] = g[6 + c];
      h[0][c] = -(h[1][c] + h[2][c] + h[3][c]);
    }
  }
  std::vector<std::array<double, 12>> tetVectors_;       // per-tet, per-corner results to gather
  std::vector<std::array<double, 24>> tetDiagonal_;      // per-corner diagonal block of K (6 each)
  std::vector<double> tetEnergy_;
  std::vector<int> tetIterations_;
  NodeIncidence incidence_;
  std::size_t filled_ = 0;  // slots [filled_, size()) are appended and not written yet
  double lastTetPassMs_ = 0;
};

}  // namespace blobvk::fem
