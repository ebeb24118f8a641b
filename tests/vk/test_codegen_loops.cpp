// The specialised evaluator's compact form (vk/eval/program_shape.h, vk/eval/program_codegen_loops.cpp):
// a generated tower of many equal instances becomes a few shared functions called in loops, and
// its field is bit for bit the CPU reference's and the interpreter's, whole and per pruned tile;
// and the cost model (vk/eval/evaluator_choice.h) picks the interpreter for the issue's tower and the
// specialised code where its build pays back.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/grid.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/field.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/program_shape.h"
#include "blobvk/vk/extract/polygonize.h"
#include "reference_checks.h"
#include "shipped_scenes.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

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
  // Bit-identity with the CPU reference is lavapipe's (docs/vulkan.md: other drivers' sin/cos/pow
  // differ in the last bits); against the interpreter it holds on every device.
  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  if (lavapipe) {
    EXPECT_TRUE(sameBits(interpreted, reference)) << "the interpreter differs from the reference";
  }
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
      if (lavapipe) {
        EXPECT_TRUE(sameBits(field, reference)) << what;
      }
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

// On lavapipe (defaultCodegenOptions for a CPU driver) short programs stay unrolled and long ones
// take the looped form, whose skips branch even though the CPU default masks them: masked, every
// lane would run every instance of every loop.
TEST(EvaluatorChoice, CpuDriversLoopOnlyLongPrograms) {
  const vk::CodegenOptions cpu = vk::defaultCodegenOptions(true);
  EXPECT_FALSE(cpu.branchOnSkips);
  const auto small = blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 1));  // 201 instructions
  ASSERT_LE(small.code.size(), cpu.loops.minProgramInstructions);
  EXPECT_FALSE(vk::specialisedCodeLoops(small, {}, cpu.loops));
  EXPECT_EQ(vk::specialisedCodeSize(small, {}, cpu.loops), small.code.size());
  EXPECT_TRUE(vk::specialisedData(small, cpu.loops).empty());
  EXPECT_EQ(count(vk::generateSpecialisedEvaluator(small, cpu), "subgroupAll"), 0u);

  const auto issue = blobtree::compile(blobtree::generateTower(5, 8, 6.0, 6.0, 3));  // 3,024
  ASSERT_GT(issue.code.size(), cpu.loops.minProgramInstructions);
  EXPECT_TRUE(vk::specialisedCodeLoops(issue, {}, cpu.loops));
  EXPECT_LT(vk::specialisedCodeSize(issue, {}, cpu.loops) * 100, issue.code.size());
  EXPECT_FALSE(vk::specialisedData(issue, cpu.loops).empty());
  const std::string glsl = vk::generateSpecialisedEvaluator(issue, cpu);
  EXPECT_GT(count(glsl, "for (uint i"), 0u);
  EXPECT_GT(count(glsl, "subgroupAll"), 0u) << "looped code must branch on its skips";
  // A region that prunes the program short unrolls it there.
  vk::PointRegion corner;
  corner.valid = true;
  for (int a = 0; a < 3; ++a) corner.lo[a] = -1e6f, corner.hi[a] = -1e6f + 1.0f;
  EXPECT_FALSE(vk::specialisedCodeLoops(issue, corner, cpu.loops));
  // GPUs loop whatever the length.
  EXPECT_TRUE(vk::specialisedCodeLoops(small, {}, vk::defaultCodegenOptions(false).loops));
}

