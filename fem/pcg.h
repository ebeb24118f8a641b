// Jacobi-preconditioned conjugate gradients on a BlockMatrix3, restricted to free DOFs (mask 0 =
// fixed: those entries of x are kept as given). x holds the warm start on entry.
#pragma once

#include "fem/block_matrix.h"

#include <vector>

namespace blobvk::fem {

struct PcgResult {
  int iterations = 0;
  double relativeResidual = 0;  // |r| / |b| over free DOFs
};

// Stops when |r| <= tolerance * |b| or after maxIterations (tolerance 0: run them all).
PcgResult solvePcg(const BlockMatrix3& A, const std::vector<double>& b, const std::vector<unsigned char>& freeDof,
                   std::vector<double>& x, int maxIterations, double tolerance);

}  // namespace blobvk::fem
