#include "blobvk/vk/extract/host_scan.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <vector>

namespace blobvk::vk {
namespace {

// Values per chunk: a chunk's pass stays in the core's L2, and a few thousand values do not pay
// for a thread's hand-over.
constexpr std::size_t kChunk = std::size_t(1) << 16;

std::uint32_t scanSerial(std::uint32_t* values, std::size_t count, std::uint32_t carry) {
  for (std::size_t i = 0; i < count; ++i) {
    const std::uint32_t v = values[i];
    values[i] = carry;
    carry += v;
  }
  return carry;
}

}  // namespace

std::uint32_t exclusiveScanInPlace(std::uint32_t* values, std::size_t count) {
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  if (chunks <= 1) return scanSerial(values, count, 0);
  // Reduce then scan: each chunk's sum, their exclusive scan, then each chunk scanned from its
  // carry. Integer sums: the result does not depend on how the chunks fall to the threads.
  std::vector<std::uint32_t> carry(chunks + 1, 0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    const std::uint32_t* v = values + c * kChunk;
    const std::size_t n = std::min(kChunk, count - c * kChunk);
    std::uint32_t s = 0;
    for (std::size_t i = 0; i < n; ++i) s += v[i];
    carry[c + 1] = s;
  });
  for (std::size_t c = 0; c < chunks; ++c) carry[c + 1] += carry[c];
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    scanSerial(values + c * kChunk, std::min(kChunk, count - c * kChunk), carry[c]);
  });
  return carry[chunks];
}

}  // namespace blobvk::vk
