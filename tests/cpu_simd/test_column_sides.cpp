// cpu::ColumnSides (the Vulkan path's row culling bound) against the field itself: every grid
// point of a column given a side has that side (blobtree::evaluate at every point of the
// column's closed box), called from one thread and from many at once.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/column_sides.h"
#include "tests/vk/shipped_scenes.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace blobvk {
namespace {

using testing::shipped;
using Scene = testing::ShippedScene;

// A box of 16 cells from grid point `first`, in n x n columns along y and z, each cut into nx
// segments along x; returns how many boxes it proved and checks each proven box at every point
// of its closed box.
std::size_t checkBox(const Scene& s, const cpu::ColumnSides& sides, const int first[3], std::uint32_t nx,
                     std::uint32_t n, const std::string& what) {
  const int cells = 16 / int(n), length = 16 / int(nx);
  std::vector<float> x(nx + 1), y(n + 1), z(n + 1);
  for (std::uint32_t i = 0; i <= nx; ++i) x[i] = s.grid.point(first[0] + length * int(i), 0, 0).x;
  for (std::uint32_t j = 0; j <= n; ++j) {
    y[j] = s.grid.point(0, first[1] + cells * int(j), 0).y;
    z[j] = s.grid.point(0, 0, first[2] + cells * int(j)).z;
  }
  std::vector<std::uint8_t> side(std::size_t(nx) * n * n, 9);
  sides(x.data(), nx, y.data(), z.data(), n, side.data());
  std::size_t proven = 0;
  for (std::uint32_t k = 0; k < n; ++k)
    for (std::uint32_t j = 0; j < n; ++j)
      for (std::uint32_t i = 0; i < nx; ++i) {
        const std::uint8_t c = side[i + nx * (j + n * k)];
        EXPECT_LE(c, 2) << what;
        if (c == 2) continue;
        ++proven;
        for (int pz = cells * int(k); pz <= cells * int(k + 1); ++pz)
          for (int py = cells * int(j); py <= cells * int(j + 1); ++py)
            for (int px = length * int(i); px <= length * int(i + 1); ++px) {
              const float f = blobtree::evaluate(s.program, s.grid.point(first[0] + px, first[1] + py, first[2] + pz));
              if ((f >= layout::ISO_VALUE) != (c == 1)) {
                ADD_FAILURE() << what << ": box " << i << "," << j << "," << k << " proven " << int(c) << " but f = " << f;
                return proven;
              }
            }
      }
  return proven;
}

TEST(ColumnSides, EveryPointOfAColumnGivenASideHasIt) {
  std::mt19937 rng(11);
  for (const char* name : {"tower", "random128", "eggshell", "dice", "craniotomy"}) {
    const Scene s = shipped(name, 96);
    const cpu::ColumnSides sides(s.program);
    std::size_t proven = 0;
    for (int box = 0; box < 60; ++box) {
      int first[3];
      for (int a = 0; a < 3; ++a)
        first[a] = std::uniform_int_distribution<int>(0, std::max(0, s.grid.cells[a] - 16))(rng);
      for (std::uint32_t n : {2u, 4u, 8u})
        for (std::uint32_t nx : {1u, 2u, 4u})
          proven += checkBox(s, sides, first, nx, n,
                             std::string(name) + " box " + std::to_string(box) + ", " + std::to_string(nx) + " x " +
                                 std::to_string(n) + " x " + std::to_string(n));
    }
    EXPECT_GT(proven, 0u) << name;  // the bound decides columns, not only "may cross"
  }
}

// The row culling calls one ColumnSides from every thread at once (each keeps its own tapes).
TEST(ColumnSides, ManyThreadsAtOnceGiveOneThreadsSides) {
  const Scene s = shipped("tower", 128);
  const cpu::ColumnSides shared(s.program);
  std::vector<std::array<int, 3>> boxes;
  for (int z = 0; z + 16 <= s.grid.cells.z; z += 16)
    for (int y = 0; y + 16 <= s.grid.cells.y; y += 16)
      for (int x = 0; x + 16 <= s.grid.cells.x; x += 16) boxes.push_back({x, y, z});
  auto sidesOf = [&](const cpu::ColumnSides& sides, const std::array<int, 3>& b) {
    float x[5], y[9], z[9];
    for (int i = 0; i <= 4; ++i) x[i] = s.grid.point(b[0] + 4 * i, 0, 0).x;
    for (int j = 0; j <= 8; ++j) y[j] = s.grid.point(0, b[1] + 2 * j, 0).y, z[j] = s.grid.point(0, 0, b[2] + 2 * j).z;
    std::array<std::uint8_t, 256> out{};
    sides(x, 4, y, z, 8, out.data());
    return out;
  };
  std::vector<std::array<std::uint8_t, 256>> serial(boxes.size()), parallel(boxes.size());
  {
    const cpu::ColumnSides own(s.program);
    for (std::size_t i = 0; i < boxes.size(); ++i) serial[i] = sidesOf(own, boxes[i]);
  }
  tbb::parallel_for(std::size_t(0), boxes.size(), [&](std::size_t i) { parallel[i] = sidesOf(shared, boxes[i]); });
  ASSERT_GT(boxes.size(), 20u);
  EXPECT_EQ(serial, parallel);
}

TEST(ColumnSides, HoldOnIeeeDevicesWithTwistsAndBends) {
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("tower", 16).program));
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("random128", 16).program));
  // Twists' and bends' bounds keep a margin for the device's sin and cos.
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("twisted_column", 16).program));
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(shipped("creature", 16).program));
  // A Ricci blend (pow) alone: the sides keep kPowDeviceMargin from the iso-value.
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(
      blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/tower_fragment.blob").root)));
  // Up to power 8.8: above, a child's power flushed to 0 on one side only moves the blend by
  // 2^(-126/n), more than half the margin.
  auto ricci = [](double power) { return blobtree::compile(blobtree::generateRandomRicciBlobs(6, 3, power)); };
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(ricci(0.5)));
  EXPECT_TRUE(cpu::ColumnSides::boundsHoldOnIeeeDevices(ricci(8.0)));
  EXPECT_FALSE(cpu::ColumnSides::boundsHoldOnIeeeDevices(ricci(16.0)));
  EXPECT_GT(std::exp2(-126.0 / 16.0), 0.5 * cpu::ColumnSides::kPowDeviceMargin);
  EXPECT_LT(std::exp2(-126.0 / 8.0), 0.5 * cpu::ColumnSides::kPowDeviceMargin);
}

}  // namespace
}  // namespace blobvk
