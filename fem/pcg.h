// Jacobi-preconditioned conjugate gradients on a matrix-free symmetric operator, restricted to
// free DOFs (mask 0 = fixed: those entries of x are kept as given). x holds the warm start.
#pragma once

#include <functional>
#include <vector>

namespace blobvk::fem {

struct PcgResult {
  int iterations = 0;
  double relativeResidual = 0;  // |r| / |b| over free DOFs
};

// y = A x over all DOFs (x and y hold b.size() values).
using LinearOperator = std::function<void(const double* x, double* y)>;

// Stops when |r| <= tolerance * |b| or after maxIterations (tolerance 0: run them all).
// `diagonal` is A's diagonal (the Jacobi preconditioner; entries <= 0 are not preconditioned).
PcgResult solvePcg(const LinearOperator& A, const std::vector<double>& diagonal, const std::vector<double>& b,
                   const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations, double tolerance);

}  // namespace blobvk::fem
