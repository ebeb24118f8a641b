#include "blobvk/vk/extract/row_culling.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <memory>
#include <utility>

namespace blobvk::vk {

bool cullsRows(const GpuPolygonizeOptions& options, bool llvmpipe, std::uint32_t brickCells) {
  return options.columnSides && llvmpipe && !options.brickTapes && brickCells >= 2 * kRowCullingColumnCells;
}

namespace {

constexpr std::uint32_t kMaxR = 17, kMaxSegments = 4;

// Per brick, a byte per row: 0 without a span, its inside bit in bit 7; else the span's first
// segment (bits 0-2) and count (3-5), and the inside bits of the proven segments before and
// after it (6, 7). Then how many rows have a span of 1, 2 ... segments.
struct BrickRows {
  std::array<std::uint8_t, kMaxR * kMaxR> row;
  std::array<std::uint32_t, kMaxSegments + 1> spans;
};

// RowPlan::rows' second word for a row byte with a span: its segments, and the inside bits of the
// points outside them.
std::uint32_t spanWord(std::uint8_t row, std::uint32_t R) {
  const std::uint32_t L = kRowCullingSegmentCells, s0 = row & 7u, count = row >> 3 & 7u, s1 = s0 + count;
  std::uint32_t outside = 0;
  if (row & 0x40u) outside |= (1u << (s0 * L)) - 1u;
  if (row & 0x80u) outside |= ((1u << R) - 1u) & ~((2u << (s1 * L)) - 1u);
  return outside | s0 << 17 | count << 20;
}

// A row's byte (BrickRows::row) from its word: three nx-bit fields, a bit per segment, of the
// columns holding the row ORed: proven below (bits 0-3), at or above (4-7), may cross (8-11).
std::uint8_t rowByte(std::uint32_t word, std::uint32_t nx) {
  const std::uint32_t all = (1u << nx) - 1;
  // Sides that disagree could only come from a broken bound: evaluate the segment; and where
  // proven segments of a row disagree where they meet, the whole row.
  const std::uint32_t below = word & 15u, above = word >> 4 & 15u, crossing = word >> 8 & 15u;
  std::uint32_t evaluate = crossing | (below & above);
  const std::uint32_t up = above & ~evaluate;
  for (std::uint32_t i = 0; i + 1 < nx; ++i) {
    const std::uint32_t pair = 3u << i;
    if ((evaluate & pair) == 0 && (up & pair) != 0 && (up & pair) != pair) evaluate = all;
  }
  if (evaluate == 0) return up != 0 ? 0x80u : 0u;
  // The span from the first segment to evaluate to the last: one run of points for the lane.
  const std::uint32_t s0 = std::uint32_t(std::countr_zero(evaluate));
  const std::uint32_t s1 = 32u - std::uint32_t(std::countl_zero(evaluate));
  const bool upBefore = s0 > 0 && (up >> (s0 - 1) & 1u), upAfter = s1 < nx && (up >> s1 & 1u);
  return std::uint8_t(s0 | (s1 - s0) << 3 | (upBefore ? 0x40u : 0u) | (upAfter ? 0x80u : 0u));
}

// rowByte for every word of a brick's rows, made once per batch: a brick has R^2 rows and a
// handful of distinct words.
using RowBytes = std::array<std::uint8_t, 1u << 12>;

BrickRows classifyBrick(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, std::uint32_t log2B,
                        const RowBytes& rowBytes, const std::array<std::uint32_t, 3>& brick) {
  const std::uint32_t B = 1u << log2B, R = B + 1, C = kRowCullingColumnCells, n = B / C;
  const std::uint32_t L = kRowCullingSegmentCells, nx = B / L;
  const int x0 = int(brick[0] << log2B), y0 = int(brick[1] << log2B), z0 = int(brick[2] << log2B);
  // The float coordinates of the grid points the field kernel evaluates (GridSpec::point), past
  // the grid's end too: a brick there evaluates points that no pass reads.
  std::array<float, kMaxSegments + 1> x{};
  std::array<float, kMaxR> y{}, z{};
  for (std::uint32_t i = 0; i <= nx; ++i) x[i] = grid.point(x0 + int(i * L), 0, 0).x;
  for (std::uint32_t j = 0; j <= n; ++j) {
    y[j] = grid.point(0, y0 + int(j * C), 0).y;
    z[j] = grid.point(0, 0, z0 + int(j * C)).z;
  }
  std::array<std::uint8_t, kMaxSegments * 64> sides{};
  options.columnSides(x.data(), nx, y.data(), z.data(), n, sides.data());
  // Per column a word of three nx-bit fields, a bit per segment: it is proven below there (bits
  // 0-3), at or above (4-7), it may cross (8-11). A row's word ORs the words of the up to four
  // columns whose closed boxes hold it: along y first, then along z.
  std::array<std::uint16_t, 64> word{};
  for (std::uint32_t c = 0; c < n * n; ++c)
    for (std::uint32_t i = 0; i < nx; ++i) word[c] |= std::uint16_t(1u << (i + 4 * std::min<std::uint32_t>(sides[i + nx * c], 2)));
  std::array<std::uint16_t, (kMaxR / kRowCullingColumnCells) * kMaxR> alongY{};  // [k * R + ly]
  for (std::uint32_t k = 0; k < n; ++k)
    for (std::uint32_t ly = 0; ly < R; ++ly) {
      const std::uint32_t j = std::min(ly / C, n - 1);
      std::uint16_t w = word[j + n * k];
      if (ly % C == 0 && ly > 0 && ly < B) w |= word[j - 1 + n * k];
      alongY[k * R + ly] = w;
    }
  std::array<std::uint16_t, kMaxR * kMaxR> rowWord{};
  for (std::uint32_t lz = 0; lz < R; ++lz) {
    const std::uint32_t k = std::min(lz / C, n - 1);
    const bool two = lz % C == 0 && lz > 0 && lz < B;
    for (std::uint32_t ly = 0; ly < R; ++ly)
      rowWord[ly + lz * R] = std::uint16_t(alongY[k * R + ly] | (two ? alongY[(k - 1) * R + ly] : 0u));
  }
  BrickRows out;
  out.spans.fill(0);
  for (std::uint32_t r = 0; r < R * R; ++r) {
    const std::uint8_t row = rowBytes[rowWord[r]];
    out.row[r] = row;
    ++out.spans[row >> 3 & 7u];
  }
  out.spans[0] = 0;  // rows without a span are counted by the caller
  return out;
}

}  // namespace

RowPlan planRows(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, const BrickGrid& bg,
                 std::span<const std::uint32_t> packed, const BrickTileOrder& order) {
  const std::uint32_t R = (1u << bg.log2B) + 1, rows = R * R;
  const std::size_t n = order.order.size(), tiles = order.starts.size() - 1;
  RowBytes rowBytes;
  for (std::uint32_t w = 0; w < rowBytes.size(); ++w) rowBytes[w] = rowByte(w, (1u << bg.log2B) / kRowCullingSegmentCells);
  const std::unique_ptr<BrickRows[]> bricks(new BrickRows[n]);  // each filled whole: no zeroing
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    bricks[i] = classifyBrick(options, grid, bg.log2B, rowBytes, bg.unpack(packed[order.order[i]]));
  });
  // Where each brick's entries of each span length go: by tile, then by length (the lanes of a
  // work group then loop alike), then by brick; and where its one-sided rows go.
  std::vector<std::array<std::uint32_t, kMaxSegments + 1>> at(n);
  std::vector<std::uint32_t> fillAt(n);
  RowPlan plan;
  std::uint32_t entries = 0, fills = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    plan.starts.push_back(entries);
    for (std::uint32_t len = 1; len <= kMaxSegments; ++len)
      for (std::uint32_t i = order.starts[t]; i < order.starts[t + 1]; ++i) {
        at[i][len] = entries;
        entries += bricks[i].spans[len];
        plan.evaluations += std::uint64_t(bricks[i].spans[len]) * (len * kRowCullingSegmentCells + 1);
      }
  }
  plan.starts.push_back(entries);
  for (std::size_t i = 0; i < n; ++i) {
    fillAt[i] = fills;
    std::uint32_t spans = 0;
    for (const std::uint32_t c : bricks[i].spans) spans += c;
    fills += rows - spans;
  }
  plan.rows.resize(2ull * entries);
  plan.fills.resize(fills);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    const std::uint32_t a = order.order[i];
    const BrickRows& b = bricks[i];
    std::array<std::uint32_t, kMaxSegments + 1> next = at[i];
    std::uint32_t* fill = plan.fills.data() + fillAt[i];
    for (std::uint32_t r = 0; r < rows; ++r) {
      const std::uint8_t row = b.row[r];
      if ((row & 0x38u) == 0) {  // no span
        *fill++ = (a * rows + r) << 1 | std::uint32_t(row >> 7);
        continue;
      }
      const std::uint32_t e = next[row >> 3 & 7u]++;
      plan.rows[2ull * e] = a << 9 | r;
      plan.rows[2ull * e + 1] = spanWord(row, R);
    }
  });
  return plan;
}

}  // namespace blobvk::vk
