// The specialised gradient (vk/eval/gradient_codegen.h): vertex kernels built around unrolled
// specialised code carry their own generated gradient instead of the interpreter, and their
// normals and colours are the interpreter's byte for byte and the CPU reference's
// (blobtree::evaluateGradientColour through cpu::polygonizeReference).
#include "blobvk/blobtree/generators.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/blobtree/scene_io.h"
#include "blobvk/cpu_simd/reference_polygonizer.h"
#include "blobvk/vk/device/shader_registry.h"
#include "blobvk/vk/eval/evaluator_choice.h"
#include "blobvk/vk/eval/evaluator_costs.h"
#include "blobvk/vk/eval/gpu_program.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/runtime_compiler.h"
#include "blobvk/vk/extract/polygonize.h"
#include "models.h"
#include "reference_checks.h"
#include "vk_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

// Whether the SPIR-V declares a variable at the binding of the Program's box records
// (PROGRAM_BINDING + 3 = 3 in the vertex kernels): the gradient interpreter reads them, the
// generated gradient spells its boxes out (the field code never binds them).
bool bindsBoxRecords(std::span<const std::uint32_t> words) {
  constexpr std::uint32_t kOpDecorate = 71, kDecorationBinding = 33;
  for (std::size_t i = 5; i < words.size();) {
    const std::uint32_t count = words[i] >> 16, op = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) break;
    if (op == kOpDecorate && count >= 4 && words[i + 2] == kDecorationBinding && words[i + 3] == 3) return true;
    i += count;
  }
  return false;
}

TEST(SpecialisedGradient, VertexKernelsOfSpecialisedCodeInterpretNothing) {
  // The check can fail: the embedded kernels interpret, and bind the boxes.
  EXPECT_TRUE(bindsBoxRecords(vk::shaderCode("brick_vertices")));
  EXPECT_TRUE(bindsBoxRecords(vk::shaderCode("brick_vertices_direct")));
  EXPECT_TRUE(bindsBoxRecords(vk::shaderCode("vertices")));
  for (const auto& model : testModels()) {
    const auto program = blobtree::compile(model.root);
    // Unrolled, as lavapipe runs programs of up to 400 instructions.
    const std::string glsl = vk::generateSpecialisedEvaluator(program, vk::defaultCodegenOptions(true));
    EXPECT_NE(glsl.find("BLOBVK_GENERATED_GRADIENT"), std::string::npos) << model.name;
    for (const char* shader : {"vertices.comp", "brick_vertices.comp", "brick_vertices_direct.comp"}) {
      const auto code = vk::compileComputeShader(shader, {{"eval_program.glsl", glsl}});
      EXPECT_FALSE(bindsBoxRecords(code)) << model.name << " " << shader;
    }
  }
}

// The functions the SPIR-V names (OpName), e.g. "evaluateField(vf3;u1;".
std::vector<std::string> functionNames(std::span<const std::uint32_t> words) {
  constexpr std::uint32_t kOpName = 5;
  std::vector<std::string> names;
  for (std::size_t i = 5; i < words.size();) {
    const std::uint32_t count = words[i] >> 16, op = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) break;
    if (op == kOpName && count > 2) {
      const char* text = reinterpret_cast<const char*>(&words[i + 2]);
      const std::string name(text, strnlen(text, (count - 2) * 4));
      if (name.find('(') != std::string::npos) names.push_back(name);
    }
    i += count;
  }
  return names;
}

bool namesFunction(const std::vector<std::string>& names, const std::string& function) {
  return std::any_of(names.begin(), names.end(), [&](const std::string& n) { return n.rfind(function + "(", 0) == 0; });
}

