#include "fem/pcg.h"

#include <cmath>

#include <Eigen/Core>

namespace blobvk::fem {

PcgResult solvePcg(const BlockMatrix3& A, const std::vector<double>& bIn, const std::vector<unsigned char>& freeDof,
                   std::vector<double>& xIn, int maxIterations, double tolerance) {
  const Eigen::Index n = Eigen::Index(bIn.size());
  Eigen::Map<Eigen::VectorXd> x(xIn.data(), n);
  const Eigen::Map<const Eigen::VectorXd> b(bIn.data(), n);
  Eigen::VectorXd mask(n), invDiag(n), r(n), z(n), p(n), Ap(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    mask[i] = freeDof[std::size_t(i)] ? 1.0 : 0.0;
    const double d = A.block(A.diagonal(std::size_t(i / 3)))[(i % 3) * 4];
    invDiag[i] = d > 0 ? mask[i] / d : 0.0;
  }
  PcgResult result;
  const double bNorm = b.cwiseProduct(mask).norm();
  if (bNorm == 0 && x.cwiseProduct(mask).squaredNorm() == 0) return result;
  A.multiply(x.data(), Ap.data());
  r = (b - Ap).cwiseProduct(mask);
  z = invDiag.cwiseProduct(r);
  p = z;
  double rz = r.dot(z);
  const double target = tolerance * (bNorm > 0 ? bNorm : 1.0);
  double rNorm = r.norm();
  while (result.iterations < maxIterations && rNorm > target) {
    A.multiply(p.data(), Ap.data());
    Ap = Ap.cwiseProduct(mask);
    const double pAp = p.dot(Ap);
    if (!(pAp > 0)) break;  // direction of no curvature (converged to round-off, or bad matrix)
    const double alpha = rz / pAp;
    x += alpha * p;
    r -= alpha * Ap;
    z = invDiag.cwiseProduct(r);
    const double rzNew = r.dot(z);
    p = z + (rzNew / rz) * p;
    rz = rzNew;
    rNorm = r.norm();
    ++result.iterations;
  }
  result.relativeResidual = bNorm > 0 ? rNorm / bNorm : rNorm;
  return result;
}

}  // namespace blobvk::fem
