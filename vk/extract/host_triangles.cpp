#include "blobvk/vk/extract/host_triangles.h"

#include "blobvk/vk/extract/case_table.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cstddef>

namespace blobvk::vk {
namespace {

// Per configuration and k-th triangle, its three corners' edges as the start point's offset
// from the cell (x, y, z: bits 0-2) and the edge's axis (bits 3-4), decoded once from the case
// table (an edge e: axis e >> 2, the start point moved off the axis by e & 1 and (e >> 1) & 1).
struct CornerTable {
  std::uint8_t corner[256][5][3] = {};
  CornerTable() {
    const std::uint32_t* cases = caseTableUniform().data();  // count, edges 0..7, edges 8..14, 0
    for (std::uint32_t config = 0; config < 256; ++config) {
      const std::uint32_t* entry = cases + 4u * config;
      for (std::uint32_t k = 0; k < entry[0] && k < 5u; ++k) {
        for (std::uint32_t i = 0; i < 3; ++i) {
          const std::uint32_t j = k * 3u + i;
          const std::uint32_t e = j < 8u ? (entry[1] >> (4u * j)) & 15u : (entry[2] >> (4u * (j - 8u))) & 15u;
          const std::uint32_t axis = e >> 2, u = e & 1u, w = (e >> 1) & 1u;
          std::uint32_t d[3] = {0, 0, 0};
          d[axis == 0u ? 1u : 0u] += u;
          d[axis == 2u ? 1u : 2u] += w;
          corner[config][k][i] = std::uint8_t(d[0] | d[1] << 1 | d[2] << 2 | axis << 3);
        }
      }
    }
  }
};

// A triangle's three vertex indices from its source word pair (brick_triangles.comp,
// triangleCorners: the word layouts are brick_sources.comp's).
struct Assembler {
  const HostTriangleInputs& in;
  const CornerTable& table;
  std::uint32_t B, R;

  std::array<std::uint32_t, 3> corners(std::uint32_t a, std::uint32_t word) const {
    const std::uint32_t k = (word >> 8) & 7u, x = (word >> 11) & 15u, cellRow = (word >> 15) & 255u;
    const std::uint32_t faces = word >> 23;
    const std::uint32_t cy = cellRow & (B - 1u), cz = cellRow >> in.log2B;
    const std::uint8_t* corner = table.corner[word & 255u][k];
    std::array<std::uint32_t, 3> out;
    for (std::uint32_t i = 0; i < 3; ++i) {
      const std::uint32_t d = corner[i], axis = d >> 3;
      std::uint32_t px = x + (d & 1u), py = cy + ((d >> 1) & 1u), pz = cz + ((d >> 2) & 1u);
      // A point on an upper face belongs to the neighbour there, unless the brick is the grid's
      // last; it is that brick's point 0 on the axis.
      const std::uint32_t ux = std::uint32_t(px == B) & faces, uy = std::uint32_t(py == B) & (faces >> 1),
                          uz = std::uint32_t(pz == B) & (faces >> 2);
      const std::uint32_t side = ux | uy << 1 | uz << 2;
      px = ux ? 0u : px;
      py = uy ? 0u : py;
      pz = uz ? 0u : pz;
      const std::uint32_t owner = side ? in.neighbours[a * 8u + side] : a;
      const std::uint32_t point = in.pointWords[((std::size_t(owner) * R + pz) * R + py) * R + px];
      // The edge's rank among the point's crossing edges: its set bits below `axis` (at most two;
      // a shift and an add, where std::popcount is a libgcc call without -mpopcnt).
      const std::uint32_t below = point & ((1u << axis) - 1u);
      out[i] = in.vertexBase + (point >> 3) + (below & 1u) + (below >> 1);
    }
    return out;
  }
};

}  // namespace

void assembleTrianglesOnHost(const HostTriangleInputs& in, std::uint32_t count, std::array<std::uint32_t, 3>* out) {
  static const CornerTable table;
  const Assembler assembler{in, table, 1u << in.log2B, (1u << in.log2B) + 1u};
  // Each triangle is written at its own index: the split does not change a byte.
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, count, 1u << 14), [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t t = r.begin(); t < r.end(); ++t) out[t] = assembler.corners(in.sources[2ull * t], in.sources[2ull * t + 1]);
  });
}

}  // namespace blobvk::vk
