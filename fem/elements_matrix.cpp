// ElementSet::assembleMatrix: A = diag(nodeScale) + s K~ at the rotations of the last
// computeForces into the solver's block-sparse matrix (system_matrix.h), one row per task.
#include "blobvk/fem/elements.h"
#include "blobvk/fem/kernel_dispatch.h"
#include "blobvk/fem/system_matrix.h"

#include <algorithm>
#include <vector>

#include <tbb/parallel_for.h>

namespace blobvk::fem {

BLOBVK_FEM_KERNEL void ElementSet::assembleMatrixRows(std::size_t begin, std::size_t end, SystemMatrix& matrix,
                                                       const double* nodeScale, double scale) const {
  std::vector<double> acc(9 * matrix.longestRow());  // the row's off-diagonal blocks, summed in double
  for (std::size_t r = begin; r != end; ++r) {
    const std::uint32_t first = matrix.rowBegin(r), count = matrix.rowEnd(r) - first;
    std::fill_n(acc.begin(), 9 * std::size_t(count), 0.0);
    // Block (a, b) of a tet = scale V [mu (h_a . h_b) I + mu h_b h_a^T + lambda h_a h_b^T], the
    // derivative of applySystem's per-tet product; summed in the incidence row's order.
    for (const std::uint32_t* q = incidence_.begin(r); q != incidence_.end(r); ++q) {
      const std::uint32_t e = NodeIncidence::tetOf(*q);
      const int a = NodeIncidence::cornerOf(*q);
      double h[4][3];
      cornerGradients(e, h);
      const double sm = scale * volume_[e] * mu_[e], sl = scale * volume_[e] * stepLambda_[e];
      const double* hi = h[a];
      const double smi[3] = {sm * hi[0], sm * hi[1], sm * hi[2]}, sli[3] = {sl * hi[0], sl * hi[1], sl * hi[2]};
      for (int b = 0; b < 4; ++b) {
        if (b == a) continue;
        const double* hj = h[b];
        double* block = acc.data() + 9 * std::size_t(matrix.slot(e, a, b));
        const double dot = smi[0] * hj[0] + smi[1] * hj[1] + smi[2] * hj[2];
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y) block[3 * x + y] += (x == y ? dot : 0.0) + hj[x] * smi[y] + sli[x] * hj[y];
      }
    }
    // Off-diagonals rounded to float; the diagonal is minus their sum as stored (the rows of K~
    // sum to zero), so the stored K~ still maps a rigid translation to exactly zero.
    double sum[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (std::uint32_t k = 0; k < count; ++k) {
      float* out = matrix.offDiagonal(first + k);
      for (int v = 0; v < 9; ++v) {
        out[v] = float(acc[9 * std::size_t(k) + std::size_t(v)]);
        sum[v] += double(out[v]);
      }
    }
    double* d = matrix.diagonal(r);
    const double m = nodeScale ? nodeScale[r] : 0.0;
    for (int v = 0; v < 9; ++v) d[v] = (v % 4 == 0 ? m : 0.0) - sum[v];
  }
}

void ElementSet::assembleMatrix(SystemMatrix& matrix, const double* nodeScale, double scale) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodeCount(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    assembleMatrixRows(r.begin(), r.end(), matrix, nodeScale, scale);
  });
}

}  // namespace blobvk::fem
