#include "blobvk/fem/preconditioner.h"

#include "blobvk/fem/block_system.h"

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCore>
#include <tbb/parallel_for.h>

namespace blobvk::fem {

struct SystemPreconditioner::Impl {
  PreconditionerKind kind = PreconditionerKind::Jacobi;
  std::size_t n = 0;  // DOFs
  // Jacobi: inverse diagonal; block-Jacobi: inverse 3x3 blocks (row-major, 9 per node).
  std::vector<double> inverse;
  const std::vector<unsigned char>* freeDof = nullptr;
  // Incomplete Cholesky: A's lower triangle (column-major), where each stored value comes from
  // in the block system, and the factorization.
  Eigen::SparseMatrix<double> lower;
  std::vector<std::uint32_t> source;
  Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>> cholesky;
  bool analyzed = false;
  mutable Eigen::VectorXd rhs, result;

  void buildLowerPattern(const BlockSystem& system);
};

SystemPreconditioner::SystemPreconditioner() : impl_(std::make_unique<Impl>()) {}
SystemPreconditioner::~SystemPreconditioner() = default;
SystemPreconditioner::SystemPreconditioner(SystemPreconditioner&&) noexcept = default;
SystemPreconditioner& SystemPreconditioner::operator=(SystemPreconditioner&&) noexcept = default;

void SystemPreconditioner::setDiagonalBlocks(PreconditionerKind kind, const std::vector<double>& blocks,
                                             const std::vector<unsigned char>& freeDof) {
  Impl& d = *impl_;
  d.kind = kind;
  d.freeDof = &freeDof;
  const std::size_t nodes = blocks.size() / 6;
  d.n = 3 * nodes;
  if (kind == PreconditionerKind::Jacobi) {
    d.inverse.resize(d.n);
    for (std::size_t i = 0; i < d.n; ++i) {
      const double a = blocks[6 * (i / 3) + i % 3];
      d.inverse[i] = freeDof[i] && a > 0 ? 1.0 / a : 0.0;
    }
    return;
  }
  d.inverse.resize(9 * nodes);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodes, 1024), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      const double* b = blocks.data() + 6 * r;
      Eigen::Matrix3d m;
      m << b[0], b[3], b[4], b[3], b[1], b[5], b[4], b[5], b[2];
      // A fixed DOF is decoupled: its row and column become the identity's.
      for (int c = 0; c < 3; ++c)
        if (!freeDof[3 * r + std::size_t(c)]) {
          m.row(c).setZero();
          m.col(c).setZero();
          m(c, c) = 1;
        }
      Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> out(d.inverse.data() + 9 * r);
      const Eigen::LDLT<Eigen::Matrix3d> ldlt(m);
      if (ldlt.info() == Eigen::Success && ldlt.isPositive() && std::abs(m.determinant()) > 0) {
        out = m.inverse();
      } else {  // not positive definite (cannot happen for a valid system): Jacobi for this node
        out.setZero();
        for (int c = 0; c < 3; ++c) out(c, c) = m(c, c) > 0 ? 1.0 / m(c, c) : 0.0;
      }
      for (int c = 0; c < 3; ++c)
        if (!freeDof[3 * r + std::size_t(c)]) {
          out.row(c).setZero();
          out.col(c).setZero();
        }
    }
  });
}

void SystemPreconditioner::Impl::buildLowerPattern(const BlockSystem& system) {
  // Column j = 3c + b of the lower triangle equals row j of the upper one (A is symmetric):
  // blocks (c, r) of block row c with r >= c, entries (b, a) with 3r + a >= j, rows increasing.
  const std::size_t nodes = system.nodeCount();
  std::vector<int> outer(3 * nodes + 1, 0), inner;
  source.clear();
  for (std::size_t c = 0; c < nodes; ++c)
    for (int b = 0; b < 3; ++b) {
      const std::size_t j = 3 * c + std::size_t(b);
      for (std::uint32_t k = system.diagonal[c]; k < system.rowStart[c + 1]; ++k)
        for (int a = 0; a < 3; ++a) {
          const std::size_t i = 3 * std::size_t(system.column[k]) + std::size_t(a);
          if (i < j) continue;
          inner.push_back(int(i));
          source.push_back(9 * k + std::uint32_t(3 * b + a));
        }
      outer[j + 1] = int(inner.size());
    }
  std::vector<double> zeros(inner.size(), 0.0);
  lower = Eigen::Map<const Eigen::SparseMatrix<double>>(Eigen::Index(3 * nodes), Eigen::Index(3 * nodes),
                                                        Eigen::Index(inner.size()), outer.data(), inner.data(), zeros.data());
}

bool SystemPreconditioner::factorize(const BlockSystem& system, const std::vector<unsigned char>& freeDof,
                                     bool patternChanged) {
  Impl& d = *impl_;
  d.kind = PreconditionerKind::IncompleteCholesky;
  d.freeDof = &freeDof;
  d.n = 3 * system.nodeCount();
  patternChanged = patternChanged || !d.analyzed || d.lower.rows() != Eigen::Index(d.n);
  if (patternChanged) d.buildLowerPattern(system);
  double* values = d.lower.valuePtr();
  const int* inner = d.lower.innerIndexPtr();
  const int* outer = d.lower.outerIndexPtr();
  for (std::size_t j = 0; j < d.n; ++j)
    for (int k = outer[j]; k < outer[j + 1]; ++k) {
      const std::size_t i = std::size_t(inner[k]);
      const bool free = freeDof[i] && freeDof[j];
      values[k] = free ? system.values[d.source[std::size_t(k)]] : (i == j ? 1.0 : 0.0);
    }
  if (patternChanged) d.cholesky.analyzePattern(d.lower);
  d.analyzed = true;
  d.cholesky.factorize(d.lower);
  d.rhs.resize(Eigen::Index(d.n));
  d.result.resize(Eigen::Index(d.n));
  return d.cholesky.info() == Eigen::Success;
}

PreconditionerKind SystemPreconditioner::kind() const { return impl_->kind; }
const std::vector<double>& SystemPreconditioner::inverse() const { return impl_->inverse; }

void SystemPreconditioner::apply(const double* r, double* z) const {
  const Impl& d = *impl_;
  const std::vector<unsigned char>& freeDof = *d.freeDof;
  switch (d.kind) {
    case PreconditionerKind::Jacobi:
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, d.n, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) z[i] = d.inverse[i] * r[i];
      });
      return;
    case PreconditionerKind::BlockJacobi:
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, d.n / 3, 4096), [&](const tbb::blocked_range<std::size_t>& range) {
        for (std::size_t node = range.begin(); node != range.end(); ++node) {
          const double* m = d.inverse.data() + 9 * node;
          const double* x = r + 3 * node;
          for (int a = 0; a < 3; ++a) z[3 * node + std::size_t(a)] = m[3 * a] * x[0] + m[3 * a + 1] * x[1] + m[3 * a + 2] * x[2];
        }
      });
      return;
    case PreconditionerKind::IncompleteCholesky:
      for (std::size_t i = 0; i < d.n; ++i) d.rhs[Eigen::Index(i)] = freeDof[i] ? r[i] : 0.0;
      d.result = d.cholesky.solve(d.rhs);
      for (std::size_t i = 0; i < d.n; ++i) z[i] = freeDof[i] ? d.result[Eigen::Index(i)] : 0.0;
      return;
  }
}

}  // namespace blobvk::fem
