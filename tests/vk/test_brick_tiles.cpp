// The sparse field pass's tiles of bricks (vk/extract/brick_tiles.h): the plan covers every brick
// exactly once with a region holding all its points, the batch order groups bricks by tile, and
// meshes evaluated with kernels pruned per tile are the CPU reference's and, byte for byte, those
// of one unpruned kernel.
#include "blobvk/blobtree/scene_json.h"
#include "blobvk/cpu_simd/mpu_polygonizer.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/device/error.h"
#include "blobvk/vk/eval/field_tiles.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/brick_tiles.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

bool regionHolds(const vk::PointRegion& r, const glm::vec3& p) {
  for (int i = 0; i < 3; ++i)
    if (p[i] < r.lo[i] || p[i] > r.hi[i]) return false;
  return true;
}

// Packed brick coordinates take the bits each axis's brick count needs: the tower at 4096³ in
// bricks of 4³ (2332 x 4098 x 2332 cells: 583 x 1025 x 583 bricks) packs in 10 + 11 + 10 bits and
// every corner of its brick box round-trips; a cube of 1025³ bricks (33 bits), 2048 bricks along x
// (a segment record's row count) and a layer of 2^21 bricks are refused, naming the limit.
TEST(BrickGridPacking, EachAxisTakesTheBitsItsBricksNeed) {
  blobtree::GridSpec grid;
  grid.cells = {2332, 4098, 2332};
  const vk::BrickGrid tower = vk::brickGridFor(grid, 4);
  ASSERT_EQ(tower.x, 583u);
  ASSERT_EQ(tower.y, 1025u);
  EXPECT_EQ(tower.bitsX() + tower.bitsY() + tower.bitsZ(), 31u);
  for (std::uint32_t c = 0; c < 8; ++c) {
    const std::array<std::uint32_t, 3> b{c & 1 ? tower.x - 1 : 0, c & 2 ? tower.y - 1 : 0, c & 4 ? tower.z - 1 : 0};
    EXPECT_EQ(tower.unpack(tower.pack(b)), b);
  }
  const std::array<std::uint32_t, 3> inner{300, 1024, 17};
  EXPECT_EQ(tower.unpack(tower.pack(inner)), inner);
  for (const glm::ivec3 cells : {glm::ivec3(4098, 4098, 4098), glm::ivec3(8192, 4, 4), glm::ivec3(4096, 8192, 4)}) {
    grid.cells = cells;
    try {
      vk::brickGridFor(grid, 4);
      ADD_FAILURE() << cells.x << " x " << cells.y << " x " << cells.z << " cells in bricks of 4 were accepted";
    } catch (const vk::VulkanError& e) {
      EXPECT_NE(std::string(e.what()).find("use larger bricks"), std::string::npos) << e.what();
    }
  }
}