// lavapipe translates every function of a module, called or not (glslang keeps them with its
// optimiser off), so generated kernels hold only what they call: a field kernel the field, the
// direct vertex kernel the gradient, with one formula per primitive type (no type switch).
TEST(SpecialisedGradient, GeneratedKernelsHoldOnlyTheFunctionsTheyCall) {
  for (const auto& model : testModels()) {
    const auto program = blobtree::compile(model.root);
    const std::string glsl = vk::generateSpecialisedEvaluator(program, vk::defaultCodegenOptions(true));
    if (glsl.find("BLOBVK_GENERATED_GRADIENT") == std::string::npos) continue;  // looped code
    for (const char* shader : {"brick_field.comp", "field_grid.comp"}) {
      const auto names = functionNames(vk::compileComputeShader(shader, {{"eval_program.glsl", glsl}}));
      EXPECT_TRUE(namesFunction(names, "evaluateField")) << model.name << " " << shader;
      EXPECT_FALSE(namesFunction(names, "evaluateFieldColour")) << model.name << " " << shader;
      EXPECT_FALSE(namesFunction(names, "evaluateGradient")) << model.name << " " << shader;
    }
    const auto direct = functionNames(vk::compileComputeShader("brick_vertices_direct.comp", {{"eval_program.glsl", glsl}}));
    EXPECT_TRUE(namesFunction(direct, "evaluateGradient")) << model.name;
    EXPECT_FALSE(namesFunction(direct, "evaluateField")) << model.name;
    EXPECT_FALSE(namesFunction(direct, "evaluateFieldColour")) << model.name;
    EXPECT_FALSE(namesFunction(direct, "primitiveGradientOf")) << model.name;  // the switch over every type
    for (const auto& prim : program.primitives)
      EXPECT_TRUE(namesFunction(direct, "primitiveGradientOfType" + std::to_string(prim.meta.x))) << model.name;
    // The vertex kernel with samples still evaluates the field (the check can fail).
    const auto samples = functionNames(vk::compileComputeShader("brick_vertices.comp", {{"eval_program.glsl", glsl}}));
    EXPECT_TRUE(namesFunction(samples, "evaluateField")) << model.name;
  }
}

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

// Pruned to a region (a tile of the sparse vertex pass), the generated gradient drops each
// primitive whose support box misses it, as the field code does: random128 (128 primitives under
// one skip box) in its lower octant keeps some and drops others, and keeps all over its bounds.
// That the pruned code gives the whole program's bytes, signs of zero included, is
// TiledVertexPassGivesTheBytesOfOneKernel's.
TEST(SpecialisedGradient, PrunedToARegionItDropsThePrimitivesThatMissIt) {
  const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/random128.json");
  const blobtree::Program program = blobtree::compile(scene.root);
  const std::size_t primitives = program.primitives.size();
  ASSERT_EQ(primitives, 128u);
  const blobtree::Aabb b = program.bounds;
  auto gradientOf = [&](const vk::PointRegion& region) {
    vk::CodegenOptions codegen = vk::defaultCodegenOptions(true);
    codegen.region = region;
    const std::string glsl = vk::generateSpecialisedEvaluator(program, codegen);
    const std::size_t at = glsl.find("precise float evaluateGradient(");
    EXPECT_NE(at, std::string::npos);
    return at == std::string::npos ? std::string() : glsl.substr(at);
  };
  vk::PointRegion octant;
  octant.valid = true;
  for (int a = 0; a < 3; ++a) octant.lo[a] = b.lo[a], octant.hi[a] = 0.5f * (b.lo[a] + b.hi[a]);
  const std::string pruned = gradientOf(octant);
  // A run of dropped primitives added into one register is written once, as its last primitive
  // and a loop over the colour's blends ("// N pruned primitives added into rA").
  std::size_t dropped = occurrences(pruned, "pruned: the primitive is 0 in the region"), runs = 0, inRuns = 0;
  const std::string runMark = " pruned primitives added into ";
  for (std::size_t at = pruned.find(runMark); at != std::string::npos; at = pruned.find(runMark, at + 1)) {
    const std::size_t start = pruned.rfind("// ", at) + 3;
    inRuns += std::stoul(pruned.substr(start, at - start));
    ++runs;
  }
  dropped += inRuns - runs;
  const std::size_t kept = occurrences(pruned, " = primitiveGradientOfType");
  EXPECT_GT(dropped, primitives / 4);
  EXPECT_GT(runs, 0u) << "random128's dropped points come in runs";
  EXPECT_GT(inRuns, dropped / 2);
  EXPECT_GT(kept, 0u);
  EXPECT_EQ(dropped + kept, primitives);
  vk::PointRegion all;
  all.valid = true;
  for (int a = 0; a < 3; ++a) all.lo[a] = b.lo[a], all.hi[a] = b.hi[a];
  EXPECT_EQ(occurrences(gradientOf(all), "pruned: the primitive"), 0u);
}

