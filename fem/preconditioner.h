// Preconditioners for the implicit system's CG (z = P^-1 r), built from what a step computes:
// Jacobi and 3x3 block-Jacobi from A's diagonal blocks (6 values per node), incomplete Cholesky
// from the assembled block system (Eigen's IncompleteCholesky, AMD ordering, the ordering kept
// while the mesh's pattern is). Fixed DOFs are decoupled (identity rows), so P stays SPD.
// Everything is serial or per-row, so P^-1 r does not depend on the thread count.
#pragma once

#include "blobvk/fem/simulation.h"  // PreconditionerKind

#include <memory>
#include <vector>

namespace blobvk::fem {

struct BlockSystem;

class SystemPreconditioner {
 public:
  SystemPreconditioner();
  ~SystemPreconditioner();
  SystemPreconditioner(SystemPreconditioner&&) noexcept;
  SystemPreconditioner& operator=(SystemPreconditioner&&) noexcept;

  // Jacobi / block-Jacobi: blocks holds 6 values per node (xx, yy, zz, xy, xz, yz).
  void setDiagonalBlocks(PreconditionerKind kind, const std::vector<double>& blocks, const std::vector<unsigned char>& freeDof);
  // Incomplete Cholesky of `system`; patternChanged: the block pattern is new (the fill-reducing
  // ordering is recomputed). Returns false when the factorization failed (the caller falls back).
  bool factorize(const BlockSystem& system, const std::vector<unsigned char>& freeDof, bool patternChanged);
  // z = P^-1 r over 3 * nodes values (fixed DOFs: z = 0).
  void apply(const double* r, double* z) const;
  // The kind last set up, and for Jacobi / block-Jacobi P^-1 (3 / 9 values per node).
  PreconditionerKind kind() const;
  const std::vector<double>& inverse() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace blobvk::fem
