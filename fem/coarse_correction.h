// A two-level additive correction for the (block-)Jacobi CG: nodes grouped in aggregates (cubes
// of the rest shape holding ~targetNodes nodes), the implicit system restricted to the
// aggregates' translations (Ac = R A R^T, 3 unknowns per aggregate, R sums a node's free DOFs
// into its aggregate) and solved exactly: P^-1 = D^-1 + R^T Ac^-1 R. Block-Jacobi damps the
// local, oscillating part of the error; what CG otherwise spends most iterations on is the smooth,
// long-range part, which the aggregates' translations capture (~3x fewer iterations on the
// pressed block, docs/fem.md). Everything is serial or per aggregate in a fixed order, so the
// result does not depend on the thread count.
#pragma once

#include "blobvk/mesh/tetmesh.h"

#include <memory>
#include <vector>

namespace blobvk::fem {

class SystemMatrix;

class CoarseCorrection {
 public:
  CoarseCorrection();
  ~CoarseCorrection();
  CoarseCorrection(CoarseCorrection&&) noexcept;
  CoarseCorrection& operator=(CoarseCorrection&&) noexcept;

  // Bins the rest positions into cubes sized to hold ~targetNodes nodes (of the bounding box's
  // density); aggregates are numbered in node order of first appearance.
  void setAggregates(const std::vector<mesh::Double3>& rest, std::size_t targetNodes);
  std::size_t aggregateCount() const;
  // Ac = R A R^T over free DOFs, factored (sparse Cholesky). Nodes added since (a topology
  // change) join the cube their rest position falls in. Returns false when Ac is not positive
  // definite (then apply must not be called).
  bool factor(const SystemMatrix& A, const std::vector<unsigned char>& freeDof, const std::vector<mesh::Double3>& rest);
  // u += R^T Ac^-1 R r on free DOFs (r is 0 on fixed DOFs); returns (R r) . Ac^-1 R r, which is
  // (r, R^T Ac^-1 R r).
  double apply(const double* r, double* u, const std::vector<unsigned char>& freeDof) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace blobvk::fem
