// Results must not depend on a driver's freedom to fuse a * b + c (issue 15): every float
// multiply, add and subtract in the kernels whose values reach a field, mesh vertex or colour
// carries SPIR-V's NoContraction (GLSL `precise`), both in the embedded shaders and in the
// specialised evaluator the code generator writes. Read straight from the SPIR-V words, so a
// formula added later without `precise` fails here, on any machine (no device needed).
#include "blobvk/blobtree/program.h"
#include "models.h"
#include "blobvk/vk/eval/program_codegen.h"
#include "blobvk/vk/eval/runtime_compiler.h"
#include "blobvk/vk/device/shader_registry.h"

#include <gtest/gtest.h>

#include <set>
#include <span>
#include <string>
#include <vector>

namespace blobvk::testing {
namespace {

constexpr std::uint32_t kOpDecorate = 71, kDecorationNoContraction = 42;
constexpr std::uint32_t kOpFAdd = 129, kOpFSub = 131, kOpFMul = 133, kOpVectorTimesScalar = 142,
                        kOpMatrixTimesVector = 145, kOpDot = 148;

struct Audit {
  std::size_t arithmetic = 0;          // float mul/add/sub results
  std::vector<std::uint32_t> contractible;  // of those, the ids without NoContraction
  std::size_t dots = 0;                // OpDot: precision left to the driver
};

Audit audit(std::span<const std::uint32_t> words) {
  Audit a;
  std::set<std::uint32_t> noContraction;
  std::vector<std::uint32_t> results;
  for (std::size_t i = 5; i < words.size();) {
    const std::uint32_t count = words[i] >> 16, op = words[i] & 0xffffu;
    if (count == 0 || i + count > words.size()) break;
    if (op == kOpDecorate && count >= 3 && words[i + 2] == kDecorationNoContraction) noContraction.insert(words[i + 1]);
    if (op == kOpFAdd || op == kOpFSub || op == kOpFMul || op == kOpVectorTimesScalar || op == kOpMatrixTimesVector)
      results.push_back(words[i + 2]);
    if (op == kOpDot) ++a.dots;
    i += count;
  }
  a.arithmetic = results.size();
  for (auto id : results)
    if (!noContraction.count(id)) a.contractible.push_back(id);
  return a;
}

std::string ids(const std::vector<std::uint32_t>& v) {
  std::string s;
  for (auto id : v) s += " %" + std::to_string(id);
  return s;
}

TEST(NoContraction, EmbeddedFieldAndVertexKernels) {
  for (const char* name :
       {"field_grid", "vertices", "vertices_tiled", "brick_field", "brick_field_rows", "brick_vertices",
        "brick_vertices_direct",
        "brick_vertices_tiled", "brick_vertices_direct_tiled"}) {
    const Audit a = audit(vk::shaderCode(name));
    EXPECT_GT(a.arithmetic, 20u) << name;  // the evaluator is in there
    EXPECT_TRUE(a.contractible.empty()) << name << ": contractible float ops" << ids(a.contractible);
    EXPECT_EQ(a.dots, 0u) << name;
  }
}

TEST(NoContraction, SpecialisedEvaluatorOfEveryPrimitiveOperatorAndWarp) {
  for (const auto& model : testModels()) {
    const auto program = blobtree::compile(model.root);
    const std::string glsl = vk::generateSpecialisedEvaluator(program);
    for (const char* shader :
         {"field_grid.comp", "vertices.comp", "brick_field.comp", "brick_field_rows.comp", "brick_vertices.comp",
          "brick_vertices_direct.comp",
          "brick_vertices_tiled.comp", "brick_vertices_direct_tiled.comp"}) {
      const auto code = vk::compileComputeShader(shader, {{"eval_program.glsl", glsl}});
      const Audit a = audit(code);
      EXPECT_GT(a.arithmetic, 10u) << model.name << " " << shader;
      EXPECT_TRUE(a.contractible.empty()) << model.name << " " << shader << ":" << ids(a.contractible);
      EXPECT_EQ(a.dots, 0u) << model.name << " " << shader;
    }
  }
}

}  // namespace
}  // namespace blobvk::testing
