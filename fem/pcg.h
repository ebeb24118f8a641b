// Preconditioned conjugate gradients on a matrix-free symmetric operator, restricted to free
// DOFs (mask 0 = fixed: those entries of x are kept as given). x holds the warm start.
#pragma once

#include <functional>
#include <vector>

namespace blobvk::fem {

struct PcgResult {
  int iterations = 0;
  double relativeResidual = 0;  // |r| / |b| over free DOFs
  bool converged = false;       // |r| <= tolerance |b| was reached
};

// y = A x over all DOFs (x and y hold b.size() values).
using LinearOperator = std::function<void(const double* x, double* y)>;
// z = P^-1 r over all DOFs, P symmetric positive definite (entries of fixed DOFs are ignored).
using PreconditionerOperator = std::function<void(const double* r, double* z)>;

// Stops when |r| <= tolerance * |b| or after maxIterations (tolerance 0: run them all).
PcgResult solvePcg(const LinearOperator& A, const PreconditionerOperator& P, const std::vector<double>& b,
                   const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations, double tolerance);

}  // namespace blobvk::fem
