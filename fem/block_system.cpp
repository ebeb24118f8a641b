#include "blobvk/fem/block_system.h"

#include "blobvk/fem/node_incidence.h"

#include <algorithm>

#include <tbb/parallel_for.h>

namespace blobvk::fem {

long BlockSystem::find(std::size_t r, std::uint32_t c) const {
  const auto first = column.begin() + rowStart[r], last = column.begin() + rowStart[r + 1];
  const auto it = std::lower_bound(first, last, c);
  return it != last && *it == c ? long(it - column.begin()) : -1;
}

void buildBlockPattern(const NodeIncidence& incidence, const std::vector<std::array<std::uint32_t, 4>>& tets,
                       BlockSystem& system) {
  const std::size_t n = incidence.nodeCount();
  // Per row, its sorted unique neighbours; rows are independent, so they are found in parallel
  // into per-row lists and then laid out in row order.
  std::vector<std::vector<std::uint32_t>> rows(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const tbb::blocked_range<std::size_t>& range) {
    for (std::size_t r = range.begin(); r != range.end(); ++r) {
      auto& row = rows[r];
      row.push_back(std::uint32_t(r));  // an isolated node keeps its diagonal block
      for (const std::uint32_t* q = incidence.begin(r); q != incidence.end(r); ++q)
        for (std::uint32_t v : tets[NodeIncidence::tetOf(*q)]) row.push_back(v);
      std::sort(row.begin(), row.end());
      row.erase(std::unique(row.begin(), row.end()), row.end());
    }
  });
  system.rowStart.assign(n + 1, 0);
  for (std::size_t r = 0; r < n; ++r) system.rowStart[r + 1] = system.rowStart[r] + std::uint32_t(rows[r].size());
  system.column.resize(system.rowStart[n]);
  system.diagonal.resize(n);
  for (std::size_t r = 0; r < n; ++r) {
    std::copy(rows[r].begin(), rows[r].end(), system.column.begin() + system.rowStart[r]);
    system.diagonal[r] = std::uint32_t(system.find(r, std::uint32_t(r)));
  }
  system.values.assign(9 * system.column.size(), 0.0);
}

}  // namespace blobvk::fem
