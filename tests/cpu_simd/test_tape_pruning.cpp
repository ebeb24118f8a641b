// Pruned tapes against the full Program: the same field bits (and, for colour tapes, the same
// colour bits) at random points of the region, with the scalar reference and the SIMD kernels,
// on every test model; and pruning really shortens the code of a large blend.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/cpu_simd/tape_pruning.h"
#include "tests/cpu_simd/models.h"

#include <gtest/gtest.h>

#include <bit>
#include <random>

namespace blobvk::cpu {
namespace {

std::vector<std::pair<std::string, blobtree::Node>> allModels() {
  std::vector<std::pair<std::string, blobtree::Node>> out;
  for (auto& m : testmodels::primitiveModels()) out.push_back(m);
  for (auto& m : testmodels::operatorModels()) out.push_back(m);
  for (auto& m : testmodels::warpModels()) out.push_back(m);
  out.emplace_back("tower", testmodels::tower());
  out.emplace_back("random_blobs", testmodels::randomBlobs(128));
  out.emplace_back("tiny", testmodels::tinyPrimitives());
  out.emplace_back("thin_shell", testmodels::thinShell());
  return out;
}

std::uint32_t bits(float f) { return std::bit_cast<std::uint32_t>(f); }

TEST(TapePruning, SameBitsAsTheFullProgramInsideTheRegion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [name, node] : allModels()) {
    SCOPED_TRACE(name);
    const blobtree::Program program = blobtree::compile(node);
    blobtree::Program fieldTape = makeTapeProgram(program), colourTape = fieldTape;
    const bool finite = program.bounds.finite();
    const glm::vec3 lo = finite ? program.bounds.lo : glm::vec3(-2.5f);
    const glm::vec3 hi = finite ? program.bounds.hi : glm::vec3(2.5f);
    std::size_t shorter = 0;
    for (int region = 0; region < 40; ++region) {
      // Regions from a tenth of the model to all of it, anywhere in (and around) its bounds.
      const float size = 0.1f + 0.9f * u(rng) * u(rng);
      const glm::vec3 extent = (hi - lo) * size;
      const glm::vec3 rlo =
          lo - 0.1f * (hi - lo) + glm::vec3(u(rng), u(rng), u(rng)) * (1.2f * (hi - lo) - extent);
      const glm::vec3 rhi = rlo + extent;
      specialiseTape(program, rlo, rhi, TapeUse::Field, fieldTape);
      specialiseTape(program, rlo, rhi, TapeUse::FieldColour, colourTape);
      shorter += fieldTape.code.size() < program.code.size();
      std::vector<float> x, y, z;
      for (int i = 0; i < 64; ++i) {
        const glm::vec3 t(u(rng), u(rng), u(rng));
        // Corners and faces of the region too: the pruning must hold on its closed box.
        const glm::vec3 q = i < 8 ? glm::vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1) : t;
        const glm::vec3 p = rlo + q * (rhi - rlo);
        x.push_back(p.x), y.push_back(p.y), z.push_back(p.z);
        const float full = blobtree::evaluate(program, p);
        ASSERT_EQ(bits(blobtree::evaluate(fieldTape, p)), bits(full)) << "region " << region;
        const blobtree::FieldColour fc = blobtree::evaluateWithColour(program, p);
        const blobtree::FieldColour tc = blobtree::evaluateWithColour(colourTape, p);
        ASSERT_EQ(bits(tc.field), bits(fc.field));
        ASSERT_EQ(bits(tc.colour.x), bits(fc.colour.x));
        ASSERT_EQ(bits(tc.colour.y), bits(fc.colour.y));
        ASSERT_EQ(bits(tc.colour.z), bits(fc.colour.z));
      }
      const SimdLevel level = bestSimdLevel();
      std::vector<float> a(x.size()), b(x.size());
      evaluateFieldBatch(program, x.data(), y.data(), z.data(), a.data(), x.size(), level);
      evaluateFieldBatch(fieldTape, x.data(), y.data(), z.data(), b.data(), x.size(), level);
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(bits(a[i]), bits(b[i])) << "SIMD " << i;
      }
    }
    if (name == "tower" || name == "random_blobs") {
      EXPECT_GT(shorter, 20u);
    }
  }
}