TEST(BrickTiles, CoverEveryBrickOnceWithRegionsHoldingTheirPoints) {
  for (const char* name : {"tower", "random128"}) {
    for (std::uint32_t brickCells : {4u, 16u}) {
      const ShippedScene sc = shipped(name, 100);
      const vk::BrickGrid bg = vk::brickGridFor(sc.grid, brickCells);
      const auto tiles = vk::planBrickTiles(sc.program, sc.grid, bg, 8);
      const std::string what = std::string(name) + " B=" + std::to_string(brickCells);
      ASSERT_GT(tiles.size(), 1u) << what << ": pruning should pay on this scene";
      ASSERT_LE(tiles.size(), 8u) << what;
      const std::uint32_t whole = vk::prunedEvaluationCost(sc.program, {});
      std::uint32_t cheaper = 0;
      for (const auto& t : tiles) cheaper += vk::prunedEvaluationCost(sc.program, t.region) < whole ? 1u : 0u;
      EXPECT_GT(cheaper, 0u) << what;
      std::vector<std::uint32_t> packed;
      std::vector<std::array<std::uint32_t, 3>> coords;  // of each packed brick
      for (std::uint32_t z = 0; z < bg.z; ++z)
        for (std::uint32_t y = 0; y < bg.y; ++y)
          for (std::uint32_t x = 0; x < bg.x; ++x) {
            std::uint32_t holders = 0;
            for (const auto& t : tiles) {
              if (x < t.first[0] || x > t.last[0] || y < t.first[1] || y > t.last[1] || z < t.first[2] || z > t.last[2])
                continue;
              ++holders;
              // The corners of every point the field kernel evaluates for the brick (past the grid's end too).
              for (std::uint32_t c = 0; c < 8; ++c) {
                const glm::vec3 p = sc.grid.point(int((x + (c & 1)) * brickCells), int((y + ((c >> 1) & 1)) * brickCells),
                                                  int((z + (c >> 2)) * brickCells));
                EXPECT_TRUE(regionHolds(t.region, p)) << what << " brick " << x << "," << y << "," << z;
              }
            }
            EXPECT_EQ(holders, 1u) << what << " brick " << x << "," << y << "," << z;
            if ((x + y + z) % 3 == 0) {  // a sparse batch
              packed.push_back(bg.pack({x, y, z}));
              coords.push_back({x, y, z});
            }
          }
      const vk::BrickTileOrder order = vk::orderBricksByTile(tiles, bg, packed);
      ASSERT_EQ(order.starts.size(), tiles.size() + 1);
      ASSERT_EQ(order.starts.back(), packed.size());
      std::vector<std::uint32_t> sorted = order.order;
      std::sort(sorted.begin(), sorted.end());
      std::vector<std::uint32_t> identity(packed.size());
      std::iota(identity.begin(), identity.end(), 0u);
      EXPECT_EQ(sorted, identity) << what << ": the order is a permutation of the batch";
      for (std::size_t t = 0; t < tiles.size(); ++t)
        for (std::uint32_t i = order.starts[t]; i < order.starts[t + 1]; ++i) {
          const std::array<std::uint32_t, 3> b = coords[order.order[i]];
          for (int k = 0; k < 3; ++k) EXPECT_TRUE(b[k] >= tiles[t].first[k] && b[k] <= tiles[t].last[k]) << what;
          if (i > order.starts[t]) {
            EXPECT_LT(order.order[i - 1], order.order[i]) << what;
          }
        }
    }
  }
}

// How many of `tiles` hold each brick of `bg`: 1 everywhere when they cover the grid once.
std::vector<std::uint32_t> holdersPerBrick(const std::vector<vk::BrickTile>& tiles, const vk::BrickGrid& bg) {
  std::vector<std::uint32_t> holders(std::size_t(bg.x) * bg.y * bg.z, 0);
  for (const auto& t : tiles)
    for (std::uint32_t z = t.first[2]; z <= t.last[2] && z < bg.z; ++z)
      for (std::uint32_t y = t.first[1]; y <= t.last[1] && y < bg.y; ++y)
        for (std::uint32_t x = t.first[0]; x <= t.last[0] && x < bg.x; ++x)
          ++holders[(std::size_t(z) * bg.y + y) * bg.x + x];
  return holders;
}

