#include "fem/block_matrix.h"

#include <algorithm>
#include <cstring>

#include <tbb/parallel_for.h>

namespace blobvk::fem {

void BlockMatrix3::build(std::size_t n, const std::vector<std::array<std::uint32_t, 4>>& tets) {
  std::vector<std::vector<std::uint32_t>> adjacency(n);
  for (const auto& t : tets)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) adjacency[t[i]].push_back(t[j]);
  rowStart_.assign(n + 1, 0);
  columns_.clear();
  diagonal_.assign(n, 0);
  for (std::size_t r = 0; r < n; ++r) {
    auto& a = adjacency[r];
    a.push_back(std::uint32_t(r));  // isolated nodes still get a diagonal block
    std::sort(a.begin(), a.end());
    a.erase(std::unique(a.begin(), a.end()), a.end());
    rowStart_[r] = std::uint32_t(columns_.size());
    for (auto c : a) {
      if (c == r) diagonal_[r] = std::uint32_t(columns_.size());
      columns_.push_back(c);
    }
  }
  rowStart_[n] = std::uint32_t(columns_.size());
  slots_.resize(tets.size() * 16);
  for (std::size_t e = 0; e < tets.size(); ++e)
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        const std::uint32_t r = tets[e][i], c = tets[e][j];
        const auto begin = columns_.begin() + rowStart_[r], end = columns_.begin() + rowStart_[r + 1];
        slots_[e * 16 + std::size_t(i * 4 + j)] = std::uint32_t(std::lower_bound(begin, end, c) - columns_.begin());
      }
  values_.assign(columns_.size() * 9, 0.0);
}

void BlockMatrix3::setZero() { std::fill(values_.begin(), values_.end(), 0.0); }

void BlockMatrix3::multiply(const double* x, double* y) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, rows(), 256), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      double a0 = 0, a1 = 0, a2 = 0;
      for (std::uint32_t k = rowStart_[r]; k < rowStart_[r + 1]; ++k) {
        const double* b = values_.data() + std::size_t(k) * 9;
        const double* v = x + std::size_t(columns_[k]) * 3;
        a0 += b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
        a1 += b[3] * v[0] + b[4] * v[1] + b[5] * v[2];
        a2 += b[6] * v[0] + b[7] * v[1] + b[8] * v[2];
      }
      y[3 * r] = a0;
      y[3 * r + 1] = a1;
      y[3 * r + 2] = a2;
    }
  });
}

}  // namespace blobvk::fem
