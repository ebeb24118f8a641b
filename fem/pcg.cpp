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

PcgResult solvePcg(const LinearOperator& A, const PreconditionerOperator& P, const std::vector<double>& b,
                   const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations,
                   double tolerance) {
  const std::size_t n = b.size();
  std::vector<double> mask(n), r(n), z(n), p(n), Ap(n);
  std::vector<Sums> partial;
  auto parallelPass = [n](const auto& body) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kChunk), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) body(i);
    });
  };
  // Setup: mask, |b|^2 and |x|^2 over free DOFs.
  auto [bb, xx] = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
    Sums s{0, 0};
    for (std::size_t i = begin; i < end; ++i) {
      mask[i] = freeDof[i] ? 1.0 : 0.0;
      s[0] += b[i] * mask[i] * b[i];
      s[1] += x[i] * mask[i] * x[i];
    }
    return s;
  });
  PcgResult result;
  const double bNorm = std::sqrt(bb);
  if (bNorm == 0 && xx == 0) {
    result.converged = true;
    return result;
  }
  A(x.data(), Ap.data());
  double rr = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
    Sums s{0, 0};
    for (std::size_t i = begin; i < end; ++i) {
      r[i] = (b[i] - Ap[i]) * mask[i];
      s[0] += r[i] * r[i];
    }
    return s;
  })[0];
  // z = P^-1 r on free DOFs; returns r.z.
  auto precondition = [&] {
    P(r.data(), z.data());
    return reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0};
      for (std::size_t i = begin; i < end; ++i) {
        z[i] *= mask[i];
        s[0] += r[i] * z[i];
      }
      return s;
    })[0];
  };
  const double target = tolerance * (bNorm > 0 ? bNorm : 1.0);
  double rNorm = std::sqrt(rr);
  double rz = 0;
  if (rNorm > target && maxIterations > 0) {
    rz = precondition();
    parallelPass([&](std::size_t i) { p[i] = z[i]; });
  }
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
    rr = reduceChunks(n, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0};
      for (std::size_t i = begin; i < end; ++i) {
        x[i] += alpha * p[i];
        r[i] -= alpha * Ap[i];
        s[0] += r[i] * r[i];
      }
      return s;
    })[0];
    rNorm = std::sqrt(rr);
    ++result.iterations;
    if (rNorm <= target) break;
    const double rzNew = precondition();
    const double beta = rzNew / rz;
    parallelPass([&](std::size_t i) { p[i] = z[i] + beta * p[i]; });
    rz = rzNew;
  }
  result.relativeResidual = bNorm > 0 ? rNorm / bNorm : rNorm;
  result.converged = rNorm <= target;
  return result;
}

}  // namespace blobvk::fem