// A program of thousands of instructions (tower_L6P8I4: 6,448) is generated looped on CPU
// drivers, where every record load in a loop is a loop over the lanes. Past maxTiles its tiles
// split on until each tile's pruned code unrolls, still covering every brick once, within the
// cap; where any repeated shape loops (GPUs' options) nothing splits past maxTiles.
TEST(BrickTiles, LoopedTilesSplitUntilTheirCodeUnrolls) {
  const ShippedScene large = shipped("tower_L6P8I4", 256);
  const vk::BrickGrid bg = vk::brickGridFor(large.grid, 8);
  const vk::LoopOptions cpuLoops = vk::defaultCodegenOptions(true).loops;
  const vk::LoopOptions gpuLoops = vk::defaultCodegenOptions(false).loops;
  auto loops = [&](const vk::BrickTile& t) { return vk::specialisedCodeLoops(large.program, t.region, cpuLoops); };
  const auto coarse = vk::planBrickTiles(large.program, large.grid, bg, 8);
  ASSERT_LE(coarse.size(), 8u);
  ASSERT_TRUE(std::any_of(coarse.begin(), coarse.end(), loops)) << "premise: eight tiles of this program loop";
  const auto split = vk::planBrickTiles(large.program, large.grid, bg, 8, 128, cpuLoops);
  EXPECT_GT(split.size(), 8u);
  EXPECT_LE(split.size(), 128u);
  for (const auto& t : split)
    EXPECT_FALSE(loops(t)) << "tile " << t.first[0] << "," << t.first[1] << "," << t.first[2] << " still loops";
  const auto holders = holdersPerBrick(split, bg);
  EXPECT_EQ(std::count(holders.begin(), holders.end(), 1u), std::ptrdiff_t(holders.size()))
      << "every brick in exactly one tile";
  const auto capped = vk::planBrickTiles(large.program, large.grid, bg, 8, 20, cpuLoops);
  EXPECT_LE(capped.size(), 20u) << "the cap holds";
  EXPECT_GT(capped.size(), 8u);
  EXPECT_EQ(vk::planBrickTiles(large.program, large.grid, bg, 8, 128, gpuLoops).size(), coarse.size());
}

// A knot of primitives that every split keeps whole (600 points within 0.05 of the origin per axis, each
// reaching 1 unit) is left looped in the tiles maxTiles gives, not cut into kernels that all loop.
TEST(BrickTiles, AKnotNoSplitShedsIsNotSplitFurther) {
  nlohmann::json children = nlohmann::json::array();
  for (int i = 0; i < 600; ++i) {
    const double a = 0.05 * std::sin(i * 1.7), b = 0.05 * std::cos(i * 2.3), c = 0.05 * std::sin(i * 0.37);
    children.push_back({{"type", "point"}, {"centre", {a, b, c}}, {"support", 1.0}});
  }
  const nlohmann::json scene = {{"blobvk", 1}, {"root", {{"type", "union"}, {"children", children}}}};
  const blobtree::Program program = blobtree::compile(blobtree::parseSceneJson(scene.dump(), "knot.json").root);
  const blobtree::GridSpec grid = gridAt(program, 128);
  const vk::LoopOptions cpuLoops = vk::defaultCodegenOptions(true).loops;
  ASSERT_TRUE(vk::specialisedCodeLoops(program, {}, cpuLoops)) << "premise: the knot's code loops";
  const vk::BrickGrid bg = vk::brickGridFor(grid, 8);
  const auto tiles = vk::planBrickTiles(program, grid, bg, 8, 128, cpuLoops);
  EXPECT_LE(tiles.size(), 8u);
  const auto holders = holdersPerBrick(tiles, bg);
  EXPECT_EQ(std::count(holders.begin(), holders.end(), 1u), std::ptrdiff_t(holders.size()));
}

