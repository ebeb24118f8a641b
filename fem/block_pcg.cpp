#include "blobvk/fem/block_pcg.h"

#include "blobvk/fem/system_matrix.h"

#include <array>
#include <cmath>

#include <tbb/parallel_for.h>

namespace blobvk::fem {
namespace {

constexpr std::size_t kChunkNodes = 512;
using Sums = std::array<double, 3>;

// body(firstNode, endNode) -> Sums over fixed node chunks in parallel; chunk sums added in order.
template <class Body>
Sums overChunks(std::size_t nodes, std::vector<Sums>& partial, const Body& body) {
  const std::size_t chunks = (nodes + kChunkNodes - 1) / kChunkNodes;
  partial.resize(chunks);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c)
      partial[c] = body(c * kChunkNodes, std::min(nodes, (c + 1) * kChunkNodes));
  });
  Sums total{0, 0, 0};
  for (const Sums& s : partial)
    for (int k = 0; k < 3; ++k) total[std::size_t(k)] += s[std::size_t(k)];
  return total;
}

// z = P^-1 r for one node.
inline void precondition(const double* inverse, int stride, const double* r, double* z) {
  if (stride == 9) {
    for (int a = 0; a < 3; ++a) z[a] = inverse[3 * a] * r[0] + inverse[3 * a + 1] * r[1] + inverse[3 * a + 2] * r[2];
  } else {
    for (int a = 0; a < 3; ++a) z[a] = inverse[a] * r[a];
  }
}

}  // namespace

PcgResult solveBlockPcg(const SystemMatrix& A, const std::vector<double>& inverse, int stride, const std::vector<double>& b,
                        const std::vector<unsigned char>& freeDof, std::vector<double>& x, int maxIterations,
                        double tolerance, BlockPcgScratch& scratch) {
  const std::size_t n = b.size(), nodes = n / 3;
  auto &r = scratch.r, &z = scratch.z, &p = scratch.p, &Ap = scratch.Ap;
  auto& partial = scratch.partial;
  r.resize(n);
  z.resize(n);
  p.resize(n);
  Ap.resize(n);
  const std::size_t st = std::size_t(stride);
  // r = (b - A x) on free DOFs; |b|^2, |x|^2 and |r|^2 over free DOFs.
  const Sums setup = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
    A.multiplyRows(begin, end, x.data(), Ap.data());
    Sums s{0, 0, 0};
    for (std::size_t i = 3 * begin; i < 3 * end; ++i) {
      const double m = freeDof[i] ? 1.0 : 0.0;
      r[i] = (b[i] - Ap[i]) * m;
      s[0] += m * b[i] * b[i];
      s[1] += m * x[i] * x[i];
      s[2] += r[i] * r[i];
    }
    return s;
  });
  PcgResult result;
  const double bNorm = std::sqrt(setup[0]);
  if (bNorm == 0 && setup[1] == 0) {
    result.converged = true;
    return result;
  }
  const double target = tolerance * (bNorm > 0 ? bNorm : 1.0);
  double rNorm = std::sqrt(setup[2]), rz = 0;
  if (rNorm > target && maxIterations > 0) {
    rz = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0, 0};
      for (std::size_t v = begin; v < end; ++v) {
        precondition(inverse.data() + st * v, stride, r.data() + 3 * v, z.data() + 3 * v);
        for (std::size_t i = 3 * v; i < 3 * v + 3; ++i) {
          p[i] = z[i];
          s[0] += r[i] * z[i];
        }
      }
      return s;
    })[0];
  }
  while (result.iterations < maxIterations && rNorm > target) {
    const double pAp = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
      A.multiplyRows(begin, end, p.data(), Ap.data());
      Sums s{0, 0, 0};
      for (std::size_t i = 3 * begin; i < 3 * end; ++i) {
        Ap[i] = freeDof[i] ? Ap[i] : 0.0;
        s[0] += p[i] * Ap[i];
      }
      return s;
    })[0];
    if (!(pAp > 0)) break;  // direction of no curvature (converged to round-off, or bad matrix)
    const double alpha = rz / pAp;
    const Sums sums = overChunks(nodes, partial, [&](std::size_t begin, std::size_t end) {
      Sums s{0, 0, 0};
      for (std::size_t v = begin; v < end; ++v) {
        for (std::size_t i = 3 * v; i < 3 * v + 3; ++i) {
          x[i] += alpha * p[i];
          r[i] -= alpha * Ap[i];
          s[0] += r[i] * r[i];
        }
        precondition(inverse.data() + st * v, stride, r.data() + 3 * v, z.data() + 3 * v);
        for (std::size_t i = 3 * v; i < 3 * v + 3; ++i) s[1] += r[i] * z[i];
      }
      return s;
    });
    rNorm = std::sqrt(sums[0]);
    ++result.iterations;
    if (rNorm <= target) break;
    const double beta = sums[1] / rz;
    rz = sums[1];
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 3 * kChunkNodes), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) p[i] = z[i] + beta * p[i];
    });
  }
  result.relativeResidual = bNorm > 0 ? rNorm / bNorm : rNorm;
  result.converged = rNorm <= target;
  return result;
}

}  // namespace blobvk::fem
