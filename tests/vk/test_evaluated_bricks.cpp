// The cost model weighs the field at the points the sparse extraction evaluates, the active
// bricks, not the whole grid (vk/eval/evaluator_choice.h, EvaluatedBricks): its estimates follow
// the bricks given, and the sparse path chooses with the bricks its classification found.
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <utility>
#include <vector>

namespace blobvk::testing {
namespace {

// Every brick of `cells`-cell bricks over the grid.
vk::EvaluatedBricks allBricks(const blobtree::GridSpec& grid, std::uint32_t cells) {
  vk::EvaluatedBricks e;
  e.cells = cells;
  for (std::uint32_t z = 0; z * cells < std::uint32_t(grid.cells.z); ++z)
    for (std::uint32_t y = 0; y * cells < std::uint32_t(grid.cells.y); ++y)
      for (std::uint32_t x = 0; x * cells < std::uint32_t(grid.cells.x); ++x) e.bricks.push_back({x, y, z});
  return e;
}

vk::EvaluatorEstimate interpreterFor(const blobtree::Program& program, const blobtree::GridSpec& grid,
                                     const vk::EvaluatedBricks* evaluated) {
  vk::EvaluatorJob job;  // the field alone: the vertex pass scales with the grid, not the bricks
  job.tiling.maxTiles = 1;
  job.evaluated = evaluated;
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  const auto choice = vk::chooseEvaluator(true, program, grid, job, unrolled);
  EXPECT_EQ(choice.candidates.front().traversal, vk::Traversal::Stackless);
  return choice.candidates.front();
}

TEST(EvaluatedBricks, EveryBrickCostsAboutTheWholeGrid) {
  const auto program = blobtree::compile(blobtree::generateTower(2, 6, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 96);
  const vk::EvaluatedBricks all = allBricks(grid, 16);
  const double whole = interpreterFor(program, grid, nullptr).runSeconds;
  const double bricks = interpreterFor(program, grid, &all).runSeconds;
  ASSERT_GT(whole, 0.0);
  // Bricks share their face points ((17/16)^3 = 1.2 more points) and their blocks reach one brick
  // further (a little less pruning): more, never less, and not by much.
  EXPECT_GE(bricks, whole);
  EXPECT_LT(bricks, 1.6 * whole);
}

TEST(EvaluatedBricks, TheFieldCostFollowsTheBricksGiven) {
  const auto program = blobtree::compile(blobtree::generateTower(2, 6, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 96);
  vk::EvaluatedBricks one, two, none;
  one.bricks = {{2, 2, 2}};
  two.bricks = {{2, 2, 2}, {2, 2, 2}};  // the same brick twice: twice the points, same pruning
  const double a = interpreterFor(program, grid, &one).runSeconds;
  const double b = interpreterFor(program, grid, &two).runSeconds;
  EXPECT_GT(a, 0.0);
  EXPECT_DOUBLE_EQ(b, 2.0 * a);
  EXPECT_EQ(interpreterFor(program, grid, &none).runSeconds, 0.0);
  // A brick beyond the grid evaluates nothing.
  vk::EvaluatedBricks outside;
  outside.bricks = {{1000, 0, 0}};
  EXPECT_EQ(interpreterFor(program, grid, &outside).runSeconds, 0.0);
  // Every subset of the bricks costs no more than the set.
  const vk::EvaluatedBricks all = allBricks(grid, 16);
  vk::EvaluatedBricks half = all;
  half.bricks.resize(all.bricks.size() / 2);
  EXPECT_LT(interpreterFor(program, grid, &half).runSeconds, interpreterFor(program, grid, &all).runSeconds);
}

// A specialised kernel pays back its build over the whole grid's points; over a few active
// bricks it does not, and the interpreter is the earlier finish.
TEST(EvaluatedBricks, FewActiveBricksTakeTheInterpreter) {
  // Long enough that its unrolled kernel takes seconds to build (808 instructions).
  const auto program = blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 2));
  ASSERT_GT(program.code.size(), 600u);
  const auto grid = gridAt(program, 256);
  vk::EvaluatorJob job;  // the field alone
  job.tiling.maxTiles = 1;
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  ASSERT_EQ(vk::chooseEvaluator(true, program, grid, job, unrolled).chosen.traversal, vk::Traversal::Specialised);
  vk::EvaluatedBricks few;
  few.bricks = {{4, 4, 4}, {5, 4, 4}};
  job.evaluated = &few;
  EXPECT_EQ(vk::chooseEvaluator(true, program, grid, job, unrolled).chosen.traversal, vk::Traversal::Stackless);
}

// The sparse path reports the evaluator it ran and, on lavapipe, the model's estimate for it,
// made with the bricks its own classification kept (classifyBricks is the oracle).
TEST_F(VulkanTest, TheSparsePathChoosesWithItsActiveBricks) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 64);
  vk::GpuPolygonizeOptions options;
  options.traversal = vk::Traversal::Auto;
  vk::GpuStats stats;
  const auto mesh = vk::polygonize(device(), program, grid, options, &stats);
  ASSERT_FALSE(mesh.triangles.empty());
  ASSERT_NE(stats.traversal, vk::Traversal::Auto);

