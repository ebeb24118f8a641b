// Preconditioned CG on the assembled system (system_matrix.h) with a Jacobi or 3x3
// block-Jacobi preconditioner, its vector updates fused into three parallel passes per
// iteration (product + p.Ap; x, r, z = P^-1 r and their dots; p) instead of six: at 10k tets a
// pass costs about as much in scheduling as in arithmetic. Same stopping rule and free-DOF
// restriction as solvePcg (pcg.h). Dots are summed per fixed chunk of nodes, then the chunk sums
// in order, so results do not depend on the thread count.
#pragma once

#include "blobvk/fem/pcg.h"

#include <array>
#include <vector>

namespace blobvk::fem {

class SystemMatrix;

// The solver's vectors, kept by the caller between solves (a step then allocates nothing).
struct BlockPcgScratch {
  std::vector<double> r, z, p, Ap;
  std::vector<std::array<double, 3>> partial;
};

// inverse: P^-1 per node, 9 values (block-Jacobi, row-major) or 3 (Jacobi: the diagonal),
// inverseStride says which; zero on fixed DOFs. x holds the warm start (fixed entries kept).
PcgResult solveBlockPcg(const SystemMatrix& A, const std::vector<double>& inverse, int inverseStride,
                        const std::vector<double>& b, const std::vector<unsigned char>& freeDof, std::vector<double>& x,
                        int maxIterations, double tolerance, BlockPcgScratch& scratch);

}  // namespace blobvk::fem
