// The brick classification's generated kernel (vk/eval/interval_codegen.h,
// vk/extract/classify_kernel.h) against the interpreter it replaces: the same flags brick for
// brick on every shipped scene and legacy .blob file (the interpreter's flags are themselves
// checked against the scalar reference's samples in test_sparse.cpp), and meshes the CPU
// reference's index by index; programs it cannot mirror exactly are refused.
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/interval_codegen.h"
#include "blobvk/vk/extract/polygonize.h"
#include "blobvk/vk/extract/sparse_polygonizer.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// Bricks of 4 cells on 64 cells: 4,096 bricks, so the coarser levels run too (kParentPassBricks).
void expectSameFlags(vk::Device& device, const blobtree::Program& program, const blobtree::GridSpec& grid,
                     const std::string& what) {
  ASSERT_TRUE(vk::canGenerateIntervalBounds(program)) << what;
  for (std::uint32_t brickCells : {4u, 16u}) {
    const auto interpreted = vk::classifyBricks(device, program, grid, brickCells, true, vk::ClassifyCode::Interpreter);
    const auto generated = vk::classifyBricks(device, program, grid, brickCells, true, vk::ClassifyCode::Generated);
    std::size_t active = 0, differ = 0;
    for (std::size_t i = 0; i < interpreted.size(); ++i) {
      active += interpreted[i];
      differ += interpreted[i] != generated[i];
    }
    EXPECT_EQ(differ, 0u) << what << " B=" << brickCells;
    EXPECT_EQ(generated.size(), interpreted.size()) << what;
    EXPECT_GT(active, 0u) << what << " B=" << brickCells;
  }
}

class GeneratedClassification : public VulkanTest, public ::testing::WithParamInterface<std::string> {};

TEST_P(GeneratedClassification, GivesTheInterpretersFlags) {
  const ShippedScene s = shipped(GetParam(), 64);
  if (s.program.code.size() > vk::kMaxIntervalInstructions) {  // tower_L6P8I4: refused, interpreted
    EXPECT_FALSE(vk::canGenerateIntervalBounds(s.program)) << GetParam();
    EXPECT_EQ(vk::classifyBricks(device(), s.program, s.grid, 16, true, vk::ClassifyCode::Generated),
              vk::classifyBricks(device(), s.program, s.grid, 16, true, vk::ClassifyCode::Interpreter));
    return;
  }
  expectSameFlags(device(), s.program, s.grid, GetParam());
}

INSTANTIATE_TEST_SUITE_P(Shipped, GeneratedClassification, ::testing::ValuesIn(shippedSceneNames()),
                         [](const auto& info) { return info.param; });

TEST_F(VulkanTest, GeneratedClassificationOfLegacyBlobFiles) {
  for (const char* name : {"peanut", "tower_fragment"}) {
    const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/legacy/" + name + ".blob");
    const blobtree::Program program = blobtree::compile(scene.root);
    expectSameFlags(device(), program, gridAt(program, 64), name);
  }
}

// The whole sparse path with the generated classification: the CPU reference's mesh, and the
// interpreted classification's bytes.
TEST_F(VulkanTest, GeneratedClassificationGivesTheReferenceMesh) {
  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  for (const char* name : {"tower", "random128", "twisted_column", "creature"}) {
    const ShippedScene s = shipped(name, 48);
    const mesh::TriMesh ref = cpu::polygonizeReference(s.program, s.grid);
    vk::GpuPolygonizeOptions options;
    options.brickCells = 4;
    options.classifyCode = vk::ClassifyCode::Generated;
    vk::GpuStats stats;
    const mesh::TriMesh generated = vk::polygonize(device(), s.program, s.grid, options, &stats);
    EXPECT_TRUE(stats.generatedClassification) << name;
    expectSameMeshAsReference(generated, ref, referenceToleranceCells(lavapipe) * s.grid.cellSize, name);
    options.classifyCode = vk::ClassifyCode::Interpreter;
    const mesh::TriMesh interpreted = vk::polygonize(device(), s.program, s.grid, options, &stats);
    EXPECT_FALSE(stats.generatedClassification) << name;
    expectSameBytes(generated, interpreted, name);
  }
}