// Kernels pruned per tile give the reference mesh and the bytes of one whole-program kernel, in
// one batch and in batches of a few bricks (each batch orders its own bricks by tile).
// Plans are remembered per program and grid (vk/eval/host_memo.h): a later job of another program
// or grid gets its own plan, never the last one's, and asking again gives the same plan.
TEST(BrickTiles, PlansAreRememberedPerProgramAndGrid) {
  const ShippedScene tower = shipped("tower", 96), random = shipped("random128", 96);
  auto same = [](const std::vector<vk::BrickTile>& a, const std::vector<vk::BrickTile>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (a[i].first != b[i].first || a[i].last != b[i].last) return false;
      for (int k = 0; k < 3; ++k)
        if (a[i].region.lo[k] != b[i].region.lo[k] || a[i].region.hi[k] != b[i].region.hi[k]) return false;
    }
    return true;
  };
  const vk::BrickGrid bg = vk::brickGridFor(tower.grid, 8);
  const auto randomFirst = vk::planBrickTiles(random.program, tower.grid, bg, 7);
  const auto towerPlan = vk::planBrickTiles(tower.program, tower.grid, bg, 7);
  EXPECT_FALSE(same(randomFirst, towerPlan)) << "two models on one grid should tile differently";
  EXPECT_TRUE(same(vk::planBrickTiles(random.program, tower.grid, bg, 7), randomFirst));
  blobtree::GridSpec moved = tower.grid;
  moved.origin.x += 4.0f * tower.grid.cellSize;
  const auto movedPlan = vk::planBrickTiles(tower.program, moved, bg, 7);
  ASSERT_FALSE(movedPlan.empty());
  EXPECT_NE(movedPlan.front().region.lo[0], towerPlan.front().region.lo[0]) << "a moved grid's regions move";

  // Which tiles get kernels of their own: the answer for each region, remembered.
  const ShippedScene large = shipped("tower_L6P8I4", 64);
  std::vector<vk::PointRegion> regions;
  for (const auto& t : vk::planBrickTiles(large.program, large.grid, vk::brickGridFor(large.grid, 8), 16))
    regions.push_back(t.region);
  ASSERT_GT(regions.size(), 1u);
  const vk::LoopOptions loops;
  std::vector<char> each;
  for (const auto& r : regions) each.push_back(vk::specialiseTile(large.program, r, loops));
  const std::uint64_t print = vk::programFingerprint(large.program);
  EXPECT_EQ(vk::specialiseTiles(large.program, print, regions, loops), each);
  EXPECT_EQ(vk::specialiseTiles(large.program, print, regions, loops), each);
}

TEST_F(VulkanTest, FieldTilesGiveTheBytesOfOneKernel) {
  for (const char* name : {"tower", "random128"}) {
    const ShippedScene sc = shipped(name, 48);
    vk::GpuPolygonizeOptions o;
    o.traversal = vk::Traversal::Specialised;
    o.brickCells = 8;
    o.maxFieldTiles = 1;
    vk::GpuStats oneStats;
    const auto one = vk::polygonize(device(), sc.program, sc.grid, o, &oneStats);
    EXPECT_EQ(oneStats.fieldTiles, 1u) << name;
    expectSameMeshAsReference(one, cpu::polygonizeReference(sc.program, sc.grid), 1e-4f * sc.grid.cellSize, name);
    o.maxFieldTiles = 8;
    for (std::uint32_t batchBricks : {0u, 9u}) {
      o.maxBatchBricks = batchBricks;
      vk::GpuStats st;
      const auto m = vk::polygonize(device(), sc.program, sc.grid, o, &st);
      const std::string what = std::string(name) + ", batches of " + std::to_string(batchBricks) + " bricks";
      EXPECT_GT(st.fieldTiles, 1u) << what;
      expectSameBytes(m, one, what);
    }
  }
}

// Looped tiles split until their code unrolls (tower_L6P8I4 at 256 cells, which Auto splits)
// give the mesh of the CPU backend byte for byte, as every lavapipe mesh does (docs/vulkan.md).
TEST_F(VulkanTest, LoopedTilesSplitUntilTheyUnrollGiveTheCpuBytes) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "GPUs loop any repeated shape: no split";
  const ShippedScene sc = shipped("tower_L6P8I4", 256);
  vk::GpuPolygonizeOptions o;  // Auto: the split pays here (AutoSplitsLoopedTilesWhereTheyPay)
  vk::GpuStats st;
  const auto split = vk::polygonize(device(), sc.program, sc.grid, o, &st);
  EXPECT_EQ(st.traversal, vk::Traversal::Specialised);
  EXPECT_GT(st.fieldTiles, o.maxFieldTiles);
  EXPECT_LE(st.fieldTiles, o.maxFieldTilesForLoopedCode);
  const auto cpu = cpu::polygonizeMpu(sc.program, sc.grid);
  ASSERT_GT(cpu.triangleCount(), 0u);
  EXPECT_TRUE(sameBytes(split.positions, cpu.positions));
  EXPECT_TRUE(sameBytes(split.normals, cpu.normals));
  EXPECT_TRUE(sameBytes(split.colours, cpu.colours));
  EXPECT_TRUE(sameBytes(split.triangles, cpu.triangles));
}