// The cost model weighs the generated gradient's larger vertex kernel: the shipped tower at 256
// cells on lavapipe, meshed 4 times (a benchmark), takes it (its interpreted gradient was most of
// the mesh's time); a program whose unrolled vertex kernel would break the build's memory bound
// interprets the gradient.
TEST(SpecialisedGradient, TheCostModelTakesItWhereItsBuildFits) {
  vk::EvaluatorJob job;
  job.vertexPass = true;
  job.repeats = 4;
  const auto tower =
      blobtree::compile(blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/tower.json").root);
  blobtree::GridRequest request;
  request.resolution = 256;
  const auto towerChoice =
      vk::chooseEvaluator(true, tower, blobtree::chooseGrid(tower, {}, request), job, vk::defaultCodegenOptions(true));
  EXPECT_EQ(towerChoice.chosen.traversal, vk::Traversal::Specialised);
  EXPECT_TRUE(towerChoice.chosen.vertexGradient);
  EXPECT_LE(towerChoice.chosen.buildMegabytes, vk::costs::kMaxBuildMegabytes);

  const auto large = blobtree::compile(blobtree::generateTower(3, 8, 6.0, 6.0, 2));  // 808 instructions
  vk::CodegenOptions unrolled = vk::defaultCodegenOptions(true);
  unrolled.loops.enabled = false;
  request.resolution = 64;
  const auto largeChoice = vk::chooseEvaluator(true, large, blobtree::chooseGrid(large, {}, request), job, unrolled);
  for (const auto& c : largeChoice.candidates)
    if (c.traversal == vk::Traversal::Specialised) {
      EXPECT_FALSE(c.vertexGradient);
    }
}

::testing::AssertionResult sameBytes(std::span<const mesh::Float3> a, std::span<const mesh::Float3> b) {
  if (a.size() != b.size()) return ::testing::AssertionFailure() << a.size() << " against " << b.size() << " values";
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(mesh::Float3)) != 0)
      return ::testing::AssertionFailure() << "value " << i << " of " << a.size() << " differs: (" << a[i].x << ", "
                                           << a[i].y << ", " << a[i].z << ") against (" << b[i].x << ", " << b[i].y
                                           << ", " << b[i].z << ")";
  return ::testing::AssertionSuccess();
}

float worstDifference(std::span<const mesh::Float3> a, std::span<const mesh::Float3> b) {
  if (a.size() != b.size()) return INFINITY;
  float w = 0.0f;
  for (std::size_t i = 0; i < a.size(); ++i)
    w = std::max({w, std::abs(a[i].x - b[i].x), std::abs(a[i].y - b[i].y), std::abs(a[i].z - b[i].z)});
  return w;
}

// sin, cos and pow on lavapipe are not the C library's: programs with twist or bend warps or
// Ricci blends agree with the CPU to rounding, the others bit for bit (docs/vulkan.md).
bool usesTranscendentals(const blobtree::Program& program) {
  for (const auto& in : program.code)
    if ((in.code.x & 0xffu) == layout::OP_POW) return true;
  for (const auto& w : program.warps)
    if (w.meta.x == layout::WARP_TWIST || w.meta.x == layout::WARP_BEND) return true;
  return false;
}

struct GradientCase {
  const char* name;  // a shipped scene, or "csg_warps" (tests/vk/models.h: every primitive, operator and warp)
  int refineSteps;
};

class SpecialisedGradientTest : public VulkanTest, public ::testing::WithParamInterface<GradientCase> {};