// The decision for the issue's tower meshed at 64 cells on lavapipe: its unrolled code cannot pay
// back within the job (the interpreter wins, EvaluatorChoice.IssueTowerMeshTakesTheInterpreterOnLavapipe);
// the default looped code builds about as fast as the interpreter and runs faster, so it is taken.
// The same up to 56,784 instructions, with a build of a few megabytes, never over the memory bound.
TEST(EvaluatorChoice, LavapipeTakesLoopedCodeForLongInstancedPrograms) {
  const vk::CodegenOptions cpu = vk::defaultCodegenOptions(true);
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.tiling.maxTiles = 1;  // as the sparse extraction asks
  for (int grid : {3, 13}) {
    const auto program = blobtree::compile(blobtree::generateTower(5, 8, 6.0, 6.0, grid));
    const auto choice = vk::chooseEvaluator(true, program, gridAt(program, 64), job, cpu);
    const std::string what = std::to_string(program.code.size()) + " instructions";
    ASSERT_EQ(choice.candidates.size(), 2u) << what;
    const auto& interpreter = choice.candidates[0];
    const auto& looped = choice.candidates[1];
    EXPECT_EQ(interpreter.traversal, vk::Traversal::Stackless) << what;
    EXPECT_EQ(looped.traversal, vk::Traversal::Specialised) << what;
    EXPECT_EQ(choice.chosen.traversal, vk::Traversal::Specialised) << what;
    // Its build is the interpreter's plus a fraction of a second, not the unrolled code's minutes.
    EXPECT_LT(looped.buildSeconds, interpreter.buildSeconds + 0.25) << what;
    EXPECT_TRUE(looped.looped) << what;
    EXPECT_LT(looped.runSeconds, interpreter.runSeconds) << what;
    EXPECT_LT(looped.buildMegabytes, 20.0) << what;
  }
  // A short program keeps its unrolled code where the build pays back: a small tower at 64 cells.
  const auto small = blobtree::compile(blobtree::generateTower(1, 8, 6.0, 6.0, 1));
  const auto choice = vk::chooseEvaluator(true, small, gridAt(small, 64), job, cpu);
  EXPECT_EQ(choice.chosen.traversal, vk::Traversal::Specialised);
  EXPECT_FALSE(vk::specialisedCodeLoops(small, {}, cpu.loops));
}

// Kernels already built cost nothing: with every kernel built, the model weighs run time alone,
// and the specialised code runs faster than the interpreter.
TEST(EvaluatorChoice, BuiltKernelsAreASunkCost) {
  const auto program = blobtree::compile(blobtree::generateTower(5, 8, 6.0, 6.0, 3));
  vk::EvaluatorJob job;
  job.vertexPass = true;
  vk::CodegenOptions unrolled;
  unrolled.loops.enabled = false;
  const auto grid = gridAt(program, 64);
  const auto cold = vk::chooseEvaluator(true, program, grid, job, unrolled);
  const auto warm = vk::chooseEvaluator(true, program, grid, job, unrolled,
                                        [](const std::string&, const vk::CodegenOptions*) { return true; });
  ASSERT_EQ(cold.candidates.size(), warm.candidates.size());
  for (std::size_t i = 0; i < warm.candidates.size(); ++i) {
    EXPECT_EQ(warm.candidates[i].buildSeconds, 0.0);
    EXPECT_GT(cold.candidates[i].buildSeconds, 0.0);
    // With nothing to build, a candidate may take the vertex kernel with the generated gradient,
    // which the cold job's memory bound rules out: never slower.
    EXPECT_LE(warm.candidates[i].runSeconds, cold.candidates[i].runSeconds);
  }
  EXPECT_EQ(warm.chosen.traversal, vk::Traversal::Specialised);
  // Only the interpreter's field kernel built: the interpreter's field costs nothing to build,
  // its vertex kernel still does.
  const auto fieldOnly = vk::chooseEvaluator(true, program, grid, job, unrolled,
                                             [](const std::string& shader, const vk::CodegenOptions* c) {
                                               return shader == "field_grid" && c == nullptr;
                                             });
  EXPECT_GT(fieldOnly.candidates[0].buildSeconds, 0.0);
  EXPECT_LT(fieldOnly.candidates[0].buildSeconds, cold.candidates[0].buildSeconds);
}

// Looped code generates no gradient, so the choice leaves the option as the caller set it: the
// kernels an Auto job builds have the names a Specialised job with the default options builds
// (on GPU drivers, where all code is looped, a job's kernels were otherwise never found again).
TEST(EvaluatorChoice, LoopedCodeKeepsTheCallersGradientOption) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.tiling.maxTiles = 1;
  const vk::CodegenOptions gpu = vk::defaultCodegenOptions(false);
  ASSERT_TRUE(vk::specialisedCodeLoops(program, {}, gpu.loops));
  for (bool gradient : {true, false}) {
    vk::CodegenOptions c = gpu;
    c.gradient = gradient;
    const auto choice = vk::chooseEvaluator(false, program, gridAt(program, 12), job, c);
    ASSERT_EQ(choice.chosen.traversal, vk::Traversal::Specialised);
    EXPECT_EQ(choice.chosen.vertexGradient, gradient);
    // Kernels a job with these options built (their names carry the option) are found: the
    // specialised candidate builds nothing.
    const auto built = vk::chooseEvaluator(false, program, gridAt(program, 12), job, c,
                                           [&](const std::string&, const vk::CodegenOptions* k) {
                                             return k != nullptr && k->gradient == gradient;
                                           });
    ASSERT_GE(built.candidates.size(), 2u);
    EXPECT_EQ(built.candidates[1].buildSeconds, 0.0) << "gradient option " << gradient;
  }
}

