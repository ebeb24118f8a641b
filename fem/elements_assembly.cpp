// ElementSet::assembleSystem: the warped stiffness of the last computeForces as 3x3 blocks
// (the preconditioner's copy of the system; the solver applies it matrix-free).
#include "blobvk/fem/block_system.h"
#include "blobvk/fem/elements.h"

#include <tbb/parallel_for.h>

namespace blobvk::fem {

void ElementSet::assembleSystem(BlockSystem& system, const double* nodeScale, double scale) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodeCount(), 256), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      double* rowValues = system.values.data() + 9 * std::size_t(system.rowStart[r]);
      std::fill(rowValues, system.values.data() + 9 * std::size_t(system.rowStart[r + 1]), 0.0);
      double* diagonal = system.values.data() + 9 * std::size_t(system.diagonal[r]);
      const double s = nodeScale ? nodeScale[r] : 0.0;
      diagonal[0] += s;
      diagonal[4] += s;
      diagonal[8] += s;
      // Block (i, j) of a tet = scale V [mu (h_i . h_j) I + mu h_j h_i^T + lambda h_i h_j^T],
      // the derivative of applySystem's per-tet product (h = R g, rotated gradients).
      for (const std::uint32_t* q = incidence_.begin(r); q != incidence_.end(r); ++q) {
        const std::uint32_t e = NodeIncidence::tetOf(*q);
        const int a = NodeIncidence::cornerOf(*q);
        double h[4][3];
        cornerGradients(e, h);
        const double sm = scale * volume_[e] * mu_[e], sl = scale * volume_[e] * stepLambda_[e];
        const double* hi = h[a];
        for (int b = 0; b < 4; ++b) {
          const double* hj = h[b];
          double* block = system.values.data() + 9 * std::size_t(system.find(r, tets_[e][std::size_t(b)]));
          const double dot = sm * (hi[0] * hj[0] + hi[1] * hj[1] + hi[2] * hj[2]);
          for (int x = 0; x < 3; ++x)
            for (int y = 0; y < 3; ++y) block[3 * x + y] += (x == y ? dot : 0.0) + sm * hj[x] * hi[y] + sl * hi[x] * hj[y];
        }
      }
    }
  });
}

}  // namespace blobvk::fem