TEST_P(SpecialisedGradientTest, NormalsAndColoursEqualTheInterpretersAndTheReference) {
  const GradientCase c = GetParam();
  blobtree::Program program;
  blobtree::GridSpec grid;
  blobtree::GridRequest request;
  request.resolution = 24;
  if (std::string(c.name) == "csg_warps") {
    program = blobtree::compile(testModels()[2].root);
    grid = blobtree::chooseGrid(program, testBounds(), request);
  } else {
    const auto scene = blobtree::loadScene(std::string(BLOBVK_SOURCE_DIR) + "/scenes/" + c.name + ".json");
    program = blobtree::compile(scene.root);
    grid = blobtree::chooseGrid(program, scene.grid, request);
  }
  ASSERT_TRUE(vk::canSpecialise(program)) << c.name;
  vk::GpuPolygonizeOptions options;
  options.refineSteps = c.refineSteps;
  options.traversal = vk::Traversal::Specialised;
  const mesh::TriMesh specialised = vk::polygonize(device(), program, grid, options);
  options.traversal = vk::Traversal::Stackless;
  const mesh::TriMesh interpreted = vk::polygonize(device(), program, grid, options);
  cpu::ReferenceOptions ro;
  ro.refineSteps = c.refineSteps;
  const mesh::TriMesh reference = cpu::polygonizeReference(program, grid, ro);
  const std::string what = std::string(c.name) + ", " + std::to_string(c.refineSteps) + " refinement steps";

  ASSERT_GT(reference.triangleCount(), 0u) << what;
  ASSERT_EQ(specialised.normals.size(), specialised.positions.size()) << what;
  ASSERT_EQ(specialised.colours.size(), specialised.positions.size()) << what;
  EXPECT_EQ(specialised.edgeKeys, reference.edgeKeys) << what;
  EXPECT_EQ(specialised.triangles, reference.triangles) << what;
  const bool lavapipe = device().info().type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  if (lavapipe) {
    // Same float operations in the same order as the interpreter: the same bytes.
    EXPECT_TRUE(sameBytes(specialised.positions, interpreted.positions)) << what;
    EXPECT_TRUE(sameBytes(specialised.normals, interpreted.normals)) << what;
    EXPECT_TRUE(sameBytes(specialised.colours, interpreted.colours)) << what;
  }
  if (lavapipe && !usesTranscendentals(program)) {
    EXPECT_TRUE(sameBytes(specialised.positions, reference.positions)) << what;
    EXPECT_TRUE(sameBytes(specialised.normals, reference.normals)) << what;
    EXPECT_TRUE(sameBytes(specialised.colours, reference.colours)) << what;
  } else {
    // sin/cos/pow round differently from the CPU's; other drivers' refinement steps then settle
    // up to a hundredth of a cell apart (docs/vulkan.md; 1e-3 cells seen on an NVIDIA H200 for
    // csg_warps with 2 steps).
    const float tolerance = lavapipe ? 1e-4f : 1e-2f;
    EXPECT_LE(worstDifference(specialised.positions, reference.positions), tolerance * grid.cellSize) << what;
    EXPECT_LE(worstDifference(specialised.normals, reference.normals), lavapipe ? 1e-4f : 1e-2f) << what;
    EXPECT_LE(worstDifference(specialised.colours, reference.colours), lavapipe ? 1e-4f : 1e-3f) << what;
  }
}

// Warps (twist, bend, taper, shear, with matrices), Ricci blends and CSG: the csg_warps model
// and twisted_column; box skips, unions and blends over many primitives: tower and dice;
// differences and intersections: craniotomy.
INSTANTIATE_TEST_SUITE_P(Scenes, SpecialisedGradientTest,
                         ::testing::Values(GradientCase{"csg_warps", 0}, GradientCase{"csg_warps", 2},
                                           GradientCase{"twisted_column", 0}, GradientCase{"tower", 2},
                                           GradientCase{"dice", 0}, GradientCase{"craniotomy", 0}),
                         [](const auto& info) {
                           return std::string(info.param.name) + "_refine" + std::to_string(info.param.refineSteps);
                         });

}  // namespace
}  // namespace blobvk::testing
