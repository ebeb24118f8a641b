#include "blobvk/fem/block_pcg.h"

#include "blobvk/fem/coarse_correction.h"
#include "blobvk/fem/kernel_dispatch.h"
#include "blobvk/fem/system_matrix.h"

#include <array>
#include <cmath>

#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

constexpr std::size_t kChunkNodes = 512;
using Sums = std::array<double, 4>;

// body(firstNode, endNode) -> Sums over fixed node chunks in parallel; chunk sums added in order.
template <class Body>
Sums overChunks(std::size_t nodes, std::vector<Sums>& partial, const Body& body) {
  const std::size_t chunks = (nodes + kChunkNodes - 1) / kChunkNodes;
  partial.resize(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c)
      partial[c] = body(c * kChunkNodes, std::min(nodes, (c + 1) * kChunkNodes));
  });
  Sums total{0, 0, 0, 0};
  for (const Sums& s : partial)
    for (std::size_t k = 0; k < total.size(); ++k) total[k] += s[k];
  return total;
}

// u = P^-1 r for one node: a 3x3 block (Stride 9, row-major) or a diagonal (Stride 3).
template <int Stride>
inline void precondition(const double* inverse, const double* r, double* u) {
  if constexpr (Stride == 9) {
    for (int a = 0; a < 3; ++a) u[a] = inverse[3 * a] * r[0] + inverse[3 * a + 1] * r[1] + inverse[3 * a + 2] * r[2];
  } else {
    for (int a = 0; a < 3; ++a) u[a] = inverse[a] * r[a];
  }
}

// Per-component partial dots (three independent sums, so the loop is not one serial chain of
// additions), folded in a fixed order.
struct Dots {
  double v[3] = {0, 0, 0};
  void add(int c, double x) { v[c] += x; }
  double total() const { return (v[0] + v[1]) + v[2]; }
};

// The first pass: r = b - A x and u = P^-1 r on free DOFs; sums |b|^2, |x|^2, |r|^2 and (r, u).
template <int Stride>
BLOBVK_FEM_KERNEL Sums residualChunk(const SystemMatrix& A, const double* inverse, const double* b,
                                     const unsigned char* freeDof, const double* x, double* r, double* u, double* w,
                                     std::size_t begin, std::size_t end) {
  A.multiplyRows(begin, end, x, w);
  Dots bb, xx, rr, ru;
  for (std::size_t v = begin; v < end; ++v) {
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * v + std::size_t(c);
      const double m = freeDof[i] ? 1.0 : 0.0;
      r[i] = (b[i] - w[i]) * m;
      bb.add(c, m * b[i] * b[i]);
      xx.add(c, m * x[i] * x[i]);
      rr.add(c, r[i] * r[i]);
    }
    precondition<Stride>(inverse + Stride * v, r + 3 * v, u + 3 * v);
    for (int c = 0; c < 3; ++c) ru.add(c, r[3 * v + std::size_t(c)] * u[3 * v + std::size_t(c)]);
  }
  return {bb.total(), xx.total(), rr.total(), ru.total()};
}

// w = A u on free DOFs (0 on fixed ones); returns (w, u).
BLOBVK_FEM_KERNEL Sums productChunk(const SystemMatrix& A, const unsigned char* freeDof, const double* u, double* w,
                                    std::size_t begin, std::size_t end) {
  A.multiplyRows(begin, end, u, w);
  Dots wu;
  for (std::size_t v = begin; v < end; ++v)
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * v + std::size_t(c);
      w[i] = freeDof[i] ? w[i] : 0.0;
      wu.add(c, w[i] * u[i]);
    }
  return {wu.total(), 0, 0, 0};
}