// The MPU polygonizer prunes an MPU's tapes from its group's tapes (a tape of a tape): the
// result must still give the full Program's bits inside the sub-region, colours included.
TEST(TapePruning, ATapeOfATapeKeepsTheBitsInsideTheSubRegion) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [name, node] : allModels()) {
    SCOPED_TRACE(name);
    const blobtree::Program program = blobtree::compile(node);
    blobtree::Program groupField = makeTapeProgram(program), groupColour = groupField;
    blobtree::Program childField = makeTapeProgram(groupField), childColour = childField;
    const bool finite = program.bounds.finite();
    const glm::vec3 lo = finite ? program.bounds.lo : glm::vec3(-2.5f);
    const glm::vec3 hi = finite ? program.bounds.hi : glm::vec3(2.5f);
    for (int region = 0; region < 30; ++region) {
      const glm::vec3 extent = (hi - lo) * (0.1f + 0.5f * u(rng));
      const glm::vec3 glo = lo + glm::vec3(u(rng), u(rng), u(rng)) * (hi - lo - extent);
      const glm::vec3 ghi = glo + extent;
      specialiseTapes(program, glo, ghi, groupField, &groupColour);
      // A sub-box of the group's box (an MPU of a group), sometimes touching its faces.
      const glm::vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
      const glm::vec3 slo = glo + glm::min(a, b) * (ghi - glo) * (region % 3 == 0 ? 0.0f : 1.0f);
      const glm::vec3 shi = glo + glm::max(a, b) * (ghi - glo);
      specialiseTape(groupField, slo, shi, TapeUse::Field, childField);
      specialiseTape(groupColour, slo, shi, TapeUse::FieldColour, childColour);
      for (int i = 0; i < 64; ++i) {
        const glm::vec3 q = i < 8 ? glm::vec3(i & 1, (i >> 1) & 1, (i >> 2) & 1)
                                  : glm::vec3(u(rng), u(rng), u(rng));
        const glm::vec3 p = slo + q * (shi - slo);
        ASSERT_EQ(bits(blobtree::evaluate(childField, p)), bits(blobtree::evaluate(program, p)))
            << "region " << region;
        const blobtree::FieldColour fc = blobtree::evaluateWithColour(program, p);
        const blobtree::FieldColour tc = blobtree::evaluateWithColour(childColour, p);
        ASSERT_EQ(bits(tc.field), bits(fc.field)) << "region " << region;
        ASSERT_EQ(bits(tc.colour.x), bits(fc.colour.x)) << "region " << region;
        ASSERT_EQ(bits(tc.colour.y), bits(fc.colour.y));
        ASSERT_EQ(bits(tc.colour.z), bits(fc.colour.z));
      }
    }
  }
}

TEST(TapePruning, ASmallRegionOfALargeBlendKeepsAFewPrimitives) {
  const blobtree::Program program = blobtree::compile(testmodels::randomBlobs(128));
  blobtree::Program tape = makeTapeProgram(program);
  const glm::vec3 c = 0.5f * (program.bounds.lo + program.bounds.hi);
  specialiseTape(program, c - 0.2f, c + 0.2f, TapeUse::Field, tape);
  std::size_t prims = 0;
  for (const auto& in : tape.code) prims += (in.code.x & 0xffu) == layout::OP_PRIM;
  EXPECT_GT(tape.code.size(), 0u);
  EXPECT_LT(prims, 20u) << "of 128";
  EXPECT_LT(tape.code.size() * 5, program.code.size());
}

TEST(TapePruning, RejectsATapeNotMadeForTheProgram) {
  const blobtree::Program program = blobtree::compile(testmodels::tower());
  blobtree::Program notATape = program;
  EXPECT_THROW(specialiseTape(program, glm::dvec3(0), glm::dvec3(1), TapeUse::Field, notATape),
               std::invalid_argument);
}

}  // namespace
}  // namespace blobvk::cpu
