// Row culling (GpuPolygonizeOptions::columnSides): which rows of points of a batch's bricks the
// field pass evaluates. Each brick of B >= 4 cells is cut into columns of 2 x 2 cells (whole along
// x, the field kernel's rows); a host bound gives each column's side. Columns of 2 cells leave
// about a tenth fewer rows than columns of 4 for about 1.5x the host's bounding time (random128
// at 256 and 512 cells: 53 % of the rows against 59 %). A row is evaluated when it
// lies in the closed box of a column that may cross; every other row lies only in columns proven
// on one side, which agree, and takes their side as its inside bits (brick_row_fill.comp).
// Why that keeps the mesh: every grid edge of a brick lies in some column's closed box, so a
// crossing edge lies in one that may cross, and both its ends are evaluated; the vertex pass
// reads samples on crossing edges only.
#pragma once

#include "blobvk/blobtree/grid.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"

#include <cstdint>
#include <span>
#include <vector>

namespace blobvk::vk {

inline constexpr std::uint32_t kRowCullingColumnCells = 2;

// Whether a job culls rows: a bound given, llvmpipe (the active-brick list is on the host, and it
// evaluates with IEEE division and sqrt, which the bound's contract assumes), no brick tapes,
// bricks of at least two columns a side.
bool cullsRows(const GpuPolygonizeOptions& options, bool llvmpipe, std::uint32_t brickCells);

struct RowPlan {
  // Rows to evaluate, batch brick << 9 | row (y + z * R), grouped as the bricks are by field tile.
  std::vector<std::uint32_t> rows;
  std::vector<std::uint32_t> starts;  // per field tile, its first entry of `rows` (tiles + 1)
  // Rows proven on one side: (batch brick * R^2 + row) << 1 | inside.
  std::vector<std::uint32_t> fills;
};

// The plan for a batch: `packed` its bricks (the batch's numbering), `order` them by field tile.
RowPlan planRows(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, const BrickGrid& bg,
                 std::span<const std::uint32_t> packed, const BrickTileOrder& order);

}  // namespace blobvk::vk
