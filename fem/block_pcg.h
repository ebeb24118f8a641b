// Preconditioned CG on the assembled system (system_matrix.h) with a Jacobi or 3x3
// block-Jacobi preconditioner in two parallel passes per iteration (the product w = A u with
// (w, u); then p, s = A p, x, r, u = P^-1 r and the dots |r|^2, (r, u)) instead of three: at 10k
// tets a pass costs about as much in scheduling as in arithmetic. Chronopoulos-Gear's recurrence
// (p.Ap from (w, u)) is what lets both dots share one pass. With `coarse`, P^-1 also adds the
// two-level correction (coarse_correction.h), serially after the update pass. Same stopping rule and free-DOF
// restriction as solvePcg (pcg.h). Dots are summed per fixed chunk of nodes, then the chunk sums
// in order, so results do not depend on the thread count.
#pragma once

#include "blobvk/fem/pcg.h"

#include <array>
#include <vector>

namespace blobvk::fem {

class SystemMatrix;
class CoarseCorrection;

// The solver's vectors, kept by the caller between solves (a step then allocates nothing).
struct BlockPcgScratch {
  std::vector<double> r, u, p, s, w;
  std::vector<std::array<double, 4>> partial;
};

// inverse: P^-1 per node, 9 values (block-Jacobi, row-major) or 3 (Jacobi: the diagonal),
// inverseStride says which; zero on fixed DOFs. x holds the warm start (fixed entries kept).
PcgResult solveBlockPcg(const SystemMatrix& A, const std::vector<double>& inverse, int inverseStride,
                        const std::vector<double>& b, const std::vector<unsigned char>& freeDof, std::vector<double>& x,
                        int maxIterations, double tolerance, BlockPcgScratch& scratch,
                        const CoarseCorrection* coarse = nullptr);

}  // namespace blobvk::fem
