#include "blobvk/fem/coarse_correction.h"

#include "blobvk/fem/system_matrix.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <tbb/parallel_for.h>

namespace blobvk::fem {

struct CoarseCorrection::Impl {
  mesh::Double3 origin{};
  double edge = 1;
  std::unordered_map<std::uint64_t, std::uint32_t> idOfCube;
  std::vector<std::uint32_t> aggregate;          // per node
  std::vector<std::uint32_t> memberStart, members;  // per aggregate, its nodes in node order
  std::size_t count = 0;
  // Per aggregate, its coarse row: (column aggregate, 3x3 block) sorted by column.
  std::vector<std::vector<std::pair<std::uint32_t, std::array<double, 9>>>> rows;
  Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt;
  mutable Eigen::VectorXd g, c;

  std::uint32_t assign(const mesh::Double3& p) {
    const auto cube = [&](double x, double o) {
      return std::uint64_t(std::clamp(std::floor((x - o) / edge), 0.0, double((1u << 20) - 1)));
    };
    const std::uint64_t key = (cube(p.x, origin.x) << 42) | (cube(p.y, origin.y) << 21) | cube(p.z, origin.z);
    const auto [it, added] = idOfCube.emplace(key, std::uint32_t(count));
    if (added) ++count;
    return it->second;
  }

  void listMembers() {
    memberStart.assign(count + 1, 0);
    for (std::uint32_t a : aggregate) ++memberStart[a + 1];
    for (std::size_t k = 0; k < count; ++k) memberStart[k + 1] += memberStart[k];
    members.resize(aggregate.size());
    std::vector<std::uint32_t> next(memberStart.begin(), memberStart.end() - 1);
    for (std::size_t v = 0; v < aggregate.size(); ++v) members[next[aggregate[v]]++] = std::uint32_t(v);
  }
};

CoarseCorrection::CoarseCorrection() : impl_(std::make_unique<Impl>()) {}
CoarseCorrection::~CoarseCorrection() = default;
CoarseCorrection::CoarseCorrection(CoarseCorrection&&) noexcept = default;
CoarseCorrection& CoarseCorrection::operator=(CoarseCorrection&&) noexcept = default;

std::size_t CoarseCorrection::aggregateCount() const { return impl_->count; }

void CoarseCorrection::setAggregates(const std::vector<mesh::Double3>& rest, std::size_t targetNodes) {
  Impl& d = *impl_;
  d.idOfCube.clear();
  d.aggregate.clear();
  d.count = 0;
  if (rest.empty()) return;
  mesh::Double3 lo = rest[0], hi = rest[0];
  for (const auto& p : rest) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  // Thin boxes: each extent at least a tenth of the largest, so the volume is not ~0.
  const double size = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-12});
  const double volume = std::max(hi.x - lo.x, 0.1 * size) * std::max(hi.y - lo.y, 0.1 * size) * std::max(hi.z - lo.z, 0.1 * size);
  d.origin = lo;
  d.edge = std::cbrt(volume * double(std::max<std::size_t>(targetNodes, 1)) / double(rest.size()));
  d.aggregate.reserve(rest.size());
  for (const auto& p : rest) d.aggregate.push_back(d.assign(p));
  d.listMembers();
}

bool CoarseCorrection::factor(const SystemMatrix& A, const std::vector<unsigned char>& freeDof,
                              const std::vector<mesh::Double3>& rest) {
  Impl& d = *impl_;
  const std::size_t n = A.nodeCount();
  if (d.aggregate.size() < n) {  // new nodes of a topology change
    while (d.aggregate.size() < n) d.aggregate.push_back(d.assign(rest[d.aggregate.size()]));
    d.listMembers();
  }
  // Row I of Ac: the sum over I's nodes i and their row's blocks A_ij of the free-DOF part of
  // A_ij, into column aggregate(j). Per aggregate in parallel, each into its own row, nodes and
  // blocks in order: no races, a fixed summation order.
  d.rows.resize(d.count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, d.count, 4), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<std::int32_t> slotOf(d.count, -1);
    for (std::size_t I = range.begin(); I != range.end(); ++I) {
      auto& row = d.rows[I];
      row.clear();
      const auto add = [&](std::size_t i, std::size_t j, const auto* block) {
        const std::uint32_t J = d.aggregate[j];
        if (slotOf[J] < 0) {
          slotOf[J] = std::int32_t(row.size());
          row.push_back({J, {}});
        }
        auto& sum = row[std::size_t(slotOf[J])].second;
        for (int a = 0; a < 3; ++a)
          for (int c = 0; c < 3; ++c)
            if (freeDof[3 * i + std::size_t(a)] && freeDof[3 * j + std::size_t(c)])
              sum[std::size_t(3 * a + c)] += double(block[3 * a + c]);
      };
      for (std::uint32_t m = d.memberStart[I]; m != d.memberStart[I + 1]; ++m) {
        const std::size_t i = d.members[m];
        add(i, i, A.diagonal(i));
        for (std::uint32_t k = A.rowBegin(i); k != A.rowEnd(i); ++k) add(i, A.column(k), A.offDiagonal(k));
      }
      for (const auto& entry : row) slotOf[entry.first] = -1;
    }
  });
  std::vector<Eigen::Triplet<double>> triplets;
  for (std::size_t I = 0; I < d.count; ++I)
    for (const auto& [J, block] : d.rows[I])
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) {
          const double v = block[std::size_t(3 * a + c)];
          // A component of an aggregate with no free DOF is decoupled (an identity row).
          const bool empty = I == J && a == c && v == 0;
          if (v != 0 || empty) triplets.emplace_back(int(3 * I) + a, int(3 * J) + c, empty ? 1.0 : v);
        }
  const int m = int(3 * d.count);
  Eigen::SparseMatrix<double> ac(m, m);
  ac.setFromTriplets(triplets.begin(), triplets.end());
  d.llt.compute(ac);  // AMD ordering; the coarse system is small (3 per ~125 nodes)
  d.g.resize(m);
  d.c.resize(m);
  return d.llt.info() == Eigen::Success;
}

double CoarseCorrection::apply(const double* r, double* u, const std::vector<unsigned char>& freeDof) const {
  Impl& d = *impl_;
  d.g.setZero();
  for (std::size_t v = 0; v < d.aggregate.size(); ++v)
    for (int a = 0; a < 3; ++a) d.g[3 * Eigen::Index(d.aggregate[v]) + a] += r[3 * v + std::size_t(a)];
  d.c = d.llt.solve(d.g);
  for (std::size_t v = 0; v < d.aggregate.size(); ++v)
    for (int a = 0; a < 3; ++a)
      if (freeDof[3 * v + std::size_t(a)]) u[3 * v + std::size_t(a)] += d.c[3 * Eigen::Index(d.aggregate[v]) + a];
  return d.g.dot(d.c);
}

}  // namespace blobvk::fem
