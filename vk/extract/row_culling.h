// Row culling (GpuPolygonizeOptions::columnSides): which points of a batch's bricks the field
// pass evaluates. Each brick of B >= 4 cells is cut into columns of 2 x 2 cells along y and z,
// and each column into segments of 4 cells along x (the field kernel's rows, a vec4 of samples a
// segment); a host bound gives each such box's side. A row's segment is evaluated when it lies in
// the closed box of one that may cross; the field pass's lane for the row evaluates the span from
// its first such segment to its last, and takes the proven side of the points outside the span
// (a row without one takes it whole, brick_row_fill.comp). Every such point lies only in boxes
// proven on one side, which agree.
// Why that keeps the mesh: every grid edge of a brick lies in some box's closed box, so a
// crossing edge lies in one that may cross, and both its ends are evaluated; the vertex pass
// reads samples on crossing edges only.
// Measured (tower and random128 at 512 cells, `blobvk bench`): columns of 2 cells leave about a
// tenth fewer rows than columns of 4; segments of 4 cells take about 0.4x the samples of whole
// rows (FVEPT 10.1 -> 3.9, 6.8 -> 3.2), segments of 8 about 0.65x.
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
// Columns are cut along x into segments of this many cells, a vec4 of samples each.
inline constexpr std::uint32_t kRowCullingSegmentCells = 4;

// Whether a job culls rows: a bound given, llvmpipe (the active-brick list is on the host, and it
// evaluates with IEEE division and sqrt, which the bound's contract assumes), no brick tapes,
// bricks of at least two columns a side.
bool cullsRows(const GpuPolygonizeOptions& options, bool llvmpipe, std::uint32_t brickCells);

struct RowPlan {
  // Rows to evaluate, two words an entry: batch brick << 9 | row (y + z * R); then the span of
  // segments the lane evaluates, first << 17 | count << 20, and the inside bits of the row's
  // points outside it (bits 0-16). Grouped as the bricks are by field tile, within a tile by count.
  std::vector<std::uint32_t> rows;
  std::vector<std::uint32_t> starts;  // per field tile, its first entry of `rows` (tiles + 1)
  std::uint64_t evaluations = 0;      // the points the entries evaluate
  // Rows proven on one side: (batch brick * R^2 + row) << 1 | inside.
  std::vector<std::uint32_t> fills;
};

// The plan for a batch: `packed` its bricks (the batch's numbering), `order` them by field tile.
RowPlan planRows(const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid, const BrickGrid& bg,
                 std::span<const std::uint32_t> packed, const BrickTileOrder& order);

}  // namespace blobvk::vk