  const auto flags = vk::classifyBricks(device(), program, grid, options.brickCells);
  const vk::BrickGrid bg = vk::brickGridFor(grid, options.brickCells);
  vk::EvaluatedBricks active;
  active.cells = options.brickCells;
  for (std::uint32_t i = 0; i < flags.size(); ++i)
    if (flags[i]) active.bricks.push_back({i % bg.x, i / bg.x % bg.y, i / (bg.x * bg.y)});
  ASSERT_EQ(active.bricks.size(), stats.activeBricks);
  ASSERT_LT(active.bricks.size(), flags.size());

  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.refineSteps = options.refineSteps;
  job.tiling.maxTiles = 1;
  job.evaluated = lavapipe ? &active : nullptr;
  const auto expected = vk::chooseEvaluator(device(), program, grid, job, vk::defaultCodegenOptions(device())).chosen;
  EXPECT_EQ(stats.traversal, expected.traversal);
  if (lavapipe) {
    EXPECT_DOUBLE_EQ(stats.modelRunSeconds, expected.runSeconds);
    EXPECT_GT(stats.modelRunSeconds, 0.0);
  }

  // A forced evaluator is reported as such, with the model's estimate for it on lavapipe.
  options.traversal = vk::Traversal::Stackless;
  vk::polygonize(device(), program, grid, options, &stats);
  EXPECT_EQ(stats.traversal, vk::Traversal::Stackless);
  if (lavapipe) {
    EXPECT_GT(stats.modelRunSeconds, 0.0);
  }
}

// The decisions whole meshes at 64 cells measured on a quiet lavapipe machine (fresh process each,
// `--traversal auto` against `stackless`, docs/performance.md): a four-instruction shell on 8-22
// active bricks evaluates in about 10 ms interpreted, less than its specialised kernels take to
// build, so it keeps the interpreter; dice and random128, whose overlapping primitives the
// interpreter evaluates slowly (0.9 s and 4.5 s), take the specialised code.
TEST_F(VulkanTest, MeshesAt64CellsChooseWhatMeasuredFaster) {
  if (device().info().type != VK_PHYSICAL_DEVICE_TYPE_CPU) GTEST_SKIP() << "the model's constants are lavapipe's";
  const std::pair<const char*, vk::Traversal> cases[] = {{"eggshell", vk::Traversal::Stackless},
                                                         {"soft_peanut", vk::Traversal::Stackless},
                                                         {"dice", vk::Traversal::Specialised},
                                                         {"random128", vk::Traversal::Specialised}};
  for (const auto& [name, expected] : cases) {
    const ShippedScene s = shipped(name, 64);
    const std::uint32_t cells = vk::GpuPolygonizeOptions{}.brickCells;
    const auto flags = vk::classifyBricks(device(), s.program, s.grid, cells);
    const vk::BrickGrid bg = vk::brickGridFor(s.grid, cells);
    vk::EvaluatedBricks active;
    active.cells = cells;
    for (std::uint32_t i = 0; i < flags.size(); ++i)
      if (flags[i]) active.bricks.push_back({i % bg.x, i / bg.x % bg.y, i / (bg.x * bg.y)});
    vk::EvaluatorJob job;
    job.vertexPass = true;
    job.tiling.maxTiles = 1;
    job.evaluated = &active;
    const auto choice = vk::chooseEvaluator(true, s.program, s.grid, job, vk::defaultCodegenOptions(true));
    EXPECT_EQ(choice.chosen.traversal, expected) << name << ", " << active.bricks.size() << " active bricks";
  }
}

}  // namespace
}  // namespace blobvk::testing
