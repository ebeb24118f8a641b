#include "blobvk/vk/extract/row_culling.h"

#include <tbb/parallel_for.h>

#include <array>
#include <bitset>
#include <utility>

namespace blobvk::vk {

bool cullsRows(const GpuPolygonizeOptions& options, bool llvmpipe, std::uint32_t brickCells) {
  return options.columnSides && llvmpipe && !options.brickTapes && brickCells >= 2 * kRowCullingColumnCells;
}

namespace {

constexpr std::uint32_t kMaxR = 17;
// Per brick: the rows to evaluate, and the inside bit of the others.
struct BrickRows {
  std::bitset<kMaxR * kMaxR> evaluate, inside;
};

BrickRows classifyBrick(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, std::uint32_t log2B,
                        const std::array<std::uint32_t, 3>& brick) {
  const std::uint32_t B = 1u << log2B, R = B + 1, C = kRowCullingColumnCells, n = B / C;
  const int x0 = int(brick[0] << log2B), y0 = int(brick[1] << log2B), z0 = int(brick[2] << log2B);
  // The float coordinates of the grid points the field kernel evaluates (GridSpec::point), past
  // the grid's end too: a brick there evaluates points that no pass reads.
  const float x[2] = {grid.point(x0, 0, 0).x, grid.point(x0 + int(B), 0, 0).x};
  std::array<float, kMaxR> y{}, z{};
  for (std::uint32_t j = 0; j <= n; ++j) {
    y[j] = grid.point(0, y0 + int(j * C), 0).y;
    z[j] = grid.point(0, 0, z0 + int(j * C)).z;
  }
  std::array<std::uint8_t, 64> sides{};
  options.columnSides(x, y.data(), z.data(), n, sides.data());
  BrickRows out;
  std::bitset<kMaxR * kMaxR> below, above;  // rows in a column proven below / at or above
  for (std::uint32_t k = 0; k < n; ++k)
    for (std::uint32_t j = 0; j < n; ++j) {
      const std::uint8_t side = sides[j + n * k];
      for (std::uint32_t lz = k * C; lz <= k * C + C; ++lz)
        for (std::uint32_t ly = j * C; ly <= j * C + C; ++ly) {
          const std::uint32_t r = ly + lz * R;
          if (side == 0) below.set(r);
          else if (side == 1) above.set(r);
          else out.evaluate.set(r);
        }
    }
  // Columns that disagree on a row could only come from a broken bound: evaluate it.
  out.evaluate |= below & above;
  out.inside = above & ~out.evaluate;
  return out;
}

}  // namespace

RowPlan planRows(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, const BrickGrid& bg,
                 std::span<const std::uint32_t> packed, const BrickTileOrder& order) {
  const std::uint32_t R = (1u << bg.log2B) + 1, rows = R * R;
  const std::size_t n = order.order.size();
  // Per brick in tile order: its rows, then where its entries go (a scan), then the entries.
  std::vector<BrickRows> bricks(n);
  std::vector<std::uint32_t> evaluated(n + 1, 0);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    bricks[i] = classifyBrick(options, grid, bg.log2B, bg.unpack(packed[order.order[i]]));
    evaluated[i] = std::uint32_t(bricks[i].evaluate.count());
  });
  std::uint32_t total = 0;
  for (std::size_t i = 0; i < n; ++i) total += std::exchange(evaluated[i], total);
  evaluated[n] = total;
  RowPlan plan;
  plan.rows.resize(total);
  plan.fills.resize(n * rows - total);
  tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
    const std::uint32_t a = order.order[i];
    const BrickRows& b = bricks[i];
    std::uint32_t* row = plan.rows.data() + evaluated[i];
    std::uint32_t* fill = plan.fills.data() + (i * rows - evaluated[i]);
    for (std::uint32_t r = 0; r < rows; ++r) {
      if (b.evaluate.test(r)) *row++ = a << 9 | r;
      else *fill++ = (a * rows + r) << 1 | (b.inside.test(r) ? 1u : 0u);
    }
  });
  for (const std::uint32_t first : order.starts) plan.starts.push_back(evaluated[first]);
  return plan;
}

}  // namespace blobvk::vk
