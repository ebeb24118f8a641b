// The specialised evaluator's compact form (vk/eval/program_shape.h, vk/eval/program_codegen_loops.cpp):
// a generated tower of many equal instances becomes a few shared functions called in loops, and
// its field is bit for bit the CPU reference's and the interpreter's, whole and per pruned tile;
// and the cost model (vk/eval/evaluator_choice.h) picks the interpreter for the issue's tower and the
// specialised code where its build pays back.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/program_shape.h"
#include "reference_checks.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

blobtree::GridSpec gridAt(const blobtree::Program& program, int resolution) {
  blobtree::GridRequest request;
  request.resolution = resolution;
  return blobtree::chooseGrid(program, {}, request);
}

bool sameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// 2 x 2 towers of 3 storeys of 8 pillars: 12 equal storeys, 96 equal pillars.
blobtree::Program repeatedTower() { return blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 2)); }

TEST(CodeShapes, RepeatedInstancesShareOneShapeAndLoop) {
  const auto program = repeatedTower();
  const auto shapes = vk::CodeShapes::analyse(program, {});
  ASSERT_NE(shapes, nullptr) << "compile()'s code must parse";
  // Far fewer shapes than expressions: the storeys and pillars repeat.
  EXPECT_LT(shapes->shapeCount() * 10, shapes->exprs().size());
  std::size_t loops = 0;
  for (std::size_t e = 0; e < shapes->exprs().size(); ++e) loops += shapes->loops(std::int32_t(e)).size();
  EXPECT_GT(loops, 0u);
  // The root expression covers the whole program.
  const auto& root = shapes->exprs()[std::size_t(shapes->root())];
  EXPECT_EQ(root.begin, 0u);
  EXPECT_EQ(root.end, program.code.size());

  const std::string glsl = vk::generateSpecialisedEvaluator(program);
  std::uint32_t emitted = 0;
  vk::generateSpecialisedEvaluator(program, {}, &emitted);
  EXPECT_LT(emitted * 8, program.code.size()) << "loops must keep the code a fraction of the program";
  EXPECT_GT(count(glsl, "for (uint i"), 0u);
  EXPECT_NE(glsl.find("uvec4 D[]"), std::string::npos);
  // The unrolled form spells out every primitive.
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  std::size_t cylinders = 0;
  for (const auto& prim : program.primitives) cylinders += prim.meta.x == layout::PRIM_CYLINDER;
  EXPECT_EQ(cylinders, 96u);
  EXPECT_EQ(count(vk::generateSpecialisedEvaluator(program, unrolled), "wyvill(ddCylinder"), 2 * cylinders);
}

TEST(CodeShapes, CodeNotInCompileFormIsUnrolled) {
  auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  program.code.push_back(program.code.back());  // a combine with nothing to combine
  EXPECT_EQ(vk::CodeShapes::analyse(program, {}), nullptr);
}

class LoopedFieldTest : public VulkanTest {};

// The looped specialised field, with and without branches on skips, whole and in pruned tiles,
// against the CPU reference and the interpreter: every float identical.
TEST_F(LoopedFieldTest, RepeatedTowerFieldEqualsReferenceBitForBit) {
  const auto program = repeatedTower();
  const auto grid = gridAt(program, 28);
  const auto reference = referenceField(program, grid);
  vk::FieldOptions interpreter;
  interpreter.traversal = vk::Traversal::Stackless;
  const auto interpreted = vk::evaluateFieldOnGrid(device(), program, grid, interpreter);
  EXPECT_TRUE(sameBits(interpreted, reference)) << "the interpreter differs from the reference";
  for (bool branches : {false, true}) {
    for (std::uint32_t tiles : {1u, 8u}) {
      vk::CodegenOptions codegen;
      codegen.branchOnSkips = branches;
      codegen.loops.enabled = true;
      vk::FieldOptions o;
      o.traversal = vk::Traversal::Specialised;
      o.codegen = &codegen;
      o.tiling.maxTiles = tiles;
      o.tiling.minGain = 0.0;
      o.tiling.minPointsForLargePrograms = 0;
      vk::FieldStats stats;
      const auto field = vk::evaluateFieldOnGrid(device(), program, grid, o, &stats);
      const std::string what = std::string(branches ? "branches" : "masked") + ", " + std::to_string(stats.tiles) + " tiles";
      EXPECT_TRUE(sameBits(field, reference)) << what;
      EXPECT_TRUE(sameBits(field, interpreted)) << what;
      if (tiles > 1) {
        EXPECT_GT(stats.tiles, 1u);
      }
    }
  }
}

TEST(EvaluatorChoice, IssueTowerMeshTakesTheInterpreterOnLavapipe) {
  const auto program = blobtree::compile(blobtree::generateTower(5, 8, 6.0, 6.0, 3));
  ASSERT_EQ(program.code.size(), 3024u);
  vk::EvaluatorJob job;
  job.vertexPass = true;
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  const auto choice = vk::chooseEvaluator(true, program, gridAt(program, 64), job, unrolled);
  EXPECT_EQ(choice.chosen.traversal, vk::Traversal::Stackless);
  EXPECT_GE(choice.candidates.size(), 2u);
  for (const auto& c : choice.candidates) EXPECT_LE(choice.chosen.total(1), c.total(1));
  // A GPU keeps the specialised code.
  EXPECT_EQ(vk::chooseEvaluator(false, program, gridAt(program, 64), job, unrolled).chosen.traversal,
            vk::Traversal::Specialised);
}

TEST(EvaluatorChoice, SpecialisedCodePaysBackOverManyRepeats) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  vk::EvaluatorJob once;
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  const auto grid = gridAt(program, 128);
  const auto a = vk::chooseEvaluator(true, program, grid, once, unrolled);
  vk::EvaluatorJob many = once;
  many.repeats = 1000;
  const auto b = vk::chooseEvaluator(true, program, grid, many, unrolled);
  EXPECT_EQ(b.chosen.traversal, vk::Traversal::Specialised);
  // More repeats never make the build-heavy choice less attractive.
  EXPECT_LE(b.chosen.runSeconds, a.chosen.runSeconds);
}

// Auto (the default) resolves to one of the evaluators, so its field is theirs bit for bit.
TEST_F(VulkanTest, AutoFieldEqualsTheInterpreter) {
  const auto program = repeatedTower();
  const auto grid = gridAt(program, 20);
  vk::FieldOptions interpreter;
  interpreter.traversal = vk::Traversal::Stackless;
  EXPECT_TRUE(sameBits(vk::evaluateFieldOnGrid(device(), program, grid),
                       vk::evaluateFieldOnGrid(device(), program, grid, interpreter)));
}

}  // namespace
}  // namespace blobvk::testing
