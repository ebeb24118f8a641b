#include "blobvk/vk/extract/host_triangles.h"

#include "blobvk/vk/extract/case_table.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace blobvk::vk {
namespace {

// A triangle's three vertex indices from its source word pair (brick_triangles.comp,
// triangleCorners: the word layouts are brick_sources.comp's).
struct Assembler {
  const HostTriangleInputs& in;
  const std::uint32_t* cases;  // caseTableUniform(): count, edges 0..7, edges 8..14, 0
  std::uint32_t B, R;

  std::array<std::uint32_t, 3> corners(std::uint32_t a, std::uint32_t word) const {
    const std::uint32_t k = (word >> 8) & 7u, x = (word >> 11) & 15u, cellRow = (word >> 15) & 255u;
    const std::uint32_t faces = word >> 23;
    const std::uint32_t cell[3] = {x, cellRow & (B - 1u), cellRow >> in.log2B};
    const std::uint32_t* entry = cases + 4u * (word & 255u);
    std::array<std::uint32_t, 3> out;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t j = k * 3u + i;
      const std::uint32_t e = j < 8u ? (entry[1] >> (4u * j)) & 15u : (entry[2] >> (4u * (j - 8u))) & 15u;
      const std::uint32_t axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
      // The edge's start point: the cell's corner, moved off the edge's axis by (u, w).
      std::uint32_t p[3] = {cell[0], cell[1], cell[2]};
      p[axis == 0u ? 1u : 0u] += u;
      p[axis == 2u ? 1u : 2u] += w;
      // A point on an upper face belongs to the neighbour there, unless the brick is the grid's last.
      std::uint32_t side = 0;
      for (std::uint32_t d = 0; d < 3; ++d) {
        if (p[d] == B && (faces >> d & 1u) != 0u) {
          side |= 1u << d;
          p[d] = 0;
        }
      }
      const std::uint32_t owner = side ? in.neighbours[a * 8u + side] : a;
      const std::uint32_t point = in.pointWords[((std::size_t(owner) * R + p[2]) * R + p[1]) * R + p[0]];
      // The edge's rank among the point's crossing edges: its set bits below `axis` (at most two;
      // a shift and adds, where std::popcount is a libgcc call without -mpopcnt).
      const std::uint32_t below = point & ((1u << axis) - 1u);
      const std::uint32_t rank = (below & 1u) + (below >> 1);
      out[i] = in.vertexBase + (point >> 3) + rank;
    }
    return out;
  }
};

}  // namespace

void assembleTrianglesOnHost(const HostTriangleInputs& in, std::uint32_t count, std::array<std::uint32_t, 3>* out) {
  const Assembler assembler{in, caseTableUniform().data(), 1u << in.log2B, (1u << in.log2B) + 1u};
  // Each triangle is written at its own index: the split does not change a byte.
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, count, 1u << 14), [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t t = r.begin(); t < r.end(); ++t) out[t] = assembler.corners(in.sources[2ull * t], in.sources[2ull * t + 1]);
  });
}

}  // namespace blobvk::vk
