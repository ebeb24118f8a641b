#include "blobvk/fem/pcg.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace blobvk::fem {
namespace {

// Vector passes run in parallel over fixed chunks; a dot product sums each chunk, then the chunk
// sums in order, so results do not depend on the thread count. Each pass fuses the updates of
// one CG step that read the same entries (3 passes per iteration instead of ~8 serial ones).
constexpr std::size_t kChunk = 4096;

using Sums = std::array<double, 2>;

// Runs body(begin, end) -> Sums over every chunk of [0, n) in parallel; returns the chunk sums
// added in chunk order.
template <class Body>
Sums reduceChunks(std::size_t n, std::vector<Sums>& partial, const Body& body) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  partial.assign(chunks, {0, 0});
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) partial[c] = body(c * kChunk, std::min(n, (c + 1) * kChunk));
  });
  Sums total{0, 0};
  for (const Sums& s : partial) {
    total[0] += s[0];
    total[1] += s[1];
  }
  return total;
}

}  // namespace

PcgResult solvePcg(const LinearOperator& A, const std::vector<double>& diagonal, const std::vector<double>& b,
                   const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations,
                   double tolerance) {
  const std::size_t n = b.size();
  std::vector<double> mask(n), invDiag(n), r(n), z(n), p(n), Ap(n);
  std::vector<Sums> partial;
  // Setup: mask, preconditioner, |b|^2 and |x|^2 over free DOFs.
  auto [bb, xx] = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
    Sums s{0, 0};
    for (std::size_t i = begin; i < end; ++i) {
      mask[i] = freeDof[i] ? 1.0 : 0.0;
      invDiag[i] = diagonal[i] > 0 ? mask[i] / diagonal[i] : 0.0;
      s[0] += b[i] * mask[i] * b[i];
      s[1] += x[i] * mask[i] * x[i];
    }
    return s;
  });
  PcgResult result;
  const double bNorm = std::sqrt(bb);
  if (bNorm == 0 && xx == 0) return result;
  A(x.data(), Ap.data());
  auto [rz, rr] = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
    Sums s{0, 0};
    for (std::size_t i = begin; i < end; ++i) {
      r[i] = (b[i] - Ap[i]) * mask[i];
      z[i] = invDiag[i] * r[i];
      p[i] = z[i];
      s[0] += r[i] * z[i];
      s[1] += r[i] * r[i];
    }
    return s;
  });
  const double target = tolerance * (bNorm > 0 ? bNorm : 1.0);
  double rNorm = std::sqrt(rr);
  while (result.iterations < maxIterations && rNorm > target) {
    A(p.data(), Ap.data());
    const double pAp = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0};
      for (std::size_t i = begin; i < end; ++i) {
        Ap[i] *= mask[i];
        s[0] += p[i] * Ap[i];
      }
      return s;
    })[0];
    if (!(pAp > 0)) break;  // direction of no curvature (converged to round-off, or bad matrix)
    const double alpha = rz / pAp;
    const auto [rzNew, rrNew] = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0};
      for (std::size_t i = begin; i < end; ++i) {
        x[i] += alpha * p[i];
        r[i] -= alpha * Ap[i];
        z[i] = invDiag[i] * r[i];
        s[0] += r[i] * z[i];
        s[1] += r[i] * r[i];
      }
      return s;
    });
    const double beta = rzNew / rz;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) p[i] = z[i] + beta * p[i];
    });
    rz = rzNew;
    rNorm = std::sqrt(rrNew);
    ++result.iterations;
  }
  result.relativeResidual = bNorm > 0 ? rNorm / bNorm : rNorm;
  return result;
}

}  // namespace blobvk::fem
