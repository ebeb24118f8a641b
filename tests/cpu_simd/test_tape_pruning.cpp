// Pruned tapes against the full Program: the same field bits (and, for colour tapes, the same
// colour bits) at random points of the region, with the scalar reference and the SIMD kernels,
// on every test model; the analytic-gradient pass on colour tapes (long chains of null twins
// added into one register, which the SIMD pass cuts short) gives the full Program's reference
// bits; and pruning really shortens the code of a large blend.
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/gradient.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "blobvk/cpu_simd/tape_pruning.h"
#include "tests/cpu_simd/models.h"

#include <gtest/gtest.h>

#include <bit>
#include <random>
#include <utility>

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

// Where the tests draw their regions: the model's bounds, or a box around the origin for a
// model without finite ones.
std::pair<glm::vec3, glm::vec3> regionsBox(const blobtree::Program& program) {
  if (program.bounds.finite()) return {program.bounds.lo, program.bounds.hi};
  return {glm::vec3(-2.5f), glm::vec3(2.5f)};
}

TEST(TapePruning, SameBitsAsTheFullProgramInsideTheRegion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const auto& [name, node] : allModels()) {
    SCOPED_TRACE(name);
    const blobtree::Program program = blobtree::compile(node);
    blobtree::Program fieldTape = makeTapeProgram(program), colourTape = fieldTape;
    const auto [lo, hi] = regionsBox(program);
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
    const auto [lo, hi] = regionsBox(program);
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

// The MPU's attribute pass runs the analytic-gradient evaluator on colour tapes: in small regions
// of a large blend most adds take a null twin, in chains the SIMD pass stops once an add changes
// no bit. Field, gradient and colour must be blobtree::evaluateGradientColour's bits on the full
// Program, at every SIMD level, in the K-block chunks and in the single-block tail.
//
// In a blend the colour an add leaves is already a quotient by the register's clamped field, and
// a null twin's add (weight 0) then keeps its bits; after a union it is a primitive's colour, and
// the first add of a null twin may round it (c * w / w): `union_then_far_blend` has that case.
blobtree::Node unionThenFarBlend() {
  using testmodels::primitive;
  const auto coloured = [](glm::dvec3 centre, glm::dvec3 colour) {
    blobtree::Node n = primitive(blobtree::PrimitiveType::Point, centre);
    std::get<blobtree::Primitive>(n.kind).colour = colour;
    return n;
  };
  std::vector<blobtree::Node> kids{testmodels::op(blobtree::OperatorType::Union, {coloured({0, 0, 0}, {0.13, 0.71, 0.37}),
                                                              coloured({0.4, 0.1, 0}, {0.83, 0.29, 0.61})})};
  for (int i = 0; i < 30; ++i) kids.push_back(coloured({4.0 + 0.3 * i, 0, 0}, {0.01 * i, 0.5, 1.0 - 0.02 * i}));
  return testmodels::op(blobtree::OperatorType::Blend, std::move(kids));
}

TEST(TapePruning, TheGradientPassOnColourTapesGivesTheReferenceBits) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<SimdLevel> levels;
  for (SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512})
    if (simdLevelSupported(l)) levels.push_back(l);
  auto models = allModels();
  models.emplace_back("union_then_far_blend", unionThenFarBlend());
  for (const auto& [name, node] : models) {
    SCOPED_TRACE(name);
    const blobtree::Program program = blobtree::compile(node);
    blobtree::Program fieldTape = makeTapeProgram(program), colourTape = fieldTape;
    const auto [lo, hi] = regionsBox(program);
    std::size_t longestChain = 0, blended = 0;
    for (int region = 0; region < 30; ++region) {
      // MPU-sized to a third of the model, so that some regions see few of a blend's primitives.
      const glm::vec3 extent = (hi - lo) * (0.04f + 0.3f * u(rng) * u(rng));
      const bool nearUnion = name == "union_then_far_blend";  // around the union, far from the rest
      const glm::vec3 rlo = nearUnion ? glm::vec3(-0.6f) + glm::vec3(u(rng), u(rng), u(rng)) * 0.3f
                                      : lo + glm::vec3(u(rng), u(rng), u(rng)) * (hi - lo - extent);
      const glm::vec3 rhi = rlo + (nearUnion ? glm::vec3(0.8f) : extent);
      specialiseTapes(program, rlo, rhi, fieldTape, &colourTape);
      std::size_t chain = 0;
      for (const auto& in : colourTape.code) {
        const bool twin = (in.code.x & 0xffu) == layout::OP_PRIM && in.code.y >= program.primitives.size();
        const bool add = (in.code.x & 0xffu) == layout::OP_ADD;
        chain = twin ? chain + 1 : add ? chain : 0;
        longestChain = std::max(longestChain, chain);
      }
      const std::size_t n = 64 + 37;  // whole chunks at every lane width, then a partial block
      std::vector<float> x(n), y(n), z(n);
      for (std::size_t i = 0; i < n; ++i) {
        const glm::vec3 p = rlo + glm::vec3(u(rng), u(rng), u(rng)) * (rhi - rlo);
        x[i] = p.x, y[i] = p.y, z[i] = p.z;
      }
      for (SimdLevel level : levels) {
        std::vector<float> f(n), gx(n), gy(n), gz(n), r(n), g(n), b(n);
        evaluateGradientBatch(colourTape, x.data(), y.data(), z.data(), f.data(), gx.data(), gy.data(),
                              gz.data(), r.data(), g.data(), b.data(), n, level);
        for (std::size_t i = 0; i < n; ++i) {
          const blobtree::FieldGradient ref = blobtree::evaluateGradientColour(program, {x[i], y[i], z[i]});
          const std::string where = std::string(toString(level)) + " region " + std::to_string(region) +
                                    " point " + std::to_string(i);
          ASSERT_EQ(bits(f[i]), bits(ref.field)) << where;
          ASSERT_EQ(bits(gx[i]), bits(ref.gradient.x)) << where;
          ASSERT_EQ(bits(gy[i]), bits(ref.gradient.y)) << where;
          ASSERT_EQ(bits(gz[i]), bits(ref.gradient.z)) << where;
          ASSERT_EQ(bits(r[i]), bits(ref.colour.x)) << where;
          ASSERT_EQ(bits(g[i]), bits(ref.colour.y)) << where;
          ASSERT_EQ(bits(b[i]), bits(ref.colour.z)) << where;
          blended += level == levels.front() && ref.field > 0.0f;
        }
      }
    }
    if (name == "random_blobs" || name == "union_then_far_blend") {
      EXPECT_GT(longestChain, 20u) << "no long chain of null twins: the test misses the cut-short path";
      EXPECT_GT(blended, 200u) << "few points where the blend's weights are not all 0";
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
