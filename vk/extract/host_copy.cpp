#include "blobvk/vk/extract/host_copy.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstdint>
#include <cstring>

namespace blobvk::vk {

namespace {
constexpr std::size_t kPage = 4096;
constexpr std::size_t kChunk = std::size_t(1) << 20;  // bytes per task: large enough to stream
}  // namespace

void prefaultParallel(void* p, std::size_t bytes) {
  if (bytes == 0) return;
  auto* base = static_cast<volatile unsigned char*>(p);
  const std::size_t pages = (bytes + kPage - 1) / kPage;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pages, kChunk / kPage),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t page = r.begin(); page != r.end(); ++page) base[page * kPage] = 0;
                    });
}

void copyParallel(void* dst, const void* src, std::size_t bytes) {
  auto* d = static_cast<unsigned char*>(dst);
  const auto* s = static_cast<const unsigned char*>(src);
  const std::size_t chunks = (bytes + kChunk - 1) / kChunk;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks), [&](const tbb::blocked_range<std::size_t>& r) {
    const std::size_t begin = r.begin() * kChunk, end = std::min(bytes, r.end() * kChunk);
    std::memcpy(d + begin, s + begin, end - begin);
  });
}

}  // namespace blobvk::vk
