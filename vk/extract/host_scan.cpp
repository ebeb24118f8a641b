#include "blobvk/vk/extract/host_scan.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_scan.h>

#include <functional>

namespace blobvk::vk {

std::uint32_t exclusiveScanInPlace(std::uint32_t* values, std::size_t count) {
  // Integer sums: the result does not depend on how TBB splits the range. Each value is read
  // before the final pass over its range overwrites it, so the scan can run in place. Ranges of
  // at least 2^16 values: fewer do not pay for a thread's hand-over.
  return tbb::parallel_scan(
      tbb::blocked_range<std::size_t>(0, count, std::size_t(1) << 16), std::uint32_t(0),
      [values](const tbb::blocked_range<std::size_t>& r, std::uint32_t sum, bool final) {
        for (std::size_t i = r.begin(); i < r.end(); ++i) {
          const std::uint32_t v = values[i];
          if (final) values[i] = sum;
          sum += v;
        }
        return sum;
      },
      std::plus<std::uint32_t>());
}

}  // namespace blobvk::vk
