#include "blobvk/vk/extract/host_classify.h"

#include "blobvk/vk/extract/sparse_batches.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <vector>

namespace blobvk::vk {

bool classifiesOnHost(const Device& device, const GpuPolygonizeOptions& options, const BrickGrid& bricks) {
  return options.columnSides && options.hostPassesOnCpuDevices && options.windowLayers == 0 &&
         device.info().isLlvmpipe() && bricks.count() <= kHostClassifyMaxBricks;
}

ClassifiedBricks classifyOnHost(Device& device, const GpuPolygonizeOptions& options, const blobtree::GridSpec& grid,
                                const BrickGrid& bg, GpuStats& s, const ClassifyWatch& watch) {
  const auto start = std::chrono::steady_clock::now();
  ClassifiedBricks c;
  c.bricks = bg;
  const std::uint32_t B = 1u << bg.log2B, rows = bg.z * bg.y;
  // The float coordinates of a brick's first and last grid points along each axis (GridSpec::
  // point, as the field pass evaluates them), its last clipped to the grid.
  auto span = [&](int axis, std::uint32_t brick) {
    const int cells = axis == 0 ? grid.cells.x : axis == 1 ? grid.cells.y : grid.cells.z;
    const int first = int(brick * B), last = std::min(int((brick + 1) * B), cells);
    auto coordinate = [&](int i) {
      const auto p = grid.point(axis == 0 ? i : 0, axis == 1 ? i : 0, axis == 2 ? i : 0);
      return axis == 0 ? p.x : axis == 1 ? p.y : p.z;
    };
    return std::array<float, 2>{coordinate(first), coordinate(last)};
  };
  // Two levels: blocks of 4 x 4 x 4 bricks first (clipped to the grid), then the bricks of the
  // blocks that may cross; a block's box holds its bricks', so a block proven one-sided proves
  // them (eggshell at 512 cells: 945 of 20,097 bricks active, most blocks dropped whole).
  auto side = [&](std::array<std::uint32_t, 3> first, std::array<std::uint32_t, 3> end) {
    const std::array<float, 2> x{span(0, first[0])[0], span(0, end[0] - 1)[1]};
    const std::array<float, 2> y{span(1, first[1])[0], span(1, end[1] - 1)[1]};
    const std::array<float, 2> z{span(2, first[2])[0], span(2, end[2] - 1)[1]};
    std::uint8_t out = 2;
    options.columnSides(x.data(), 1, y.data(), z.data(), 1, &out);
    return out;  // 0 below the iso-value, 1 at or above, 2 either
  };
  constexpr std::uint32_t kBlock = 4;
  const std::uint32_t blocksX = (bg.x + kBlock - 1) / kBlock, blocksY = (bg.y + kBlock - 1) / kBlock,
                      blocksZ = (bg.z + kBlock - 1) / kBlock;
  std::vector<std::uint8_t> active(bg.count(), 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, blocksX * blocksY * blocksZ),
                    [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t b = r.begin(); b < r.end(); ++b) {
      const std::array<std::uint32_t, 3> first{b % blocksX * kBlock, b / blocksX % blocksY * kBlock, b / blocksX / blocksY * kBlock};
      const std::array<std::uint32_t, 3> end{std::min(first[0] + kBlock, bg.x), std::min(first[1] + kBlock, bg.y),
                                             std::min(first[2] + kBlock, bg.z)};
      if (side(first, end) != 2) continue;
      for (std::uint32_t z = first[2]; z < end[2]; ++z)
        for (std::uint32_t y = first[1]; y < end[1]; ++y)
          for (std::uint32_t x = first[0]; x < end[0]; ++x)
            active[(std::uint64_t(z) * bg.y + y) * bg.x + x] = side({x, y, z}, {x + 1, y + 1, z + 1}) == 2;
    }
  });
  // The tables in (z, y, x) order: each row's first active brick (and the count after the last
  // row), the packed list, each layer's first.
  std::vector<std::uint32_t> rowStarts(rows + 1), list;
  c.layerStarts.assign(bg.z + 1, 0);
  std::uint32_t count = 0;
  for (std::uint32_t row = 0; row < rows; ++row) {
    if (row % bg.y == 0) c.layerStarts[row / bg.y] = count;
    rowStarts[row] = count;
    for (std::uint32_t x = 0; x < bg.x; ++x) {
      if (!active[std::uint64_t(row) * bg.x + x]) continue;
      list.push_back(bg.pack({x, row % bg.y, row / bg.y}));
      ++count;
    }
  }
  rowStarts[rows] = count;
  c.layerStarts[bg.z] = count;
  ScanWindow w;
  w.firstLayer = 0;
  w.endLayer = bg.z;
  w.rowStarts = makeSparseBuffer(device, rowStarts.size() * 4ull, "brick row starts", c.bytes);
  device.upload(w.rowStarts, rowStarts.data(), rowStarts.size() * 4ull);
  w.list = makeSparseBuffer(device, std::max<std::uint64_t>(list.size(), 1) * 4, "brick list", c.bytes);
  if (!list.empty()) device.upload(w.list, list.data(), list.size() * 4ull);
  c.windows.push_back(std::move(w));
  for (std::uint32_t z = 0; z < bg.z && !c.abandoned; ++z)
    c.abandoned = c.layerStarts[std::min(z + watch.abandonLayers, bg.z)] - c.layerStarts[z] > watch.abandonPairsOver;
  s.activeBricks = count;
  s.hostClassification = true;
  s.classifySeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return c;
}

}  // namespace blobvk::vk
