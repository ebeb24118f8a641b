// Row culling (vk/extract/row_culling.h, cpu/column_sides.h): the field pass on llvmpipe skips the
// rows of points that the CPU backend's bound proves on one side of the iso-value.
// - cpu::ColumnSides against the field itself: every grid point of a column given a side has that
//   side (blobtree::evaluate at every point of the column's closed box).
// - The device: with culling, the mesh of every shipped scene it applies to is the CPU
//   reference's and the bytes of the run without it, in one batch and in batches of a few
//   bricks, with bricks of 16 and 8, on the specialised tiles and the interpreter; fewer points
//   are evaluated.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/cpu_simd/column_sides.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/extract/polygonize.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

vk::GpuPolygonizeOptions culling(const std::shared_ptr<cpu::ColumnSides>& sides) {
  vk::GpuPolygonizeOptions o;
  o.columnSides = [sides](const float x[2], const float* y, const float* z, std::uint32_t n, std::uint8_t* out) {
    (*sides)(x, y, z, n, out);
  };
  return o;
}

TEST(ColumnSides, EveryPointOfAColumnGivenASideHasIt) {
  std::mt19937 rng(11);
  for (const char* name : {"tower", "random128", "eggshell", "dice", "craniotomy"}) {
    const ShippedScene s = shipped(name, 96);
    const cpu::ColumnSides sides(s.program);
    std::size_t proven = 0, crossing = 0;
    for (int box = 0; box < 60; ++box) {
      // Boxes of 16 cells at random places, columns of 4 cells (the field pass cuts bricks in
      // columns of 2; the bound is the same for any size).
      int first[3];
      for (int a = 0; a < 3; ++a)
        first[a] = std::uniform_int_distribution<int>(0, std::max(0, s.grid.cells[a] - 16))(rng);
      const float x[2] = {s.grid.point(first[0], 0, 0).x, s.grid.point(first[0] + 16, 0, 0).x};
      float y[5], z[5];
      for (int j = 0; j <= 4; ++j) {
        y[j] = s.grid.point(0, first[1] + 4 * j, 0).y;
        z[j] = s.grid.point(0, 0, first[2] + 4 * j).z;
      }
      std::uint8_t side[16];
      sides(x, y, z, 4, side);
      for (int k = 0; k < 4; ++k)
        for (int j = 0; j < 4; ++j) {
          const std::uint8_t c = side[j + 4 * k];
          ASSERT_LE(c, 2) << name;
          if (c == 2) {
            ++crossing;
            continue;
          }
          ++proven;
          for (int pz = 4 * k; pz <= 4 * k + 4; ++pz)
            for (int py = 4 * j; py <= 4 * j + 4; ++py)
              for (int px = 0; px <= 16; ++px) {
                const float f = blobtree::evaluate(s.program, s.grid.point(first[0] + px, first[1] + py, first[2] + pz));
                ASSERT_EQ(f >= layout::ISO_VALUE, c == 1) << name << " box " << box << " column " << j << "," << k;
              }
        }
    }
    EXPECT_GT(proven, 0u) << name;  // the bound decides columns, not only "may cross"
  }
}

TEST(ColumnSides, HoldOnIeeeDevicesOnlyWithoutPowSinAndCos) {
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("tower", 16).program));
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("random128", 16).program));
  EXPECT_FALSE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("twisted_column", 16).program));  // twist
}

TEST_F(VulkanTest, RowCullingGivesTheMeshOfEveryRow) {
  if (!device().info().isLlvmpipe()) GTEST_SKIP() << "row culling runs on llvmpipe only";
  for (const std::string& name : shippedSceneNames()) {
    ShippedScene s = shipped(name, 64);
    if (!cpu::ColumnSides::boundsHoldOnIeeeDevices(s.program)) continue;
    const auto sides = std::make_shared<cpu::ColumnSides>(s.program);
    const mesh::TriMesh reference = cpu::polygonizeReference(s.program, s.grid, {});
    struct Setting {
      std::uint32_t brickCells;
      vk::Traversal traversal;
      std::uint32_t batchBricks;
    };
    for (const Setting& setting : {Setting{16, vk::Traversal::Auto, 0}, Setting{16, vk::Traversal::Stackless, 7},
                                   Setting{8, vk::Traversal::Auto, 7}, Setting{8, vk::Traversal::Stackless, 0}}) {
          const auto [brickCells, traversal, batchBricks] = setting;
          const std::string what = name + ", bricks of " + std::to_string(brickCells) + ", " +
                                   vk::traversalName(traversal) + ", batches of " + std::to_string(batchBricks);
          vk::GpuPolygonizeOptions o = culling(sides);
          o.brickCells = brickCells;
          o.traversal = traversal;
          o.maxBatchBricks = batchBricks;
          vk::GpuStats culled, every;
          const mesh::TriMesh m = vk::polygonize(device(), s.program, s.grid, o, &culled);
          o.columnSides = nullptr;
          const mesh::TriMesh all = vk::polygonize(device(), s.program, s.grid, o, &every);
          expectSameBytes(m, all, what);
          expectSameMeshAsReference(m, reference, 1e-4f * s.grid.cellSize, what);
          // Every row of an active brick without culling; with it, whole rows and fewer of them.
          const std::uint64_t R = every.brickCells + 1;  // tower_L6P8I4 takes 8 on llvmpipe (its loop limit)
          EXPECT_EQ(culled.brickCells, every.brickCells) << what;
          if (every.batches == 1) {
            EXPECT_EQ(every.fieldEvaluations, std::uint64_t(every.activeBricks) * R * R * R) << what;
          }
          EXPECT_EQ(culled.fieldEvaluations % R, 0u) << what;
          if (!reference.triangles.empty()) {
            EXPECT_LT(culled.fieldEvaluations, every.fieldEvaluations) << what;
          }
        }
  }
}

}  // namespace
}  // namespace blobvk::testing