// Auto: a job expecting more runs interprets and builds the generated kernel in the background;
// a later job of the same program takes it.
TEST_F(VulkanTest, LaterJobsTakeTheClassificationBuiltInTheBackground) {
  ShippedScene s = shipped("twisted_column", 64);  // a short program: a quick build
  // max(r0, r0) at the end: the same field, a program no other test has built a kernel for.
  s.program.code.push_back({{layout::OP_MAX, 0, 0, 0}});
  vk::GpuPolygonizeOptions options;
  options.expectedRuns = 1000000;  // enough runs for the build to pay (classifyCodePays)
  ASSERT_TRUE(vk::classifyCodePays(s.program, s.grid, options.brickCells, options.expectedRuns - 1));
  EXPECT_FALSE(vk::classifyCodePays(s.program, s.grid, options.brickCells, 1));
  vk::GpuStats first, second;
  const mesh::TriMesh a = vk::polygonize(device(), s.program, s.grid, options, &first);
  EXPECT_FALSE(first.generatedClassification);
  device().waitForBackgroundBuilds();
  const mesh::TriMesh b = vk::polygonize(device(), s.program, s.grid, options, &second);
  EXPECT_TRUE(second.generatedClassification);
  expectSameBytes(a, b, "twisted_column, the second job");
}

// The cost model keeps the interpreter for a program of many skips (tower, where the generated
// code measured slower), and its walk counts every instruction of a program without skips.
TEST(ClassifyCostModel, KeepsTheInterpreterForManySkips) {
  const ShippedScene tower = shipped("tower", 256);
  EXPECT_FALSE(vk::classifyCodePays(tower.program, tower.grid, 16, 1000000));
  blobtree::Program flat;
  flat.primitives.push_back({{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {layout::PRIM_POINT, 0, 0, 0}});
  for (int i = 0; i < 3; ++i) flat.code.push_back({{layout::OP_PRIM, 0, 0, 0}});
  blobtree::GridSpec grid;
  grid.cells = {64, 32, 16};  // bricks of 16: 4 x 2 x 1, one vector of 8 lanes
  const vk::ClassifyWork w = vk::classifyWork(flat, grid, 16);
  EXPECT_DOUBLE_EQ(w.interpreted, 3.0);
  EXPECT_DOUBLE_EQ(w.generated, 3.0);
}

// Skips nested deeper than the interpreter's pending stack (it gives up there, at run time): the
// generator refuses, and the Generated choice falls back to the interpreter (the same flags).
TEST_F(VulkanTest, GeneratedClassificationRefusesWhatItCannotMirror) {
  using namespace layout;
  blobtree::Program p;
  p.matrices.push_back({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}});
  p.primitives.push_back({{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {PRIM_POINT, 0, 0, 0}});
  p.boxes.push_back({{-2, -2, -2, 0}, {0.1f, 0.1f, 0.1f, 0}});
  const std::uint32_t depth = 17;  // MAX_PENDING + 1
  for (std::uint32_t i = 0; i < depth; ++i) p.code.push_back({{OP_SKIP, 0, 0, depth + 1}});
  p.code.push_back({{OP_PRIM, 0, 0, 0}});
  p.fieldRegisters = 1;
  EXPECT_FALSE(vk::canGenerateIntervalBounds(p));
  EXPECT_THROW(vk::generateIntervalBounds(p), std::invalid_argument);
  blobtree::GridSpec grid;
  grid.cells = {32, 32, 32};
  grid.cellSize = 4.0f / 32.0f;
  grid.origin = {-2.0f, -2.0f, -2.0f};
  const auto interpreted = vk::classifyBricks(device(), p, grid, 4, true, vk::ClassifyCode::Interpreter);
  EXPECT_EQ(vk::classifyBricks(device(), p, grid, 4, true, vk::ClassifyCode::Generated), interpreted);
  // One skip fewer: within the stack, generated, the same flags.
  p.code.erase(p.code.begin());
  for (auto& in : p.code)
    if ((in.code.x & 0xffu) == OP_SKIP) in.code.w = depth;
  EXPECT_TRUE(vk::canGenerateIntervalBounds(p));
  EXPECT_EQ(vk::classifyBricks(device(), p, grid, 4, true, vk::ClassifyCode::Generated),
            vk::classifyBricks(device(), p, grid, 4, true, vk::ClassifyCode::Interpreter));
  // A skip jumping backwards, or past the code: refused.
  p.code.front().code.w = 0;
  EXPECT_FALSE(vk::canGenerateIntervalBounds(p));
  p.code.front().code.w = std::uint32_t(p.code.size() + 1);
  EXPECT_FALSE(vk::canGenerateIntervalBounds(p));
}

}  // namespace
}  // namespace blobvk::testing