// Auto splits looped tiles only where the unrolled kernels' builds pay: tower_L6P8I4 at 256 cells
// (48 tiles, the field pass 5-7 s -> 0.2-0.25 s a run, a first run no slower) but not at 64.
TEST_F(VulkanTest, AutoSplitsLoopedTilesWhereTheyPay) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  for (const int resolution : {64, 256}) {
    const ShippedScene sc = shipped("tower_L6P8I4", resolution);
    vk::GpuStats cs;
    const vk::ClassifiedBricks classified =
        vk::classifyAndCompact(device(), sc.program, sc.grid, vk::brickGridFor(sc.grid, 8), cs);
    vk::GpuPolygonizeOptions o;  // Auto, up to 128 tiles for looped code
    const vk::SparseEvaluator e = vk::resolveSparseEvaluator(device(), sc.program, sc.grid, o, &classified);
    const vk::GpuPolygonizeOptions resolved = e.apply(o);
    if (resolution == 64) {
      EXPECT_EQ(resolved.maxFieldTilesForLoopedCode, 0u) << "64 cells: the builds would not pay";
    } else {
      EXPECT_EQ(e.traversal, vk::Traversal::Specialised);
      EXPECT_EQ(resolved.maxFieldTilesForLoopedCode, 128u) << "256 cells";
      EXPECT_GT(resolved.maxFieldTiles, 1u);
    }
  }
}

// Auto tiles the field only where the pruned kernels pay back their builds over the job's
// active bricks: not dice at 64 cells (64 active bricks, 2 ms of field: measured +0.1 s of
// start-up with 8 tiles), but the tower at 256 (field 0.09 s against 0.23 s a run, measured no
// slower a first run).
TEST_F(VulkanTest, AutoTilesTheFieldWhereItPays) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  vk::GpuPolygonizeOptions o;  // Auto, up to 8 tiles
  vk::GpuStats small, large;
  const ShippedScene dice = shipped("dice", 64);
  vk::polygonize(device(), dice.program, dice.grid, o, &small);
  EXPECT_EQ(small.traversal, vk::Traversal::Specialised);
  EXPECT_EQ(small.fieldTiles, 1u);
  const ShippedScene tower = shipped("tower", 256);
  vk::polygonize(device(), tower.program, tower.grid, o, &large);
  EXPECT_EQ(large.traversal, vk::Traversal::Specialised);
  EXPECT_GT(large.fieldTiles, 1u);
}

// A job that runs again may take up to 16 tiles where the finer plan's saving over its runs pays
// its extra kernels (tower at 512 cells: the field pass a quarter shorter); one run keeps 8, and
// a cap the caller gives holds for repeated jobs too.
TEST_F(VulkanTest, RepeatedJobsTakeMoreTilesWhereTheyPay) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  const ShippedScene tower = shipped("tower", 512);
  vk::GpuStats cs;
  const vk::ClassifiedBricks classified =
      vk::classifyAndCompact(device(), tower.program, tower.grid, vk::brickGridFor(tower.grid, 16), cs);
  auto capFor = [&](std::uint32_t runs, std::uint32_t repeatedCap) {
    vk::GpuPolygonizeOptions o;  // Auto, 8 tiles, 16 for repeated jobs
    o.expectedRuns = runs;
    o.repeatedJobFieldTiles = repeatedCap;
    const vk::SparseEvaluator e = vk::resolveSparseEvaluator(device(), tower.program, tower.grid, o, &classified);
    EXPECT_EQ(e.traversal, vk::Traversal::Specialised);
    EXPECT_TRUE(e.fieldTiles);
    return e.apply(o).maxFieldTiles;
  };
  EXPECT_EQ(capFor(1, 16), 8u);
  EXPECT_EQ(capFor(6, 16), 16u);
  EXPECT_EQ(capFor(6, 8), 8u);
  EXPECT_GT(vk::planBrickTiles(tower.program, tower.grid, classified.bricks, 16).size(), 8u);
}

}  // namespace
}  // namespace blobvk::testing
