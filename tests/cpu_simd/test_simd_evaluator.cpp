// The SIMD evaluators against the scalar reference: every node type, warps, partial and full
// box skips, colours and normals, on random points around each model (array lengths that are
// not a multiple of the lane width exercise the padded tail).
#include "blobvk/blobtree/evaluate.h"
#include "blobvk/blobtree/gradient.h"
#include "blobvk/blobtree/program.h"
#include "blobvk/cpu_simd/simd_evaluator.h"
#include "tests/cpu_simd/models.h"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <vector>

namespace blobvk::cpu {
namespace {

struct Points {
  std::vector<float> x, y, z;
};

Points randomPoints(const blobtree::Program& program, std::size_t n, unsigned seed) {
  glm::vec3 lo(-3.0f), hi(3.0f);
  if (program.bounds.finite()) {
    const glm::vec3 pad = 0.25f * (program.bounds.hi - program.bounds.lo) + 0.1f;
    lo = program.bounds.lo - pad, hi = program.bounds.hi + pad;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    p.x.push_back(lo.x + (hi.x - lo.x) * u(rng));
    p.y.push_back(lo.y + (hi.y - lo.y) * u(rng));
    p.z.push_back(lo.z + (hi.z - lo.z) * u(rng));
  }
  return p;
}

std::vector<SimdLevel> levels() {
  std::vector<SimdLevel> out;
  for (SimdLevel l : {SimdLevel::Scalar, SimdLevel::Avx2, SimdLevel::Avx512})
    if (simdLevelSupported(l)) out.push_back(l);
  return out;
}

std::vector<std::pair<std::string, blobtree::Node>> allModels() {
  std::vector<std::pair<std::string, blobtree::Node>> all;
  for (auto& m : testmodels::primitiveModels()) all.push_back(std::move(m));
  for (auto& m : testmodels::operatorModels()) all.push_back(std::move(m));
  for (auto& m : testmodels::warpModels()) all.push_back(std::move(m));
  all.emplace_back("tower", testmodels::tower());
  all.emplace_back("random_blobs", testmodels::randomBlobs(64));
  all.emplace_back("tiny", testmodels::tinyPrimitives());
  all.emplace_back("thin_shell", testmodels::thinShell());
  return all;
}

void expectMatchesReference(const std::string& name, const blobtree::Program& program,
                            SimdLevel level) {
  SCOPED_TRACE(name + " / " + toString(level));
  const std::size_t n = 1003;
  const Points p = randomPoints(program, n, 7);
  std::vector<float> f(n), r(n), g(n), b(n), f2(n);
  evaluateFieldBatch(program, p.x.data(), p.y.data(), p.z.data(), f.data(), n, level);
  evaluateFieldColourBatch(program, p.x.data(), p.y.data(), p.z.data(), f2.data(), r.data(),
                           g.data(), b.data(), n, level);
  std::size_t bitwise = 0, nonZero = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const glm::vec3 q(p.x[i], p.y[i], p.z[i]);
    const float ref = blobtree::evaluate(program, q);
    ASSERT_NEAR(f[i], ref, 1e-6f) << "point " << i;
    bitwise += std::bit_cast<std::uint32_t>(f[i]) == std::bit_cast<std::uint32_t>(ref) ||
               (f[i] == 0.0f && ref == 0.0f);
    nonZero += ref != 0.0f;
    const blobtree::FieldColour fc = blobtree::evaluateWithColour(program, q);
    ASSERT_NEAR(f2[i], fc.field, 1e-6f);
    ASSERT_NEAR(r[i], fc.colour.x, 1e-6f);
    ASSERT_NEAR(g[i], fc.colour.y, 1e-6f);
    ASSERT_NEAR(b[i], fc.colour.z, 1e-6f);
  }
  // Same operations in the same order: the fields are the reference's bits, which is what lets
  // the MPU mesh equal the reference mesh exactly.
  EXPECT_EQ(bitwise, n);
  EXPECT_GT(nonZero, n / 100) << "the sample misses the model";
}

TEST(SimdEvaluator, MatchesScalarReferenceOnEveryNodeType) {
  for (const auto& [name, node] : allModels()) {
    for (bool skips : {true, false}) {
      blobtree::CompileOptions co;
      co.boxSkips = skips;
      const blobtree::Program program = blobtree::compile(node, co);
      for (SimdLevel level : levels()) expectMatchesReference(name, program, level);
    }
  }
}

// The analytic gradient pass: field, gradient and colour equal blobtree::evaluateGradient(Colour)
// bit for bit at every level (the MPU normals are then the reference normals exactly).
TEST(SimdEvaluator, GradientsAreTheReferenceBitsOnEveryNodeType) {
  const auto bits = [](float v) { return std::bit_cast<std::uint32_t>(v); };
  for (const auto& [name, node] : allModels()) {
    for (bool skips : {true, false}) {
      blobtree::CompileOptions co;
      co.boxSkips = skips;
      const blobtree::Program program = blobtree::compile(node, co);
      const std::size_t n = 517;
      const Points p = randomPoints(program, n, 13);
      for (SimdLevel level : levels()) {
        SCOPED_TRACE(name + " / " + toString(level) + (skips ? " / skips" : ""));
        for (bool colour : {false, true}) {
          std::vector<float> f(n), gx(n), gy(n), gz(n), r(n), g(n), b(n);
          evaluateGradientBatch(program, p.x.data(), p.y.data(), p.z.data(), f.data(), gx.data(), gy.data(), gz.data(),
                                colour ? r.data() : nullptr, g.data(), b.data(), n, level);
          std::size_t nonZero = 0;
          for (std::size_t i = 0; i < n; ++i) {
            const glm::vec3 q(p.x[i], p.y[i], p.z[i]);
            const blobtree::FieldGradient ref =
                colour ? blobtree::evaluateGradientColour(program, q) : blobtree::evaluateGradient(program, q);
            ASSERT_EQ(bits(f[i]), bits(ref.field)) << "point " << i;
            ASSERT_EQ(bits(gx[i]), bits(ref.gradient.x)) << "point " << i << " " << gx[i] << " vs " << ref.gradient.x;
            ASSERT_EQ(bits(gy[i]), bits(ref.gradient.y)) << "point " << i;
            ASSERT_EQ(bits(gz[i]), bits(ref.gradient.z)) << "point " << i;
            if (colour) {
              ASSERT_EQ(bits(r[i]), bits(ref.colour.x)) << "point " << i;
              ASSERT_EQ(bits(g[i]), bits(ref.colour.y)) << "point " << i;
              ASSERT_EQ(bits(b[i]), bits(ref.colour.z)) << "point " << i;
            }
            nonZero += glm::length(ref.gradient) > 0.0f;
          }
          EXPECT_GT(nonZero, n / 100) << "the sample misses the model";
        }
      }
    }
  }
}

TEST(SimdEvaluator, PartialAndFullSkipsInOneBatch) {
  // Two far-apart clusters: blocks straddle skip boxes (partial) or miss them (full).
  std::vector<blobtree::Node> left, right;
  for (int i = 0; i < 4; ++i) {
    left.push_back(testmodels::primitive(blobtree::PrimitiveType::Point, {-4.0 + 0.3 * i, 0, 0}));
    right.push_back(testmodels::primitive(blobtree::PrimitiveType::Point, {4.0, 0.3 * i, 0}));
  }
  const blobtree::Node root = testmodels::op(
      blobtree::OperatorType::Union,
      {testmodels::op(blobtree::OperatorType::Blend, left),
       testmodels::op(blobtree::OperatorType::Blend, right)});
  const blobtree::Program program = blobtree::compile(root);
  ASSERT_FALSE(program.boxes.empty()) << "compile() emitted no skips; the test would be vacuous";
  for (SimdLevel level : levels()) expectMatchesReference("two_clusters", program, level);
}

TEST(SimdEvaluator, NormalsMatchReference) {
  const blobtree::Program program = blobtree::compile(testmodels::warpModels()[0].second);
  const std::size_t n = 301;
  const Points p = randomPoints(program, n, 3);
  std::vector<float> nx(n), ny(n), nz(n);
  for (SimdLevel level : levels()) {
    evaluateNormalBatch(program, p.x.data(), p.y.data(), p.z.data(), nx.data(), ny.data(),
                        nz.data(), n, 1e-4f, level);
    for (std::size_t i = 0; i < n; ++i) {
      const glm::vec3 ref = blobtree::normal(program, glm::vec3(p.x[i], p.y[i], p.z[i]));
      ASSERT_EQ(nx[i], ref.x) << toString(level) << " point " << i;
      ASSERT_EQ(ny[i], ref.y);
      ASSERT_EQ(nz[i], ref.z);
    }
  }
}

// An analytic oracle for the normals: a point primitive's field falls off radially, so its unit
// normal at any point of its support (not its centre) is the direction away from the centre.
TEST(SimdEvaluator, NormalsOfAPointPrimitiveAreRadial) {
  const glm::vec3 centre(0.3f, -0.2f, 0.1f);
  const blobtree::Program program =
      blobtree::compile(testmodels::primitive(blobtree::PrimitiveType::Point, glm::dvec3(centre), {}, 0, 0, 1.0));
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), r(0.2f, 0.9f);
  Points p;
  std::vector<glm::vec3> radial;
  while (radial.size() < 97) {
    const glm::vec3 d(u(rng), u(rng), u(rng));
    if (glm::length(d) < 0.1f || glm::length(d) > 1.0f) continue;
    radial.push_back(glm::normalize(d));
    const glm::vec3 q = centre + r(rng) * radial.back();
    p.x.push_back(q.x), p.y.push_back(q.y), p.z.push_back(q.z);
  }
  const std::size_t n = radial.size();
  std::vector<float> nx(n), ny(n), nz(n);
  for (SimdLevel level : levels()) {
    evaluateNormalBatch(program, p.x.data(), p.y.data(), p.z.data(), nx.data(), ny.data(), nz.data(), n, 1e-4f, level);
    for (std::size_t i = 0; i < n; ++i) {
      const glm::vec3 normal(nx[i], ny[i], nz[i]);
      EXPECT_NEAR(glm::length(normal), 1.0f, 1e-4f) << toString(level) << " point " << i;
      EXPECT_GT(glm::dot(normal, radial[i]), 0.999f) << toString(level) << " point " << i;
    }
  }
}

TEST(SimdEvaluator, DispatchReportsTheCpu) {
  EXPECT_TRUE(simdLevelSupported(SimdLevel::Scalar));
  EXPECT_TRUE(simdLevelSupported(bestSimdLevel()));
  EXPECT_EQ(simdWidth(SimdLevel::Avx2), 8);
  EXPECT_EQ(simdWidth(SimdLevel::Avx512), 16);
}

}  // namespace
}  // namespace blobvk::cpu
