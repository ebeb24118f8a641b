#include "blobvk/fem/system_matrix.h"

#include "blobvk/fem/kernel_dispatch.h"
#include "blobvk/fem/node_incidence.h"

#include <algorithm>
#include <stdexcept>

#include <tbb/parallel_for.h>

namespace blobvk::fem {

namespace {
constexpr std::size_t kRowGrain = 256;

template <class Body>
void forRows(std::size_t n, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kRowGrain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
  });
}
}  // namespace

void SystemMatrix::buildPattern(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets) {
  const std::size_t n = incidence.nodeCount();
  // Each row's neighbours are at most 3 per incident tet: rows are sorted and deduplicated in
  // place at that bound, in parallel, then packed (no per-row allocation: a vector per row cost
  // ~35 ms at 100k tets, which the first step after every cut would pay).
  std::vector<std::uint32_t> bound(n + 1, 0), length(n, 0);
  for (std::size_t r = 0; r < n; ++r) bound[r + 1] = bound[r] + 3 * incidence.count(r);
  std::vector<std::uint32_t> scratch(bound[n]);
  forRows(n, [&](std::size_t r) {
    std::uint32_t* out = scratch.data() + bound[r];
    std::uint32_t* end = out;
    for (const std::uint32_t* q = incidence.begin(r); q != incidence.end(r); ++q)
      for (std::uint32_t v : tets[NodeIncidence::tetOf(*q)])
        if (v != r) *end++ = v;
    std::sort(out, end);
    length[r] = std::uint32_t(std::unique(out, end) - out);
  });
  rowStart_.assign(n + 1, 0);
  longestRow_ = 0;
  for (std::size_t r = 0; r < n; ++r) {
    rowStart_[r + 1] = rowStart_[r] + length[r];
    longestRow_ = std::max<std::size_t>(longestRow_, length[r]);
  }
  if (longestRow_ > 0xFFFF) throw std::length_error("system matrix: a node has more than 65535 neighbours");
  column_.resize(rowStart_[n]);
  forRows(n, [&](std::size_t r) { std::copy_n(scratch.data() + bound[r], length[r], column_.data() + rowStart_[r]); });
  tetSlots_.resize(tets.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, tets.size(), 1024), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t e = range.begin(); e != range.end(); ++e) {
      const auto& t = tets[e];
      for (int a = 0; a < 4; ++a) {
        const auto first = column_.begin() + rowStart_[t[std::size_t(a)]];
        const auto last = column_.begin() + rowStart_[t[std::size_t(a)] + 1];
        for (int b = 0; b < 4; ++b)
          tetSlots_[e][std::size_t(4 * a + b)] =
              a == b ? 0 : std::uint16_t(std::lower_bound(first, last, t[std::size_t(b)]) - first);
      }
    }
  });
  offDiagonal_.resize(9 * column_.size());
  diagonal_.resize(9 * n);
}

BLOBVK_FEM_KERNEL void SystemMatrix::multiplyRows(std::size_t begin, std::size_t end, const double* p, double* y) const {
  for (std::size_t r = begin; r != end; ++r) {
    const double* d = diagonal_.data() + 9 * r;
    const double* pr = p + 3 * r;
    double y0 = d[0] * pr[0] + d[1] * pr[1] + d[2] * pr[2];
    double y1 = d[3] * pr[0] + d[4] * pr[1] + d[5] * pr[2];
    double y2 = d[6] * pr[0] + d[7] * pr[1] + d[8] * pr[2];
    for (std::uint32_t k = rowStart_[r]; k != rowStart_[r + 1]; ++k) {
      const float* b = offDiagonal_.data() + 9 * std::size_t(k);
      const double* pc = p + 3 * std::size_t(column_[k]);
      y0 += double(b[0]) * pc[0] + double(b[1]) * pc[1] + double(b[2]) * pc[2];
      y1 += double(b[3]) * pc[0] + double(b[4]) * pc[1] + double(b[5]) * pc[2];
      y2 += double(b[6]) * pc[0] + double(b[7]) * pc[1] + double(b[8]) * pc[2];
    }
    y[3 * r] = y0;
    y[3 * r + 1] = y1;
    y[3 * r + 2] = y2;
  }
}

void SystemMatrix::multiply(const double* p, double* y) const {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nodeCount(), kRowGrain),
                    [&](const tbb::blocked_range<std::size_t>& r) { multiplyRows(r.begin(), r.end(), p, y); });
}

}  // namespace blobvk::fem
