#include "resolution_limit.h"

#include "resource_limits.h"

#include <unistd.h>

#include <string>

namespace blobvk::app {
namespace {

std::uint64_t physicalMemoryBytes() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  return pages > 0 && size > 0 ? std::uint64_t(pages) * std::uint64_t(size) : 0;
}

std::uint64_t cubeEstimate(int n) {
  blobtree::GridSpec grid;
  grid.cells = glm::ivec3(n);
  return estimatePolygonizeBytes(grid, "cpu");
}

}  // namespace

int maxResolution() {
  static const int limit = [] {
    const std::uint64_t memory = physicalMemoryBytes();
    if (memory == 0) return 4096;  // unknown memory: a conservative fixed limit
    // The estimate grows monotonically with N: bisect for the largest N that fits.
    int lo = 1, hi = 1 << 20;
    while (lo < hi) {
      const int mid = lo + (hi - lo + 1) / 2;
      if (cubeEstimate(mid) <= memory) lo = mid;
      else hi = mid - 1;
    }
    return lo;
  }();
  return limit;
}

CLI::Validator resolutionRange(int minimum) {
  return CLI::Validator(
      [minimum](std::string& value) -> std::string {
        long n = 0;
        try {
          std::size_t used = 0;
          n = std::stol(value, &used);
          if (used != value.size()) return "'" + value + "' is not a whole number";
        } catch (const std::exception&) {
          return "'" + value + "' is not a whole number";
        }
        const int limit = maxResolution();
        if (n < minimum) return "resolution " + value + " is below " + std::to_string(minimum);
        if (n > limit) {
          return "resolution " + value + " is above " + std::to_string(limit) +
                 ", the finest grid whose mesh fits in this machine's memory";
        }
        return {};
      },
      "RESOLUTION", "resolution");
}

}  // namespace blobvk::app
