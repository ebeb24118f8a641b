#include "blobvk/vk/extract/vertex_tile_lists.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <utility>
#include <vector>

namespace blobvk::vk {
namespace {

constexpr std::uint32_t kChunk = 1u << 16;  // vertices a task counts, then lists

}  // namespace

void listVerticesByTile(const std::uint32_t* sources, std::uint32_t vertices, const std::uint32_t* brickTile,
                        std::uint32_t tiles, std::uint32_t workgroupSize, std::uint32_t* lists, std::uint32_t* args) {
  const std::uint32_t chunks = (vertices + kChunk - 1) / kChunk;
  // Per chunk, its vertices per tile; then where the chunk's entries of each tile start: the
  // tile's start plus the earlier chunks' counts, so each list runs in ascending vertex order.
  std::vector<std::uint32_t> at(std::size_t(chunks) * tiles, 0);
  auto range = [&](std::uint32_t c) { return std::pair(c * kChunk, std::min(vertices, (c + 1) * kChunk)); };
  tbb::parallel_for(std::uint32_t(0), chunks, [&](std::uint32_t c) {
    std::uint32_t* count = at.data() + std::size_t(c) * tiles;
    const auto [begin, end] = range(c);
    for (std::uint32_t v = begin; v < end; ++v) ++count[brickTile[sources[2ull * v]]];
  });
  std::uint32_t first = 0;
  for (std::uint32_t t = 0; t < tiles; ++t) {
    const std::uint32_t tileFirst = first;
    for (std::uint32_t c = 0; c < chunks; ++c) {
      const std::uint32_t n = at[std::size_t(c) * tiles + t];
      at[std::size_t(c) * tiles + t] = first;
      first += n;
    }
    const std::uint32_t count = first - tileFirst;
    const std::uint32_t groups = (count + workgroupSize - 1) / workgroupSize, x = std::min(groups, 65535u);
    std::uint32_t* a = args + 8ull * t;
    a[0] = x;
    a[1] = x == 0 ? 0 : (groups + x - 1) / x;
    a[2] = 1;
    a[3] = count;
    a[4] = tileFirst;
  }
  tbb::parallel_for(std::uint32_t(0), chunks, [&](std::uint32_t c) {
    std::uint32_t* next = at.data() + std::size_t(c) * tiles;
    const auto [begin, end] = range(c);
    for (std::uint32_t v = begin; v < end; ++v) lists[next[brickTile[sources[2ull * v]]]++] = v;
  });
}

}  // namespace blobvk::vk