// On a device, the kernels a job built are found: the same job again weighs no build.
TEST_F(VulkanTest, TheDeviceReportsTheKernelsAJobBuilt) {
  const auto program = blobtree::compile(blobtree::generateTower(1, 4, 6.0, 6.0, 1));
  const auto grid = gridAt(program, 12);
  vk::GpuPolygonizeOptions options;
  options.traversal = vk::Traversal::Specialised;
  options.maxFieldTiles = 1;
  // The cost model weighs the dense pipeline's kernels (field_grid, vertices); the sparse
  // extraction builds brick kernels of its own, which it does not look up yet.
  options.sparse = false;
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.tiling.maxTiles = 1;
  const vk::CodegenOptions codegen = vk::defaultCodegenOptions(device());
  const auto before = vk::chooseEvaluator(device(), program, grid, job, codegen);
  vk::polygonize(device(), program, grid, options);
  const auto after = vk::chooseEvaluator(device(), program, grid, job, codegen);
  ASSERT_EQ(before.candidates.size(), after.candidates.size());
  ASSERT_GE(after.candidates.size(), 2u);
  EXPECT_EQ(after.candidates[1].traversal, vk::Traversal::Specialised);
  EXPECT_GT(before.candidates[1].buildSeconds, 0.0);
  EXPECT_EQ(after.candidates[1].buildSeconds, 0.0);
  options.traversal = vk::Traversal::Stackless;
  vk::polygonize(device(), program, grid, options);
  EXPECT_EQ(vk::chooseEvaluator(device(), program, grid, job, codegen).candidates[0].buildSeconds, 0.0);
}

// A generated instanced scene (the issue's tower, 3,024 instructions): on its default path the
// device runs the looped code, and the mesh is the interpreter's byte for byte (positions,
// normals, colours, triangles, keys), with and without refinement, sparse and dense; its edges
// and triangles are the CPU reference mesh's.
TEST_F(VulkanTest, InstancedTowerDefaultMeshEqualsTheInterpreterByteForByte) {
  const auto program = blobtree::compile(blobtree::generateTower(5, 8, 6.0, 6.0, 3));
  const auto grid = gridAt(program, 20);
  const vk::CodegenOptions codegen = vk::defaultCodegenOptions(device());
  ASSERT_TRUE(vk::specialisedCodeLoops(program, {}, codegen.loops));
  const mesh::TriMesh cpu = cpu::polygonizeReference(program, grid);
  ASSERT_GT(cpu.triangleCount(), 0u);
  for (bool sparse : {true, false}) {
    for (int refineSteps : {0, 2}) {
      vk::GpuPolygonizeOptions options;
      options.sparse = sparse;
      options.refineSteps = refineSteps;
      options.traversal = vk::Traversal::Stackless;
      const mesh::TriMesh interpreted = vk::polygonize(device(), program, grid, options);
      options.traversal = vk::Traversal::Auto;
      const mesh::TriMesh byDefault = vk::polygonize(device(), program, grid, options);
      options.traversal = vk::Traversal::Specialised;
      const mesh::TriMesh looped = vk::polygonize(device(), program, grid, options);
      const std::string what = std::string(sparse ? "sparse" : "dense") + ", " + std::to_string(refineSteps) + " steps";
      for (const mesh::TriMesh* m : {&byDefault, &looped}) {
        EXPECT_EQ(m->edgeKeys, interpreted.edgeKeys) << what;
        EXPECT_EQ(m->triangles, interpreted.triangles) << what;
        EXPECT_TRUE(m->positions == interpreted.positions) << what << ": positions";
        EXPECT_TRUE(m->normals == interpreted.normals) << what << ": normals";
        EXPECT_TRUE(m->colours == interpreted.colours) << what << ": colours";
      }
      if (refineSteps == 0) {
        EXPECT_EQ(interpreted.edgeKeys, cpu.edgeKeys) << what;
        EXPECT_EQ(interpreted.triangles, cpu.triangles) << what;
      }
    }
  }
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