// One iteration's vector updates, fused: p = u + beta p, s = w + beta s (s = A p), x += alpha p,
// r -= alpha s, u = P^-1 r; returns |r|^2 and (r, u).
template <int Stride>
BLOBVK_FEM_KERNEL Sums updateChunk(const double* inverse, double alpha, double beta, double* p, double* s, double* x,
                                   double* r, double* u, const double* w, std::size_t begin, std::size_t end) {
  Dots rr, ru;
  for (std::size_t v = begin; v < end; ++v) {
    for (int c = 0; c < 3; ++c) {
      const std::size_t i = 3 * v + std::size_t(c);
      p[i] = u[i] + beta * p[i];
      s[i] = w[i] + beta * s[i];
      x[i] += alpha * p[i];
      r[i] -= alpha * s[i];
      rr.add(c, r[i] * r[i]);
    }
    precondition<Stride>(inverse + Stride * v, r + 3 * v, u + 3 * v);
    for (int c = 0; c < 3; ++c) ru.add(c, r[3 * v + std::size_t(c)] * u[3 * v + std::size_t(c)]);
  }
  return {rr.total(), ru.total(), 0, 0};
}

template <int Stride>
PcgResult solve(const SystemMatrix& A, const std::vector<double>& inverse, const std::vector<double>& b,
                const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations, double tolerance,
                BlockPcgScratch& scratch, const CoarseCorrection* coarse) {
  const std::size_t n = b.size(), nodes = n / 3;
  auto &r = scratch.r, &u = scratch.u, &p = scratch.p, &s = scratch.s, &w = scratch.w;
  auto& partial = scratch.partial;
  r.resize(n);
  u.resize(n);
  p.assign(n, 0.0);  // beta = 0 at the first update: p = u, s = w
  s.assign(n, 0.0);
  w.resize(n);
  const Sums setup = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
    return residualChunk<Stride>(A, inverse.data(), b.data(), freeDof.data(), x.data(), r.data(), u.data(), w.data(),
                                 begin, end);
  });
  PcgResult result;
  const double bNorm = std::sqrt(setup[0]);
  if (bNorm == 0 && setup[1] == 0) {
    result.converged = true;
    return result;
  }
  const double target = tolerance * (bNorm > 0 ? bNorm : 1.0);
  double rNorm = std::sqrt(setup[2]), ru = setup[3];
  if (coarse) ru += coarse->apply(r.data(), u.data(), freeDof);
  // Chronopoulos-Gear CG: the same iterates as standard PCG in exact arithmetic, but both dots
  // of an iteration come from one pass (alpha follows from (r, u) and (A u, u) by a recurrence),
  // so an iteration is two parallel passes (product; fused updates), not three.
  double alpha = 0, beta = 0;
  while (result.iterations < maxIterations && rNorm > target) {
    const double wu = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
      return productChunk(A, freeDof.data(), u.data(), w.data(), begin, end);
    })[0];
    // p.Ap of the next direction p = u + beta p.
    const double pAp = result.iterations == 0 ? wu : wu - beta * ru / alpha;
    if (!(pAp > 0)) break;  // direction of no curvature (converged to round-off, or bad matrix)
    alpha = ru / pAp;
    const Sums sums = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
      return updateChunk<Stride>(inverse.data(), alpha, beta, p.data(), s.data(), x.data(), r.data(), u.data(), w.data(),
                                 begin, end);
    });
    rNorm = std::sqrt(sums[0]);
    ++result.iterations;
    const double ruNext = sums[1] + (coarse && rNorm > target ? coarse->apply(r.data(), u.data(), freeDof) : 0.0);
    beta = ruNext / ru;
    ru = ruNext;
  }
  result.relativeResidual = bNorm > 0 ? rNorm / bNorm : rNorm;
  result.converged = rNorm <= target;
  return result;
}

}  // namespace

PcgResult solveBlockPcg(const SystemMatrix& A, const std::vector<double>& inverse, int stride, const std::vector<double>& b,
                        const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations,
                        double tolerance, BlockPcgScratch& scratch, const CoarseCorrection* coarse) {
  if (stride == 9) return solve<9>(A, inverse, b, freeDof, x, maxIterations, tolerance, scratch, coarse);
  return solve<3>(A, inverse, b, freeDof, x, maxIterations, tolerance, scratch, coarse);
}

}  // namespace blobvk::fem
