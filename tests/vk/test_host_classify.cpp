// The classification on the host (vk/extract/host_classify.h): with the CPU backend's bound,
// every cell whose corners straddle the iso-value (the CPU field at the grid points, the oracle)
// lies in a listed brick, the list ascends in (z, y, x) order with the row and layer starts that
// number it, the watch's abandon rule holds, and every shipped scene's mesh is the device
// classification's byte for byte and the CPU reference's, in one batch and in batches of a few
// bricks.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/cpu_simd/column_sides.h"
#include "blobvk/vk/extract/host_classify.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "both_paths.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <memory>
#include <set>
#include <string>
#include <tuple>
#include <vector>

namespace blobvk::testing {
namespace {

vk::GpuPolygonizeOptions withBound(const blobtree::Program& program) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides = std::make_shared<cpu::ColumnSides>(program)](
                      const float* x, std::uint32_t nx, const float* y, const float* z, std::uint32_t n,
                      std::uint8_t* out) { (*sides)(x, nx, y, z, n, out); };
  return o;
}

TEST_F(VulkanTest, HostClassificationListsEveryBrickTheSurfaceCrosses) {
  std::size_t scenes = 0;
  for (const std::string& name : shippedSceneNames()) {
    const ShippedScene s = shipped(name, 40);
    if (!cpu::ColumnSides::boundsHoldOnIeeeDevices(s.program)) continue;
    ++scenes;
    const vk::BrickGrid bg = vk::brickGridFor(s.grid, 4);
    vk::GpuStats stats;
    const vk::ClassifiedBricks c = vk::classifyOnHost(device(), withBound(s.program), s.grid, bg, stats);
    ASSERT_EQ(c.windows.size(), 1u) << name;
    ASSERT_FALSE(c.abandoned) << name;
    const std::uint32_t count = c.layerStarts.back();
    EXPECT_EQ(stats.activeBricks, count) << name;
    EXPECT_TRUE(stats.hostClassification) << name;
    const std::vector<std::uint32_t> list = c.downloadList(device(), 0, count);
    std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> listed;  // (z, y, x)
    std::tuple<std::uint32_t, std::uint32_t, std::uint32_t> previous{0, 0, 0};
    for (std::uint32_t i = 0; i < count; ++i) {
      const auto b = bg.unpack(list[i]);
      const std::tuple<std::uint32_t, std::uint32_t, std::uint32_t> zyx{b[2], b[1], b[0]};
      if (i > 0) {
        EXPECT_LT(previous, zyx) << name << ": the list ascends in (z, y, x)";
      }
      previous = zyx;
      listed.insert(zyx);
      EXPECT_LE(c.layerStarts[b[2]], i) << name;
      EXPECT_LT(i, c.layerStarts[b[2] + 1]) << name;
    }
    std::vector<std::uint32_t> rowStarts(bg.z * bg.y + 1);
    device().download(c.windows[0].rowStarts, rowStarts.data(), rowStarts.size() * 4);
    for (std::uint32_t i = 0; i < count; ++i) {
      const auto b = bg.unpack(list[i]);
      const std::uint32_t row = b[2] * bg.y + b[1];
      EXPECT_TRUE(rowStarts[row] <= i && i < rowStarts[row + 1]) << name << ": brick " << i << " in its row's run";
    }
    EXPECT_EQ(rowStarts.back(), count) << name;
    // The oracle: inside bits of the CPU field at every grid point; a cell whose corners differ
    // holds a crossing edge, and its brick must be listed.
    const int nx = s.grid.cells.x + 1, ny = s.grid.cells.y + 1, nz = s.grid.cells.z + 1;
    std::vector<std::uint8_t> inside(std::size_t(nx) * ny * nz);
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          inside[(std::size_t(k) * ny + j) * nx + i] =
              blobtree::evaluate(s.program, s.grid.point(i, j, k)) >= layout::ISO_VALUE;
    std::size_t crossingCells = 0, missing = 0;
    for (int k = 0; k + 1 < nz; ++k)
      for (int j = 0; j + 1 < ny; ++j)
        for (int i = 0; i + 1 < nx; ++i) {
          int ones = 0;
          for (int c8 = 0; c8 < 8; ++c8)
            ones += inside[(std::size_t(k + (c8 >> 2)) * ny + j + (c8 >> 1 & 1)) * nx + i + (c8 & 1)];
          if (ones == 0 || ones == 8) continue;
          ++crossingCells;
          missing += !listed.count({std::uint32_t(k) >> 2, std::uint32_t(j) >> 2, std::uint32_t(i) >> 2});
        }
    EXPECT_GT(crossingCells, 0u) << name;
    EXPECT_EQ(missing, 0u) << name << ": cells the surface crosses in unlisted bricks";
    EXPECT_LT(count, bg.count()) << name << ": some bricks are proven one-sided";
    // Two adjacent layers over 0 active bricks: abandoned, for smaller bricks.
    vk::ClassifyWatch watch;
    watch.abandonPairsOver = 0;
    EXPECT_TRUE(vk::classifyOnHost(device(), withBound(s.program), s.grid, bg, stats, watch).abandoned) << name;
  }
  EXPECT_GE(scenes, 5u);
}

TEST_F(VulkanTest, HostAndDeviceClassificationsGiveTheSameMeshes) {
  const bool llvmpipe = device().info().isLlvmpipe();
  BothPaths paths;
  paths.resolution = 40;
  paths.keep = [](const ShippedScene& s) { return cpu::ColumnSides::boundsHoldOnIeeeDevices(s.program); };
  paths.base = [](const ShippedScene& s) {
    vk::GpuPolygonizeOptions o = withBound(s.program);
    o.traversal = vk::Traversal::Stackless;  // quick to build; the classification does not see it
    return o;
  };
  paths.change = [](vk::GpuPolygonizeOptions& o) { o.hostPassesOnCpuDevices = false; };
  paths.check = [llvmpipe](const std::string& what, const ShippedScene&, const mesh::TriMesh&, const vk::GpuStats& host,
                           const vk::GpuStats& onDevice) {
    EXPECT_EQ(host.hostClassification, llvmpipe) << what;
    EXPECT_FALSE(onDevice.hostClassification) << what;
  };
  expectBothPathsGiveTheSameMeshes(device(), paths);
}

}  // namespace
}  // namespace blobvk::testing
