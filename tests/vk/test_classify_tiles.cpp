// The interpreted classification tile by tile (vk/extract/classify_tiles.h): a plan's tiles cover
// every brick of the top level once and every finer level's through boxBelow, each tape is no
// longer than the program and shorter where the tile misses primitives, and the cost model takes
// tiles on lavapipe where the interpreter runs the whole program at every brick (random128) and
// not where its skips already prune (tower) or the program is a few instructions (eggshell).
// That the tiles' flags never drop a brick with surface is SparseClassification's (test_sparse).
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/extract/classify_tiles.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// Scaling a box of coarse bricks to a finer level gives the finer bricks whose coarse ancestor
// lies in the box, clipped to the finer grid (whose count is the coarse one's halved, rounded up).
TEST(ClassifyTiles, BoxBelowHoldsTheDescendantsWithinTheGrid) {
  const vk::BrickGrid fine{2, 9, 4, 7};
  const vk::BrickBox coarse{{1, 0, 2}, {5, 2, 4}};  // x 1..4 of 5, y 0..1 of 2, z 2..3 of 4
  const vk::BrickBox b = vk::boxBelow(coarse, 1, fine);
  EXPECT_EQ(b.first, (std::array<std::uint32_t, 3>{2, 0, 4}));
  EXPECT_EQ(b.end, (std::array<std::uint32_t, 3>{9, 4, 7}));
  for (std::uint32_t z = 0; z < fine.z; ++z)
    for (std::uint32_t y = 0; y < fine.y; ++y)
      for (std::uint32_t x = 0; x < fine.x; ++x) {
        const bool inBox = x >= b.first[0] && x < b.end[0] && y >= b.first[1] && y < b.end[1] && z >= b.first[2] &&
                           z < b.end[2];
        const bool ancestorInBox = x / 2 >= coarse.first[0] && x / 2 < coarse.end[0] && y / 2 >= coarse.first[1] &&
                                   y / 2 < coarse.end[1] && z / 2 >= coarse.first[2] && z / 2 < coarse.end[2];
        EXPECT_EQ(inBox, ancestorInBox) << x << " " << y << " " << z;
      }
}

// Every brick of the top level in exactly one tile; tapes no longer than the program; random128's
// (128 primitives under one skip box) shorter in every tile of a split of its grid.
TEST(ClassifyTiles, APlanCoversTheTopLevelOnceWithPrunedTapes) {
  for (const char* name : {"random128", "tower", "dice"}) {
    const ShippedScene s = shipped(name, 256);
    const vk::BrickGrid finest = vk::brickGridFor(s.grid, 16);
    const vk::BrickGrid top{finest.log2B + 1, (finest.x + 1) / 2, (finest.y + 1) / 2, (finest.z + 1) / 2};
    const auto emptyBox = std::uint32_t(s.program.boxes.size());
    const vk::ClassifyTilesPlan plan = vk::planClassifyTiles(s.program, s.grid, finest, top, emptyBox, 64);
    ASSERT_GE(plan.tiles.size(), 8u) << name;
    std::vector<int> covered(top.count(), 0);
    for (const vk::PlannedClassifyTile& t : plan.tiles) {
      EXPECT_FALSE(t.top.empty()) << name;
      EXPECT_LE(t.tape.size(), s.program.code.size()) << name;
      if (std::string(name) == "random128") {
        EXPECT_LT(t.tape.size(), s.program.code.size()) << name;
      }
      for (std::uint32_t z = t.top.first[2]; z < t.top.end[2]; ++z)
        for (std::uint32_t y = t.top.first[1]; y < t.top.end[1]; ++y)
          for (std::uint32_t x = t.top.first[0]; x < t.top.end[0]; ++x) ++covered[(std::size_t(z) * top.y + y) * top.x + x];
    }
    for (std::size_t i = 0; i < covered.size(); ++i) EXPECT_EQ(covered[i], 1) << name << ": top brick " << i;
    EXPECT_GT(plan.wholeSeconds, 0.0) << name;
  }
}

// The cost model on lavapipe: random128 classifies tile by tile at 256 and 512 cells (its
// interpreter runs 256 instructions at every brick), tower (its skips prune at run time) and
// eggshell (4 instructions) with the whole program; GpuStats says which.
TEST_F(VulkanTest, TheCostModelTilesTheClassificationWhereTheInterpreterRunsEverything) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "lavapipe's constants";
  for (int resolution : {256, 512})
    for (const char* name : {"random128", "tower", "eggshell"}) {
      const ShippedScene s = shipped(name, resolution);
      vk::GpuStats stats;
      const vk::ClassifiedBricks c =
          vk::classifyAndCompact(device(), s.program, s.grid, vk::brickGridFor(s.grid, 16), stats, nullptr, 0,
                                 {vk::ClassifyCode::Interpreter, 1});
      const std::string what = std::string(name) + " at " + std::to_string(resolution);
      if (std::string(name) == "random128") {
        EXPECT_GE(stats.classifyTiles, 8u) << what;
      } else {
        EXPECT_EQ(stats.classifyTiles, 0u) << what;
      }
      EXPECT_GT(c.layerStarts.back(), 0u) << what;
    }
}

// Tiles in windows of brick layers (a grid whose flags outgrow one storage buffer): each window
// classifies its layers and the parent layers above them tile by tile, and the tables are those
// of one window, tiles forced on the scenes where the cost model takes them or not.
TEST_F(VulkanTest, TiledClassificationInWindowsGivesTheTablesOfOneWindow) {
  for (const char* name : {"random128", "tower"}) {
    const ShippedScene s = shipped(name, 40);
    for (std::uint32_t brickCells : {2u, 4u}) {
      const vk::BrickGrid bricks = vk::brickGridFor(s.grid, brickCells);
      vk::ClassifyChoice tiled{vk::ClassifyCode::Interpreter, 1};
      tiled.tilesWhenTheyPay = false;
      vk::GpuStats wholeStats;
      const vk::ClassifiedBricks one = vk::classifyAndCompact(device(), s.program, s.grid, bricks, wholeStats, nullptr, 0, tiled);
      const std::string base = std::string(name) + ", B=" + std::to_string(brickCells);
      ASSERT_GE(wholeStats.classifyTiles, 8u) << base;
      for (std::uint32_t windowLayers : {1u, 3u}) {
        const std::string what = base + ", windows of " + std::to_string(windowLayers) + " layers";
        vk::GpuStats st;
        const vk::ClassifiedBricks w = vk::classifyAndCompact(device(), s.program, s.grid, bricks, st, nullptr, windowLayers, tiled);
        EXPECT_EQ(st.classifyTiles, wholeStats.classifyTiles) << what;
        EXPECT_EQ(w.windows.size(), (bricks.z + windowLayers - 1) / windowLayers) << what;
        EXPECT_EQ(w.layerStarts, one.layerStarts) << what;
        EXPECT_EQ(w.downloadList(device(), 0, w.layerStarts.back()), one.downloadList(device(), 0, one.layerStarts.back()))
            << what;
      }
    }
  }
}

}  // namespace
}  // namespace blobvk::testing
