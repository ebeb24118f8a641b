#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "models.h"
#include "reference_checks.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/stack_program.h"
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
  return referenceField(program, grid);
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
  EXPECT_LT(maxDiff(pieces, cpuField(program, grid)), 1e-5f) << model.name;  // the oracle
  EXPECT_EQ(pieces, whole);  // and bricking changes no bit
}

TEST_P(FieldTest, WithoutBoxSkipsGivesTheSameField) {
  const auto model = testModels()[GetParam()];
  blobtree::CompileOptions noSkips;
  noSkips.boxSkips = false;
  const auto program = blobtree::compile(model.root);
  const auto plain = blobtree::compile(model.root, noSkips);
  const auto grid = gridFor(program, 16);
  const auto withSkips = vk::evaluateFieldOnGrid(device(), program, grid);
  const auto withoutSkips = vk::evaluateFieldOnGrid(device(), plain, grid);
  // Each against the CPU reference of its own Program, then against each other.
  EXPECT_LT(maxDiff(withSkips, cpuField(program, grid)), 1e-5f) << model.name;
  EXPECT_LT(maxDiff(withoutSkips, cpuField(plain, grid)), 1e-5f) << model.name;
  EXPECT_LT(maxDiff(withSkips, withoutSkips), 1e-6f) << model.name;
}

// The specialised evaluator (generated GLSL) with both skip styles: real branches (what GPUs
// get) and masked straight-line code (what CPU drivers get) give the interpreter's field.
TEST_P(FieldTest, SpecialisedMatchesStacklessWithAndWithoutBranches) {
  const auto model = testModels()[GetParam()];
  const auto program = blobtree::compile(model.root);
  ASSERT_TRUE(vk::canSpecialise(program));
  const auto grid = gridFor(program, 20);
  const auto cpu = cpuField(program, grid);
  const auto stackless = vk::evaluateFieldOnGrid(device(), program, grid);
  for (bool branch : {true, false}) {
    vk::CodegenOptions codegen;
    codegen.branchOnSkips = branch;
    vk::FieldOptions o;
    o.traversal = vk::Traversal::Specialised;
    o.codegen = &codegen;
    const auto gpu = vk::evaluateFieldOnGrid(device(), program, grid, o);
    EXPECT_LT(maxDiff(gpu, cpu), 1e-5f) << model.name << (branch ? " branches" : " masked");
    EXPECT_LT(maxDiff(gpu, stackless), 1e-6f) << model.name << (branch ? " branches" : " masked");
  }
}

INSTANTIATE_TEST_SUITE_P(Models, FieldTest, ::testing::Range<std::size_t>(0, testModels().size()),
                         [](const auto& info) { return testModels()[info.param].name; });

// A program whose unrolled code is over the generator's limit runs on the stackless interpreter
// instead; with loops (one function for its 2,100 equal points) it fits.
TEST_F(VulkanTest, OversizedProgramFallsBackToTheInterpreter) {
  std::vector<blobtree::Node> blobs;
  for (int i = 0; i < 2100; ++i) blobs.push_back(pointAt({0.001 * i - 1.0, 0.0005 * i, 0.0}));
  const auto program = blobtree::compile(combine(blobtree::OperatorType::Blend, std::move(blobs)));
  ASSERT_GT(program.code.size(), vk::kMaxSpecialisedInstructions);
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  EXPECT_FALSE(vk::canSpecialise(program, {}, unrolled.loops));
  EXPECT_THROW(vk::generateSpecialisedEvaluator(program, unrolled), std::invalid_argument);
  EXPECT_TRUE(vk::canSpecialise(program));
  EXPECT_LT(vk::specialisedCodeSize(program), 64u);
  const auto grid = gridFor(program, 8);
  vk::FieldOptions o;
  o.traversal = vk::Traversal::Specialised;
  const auto fallback = vk::evaluateFieldOnGrid(device(), program, grid, o);
  EXPECT_LT(maxDiff(fallback, cpuField(program, grid)), 1e-5f);
  EXPECT_EQ(fallback, vk::evaluateFieldOnGrid(device(), program, grid));  // it is the interpreter
}

TEST(ProgramCodegen, GeneratesOneStatementPerInstructionWithLiterals) {
  const auto program = blobtree::compile(combine(blobtree::OperatorType::Blend, {pointAt({0.25, 0, 0}), pointAt({-0.5, 0, 0})}));
  const std::string glsl = vk::generateSpecialisedEvaluator(program);
  EXPECT_NE(glsl.find("float evaluateField(vec3 p, uint n)"), std::string::npos);
  EXPECT_NE(glsl.find("float evaluateFieldColour(vec3 p, uint n, out vec3 colour)"), std::string::npos);
  EXPECT_NE(glsl.find("vec3(0.25, 0.0, 0.0)"), std::string::npos) << glsl;  // the first centre, exact
  EXPECT_EQ(glsl.find("programCode"), std::string::npos);                  // no Program buffer is read
}

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
