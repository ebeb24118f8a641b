#include "blobtree/evaluate.h"
#include "blobtree/grid.h"
#include "blobtree/program.h"
#include "models.h"
#include "vk/field.h"
#include "vk/stack_program.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cmath>

namespace blobvk::testing {
namespace {

blobtree::GridSpec gridFor(const blobtree::Program& program, int resolution) {
  blobtree::GridRequest request;
  request.resolution = resolution;
  return blobtree::chooseGrid(program, testBounds(), request);
}

float maxDiff(const std::vector<float>& a, const std::vector<float>& b) {
  float m = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

std::vector<float> cpuField(const blobtree::Program& program, const blobtree::GridSpec& grid) {
  std::vector<float> f(grid.pointCount());
  const auto pts = grid.points();
  for (int k = 0; k < pts.z; ++k)
    for (int j = 0; j < pts.y; ++j)
      for (int i = 0; i < pts.x; ++i)
        f[grid.pointIndex(i, j, k)] = blobtree::evaluate(program, grid.point(i, j, k));
  return f;
}

class FieldTest : public VulkanTest, public ::testing::WithParamInterface<std::size_t> {};

TEST_P(FieldTest, MatchesScalarReferenceBothTraversals) {
  const auto model = testModels()[GetParam()];
  const auto program = blobtree::compile(model.root);
  const auto grid = gridFor(program, 24);
  const auto cpu = cpuField(program, grid);
  vk::FieldStats stats;
  const auto gpu = vk::evaluateFieldOnGrid(device(), program, grid, {}, &stats);
  ASSERT_EQ(gpu.size(), cpu.size());
  EXPECT_LT(maxDiff(gpu, cpu), 1e-5f) << model.name;
  EXPECT_EQ(stats.evaluations, cpu.size());

  vk::FieldOptions stack;
  stack.traversal = vk::Traversal::StackBased;
  const auto gpuStack = vk::evaluateFieldOnGrid(device(), program, grid, stack);
  EXPECT_LT(maxDiff(gpuStack, cpu), 1e-5f) << model.name;
  EXPECT_LT(maxDiff(gpuStack, gpu), 1e-6f) << model.name;
}

TEST_P(FieldTest, BrickedEqualsSingleBrick) {
  const auto model = testModels()[GetParam()];
  const auto program = blobtree::compile(model.root);
  const auto grid = gridFor(program, 20);
  const auto whole = vk::evaluateFieldOnGrid(device(), program, grid);
  vk::FieldOptions bricked;
  const auto pts = grid.points();
  bricked.maxBrickBytes = std::uint64_t(pts.x) * pts.y * 4 * 3;  // 3 layers per brick
  vk::FieldStats stats;
  const auto pieces = vk::evaluateFieldOnGrid(device(), program, grid, bricked, &stats);
  EXPECT_GE(stats.bricks, 7u);
  EXPECT_EQ(pieces, whole);
}

TEST_P(FieldTest, WithoutBoxSkipsGivesTheSameField) {
  const auto model = testModels()[GetParam()];
  blobtree::CompileOptions noSkips;
  noSkips.boxSkips = false;
  const auto program = blobtree::compile(model.root);
  const auto plain = blobtree::compile(model.root, noSkips);
  const auto grid = gridFor(program, 16);
  EXPECT_LT(maxDiff(vk::evaluateFieldOnGrid(device(), program, grid),
                    vk::evaluateFieldOnGrid(device(), plain, grid)),
            1e-6f);
}

INSTANTIATE_TEST_SUITE_P(Models, FieldTest, ::testing::Range<std::size_t>(0, testModels().size()),
                         [](const auto& info) { return testModels()[info.param].name; });

TEST(StackProgram, TreeEncodingHasOneNodePairPerNode) {
  const auto program = blobtree::compile(testModels()[2].root);
  const auto tree = vk::buildStackProgram(program);
  ASSERT_FALSE(tree.empty());
  EXPECT_EQ(tree.size() % 2, 0u);
  // Every leaf refers to a primitive; every primitive appears at least once.
  std::vector<int> seen(program.primitives.size(), 0);
  for (std::size_t n = 0; n < tree.size(); n += 2) {
    if ((tree[n].code.x & 0xffu) == vk::TREE_LEAF) ++seen.at(tree[n].code.y);
  }
  for (int s : seen) EXPECT_GE(s, 1);
}

}  // namespace
}  // namespace blobvk::testing
